/**
 * SECTION:element-landmarkslam
 * @title: landmarkslam
 *
 * The robot's pose and the landmarks' positions together, from the ranges
 * and bearings that `ipmrange` attached to the detections
 * (docs/landmarkslam.md): an extended Kalman filter over the pose and the
 * landmark positions, association by class with a Mahalanobis gate and a
 * joint compatibility test, so that landmarks of one colour are never
 * merged or split.
 *
 * Without `map`, the first pose is the map's origin, heading +x. With
 * `map`, its landmarks are fixed anchors and the first pose is solved on
 * them; landmarks it lacks are added with ids `S1`, `S2`, ... The map's
 * coded markers are anchors found by their code (beacondetect).
 *
 * Output, per frame:
 * - a `GstLandmarkPoseMeta` with the fields trilaterate writes (`solver`
 *   `slam`, `filter` `ekf`);
 * - a `GstLandmarkMapMeta`: the landmarks, their covariances, confirmed
 *   or tentative (docs/metadata.md);
 * - on each detection a `landmark-match` structure: `matched`,
 *   `landmark-id`, or `reason` (`no-range`, `not-kept`, `cut-by-border`,
 *   `ambiguous`, `uncertain-heading`, `map-full`, `no-pose`,
 *   `coded-marker`: a coded marker the map does not anchor).
 *
 * Placed after `trilaterate` it uses the detections trilaterate accepted,
 * leaves trilaterate's `landmark-match` in place and replaces its pose.
 *
 * `odometry=PATH` reads a JSON-lines file of robot-frame increments
 * (`{"t": s, "dx": m, "dy": m, "dheading": rad}`, stream time) in place of
 * the constant-velocity model, a line stamped up to `odometry-tolerance`
 * (1 ms) after a frame counting for that frame; `camera-forward` says how
 * far ahead of the
 * point whose motion the odometry reports (a wheeled robot's turning
 * centre) the camera is; `odometry-slip`, `odometry-heading-slip` and
 * `odometry-turn-slip` state its slip (random walks, synth's units), and
 * `odometry-slip-adapt` (default on) learns one scale of them from how
 * far the landmarks correct the pose after odometry predictions, by
 * default only upward (`odometry-slip-scale-min` 1: the filter never
 * grows more confident than the stated slip; its value in use:
 * `odometry-slip-scale` of the landmark-map message). Live
 * odometry comes from the application as
 * `landmark-odometry` custom downstream events (serialized or
 * out-of-band) with the increment since the previous one, `dx`, `dy`,
 * `dheading` (landmark_odometry_event_new, docs/embedding.md): those
 * received before a frame are its motion. `map-out=PATH` writes the
 * anchors and the confirmed landmarks at EOS in trilaterate's map format,
 * and whenever the application emits the `write-map` action signal
 * (`gboolean write_map (GstElement *, const gchar *path)`, path NULL:
 * `map-out`), also while playing; the file is replaced atomically (a
 * temporary file renamed), and a path that cannot be written is a warning
 * naming it (the signal returns FALSE) while the estimate goes on;
 * `post-messages` posts the map of every frame as a `landmark-map` element
 * message.
 *
 * A missing or malformed map or odometry file fails the change to READY
 * with an error naming it. Every property may change while playing (a new
 * map or odometry file restarts the estimate); a bad value set then is
 * reported with a warning and the previous settings stay in force.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! decodebin ! videoconvert !
 *     labsegment ! blobroundness ! ipmrange calibration=camera.yml
 *     map=map.json ! landmarkslam map-out=built.json ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlandmarkslam.h"

#include <gst/video/video.h>

#include <cmath>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "elementsettings.h"
#include "landmarkmap.h"
#include "landmarkmeta.h"
#include "posemeta.h"
#include "slam.h"
#include "slamio.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_slam_debug);
#define GST_CAT_DEFAULT gst_landmark_slam_debug

/* frame interval assumed for buffers without timestamps */
#define FALLBACK_FRAME_NS (GST_SECOND / 30)

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string map, map_out, odometry;
  guint confirm_views = 3;
  gdouble confirm_baseline = 0;
  gdouble confirm_sigma = 0.03;
  gdouble gate = 13.82;
  gdouble camera_forward = 0;
  /* ns an odometry line may be stamped after the frame it belongs to */
  guint64 odometry_tolerance = 1000000;
  /* the odometry's slip, as gst-landmark synth states it (random walks) */
  gdouble odometry_slip = 0.002;
  gdouble odometry_heading_slip = 0.002;
  gdouble odometry_turn_slip = 0.002;
  gboolean odometry_slip_adapt = TRUE;
  gdouble odometry_slip_scale_min = 1.0;
  /* the detections' slow error (docs/landmarkslam.md) */
  gdouble measurement_slow_share = 0.5;
  gdouble measurement_slow_length = 0.3;
  gboolean post_messages = FALSE;
};

