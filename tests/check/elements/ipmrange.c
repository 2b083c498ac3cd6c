/* ipmrange: hand-attached detections (landmark-blob with centroid and
 * frame size) against analytic range and bearing; no-floor; bad properties
 * and calibration files fail READY; calibration files are read. */
#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include <math.h>
#include <string.h>

#define W 641
#define H 481
#define CAL_DIR GST_TEST_FILES_PATH "/calibration"

/* Adds a detection with a landmark-blob structure (centroid only). */
static void
add_detection (GstBuffer * buf, gint id, const gchar * cls, gdouble u,
    gdouble v, guint fw, guint fh)
{
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, cls,
      (guint) MAX (0, u - 5), (guint) MAX (0, v - 5), 10, 10);
  roi->id = id;
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, cls,
          "centroid-x", G_TYPE_DOUBLE, u, "centroid-y", G_TYPE_DOUBLE, v,
          "kept", G_TYPE_BOOLEAN, TRUE, "frame-width", G_TYPE_UINT, fw,
          "frame-height", G_TYPE_UINT, fh, NULL));
}

static GstBuffer *
run_one (GstHarness * h, GstBuffer * in)
{
  GstBuffer *out = gst_harness_push_and_pull (h, in);
  fail_unless (out != NULL);
  return out;
}

static const GstStructure *
range_of (GstBuffer * buf, gint id)
{
  return landmark_check_roi_param (buf, id, "landmark-range");
}

/* Floor point of normalized camera coordinates (xn, yn) for a camera at
 * height hgt, tilt t (radians), roll 0 (docs/conventions.md). */
static gboolean
analytic_floor (double xn, double yn, double hgt, double t, double *gx,
    double *gy)
{
  /* d = xn x_c + yn y_c + z_c */
  const double dx = -yn * sin (t) + cos (t);
  const double dy = -xn;
  const double dz = -yn * cos (t) - sin (t);
  if (dz >= 0)
    return FALSE;
  *gx = hgt / -dz * dx;
  *gy = hgt / -dz * dy;
  return TRUE;
}

static GstHarness *
harness (const gchar * launch)
{
  GstHarness *h = gst_harness_new_parse (launch);
  gchar *caps = g_strdup_printf ("video/x-raw,format=GRAY8,width=%d,"
      "height=%d,framerate=30/1", W, H);
  gst_harness_set_src_caps_str (h, caps);
  g_free (caps);
  return h;
}

static void
check_point (const GstStructure * r, double gx, double gy, double tol)
{
  double range, bearing, x, y, rg;
  gboolean nf = TRUE;
  fail_unless (r != NULL);
  fail_unless (gst_structure_get_double (r, "range", &range));
  fail_unless (gst_structure_get_double (r, "bearing", &bearing));
  fail_unless (gst_structure_get_double (r, "ground-x", &x));
  fail_unless (gst_structure_get_double (r, "ground-y", &y));
  fail_unless (gst_structure_get_double (r, "range-ground", &rg));
  fail_unless (gst_structure_get_boolean (r, "no-floor", &nf) && !nf);
  fail_unless (gst_structure_has_field (r, "range-sigma"));
  fail_unless (gst_structure_has_field (r, "bearing-sigma"));
  fail_unless_equals_string (gst_structure_get_string (r, "method"),
      "ground");
  fail_unless (fabs (range - hypot (gx, gy)) < tol, "range %.9f want %.9f",
      range, hypot (gx, gy));
  fail_unless (fabs (bearing - atan2 (gy, gx)) < 1e-6, "bearing %.9f want "
      "%.9f", bearing, atan2 (gy, gx));
  fail_unless (fabs (x - gx) < tol && fabs (y - gy) < tol);
  fail_unless (fabs (rg - range) < 1e-12);
}

