/* Unit tests of labsegment.
 *
 * Every expectation here is computed independently of the element: frames
 * are laid out byte by byte by hand (no GStreamer pack functions), colours
 * are classified with this file's own sRGB -> CIE L*a*b* conversion (the
 * IEC 61966-2-1 matrix and D65 white, not the element's constants) against
 * the palette values read from the JSON files, and YUV frames use this
 * file's own Y'CbCr conversion (BT.601 or BT.709, limited or full range, as
 * the caps say). Test colours are chosen far from every decision boundary;
 * each expectation asserts that margin, so a change of the built-in palette
 * that makes a colour ambiguous fails loudly here rather than silently
 * changing what is tested.
 *
 * The labels meta is read as applications do: gst_buffer_get_custom_meta()
 * by name, then the GstStructure fields. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <json-glib/json-glib.h>

#include <math.h>
#include <string.h>

#define PALETTES GST_TEST_FILES_PATH "/palettes/"
#define META_NAME "GstLandmarkLabelsMeta"
#define MAX_CLASSES 64
/* Smallest Delta E between a test colour's nearest and second-nearest
 * reference (and between its distance and max-distance). */
#define MIN_MARGIN 2.0
#define DEFAULT_MAX_DISTANCE 1000.0

/* ------------------------------------------------------------------ */
/* Reference colour maths, written for these tests                    */
/* ------------------------------------------------------------------ */

typedef struct
{
  guint8 r, g, b;
} Rgb;

typedef struct
{
  gchar *name;
  gdouble lab[3];
  gboolean marker;
} RefClass;

typedef struct
{
  guint n;
  RefClass cls[MAX_CLASSES];
} RefPalette;

static void
ref_palette_load (const gchar * path, RefPalette * p)
{
  JsonParser *parser = json_parser_new ();
  GError *err = NULL;
  JsonObject *root;
  JsonArray *classes;
  guint i, j;

  fail_unless (json_parser_load_from_file (parser, path, &err),
      "%s: %s", path, err ? err->message : "?");
  root = json_node_get_object (json_parser_get_root (parser));
  classes = json_object_get_array_member (root, "classes");
  p->n = json_array_get_length (classes);
  fail_unless (p->n > 0 && p->n <= MAX_CLASSES);
  for (i = 0; i < p->n; i++) {
    JsonObject *c = json_array_get_object_element (classes, i);
    JsonArray *lab = json_object_get_array_member (c, "lab");
    p->cls[i].name = g_strdup (json_object_get_string_member (c, "name"));
    for (j = 0; j < 3; j++)
      p->cls[i].lab[j] = json_array_get_double_element (lab, j);
    p->cls[i].marker = json_object_has_member (c, "marker") ?
        json_object_get_boolean_member (c, "marker") : TRUE;
  }
  g_object_unref (parser);
}

static void
ref_palette_clear (RefPalette * p)
{
  guint i;
  for (i = 0; i < p->n; i++)
    g_free (p->cls[i].name);
  p->n = 0;
}

/* label (1-based) of the class called `name`; fails if absent */
static guint
ref_label (const RefPalette * p, const gchar * name)
{
  guint i;
  for (i = 0; i < p->n; i++)
    if (!strcmp (p->cls[i].name, name))
      return i + 1;
  fail ("class %s is not in the palette", name);
  return 0;
}

static gdouble
srgb_decode (gdouble v)
{
  return v <= 0.04045 ? v / 12.92 : pow ((v + 0.055) / 1.055, 2.4);
}

static gdouble
cie_f (gdouble t)
{
  const gdouble d = 6.0 / 29.0;
  return t > d * d * d ? cbrt (t) : t / (3.0 * d * d) + 4.0 / 29.0;
}

/* gamma-encoded sRGB in [0, 1] -> CIE L*a*b* (D65) */
static void
rgb01_to_lab (const gdouble rgb[3], gdouble lab[3])
{
  const gdouble r = srgb_decode (rgb[0]), g = srgb_decode (rgb[1]),
      b = srgb_decode (rgb[2]);
  const gdouble x = (0.4124564 * r + 0.3575761 * g + 0.1804375 * b) / 0.95047;
  const gdouble y = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
  const gdouble z = (0.0193339 * r + 0.1191920 * g + 0.9503041 * b) / 1.08883;
  lab[0] = 116.0 * cie_f (y) - 16.0;
  lab[1] = 500.0 * (cie_f (x) - cie_f (y));
  lab[2] = 200.0 * (cie_f (y) - cie_f (z));
}

static guint8
clamp8 (gdouble v)
{
  return (guint8) CLAMP (lround (v), 0, 255);
}

static gdouble
clamp01 (gdouble v)
{
  return CLAMP (v, 0.0, 1.0);
}

/* A Y'CbCr encoding: luma coefficients and range. */
typedef struct
{
  gdouble kr, kb;
  gboolean full_range;
} YuvModel;

/* the default colorimetry of SD YUV caps */
static const YuvModel bt601 = { 0.299, 0.114, FALSE };
/* the default of HD YUV caps */
static const YuvModel bt709 = { 0.2126, 0.0722, FALSE };
/* JPEG-style full range */
static const YuvModel bt601_full = { 0.299, 0.114, TRUE };

static void
rgb_to_yuv (const YuvModel * m, const Rgb * c, guint8 yuv[3])
{
  const gdouble r = c->r / 255.0, g = c->g / 255.0, b = c->b / 255.0;
  const gdouble y = m->kr * r + (1.0 - m->kr - m->kb) * g + m->kb * b;
  const gdouble cb = (b - y) / (2.0 * (1.0 - m->kb));
  const gdouble cr = (r - y) / (2.0 * (1.0 - m->kr));
  const gdouble ys = m->full_range ? 255.0 : 219.0;
  const gdouble yo = m->full_range ? 0.0 : 16.0;
  const gdouble cs = m->full_range ? 255.0 : 224.0;
  yuv[0] = clamp8 (yo + ys * y);
  yuv[1] = clamp8 (128.0 + cs * cb);
  yuv[2] = clamp8 (128.0 + cs * cr);
}

static void
yuv_to_rgb01 (const YuvModel * m, const guint8 yuv[3], gdouble rgb[3])
{
  const gdouble ys = m->full_range ? 255.0 : 219.0;
  const gdouble yo = m->full_range ? 0.0 : 16.0;
  const gdouble cs = m->full_range ? 255.0 : 224.0;
  const gdouble y = (yuv[0] - yo) / ys;
  const gdouble cb = (yuv[1] - 128.0) / cs, cr = (yuv[2] - 128.0) / cs;
  const gdouble r = y + 2.0 * (1.0 - m->kr) * cr;
  const gdouble b = y + 2.0 * (1.0 - m->kb) * cb;
  rgb[0] = clamp01 (r);
  rgb[1] = clamp01 ((y - m->kr * r - m->kb * b) / (1.0 - m->kr - m->kb));
  rgb[2] = clamp01 (b);
}

/* luma code value of an 0xRRGGBB colour, BT.601 limited range */
static gdouble
luma601 (guint rgb)
{
  const gdouble r = ((rgb >> 16) & 0xff) / 255.0,
      g = ((rgb >> 8) & 0xff) / 255.0, b = (rgb & 0xff) / 255.0;
  return 16.0 + 219.0 * (0.299 * r + 0.587 * g + 0.114 * b);
}

/* Nearest class (label 1..n, 0: none within max_distance) among the classes
 * with active[k] (NULL: all); ties go to the lower index. `gap` receives the
 * distance to the runner-up minus the best, `best` the best distance. */
static guint
ref_nearest (const RefPalette * p, const gdouble lab[3],
    const gboolean * active, gboolean use_lightness, gdouble max_distance,
    gdouble * gap, gdouble * best)
{
  gdouble d1 = G_MAXDOUBLE, d2 = G_MAXDOUBLE;
  guint k, k1 = 0;

  for (k = 0; k < p->n; k++) {
    const gdouble dl = use_lightness ? lab[0] - p->cls[k].lab[0] : 0.0;
    const gdouble da = lab[1] - p->cls[k].lab[1];
    const gdouble db = lab[2] - p->cls[k].lab[2];
    const gdouble d = sqrt (dl * dl + da * da + db * db);
    if (active && !active[k])
      continue;
    if (d < d1) {
      d2 = d1;
      d1 = d;
      k1 = k + 1;
    } else if (d < d2) {
      d2 = d;
    }
  }
  if (gap)
    *gap = k1 == 0 || d2 == G_MAXDOUBLE ? G_MAXDOUBLE : d2 - d1;
  if (best)
    *best = d1;
  if (k1 == 0 || d1 > max_distance)
    return 0;
  return k1;
}

/* As ref_nearest, and asserts that the choice is clear-cut. */
static guint
ref_classify (const RefPalette * p, const gdouble lab[3],
    const gboolean * active, gboolean use_lightness, gdouble max_distance,
    const gchar * what)
{
  gdouble gap, best;
  guint l = ref_nearest (p, lab, active, use_lightness, max_distance, &gap,
      &best);
  fail_unless (gap >= MIN_MARGIN, "test colour %s is ambiguous: the two "
      "nearest classes are %.2f Delta E apart", what, gap);
  fail_unless (fabs (best - max_distance) >= MIN_MARGIN || best == G_MAXDOUBLE,
      "test colour %s is %.2f from its nearest class, too close to "
      "max-distance %.2f", what, best, max_distance);
  return l;
}