/* What the settings give, checked. */
struct Config {
  Settings s;
  std::vector<landmark::MapPoint> map;
  std::vector<landmark::OdometryStep> odometry;
};

struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  /* held while the streaming thread changes the estimate, and by
   * write-map from the application's thread; recursive because a sync bus
   * handler of a message posted mid-frame may emit write-map */
  std::recursive_mutex slam_lock;
  /* one map write at a time, taken after the snapshot (never while
   * slam_lock is held: a sync handler may write mid-frame), and the frame
   * count of the newest snapshot written: an older one is not written
   * over it */
  std::mutex write_lock;
  /* the frame's landmark-map message, posted after slam_lock is released */
  GstMessage *pending_message = nullptr;
  guint64 written_frames = 0;
  std::string written_path;
  landmark::Slam slam;
  GstClockTime last_time = GST_CLOCK_TIME_NONE;
  size_t odometry_next = 0;
  bool odometry_ended = false;          /* said once */
  guint64 frames = 0;
  landmark::RangedDetections ranged;  /* reused */
  std::vector<landmark::SlamObservation> obs;   /* reused */

  /* live odometry (landmark-odometry events), summed until the next frame;
   * out-of-band events come from the application's threads */
  std::mutex live_lock;
  landmark::OdometrySum live;
  bool live_seen = false;
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstLandmarkSlam, gst_landmark_slam,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, landmarkslam,
    "Landmark SLAM: robot pose and landmark map together");

/* ---- configuration -------------------------------------------------- */

/* Reads the map (anchors) and odometry files the settings name. */
static bool
slam_parse (const Settings & s, Config * cfg, landmark::SettingsError * err)
{
  cfg->s = s;
  cfg->map.clear ();
  cfg->odometry.clear ();
  std::string why;
  if (!s.map.empty ()) {
    landmark::LandmarkMap map;
    if (!landmark::map_load_file (s.map, &map, &why))
      return err->fail ("map", why);
    /* coded anchors by their code (beacondetect), as trilaterate's */
    cfg->map = landmark::map_pose_landmarks (map);
  }
  /* no odometry file: the constant-velocity model */
  return s.odometry.empty ()
      || landmark::odometry_load_file (s.odometry, &cfg->odometry, &why)
      || err->fail ("odometry", why);
}

