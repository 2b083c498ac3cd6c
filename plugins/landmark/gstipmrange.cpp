/**
 * SECTION:element-ipmrange
 * @title: ipmrange
 *
 * Range and bearing to every detection by inverse perspective mapping
 * (the seed's section 3.4.1, docs/ipmrange.md). For every detection that
 * `blobroundness` attached (a `GstVideoRegionOfInterestMeta` with a
 * `landmark-blob` structure) it adds a `landmark-range` parameter
 * structure, in the robot frame of docs/conventions.md:
 *
 * - `range` (metres, horizontal, from the camera's floor point to the
 *   marker centre), `bearing` (radians, positive to the left),
 *   `ground-x` (forward), `ground-y` (left): `range = hypot (ground-x,
 *   ground-y)`;
 * - `range-ground`: from where the marker's centre ray meets the plane of
 *   the marker's centre; `range-size`: from its apparent size, when its
 *   diameter is known;
 * - `method`: what `range` reports (`ground`, `size` or `fused`, the
 *   inverse-variance weighted mean of the two);
 * - `range-sigma`, `bearing-sigma`: one-sigma estimates (a `pixel-sigma`
 *   error of the blob's outline points, which moves its centre by less the
 *   larger the blob, propagated through the camera; the mounting's
 *   `height-sigma` and `tilt-sigma`; and `size-excess`, docs/ranging.md);
 * - `size-excess`: metres, the part of the disagreement of `range-size`
 *   and `range-ground` that their sigmas do not explain (a blob cut or
 *   merged), 0 without it;
 * - `rim-range-sigma`, `rim-bearing-sigma`: the part of the sigmas from the
 *   outline lying off the marker's edge (blur, the colour threshold): an
 *   error that repeats in every view of a pass, for a filter that would
 *   not average it away (docs/ranging.md);
 * - `no-floor`: true when the ray never meets the marker's plane (above
 *   the horizon); then no range fields, never a negative or infinite one.
 *
 * Camera models (`model`):
 * - `pinhole` (default): `camera-height`, `tilt` (degrees below the
 *   horizontal), `roll` (degrees), and intrinsics from `hfov` (principal
 *   point at the centre, `cx = (W - 1) / 2`), or `fx`, `fy`, `cx`, `cy`, or
 *   `calibration`: an OpenCV FileStorage file (YAML or XML) with
 *   `camera_matrix` and `distortion_coefficients` (as OpenCV's calibration
 *   sample writes them; `cameraMatrix`/`distCoeffs` are read too), scaled
 *   to the frame when its `image_width`/`image_height` differ; distortion is
 *   undone for the points used; its `camera_height`, `tilt_deg` and
 *   `roll_deg` (as `gst-landmark calibrate floor` writes them) replace the
 *   properties. Exact ray-plane intersection.
 * - `seed`: the seed's angle-linear model from `camera-height`,
 *   `blind-distance`, `view-depth` and `half-width` (equations 3.1-3.6),
 *   or a `calibration` file with `model: angle-linear` (`gst-landmark calibrate
 *   seed`), which selects this model.
 *
 * A camera file wins for what it holds; the properties give the rest.
 *
 * Where the marker is: a disc (`marker-kind=disc`) lies flat with its
 * centre at `marker-height` (0: on the floor): its fitted ellipse is
 * mapped onto that plane and the centre of the circle through it is the
 * marker's centre (not the image centroid, which is biased at slant
 * views). A ball's centre is at `marker-height` (its radius): it lies on
 * the axis of the cone tangent to the ball, which bisects the rays of the
 * ellipse's major-axis ends. `map` (the landmark map JSON `trilaterate`
 * reads) gives height, diameter and kind per class instead; a class whose
 * landmarks disagree falls back to the properties.
 *
 * The geometry is computed when the caps or a property change, never per
 * frame. Every property may change while playing; a bad value set while
 * playing is reported with a warning and the previous settings stay.
 * Impossible geometry (zero height, a tilt that sees no floor, a field of
 * view out of range, an unreadable or malformed calibration or map file)
 * fails the change to READY with an error naming the property or file.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! avidemux ! jpegdec !
 *     videoconvert ! labsegment palette=palette.json min-class-pixels=0 !
 *     blobroundness ! ipmrange camera-height=0.3 tilt=25 hfov=60
 *     marker-diameter=0.1 range-method=fused !
 *     landmarklog location=ranges.jsonl ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstipmrange.h"

#include <gst/video/video.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "cameraprops.h"
#include "colourdrift.h"
#include "elementsettings.h"
#include "fileutil.h"
#include "frameformat.h"
#include "framelight.h"
#include "camerasetup.h"
#include "landmarkmeta.h"
#include "analyticsmeta.h"
#include "beaconrange.h"
#include "landmarkmap.h"
#include "markerclasses.h"
#include "markerevidence.h"

GST_DEBUG_CATEGORY_STATIC (gst_ipm_range_debug);
#define GST_CAT_DEFAULT gst_ipm_range_debug

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  landmark::CameraSettings camera;
  gdouble marker_height = 0.0;
  gdouble marker_diameter = 0.0;
  GstIpmRangeMarkerKind marker_kind = GST_IPM_RANGE_MARKER_DISC;
  std::string map;
  GstIpmRangeMethod method = GST_IPM_RANGE_METHOD_GROUND;
  gdouble pixel_sigma = 0.5;
  gdouble height_sigma = 0.0;     /* relative */
  gdouble tilt_sigma = 0.0;       /* degrees */
  gboolean check_size = TRUE;
};

