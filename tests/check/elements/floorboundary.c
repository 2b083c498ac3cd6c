/* Unit tests of floorboundary.
 *
 * Label planes are drawn here and attached by hand as a
 * GstLandmarkLabelsMeta. The expected ranges come from the pinhole model
 * written out in this file (range = h / tan (tilt + atan ((v - cy) / f))
 * for the centre column), never from the element's own code. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include <math.h>
#include <string.h>

#define FLOOR_META LANDMARK_FLOOR_META

enum
{ NONE, RED, GREEN, YELLOW, PINK, BLUE, WHITE, GREY };

#define W 640
#define H 480
#define CAM_H 0.3
#define TILT 25.0
#define HFOV 60.0

static gdouble
focal (void)
{
  return (W / 2.0) / tan (HFOV / 2 * G_PI / 180);
}

/* Floor distance ahead of the edge above row `edge` in the centre. */
static gdouble
edge_distance (guint edge)
{
  const gdouble below = TILT * G_PI / 180 +
      atan ((edge - 0.5 - (H - 1) / 2.0) / focal ());
  return CAM_H / tan (below);
}

static GstBuffer *
frame_with_labels (const guint8 * plane, guint w, guint h,
    const gchar ** names, const gboolean * markers, guint n)
{
  GstBuffer *buf = gst_buffer_new_allocate (NULL, (gsize) w * h, NULL);
  gst_buffer_memset (buf, 0, 0x55, (gsize) w * h);
  landmark_check_labels_attach (buf, plane, w, h, w, names, markers, n);
  return buf;
}

static GstHarness *
harness_new (const gchar * props)
{
  gchar *desc = g_strdup_printf ("floorboundary camera-height=0.3 tilt=25 "
      "hfov=60 %s", props ? props : "");
  GstHarness *hr = landmark_check_harness_new (desc,
      "video/x-raw,format=GRAY8,width=640,height=480,framerate=30/1");
  g_free (desc);
  return hr;
}

/* The floor's arrays, copied out. */
typedef struct
{
  guint bins, width;
  gfloat range[3600], marker[3600];
  guint8 state[3600];
  gfloat row[W], x[W], y[W];
  guint8 bstate[W];
  gdouble max_range, nearest;
} Floor;

static void
copy_array (const GstStructure * s, const gchar * field, gpointer dst,
    gsize bytes)
{
  GstBuffer *b = NULL;
  fail_unless (gst_structure_get (s, field, GST_TYPE_BUFFER, &b, NULL),
      "no %s", field);
  fail_unless_equals_int (gst_buffer_get_size (b), bytes);
  gst_buffer_extract (b, 0, dst, bytes);
  gst_buffer_unref (b);
}

static void
floor_read (GstBuffer * out, Floor * f)
{
  GstCustomMeta *m = gst_buffer_get_custom_meta (out, FLOOR_META);
  const GstStructure *s;
  fail_unless (m != NULL, "no " FLOOR_META);
  s = gst_custom_meta_get_structure (m);
  fail_unless (gst_structure_get_uint (s, "bearing-bins", &f->bins));
  fail_unless (gst_structure_get_uint (s, "width", &f->width));
  fail_unless (gst_structure_get_double (s, "max-range", &f->max_range));
  fail_unless (f->bins <= 3600 && f->width <= W);
  copy_array (s, "rop-range", f->range, f->bins * 4);
  copy_array (s, "rop-marker-range", f->marker, f->bins * 4);
  copy_array (s, "rop-state", f->state, f->bins);
  copy_array (s, "boundary-row", f->row, f->width * 4);
  copy_array (s, "boundary-x", f->x, f->width * 4);
  copy_array (s, "boundary-y", f->y, f->width * 4);
  copy_array (s, "boundary-state", f->bstate, f->width);
  f->nearest = -1;
  gst_structure_get_double (s, "nearest-range", &f->nearest);
}