static const landmark::PropertyTable<Settings> &
slam_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("map", "Map file",
          "Known landmarks (docs/conventions.md), fixed anchors of the "
          "map frame; none: the first pose is the origin",
          &Settings::map)
      .string ("map-out", "Map output file",
          "Where to write the map (anchors and confirmed landmarks) at EOS, "
          "in the map format of docs/conventions.md",
          &Settings::map_out)
      .string ("odometry", "Odometry file",
          "JSON lines of robot-frame increments {\"t\", \"dx\", \"dy\", "
          "\"dheading\"} (seconds of stream time, metres, radians); none: "
          "constant-velocity model", &Settings::odometry)
      .number ("odometry-tolerance", "Odometry tolerance",
          "Nanoseconds an odometry line's time may be after a frame's and "
          "still count for that frame (timestamps rounded differently: a "
          "demuxer truncating, stamps written to the millisecond)",
          &Settings::odometry_tolerance, (guint64) 0, (guint64) GST_SECOND)
      .number ("camera-forward", "Camera forward",
          "Metres the camera's floor point is ahead of the point whose "
          "motion the odometry reports (the turning centre, the middle of a "
          "differential drive's axle); 0: the odometry reports the camera's "
          "own motion", &Settings::camera_forward, -10.0, 10.0)
      .number ("odometry-slip", "Odometry slip",
          "Metres per square root of metre: the odometry's translation "
          "slip, a random walk over the distance (the sigma after one "
          "metre, along and across)", &Settings::odometry_slip, 0.0, 1.0)
      .number ("odometry-heading-slip", "Odometry heading slip",
          "Radians per square root of metre: the odometry's heading slip "
          "per distance driven", &Settings::odometry_heading_slip, 0.0, 1.0)
      .number ("odometry-turn-slip", "Odometry turn slip",
          "Radians per square root of radian: the odometry's heading slip "
          "per angle turned", &Settings::odometry_turn_slip, 0.0, 1.0)
      .boolean ("odometry-slip-adapt", "Odometry slip adapt",
          "Learn the slip actually met: one scale of the three slip sigmas "
          "(odometry-slip-scale-min to 4), from how far the landmarks "
          "correct the pose after odometry predictions, starting from the "
          "stated values", &Settings::odometry_slip_adapt)
      .number ("odometry-slip-scale-min", "Odometry slip scale min",
          "The smallest scale the learnt slip may take: 1 learns only a "
          "slip larger than stated (the filter never more confident than "
          "the statement); below 1 it may also learn a smaller one",
          &Settings::odometry_slip_scale_min, 0.25, 1.0)
      .number ("measurement-slow-share", "Measurement slow share",
          "Share of each detection's stated variance taken as an error that "
          "changes only slowly with the viewpoint (states per landmark in "
          "view); 0: every error white",
          &Settings::measurement_slow_share, 0.0, 0.95)
      .number ("measurement-slow-length", "Measurement slow length",
          "Metres driven (a radian turned counted as a metre) over which "
          "the slow error changes: its correlation length",
          &Settings::measurement_slow_length, 0.01, 100.0)
      .number ("confirm-views", "Confirm views",
          "Frames a landmark must be paired in (views, counted from poses "
          "confirm-baseline apart) before it is confirmed: that it exists",
          &Settings::confirm_views, 1u, 1000u)
      .number ("confirm-baseline", "Confirm baseline",
          "Metres the robot must move between two counted views (0: every "
          "frame the landmark is paired in counts)",
          &Settings::confirm_baseline, 0.0, 100.0)
      .number ("confirm-sigma", "Confirm sigma",
          "Metres: a landmark is confirmed once the largest standard "
          "deviation of its position is at most this (and it has its "
          "views): that it is known", &Settings::confirm_sigma, 0.0001, 100.0)
      .number ("gate", "Gate",
          "Association gate: squared Mahalanobis distance of a range and "
          "bearing to a landmark (chi-square, 2 degrees of freedom; 13.82 "
          "is 99.9 %)", &Settings::gate, 0.1, 1000.0)
      .boolean ("post-messages", "Post messages",
          "Post a landmark-map element message per frame (the fields of "
          "the map meta)", &Settings::post_messages);
  return table;
}

/* The part of the disagreement of ipmrange's floor and size ranges that
 * their sigmas do not explain (docs/landmarkslam.md, "Blobs segmented in part"):
 * ipmrange's `size-excess`, signed as `range-size - range-ground`; 0
 * without it. ipmrange has added it once to range-sigma and bearing-sigma;
 * the filter adds it once per view of the pass (slam_observation_sigmas),
 * so it is taken out of the observation's sigmas here. */