/* ------------------------------------------------------------------ */
/* Formats and hand-made frames                                       */
/* ------------------------------------------------------------------ */

typedef struct
{
  GstVideoFormat format;
  gboolean yuv;
  gint pstride;                 /* packed RGB: bytes per pixel */
  gint off[3];                  /* packed RGB: byte offsets of R, G, B */
  gint filler;                  /* packed RGB: x or A byte, -1 if none */
} FormatDesc;

static const FormatDesc formats[] = {
  {GST_VIDEO_FORMAT_RGB, FALSE, 3, {0, 1, 2}, -1},
  {GST_VIDEO_FORMAT_BGR, FALSE, 3, {2, 1, 0}, -1},
  {GST_VIDEO_FORMAT_RGBx, FALSE, 4, {0, 1, 2}, 3},
  {GST_VIDEO_FORMAT_BGRx, FALSE, 4, {2, 1, 0}, 3},
  {GST_VIDEO_FORMAT_xRGB, FALSE, 4, {1, 2, 3}, 0},
  {GST_VIDEO_FORMAT_xBGR, FALSE, 4, {3, 2, 1}, 0},
  {GST_VIDEO_FORMAT_RGBA, FALSE, 4, {0, 1, 2}, 3},
  {GST_VIDEO_FORMAT_BGRA, FALSE, 4, {2, 1, 0}, 3},
  {GST_VIDEO_FORMAT_I420, TRUE, 0, {0, 0, 0}, -1},
  {GST_VIDEO_FORMAT_NV12, TRUE, 0, {0, 0, 0}, -1},
  {GST_VIDEO_FORMAT_YUY2, TRUE, 0, {0, 0, 0}, -1},
};

#define FMT_RGB (&formats[0])
#define FMT_BGRx (&formats[3])
#define FMT_I420 (&formats[8])
#define FMT_NV12 (&formats[9])
#define FMT_YUY2 (&formats[10])

/* Colours near the built-in references; builtin_names[] is the class each
 * must fall in (checked by computation in check_builtin_colour_choice()). */
static const Rgb builtin_colours[] = {
  {170, 60, 40},                /* red */
  {128, 128, 128},              /* grey */
  {235, 235, 235},              /* white */
  {30, 80, 200},                /* blue */
  {230, 230, 60},               /* yellow */
  {130, 210, 100},              /* green */
  {255, 105, 180},              /* pink */
  {0, 255, 0},                  /* saturated green: ~53 from "green" */
};

static const gchar *builtin_names[] = {
  "red", "grey", "white", "blue", "yellow", "green", "pink", "green",
};

enum
{ C_RED, C_GREY, C_WHITE, C_BLUE, C_YELLOW, C_GREEN, C_PINK, C_FAR_GREEN };

/* A frame: one colour index per pixel. */
typedef struct
{
  const FormatDesc *fmt;
  guint width, height;
  guint8 *index;
  const Rgb *colours;
  guint n_colours;
  const YuvModel *yuv;          /* YUV formats: how colours are encoded */
} Picture;

static void
picture_init (Picture * pic, const FormatDesc * fmt, guint w, guint h,
    const Rgb * colours, guint n_colours)
{
  pic->fmt = fmt;
  pic->width = w;
  pic->height = h;
  pic->index = g_new0 (guint8, (gsize) w * h);
  pic->colours = colours;
  pic->n_colours = n_colours;
  pic->yuv = &bt601;
}

static void
picture_clear (Picture * pic)
{
  g_clear_pointer (&pic->index, g_free);
}

/* Fills a rectangle (clipped to the frame) with colour c. */
static void
picture_fill (Picture * pic, guint x0, guint y0, guint w, guint h, guint8 c)
{
  guint x, y;
  for (y = y0; y < y0 + h && y < pic->height; y++)
    for (x = x0; x < x0 + w && x < pic->width; x++)
      pic->index[y * pic->width + x] = c;
}

/* Colour blocks of 2x2 pixels (aligned, so chroma subsampling keeps them
 * exact) cycling through `colours`; neighbouring rows differ, so a wrong
 * stride shows. */
static void
picture_pattern (Picture * pic, const guint8 * cycle, guint n)
{
  guint x, y;
  for (y = 0; y < pic->height; y++)
    for (x = 0; x < pic->width; x++)
      pic->index[y * pic->width + x] = cycle[((x / 2) + 3 * (y / 2)) % n];
}

static guint
plane_height (GstVideoFormat f, guint plane, guint h)
{
  if (plane > 0 && (f == GST_VIDEO_FORMAT_I420 || f == GST_VIDEO_FORMAT_NV12))
    return (h + 1) / 2;
  return h;
}

static guint32 garbage_state = 0x12345678;

static guint8
garbage (void)
{
  /* xorshift32 */
  garbage_state ^= garbage_state << 13;
  garbage_state ^= garbage_state >> 17;
  garbage_state ^= garbage_state << 5;
  return (guint8) garbage_state;
}

/* Writes the picture into memory laid out with the given plane offsets
 * and strides. */
static void
picture_paint (const Picture * pic, guint8 * data, const gsize * offset,
    const gint * stride)
{
  const FormatDesc *f = pic->fmt;
  const guint w = pic->width, h = pic->height;
  guint8 *yuv = g_new0 (guint8, 3 * pic->n_colours);
  guint x, y, i;

  for (i = 0; i < pic->n_colours; i++)
    rgb_to_yuv (pic->yuv, &pic->colours[i], yuv + 3 * i);

  if (!f->yuv) {
    for (y = 0; y < h; y++) {
      for (x = 0; x < w; x++) {
        const Rgb *c = &pic->colours[pic->index[y * w + x]];
        guint8 *p = data + offset[0] + (gsize) y * stride[0] + x * f->pstride;
        p[f->off[0]] = c->r;
        p[f->off[1]] = c->g;
        p[f->off[2]] = c->b;
        if (f->filler >= 0)
          p[f->filler] = garbage ();    /* x / alpha must not matter */
      }
    }
  } else if (f->format == GST_VIDEO_FORMAT_YUY2) {
    for (y = 0; y < h; y++) {
      guint8 *row = data + offset[0] + (gsize) y * stride[0];
      for (x = 0; x < w; x++)
        row[x * 2] = yuv[3 * pic->index[y * w + x]];
      for (x = 0; x < w; x += 2) {
        const guint8 *c = yuv + 3 * pic->index[y * w + x];
        row[(x / 2) * 4 + 1] = c[1];
        row[(x / 2) * 4 + 3] = c[2];
      }
    }
  } else {
    const gboolean nv12 = f->format == GST_VIDEO_FORMAT_NV12;
    for (y = 0; y < h; y++)
      for (x = 0; x < w; x++)
        data[offset[0] + (gsize) y * stride[0] + x] =
            yuv[3 * pic->index[y * w + x]];
    for (y = 0; y < (h + 1) / 2; y++) {
      for (x = 0; x < (w + 1) / 2; x++) {
        const guint8 *c = yuv + 3 * pic->index[(2 * y) * w + 2 * x];
        if (nv12) {
          guint8 *uv = data + offset[1] + (gsize) y * stride[1] + 2 * x;
          uv[0] = c[1];
          uv[1] = c[2];
        } else {
          data[offset[1] + (gsize) y * stride[1] + x] = c[1];
          data[offset[2] + (gsize) y * stride[2] + x] = c[2];
        }
      }
    }
  }
  g_free (yuv);
}

/* Builds the buffer for a picture. pad == 0: GStreamer's default layout
 * for the caps, no video meta. pad > 0: every row `pad` bytes longer and
 * gaps before, between and after the planes, described by a GstVideoMeta.
 * Every byte that is not a pixel is garbage. `caps_info` receives the
 * video info of the caps to use. */
static GstBuffer *
picture_to_buffer (const Picture * pic, guint pad, GstVideoInfo * caps_info)
{
  GstVideoInfo info;
  gsize offset[GST_VIDEO_MAX_PLANES] = { 0, };
  gint stride[GST_VIDEO_MAX_PLANES] = { 0, };
  gsize size, i;
  guint p, n_planes;
  GstBuffer *buf;
  GstMapInfo map;

  fail_unless (gst_video_info_set_format (&info, pic->fmt->format,
          pic->width, pic->height));
  GST_VIDEO_INFO_FPS_N (&info) = 25;
  GST_VIDEO_INFO_FPS_D (&info) = 1;
  if (pic->fmt->yuv) {
    gdouble kr = 0, kb = 0;
    /* full range must be asked for; the matrix must be GStreamer's
     * default for the frame size, which is what the caps of most sources
     * say (BT.601 for SD, BT.709 for HD) */
    if (pic->yuv->full_range)
      info.colorimetry.range = GST_VIDEO_COLOR_RANGE_0_255;
    fail_unless (gst_video_color_matrix_get_Kr_Kb (info.colorimetry.matrix,
            &kr, &kb));
    fail_unless (kr == pic->yuv->kr && kb == pic->yuv->kb,
        "%ux%u: the caps say Kr=%g Kb=%g, the test frame uses %g %g",
        pic->width, pic->height, kr, kb, pic->yuv->kr, pic->yuv->kb);
  }
  *caps_info = info;

  n_planes = GST_VIDEO_INFO_N_PLANES (&info);
  if (pad == 0) {
    for (p = 0; p < n_planes; p++) {
      offset[p] = GST_VIDEO_INFO_PLANE_OFFSET (&info, p);
      stride[p] = GST_VIDEO_INFO_PLANE_STRIDE (&info, p);
    }
    size = GST_VIDEO_INFO_SIZE (&info);
  } else {
    gsize pos = 16;
    for (p = 0; p < n_planes; p++) {
      stride[p] = GST_VIDEO_INFO_PLANE_STRIDE (&info, p) + pad;
      offset[p] = pos;
      pos += (gsize) stride[p] * plane_height (pic->fmt->format, p,
          pic->height) + 8;
    }
    size = pos + 24;
  }

  buf = gst_buffer_new_allocate (NULL, size, NULL);
  fail_unless (gst_buffer_map (buf, &map, GST_MAP_WRITE));
  for (i = 0; i < size; i++)
    map.data[i] = garbage ();
  picture_paint (pic, map.data, offset, stride);
  gst_buffer_unmap (buf, &map);

  if (pad > 0)
    gst_buffer_add_video_meta_full (buf, GST_VIDEO_FRAME_FLAG_NONE,
        pic->fmt->format, pic->width, pic->height, n_planes, offset, stride);
  return buf;
}

