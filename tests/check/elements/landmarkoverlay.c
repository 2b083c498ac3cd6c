/* Unit tests of landmarkoverlay.
 *
 * Expectations are computed here, independently of the element: frames
 * are laid out byte by byte by this file (with GstVideoInfo only for
 * strides and plane offsets), YUV pixels are encoded and decoded with this
 * file's own BT.601 limited-range formulas, ellipse outlines are sampled
 * from the ellipse equation, and the element is judged by which pixels it
 * changes: on the outline of a detection and next to it (its label), never
 * inside the ellipse or far away from it; insets only when their metadata
 * is there; nothing at all when every part is switched off. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <glib/gstdio.h>

#include <math.h>
#include <string.h>

#define LABELS_META "GstLandmarkLabelsMeta"
#define POSE_META "GstLandmarkPoseMeta"
#define FLOOR_META "GstLandmarkFloorMeta"
#define PAD_BYTE 0xA5
#define GREY 128

/* ------------------------------------------------------------------ */
/* Formats, frames, pixels                                            */
/* ------------------------------------------------------------------ */

typedef enum
{
  PACKED, I420, NV12, YUY2
} Kind;

typedef struct
{
  const gchar *name;
  Kind kind;
  gint pstride;
  gint off[4];                  /* bytes of R, G, B and the unused byte */
} Fmt;

static const Fmt formats[] = {
  {"RGB", PACKED, 3, {0, 1, 2, -1}},
  {"BGR", PACKED, 3, {2, 1, 0, -1}},
  {"RGBx", PACKED, 4, {0, 1, 2, 3}},
  {"BGRx", PACKED, 4, {2, 1, 0, 3}},
  {"xRGB", PACKED, 4, {1, 2, 3, 0}},
  {"xBGR", PACKED, 4, {3, 2, 1, 0}},
  {"RGBA", PACKED, 4, {0, 1, 2, 3}},
  {"BGRA", PACKED, 4, {2, 1, 0, 3}},
  {"I420", I420, 1, {0}},
  {"NV12", NV12, 1, {0}},
  {"YUY2", YUY2, 2, {0}},
};

static const Fmt *
fmt_by_name (const gchar * name)
{
  guint i;
  for (i = 0; i < G_N_ELEMENTS (formats); i++)
    if (!strcmp (formats[i].name, name))
      return &formats[i];
  fail ("no format %s", name);
  return NULL;
}

static guint8
clamp8 (gdouble v)
{
  return (guint8) CLAMP (lround (v), 0, 255);
}

/* BT.601, limited range (the caps below say so) */
static void
rgb_to_yuv (const guint8 rgb[3], guint8 yuv[3])
{
  const gdouble r = rgb[0] / 255.0, g = rgb[1] / 255.0, b = rgb[2] / 255.0;
  const gdouble y = 0.299 * r + 0.587 * g + 0.114 * b;
  yuv[0] = clamp8 (16 + 219 * y);
  yuv[1] = clamp8 (128 + 224 * (b - y) / 1.772);
  yuv[2] = clamp8 (128 + 224 * (r - y) / 1.402);
}

static void
yuv_to_rgb (const guint8 yuv[3], guint8 rgb[3])
{
  const gdouble y = (yuv[0] - 16) / 219.0;
  const gdouble cb = (yuv[1] - 128) / 224.0, cr = (yuv[2] - 128) / 224.0;
  const gdouble r = y + 1.402 * cr;
  const gdouble b = y + 1.772 * cb;
  const gdouble g = (y - 0.299 * r - 0.114 * b) / 0.587;
  rgb[0] = clamp8 (255 * r);
  rgb[1] = clamp8 (255 * g);
  rgb[2] = clamp8 (255 * b);
}

typedef struct
{
  const Fmt *fmt;
  GstVideoInfo info;
} Layout;

static void
layout_init (Layout * l, const gchar * format, gint w, gint h)
{
  l->fmt = fmt_by_name (format);
  fail_unless (gst_video_info_set_format (&l->info,
          gst_video_format_from_string (format), w, h));
  if (l->fmt->kind != PACKED)
    fail_unless (gst_video_colorimetry_from_string (&l->info.colorimetry,
            "bt601"));
  l->info.fps_n = 30;
  l->info.fps_d = 1;
}

static GstCaps *
layout_caps (const Layout * l)
{
  return gst_video_info_to_caps (&l->info);
}

/* where the bytes of pixel (x, y) are: luma (or RGB pixel) and chroma */
static guint8 *
pixel_ptr (const Layout * l, guint8 * data, gint x, gint y)
{
  const GstVideoInfo *i = &l->info;
  switch (l->fmt->kind) {
    case PACKED:
      return data + i->offset[0] + (gsize) y * i->stride[0] +
          (gsize) x * l->fmt->pstride;
    case I420:
    case NV12:
      return data + i->offset[0] + (gsize) y * i->stride[0] + x;
    case YUY2:
      return data + i->offset[0] + (gsize) y * i->stride[0] + (x / 2) * 4 +
          (x % 2) * 2;
  }
  return NULL;
}

static void
chroma_ptrs (const Layout * l, guint8 * data, gint x, gint y, guint8 ** u,
    guint8 ** v)
{
  const GstVideoInfo *i = &l->info;
  switch (l->fmt->kind) {
    case I420:
      *u = data + i->offset[1] + (gsize) (y / 2) * i->stride[1] + x / 2;
      *v = data + i->offset[2] + (gsize) (y / 2) * i->stride[2] + x / 2;
      break;
    case NV12:
      *u = data + i->offset[1] + (gsize) (y / 2) * i->stride[1] + (x / 2) * 2;
      *v = *u + 1;
      break;
    case YUY2:
      *u = data + i->offset[0] + (gsize) y * i->stride[0] + (x / 2) * 4 + 1;
      *v = *u + 2;
      break;
    default:
      *u = *v = NULL;
  }
}

static void
put_rgb (const Layout * l, guint8 * data, gint x, gint y, const guint8 c[3])
{
  guint8 *p = pixel_ptr (l, data, x, y);
  if (l->fmt->kind == PACKED) {
    p[l->fmt->off[0]] = c[0];
    p[l->fmt->off[1]] = c[1];
    p[l->fmt->off[2]] = c[2];
  } else {
    guint8 yuv[3], *u, *v;
    rgb_to_yuv (c, yuv);
    *p = yuv[0];
    chroma_ptrs (l, data, x, y, &u, &v);
    *u = yuv[1];
    *v = yuv[2];
  }
}

static void
get_rgb (const Layout * l, const guint8 * data, gint x, gint y, guint8 c[3])
{
  const guint8 *p = pixel_ptr (l, (guint8 *) data, x, y);
  if (l->fmt->kind == PACKED) {
    c[0] = p[l->fmt->off[0]];
    c[1] = p[l->fmt->off[1]];
    c[2] = p[l->fmt->off[2]];
  } else {
    guint8 yuv[3], *u, *v;
    chroma_ptrs (l, (guint8 *) data, x, y, &u, &v);
    yuv[0] = *p;
    yuv[1] = *u;
    yuv[2] = *v;
    yuv_to_rgb (yuv, c);
  }
}

/* A frame of one colour; every byte that is not part of a pixel (row
 * padding, the x/A byte) holds PAD_BYTE. */
static GstBuffer *
frame_new (const Layout * l, guint8 r, guint8 g, guint8 b)
{
  GstBuffer *buf = gst_buffer_new_allocate (NULL, l->info.size, NULL);
  const guint8 c[3] = { r, g, b };
  GstMapInfo map;
  gint x, y;

  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  memset (map.data, PAD_BYTE, map.size);
  for (y = 0; y < GST_VIDEO_INFO_HEIGHT (&l->info); y++)
    for (x = 0; x < GST_VIDEO_INFO_WIDTH (&l->info); x++)
      put_rgb (l, map.data, x, y, c);
  gst_buffer_unmap (buf, &map);
  return buf;
}

/* Is byte i of the frame part of a pixel of the format (as opposed to
 * padding or an unused byte)? */
static gboolean
is_pixel_byte (const Layout * l, gsize i)
{
  const GstVideoInfo *vi = &l->info;
  const gint w = GST_VIDEO_INFO_WIDTH (vi), h = GST_VIDEO_INFO_HEIGHT (vi);
  const gint cw = (w + 1) / 2, ch = (h + 1) / 2;
  guint p, n_planes = GST_VIDEO_INFO_N_PLANES (vi);

  for (p = 0; p < n_planes; p++) {
    const gsize start = vi->offset[p];
    const gint rows = p == 0 ? h : ch;
    gint row_bytes;
    gsize rel, col;

    if (i < start || i >= start + (gsize) rows * vi->stride[p])
      continue;
    rel = i - start;
    col = rel % vi->stride[p];
    switch (l->fmt->kind) {
      case PACKED:
        row_bytes = w * l->fmt->pstride;
        return (gint) col < row_bytes &&
            (gint) (col % l->fmt->pstride) != l->fmt->off[3];
      case I420:
        row_bytes = p == 0 ? w : cw;
        return (gint) col < row_bytes;
      case NV12:
        row_bytes = p == 0 ? w : 2 * cw;
        return (gint) col < row_bytes;
      case YUY2:
        row_bytes = 4 * cw;
        return (gint) col < row_bytes;
    }
  }
  return FALSE;
}

