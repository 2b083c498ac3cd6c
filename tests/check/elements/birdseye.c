/* Unit tests of birdseye: output size and scale, a line on the floor at a
 * known distance (its image row from the pinhole model written out here),
 * strides of odd widths, the frame's metadata kept and image metadata
 * dropped, bad settings; what `draw` draws, at the positions the view's
 * formula gives (docs/birdseye.md), in every format (the cost of a remap
 * and of the drawings: tests/bench/element-cost.c). */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <glib/gstdio.h>

#include <math.h>
#include <string.h>

#define CAM_H 0.3
#define TILT 25.0
#define HFOV 60.0

/* Image row (pixel centres) of the floor at distance x ahead, centre
 * column, for a w x h frame. */
static gdouble
row_of_distance (gdouble x, guint w, guint h)
{
  const gdouble f = (w / 2.0) / tan (HFOV / 2 * G_PI / 180);
  return (h - 1) / 2.0 + f * tan (atan2 (CAM_H, x) - TILT * G_PI / 180);
}

/* An RGB frame, grey floor, with a white band of image rows covering the
 * floor from x0 to x1 metres ahead. Rows are padded (stride > 3 w). */
static GstBuffer *
frame_with_band (const GstVideoInfo * info, gdouble x0, gdouble x1)
{
  const guint w = GST_VIDEO_INFO_WIDTH (info), h = GST_VIDEO_INFO_HEIGHT
      (info);
  const gint stride = GST_VIDEO_INFO_PLANE_STRIDE (info, 0);
  GstBuffer *buf = gst_buffer_new_allocate (NULL, info->size, NULL);
  GstMapInfo map;
  const gdouble v0 = row_of_distance (x1, w, h), v1 = row_of_distance (x0,
      w, h);
  guint u, v;
  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  memset (map.data, 0, map.size);
  for (v = 0; v < h; v++)
    for (u = 0; u < w; u++) {
      guint8 *px = map.data + (gsize) v * stride + 3 * u;
      const guint8 c = (v >= v0 && v <= v1) ? 250 : 100;
      px[0] = px[1] = px[2] = c;
    }
  gst_buffer_unmap (buf, &map);
  return buf;
}

static GstHarness *
harness_new (const gchar * props, guint w, guint h)
{
  gchar *desc = g_strdup_printf ("birdseye camera-height=0.3 tilt=25 "
      "hfov=60 %s", props ? props : "");
  gchar *caps = g_strdup_printf ("video/x-raw,format=RGB,width=%u,"
      "height=%u,framerate=30/1", w, h);
  GstHarness *hr = landmark_check_harness_new (desc, caps);
  g_free (caps);
  g_free (desc);
  return hr;
}

/* A w x h frame with a bright band from 1.9 to 2.1 m ahead, remapped: the
 * output and its video info. */
static GstBuffer *
remap_band (GstHarness * hr, guint w, guint h, GstVideoInfo * out_info)
{
  GstVideoInfo in;
  GstCaps *caps;
  GstBuffer *out;
  gst_video_info_set_format (&in, GST_VIDEO_FORMAT_RGB, w, h);
  out = gst_harness_push_and_pull (hr, frame_with_band (&in, 1.9, 2.1));
  caps = gst_pad_get_current_caps (hr->sinkpad);
  fail_unless (gst_video_info_from_caps (out_info, caps));
  gst_caps_unref (caps);
  return out;
}

static guint8
pixel (GstBuffer * out, const GstVideoInfo * info, guint i, guint j)
{
  GstMapInfo map;
  guint8 v;
  gst_buffer_map (out, &map, GST_MAP_READ);
  v = map.data[(gsize) j * GST_VIDEO_INFO_PLANE_STRIDE (info, 0) + 3 * i];
  gst_buffer_unmap (out, &map);
  return v;
}

/* A band of floor from 1.9 to 2.1 m shows as output rows 400 - 100 x:
 * rows 190..209 white, rows outside it grey, and the same across the
 * view (a straight line). Odd input width: strides. */