/* ------------------------------------------------------------------ */
/* Expected results                                                   */
/* ------------------------------------------------------------------ */

typedef struct
{
  const RefPalette *palette;
  guint min_class_pixels;
  gdouble max_distance;
  gboolean use_lightness;
  gboolean rare_unlabelled;     /* rare-classes=unlabelled, else nearest */
} Config;

typedef struct
{
  guint8 first[256];            /* per colour index: nearest over all */
  guint8 final[256];            /* per colour index: after the rule */
  guint first_counts[MAX_CLASSES + 1];
  guint final_counts[MAX_CLASSES + 1];
  gboolean active[MAX_CLASSES];
} Expected;

/* The colour of a colour index as the element sees it: YUV frames carry
 * the rounded Y'CbCr code values. */
static void
picture_colour_lab (const Picture * pic, guint i, gdouble lab[3])
{
  gdouble rgb[3];
  if (pic->fmt->yuv) {
    guint8 yuv[3];
    rgb_to_yuv (pic->yuv, &pic->colours[i], yuv);
    yuv_to_rgb01 (pic->yuv, yuv, rgb);
  } else {
    rgb[0] = pic->colours[i].r / 255.0;
    rgb[1] = pic->colours[i].g / 255.0;
    rgb[2] = pic->colours[i].b / 255.0;
  }
  rgb01_to_lab (rgb, lab);
}

/* The documented rule: first pass over all classes; classes with at least
 * min-class-pixels pixels stay active (0: all); pixels of other classes go
 * to the nearest active class within max-distance, else 0
 * (rare-classes=nearest), or get 0 (rare-classes=unlabelled). */
static void
expect_picture (const Picture * pic, const Config * cfg, Expected * e)
{
  const gsize npix = (gsize) pic->width * pic->height;
  gboolean used[256] = { FALSE, };
  gsize i;
  guint c, k;

  memset (e, 0, sizeof (*e));
  for (i = 0; i < npix; i++)
    used[pic->index[i]] = TRUE;

  for (c = 0; c < pic->n_colours; c++) {
    gdouble lab[3];
    gchar what[64];
    if (!used[c])
      continue;
    picture_colour_lab (pic, c, lab);
    g_snprintf (what, sizeof (what), "(%u,%u,%u)", pic->colours[c].r,
        pic->colours[c].g, pic->colours[c].b);
    e->first[c] = ref_classify (cfg->palette, lab, NULL, cfg->use_lightness,
        cfg->max_distance, what);
  }
  for (i = 0; i < npix; i++)
    e->first_counts[e->first[pic->index[i]]]++;
  for (k = 0; k < cfg->palette->n; k++)
    e->active[k] = cfg->min_class_pixels == 0 ||
        e->first_counts[k + 1] >= cfg->min_class_pixels;

  for (c = 0; c < pic->n_colours; c++) {
    gdouble lab[3];
    gchar what[64];
    const guint l = e->first[c];
    if (!used[c])
      continue;
    if (l == 0 || e->active[l - 1]) {
      e->final[c] = l;
      continue;
    }
    if (cfg->rare_unlabelled) {
      e->final[c] = 0;
      continue;
    }
    picture_colour_lab (pic, c, lab);
    g_snprintf (what, sizeof (what), "(%u,%u,%u) among active classes",
        pic->colours[c].r, pic->colours[c].g, pic->colours[c].b);
    e->final[c] = ref_classify (cfg->palette, lab, e->active,
        cfg->use_lightness, cfg->max_distance, what);
  }
  for (i = 0; i < npix; i++)
    e->final_counts[e->final[pic->index[i]]]++;
}

/* ------------------------------------------------------------------ */
/* Reading the labels meta as an application does                     */
/* ------------------------------------------------------------------ */

static const GstStructure *
labels_meta (GstBuffer * buf)
{
  GstCustomMeta *meta = gst_buffer_get_custom_meta (buf, META_NAME);
  fail_unless (meta != NULL, "no " META_NAME " on the buffer");
  return gst_custom_meta_get_structure (meta);
}

static const GValue *
array_value (const GstStructure * s, const gchar * field, guint i)
{
  const GValue *a = gst_structure_get_value (s, field);
  fail_unless (a != NULL && GST_VALUE_HOLDS_ARRAY (a),
      "field %s missing or not an array", field);
  fail_unless (i < gst_value_array_get_size (a), "%s[%u] out of range",
      field, i);
  return gst_value_array_get_value (a, i);
}

static guint
array_size (const GstStructure * s, const gchar * field)
{
  const GValue *a = gst_structure_get_value (s, field);
  fail_unless (a != NULL && GST_VALUE_HOLDS_ARRAY (a),
      "field %s missing or not an array", field);
  return gst_value_array_get_size (a);
}

static guint
array_uint (const GstStructure * s, const gchar * field, guint i)
{
  const GValue *v = array_value (s, field, i);
  fail_unless (G_VALUE_HOLDS_UINT (v), "%s[%u] is not a guint", field, i);
  return g_value_get_uint (v);
}

static gboolean
array_bool (const GstStructure * s, const gchar * field, guint i)
{
  const GValue *v = array_value (s, field, i);
  fail_unless (G_VALUE_HOLDS_BOOLEAN (v), "%s[%u] is not a boolean", field, i);
  return g_value_get_boolean (v);
}

static const gchar *
array_string (const GstStructure * s, const gchar * field, guint i)
{
  const GValue *v = array_value (s, field, i);
  fail_unless (G_VALUE_HOLDS_STRING (v), "%s[%u] is not a string", field, i);
  return g_value_get_string (v);
}

static guint
field_uint (const GstStructure * s, const gchar * field)
{
  guint v = 0;
  fail_unless (gst_structure_get_uint (s, field, &v), "no guint field %s",
      field);
  return v;
}

/* The label plane, mapped: labels of pixel (x, y) at data[y * stride + x]. */
typedef struct
{
  GstBuffer *plane;
  GstMapInfo map;
  guint width, height, stride;
} LabelPlane;

static void
label_plane_map (GstBuffer * buf, LabelPlane * lp)
{
  const GstStructure *s = labels_meta (buf);
  lp->plane = NULL;
  fail_unless (gst_structure_get (s, "labels", GST_TYPE_BUFFER, &lp->plane,
          NULL), "no GstBuffer field 'labels'");
  lp->width = field_uint (s, "width");
  lp->height = field_uint (s, "height");
  lp->stride = field_uint (s, "stride");
  fail_unless (lp->stride >= lp->width);
  fail_unless (gst_buffer_map (lp->plane, &lp->map, GST_MAP_READ));
  if (lp->height > 0)
    fail_unless (lp->map.size >= (gsize) lp->stride * (lp->height - 1) +
        lp->width, "label plane of %" G_GSIZE_FORMAT " bytes is too small",
        lp->map.size);
}

static void
label_plane_unmap (LabelPlane * lp)
{
  gst_buffer_unmap (lp->plane, &lp->map);
  gst_buffer_unref (lp->plane);
}

