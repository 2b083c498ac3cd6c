/**
 * SECTION:element-trilaterate
 * @title: trilaterate
 *
 * The robot's pose on a landmark map from the ranges and bearings that
 * `ipmrange` attached to the detections (the seed's sections 3.4.2-3.4.3,
 * docs/trilaterate.md, docs/positioning.md).
 *
 * For every frame it associates detections with the map's landmarks (by
 * class; where a colour appears more than once, the previous or predicted
 * pose decides within `gate` metres, or, without one, a consensus over
 * pairs of detections), then solves with what is matched:
 *
 * - one landmark: the position from its range and bearing and a measured
 *   heading: `heading` (a compass), or with `filter=ekf` the filter's
 *   prediction and its grown uncertainty; never the previous pose's (it
 *   goes stale as the robot turns): without one there is no pose;
 * - two landmarks: the two-circle intersection, the bearings choosing the
 *   intersection and giving the heading;
 * - three or more: consensus over pairs against one wrong detection, then
 *   Huber-weighted Gauss-Newton over all ranges and bearings.
 *
 * `filter=ekf` runs an extended Kalman filter over the ranges and bearings
 * with a ground robot's constant-velocity motion (it drives along its
 * heading: core/estimation/groundmotion.h), which smooths the poses and bridges frames
 * with too few landmarks for up to `max-age` seconds.
 *
 * Output, per frame:
 * - a `GstLandmarkPoseMeta` (`GstCustomMeta`) when there is a pose, its
 *   structure holding `x`, `y` (metres), `heading` (radians, wrapped to
 *   (-pi, pi]), `covariance` (9 doubles, row-major over x, y, heading),
 *   `landmarks` (array of the map ids used), `n-landmarks` (guint),
 *   `residual` (metres, RMS over the landmarks used), `solver` (`one`,
 *   `two`, `lsq`, or `ekf` for a bridged frame), `geometry` (`ok`,
 *   `collinear-landmarks`, `robot-on-baseline`, `robot-in-line`), `filter`
 *   (`none` or `ekf`);
 * - on each detection a `landmark-match` parameter structure: `matched`,
 *   `landmark-id` and `matched-by` (when matched: `pose`, used in the
 *   frame's pose; without a pose `colour`, the map holds its colour once,
 *   or `prior`, a repeated colour placed by the previous or predicted pose
 *   within `gate`), `residual` (metres, when a pose gives
 *   one), `reason` (when unmatched: `no-range`, `not-kept`,
 *   `no-landmark-of-class`, `outside-gate`, `ambiguous`, `duplicate`,
 *   `outlier`, `too-few-landmarks`, `no-solution`);
 * - a `landmark-pose` element message (`post-messages`): `timestamp`,
 *   `stream-time`, `running-time` (guint64, ns), `has-pose`, the pose
 *   fields above when there is one, else `reason` (`too-few-landmarks` or
 *   `no-solution`), and `n-detections` (detections with a range).
 *
 * A missing or malformed map fails the change to READY with an error
 * naming the file and the entry. Every property may change while playing;
 * a bad value set then is reported with a warning and the previous
 * settings and map stay in force.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 -m filesrc location=clip.avi ! decodebin ! videoconvert !
 *     labsegment palette=pal.json min-class-pixels=0 ! blobroundness !
 *     ipmrange camera-height=0.5 tilt=20 hfov=80 map=map.json !
 *     trilaterate map=map.json filter=ekf ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gsttrilaterate.h"

#include <gst/video/video.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "elementsettings.h"
#include "landmarkmap.h"
#include "landmarkmeta.h"
#include "analyticsmeta.h"
#include "posemeta.h"
#include "posetracker.h"

GST_DEBUG_CATEGORY_STATIC (gst_trilaterate_debug);
#define GST_CAT_DEFAULT gst_trilaterate_debug

#define HEADING_UNSET -361.0
/* frame interval assumed for buffers without timestamps */
#define FALLBACK_FRAME_NS (GST_SECOND / 30)

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string map;
  GstTrilaterateFilter filter = GST_TRILATERATE_FILTER_NONE;
  gdouble heading = HEADING_UNSET;      /* degrees */
  gdouble heading_sigma = 2.0;          /* degrees */
  gdouble gate = 0.5;
  gdouble inlier_distance = 0.25;
  gdouble max_age = 1.0;
  /* as labsegment: the metadata is the per-frame channel; a message per
   * frame piles up on a bus nobody watches */
  gboolean post_messages = FALSE;
};