/* Bytes that are not pixels are never written. */
static void
check_non_pixel_bytes (const Layout * l, GstBuffer * out)
{
  GstMapInfo map;
  gsize i;
  gst_buffer_map (out, &map, GST_MAP_READ);
  for (i = 0; i < map.size; i++)
    if (!is_pixel_byte (l, i))
      fail_unless_equals_int (map.data[i], PAD_BYTE);
  gst_buffer_unmap (out, &map);
}

/* Which pixels differ: any of R, G, B in packed formats, the luma in YUV
 * formats. Returns a w*h array (g_free) and the count. */
static guint8 *
changed_mask (const Layout * l, GstBuffer * in, GstBuffer * out, guint * n)
{
  const gint w = GST_VIDEO_INFO_WIDTH (&l->info),
      h = GST_VIDEO_INFO_HEIGHT (&l->info);
  guint8 *mask = g_new0 (guint8, (gsize) w * h);
  GstMapInfo a, b;
  gint x, y;

  *n = 0;
  gst_buffer_map (in, &a, GST_MAP_READ);
  gst_buffer_map (out, &b, GST_MAP_READ);
  fail_unless_equals_int (a.size, b.size);
  for (y = 0; y < h; y++) {
    for (x = 0; x < w; x++) {
      const guint8 *p = pixel_ptr (l, a.data, x, y);
      const guint8 *q = pixel_ptr (l, b.data, x, y);
      gboolean diff;
      if (l->fmt->kind == PACKED)
        diff = p[l->fmt->off[0]] != q[l->fmt->off[0]] ||
            p[l->fmt->off[1]] != q[l->fmt->off[1]] ||
            p[l->fmt->off[2]] != q[l->fmt->off[2]];
      else
        diff = *p != *q;
      mask[(gsize) y * w + x] = diff;
      *n += diff;
    }
  }
  gst_buffer_unmap (in, &a);
  gst_buffer_unmap (out, &b);
  return mask;
}

static gboolean
buffers_equal (GstBuffer * a, GstBuffer * b)
{
  GstMapInfo ma, mb;
  gboolean eq;
  gst_buffer_map (a, &ma, GST_MAP_READ);
  gst_buffer_map (b, &mb, GST_MAP_READ);
  eq = ma.size == mb.size && memcmp (ma.data, mb.data, ma.size) == 0;
  gst_buffer_unmap (a, &ma);
  gst_buffer_unmap (b, &mb);
  return eq;
}

/* Changed pixels inside [x0, x1) x [y0, y1). */
static guint
count_in (const guint8 * mask, gint w, gint x0, gint y0, gint x1, gint y1)
{
  guint n = 0;
  gint x, y;
  for (y = y0; y < y1; y++)
    for (x = x0; x < x1; x++)
      n += mask[(gsize) y * w + x];
  return n;
}

/* Pixels of [x0, x1) x [y0, y1) whose decoded colour is within tol of c
 * in every channel: their number, and their mean x, y when asked. */
static guint
colour_centroid (const Layout * l, GstBuffer * buf, const guint8 c[3],
    gint tol, gint x0, gint y0, gint x1, gint y1, gdouble * mx, gdouble * my)
{
  GstMapInfo map;
  guint n = 0;
  gdouble sx = 0, sy = 0;
  gint x, y;
  gst_buffer_map (buf, &map, GST_MAP_READ);
  for (y = y0; y < y1; y++)
    for (x = x0; x < x1; x++) {
      guint8 p[3];
      get_rgb (l, map.data, x, y, p);
      if (ABS (p[0] - c[0]) <= tol && ABS (p[1] - c[1]) <= tol &&
          ABS (p[2] - c[2]) <= tol) {
        n++;
        sx += x;
        sy += y;
      }
    }
  gst_buffer_unmap (buf, &map);
  if (mx && my) {
    *mx = n ? sx / n : 0;
    *my = n ? sy / n : 0;
  }
  return n;
}

static guint
count_colour (const Layout * l, GstBuffer * buf, const guint8 c[3], gint tol,
    gint x0, gint y0, gint x1, gint y1)
{
  return colour_centroid (l, buf, c, tol, x0, y0, x1, y1, NULL, NULL);
}

/* ------------------------------------------------------------------ */
/* Metadata made by hand                                              */
/* ------------------------------------------------------------------ */

/* An ellipse in the pixels of an analysed frame of fw x fh. */
typedef struct
{
  gdouble x, y, major, minor, angle;
  guint fw, fh;
} Ellipse;

/* The ellipse in the pixels of a w x h frame (pixel centres at integers:
 * u' = (u + 0.5) w / fw - 0.5), as centre and semi-axes along the image
 * axes before rotation (the scale is the same in x and y in these tests). */
static void
ellipse_in_frame (const Ellipse * e, gint w, gint h, gdouble * cx,
    gdouble * cy, gdouble * a, gdouble * b)
{
  const gdouble sx = (gdouble) w / e->fw, sy = (gdouble) h / e->fh;
  fail_unless (fabs (sx - sy) < 1e-9);
  *cx = (e->x + 0.5) * sx - 0.5;
  *cy = (e->y + 0.5) * sy - 0.5;
  *a = e->major / 2 * sx;
  *b = e->minor / 2 * sy;
}

/* Normalised radius of (x, y): 1 on the outline. */
static gdouble
ellipse_rho (const Ellipse * e, gint w, gint h, gdouble x, gdouble y)
{
  gdouble cx, cy, a, b, u, v;
  ellipse_in_frame (e, w, h, &cx, &cy, &a, &b);
  u = (x - cx) * cos (e->angle) + (y - cy) * sin (e->angle);
  v = -(x - cx) * sin (e->angle) + (y - cy) * cos (e->angle);
  return sqrt ((u / a) * (u / a) + (v / b) * (v / b));
}

/* Its bounding box in the w x h frame. */
static void
ellipse_bbox (const Ellipse * e, gint w, gint h, gint bbox[4])
{
  gdouble cx, cy, a, b, hx, hy;
  ellipse_in_frame (e, w, h, &cx, &cy, &a, &b);
  hx = sqrt (pow (a * cos (e->angle), 2) + pow (b * sin (e->angle), 2));
  hy = sqrt (pow (a * sin (e->angle), 2) + pow (b * cos (e->angle), 2));
  bbox[0] = (gint) floor (cx - hx);
  bbox[1] = (gint) floor (cy - hy);
  bbox[2] = (gint) ceil (cx + hx) - bbox[0] + 1;
  bbox[3] = (gint) ceil (cy + hy) - bbox[1] + 1;
}

static GstVideoRegionOfInterestMeta *
add_detection (GstBuffer * buf, const gchar * cls, const Ellipse * e,
    gint w, gint h, gboolean kept)
{
  GstVideoRegionOfInterestMeta *roi;
  gint bb[4];
  GstStructure *s;

  ellipse_bbox (e, w, h, bb);
  roi = gst_buffer_add_video_region_of_interest_meta (buf, cls,
      MAX (bb[0], 0), MAX (bb[1], 0), bb[2], bb[3]);
  fail_unless (roi != NULL);
  s = gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, cls,
      "area", G_TYPE_DOUBLE, G_PI * e->major * e->minor / 4,
      "roundness", G_TYPE_DOUBLE, 0.93,
      "ellipse-x", G_TYPE_DOUBLE, e->x, "ellipse-y", G_TYPE_DOUBLE, e->y,
      "ellipse-major", G_TYPE_DOUBLE, e->major,
      "ellipse-minor", G_TYPE_DOUBLE, e->minor,
      "ellipse-angle", G_TYPE_DOUBLE, e->angle,
      "kept", G_TYPE_BOOLEAN, kept,
      "frame-width", G_TYPE_UINT, e->fw, "frame-height", G_TYPE_UINT, e->fh,
      NULL);
  if (!kept)
    gst_structure_set (s, "reject-reason", G_TYPE_STRING, "not round", NULL);
  gst_video_region_of_interest_meta_add_param (roi, s);
  return roi;
}

static void
add_range (GstVideoRegionOfInterestMeta * roi, gdouble range,
    gdouble bearing, const gchar * landmark)
{
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "range", G_TYPE_DOUBLE, range,
          "bearing", G_TYPE_DOUBLE, bearing, "method", G_TYPE_STRING,
          "ground", NULL));
  if (landmark)
    gst_video_region_of_interest_meta_add_param (roi,
        gst_structure_new ("landmark-match", "matched", G_TYPE_BOOLEAN, TRUE,
            "landmark-id", G_TYPE_STRING, landmark, "residual",
            G_TYPE_DOUBLE, 0.01, NULL));
}

