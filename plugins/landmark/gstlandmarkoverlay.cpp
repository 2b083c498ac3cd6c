/**
 * SECTION:element-landmarkoverlay
 * @title: landmarkoverlay
 *
 * Draws the gst-landmark metadata of each frame onto the frame itself, in
 * place and in the frame's own format (no format change, no conversion of
 * the whole frame): what the seed's program showed in its window.
 *
 * - `show-detections`: every detection (`GstVideoRegionOfInterestMeta`,
 *   docs/metadata.md): the fitted ellipse of its `landmark-blob`
 *   parameters (`ellipse-x`, `ellipse-y`, `ellipse-major`, `ellipse-minor`,
 *   `ellipse-angle`, scaled from `frame-width` x `frame-height` to the
 *   current frame), or its bounding box when there is no ellipse, in the
 *   class colour with a dark halo, a cross at the centroid, and a label:
 *   the matched landmark id (`landmark-match`), the class name and the
 *   roundness (`rnd 0.93`) on the first line, the range with four
 *   decimals (the seed's `XX.XXXX`) in metres and the bearing in degrees
 *   (positive to the left) from `landmark-range` on the second. Rejected
 *   blobs (`kept=false`) are drawn dashed and grey with their
 *   `reject-reason`, unless `show-rejected=false`.
 * - `show-pose`: the pose of a `GstLandmarkPoseMeta` (`x`, `y` in metres,
 *   `heading` in degrees) as a text line at the bottom left.
 * - `show-histogram`: an inset at the top left with a bar per palette
 *   class of the labels meta (`class-counts` on a logarithmic scale, bars
 *   in `class-rgb`, classes below the threshold translucent) and the
 *   dominant-colour threshold `min-class-pixels` as a dashed line.
 * - `show-indicators`: under it, one round indicator per marker class,
 *   lit in the class colour when the class is active (`class-active`).
 * - `show-minimap`: an inset at the top right with a top-down view of the
 *   landmark map (`map`, a JSON file in the format of docs/conventions.md),
 *   the robot pose as a triangle, and for each detection with a range a
 *   ray from the robot along its bearing and, when it is matched to a map
 *   landmark, the range circle around that landmark. With a
 *   `GstLandmarkMapMeta` (landmarkslam), its landmarks with their 95 %
 *   uncertainty ellipses (solid and filled when confirmed, dashed rings
 *   when tentative) and the pose's 95 % ellipse. Drawn only when the
 *   frame has a pose meta and a map is set or a map meta is present.
 * - `show-boundary`: the floor boundary of a `GstLandmarkFloorMeta` across
 *   the image (red on obstacles, cyan where the floor reaches max-range).
 * - `show-free-space`: the floor meta's radial obstacle profile as a green
 *   polygon around the robot in the mini-map: in the map frame with a
 *   pose, robot-centred (forward up) without one.
 *
 * Sizes of text, lines and insets follow the frame height (`text-scale`
 * scales the text further). Without metadata (or with every part switched
 * off) frames pass through untouched and are not even mapped for writing.
 * Every property can change while playing; the map file is read when the
 * element starts and again when `map` is set. QoS is off: no frame is
 * ever dropped.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! avidemux ! jpegdec !
 *     videoconvert ! labsegment ! blobroundness ! landmarkoverlay
 *     map=map.json ! videoconvert ! autovideosink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlandmarkoverlay.h"

#include <gst/base/gstbasetransform.h>
#include <gst/video/video.h>

#include <array>
#include <cmath>
#include <cstring>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "elementsettings.h"
#include "frameformat.h"
#include "landmarkmeta.h"
#include "overlaydraw.h"
#include "palette.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_overlay_debug);
#define GST_CAT_DEFAULT gst_landmark_overlay_debug

/* *INDENT-OFF* */
namespace {

namespace ov = landmark::overlay;

using landmark::kMaxClasses;

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string map;              /* empty: no map */
  guint map_generation = 0;     /* sets of `map` */
  gboolean show_detections = TRUE;
  gboolean show_rejected = TRUE;
  gboolean show_pose = TRUE;
  gboolean show_histogram = TRUE;
  gboolean show_indicators = TRUE;
  gboolean show_minimap = TRUE;
  gboolean show_boundary = TRUE;
  gboolean show_free_space = TRUE;
  gdouble text_scale = 1.0;
};