LANDMARK_TEST ("general", test_pinhole_hfov)
{
  GstHarness *h = harness ("ipmrange camera-height=0.5 tilt=30 hfov=60");
  const double f = (W / 2.0) / tan (M_PI / 6), cx = (W - 1) / 2.0,
      cy = (H - 1) / 2.0, t = M_PI / 6;
  const double pts[][2] = { {320, 240}, {500, 300}, {100, 460}, {10, 250} };
  GstBuffer *in = gst_buffer_new_and_alloc (W * H), *out;
  for (guint i = 0; i < G_N_ELEMENTS (pts); i++)
    add_detection (in, i, "red", pts[i][0], pts[i][1], W, H);
  out = run_one (h, in);
  for (guint i = 0; i < G_N_ELEMENTS (pts); i++) {
    double gx, gy;
    fail_unless (analytic_floor ((pts[i][0] - cx) / f, (pts[i][1] - cy) / f,
            0.5, t, &gx, &gy));
    check_point (range_of (out, i), gx, gy, 1e-9);
  }
  /* straight ahead at the centre, right of centre is negative bearing */
  {
    double r, b;
    gst_structure_get_double (range_of (out, 0), "range", &r);
    fail_unless (fabs (r - 0.5 / tan (t)) < 1e-9);
    gst_structure_get_double (range_of (out, 1), "bearing", &b);
    fail_unless (b < 0);
  }
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

/* Detections measured on a half-size frame are scaled to the caps. */
LANDMARK_TEST ("general", test_scaled_detections)
{
  GstHarness *h = harness ("ipmrange camera-height=0.4 tilt=20 fx=600 "
      "cx=300 cy=250");
  GstBuffer *in = gst_buffer_new_and_alloc (W * H), *out;
  double gx, gy;
  /* (200.25, 180.25) on a 320.5 x 240.5 frame is (400.5, 360.5) here */
  add_detection (in, 0, "red", 199.75, 179.75, 320, 240);
  out = run_one (h, in);
  {
    const double u = (199.75 + 0.5) * W / 320.0 - 0.5;
    const double v = (179.75 + 0.5) * H / 240.0 - 0.5;
    fail_unless (analytic_floor ((u - 300) / 600, (v - 250) / 600, 0.4,
            20 * M_PI / 180, &gx, &gy));
  }
  check_point (range_of (out, 0), gx, gy, 1e-9);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_no_floor)
{
  /* tilt 10: rows above v ~ 120 look above the horizon */
  GstHarness *h = harness ("ipmrange camera-height=0.5 tilt=10 hfov=60");
  GstBuffer *in = gst_buffer_new_and_alloc (W * H), *out;
  const GstStructure *r;
  gboolean nf = FALSE;
  add_detection (in, 0, "red", 320, 5, W, H);
  add_detection (in, 1, "red", 320, 470, W, H);
  out = run_one (h, in);
  r = range_of (out, 0);
  fail_unless (r != NULL);
  fail_unless (gst_structure_get_boolean (r, "no-floor", &nf) && nf);
  fail_if (gst_structure_has_field (r, "range"));
  fail_if (gst_structure_has_field (r, "range-ground"));
  fail_if (gst_structure_has_field (r, "ground-x"));
  /* above the horizon: no marker, whose centre is below the camera */
  {
    gboolean kept = TRUE;
    fail_unless (gst_structure_get_boolean (r, "kept", &kept) && !kept);
    fail_unless_equals_string (gst_structure_get_string (r,
            "reject-reason"), "no-floor");
  }
  r = range_of (out, 1);
  fail_unless (gst_structure_get_boolean (r, "no-floor", &nf) && !nf);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

/* Setting `launch` to READY fails with a settings error whose message or
 * debug text contains `what`. */
static void
expect_ready_error (const gchar * launch, const gchar * what)
{
  landmark_check_start_fails (landmark_check_element (launch),
      GST_STATE_READY, LANDMARK_CHECK_IN_EITHER, what, NULL);
}

/* GObject refuses a value beyond a property's range with a warning (GLib
 * 2.74, Debian 12) or a critical (GLib 2.84, Debian 13). */
#define ASSERT_REFUSED(code)                                            \
  G_STMT_START {                                                        \
    _gst_check_expecting_log = TRUE;                                    \
    _gst_check_raised_warning = _gst_check_raised_critical = FALSE;     \
    code;                                                               \
    fail_unless (_gst_check_raised_warning || _gst_check_raised_critical, \
        "no warning or critical from: " #code);                         \
    _gst_check_expecting_log = FALSE;                                   \
  } G_STMT_END

LANDMARK_TEST ("general", test_bad_properties)
{
  expect_ready_error ("ipmrange camera-height=0", "camera-height");
  expect_ready_error ("ipmrange hfov=0", "hfov");
  expect_ready_error ("ipmrange hfov=180", "hfov");
  expect_ready_error ("ipmrange tilt=-60", "no floor");
  {
    /* beyond the ranges GObject refuses the value; it never reaches READY */
    GstElement *e = gst_element_factory_make ("ipmrange", NULL);
    gdouble tilt, hfov;
    ASSERT_REFUSED (g_object_set (e, "tilt", 100.0, NULL));
    ASSERT_REFUSED (g_object_set (e, "hfov", 190.0, NULL));
    g_object_get (e, "tilt", &tilt, "hfov", &hfov, NULL);
    fail_unless (tilt == 25.0 && hfov == 60.0, "tilt %f hfov %f", tilt, hfov);
    gst_object_unref (e);
  }
  expect_ready_error ("ipmrange model=seed", "view-depth");
  expect_ready_error ("ipmrange marker-height=0.5 camera-height=0.3",
      "marker-height");
  expect_ready_error ("ipmrange calibration=/nonexistent/cam.yaml",
      "/nonexistent/cam.yaml");
  expect_ready_error ("ipmrange calibration=" CAL_DIR "/no-matrix.yaml",
      "camera_matrix");
  expect_ready_error ("ipmrange calibration=" CAL_DIR "/garbage.yaml",
      "garbage.yaml");
  expect_ready_error ("ipmrange map=/nonexistent/map.json", "map");
}
GST_END_TEST;

LANDMARK_TEST ("general", test_calibration_yaml)
{
  GstHarness *h = harness ("ipmrange camera-height=0.3 tilt=25 "
      "calibration=" CAL_DIR "/cam640.yaml");
  GstBuffer *in = gst_buffer_new_and_alloc (W * H), *out;
  double gx, gy;
  /* the file is for 640x480; the caps are 641x481: K scales by 641/640 */
  const double kx = W / 640.0, ky = H / 480.0;
  const double fx = 500 * kx, fy = 500 * ky;
  const double cx = 320.5 * kx - 0.5, cy = 240.5 * ky - 0.5;
  add_detection (in, 0, "red", 450, 400, W, H);
  out = run_one (h, in);
  fail_unless (analytic_floor ((450 - cx) / fx, (400 - cy) / fy, 0.3,
          25 * M_PI / 180, &gx, &gy));
  check_point (range_of (out, 0), gx, gy, 1e-9);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

/* Distorted pixel -> normalized, by fixed-point iteration of OpenCV's
 * model (k1 k2 p1 p2 k3). */
static void
undistort (double u, double v, const double *k, double fx, double fy,
    double cx, double cy, double *xn, double *yn)
{
  const double xd = (u - cx) / fx, yd = (v - cy) / fy;
  double x = xd, y = yd;
  for (int i = 0; i < 500; i++) {
    const double r2 = x * x + y * y;
    const double rad = 1 + k[0] * r2 + k[1] * r2 * r2 + k[4] * r2 * r2 * r2;
    const double dx = 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x);
    const double dy = k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y;
    x = (xd - dx) / rad;
    y = (yd - dy) / rad;
  }
  *xn = x;
  *yn = y;
}

LANDMARK_TEST ("general", test_calibration_xml_distorted)
{
  GstHarness *h = gst_harness_new_parse ("ipmrange camera-height=0.3 "
      "tilt=25 calibration=" CAL_DIR "/cam640-distorted.xml");
  const double k[5] = { -0.25, 0.08, 0.001, -0.002, -0.01 };
  const double pts[][2] = { {600, 450}, {40, 420}, {322.5, 300} };
  GstBuffer *in = gst_buffer_new_and_alloc (640 * 480), *out;
  gst_harness_set_src_caps_str (h, "video/x-raw,format=GRAY8,width=640,"
      "height=480,framerate=30/1");
  for (guint i = 0; i < G_N_ELEMENTS (pts); i++)
    add_detection (in, i, "red", pts[i][0], pts[i][1], 640, 480);
  out = run_one (h, in);
  for (guint i = 0; i < G_N_ELEMENTS (pts); i++) {
    double xn, yn, gx, gy, gx0 = 0, gy0 = 0;
    undistort (pts[i][0], pts[i][1], k, 520, 518, 322.5, 238.25, &xn, &yn);
    fail_unless (analytic_floor (xn, yn, 0.3, 25 * M_PI / 180, &gx, &gy));
    check_point (range_of (out, i), gx, gy, 1e-7);
    /* and the distortion mattered at the corners */
    analytic_floor ((pts[i][0] - 322.5) / 520, (pts[i][1] - 238.25) / 518,
        0.3, 25 * M_PI / 180, &gx0, &gy0);
    if (i < 2)
      fail_unless (hypot (gx - gx0, gy - gy0) > 1e-3);
  }
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_seed_model)
{
  /* h 0.4, b 0.3, d 0.9, w 0.6: bottom row at b, centre of the left edge
   * at (b + d, +w), eqs 3.5-3.6 */
  GstHarness *h = gst_harness_new_parse ("ipmrange model=seed "
      "camera-height=0.4 blind-distance=0.3 view-depth=0.9 half-width=0.6");
  GstBuffer *in = gst_buffer_new_and_alloc (640 * 480), *out;
  gst_harness_set_src_caps_str (h, "video/x-raw,format=GRAY8,width=640,"
      "height=480,framerate=30/1");
  add_detection (in, 0, "red", 319.5, 479, 640, 480);
  add_detection (in, 1, "red", 0, 239.5, 640, 480);
  out = run_one (h, in);
  check_point (range_of (out, 0), 0.3, 0.0, 1e-9);
  check_point (range_of (out, 1), 1.2, 0.6, 1e-9);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

LANDMARK_TEST ("general", test_change_while_playing)
{
  GstHarness *h = harness ("ipmrange camera-height=0.5 tilt=30 hfov=60");
  GstBuffer *in, *out;
  double r1, r2;
  in = gst_buffer_new_and_alloc (W * H);
  add_detection (in, 0, "red", 320, 240, W, H);
  out = run_one (h, in);
  gst_structure_get_double (range_of (out, 0), "range", &r1);
  gst_buffer_unref (out);
  {
    GstElement *e = gst_harness_find_element (h, "ipmrange");
    g_object_set (e, "camera-height", 1.0, NULL);
    gst_object_unref (e);
  }
  in = gst_buffer_new_and_alloc (W * H);
  add_detection (in, 0, "red", 320, 240, W, H);
  out = run_one (h, in);
  gst_structure_get_double (range_of (out, 0), "range", &r2);
  fail_unless (fabs (r2 - 2 * r1) < 1e-9, "%g %g", r1, r2);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}
GST_END_TEST;

LANDMARK_CHECK_MAIN (ipmrange);
