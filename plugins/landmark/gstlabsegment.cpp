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

#include <array>
#include <chrono>
#include <string>
#include <vector>

#include "classtable.h"
#include "elementsettings.h"
#include "frameformat.h"
#include "labsegmentpixels.h"
#include "landmarkmeta.h"
#include "analyticsmeta.h"
#include "palette.h"

GST_DEBUG_CATEGORY_STATIC (gst_lab_segment_debug);
#define GST_CAT_DEFAULT gst_lab_segment_debug

/* *INDENT-OFF* */
namespace {

using landmark::ClassTable;

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string palette;  /* empty: built-in palette */
  guint palette_generation = 0;     /* sets of `palette` */
  /* blobroundness's default min-area: a class with fewer pixels cannot hold
   * a blob it keeps, so the rule never hides a landmark (the seed used 500) */
  guint min_class_pixels = 100;
  gdouble max_distance = 1000.0;
  gboolean use_lightness = TRUE;
  GstLabSegmentOutput output = GST_LAB_SEGMENT_OUTPUT_PASSTHROUGH;
  gboolean post_messages = FALSE;
  GstLabSegmentRareClasses rare_classes = GST_LAB_SEGMENT_RARE_UNLABELLED;
  guint n_threads = 0;  /* 0: landmark::frame_threads decides */
  gboolean adapt = FALSE;
};

/* Every value the properties accept is valid; the palette file is read
 * apart (State::palette). */
struct Config {
  Settings s;
};

/* Built in start() and set_info(), used by the streaming thread only. */
struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  landmark::SettingsFile<landmark::Palette> palette;
  landmark::ClassTable table;
  bool table_valid = false;
  gdouble table_max_distance = -1;
  gboolean table_use_lightness = TRUE;
  /* adapt=true: the drift followed, the gains the table was built with,
   * frames since it was, and a frame's samples (kept: no allocation) */
  landmark::ColourDrift drift;
  /* the palette's reference colours and their classes (what the table is
   * built from, before gains) */
  std::vector<landmark::Lab> palette_refs;
  std::vector<int> palette_ref_class;
  /* each reference's shading segment; empty when no class has shading */
  std::vector<landmark::Lab> palette_dark, palette_light;
  std::array<double, 3> table_gains {1.0, 1.0, 1.0};
  guint frames_since_build = 0;
  bool rebuild_for_drift = false;
  landmark::ClassColourSums samples;

  landmark::FrameLayout layout;
  landmark::InputModel model;
  guint width = 0, height = 0;
  GstBufferPool *plane_pool = nullptr;
  /* started on the first frame that needs them, resized when n-threads or
   * the frame size changes the count */
  landmark::PixelWorkers workers;

  /* per-class colour in the frame's own components, for output=labels */
  std::vector<std::array<uint8_t, 3>> display;
  std::array<uint8_t, 3> black {};
  /* constant meta fields, rebuilt with the palette */
  GValue names = G_VALUE_INIT, markers = G_VALUE_INIT, roles = G_VALUE_INIT,
      rgb = G_VALUE_INIT;
  bool warned_no_class = false;

  ~State () {
    if (plane_pool) {
      gst_buffer_pool_set_active (plane_pool, FALSE);
      gst_object_unref (plane_pool);
    }
    g_value_unset (&names);
    g_value_unset (&markers);
    g_value_unset (&roles);
    g_value_unset (&rgb);
  }
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstLabSegment, gst_lab_segment,
    Settings, State, GstVideoFilter, GST_TYPE_VIDEO_FILTER, labsegment,
    "CIE L*a*b* colour segmentation");

LANDMARK_DEFINE_ENUM_TYPE (gst_lab_segment_output_get_type,
    "GstLabSegmentOutput",
    {GST_LAB_SEGMENT_OUTPUT_PASSTHROUGH,
        "Video unchanged; labels as metadata only", "passthrough"},
    {GST_LAB_SEGMENT_OUTPUT_LABELS,
        "False-colour view of the class labels", "labels"});

LANDMARK_DEFINE_ENUM_TYPE (gst_lab_segment_rare_classes_get_type,
    "GstLabSegmentRareClasses",
    {GST_LAB_SEGMENT_RARE_NEAREST,
        "The nearest class that reached the threshold (the seed's rule)",
        "nearest"},
    {GST_LAB_SEGMENT_RARE_UNLABELLED, "No class (label 0)", "unlabelled"});

