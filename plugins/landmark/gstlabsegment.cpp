/**
 * SECTION:element-labsegment
 * @title: labsegment
 *
 * Classifies every pixel by its nearest reference colour in CIE L*a*b*
 * (D65, sRGB input; L*, a* and b* all count, or only a* and b* with
 * `use-lightness=false`) and attaches the class plane to the buffer as a
 * `GstLandmarkLabelsMeta` (docs/metadata.md).
 *
 * The dominant-colour rule: a first pass over all palette classes gives the
 * frame's class histogram; only classes with at least `min-class-pixels`
 * pixels take part in the final labelling (0 turns the rule off). Pixels
 * farther than `max-distance` from every active class get label 0.
 *
 * Video passes through unchanged (`output=passthrough`), or is replaced by a
 * false-colour view of the classes (`output=labels`).
 *
 * Classification goes through a lookup table from the pixel's own 8-bit
 * components (RGB or Y'CbCr) to its class, built when the palette, the
 * settings or the caps change; it returns for every colour exactly what the
 * direct L*a*b* computation returns.
 *
 * With `post-messages=true` it posts a `landmark-histogram` element message
 * per frame: `timestamp`, `stream-time`, `running-time` (guint64, ns),
 * `class-names` (array of strings), `class-counts` (array of guint, first
 * pass), `class-active` (array of booleans), `min-class-pixels` (guint).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=100 ! labsegment output=labels !
 *     videoconvert ! jpegenc ! avimux ! filesink location=labels.avi
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlabsegment.h"

#include <gst/base/gstbasetransform.h>
#include <gst/video/video.h>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <array>
#include <chrono>
#include <cstring>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "classtable.h"
#include "landmarkcv.h"
#include "landmarkmeta.h"
#include "palette.h"

GST_DEBUG_CATEGORY_STATIC (gst_lab_segment_debug);
#define GST_CAT_DEFAULT gst_lab_segment_debug

/* blobroundness's default min-area: a class with fewer pixels cannot hold
 * a blob it keeps, so the rule never hides a landmark (the seed used 500) */
#define DEFAULT_MIN_CLASS_PIXELS 100
#define DEFAULT_MAX_DISTANCE 1000.0
#define DEFAULT_USE_LIGHTNESS TRUE
#define DEFAULT_OUTPUT GST_LAB_SEGMENT_OUTPUT_PASSTHROUGH
#define DEFAULT_POST_MESSAGES FALSE
#define DEFAULT_RARE_CLASSES GST_LAB_SEGMENT_RARE_UNLABELLED

enum
{
  PROP_0,
  PROP_PALETTE,
  PROP_MIN_CLASS_PIXELS,
  PROP_MAX_DISTANCE,
  PROP_USE_LIGHTNESS,
  PROP_OUTPUT,
  PROP_POST_MESSAGES,
  PROP_RARE_CLASSES,
};


static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS,
    GST_STATIC_CAPS (GST_VIDEO_CAPS_MAKE (LANDMARK_VIDEO_FORMATS)));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS (GST_VIDEO_CAPS_MAKE (LANDMARK_VIDEO_FORMATS)));

/* *INDENT-OFF* */
namespace {

using landmark::kMaxClasses;

/* What the user sets; read by the streaming thread under the lock. */
struct Settings {
  std::string palette;  /* empty: built-in palette */
  guint palette_generation = 0;
  guint min_class_pixels = DEFAULT_MIN_CLASS_PIXELS;
  gdouble max_distance = DEFAULT_MAX_DISTANCE;
  gboolean use_lightness = DEFAULT_USE_LIGHTNESS;
  GstLabSegmentOutput output = DEFAULT_OUTPUT;
  gboolean post_messages = DEFAULT_POST_MESSAGES;
  GstLabSegmentRareClasses rare_classes = DEFAULT_RARE_CLASSES;
};

/* How the three components of a pixel are laid out in a frame. */
enum class Layout { PACKED3, PACKED4, YUV420, YUY2 };

struct FrameLayout {
  Layout layout = Layout::PACKED4;
  int offset[3] = { 0, 1, 2 };  /* R,G,B byte offsets for packed RGB */
  int key_shift = 0;            /* bits to drop from a 4-byte pixel */
  landmark::KeyOrder order = landmark::KeyOrder::C0_LOW;
};

/* Built in start() and set_info(), used by the streaming thread only. */
struct State {
  landmark::Palette palette;
  guint palette_generation = 0;
  landmark::ClassTable table;
  bool table_valid = false;
  gdouble table_max_distance = -1;
  gboolean table_use_lightness = TRUE;

  FrameLayout layout;
  landmark::InputModel model;
  guint width = 0, height = 0;
  GstBufferPool *plane_pool = nullptr;

  /* per-class colour in the frame's own components, for output=labels */
  std::vector<std::array<uint8_t, 3>> display;
  std::array<uint8_t, 3> black {};
  /* constant meta fields, rebuilt with the palette */
  GValue names = G_VALUE_INIT, markers = G_VALUE_INIT, rgb = G_VALUE_INIT;
  bool warned_no_class = false;
};

}  // namespace

