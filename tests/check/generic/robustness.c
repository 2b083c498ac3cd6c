/* Robustness of every element of the gst-landmark plugin, and of the whole
 * chain, against what real streams do:
 *
 *  - every format of the sink template at 1x1, 2x2, 3x5, 17x9 and 641x479,
 *    each also with padded strides and offsets (GstVideoMeta in a buffer
 *    larger than needed), and 3840x2160 once per format through the chain;
 *  - caps changes mid-stream (size and format) through the chain, with a
 *    disc drawn at a known place: labels, detection, range and overlay
 *    follow the new geometry;
 *  - buffers without the metadata an element wants, and with metadata that
 *    does not fit the frame;
 *  - every writable property set from another thread while frames flow;
 *  - 1,000 NULL -> PLAYING -> NULL cycles per element and for the chain.
 *
 * In every case each frame pushed comes out, once, in order, and elements
 * that only analyse leave the bytes of the buffer (padding included)
 * untouched. Element lists and formats come from the registry and the pad
 * templates, so a new element of the plugin is covered without editing this
 * file. Flushing seeks on a file pipeline are in tests/python/test_seek.py. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <glib/gstdio.h>
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>
#include <unistd.h>

#define PLUGIN_NAME "landmark"
#define CLIP_DIR GST_TEST_FILES_PATH "/clips/path-small"
#define MAP_FILE CLIP_DIR "/map.json"
#define LABELS_META "GstLandmarkLabelsMeta"
#define POSE_META "GstLandmarkPoseMeta"
#define FPS 30
#define FRAME_NS (GST_SECOND / FPS)

/* Formats tried on a sink pad that takes any video/x-raw: the formats our
 * pixel elements handle, plus GRAY8 (an analyser must not care). */
static const gchar *any_formats[] = {
  "RGB", "BGR", "RGBx", "BGRx", "xRGB", "xBGR", "RGBA", "BGRA", "I420",
  "NV12", "YUY2", "GRAY8",
};

typedef struct
{
  guint w, h;
} Size;

static const Size sizes[] = {
  {1, 1}, {2, 2}, {3, 5}, {17, 9}, {641, 479},
};

/* the elements of the plugin, sorted; filled when the suite is built */
static GList *element_names;
/* ------------------------------------------------------------------ */
/* The plugin's elements and how to configure them                     */
/* ------------------------------------------------------------------ */

static GList *
plugin_element_names (void)
{
  GstRegistry *registry = gst_registry_get ();
  GstPlugin *plugin = gst_registry_find_plugin (registry, PLUGIN_NAME);
  GList *features, *l, *names = NULL;

  g_assert (plugin != NULL);
  gst_object_unref (plugin);
  features = gst_registry_get_feature_list_by_plugin (registry, PLUGIN_NAME);
  for (l = features; l; l = l->next)
    /* converters (birdseye) make another picture of another size: their
     * own tests check it */
    if (GST_IS_ELEMENT_FACTORY (l->data) &&
        !strstr (gst_element_factory_get_metadata (l->data,
                GST_ELEMENT_METADATA_KLASS), "Converter"))
      names = g_list_insert_sorted (names,
          g_strdup (gst_plugin_feature_get_name (l->data)),
          (GCompareFunc) g_strcmp0);
  gst_plugin_feature_list_free (features);
  return names;
}

static const gchar *
element_name (guint i)
{
  const gchar *name = g_list_nth_data (element_names, i);
  fail_unless (name != NULL);
  return name;
}

static const gchar *
factory_name (GstElement * e)
{
  return GST_OBJECT_NAME (gst_element_get_factory (e));
}

/* Elements whose klass says they change pixels (landmarkoverlay); all
 * others analyse and must leave the video alone. */
static gboolean
draws (const gchar * name)
{
  GstElementFactory *f = gst_element_factory_find (name);
  const gchar *klass =
      gst_element_factory_get_metadata (f, GST_ELEMENT_METADATA_KLASS);
  gboolean r = klass && strstr (klass, "Effect") != NULL;
  gst_object_unref (f);
  return r;
}

static gchar *
tmp_file (const gchar * stem)
{
  static gint counter = 0;
  gchar *name = g_strdup_printf ("%s-%d-%d.jsonl", stem, (gint) getpid (),
      g_atomic_int_add (&counter, 1));
  gchar *path = g_build_filename (landmark_check_tmp_dir, name, NULL);
  g_free (name);
  return path;
}

static GstElement *
make_element (const gchar * name)
{
  GstElement *e = gst_element_factory_make (name, NULL);
  fail_unless (e != NULL, "cannot create %s", name);
  landmark_check_configure_element (e);
  return e;
}

static GstHarness *
harness_for (const gchar * name)
{
  GstElement *e = make_element (name);
  GstHarness *h = gst_harness_new_with_element (e, "sink", "src");
  gst_object_unref (e);
  return h;
}

/* The whole chain in one harness; overlay_props switch its parts. */
static GstHarness *
chain_harness (const gchar * overlay_props, gchar ** log_path)
{
  gchar *log = tmp_file ("chain");
  gchar *desc = g_strdup_printf ("labsegment min-class-pixels=50 ! "
      "blobroundness ! ipmrange ! trilaterate map=%s ! landmarkoverlay %s ! "
      "landmarklog location=%s", MAP_FILE, overlay_props, log);
  GstHarness *h = gst_harness_new_parse (desc);
  fail_unless (h != NULL, "%s", desc);
  g_free (desc);
  if (log_path)
    *log_path = log;
  else
    g_free (log);
  return h;
}

#define OVERLAY_ALL_OFF "show-detections=false show-rejected=false " \
  "show-pose=false show-histogram=false show-indicators=false " \
  "show-minimap=false"

/* Lines in a landmarklog file, each checked to be one whole JSON object. */
static guint
count_log_lines (const gchar * path)
{
  gchar *text = NULL, **lines;
  gsize len = 0;
  guint i, n = 0;
  GError *err = NULL;

  fail_unless (g_file_get_contents (path, &text, &len, &err), "%s: %s",
      path, err ? err->message : "");
  fail_unless (len == 0 || text[len - 1] == '\n', "%s ends mid-line", path);
  lines = g_strsplit (text, "\n", -1);
  for (i = 0; lines[i]; i++) {
    JsonParser *parser;
    if (!lines[i][0])
      continue;
    parser = json_parser_new ();
    fail_unless (json_parser_load_from_data (parser, lines[i], -1, NULL),
        "%s: line %u is not JSON", path, i + 1);
    fail_unless (JSON_NODE_HOLDS_OBJECT (json_parser_get_root (parser)));
    g_object_unref (parser);
    n++;
  }
  g_strfreev (lines);
  g_free (text);
  return n;
}

/* ------------------------------------------------------------------ */
/* Frames                                                              */
/* ------------------------------------------------------------------ */

/* A disc in pixel coordinates, pixel centres at integers: pixel (x, y) is
 * inside when (x - cx)^2 + (y - cy)^2 <= r^2. */
typedef struct
{
  gdouble cx, cy, r;
} Disc;

/* the default palette's red, sRGB 0..255; computed here from the palette
 * file's L*a*b*, not taken from the plugin */
static guint8 red_rgb[3];

static void
load_red (void)
{
  JsonParser *parser = json_parser_new ();
  JsonArray *classes;
  GError *err = NULL;
  guint i, k;
  gboolean found = FALSE;

  fail_unless (json_parser_load_from_file (parser, LANDMARK_DEFAULT_PALETTE,
          &err), "%s", err ? err->message : "");
  classes = json_object_get_array_member (json_node_get_object
      (json_parser_get_root (parser)), "classes");
  for (i = 0; i < json_array_get_length (classes); i++) {
    JsonObject *c = json_array_get_object_element (classes, i);
    JsonArray *lab;
    gdouble v[3];
    guint rgb;
    if (g_strcmp0 (json_object_get_string_member (c, "name"), "red"))
      continue;
    lab = json_object_get_array_member (c, "lab");
    for (k = 0; k < 3; k++)
      v[k] = json_array_get_double_element (lab, k);
    rgb = landmark_check_lab_to_rgb24 (v);
    red_rgb[0] = rgb >> 16;
    red_rgb[1] = (rgb >> 8) & 0xff;
    red_rgb[2] = rgb & 0xff;
    found = TRUE;
  }
  g_object_unref (parser);
  fail_unless (found, "no red in the default palette");
}