/* Every value the properties accept is valid; the map file is read apart
 * (State::map). */
struct Config {
  Settings s;
};

/* Built in start() and set_info(), used by the streaming thread only. */
struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  landmark::SettingsFile<ov::LandmarkMap> map;   /* path "": no map */
  ov::LandmarkMap no_map;       /* drawn without a pose: robot-centred */

  ov::Renderer renderer;
  ov::Target target;

  /* built-in palette colours, the fallback for classes without a labels
   * meta */
  std::vector<std::pair<std::string, ov::Rgb>> default_colours;

  /* per-frame scratch, reused */
  std::vector<ov::Detection> detections;
  std::array<ov::ClassInfo, kMaxClasses> classes;
  std::vector<ov::Rgb> map_colours;
  std::vector<ov::EstimatedLandmark> estimated;
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_ELEMENT (GstLandmarkOverlay, gst_landmark_overlay,
    GstVideoFilter, GST_TYPE_VIDEO_FILTER, landmarkoverlay,
    "Draws landmark detections, pose, class histogram and map");

/* ---- configuration -------------------------------------------------- */

/* The map file; the empty path is no map. */
static bool
landmark_overlay_load_map (const std::string & path, ov::LandmarkMap * map,
    std::string * why)
{
  return path.empty () || landmark::map_load_file (path, map, why);
}

static const landmark::PropertyTable<Settings> &
landmark_overlay_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .file ("map", "Map file",
          "JSON landmark map (docs/conventions.md) for the mini-map; unset: "
          "no mini-map", &Settings::map, &Settings::map_generation)
      .boolean ("show-detections", "Show detections",
          "Draw each detection: ellipse or box, class, roundness, range, "
          "bearing and matched landmark", &Settings::show_detections)
      .boolean ("show-rejected", "Show rejected blobs",
          "Also draw blobs the filters rejected (landmark-blob kept=false), "
          "dashed and grey", &Settings::show_rejected)
      .boolean ("show-pose", "Show pose",
          "Write the robot pose (x, y in metres, heading in degrees) at the "
          "bottom left", &Settings::show_pose)
      .boolean ("show-histogram", "Show histogram",
          "Inset at the top left: pixels per class (log scale) with the "
          "min-class-pixels threshold", &Settings::show_histogram)
      .boolean ("show-indicators", "Show class indicators",
          "One indicator per marker class, lit when the class is active",
          &Settings::show_indicators)
      .boolean ("show-minimap", "Show mini-map",
          "Inset at the top right: the map, the robot pose and the range "
          "circles (needs a pose meta and the map property), or the free "
          "space alone", &Settings::show_minimap)
      .boolean ("show-boundary", "Show floor boundary",
          "The floor boundary of a floor meta across the image: red on "
          "obstacles, cyan where the floor reaches max-range or the top "
          "row", &Settings::show_boundary)
      .boolean ("show-free-space", "Show free space",
          "The floor meta's radial obstacle profile as a green polygon "
          "around the robot in the mini-map (in the map frame with a pose, "
          "robot-centred and forward up without one)",
          &Settings::show_free_space)
      .number ("text-scale", "Text scale",
          "Factor on the automatic text size (which follows the frame "
          "height)", &Settings::text_scale, 0.25, 8.0);
  return table;
}

static void
gst_landmark_overlay_map_changed (GstLandmarkOverlay * self)
{
  const auto & map = self->priv->state.map;
  if (!map.path.empty ())
    GST_INFO_OBJECT (self, "map %s: %zu landmarks", map.path.c_str (),
        map.contents.landmarks.size ());
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_landmark_overlay_init (GstLandmarkOverlay * self)
{
  self->priv = new GstLandmarkOverlayPrivate ();
  self->priv->state.detections.reserve (64);
  self->priv->state.map_colours.reserve (64);
  landmark::init_metadata_element (GST_BASE_TRANSFORM (self));
}

/* ---- states and caps ------------------------------------------------ */

static gboolean
gst_landmark_overlay_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_OVERLAY (trans);
  State & st = self->priv->state;
  if (!st.applied.start (GST_ELEMENT (self), self->priv->settings,
          landmark::accept_settings<Settings, Config>))
    return FALSE;
  const Settings & s = st.applied.config.s;
  if (!st.map.start (GST_ELEMENT (self), "map", s.map, s.map_generation,
          landmark_overlay_load_map))
    return FALSE;
  gst_landmark_overlay_map_changed (self);
  if (st.default_colours.empty ()) {
    for (const auto & c : landmark::palette_default ().classes) {
      double rgb[3];
      landmark::lab_to_srgb (c.lab, rgb);
      ov::Rgb col;
      col.r = (guint8) (rgb[0] * 255 + 0.5);
      col.g = (guint8) (rgb[1] * 255 + 0.5);
      col.b = (guint8) (rgb[2] * 255 + 0.5);
      st.default_colours.emplace_back (c.name, col);
    }
  }
  return TRUE;
}