/* ---- configuration -------------------------------------------------- */

/* The palette file, or the built-in palette for the empty path. */
static bool
lab_segment_load_palette (const std::string & path,
    landmark::Palette * palette, std::string * why)
{
  if (path.empty ()) {
    *palette = landmark::palette_default ();
    return true;
  }
  return landmark::palette_load_file (path, palette, why);
}

static const landmark::PropertyTable<Settings> &
lab_segment_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .file ("palette", "Palette file",
          "JSON palette file of reference colours (docs/palette.md); unset: "
          "built-in red, green, yellow, pink, blue markers and white, grey "
          "background", &Settings::palette, &Settings::palette_generation)
      .number ("min-class-pixels", "Dominant-colour threshold",
          "Pixels a class needs in a frame's first-pass histogram to take "
          "part in the final labelling (0: every class takes part)",
          &Settings::min_class_pixels, 0u, G_MAXUINT)
      .number ("max-distance", "Maximum colour distance",
          "Largest CIE76 Delta E from a class reference that still counts as "
          "that class; farther pixels get label 0",
          &Settings::max_distance, 0.0, 1000.0)
      .boolean ("use-lightness", "Use lightness",
          "Measure colour distance over L*, a* and b* (false: a* and b* only, "
          "the seed's first variant)", &Settings::use_lightness)
      .enumeration ("output", "Output", "What the video output shows",
          &Settings::output, GST_TYPE_LAB_SEGMENT_OUTPUT)
      .boolean ("post-messages", "Post messages",
          "Post a landmark-histogram element message for every frame",
          &Settings::post_messages)
      .enumeration ("rare-classes", "Rare classes",
          "Where pixels go whose nearest class has fewer than "
          "min-class-pixels pixels in the frame", &Settings::rare_classes,
          GST_TYPE_LAB_SEGMENT_RARE_CLASSES)
      .number ("n-threads", "Threads",
          "Threads that label a frame in horizontal slices, with results "
          "identical to one thread (0: every core for frames of 1920x1080 "
          "pixels and more, one below)", &Settings::n_threads, 0u,
          landmark::WorkerPool::kMaxThreads)
      .boolean ("adapt", "Follow drift",
          "Follow the camera's exposure and white-balance drift: channel "
          "gains that carry the palette's one-colour classes onto their "
          "pixels are estimated over recent frames (within one stop, and 15 "
          "% between red, green and blue) and the references re-made with "
          "them", &Settings::adapt);
  return table;
}

/* (Re)initialises v as an empty GstValueArray with room for n values. */
static void
value_array_init (GValue * v, guint n)
{
  if (G_IS_VALUE (v))
    g_value_unset (v);
  gst_value_array_init (v, n);
}

/* A new palette: the meta fields that depend on it only, and the table. */
static void
gst_lab_segment_palette_changed (GstLabSegment * self)
{
  State & st = self->priv->state;
  st.table_valid = false;
  const landmark::Palette & palette = st.palette.contents;
  const guint n = palette.classes.size ();
  value_array_init (&st.names, n);
  value_array_init (&st.markers, n);
  value_array_init (&st.roles, n);
  value_array_init (&st.rgb, n);
  for (const auto & c : palette.classes) {
    landmark_value_array_append_string (&st.names, c.name.c_str ());
    landmark_value_array_append_boolean (&st.markers, c.marker);
    landmark_value_array_append_string (&st.roles,
        landmark::palette_role_name (c.role));
    double rgb[3];
    landmark::lab_to_srgb (c.lab, rgb);
    landmark_value_array_append_uint (&st.rgb,
        ((guint) (rgb[0] * 255 + 0.5) << 16) |
        ((guint) (rgb[1] * 255 + 0.5) << 8) | (guint) (rgb[2] * 255 + 0.5));
  }
  std::vector<landmark::Lab> labs;
  std::vector<bool> single;
  for (const auto & c : palette.classes) {
    labs.push_back (c.lab);
    single.push_back (c.references.size () <= 1);
  }
  st.drift.reset (labs, single);
  landmark::palette_references (palette, &st.palette_refs,
      &st.palette_ref_class);
  st.palette_dark.clear ();
  st.palette_light.clear ();
  for (const auto & c : palette.classes)
    if (c.shade_lo != 1.0 || c.shade_hi != 1.0) {
      landmark::palette_shading_ends (palette, &st.palette_dark,
          &st.palette_light);
      break;
    }
  GST_INFO_OBJECT (self, "palette %s: %u classes",
      st.palette.path.empty ()? "(built-in)" : st.palette.path.c_str (), n);
}