typedef struct
{
  const gchar *name;
  guint rgb;
  guint count;
  gboolean active, marker;
} TestClass;

static void
add_labels (GstBuffer * buf, const TestClass * classes, guint n,
    guint min_class_pixels, guint aw, guint ah)
{
  GstStructure *s = landmark_check_meta_add (buf, LABELS_META);
  const gchar **names = g_new (const gchar *, n);
  guint *rgb = g_new (guint, n), *counts = g_new (guint, n);
  gboolean *active = g_new (gboolean, n), *markers = g_new (gboolean, n);
  guint k;

  for (k = 0; k < n; k++) {
    names[k] = classes[k].name;
    rgb[k] = classes[k].rgb;
    counts[k] = classes[k].count;
    active[k] = classes[k].active;
    markers[k] = classes[k].marker;
  }
  landmark_check_set_array (s, "class-names", G_TYPE_STRING, names, n);
  landmark_check_set_array (s, "class-rgb", G_TYPE_UINT, rgb, n);
  landmark_check_set_array (s, "class-counts", G_TYPE_UINT, counts, n);
  landmark_check_set_array (s, "class-active", G_TYPE_BOOLEAN, active, n);
  landmark_check_set_array (s, "class-markers", G_TYPE_BOOLEAN, markers, n);
  gst_structure_set (s, "min-class-pixels", G_TYPE_UINT, min_class_pixels,
      "analysis-width", G_TYPE_UINT, aw, "analysis-height", G_TYPE_UINT, ah,
      "width", G_TYPE_UINT, aw, "height", G_TYPE_UINT, ah, NULL);
  g_free (names);
  g_free (rgb);
  g_free (counts);
  g_free (active);
  g_free (markers);
}

static void
add_pose (GstBuffer * buf, gdouble x, gdouble y, gdouble heading)
{
  GstCustomMeta *m = gst_buffer_add_custom_meta (buf, POSE_META);
  fail_unless (m != NULL, "pose meta not registered");
  gst_structure_set (gst_custom_meta_get_structure (m), "x", G_TYPE_DOUBLE,
      x, "y", G_TYPE_DOUBLE, y, "heading", G_TYPE_DOUBLE, heading, NULL);
}

static void
set_array (GstStructure * s, const gchar * field, gconstpointer data,
    gsize size)
{
  GstBuffer *b = gst_buffer_new_memdup (data, size);
  gst_structure_set (s, field, GST_TYPE_BUFFER, b, NULL);
  gst_buffer_unref (b);
}

/* A floor meta (docs/floorboundary.md) of a cols x rows label plane, with
 * the boundary per column and the ROP per bin. */
static void
add_floor (GstBuffer * buf, guint cols, guint rows, const gfloat * row,
    const guint8 * col_state, guint bins, const gfloat * range,
    const guint8 * bin_state)
{
  GstCustomMeta *m = gst_buffer_add_custom_meta (buf, FLOOR_META);
  GstStructure *s;
  fail_unless (m != NULL, "floor meta not registered");
  s = gst_custom_meta_get_structure (m);
  gst_structure_set (s, "width", G_TYPE_UINT, cols, "height", G_TYPE_UINT,
      rows, "bearing-bins", G_TYPE_UINT, bins, "bin-width", G_TYPE_DOUBLE,
      2 * G_PI / bins, "max-range", G_TYPE_DOUBLE, 4.0, NULL);
  set_array (s, "boundary-row", row, cols * sizeof (gfloat));
  set_array (s, "boundary-state", col_state, cols);
  set_array (s, "rop-range", range, bins * sizeof (gfloat));
  set_array (s, "rop-state", bin_state, bins);
}

/* ------------------------------------------------------------------ */
/* Files                                                              */
/* ------------------------------------------------------------------ */

static gchar *
write_file (const gchar * name, const gchar * text)
{
  gchar *path = g_build_filename (landmark_check_tmp_dir, name, NULL);
  fail_unless (g_file_set_contents (path, text, -1, NULL));
  return path;
}

/* A 6 m x 6 m field with three landmarks. */
static const gchar *map_json =
    "{\"landmarks\": ["
    "{\"id\": \"L1\", \"class\": \"red\", \"x\": 1.0, \"y\": 1.0, \"z\": 0.0,"
    " \"diameter\": 0.3, \"kind\": \"disc\"},"
    "{\"id\": \"L2\", \"class\": \"green\", \"x\": 5.0, \"y\": 1.0, \"z\": 0.0,"
    " \"diameter\": 0.3, \"kind\": \"disc\"},"
    "{\"id\": \"L3\", \"class\": \"blue\", \"x\": 3.0, \"y\": 5.0, \"z\": 0.1,"
    " \"diameter\": 0.2, \"kind\": \"ball\"}]}";

static const gchar *map2_json =
    "{\"landmarks\": [{\"id\": \"A\", \"class\": \"red\", \"x\": -2, "
    "\"y\": 7}], \"note\": \"other keys are ignored\"}";

/* ------------------------------------------------------------------ */
/* The element                                                        */
/* ------------------------------------------------------------------ */

/* The element with properties given as "name=value ..." set before it
 * starts (the map is read at start), in a harness. */
static GstHarness *
overlay_new (const Layout * l, const gchar * props)
{
  GstElement *e = gst_element_factory_make ("landmarkoverlay", NULL);
  gchar **kv = g_strsplit (props ? props : "", " ", -1);
  GstHarness *h;
  guint i;

  fail_unless (e != NULL);
  for (i = 0; kv[i]; i++) {
    gchar **p;
    if (!*kv[i])
      continue;
    p = g_strsplit (kv[i], "=", 2);
    fail_unless (p[0] && p[1], "bad property %s", kv[i]);
    gst_util_set_object_arg (G_OBJECT (e), p[0], p[1]);
    g_strfreev (p);
  }
  g_strfreev (kv);
  h = gst_harness_new_with_element (e, "sink", "src");
  gst_object_unref (e);
  gst_harness_set_src_caps (h, layout_caps (l));
  return h;
}

/* Pushes a copy of `in` and returns the output (the input stays ours). */
static GstBuffer *
run (GstHarness * h, GstBuffer * in)
{
  GstBuffer *out = gst_harness_push_and_pull (h, gst_buffer_copy (in));
  fail_unless (out != NULL);
  return out;
}

/* The end of a case: its output, its input and the harness freed. */
static void
done (GstHarness * h, GstBuffer * in, GstBuffer * out)
{
  gst_buffer_unref (out);
  gst_buffer_unref (in);
  gst_harness_teardown (h);
}

/* A copy of `in` comes out unchanged (`what`, when given, names the
 * case); then `in` and the harness are freed. */
static void
unchanged_then_done (GstHarness * h, GstBuffer * in, const gchar * what)
{
  GstBuffer *out = run (h, in);
  fail_unless (buffers_equal (in, out), "%s changed", what ? what : "frame");
  done (h, in, out);
}

/* The test ellipse: in a 320x240 frame, centred at (200, 140), 80 x 40,
 * major axis 0.4 rad below +u; given in an analysed frame of the same
 * size, or of half the size (the element must scale it). */
static const Ellipse ellipse_same = { 200.0, 140.0, 80.0, 40.0, 0.4, 320, 240 };
static const Ellipse ellipse_half = { 99.75, 69.75, 40.0, 20.0, 0.4, 160, 120 };

/* The outline of e in a w x h frame: which of n samples changed. */
static guint
outline_changed (const Ellipse * e, gint w, gint h, const guint8 * mask,
    guint n)
{
  gdouble cx, cy, a, b;
  guint i, changed = 0;
  ellipse_in_frame (e, w, h, &cx, &cy, &a, &b);
  for (i = 0; i < n; i++) {
    const gdouble t = 2 * G_PI * i / n;
    const gdouble u = cx + a * cos (t) * cos (e->angle) -
        b * sin (t) * sin (e->angle);
    const gdouble v = cy + a * cos (t) * sin (e->angle) +
        b * sin (t) * cos (e->angle);
    const gint x = (gint) lround (u), y = (gint) lround (v);
    if (x >= 0 && y >= 0 && x < w && y < h)
      changed += mask[(gsize) y * w + x];
  }
  return changed;
}

/* Where the drawing of one detection may change pixels: near the outline,
 * at the centre mark, and above the box (its label). Everywhere else,
 * inside the ellipse and around it, nothing changes. */