LANDMARK_TEST ("general", test_band_at_two_metres)
{
  const guint sizes[][2] = { {640, 480}, {321, 241} };
  guint k;
  for (k = 0; k < G_N_ELEMENTS (sizes); k++) {
    const guint w = sizes[k][0], h = sizes[k][1];
    GstHarness *hr = harness_new (NULL, w, h);
    GstVideoInfo out_info;
    GstBuffer *out = remap_band (hr, w, h, &out_info);
    guint i;
    fail_unless_equals_int (GST_VIDEO_INFO_WIDTH (&out_info), 400);
    fail_unless_equals_int (GST_VIDEO_INFO_HEIGHT (&out_info), 400);
    for (i = 150; i <= 250; i += 10) {
      /* 2.05 m and 1.95 m: inside the band; 2.3 and 1.7 m: floor */
      fail_unless (pixel (out, &out_info, i, 195) > 200, "%ux%u col %u", w,
          h, i);
      fail_unless (pixel (out, &out_info, i, 204) > 200);
      fail_unless (abs (pixel (out, &out_info, i, 170) - 100) < 5);
      fail_unless (abs (pixel (out, &out_info, i, 230) - 100) < 5);
    }
    /* the floor right under the camera is out of view: black */
    fail_unless_equals_int (pixel (out, &out_info, 200, 399), 0);
    gst_buffer_unref (out);
    gst_harness_teardown (hr);
  }
}

GST_END_TEST;

/* pixels-per-metre and the extents set the size and the scale */
LANDMARK_TEST ("general", test_scale_and_extent)
{
  GstHarness *hr = harness_new ("pixels-per-metre=50 forward=3 behind=1 "
      "side=1.5", 640, 480);
  GstVideoInfo out_info;
  GstBuffer *out = remap_band (hr, 640, 480, &out_info);
  fail_unless_equals_int (GST_VIDEO_INFO_WIDTH (&out_info), 150);
  fail_unless_equals_int (GST_VIDEO_INFO_HEIGHT (&out_info), 200);
  /* the camera's floor point is 1 m (50 px) above the bottom: 2 m ahead
   * is row 200 - 50 - 100 = 50 */
  fail_unless (pixel (out, &out_info, 75, 49) > 200);
  fail_unless (pixel (out, &out_info, 75, 51) > 200);
  fail_unless (abs (pixel (out, &out_info, 75, 40) - 100) < 5);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* The frame's results travel with it; the label plane (pixel
 * coordinates of the camera image) does not. */
