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
 * - one landmark: the position from its range and bearing and a known
 *   heading (`heading`, or the previous or predicted pose's);
 * - two landmarks: the two-circle intersection, the bearings choosing the
 *   intersection and giving the heading;
 * - three or more: consensus over pairs against one wrong detection, then
 *   Huber-weighted Gauss-Newton over all ranges and bearings.
 *
 * `filter=ekf` runs a constant-velocity extended Kalman filter over the
 * ranges and bearings, which smooths the poses and bridges frames with too
 * few landmarks for up to `max-age` seconds.
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
 *   `landmark-id` (when matched), `residual` (metres, when a pose gives
 *   one), `reason` (when unmatched: `no-range`, `not-kept`,
 *   `no-landmark-of-class`, `outside-gate`, `ambiguous`, `duplicate`,
 *   `outlier`, `too-few-landmarks`, `no-solution`);
 * - a `landmark-pose` element message (`post-messages`): `timestamp`,
 *   `stream-time`, `running-time` (guint64, ns), `has-pose`, the pose
 *   fields above when there is one, else `reason` (`too-few-landmarks` or
 *   `no-solution`), and `n-detections` (detections with a range).
 *
 * A missing or malformed map fails the change to READY with an error
 * naming the file and the entry.
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

#include <cmath>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "landmarkmap.h"
#include "landmarkmeta.h"
#include "posesolver.h"

GST_DEBUG_CATEGORY_STATIC (gst_trilaterate_debug);
#define GST_CAT_DEFAULT gst_trilaterate_debug

#define HEADING_UNSET -361.0
#define DEFAULT_FILTER GST_TRILATERATE_FILTER_NONE
#define DEFAULT_HEADING HEADING_UNSET
#define DEFAULT_HEADING_SIGMA 2.0
#define DEFAULT_GATE 0.5
#define DEFAULT_INLIER_DISTANCE 0.25
#define DEFAULT_MAX_AGE 1.0
/* as labsegment: the metadata is the per-frame channel; a message per
 * frame piles up on a bus nobody watches */
#define DEFAULT_POST_MESSAGES FALSE
/* frame interval assumed for buffers without timestamps */
#define FALLBACK_FRAME_NS (GST_SECOND / 30)

enum
{
  PROP_0,
  PROP_MAP,
  PROP_FILTER,
  PROP_HEADING,
  PROP_HEADING_SIGMA,
  PROP_GATE,
  PROP_INLIER_DISTANCE,
  PROP_MAX_AGE,
  PROP_POST_MESSAGES,
};

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

/* *INDENT-OFF* */
namespace {

struct Settings {
  std::string map;
  GstTrilaterateFilter filter = DEFAULT_FILTER;
  gdouble heading = DEFAULT_HEADING;          /* degrees */
  gdouble heading_sigma = DEFAULT_HEADING_SIGMA;  /* degrees */
  gdouble gate = DEFAULT_GATE;
  gdouble inlier_distance = DEFAULT_INLIER_DISTANCE;
  gdouble max_age = DEFAULT_MAX_AGE;
  gboolean post_messages = DEFAULT_POST_MESSAGES;
  guint generation = 0;
};

struct State {
  Settings s;
  std::vector<landmark::MapPoint> map;
  std::string map_path;
  /* the previous pose (filter=none) */
  bool have_last = false;
  landmark::Pose2 last;
  double last_cov[9] = { 0 };
  GstClockTime last_time = GST_CLOCK_TIME_NONE;
  /* filter=ekf */
  landmark::PoseFilter ekf;
  GstClockTime ekf_time = GST_CLOCK_TIME_NONE;     /* state's time */
  GstClockTime ekf_measured = GST_CLOCK_TIME_NONE; /* last update */
  guint64 frames = 0;
  bool map_classes_checked = false;   /* against the first labels */
};

}  // namespace

struct GstTrilateratePrivate {
  std::mutex lock;              /* guards settings */
  Settings settings;
  State state;
};

struct _GstTrilaterate {
  GstBaseTransform parent;
  GstTrilateratePrivate *priv;
};
/* *INDENT-ON* */

G_DEFINE_TYPE_WITH_CODE (GstTrilaterate, gst_trilaterate,
    GST_TYPE_BASE_TRANSFORM,
    GST_DEBUG_CATEGORY_INIT (gst_trilaterate_debug, "trilaterate", 0,
        "Robot pose from landmark ranges and bearings"));
GST_ELEMENT_REGISTER_DEFINE (trilaterate, "trilaterate", GST_RANK_NONE,
    GST_TYPE_TRILATERATE);

GType
gst_trilaterate_filter_get_type (void)
{
  static GType type = 0;
  static const GEnumValue values[] = {
    {GST_TRILATERATE_FILTER_NONE, "Each frame's own solution", "none"},
    {GST_TRILATERATE_FILTER_EKF, "Constant-velocity extended Kalman filter "
          "over the ranges and bearings; bridges frames with too few "
          "landmarks", "ekf"},
    {0, nullptr, nullptr},
  };
  if (g_once_init_enter (&type)) {
    GType t = g_enum_register_static ("GstTrilaterateFilter", values);
    g_once_init_leave (&type, t);
  }
  return type;
}

/* ---- configuration -------------------------------------------------- */

static gboolean
trilaterate_load_map (const Settings & s, std::vector<landmark::MapPoint>
    *out, const char **property, std::string * why)
{
  *property = "map";
  if (s.map.empty ()) {
    *why = "no landmark map: set map=PATH (the JSON file of "
        "docs/conventions.md)";
    return FALSE;
  }
  landmark::LandmarkMap map;
  if (!landmark::map_load_file (s.map, &map, why))
    return FALSE;
  if (map.landmarks.empty ()) {
    *why = s.map + ": the map has no landmarks";
    return FALSE;
  }
  out->clear ();
  for (const auto & lm : map.landmarks)
    out->push_back ({ lm.id, lm.class_name, lm.x, lm.y, lm.z, lm.diameter,
            lm.ball });
  return TRUE;
}

/* Applies the settings; on failure posts an error (fatal) or a warning and
 * keeps the previous configuration. */
static gboolean
gst_trilaterate_configure (GstTrilaterate * self, gboolean fatal)
{
  State & st = self->priv->state;
  Settings s;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    s = self->priv->settings;
  }
  st.s.generation = s.generation;
  if (s.map != st.map_path || st.map.empty ()) {
    std::vector<landmark::MapPoint> map;
    const char *property = nullptr;
    std::string why;
    if (!trilaterate_load_map (s, &map, &property, &why)) {
      if (fatal)
        GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
            ("Invalid '%s' value.", property), ("%s", why.c_str ()));
      else
        GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
            ("Invalid '%s' value; the previous map stays.", property),
            ("%s", why.c_str ()));
      s.map = st.map_path;
      st.s = s;
      return FALSE;
    }
    st.map = std::move (map);
    st.map_path = s.map;
    st.map_classes_checked = false;
    /* a new map: the previous pose means nothing on it */
    st.have_last = false;
    st.ekf.reset ();
    GST_INFO_OBJECT (self, "map %s: %zu landmarks", s.map.c_str (),
        st.map.size ());
  }
  if (s.filter != st.s.filter)
    st.ekf.reset ();
  st.s = s;
  return TRUE;
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_trilaterate_init (GstTrilaterate * self)
{
  self->priv = new GstTrilateratePrivate ();
  GstBaseTransform *trans = GST_BASE_TRANSFORM (self);
  gst_base_transform_set_in_place (trans, TRUE);
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

static void
gst_trilaterate_finalize (GObject * object)
{
  delete GST_TRILATERATE (object)->priv;
  G_OBJECT_CLASS (gst_trilaterate_parent_class)->finalize (object);
}

static void
gst_trilaterate_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  auto priv = GST_TRILATERATE (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  Settings & s = priv->settings;
  switch (prop_id) {
    case PROP_MAP:{
      const gchar *v = g_value_get_string (value);
      s.map = v ? v : "";
      break;
    }
    case PROP_FILTER:
      s.filter = (GstTrilaterateFilter) g_value_get_enum (value);
      break;
    case PROP_HEADING:
      s.heading = g_value_get_double (value);
      break;
    case PROP_HEADING_SIGMA:
      s.heading_sigma = g_value_get_double (value);
      break;
    case PROP_GATE:
      s.gate = g_value_get_double (value);
      break;
    case PROP_INLIER_DISTANCE:
      s.inlier_distance = g_value_get_double (value);
      break;
    case PROP_MAX_AGE:
      s.max_age = g_value_get_double (value);
      break;
    case PROP_POST_MESSAGES:
      s.post_messages = g_value_get_boolean (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      return;
  }
  s.generation++;
}

static void
gst_trilaterate_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  auto priv = GST_TRILATERATE (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  const Settings & s = priv->settings;
  switch (prop_id) {
    case PROP_MAP:
      g_value_set_string (value, s.map.empty ()? nullptr : s.map.c_str ());
      break;
    case PROP_FILTER:
      g_value_set_enum (value, s.filter);
      break;
    case PROP_HEADING:
      g_value_set_double (value, s.heading);
      break;
    case PROP_HEADING_SIGMA:
      g_value_set_double (value, s.heading_sigma);
      break;
    case PROP_GATE:
      g_value_set_double (value, s.gate);
      break;
    case PROP_INLIER_DISTANCE:
      g_value_set_double (value, s.inlier_distance);
      break;
    case PROP_MAX_AGE:
      g_value_set_double (value, s.max_age);
      break;
    case PROP_POST_MESSAGES:
      g_value_set_boolean (value, s.post_messages);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

/* ---- states --------------------------------------------------------- */

static GstStateChangeReturn
gst_trilaterate_change_state (GstElement * element, GstStateChange transition)
{
  auto self = GST_TRILATERATE (element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    /* a missing or malformed map fails READY */
    Settings s;
    {
      std::lock_guard<std::mutex> lk (self->priv->lock);
      s = self->priv->settings;
    }
    std::vector<landmark::MapPoint> map;
    const char *property = nullptr;
    std::string why;
    if (!trilaterate_load_map (s, &map, &property, &why)) {
      GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
          ("Invalid '%s' value.", property), ("%s", why.c_str ()));
      return GST_STATE_CHANGE_FAILURE;
    }
  }
  return GST_ELEMENT_CLASS (gst_trilaterate_parent_class)->change_state
      (element, transition);
}

static void
gst_trilaterate_reset (State & st)
{
  st.have_last = false;
  st.last_time = GST_CLOCK_TIME_NONE;
  st.ekf.reset ();
  st.ekf_time = st.ekf_measured = GST_CLOCK_TIME_NONE;
  st.frames = 0;
}

static gboolean
gst_trilaterate_start (GstBaseTransform * trans)
{
  auto self = GST_TRILATERATE (trans);
  State & st = self->priv->state;
  gst_trilaterate_reset (st);
  st.map.clear ();
  st.map_path.clear ();
  return gst_trilaterate_configure (self, TRUE);
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

static void
append_double (GValue * array, double x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, G_TYPE_DOUBLE);
  g_value_set_double (&v, x);
  gst_value_array_append_and_take_value (array, &v);
}

static void
append_string (GValue * array, const std::string & x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, G_TYPE_STRING);
  g_value_set_string (&v, x.c_str ());
  gst_value_array_append_and_take_value (array, &v);
}

struct FramePose {
  bool ok = false;
  std::string why;
  landmark::Pose2 pose;
  double cov[9] = { 0 };
  std::vector<std::string> ids;
  double residual = 0;
  std::string solver, geometry = "ok", filter;
};

/* Writes the pose fields into s. */
static void
set_pose_fields (GstStructure * s, const FramePose & fp)
{
  GValue cov = G_VALUE_INIT, ids = G_VALUE_INIT;
  gst_value_array_init (&cov, 9);
  for (double c : fp.cov)
    append_double (&cov, c);
  gst_value_array_init (&ids, fp.ids.size ());
  for (const auto & id : fp.ids)
    append_string (&ids, id);
  gst_structure_set (s,
      "x", G_TYPE_DOUBLE, fp.pose.x,
      "y", G_TYPE_DOUBLE, fp.pose.y,
      "heading", G_TYPE_DOUBLE, fp.pose.heading,
      "n-landmarks", G_TYPE_UINT, (guint) fp.ids.size (),
      "residual", G_TYPE_DOUBLE, fp.residual,
      "solver", G_TYPE_STRING, fp.solver.c_str (),
      "geometry", G_TYPE_STRING, fp.geometry.c_str (),
      "filter", G_TYPE_STRING, fp.filter.c_str (), nullptr);
  gst_structure_take_value (s, "covariance", &cov);
  gst_structure_take_value (s, "landmarks", &ids);
}

static GstFlowReturn
gst_trilaterate_process (GstTrilaterate * self, GstBuffer * buf)
{
  GstBaseTransform *trans = GST_BASE_TRANSFORM_CAST (self);
  State & st = self->priv->state;
  const Settings & s = st.s;

  /* the frame's time: its timestamp, else a nominal frame rate */
  GstClockTime now = GST_BUFFER_PTS (buf);
  if (!GST_CLOCK_TIME_IS_VALID (now))
    now = st.frames * FALLBACK_FRAME_NS;
  st.frames++;
  const GstClockTime max_age = (GstClockTime) (s.max_age * GST_SECOND);
  auto fresh = [&](GstClockTime t) {
    return GST_CLOCK_TIME_IS_VALID (t) && now >= t && now - t <= max_age;
  };

  /* detections with a range */
  std::vector<GstVideoRegionOfInterestMeta *> rois;
  {
    gpointer iter = nullptr;
    GstMeta *meta;
    while ((meta = gst_buffer_iterate_meta_filtered (buf, &iter,
                GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)))
      rois.push_back ((GstVideoRegionOfInterestMeta *) meta);
  }
  std::vector<landmark::Detection> dets;
  std::vector<GstVideoRegionOfInterestMeta *> det_roi;
  std::vector<std::pair<GstVideoRegionOfInterestMeta *, const char *>> skip;
  for (GstVideoRegionOfInterestMeta * roi : rois) {
    /* rejected upstream: by shape (blobroundness) or size (ipmrange) */
    const gchar *by, *why;
    if (landmark_detection_rejected (buf, roi, &by, &why)) {
      skip.push_back ({ roi, "not-kept" });
      continue;
    }
    const GstStructure *r = landmark_detection_get_param (buf, roi,
        LANDMARK_RANGE_PARAMS);
    gboolean no_floor = FALSE;
    landmark::Detection d;
    if (!r || (gst_structure_get_boolean (r, "no-floor", &no_floor)
            && no_floor)
        || !gst_structure_get_double (r, "ground-x", &d.obs.gx)
        || !gst_structure_get_double (r, "ground-y", &d.obs.gy)) {
      skip.push_back ({ roi, "no-range" });
      continue;
    }
    gst_structure_get_double (r, "range-sigma", &d.obs.range_sigma);
    gst_structure_get_double (r, "bearing-sigma", &d.obs.bearing_sigma);
    const gchar *cls = g_quark_to_string (roi->roi_type);
    d.class_name = cls ? cls : "";
    const gchar *kind = gst_structure_get_string (r, "marker-kind");
    d.has_marker = kind
        && gst_structure_get_double (r, "marker-height", &d.marker_z)
        && gst_structure_get_double (r, "marker-diameter",
        &d.marker_diameter);
    d.marker_ball = d.has_marker && g_str_equal (kind, "ball");
    dets.push_back (d);
    det_roi.push_back (roi);
  }

  /* the prior: predicted (ekf) or previous (none) pose */
  landmark::LocaliseOptions opt;
  opt.gate = s.gate;
  opt.lsq.inlier_gate = s.inlier_distance;
  double prior_heading_sigma = 0;
  const bool ekf = s.filter == GST_TRILATERATE_FILTER_EKF;
  if (ekf && st.ekf.initialised ()) {
    if (fresh (st.ekf_measured)) {
      if (GST_CLOCK_TIME_IS_VALID (st.ekf_time) && now > st.ekf_time)
        st.ekf.predict ((double) (now - st.ekf_time) / GST_SECOND);
      st.ekf_time = now;
      opt.have_prior = true;
      opt.prior = st.ekf.pose ();
      double c[9];
      st.ekf.pose_cov (c);
      prior_heading_sigma = std::sqrt (std::max (0.0, c[8]));
    } else {
      st.ekf.reset ();
    }
  } else if (!ekf && st.have_last && fresh (st.last_time)) {
    opt.have_prior = true;
    opt.prior = st.last;
    /* the heading may have changed since */
    prior_heading_sigma = std::sqrt (std::max (0.0, st.last_cov[8])) + 0.05;
  }
  if (s.heading > HEADING_UNSET) {
    opt.have_heading = true;
    opt.heading = landmark::wrap_angle (s.heading * G_PI / 180);
    opt.heading_sigma = s.heading_sigma * G_PI / 180;
  } else if (opt.have_prior) {
    opt.have_heading = true;
    opt.heading = opt.prior.heading;
    opt.heading_sigma = prior_heading_sigma;
  }

  const landmark::LocaliseResult res = landmark::localise (st.map, dets,
      opt);

  FramePose fp;
  fp.filter = ekf ? "ekf" : "none";
  std::vector<landmark::Correspondence> used;
  for (size_t k = 0; k < dets.size (); k++) {
    if (res.match[k] >= 0) {
      const auto & m = st.map[res.match[k]];
      used.push_back ({ dets[k].obs, m.x, m.y });
      fp.ids.push_back (m.id);
    }
  }
  if (res.ok) {
    fp.ok = true;
    fp.pose = res.solution.pose;
    std::copy (res.solution.cov, res.solution.cov + 9, fp.cov);
    fp.residual = res.solution.residual;
    fp.solver = res.solution.solver;
    fp.geometry = landmark::geometry_name (res.solution.geometry);
  }
  if (ekf) {
    if (!st.ekf.initialised ()) {
      if (res.ok) {
        st.ekf.init (res.solution.pose, res.solution.cov);
        st.ekf_time = st.ekf_measured = now;
      }
    } else {
      if (!used.empty () && st.ekf.update (used) > 0)
        st.ekf_measured = now;
      fp.ok = true;
      fp.pose = st.ekf.pose ();
      st.ekf.pose_cov (fp.cov);
      if (!res.ok) {
        fp.solver = "ekf";
        fp.ids.clear ();
        fp.geometry = "ok";
        used.clear ();
      }
      double sum = 0;
      for (const auto & c : used) {
        const double r = landmark::correspondence_residual (fp.pose, c);
        sum += r * r;
      }
      fp.residual = used.empty ()? 0 : std::sqrt (sum / used.size ());
    }
  }
  if (!fp.ok)
    fp.why = res.why.empty ()? "too-few-landmarks" : res.why;
  if (fp.ok && !ekf) {
    st.have_last = true;
    st.last = fp.pose;
    std::copy (fp.cov, fp.cov + 9, st.last_cov);
    st.last_time = now;
  }

  /* landmark-match on every detection */
  for (const auto & sk : skip)
    landmark_detection_add_param (buf, sk.first,
        gst_structure_new (LANDMARK_MATCH_PARAMS,
            "matched", G_TYPE_BOOLEAN, FALSE,
            "reason", G_TYPE_STRING, sk.second, nullptr));
  for (size_t k = 0; k < dets.size (); k++) {
    GstStructure *m = gst_structure_new (LANDMARK_MATCH_PARAMS,
        "matched", G_TYPE_BOOLEAN, res.match[k] >= 0, nullptr);
    if (res.match[k] >= 0)
      gst_structure_set (m, "landmark-id", G_TYPE_STRING,
          st.map[res.match[k]].id.c_str (), nullptr);
    else if (!res.reasons[k].empty ())
      gst_structure_set (m, "reason", G_TYPE_STRING,
          res.reasons[k].c_str (), nullptr);
    if (std::isfinite (res.residual[k]))
      gst_structure_set (m, "residual", G_TYPE_DOUBLE, res.residual[k],
          nullptr);
    landmark_detection_add_param (buf, det_roi[k], m);
  }

  if (fp.ok)
    set_pose_fields (landmark_pose_meta_add (buf), fp);

  GST_LOG_OBJECT (self, "%zu detections, %s", dets.size (), fp.ok ?
      fp.solver.c_str () : fp.why.c_str ());
  if (s.post_messages) {
    const GstClockTime ts = GST_BUFFER_PTS (buf);
    GstStructure *m = gst_structure_new ("landmark-pose",
        "timestamp", G_TYPE_UINT64, ts,
        "stream-time", G_TYPE_UINT64,
        gst_segment_to_stream_time (&trans->segment, GST_FORMAT_TIME, ts),
        "running-time", G_TYPE_UINT64,
        gst_segment_to_running_time (&trans->segment, GST_FORMAT_TIME, ts),
        "has-pose", G_TYPE_BOOLEAN, fp.ok,
        "n-detections", G_TYPE_UINT, (guint) dets.size (), nullptr);
    if (fp.ok)
      set_pose_fields (m, fp);
    else
      gst_structure_set (m, "reason", G_TYPE_STRING, fp.why.c_str (),
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
  guint generation;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    generation = self->priv->settings.generation;
  }
  if (generation != st.s.generation)
    gst_trilaterate_configure (self, FALSE);
  /* A map class that the palette lacks is legal (a map may serve several
   * robots) but never matches: say so once, with the first labels. */
  const GstStructure *labels;
  if (!st.map_classes_checked && !st.map.empty ()
      && (labels = landmark_labels_meta_get (buf))) {
    st.map_classes_checked = true;
    std::vector<std::pair<std::string, std::string>> classes;
    for (const auto & p : st.map)
      classes.push_back ({ p.class_name, p.id });
    landmark_warn_map_classes_missing (GST_ELEMENT_CAST (self), labels,
        st.map_path, classes, "they can never be matched.");
  }
  try {
    return gst_trilaterate_process (self, buf);
  }
  catch (const std::exception & e) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("Positioning failed."),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
}

static void
gst_trilaterate_class_init (GstTrilaterateClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  gobject_class->set_property = gst_trilaterate_set_property;
  gobject_class->get_property = gst_trilaterate_get_property;
  gobject_class->finalize = gst_trilaterate_finalize;

  const GParamFlags flags = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property (gobject_class, PROP_MAP,
      g_param_spec_string ("map", "Map file",
          "Landmark map JSON (docs/conventions.md); required", nullptr,
          flags));
  g_object_class_install_property (gobject_class, PROP_FILTER,
      g_param_spec_enum ("filter", "Filter",
          "Temporal filter of the poses", GST_TYPE_TRILATERATE_FILTER,
          DEFAULT_FILTER, flags));
  g_object_class_install_property (gobject_class, PROP_HEADING,
      g_param_spec_double ("heading", "Heading",
          "Known heading for the one-landmark solver, degrees "
          "counter-clockwise from the map's +x; -361: unknown (use the "
          "previous or predicted pose's)", HEADING_UNSET, 360.0,
          DEFAULT_HEADING, flags));
  g_object_class_install_property (gobject_class, PROP_HEADING_SIGMA,
      g_param_spec_double ("heading-sigma", "Heading sigma",
          "One-sigma error of the heading property, degrees", 0.0, 180.0,
          DEFAULT_HEADING_SIGMA, flags));
  g_object_class_install_property (gobject_class, PROP_GATE,
      g_param_spec_double ("gate", "Gate",
          "Association gate: metres between a detection placed by the "
          "previous or predicted pose and its landmark", 0.0, 1000.0,
          DEFAULT_GATE, flags));
  g_object_class_install_property (gobject_class, PROP_INLIER_DISTANCE,
      g_param_spec_double ("inlier-distance", "Inlier distance",
          "Consensus: metres within which a landmark agrees with a pose "
          "(at least three range/bearing sigmas)", 0.0, 1000.0,
          DEFAULT_INLIER_DISTANCE, flags));
  g_object_class_install_property (gobject_class, PROP_MAX_AGE,
      g_param_spec_double ("max-age", "Maximum age",
          "Seconds a previous pose stays a prior, and filter=ekf bridges "
          "frames without landmarks", 0.0, 3600.0, DEFAULT_MAX_AGE, flags));
  g_object_class_install_property (gobject_class, PROP_POST_MESSAGES,
      g_param_spec_boolean ("post-messages", "Post messages",
          "Post a landmark-pose element message per frame",
          DEFAULT_POST_MESSAGES, flags));

  gst_element_class_set_static_metadata (element_class,
      "Landmark trilateration", "Filter/Analyzer/Video",
      "Robot pose on a landmark map from the ranges and bearings of the "
      "detections: one, two or many landmarks, optional EKF",
      "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  element_class->change_state =
      GST_DEBUG_FUNCPTR (gst_trilaterate_change_state);
  trans_class->start = GST_DEBUG_FUNCPTR (gst_trilaterate_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_trilaterate_sink_event);
  trans_class->transform_ip = GST_DEBUG_FUNCPTR (gst_trilaterate_transform_ip);

  gst_type_mark_as_plugin_api (GST_TYPE_TRILATERATE_FILTER,
      (GstPluginAPIFlags) 0);
}
