/**
 * SECTION:element-floorboundary
 * @title: floorboundary
 *
 * The free floor in front of the robot, from the class labels `labsegment`
 * attaches (`GstLandmarkLabelsMeta`): per image column, walking up from the
 * bottom row, the row where the floor ends (a run of at least
 * `min-obstacle-rows` pixels of non-floor classes, so specks, texture and
 * thin shadows do not end it); that point mapped to the floor through the
 * camera model of `ipmrange` (pinhole, camera file, roll, the seed's
 * model: the same properties); and the Radial Obstacle Profile (ROP): per
 * bearing bin, the free range (docs/floorboundary.md).
 *
 * The floor is the classes named in `floor-classes` (unset: the classes
 * whose palette role is floor, or, when the palette names none, every class
 * it does not mark as a marker). Marker classes are walked over as
 * floor (a landmark disc on the floor is not an obstacle); the nearest
 * marker pixel per bin is reported in `rop-marker-range`.
 * `markers=detections` walks over marker pixels only inside the boxes of
 * accepted detections (floorboundary after blobroundness): a box of a
 * marker's colour is then an obstacle. `markers=obstacles` makes markers
 * end the floor like any obstacle (landmark balls). With
 * `max-marker-length`, a run of marker pixels longer than that on the
 * floor stands up (a ball) and ends the floor at its bulge. After
 * `ipmrange`, every accepted detection it ranged as a ball (`marker-kind`
 * ball, with its diameter) stands in the profile as its circle on the
 * floor: the bins it covers end at its bulge. After `blobroundness`, the
 * pixels within 1.5 pixels of every other accepted detection's ellipse
 * are floor (a disc's rim, blended with the floor, does not end it).
 *
 * Each frame with labels gets a `GstLandmarkFloorMeta` (docs/metadata.md):
 * `width`, `height` (the analysed label plane), `bearing-bins`,
 * `bin-width` (radians), `max-range` (metres), `rop-range`,
 * `rop-marker-range` (float32 per bin), `rop-state` (uint8 per bin: 0 not
 * seen, 1 free up to max-range, 2 obstacle at rop-range, 3 free up to
 * rop-range where the image ends), `boundary-row`, `boundary-x`,
 * `boundary-y` (float32 per column: the boundary's image row and floor
 * point, robot frame), `boundary-state` (uint8 per column),
 * `nearest-range`, `nearest-bearing` (the nearest obstacle; absent without
 * one). With `post-messages=true` a `landmark-obstacles` element message
 * per frame carries `timestamp`, `stream-time`, `running-time`,
 * `bearing-bins`, `bin-width`, `max-range`, `ranges` and `states` (arrays
 * per bin) and `nearest-range`, `nearest-bearing`.
 *
 * Video passes unchanged and is never mapped. Without a labels meta,
 * buffers pass untouched and one warning is posted. Every property may
 * change while playing; a bad value set while playing is reported with a
 * warning and the previous settings stay in force. Bad settings, a camera
 * that sees no floor, and labels without a floor class are errors.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! avidemux ! jpegdec !
 *     videoconvert ! labsegment ! floorboundary camera-height=0.3 tilt=25
 *     hfov=60 post-messages=true ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstfloorboundary.h"

#include <gst/video/video.h>

#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "fileutil.h"
#include "floorprofile.h"
#include "cameraprops.h"
#include "elementsettings.h"
#include "landmarkmeta.h"
#include "overlaymeta.h"

GST_DEBUG_CATEGORY_STATIC (gst_floor_boundary_debug);
#define GST_CAT_DEFAULT gst_floor_boundary_debug

#define MAX_BEARING_BINS 36000

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  landmark::CameraSettings camera;
  std::string floor_classes;    /* empty: every non-marker class */
  GstFloorBoundaryMarkers markers = GST_FLOOR_BOUNDARY_MARKERS_FLOOR;
  guint min_obstacle_rows = 6;
  guint bearing_bins = 360;
  gdouble max_range = 4.0;
  gboolean post_messages = FALSE;
  gdouble max_marker_length = 0.0;
};

/* Settings checked, with the camera file read. */
struct Config {
  landmark::CameraSetup camera;
  std::vector<std::string> floor_classes;
  GstFloorBoundaryMarkers markers = GST_FLOOR_BOUNDARY_MARKERS_FLOOR;
  landmark::FloorProfileParams profile;
  bool post_messages = false;
};

struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  landmark::CameraGeometry geometry;
  landmark::FloorProfile profile;
  guint built_w = 0, built_h = 0;     /* what profile was built for */

  /* the labels' classes, the video size, the warnings given */
  landmark::LabelsInput input;
  std::vector<guint> floor_labels;
  landmark::LabelRole role[256];

  std::vector<landmark::MarkerBox> marker_boxes;   /* markers=detections */
  std::vector<landmark::RangedBall> balls;   /* ranged by ipmrange */
  std::vector<landmark::ImageEllipse> discs;   /* the other landmarks */
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstFloorBoundary, gst_floor_boundary,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, floorboundary,
    "Floor boundary and radial obstacle profile");

LANDMARK_DEFINE_ENUM_TYPE (gst_floor_boundary_markers_get_type,
    "GstFloorBoundaryMarkers",
    {GST_FLOOR_BOUNDARY_MARKERS_FLOOR, "Marker pixels are walked over as "
          "floor and reported in rop-marker-range", "floor"},
    {GST_FLOOR_BOUNDARY_MARKERS_DETECTIONS, "Marker pixels are floor "
          "inside the boxes of accepted detections, obstacles elsewhere",
        "detections"},
    {GST_FLOOR_BOUNDARY_MARKERS_OBSTACLES, "Marker pixels end the floor "
          "like any obstacle", "obstacles"});

/* ---- configuration -------------------------------------------------- */

static bool
floor_boundary_parse (const Settings & s, Config * cfg,
    landmark::SettingsError * err)
{
  *cfg = Config ();
  if (!landmark::camera_setup_resolve (s.camera, &cfg->camera,
          &err->property, &err->why))
    return false;
  if (!landmark::parse_name_list (s.floor_classes, "floor-classes",
          &cfg->floor_classes, err))
    return false;
  if (!(s.max_range > 0))
    return err->fail ("max-range", "the range must be positive, got " +
        landmark::number_text (s.max_range));
  cfg->markers = s.markers;
  cfg->profile.min_obstacle_rows = (int) s.min_obstacle_rows;
  cfg->profile.bearing_bins = (int) s.bearing_bins;
  cfg->profile.max_range = s.max_range;
  cfg->profile.max_marker_length = s.max_marker_length;
  cfg->post_messages = s.post_messages;
  return true;
}

/* Builds the geometry and the profile's tables for a plane size. */
static bool
floor_boundary_build (const Config & cfg, guint w, guint h,
    landmark::CameraGeometry * geometry, landmark::FloorProfile * profile,
    landmark::SettingsError * err)
{
  landmark::CameraParams p;
  if (!landmark::camera_setup_params (cfg.camera, (int) w, (int) h, &p,
          &err->property, &err->why))
    return false;
  err->property = cfg.camera.e.seed ? "model" : "tilt";
  if (!geometry->configure (p, &err->why))
    return false;
  if (!profile->configure (*geometry, cfg.profile, &err->why)) {
    err->why += " (" + std::to_string (w) + "x" + std::to_string (h) + ")";
    return false;
  }
  return true;
}

static const landmark::PropertyTable<Settings> &
floor_boundary_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      /* the camera: ipmrange's properties, the same meanings */
      .part (&Settings::camera, camera_properties ())
      /* the floor */
      .string ("floor-classes", "Floor classes",
          "Comma-separated class names that are floor (unset: the classes "
          "whose palette role is floor, or every non-marker class when it "
          "names none)", &Settings::floor_classes)
      .enumeration ("markers", "Markers",
          "What pixels of marker classes are for the walk: floor (landmark "
          "discs lie on it), floor only inside accepted detections (put "
          "floorboundary after blobroundness), or obstacles (landmark "
          "balls)", &Settings::markers, GST_TYPE_FLOOR_BOUNDARY_MARKERS)
      .number ("min-obstacle-rows", "Minimum obstacle rows",
          "Rows of non-floor pixels in a column, one above the other, that "
          "end the floor; shorter runs (specks, texture, thin shadows) do "
          "not", &Settings::min_obstacle_rows, 1u, 255u)
      .number ("bearing-bins", "Bearing bins",
          "Bins of the radial obstacle profile over the full circle; bin 0 "
          "straight ahead, bin k at k * 360 / bearing-bins degrees to the "
          "left", &Settings::bearing_bins, 1u, (guint) MAX_BEARING_BINS)
      .number ("max-range", "Maximum range",
          "Metres: floor free this far counts as free, farther obstacles "
          "are not reported", &Settings::max_range, 0.0, 1000.0)
      .number ("max-marker-length", "Maximum marker length",
          "Metres: a run of walked-over marker pixels whose floor points "
          "span more than this stands up (a landmark ball) and ends the "
          "floor at its bulge; about 1.5 x the landmark discs' diameter; 0: "
          "off", &Settings::max_marker_length, 0.0, 1000.0)
      .boolean ("post-messages", "Post messages",
          "Post a landmark-obstacles element message per frame",
          &Settings::post_messages);
  return table;
}