/* Settings checked, with the files read. */
struct Config {
  Settings s;
  landmark::CameraSetup camera;       /* the camera file merged */
  landmark::MarkerClasses markers;    /* the map read */
  std::vector<landmark::MapLandmark> coded;   /* its coded markers */
};

struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  landmark::CameraGeometry geometry;
  gint geometry_w = 0, geometry_h = 0;    /* what geometry was built for */
  gint caps_w = 0, caps_h = 0;            /* from the caps, 0: unknown */
  /* the frame's pixels, for a ball's outline (measure_end_offsets):
   * readable when the caps are of a format the plugin reads */
  GstVideoInfo info;
  LandmarkFrameFormat format;
  bool readable = false;
  GstVideoFrame frame;
  bool mapped = false;
  landmark::FrameLight light;             /* of the mapped frame */
  std::vector<double> outline;            /* size test scratch */
  std::vector<GstVideoRegionOfInterestMeta *> rois;
  bool map_classes_checked = false;       /* against the first labels */
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstIpmRange, gst_ipm_range,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, ipmrange,
    "Landmark range and bearing by inverse perspective mapping");

LANDMARK_DEFINE_ENUM_TYPE (gst_ipm_range_model_get_type, "GstIpmRangeModel",
    {GST_IPM_RANGE_MODEL_PINHOLE, "Pinhole camera (OpenCV intrinsics, "
          "optional distortion), exact ray-floor intersection", "pinhole"},
    {GST_IPM_RANGE_MODEL_SEED, "Angle-linear floor model (the seed's) "
          "from camera-height, blind-distance, view-depth, half-width",
        "angle-linear"},
    /* its former name, still accepted */
    {GST_IPM_RANGE_MODEL_SEED, "The same as angle-linear", "seed"});

LANDMARK_DEFINE_ENUM_TYPE (gst_ipm_range_method_get_type, "GstIpmRangeMethod",
    {GST_IPM_RANGE_METHOD_GROUND, "Where the ray meets the marker's plane",
        "ground"},
    {GST_IPM_RANGE_METHOD_SIZE, "From the apparent size and the known "
          "diameter (ground when the diameter is unknown)", "size"},
    {GST_IPM_RANGE_METHOD_FUSED, "Inverse-variance weighted mean of ground "
          "and size", "fused"});

LANDMARK_DEFINE_ENUM_TYPE (gst_ipm_range_marker_kind_get_type,
    "GstIpmRangeMarkerKind",
    {GST_IPM_RANGE_MARKER_DISC, "A flat disc, centre at marker-height",
        "disc"},
    {GST_IPM_RANGE_MARKER_BALL, "A ball, centre at marker-height (its "
          "radius when it rests on the floor)", "ball"});

/* ---- configuration -------------------------------------------------- */

