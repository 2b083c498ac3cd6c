/* trilaterate: hand-made detections with landmark-range structures from a
 * known pose recover it (one, two, three landmarks), the pose meta,
 * landmark-match and landmark-pose message fields, frames without a pose,
 * bad maps failing READY, filter=ekf bridging frames without landmarks. */
#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include <glib/gstdio.h>
#include <unistd.h>
#include <math.h>
#include <string.h>

/* red and green twice (far apart), blue and yellow once */
static const gchar *MAP_JSON =
    "{\"landmarks\": ["
    "{\"id\": \"R1\", \"class\": \"red\", \"x\": 0, \"y\": 0},"
    "{\"id\": \"G1\", \"class\": \"green\", \"x\": 4, \"y\": 0},"
    "{\"id\": \"B1\", \"class\": \"blue\", \"x\": 4, \"y\": 4, \"z\": 0.1,"
    " \"diameter\": 0.2, \"kind\": \"ball\"},"
    "{\"id\": \"R2\", \"class\": \"red\", \"x\": 8, \"y\": 4},"
    "{\"id\": \"G2\", \"class\": \"green\", \"x\": 8, \"y\": 0},"
    "{\"id\": \"Y1\", \"class\": \"yellow\", \"x\": 0, \"y\": 4}]}";

static const struct
{
  const gchar *cls;
  double x, y;
} LM[] = { {"red", 0, 0}, {"green", 4, 0}, {"blue", 4, 4}, {"red", 8, 4},
  {"green", 8, 0}, {"yellow", 0, 4}
};

static gchar *map_path;

static gchar *
write_tmp (const gchar * text)
{
  return landmark_check_write_tmp ("trilaterate", ".json", text);
}

static void
setup (void)
{
  map_path = write_tmp (MAP_JSON);
}

static void
teardown (void)
{
  g_unlink (map_path);
  g_free (map_path);
}

/* A detection of map landmark k seen from pose (x, y, h), with a
 * landmark-range structure in the robot frame (docs/conventions.md). */
static void
add_seen_sigma (GstBuffer * buf, gint id, guint k, double x, double y,
    double h, double range_bias, double range_sigma);

static void
add_seen (GstBuffer * buf, gint id, guint k, double x, double y, double h,
    double range_bias)
{
  add_seen_sigma (buf, id, k, x, y, h, range_bias, 0.01);
}


/* The same with the range's sigma given. */
static void
add_seen_sigma (GstBuffer * buf, gint id, guint k, double x, double y,
    double h, double range_bias, double range_sigma)
{
  const double dx = LM[k].x - x, dy = LM[k].y - y;
  double gx = cos (h) * dx + sin (h) * dy;
  double gy = -sin (h) * dx + cos (h) * dy;
  const double r0 = hypot (gx, gy), r = r0 + range_bias;
  gx *= r / r0;
  gy *= r / r0;
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, LM[k].cls, 10, 10,
      8, 8);
  roi->id = id;
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "range", G_TYPE_DOUBLE, r,
          "bearing", G_TYPE_DOUBLE, atan2 (gy, gx), "ground-x", G_TYPE_DOUBLE,
          gx, "ground-y", G_TYPE_DOUBLE, gy, "range-sigma", G_TYPE_DOUBLE,
          range_sigma, "bearing-sigma", G_TYPE_DOUBLE, 0.005, "no-floor",
          G_TYPE_BOOLEAN, FALSE, NULL));
}

static void
add_no_floor (GstBuffer * buf, gint id, const gchar * cls)
{
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, cls, 10, 10, 8, 8);
  roi->id = id;
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "no-floor", G_TYPE_BOOLEAN, TRUE,
          NULL));
}