static void
check_detection_drawing (const Ellipse * e, gint w, gint h,
    const guint8 * mask, const gchar * what)
{
  gdouble cx, cy, a, b;
  gint bb[4], x, y;
  guint outline, inside = 0, outside = 0, label;

  ellipse_in_frame (e, w, h, &cx, &cy, &a, &b);
  ellipse_bbox (e, w, h, bb);
  outline = outline_changed (e, w, h, mask, 72);
  fail_unless (outline >= 65, "%s: only %u of 72 outline points drawn",
      what, outline);
  for (y = 0; y < h; y++) {
    for (x = 0; x < w; x++) {
      const gdouble rho = ellipse_rho (e, w, h, x, y);
      const gboolean centre = hypot (x - cx, y - cy) <= 8;
      if (!mask[(gsize) y * w + x])
        continue;
      if (rho <= 0.7 && !centre)
        inside++;
      if (rho >= 1.35 && y >= bb[1])
        outside++;
    }
  }
  fail_unless_equals_int (inside, 0);
  fail_unless (outside == 0, "%s: %u pixels changed away from the ellipse",
      what, outside);
  /* a label: text above the box, starting at its left edge */
  label = count_in (mask, w, bb[0], MAX (0, bb[1] - 40), MIN (w, bb[0] + 150),
      bb[1]);
  fail_unless (label >= 50, "%s: no label above the detection (%u)", what,
      label);
  fail_unless_equals_int (count_in (mask, w, 0, 0, bb[0] - 4, bb[1]), 0);
}

/* ------------------------------------------------------------------ */
/* Tests: drawing where the detections are                            */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("detections", test_properties)
{
  GstElement *e = gst_element_factory_make ("landmarkoverlay", NULL);
  const gchar *shows[] = { "show-detections", "show-rejected", "show-pose",
    "show-histogram", "show-indicators", "show-minimap", "show-boundary",
    "show-free-space"
  };
  gchar *map = NULL;
  gdouble scale;
  guint i;

  fail_unless (e != NULL);
  for (i = 0; i < G_N_ELEMENTS (shows); i++) {
    gboolean v = FALSE;
    g_object_get (e, shows[i], &v, NULL);
    fail_unless (v, "%s is not on by default", shows[i]);
    g_object_set (e, shows[i], FALSE, NULL);
    g_object_get (e, shows[i], &v, NULL);
    fail_if (v);
  }
  g_object_get (e, "map", &map, "text-scale", &scale, NULL);
  fail_unless (map == NULL);
  fail_unless_equals_float (scale, 1.0);
  g_object_set (e, "map", "/some/map.json", "text-scale", 2.5, NULL);
  g_object_get (e, "map", &map, "text-scale", &scale, NULL);
  fail_unless_equals_string (map, "/some/map.json");
  fail_unless_equals_float (scale, 2.5);
  g_free (map);
  gst_object_unref (e);
}

GST_END_TEST;