static guint8 *
plane_floor_below (guint edge, guint8 floor_label, guint8 above)
{
  guint8 *p = g_malloc ((gsize) W * H);
  memset (p, above, (gsize) W * edge);
  memset (p + (gsize) W * edge, floor_label, (gsize) W * (H - edge));
  return p;
}

static GstBuffer *
push (GstHarness * hr, const guint8 * plane)
{
  GstBuffer *out = gst_harness_push_and_pull (hr, frame_with_labels (plane,
          W, H, landmark_check_names7, landmark_check_markers7, 7));
  fail_unless (out != NULL);
  return out;
}

/* A wall straight ahead: white above a grey floor. Bin 0 and the centre
 * column see it at h / tan of the edge's angle. */
LANDMARK_TEST ("general", test_wall_straight_ahead)
{
  GstHarness *hr = harness_new ("floor-classes=grey");
  const guint edges[] = { 70, 160, 300 };
  guint i;
  for (i = 0; i < G_N_ELEMENTS (edges); i++) {
    guint8 *p = plane_floor_below (edges[i], GREY, WHITE);
    GstBuffer *out = push (hr, p);
    Floor f;
    const gdouble X = edge_distance (edges[i]);
    floor_read (out, &f);
    fail_unless_equals_int (f.bins, 360);
    fail_unless_equals_int (f.state[0], 2);     /* obstacle */
    /* bin 0 spans +-0.5 deg: X / cos (0.5 deg) at most */
    fail_unless (f.range[0] >= X * (1 - 1e-5) &&
        f.range[0] <= X / cos (0.5 * G_PI / 180) * (1 + 1e-5),
        "wall at %g: bin 0 %g", X, f.range[0]);
    /* the centre columns straddle bearing 0 */
    fail_unless (fabs (f.x[320] - X) < 1e-4 * X, "x %g vs %g", f.x[320], X);
    fail_unless (fabs (f.row[320] - (edges[i] - 0.5)) < 1e-4);
    fail_unless_equals_int (f.bstate[320], 2);
    fail_unless (fabs (f.nearest - f.range[0]) < 1e-6);
    /* behind the robot: not seen */
    fail_unless_equals_int (f.state[180], 0);
    gst_buffer_unref (out);
    g_free (p);
  }
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* All floor: free up to max-range ahead; with a max-range beyond the top
 * row's floor point, the view ends there (state 3). */
LANDMARK_TEST ("general", test_free_and_view_edge)
{
  guint8 *p = plane_floor_below (0, GREY, GREY);
  GstHarness *hr = harness_new ("max-range=3");
  GstBuffer *out = push (hr, p);
  Floor f;
  floor_read (out, &f);
  fail_unless_equals_int (f.state[0], 1);
  fail_unless (f.range[0] == 3.0f);
  fail_unless (f.nearest < 0);
  gst_buffer_unref (out);
  g_object_set (hr->element, "max-range", 100.0, NULL);
  out = push (hr, p);
  floor_read (out, &f);
  fail_unless_equals_int (f.state[0], 3);
  fail_unless (fabs (f.range[0] - edge_distance (0)) < 1e-3 *
      edge_distance (0), "%g vs %g", f.range[0], edge_distance (0));
  gst_buffer_unref (out);
  g_free (p);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* A red disc lying on the floor is walked over and reported in
 * rop-marker-range; with markers=obstacles it ends the floor. Specks
 * and a two-row shadow change nothing. */
LANDMARK_TEST ("general", test_markers_specks_shadows)
{
  GstHarness *hr = harness_new ("floor-classes=grey max-range=4");
  guint8 *p = plane_floor_below (0, GREY, GREY);
  const guint dv = 250;         /* the disc's centre row, centre column */
  guint u, v;
  GstBuffer *out;
  Floor f;
  for (v = 0; v < H; v++)
    for (u = 0; u < W; u++) {
      const gdouble du = (u - 319.5) / 40.0, dd = (v - (gdouble) dv) / 12.0;
      if (du * du + dd * dd <= 1)
        p[v * W + u] = RED;
      else if ((u * 7 + v * 13) % 97 == 0)
        p[v * W + u] = WHITE;   /* specks */
      else if (v == 400 || v == 401)
        p[v * W + u] = WHITE;   /* a thin shadow line */
    }
  out = push (hr, p);
  floor_read (out, &f);
  fail_unless_equals_int (f.state[0], 1);
  fail_unless (f.range[0] == 4.0f);
  /* the disc's lowest row is dv + 11 (row dv + 12 holds no pixel centre) */
  fail_unless (fabs (f.marker[0] - edge_distance (dv + 12)) < 0.01,
      "marker %g vs %g", f.marker[0], edge_distance (dv + 12));
  gst_buffer_unref (out);

  gst_util_set_object_arg (G_OBJECT (hr->element), "markers", "obstacles");
  out = push (hr, p);
  floor_read (out, &f);
  fail_unless_equals_int (f.state[0], 2);
  fail_unless (fabs (f.range[0] - edge_distance (dv + 12)) < 0.01);
  gst_buffer_unref (out);
  g_free (p);
  gst_harness_teardown (hr);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_message)
{
  GstHarness *hr = harness_new ("floor-classes=grey post-messages=true "
      "bearing-bins=72");
  GstBus *bus = gst_bus_new ();
  guint8 *p = plane_floor_below (200, GREY, WHITE);
  GstBuffer *out;
  GstMessage *msg;
  const GstStructure *s;
  const GValue *ranges;
  gdouble nearest;
  gst_element_set_bus (hr->element, bus);
  out = push (hr, p);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT);
  fail_unless (msg != NULL);
  s = gst_message_get_structure (msg);
  fail_unless (gst_structure_has_name (s, "landmark-obstacles"));
  ranges = gst_structure_get_value (s, "ranges");
  fail_unless_equals_int (gst_value_array_get_size (ranges), 72);
  fail_unless (gst_structure_get_double (s, "nearest-range", &nearest));
  fail_unless (fabs (nearest - edge_distance (200)) < 1e-3);
  gst_message_unref (msg);
  gst_buffer_unref (out);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  g_free (p);
  gst_harness_teardown (hr);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bad_properties)
{
  static const gchar *const bad[] = {
    "max-range=0",
    "floor-classes=grey,,white",
    "calibration=/nonexistent/camera.yaml",
    "camera-height=0",
    /* looking up: the camera sees no floor */
    "tilt=-45",
    NULL
  };
  landmark_check_bad_settings ("floorboundary", bad);
}

GST_END_TEST;

/* Errors known only once the labels arrive: a floor class they lack, and
 * labels with no floor class at all */
static void
check_bad_labels (const gchar * props, const gchar ** names,
    const gboolean * markers, guint n, const gchar * text)
{
  GstHarness *hr = harness_new (props);
  GstBus *bus = gst_bus_new ();
  guint8 *p = plane_floor_below (100, 1, 2);
  GError *err = NULL;
  gst_element_set_bus (hr->element, bus);
  fail_unless_equals_int (gst_harness_push (hr, frame_with_labels (p, W, H,
              names, markers, n)), GST_FLOW_ERROR);
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_ERROR, &err), 1);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS));
  fail_unless (strstr (err->message, text) != NULL, "%s", err->message);
  g_clear_error (&err);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  g_free (p);
  gst_harness_teardown (hr);
}