static GstHarness *
harness_with (const gchar * props, GstBus ** bus)
{
  gchar *launch = g_strdup_printf ("trilaterate map=%s %s", map_path, props);
  GstHarness *h = gst_harness_new_parse (launch);
  g_free (launch);
  gst_harness_set_src_caps_str (h, "video/x-raw,format=GRAY8,width=64,"
      "height=48,framerate=30/1");
  *bus = landmark_check_bus_attach (h->element);
  return h;
}

/* messages on: the tests read the landmark-pose message */
static GstHarness *
harness (const gchar * props, GstBus ** bus)
{
  gchar *all = g_strconcat ("post-messages=true ", props, NULL);
  GstHarness *h = harness_with (all, bus);
  g_free (all);
  return h;
}

static void
harness_done (GstHarness * h, GstBus * bus)
{
  landmark_check_bus_detach (h->element, bus);
  gst_harness_teardown (h);
}

static GstBuffer *
frame (guint n)
{
  return landmark_check_frame_new (64 * 48, n);
}

/* Frame n with detections 0-2 of the map's landmarks 0-2 seen from the
 * robot at (3, 1) heading 2 rad, exactly ranged. */
static GstBuffer *
frame_of_three (guint n)
{
  GstBuffer *buf = frame (n);
  for (guint k = 0; k < 3; k++)
    add_seen (buf, (gint) k, k, 3, 1, 2.0, 0);
  return buf;
}

/* Pushes frame n with one detection, of blue (the map's landmark 2), seen
 * from (x, y) at heading h; the output buffer. */
static GstBuffer *
push_blue (GstHarness * harness, guint n, double x, double y, double h)
{
  GstBuffer *buf = frame (n);
  add_seen (buf, 0, 2, x, y, h, 0);
  return gst_harness_push_and_pull (harness, buf);
}

/* one frame through trilaterate with props: no message may come of it */
static void
check_no_messages (const gchar * props)
{
  GstBus *bus;
  GstHarness *h = harness_with (props, &bus);
  GstBuffer *out = gst_harness_push_and_pull (h, frame (1));
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT) == NULL,
      "a message with \"%s\"", props);
  gst_buffer_unref (out);
  harness_done (h, bus);
}

/* the trilaterate element's landmark-pose message for the last frame */
static GstStructure *
pop_pose_message (GstBus * bus)
{
  GstMessage *msg;
  GstStructure *last = NULL;
  while ((msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT))) {
    const GstStructure *s = gst_message_get_structure (msg);
    if (gst_structure_has_name (s, "landmark-pose")) {
      if (last)
        gst_structure_free (last);
      last = gst_structure_copy (s);
    }
    gst_message_unref (msg);
  }
  fail_unless (last != NULL, "no landmark-pose message");
  return last;
}

static void
check_pose_structure (const GstStructure * s, double x, double y, double h,
    double tol, const gchar * solver, guint n)
{
  double px, py, ph, res;
  guint nl;
  fail_unless (gst_structure_get_double (s, "x", &px));
  fail_unless (gst_structure_get_double (s, "y", &py));
  fail_unless (gst_structure_get_double (s, "heading", &ph));
  fail_unless (gst_structure_get_double (s, "residual", &res));
  fail_unless (gst_structure_get_uint (s, "n-landmarks", &nl));
  fail_unless (fabs (px - x) < tol && fabs (py - y) < tol
      && fabs (remainder (ph - h, 2 * M_PI)) < tol,
      "pose (%.6f, %.6f, %.6f) want (%.6f, %.6f, %.6f)", px, py, ph, x, y, h);
  if (solver)
    fail_unless_equals_string (gst_structure_get_string (s, "solver"),
        solver);
  fail_unless_equals_int (nl, n);
  const GValue *cov = gst_structure_get_value (s, "covariance");
  fail_unless (cov && GST_VALUE_HOLDS_ARRAY (cov));
  fail_unless_equals_int (gst_value_array_get_size (cov), 9);
  for (guint i = 0; i < 9; i++)
    fail_unless (G_VALUE_HOLDS_DOUBLE (gst_value_array_get_value (cov, i)));
  fail_unless (g_value_get_double (gst_value_array_get_value (cov, 0)) > 0);
  const GValue *ids = gst_structure_get_value (s, "landmarks");
  fail_unless (ids && GST_VALUE_HOLDS_ARRAY (ids));
  fail_unless_equals_int (gst_value_array_get_size (ids), n);
}