LANDMARK_TEST ("detections", test_ellipse_drawn_where_the_detection_is)
{
  Layout l;
  GstHarness *h;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n;

  layout_init (&l, "BGR", 320, 240);
  h = overlay_new (&l, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  add_detection (in, "red", &ellipse_same, 320, 240, TRUE);
  out = run (h, in);
  mask = changed_mask (&l, in, out, &n);
  check_detection_drawing (&ellipse_same, 320, 240, mask, "BGR");
  /* the bottom of the frame, far below the detection, is untouched */
  fail_unless_equals_int (count_in (mask, 320, 0, 180, 320, 240), 0);
  g_free (mask);
  done (h, in, out);
}

GST_END_TEST;

/* Blob pixel fields refer to the analysed frame: drawn scaled. */
LANDMARK_TEST ("detections", test_ellipse_scaled_from_analysed_frame)
{
  Layout l;
  GstHarness *h;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n;
  /* where the ellipse would be if it were not scaled */
  const Ellipse unscaled = { 99.75, 69.75, 40.0, 20.0, 0.4, 320, 240 };

  layout_init (&l, "RGB", 320, 240);
  h = overlay_new (&l, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  add_detection (in, "red", &ellipse_half, 320, 240, TRUE);
  out = run (h, in);
  mask = changed_mask (&l, in, out, &n);
  check_detection_drawing (&ellipse_half, 320, 240, mask, "scaled");
  fail_unless_equals_int (outline_changed (&unscaled, 320, 240, mask, 72), 0);
  g_free (mask);
  done (h, in, out);
}

GST_END_TEST;

/* Kept blobs: a solid outline in the class colour. Rejected: dashed (part
 * of the outline only) and grey; not drawn with show-rejected=false. */
LANDMARK_TEST ("detections", test_rejected_blob_style)
{
  Layout l;
  GstHarness *h;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n, i, drawn, reddish = 0, greyish = 0;
  const Ellipse *e = &ellipse_same;
  gdouble cx, cy, a, b;
  GstMapInfo map;

  layout_init (&l, "RGB", 320, 240);
  ellipse_in_frame (e, 320, 240, &cx, &cy, &a, &b);
  h = overlay_new (&l, NULL);

  for (i = 0; i < 2; i++) {
    const gboolean kept = i == 0;
    guint k, colour = 0;
    in = frame_new (&l, GREY, GREY, GREY);
    add_detection (in, "red", e, 320, 240, kept);
    out = run (h, in);
    mask = changed_mask (&l, in, out, &n);
    drawn = outline_changed (e, 320, 240, mask, 72);
    gst_buffer_map (out, &map, GST_MAP_READ);
    for (k = 0; k < 72; k++) {
      const gdouble t = 2 * G_PI * k / 72;
      const gint x = (gint) lround (cx + a * cos (t) * cos (e->angle) -
          b * sin (t) * sin (e->angle));
      const gint y = (gint) lround (cy + a * cos (t) * sin (e->angle) +
          b * sin (t) * cos (e->angle));
      guint8 p[3];
      if (!mask[y * 320 + x])
        continue;
      get_rgb (&l, map.data, x, y, p);
      if (kept && p[0] > p[1] + 40)
        colour++;
      if (!kept && MAX (MAX (p[0], p[1]), p[2]) - MIN (MIN (p[0], p[1]),
              p[2]) < 30)
        colour++;
    }
    gst_buffer_unmap (out, &map);
    if (kept) {
      fail_unless (drawn >= 65);
      reddish = colour;
      fail_unless (reddish * 10 >= drawn * 6, "kept: %u of %u red", reddish,
          drawn);
    } else {
      /* dashes: some of the outline, not all of it */
      fail_unless (drawn >= 20 && drawn <= 60, "rejected: %u of 72", drawn);
      greyish = colour;
      fail_unless (greyish * 10 >= drawn * 6, "rejected: %u of %u grey",
          greyish, drawn);
    }
    g_free (mask);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }

  g_object_set (h->element, "show-rejected", FALSE, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  add_detection (in, "red", e, 320, 240, FALSE);
  unchanged_then_done (h, in, NULL);
}

GST_END_TEST;

/* A detection without blob parameters: its bounding box is drawn. */
LANDMARK_TEST ("detections", test_bbox_without_ellipse)
{
  Layout l;
  GstHarness *h;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n;
  const gint bx = 100, by = 120, bw = 60, bh = 40;

  layout_init (&l, "BGRx", 320, 240);
  h = overlay_new (&l, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  fail_unless (gst_buffer_add_video_region_of_interest_meta (in, "blue", bx,
          by, bw, bh) != NULL);
  out = run (h, in);
  mask = changed_mask (&l, in, out, &n);
  /* the four sides */
  fail_unless (count_in (mask, 320, bx + 5, by, bx + bw - 5, by + 1) >= 40);
  fail_unless (count_in (mask, 320, bx + 5, by + bh - 1, bx + bw - 5,
          by + bh) >= 40);
  fail_unless (count_in (mask, 320, bx, by + 5, bx + 1, by + bh - 5) >= 25);
  fail_unless (count_in (mask, 320, bx + bw - 1, by + 5, bx + bw,
          by + bh - 5) >= 25);
  /* inside, away from the sides and the centre mark: untouched */
  fail_unless_equals_int (count_in (mask, 320, bx + 4, by + 4, bx + 20,
          by + 14), 0);
  /* below and beside: untouched */
  fail_unless_equals_int (count_in (mask, 320, 0, by + bh + 4, 320, 240), 0);
  fail_unless_equals_int (count_in (mask, 320, 0, by, bx - 4, by + bh), 0);
  g_free (mask);
  done (h, in, out);
}

GST_END_TEST;

/* The same drawing in every format: the same pixels change (luma in YUV),
 * colour reaches the chroma, nothing but pixels is written. */
LANDMARK_TEST_LOOP ("detections", test_every_format, G_N_ELEMENTS (formats))
{
  const Fmt *f = &formats[__i__];
  /* odd size: padded rows, partial chroma blocks */
  const gint w = 321, h = 241;
  Layout ref, l;
  GstHarness *hr, *hf;
  GstBuffer *rin, *rout, *in, *out;
  guint8 *rmask, *mask;
  guint rn, n, near = 0, far = 0;
  gint x, y;
  const Ellipse e = { 200.0, 140.0, 80.0, 40.0, 0.4, 321, 241 };

  layout_init (&ref, "BGR", w, h);
  hr = overlay_new (&ref, NULL);
  rin = frame_new (&ref, GREY, GREY, GREY);
  add_detection (rin, "red", &e, w, h, TRUE);
  rout = run (hr, rin);
  rmask = changed_mask (&ref, rin, rout, &rn);

  layout_init (&l, f->name, w, h);
  hf = overlay_new (&l, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  add_detection (in, "red", &e, w, h, TRUE);
  out = run (hf, in);
  mask = changed_mask (&l, in, out, &n);
  check_non_pixel_bytes (&l, out);
  check_detection_drawing (&e, w, h, mask, f->name);

  /* every pixel changed here changed in BGR too, or is next to one that
   * did, and the other way round */
  for (y = 0; y < h; y++)
    for (x = 0; x < w; x++) {
      gint dx, dy;
      gboolean found = FALSE;
      if (!mask[y * w + x] && !rmask[y * w + x])
        continue;
      for (dy = -1; dy <= 1 && !found; dy++)
        for (dx = -1; dx <= 1 && !found; dx++) {
          const gint xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h)
            continue;
          found = mask[y * w + x] ? rmask[yy * w + xx] : mask[yy * w + xx];
        }
      if (found)
        near++;
      else
        far++;
    }
  fail_unless (far * 100 <= near, "%s: %u changed pixels differ from BGR "
      "(%u agree)", f->name, far, near);
  fail_unless (n * 10 >= rn * 8 && n * 10 <= rn * 12, "%s: %u changed, "
      "BGR %u", f->name, n, rn);

  /* the colour reaches the chroma planes */
  if (f->kind != PACKED) {
    GstMapInfo a, b;
    guint chroma = 0, k;
    gdouble cx, cy, ea, eb;
    ellipse_in_frame (&e, w, h, &cx, &cy, &ea, &eb);
    gst_buffer_map (in, &a, GST_MAP_READ);
    gst_buffer_map (out, &b, GST_MAP_READ);
    for (k = 0; k < 72; k++) {
      const gdouble t = 2 * G_PI * k / 72;
      guint8 *u0, *v0, *u1, *v1;
      x = (gint) lround (cx + ea * cos (t) * cos (e.angle) -
          eb * sin (t) * sin (e.angle));
      y = (gint) lround (cy + ea * cos (t) * sin (e.angle) +
          eb * sin (t) * cos (e.angle));
      chroma_ptrs (&l, a.data, x, y, &u0, &v0);
      chroma_ptrs (&l, b.data, x, y, &u1, &v1);
      chroma += *u0 != *u1 || *v0 != *v1;
    }
    gst_buffer_unmap (in, &a);
    gst_buffer_unmap (out, &b);
    fail_unless (chroma >= 50, "%s: chroma changed at %u of 72 outline "
        "points", f->name, chroma);
  }

  g_free (mask);
  g_free (rmask);
  gst_buffer_unref (out);
  gst_buffer_unref (in);
  gst_buffer_unref (rout);
  gst_buffer_unref (rin);
  gst_harness_teardown (hf);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Tests: nothing drawn without metadata or with every part off        */
/* ------------------------------------------------------------------ */

static GstBuffer *
frame_with_everything (const Layout * l)
{
  const gint w = GST_VIDEO_INFO_WIDTH (&l->info),
      h = GST_VIDEO_INFO_HEIGHT (&l->info);
  static const TestClass classes[] = {
    {"red", 0xC82828, 5000, TRUE, TRUE},
    {"green", 0x28C83C, 100, FALSE, TRUE},
    {"grey", 0x808080, 50000, TRUE, FALSE},
  };
  const Ellipse e = { w * 0.6, h * 0.6, w * 0.25, h * 0.12, 0.3,
    (guint) w, (guint) h
  };
  const Ellipse far_away = { 1e9, -1e9, 1e12, 1e-12, 1e6, 640, 480 };
  GstBuffer *buf = frame_new (l, 90, 110, 130);
  GstVideoRegionOfInterestMeta *roi;

  add_labels (buf, classes, G_N_ELEMENTS (classes), 500, w, h);
  roi = add_detection (buf, "red", &e, w, h, TRUE);
  add_range (roi, 2.5, 0.3, "L1");
  add_detection (buf, "green", &e, w, h, FALSE);
  /* absurd numbers must not upset the drawing */
  roi = gst_buffer_add_video_region_of_interest_meta (buf, "nosuchclass",
      G_MAXUINT / 2, G_MAXUINT / 2, G_MAXUINT / 2, G_MAXUINT / 2);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "ellipse-x", G_TYPE_DOUBLE,
          far_away.x, "ellipse-y", G_TYPE_DOUBLE, far_away.y,
          "ellipse-major", G_TYPE_DOUBLE, far_away.major,
          "ellipse-minor", G_TYPE_DOUBLE, far_away.minor,
          "ellipse-angle", G_TYPE_DOUBLE, far_away.angle,
          "centroid-x", G_TYPE_DOUBLE, -1e300, "centroid-y", G_TYPE_DOUBLE,
          1e300, "roundness", G_TYPE_DOUBLE, NAN,
          "frame-width", G_TYPE_UINT, far_away.fw,
          "frame-height", G_TYPE_UINT, 0, NULL));
  add_range (roi, 1e9, -7.0, "nosuchlandmark");
  add_pose (buf, 2.0, 3.0, 1.0);
  return buf;
}

LANDMARK_TEST_LOOP ("unchanged", test_no_metadata_unchanged,
    G_N_ELEMENTS (formats))
{
  const Fmt *f = &formats[__i__];
  Layout l;
  GstHarness *h;
  GstBuffer *in;
  gchar *map = write_file ("map.json", map_json);
  gchar *props = g_strdup_printf ("map=%s", map);

  layout_init (&l, f->name, 33, 17);
  h = overlay_new (&l, props);
  in = frame_new (&l, 10, 200, 60);
  unchanged_then_done (h, in, f->name);
  g_free (props);
  g_free (map);
}

GST_END_TEST;

LANDMARK_TEST_LOOP ("unchanged", test_all_parts_off_unchanged,
    G_N_ELEMENTS (formats))
{
  const Fmt *f = &formats[__i__];
  Layout l;
  GstHarness *h;
  GstBuffer *in, *out;
  gchar *map = write_file ("map.json", map_json);
  gchar *props = g_strdup_printf ("map=%s show-detections=false "
      "show-pose=false show-histogram=false show-indicators=false "
      "show-minimap=false", map);

  layout_init (&l, f->name, 321, 241);
  h = overlay_new (&l, props);
  in = frame_with_everything (&l);
  out = run (h, in);
  fail_unless (buffers_equal (in, out), "%s changed with every part off",
      f->name);

  /* and switched on again while playing: drawn */
  g_object_set (h->element, "show-detections", TRUE, NULL);
  gst_buffer_unref (out);
  out = run (h, in);
  fail_if (buffers_equal (in, out));
  done (h, in, out);
  g_free (props);
  g_free (map);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Tests: histogram, indicators                                       */
/* ------------------------------------------------------------------ */

static const guint8 RED[3] = { 200, 40, 40 };
static const guint8 GREEN[3] = { 40, 200, 60 };

/* Colours are right in every format: an active class's bar is a solid
 * area of its colour; an inactive one is not drawn in its pure colour. */
LANDMARK_TEST_LOOP ("insets", test_histogram_colours, G_N_ELEMENTS (formats))
{
  const Fmt *f = &formats[__i__];
  const gint w = 640, h = 480;
  static const TestClass classes[] = {
    {"red", 0xC82828, 50000, TRUE, TRUE},
    {"green", 0x28C83C, 20000, FALSE, TRUE},
    {"floor", 0x808080, 200000, TRUE, FALSE},
  };
  Layout l;
  GstHarness *h_;
  GstBuffer *in, *out;
  guint red_tl, red_rest, green_pure, greenish = 0;
  gint x, y;
  GstMapInfo map;

  layout_init (&l, f->name, w, h);
  h_ = overlay_new (&l, "show-indicators=false");
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, G_N_ELEMENTS (classes), 500, w, h);
  out = run (h_, in);
  check_non_pixel_bytes (&l, out);

  red_tl = count_colour (&l, out, RED, 8, 0, 0, w / 2, h / 2);
  red_rest = count_colour (&l, out, RED, 40, 0, h / 2, w, h) +
      count_colour (&l, out, RED, 40, w / 2, 0, w, h / 2);
  fail_unless (red_tl >= 500, "%s: %u red pixels in the inset", f->name,
      red_tl);
  fail_unless_equals_int (red_rest, 0);

  green_pure = count_colour (&l, out, GREEN, 8, 0, 0, w, h);
  gst_buffer_map (out, &map, GST_MAP_READ);
  for (y = 0; y < h / 2; y++)
    for (x = 0; x < w / 2; x++) {
      guint8 p[3];
      get_rgb (&l, map.data, x, y, p);
      greenish += p[1] > p[0] + 25 && p[1] > p[2] + 25;
    }
  gst_buffer_unmap (out, &map);
  fail_unless (green_pure <= 5, "%s: inactive class drawn opaque (%u)",
      f->name, green_pure);
  fail_unless (greenish >= 200, "%s: inactive class not drawn (%u)",
      f->name, greenish);

  gst_buffer_unref (out);
  gst_buffer_unref (in);
  gst_harness_teardown (h_);
}

GST_END_TEST;

LANDMARK_TEST ("insets", test_histogram_only_with_labels)
{
  const gint w = 320, h = 240;
  static const TestClass classes[] = {
    {"red", 0xC82828, 5000, TRUE, TRUE},
    {"blue", 0x2840C8, 300, FALSE, TRUE},
  };
  Layout l;
  GstHarness *h_;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n;

  layout_init (&l, "BGR", w, h);
  h_ = overlay_new (&l, NULL);

  /* a pose meta but no labels: no inset at the top left */
  in = frame_new (&l, GREY, GREY, GREY);
  add_pose (in, 1, 1, 0);
  out = run (h_, in);
  mask = changed_mask (&l, in, out, &n);
  fail_unless (n > 0);          /* the pose line */
  fail_unless_equals_int (count_in (mask, w, 0, 0, w / 2, h / 2), 0);
  g_free (mask);
  gst_buffer_unref (out);
  gst_buffer_unref (in);

  /* with labels: the inset, and nothing in the lower half */
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, 2, 500, w, h);
  out = run (h_, in);
  mask = changed_mask (&l, in, out, &n);
  fail_unless (count_in (mask, w, 0, 0, w / 2, h / 2) >= 1000);
  fail_unless_equals_int (count_in (mask, w, 0, h / 2, w, h), 0);
  fail_unless_equals_int (count_in (mask, w, w / 2, 0, w, h), 0);
  g_free (mask);
  gst_buffer_unref (out);

  /* histogram and indicators off: nothing */
  g_object_set (h_->element, "show-histogram", FALSE, "show-indicators",
      FALSE, NULL);
  unchanged_then_done (h_, in, NULL);
}

GST_END_TEST;

/* A larger count gives a taller bar; the threshold line moves up with the
 * threshold. */
LANDMARK_TEST ("insets", test_histogram_scale_and_threshold)
{
  const gint w = 640, h = 480;
  TestClass classes[] = {
    {"red", 0xC82828, 1000, TRUE, TRUE},
    {"blue", 0x2840C8, 3000, TRUE, TRUE},
  };
  Layout l;
  GstHarness *h_;
  guint reds[2], t;
  gint rows[2];

  layout_init (&l, "RGB", w, h);
  h_ = overlay_new (&l, "show-indicators=false");
  for (t = 0; t < 2; t++) {
    GstBuffer *in = frame_new (&l, GREY, GREY, GREY), *out;
    classes[0].count = t == 0 ? 1000 : 100000;
    add_labels (in, classes, 2, 500, w, h);
    out = run (h_, in);
    reds[t] = count_colour (&l, out, RED, 8, 0, 0, w / 2, h / 2);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }
  fail_unless (reds[1] > reds[0] * 1.3, "bar heights %u, %u", reds[0],
      reds[1]);

  /* the row with the most white pixels is the dashed threshold line */
  for (t = 0; t < 2; t++) {
    GstBuffer *in = frame_new (&l, GREY, GREY, GREY), *out;
    const guint8 white[3] = { 255, 255, 255 };
    guint best = 0;
    gint y;
    add_labels (in, classes, 2, t == 0 ? 50 : 50000, w, h);
    out = run (h_, in);
    rows[t] = -1;
    for (y = 0; y < h / 2; y++) {
      const guint c = count_colour (&l, out, white, 30, 0, y, w / 2, y + 1);
      if (c > best) {
        best = c;
        rows[t] = y;
      }
    }
    fail_unless (best >= 50, "no threshold line (%u)", best);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }
  fail_unless (rows[1] < rows[0] - 10, "threshold rows %d, %d", rows[0],
      rows[1]);
  gst_harness_teardown (h_);
}

GST_END_TEST;

/* One indicator per marker class, lit in its colour when active. */
LANDMARK_TEST ("insets", test_indicators)
{
  const gint w = 640, h = 480;
  TestClass classes[] = {
    {"red", 0xC82828, 5000, TRUE, TRUE},
    {"green", 0x28C83C, 5000, TRUE, TRUE},
    {"white", 0xF0F0F0, 5000, TRUE, FALSE},
  };
  Layout l;
  GstHarness *h_;
  guint red[2], t;

  layout_init (&l, "I420", w, h);
  h_ = overlay_new (&l, "show-histogram=false");
  for (t = 0; t < 2; t++) {
    GstBuffer *in = frame_new (&l, GREY, GREY, GREY), *out;
    guint8 *mask;
    guint n;
    classes[0].active = t == 0;
    add_labels (in, classes, 3, 500, w, h);
    out = run (h_, in);
    red[t] = count_colour (&l, out, RED, 10, 0, 0, w / 2, h / 2);
    mask = changed_mask (&l, in, out, &n);
    fail_unless (n > 0);
    fail_unless_equals_int (count_in (mask, w, 0, h / 4, w, h), 0);
    g_free (mask);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }
  fail_unless (red[0] >= 30, "lit indicator: %u red pixels", red[0]);
  fail_unless (red[1] * 3 < red[0], "unlit indicator: %u red pixels (lit "
      "%u)", red[1], red[0]);
  gst_harness_teardown (h_);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Tests: pose line, mini-map                                         */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("insets", test_pose_line)
{
  const gint w = 320, h = 240;
  Layout l;
  GstHarness *h_;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n;

  GstBuffer *same, *other, *out_same, *out_other;

  layout_init (&l, "NV12", w, h);
  h_ = overlay_new (&l, NULL);
  in = frame_new (&l, GREY, GREY, GREY);
  add_pose (in, 1.25, -3.5, 2.0);
  out = run (h_, in);
  mask = changed_mask (&l, in, out, &n);
  fail_unless (n >= 200);
  fail_unless_equals_int (n, count_in (mask, w, 0, h * 3 / 4, w, h));
  g_free (mask);

  /* the line is the pose's (its text: tests/core/test_overlaytext.cpp):
   * the same pose draws the same pixels, one a centimetre away others */
  same = frame_new (&l, GREY, GREY, GREY);
  add_pose (same, 1.25, -3.5, 2.0);
  other = frame_new (&l, GREY, GREY, GREY);
  add_pose (other, 1.26, -3.5, 2.0);
  out_same = run (h_, same);
  out_other = run (h_, other);
  fail_unless (buffers_equal (out, out_same));
  fail_if (buffers_equal (out, out_other), "a different pose drew the "
      "same line");
  gst_buffer_unref (out);
  gst_buffer_unref (out_same);
  gst_buffer_unref (out_other);
  gst_buffer_unref (same);
  gst_buffer_unref (other);

  g_object_set (h_->element, "show-pose", FALSE, NULL);
  unchanged_then_done (h_, in, NULL);
}

GST_END_TEST;

/* The mini-map needs both a pose and a map; it shows the landmarks in
 * their class colours, the robot where it is, and range circles. */
LANDMARK_TEST ("insets", test_minimap_needs_pose_and_map)
{
  const gint w = 320, h = 240;
  static const TestClass classes[] = {
    {"red", 0xFF0000, 5000, TRUE, TRUE},
    {"green", 0x00FF00, 5000, TRUE, TRUE},
    {"blue", 0x0000FF, 5000, TRUE, TRUE},
  };
  const guint8 pure_red[3] = { 255, 0, 0 }, pure_green[3] = { 0, 255, 0 };
  gchar *map = write_file ("map.json", map_json);
  Layout l;
  GstHarness *h_;
  GstBuffer *in, *out, *out2;
  guint8 *mask;
  guint n, plain, with_range;

  layout_init (&l, "BGR", w, h);
  h_ = overlay_new (&l, "show-histogram=false show-indicators=false "
      "show-pose=false");

  /* a pose, no map: nothing */
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, 3, 500, w, h);
  add_pose (in, 3, 3, 0);
  out = run (h_, in);
  fail_unless (buffers_equal (in, out));
  gst_buffer_unref (out);

  /* a pose and a map: the inset at the top right, in the class colours */
  g_object_set (h_->element, "map", map, NULL);
  out = run (h_, in);
  mask = changed_mask (&l, in, out, &n);
  plain = count_in (mask, w, w / 2, 0, w, h / 2);
  fail_unless (plain >= 1000);
  fail_unless_equals_int (n, plain);
  fail_unless (count_colour (&l, out, pure_red, 10, w / 2, 0, w, h / 2) >= 3);
  fail_unless (count_colour (&l, out, pure_green, 10, w / 2, 0, w,
          h / 2) >= 3);
  g_free (mask);

  /* the robot elsewhere: a different picture */
  gst_buffer_unref (in);
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, 3, 500, w, h);
  add_pose (in, 1, 4, 2.0);
  out2 = run (h_, in);
  fail_if (buffers_equal (out, out2));
  gst_buffer_unref (out2);
  gst_buffer_unref (out);

  /* a ranged, matched detection adds its circle and ray */
  gst_buffer_unref (in);
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, 3, 500, w, h);
  add_pose (in, 3, 3, 0);
  add_range (gst_buffer_add_video_region_of_interest_meta (in, "red", 0, 0,
          1, 1), 2.83, -2.36, "L1");
  g_object_set (h_->element, "show-detections", FALSE, NULL);
  out = run (h_, in);
  {
    /* the same frame without the detection */
    GstBuffer *in2 = frame_new (&l, GREY, GREY, GREY);
    add_labels (in2, classes, 3, 500, w, h);
    add_pose (in2, 3, 3, 0);
    out2 = run (h_, in2);
    gst_buffer_unref (in2);
  }
  mask = changed_mask (&l, out2, out, &n);
  with_range = count_in (mask, w, w / 2, 0, w, h / 2);
  fail_unless (with_range >= 40, "range circle: %u pixels", with_range);
  fail_unless_equals_int (n, with_range);
  (void) plain;
  g_free (mask);
  gst_buffer_unref (out2);
  gst_buffer_unref (out);

  /* a map but no pose: nothing */
  gst_buffer_unref (in);
  in = frame_new (&l, GREY, GREY, GREY);
  add_labels (in, classes, 3, 500, w, h);
  out = run (h_, in);
  fail_unless (buffers_equal (in, out));
  gst_buffer_unref (out);

  /* switched off */
  gst_buffer_unref (in);
  in = frame_new (&l, GREY, GREY, GREY);
  add_pose (in, 3, 3, 0);
  g_object_set (h_->element, "show-minimap", FALSE, NULL);
  unchanged_then_done (h_, in, NULL);
  g_free (map);
}