static gboolean
gst_landmark_overlay_stop (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_OVERLAY (trans);
  self->priv->state.renderer.configure (0, 0);
  return TRUE;
}

static gboolean
gst_landmark_overlay_configure (GstVideoFilter * filter,
    const LandmarkFrameFormat & format, const GstVideoInfo * in_info)
{
  auto self = GST_LANDMARK_OVERLAY (filter);
  State & st = self->priv->state;
  ov::Target t;
  t.kind = format.kind == LandmarkFrameFormat::Kind::I420 ?
      ov::Target::Kind::I420 : format.kind == LandmarkFrameFormat::Kind::NV12 ?
      ov::Target::Kind::NV12 : format.kind == LandmarkFrameFormat::Kind::YUY2 ?
      ov::Target::Kind::YUY2 : ov::Target::Kind::PACKED;
  t.pixel_stride = format.pixel_stride;
  for (int c = 0; c < 3; c++)
    t.offset[c] = format.offset[c];
  t.model = format.model;
  t.width = GST_VIDEO_INFO_WIDTH (in_info);
  t.height = GST_VIDEO_INFO_HEIGHT (in_info);
  st.target = t;
  try {
    if (st.renderer.width () != t.width || st.renderer.height () != t.height)
      st.renderer.configure (t.width, t.height);
  }
  catch (const std::exception & e) {
    GST_ERROR_OBJECT (self, "cannot allocate the overlay canvas: %s",
        e.what ());
    return FALSE;
  }
  return TRUE;
}

/* ---- reading the metadata ------------------------------------------- */

namespace {

bool
get_number (const GstStructure * s, const char *field, double *out)
{
  const GValue *v = s ? gst_structure_get_value (s, field) : nullptr;
  if (!v)
    return false;
  if (G_VALUE_HOLDS_DOUBLE (v))
    *out = g_value_get_double (v);
  else if (G_VALUE_HOLDS_FLOAT (v))
    *out = g_value_get_float (v);
  else if (G_VALUE_HOLDS_INT (v))
    *out = g_value_get_int (v);
  else if (G_VALUE_HOLDS_UINT (v))
    *out = g_value_get_uint (v);
  else
    return false;
  return std::isfinite (*out);
}

bool
get_bool (const GstStructure * s, const char *field, bool *out)
{
  gboolean b;
  if (!s || !gst_structure_get_boolean (s, field, &b))
    return false;
  *out = b;
  return true;
}

ov::Rgb
rgb_from_uint (guint v)
{
  ov::Rgb c;
  c.r = (v >> 16) & 0xff;
  c.g = (v >> 8) & 0xff;
  c.b = v & 0xff;
  return c;
}

}  // namespace