/* the pose meta of an output buffer: there, and as expected */
static void
check_pose (GstBuffer * out, double x, double y, double h, double tol,
    const gchar * solver, guint n)
{
  GstCustomMeta *meta = gst_buffer_get_custom_meta (out,
      "GstLandmarkPoseMeta");
  fail_unless (meta != NULL, "no pose meta");
  check_pose_structure (gst_custom_meta_get_structure (meta), x, y, h, tol,
      solver, n);
}

static const GstStructure *
match_of (GstBuffer * buf, gint id)
{
  return landmark_check_roi_param (buf, id, "landmark-match");
}

static void
check_matched (GstBuffer * buf, gint id, const gchar * landmark)
{
  const GstStructure *m = match_of (buf, id);
  gboolean matched = FALSE;
  double r;
  fail_unless (m != NULL);
  fail_unless (gst_structure_get_boolean (m, "matched", &matched));
  if (landmark) {
    fail_unless (matched, "detection %d unmatched", id);
    fail_unless_equals_string (gst_structure_get_string (m, "landmark-id"),
        landmark);
    fail_unless (gst_structure_get_double (m, "residual", &r) && r < 1e-6);
  } else {
    fail_unless (!matched, "detection %d matched", id);
    fail_unless (!gst_structure_has_field (m, "landmark-id"));
    fail_unless (gst_structure_get_string (m, "reason") != NULL);
  }
}

/* No pose on buf (no pose meta; the frame's message says has-pose false,
 * too-few-landmarks, no position) and detection 0 named `landmark` by its
 * colour alone. */
static void
check_no_pose_colour_match (GstBuffer * buf, GstBus * bus,
    const gchar * landmark)
{
  const GstStructure *m = match_of (buf, 0);
  gboolean has = TRUE;
  GstStructure *msg;
  fail_unless (gst_buffer_get_custom_meta (buf, "GstLandmarkPoseMeta") ==
      NULL);
  fail_unless (gst_structure_get_boolean (m, "matched", &has) && has);
  fail_unless_equals_string (gst_structure_get_string (m, "landmark-id"),
      landmark);
  fail_unless_equals_string (gst_structure_get_string (m, "matched-by"),
      "colour");
  msg = pop_pose_message (bus);
  fail_unless (gst_structure_get_boolean (msg, "has-pose", &has) && !has);
  fail_unless_equals_string (gst_structure_get_string (msg, "reason"),
      "too-few-landmarks");
  fail_unless (!gst_structure_has_field (msg, "x"));
  gst_structure_free (msg);
}