GST_END_TEST;

/* The floor boundary: for a label plane of half the frame's size, the
 * boundary row r of column c is drawn at frame pixel
 * ((c + 0.5) 2 - 0.5, (r + 0.5) 2 - 0.5): red on obstacle columns, cyan on
 * free ones, nothing on not-seen ones, and nothing else changes. */
LANDMARK_TEST ("insets", test_floor_boundary)
{
  const gint w = 320, h = 240, cols = 160, rows = 120;
  const guint8 red[3] = { 255, 40, 40 }, cyan[3] = { 0, 220, 255 };
  gfloat row[160], range[8] = { 0 };
  guint8 state[160], bin_state[8] = { 0 };
  Layout l;
  GstHarness *h_;
  GstBuffer *in, *out;
  guint8 *mask;
  guint n, x;
  gint c;

  for (c = 0; c < cols; c++) {
    /* obstacle at row edge 59.5 (frame y 119.5) on the left, free at row
     * edge 30.5 (frame y 61.5) in the middle, not seen on the right */
    row[c] = c < 70 ? 59.5f : c < 130 ? 30.5f : -1.0f;
    state[c] = c < 70 ? 2 : c < 130 ? 1 : 0;
  }
  layout_init (&l, "BGR", w, h);
  h_ = overlay_new (&l, "show-minimap=false");
  in = frame_new (&l, GREY, GREY, GREY);
  add_floor (in, cols, rows, row, state, 8, range, bin_state);
  out = run (h_, in);
  mask = changed_mask (&l, in, out, &n);
  /* every column of each run has its colour on the line, none off it */
  for (x = 3; x < 134; x++)
    fail_unless (count_colour (&l, out, red, 12, x, 118, x + 1, 122) >= 1,
        "no red at column %u", x);
  for (x = 146; x < 256; x++)
    fail_unless (count_colour (&l, out, cyan, 12, x, 60, x + 1, 64) >= 1,
        "no cyan at column %u", x);
  fail_unless_equals_int (count_colour (&l, out, red, 60, 0, 0, w, 114), 0);
  fail_unless_equals_int (count_colour (&l, out, red, 60, 0, 126, w, h), 0);
  fail_unless_equals_int (count_colour (&l, out, cyan, 60, 0, 0, w, 56), 0);
  fail_unless_equals_int (count_colour (&l, out, cyan, 60, 0, 68, w, h), 0);
  /* the halo and line stay near the two rows; the not-seen third is bare */
  fail_unless_equals_int (n, count_in (mask, w, 0, 56, 264, 68) +
      count_in (mask, w, 0, 113, 264, 127));
  fail_unless_equals_int (count_in (mask, w, 264, 0, w, h), 0);
  g_free (mask);
  gst_buffer_unref (out);

  g_object_set (h_->element, "show-boundary", FALSE, NULL);
  unchanged_then_done (h_, in, NULL);
}