static void
video_info_init (GstVideoInfo * info, const gchar * format, guint w, guint h)
{
  GstVideoFormat f = gst_video_format_from_string (format);
  fail_if (f == GST_VIDEO_FORMAT_UNKNOWN, "unknown format %s", format);
  fail_unless (gst_video_info_set_format (info, f, w, h));
  GST_VIDEO_INFO_FPS_N (info) = FPS;
  GST_VIDEO_INFO_FPS_D (info) = 1;
}

/* Grey background (a gentle ramp, still the grey class) and a red disc. */
static void
paint_rgb (guint8 * data, gint stride, guint w, guint h, const Disc * d)
{
  guint x, y;
  for (y = 0; y < h; y++) {
    guint8 *row = data + (gsize) y * stride;
    for (x = 0; x < w; x++) {
      gboolean in = d && (x - d->cx) * (x - d->cx) + (y - d->cy) * (y -
          d->cy) <= d->r * d->r;
      if (in) {
        memcpy (row + 3 * x, red_rgb, 3);
      } else {
        guint8 g = 112 + (x * 3 + y * 5) % 33;
        row[3 * x] = row[3 * x + 1] = row[3 * x + 2] = g;
      }
    }
  }
}

/* A frame of info's format and size with a disc drawn (d may be NULL). In
 * a padded frame every plane has a larger stride and its own offset, the
 * buffer has bytes before, between and after the planes, and a GstVideoMeta
 * says where the planes are. Unused bytes hold a pattern, so an element
 * that writes there is caught by comparing the whole buffer. */
static GstBuffer *
frame_new (const GstVideoInfo * info, gboolean padded, const Disc * d,
    guint index)
{
  const guint w = GST_VIDEO_INFO_WIDTH (info), h = GST_VIDEO_INFO_HEIGHT (info);
  const guint n = GST_VIDEO_INFO_N_PLANES (info);
  gsize offset[GST_VIDEO_MAX_PLANES] = { 0 }, size = info->size, i;
  gint stride[GST_VIDEO_MAX_PLANES] = { 0 };
  GstVideoInfo src, dst = *info;
  GstBuffer *buf, *sbuf;
  GstVideoFrame sf, df;
  GstVideoConverter *conv;
  GstMapInfo map;
  guint p;

  for (p = 0; p < n; p++) {
    offset[p] = info->offset[p];
    stride[p] = info->stride[p];
  }
  if (padded) {
    gsize at = 96;
    for (p = 0; p < n; p++) {
      gsize end = p + 1 < n ? info->offset[p + 1] : info->size;
      gsize rows = (end - info->offset[p] + info->stride[p] - 1) /
          info->stride[p];
      stride[p] = info->stride[p] + 64 + 8 * p;
      offset[p] = at;
      at += (gsize) stride[p] * rows + 40;
    }
    size = at + 128;
    for (p = 0; p < n; p++) {
      dst.offset[p] = offset[p];
      dst.stride[p] = stride[p];
    }
    dst.size = size;
  }
  buf = gst_buffer_new_allocate (NULL, size, NULL);
  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  for (i = 0; i < map.size; i++)
    map.data[i] = (guint8) (0x5a ^ (i * 13));
  gst_buffer_unmap (buf, &map);
  if (padded)
    gst_buffer_add_video_meta_full (buf, GST_VIDEO_FRAME_FLAG_NONE,
        GST_VIDEO_INFO_FORMAT (info), w, h, n, offset, stride);

  /* draw in RGB, convert with GStreamer's converter to the format */
  video_info_init (&src, "RGB", w, h);
  sbuf = gst_buffer_new_allocate (NULL, src.size, NULL);
  fail_unless (gst_video_frame_map (&sf, &src, sbuf, GST_MAP_READWRITE));
  paint_rgb (GST_VIDEO_FRAME_PLANE_DATA (&sf, 0),
      GST_VIDEO_FRAME_PLANE_STRIDE (&sf, 0), w, h, d);
  fail_unless (gst_video_frame_map (&df, &dst, buf, GST_MAP_WRITE));
  conv = gst_video_converter_new (&src, &dst,
      gst_structure_new ("config", GST_VIDEO_CONVERTER_OPT_DITHER_METHOD,
          GST_TYPE_VIDEO_DITHER_METHOD, GST_VIDEO_DITHER_NONE, NULL));
  fail_unless (conv != NULL);
  gst_video_converter_frame (conv, &sf, &df);
  gst_video_converter_free (conv);
  gst_video_frame_unmap (&df);
  gst_video_frame_unmap (&sf);
  gst_buffer_unref (sbuf);

  GST_BUFFER_PTS (buf) = index * FRAME_NS;
  GST_BUFFER_DURATION (buf) = FRAME_NS;
  return buf;
}

/* A disc centred at (nx, ny) of the frame (fractions of its width and
 * height), radius 9% of the smaller side. */
static Disc
disc_at (guint w, guint h, gdouble nx, gdouble ny)
{
  Disc d;
  d.cx = nx * w - 0.5;
  d.cy = ny * h - 0.5;
  d.r = 0.09 * MIN (w, h);
  return d;
}

/* ------------------------------------------------------------------ */
/* Metadata made by hand, for elements tested without their upstream   */
/* ------------------------------------------------------------------ */


/* A labels meta with a w x h plane (stride, and plane_bytes bytes of
 * storage, may disagree with it on purpose): label 1 (red) in the disc,
 * 7 (grey) elsewhere. plane_bytes G_MAXSIZE: exactly stride * h. */
static void
add_labels (GstBuffer * buf, guint w, guint h, guint stride,
    gsize plane_bytes, const Disc * d)
{
  GstCustomMeta *m = gst_buffer_add_custom_meta (buf, LABELS_META);
  GstStructure *s;
  GstBuffer *plane;
  GstMapInfo map;
  guint counts[7] = { 0 }, x, y;
  const gboolean active[7] = { TRUE, FALSE, FALSE, FALSE, FALSE, FALSE,
    TRUE
  };

  fail_unless (m != NULL, LABELS_META " not registered: plugin not loaded");
  s = gst_custom_meta_get_structure (m);
  if (plane_bytes == G_MAXSIZE)
    plane_bytes = (gsize) stride * h;
  plane = gst_buffer_new_allocate (NULL, plane_bytes, NULL);
  gst_buffer_map (plane, &map, GST_MAP_WRITE);
  if (map.size)                 /* memset of NULL is undefined, even for 0 */
    memset (map.data, 7, map.size);
  for (y = 0; y < h; y++)
    for (x = 0; x < w && x < stride; x++) {
      gsize i = (gsize) y * stride + x;
      gboolean in = d && (x - d->cx) * (x - d->cx) + (y - d->cy) * (y -
          d->cy) <= d->r * d->r;
      if (i < map.size)
        map.data[i] = in ? 1 : 7;
      counts[in ? 0 : 6]++;
    }
  gst_buffer_unmap (plane, &map);
  gst_structure_set (s, "labels", GST_TYPE_BUFFER, plane,
      "width", G_TYPE_UINT, w, "height", G_TYPE_UINT, h,
      "stride", G_TYPE_UINT, stride,
      "analysis-width", G_TYPE_UINT, w, "analysis-height", G_TYPE_UINT, h,
      "min-class-pixels", G_TYPE_UINT, 1, NULL);
  gst_buffer_unref (plane);
  landmark_check_set_array (s, "class-names", G_TYPE_STRING,
      landmark_check_names7, 7);
  landmark_check_set_array (s, "class-markers", G_TYPE_BOOLEAN,
      landmark_check_markers7, 7);
  landmark_check_set_array (s, "class-counts", G_TYPE_UINT, counts, 7);
  landmark_check_set_array (s, "class-active", G_TYPE_BOOLEAN, active, 7);
}

/* A detection of the disc, as blobroundness would attach it, for a frame
 * of fw x fh (the bounding box clipped to the frame). */