/* Every field of the labels meta against the expectation. */
static void
check_labels_meta (GstBuffer * out, const Picture * pic, const Config * cfg,
    const Expected * e)
{
  const GstStructure *s = labels_meta (out);
  const RefPalette *p = cfg->palette;
  LabelPlane lp;
  guint x, y, k, mismatches = 0;
  gdouble max_distance = -1;
  gboolean use_lightness = !cfg->use_lightness;

  label_plane_map (out, &lp);
  fail_unless_equals_int (lp.width, pic->width);
  fail_unless_equals_int (lp.height, pic->height);
  for (y = 0; y < pic->height; y++) {
    for (x = 0; x < pic->width; x++) {
      const guint8 c = pic->index[y * pic->width + x];
      const guint8 got = lp.map.data[(gsize) y * lp.stride + x];
      if (got != e->final[c] && mismatches++ == 0)
        GST_ERROR ("%s %ux%u: first mismatch at (%u,%u), colour (%u,%u,%u):"
            " label %u, expected %u", gst_video_format_to_string
            (pic->fmt->format), pic->width, pic->height, x, y,
            pic->colours[c].r, pic->colours[c].g, pic->colours[c].b, got,
            e->final[c]);
    }
  }
  label_plane_unmap (&lp);
  fail_unless (mismatches == 0, "%s %ux%u: %u of %u labels are wrong "
      "(first one in the log)", gst_video_format_to_string (pic->fmt->format),
      pic->width, pic->height, mismatches, pic->width * pic->height);

  fail_unless_equals_int (array_size (s, "class-names"), p->n);
  fail_unless_equals_int (array_size (s, "class-markers"), p->n);
  fail_unless_equals_int (array_size (s, "class-rgb"), p->n);
  fail_unless_equals_int (array_size (s, "class-counts"), p->n);
  fail_unless_equals_int (array_size (s, "class-active"), p->n);
  fail_unless_equals_int (array_size (s, "label-counts"), p->n);
  for (k = 0; k < p->n; k++) {
    fail_unless_equals_string (array_string (s, "class-names", k),
        p->cls[k].name);
    fail_unless_equals_int (array_bool (s, "class-markers", k),
        p->cls[k].marker);
    {
      /* the display colour of the reference, within rounding */
      const guint got = array_uint (s, "class-rgb", k);
      const guint want = landmark_check_lab_to_rgb24 (p->cls[k].lab);
      guint shift;
      fail_unless (got <= 0xffffff);
      for (shift = 0; shift <= 16; shift += 8)
        fail_unless (ABS ((gint) ((got >> shift) & 0xff) -
                (gint) ((want >> shift) & 0xff)) <= 2,
            "class-rgb[%s] = %06x, expected about %06x", p->cls[k].name, got,
            want);
    }
    fail_unless (array_uint (s, "class-counts", k) == e->first_counts[k + 1],
        "class-counts[%s] = %u, expected %u", p->cls[k].name,
        array_uint (s, "class-counts", k), e->first_counts[k + 1]);
    fail_unless (array_bool (s, "class-active", k) == e->active[k],
        "class-active[%s] = %d, expected %d", p->cls[k].name,
        array_bool (s, "class-active", k), e->active[k]);
    fail_unless (array_uint (s, "label-counts", k) == e->final_counts[k + 1],
        "label-counts[%s] = %u, expected %u", p->cls[k].name,
        array_uint (s, "label-counts", k), e->final_counts[k + 1]);
  }
  fail_unless_equals_int (field_uint (s, "unclassified"), e->final_counts[0]);
  fail_unless_equals_int (field_uint (s, "min-class-pixels"),
      cfg->min_class_pixels);
  fail_unless (gst_structure_get_double (s, "max-distance", &max_distance));
  fail_unless_equals_float (max_distance, cfg->max_distance);
  fail_unless (gst_structure_get_boolean (s, "use-lightness", &use_lightness));
  fail_unless_equals_int (use_lightness, cfg->use_lightness);
}

/* ------------------------------------------------------------------ */
/* Running the element                                                */
/* ------------------------------------------------------------------ */

static GstHarness *
harness_new (const gchar * palette_path, const Config * cfg)
{
  GstHarness *h = gst_harness_new ("labsegment");
  g_object_set (h->element, "min-class-pixels", cfg->min_class_pixels,
      "max-distance", cfg->max_distance, "use-lightness", cfg->use_lightness,
      NULL);
  gst_util_set_object_arg (G_OBJECT (h->element), "rare-classes",
      cfg->rare_unlabelled ? "unlabelled" : "nearest");
  if (palette_path)
    g_object_set (h->element, "palette", palette_path, NULL);
  return h;
}

static void
set_output (GstHarness * h, const gchar * nick)
{
  gst_util_set_object_arg (G_OBJECT (h->element), "output", nick);
}

/* Pushes one frame through a fresh element and returns the output buffer;
 * checks that the output caps are the input caps. `in_bytes` receives a
 * copy of the input buffer's memory. */
static GstBuffer *
run_picture (const Picture * pic, guint pad, const gchar * palette_path,
    const Config * cfg, const gchar * output, GBytes ** in_bytes)
{
  GstVideoInfo info;
  GstBuffer *in = picture_to_buffer (pic, pad, &info), *out;
  GstCaps *caps = gst_video_info_to_caps (&info), *out_caps;
  GstHarness *h = harness_new (palette_path, cfg);
  gpointer copy;
  gsize size;

  if (output)
    set_output (h, output);
  gst_harness_set_src_caps (h, gst_caps_ref (caps));
  gst_buffer_extract_dup (in, 0, gst_buffer_get_size (in), &copy, &size);
  if (in_bytes)
    *in_bytes = g_bytes_new_take (copy, size);
  else
    g_free (copy);

  GST_BUFFER_PTS (in) = 0;
  GST_BUFFER_DURATION (in) = GST_SECOND / 25;
  out = gst_harness_push_and_pull (h, in);
  fail_unless (out != NULL, "no output buffer");

  out_caps = gst_pad_get_current_caps (h->sinkpad);
  fail_unless (out_caps != NULL && gst_caps_is_equal (out_caps, caps),
      "output caps %" GST_PTR_FORMAT " differ from input %" GST_PTR_FORMAT,
      out_caps, caps);
  gst_caps_unref (out_caps);
  gst_caps_unref (caps);
  gst_harness_teardown (h);
  return out;
}

static void
check_same_bytes (GstBuffer * out, GBytes * in)
{
  gsize size;
  const guint8 *data = g_bytes_get_data (in, &size);
  GstMapInfo map;
  gsize i;

  fail_unless_equals_uint64 (gst_buffer_get_size (out), size);
  fail_unless (gst_buffer_map (out, &map, GST_MAP_READ));
  for (i = 0; i < size; i++)
    if (map.data[i] != data[i])
      break;
  gst_buffer_unmap (out, &map);
  fail_unless (i == size, "output=passthrough changed byte %" G_GSIZE_FORMAT
      " of %" G_GSIZE_FORMAT, i, size);
}

static RefPalette builtin;

static void
load_builtin (void)
{
  ref_palette_load (LANDMARK_DEFAULT_PALETTE, &builtin);
}

static void
clear_builtin (void)
{
  ref_palette_clear (&builtin);
}

static Config
builtin_config (guint min_class_pixels)
{
  Config cfg = { &builtin, min_class_pixels, DEFAULT_MAX_DISTANCE, TRUE,
    FALSE
  };
  return cfg;
}

/* The full check of one picture in passthrough mode: labels, every meta
 * field, unchanged video bytes. */
static void
segment_and_check (const Picture * pic, guint pad, const gchar * palette_path,
    const Config * cfg)
{
  GBytes *in_bytes = NULL;
  GstBuffer *out;
  Expected e;

  expect_picture (pic, cfg, &e);
  out = run_picture (pic, pad, palette_path, cfg, NULL, &in_bytes);
  check_labels_meta (out, pic, cfg, &e);
  check_same_bytes (out, in_bytes);
  g_bytes_unref (in_bytes);
  gst_buffer_unref (out);
}

/* The seven built-in colours, each checked against the class it was chosen
 * for, so the test frames cover every class. */
static const guint8 all_seven[] = {
  C_RED, C_GREY, C_WHITE, C_BLUE, C_YELLOW, C_GREEN, C_PINK,
};