/* Settings checked, with the map they name. */
struct Config {
  Settings s;
  std::vector<landmark::MapPoint> map;
};

struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  /* the previous pose and the filter */
  landmark::PoseTracker tracker;
  guint64 frames = 0;
  bool map_classes_checked = false;   /* against the first labels */
  landmark::RangedDetections ranged;  /* reused */
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstTrilaterate, gst_trilaterate,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, trilaterate,
    "Robot pose from landmark ranges and bearings");

LANDMARK_DEFINE_ENUM_TYPE (gst_trilaterate_filter_get_type,
    "GstTrilaterateFilter",
    {GST_TRILATERATE_FILTER_NONE, "Each frame's own solution", "none"},
    {GST_TRILATERATE_FILTER_EKF, "Constant-velocity extended Kalman filter "
          "over the ranges and bearings; bridges frames with too few "
          "landmarks", "ekf"});

/* ---- configuration -------------------------------------------------- */

/* Checks the settings and reads the map they name into cfg. */
static bool
trilaterate_parse (const Settings & s, Config * cfg,
    landmark::SettingsError * err)
{
  if (s.map.empty ())
    return err->fail ("map", "no landmark map: set map=PATH (the JSON file "
        "of docs/conventions.md)");
  landmark::LandmarkMap map;
  std::string why;
  if (!landmark::map_load_file (s.map, &map, &why))
    return err->fail ("map", why);
  cfg->s = s;
  /* discs and balls by class, coded markers by code (beacondetect) */
  cfg->map = landmark::map_pose_landmarks (map);
  return !cfg->map.empty () || err->fail ("map", s.map + ": the map has no "
      "landmarks");
}

static const landmark::PropertyTable<Settings> &
trilaterate_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("map", "Map file",
          "Landmark map JSON (docs/conventions.md); required",
          &Settings::map)
      .enumeration ("filter", "Filter", "Temporal filter of the poses",
          &Settings::filter, GST_TYPE_TRILATERATE_FILTER)
      .number ("heading", "Heading",
          "Known heading for the one-landmark solver, degrees "
          "counter-clockwise from the map's +x; -361: unknown (filter=ekf: "
          "the predicted pose's; none: no one-landmark pose)",
          &Settings::heading,
          HEADING_UNSET, 360.0)
      .number ("heading-sigma", "Heading sigma",
          "One-sigma error of the heading property, degrees",
          &Settings::heading_sigma, 0.0, 180.0)
      .number ("gate", "Gate",
          "Association gate: metres between a detection placed by the "
          "previous or predicted pose and its landmark", &Settings::gate,
          0.0, 1000.0)
      .number ("inlier-distance", "Inlier distance",
          "Consensus: metres within which a landmark agrees with a pose "
          "(at least three range/bearing sigmas)", &Settings::inlier_distance,
          0.0, 1000.0)
      .number ("max-age", "Maximum age",
          "Seconds a previous pose stays a prior, and filter=ekf bridges "
          "frames without landmarks",
          &Settings::max_age, 0.0, 3600.0)
      .boolean ("post-messages", "Post messages",
          "Post a landmark-pose element message per frame",
          &Settings::post_messages);
  return table;
}

/* ---- instance and states -------------------------------------------- */

static void
gst_trilaterate_reset (State & st)
{
  st.tracker.reset ();
  st.frames = 0;
}