static double
range_disagreement (GstBuffer * buf, GstVideoRegionOfInterestMeta * roi,
    landmark::RangeBearing * obs)
{
  const GstStructure *rs = landmark_detection_get_param (buf, roi,
      LANDMARK_RANGE_PARAMS);
  double excess, r_size, r_ground;
  if (!rs || !gst_structure_get_double (rs, "size-excess", &excess)
      || !(excess > 0) || !std::isfinite (excess)
      || !gst_structure_get_double (rs, "range-size", &r_size)
      || !gst_structure_get_double (rs, "range-ground", &r_ground))
    return 0;
  const double r = obs->range ();
  if (obs->range_sigma > 0)
    obs->range_sigma = std::sqrt (std::max (0.0, obs->range_sigma *
            obs->range_sigma - excess * excess));
  if (obs->bearing_sigma > 0 && r > 0)
    obs->bearing_sigma = std::sqrt (std::max (0.0, obs->bearing_sigma *
            obs->bearing_sigma - (excess / r) * (excess / r)));
  return std::copysign (excess, r_size - r_ground);
}

/* The estimate starts again on the configured anchors. */
static void
slam_restart (State & st)
{
  st.slam.set_map (st.applied.config.map);
  st.odometry_next = 0;
  st.odometry_ended = false;
  st.last_time = GST_CLOCK_TIME_NONE;
  std::lock_guard<std::mutex> lk (st.live_lock);
  st.live = landmark::OdometrySum ();
}

static void
slam_apply_options (State & st)
{
  const Settings & s = st.applied.config.s;
  st.slam.opt.confirm_views = (int) s.confirm_views;
  st.slam.opt.confirm_baseline = s.confirm_baseline;
  st.slam.opt.confirm_sigma = s.confirm_sigma;
  st.slam.opt.gate_chi2 = s.gate;
  st.slam.opt.odo_camera_forward = s.camera_forward;
  /* a scale learnt against other stated values (or while not learning)
   * does not carry over: learning starts again from the new ones */
  landmark::SlamOptions & o = st.slam.opt;
  const bool slip_changed = o.odo_trans_sigma != s.odometry_slip
      || o.odo_rot_per_m != s.odometry_heading_slip
      || o.odo_rot_sigma != s.odometry_turn_slip
      || o.odo_slip_adapt != s.odometry_slip_adapt
      || o.odo_slip_scale_min != s.odometry_slip_scale_min;
  o.odo_trans_sigma = s.odometry_slip;
  o.odo_rot_per_m = s.odometry_heading_slip;
  o.odo_rot_sigma = s.odometry_turn_slip;
  o.odo_slip_adapt = s.odometry_slip_adapt;
  o.odo_slip_scale_min = s.odometry_slip_scale_min;
  if (slip_changed)
    st.slam.restart_slip_learning ();
  st.slam.set_slow_errors (s.measurement_slow_share,
      s.measurement_slow_length);
}

/* Brings the state up to date with settings changed while playing (a bad
 * value: a warning, and the previous settings stay). A new map or
 * odometry file restarts the estimate; the other settings apply from this
 * frame. */
static void
gst_landmark_slam_sync_settings (GstLandmarkSlam * self)
{
  State & st = self->priv->state;
  const Config & previous = st.applied.config;    /* until sync replaces it */
  bool restart = false;
  auto parse = [&](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    restart = s.map != previous.s.map || s.odometry != previous.s.odometry;
    if (restart)
      return slam_parse (s, cfg, err);
    cfg->s = s;
    cfg->map = previous.map;
    cfg->odometry = previous.odometry;
    return true;
  };
  if (!st.applied.sync (GST_ELEMENT (self), self->priv->settings, parse))
    return;
  if (restart)
    slam_restart (st);
  slam_apply_options (st);
}

/* ---- states and events ---------------------------------------------- */