static void
check_builtin_colour_choice (const FormatDesc * fmt)
{
  Picture pic;
  guint i;
  picture_init (&pic, fmt, 1, 1, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  for (i = 0; i < G_N_ELEMENTS (builtin_colours); i++) {
    gdouble lab[3];
    picture_colour_lab (&pic, i, lab);
    fail_unless_equals_int (ref_classify (&builtin, lab, NULL, TRUE,
            DEFAULT_MAX_DISTANCE, builtin_names[i]),
        ref_label (&builtin, builtin_names[i]));
  }
  picture_clear (&pic);
}

/* ------------------------------------------------------------------ */
/* Tests                                                              */
/* ------------------------------------------------------------------ */

/* Loop tests run once per entry of formats[]. */
LANDMARK_TEST_LOOP ("formats", test_format_passthrough, G_N_ELEMENTS (formats))
{
  const FormatDesc *fmt = &formats[__i__];
  Config cfg = builtin_config (0);
  Picture pic;

  check_builtin_colour_choice (fmt);
  picture_init (&pic, fmt, 64, 48, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_pattern (&pic, all_seven, G_N_ELEMENTS (all_seven));
  segment_and_check (&pic, 0, NULL, &cfg);
  picture_clear (&pic);
}

GST_END_TEST;

LANDMARK_TEST_LOOP ("formats", test_format_sizes, G_N_ELEMENTS (formats))
{
  static const guint sizes[][2] = {
    {1, 1}, {2, 2}, {3, 4}, {3, 5}, {3, 1}, {641, 479},
  };
  const FormatDesc *fmt = &formats[__i__];
  Config cfg = builtin_config (0);
  guint s;

  for (s = 0; s < G_N_ELEMENTS (sizes); s++) {
    Picture pic;
    GST_INFO ("%s %ux%u", gst_video_format_to_string (fmt->format),
        sizes[s][0], sizes[s][1]);
    picture_init (&pic, fmt, sizes[s][0], sizes[s][1], builtin_colours,
        G_N_ELEMENTS (builtin_colours));
    picture_pattern (&pic, all_seven, G_N_ELEMENTS (all_seven));
    segment_and_check (&pic, 0, NULL, &cfg);
    picture_clear (&pic);
  }
}

GST_END_TEST;

LANDMARK_TEST_LOOP ("formats", test_format_padded_strides,
    G_N_ELEMENTS (formats))
{
  static const guint pads[] = { 7, 64 };
  const FormatDesc *fmt = &formats[__i__];
  Config cfg = builtin_config (0);
  guint i;

  for (i = 0; i < G_N_ELEMENTS (pads); i++) {
    Picture pic;
    picture_init (&pic, fmt, 37, 22, builtin_colours,
        G_N_ELEMENTS (builtin_colours));
    picture_pattern (&pic, all_seven, G_N_ELEMENTS (all_seven));
    segment_and_check (&pic, pads[i], NULL, &cfg);
    picture_clear (&pic);
  }
}

GST_END_TEST;

/* output=labels: the frame shows the class colours (class-rgb), black for
 * label 0; labels themselves are unchanged by the mode. */
LANDMARK_TEST_LOOP ("formats", test_format_output_labels,
    G_N_ELEMENTS (formats))
{
  static const guint8 cycle[] = {
    C_RED, C_GREY, C_FAR_GREEN, C_WHITE, C_BLUE, C_YELLOW, C_GREEN, C_PINK,
  };
  const FormatDesc *fmt = &formats[__i__];
  /* max-distance 20: the saturated green becomes label 0 (black) */
  Config cfg = { &builtin, 0, 20.0, TRUE, FALSE };
  Picture pic;
  Expected e;
  GstBuffer *out;
  GstVideoInfo info;
  GstVideoFrame frame;
  LabelPlane lp;
  const GstStructure *s;
  guint x, y, bad = 0;

  picture_init (&pic, fmt, 38, 26, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_pattern (&pic, cycle, G_N_ELEMENTS (cycle));
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_FAR_GREEN], 0);
  out = run_picture (&pic, 0, NULL, &cfg, "labels", NULL);
  check_labels_meta (out, &pic, &cfg, &e);

  s = labels_meta (out);
  fail_unless (gst_video_info_set_format (&info, fmt->format, pic.width,
          pic.height));
  fail_unless (gst_video_frame_map (&frame, &info, out, GST_MAP_READ));
  label_plane_map (out, &lp);
  for (y = 0; y < pic.height; y++) {
    for (x = 0; x < pic.width; x++) {
      const guint l = lp.map.data[(gsize) y * lp.stride + x];
      const guint rgb = l ? array_uint (s, "class-rgb", l - 1) : 0;
      if (!fmt->yuv) {
        const guint8 *p = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (&frame,
            0) + (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (&frame, 0) +
            x * fmt->pstride;
        const guint got = (p[fmt->off[0]] << 16) | (p[fmt->off[1]] << 8) |
            p[fmt->off[2]];
        if (got != rgb && bad++ == 0)
          GST_ERROR ("(%u,%u) label %u: shows %06x, class-rgb %06x", x, y, l,
              got, rgb);
      } else {
        const guint8 *row = (const guint8 *)
            GST_VIDEO_FRAME_PLANE_DATA (&frame, 0) +
            (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (&frame, 0);
        const guint got = fmt->format == GST_VIDEO_FORMAT_YUY2 ?
            row[x * 2] : row[x];
        if (fabs (got - luma601 (rgb)) > 2.0 && bad++ == 0)
          GST_ERROR ("(%u,%u) label %u: luma %u, class-rgb %06x has %.1f", x,
              y, l, got, rgb, luma601 (rgb));
      }
    }
  }
  label_plane_unmap (&lp);
  gst_video_frame_unmap (&frame);
  fail_unless (bad == 0, "%s: %u pixels do not show their class colour "
      "(first one in the log)", gst_video_format_to_string (fmt->format), bad);
  gst_buffer_unref (out);
  picture_clear (&pic);
}

GST_END_TEST;

/* A large grey and a large blue region and a pink patch of N pixels. */
static void
dominance_picture (Picture * pic, const FormatDesc * fmt, guint * n_pink)
{
  picture_init (pic, fmt, 64, 48, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_fill (pic, 0, 0, 64, 24, C_GREY);
  picture_fill (pic, 0, 24, 64, 24, C_BLUE);
  picture_fill (pic, 20, 30, 6, 6, C_PINK);     /* 2x2-aligned */
  *n_pink = 36;
}

LANDMARK_TEST_LOOP ("rules", test_dominant_colour_rule, G_N_ELEMENTS (formats))
{
  const FormatDesc *fmt = &formats[__i__];
  const guint pink = ref_label (&builtin, "pink");
  Picture pic;
  guint n;
  Expected e;
  Config cfg;

  dominance_picture (&pic, fmt, &n);

  /* N < min-class-pixels: the patch goes to the nearest active class */
  cfg = builtin_config (n + 1);
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.first[C_PINK], pink);
  fail_unless (!e.active[pink - 1]);
  fail_unless (e.final[C_PINK] != pink && e.final[C_PINK] != 0);
  fail_unless_equals_int (e.first_counts[pink], n);
  GST_INFO ("pink patch expected as %s",
      builtin.cls[e.final[C_PINK] - 1].name);
  segment_and_check (&pic, 0, NULL, &cfg);

  /* rare-classes=unlabelled: the patch loses its label instead */
  cfg.rare_unlabelled = TRUE;
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_PINK], 0);
  segment_and_check (&pic, 0, NULL, &cfg);

  /* exactly min-class-pixels: the class counts */
  cfg = builtin_config (n);
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_PINK], pink);
  segment_and_check (&pic, 0, NULL, &cfg);

  /* the rule off */
  cfg = builtin_config (0);
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_PINK], pink);
  segment_and_check (&pic, 0, NULL, &cfg);

  picture_clear (&pic);
}

GST_END_TEST;

/* Many demoted pixels of two classes, in an odd-sized frame: the
 * relabelling must cover every one of them, wherever they are. */