GST_END_TEST;

/* The free space: a wedge of +-30 degrees around straight ahead, an
 * obstacle 1 m away. Its green fill (translucent over grey) and its red
 * far edge lie in the mini-map, the red beyond the green in the robot's
 * forward direction: up without a pose, along the heading with one
 * (right for heading 0, up for 90 degrees, left for 180). */
LANDMARK_TEST ("insets", test_floor_free_space)
{
  const gint w = 320, h = 240, bins = 360;
  const guint8 red[3] = { 255, 40, 40 };
  /* 110/255 of (40, 230, 40) over the inset's background: 150/255 of
   * black over grey 128 */
  const guint8 green[3] = { 47, 129, 47 };
  gchar *map = write_file ("map.json", map_json);
  gfloat row[4] = { -1, -1, -1, -1 }, range[360];
  guint8 state[4] = { 0 }, bin_state[360];
  const gdouble headings[] = { -1, 0, G_PI / 2, G_PI };
  Layout l;
  GstHarness *h_;
  guint i;
  gint b;

  for (b = 0; b < bins; b++) {
    const gboolean seen = b <= 30 || b >= bins - 30;
    range[b] = seen ? 1.0f : 0.0f;
    bin_state[b] = seen ? 2 : 0;
  }
  layout_init (&l, "RGB", w, h);
  h_ = overlay_new (&l, "show-histogram=false show-indicators=false "
      "show-pose=false show-boundary=false");
  g_object_set (h_->element, "map", map, NULL);
  for (i = 0; i < G_N_ELEMENTS (headings); i++) {
    GstBuffer *in = frame_new (&l, GREY, GREY, GREY), *out;
    gdouble gx, gy, rx, ry, dx, dy;
    guint8 *mask;
    guint n, ng, nr;
    add_floor (in, 4, 4, row, state, bins, range, bin_state);
    if (headings[i] >= 0)
      add_pose (in, 3, 3, headings[i]);
    out = run (h_, in);
    mask = changed_mask (&l, in, out, &n);
    /* only the inset, top right */
    fail_unless_equals_int (n, count_in (mask, w, w / 2, 0, w, h / 2));
    ng = colour_centroid (&l, out, green, 10, w / 2, 0, w, h / 2, &gx, &gy);
    nr = colour_centroid (&l, out, red, 12, w / 2, 0, w, h / 2, &rx, &ry);
    fail_unless (ng >= 40, "heading %g: %u green pixels", headings[i], ng);
    fail_unless (nr >= 5, "heading %g: %u red pixels", headings[i], nr);
    dx = rx - gx;
    dy = ry - gy;
    if (headings[i] < 0 || headings[i] == G_PI / 2)
      fail_unless (dy < -2 && fabs (dx) < 1.5, "heading %g: red at %g, %g "
          "from green", headings[i], dx, dy);
    else if (headings[i] == 0)
      fail_unless (dx > 2 && fabs (dy) < 1.5, "heading 0: %g, %g", dx, dy);
    else
      fail_unless (dx < -2 && fabs (dy) < 1.5, "heading pi: %g, %g", dx, dy);
    g_free (mask);
    gst_buffer_unref (out);

    /* switched off: without a pose nothing is left to draw */
    g_object_set (h_->element, "show-free-space", FALSE, NULL);
    out = run (h_, in);
    if (headings[i] < 0)
      fail_unless (buffers_equal (in, out));
    else
      fail_unless_equals_int (count_colour (&l, out, green, 10, w / 2, 0, w,
              h / 2), 0);
    gst_buffer_unref (out);
    g_object_set (h_->element, "show-free-space", TRUE, NULL);
    gst_buffer_unref (in);
  }
  gst_harness_teardown (h_);
  g_free (map);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Tests: map files                                                   */
/* ------------------------------------------------------------------ */

typedef struct
{
  const gchar *json;            /* NULL: the file does not exist */
  const gchar *expect;          /* in the error's debug text */
} BadMap;

static const BadMap bad_maps[] = {
  {NULL, "cannot read"},
  {"{\"landmarks\": [", "not valid JSON"},
  {"[]", "top level"},
  {"{\"marks\": []}", "\"landmarks\" must be an array"},
  {"{\"landmarks\": []}", "empty"},
  {"{\"landmarks\": [{\"id\": \"L1\", \"class\": \"red\", \"x\": 1, "
        "\"y\": 2}, {\"id\": \"L2\", \"class\": \"red\", \"y\": 1}]}",
      "landmarks[1] (\"L2\"): \"x\""},
  {"{\"landmarks\": [{\"id\": \"L1\", \"class\": \"red\", \"x\": \"1\", "
        "\"y\": 2}]}", "landmarks[0] (\"L1\"): \"x\""},
  {"{\"landmarks\": [{\"class\": \"red\", \"x\": 1, \"y\": 2}]}",
      "landmarks[0]: \"id\""},
  {"{\"landmarks\": [{\"id\": \"L1\", \"x\": 1, \"y\": 2}]}",
      "landmarks[0] (\"L1\"): \"class\""},
  {"{\"landmarks\": [{\"id\": \"A\", \"class\": \"red\", \"x\": 1, "
        "\"y\": 2}, {\"id\": \"A\", \"class\": \"red\", \"x\": 3, "
        "\"y\": 2}]}", "landmarks[1] (\"A\"): duplicate id"},
  {"{\"landmarks\": [{\"id\": \"A\", \"class\": \"red\", \"x\": 1, "
        "\"y\": 2, \"kind\": \"cube\"}]}", "\"kind\""},
  {"{\"landmarks\": [{\"id\": \"A\", \"class\": \"red\", \"x\": 1, "
        "\"y\": 2, \"diameter\": -0.2}]}", "\"diameter\""},
  {"{\"landmarks\": [7]}", "landmarks[0]: must be an object"},
};

static void
check_map_error (GstBus * bus, const gchar * path, const gchar * expect,
    GstMessageType type)
{
  GstMessage *msg = gst_bus_pop_filtered (bus, type);
  GError *err = NULL;
  gchar *dbg = NULL;

  fail_unless (msg != NULL, "no %s message", gst_message_type_get_name (type));
  if (type == GST_MESSAGE_ERROR)
    gst_message_parse_error (msg, &err, &dbg);
  else
    gst_message_parse_warning (msg, &err, &dbg);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS), "%s", err->message);
  fail_unless (strstr (err->message, path) != NULL, "%s", err->message);
  fail_unless (dbg && strstr (dbg, path) != NULL, "%s", dbg);
  fail_unless (strstr (dbg, expect) != NULL, "'%s' not in '%s'", expect,
      dbg);
  g_error_free (err);
  g_free (dbg);
  gst_message_unref (msg);
}