static gboolean
gst_landmark_slam_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  std::lock_guard<std::recursive_mutex> lk (st.slam_lock);
  st.frames = 0;
  {
    std::lock_guard<std::mutex> writing (st.write_lock);
    st.written_frames = 0;
    st.written_path.clear ();
  }
  slam_restart (st);
  slam_apply_options (st);
  return TRUE;
}

/* Writes the map to path, or to map-out when path is empty (nothing to do
 * without either at EOS). An unwritable path is an error that names it at
 * EOS, a warning when asked while running (the estimate goes on); the
 * estimate stays in the metadata already sent. */
static gboolean
gst_landmark_slam_write_map (GstLandmarkSlam * self, const char *asked,
    bool at_eos)
{
  State & st = self->priv->state;
  /* as set now: map-out needs no parsing, so it is read where it is used */
  const std::string path = asked && *asked ? std::string (asked) :
      self->priv->settings.copy ().map_out;
  if (path.empty ()) {
    if (!at_eos)
      GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
          ("write-map: no path given and 'map-out' is not set."), (nullptr));
    return at_eos;
  }
  std::unique_lock<std::recursive_mutex> lk (st.slam_lock);
  const std::string text = landmark::slam_map_json (st.slam.landmarks ());
  const guint64 frames = st.frames;
  lk.unlock ();
  std::lock_guard<std::mutex> writing (st.write_lock);
  if (frames < st.written_frames && path == st.written_path)
    return TRUE;                /* a newer estimate is already there */
  std::string why;
  if (!landmark::slam_write_file (path, text, &why)) {
    if (at_eos)
      GST_ELEMENT_ERROR (self, RESOURCE, OPEN_WRITE,
          ("Invalid 'map-out' value."), ("%s", why.c_str ()));
    else
      GST_ELEMENT_WARNING (self, RESOURCE, OPEN_WRITE,
          ("write-map: cannot write the map to %s.", path.c_str ()),
          ("%s", why.c_str ()));
    return FALSE;
  }
  st.written_frames = frames;
  st.written_path = path;
  GST_INFO_OBJECT (self, "map written to %s", path.c_str ());
  return TRUE;
}

/* The write-map action signal. */
static gboolean
gst_landmark_slam_write_map_action (GstLandmarkSlam * self, const char *path)
{
  return gst_landmark_slam_write_map (self, path, false);
}

/* An increment from the application; a malformed one is refused with a
 * warning naming the field (the estimate goes on without it). */
static void
gst_landmark_slam_live_odometry (GstLandmarkSlam * self,
    const GstStructure * s)
{
  State & st = self->priv->state;
  double d[3] = { 0, 0, 0 };
  const char *fields[3] = { "dx", "dy", "dheading" };
  for (int i = 0; i < 3; i++) {
    const bool optional = i == 1;
    if (!(optional && !gst_structure_has_field (s, fields[i])) &&
        !(gst_structure_get_double (s, fields[i], &d[i]) &&
            std::isfinite (d[i]))) {
      GST_ELEMENT_WARNING (self, STREAM, FORMAT,
          ("Ignored a %s event: '%s' must be a finite number (double).",
              GST_LANDMARK_ODOMETRY_EVENT_NAME, fields[i]),
          ("%" GST_PTR_FORMAT, s));
      return;
    }
  }
  std::lock_guard<std::mutex> lk (st.live_lock);
  st.live.add (d[0], d[1], d[2]);
  st.live_seen = true;
}

static gboolean
gst_landmark_slam_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_EOS:
      {
        std::lock_guard<std::recursive_mutex> lk (st.slam_lock);
        GST_INFO_OBJECT (self, "odometry slip scale %.3f (measurements' "
            "scale %.3f)", st.slam.odometry_slip_scale (),
            st.slam.measurement_scale ());
      }
      if (!gst_landmark_slam_write_map (self, nullptr, true)) {
        gst_event_unref (event);
        return FALSE;
      }
      break;
    case GST_EVENT_FLUSH_STOP:
    case GST_EVENT_STREAM_START:{
      /* a new stream or a seek: time restarts, so does the estimate */
      std::lock_guard<std::recursive_mutex> lk (st.slam_lock);
      slam_restart (st);
      break;
    }
    case GST_EVENT_CUSTOM_DOWNSTREAM:
    case GST_EVENT_CUSTOM_DOWNSTREAM_OOB:
      if (gst_event_has_name (event, GST_LANDMARK_ODOMETRY_EVENT_NAME))
        gst_landmark_slam_live_odometry (self, gst_event_get_structure
            (event));
      break;
    default:
      break;
  }
  return GST_BASE_TRANSFORM_CLASS (gst_landmark_slam_parent_class)->sink_event
      (trans, event);
}