/* ---- states --------------------------------------------------------- */

static gboolean
gst_floor_boundary_start (GstBaseTransform * trans)
{
  State & st = GST_FLOOR_BOUNDARY (trans)->priv->state;
  st.built_w = st.built_h = 0;
  return TRUE;
}

static gboolean
gst_floor_boundary_stop (GstBaseTransform * trans)
{
  State & st = GST_FLOOR_BOUNDARY (trans)->priv->state;
  st.built_w = st.built_h = 0;
  st.input.classes.valid = false;
  return TRUE;
}

static gboolean
gst_floor_boundary_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps * outcaps)
{
  State & st = GST_FLOOR_BOUNDARY (trans)->priv->state;
  (void) outcaps;
  st.input.set_caps (incaps);
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

/* Brings the state up to date with settings changed while running. A bad
 * value (or a camera that then sees no floor) is reported with a warning
 * and the previous settings stay in force. */
static void
gst_floor_boundary_sync_settings (GstFloorBoundary * self)
{
  State & st = self->priv->state;
  landmark::CameraGeometry geometry;
  landmark::FloorProfile profile;
  /* before the first frame the caps' size stands in for the label plane's
   * (labsegment labels every pixel), so a camera set then that sees no floor
   * is refused here too instead of failing the first frame */
  const guint check_w = st.built_w > 0 ? st.built_w : st.input.video_width;
  const guint check_h = st.built_w > 0 ? st.built_h : st.input.video_height;
  auto parse_and_build = [&](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    return floor_boundary_parse (s, cfg, err) && (check_w < 2 || check_h < 2
        || floor_boundary_build (*cfg, check_w, check_h, &geometry,
            &profile, err));
  };
  if (!st.applied.sync (GST_ELEMENT (self), self->priv->settings,
          parse_and_build))
    return;
  st.input.classes.valid = false;     /* floor-classes or markers may have changed */
  if (st.built_w > 0) {
    st.geometry = std::move (geometry);
    st.profile = std::move (profile);
  }
  GST_INFO_OBJECT (self, "settings changed");
}

/* The role of each label for this frame's palette. FALSE (error posted)
 * on an unknown class or when no class is floor. */
static gboolean
gst_floor_boundary_update_roles (GstFloorBoundary * self,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  if (!st.input.classes.changed (labels))
    return TRUE;
  const guint n = st.input.classes.names.size ();
  /* label 0 (no class) and labels beyond the palette: not floor */
  for (auto & r : st.role)
    r = landmark::LabelRole::Obstacle;
  const Config & cfg = st.applied.config;
  const landmark::LabelRole marker_role =
      cfg.markers == GST_FLOOR_BOUNDARY_MARKERS_OBSTACLES ?
      landmark::LabelRole::Obstacle : landmark::LabelRole::Marker;
  /* unset floor-classes: the palette's floor classes; a palette without
   * roles (or with no floor class) makes every non-marker class floor */
  bool palette_names_floor = false;
  for (guint k = 0; k < n; k++)
    palette_names_floor |= st.input.classes.roles[k] == "floor";
  guint floors = 0;
  for (guint k = 0; k < n; k++) {
    if (st.input.classes.markers[k]) {
      st.role[k + 1] = marker_role;
    } else if (cfg.floor_classes.empty () && (!palette_names_floor
            || st.input.classes.roles[k] == "floor")) {
      st.role[k + 1] = landmark::LabelRole::Floor;
      floors++;
    }
  }
  if (!st.input.classes.labels_of (GST_ELEMENT (self), "floor-classes",
          cfg.floor_classes, &st.floor_labels))
    return FALSE;
  for (guint label : st.floor_labels) {
    st.role[label] = landmark::LabelRole::Floor;
    floors++;
  }
  if (floors == 0) {
    GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
        ("No floor class: every class of the labels is a marker; set "
            "'floor-classes'."), ("the palette has: %s",
            st.input.classes.list ().c_str ()));
    return FALSE;
  }
  st.input.classes.valid = true;
  return TRUE;
}