static void
add_detection (GstBuffer * buf, const Disc * d, guint fw, guint fh)
{
  gint x0 = (gint) MAX (0, floor (d->cx - d->r));
  gint y0 = (gint) MAX (0, floor (d->cy - d->r));
  gint x1 = (gint) MIN ((gint) fw, ceil (d->cx + d->r) + 1);
  gint y1 = (gint) MIN ((gint) fh, ceil (d->cy + d->r) + 1);
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, "red", x0, y0,
      MAX (1, x1 - x0), MAX (1, y1 - y0));
  roi->id = 0;
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, "red",
          "area", G_TYPE_DOUBLE, G_PI * d->r * d->r,
          "perimeter", G_TYPE_DOUBLE, 2 * G_PI * d->r,
          "roundness", G_TYPE_DOUBLE, 1.0,
          "centroid-x", G_TYPE_DOUBLE, d->cx,
          "centroid-y", G_TYPE_DOUBLE, d->cy,
          "equivalent-diameter", G_TYPE_DOUBLE, 2 * d->r,
          "ellipse-x", G_TYPE_DOUBLE, d->cx, "ellipse-y", G_TYPE_DOUBLE, d->cy,
          "ellipse-major", G_TYPE_DOUBLE, 2 * d->r,
          "ellipse-minor", G_TYPE_DOUBLE, 2 * d->r,
          "ellipse-angle", G_TYPE_DOUBLE, 0.0,
          "ellipse-fit", G_TYPE_DOUBLE, 1.0,
          "kept", G_TYPE_BOOLEAN, TRUE,
          "frame-width", G_TYPE_UINT, fw, "frame-height", G_TYPE_UINT, fh,
          NULL));
}

static void
add_pose (GstBuffer * buf)
{
  GstCustomMeta *m = gst_buffer_add_custom_meta (buf, POSE_META);
  fail_unless (m != NULL);
  gst_structure_set (gst_custom_meta_get_structure (m),
      "x", G_TYPE_DOUBLE, 2.0, "y", G_TYPE_DOUBLE, 3.0,
      "heading", G_TYPE_DOUBLE, 0.5, NULL);
}

/* Everything the elements read, consistent with a w x h frame. */
static void
add_all_meta (GstBuffer * buf, guint w, guint h, const Disc * d)
{
  add_labels (buf, w, h, w, G_MAXSIZE, d);
  add_detection (buf, d, w, h);
  add_pose (buf);
}

/* ------------------------------------------------------------------ */
/* Checking what comes out                                             */
/* ------------------------------------------------------------------ */

static const GstStructure *
labels_of (GstBuffer * buf)
{
  GstCustomMeta *m = gst_buffer_get_custom_meta (buf, LABELS_META);
  return m ? gst_custom_meta_get_structure (m) : NULL;
}

/* Metadata geometry of an output frame of w x h: every detection's box is
 * inside the frame; with CHECK_LABELS the label plane (if any) has the
 * frame's size and enough bytes, with CHECK_BLOBS every landmark-blob was
 * measured on a frame of this size. */
#define CHECK_LABELS 1
#define CHECK_BLOBS 2
#define CHECK_ALL (CHECK_LABELS | CHECK_BLOBS)

static void
check_meta_geometry (GstBuffer * out, guint w, guint h, guint checks,
    const gchar * what)
{
  const GstStructure *labels = labels_of (out);
  gpointer iter = NULL;
  GstMeta *meta;

  if (labels && (checks & CHECK_LABELS)) {
    guint lw = 0, lh = 0, stride = 0;
    GstBuffer *plane = NULL;
    fail_unless (gst_structure_get (labels, "width", G_TYPE_UINT, &lw,
            "height", G_TYPE_UINT, &lh, "stride", G_TYPE_UINT, &stride,
            "labels", GST_TYPE_BUFFER, &plane, NULL), "%s: labels fields",
        what);
    fail_unless (lw == w && lh == h, "%s: label plane %ux%u on a %ux%u frame",
        what, lw, lh, w, h);
    fail_unless (stride >= lw, "%s", what);
    fail_unless (gst_buffer_get_size (plane) >= (gsize) stride * lh,
        "%s: label plane of %" G_GSIZE_FORMAT " bytes", what,
        gst_buffer_get_size (plane));
    gst_buffer_unref (plane);
  }
  while ((meta = gst_buffer_iterate_meta_filtered (out, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *) meta;
    GstStructure *blob =
        gst_video_region_of_interest_meta_get_param (roi, "landmark-blob");
    fail_unless (roi->x + roi->w <= w && roi->y + roi->h <= h,
        "%s: box %u,%u %ux%u outside the %ux%u frame", what, roi->x, roi->y,
        roi->w, roi->h, w, h);
    if (blob && (checks & CHECK_BLOBS)) {
      guint fw = 0, fh = 0;
      fail_unless (gst_structure_get_uint (blob, "frame-width", &fw) &&
          gst_structure_get_uint (blob, "frame-height", &fh), "%s", what);
      fail_unless (fw == w && fh == h, "%s: blob measured on %ux%u, frame "
          "%ux%u", what, fw, fh, w, h);
    }
  }
}

/* A pushed frame: its timestamp, and its bytes when they must come back. */
typedef struct
{
  GstClockTime pts;
  GBytes *bytes;
} Sent;

static GBytes *
buffer_bytes (GstBuffer * buf)
{
  gpointer data;
  gsize size;
  gst_buffer_extract_dup (buf, 0, gst_buffer_get_size (buf), &data, &size);
  return g_bytes_new_take (data, size);
}

static void
push_frame (GstHarness * h, GstBuffer * buf, gboolean keep_bytes, Sent * s)
{
  s->pts = GST_BUFFER_PTS (buf);
  s->bytes = keep_bytes ? buffer_bytes (buf) : NULL;
  fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
}

/* Pulls one output per sent frame, in order, same timestamps, same bytes
 * where kept; calls check on each; then nothing more is waiting. */
static void
pull_sent (GstHarness * h, Sent * sent, guint n,
    void (*check) (GstBuffer *, guint, gpointer), gpointer data,
    const gchar * what)
{
  guint i;
  for (i = 0; i < n; i++) {
    GstBuffer *out = gst_harness_pull (h);
    fail_unless (out != NULL, "%s: frame %u did not come out", what, i);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), sent[i].pts);
    if (sent[i].bytes) {
      gsize size;
      const guint8 *bytes = g_bytes_get_data (sent[i].bytes, &size);
      fail_unless_equals_uint64 (gst_buffer_get_size (out), size);
      fail_unless (gst_buffer_memcmp (out, 0, bytes, size) == 0,
          "%s: frame %u: bytes changed", what, i);
      g_bytes_unref (sent[i].bytes);
      sent[i].bytes = NULL;
    }
    if (check)
      check (out, i, data);
    gst_buffer_unref (out);
  }
  fail_unless_equals_int (gst_harness_buffers_in_queue (h), 0);
}

/* Bus on a harnessed element: warnings and errors it posts. */
static void
count_messages (GstBus * bus, guint * warnings, guint * errors)
{
  GstMessage *msg;
  while ((msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING |
              GST_MESSAGE_ERROR))) {
    GError *err = NULL;
    gchar *dbg = NULL;
    if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_WARNING) {
      gst_message_parse_warning (msg, &err, &dbg);
      (*warnings)++;
    } else {
      gst_message_parse_error (msg, &err, &dbg);
      (*errors)++;
    }
    GST_INFO ("%s: %s (%s)", GST_MESSAGE_TYPE_NAME (msg), err->message,
        dbg ? dbg : "");
    g_clear_error (&err);
    g_free (dbg);
    gst_message_unref (msg);
  }
}

/* Sink formats of an element's template; a template without a format
 * field (any video/x-raw) gets any_formats. */