static void
gst_lab_segment_build_table (GstLabSegment * self, gdouble max_distance,
    gboolean use_lightness, const std::array<double, 3> & gains)
{
  State & st = self->priv->state;
  landmark::ClassifierConfig cfg;
  cfg.refs = st.palette_refs;
  cfg.ref_class = st.palette_ref_class;
  cfg.dark = st.palette_dark;
  cfg.light = st.palette_light;
  if (gains != std::array<double, 3> {1.0, 1.0, 1.0})
    for (auto *refs : {&cfg.refs, &cfg.dark, &cfg.light})
      for (landmark::Lab & ref : *refs)
        ref = landmark::lab_under_gains (ref, gains);
  st.table_gains = gains;
  st.frames_since_build = 0;
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
  for (const auto & c : st.palette.contents.classes) {
    double rgb[3];
    std::array<uint8_t, 3> comp;
    landmark::lab_to_srgb (c.lab, rgb);
    st.model.from_srgb (rgb, comp.data ());
    st.display.push_back (comp);
  }
  const double black[3] = { 0, 0, 0 };
  st.model.from_srgb (black, st.black.data ());
  GST_INFO_OBJECT (self, "class table built in %.1f ms (%zu boundary cells, "
      "gains %.3f %.3f %.3f)", ms, st.table.boundary_cells (), gains[0],
      gains[1], gains[2]);
}

/* ---- states and caps ------------------------------------------------ */

static const landmark::FileSetting<State, Settings, landmark::Palette>
    palette_file = { &State::palette, &Settings::palette,
  &Settings::palette_generation, "palette", lab_segment_load_palette
};

/* the settings and the palette file
 * (landmark::change_state_checking_settings) */
static bool
gst_lab_segment_apply_settings (GstLabSegment * self)
{
  return landmark::apply_settings_and_file (self, palette_file,
      gst_lab_segment_palette_changed);
}

static gboolean
gst_lab_segment_start (GstBaseTransform * trans)
{
  auto self = GST_LAB_SEGMENT (trans);
  self->priv->state.warned_no_class = false;
  return TRUE;
}

static gboolean
gst_lab_segment_stop (GstBaseTransform * trans)
{
  auto self = GST_LAB_SEGMENT (trans);
  State & st = self->priv->state;
  if (st.plane_pool) {
    gst_buffer_pool_set_active (st.plane_pool, FALSE);
    gst_clear_object (&st.plane_pool);
  }
  st.table_valid = false;
  st.width = st.height = 0;
  st.workers.set_threads (1);
  return TRUE;
}

