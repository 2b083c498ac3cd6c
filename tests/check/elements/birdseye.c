/* Unit tests of birdseye: output size and scale, a line on the floor at a
 * known distance (its image row from the pinhole model written out here),
 * strides of odd widths, the frame's metadata kept and image metadata
 * dropped, bad settings (the cost of a remap: tests/bench/element-cost.c). */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

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