/* The labels meta's classes; returns how many (0 without the meta). */
static int
gst_landmark_overlay_read_classes (State & st, const GstStructure * labels,
    ov::Histogram * hist)
{
  const guint n = MIN (landmark_labels_n_classes (labels), (guint) kMaxClasses);
  for (guint k = 0; k < n; k++) {
    ov::ClassInfo & ci = st.classes[k];
    ci = ov::ClassInfo ();
    ci.name = landmark_labels_class_name (labels, k);
    const GValue *v = landmark_labels_class_value (labels,
        LANDMARK_LABELS_CLASS_RGB, k);
    if (v && G_VALUE_HOLDS_UINT (v))
      ci.colour = rgb_from_uint (g_value_get_uint (v));
    ci.count = landmark_labels_class_count (labels, k);
    v = landmark_labels_class_value (labels, LANDMARK_LABELS_CLASS_ACTIVE,
        k);
    ci.active = v && G_VALUE_HOLDS_BOOLEAN (v) && g_value_get_boolean (v);
    v = landmark_labels_class_value (labels, LANDMARK_LABELS_CLASS_MARKERS,
        k);
    ci.marker = !(v && G_VALUE_HOLDS_BOOLEAN (v)) || g_value_get_boolean (v);
  }
  hist->classes = st.classes.data ();
  hist->n = (int) n;
  guint threshold = 0, aw = 0, ah = 0;
  gst_structure_get_uint (labels, LANDMARK_LABELS_MIN_CLASS_PIXELS,
      &threshold);
  hist->threshold = threshold;
  if (!gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_WIDTH, &aw) ||
      !gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_HEIGHT, &ah)) {
    gst_structure_get_uint (labels, LANDMARK_LABELS_WIDTH, &aw);
    gst_structure_get_uint (labels, LANDMARK_LABELS_HEIGHT, &ah);
  }
  hist->total = (double) aw * ah;
  return (int) n;
}

static ov::Rgb
gst_landmark_overlay_class_colour (const State & st, int n_classes,
    const char *name)
{
  if (name) {
    for (int k = 0; k < n_classes; k++)
      if (st.classes[k].name && !strcmp (st.classes[k].name, name))
        return st.classes[k].colour;
    for (const auto & dc : st.default_colours)
      if (dc.first == name)
        return dc.second;
  }
  return ov::Rgb ();
}

static void
gst_landmark_overlay_read_detections (GstLandmarkOverlay * self,
    GstBuffer * buf, int n_classes, int width, int height)
{
  State & st = self->priv->state;
  st.detections.clear ();
  gpointer iter = nullptr;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (buf, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    auto roi = (GstVideoRegionOfInterestMeta *) meta;
    ov::Detection d;
    d.class_name = g_quark_to_string (roi->roi_type);
    d.x = roi->x;
    d.y = roi->y;
    d.w = roi->w;
    d.h = roi->h;
    const GstStructure *blob =
        landmark_detection_get_param (buf, roi, LANDMARK_BLOB_PARAMS);
    if (blob) {
      if (const char *cls = gst_structure_get_string (blob, "class"))
        d.class_name = cls;
      double fw = 0, fh = 0;
      if (get_number (blob, "frame-width", &fw) && fw > 0)
        d.sx = width / fw;
      if (get_number (blob, "frame-height", &fh) && fh > 0)
        d.sy = height / fh;
      d.has_ellipse = get_number (blob, "ellipse-x", &d.ellipse_x) &&
          get_number (blob, "ellipse-y", &d.ellipse_y) &&
          get_number (blob, "ellipse-major", &d.ellipse_major) &&
          get_number (blob, "ellipse-minor", &d.ellipse_minor) &&
          d.ellipse_major >= 0 && d.ellipse_minor >= 0;
      if (d.has_ellipse && !get_number (blob, "ellipse-angle",
              &d.ellipse_angle))
        d.ellipse_angle = 0;
      d.has_centroid = get_number (blob, "centroid-x", &d.centroid_x) &&
          get_number (blob, "centroid-y", &d.centroid_y);
      d.has_roundness = get_number (blob, "roundness", &d.roundness);
      get_bool (blob, "kept", &d.kept);
      d.reject_reason = gst_structure_get_string (blob, "reject-reason");
    }
    const GstStructure *range =
        landmark_detection_get_param (buf, roi, LANDMARK_RANGE_PARAMS);
    if (range) {
      get_bool (range, "no-floor", &d.no_floor);
      d.has_range = get_number (range, "range", &d.range) && d.range >= 0;
      d.has_bearing = get_number (range, "bearing", &d.bearing);
    }
    const GstStructure *match =
        landmark_detection_get_param (buf, roi, LANDMARK_MATCH_PARAMS);
    if (match) {
      d.has_match = true;
      get_bool (match, "matched", &d.matched);
      d.landmark_id = gst_structure_get_string (match, "landmark-id");
    }
    /* rejected by any stage (shape, size, map) draws as rejected */
    const gchar *rejected_by;
    d.kept = !landmark_detection_rejected (buf, roi, &rejected_by,
        &d.reject_reason);
    d.colour = gst_landmark_overlay_class_colour (st, n_classes,
        d.class_name);
    GST_LOG_OBJECT (self, "detection %d %s bbox %g,%g %gx%g blob:%d "
        "ellipse:%d range:%d match:%d kept:%d", roi->id, d.class_name, d.x,
        d.y, d.w, d.h, blob != nullptr, d.has_ellipse, d.has_range,
        d.has_match, d.kept);
    st.detections.push_back (d);
  }
}

