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
 * them; landmarks it lacks are added with ids `S1`, `S2`, ...
 *
 * Output, per frame:
 * - a `GstLandmarkPoseMeta` with the fields trilaterate writes (`solver`
 *   `slam`, `filter` `ekf`);
 * - a `GstLandmarkMapMeta`: the landmarks, their covariances, confirmed
 *   or tentative (docs/metadata.md);
 * - on each detection a `landmark-match` structure: `matched`,
 *   `landmark-id`, or `reason` (`no-range`, `not-kept`, `cut-by-border`,
 *   `ambiguous`, `map-full`, `no-pose`).
 *
 * Placed after `trilaterate` it uses the detections trilaterate accepted,
 * leaves trilaterate's `landmark-match` in place and replaces its pose.
 *
 * `odometry=PATH` reads a JSON-lines file of robot-frame increments
 * (`{"t": s, "dx": m, "dy": m, "dheading": rad}`, stream time) in place of
 * the constant-velocity model. `map-out=PATH` writes the anchors and the
 * confirmed landmarks at EOS in trilaterate's map format.
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
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "landmarkmap.h"
#include "landmarkmeta.h"
#include "slam.h"
#include "slamio.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_slam_debug);
#define GST_CAT_DEFAULT gst_landmark_slam_debug

#define DEFAULT_CONFIRM_VIEWS 3
#define DEFAULT_CONFIRM_BASELINE 0.25
#define DEFAULT_GATE 13.82
/* frame interval assumed for buffers without timestamps */
#define FALLBACK_FRAME_NS (GST_SECOND / 30)

enum
{
  PROP_0,
  PROP_MAP,
  PROP_MAP_OUT,
  PROP_ODOMETRY,
  PROP_CONFIRM_VIEWS,
  PROP_CONFIRM_BASELINE,
  PROP_GATE,
};

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

/* *INDENT-OFF* */
namespace {

struct Settings {
  std::string map, map_out, odometry;
  guint confirm_views = DEFAULT_CONFIRM_VIEWS;
  gdouble confirm_baseline = DEFAULT_CONFIRM_BASELINE;
  gdouble gate = DEFAULT_GATE;
  guint generation = 0;
};

/* What the settings give, checked. */
struct Config {
  Settings s;
  std::vector<landmark::MapPoint> map;
  std::vector<landmark::OdometryStep> odometry;
};

struct State {
  Config cfg;
  bool have_cfg = false;
  landmark::Slam slam;
  GstClockTime last_time = GST_CLOCK_TIME_NONE;
  size_t odometry_next = 0;
  guint64 frames = 0;
  bool map_written = false;
};

}  // namespace

struct GstLandmarkSlamPrivate {
  std::mutex lock;              /* guards settings */
  Settings settings;
  State state;
};

struct _GstLandmarkSlam {
  GstBaseTransform parent;
  GstLandmarkSlamPrivate *priv;
};
/* *INDENT-ON* */

G_DEFINE_TYPE_WITH_CODE (GstLandmarkSlam, gst_landmark_slam,
    GST_TYPE_BASE_TRANSFORM,
    GST_DEBUG_CATEGORY_INIT (gst_landmark_slam_debug, "landmarkslam", 0,
        "Landmark SLAM: robot pose and landmark map together"));
GST_ELEMENT_REGISTER_DEFINE (landmarkslam, "landmarkslam", GST_RANK_NONE,
    GST_TYPE_LANDMARK_SLAM);

/* ---- configuration -------------------------------------------------- */

static gboolean
slam_build_config (const Settings & s, Config * cfg, const char **property,
    std::string * why)
{
  cfg->s = s;
  cfg->map.clear ();
  cfg->odometry.clear ();
  if (!s.map.empty ()) {
    *property = "map";
    landmark::LandmarkMap map;
    if (!landmark::map_load_file (s.map, &map, why))
      return FALSE;
    for (const auto & lm : map.landmarks)
      cfg->map.push_back ({ lm.id, lm.class_name, lm.x, lm.y, lm.z,
              lm.diameter, lm.ball });
  }
  if (!s.odometry.empty ()) {
    *property = "odometry";
    if (!landmark::odometry_load_file (s.odometry, &cfg->odometry, why))
      return FALSE;
  }
  return TRUE;
}