struct _GstLabSegment {
  GstVideoFilter parent;
  std::mutex *lock;    /* guards settings */
  Settings *settings;
  State *state;
};
/* *INDENT-ON* */

G_DEFINE_TYPE_WITH_CODE (GstLabSegment, gst_lab_segment,
    GST_TYPE_VIDEO_FILTER,
    GST_DEBUG_CATEGORY_INIT (gst_lab_segment_debug, "labsegment", 0,
        "CIE L*a*b* colour segmentation"));
GST_ELEMENT_REGISTER_DEFINE (labsegment, "labsegment", GST_RANK_NONE,
    GST_TYPE_LAB_SEGMENT);

GType
gst_lab_segment_output_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {GST_LAB_SEGMENT_OUTPUT_PASSTHROUGH,
        "Video unchanged; labels as metadata only", "passthrough"},
    {GST_LAB_SEGMENT_OUTPUT_LABELS,
        "False-colour view of the class labels", "labels"},
    {0, nullptr, nullptr},
  };
  if (g_once_init_enter (&type)) {
    GType t = g_enum_register_static ("GstLabSegmentOutput", values);
    g_once_init_leave (&type, t);
  }
  return type;
}

GType
gst_lab_segment_rare_classes_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {GST_LAB_SEGMENT_RARE_NEAREST,
        "The nearest class that reached the threshold (the seed's rule)",
        "nearest"},
    {GST_LAB_SEGMENT_RARE_UNLABELLED, "No class (label 0)", "unlabelled"},
    {0, nullptr, nullptr},
  };
  if (g_once_init_enter (&type)) {
    GType t = g_enum_register_static ("GstLabSegmentRareClasses", values);
    g_once_init_leave (&type, t);
  }
  return type;
}

/* ---- per-pixel kernels ---------------------------------------------- */

namespace {

/* counts[v] = pixels of the plane with label v, for v in 1..n and
 * kPending (other entries are left 0). One pass per value: compares of 16
 * labels at a time beat a scalar histogram on any palette up to 16 classes;
 * larger palettes use four interleaved scalar histograms. */
void
count_labels (const guint8 * plane, gsize size, guint n, guint32 counts[256])
{
  memset (counts, 0, sizeof (guint32) * 256);
#ifdef __SSE2__
  if (n <= 16) {
    guint8 values[kMaxClasses + 2];
    for (guint k = 0; k < n; k++)
      values[k] = k + 1;
    values[n] = landmark::ClassTable::kPending;
    const gsize vec_end = size & ~(gsize) 15;
    for (guint i = 0; i <= n; i++) {
      const __m128i v = _mm_set1_epi8 ((char) values[i]);
      guint64 total = 0;
      gsize pos = 0;
      while (pos < vec_end) {
        /* 8-bit per-lane counters, summed before they can overflow */
        const gsize stop = MIN (vec_end, pos + 255 * 16);
        __m128i acc = _mm_setzero_si128 ();
        for (; pos < stop; pos += 16) {
          const __m128i x = _mm_loadu_si128 ((const __m128i *) (plane + pos));
          acc = _mm_sub_epi8 (acc, _mm_cmpeq_epi8 (x, v));
        }
        const __m128i sums = _mm_sad_epu8 (acc, _mm_setzero_si128 ());
        total += (guint64) _mm_cvtsi128_si32 (sums) +
            (guint64) _mm_extract_epi16 (sums, 4);
      }
      for (gsize j = vec_end; j < size; j++)
        total += plane[j] == values[i];
      counts[values[i]] = (guint32) total;
    }
    return;
  }
#endif
  (void) n;
  guint32 bank[4][256] = { {0} };
  gsize j = 0;
  for (; j + 4 <= size; j += 4) {
    bank[0][plane[j]]++;
    bank[1][plane[j + 1]]++;
    bank[2][plane[j + 2]]++;
    bank[3][plane[j + 3]]++;
  }
  for (; j < size; j++)
    bank[0][plane[j]]++;
  for (int k = 0; k < 256; k++)
    counts[k] = bank[0][k] + bank[1][k] + bank[2][k] + bank[3][k];
}

/* Reads the components of pixel x of the current row, whatever the
 * layout; the classify and remap passes share it. */
struct PixelReader {
  const GstVideoFrame *frame;
  FrameLayout layout;
  const guint8 *row0 = nullptr, *row1 = nullptr, *row2 = nullptr;
  int upstride = 1;