LANDMARK_TEST ("general", test_three_landmarks)
{
  GstBus *bus;
  GstHarness *h = harness ("", &bus);
  GstBuffer *in = frame (0), *out;
  GstStructure *msg;
  const GstStructure *pose;
  /* R1, G1, Y1 from (2, 2) facing -115 degrees; red and green repeat on
   * the map, the consensus places them; a pink blob and a no-floor one
   * are left unmatched */
  const double x = 2, y = 2, hd = -2.0;
  add_seen (in, 0, 0, x, y, hd, 0);
  add_seen (in, 1, 1, x, y, hd, 0);
  add_seen (in, 2, 5, x, y, hd, 0);
  add_no_floor (in, 3, "blue");
  {
    GstVideoRegionOfInterestMeta *roi =
        gst_buffer_add_video_region_of_interest_meta (in, "pink", 0, 0, 4, 4);
    roi->id = 4;
    gst_video_region_of_interest_meta_add_param (roi,
        gst_structure_new ("landmark-range", "ground-x", G_TYPE_DOUBLE, 1.0,
            "ground-y", G_TYPE_DOUBLE, 0.0, "no-floor", G_TYPE_BOOLEAN,
            FALSE, NULL));
  }
  out = gst_harness_push_and_pull (h, in);
  pose = gst_buffer_get_custom_meta (out, "GstLandmarkPoseMeta") ?
      gst_custom_meta_get_structure (gst_buffer_get_custom_meta (out,
          "GstLandmarkPoseMeta")) : NULL;
  fail_unless (pose != NULL);
  check_pose_structure (pose, x, y, hd, 1e-9, "lsq", 3);
  fail_unless_equals_string (gst_structure_get_string (pose, "geometry"),
      "ok");
  check_matched (out, 0, "R1");
  check_matched (out, 1, "G1");
  check_matched (out, 2, "Y1");
  check_matched (out, 3, NULL);
  fail_unless_equals_string (gst_structure_get_string (match_of (out, 3),
          "reason"), "no-range");
  check_matched (out, 4, NULL);
  fail_unless_equals_string (gst_structure_get_string (match_of (out, 4),
          "reason"), "no-landmark-of-class");

  msg = pop_pose_message (bus);
  {
    gboolean has = FALSE;
    guint64 ts = 1, rt = 1;
    fail_unless (gst_structure_get_boolean (msg, "has-pose", &has) && has);
    fail_unless (gst_structure_get_uint64 (msg, "timestamp", &ts) && ts == 0);
    fail_unless (gst_structure_get_uint64 (msg, "running-time", &rt)
        && rt == 0);
    check_pose_structure (msg, x, y, hd, 1e-9, "lsq", 3);
  }
  gst_structure_free (msg);
  gst_buffer_unref (out);
  harness_done (h, bus);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_two_and_one)
{
  GstBus *bus;
  GstHarness *h = harness ("heading=30", &bus);
  GstBuffer *in, *out;
  /* two landmarks, robot right of the G2-B1 line... either side */
  const double poses[][3] = { {6, 2, 0.5}, {6, -1.5, 1.2} };
  for (guint i = 0; i < G_N_ELEMENTS (poses); i++) {
    in = frame (i);
    add_seen (in, 0, 2, poses[i][0], poses[i][1], poses[i][2], 0);
    add_seen (in, 1, 5, poses[i][0], poses[i][1], poses[i][2], 0);
    out = gst_harness_push_and_pull (h, in);
    check_pose (out, poses[i][0], poses[i][1], poses[i][2], 1e-9, "two", 2);
    check_matched (out, 0, "B1");
    check_matched (out, 1, "Y1");
    gst_buffer_unref (out);
  }
  /* one landmark with the heading property (30 degrees) */
  out = push_blue (h, 5, 1.0, 1.5, M_PI / 6);
  check_pose (out, 1.0, 1.5, M_PI / 6, 1e-9, "one", 1);
  gst_buffer_unref (out);
  harness_done (h, bus);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_no_pose)
{
  GstBus *bus;
  GstHarness *h = harness ("", &bus);
  /* one landmark, no heading, no previous pose: too few for a pose; the
   * map holds blue once, so the detection is B1 (by colour) */
  GstBuffer *in, *out = push_blue (h, 0, 2, 2, 0.3);
  check_no_pose_colour_match (out, bus, "B1");
  fail_unless (!gst_structure_has_field (match_of (out, 0), "residual"));
  gst_buffer_unref (out);

  /* red alone: the map has it twice and nothing tells R1 from R2 */
  in = frame (1);
  add_seen (in, 0, 0, 2, 2, 0.3, 0);
  out = gst_harness_push_and_pull (h, in);
  check_matched (out, 0, NULL);
  fail_unless_equals_string (gst_structure_get_string (match_of (out, 0),
          "reason"), "ambiguous");
  gst_structure_free (pop_pose_message (bus));
  gst_buffer_unref (out);

  harness_done (h, bus);

  /* messages off, and off by default: nothing posted */
  check_no_messages ("post-messages=false");
  check_no_messages ("");
}
GST_END_TEST;