static void
slam_apply_options (State & st)
{
  st.slam.opt.confirm_views = (int) st.cfg.s.confirm_views;
  st.slam.opt.confirm_baseline = st.cfg.s.confirm_baseline;
  st.slam.opt.gate_chi2 = st.cfg.s.gate;
}

/* Applies the settings; on failure posts an error (fatal) or a warning and
 * keeps the previous configuration. A new map or odometry file restarts
 * the estimate; the other settings apply from the next frame. */
static gboolean
gst_landmark_slam_configure (GstLandmarkSlam * self, gboolean fatal)
{
  State & st = self->priv->state;
  Settings s;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    s = self->priv->settings;
  }
  const bool restart = !st.have_cfg || s.map != st.cfg.s.map
      || s.odometry != st.cfg.s.odometry;
  if (restart) {
    Config cfg;
    const char *property = "map";
    std::string why;
    if (!slam_build_config (s, &cfg, &property, &why)) {
      if (fatal)
        GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
            ("Invalid '%s' value.", property), ("%s", why.c_str ()));
      else
        GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
            ("Invalid '%s' value; the previous settings stay.", property),
            ("%s", why.c_str ()));
      st.cfg.s.generation = s.generation;
      return FALSE;
    }
    st.cfg = std::move (cfg);
    st.have_cfg = true;
    st.slam.set_map (st.cfg.map);
    st.odometry_next = 0;
    st.last_time = GST_CLOCK_TIME_NONE;
  } else {
    st.cfg.s = s;
  }
  slam_apply_options (st);
  return TRUE;
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_landmark_slam_init (GstLandmarkSlam * self)
{
  self->priv = new GstLandmarkSlamPrivate ();
  GstBaseTransform *trans = GST_BASE_TRANSFORM (self);
  gst_base_transform_set_in_place (trans, TRUE);
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

static void
gst_landmark_slam_finalize (GObject * object)
{
  delete GST_LANDMARK_SLAM (object)->priv;
  G_OBJECT_CLASS (gst_landmark_slam_parent_class)->finalize (object);
}

static void
gst_landmark_slam_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  auto priv = GST_LANDMARK_SLAM (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  Settings & s = priv->settings;
  switch (prop_id) {
    case PROP_MAP:{
      const gchar *v = g_value_get_string (value);
      s.map = v ? v : "";
      break;
    }
    case PROP_MAP_OUT:{
      const gchar *v = g_value_get_string (value);
      s.map_out = v ? v : "";
      break;
    }
    case PROP_ODOMETRY:{
      const gchar *v = g_value_get_string (value);
      s.odometry = v ? v : "";
      break;
    }
    case PROP_CONFIRM_VIEWS:
      s.confirm_views = g_value_get_uint (value);
      break;
    case PROP_CONFIRM_BASELINE:
      s.confirm_baseline = g_value_get_double (value);
      break;
    case PROP_GATE:
      s.gate = g_value_get_double (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      return;
  }
  s.generation++;
}

static void
gst_landmark_slam_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  auto priv = GST_LANDMARK_SLAM (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  const Settings & s = priv->settings;
  auto str = [](const std::string & v) {
    return v.empty ()? nullptr : v.c_str ();
  };
  switch (prop_id) {
    case PROP_MAP:
      g_value_set_string (value, str (s.map));
      break;
    case PROP_MAP_OUT:
      g_value_set_string (value, str (s.map_out));
      break;
    case PROP_ODOMETRY:
      g_value_set_string (value, str (s.odometry));
      break;
    case PROP_CONFIRM_VIEWS:
      g_value_set_uint (value, s.confirm_views);
      break;
    case PROP_CONFIRM_BASELINE:
      g_value_set_double (value, s.confirm_baseline);
      break;
    case PROP_GATE:
      g_value_set_double (value, s.gate);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

/* ---- states and events ---------------------------------------------- */

static GstStateChangeReturn
gst_landmark_slam_change_state (GstElement * element,
    GstStateChange transition)
{
  auto self = GST_LANDMARK_SLAM (element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    /* a missing or malformed map or odometry file fails READY */
    Settings s;
    {
      std::lock_guard<std::mutex> lk (self->priv->lock);
      s = self->priv->settings;
    }
    Config cfg;
    const char *property = "map";
    std::string why;
    if (!slam_build_config (s, &cfg, &property, &why)) {
      GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
          ("Invalid '%s' value.", property), ("%s", why.c_str ()));
      return GST_STATE_CHANGE_FAILURE;
    }
  }
  return GST_ELEMENT_CLASS (gst_landmark_slam_parent_class)->change_state
      (element, transition);
}

static gboolean
gst_landmark_slam_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  st.have_cfg = false;
  st.frames = 0;
  st.map_written = false;
  return gst_landmark_slam_configure (self, TRUE);
}

/* Writes map-out; an unwritable path is an error that names it (the
 * estimate stays in the metadata already sent). */
static gboolean
gst_landmark_slam_write_map (GstLandmarkSlam * self)
{
  State & st = self->priv->state;
  std::string path;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    path = self->priv->settings.map_out;
  }
  if (path.empty ())
    return TRUE;
  std::string why;
  if (!landmark::slam_write_file (path,
          landmark::slam_map_json (st.slam.landmarks ()), &why)) {
    GST_ELEMENT_ERROR (self, RESOURCE, OPEN_WRITE,
        ("Invalid 'map-out' value."), ("%s", why.c_str ()));
    return FALSE;
  }
  GST_INFO_OBJECT (self, "map written to %s", path.c_str ());
  st.map_written = true;
  return TRUE;
}

static gboolean
gst_landmark_slam_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_EOS:
      if (!gst_landmark_slam_write_map (self)) {
        gst_event_unref (event);
        return FALSE;
      }
      break;
    case GST_EVENT_FLUSH_STOP:
    case GST_EVENT_STREAM_START:
      /* a new stream or a seek: time restarts, so does the estimate */
      if (st.have_cfg)
        st.slam.set_map (st.cfg.map);
      st.last_time = GST_CLOCK_TIME_NONE;
      st.odometry_next = 0;
      break;
    default:
      break;
  }
  return GST_BASE_TRANSFORM_CLASS (gst_landmark_slam_parent_class)->sink_event
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