/* Checks the settings and reads the files. */
static bool
ipm_range_parse (const Settings & s, Config * cfg,
    landmark::SettingsError * err)
{
  *cfg = Config ();
  cfg->s = s;
  /* the camera file wins for what it holds (floorprofile.h) */
  if (!landmark::camera_setup_resolve (s.camera, &cfg->camera,
          &err->property, &err->why))
    return false;
  const double camera_height = cfg->camera.e.camera_height;
  if (s.marker_height >= camera_height)
    return err->fail ("marker-height", "the marker centre must be below the "
        "camera (marker-height " + landmark::number_text (s.marker_height) +
        " >= camera-height " + landmark::number_text (camera_height) + ")");
  landmark::MarkerSpec marker;
  marker.z = s.marker_height;
  marker.diameter = s.marker_diameter;
  marker.ball = s.marker_kind == GST_IPM_RANGE_MARKER_BALL;
  err->property = "map";
  if (!landmark::marker_classes_load (s.map, marker, camera_height,
          &cfg->markers, &err->why))
    return false;
  /* beacondetect's detections carry a code of these (docs/beacons.md) */
  landmark::LandmarkMap map;
  if (!s.map.empty () && !landmark::map_load_file (s.map, &map, &err->why))
    return false;
  for (landmark::MapLandmark & m : map.landmarks)
    if (m.coded ())
      cfg->coded.push_back (std::move (m));
  return true;
}

static const landmark::PropertyTable<Settings> &
ipm_range_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .part (&Settings::camera, camera_properties ())
      .number ("marker-height", "Marker height",
          "Height of the markers' centre above the floor, metres (a ball: "
          "its radius); the map's z overrides it per class",
          &Settings::marker_height, 0.0, 1000.0)
      .number ("marker-diameter", "Marker diameter",
          "Diameter of the markers, metres, for the size range (0: "
          "unknown); the map's diameter overrides it per class",
          &Settings::marker_diameter, 0.0, 1000.0)
      .enumeration ("marker-kind", "Marker kind",
          "Shape of the markers; the map's kind overrides it per class",
          &Settings::marker_kind, GST_TYPE_IPM_RANGE_MARKER_KIND)
      .string ("map", "Map file",
          "Landmark map JSON: z, diameter and kind of each class's "
          "landmarks", &Settings::map)
      .enumeration ("range-method", "Range method", "What range reports",
          &Settings::method, GST_TYPE_IPM_RANGE_METHOD)
      .number ("pixel-sigma", "Pixel sigma",
          "One-sigma error of a point of a blob's outline, pixels: the "
          "centre's error follows from it and the blob's size, for "
          "range-sigma, bearing-sigma and the fused weights",
          &Settings::pixel_sigma, 0.0, 100.0)
      .number ("height-sigma", "Height sigma",
          "One-sigma error of the camera height, relative (0.005: 1 mm in "
          "0.2 m), added to range-sigma (0: the height is exact)",
          &Settings::height_sigma, 0.0, 1.0)
      .number ("tilt-sigma", "Tilt sigma",
          "One-sigma error of the tilt, degrees, added to range-sigma (0: "
          "the tilt is exact)", &Settings::tilt_sigma, 0.0, 90.0)
      .boolean ("check-size", "Check size",
          "Reject a detection (kept=false, reject-reason=size) whose image "
          "disagrees in size or aspect with a marker of known diameter at "
          "its floor position", &Settings::check_size);
  return table;
}

/* Builds the geometry for a frame size; posts an error on failure. */
static gboolean
gst_ipm_range_build (GstIpmRange * self, gint width, gint height,
    gboolean fatal)
{
  State & st = self->priv->state;
  landmark::CameraParams p;
  const char *property = nullptr;
  std::string why;
  if (landmark::camera_setup_params (st.applied.config.camera, width, height,
          &p, &property, &why)) {
    property = "tilt";
    if (st.geometry.configure (p, &why)) {
      st.geometry_w = width;
      st.geometry_h = height;
      GST_INFO_OBJECT (self, "geometry for %dx%d: %s, height %.4f m, "
          "tilt %.3f, roll %.3f deg, fx %.3f fy %.3f cx %.3f cy %.3f, %zu "
          "distortion coefficients, seed b %.4f d %.4f w %.4f", width, height,
          p.model == landmark::CameraModel::Seed ? "angle-linear" : "pinhole",
          p.camera_height, p.tilt_deg, p.roll_deg, p.fx, p.fy, p.cx, p.cy,
          p.dist.size (), p.blind_distance, p.view_depth, p.half_width);
      return TRUE;
    }
  }
  st.geometry_w = st.geometry_h = 0;
  if (fatal)
    GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
        ("Invalid camera geometry for %dx%d ('%s').", width, height,
            property), ("%s", why.c_str ()));
  else
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("Invalid camera geometry for %dx%d ('%s').", width, height,
            property), ("%s", why.c_str ()));
  return FALSE;
}

/* ---- states and caps ------------------------------------------------ */

/* Settings changed while playing: parsed, and the geometry rebuilt at the
 * current size; a bad value (or a geometry that sees no floor) is a
 * warning and the previous settings and geometry stay. */