/* A pose from three landmarks, then blue alone: without a measured heading
 * (the previous pose's is no measurement) there is no one-landmark pose,
 * and B1 is named by its colour. */
LANDMARK_TEST ("general", test_one_landmark_needs_heading)
{
  GstBus *bus;
  GstHarness *h = harness ("", &bus);
  GstBuffer *out = gst_harness_push_and_pull (h, frame_of_three (0));
  check_pose (out, 3, 1, 2.0, 1e-9, "lsq", 3);
  fail_unless_equals_string (gst_structure_get_string (match_of (out, 2),
          "matched-by"), "pose");
  gst_buffer_unref (out);
  gst_structure_free (pop_pose_message (bus));

  /* the robot turned 0.2 rad; blue alone */
  out = push_blue (h, 1, 3, 1, 2.2);
  /* no one-landmark pose from the previous pose's heading */
  check_no_pose_colour_match (out, bus, "B1");
  gst_buffer_unref (out);
  harness_done (h, bus);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_outlier_and_gate)
{
  GstBus *bus;
  GstHarness *h = harness ("", &bus);
  GstBuffer *in = frame_of_three (0), *out;
  /* four landmarks, Y1 ranged 0.7 m too far: rejected */
  add_seen (in, 3, 5, 3, 1, 2.0, 0.7);
  out = gst_harness_push_and_pull (h, in);
  check_pose (out, 3, 1, 2.0, 1e-9, "lsq", 3);
  check_matched (out, 3, NULL);
  fail_unless_equals_string (gst_structure_get_string (match_of (out, 3),
          "reason"), "outlier");
  gst_buffer_unref (out);

  /* next frame: only the two repeated colours; the previous pose gates
   * them to R1 and G1 (R2 and G2 would fit as well without it) */
  in = frame (1);
  add_seen (in, 0, 0, 3.02, 1.01, 2.01, 0);
  add_seen (in, 1, 1, 3.02, 1.01, 2.01, 0);
  out = gst_harness_push_and_pull (h, in);
  check_pose (out, 3.02, 1.01, 2.01, 1e-9, "two", 2);
  check_matched (out, 0, "R1");
  check_matched (out, 1, "G1");
  gst_buffer_unref (out);
  harness_done (h, bus);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_ekf_bridges)
{
  GstBus *bus;
  GstHarness *h = harness ("filter=ekf max-age=0.5", &bus);
  GstBuffer *in, *out;
  const GstStructure *pose;
  guint n;
  /* 0.3 m/s along +x; landmarks in frames 0-29, none in 30-39, none
   * after 0.5 s */
  for (n = 0; n < 60; n++) {
    const double x = 1 + 0.3 * n / 30.0, y = 2, hd = 0.0;
    in = frame (n);
    if (n < 30) {
      add_seen (in, 0, 0, x, y, hd, 0);
      add_seen (in, 1, 1, x, y, hd, 0);
      add_seen (in, 2, 2, x, y, hd, 0);
    }
    out = gst_harness_push_and_pull (h, in);
    GstCustomMeta *m = gst_buffer_get_custom_meta (out,
        "GstLandmarkPoseMeta");
    if (n < 30 + 14) {
      double px, py;
      fail_unless (m != NULL, "no pose in frame %u", n);
      pose = gst_custom_meta_get_structure (m);
      gst_structure_get_double (pose, "x", &px);
      gst_structure_get_double (pose, "y", &py);
      fail_unless (hypot (px - x, py - y) < (n < 30 ? 0.01 : 0.03),
          "frame %u: (%.4f, %.4f) want (%.4f, %.4f)", n, px, py, x, y);
      fail_unless_equals_string (gst_structure_get_string (pose, "filter"),
          "ekf");
      if (n >= 30)
        fail_unless_equals_string (gst_structure_get_string (pose,
                "solver"), "ekf");
    } else if (n > 30 + 16) {
      fail_unless (m == NULL, "frame %u bridged beyond max-age", n);
    }
    gst_buffer_unref (out);
  }
  harness_done (h, bus);
}
GST_END_TEST;