LANDMARK_TEST_LOOP ("rules", test_dominant_colour_rule_large,
    G_N_ELEMENTS (formats))
{
  const FormatDesc *fmt = &formats[__i__];
  Config cfg = builtin_config (20000);
  Picture pic;
  Expected e;

  picture_init (&pic, fmt, 641, 479, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_fill (&pic, 0, 0, 641, 240, C_GREY);
  picture_fill (&pic, 0, 240, 641, 239, C_BLUE);
  picture_fill (&pic, 100, 300, 120, 90, C_PINK);       /* 10800 pixels */
  picture_fill (&pic, 400, 100, 60, 50, C_YELLOW);      /* 3000 pixels */
  picture_fill (&pic, 632, 0, 9, 479, C_PINK);  /* on the odd edge */
  expect_picture (&pic, &cfg, &e);
  fail_unless (!e.active[e.first[C_PINK] - 1]);
  fail_unless (!e.active[e.first[C_YELLOW] - 1]);
  fail_unless (e.final[C_PINK] != e.first[C_PINK]);
  fail_unless (e.final[C_YELLOW] != e.first[C_YELLOW]);
  segment_and_check (&pic, 0, NULL, &cfg);
  cfg.rare_unlabelled = TRUE;
  expect_picture (&pic, &cfg, &e);
  fail_unless (e.final[C_PINK] == 0 && e.final[C_YELLOW] == 0);
  segment_and_check (&pic, 0, NULL, &cfg);
  picture_clear (&pic);
}

GST_END_TEST;

LANDMARK_TEST ("rules", test_no_class_reaches_threshold)
{
  Config cfg = builtin_config (65);
  GstBuffer *out;
  const GstStructure *s;
  LabelPlane lp;
  Picture pic;
  Expected e;
  guint k, i, total = 0;

  /* four quadrants of 64 pixels each */
  picture_init (&pic, FMT_RGB, 16, 16, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_fill (&pic, 0, 0, 8, 8, C_RED);
  picture_fill (&pic, 8, 0, 8, 8, C_GREY);
  picture_fill (&pic, 0, 8, 8, 8, C_BLUE);
  picture_fill (&pic, 8, 8, 8, 8, C_YELLOW);
  expect_picture (&pic, &cfg, &e);
  out = run_picture (&pic, 0, NULL, &cfg, NULL, NULL);
  check_labels_meta (out, &pic, &cfg, &e);

  /* and, spelled out: */
  s = labels_meta (out);
  fail_unless_equals_int (field_uint (s, "unclassified"), 16 * 16);
  for (k = 0; k < builtin.n; k++) {
    fail_if (array_bool (s, "class-active", k));
    fail_unless_equals_int (array_uint (s, "label-counts", k), 0);
    total += array_uint (s, "class-counts", k);
  }
  fail_unless_equals_int (total, 16 * 16);
  label_plane_map (out, &lp);
  for (i = 0; i < 16; i++)
    fail_unless_equals_int (lp.map.data[i * lp.stride + i], 0);
  label_plane_unmap (&lp);
  gst_buffer_unref (out);
  picture_clear (&pic);
}

GST_END_TEST;

LANDMARK_TEST ("rules", test_max_distance)
{
  const guint green = ref_label (&builtin, "green");
  Picture pic;
  Config cfg;
  Expected e;
  gdouble lab[3], gap, best;

  picture_init (&pic, FMT_RGB, 32, 32, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_fill (&pic, 0, 0, 16, 32, C_FAR_GREEN);
  picture_fill (&pic, 16, 0, 16, 32, C_GREY);

  picture_colour_lab (&pic, C_FAR_GREEN, lab);
  fail_unless_equals_int (ref_nearest (&builtin, lab, NULL, TRUE,
          DEFAULT_MAX_DISTANCE, &gap, &best), green);
  fail_unless (best > 10.0 + MIN_MARGIN, "(0,255,0) is only %.1f from green",
      best);
  GST_INFO ("(0,255,0) is %.2f Delta E from green", best);

  /* default: everything within reach */
  cfg = builtin_config (0);
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_FAR_GREEN], green);
  segment_and_check (&pic, 0, NULL, &cfg);

  /* max-distance=10: the saturated green is nobody's, grey still grey */
  cfg.max_distance = 10.0;
  expect_picture (&pic, &cfg, &e);
  fail_unless_equals_int (e.final[C_FAR_GREEN], 0);
  fail_unless_equals_int (e.final[C_GREY], ref_label (&builtin, "grey"));
  fail_unless_equals_int (e.final_counts[0], 16 * 32);
  segment_and_check (&pic, 0, NULL, &cfg);

  picture_clear (&pic);
}

GST_END_TEST;

LANDMARK_TEST ("rules", test_use_lightness)
{
  static const Rgb greys[] = { {60, 60, 60}, {200, 200, 200} };
  const gchar *path = PALETTES "lightness.json";
  RefPalette pal;
  Picture pic;
  Config cfg;
  GstBuffer *out;
  LabelPlane lp;
  const GstStructure *s;
  guint dark_label, light_label;
  const gchar *name;

  ref_palette_load (path, &pal);
  picture_init (&pic, FMT_RGB, 20, 10, greys, G_N_ELEMENTS (greys));
  picture_fill (&pic, 10, 0, 10, 10, 1);

  /* with L*: the two greys are different classes */
  cfg.palette = &pal;
  cfg.min_class_pixels = 0;
  cfg.max_distance = DEFAULT_MAX_DISTANCE;
  cfg.use_lightness = TRUE;
  segment_and_check (&pic, 0, path, &cfg);
  {
    Expected e;
    expect_picture (&pic, &cfg, &e);
    fail_unless_equals_int (e.final[0], ref_label (&pal, "dark"));
    fail_unless_equals_int (e.final[1], ref_label (&pal, "light"));
  }

  /* a*b* only: both greys are equally near "dark" and "light", so they
   * must land in one and the same class */
  cfg.use_lightness = FALSE;
  out = run_picture (&pic, 0, path, &cfg, NULL, NULL);
  s = labels_meta (out);
  label_plane_map (out, &lp);
  dark_label = lp.map.data[0];
  light_label = lp.map.data[19];
  label_plane_unmap (&lp);
  fail_unless_equals_int (dark_label, light_label);
  fail_unless (dark_label != 0);
  name = array_string (s, "class-names", dark_label - 1);
  fail_unless (!strcmp (name, "dark") || !strcmp (name, "light"),
      "greys labelled %s", name);
  fail_unless_equals_int (array_uint (s, "label-counts", dark_label - 1),
      200);
  fail_unless_equals_int (field_uint (s, "unclassified"), 0);
  gst_buffer_unref (out);

  picture_clear (&pic);
  ref_palette_clear (&pal);
}

GST_END_TEST;

LANDMARK_TEST ("configuration", test_custom_palette)
{
  static const Rgb colours[] = {
    {235, 145, 40},             /* orange */
    {60, 200, 210},             /* cyan */
    {110, 40, 150},             /* purple */
    {20, 20, 20},               /* black */
  };
  static const gchar *names[] = { "orange", "cyan", "purple", "black" };
  static const guint8 cycle[] = { 0, 1, 2, 3 };
  const gchar *path = PALETTES "good-custom.json";
  RefPalette pal;
  guint f, i;

  ref_palette_load (path, &pal);
  for (f = 0; f < G_N_ELEMENTS (formats); f++) {
    Config cfg = { &pal, 0, DEFAULT_MAX_DISTANCE, TRUE, FALSE };
    Picture pic;
    Expected e;
    picture_init (&pic, &formats[f], 24, 16, colours, G_N_ELEMENTS (colours));
    picture_pattern (&pic, cycle, G_N_ELEMENTS (cycle));
    expect_picture (&pic, &cfg, &e);
    for (i = 0; i < G_N_ELEMENTS (names); i++)
      fail_unless_equals_int (e.final[i], ref_label (&pal, names[i]));
    segment_and_check (&pic, 0, path, &cfg);
    picture_clear (&pic);
  }
  ref_palette_clear (&pal);
}

GST_END_TEST;

/* YUV frames in the colorimetry their caps state. Each case has a colour
 * that the wrong interpretation (BT.601 limited, the usual assumption)
 * would put in another class, so a matrix or range that is ignored shows. */
LANDMARK_TEST ("formats", test_yuv_colorimetry)
{
  static const struct
  {
    const YuvModel *model;
    guint width, height;
    Rgb telltale;
  } cases[] = {
    {&bt709, 1280, 720, {0, 165, 145}},
    {&bt601_full, 320, 240, {195, 255, 190}},
  };
  static const guint8 cycle[] = {
    C_RED, C_GREY, C_WHITE, C_BLUE, C_YELLOW, C_GREEN, C_PINK, C_FAR_GREEN,
  };
  const FormatDesc *yuv_formats[] = { FMT_I420, FMT_NV12, FMT_YUY2 };
  Config cfg = builtin_config (0);
  guint c, f;

  for (c = 0; c < G_N_ELEMENTS (cases); c++) {
    Rgb colours[G_N_ELEMENTS (builtin_colours) + 1];
    const guint telltale = G_N_ELEMENTS (builtin_colours);
    guint8 pattern[G_N_ELEMENTS (cycle) + 1];

    memcpy (colours, builtin_colours, sizeof (builtin_colours));
    colours[telltale] = cases[c].telltale;
    memcpy (pattern, cycle, sizeof (cycle));
    pattern[G_N_ELEMENTS (cycle)] = telltale;

    for (f = 0; f < G_N_ELEMENTS (yuv_formats); f++) {
      Picture pic;
      Expected e;
      gdouble lab[3], rgb[3];
      guint8 yuv[3];

      picture_init (&pic, yuv_formats[f], cases[c].width, cases[c].height,
          colours, G_N_ELEMENTS (colours));
      picture_pattern (&pic, pattern, G_N_ELEMENTS (pattern));
      pic.yuv = cases[c].model;
      expect_picture (&pic, &cfg, &e);

      /* the telltale's code values read as BT.601 limited range land in
       * another class */
      rgb_to_yuv (pic.yuv, &colours[telltale], yuv);
      yuv_to_rgb01 (&bt601, yuv, rgb);
      rgb01_to_lab (rgb, lab);
      fail_if (ref_nearest (&builtin, lab, NULL, TRUE, DEFAULT_MAX_DISTANCE,
              NULL, NULL) == e.final[telltale],
          "case %u: the telltale colour does not tell", c);

      segment_and_check (&pic, 0, NULL, &cfg);
      picture_clear (&pic);
    }
  }
}

GST_END_TEST;

/* One element through caps changes: format, size and colorimetry change
 * between buffers; every buffer is labelled for its own caps. */
LANDMARK_TEST ("formats", test_caps_change_midstream)
{
  static const struct
  {
    const FormatDesc *fmt;
    guint width, height;
    const YuvModel *yuv;
  } steps[] = {
    /* same colour model, other byte orders and pixel strides */
    {&formats[0], 64, 48, &bt601},     /* RGB */
    {&formats[1], 64, 48, &bt601},     /* BGR */
    {&formats[5], 64, 48, &bt601},     /* xBGR */
    {&formats[6], 64, 48, &bt601},     /* RGBA */
    {&formats[4], 33, 7, &bt601},      /* xRGB */
    {&formats[3], 641, 479, &bt601},   /* BGRx */
    /* YUV, and back */
    {FMT_I420, 32, 16, &bt601},
    {FMT_YUY2, 32, 16, &bt601},
    {FMT_NV12, 20, 10, &bt601},
    {FMT_YUY2, 1280, 720, &bt709},
    {FMT_I420, 1280, 720, &bt709},
    {FMT_I420, 32, 16, &bt601},
    {FMT_BGRx, 3, 5, &bt601},
    {FMT_RGB, 3, 5, &bt601},
  };
  Config cfg = builtin_config (0);
  GstHarness *h = harness_new (NULL, &cfg);
  guint i;

  for (i = 0; i < G_N_ELEMENTS (steps); i++) {
    GstVideoInfo info;
    GstBuffer *in, *out;
    Picture pic;
    Expected e;

    picture_init (&pic, steps[i].fmt, steps[i].width, steps[i].height,
        builtin_colours, G_N_ELEMENTS (builtin_colours));
    pic.yuv = steps[i].yuv;
    picture_pattern (&pic, all_seven, G_N_ELEMENTS (all_seven));
    expect_picture (&pic, &cfg, &e);
    in = picture_to_buffer (&pic, 0, &info);
    gst_harness_set_src_caps (h, gst_video_info_to_caps (&info));
    GST_BUFFER_PTS (in) = i * GST_SECOND;
    out = gst_harness_push_and_pull (h, in);
    fail_unless (out != NULL);
    check_labels_meta (out, &pic, &cfg, &e);
    gst_buffer_unref (out);
    picture_clear (&pic);
  }
  gst_harness_teardown (h);
}

GST_END_TEST;

/* The largest palette: 64 classes, labels 1..64 all in use. */
LANDMARK_TEST ("configuration", test_palette_64_classes)
{
  static const guint8 levels[] = { 32, 96, 160, 224 };
  const gchar *path = PALETTES "good-64-classes.json";
  const FormatDesc *some[] = { FMT_RGB, FMT_BGRx, FMT_I420, FMT_YUY2 };
  Rgb colours[64];
  guint8 cycle[64];
  RefPalette pal;
  guint i, f;

  ref_palette_load (path, &pal);
  fail_unless_equals_int (pal.n, 64);
  for (i = 0; i < 64; i++) {
    colours[i].r = levels[i / 16];
    colours[i].g = levels[(i / 4) % 4];
    colours[i].b = levels[i % 4];
    cycle[i] = i;
  }
  for (f = 0; f < G_N_ELEMENTS (some); f++) {
    Config cfg = { &pal, 0, DEFAULT_MAX_DISTANCE, TRUE, FALSE };
    Picture pic;
    Expected e;
    picture_init (&pic, some[f], 66, 34, colours, 64);
    picture_pattern (&pic, cycle, 64);
    expect_picture (&pic, &cfg, &e);
    for (i = 0; i < 64; i++)
      fail_unless_equals_int (e.final[i], i + 1);
    segment_and_check (&pic, 0, path, &cfg);
    picture_clear (&pic);
  }
  ref_palette_clear (&pal);
}

GST_END_TEST;

static void
segment_builtin_pattern_rgb (GstHarness * h, Picture * pic, GstBuffer ** in)
{
  GstVideoInfo info;
  picture_init (pic, FMT_RGB, 32, 16, builtin_colours,
      G_N_ELEMENTS (builtin_colours));
  picture_pattern (pic, all_seven, G_N_ELEMENTS (all_seven));
  *in = picture_to_buffer (pic, 0, &info);
  gst_harness_set_src_caps (h, gst_video_info_to_caps (&info));
}

/* One landmark-histogram element message per buffer, fields as in the
 * meta of that buffer, times from the segment. */
LANDMARK_TEST ("streaming", test_post_messages)
{
  Config cfg = builtin_config (40);
  GstHarness *h = harness_new (NULL, &cfg);
  GstBus *bus = gst_bus_new ();
  GstSegment seg;
  GstBuffer *templ;
  Picture pic;
  GstMessage *msg;
  guint i, k;

  gst_element_set_bus (h->element, bus);
  segment_builtin_pattern_rgb (h, &pic, &templ);

  /* without the property: no messages */
  gst_buffer_unref (gst_harness_push_and_pull (h, gst_buffer_copy (templ)));
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT) == NULL);

  g_object_set (h->element, "post-messages", TRUE, NULL);
  gst_segment_init (&seg, GST_FORMAT_TIME);
  seg.start = 1 * GST_SECOND;
  seg.time = 10 * GST_SECOND;
  seg.base = 100 * GST_SECOND;
  fail_unless (gst_harness_push_event (h, gst_event_new_segment (&seg)));

  for (i = 0; i < 4; i++) {
    const GstClockTime pts = seg.start + i * 40 * GST_MSECOND;
    const GstStructure *m, *ms;
    GstBuffer *in, *out;
    GstVideoInfo info;
    Picture p;
    Expected e;
    guint64 t;
    guint u;

    /* a different frame each time; buffers 1 and 3 have a class below
     * min-class-pixels, whose first-pass count must still be reported */
    picture_init (&p, FMT_RGB, 32, 16, builtin_colours,
        G_N_ELEMENTS (builtin_colours));
    switch (i) {
      case 0:
        picture_pattern (&p, all_seven, G_N_ELEMENTS (all_seven));
        break;
      case 1:
        picture_fill (&p, 0, 0, 32, 16, C_RED);
        picture_fill (&p, 4, 4, 4, 4, C_PINK);  /* 16 < 40 */
        break;
      case 2:
        picture_fill (&p, 0, 0, 16, 16, C_BLUE);
        picture_fill (&p, 16, 0, 16, 16, C_WHITE);
        break;
      default:
        picture_fill (&p, 0, 0, 32, 16, C_GREY);
        picture_fill (&p, 30, 0, 2, 16, C_YELLOW);      /* 32 < 40 */
        picture_fill (&p, 0, 14, 2, 2, C_GREEN);        /* 4 < 40 */
        break;
    }
    expect_picture (&p, &cfg, &e);
    in = picture_to_buffer (&p, 0, &info);
    GST_BUFFER_PTS (in) = pts;
    GST_BUFFER_DURATION (in) = 40 * GST_MSECOND;
    out = gst_harness_push_and_pull (h, in);
    check_labels_meta (out, &p, &cfg, &e);
    m = labels_meta (out);

    msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT);
    fail_unless (msg != NULL, "no element message for buffer %u", i);
    fail_unless (GST_MESSAGE_SRC (msg) == GST_OBJECT (h->element));
    ms = gst_message_get_structure (msg);
    fail_unless (gst_structure_has_name (ms, "landmark-histogram"));

    fail_unless (gst_structure_get_uint64 (ms, "timestamp", &t));
    fail_unless_equals_uint64 (t, pts);
    fail_unless (gst_structure_get_uint64 (ms, "stream-time", &t));
    fail_unless_equals_uint64 (t, pts - seg.start + seg.time);
    fail_unless (gst_structure_get_uint64 (ms, "running-time", &t));
    fail_unless_equals_uint64 (t, pts - seg.start + seg.base);
    fail_unless (gst_structure_get_uint (ms, "min-class-pixels", &u));
    fail_unless_equals_int (u, cfg.min_class_pixels);

    fail_unless_equals_int (array_size (ms, "class-names"), builtin.n);
    fail_unless_equals_int (array_size (ms, "class-counts"), builtin.n);
    fail_unless_equals_int (array_size (ms, "class-active"), builtin.n);
    for (k = 0; k < builtin.n; k++) {
      fail_unless_equals_string (array_string (ms, "class-names", k),
          array_string (m, "class-names", k));
      /* the meta was checked against the expectation above */
      fail_unless (array_uint (ms, "class-counts", k) ==
          array_uint (m, "class-counts", k), "buffer %u: message "
          "class-counts[%s] = %u, meta %u", i, builtin.cls[k].name,
          array_uint (ms, "class-counts", k), array_uint (m, "class-counts",
              k));
      fail_unless_equals_int (array_bool (ms, "class-active", k),
          array_bool (m, "class-active", k));
    }
    gst_message_unref (msg);
    gst_buffer_unref (out);
    picture_clear (&p);

    /* exactly one per buffer */
    fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT) == NULL,
        "more than one element message for buffer %u", i);
  }

  gst_buffer_unref (templ);
  picture_clear (&pic);
  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* ---- palette errors ---- */