  void set_row (guint y) {
    const GstVideoFrame *f = frame;
    row0 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 0) +
        (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (f, 0);
    if (layout.layout == Layout::YUV420) {
      const GstVideoFormat fmt = GST_VIDEO_FRAME_FORMAT (f);
      const guint cy = y / 2;
      if (fmt == GST_VIDEO_FORMAT_NV12) {
        row1 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        row2 = row1 + 1;
        upstride = 2;
      } else {
        row1 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        row2 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 2) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 2);
        upstride = 1;
      }
    }
  }

  inline void get (guint x, guint8 c[3]) const {
    switch (layout.layout) {
      case Layout::PACKED3:
        c[0] = row0[x * 3 + layout.offset[0]];
        c[1] = row0[x * 3 + layout.offset[1]];
        c[2] = row0[x * 3 + layout.offset[2]];
        break;
      case Layout::PACKED4:
        c[0] = row0[x * 4 + layout.offset[0]];
        c[1] = row0[x * 4 + layout.offset[1]];
        c[2] = row0[x * 4 + layout.offset[2]];
        break;
      case Layout::YUV420:
        c[0] = row0[x];
        c[1] = row1[(x >> 1) * upstride];
        c[2] = row2[(x >> 1) * upstride];
        break;
      case Layout::YUY2:
        c[0] = row0[x * 2];
        c[1] = row0[(x >> 1) * 4 + 1];
        c[2] = row0[(x >> 1) * 4 + 3];
        break;
    }
  }
};

using landmark::ClassTable;
using landmark::KeyOrder;

/* The key of a packed RGB pixel is its three colour bytes as one
 * little-endian number: a 4-byte pixel needs one load, one shift and one
 * mask (the table is built in the format's own byte order). */
static inline guint32
load32 (const guint8 * p)
{
  guint32 w;
  memcpy (&w, p, 4);
  return GUINT32_FROM_LE (w);
}

void
classify_packed4 (const guint8 * table, const guint8 * row, int shift,
    guint width, guint8 * labels)
{
  for (guint x = 0; x < width; x++)
    labels[x] = table[(load32 (row + x * 4) >> shift) & 0xffffff];
}

void
classify_packed3 (const guint8 * table, const guint8 * row, guint width,
    guint8 * labels)
{
  for (guint x = 0; x < width; x++) {
    const guint8 *p = row + x * 3;
    labels[x] = table[p[0] | (p[1] << 8) | ((guint32) p[2] << 16)];
  }
}

/* YUV keys are Y | U << 8 | V << 16; two pixels share one chroma pair. */
void
classify_frame (const ClassTable & table, PixelReader & reader,
    guint width, guint height, guint8 * labels)
{
  const guint8 *t = table.labels ();
  const FrameLayout & layout = reader.layout;
  for (guint y = 0; y < height; y++) {
    reader.set_row (y);
    guint8 *out = labels + (gsize) y * width;
    switch (layout.layout) {
      case Layout::PACKED3:
        classify_packed3 (t, reader.row0, width, out);
        break;
      case Layout::PACKED4:
        classify_packed4 (t, reader.row0, layout.key_shift, width, out);
        break;
      case Layout::YUV420:{
        const guint8 *yr = reader.row0, *ur = reader.row1, *vr = reader.row2;
        const int ps = reader.upstride;
        for (guint x = 0; x < width; x++) {
          const guint32 uv = (ur[(x >> 1) * ps] << 8) |
              ((guint32) vr[(x >> 1) * ps] << 16);
          out[x] = t[yr[x] | uv];
        }
        break;
      }
      case Layout::YUY2:{
        const guint8 *r = reader.row0;
        guint x = 0;
        for (; x + 2 <= width; x += 2) {
          const guint32 w = load32 (r + x * 2);   /* Y0 U Y1 V */
          const guint32 uv = (w & 0xff00) | ((w >> 8) & 0xff0000);
          out[x] = t[(w & 0xff) | uv];
          out[x + 1] = t[((w >> 16) & 0xff) | uv];
        }
        if (x < width) {
          const guint8 *p = r + x * 2;
          out[x] = t[p[0] | (p[1] << 8) | ((guint32) p[3] << 16)];
        }
        break;
      }
    }
  }
}

/* Writes each pixel's class colour into the frame (output=labels). */
void
draw_false_colour (GstVideoFrame * f, const FrameLayout & layout,
    const guint8 * labels, guint width, guint height,
    const std::vector<std::array<uint8_t, 3>> & display,
    const std::array<uint8_t, 3> & black)
{
  /* label 0 is black */
  const uint8_t *none = black.data ();
  auto colour = [&](guint8 l) -> const uint8_t * {
    return l == 0 ? none : display[l - 1].data ();
  };
  for (guint y = 0; y < height; y++) {
    const guint8 *lab = labels + (gsize) y * width;
    guint8 *r0 = (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 0) +
        (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (f, 0);
    switch (layout.layout) {
      case Layout::PACKED3:
      case Layout::PACKED4:{
        const int ps = layout.layout == Layout::PACKED3 ? 3 : 4;
        for (guint x = 0; x < width; x++) {
          const uint8_t *c = colour (lab[x]);
          guint8 *p = r0 + x * ps;
          p[layout.offset[0]] = c[0];
          p[layout.offset[1]] = c[1];
          p[layout.offset[2]] = c[2];
        }
        break;
      }
      case Layout::YUV420:{
        for (guint x = 0; x < width; x++) {
          r0[x] = colour (lab[x])[0];
        }
        if (y % 2)
          break;
        const bool nv12 = GST_VIDEO_FRAME_FORMAT (f) == GST_VIDEO_FORMAT_NV12;
        guint8 *u = (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) (y / 2) * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        guint8 *v = nv12 ? u + 1 : (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f,
            2) + (gsize) (y / 2) * GST_VIDEO_FRAME_PLANE_STRIDE (f, 2);
        const int ps = nv12 ? 2 : 1;
        for (guint x = 0; x < width; x += 2) {
          const uint8_t *c = colour (lab[x]);
          u[(x / 2) * ps] = c[1];
          v[(x / 2) * ps] = c[2];
        }
        break;
      }
      case Layout::YUY2:{
        for (guint x = 0; x < width; x++) {
          const uint8_t *c = colour (lab[x]);
          guint8 *p = r0 + (x >> 1) * 4;
          p[(x & 1) * 2] = c[0];
          if ((x & 1) == 0) {
            p[1] = c[1];
            p[3] = c[2];
          }
        }
        break;
      }
    }
  }
}

/* (Re)initialises v as an empty GstValueArray with room for n values. */
void
value_array_init (GValue * v, guint n)
{
  if (G_IS_VALUE (v))
    g_value_unset (v);
  gst_value_array_init (v, n);
}

void
value_array_append_uint (GValue * array, guint x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, G_TYPE_UINT);
  g_value_set_uint (&v, x);
  gst_value_array_append_and_take_value (array, &v);
}