/* A new buffer of n values of T, filled by fill (T *) while mapped. */
template <typename T, typename Fill>
static GstBuffer *
array_buffer (gsize n, Fill fill)
{
  GstBuffer *b = gst_buffer_new_allocate (nullptr, n * sizeof (T), nullptr);
  GstMapInfo map;
  if (gst_buffer_map (b, &map, GST_MAP_WRITE)) {
    fill ((T *) map.data);
    gst_buffer_unmap (b, &map);
  }
  return b;
}

static void
gst_floor_boundary_attach (GstFloorBoundary * self, GstBuffer * buf)
{
  State & st = self->priv->state;
  const landmark::FloorProfile & prof = st.profile;
  const auto & cols = prof.columns ();
  const auto & bins = prof.bins ();
  const guint w = prof.width (), nb = bins.size ();
  double nearest = -1, nearest_bearing = 0;
  for (guint k = 0; k < nb; k++)
    if (bins[k].state == landmark::FreeState::Obstacle &&
        (nearest < 0 || bins[k].range < nearest)) {
      nearest = bins[k].range;
      nearest_bearing = prof.bin_bearing (k);
    }
  GstStructure *s = landmark_floor_meta_add (buf);
  if (!s)
    return;
  /* written straight into the meta's buffers: no other per-frame copy */
  GstBuffer *b[7] = {
    array_buffer<float> (nb, [&](float *o) {
          for (guint k = 0; k < nb; k++) o[k] = bins[k].range;}),
    array_buffer<guint8> (nb, [&](guint8 * o) {
          for (guint k = 0; k < nb; k++) o[k] = (guint8) bins[k].state;}),
    array_buffer<float> (nb, [&](float *o) {
          for (guint k = 0; k < nb; k++) o[k] = bins[k].marker_range;}),
    array_buffer<float> (w, [&](float *o) {
          for (guint u = 0; u < w; u++) o[u] = cols[u].row;}),
    array_buffer<float> (w, [&](float *o) {
          for (guint u = 0; u < w; u++) o[u] = cols[u].x;}),
    array_buffer<float> (w, [&](float *o) {
          for (guint u = 0; u < w; u++) o[u] = cols[u].y;}),
    array_buffer<guint8> (w, [&](guint8 * o) {
          for (guint u = 0; u < w; u++) o[u] = (guint8) cols[u].state;}),
  };
  gst_structure_set (s,
      LANDMARK_FLOOR_WIDTH, G_TYPE_UINT, w,
      LANDMARK_FLOOR_HEIGHT, G_TYPE_UINT, (guint) prof.height (),
      LANDMARK_FLOOR_BEARING_BINS, G_TYPE_UINT, nb,
      LANDMARK_FLOOR_BIN_WIDTH, G_TYPE_DOUBLE, 2 * M_PI / nb,
      LANDMARK_FLOOR_MAX_RANGE, G_TYPE_DOUBLE, prof.params ().max_range,
      LANDMARK_FLOOR_ROP_RANGE, GST_TYPE_BUFFER, b[0],
      LANDMARK_FLOOR_ROP_STATE, GST_TYPE_BUFFER, b[1],
      LANDMARK_FLOOR_ROP_MARKER_RANGE, GST_TYPE_BUFFER, b[2],
      LANDMARK_FLOOR_BOUNDARY_ROW, GST_TYPE_BUFFER, b[3],
      LANDMARK_FLOOR_BOUNDARY_X, GST_TYPE_BUFFER, b[4],
      LANDMARK_FLOOR_BOUNDARY_Y, GST_TYPE_BUFFER, b[5],
      LANDMARK_FLOOR_BOUNDARY_STATE, GST_TYPE_BUFFER, b[6], nullptr);
  for (GstBuffer * x : b)
    gst_buffer_unref (x);
  if (nearest >= 0)
    gst_structure_set (s,
        LANDMARK_FLOOR_NEAREST_RANGE, G_TYPE_DOUBLE, nearest,
        LANDMARK_FLOOR_NEAREST_BEARING, G_TYPE_DOUBLE, nearest_bearing,
        nullptr);

  if (!st.applied.config.post_messages)
    return;
  GstBaseTransform *trans = GST_BASE_TRANSFORM_CAST (self);
  GValue ranges = G_VALUE_INIT, states = G_VALUE_INIT;
  gst_value_array_init (&ranges, nb);
  gst_value_array_init (&states, nb);
  for (guint k = 0; k < nb; k++) {
    landmark_value_array_append_double (&ranges, bins[k].range);
    landmark_value_array_append_uint (&states, (guint) bins[k].state);
  }
  GstStructure *m = landmark_frame_message_new ("landmark-obstacles", buf,
      &trans->segment);
  gst_structure_set (m, "bearing-bins", G_TYPE_UINT, nb,
      "bin-width", G_TYPE_DOUBLE, 2 * M_PI / nb,
      "max-range", G_TYPE_DOUBLE, prof.params ().max_range, nullptr);
  gst_structure_take_value (m, "ranges", &ranges);
  gst_structure_take_value (m, "states", &states);
  if (nearest >= 0)
    gst_structure_set (m, "nearest-range", G_TYPE_DOUBLE, nearest,
        "nearest-bearing", G_TYPE_DOUBLE, nearest_bearing, nullptr);
  gst_element_post_message (GST_ELEMENT_CAST (self),
      gst_message_new_element (GST_OBJECT_CAST (self), m));
}