/* ---- streaming ------------------------------------------------------ */

static void
set_map_fields (GstStructure * s,
    const std::vector<landmark::SlamLandmark> & lms)
{
  GValue ids = G_VALUE_INIT, classes = G_VALUE_INIT, xs = G_VALUE_INIT,
      ys = G_VALUE_INIT, cov = G_VALUE_INIT, confirmed = G_VALUE_INIT,
      views = G_VALUE_INIT;
  for (GValue * a : { &ids, &classes, &xs, &ys, &cov, &confirmed, &views })
    gst_value_array_init (a, lms.size ());
  for (const auto & l : lms) {
    landmark_value_array_append_string (&ids, l.id.c_str ());
    landmark_value_array_append_string (&classes, l.class_name.c_str ());
    landmark_value_array_append_double (&xs, l.x);
    landmark_value_array_append_double (&ys, l.y);
    for (double c : l.cov)
      landmark_value_array_append_double (&cov, c);
    landmark_value_array_append_boolean (&confirmed, l.confirmed);
    landmark_value_array_append_uint (&views, (guint) l.views);
  }
  gst_structure_take_value (s, "ids", &ids);
  gst_structure_take_value (s, "classes", &classes);
  gst_structure_take_value (s, "x", &xs);
  gst_structure_take_value (s, "y", &ys);
  gst_structure_take_value (s, "covariance", &cov);
  gst_structure_take_value (s, "confirmed", &confirmed);
  gst_structure_take_value (s, "views", &views);
}

/* Whether a detection of this class can be used: every disc or ball; a
 * coded marker only when the map anchors its code. */
static bool
gst_landmark_slam_usable (const std::vector<landmark::MapPoint> & map,
    const std::string & class_name)
{
  if (!landmark::is_coded_match_class (class_name))
    return true;
  for (const landmark::MapPoint & m : map)
    if (m.coded () && m.class_name == class_name)
      return true;
  return false;
}

