/* landmarkslam: hand-made detections with landmark-range structures from
 * known poses. Without a map the first pose is the origin and the map is
 * built within centimetres; two red discs stay two; a given map's ids are
 * kept in map-out; an unwritable map-out and a bad odometry file are clear
 * errors; odometry carries the pose through frames without landmarks; a
 * bad map set while PLAYING is refused with a warning; a blob cut by the
 * image border is left out. */
#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include <json-glib/json-glib.h>
#include <glib/gstdio.h>
#include <unistd.h>
#include <math.h>
#include <string.h>

/* two red discs 0.5 m apart, one green, one blue */
static const struct
{
  const gchar *cls;
  double x, y;
} LM[] = { {"red", 2, 0.5}, {"red", 2, 1.0}, {"green", 2.5, -0.5},
  {"blue", 3, 0.2}
};

#define N_LM 4

static gchar *
write_tmp (const gchar * text)
{
  return landmark_check_write_tmp ("landmarkslam", ".json", text);
}

/* landmark k seen from (x, y, h), robot frame (docs/conventions.md) */
static void
add_seen (GstBuffer * buf, gint id, guint k, double x, double y, double h)
{
  const double dx = LM[k].x - x, dy = LM[k].y - y;
  const double gx = cos (h) * dx + sin (h) * dy;
  const double gy = -sin (h) * dx + cos (h) * dy;
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, LM[k].cls, 10, 10,
      8, 8);
  roi->id = id;
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "range", G_TYPE_DOUBLE,
          hypot (gx, gy), "bearing", G_TYPE_DOUBLE, atan2 (gy, gx),
          "ground-x", G_TYPE_DOUBLE, gx, "ground-y", G_TYPE_DOUBLE, gy,
          "range-sigma", G_TYPE_DOUBLE, 0.01, "bearing-sigma", G_TYPE_DOUBLE,
          0.005, "no-floor", G_TYPE_BOOLEAN, FALSE, NULL));
}

static GstBuffer *
frame (guint n)
{
  return landmark_check_frame_new (64 * 48, n);
}

static GstHarness *
harness (const gchar * props)
{
  gchar *launch = g_strdup_printf ("landmarkslam %s", props);
  GstHarness *h = gst_harness_new_parse (launch);
  g_free (launch);
  gst_harness_set_src_caps_str (h, "video/x-raw,format=GRAY8,width=64,"
      "height=48,framerate=30/1");
  return h;
}

static const GstStructure *
meta (GstBuffer * b, const gchar * name)
{
  GstCustomMeta *m = gst_buffer_get_custom_meta (b, name);
  return m ? gst_custom_meta_get_structure (m) : NULL;
}

static double
array_double (const GstStructure * s, const gchar * field, guint i)
{
  const GValue *a = gst_structure_get_value (s, field);
  fail_unless (a != NULL && i < gst_value_array_get_size (a), "%s[%u]",
      field, i);
  return g_value_get_double (gst_value_array_get_value (a, i));
}

/* Drives the robot along +x from the origin at 0.3 m/s for n frames,
 * seeing every landmark; returns the last output buffer. */
static GstBuffer *
drive (GstHarness * h, guint n)
{
  GstBuffer *out = NULL;
  for (guint f = 0; f < n; f++) {
    GstBuffer *b = frame (f);
    for (guint k = 0; k < N_LM; k++)
      add_seen (b, k, k, 0.01 * f, 0, 0);
    if (out)
      gst_buffer_unref (out);
    out = gst_harness_push_and_pull (h, b);
    fail_unless (out != NULL);
  }
  return out;
}