static void
append_value (GValue * array, GType type, guint x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, type);
  if (type == G_TYPE_BOOLEAN)
    g_value_set_boolean (&v, x);
  else
    g_value_set_uint (&v, x);
  gst_value_array_append_and_take_value (array, &v);
}

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
    append_string (&ids, l.id);
    append_string (&classes, l.class_name);
    append_double (&xs, l.x);
    append_double (&ys, l.y);
    for (double c : l.cov)
      append_double (&cov, c);
    append_value (&confirmed, G_TYPE_BOOLEAN, l.confirmed);
    append_value (&views, G_TYPE_UINT, (guint) l.views);
  }
  gst_structure_take_value (s, "ids", &ids);
  gst_structure_take_value (s, "classes", &classes);
  gst_structure_take_value (s, "x", &xs);
  gst_structure_take_value (s, "y", &ys);
  gst_structure_take_value (s, "covariance", &cov);
  gst_structure_take_value (s, "confirmed", &confirmed);
  gst_structure_take_value (s, "views", &views);
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
    if (!st.cfg.odometry.empty ()) {
      GstSegment *seg = &GST_BASE_TRANSFORM_CAST (self)->segment;
      const guint64 a = gst_segment_to_stream_time (seg, GST_FORMAT_TIME,
          st.last_time), b = gst_segment_to_stream_time (seg,
          GST_FORMAT_TIME, now);
      double dx, dy, dh;
      landmark::odometry_between (st.cfg.odometry, (double) a / GST_SECOND,
          (double) b / GST_SECOND, &st.odometry_next, &dx, &dy, &dh);
      slam.predict_odometry (dx, dy, dh, dt);
    } else {
      slam.predict (dt);
    }
  }
  st.last_time = now;

  /* accepted detections with a range */
  std::vector<landmark::SlamObservation> obs;
  std::vector<GstVideoRegionOfInterestMeta *> obs_roi;
  std::vector<std::pair<GstVideoRegionOfInterestMeta *, const char *>> skip;
  {
    gpointer iter = nullptr;
    GstMeta *meta;
    while ((meta = gst_buffer_iterate_meta_filtered (buf, &iter,
                GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
      auto roi = (GstVideoRegionOfInterestMeta *) meta;
      const gchar *by, *why;
      if (landmark_detection_rejected (buf, roi, &by, &why)) {
        skip.push_back ({ roi, "not-kept" });
        continue;
      }
      /* A blob cut by the image border has a biased centre, so a biased
       * range and bearing with the sigmas of a whole one: an anchor
       * can absorb that, a landmark being mapped cannot. */
      const GstStructure *blob = landmark_detection_get_param (buf, roi,
          LANDMARK_BLOB_PARAMS);
      guint fw = 0, fh = 0;
      if (blob && gst_structure_get_uint (blob, "frame-width", &fw)
          && gst_structure_get_uint (blob, "frame-height", &fh)
          && (roi->x == 0 || roi->y == 0 || roi->x + roi->w >= fw
              || roi->y + roi->h >= fh)) {
        skip.push_back ({ roi, "cut-by-border" });
        continue;
      }
      const GstStructure *r = landmark_detection_get_param (buf, roi,
          LANDMARK_RANGE_PARAMS);
      gboolean no_floor = FALSE;
      landmark::SlamObservation o;
      if (!r || (gst_structure_get_boolean (r, "no-floor", &no_floor)
              && no_floor)
          || !gst_structure_get_double (r, "ground-x", &o.obs.gx)
          || !gst_structure_get_double (r, "ground-y", &o.obs.gy)) {
        skip.push_back ({ roi, "no-range" });
        continue;
      }
      gst_structure_get_double (r, "range-sigma", &o.obs.range_sigma);
      gst_structure_get_double (r, "bearing-sigma", &o.obs.bearing_sigma);
      const gchar *cls = g_quark_to_string (roi->roi_type);
      o.class_name = cls ? cls : "";
      /* a new landmark keeps the marker it was ranged with, for map-out */
      const gchar *kind = gst_structure_get_string (r, "marker-kind");
      if (kind && gst_structure_get_double (r, "marker-height", &o.marker_z)
          && gst_structure_get_double (r, "marker-diameter",
              &o.marker_diameter))
        o.marker_ball = g_str_equal (kind, "ball");
      obs.push_back (o);
      obs_roi.push_back (roi);
    }
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
  for (const auto & sk : skip)
    add_match (sk.first,
        gst_structure_new (LANDMARK_MATCH_PARAMS,
            "matched", G_TYPE_BOOLEAN, FALSE,
            "reason", G_TYPE_STRING, sk.second, nullptr));
  std::vector<std::string> ids;
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
    add_match (obs_roi[k], s);
  }

  if (f.ok) {
    GstStructure *p = landmark_pose_meta_add (buf);
    const landmark::Pose2 pose = slam.pose ();
    double c[9];
    slam.pose_cov (c);
    GValue cov = G_VALUE_INIT, idv = G_VALUE_INIT;
    gst_value_array_init (&cov, 9);
    for (double x : c)
      append_double (&cov, x);
    gst_value_array_init (&idv, ids.size ());
    for (const auto & id : ids)
      append_string (&idv, id);
    gst_structure_set (p,
        "x", G_TYPE_DOUBLE, pose.x,
        "y", G_TYPE_DOUBLE, pose.y,
        "heading", G_TYPE_DOUBLE, pose.heading,
        "n-landmarks", G_TYPE_UINT, (guint) ids.size (),
        "residual", G_TYPE_DOUBLE, f.residual,
        "solver", G_TYPE_STRING, "slam",
        "geometry", G_TYPE_STRING, "ok",
        "filter", G_TYPE_STRING, "ekf", nullptr);
    gst_structure_take_value (p, "covariance", &cov);
    gst_structure_take_value (p, "landmarks", &idv);
  }
  set_map_fields (landmark_map_meta_add (buf), slam.landmarks ());
  GST_LOG_OBJECT (self, "%zu detections, %d matched, %d new, %zu landmarks",
      obs.size (), f.n_matched, f.n_new, slam.landmarks ().size ());
  return GST_FLOW_OK;
}

static GstFlowReturn
gst_landmark_slam_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_SLAM (trans);
  State & st = self->priv->state;
  guint generation;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    generation = self->priv->settings.generation;
  }
  if (generation != st.cfg.s.generation)
    gst_landmark_slam_configure (self, FALSE);
  try {
    return gst_landmark_slam_process (self, buf);
  }
  catch (const std::exception & e) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("SLAM failed."),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
}