static void
gst_ipm_range_sync_settings (GstIpmRange * self)
{
  State & st = self->priv->state;
  landmark::CameraGeometry geometry;
  bool classes_changed = false;
  const gint w = st.geometry_w ? st.geometry_w : st.caps_w;
  const gint h = st.geometry_w ? st.geometry_h : st.caps_h;
  auto parse_and_build = [&](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    landmark::CameraParams p;
    if (!ipm_range_parse (s, cfg, err))
      return false;
    classes_changed = cfg->markers.map_classes !=
        st.applied.config.markers.map_classes;
    if (w < 2 || h < 2)
      return true;
    if (!landmark::camera_setup_params (cfg->camera, w, h, &p,
            &err->property, &err->why))
      return false;
    err->property = cfg->camera.e.seed ? "model" : "tilt";
    return geometry.configure (p, &err->why);
  };
  if (!st.applied.sync (GST_ELEMENT (self), self->priv->settings,
          parse_and_build))
    return;
  if (classes_changed)
    st.map_classes_checked = false;
  if (w >= 2 && h >= 2) {
    st.geometry = std::move (geometry);
    st.geometry_w = w;
    st.geometry_h = h;
  }
}

/* the settings, the map and the camera file
 * (landmark::change_state_checking_settings) */
static bool
gst_ipm_range_apply_settings (GstIpmRange * self)
{
  State & st = self->priv->state;
  if (!st.applied.start (GST_ELEMENT (self), self->priv->settings,
          ipm_range_parse))
    return false;
  for (const auto & h : st.applied.config.markers.hypotheses)
    GST_INFO_OBJECT (self, "map %s: the '%s' landmarks differ in height, "
        "diameter or kind: each detection is ranged under every spec and "
        "the one whose ground and size ranges agree is kept",
        st.applied.config.s.map.c_str (), h.first.c_str ());
  return true;
}

static gboolean
gst_ipm_range_start (GstBaseTransform * trans)
{
  auto self = GST_IPM_RANGE (trans);
  State & st = self->priv->state;
  st.geometry_w = st.geometry_h = 0;
  st.caps_w = st.caps_h = 0;
  st.map_classes_checked = false;
  return TRUE;
}

static gboolean
gst_ipm_range_stop (GstBaseTransform * trans)
{
  State & st = GST_IPM_RANGE (trans)->priv->state;
  st.geometry_w = st.geometry_h = 0;
  st.readable = false;
  return TRUE;
}

static gboolean
gst_ipm_range_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps * outcaps)
{
  auto self = GST_IPM_RANGE (trans);
  State & st = self->priv->state;
  (void) outcaps;
  GstVideoInfo info;
  GST_DEBUG_OBJECT (self, "caps %" GST_PTR_FORMAT, incaps);
  if (!gst_video_info_from_caps (&info, incaps)) {
    /* no frame size: built from the detections' frame size instead */
    st.caps_w = st.caps_h = 0;
    st.readable = false;
    return TRUE;
  }
  st.caps_w = GST_VIDEO_INFO_WIDTH (&info);
  st.caps_h = GST_VIDEO_INFO_HEIGHT (&info);
  st.info = info;
  switch (GST_VIDEO_INFO_FORMAT (&info)) {
    case GST_VIDEO_FORMAT_RGB: case GST_VIDEO_FORMAT_BGR:
    case GST_VIDEO_FORMAT_RGBx: case GST_VIDEO_FORMAT_BGRx:
    case GST_VIDEO_FORMAT_xRGB: case GST_VIDEO_FORMAT_xBGR:
    case GST_VIDEO_FORMAT_RGBA: case GST_VIDEO_FORMAT_BGRA:
    case GST_VIDEO_FORMAT_I420: case GST_VIDEO_FORMAT_NV12:
    case GST_VIDEO_FORMAT_YUY2:
      st.readable = landmark_frame_format (&info, &st.format);
      st.light.set_model (st.format.model);
      break;
    default:
      /* any other format is ranged from the blobs' ellipses alone */
      st.readable = false;
  }
  if (st.caps_w < 2 || st.caps_h < 2) {
    /* no camera geometry for a single row or column (the seed model
     * divides by width - 1): pass such frames unmeasured rather than
     * refuse their caps */
    st.geometry_w = st.geometry_h = 0;
    return TRUE;
  }
  if (st.caps_w == st.geometry_w && st.caps_h == st.geometry_h)
    return TRUE;
  return gst_ipm_range_build (self, st.caps_w, st.caps_h, TRUE);
}