static GstFlowReturn
gst_landmark_slam_process (GstLandmarkSlam * self, GstBuffer * buf)
{
  State & st = self->priv->state;
  landmark::Slam & slam = st.slam;

  GstClockTime now = GST_BUFFER_PTS (buf);
  if (!GST_CLOCK_TIME_IS_VALID (now))
    now = st.frames * FALLBACK_FRAME_NS;
  st.frames++;

  /* motion since the previous frame */
  if (GST_CLOCK_TIME_IS_VALID (st.last_time) && now > st.last_time) {
    const double dt = (double) (now - st.last_time) / GST_SECOND;
    const std::vector<landmark::OdometryStep> & log =
        st.applied.config.odometry;
    GstSegment *seg = &GST_BASE_TRANSFORM_CAST (self)->segment;
    guint64 ta = gst_segment_to_stream_time (seg, GST_FORMAT_TIME,
        st.last_time);
    const guint64 tb = gst_segment_to_stream_time (seg, GST_FORMAT_TIME,
        now);
    /* the first frame inside the segment: the file from the segment's
     * start on */
    if (!GST_CLOCK_TIME_IS_VALID (ta) && GST_CLOCK_TIME_IS_VALID (tb)
        && st.last_time < seg->start)
      ta = gst_segment_to_stream_time (seg, GST_FORMAT_TIME, seg->start);
    /* a line stamped up to odometry-tolerance after a frame is that
     * frame's: the frames (a, b] take the lines (a + tol, b + tol] */
    const double tol = (double) st.applied.config.s.odometry_tolerance
        / GST_SECOND;
    const double a = (double) ta / GST_SECOND + tol;
    if (log.empty ()) {
      std::unique_lock<std::mutex> lk (st.live_lock);
      const landmark::OdometrySum live = st.live;
      const bool live_seen = st.live_seen;
      st.live = landmark::OdometrySum ();
      lk.unlock ();
      if (live_seen)
        slam.predict_odometry (live.dx, live.dy, live.dheading, dt);
      else
        slam.predict (dt);
    } else if (!GST_CLOCK_TIME_IS_VALID (ta)
        || !GST_CLOCK_TIME_IS_VALID (tb)) {
      /* outside the segment the frames have no stream time to look the
       * file up at (they are clipped downstream): the motion model */
      slam.predict (dt);
    } else if (a >= log.back ().t) {
      /* past the log's end no increment would read as standing still,
       * certain: the motion model carries the pose instead */
      if (!st.odometry_ended)
        GST_ELEMENT_WARNING (self, STREAM, FAILED, ("The odometry file "
                "'%s' ends at %.3f s; later frames use the motion model.",
                st.applied.config.s.odometry.c_str (), log.back ().t), (nullptr));
      st.odometry_ended = true;
      slam.predict (dt);
    } else {
      double dx, dy, dh;
      landmark::odometry_between (log, a, (double) tb / GST_SECOND + tol,
          &st.odometry_next, &dx, &dy, &dh);
      slam.predict_odometry (dx, dy, dh, dt);
    }
  }
  st.last_time = now;

  /* accepted detections with a range. A blob cut by the image border has
   * a biased centre, so a biased range and bearing with the sigmas of a
   * whole one: an anchor can absorb that, a landmark being mapped cannot. */
  landmark::RangedDetections & ranged = st.ranged;
  landmark::ranged_detections_collect (buf, true, false, true, &ranged);
  /* a coded marker counts only where the map anchors its code: a new one
   * cannot be mapped yet (docs/beacons.md) */
  size_t used = 0;
  for (size_t k = 0; k < ranged.dets.size (); k++) {
    if (!gst_landmark_slam_usable (st.applied.config.map,
            ranged.dets[k].class_name)) {
      ranged.skipped.push_back ({ ranged.rois[k], "coded-marker" });
      continue;
    }
    ranged.dets[used] = ranged.dets[k];
    ranged.rois[used++] = ranged.rois[k];
  }
  ranged.dets.resize (used);
  ranged.rois.resize (used);
  std::vector<landmark::SlamObservation> & obs = st.obs;
  obs.clear ();
  for (size_t k = 0; k < ranged.dets.size (); k++) {
    const landmark::Detection & d = ranged.dets[k];
    landmark::SlamObservation o;
    o.class_name = d.class_name;
    o.obs = d.obs;
    /* a new landmark keeps the marker it was ranged with, for map-out */
    o.marker_z = d.marker_z;
    o.marker_diameter = d.marker_diameter;
    o.marker_ball = d.marker_ball;
    o.range_disagreement = range_disagreement (buf, ranged.rois[k],
        &o.obs);
    obs.push_back (o);
  }

  const landmark::SlamFrame f = slam.update (obs);

  /* After trilaterate, its landmark-match stays the detections' verdict
   * (a second one would reach only some readers). */
  auto add_match = [&](GstVideoRegionOfInterestMeta * roi, GstStructure * m) {
    if (landmark_detection_get_param (buf, roi, LANDMARK_MATCH_PARAMS))
      gst_structure_free (m);
    else
      landmark_detection_add_param (buf, roi, m);
  };
  landmark::ranged_detections_mark_skipped (ranged, add_match);
  landmark::PoseFields pose;
  std::vector<std::string> & ids = pose.ids;
  for (size_t k = 0; k < obs.size (); k++) {
    const int m = f.match[k];
    GstStructure *s = gst_structure_new (LANDMARK_MATCH_PARAMS,
        "matched", G_TYPE_BOOLEAN, m >= 0, nullptr);
    if (m >= 0) {
      const auto & l = slam.landmarks ()[m];
      gst_structure_set (s, "landmark-id", G_TYPE_STRING, l.id.c_str (),
          nullptr);
      if (f.reasons[k].empty ())
        ids.push_back (l.id);
    } else {
      gst_structure_set (s, "reason", G_TYPE_STRING, f.reasons[k].c_str (),
          nullptr);
    }
    add_match (ranged.rois[k], s);
  }

  if (f.ok) {
    pose.pose = slam.pose ();
    slam.pose_cov (pose.cov);
    pose.residual = f.residual;
    pose.solver = "slam";
    pose.filter = "ekf";
    landmark::pose_fields_set (landmark_pose_meta_add (buf), pose);
  }
  set_map_fields (landmark_map_meta_add (buf), slam.landmarks ());
  if (st.applied.config.s.post_messages) {
    GstStructure *m = landmark_frame_message_new ("landmark-map", buf,
        &GST_BASE_TRANSFORM_CAST (self)->segment);
    gst_structure_set (m, "has-pose", G_TYPE_BOOLEAN, (gboolean) f.ok,
        "odometry-slip-scale", G_TYPE_DOUBLE, slam.odometry_slip_scale (),
        nullptr);
    set_map_fields (m, slam.landmarks ());
    /* posted once slam_lock is released (transform_ip): a sync handler
     * may hand work to a thread that emits write-map and wait for it */
    st.pending_message = gst_message_new_element (GST_OBJECT_CAST (self), m);
  }
  GST_LOG_OBJECT (self, "%zu detections, %d matched, %d new, %zu landmarks",
      obs.size (), f.n_matched, f.n_new, slam.landmarks ().size ());
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_landmark_slam_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  GstFlowReturn ret;
  GstMessage *message;
  {
    std::lock_guard<std::recursive_mutex> lk (st.slam_lock);
    gst_landmark_slam_sync_settings (self);
    ret = landmark::run_frame (GST_ELEMENT (self), "SLAM failed.",
        [&] { return gst_landmark_slam_process (self, buf); });
    message = std::exchange (st.pending_message, nullptr);
  }
  if (message)
    gst_element_post_message (GST_ELEMENT_CAST (self), message);
  return ret;
}