static gboolean
gst_trilaterate_start (GstBaseTransform * trans)
{
  auto self = GST_TRILATERATE (trans);
  State & st = self->priv->state;
  gst_trilaterate_reset (st);
  st.map_classes_checked = false;
  GST_INFO_OBJECT (self, "map %s: %zu landmarks",
      st.applied.config.s.map.c_str (), st.applied.config.map.size ());
  return TRUE;
}

static gboolean
gst_trilaterate_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  if (GST_EVENT_TYPE (event) == GST_EVENT_FLUSH_STOP
      || GST_EVENT_TYPE (event) == GST_EVENT_STREAM_START)
    gst_trilaterate_reset (GST_TRILATERATE (trans)->priv->state);
  return GST_BASE_TRANSFORM_CLASS (gst_trilaterate_parent_class)->sink_event
      (trans, event);
}

/* ---- streaming ------------------------------------------------------ */

/* Brings the state up to date with settings changed while playing (a bad
 * value: a warning, and the previous settings and map stay). The map file
 * is read again only when `map` names another file. */
static void
gst_trilaterate_sync_settings (GstTrilaterate * self)
{
  State & st = self->priv->state;
  const Config & previous = st.applied.config;    /* until sync replaces it */
  bool new_map = false, new_filter = false;
  auto parse = [&](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    new_map = s.map != previous.s.map || previous.map.empty ();
    new_filter = s.filter != previous.s.filter;
    if (!new_map) {
      cfg->s = s;
      cfg->map = previous.map;
      return true;
    }
    if (trilaterate_parse (s, cfg, err))
      return true;
    err->why += " (the previous map stays)";
    return false;
  };
  if (!st.applied.sync (GST_ELEMENT (self), self->priv->settings, parse))
    return;
  if (new_map) {
    st.map_classes_checked = false;
    /* a new map: the previous pose means nothing on it */
    st.tracker.reset ();
    GST_INFO_OBJECT (self, "map %s: %zu landmarks",
        st.applied.config.s.map.c_str (), st.applied.config.map.size ());
  }
  if (new_filter)
    st.tracker.reset_filter ();
}