/* An accepted landmark that is not a ball lies on the floor: its blob's
 * ellipse, in pixels of the label plane (the blob's frame scaled to it;
 * not when the two scale unequally). */
static void
gst_floor_boundary_add_disc (GstFloorBoundary * self, GstBuffer * buf,
    GstVideoRegionOfInterestMeta * roi, guint plane_w, guint plane_h)
{
  using landmark::overlay::meta_number;
  const GstStructure *blob = landmark_detection_get_param (buf, roi,
      LANDMARK_BLOB_PARAMS);
  landmark::ImageEllipse e;
  double fw = 0, fh = 0;
  if (!blob || !meta_number (blob, "ellipse-x", &e.cx) ||
      !meta_number (blob, "ellipse-y", &e.cy) ||
      !meta_number (blob, "ellipse-major", &e.major) ||
      !meta_number (blob, "ellipse-minor", &e.minor) ||
      !meta_number (blob, "ellipse-angle", &e.angle) ||
      !meta_number (blob, "frame-width", &fw) ||
      !meta_number (blob, "frame-height", &fh) || fw <= 0 || fh <= 0)
    return;
  const double sx = plane_w / fw, sy = plane_h / fh;
  if (std::fabs (sx - sy) > 1e-3 * sx)
    return;
  e.cx = (e.cx + 0.5) * sx - 0.5;
  e.cy = (e.cy + 0.5) * sy - 0.5;
  e.major *= sx;
  e.minor *= sx;
  self->priv->state.discs.push_back (e);
}

/* From the accepted detections (not rejected by any stage): their boxes,
 * in pixels of the label plane and one pixel wider on each side, when
 * markers=detections; the balls ipmrange ranged, with their radius; and
 * the others' ellipses, whose rims the walk crosses (not with
 * markers=obstacles). */
static void
gst_floor_boundary_read_detections (GstFloorBoundary * self, GstBuffer * buf,
    guint plane_w, guint plane_h)
{
  State & st = self->priv->state;
  const bool want_boxes = st.applied.config.markers ==
      GST_FLOOR_BOUNDARY_MARKERS_DETECTIONS;
  st.marker_boxes.clear ();
  st.balls.clear ();
  st.discs.clear ();
  const double sx = st.input.video_width > 0 ? (double) plane_w / st.input.video_width :
      1.0;
  const double sy = st.input.video_height > 0 ? (double) plane_h /
      st.input.video_height : 1.0;
  gpointer iter = nullptr;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (buf, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    auto roi = (GstVideoRegionOfInterestMeta *) meta;
    const gchar *element = nullptr, *reason = nullptr;
    if (landmark_detection_rejected (buf, roi, &element, &reason))
      continue;
    if (want_boxes) {
      landmark::MarkerBox b;
      b.u0 = (int) std::floor (roi->x * sx) - 1;
      b.v0 = (int) std::floor (roi->y * sy) - 1;
      b.u1 = (int) std::ceil ((roi->x + roi->w) * sx) + 1;
      b.v1 = (int) std::ceil ((roi->y + roi->h) * sy) + 1;
      st.marker_boxes.push_back (b);
    }
    const GstStructure *range = landmark_detection_get_param (buf, roi,
        LANDMARK_RANGE_PARAMS);
    const gchar *kind = range ? gst_structure_get_string (range,
        "marker-kind") : nullptr;
    landmark::RangedBall ball;
    gdouble diameter = 0;
    if (kind && std::strcmp (kind, "ball") == 0) {
      if (gst_structure_get_double (range, "ground-x", &ball.x) &&
          gst_structure_get_double (range, "ground-y", &ball.y) &&
          gst_structure_get_double (range, "marker-diameter", &diameter) &&
          std::isfinite (ball.x) && std::isfinite (ball.y) && diameter > 0) {
        ball.radius = diameter / 2;
        st.balls.push_back (ball);
      }
      continue;
    }
    if (st.applied.config.markers != GST_FLOOR_BOUNDARY_MARKERS_OBSTACLES)
      gst_floor_boundary_add_disc (self, buf, roi, plane_w, plane_h);
  }
  st.profile.set_landmark_discs (st.discs);
}