LANDMARK_TEST ("general", test_no_map_builds_map)
{
  GstHarness *h = harness ("confirm-views=3 confirm-baseline=0.1");
  GstBuffer *out = drive (h, 60);
  const GstStructure *pose = meta (out, "GstLandmarkPoseMeta");
  fail_unless (pose != NULL);
  double x, y, hd;
  fail_unless (gst_structure_get_double (pose, "x", &x));
  fail_unless (gst_structure_get_double (pose, "y", &y));
  fail_unless (gst_structure_get_double (pose, "heading", &hd));
  /* the first pose is the origin: the truth's frame here */
  fail_unless (fabs (x - 0.59) < 0.02 && fabs (y) < 0.02 && fabs (hd) < 0.02,
      "pose %f %f %f", x, y, hd);
  fail_unless_equals_string (gst_structure_get_string (pose, "solver"),
      "slam");
  guint n;
  fail_unless (gst_structure_get_uint (pose, "n-landmarks", &n));
  fail_unless_equals_int (n, N_LM);
  fail_unless_equals_int (gst_value_array_get_size (gst_structure_get_value
          (pose, "covariance")), 9);

  const GstStructure *map = meta (out, "GstLandmarkMapMeta");
  fail_unless (map != NULL);
  const GValue *ids = gst_structure_get_value (map, "ids");
  /* the two red discs 0.5 m apart stay two */
  fail_unless_equals_int (gst_value_array_get_size (ids), N_LM);
  for (guint k = 0; k < N_LM; k++) {
    double lx = array_double (map, "x", k), ly = array_double (map, "y", k);
    gboolean found = FALSE;
    for (guint j = 0; j < N_LM; j++)
      found |= hypot (lx - LM[j].x, ly - LM[j].y) < 0.02;
    fail_unless (found, "landmark %u at %f %f", k, lx, ly);
    fail_unless (g_value_get_boolean (gst_value_array_get_value
            (gst_structure_get_value (map, "confirmed"), k)));
    fail_unless (array_double (map, "covariance", 4 * k) > 0);
  }
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}

GST_END_TEST;

static JsonArray *
load_map_landmarks (const gchar * path, JsonParser * parser)
{
  fail_unless (json_parser_load_from_file (parser, path, NULL), "%s", path);
  return json_object_get_array_member (json_node_get_object
      (json_parser_get_root (parser)), "landmarks");
}