/* ---- streaming ------------------------------------------------------ */


/* The size evidence: a marker of known diameter at the floor position the
 * blob was ranged to images at a known size and aspect; a blob that
 * disagrees (a speck near by, a large patch far away, a stripe) is not
 * that marker. A blob cut by the frame's edge may be smaller than the
 * marker's image, never larger. Adds the test's fields to s; returns the
 * reject reason or nullptr. */
static const char *
gst_ipm_range_check_size (GstIpmRange * self,
    const landmark::BlobObservation & obs, const landmark::MarkerSpec & m,
    const landmark::RangeEstimate & e, bool cut, bool marginal, bool thin,
    GstStructure * s)
{
  State & st = self->priv->state;
  landmark::ImageEllipse predicted;
  const double agreement = landmark::marker_size_agreement (st.geometry, obs,
      m, e, &predicted, &st.outline);
  if (agreement < 0)
    return nullptr;
  gst_structure_set (s, "predicted-major", G_TYPE_DOUBLE, predicted.major,
      "predicted-minor", G_TYPE_DOUBLE, predicted.minor, nullptr);
  if (cut) {
    const landmark::ImageEllipse measured {obs.eu, obs.ev, obs.major,
      obs.minor, obs.angle};
    return landmark::cut_blob_fits (measured, predicted) ? nullptr : "size";
  }
  const double threshold = landmark::size_agreement_threshold (predicted);
  gst_structure_set (s, "size-agreement", G_TYPE_DOUBLE, agreement,
      "size-threshold", G_TYPE_DOUBLE, threshold, nullptr);
  /* blobroundness's near miss: only an image no rectangle could give
   * makes it a marker; a thin blob passed the shape test, and the image a
   * marker has there is what tells a far disc from an edge's blend */
  if (marginal)
    gst_structure_set (s, "shape-confirmed", G_TYPE_BOOLEAN,
        agreement >= (thin ? threshold : landmark::kSizeAgreementMarginal),
        nullptr);
  return agreement < threshold ? "size" : nullptr;
}

/* The landmark-range structure of an estimate, `range` by range-method;
 * a ray that misses the marker's plane: no-floor, not kept. */
static GstStructure *
gst_ipm_range_structure (const Settings & cfg, const landmark::RangeEstimate
    & e)
{
  if (e.no_floor)
    return gst_structure_new (LANDMARK_RANGE_PARAMS,
        "no-floor", G_TYPE_BOOLEAN, TRUE, "kept", G_TYPE_BOOLEAN, FALSE,
        "reject-reason", G_TYPE_STRING, "no-floor", nullptr);
  const char *method = "ground";
  double range = e.range_ground, sigma = e.range_ground_sigma;
  if (e.has_size && cfg.method == GST_IPM_RANGE_METHOD_SIZE) {
    method = "size";
    range = e.range_size;
    sigma = e.range_size_sigma;
  } else if (e.has_size && cfg.method == GST_IPM_RANGE_METHOD_FUSED &&
      e.range_ground_sigma > 0 && e.range_size_sigma > 0) {
    method = "fused";
    const double wg = 1.0 / (e.range_ground_sigma * e.range_ground_sigma);
    const double ws = 1.0 / (e.range_size_sigma * e.range_size_sigma);
    range = (wg * e.range_ground + ws * e.range_size) / (wg + ws);
    sigma = 1.0 / std::sqrt (wg + ws);
  }
  const double k = e.range_ground > 0 ? range / e.range_ground : 1.0;
  GstStructure *s = gst_structure_new (LANDMARK_RANGE_PARAMS,
      "range", G_TYPE_DOUBLE, range,
      "bearing", G_TYPE_DOUBLE, e.bearing,
      "ground-x", G_TYPE_DOUBLE, e.ground_x * k,
      "ground-y", G_TYPE_DOUBLE, e.ground_y * k,
      "range-ground", G_TYPE_DOUBLE, e.range_ground,
      "method", G_TYPE_STRING, method,
      "range-sigma", G_TYPE_DOUBLE, e.range_sigma_total (sigma),
      "bearing-sigma", G_TYPE_DOUBLE, e.bearing_sigma_total (),
      "size-excess", G_TYPE_DOUBLE, e.size_excess,
      "rim-range-sigma", G_TYPE_DOUBLE, e.rim_range,
      "rim-bearing-sigma", G_TYPE_DOUBLE, e.rim_bearing,
      "no-floor", G_TYPE_BOOLEAN, FALSE, nullptr);
  if (e.has_size)
    gst_structure_set (s, "range-size", G_TYPE_DOUBLE, e.range_size,
        nullptr);
  return s;
}