typedef struct
{
  const gchar *file;
  /* words the debug text must contain besides the file name
   * (case-insensitive; "a|b": either) */
  const gchar *faults[3];
} BadPalette;

static const BadPalette bad_palettes[] = {
  {"does-not-exist.json", {"cannot read", NULL}},
  /* an empty document has no top-level object */
  {"bad-empty.json", {"empty|top level", NULL}},
  {"bad-malformed.json", {"JSON", NULL}},
  {"bad-no-classes.json", {"classes", "empty", NULL}},
  {"bad-classes-missing.json", {"classes", "array", NULL}},
  {"bad-duplicate-name.json", {"duplicate", "blue", NULL}},
  {"bad-lightness-range.json", {"L*", "120", NULL}},
  {"bad-unknown-key.json", {"unknown key", "colour", NULL}},
  {"bad-65-classes.json", {"65", "64", NULL}},
};

/* Does text, with every occurrence of `path` removed (the file names
 * would otherwise match words like "empty"), contain one of the
 * '|'-separated alternatives of `what`? Case-insensitive. */
static gboolean
mentions (const gchar * text, const gchar * path, const gchar * what)
{
  gchar **parts = g_strsplit (text ? text : "", path, -1);
  gchar *joined = g_strjoinv (" ", parts);
  gchar *t = g_ascii_strdown (joined, -1);
  gchar **alternatives = g_strsplit (what, "|", -1);
  gboolean found = FALSE;
  guint i;

  for (i = 0; alternatives[i] && !found; i++) {
    gchar *w = g_ascii_strdown (alternatives[i], -1);
    found = strstr (t, w) != NULL;
    g_free (w);
  }
  g_strfreev (alternatives);
  g_free (t);
  g_free (joined);
  g_strfreev (parts);
  return found;
}

/* Pops the error message from the bus and checks its domain, that it names
 * the file, and that the debug text names the fault. */