static GPtrArray *
sink_formats (const gchar * name)
{
  GstElementFactory *f = gst_element_factory_find (name);
  GPtrArray *out = g_ptr_array_new_with_free_func (g_free);
  gboolean any = FALSE;
  const GList *t;
  guint i, j;

  for (t = gst_element_factory_get_static_pad_templates (f); t; t = t->next) {
    GstStaticPadTemplate *tmpl = t->data;
    GstCaps *caps;
    if (tmpl->direction != GST_PAD_SINK)
      continue;
    caps = gst_static_pad_template_get_caps (tmpl);
    for (i = 0; i < gst_caps_get_size (caps); i++) {
      const GValue *v =
          gst_structure_get_value (gst_caps_get_structure (caps, i),
          "format");
      if (!v)
        any = TRUE;
      else if (G_VALUE_HOLDS_STRING (v))
        g_ptr_array_add (out, g_value_dup_string (v));
      else if (GST_VALUE_HOLDS_LIST (v))
        for (j = 0; j < gst_value_list_get_size (v); j++)
          g_ptr_array_add (out,
              g_value_dup_string (gst_value_list_get_value (v, j)));
    }
    gst_caps_unref (caps);
  }
  gst_object_unref (f);
  if (any)
    for (i = 0; i < G_N_ELEMENTS (any_formats); i++)
      if (!g_ptr_array_find_with_equal_func (out, any_formats[i],
              g_str_equal, NULL))
        g_ptr_array_add (out, g_strdup (any_formats[i]));
  fail_unless (out->len > 0, "%s: no sink format", name);
  return out;
}

static void
set_caps (GstHarness * h, const GstVideoInfo * info)
{
  gst_harness_set_src_caps (h, gst_video_info_to_caps (info));
}

/* ------------------------------------------------------------------ */
/* Formats x sizes, each element alone                                 */
/* ------------------------------------------------------------------ */

typedef struct
{
  guint w, h;
  const gchar *what;
} GeometryCheck;

static void
check_geometry_cb (GstBuffer * out, guint i, gpointer data)
{
  GeometryCheck *g = data;
  (void) i;
  check_meta_geometry (out, g->w, g->h, CHECK_ALL, g->what);
}

/* Each format x size x (packed, padded): a frame with every metadata the
 * elements read, then one with none. Analysers return both frames byte
 * for byte; an element that draws returns the bare frame unchanged. */
LANDMARK_TEST_LOOP ("formats", test_element_formats_and_sizes,
    LANDMARK_CHECK_PER_ELEMENT)
{
  const gchar *name = element_name (__i__);
  GPtrArray *formats = sink_formats (name);
  const gboolean paints = draws (name);
  gint64 t0 = g_get_monotonic_time ();
  guint f, s, padded, cases = 0;

  for (f = 0; f < formats->len; f++) {
    const gchar *format = g_ptr_array_index (formats, f);
    GstHarness *h = harness_for (name);
    gchar *log = g_strdup (g_object_get_data (G_OBJECT (h->element),
            LANDMARK_CHECK_FILE));
    guint pushed = 0;

    for (s = 0; s < G_N_ELEMENTS (sizes); s++) {
      GstVideoInfo info;
      video_info_init (&info, format, sizes[s].w, sizes[s].h);
      set_caps (h, &info);
      for (padded = 0; padded < 2; padded++) {
        gchar *what = g_strdup_printf ("%s %s %ux%u%s", name, format,
            sizes[s].w, sizes[s].h, padded ? " padded" : "");
        Disc d = disc_at (sizes[s].w, sizes[s].h, 0.6, 0.7);
        GeometryCheck g = { sizes[s].w, sizes[s].h, what };
        Sent sent[2];
        GstBuffer *a = frame_new (&info, padded, &d, pushed);
        GstBuffer *b = frame_new (&info, padded, &d, pushed + 1);

        add_all_meta (a, sizes[s].w, sizes[s].h, &d);
        push_frame (h, a, !paints, &sent[0]);
        push_frame (h, b, TRUE, &sent[1]);
        pushed += 2;
        pull_sent (h, sent, 2, check_geometry_cb, &g, what);
        g_free (what);
        cases++;
      }
    }
    gst_harness_teardown (h);
    if (log)
      fail_unless_equals_int (count_log_lines (log), pushed);
    g_free (log);
  }
  g_print ("%s: %u formats x %u layouts = %u cases in %.2f s\n", name,
      formats->len, (guint) G_N_ELEMENTS (sizes) * 2, cases,
      (g_get_monotonic_time () - t0) / 1e6);
  g_ptr_array_unref (formats);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Formats x sizes through the whole chain, and 3840x2160              */
/* ------------------------------------------------------------------ */

typedef struct
{
  guint w, h;
  Disc disc;
  gboolean expect_detection;
  const gchar *what;
} ChainCheck;

/* The detection of the drawn disc: a kept red blob whose centroid is within
 * tol pixels of the disc's centre; NULL if none. */
static GstVideoRegionOfInterestMeta *
find_disc (GstBuffer * out, const Disc * d, gdouble tol,
    const GstStructure ** blob_out)
{
  gpointer iter = NULL;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (out, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *) meta;
    GstStructure *blob =
        gst_video_region_of_interest_meta_get_param (roi, "landmark-blob");
    gdouble cx, cy;
    gboolean kept = FALSE;
    if (!blob || roi->roi_type != g_quark_from_string ("red"))
      continue;
    if (!gst_structure_get_double (blob, "centroid-x", &cx) ||
        !gst_structure_get_double (blob, "centroid-y", &cy) ||
        !gst_structure_get_boolean (blob, "kept", &kept) || !kept)
      continue;
    if (fabs (cx - d->cx) <= tol && fabs (cy - d->cy) <= tol) {
      if (blob_out)
        *blob_out = blob;
      return roi;
    }
  }
  return NULL;
}

static void
check_chain_cb (GstBuffer * out, guint i, gpointer data)
{
  ChainCheck *c = data;
  (void) i;
  fail_unless (labels_of (out) != NULL, "%s: no labels", c->what);
  check_meta_geometry (out, c->w, c->h, CHECK_ALL, c->what);
  if (c->expect_detection) {
    GstVideoRegionOfInterestMeta *roi = find_disc (out, &c->disc, 1.0, NULL);
    GstStructure *range;
    gdouble r;
    fail_unless (roi != NULL, "%s: the disc at %.1f,%.1f was not detected",
        c->what, c->disc.cx, c->disc.cy);
    range = gst_video_region_of_interest_meta_get_param (roi,
        "landmark-range");
    fail_unless (range != NULL, "%s: no range", c->what);
    fail_unless (gst_structure_get_double (range, "range", &r) &&
        isfinite (r) && r > 0, "%s: range", c->what);
  }
}

/* The chain with every overlay part off: all six elements leave the bytes
 * alone, and the metadata has the frame's geometry. */