void
value_array_append_boolean (GValue * array, gboolean x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, G_TYPE_BOOLEAN);
  g_value_set_boolean (&v, x);
  gst_value_array_append_and_take_value (array, &v);
}

}  // namespace

/* ---- GObject -------------------------------------------------------- */

static void
gst_lab_segment_init (GstLabSegment * self)
{
  self->lock = new std::mutex ();
  self->settings = new Settings ();
  self->state = new State ();
  gst_base_transform_set_in_place (GST_BASE_TRANSFORM (self), TRUE);
  /* a measuring element never drops late frames */
  gst_base_transform_set_qos_enabled (GST_BASE_TRANSFORM (self), FALSE);
}

static void
gst_lab_segment_finalize (GObject * object)
{
  auto self = GST_LAB_SEGMENT (object);
  if (self->state->plane_pool) {
    gst_buffer_pool_set_active (self->state->plane_pool, FALSE);
    gst_object_unref (self->state->plane_pool);
  }
  g_value_unset (&self->state->names);
  g_value_unset (&self->state->markers);
  g_value_unset (&self->state->rgb);
  delete self->state;
  delete self->settings;
  delete self->lock;
  G_OBJECT_CLASS (gst_lab_segment_parent_class)->finalize (object);
}

static void
gst_lab_segment_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  auto self = GST_LAB_SEGMENT (object);
  std::lock_guard<std::mutex> lk (*self->lock);
  Settings & s = *self->settings;
  switch (prop_id) {
    case PROP_PALETTE:{
      const gchar *path = g_value_get_string (value);
      s.palette = path ? path : "";
      s.palette_generation++;
      break;
    }
    case PROP_MIN_CLASS_PIXELS:
      s.min_class_pixels = g_value_get_uint (value);
      break;
    case PROP_MAX_DISTANCE:
      s.max_distance = g_value_get_double (value);
      break;
    case PROP_USE_LIGHTNESS:
      s.use_lightness = g_value_get_boolean (value);
      break;
    case PROP_OUTPUT:
      s.output = (GstLabSegmentOutput) g_value_get_enum (value);
      break;
    case PROP_POST_MESSAGES:
      s.post_messages = g_value_get_boolean (value);
      break;
    case PROP_RARE_CLASSES:
      s.rare_classes = (GstLabSegmentRareClasses) g_value_get_enum (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

static void
gst_lab_segment_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  auto self = GST_LAB_SEGMENT (object);
  std::lock_guard<std::mutex> lk (*self->lock);
  const Settings & s = *self->settings;
  switch (prop_id) {
    case PROP_PALETTE:
      g_value_set_string (value, s.palette.empty ()? nullptr :
          s.palette.c_str ());
      break;
    case PROP_MIN_CLASS_PIXELS:
      g_value_set_uint (value, s.min_class_pixels);
      break;
    case PROP_MAX_DISTANCE:
      g_value_set_double (value, s.max_distance);
      break;
    case PROP_USE_LIGHTNESS:
      g_value_set_boolean (value, s.use_lightness);
      break;
    case PROP_OUTPUT:
      g_value_set_enum (value, s.output);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, s.post_messages);
      break;
    case PROP_RARE_CLASSES:
      g_value_set_enum (value, s.rare_classes);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

/* ---- configuration -------------------------------------------------- */

/* Loads the palette named by the settings into the state. A bad file
 * when starting (fatal) posts an error and returns FALSE; one set while
 * playing posts a warning and the previous palette stays (a robot should
 * not stop because a setting went wrong), as in every element. */
static gboolean
gst_lab_segment_load_palette (GstLabSegment * self, const std::string & path,
    guint generation, gboolean fatal)
{
  State & st = *self->state;
  landmark::Palette palette;
  if (path.empty ()) {
    palette = landmark::palette_default ();
  } else {
    std::string why;
    if (!landmark::palette_load_file (path, &palette, &why)) {
      if (fatal) {
        GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
            ("Could not use palette file \"%s\".", path.c_str ()),
            ("%s", why.c_str ()));
        return FALSE;
      }
      GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
          ("Could not use palette file \"%s\"; the previous palette stays.",
              path.c_str ()), ("%s", why.c_str ()));
      st.palette_generation = generation;
      return TRUE;
    }
  }
  st.palette = std::move (palette);
  st.palette_generation = generation;
  st.table_valid = false;

  const guint n = st.palette.classes.size ();
  value_array_init (&st.names, n);
  value_array_init (&st.markers, n);
  value_array_init (&st.rgb, n);
  for (const auto & c : st.palette.classes) {
    GValue v = G_VALUE_INIT;
    g_value_init (&v, G_TYPE_STRING);
    g_value_set_string (&v, c.name.c_str ());
    gst_value_array_append_and_take_value (&st.names, &v);
    value_array_append_boolean (&st.markers, c.marker);
    double rgb[3];
    landmark::lab_to_srgb (c.lab, rgb);
    value_array_append_uint (&st.rgb,
        ((guint) (rgb[0] * 255 + 0.5) << 16) |
        ((guint) (rgb[1] * 255 + 0.5) << 8) | (guint) (rgb[2] * 255 + 0.5));
  }
  GST_INFO_OBJECT (self, "palette %s: %u classes",
      path.empty ()? "(built-in)" : path.c_str (), n);
  return TRUE;
}