LANDMARK_TEST ("general", test_map_out_keeps_ids)
{
  /* the map knows one red disc and the green one; the second red disc,
   * 0.5 m from the first, and the blue one are added */
  gchar *map = write_tmp ("{\"landmarks\": ["
      "{\"id\": \"R1\", \"class\": \"red\", \"x\": 2, \"y\": 0.5},"
      "{\"id\": \"G1\", \"class\": \"green\", \"x\": 2.5, \"y\": -0.5}]}");
  gchar *out_path = g_strdup_printf ("%s.out", map);
  gchar *props = g_strdup_printf ("map=%s map-out=%s confirm-views=2 "
      "confirm-baseline=0.1", map, out_path);
  GstHarness *h = harness (props);
  gst_buffer_unref (drive (h, 40));
  fail_unless (gst_harness_push_event (h, gst_event_new_eos ()));
  JsonParser *parser = json_parser_new ();
  JsonArray *lms = load_map_landmarks (out_path, parser);
  fail_unless_equals_int (json_array_get_length (lms), N_LM);
  guint added = 0;
  for (guint i = 0; i < N_LM; i++) {
    JsonObject *o = json_array_get_object_element (lms, i);
    const gchar *id = json_object_get_string_member (o, "id");
    const double x = json_object_get_double_member (o, "x");
    const double y = json_object_get_double_member (o, "y");
    if (g_str_equal (id, "R1"))
      fail_unless (x == 2 && y == 0.5);
    else if (g_str_equal (id, "G1"))
      fail_unless (x == 2.5 && y == -0.5);
    else {
      added++;
      fail_unless (g_str_has_prefix (id, "S"), "%s", id);
      gboolean near = FALSE;
      for (guint k = 1; k < N_LM; k += 2)
        near |= hypot (x - LM[k].x, y - LM[k].y) < 0.02;
      fail_unless (near, "%s at %f %f", id, x, y);
    }
  }
  fail_unless_equals_int (added, 2);
  g_object_unref (parser);
  gst_harness_teardown (h);
  g_unlink (out_path);
  g_unlink (map);
  g_free (props);
  g_free (out_path);
  g_free (map);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_map_out_unwritable)
{
  GstHarness *h = harness ("map-out=/nonexistent-dir/map.json");
  GstBus *bus = landmark_check_bus_attach (h->element);
  gst_buffer_unref (drive (h, 5));
  gst_harness_push_event (h, gst_event_new_eos ());
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL);
  GError *err = NULL;
  gchar *dbg = NULL;
  gst_message_parse_error (msg, &err, &dbg);
  fail_unless (strstr (err->message, "map-out") != NULL, "%s",
      err->message);
  fail_unless (strstr (dbg, "/nonexistent-dir/map.json") != NULL, "%s", dbg);
  g_error_free (err);
  g_free (dbg);
  gst_message_unref (msg);
  landmark_check_bus_detach (h->element, bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bad_odometry_fails_ready)
{
  gchar *odo = write_tmp ("{\"t\": 0.1, \"dx\": 0.01, \"dheading\": 0}\n"
      "{\"t\": 0.05, \"dx\": 0.01, \"dheading\": 0}\n");
  GstElement *e = gst_element_factory_make ("landmarkslam", NULL);
  g_object_set (e, "odometry", odo, NULL);
  GstBus *bus = gst_bus_new ();
  gst_element_set_bus (e, bus);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_READY),
      GST_STATE_CHANGE_FAILURE);
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL);
  GError *err = NULL;
  gchar *dbg = NULL;
  gst_message_parse_error (msg, &err, &dbg);
  gchar *where = g_strdup_printf ("%s:2: time goes backwards", odo);
  fail_unless (strstr (dbg, where) != NULL, "%s", dbg);
  g_free (where);
  g_error_free (err);
  g_free (dbg);
  gst_message_unref (msg);
  gst_element_set_state (e, GST_STATE_NULL);
  gst_element_set_bus (e, NULL);
  gst_object_unref (bus);
  gst_object_unref (e);
  g_unlink (odo);
  g_free (odo);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_odometry_bridges)
{
  /* 0.01 m forward per frame; landmarks only in the first 30 frames */
  GString *text = g_string_new (NULL);
  for (guint f = 1; f < 90; f++)
    g_string_append_printf (text, "{\"t\": %.6f, \"dx\": 0.01, \"dy\": 0, "
        "\"dheading\": 0}\n", f / 30.0);
  gchar *odo = write_tmp (text->str);
  g_string_free (text, TRUE);
  gchar *props = g_strdup_printf ("odometry=%s", odo);
  GstHarness *h = harness (props);
  GstBuffer *out = NULL;
  for (guint f = 0; f < 90; f++) {
    GstBuffer *b = frame (f);
    if (f < 30)
      for (guint k = 0; k < N_LM; k++)
        add_seen (b, k, k, 0.01 * f, 0, 0);
    if (out)
      gst_buffer_unref (out);
    out = gst_harness_push_and_pull (h, b);
  }
  const GstStructure *pose = meta (out, "GstLandmarkPoseMeta");
  fail_unless (pose != NULL);
  double x, y;
  gst_structure_get_double (pose, "x", &x);
  gst_structure_get_double (pose, "y", &y);
  fail_unless (fabs (x - 0.89) < 0.01 && fabs (y) < 0.01, "%f %f", x, y);
  guint n;
  gst_structure_get_uint (pose, "n-landmarks", &n);
  fail_unless_equals_int (n, 0);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
  g_unlink (odo);
  g_free (odo);
  g_free (props);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bad_map_while_playing_keeps_previous)
{
  GstHarness *h = harness ("");
  GstElement *slam = gst_harness_find_element (h, "landmarkslam");
  GstBus *bus = landmark_check_bus_attach (h->element);
  gst_buffer_unref (drive (h, 10));
  g_object_set (slam, "map", "/nonexistent-dir/map.json", NULL);
  gst_object_unref (slam);
  GstBuffer *out = drive (h, 3);
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING);
  fail_unless (msg != NULL);
  gst_message_unref (msg);
  /* the estimate goes on */
  fail_unless (meta (out, "GstLandmarkPoseMeta") != NULL);
  const GstStructure *map = meta (out, "GstLandmarkMapMeta");
  fail_unless_equals_int (gst_value_array_get_size (gst_structure_get_value
          (map, "ids")), N_LM);
  gst_buffer_unref (out);
  landmark_check_bus_detach (h->element, bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* a blob touching the image border is left out of the estimate */
LANDMARK_TEST ("general", test_cut_blob_left_out)
{
  GstHarness *h = harness ("");
  GstBuffer *b = frame (0);
  add_seen (b, 0, 0, 0, 0, 0);
  add_seen (b, 1, 2, 0, 0, 0);
  GstVideoRegionOfInterestMeta *cut =
      gst_buffer_get_video_region_of_interest_meta_id (b, 1);
  cut->x = 0;
  gst_video_region_of_interest_meta_add_param (cut,
      gst_structure_new ("landmark-blob", "kept", G_TYPE_BOOLEAN, TRUE,
          "frame-width", G_TYPE_UINT, 64, "frame-height", G_TYPE_UINT, 48,
          NULL));
  GstBuffer *out = gst_harness_push_and_pull (h, b);
  const GstStructure *map = meta (out, "GstLandmarkMapMeta");
  fail_unless_equals_int (gst_value_array_get_size (gst_structure_get_value
          (map, "ids")), 1);
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_get_video_region_of_interest_meta_id (out, 1);
  const GstStructure *m = gst_video_region_of_interest_meta_get_param (roi,
      "landmark-match");
  fail_unless (m != NULL);
  fail_unless_equals_string (gst_structure_get_string (m, "reason"),
      "cut-by-border");
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (landmarkslam);