static GstFlowReturn
gst_trilaterate_process (GstTrilaterate * self, GstBuffer * buf)
{
  State & st = self->priv->state;
  const Settings & s = st.applied.config.s;
  const std::vector<landmark::MapPoint> & map = st.applied.config.map;

  /* the frame's time: its timestamp, else a nominal frame rate */
  GstClockTime now = GST_BUFFER_PTS (buf);
  if (!GST_CLOCK_TIME_IS_VALID (now))
    now = st.frames * FALLBACK_FRAME_NS;
  st.frames++;

  /* detections with a range */
  landmark::RangedDetections & ranged = st.ranged;
  landmark::ranged_detections_collect (buf, false, true, true, &ranged);
  const std::vector<landmark::Detection> & dets = ranged.dets;

  landmark::PoseTrackerOptions opt;
  opt.ekf = s.filter == GST_TRILATERATE_FILTER_EKF;
  /* a measured heading: the property (the filter's prediction is the
   * tracker's) */
  opt.have_heading = s.heading > HEADING_UNSET;
  opt.heading = s.heading * G_PI / 180;
  opt.heading_sigma = s.heading_sigma * G_PI / 180;
  opt.gate = s.gate;
  opt.inlier_distance = s.inlier_distance;
  opt.max_age = s.max_age;
  const landmark::TrackedFrame tf = st.tracker.step (map, dets,
      (double) now / GST_SECOND, opt);
  const landmark::LocaliseResult & res = tf.res;
  const landmark::PoseFields & fp = tf.pose;
  const bool ok = tf.ok;
  const std::string & why = tf.why;

  /* landmark-match on every detection */
  landmark::ranged_detections_mark_skipped (ranged,
      [buf](GstVideoRegionOfInterestMeta * roi, GstStructure * m) {
        landmark_detection_add_param (buf, roi, m);
      });
  for (size_t k = 0; k < dets.size (); k++) {
    GstStructure *m = gst_structure_new (LANDMARK_MATCH_PARAMS,
        "matched", G_TYPE_BOOLEAN, res.match[k] >= 0, nullptr);
    if (res.match[k] >= 0)
      gst_structure_set (m, "landmark-id", G_TYPE_STRING,
          map[res.match[k]].id.c_str (), "matched-by", G_TYPE_STRING,
          landmark::matched_by_name (res.matched_by[k]), nullptr);
    else if (!res.reasons[k].empty ())
      gst_structure_set (m, "reason", G_TYPE_STRING,
          res.reasons[k].c_str (), nullptr);
    if (std::isfinite (res.residual[k]))
      gst_structure_set (m, "residual", G_TYPE_DOUBLE, res.residual[k],
          nullptr);
    landmark_detection_add_param (buf, ranged.rois[k], m);
  }

  if (ok)
    landmark::pose_fields_set (landmark_pose_meta_add (buf), fp);
  landmark_analytics_sync (buf);

  GST_LOG_OBJECT (self, "%zu detections, %s", dets.size (), ok ?
      fp.solver.c_str () : why.c_str ());
  if (s.post_messages) {
    GstStructure *m = landmark_frame_message_new ("landmark-pose", buf,
        &GST_BASE_TRANSFORM_CAST (self)->segment);
    gst_structure_set (m, "has-pose", G_TYPE_BOOLEAN, ok,
        "n-detections", G_TYPE_UINT, (guint) dets.size (), nullptr);
    if (ok)
      landmark::pose_fields_set (m, fp);
    else
      gst_structure_set (m, "reason", G_TYPE_STRING, why.c_str (),
          nullptr);
    gst_element_post_message (GST_ELEMENT_CAST (self),
        gst_message_new_element (GST_OBJECT_CAST (self), m));
  }
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_trilaterate_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_TRILATERATE (trans);
  State & st = self->priv->state;
  gst_trilaterate_sync_settings (self);
  const Config & cfg = st.applied.config;
  /* A map class that the palette lacks is legal (a map may serve several
   * robots) but never matches: say so once, with the first labels. */
  const GstStructure *labels;
  if (!st.map_classes_checked
      && (labels = landmark_labels_meta_get (buf))) {
    st.map_classes_checked = true;
    std::vector<std::pair<std::string, std::string>> classes;
    for (const auto & p : cfg.map)
      if (!p.coded ())    /* a code is no class; beacondetect checks bands */
        classes.push_back ({ p.class_name, p.id });
    landmark_warn_map_classes_missing (GST_ELEMENT_CAST (self), labels,
        cfg.s.map, classes, "they can never be matched.");
  }
  return landmark::run_frame (GST_ELEMENT (self), "Positioning failed.",
      [&] { return gst_trilaterate_process (self, buf); });
}

static void
gst_trilaterate_class_init (GstTrilaterateClass * klass)
{
  landmark::element_class_init<Settings, gst_trilaterate_settings,
      trilaterate_properties> (klass, gst_trilaterate_finalize,
      "Landmark trilateration", "Filter/Analyzer/Video",
      "Robot pose on a landmark map from the ranges and bearings of the "
      "detections: one, two or many landmarks, optional EKF");
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark::set_settings_lifecycle<GstTrilaterate, gst_trilaterate_get_type,
      landmark::apply_parsed<GstTrilaterate, trilaterate_parse>,
      gst_trilaterate_start> (klass);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_trilaterate_sink_event);
  trans_class->transform_ip = GST_DEBUG_FUNCPTR (gst_trilaterate_transform_ip);

  gst_type_mark_as_plugin_api (GST_TYPE_TRILATERATE_FILTER,
      (GstPluginAPIFlags) 0);
}