LANDMARK_TEST ("formats", test_chain_formats_and_sizes)
{
  GPtrArray *formats = sink_formats ("labsegment");
  GPtrArray *overlay = sink_formats ("landmarkoverlay");
  gint64 t0 = g_get_monotonic_time ();
  gdouble uhd_ms = 0;
  guint f, s, padded, cases = 0, uhd = 0;

  for (f = 0; f < formats->len; f++) {
    const gchar *format = g_ptr_array_index (formats, f);
    gchar *log;
    GstHarness *h;
    guint pushed = 0;

    if (!g_ptr_array_find_with_equal_func (overlay, format, g_str_equal,
            NULL))
      continue;
    h = chain_harness (OVERLAY_ALL_OFF, &log);
    for (s = 0; s <= G_N_ELEMENTS (sizes); s++) {
      /* the last size: 3840x2160, packed only */
      const gboolean is_uhd = s == G_N_ELEMENTS (sizes);
      const guint w = is_uhd ? 3840 : sizes[s].w;
      const guint hh = is_uhd ? 2160 : sizes[s].h;
      GstVideoInfo info;
      video_info_init (&info, format, w, hh);
      set_caps (h, &info);
      for (padded = 0; padded < (is_uhd ? 1u : 2u); padded++) {
        gchar *what = g_strdup_printf ("chain %s %ux%u%s", format, w, hh,
            padded ? " padded" : "");
        ChainCheck c = { w, hh, disc_at (w, hh, 0.6, 0.7), w >= 100, what };
        Sent sent[2];
        guint k, n = is_uhd ? 1 : 2;
        gint64 t1 = 0;
        for (k = 0; k < n; k++) {
          GstBuffer *b = frame_new (&info, padded, &c.disc, pushed++);
          t1 = g_get_monotonic_time ();
          push_frame (h, b, TRUE, &sent[k]);
        }
        if (is_uhd) {
          uhd_ms += (g_get_monotonic_time () - t1) / 1e3;
          uhd++;
        }
        pull_sent (h, sent, n, check_chain_cb, &c, what);
        g_free (what);
        cases++;
      }
    }
    gst_harness_teardown (h);
    fail_unless_equals_int (count_log_lines (log), pushed);
    g_free (log);
  }
  g_print ("chain: %u format x size cases (%u at 3840x2160, %.0f ms per "
      "4K frame through the chain) in %.2f s\n", cases, uhd,
      uhd ? uhd_ms / uhd : 0, (g_get_monotonic_time () - t0) / 1e6);
  g_ptr_array_unref (formats);
  g_ptr_array_unref (overlay);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Caps changes mid-stream through the chain                           */
/* ------------------------------------------------------------------ */

typedef struct
{
  const gchar *format;
  guint w, h;
  gdouble nx, ny;               /* disc centre, fraction of the frame */
} Phase;

static const Phase phases[] = {
  {"BGRx", 320, 240, 0.30, 0.65},
  {"I420", 640, 480, 0.62, 0.72},
  {"RGB", 160, 120, 0.45, 0.60},
  {"NV12", 641, 479, 0.70, 0.66},
  {"YUY2", 320, 180, 0.35, 0.70},
  {"RGBA", 1280, 720, 0.55, 0.75},
  {"xBGR", 320, 240, 0.30, 0.65},
  {"BGR", 642, 482, 0.62, 0.72},
};

/* ipmrange alone, given a detection at (u, v) of a w x h frame: the
 * range it reports. The reference the chain's range is held to. */
static gdouble
reference_range (guint w, guint h, gdouble u, gdouble v)
{
  GstHarness *h1 = gst_harness_new ("ipmrange");
  GstVideoInfo info;
  GstBuffer *buf, *out;
  GstVideoRegionOfInterestMeta *roi;
  Disc d = { u, v, 0.09 * MIN (w, h) };
  gdouble r = NAN;

  video_info_init (&info, "GRAY8", w, h);
  set_caps (h1, &info);
  buf = gst_buffer_new_allocate (NULL, info.size, NULL);
  gst_buffer_memset (buf, 0, 0, info.size);
  add_detection (buf, &d, w, h);
  out = gst_harness_push_and_pull (h1, buf);
  roi = gst_buffer_get_video_region_of_interest_meta_id (out, 0);
  fail_unless (roi != NULL);
  fail_unless (gst_structure_get_double
      (gst_video_region_of_interest_meta_get_param (roi, "landmark-range"),
          "range", &r));
  gst_buffer_unref (out);
  gst_harness_teardown (h1);
  return r;
}

/* Pixels of a and b differ at (x, y) in any component. */
static gboolean
pixel_differs (const GstVideoFrame * a, const GstVideoFrame * b, gint x,
    gint y)
{
  const GstVideoFormatInfo *fi = a->info.finfo;
  guint c;
  if (x < 0 || y < 0 || x >= GST_VIDEO_FRAME_WIDTH (a) ||
      y >= GST_VIDEO_FRAME_HEIGHT (a))
    return FALSE;
  for (c = 0; c < GST_VIDEO_FORMAT_INFO_N_COMPONENTS (fi); c++) {
    gint px = GST_VIDEO_FORMAT_INFO_SCALE_WIDTH (fi, c, x);
    gint py = GST_VIDEO_FORMAT_INFO_SCALE_HEIGHT (fi, c, y);
    const guint8 *pa = (const guint8 *) GST_VIDEO_FRAME_COMP_DATA (a, c) +
        py * GST_VIDEO_FRAME_COMP_STRIDE (a, c) +
        px * GST_VIDEO_FRAME_COMP_PSTRIDE (a, c);
    const guint8 *pb = (const guint8 *) GST_VIDEO_FRAME_COMP_DATA (b, c) +
        py * GST_VIDEO_FRAME_COMP_STRIDE (b, c) +
        px * GST_VIDEO_FRAME_COMP_PSTRIDE (b, c);
    if (*pa != *pb)
      return TRUE;
  }
  return FALSE;
}

/* Of 72 directions around d, the fraction where the overlay changed a
 * pixel within 2 px of the disc's outline. */
static gdouble
outline_changed (const GstVideoFrame * in, const GstVideoFrame * out,
    const Disc * d)
{
  guint k, hit = 0;
  for (k = 0; k < 72; k++) {
    const gdouble t = 2 * G_PI * k / 72;
    gdouble dr;
    for (dr = -2; dr <= 2; dr += 1) {
      gint x = (gint) lround (d->cx + (d->r + dr) * cos (t));
      gint y = (gint) lround (d->cy + (d->r + dr) * sin (t));
      if (pixel_differs (in, out, x, y)) {
        hit++;
        break;
      }
    }
  }
  return hit / 72.0;
}

typedef struct
{
  const Phase *ph;
  Disc disc, previous;
  gboolean has_previous;
  GstVideoInfo info;
  GstBuffer *in[4];
  gdouble ref_range, ref_range_slope;
} PhaseCheck;

static void
check_phase_cb (GstBuffer * out, guint i, gpointer data)
{
  PhaseCheck *p = data;
  const Phase *ph = p->ph;
  gchar *what = g_strdup_printf ("%s %ux%u frame %u", ph->format, ph->w,
      ph->h, i);
  const GstStructure *labels = labels_of (out), *blob = NULL;
  GstVideoRegionOfInterestMeta *roi;
  GstStructure *range;
  gdouble r;
  GstVideoFrame fin, fout;

  fail_unless (labels != NULL, "%s: no labels", what);
  check_meta_geometry (out, ph->w, ph->h, CHECK_ALL, what);

  /* detected where it was drawn, in this frame's pixels */
  roi = find_disc (out, &p->disc, 1.0, &blob);
  fail_unless (roi != NULL, "%s: disc drawn at %.2f,%.2f not found", what,
      p->disc.cx, p->disc.cy);

  /* ranged with this frame's geometry: as ipmrange alone ranges the drawn
   * centre in a frame of this size, within what a pixel of centroid error
   * makes */
  range = gst_video_region_of_interest_meta_get_param (roi, "landmark-range");
  fail_unless (range != NULL, "%s: no range", what);
  fail_unless (gst_structure_get_double (range, "range", &r) && isfinite (r),
      "%s: no finite range", what);
  fail_unless (fabs (r - p->ref_range) <= p->ref_range_slope + 1e-6,
      "%s: range %.4f m, expected %.4f +- %.4f m", what, r, p->ref_range,
      p->ref_range_slope);

  /* the overlay drew the ellipse around the disc where it is now, and
   * nothing around where it was in the previous caps */
  fail_unless (gst_video_frame_map (&fin, &p->info, p->in[i], GST_MAP_READ));
  fail_unless (gst_video_frame_map (&fout, &p->info, out, GST_MAP_READ));
  fail_unless (outline_changed (&fin, &fout, &p->disc) >= 0.9,
      "%s: no ellipse around the disc (%.0f%% of its outline)", what,
      100 * outline_changed (&fin, &fout, &p->disc));
  if (p->has_previous)
    fail_unless (outline_changed (&fin, &fout, &p->previous) <= 0.2,
        "%s: something drawn where the disc was before the caps change",
        what);
  gst_video_frame_unmap (&fout);
  gst_video_frame_unmap (&fin);
  gst_clear_buffer (&p->in[i]);
  g_free (what);
}

/* The disc moves with each caps change; labels, detection, range and
 * overlay follow. */
LANDMARK_TEST ("renegotiation", test_chain_renegotiation)
{
  GstHarness *h = chain_harness ("show-rejected=false show-pose=false "
      "show-histogram=false show-indicators=false show-minimap=false", NULL);
  guint k, i, pushed = 0;
  Disc previous = { 0, 0, 0 };
  gdouble range_43 = 0;

  for (k = 0; k < G_N_ELEMENTS (phases); k++) {
    const Phase *ph = &phases[k];
    PhaseCheck p;
    Sent sent[4];
    gdouble r_lo, r_hi;

    memset (&p, 0, sizeof (p));
    p.ph = ph;
    video_info_init (&p.info, ph->format, ph->w, ph->h);
    p.disc = disc_at (ph->w, ph->h, ph->nx, ph->ny);
    /* the previous disc, in this frame's pixels */
    p.previous.cx = (previous.cx + 0.5) * ph->w / phases[MAX (k, 1) - 1].w
        - 0.5;
    p.previous.cy = (previous.cy + 0.5) * ph->h / phases[MAX (k, 1) - 1].h
        - 0.5;
    p.previous.r = p.disc.r;
    p.has_previous = k > 0 && (fabs (p.previous.cx - p.disc.cx) >
        3 * p.disc.r || fabs (p.previous.cy - p.disc.cy) > 3 * p.disc.r);
    p.ref_range = reference_range (ph->w, ph->h, p.disc.cx, p.disc.cy);
    r_lo = reference_range (ph->w, ph->h, p.disc.cx, p.disc.cy - 1);
    r_hi = reference_range (ph->w, ph->h, p.disc.cx, p.disc.cy + 1);
    p.ref_range_slope = MAX (fabs (r_hi - p.ref_range),
        fabs (r_lo - p.ref_range));

    /* ipmrange's geometry scales with the frame: the same place of a 4:3
     * frame is the same range at any size */
    if (ph->w * 3 == ph->h * 4) {
      if (range_43 == 0)
        range_43 = reference_range (640, 480, ph->nx * 640 - 0.5,
            ph->ny * 480 - 0.5);
      else {
        gdouble same = reference_range (640, 480, ph->nx * 640 - 0.5,
            ph->ny * 480 - 0.5);
        fail_unless (fabs (p.ref_range - same) < 1e-3 * same,
            "%ux%u: range %.5f at a place where 640x480 gives %.5f", ph->w,
            ph->h, p.ref_range, same);
      }
    }

    set_caps (h, &p.info);
    for (i = 0; i < 3; i++) {
      GstBuffer *b = frame_new (&p.info, i == 1, &p.disc, pushed++);
      p.in[i] = gst_buffer_copy_deep (b);
      push_frame (h, b, FALSE, &sent[i]);
    }
    pull_sent (h, sent, 3, check_phase_cb, &p, ph->format);
    previous = p.disc;
  }
  g_print ("chain: %u caps changes (size and format) followed, %u frames\n",
      (guint) G_N_ELEMENTS (phases) - 1, pushed);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Missing and inconsistent metadata, each element alone               */
/* ------------------------------------------------------------------ */

typedef enum
{
  META_NONE,
  PLANE_HALF,                   /* label plane half the frame's size */
  PLANE_LARGER,                 /* larger than the frame */
  PLANE_SHORT,                  /* fewer bytes than stride x height */
  PLANE_NARROW_STRIDE,          /* stride < width */
  PLANE_EMPTY,                  /* 0 x 0 */
  PLANE_MISSING,                /* labels meta without the plane */
  BLOB_ZERO_FRAME,              /* detection measured on a 0 x 0 frame */
  BLOB_NON_FINITE,              /* NaN centroid, infinite ellipse */
  BLOB_OUTSIDE,                 /* centroid and ellipse far off the frame */
  N_META_CASES
} MetaCase;

static const gchar *meta_case_names[] = {
  "no metadata", "plane half size", "plane larger", "plane short",
  "stride < width", "plane 0x0", "no plane field", "blob frame 0x0",
  "blob NaN and inf", "blob off the frame",
};

#define MW 64
#define MH 48

/* Numbers the elements computed (every parameter structure but the
 * landmark-blob given to them, and the pose) are finite: the metadata
 * contract leaves a field out rather than hold NaN or infinity. */
static void
check_computed_finite (GstBuffer * out, const gchar * what)
{
  gpointer iter = NULL;
  GstMeta *meta;
  const GstStructure *pose;
  GstCustomMeta *pm = gst_buffer_get_custom_meta (out, POSE_META);
  guint f;

  while ((meta = gst_buffer_iterate_meta_filtered (out, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *) meta;
    GList *l;
    for (l = roi->params; l; l = l->next) {
      const GstStructure *s = l->data;
      if (gst_structure_has_name (s, "landmark-blob"))
        continue;
      for (f = 0; f < (guint) gst_structure_n_fields (s); f++) {
        const GValue *v = gst_structure_get_value (s,
            gst_structure_nth_field_name (s, f));
        if (G_VALUE_HOLDS_DOUBLE (v))
          fail_unless (isfinite (g_value_get_double (v)), "%s: %s %s = %g",
              what, gst_structure_get_name (s),
              gst_structure_nth_field_name (s, f), g_value_get_double (v));
      }
    }
  }
  pose = pm ? gst_custom_meta_get_structure (pm) : NULL;
  for (f = 0; pose && f < (guint) gst_structure_n_fields (pose); f++) {
    const GValue *v = gst_structure_get_value (pose,
        gst_structure_nth_field_name (pose, f));
    if (G_VALUE_HOLDS_DOUBLE (v))
      fail_unless (isfinite (g_value_get_double (v)), "%s: pose %s", what,
          gst_structure_nth_field_name (pose, f));
  }
}

static GstBuffer *
meta_case_frame (const GstVideoInfo * info, MetaCase c, guint index)
{
  Disc d = disc_at (MW, MH, 0.6, 0.7), half = disc_at (MW / 2, MH / 2, 0.6,
      0.7), big = disc_at (MW + 5, MH + 3, 0.6, 0.7);
  GstBuffer *b = frame_new (info, FALSE, &d, index);
  switch (c) {
    case META_NONE:
      break;
    case PLANE_HALF:
      add_labels (b, MW / 2, MH / 2, MW / 2, G_MAXSIZE, &half);
      add_detection (b, &half, MW / 2, MH / 2);
      break;
    case PLANE_LARGER:
      add_labels (b, MW + 5, MH + 3, MW + 5, G_MAXSIZE, &big);
      add_detection (b, &big, MW + 5, MH + 3);
      break;
    case PLANE_SHORT:
      add_labels (b, MW, MH, MW, (gsize) MW * MH / 2, &d);
      break;
    case PLANE_NARROW_STRIDE:
      add_labels (b, MW, MH, MW / 2, G_MAXSIZE, &d);
      break;
    case PLANE_EMPTY:
      add_labels (b, 0, 0, 0, 0, NULL);
      break;
    case PLANE_MISSING:{
      GstCustomMeta *m = gst_buffer_add_custom_meta (b, LABELS_META);
      gst_structure_set (gst_custom_meta_get_structure (m), "width",
          G_TYPE_UINT, MW, "height", G_TYPE_UINT, MH, NULL);
      landmark_check_set_array (gst_custom_meta_get_structure (m),
          "class-names", G_TYPE_STRING, landmark_check_names7, 7);
      break;
    }
    case BLOB_ZERO_FRAME:
      add_labels (b, MW, MH, MW, G_MAXSIZE, &d);
      add_detection (b, &d, 0, 0);
      break;
    case BLOB_NON_FINITE:
    case BLOB_OUTSIDE:{
      const gboolean nan = c == BLOB_NON_FINITE;
      GstVideoRegionOfInterestMeta *roi;
      add_labels (b, MW, MH, MW, G_MAXSIZE, &d);
      add_detection (b, &d, MW, MH);
      roi = gst_buffer_get_video_region_of_interest_meta_id (b, 0);
      gst_structure_set (gst_video_region_of_interest_meta_get_param (roi,
              "landmark-blob"),
          "centroid-x", G_TYPE_DOUBLE, nan ? NAN : -500.0,
          "centroid-y", G_TYPE_DOUBLE, nan ? NAN : 1e6,
          "ellipse-x", G_TYPE_DOUBLE, nan ? INFINITY : -1e9,
          "ellipse-major", G_TYPE_DOUBLE, nan ? INFINITY : 1e9,
          "ellipse-minor", G_TYPE_DOUBLE, nan ? NAN : 1e9,
          "equivalent-diameter", G_TYPE_DOUBLE, nan ? NAN : 1e9,
          "area", G_TYPE_DOUBLE, nan ? NAN : 1e18, NULL);
      add_pose (b);
      break;
    }
    default:
      g_assert_not_reached ();
  }
  return b;
}

/* Frames with no metadata, or metadata that does not fit the frame: every
 * frame comes out in order, analysers leave the bytes alone (and the
 * overlay too when there is nothing to draw), boxes stay inside the frame,
 * at most one warning per stream and no error. */
LANDMARK_TEST_LOOP ("metadata", test_element_bad_metadata,
    LANDMARK_CHECK_PER_ELEMENT)
{
  const gchar *name = element_name (__i__);
  const gboolean paints = draws (name);
  GstVideoInfo info;
  guint c, i;

  video_info_init (&info, "BGRx", MW, MH);
  for (c = 0; c < N_META_CASES; c++) {
    GstHarness *h = harness_for (name);
    gchar *log = g_strdup (g_object_get_data (G_OBJECT (h->element),
            LANDMARK_CHECK_FILE));
    GstBus *bus = gst_bus_new ();
    gchar *what = g_strdup_printf ("%s, %s", name, meta_case_names[c]);
    GeometryCheck g = { MW, MH, what };
    Sent sent[6];
    guint warnings = 0, errors = 0;

    gst_element_set_bus (h->element, bus);
    set_caps (h, &info);
    for (i = 0; i < G_N_ELEMENTS (sent); i++)
      push_frame (h, meta_case_frame (&info, c, i),
          !paints || c == META_NONE, &sent[i]);
    pull_sent (h, sent, G_N_ELEMENTS (sent), c == META_NONE ?
        check_geometry_cb : NULL, &g, what);
    {
      /* boxes inside the frame whatever the plane's size */
      GstBuffer *b = meta_case_frame (&info, c, 100);
      GstBuffer *out = gst_harness_push_and_pull (h, b);
      fail_unless (out != NULL, "%s", what);
      check_meta_geometry (out, MW, MH, 0, what);
      check_computed_finite (out, what);
      if (g_str_equal (name, "ipmrange") && (c == BLOB_NON_FINITE
              || c == BLOB_OUTSIDE)) {
        /* a centroid that is no point of the frame gets no range */
        GstVideoRegionOfInterestMeta *roi =
            gst_buffer_get_video_region_of_interest_meta_id (out, 0);
        fail_unless (roi != NULL, "%s", what);
        fail_unless (gst_video_region_of_interest_meta_get_param (roi,
                "landmark-range") == NULL, "%s: ranged", what);
      }
      gst_buffer_unref (out);
    }
    count_messages (bus, &warnings, &errors);
    fail_unless (errors == 0, "%s: %u errors", what, errors);
    fail_unless (warnings <= 1, "%s: %u warnings", what, warnings);
    gst_element_set_bus (h->element, NULL);
    gst_object_unref (bus);
    gst_harness_teardown (h);
    /* one whole JSON line per frame, whatever the metadata held */
    if (log)
      fail_unless_equals_int (count_log_lines (log), G_N_ELEMENTS (sent) + 1);
    g_free (log);
    g_free (what);
  }
  g_print ("%s: %u metadata cases of 7 frames, no crash, at most one "
      "warning each\n", name, (guint) N_META_CASES);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Properties set from another thread while frames flow                */
/* ------------------------------------------------------------------ */

/* String properties get only values known to be valid (a bad file is an
 * error by design, tested in the element tests); others are skipped. */
typedef struct
{
  const gchar *element, *property;
  const gchar *values[5];
} StringValues;

static const StringValues string_values[] = {
  {"labsegment", "palette", {NULL, LANDMARK_DEFAULT_PALETTE,
              GST_TEST_FILES_PATH "/palettes/good-alt.json",
          GST_TEST_FILES_PATH "/palettes/lightness.json", NULL}},
  {"blobroundness", "classes", {NULL, "red", "red,green", "blue,pink,yellow",
          NULL}},
  {"ipmrange", "calibration", {NULL, "",
              GST_TEST_FILES_PATH "/calibration/cam640.yaml",
          GST_TEST_FILES_PATH "/calibration/cam640-distorted.xml", NULL}},
  {"ipmrange", "map", {NULL, MAP_FILE, NULL}},
  {"beacondetect", "map", {NULL, MAP_FILE, NULL}},
  {"trilaterate", "map", {MAP_FILE, NULL}},
  {"landmarkoverlay", "map", {NULL, MAP_FILE, NULL}},
};

static const StringValues *
string_values_for (const gchar * element, const gchar * property)
{
  guint i;
  for (i = 0; i < G_N_ELEMENTS (string_values); i++)
    if (!strcmp (string_values[i].element, element) &&
        !strcmp (string_values[i].property, property))
      return &string_values[i];
  return NULL;
}

/* Properties a thread may set while PLAYING: writable, not construct-only,
 * not restricted to READY or PAUSED, not GstObject's name and parent, and
 * for strings only those with known valid values. */
static GPtrArray *
stress_properties (GstElement * e, GString * skipped)
{
  guint n, i;
  GParamSpec **specs =
      g_object_class_list_properties (G_OBJECT_GET_CLASS (e), &n);
  GPtrArray *out = g_ptr_array_new ();
  for (i = 0; i < n; i++) {
    GParamSpec *p = specs[i];
    GType t = G_PARAM_SPEC_VALUE_TYPE (p);
    const gchar *why = NULL;
    if (p->owner_type == GST_TYPE_OBJECT)
      continue;
    if (!(p->flags & G_PARAM_WRITABLE) || (p->flags & G_PARAM_CONSTRUCT_ONLY))
      why = "read-only";
    else if (p->flags & (GST_PARAM_MUTABLE_READY | GST_PARAM_MUTABLE_PAUSED))
      why = "not mutable in PLAYING";
    else if (t == G_TYPE_STRING && !string_values_for (factory_name (e),
            p->name))
      why = "string without known valid values";
    else if (t != G_TYPE_STRING && t != G_TYPE_BOOLEAN && t != G_TYPE_INT &&
        t != G_TYPE_UINT && t != G_TYPE_INT64 && t != G_TYPE_UINT64 &&
        t != G_TYPE_DOUBLE && t != G_TYPE_FLOAT && !G_TYPE_IS_ENUM (t))
      why = "type not handled";
    if (why)
      g_string_append_printf (skipped, " %s (%s)", p->name, why);
    else
      g_ptr_array_add (out, p);
  }
  g_free (specs);
  return out;
}

/* A random value in a number's range: the minimum, the maximum, the
 * default, or uniform between the minimum and a few times the default
 * (uniform over the whole range of a G_MAXDOUBLE limit would almost
 * always give ~1e308). */
static gdouble
random_number (GRand * r, gdouble lo, gdouble hi, gdouble def)
{
  gdouble top;
  switch (g_rand_int_range (r, 0, 8)) {
    case 0:
      return lo;
    case 1:
      return hi;
    case 2:
      return def;
    default:
      top = MIN (hi, MAX (lo, fabs (def) * 4 + 10));
      return lo + g_rand_double (r) * (top - lo);
  }
}

static void
random_value (GRand * r, GstElement * e, GParamSpec * p, GValue * v)
{
  GType t = G_PARAM_SPEC_VALUE_TYPE (p);
  g_value_init (v, t);
  if (t == G_TYPE_BOOLEAN) {
    g_value_set_boolean (v, g_rand_boolean (r));
  } else if (t == G_TYPE_INT) {
    GParamSpecInt *s = G_PARAM_SPEC_INT (p);
    g_value_set_int (v, (gint) CLAMP (random_number (r, s->minimum,
                s->maximum, s->default_value), s->minimum, s->maximum));
  } else if (t == G_TYPE_UINT) {
    GParamSpecUInt *s = G_PARAM_SPEC_UINT (p);
    g_value_set_uint (v, (guint) CLAMP (random_number (r, s->minimum,
                s->maximum, s->default_value), s->minimum, s->maximum));
  } else if (t == G_TYPE_INT64) {
    GParamSpecInt64 *s = G_PARAM_SPEC_INT64 (p);
    g_value_set_int64 (v, CLAMP ((gint64) random_number (r, s->minimum,
                s->maximum, s->default_value), s->minimum, s->maximum));
  } else if (t == G_TYPE_UINT64) {
    GParamSpecUInt64 *s = G_PARAM_SPEC_UINT64 (p);
    gdouble x = random_number (r, s->minimum, s->maximum, s->default_value);
    g_value_set_uint64 (v, x >= (gdouble) s->maximum ? s->maximum :
        MAX ((guint64) x, s->minimum));
  } else if (t == G_TYPE_DOUBLE) {
    GParamSpecDouble *s = G_PARAM_SPEC_DOUBLE (p);
    g_value_set_double (v, CLAMP (random_number (r, s->minimum, s->maximum,
                s->default_value), s->minimum, s->maximum));
  } else if (t == G_TYPE_FLOAT) {
    GParamSpecFloat *s = G_PARAM_SPEC_FLOAT (p);
    g_value_set_float (v, CLAMP (random_number (r, s->minimum, s->maximum,
                s->default_value), s->minimum, s->maximum));
  } else if (G_TYPE_IS_ENUM (t)) {
    GEnumClass *k = G_PARAM_SPEC_ENUM (p)->enum_class;
    g_value_set_enum (v, k->values[g_rand_int_range (r, 0,
                k->n_values)].value);
  } else if (t == G_TYPE_STRING) {
    const StringValues *sv = string_values_for (factory_name (e), p->name);
    guint n;
    /* values[0] may be NULL (the default); a NULL after it ends the list */
    for (n = 1; n < G_N_ELEMENTS (sv->values) && sv->values[n]; n++);
    g_value_set_string (v, sv->values[g_rand_int_range (r, 0, n)]);
  } else {
    g_assert_not_reached ();
  }
}

typedef struct
{
  GstElement *element;
  GPtrArray *props;
  volatile gint stop;
  guint sets;
  guint32 seed;
} Stress;

static gpointer
stress_thread (gpointer data)
{
  Stress *st = data;
  GRand *r = g_rand_new_with_seed (st->seed);
  while (!g_atomic_int_get (&st->stop)) {
    GParamSpec *p = g_ptr_array_index (st->props,
        g_rand_int_range (r, 0, st->props->len));
    GValue v = G_VALUE_INIT;
    random_value (r, st->element, p, &v);
    g_object_set_property (G_OBJECT (st->element), p->name, &v);
    g_value_unset (&v);
    st->sets++;
    /* leave the streaming thread a core on a shared machine */
    g_usleep (50);
  }
  g_rand_free (r);
  return NULL;
}

#define STRESS_FRAMES 220

/* Every settable property set from another thread, to random valid
 * values, while 220 frames flow: each comes out, in order. */
LANDMARK_TEST_LOOP ("properties", test_element_property_stress,
    LANDMARK_CHECK_PER_ELEMENT)
{
  const gchar *name = element_name (__i__);
  GstHarness *h = harness_for (name);
  GString *skipped = g_string_new (NULL);
  Stress st = { h->element, NULL, 0, 0, 0x5eed + __i__ };
  GstVideoInfo info;
  GThread *thread;
  Disc d = disc_at (160, 120, 0.6, 0.7);
  gint64 t0;
  guint i, j;

  /* values for a property the element no longer has would quietly test
   * nothing */
  for (i = 0; i < G_N_ELEMENTS (string_values); i++)
    if (!strcmp (string_values[i].element, name))
      fail_unless (g_object_class_find_property (G_OBJECT_GET_CLASS
              (h->element), string_values[i].property) != NULL,
          "%s has no property %s", name, string_values[i].property);
  st.props = stress_properties (h->element, skipped);
  fail_unless (st.props->len > 0, "%s: no property to set", name);
  video_info_init (&info, "BGRx", 160, 120);
  set_caps (h, &info);
  t0 = g_get_monotonic_time ();
  thread = g_thread_new ("stress", stress_thread, &st);
  for (i = 0; i < STRESS_FRAMES; i += 10) {
    Sent sent[10];
    for (j = 0; j < 10; j++) {
      GstBuffer *b = frame_new (&info, FALSE, &d, i + j);
      add_all_meta (b, 160, 120, &d);
      /* bytes not compared: properties may make an element draw
       * (labsegment output=labels) */
      push_frame (h, b, FALSE, &sent[j]);
    }
    pull_sent (h, sent, 10, NULL, NULL, name);
  }
  g_atomic_int_set (&st.stop, 1);
  g_thread_join (thread);
  g_print ("%s: %u frames while %u properties were set %u times "
      "(%.2f s); not set:%s\n", name, STRESS_FRAMES, st.props->len, st.sets,
      (g_get_monotonic_time () - t0) / 1e6, skipped->len ? skipped->str :
      " none");
  g_ptr_array_unref (st.props);
  g_string_free (skipped, TRUE);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* NULL -> PLAYING -> NULL                                             */
/* ------------------------------------------------------------------ */

#define CYCLES 1000
#define PUSH_EVERY 10

/* A state cycle costs well under a millisecond here (ipmrange once built a
 * 640x480 lookup table twice per start: 55 ms); the cost is printed for
 * people to watch, not asserted. */

/* CYCLES times NULL -> PLAYING -> NULL; every PUSH_EVERY-th cycle a frame
 * goes through (stream-start, caps and segment again: a stopped element
 * forgets them). Prints the time of the cycles with and without a frame. */
static void
cycle (GstHarness * h, const gchar * what)
{
  GstVideoInfo info;
  Disc d = disc_at (64, 48, 0.6, 0.7);
  gint64 t0 = g_get_monotonic_time (), with_frame = 0;
  gdouble total;
  guint i;

  video_info_init (&info, "BGRx", 64, 48);
  for (i = 0; i < CYCLES; i++) {
    fail_unless (gst_element_set_state (h->element, GST_STATE_NULL) ==
        GST_STATE_CHANGE_SUCCESS, "%s: cycle %u: NULL", what, i);
    fail_unless (gst_element_set_state (h->element, GST_STATE_PLAYING) ==
        GST_STATE_CHANGE_SUCCESS, "%s: cycle %u: PLAYING", what, i);
    if (i % PUSH_EVERY == 0) {
      gchar *id = g_strdup_printf ("robustness-%u", i);
      gint64 t1 = g_get_monotonic_time ();
      Sent sent;
      fail_unless (gst_harness_push_event (h, gst_event_new_stream_start
              (id)));
      g_free (id);
      set_caps (h, &info);
      push_frame (h, frame_new (&info, FALSE, &d, i), FALSE, &sent);
      pull_sent (h, &sent, 1, NULL, NULL, what);
      with_frame += g_get_monotonic_time () - t1;
    }
  }
  fail_unless (gst_element_set_state (h->element, GST_STATE_NULL) ==
      GST_STATE_CHANGE_SUCCESS);
  total = (g_get_monotonic_time () - t0) / 1e3;
  g_print ("%s: %u NULL-PLAYING-NULL cycles in %.2f s: %.3f ms per cycle; "
      "the %u first frames after a start took %.2f ms each\n", what, CYCLES,
      total / 1e3, (total - with_frame / 1e3) / CYCLES, CYCLES / PUSH_EVERY,
      with_frame / 1e3 / (CYCLES / PUSH_EVERY));
  /* the figure is printed, not asserted: speed lives in benchmarks */
}

LANDMARK_TEST_LOOP ("states", test_element_state_cycles,
    LANDMARK_CHECK_PER_ELEMENT)
{
  const gchar *name = element_name (__i__);
  GstHarness *h = harness_for (name);
  cycle (h, name);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("states", test_chain_state_cycles)
{
  GstHarness *h = chain_harness ("", NULL);
  cycle (h, "chain");
  gst_harness_teardown (h);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */

static void
suite_setup (void)
{
  /* load the plugin so its metas are registered by name */
  GstPlugin *plugin = gst_plugin_load_by_name (PLUGIN_NAME);
  g_assert (plugin != NULL);
  gst_object_unref (plugin);
  load_red ();
  landmark_check_tmp_dir_setup ();
}

static void
suite_teardown (void)
{
  landmark_check_tmp_dir_teardown ();
}

static gint
count_elements (void)
{
  element_names = plugin_element_names ();
  return g_list_length (element_names);
}

/* 3840x2160 frames, and labsegment rebuilding its class table for each
 * max-distance a thread sets, take several seconds on a shared 2-core
 * machine: more than check's 20 s default when it is busy */
LANDMARK_CHECK_MAIN (robustness, .setup = suite_setup,
    .teardown = suite_teardown, .timeout = 120, .elements = count_elements);