static void
gst_lab_segment_build_table (GstLabSegment * self, gdouble max_distance,
    gboolean use_lightness)
{
  State & st = *self->state;
  landmark::ClassifierConfig cfg;
  landmark::palette_references (st.palette, &cfg.refs, &cfg.ref_class);
  cfg.use_lightness = use_lightness;
  cfg.max_distance = max_distance;
  cfg.model = st.model;

  const auto t0 = std::chrono::steady_clock::now ();
  st.table.build (cfg, st.layout.order);
  const double ms = std::chrono::duration<double, std::milli> (
      std::chrono::steady_clock::now () - t0).count ();
  st.table_valid = true;
  st.table_max_distance = max_distance;
  st.table_use_lightness = use_lightness;

  st.display.clear ();
  for (const auto & c : st.palette.classes) {
    double rgb[3];
    std::array<uint8_t, 3> comp;
    landmark::lab_to_srgb (c.lab, rgb);
    st.model.from_srgb (rgb, comp.data ());
    st.display.push_back (comp);
  }
  const double black[3] = { 0, 0, 0 };
  st.model.from_srgb (black, st.black.data ());
  GST_INFO_OBJECT (self, "class table built in %.1f ms (%zu boundary cells)",
      ms, st.table.boundary_cells ());
}

static gboolean
gst_lab_segment_start (GstBaseTransform * trans)
{
  auto self = GST_LAB_SEGMENT (trans);
  std::string path;
  guint generation;
  {
    std::lock_guard<std::mutex> lk (*self->lock);
    path = self->settings->palette;
    generation = self->settings->palette_generation;
  }
  self->state->warned_no_class = false;
  return gst_lab_segment_load_palette (self, path, generation, TRUE);
}

static gboolean
gst_lab_segment_stop (GstBaseTransform * trans)
{
  auto self = GST_LAB_SEGMENT (trans);
  State & st = *self->state;
  if (st.plane_pool) {
    gst_buffer_pool_set_active (st.plane_pool, FALSE);
    gst_clear_object (&st.plane_pool);
  }
  st.table_valid = false;
  st.width = st.height = 0;
  return TRUE;
}