static void
gst_landmark_slam_class_init (GstLandmarkSlamClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  gobject_class->set_property = gst_landmark_slam_set_property;
  gobject_class->get_property = gst_landmark_slam_get_property;
  gobject_class->finalize = gst_landmark_slam_finalize;

  const GParamFlags flags = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  g_object_class_install_property (gobject_class, PROP_MAP,
      g_param_spec_string ("map", "Map file",
          "Known landmarks (docs/conventions.md), fixed anchors of the "
          "map frame; none: the first pose is the origin", nullptr, flags));
  g_object_class_install_property (gobject_class, PROP_MAP_OUT,
      g_param_spec_string ("map-out", "Map output file",
          "Where to write the map (anchors and confirmed landmarks) at EOS, "
          "in the map format of docs/conventions.md", nullptr, flags));
  g_object_class_install_property (gobject_class, PROP_ODOMETRY,
      g_param_spec_string ("odometry", "Odometry file",
          "JSON lines of robot-frame increments {\"t\", \"dx\", \"dy\", "
          "\"dheading\"} (seconds of stream time, metres, radians); none: "
          "constant-velocity model", nullptr, flags));
  g_object_class_install_property (gobject_class, PROP_CONFIRM_VIEWS,
      g_param_spec_uint ("confirm-views", "Confirm views",
          "Views from distinct poses before a landmark is confirmed",
          1, 1000, DEFAULT_CONFIRM_VIEWS, flags));
  g_object_class_install_property (gobject_class, PROP_CONFIRM_BASELINE,
      g_param_spec_double ("confirm-baseline", "Confirm baseline",
          "Metres the robot must move between two counted views", 0.0,
          100.0, DEFAULT_CONFIRM_BASELINE, flags));
  g_object_class_install_property (gobject_class, PROP_GATE,
      g_param_spec_double ("gate", "Gate",
          "Association gate: squared Mahalanobis distance of a range and "
          "bearing to a landmark (chi-square, 2 degrees of freedom; 13.82 "
          "is 99.9 %)", 0.1, 1000.0, DEFAULT_GATE, flags));

  gst_element_class_set_static_metadata (element_class,
      "Landmark SLAM", "Filter/Analyzer/Video",
      "Robot pose and landmark map together from the ranges and bearings "
      "of the detections (EKF, joint compatibility association)",
      "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  element_class->change_state =
      GST_DEBUG_FUNCPTR (gst_landmark_slam_change_state);
  trans_class->start = GST_DEBUG_FUNCPTR (gst_landmark_slam_start);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_landmark_slam_sink_event);
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_slam_transform_ip);
}