/* ---- streaming ------------------------------------------------------ */

namespace {

/* The arrays of a floor meta, mapped for the frame; unmapped when it goes
 * out of scope. A part whose arrays are missing or short stays null. */
struct FloorArrays {
  ov::Floor floor;
  struct Plane {
    GstBuffer *buf = nullptr;
    GstMapInfo map;
  } planes[4];
  int n = 0;

  FloorArrays () = default;
  FloorArrays (const FloorArrays &) = delete;
  FloorArrays & operator= (const FloorArrays &) = delete;
  ~FloorArrays () {
    for (int i = 0; i < n; i++) {
      gst_buffer_unmap (planes[i].buf, &planes[i].map);
      gst_buffer_unref (planes[i].buf);
    }
  }

  const void *get (const GstStructure * s, const char *field, gsize elem,
      gsize want) {
    Plane & p = planes[n];
    gsize count = 0;
    if (!landmark_floor_map_array (s, field, elem, &p.buf, &p.map, &count))
      return nullptr;
    n++;
    return count >= want && want > 0 ? p.map.data : nullptr;
  }
};

}  // namespace

static void
read_floor (const GstStructure * s, FloorArrays * fa)
{
  guint width = 0, height = 0, bins = 0;
  gdouble bin_width = 0;
  if (!gst_structure_get_uint (s, LANDMARK_FLOOR_WIDTH, &width) ||
      !gst_structure_get_uint (s, LANDMARK_FLOOR_HEIGHT, &height) ||
      !gst_structure_get_uint (s, LANDMARK_FLOOR_BEARING_BINS, &bins) ||
      !gst_structure_get_double (s, LANDMARK_FLOOR_BIN_WIDTH, &bin_width))
    return;
  ov::Floor & f = fa->floor;
  auto row = (const float *) fa->get (s, LANDMARK_FLOOR_BOUNDARY_ROW,
      sizeof (float), width);
  auto col_state = (const uint8_t *) fa->get (s,
      LANDMARK_FLOOR_BOUNDARY_STATE, 1, width);
  if (row && col_state && height > 0) {
    f.width = (int) width;
    f.height = (int) height;
    f.boundary_row = row;
    f.boundary_state = col_state;
  }
  auto range = (const float *) fa->get (s, LANDMARK_FLOOR_ROP_RANGE,
      sizeof (float), bins);
  auto bin_state = (const uint8_t *) fa->get (s, LANDMARK_FLOOR_ROP_STATE, 1,
      bins);
  if (range && bin_state && bin_width > 0) {
    f.bins = (int) bins;
    f.bin_width = bin_width;
    f.rop_range = range;
    f.rop_state = bin_state;
  }
}

/* The i-th double of an array field; false when absent or not a double. */
static bool
array_double (const GstStructure * s, const char *field, guint i, double *out)
{
  const GValue *a = gst_structure_get_value (s, field);
  if (!a || !GST_VALUE_HOLDS_ARRAY (a) || i >= gst_value_array_get_size (a))
    return false;
  const GValue *v = gst_value_array_get_value (a, i);
  if (!G_VALUE_HOLDS_DOUBLE (v))
    return false;
  *out = g_value_get_double (v);
  return true;
}

static const GValue *
array_value (const GstStructure * s, const char *field, guint i)
{
  const GValue *a = gst_structure_get_value (s, field);
  return a && GST_VALUE_HOLDS_ARRAY (a) && i < gst_value_array_get_size (a) ?
      gst_value_array_get_value (a, i) : nullptr;
}

