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
#include "overlaymeta.h"
#include "palette.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_overlay_debug);
#define GST_CAT_DEFAULT gst_landmark_overlay_debug

/* *INDENT-OFF* */
namespace {

namespace ov = landmark::overlay;

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

  /* the labels meta's classes, and the built-in palette's colours for
   * classes without one */
  ov::ClassColours colours;

  /* per-frame scratch, reused */
  std::vector<ov::Detection> detections;
  std::vector<ov::Rgb> map_colours;
  std::vector<ov::EstimatedLandmark> estimated;
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_ELEMENT (GstLandmarkOverlay, gst_landmark_overlay,
    Settings, State, GstVideoFilter, GST_TYPE_VIDEO_FILTER, landmarkoverlay,
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

static const landmark::FileSetting<State, Settings, ov::LandmarkMap>
    map_file = { &State::map, &Settings::map, &Settings::map_generation,
  "map", landmark_overlay_load_map
};

/* the settings and the map file
 * (landmark::change_state_checking_settings) */
static bool
gst_landmark_overlay_apply_settings (GstLandmarkOverlay * self)
{
  return landmark::apply_settings_and_file (self, map_file,
      gst_landmark_overlay_map_changed);
}

static gboolean
gst_landmark_overlay_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_OVERLAY (trans);
  self->priv->state.colours.init_defaults ();
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

/* ---- streaming ------------------------------------------------------ */

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
    const GstStructure * pose_s, ov::Estimate * est)
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
    lm.colour = st.colours.colour (cls && G_VALUE_HOLDS_STRING (cls) ?
        g_value_get_string (cls) : nullptr);
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

  return landmark::run_drawing_frame (GST_ELEMENT (self),
      "Drawing the overlay failed.", st.renderer, [&] {
        /* the settings are copied only after a change, so the steady state
         * allocates nothing here */
        landmark::sync_settings_and_file (self, map_file,
            gst_landmark_overlay_map_changed);
        const Settings & s = st.applied.config.s;
        const bool has_map = !st.map.path.empty ();

        /* what this frame has to show */
        const GstStructure *labels = landmark_labels_meta_get (buf);
        const GstStructure *pose_s = landmark_pose_meta_get (buf);
        ov::Pose pose;
        const bool has_pose = pose_s &&
            ov::meta_number (pose_s, "x", &pose.x) &&
            ov::meta_number (pose_s, "y", &pose.y) &&
            ov::meta_number (pose_s, "heading", &pose.heading);
        const bool has_rois = gst_buffer_get_meta (buf,
            GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE) != nullptr;
        const GstStructure *floor_s = (s.show_boundary ||
            (s.show_minimap && s.show_free_space)) ?
            landmark_floor_meta_get (buf) : nullptr;
        ov::FloorArrays fa;
        if (floor_s)
          ov::read_floor (floor_s, &fa);
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
        st.colours.read (labels, &hist);
        if (has_rois && (detections || minimap))
          ov::read_detections (buf, st.colours, w, h, &st.detections,
              GST_CAT_DEFAULT, G_OBJECT (self));
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
              st.map_colours.push_back (st.colours.colour (
                      lm.class_name.c_str ()));
          ov::Pose where = pose;
          if (!has_pose) {
            where = ov::Pose ();
            where.heading = M_PI / 2;
          }
          ov::Estimate est;
          if (map_meta)
            gst_landmark_overlay_read_estimate (st, map_meta, pose_s,
                &est);
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
}

static void
gst_landmark_overlay_class_init (GstLandmarkOverlayClass * klass)
{
  landmark::element_class_init<Settings, gst_landmark_overlay_settings,
      landmark_overlay_properties, gst_landmark_overlay_configure> (klass,
      gst_landmark_overlay_finalize, "Landmark overlay", "Filter/Effect/Video",
      "Draws landmark detections, robot pose, class histogram, class "
      "indicators and a mini-map of the landmark map onto the video");

  landmark::set_settings_lifecycle<GstLandmarkOverlay,
      gst_landmark_overlay_get_type, gst_landmark_overlay_apply_settings,
      gst_landmark_overlay_start> (klass, gst_landmark_overlay_stop);
  /* Our own transform_ip rather than transform_frame_ip: the frame is
   * mapped for writing only when there is something to draw. */
  GST_BASE_TRANSFORM_CLASS (klass)->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_overlay_transform_ip);
}