static void
check_palette_error (GstBus * bus, GstElement * element, const BadPalette * b,
    const gchar * path, GstMessageType type)
{
  GstMessage *msg = gst_bus_pop_filtered (bus, type);
  GError *err = NULL;
  gchar *debug = NULL;
  guint i;

  fail_unless (msg != NULL, "%s: no %s message on the bus", b->file,
      gst_message_type_get_name (type));
  fail_unless (GST_MESSAGE_SRC (msg) == GST_OBJECT (element));
  if (type == GST_MESSAGE_ERROR)
    gst_message_parse_error (msg, &err, &debug);
  else
    gst_message_parse_warning (msg, &err, &debug);
  GST_INFO ("%s: \"%s\" / \"%s\"", b->file, err->message, debug);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS), "%s: wrong error %s %d: %s", b->file,
      g_quark_to_string (err->domain), err->code, err->message);
  fail_unless (strstr (err->message, path) != NULL ||
      (debug && strstr (debug, path) != NULL),
      "%s: the error does not name the file: \"%s\" / \"%s\"", b->file,
      err->message, debug);
  for (i = 0; b->faults[i]; i++)
    fail_unless (mentions (debug, path, b->faults[i]),
        "%s: debug text \"%s\" does not mention \"%s\"", b->file, debug,
        b->faults[i]);
  g_error_free (err);
  g_free (debug);
  gst_message_unref (msg);
}

LANDMARK_TEST_LOOP ("configuration", test_bad_palette_fails_start,
    G_N_ELEMENTS (bad_palettes))
{
  const BadPalette *b = &bad_palettes[__i__];
  gchar *path = g_build_filename (GST_TEST_FILES_PATH, "palettes", b->file,
      NULL);
  GstElement *e = gst_element_factory_make ("labsegment", NULL);
  GstBus *bus = gst_bus_new ();

  fail_unless (e != NULL);
  g_object_set (e, "palette", path, NULL);
  landmark_check_refuses_ready (e, bus);
  check_palette_error (bus, e, b, path, GST_MESSAGE_ERROR);

  /* fixing the setting is enough to start */
  landmark_check_fixed_setting_starts (e, bus, "palette",
      PALETTES "good-custom.json");
  g_free (path);
}

GST_END_TEST;

LANDMARK_TEST ("configuration", test_bad_palette_while_playing)
{
  const BadPalette *b = &bad_palettes[5];       /* duplicate name */
  gchar *bad = g_build_filename (GST_TEST_FILES_PATH, "palettes", b->file,
      NULL);
  Config cfg = builtin_config (0);
  GstHarness *h = harness_new (NULL, &cfg);
  GstBus *bus = gst_bus_new ();
  GstBuffer *templ, *out;
  Picture pic;
  RefPalette alt;

  gst_element_set_bus (h->element, bus);
  segment_builtin_pattern_rgb (h, &pic, &templ);
  gst_buffer_unref (gst_harness_push_and_pull (h, gst_buffer_copy (templ)));

  /* a bad palette while playing: a warning, and the frame is segmented
   * with the previous (built-in) palette */
  g_object_set (h->element, "palette", bad, NULL);
  fail_unless_equals_int (gst_harness_push (h, gst_buffer_copy (templ)),
      GST_FLOW_OK);
  check_palette_error (bus, h->element, b, bad, GST_MESSAGE_WARNING);
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR) == NULL);
  out = gst_harness_pull (h);
  fail_unless_equals_int (array_size (labels_meta (out), "class-names"),
      cfg.palette->n);
  gst_buffer_unref (out);

  /* a good palette again: streaming resumes with it */
  ref_palette_load (PALETTES "good-alt.json", &alt);
  g_object_set (h->element, "palette", PALETTES "good-alt.json", NULL);
  fail_unless_equals_int (gst_harness_push (h, gst_buffer_copy (templ)),
      GST_FLOW_OK);
  out = gst_harness_pull (h);
  fail_unless_equals_int (array_size (labels_meta (out), "class-names"),
      alt.n);
  fail_unless_equals_string (array_string (labels_meta (out), "class-names",
          0), alt.cls[0].name);
  gst_buffer_unref (out);

  ref_palette_clear (&alt);
  gst_buffer_unref (templ);
  picture_clear (&pic);
  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
  g_free (bad);
}

GST_END_TEST;

/* Properties changed from other threads while buffers flow. */
LANDMARK_TEST ("streaming", test_properties_while_streaming)
{
  const gchar *custom = PALETTES "good-custom.json";
  const gchar *alt = PALETTES "good-alt.json";
  GstHarness *h = gst_harness_new ("labsegment");
  GParamSpec *output_spec = g_object_class_find_property
      (G_OBJECT_GET_CLASS (h->element), "output");
  GstHarnessThread *threads[8];
  GstBuffer *templ;
  Picture pic;
  RefPalette pals[2];
  GValue v = G_VALUE_INIT;
  guint i, t, n_threads = 0, iterations;
  const guint n_buffers = 60;

  ref_palette_load (custom, &pals[0]);
  ref_palette_load (alt, &pals[1]);
  segment_builtin_pattern_rgb (h, &pic, &templ);
  /* from the first buffer on, one of the two files is in use */
  g_object_set (h->element, "palette", custom, NULL);

#define STRESS(name, init, setter, value) G_STMT_START { \
    g_value_init (&v, init); setter (&v, value); \
    threads[n_threads++] = gst_harness_stress_property_start_full (h, name, \
        &v, 500); \
    g_value_unset (&v); } G_STMT_END

  STRESS ("min-class-pixels", G_TYPE_UINT, g_value_set_uint, 0);
  STRESS ("min-class-pixels", G_TYPE_UINT, g_value_set_uint, 100);
  STRESS ("max-distance", G_TYPE_DOUBLE, g_value_set_double, 15.0);
  STRESS ("max-distance", G_TYPE_DOUBLE, g_value_set_double, 1000.0);
  STRESS ("output", output_spec->value_type, g_value_set_enum, 0);
  STRESS ("output", output_spec->value_type, g_value_set_enum, 1);
  STRESS ("palette", G_TYPE_STRING, g_value_set_string, custom);
  STRESS ("palette", G_TYPE_STRING, g_value_set_string, alt);
#undef STRESS

  for (i = 0; i < n_buffers; i++) {
    GstBuffer *in = gst_buffer_copy (templ), *out;
    const GstStructure *s;
    LabelPlane lp;
    guint n, k, x, y, sum = 0, hist[MAX_CLASSES + 1] = { 0, };
    const RefPalette *pal = NULL;

    GST_BUFFER_PTS (in) = i * 40 * GST_MSECOND;
    fail_unless_equals_int (gst_harness_push (h, in), GST_FLOW_OK);
    /* the element works in the pushing thread: the output is there */
    out = gst_harness_try_pull (h);
    fail_unless (out != NULL, "buffer %u did not come out", i);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * 40 * GST_MSECOND);

    /* a consistent meta: one palette, labels within it, counts adding up */
    s = labels_meta (out);
    n = array_size (s, "class-names");
    for (t = 0; t < 2; t++)
      if (n == pals[t].n && !strcmp (array_string (s, "class-names", 0),
              pals[t].cls[0].name))
        pal = &pals[t];
    fail_unless (pal != NULL, "buffer %u: class-names from no palette", i);
    fail_unless_equals_int (array_size (s, "label-counts"), n);
    fail_unless_equals_int (array_size (s, "class-counts"), n);
    label_plane_map (out, &lp);
    fail_unless_equals_int (lp.width, pic.width);
    fail_unless_equals_int (lp.height, pic.height);
    for (y = 0; y < lp.height; y++)
      for (x = 0; x < lp.width; x++) {
        const guint l = lp.map.data[(gsize) y * lp.stride + x];
        fail_unless (l <= n, "buffer %u: label %u of %u classes", i, l, n);
        hist[l]++;
      }
    label_plane_unmap (&lp);
    for (k = 0; k < n; k++) {
      const guint first = array_uint (s, "class-counts", k);
      const guint final = array_uint (s, "label-counts", k);
      fail_unless_equals_int (final, hist[k + 1]);
      /* inactive classes lose their pixels, active ones may gain some */
      if (array_bool (s, "class-active", k))
        fail_unless (final >= first, "buffer %u: active %s %u < %u", i,
            pal->cls[k].name, final, first);
      else
        fail_unless (final == 0, "buffer %u: inactive %s has %u pixels", i,
            pal->cls[k].name, final);
      sum += first;
    }
    fail_unless_equals_int (field_uint (s, "unclassified"), hist[0]);
    fail_unless (sum <= pic.width * pic.height);
    gst_buffer_unref (out);
  }

  for (t = 0; t < n_threads; t++) {
    iterations = gst_harness_stress_thread_stop (threads[t]);
    fail_unless (iterations > 0);
  }
  fail_unless_equals_int (gst_harness_buffers_received (h), n_buffers);

  ref_palette_clear (&pals[0]);
  ref_palette_clear (&pals[1]);
  gst_buffer_unref (templ);
  picture_clear (&pic);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* A measuring element never drops frames, not even when downstream says
 * it is far behind (a QoS event that would make a QoS-enabled transform
 * drop everything below). */
LANDMARK_TEST ("streaming", test_no_buffer_dropped)
{
  GstHarness *h = gst_harness_new ("labsegment");
  GstBuffer *templ;
  Picture pic;

  segment_builtin_pattern_rgb (h, &pic, &templ);
  landmark_check_no_frame_dropped (h, templ, 50, META_NAME);
  gst_buffer_unref (templ);
  picture_clear (&pic);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (labsegment, .setup = load_builtin,
    .teardown = clear_builtin);