/* landmarkslam's map meta into st.estimated (strings borrowed from the
 * meta for the frame); a landmark whose fields are missing is skipped, a
 * missing covariance draws no ellipse. The pose's x, y covariance block
 * from the pose meta's 3x3 `covariance`. */
static void
gst_landmark_overlay_read_estimate (State & st, const GstStructure * map_s,
    const GstStructure * pose_s, int n_classes, ov::Estimate * est)
{
  st.estimated.clear ();
  const GValue *ids = map_s ? gst_structure_get_value (map_s, "ids") : nullptr;
  const guint n = ids && GST_VALUE_HOLDS_ARRAY (ids) ?
      gst_value_array_get_size (ids) : 0;
  for (guint i = 0; i < n; i++) {
    ov::EstimatedLandmark lm;
    const GValue *id = gst_value_array_get_value (ids, i);
    const GValue *cls = array_value (map_s, "classes", i);
    const GValue *ok = array_value (map_s, "confirmed", i);
    if (!G_VALUE_HOLDS_STRING (id) || !array_double (map_s, "x", i, &lm.x) ||
        !array_double (map_s, "y", i, &lm.y))
      continue;
    lm.id = g_value_get_string (id);
    lm.colour = gst_landmark_overlay_class_colour (st, n_classes,
        cls && G_VALUE_HOLDS_STRING (cls) ? g_value_get_string (cls) : nullptr);
    lm.confirmed = ok && G_VALUE_HOLDS_BOOLEAN (ok) && g_value_get_boolean (ok);
    for (guint k = 0; k < 4; k++)
      if (!array_double (map_s, "covariance", 4 * i + k, &lm.cov[k]))
        lm.cov[0] = NAN;
    st.estimated.push_back (lm);
  }
  est->landmarks = st.estimated.data ();
  est->n = (int) st.estimated.size ();
  /* rows and columns x, y of the 3x3 over x, y, heading */
  est->has_pose_cov = pose_s != nullptr;
  for (guint k = 0; k < 4 && est->has_pose_cov; k++)
    est->has_pose_cov = array_double (pose_s, "covariance",
        (k / 2) * 3 + k % 2, &est->pose_cov[k]);
}