static void
gst_landmark_slam_class_init (GstLandmarkSlamClass * klass)
{
  landmark::element_class_init<Settings, gst_landmark_slam_settings,
      slam_properties> (klass, gst_landmark_slam_finalize,
      "Landmark SLAM", "Filter/Analyzer/Video",
      "Robot pose and landmark map together from the ranges and bearings "
      "of the detections (EKF, joint compatibility association)");
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  landmark::set_settings_lifecycle<GstLandmarkSlam, gst_landmark_slam_get_type,
      landmark::apply_parsed<GstLandmarkSlam, slam_parse>,
      gst_landmark_slam_start> (klass);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_landmark_slam_sink_event);
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_slam_transform_ip);

  /**
   * GstLandmarkSlam::write-map:
   * @slam: the element
   * @path: (nullable): where to write; NULL or "": `map-out`
   *
   * Writes the map now (anchors and confirmed landmarks, the format of
   * `map-out`), atomically, from any thread and in any state.
   *
   * Returns: TRUE when written; FALSE (with a warning naming the path)
   * when it could not be, or when there is no path.
   */
  g_signal_new_class_handler ("write-map", G_TYPE_FROM_CLASS (klass),
      (GSignalFlags) (G_SIGNAL_RUN_LAST | G_SIGNAL_ACTION),
      G_CALLBACK (gst_landmark_slam_write_map_action), nullptr, nullptr,
      nullptr, G_TYPE_BOOLEAN, 1, G_TYPE_STRING);
}