/* A band's blob reaches about half a pixel beyond the marker's image at
 * either end: +0.93 px median over the height on tools/beaconstudy.py's
 * tune half (docs/beacons.md) */
static constexpr double kCodedOutlineGrowthPx = 1.0;

/* A coded marker (beacondetect's `code`): from its floor contact point and
 * its height seen, with the map's size for that code (none: the ground
 * range of its base's nearest point). The observation is in the
 * geometry's pixels. */
static void
gst_ipm_range_measure_coded (GstIpmRange * self, GstBuffer * buf,
    GstVideoRegionOfInterestMeta * roi, const GstStructure * blob,
    const char *code, const landmark::BlobObservation & scale, bool cut)
{
  const Config & cfg = self->priv->state.applied.config;
  landmark::CodedObservation obs;
  if (!gst_structure_get_double (blob, "axis-base-x", &obs.base_u) ||
      !gst_structure_get_double (blob, "axis-base-y", &obs.base_v) ||
      !gst_structure_get_double (blob, "height-px", &obs.height_px) ||
      !std::isfinite (obs.base_u) || !std::isfinite (obs.base_v))
    return;
  obs.base_u = (obs.base_u + 0.5) * scale.sx - 0.5;
  obs.base_v = (obs.base_v + 0.5) * scale.sy - 0.5;
  obs.height_px *= scale.sy;
  obs.outline_growth_px = kCodedOutlineGrowthPx * scale.sy;
  obs.whole = !cut;
  landmark::CodedMarkerSize size;
  const landmark::MapLandmark *spec = nullptr;
  for (const landmark::MapLandmark & m : cfg.coded)
    if (m.code == code)
      spec = &m;
  if (spec) {
    size.z = spec->z;
    size.height = spec->height;
    size.diameter = spec->diameter;
    size.cone = spec->kind == landmark::MapKind::Cone;
  }
  landmark::MountingSigma mounting;
  mounting.height_rel = cfg.s.height_sigma;
  mounting.tilt = cfg.s.tilt_sigma * M_PI / 180;
  const landmark::RangeEstimate e = landmark::estimate_coded_range
      (self->priv->state.geometry, obs, size, cfg.s.pixel_sigma, mounting);
  GstStructure *s = gst_ipm_range_structure (cfg.s, e);
  if (!e.no_floor) {
    gst_structure_set (s, "kept", G_TYPE_BOOLEAN, TRUE, nullptr);
    if (spec)
      gst_structure_set (s, "marker-kind", G_TYPE_STRING,
          landmark::map_kind_name (spec->kind), "marker-height",
          G_TYPE_DOUBLE, spec->z, "marker-diameter", G_TYPE_DOUBLE,
          spec->diameter, nullptr);
  }
  landmark_detection_add_param (buf, roi, s);
}