static gboolean
gst_lab_segment_set_info (GstVideoFilter * filter, GstCaps * incaps,
    GstVideoInfo * in_info, GstCaps * outcaps, GstVideoInfo * out_info)
{
  auto self = GST_LAB_SEGMENT (filter);
  State & st = *self->state;
  (void) incaps;
  (void) outcaps;
  (void) out_info;

  LandmarkFrameFormat format;
  if (!landmark_frame_format (in_info, &format)) {
    GST_ERROR_OBJECT (self, "unsupported format %s",
        GST_VIDEO_INFO_NAME (in_info));
    return FALSE;
  }
  FrameLayout layout;
  const landmark::InputModel model = format.model;
  switch (format.kind) {
    case LandmarkFrameFormat::Kind::PACKED:
      layout.layout = format.pixel_stride == 3 ? Layout::PACKED3 :
          Layout::PACKED4;
      for (int c = 0; c < 3; c++)
        layout.offset[c] = format.offset[c];
      /* G is always between R and B: the key is the three bytes from the
       * first of R and B, R low in RGB order and high in BGR order */
      layout.key_shift = 8 * MIN (layout.offset[0], layout.offset[2]);
      layout.order = layout.offset[0] < layout.offset[2] ?
          landmark::KeyOrder::C0_LOW : landmark::KeyOrder::C0_HIGH;
      break;
    case LandmarkFrameFormat::Kind::YUY2:
      layout.layout = Layout::YUY2;
      break;
    default:
      layout.layout = Layout::YUV420;
      break;
  }

  if (model != st.model || layout.order != st.layout.order)
    st.table_valid = false;
  st.layout = layout;
  st.model = model;

  const guint w = GST_VIDEO_INFO_WIDTH (in_info);
  const guint h = GST_VIDEO_INFO_HEIGHT (in_info);
  if (!st.plane_pool || w != st.width || h != st.height) {
    if (st.plane_pool) {
      gst_buffer_pool_set_active (st.plane_pool, FALSE);
      gst_clear_object (&st.plane_pool);
    }
    /* Label planes are recycled: a buffer returns to the pool when the
     * last meta holding it is freed downstream. */
    st.plane_pool = gst_buffer_pool_new ();
    GstStructure *config = gst_buffer_pool_get_config (st.plane_pool);
    gst_buffer_pool_config_set_params (config, nullptr,
        MAX ((gsize) w * h, 1), 2, 0);
    if (!gst_buffer_pool_set_config (st.plane_pool, config) ||
        !gst_buffer_pool_set_active (st.plane_pool, TRUE)) {
      GST_ERROR_OBJECT (self, "cannot allocate label planes of %ux%u", w, h);
      gst_clear_object (&st.plane_pool);
      return FALSE;
    }
    st.width = w;
    st.height = h;
  }
  GST_DEBUG_OBJECT (self, "configured for %" GST_PTR_FORMAT, incaps);
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static void
gst_lab_segment_post_histogram (GstLabSegment * self, GstBuffer * buf,
    const guint32 * counts, const guint8 * active, guint n,
    guint min_class_pixels)
{
  GstBaseTransform *trans = GST_BASE_TRANSFORM_CAST (self);
  const GstClockTime ts = GST_BUFFER_PTS (buf);
  GValue c = G_VALUE_INIT, a = G_VALUE_INIT;
  value_array_init (&c, n);
  value_array_init (&a, n);
  for (guint k = 0; k < n; k++) {
    value_array_append_uint (&c, counts[k + 1]);
    value_array_append_boolean (&a, active[k]);
  }
  GstStructure *s = gst_structure_new ("landmark-histogram",
      "timestamp", G_TYPE_UINT64, ts,
      "stream-time", G_TYPE_UINT64,
      gst_segment_to_stream_time (&trans->segment, GST_FORMAT_TIME, ts),
      "running-time", G_TYPE_UINT64,
      gst_segment_to_running_time (&trans->segment, GST_FORMAT_TIME, ts),
      "min-class-pixels", G_TYPE_UINT, min_class_pixels, nullptr);
  gst_structure_set_value (s, "class-names", &self->state->names);
  gst_structure_take_value (s, "class-counts", &c);
  gst_structure_take_value (s, "class-active", &a);
  gst_element_post_message (GST_ELEMENT_CAST (self),
      gst_message_new_element (GST_OBJECT_CAST (self), s));
}

static GstFlowReturn
gst_lab_segment_process (GstLabSegment * self, GstBuffer * buf,
    const Settings & s)
{
  GstVideoFilter *filter = GST_VIDEO_FILTER_CAST (self);
  State & st = *self->state;
  const bool draw = s.output == GST_LAB_SEGMENT_OUTPUT_LABELS;

  GstVideoFrame frame;
  if (!gst_video_frame_map (&frame, &filter->in_info, buf,
          (GstMapFlags) (draw ? GST_MAP_READWRITE : GST_MAP_READ))) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("Could not map video frame."),
        (nullptr));
    return GST_FLOW_ERROR;
  }
  const guint w = GST_VIDEO_FRAME_WIDTH (&frame);
  const guint h = GST_VIDEO_FRAME_HEIGHT (&frame);

  GstBuffer *plane = nullptr;
  if (gst_buffer_pool_acquire_buffer (st.plane_pool, &plane, nullptr) !=
      GST_FLOW_OK) {
    gst_video_frame_unmap (&frame);
    GST_ELEMENT_ERROR (self, RESOURCE, FAILED,
        ("Could not allocate a label plane."), (nullptr));
    return GST_FLOW_ERROR;
  }
  GstMapInfo pmap;
  gst_buffer_map (plane, &pmap, GST_MAP_WRITE);
  guint8 *labels = pmap.data;

  /* pass 1: nearest class over the whole palette, and its histogram */
  PixelReader reader { &frame, st.layout };
  classify_frame (st.table, reader, w, h, labels);
  const guint n = st.palette.classes.size ();
  guint32 counts[256];
  count_labels (labels, (gsize) w * h, n, counts);

  /* pixels in boundary cells not met before: fill those cells now */
  if (counts[ClassTable::kPending] > 0) {
    for (guint y = 0; y < h && counts[ClassTable::kPending] > 0; y++) {
      guint8 *row = labels + (gsize) y * w;
      if (!memchr (row, ClassTable::kPending, w))
        continue;
      reader.set_row (y);
      for (guint x = 0; x < w; x++) {
        if (row[x] != ClassTable::kPending)
          continue;
        guint8 c[3] = { 0, 0, 0 };
        reader.get (x, c);
        row[x] = st.table.resolve (c[0], c[1], c[2]);
        counts[row[x]]++;
        counts[ClassTable::kPending]--;
      }
    }
  }

  /* the dominant-colour rule */
  guint8 active[kMaxClasses] = { 0 };
  guint8 demoted[kMaxClasses + 1] = { 0 };
  bool any_demoted = false, any_active = false;
  for (guint k = 0; k < n; k++) {
    active[k] = s.min_class_pixels == 0 || counts[k + 1] >= s.min_class_pixels;
    any_active |= active[k] != 0;
    demoted[k + 1] = !active[k] && counts[k + 1] > 0;
    any_demoted |= demoted[k + 1] != 0;
  }
  guint32 final_counts[kMaxClasses + 1];
  memcpy (final_counts, counts, sizeof (final_counts));
  for (guint k = 0; k < n; k++)
    if (!active[k])
      final_counts[k + 1] = 0;

  /* pass 2: pixels of classes too rare to count (fewer than
   * n * min-class-pixels of them) go to the nearest active class, converted
   * in batches like the table's boundary cells, or lose their label */
  const bool to_nearest = any_active &&
      s.rare_classes == GST_LAB_SEGMENT_RARE_NEAREST;
  if (any_demoted && !to_nearest) {
    const gsize size = (gsize) w * h;
    for (gsize i = 0; i < size; i++)
      if (demoted[labels[i]])
        labels[i] = 0;
  } else if (any_demoted) {
    guint8 comps[3 * ClassTable::kBatch];
    guint8 *where[ClassTable::kBatch];
    guint8 relabel[ClassTable::kBatch];
    int pending = 0;
    auto flush = [&]() {
      st.table.classify_exact (comps, pending, active, relabel);
      for (int i = 0; i < pending; i++) {
        *where[i] = relabel[i];
        final_counts[relabel[i]]++;
      }
      pending = 0;
    };
    for (guint y = 0; y < h; y++) {
      guint8 *row = labels + (gsize) y * w;
      bool row_set = false;
      for (guint x = 0; x < w; x++) {
        if (!demoted[row[x]])
          continue;
        if (!row_set) {
          reader.set_row (y);
          row_set = true;
        }
        reader.get (x, comps + 3 * pending);
        where[pending++] = row + x;
        if (pending == ClassTable::kBatch)
          flush ();
      }
    }
    flush ();
  }
  guint32 classified = 0;
  for (guint k = 1; k <= n; k++)
    classified += final_counts[k];
  const guint32 unclassified = w * h - classified;

  if (draw)
    draw_false_colour (&frame, st.layout, labels, w, h, st.display,
        st.black);
  gst_buffer_unmap (plane, &pmap);
  gst_video_frame_unmap (&frame);

  GstStructure *meta = landmark_labels_meta_add (buf);
  GValue cv = G_VALUE_INIT, av = G_VALUE_INIT, lv = G_VALUE_INIT;
  value_array_init (&cv, n);
  value_array_init (&av, n);
  value_array_init (&lv, n);
  for (guint k = 0; k < n; k++) {
    value_array_append_uint (&cv, counts[k + 1]);
    value_array_append_boolean (&av, active[k]);
    value_array_append_uint (&lv, final_counts[k + 1]);
  }
  gst_structure_set (meta,
      LANDMARK_LABELS_PLANE, GST_TYPE_BUFFER, plane,
      LANDMARK_LABELS_WIDTH, G_TYPE_UINT, w,
      LANDMARK_LABELS_HEIGHT, G_TYPE_UINT, h,
      LANDMARK_LABELS_STRIDE, G_TYPE_UINT, w,
      LANDMARK_LABELS_ANALYSIS_WIDTH, G_TYPE_UINT, w,
      LANDMARK_LABELS_ANALYSIS_HEIGHT, G_TYPE_UINT, h,
      LANDMARK_LABELS_UNCLASSIFIED, G_TYPE_UINT, unclassified,
      LANDMARK_LABELS_MIN_CLASS_PIXELS, G_TYPE_UINT, s.min_class_pixels,
      LANDMARK_LABELS_MAX_DISTANCE, G_TYPE_DOUBLE, s.max_distance,
      LANDMARK_LABELS_USE_LIGHTNESS, G_TYPE_BOOLEAN, s.use_lightness, nullptr);
  gst_buffer_unref (plane);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_NAMES, &st.names);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_MARKERS, &st.markers);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_RGB, &st.rgb);
  gst_structure_take_value (meta, LANDMARK_LABELS_CLASS_COUNTS, &cv);
  gst_structure_take_value (meta, LANDMARK_LABELS_CLASS_ACTIVE, &av);
  gst_structure_take_value (meta, LANDMARK_LABELS_LABEL_COUNTS, &lv);

  if (!any_active && !st.warned_no_class && w * h > 0) {
    GST_WARNING_OBJECT (self, "no class reaches min-class-pixels=%u in a "
        "%ux%u frame: every pixel is unlabelled", s.min_class_pixels, w, h);
    st.warned_no_class = true;
  }
  if (s.post_messages)
    gst_lab_segment_post_histogram (self, buf, counts, active, n,
        s.min_class_pixels);
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_lab_segment_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LAB_SEGMENT (trans);
  State & st = *self->state;

  /* Snapshot the settings; copy the palette path only when it changed, so
   * the steady state allocates nothing here. */
  Settings s;
  std::string palette_path;
  bool reload = false;
  {
    std::lock_guard<std::mutex> lk (*self->lock);
    const Settings & cur = *self->settings;
    s.min_class_pixels = cur.min_class_pixels;
    s.max_distance = cur.max_distance;
    s.use_lightness = cur.use_lightness;
    s.output = cur.output;
    s.post_messages = cur.post_messages;
    s.rare_classes = cur.rare_classes;
    s.palette_generation = cur.palette_generation;
    if (cur.palette_generation != st.palette_generation) {
      palette_path = cur.palette;
      reload = true;
    }
  }

  try {
    if (reload && !gst_lab_segment_load_palette (self, palette_path,
            s.palette_generation, FALSE))
      return GST_FLOW_ERROR;
    if (!st.table_valid || st.table_max_distance != s.max_distance ||
        st.table_use_lightness != s.use_lightness)
      gst_lab_segment_build_table (self, s.max_distance, s.use_lightness);
    return gst_lab_segment_process (self, buf, s);
  }
  catch (const std::exception & e) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("Colour segmentation failed."),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
}