LANDMARK_TEST ("general", test_metadata)
{
  GstHarness *hr = harness_new (NULL, 64, 48);
  GstVideoInfo in;
  GstBuffer *buf, *out;
  GstCustomMeta *m;
  gdouble x = 0;
  gst_video_info_set_format (&in, GST_VIDEO_FORMAT_RGB, 64, 48);
  buf = frame_with_band (&in, 1, 2);
  m = gst_buffer_add_custom_meta (buf, "GstLandmarkPoseMeta");
  fail_unless (m != NULL);
  gst_structure_set (gst_custom_meta_get_structure (m), "x", G_TYPE_DOUBLE,
      1.25, NULL);
  m = gst_buffer_add_custom_meta (buf, "GstLandmarkLabelsMeta");
  fail_unless (m != NULL);
  out = gst_harness_push_and_pull (hr, buf);
  m = gst_buffer_get_custom_meta (out, "GstLandmarkPoseMeta");
  fail_unless (m != NULL);
  fail_unless (gst_structure_get_double (gst_custom_meta_get_structure (m),
          "x", &x));
  fail_unless_equals_float (x, 1.25);
  fail_unless (gst_buffer_get_custom_meta (out, "GstLandmarkLabelsMeta") ==
      NULL);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* ---- draw ---------------------------------------------------------- */

/* The drawings' view: 3 m wide (side 1.5) and 3.8 m high (3.5 ahead, 0.3
 * behind) at 100 px/m, 300 x 380; the camera's floor point at output
 * pixel (149.5, 349.5), and x forward, y left at
 * (149.5 - 100 y, 349.5 - 100 x) (docs/birdseye.md). */
#define VIEW "pixels-per-metre=100 side=1.5 forward=3.5 behind=0.3 "
#define VIEW_W 300
#define VIEW_H 380
#define PPM 100.0
static gdouble
view_u (gdouble y)
{
  return VIEW_W / 2.0 - 0.5 - y * PPM;
}

static gdouble
view_v (gdouble x)
{
  return VIEW_H - 0.5 - 0.3 * PPM - x * PPM;
}

/* A harness of birdseye (the drawings' view) for frames of format fmt. */
static GstHarness *
draw_harness_new (const gchar * draw, GstVideoFormat fmt)
{
  gchar *desc = g_strdup_printf ("birdseye camera-height=0.3 tilt=25 "
      "hfov=60 " VIEW "draw=%s", draw);
  gchar *caps = g_strdup_printf ("video/x-raw,format=%s,width=640,"
      "height=480,framerate=30/1", gst_video_format_to_string (fmt));
  GstHarness *hr = landmark_check_harness_new (desc, caps);
  g_free (caps);
  g_free (desc);
  return hr;
}

/* A 640x480 frame of format fmt whose every byte is `level`. */
static GstBuffer *
flat_frame (GstVideoFormat fmt, guint8 level)
{
  GstVideoInfo info;
  GstBuffer *buf;
  GstMapInfo map;
  gst_video_info_set_format (&info, fmt, 640, 480);
  buf = gst_buffer_new_allocate (NULL, info.size, NULL);
  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  memset (map.data, level, map.size);
  gst_buffer_unmap (buf, &map);
  return buf;
}

/* Output pixel (i, j) as R, G, B (grey: the grey level three times). */
static void
view_rgb (GstBuffer * out, GstVideoFormat fmt, guint i, guint j, guint8 c[3])
{
  GstVideoInfo info;
  GstMapInfo map;
  const guint8 *px;
  guint k;
  gst_video_info_set_format (&info, fmt, VIEW_W, VIEW_H);
  gst_buffer_map (out, &map, GST_MAP_READ);
  px = map.data + (gsize) j * GST_VIDEO_INFO_PLANE_STRIDE (&info, 0) +
      (gsize) i * GST_VIDEO_INFO_COMP_PSTRIDE (&info, 0);
  for (k = 0; k < 3; k++)
    c[k] = GST_VIDEO_INFO_IS_GRAY (&info) ? px[0] :
        px[GST_VIDEO_INFO_COMP_POFFSET (&info, k)];
  gst_buffer_unmap (out, &map);
}

/* a and b hold the same bytes */
static gboolean
buffers_equal (GstBuffer * a, GstBuffer * b)
{
  GstMapInfo mb;
  gboolean same = FALSE;
  if (gst_buffer_map (b, &mb, GST_MAP_READ)) {
    same = gst_buffer_get_size (a) == mb.size &&
        gst_buffer_memcmp (a, 0, mb.data, mb.size) == 0;
    gst_buffer_unmap (b, &mb);
  }
  return same;
}

static gboolean
is_obstacle_red (const guint8 c[3])
{
  return c[0] > 180 && c[1] < 90 && c[2] < 90;
}

static gboolean
is_free_green (const guint8 c[3])
{
  return c[1] > 180 && c[0] < 120 && c[2] < 120;
}

/* The free space's outline: the share of the points 0.4 to 1.4 m out from
 * the robot along bearing phi (radians, to the left) within 1 px of a
 * green pixel; and how many green pixels lie more than 40 degrees off
 * ahead (or behind the robot), where the wall's bins are not seen. */
static gdouble
outline_share (GstBuffer * out, gdouble phi, guint * stray)
{
  guint hits = 0, n = 0, i, j;
  gdouble r;
  for (r = 0.4; r <= 1.4; r += 0.02, n++) {
    gboolean hit = FALSE;
    gint di, dj;
    for (dj = -1; dj <= 1; dj++)
      for (di = -1; di <= 1; di++) {
        guint8 c[3];
        view_rgb (out, GST_VIDEO_FORMAT_RGB,
            (guint) (view_u (r * sin (phi)) + 0.5) + di,
            (guint) (view_v (r * cos (phi)) + 0.5) + dj, c);
        hit |= is_free_green (c);
      }
    hits += hit;
  }
  *stray = 0;
  for (j = 0; j < VIEW_H; j++)
    for (i = 0; i < VIEW_W; i++) {
      const gdouble x = (view_v (0) - j) / PPM, y = (view_u (0) - i) / PPM;
      guint8 c[3];
      if (hypot (x, y) < 0.1 || atan2 (fabs (y), x) < 40 * G_PI / 180)
        continue;
      view_rgb (out, GST_VIDEO_FORMAT_RGB, i, j, c);
      *stray += is_free_green (c);
    }
  return (gdouble) hits / n;
}

/* The wall at 1.5 m is drawn along output row 349.5 - 150 = 199.5: in
 * every column of the middle metre, the red pixels' mean row is within 1
 * px of it and none is 4 px away; the free space is outlined in green
 * along the seen bins' outer edges, bearings +-30.5 degrees, and nowhere
 * more than 40 degrees off ahead; with the bins to the left unseen, only
 * the right edge (bearings are positive to the left); draw=none draws
 * nothing. */
LANDMARK_TEST ("draw", test_wall_on_its_row)
{
  const gchar *draws[] = { "boundary", "none", "boundary" };
  const gdouble want = view_v (1.5);
  guint d, i, j;
  fail_unless (fabs (want - 199.5) < 1e-9);
  for (d = 0; d < G_N_ELEMENTS (draws); d++) {
    GstHarness *hr = draw_harness_new (draws[d], GST_VIDEO_FORMAT_RGB);
    GstBuffer *in = flat_frame (GST_VIDEO_FORMAT_RGB, 100), *out;
    guint reds = 0;
    landmark_check_floor_wall_attach (in, 1.5);
    if (d == 2) {
      /* the right half of the view only: bins 330..359 and 0 */
      guint8 state[360];
      for (i = 0; i < 360; i++)
        state[i] = i == 0 || i >= 330 ? 2 : 0;
      landmark_check_floor_array (gst_custom_meta_get_structure
          (gst_buffer_get_custom_meta (in, LANDMARK_FLOOR_META)), "rop-state",
          state, sizeof (state));
    }
    out = gst_harness_push_and_pull (hr, in);
    for (i = (guint) view_u (0.5); i <= (guint) view_u (-0.5); i++) {
      gdouble sum = 0;
      guint n = 0;
      for (j = 0; j < VIEW_H; j++) {
        guint8 c[3];
        view_rgb (out, GST_VIDEO_FORMAT_RGB, i, j, c);
        if (!is_obstacle_red (c))
          continue;
        fail_unless (fabs (j - want) < 4, "red at column %u row %u", i, j);
        sum += j;
        n++;
      }
      reds += n;
      if (d != 1) {
        fail_unless (n > 0, "no line in column %u", i);
        fail_unless (fabs (sum / n - want) <= 1, "column %u: row %.2f, "
            "want %.2f", i, sum / n, want);
      }
    }
    if (d == 1)
      fail_unless_equals_int (reds, 0);
    for (i = 0; i < 2; i++) {
      const gdouble phi = (i ? -30.5 : 30.5) * G_PI / 180;
      guint stray;
      const gdouble share = outline_share (out, phi, &stray);
      const gboolean drawn = d == 0 || (d == 2 && phi < 0);
      fail_unless (drawn ? share > 0.9 : share == 0, "case %u: outline at "
          "%.1f deg: %.2f", d, phi * 180 / G_PI, share);
      fail_unless_equals_int (stray, 0);
    }
    gst_buffer_unref (out);
    gst_harness_teardown (hr);
  }
}

GST_END_TEST;

/* A labels meta naming one class, `cls`, drawn in colour rgb (0xRRGGBB). */
static void
add_class (GstBuffer * buf, const gchar * cls, guint rgb)
{
  GstStructure *s = landmark_check_meta_add (buf, LANDMARK_LABELS_META);
  const gboolean yes = TRUE;
  landmark_check_set_array (s, "class-names", G_TYPE_STRING, &cls, 1);
  landmark_check_set_array (s, "class-rgb", G_TYPE_UINT, &rgb, 1);
  landmark_check_set_array (s, "class-markers", G_TYPE_BOOLEAN, &yes, 1);
}

/* The pixels of colour want (within 2 levels) in the box of half-size
 * `reach` around (cu, cv): how many, and their centroid. */
static guint
count_colour (GstBuffer * out, GstVideoFormat fmt, const guint8 want[3],
    gdouble cu, gdouble cv, gint reach, gdouble * mu, gdouble * mv)
{
  guint n = 0;
  gdouble su = 0, sv = 0;
  gint i, j;
  for (j = (gint) cv - reach; j <= (gint) cv + reach; j++)
    for (i = (gint) cu - reach; i <= (gint) cu + reach; i++) {
      guint8 c[3];
      if (i < 0 || j < 0 || i >= VIEW_W || j >= VIEW_H)
        continue;
      view_rgb (out, fmt, i, j, c);
      if (abs (c[0] - want[0]) <= 2 && abs (c[1] - want[1]) <= 2 &&
          abs (c[2] - want[2]) <= 2) {
        n++;
        su += i;
        sv += j;
      }
    }
  *mu = n ? su / n : -1;
  *mv = n ? sv / n : -1;
  return n;
}

static const GstVideoFormat draw_formats[] = {
  GST_VIDEO_FORMAT_RGB, GST_VIDEO_FORMAT_BGR, GST_VIDEO_FORMAT_BGRx,
  GST_VIDEO_FORMAT_xRGB, GST_VIDEO_FORMAT_ABGR, GST_VIDEO_FORMAT_GRAY8
};

/* A 10 cm landmark at (2.0, 0.5) is a disc centred on output pixel
 * (149.5 - 50, 349.5 - 200) = (99.5, 149.5) in its class colour (grey:
 * its luma, 0.299 R + 0.587 G + 0.114 B), of radius 0.05 x 100 = 5 px:
 * the pixels wholly inside it (centres within r - 1/2, the Renderer's
 * anti-aliasing) cover pi (r - 1/2)^2. Its id is written beside it; a
 * rejected detection at (1.0, -0.5) is not drawn. In every format. */
LANDMARK_TEST_LOOP ("draw", test_landmark_disc, G_N_ELEMENTS (draw_formats))
{
  const GstVideoFormat fmt = draw_formats[__i__];
  const gboolean grey = fmt == GST_VIDEO_FORMAT_GRAY8;
  const gdouble cu = view_u (0.5), cv = view_v (2.0), r = 0.05 * PPM;
  guint8 want[3] = { 255, 128, 0 };
  GstHarness *hr = draw_harness_new ("landmarks", fmt);
  GstBuffer *in = flat_frame (fmt, 100), *out;
  gdouble mu, mv;
  guint n, text = 0, i, j;
  fail_unless (fabs (cu - 99.5) < 1e-9 && fabs (cv - 149.5) < 1e-9);
  if (grey)
    want[0] = want[1] = want[2] =
        (guint8) lround (0.299 * 255 + 0.587 * 128 + 0.114 * 0);
  add_class (in, "orange", 0xff8000);
  landmark_check_ranged_attach (in, "orange", 2.0, 0.5, 0.1, TRUE, "L7");
  landmark_check_ranged_attach (in, "orange", 1.0, -0.5, 0.1, FALSE, NULL);
  out = gst_harness_push_and_pull (hr, in);
  n = count_colour (out, fmt, want, cu, cv, 12, &mu, &mv);
  fail_unless (fabs (mu - cu) <= 1 && fabs (mv - cv) <= 1,
      "%s: centre (%.2f, %.2f), want (%.1f, %.1f)",
      gst_video_format_to_string (fmt), mu, mv, cu, cv);
  fail_unless (fabs (sqrt (n / G_PI) + 0.5 - r) <= 1,
      "%s: %u pixels, radius %.2f, want %.1f",
      gst_video_format_to_string (fmt), n, sqrt (n / G_PI) + 0.5, r);
  /* the id, white, right of the disc */
  for (j = (guint) cv - 8; j <= (guint) cv + 8; j++)
    for (i = (guint) (cu + r + 2); i < (guint) (cu + r + 30); i++) {
      guint8 c[3];
      view_rgb (out, fmt, i, j, c);
      text += c[0] > 200 && c[1] > 200 && c[2] > 200;
    }
  fail_unless (text > 5, "no id beside the landmark");
  /* the rejected one: nothing at (1.0, -0.5) */
  fail_unless_equals_int (count_colour (out, fmt, want, view_u (-0.5),
          view_v (1.0), 12, &mu, &mv), 0);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* Image pixel (u, v) of floor point (x, y) for the 640x480 pinhole camera
 * of these tests (0.3 m up, tilted 25 degrees down, hfov 60, no roll):
 * camera axes forward (cos t, 0, -sin t), right (0, -1, 0), down
 * (-sin t, 0, -cos t). */
static void
floor_to_image (gdouble x, gdouble y, gdouble * u, gdouble * v)
{
  const gdouble t = TILT * G_PI / 180;
  const gdouble f = 320 / tan (HFOV / 2 * G_PI / 180);
  const gdouble depth = x * cos (t) + CAM_H * sin (t);
  *u = 319.5 + f * -y / depth;
  *v = 239.5 + f * (CAM_H * cos (t) - x * sin (t)) / depth;
}

/* The landmark's size without ipmrange's diameter: from the map (the
 * matched landmark's, 0.2 m: radius 10 px), and measured (no map): a blob
 * whose ellipse spans the image points of (2.0, 0.45) and (2.0, 0.55), so
 * 0.1 m across: radius 5 px. */
LANDMARK_TEST ("draw", test_landmark_size_from_map_or_measured)
{
  const guint8 want[3] = { 255, 128, 0 };
  const gdouble cu = view_u (0.5), cv = view_v (2.0);
  gchar *map = landmark_check_write_tmp ("map", ".json", "{\"landmarks\": "
      "[{\"id\": \"L7\", \"class\": \"orange\", \"x\": 0, \"y\": 0, "
      "\"diameter\": 0.2, \"kind\": \"disc\"}]}");
  gchar *draw = g_strdup_printf ("landmarks map=%s", map);
  GstHarness *hr = draw_harness_new (draw, GST_VIDEO_FORMAT_RGB);
  GstBuffer *in = flat_frame (GST_VIDEO_FORMAT_RGB, 100), *out;
  GstVideoRegionOfInterestMeta *roi;
  gdouble mu, mv, u0, u1, v0;
  guint n;
  add_class (in, "orange", 0xff8000);
  landmark_check_ranged_attach (in, "orange", 2.0, 0.5, 0, TRUE, "L7");
  out = gst_harness_push_and_pull (hr, in);
  n = count_colour (out, GST_VIDEO_FORMAT_RGB, want, cu, cv, 16, &mu, &mv);
  fail_unless (fabs (sqrt (n / G_PI) + 0.5 - 10) <= 1, "map: radius %.2f",
      sqrt (n / G_PI) + 0.5);
  fail_unless (fabs (mu - cu) <= 1 && fabs (mv - cv) <= 1);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);

  hr = draw_harness_new ("landmarks", GST_VIDEO_FORMAT_RGB);
  in = flat_frame (GST_VIDEO_FORMAT_RGB, 100);
  add_class (in, "orange", 0xff8000);
  floor_to_image (2.0, 0.55, &u0, &v0);
  floor_to_image (2.0, 0.45, &u1, &v0);
  roi = gst_buffer_add_video_region_of_interest_meta (in, "orange",
      (guint) u0 - 1, (guint) v0 - 3, (guint) (u1 - u0) + 3, 7);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, "orange",
          "kept", G_TYPE_BOOLEAN, TRUE, "frame-width", G_TYPE_UINT, 640,
          "frame-height", G_TYPE_UINT, 480, "ellipse-x", G_TYPE_DOUBLE,
          (u0 + u1) / 2, "ellipse-y", G_TYPE_DOUBLE, v0, "ellipse-major",
          G_TYPE_DOUBLE, u1 - u0, "ellipse-minor", G_TYPE_DOUBLE, 4.0,
          "ellipse-angle", G_TYPE_DOUBLE, 0.0, NULL));
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "ground-x", G_TYPE_DOUBLE, 2.0,
          "ground-y", G_TYPE_DOUBLE, 0.5, "kept", G_TYPE_BOOLEAN, TRUE,
          NULL));
  out = gst_harness_push_and_pull (hr, in);
  n = count_colour (out, GST_VIDEO_FORMAT_RGB, want, cu, cv, 16, &mu, &mv);
  fail_unless (fabs (sqrt (n / G_PI) + 0.5 - 5) <= 1, "measured: radius "
      "%.2f (ellipse %.1f px wide)", sqrt (n / G_PI) + 0.5, u1 - u0);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);
  g_unlink (map);
  g_free (map);
  g_free (draw);
}