static void
gst_ipm_range_measure (GstIpmRange * self, GstBuffer * buf,
    GstVideoRegionOfInterestMeta * roi)
{
  State & st = self->priv->state;
  const Config & cfg = st.applied.config;
  const GstStructure *blob = landmark_detection_get_param (buf, roi,
      LANDMARK_BLOB_PARAMS);

  landmark::BlobObservation obs;
  guint fw = 0, fh = 0;
  bool have_centroid = false;
  gboolean marginal = FALSE;
  bool thin = false;
  if (blob) {
    gst_structure_get_boolean (blob, "shape-marginal", &marginal);
    thin = g_strcmp0 (gst_structure_get_string (blob, "reject-reason"),
        "thin") == 0;
    have_centroid = gst_structure_get_double (blob, "centroid-x", &obs.u)
        && gst_structure_get_double (blob, "centroid-y", &obs.v);
    obs.has_ellipse = gst_structure_get_double (blob, "ellipse-x", &obs.eu)
        && gst_structure_get_double (blob, "ellipse-y", &obs.ev)
        && gst_structure_get_double (blob, "ellipse-major", &obs.major)
        && gst_structure_get_double (blob, "ellipse-minor", &obs.minor)
        && gst_structure_get_double (blob, "ellipse-angle", &obs.angle);
    gst_structure_get_double (blob, "equivalent-diameter",
        &obs.equivalent_diameter);
    gst_structure_get_uint (blob, "frame-width", &fw);
    gst_structure_get_uint (blob, "frame-height", &fh);
  }
  if (!have_centroid) {
    /* the box's centre, pixel-centre convention */
    obs.u = roi->x + (roi->w - 1) / 2.0;
    obs.v = roi->y + (roi->h - 1) / 2.0;
    obs.has_ellipse = false;
    fw = fh = 0;
  }
  if (fw == 0 || fh == 0) {
    fw = st.caps_w ? st.caps_w : st.geometry_w;
    fh = st.caps_h ? st.caps_h : st.geometry_h;
  }
  if (st.geometry_w == 0 && fw >= 2 && fh >= 2)
    gst_ipm_range_build (self, fw, fh, FALSE);
  if (st.geometry_w == 0 || fw == 0 || fh == 0)
    return;
  /* a centroid is inside its frame: anything else is a broken detection
   * from upstream, which gets no range rather than one behind the camera */
  if (!(obs.u >= -0.5 && obs.u <= fw - 0.5 && obs.v >= -0.5
          && obs.v <= fh - 0.5)) {
    GST_DEBUG_OBJECT (self, "centroid (%g, %g) outside its %ux%u frame: "
        "not ranged", obs.u, obs.v, fw, fh);
    return;
  }
  if (obs.has_ellipse && !(std::isfinite (obs.eu) && std::isfinite (obs.ev)
          && std::isfinite (obs.major) && std::isfinite (obs.minor)
          && std::isfinite (obs.angle) && obs.major >= 0 && obs.minor >= 0))
    obs.has_ellipse = false;
  if (!std::isfinite (obs.equivalent_diameter))
    obs.equivalent_diameter = 0;
  obs.sx = (double) st.geometry_w / fw;
  obs.sy = (double) st.geometry_h / fh;
  const bool cut = roi->x == 0 || roi->y == 0 || roi->x + roi->w >= fw
      || roi->y + roi->h >= fh;
  if (const char *code = blob ? gst_structure_get_string (blob, "code") :
      nullptr) {
    gst_ipm_range_measure_coded (self, buf, roi, blob, code, obs, cut);
    return;
  }

  const std::vector<landmark::MarkerSpec> *hypotheses = nullptr;
  landmark::MarkerSpec marker = cfg.markers.spec (g_quark_to_string
      (roi->roi_type), &hypotheses);
  if (marker.z >= cfg.camera.e.camera_height)
    marker.z = 0;   /* cannot range it; treat as on the floor */

  /* a ball's outline from the frame's pixels, where they are those the
   * blob was measured on */
  bool maybe_ball = marker.ball;
  if (hypotheses)
    for (const landmark::MarkerSpec & h : *hypotheses)
      maybe_ball = maybe_ball || h.ball;
  if (maybe_ball && obs.has_ellipse && st.mapped
      && (gint) fw == GST_VIDEO_FRAME_WIDTH (&st.frame)
      && (gint) fh == GST_VIDEO_FRAME_HEIGHT (&st.frame))
    landmark::measure_end_offsets (&obs, landmark::ball_axis_angle
        (st.geometry, obs), [&st](int x, int y, int n, double *rgb) {
          return st.light.row_light (x, y, n, rgb);
        });

  landmark::MountingSigma mounting;
  mounting.height_rel = cfg.s.height_sigma;
  mounting.tilt = cfg.s.tilt_sigma * M_PI / 180;
  landmark::RangeEstimate e;
  const landmark::MarkerSpec *chosen = nullptr;
  /* a blob cut by the frame's edge has no trustworthy size to choose by */
  /* one class, several kinds of marker: the blob's size and aspect
   * choose among them (markerevidence.h); when nothing can choose, the
   * properties' marker applies, as for a class the map lacks */
  if (hypotheses && !cut)
    chosen = landmark::choose_marker (st.geometry, obs, *hypotheses,
        cfg.s.pixel_sigma, mounting, &e, &st.outline);
  if (hypotheses && cut)
    chosen = landmark::cut_blob_fits_no_marker (st.geometry, obs,
        *hypotheses, cfg.s.pixel_sigma, mounting, &e, &st.outline);
  if (!chosen)
    e = landmark::estimate_range (st.geometry, obs, marker,
        cfg.s.pixel_sigma, mounting);
  if (!chosen && hypotheses && !e.no_floor)
    landmark::add_marker_kind_spread (st.geometry, obs, *hypotheses,
        cfg.s.pixel_sigma, mounting, &e);

  GstStructure *s = gst_ipm_range_structure (cfg.s, e);
  if (e.no_floor) {
    /* every marker's centre is below the camera, so its ray meets its
     * plane: a blob whose ray does not is no marker (a wall, the sky) */
    landmark_detection_add_param (buf, roi, s);
    return;
  }
  /* the marker the range assumed, unless the class has several and none
   * could be chosen (then its kind is not known) */
  const landmark::MarkerSpec *assumed = chosen ? chosen :
      hypotheses ? nullptr : &marker;
  if (assumed) {
    gst_structure_set (s, "marker-kind", G_TYPE_STRING,
        assumed->ball ? "ball" : "disc", "marker-height", G_TYPE_DOUBLE,
        assumed->z, nullptr);
    if (assumed->diameter > 0)
      gst_structure_set (s, "marker-diameter", G_TYPE_DOUBLE,
          assumed->diameter, nullptr);
  }
  const char *reject = nullptr;
  if (cfg.s.check_size)
    reject = gst_ipm_range_check_size (self, obs, chosen ? *chosen : marker,
        e, cut, marginal, thin, s);
  gst_structure_set (s, "kept", G_TYPE_BOOLEAN, reject == nullptr, nullptr);
  if (reject)
    gst_structure_set (s, "reject-reason", G_TYPE_STRING, reject, nullptr);
  landmark_detection_add_param (buf, roi, s);
}