static GstFlowReturn
gst_landmark_overlay_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_OVERLAY (trans);
  GstVideoFilter *filter = GST_VIDEO_FILTER_CAST (self);
  State & st = self->priv->state;

  const GstFlowReturn ret = landmark::run_frame (GST_ELEMENT (self),
      "Drawing the overlay failed.", [&] {
        /* the settings are copied only after a change, so the steady state
         * allocates nothing here */
        if (st.applied.sync (GST_ELEMENT (self), self->priv->settings,
                landmark::accept_settings<Settings, Config>)) {
          const Settings & s = st.applied.config.s;
          if (st.map.sync (GST_ELEMENT (self), "map", s.map, s.map_generation,
                  landmark_overlay_load_map))
            gst_landmark_overlay_map_changed (self);
        }
        const Settings & s = st.applied.config.s;
        const bool has_map = !st.map.path.empty ();

        /* what this frame has to show */
        const GstStructure *labels = landmark_labels_meta_get (buf);
        const GstStructure *pose_s = landmark_pose_meta_get (buf);
        ov::Pose pose;
        const bool has_pose = pose_s && get_number (pose_s, "x", &pose.x) &&
            get_number (pose_s, "y", &pose.y) &&
            get_number (pose_s, "heading", &pose.heading);
        const bool has_rois = gst_buffer_get_meta (buf,
            GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE) != nullptr;
        const GstStructure *floor_s = (s.show_boundary ||
            (s.show_minimap && s.show_free_space)) ?
            landmark_floor_meta_get (buf) : nullptr;
        FloorArrays fa;
        if (floor_s)
          read_floor (floor_s, &fa);
        const bool boundary = s.show_boundary && fa.floor.boundary_row;
        const bool free_space = s.show_minimap && s.show_free_space &&
            fa.floor.rop_range;
        const bool panel = labels && (s.show_histogram || s.show_indicators);
        /* the map (or landmarkslam's estimate) needs a pose to be placed;
         * the free space is drawn robot-centred (forward up) without one */
        const GstStructure *map_meta = s.show_minimap && has_pose ?
            landmark_map_meta_get (buf) : nullptr;
        const bool map_frame = has_pose && (has_map || map_meta);
        const bool minimap = s.show_minimap && (map_frame || free_space);
        const bool detections = s.show_detections && has_rois;
        const bool pose_text = s.show_pose && has_pose;
        if (!panel && !minimap && !detections && !pose_text && !boundary)
          return GST_FLOW_OK;

        const int w = st.target.width, h = st.target.height;
        ov::Histogram hist;
        const int n_classes = labels ?
            gst_landmark_overlay_read_classes (st, labels, &hist) : 0;
        if (has_rois && (detections || minimap))
          gst_landmark_overlay_read_detections (self, buf, n_classes, w, h);
        else
          st.detections.clear ();

        GstVideoFrame frame;
        if (!gst_video_frame_map (&frame, &filter->in_info, buf,
                GST_MAP_READWRITE)) {
          GST_ELEMENT_ERROR (self, STREAM, FAILED,
              ("Could not map video frame."), (nullptr));
          return GST_FLOW_ERROR;
        }
        ov::Target t = st.target;
        for (guint p = 0; p < GST_VIDEO_FRAME_N_PLANES (&frame) && p < 3; p++) {
          t.data[p] = (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (&frame, p);
          t.stride[p] = GST_VIDEO_FRAME_PLANE_STRIDE (&frame, p);
        }

        ov::Renderer & r = st.renderer;
        r.begin_frame (s.text_scale);
        if (detections) {
          /* rejected blobs first, so kept ones are drawn over them */
          if (s.show_rejected)
            for (const auto & d : st.detections)
              if (!d.kept)
                r.draw_detection (d);
          for (const auto & d : st.detections)
            if (d.kept)
              r.draw_detection (d);
        }
        if (boundary)
          r.draw_boundary (fa.floor);
        if (panel)
          r.draw_class_panel (hist, s.show_histogram, s.show_indicators);
        if (minimap) {
          st.map_colours.clear ();
          const bool with_map = has_map && has_pose;
          if (with_map)
            for (const auto & lm : st.map.contents.landmarks)
              st.map_colours.push_back (gst_landmark_overlay_class_colour (st,
                      n_classes, lm.class_name.c_str ()));
          ov::Pose where = pose;
          if (!has_pose) {
            where = ov::Pose ();
            where.heading = M_PI / 2;
          }
          ov::Estimate est;
          if (map_meta)
            gst_landmark_overlay_read_estimate (st, map_meta, pose_s,
                n_classes, &est);
          r.draw_minimap (with_map ? st.map.contents : st.no_map,
              st.map_colours.data (), where, st.detections.data (),
              (int) st.detections.size (), free_space ? &fa.floor : nullptr,
              map_meta ? &est : nullptr);
        }
        if (pose_text)
          r.draw_pose_text (pose);
        r.draw_labels ();
        r.composite (t);
        gst_video_frame_unmap (&frame);
        return GST_FLOW_OK;
      });
  /* a frame that failed half drawn leaves nothing on the canvas */
  if (ret != GST_FLOW_OK)
    st.renderer.discard ();
  return ret;
}

static void
gst_landmark_overlay_class_init (GstLandmarkOverlayClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  GstVideoFilterClass *filter_class = GST_VIDEO_FILTER_CLASS (klass);
  const GParamFlags flags = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);

  gobject_class->finalize = gst_landmark_overlay_finalize;
  landmark::install_properties<Settings, gst_landmark_overlay_settings,
      landmark_overlay_properties> (gobject_class, flags);

  landmark_set_pixel_element_class (GST_ELEMENT_CLASS (klass),
      "Landmark overlay", "Filter/Effect/Video",
      "Draws landmark detections, robot pose, class histogram, class "
      "indicators and a mini-map of the landmark map onto the video");

  trans_class->start = GST_DEBUG_FUNCPTR (gst_landmark_overlay_start);
  trans_class->stop = GST_DEBUG_FUNCPTR (gst_landmark_overlay_stop);
  /* Our own transform_ip rather than transform_frame_ip: the frame is
   * mapped for writing only when there is something to draw. */
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_overlay_transform_ip);
  filter_class->set_info =
      landmark_pixel_set_info<gst_landmark_overlay_configure>;
}