static gboolean
gst_lab_segment_configure (GstVideoFilter * filter,
    const LandmarkFrameFormat & format, const GstVideoInfo * in_info)
{
  auto self = GST_LAB_SEGMENT (filter);
  State & st = self->priv->state;
  const landmark::FrameLayout layout = landmark::frame_layout (format);
  if (format.model != st.model || layout.order != st.layout.order)
    st.table_valid = false;
  st.layout = layout;
  st.model = format.model;

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
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static void
gst_lab_segment_post_histogram (GstLabSegment * self, GstBuffer * buf,
    const guint32 * counts, const guint8 * active, guint n,
    guint min_class_pixels)
{
  GValue c = G_VALUE_INIT, a = G_VALUE_INIT;
  gst_value_array_init (&c, n);
  gst_value_array_init (&a, n);
  for (guint k = 0; k < n; k++) {
    landmark_value_array_append_uint (&c, counts[k + 1]);
    landmark_value_array_append_boolean (&a, active[k]);
  }
  GstStructure *s = landmark_frame_message_new ("landmark-histogram", buf,
      &GST_BASE_TRANSFORM_CAST (self)->segment);
  gst_structure_set (s, "min-class-pixels", G_TYPE_UINT, min_class_pixels,
      nullptr);
  gst_structure_set_value (s, "class-names", &self->priv->state.names);
  gst_structure_take_value (s, "class-counts", &c);
  gst_structure_take_value (s, "class-active", &a);
  gst_element_post_message (GST_ELEMENT_CAST (self),
      gst_message_new_element (GST_OBJECT_CAST (self), s));
}

/* Attaches the labels meta: the plane and what the frame's passes found. */
static void
gst_lab_segment_attach_labels (GstLabSegment * self, GstBuffer * buf,
    GstBuffer * plane, guint w, guint h, const guint32 * counts,
    const landmark::ClassRule & rule, const Settings & s)
{
  State & st = self->priv->state;
  const guint n = st.palette.contents.classes.size ();
  guint32 classified = 0;
  for (guint k = 1; k <= n; k++)
    classified += rule.final_counts[k];

  GstStructure *meta = landmark_labels_meta_add (buf);
  GValue cv = G_VALUE_INIT, av = G_VALUE_INIT, lv = G_VALUE_INIT;
  gst_value_array_init (&cv, n);
  gst_value_array_init (&av, n);
  gst_value_array_init (&lv, n);
  for (guint k = 0; k < n; k++) {
    landmark_value_array_append_uint (&cv, counts[k + 1]);
    landmark_value_array_append_boolean (&av, rule.active[k]);
    landmark_value_array_append_uint (&lv, rule.final_counts[k + 1]);
  }
  gst_structure_set (meta,
      LANDMARK_LABELS_PLANE, GST_TYPE_BUFFER, plane,
      LANDMARK_LABELS_WIDTH, G_TYPE_UINT, w,
      LANDMARK_LABELS_HEIGHT, G_TYPE_UINT, h,
      LANDMARK_LABELS_STRIDE, G_TYPE_UINT, w,
      LANDMARK_LABELS_ANALYSIS_WIDTH, G_TYPE_UINT, w,
      LANDMARK_LABELS_ANALYSIS_HEIGHT, G_TYPE_UINT, h,
      LANDMARK_LABELS_UNCLASSIFIED, G_TYPE_UINT, w * h - classified,
      LANDMARK_LABELS_MIN_CLASS_PIXELS, G_TYPE_UINT, s.min_class_pixels,
      LANDMARK_LABELS_MAX_DISTANCE, G_TYPE_DOUBLE, s.max_distance,
      LANDMARK_LABELS_USE_LIGHTNESS, G_TYPE_BOOLEAN, s.use_lightness, nullptr);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_NAMES, &st.names);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_MARKERS, &st.markers);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_ROLES, &st.roles);
  gst_structure_set_value (meta, LANDMARK_LABELS_CLASS_RGB, &st.rgb);
  gst_structure_take_value (meta, LANDMARK_LABELS_CLASS_COUNTS, &cv);
  gst_structure_take_value (meta, LANDMARK_LABELS_CLASS_ACTIVE, &av);
  gst_structure_take_value (meta, LANDMARK_LABELS_LABEL_COUNTS, &lv);
  if (s.adapt) {
    GValue gv = G_VALUE_INIT;
    gst_value_array_init (&gv, 3);
    for (double g : st.table_gains)
      landmark_value_array_append_double (&gv, g);
    gst_structure_take_value (meta, LANDMARK_LABELS_COLOUR_GAINS, &gv);
  }
}

/* adapt=true: takes the frame's labelled colours into the drift estimate;
 * once the references it gives differ from the table's by a
 * just-noticeable difference, the table is rebuilt before the next frame
 * (at most every kDriftRebuildFrames frames: a build costs milliseconds). */
static void
gst_lab_segment_follow_drift (GstLabSegment * self,
    const GstVideoFrame * frame, const guint8 * labels, guint n)
{
  constexpr guint kDriftRebuildFrames = 10;
  constexpr double kJustNoticeable = 2.3;
  State & st = self->priv->state;
  landmark::class_colour_sums (frame, st.layout, st.model, labels, n,
      &st.samples);
  st.frames_since_build++;
  if (!st.drift.update (st.samples) ||
      st.frames_since_build < kDriftRebuildFrames)
    return;
  /* the table holds the references under the gains it was built with */
  const std::vector<landmark::Lab> & built = st.table.config ().refs;
  for (size_t i = 0; i < built.size () && i < st.palette_refs.size (); i++) {
    const landmark::Lab now = landmark::lab_under_gains (st.palette_refs[i],
        st.drift.gains ());
    if (std::hypot (now.L - built[i].L, now.a - built[i].a,
            now.b - built[i].b) > kJustNoticeable) {
      st.rebuild_for_drift = true;
      return;
    }
  }
}