static GstFlowReturn
gst_ipm_range_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_IPM_RANGE (trans);
  State & st = self->priv->state;
  gst_ipm_range_sync_settings (self);
  if (st.geometry_w == 0 && st.caps_w >= 2 && st.caps_h >= 2)
    gst_ipm_range_build (self, st.caps_w, st.caps_h, FALSE);
  /* A map class that the palette lacks is legal (a map may serve several
   * robots) but never matches: say so once, with the first labels. */
  const Config & cfg = st.applied.config;
  const GstStructure *labels;
  if (!st.map_classes_checked && !cfg.markers.map_classes.empty ()
      && (labels = landmark_labels_meta_get (buf))) {
    st.map_classes_checked = true;
    landmark_warn_map_classes_missing (GST_ELEMENT_CAST (self), labels,
        cfg.s.map, cfg.markers.map_classes,
        "their heights and sizes are never used.");
  }
  return landmark::run_frame (GST_ELEMENT (self), "Ranging failed.", [&] {
        /* collect first: adding parameters adds metas to the buffer */
        landmark_detections_collect (buf, &st.rois);
        /* no reference taken: the buffer must stay writable for the
         * parameters added to its metas */
        st.mapped = !st.rois.empty () && st.readable
            && gst_video_frame_map (&st.frame, &st.info, buf, (GstMapFlags)
            (GST_MAP_READ | GST_VIDEO_FRAME_MAP_FLAG_NO_REF));
        if (st.mapped)
          st.light.read_planes (&st.frame);
        struct Unmap {
          State & st;
          ~Unmap () {
            if (st.mapped)
              gst_video_frame_unmap (&st.frame);
            st.mapped = false;
          }
        } unmap {st};
        for (GstVideoRegionOfInterestMeta * roi : st.rois)
          gst_ipm_range_measure (self, buf, roi);
        landmark_analytics_sync (buf);
        return GST_FLOW_OK;
      });
}

static void
gst_ipm_range_class_init (GstIpmRangeClass * klass)
{
  landmark::element_class_init<Settings, gst_ipm_range_settings,
      ipm_range_properties> (klass, gst_ipm_range_finalize,
      "Landmark range by inverse perspective mapping",
      "Filter/Analyzer/Video",
      "Adds range and bearing (robot frame) to every landmark detection, "
      "from a pinhole or the seed's camera model and the markers' size");
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark::set_settings_lifecycle<GstIpmRange, gst_ipm_range_get_type,
      gst_ipm_range_apply_settings, gst_ipm_range_start> (klass,
      gst_ipm_range_stop);
  trans_class->set_caps = GST_DEBUG_FUNCPTR (gst_ipm_range_set_caps);
  trans_class->transform_ip = GST_DEBUG_FUNCPTR (gst_ipm_range_transform_ip);

  gst_type_mark_as_plugin_api (GST_TYPE_IPM_RANGE_MODEL,
      (GstPluginAPIFlags) 0);
  gst_type_mark_as_plugin_api (GST_TYPE_IPM_RANGE_METHOD,
      (GstPluginAPIFlags) 0);
  gst_type_mark_as_plugin_api (GST_TYPE_IPM_RANGE_MARKER_KIND,
      (GstPluginAPIFlags) 0);
}