static GstFlowReturn
gst_floor_boundary_process (GstFloorBoundary * self, GstBuffer * buf,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  GstBuffer *plane = nullptr;
  guint w = 0, h = 0, stride = 0;
  const bool have = landmark_labels_get_plane (labels, &plane, &w, &h,
      &stride);
  if (!have || w < 2 || h < 2) {
    if (have)
      gst_buffer_unref (plane);
    if (!st.input.warned_bad_plane) {
      GST_ELEMENT_WARNING (self, STREAM, FORMAT,
          ("The labels metadata has no usable label plane."),
          ("missing or inconsistent plane fields, or smaller than 2x2; "
              "buffers pass unmeasured"));
      st.input.warned_bad_plane = true;
    }
    return GST_FLOW_OK;
  }
  if (!gst_floor_boundary_update_roles (self, labels)) {
    gst_buffer_unref (plane);
    return GST_FLOW_ERROR;
  }
  if (w != st.built_w || h != st.built_h) {
    landmark::SettingsError err;
    if (!floor_boundary_build (st.applied.config, w, h, &st.geometry,
            &st.profile, &err)) {
      gst_buffer_unref (plane);
      st.built_w = st.built_h = 0;
      GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
          ("Invalid camera geometry for %ux%u ('%s').", w, h, err.property),
          ("%s", err.why.c_str ()));
      return GST_FLOW_ERROR;
    }
    st.built_w = w;
    st.built_h = h;
    GST_INFO_OBJECT (self, "tables built for %ux%u", w, h);
  }
  GstMapInfo map;
  if (!gst_buffer_map (plane, &map, GST_MAP_READ)) {
    gst_buffer_unref (plane);
    GST_ELEMENT_ERROR (self, STREAM, FAILED,
        ("Could not read the label plane."), (nullptr));
    return GST_FLOW_ERROR;
  }
  gst_floor_boundary_read_detections (self, buf, w, h);
  st.profile.scan (map.data, stride, st.role,
      st.applied.config.markers == GST_FLOOR_BOUNDARY_MARKERS_DETECTIONS ?
      &st.marker_boxes : nullptr);
  st.profile.stand_balls (st.balls);
  gst_buffer_unmap (plane, &map);
  gst_buffer_unref (plane);
  gst_floor_boundary_attach (self, buf);
  return GST_FLOW_OK;
}

static void
gst_floor_boundary_class_init (GstFloorBoundaryClass * klass)
{
  landmark::element_class_init<Settings, gst_floor_boundary_settings,
      floor_boundary_properties> (klass, gst_floor_boundary_finalize,
      "Floor boundary", "Filter/Analyzer/Video",
      "Finds where the floor ends in every image column of labsegment's "
      "labels, maps it to the floor and attaches the radial obstacle "
      "profile (free range per bearing) as metadata");
  landmark::set_labels_measuring<GstFloorBoundary, gst_floor_boundary_get_type,
      floor_boundary_parse, gst_floor_boundary_start,
      gst_floor_boundary_sync_settings, gst_floor_boundary_process> (klass,
      gst_floor_boundary_stop, GST_DEBUG_FUNCPTR (gst_floor_boundary_set_caps));

  gst_type_mark_as_plugin_api (GST_TYPE_FLOOR_BOUNDARY_MARKERS,
      (GstPluginAPIFlags) 0);
}