/* The robot stops after a second at 0.3 m/s along +x. From then on it
 * sees the yellow landmark (its colour's only one) exactly and a green one
 * ranged 1 m short with a 0.5 m sigma (a blob merged or cut): no pose
 * fits both, yet the filter, testing each pairing against its own
 * prediction, keeps the yellow one and follows the robot to its stop. */
LANDMARK_TEST ("general", test_ekf_keeps_pairings_without_a_solution)
{
  GstBus *bus;
  GstHarness *h = harness ("filter=ekf", &bus);
  guint n;
  for (n = 0; n < 75; n++) {
    const double x = 1 + 0.3 * MIN (n, 30) / 30.0, y = 2, hd = 0.0;
    GstBuffer *in = frame (n);
    if (n < 30) {
      add_seen (in, 0, 0, x, y, hd, 0);
      add_seen (in, 1, 1, x, y, hd, 0);
      add_seen (in, 2, 5, x, y, hd, 0);
    } else {
      add_seen (in, 0, 5, x, y, hd, 0);
      add_seen_sigma (in, 1, 1, x, y, hd, -1.0, 0.5);
    }
    GstBuffer *out = gst_harness_push_and_pull (h, in);
    if (n >= 60) {
      GstCustomMeta *m = gst_buffer_get_custom_meta (out,
          "GstLandmarkPoseMeta");
      double px, py;
      fail_unless (m != NULL, "no pose in frame %u", n);
      const GstStructure *pose = gst_custom_meta_get_structure (m);
      gst_structure_get_double (pose, "x", &px);
      gst_structure_get_double (pose, "y", &py);
      fail_unless (hypot (px - x, py - y) < 0.05,
          "frame %u: (%.4f, %.4f) want (%.4f, %.4f)", n, px, py, x, y);
    }
    gst_buffer_unref (out);
  }
  harness_done (h, bus);
}
GST_END_TEST;

/* Setting `launch` to READY fails with a settings error whose message or
 * debug text contains every string of `what`. */
static void
expect_ready_error (const gchar * launch, const gchar * what1,
    const gchar * what2)
{
  landmark_check_start_fails (landmark_check_element (launch),
      GST_STATE_READY, LANDMARK_CHECK_IN_DEBUG, what1, what2);
}

LANDMARK_TEST ("general", test_bad_maps)
{
  gchar *bad = write_tmp ("{\"landmarks\": [{\"id\": \"A\", \"class\": "
      "\"red\", \"x\": 1, \"y\": 2}, {\"id\": \"B7\", \"class\": \"red\", "
      "\"x\": \"far\", \"y\": 2}]}");
  gchar *empty = write_tmp ("{\"landmarks\": []}");
  gchar *launch;

  expect_ready_error ("trilaterate", "map=", NULL);
  expect_ready_error ("trilaterate map=/nonexistent/map.json",
      "/nonexistent/map.json", NULL);
  launch = g_strdup_printf ("trilaterate map=%s", bad);
  expect_ready_error (launch, bad, "B7");
  g_free (launch);
  launch = g_strdup_printf ("trilaterate map=%s", empty);
  expect_ready_error (launch, empty, "empty");
  g_free (launch);
  g_unlink (bad);
  g_unlink (empty);
  g_free (bad);
  g_free (empty);
}
GST_END_TEST;

LANDMARK_CHECK_MAIN (trilaterate, .setup = setup, .teardown = teardown,
    .checked = TRUE);