static GstFlowReturn
gst_lab_segment_process (GstLabSegment * self, GstBuffer * buf,
    const Settings & s)
{
  GstVideoFilter *filter = GST_VIDEO_FILTER_CAST (self);
  State & st = self->priv->state;
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

  /* pass 1: nearest class over the whole palette, and its histogram;
   * pass 2: the dominant-colour rule */
  const guint n = st.palette.contents.classes.size ();
  st.workers.set_threads (landmark::frame_threads (s.n_threads,
          (gsize) w * h));
  guint32 counts[256];
  landmark::label_frame (st.table, &frame, st.layout, n, labels, counts,
      st.workers);
  landmark::ClassRule rule;
  landmark::dominant_colour_rule (st.table, &frame, st.layout, n,
      s.min_class_pixels, s.rare_classes == GST_LAB_SEGMENT_RARE_NEAREST,
      counts, labels, &rule, st.workers.pool);

  if (s.adapt)
    gst_lab_segment_follow_drift (self, &frame, labels, n);
  if (draw)
    landmark::draw_false_colour (&frame, st.layout, labels, st.display,
        st.black, st.workers.pool);
  gst_buffer_unmap (plane, &pmap);
  gst_video_frame_unmap (&frame);

  gst_lab_segment_attach_labels (self, buf, plane, w, h, counts, rule, s);
  gst_buffer_unref (plane);
  landmark_analytics_sync (buf);

  if (!rule.any_active && !st.warned_no_class && w * h > 0) {
    GST_WARNING_OBJECT (self, "no class reaches min-class-pixels=%u in a "
        "%ux%u frame: every pixel is unlabelled", s.min_class_pixels, w, h);
    st.warned_no_class = true;
  }
  if (s.post_messages)
    gst_lab_segment_post_histogram (self, buf, counts, rule.active, n,
        s.min_class_pixels);
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_lab_segment_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LAB_SEGMENT (trans);
  State & st = self->priv->state;
  return landmark::run_frame (GST_ELEMENT (self),
      "Colour segmentation failed.", [&] {
        /* the settings are copied only after a change, so the steady
         * state allocates nothing here */
        landmark::sync_settings_and_file (self, palette_file,
            gst_lab_segment_palette_changed);
        const Settings & s = st.applied.config.s;
        static constexpr std::array<double, 3> kNoGains {1.0, 1.0, 1.0};
        if (!s.adapt && st.table_gains != kNoGains) {
          /* adapt turned off: the palette as it is, and a fresh start
           * when it is turned on again */
          gst_lab_segment_palette_changed (self);
        }
        if (!st.table_valid || st.table_max_distance != s.max_distance ||
            st.table_use_lightness != s.use_lightness ||
            st.rebuild_for_drift) {
          st.rebuild_for_drift = false;
          gst_lab_segment_build_table (self, s.max_distance,
              s.use_lightness, s.adapt ? st.drift.gains () : kNoGains);
        }
        return gst_lab_segment_process (self, buf, s);
      });
}

static void
gst_lab_segment_class_init (GstLabSegmentClass * klass)
{
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark::element_class_init<Settings, gst_lab_segment_settings,
      lab_segment_properties, gst_lab_segment_configure> (klass,
      gst_lab_segment_finalize, "Lab colour segmentation",
      "Filter/Analyzer/Video",
      "Labels every pixel with its nearest palette colour in CIE L*a*b*, "
      "with the dominant-colour rule, as buffer metadata");

  landmark::set_settings_lifecycle<GstLabSegment, gst_lab_segment_get_type,
      gst_lab_segment_apply_settings, gst_lab_segment_start> (klass,
      gst_lab_segment_stop);
  /* Our own transform_ip rather than transform_frame_ip: the frame is
   * mapped for writing only when output=labels, so analysing a shared
   * buffer (after a tee) does not copy it. */
  trans_class->transform_ip = GST_DEBUG_FUNCPTR (gst_lab_segment_transform_ip);

  gst_type_mark_as_plugin_api (GST_TYPE_LAB_SEGMENT_OUTPUT,
      (GstPluginAPIFlags) 0);
  gst_type_mark_as_plugin_api (GST_TYPE_LAB_SEGMENT_RARE_CLASSES,
      (GstPluginAPIFlags) 0);
}