GST_END_TEST;

static gboolean
is_white (GstBuffer * out, GstVideoFormat fmt, gdouble i, gdouble j)
{
  guint8 c[3];
  view_rgb (out, fmt, (guint) i, (guint) j, c);
  return c[0] > 240 && c[1] > 240 && c[2] > 240;
}

/* Of the floor points 1.0 to 2.5 m ahead on the image's left (side 1) or
 * right (side -1) edge, u = -0.5 or 639.5, i.e. y = +-320 depth / f, the
 * share that have a bright pixel within 1 px of their output pixel. */
static gdouble
edge_share (GstBuffer * out, gint side)
{
  const gdouble t = TILT * G_PI / 180;
  const gdouble f = 320 / tan (HFOV / 2 * G_PI / 180);
  guint hits = 0, n = 0;
  gdouble x;
  for (x = 1.0; x <= 2.5; x += 0.02, n++) {
    const gdouble y = side * 320 * (x * cos (t) + CAM_H * sin (t)) / f;
    gboolean hit = FALSE;
    gint di, dj;
    for (dj = -1; dj <= 1; dj++)
      for (di = -1; di <= 1; di++) {
        guint8 c[3];
        view_rgb (out, GST_VIDEO_FORMAT_RGB, (guint) (view_u (y) + 0.5) + di,
            (guint) (view_v (x) + 0.5) + dj, c);
        hit |= c[0] > 180 && c[1] > 180 && c[2] > 180;
      }
    hits += hit;
  }
  return (gdouble) hits / n;
}