LANDMARK_TEST ("general", test_no_floor_class)
{
  static const gchar *markers_only[] = { "red", "blue" };
  static const gboolean all_markers[] = { TRUE, TRUE };
  check_bad_labels ("floor-classes=carpet", landmark_check_names7,
      landmark_check_markers7, 7, "carpet");
  check_bad_labels (NULL, markers_only, all_markers, 2, "No floor class");
}

GST_END_TEST;

/* A bad value while playing: one warning, the previous settings stay */
LANDMARK_TEST ("general", test_change_while_playing)
{
  GstHarness *hr = harness_new ("floor-classes=grey max-range=3");
  GstBus *bus = gst_bus_new ();
  guint8 *p = plane_floor_below (0, GREY, GREY);
  GError *err = NULL;
  GstBuffer *out;
  Floor f;
  guint i;
  gst_element_set_bus (hr->element, bus);
  g_object_set (hr->element, "tilt", -45.0, NULL);
  for (i = 0; i < 3; i++) {
    out = push (hr, p);
    floor_read (out, &f);
    fail_unless_equals_int (f.state[0], 1);
    fail_unless (f.range[0] == 3.0f);
    gst_buffer_unref (out);
  }
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_WARNING, &err), 1);
  fail_unless (strstr (err->message, "'tilt'") != NULL, "%s", err->message);
  g_clear_error (&err);
  g_object_set (hr->element, "tilt", 25.0, "max-range", 2.0, NULL);
  out = push (hr, p);
  floor_read (out, &f);
  fail_unless (f.range[0] == 2.0f);
  gst_buffer_unref (out);
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_ERROR, NULL), 0);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  g_free (p);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* A camera set before the first frame that sees floor at the nominal
 * 640x480 but not at the stream's size (fx in pixels, looking up: the
 * bottom edge is 50 degrees below the axis at 480 rows, 17 at 120): refused
 * with one warning, the first frame measured with the previous camera */