static void
gst_lab_segment_class_init (GstLabSegmentClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  GstVideoFilterClass *filter_class = GST_VIDEO_FILTER_CLASS (klass);

  gobject_class->set_property = gst_lab_segment_set_property;
  gobject_class->get_property = gst_lab_segment_get_property;
  gobject_class->finalize = gst_lab_segment_finalize;

  g_object_class_install_property (gobject_class, PROP_PALETTE,
      g_param_spec_string ("palette", "Palette file",
          "JSON palette file of reference colours (docs/palette.md); unset: "
          "built-in red, green, yellow, pink, blue markers and white, grey "
          "background", nullptr,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property (gobject_class, PROP_MIN_CLASS_PIXELS,
      g_param_spec_uint ("min-class-pixels", "Dominant-colour threshold",
          "Pixels a class needs in a frame's first-pass histogram to take "
          "part in the final labelling (0: every class takes part)",
          0, G_MAXUINT, DEFAULT_MIN_CLASS_PIXELS,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property (gobject_class, PROP_MAX_DISTANCE,
      g_param_spec_double ("max-distance", "Maximum colour distance",
          "Largest CIE76 Delta E from a class reference that still counts as "
          "that class; farther pixels get label 0",
          0.0, 1000.0, DEFAULT_MAX_DISTANCE,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property (gobject_class, PROP_USE_LIGHTNESS,
      g_param_spec_boolean ("use-lightness", "Use lightness",
          "Measure colour distance over L*, a* and b* (false: a* and b* only, "
          "the seed's first variant)", DEFAULT_USE_LIGHTNESS,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property (gobject_class, PROP_OUTPUT,
      g_param_spec_enum ("output", "Output",
          "What the video output shows", GST_TYPE_LAB_SEGMENT_OUTPUT,
          DEFAULT_OUTPUT,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages",
          "Post a landmark-histogram element message for every frame",
          DEFAULT_POST_MESSAGES,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));

  gst_element_class_set_static_metadata (element_class,
      "Lab colour segmentation", "Filter/Analyzer/Video",
      "Labels every pixel with its nearest palette colour in CIE L*a*b*, "
      "with the dominant-colour rule, as buffer metadata",
      "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  trans_class->start = GST_DEBUG_FUNCPTR (gst_lab_segment_start);
  trans_class->stop = GST_DEBUG_FUNCPTR (gst_lab_segment_stop);
  /* Our own transform_ip rather than transform_frame_ip: the frame is
   * mapped for writing only when output=labels, so analysing a shared
   * buffer (after a tee) does not copy it. */
  trans_class->transform_ip = GST_DEBUG_FUNCPTR (gst_lab_segment_transform_ip);
  filter_class->set_info = GST_DEBUG_FUNCPTR (gst_lab_segment_set_info);

  g_object_class_install_property (gobject_class, PROP_RARE_CLASSES,
      g_param_spec_enum ("rare-classes", "Rare classes",
          "Where pixels go whose nearest class has fewer than "
          "min-class-pixels pixels in the frame",
          GST_TYPE_LAB_SEGMENT_RARE_CLASSES, DEFAULT_RARE_CLASSES,
          (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_PLAYING)));

  gst_type_mark_as_plugin_api (GST_TYPE_LAB_SEGMENT_OUTPUT,
      (GstPluginAPIFlags) 0);
  gst_type_mark_as_plugin_api (GST_TYPE_LAB_SEGMENT_RARE_CLASSES,
      (GstPluginAPIFlags) 0);
}