/* The robot: a white triangle standing on the camera's floor point
 * (149.5, 349.5), 0.3 m above the bottom, pointing up: white 4 px above
 * the point, not 5 px below it; the field of view's edges dashed along
 * the image's left and right edges on the floor (a dash is 6 px, a gap
 * 8.5: at least a third of the points). The property changes while
 * playing: none, robot, none again, the plain remap each time it is
 * off. */
LANDMARK_TEST ("draw", test_robot_and_change_while_playing)
{
  GstHarness *hr = draw_harness_new ("none", GST_VIDEO_FORMAT_RGB);
  GstHarness *plain = draw_harness_new ("none", GST_VIDEO_FORMAT_RGB);
  const gchar *steps[] = { "none", "robot", "none" };
  const gdouble ou = view_u (0), ov = view_v (0);
  GstBuffer *want = gst_harness_push_and_pull (plain,
      flat_frame (GST_VIDEO_FORMAT_RGB, 100));
  guint k;
  fail_unless (fabs (ou - 149.5) < 1e-9 && fabs (ov - 349.5) < 1e-9);
  for (k = 0; k < G_N_ELEMENTS (steps); k++) {
    GstBuffer *out;
    gst_util_set_object_arg (G_OBJECT (hr->element), "draw", steps[k]);
    out = gst_harness_push_and_pull (hr, flat_frame (GST_VIDEO_FORMAT_RGB,
            100));
    if (k == 1) {
      fail_unless (is_white (out, GST_VIDEO_FORMAT_RGB, ou, ov - 4));
      fail_unless (!is_white (out, GST_VIDEO_FORMAT_RGB, ou, ov + 5));
      fail_unless (!buffers_equal (out, want));
      fail_unless (edge_share (out, 1) > 0.33, "left edge: %.2f",
          edge_share (out, 1));
      fail_unless (edge_share (out, -1) > 0.33, "right edge: %.2f",
          edge_share (out, -1));
    } else {
      fail_unless (edge_share (out, 1) == 0 && edge_share (out, -1) == 0);
      fail_unless (buffers_equal (out, want), "step %u: not the remap", k);
    }
    gst_buffer_unref (out);
  }
  gst_buffer_unref (want);
  gst_harness_teardown (plain);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* With draw=none, a frame with a floor meta and detections is exactly the
 * remap of the frame without them; bad metadata (fields missing, NaN,
 * infinite) draws nothing with draw=boundary+landmarks. */
LANDMARK_TEST ("draw", test_none_and_bad_meta_draw_nothing)
{
  GstStructure *s;
  GstVideoRegionOfInterestMeta *roi;
  GstHarness *plain = draw_harness_new ("none", GST_VIDEO_FORMAT_RGB);
  GstHarness *none = draw_harness_new ("none", GST_VIDEO_FORMAT_RGB);
  GstHarness *bad = draw_harness_new ("boundary+landmarks",
      GST_VIDEO_FORMAT_RGB);
  GstBuffer *want = gst_harness_push_and_pull (plain,
      flat_frame (GST_VIDEO_FORMAT_RGB, 100));
  GstBuffer *in = flat_frame (GST_VIDEO_FORMAT_RGB, 100), *out;
  const gfloat nan_x[2] = { NAN, INFINITY }, row[2] = { 10, 20 };
  const guint8 state[2] = { 2, 2 };
  /* floor arrays: NaN and infinite floor points and ranges */
  const struct
  {
    const gchar *field;
    gconstpointer data;
    gsize n;
  } arrays[] = {
    {"boundary-row", row, sizeof (row)}, {"boundary-state", state, 2},
    {"boundary-x", nan_x, sizeof (nan_x)}, {"boundary-y", row, sizeof (row)},
    {"rop-range", nan_x, sizeof (nan_x)}, {"rop-state", state, 2},
  };
  guint k;
  landmark_check_floor_wall_attach (in, 1.5);
  add_class (in, "orange", 0xff8000);
  landmark_check_ranged_attach (in, "orange", 2.0, 0.5, 0.1, TRUE, "L7");
  out = gst_harness_push_and_pull (none, in);
  fail_unless (buffers_equal (out, want));
  gst_buffer_unref (out);

  /* a floor meta with NaN floor points, an infinite range and no
   * bin-width; detections without a floor position or with a NaN one */
  in = flat_frame (GST_VIDEO_FORMAT_RGB, 100);
  s = landmark_check_meta_add (in, LANDMARK_FLOOR_META);
  gst_structure_set (s, "width", G_TYPE_UINT, 2, "height", G_TYPE_UINT, 480,
      "bearing-bins", G_TYPE_UINT, 2, NULL);
  for (k = 0; k < G_N_ELEMENTS (arrays); k++)
    landmark_check_floor_array (s, arrays[k].field, arrays[k].data,
        arrays[k].n);
  roi = gst_buffer_add_video_region_of_interest_meta (in, "orange", 1, 1, 4,
      4);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "range", G_TYPE_DOUBLE, 1.0,
          NULL));
  roi = gst_buffer_add_video_region_of_interest_meta (in, "orange", 1, 1, 4,
      4);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "ground-x", G_TYPE_DOUBLE, NAN,
          "ground-y", G_TYPE_DOUBLE, 0.0, NULL));
  out = gst_harness_push_and_pull (bad, in);
  fail_unless (buffers_equal (out, want), "bad metadata drew something");
  gst_buffer_unref (out);
  gst_buffer_unref (want);
  gst_harness_teardown (bad);
  gst_harness_teardown (none);
  gst_harness_teardown (plain);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bad_properties)
{
  static const gchar *const bad[] = {
    "side=0",
    "forward=0",
    "tilt=-45",
    "calibration=/nonexistent/camera.yaml",
    NULL
  };
  landmark_check_bad_settings ("birdseye", bad);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (birdseye);