LANDMARK_TEST ("general", test_camera_refused_before_first_frame)
{
  GstHarness *hr = landmark_check_harness_new ("floorboundary "
      "camera-height=0.3 tilt=25 hfov=60 floor-classes=grey max-range=3",
      "video/x-raw,format=GRAY8,width=160,height=120,framerate=30/1");
  GstBus *bus = gst_bus_new ();
  guint8 *p = g_malloc ((gsize) 160 * 120);
  GError *err = NULL;
  GstBuffer *out;
  gst_element_set_bus (hr->element, bus);
  memset (p, GREY, (gsize) 160 * 120);
  g_object_set (hr->element, "fx", 200.0, "tilt", -30.0, NULL);
  out = gst_harness_push_and_pull (hr, frame_with_labels (p, 160, 120,
          landmark_check_names7, landmark_check_markers7, 7));
  fail_unless (out != NULL);
  fail_unless (gst_buffer_get_custom_meta (out, FLOOR_META) != NULL);
  gst_buffer_unref (out);
  /* popping one type discards the others: warnings first */
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_WARNING | GST_MESSAGE_ERROR, &err), 1);
  fail_unless (strstr (err->message, "'tilt'") != NULL, "%s", err->message);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS));
  g_clear_error (&err);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  g_free (p);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* Video untouched; no labels meta: one warning, buffers pass */
LANDMARK_TEST ("general", test_no_labels_meta)
{
  GstHarness *hr = harness_new (NULL);
  GstBus *bus = gst_bus_new ();
  GError *err = NULL;
  guint i;
  gst_element_set_bus (hr->element, bus);
  for (i = 0; i < 5; i++) {
    GstBuffer *in = gst_buffer_new_allocate (NULL, (gsize) W * H, NULL);
    GstBuffer *out;
    gst_buffer_memset (in, 0, (guint8) i, (gsize) W * H);
    out = gst_harness_push_and_pull (hr, in);
    fail_unless (out != NULL);
    fail_unless (gst_buffer_get_custom_meta (out, FLOOR_META) == NULL);
    gst_buffer_unref (out);
  }
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_WARNING, &err), 1);
  fail_unless (strstr (err->message, "labsegment") != NULL);
  g_clear_error (&err);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (hr);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (floorboundary);