LANDMARK_TEST_LOOP ("configuration", test_bad_map_fails_start,
    G_N_ELEMENTS (bad_maps))
{
  const BadMap *b = &bad_maps[__i__];
  gchar *path = b->json ? write_file ("bad.json", b->json) :
      g_build_filename (landmark_check_tmp_dir, "missing.json", NULL);
  gchar *good = write_file ("good.json", map2_json);
  GstElement *e = gst_element_factory_make ("landmarkoverlay", NULL);
  GstBus *bus = gst_bus_new ();

  g_object_set (e, "map", path, NULL);
  landmark_check_refuses_ready (e, bus);
  check_map_error (bus, path, b->expect, GST_MESSAGE_ERROR);

  /* a good map is enough to start */
  landmark_check_fixed_setting_starts (e, bus, "map", good);
  g_remove (path);
  g_free (path);
  g_free (good);
}

GST_END_TEST;

LANDMARK_TEST ("configuration", test_bad_map_while_playing)
{
  gchar *good = write_file ("good.json", map_json);
  gchar *bad = write_file ("bad.json", bad_maps[5].json);
  Layout l;
  GstHarness *h;
  GstBus *bus = gst_bus_new ();
  GstBuffer *in, *out;

  layout_init (&l, "BGR", 320, 240);
  h = overlay_new (&l, NULL);
  gst_element_set_bus (h->element, bus);
  in = frame_new (&l, GREY, GREY, GREY);
  add_pose (in, 3, 3, 0);
  g_object_set (h->element, "map", good, NULL);
  gst_buffer_unref (run (h, in));

  /* a bad map while playing: a warning, and the previous map draws on */
  g_object_set (h->element, "map", bad, NULL);
  fail_unless_equals_int (gst_harness_push (h, gst_buffer_copy (in)),
      GST_FLOW_OK);
  check_map_error (bus, bad, bad_maps[5].expect, GST_MESSAGE_WARNING);
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR) == NULL);
  out = gst_harness_pull (h);
  fail_if (buffers_equal (in, out));
  gst_buffer_unref (out);

  /* fixed: streaming resumes */
  g_object_set (h->element, "map", good, NULL);
  out = run (h, in);
  fail_if (buffers_equal (in, out));
  gst_buffer_unref (out);
  gst_buffer_unref (in);
  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
  g_free (bad);
  g_free (good);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Tests: sizes, streaming                                            */
/* ------------------------------------------------------------------ */

LANDMARK_TEST_LOOP ("streaming", test_odd_sizes, G_N_ELEMENTS (formats))
{
  const Fmt *f = &formats[__i__];
  static const gint sizes[][2] = { {1, 1}, {2, 2}, {3, 5}, {5, 3}, {17, 13},
  {64, 9}, {9, 64}
  };
  gchar *map = write_file ("map.json", map_json);
  gchar *props = g_strdup_printf ("map=%s", map);
  guint s;

  for (s = 0; s < G_N_ELEMENTS (sizes); s++) {
    Layout l;
    GstHarness *h;
    GstBuffer *in, *out;
    layout_init (&l, f->name, sizes[s][0], sizes[s][1]);
    h = overlay_new (&l, props);
    in = frame_with_everything (&l);
    out = run (h, in);
    fail_unless_equals_int (gst_buffer_get_size (out),
        gst_buffer_get_size (in));
    check_non_pixel_bytes (&l, out);
    gst_buffer_unref (out);
    /* and tiny text */
    g_object_set (h->element, "text-scale", 0.25, NULL);
    out = run (h, in);
    check_non_pixel_bytes (&l, out);
    done (h, in, out);
  }
  g_free (props);
  g_free (map);
}

GST_END_TEST;

/* Properties changed from other threads while buffers flow: every buffer
 * comes out, in order, drawn or not, never with an error. */
LANDMARK_TEST ("streaming", test_properties_while_streaming)
{
  gchar *map = write_file ("map.json", map_json);
  gchar *map2 = write_file ("map2.json", map2_json);
  const gchar *shows[] = { "show-detections", "show-rejected", "show-pose",
    "show-histogram", "show-indicators", "show-minimap", "show-boundary",
    "show-free-space"
  };
  GstHarnessThread *threads[32];
  guint n_threads = 0, i, t;
  Layout l;
  GstHarness *h;
  GstBuffer *templ;
  GValue v = G_VALUE_INIT;
  const guint n_buffers = 80;

  layout_init (&l, "I420", 320, 240);
  h = overlay_new (&l, NULL);
  templ = frame_with_everything (&l);

  for (i = 0; i < G_N_ELEMENTS (shows); i++) {
    for (t = 0; t < 2; t++) {
      g_value_init (&v, G_TYPE_BOOLEAN);
      g_value_set_boolean (&v, t);
      threads[n_threads++] = gst_harness_stress_property_start_full (h,
          shows[i], &v, 300);
      g_value_unset (&v);
    }
  }
  g_value_init (&v, G_TYPE_STRING);
  g_value_set_string (&v, map);
  threads[n_threads++] = gst_harness_stress_property_start_full (h, "map",
      &v, 700);
  g_value_set_string (&v, map2);
  threads[n_threads++] = gst_harness_stress_property_start_full (h, "map",
      &v, 700);
  g_value_unset (&v);
  g_value_init (&v, G_TYPE_DOUBLE);
  g_value_set_double (&v, 0.5);
  threads[n_threads++] = gst_harness_stress_property_start_full (h,
      "text-scale", &v, 300);
  g_value_set_double (&v, 3.0);
  threads[n_threads++] = gst_harness_stress_property_start_full (h,
      "text-scale", &v, 300);
  g_value_unset (&v);

  for (i = 0; i < n_buffers; i++) {
    GstBuffer *in = gst_buffer_copy (templ), *out;
    GST_BUFFER_PTS (in) = i * 40 * GST_MSECOND;
    fail_unless_equals_int (gst_harness_push (h, in), GST_FLOW_OK);
    out = gst_harness_try_pull (h);
    fail_unless (out != NULL, "buffer %u did not come out", i);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * 40 * GST_MSECOND);
    gst_buffer_unref (out);
  }
  for (t = 0; t < n_threads; t++)
    fail_unless (gst_harness_stress_thread_stop (threads[t]) > 0);
  fail_unless_equals_int (gst_harness_buffers_received (h), n_buffers);
  gst_buffer_unref (templ);
  gst_harness_teardown (h);
  g_free (map2);
  g_free (map);
}

GST_END_TEST;

/* Never drops a frame, not even when downstream says it is far behind. */
LANDMARK_TEST ("streaming", test_no_buffer_dropped)
{
  Layout l;
  GstHarness *h;
  GstBuffer *templ;

  layout_init (&l, "BGRx", 160, 120);
  h = overlay_new (&l, NULL);
  templ = frame_with_everything (&l);
  landmark_check_no_frame_dropped (h, templ, 40, NULL);
  gst_buffer_unref (templ);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* a temporary folder for map and palette files */
LANDMARK_CHECK_MAIN (landmarkoverlay,
    .setup = landmark_check_tmp_dir_setup,
    .teardown = landmark_check_tmp_dir_teardown);
