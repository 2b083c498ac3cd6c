/**
 * SECTION:element-landmarkpublish
 * @title: landmarkpublish
 *
 * Sends the gst-landmark results of every frame to an MQTT broker, one
 * message per frame, and passes the video through untouched (a passthrough
 * GstBaseTransform on any `video/x-raw`, QoS off, like landmarklog).
 *
 * The message is the JSON object landmarklog writes for the frame
 * (docs/landmarklog.md) with three fields in front:
 *
 * |[
 * {"robot": "r1", "running-time": 33333333, "wall-time": 1764072000.123456,
 *  "frame": 1, "pts": 33333333, "duration": 33333333, "width": 640,
 *  "height": 480, "labels": {...}, "detections": [...], "pose": {...}}
 * ]|
 *
 * - `robot`: the `robot` property; `running-time`: the buffer's running
 *   time in nanoseconds (absent without a timestamp); `wall-time`: seconds
 *   since 1970 (UTC) when the element handled the frame.
 *
 * Topics (`{robot}` and `{client-id}` are replaced; nothing else in braces,
 * no `+` or `#`):
 * - `topic` (`landmark/{robot}/frame`): every frame, at `mqtt-qos` (not `qos`: GstBaseTransform's own property).
 * - `pose-topic` (`landmark/{robot}/pose`): the latest pose, retained, so
 *   a subscriber that arrives late gets it at once. Empty: not sent.
 * - `status-topic` (`landmark/{robot}/status`): retained `online` when
 *   connected, `offline` when the element stops, and the same `offline` as
 *   the broker's last will when the connection dies. Empty: not sent.
 *
 * Delivery: the streaming thread only appends the message to a bounded
 * in-order queue and never waits for the network. A network thread of the
 * element connects, hands the queue to libmosquitto in order (at most 20
 * in flight) and, when the broker is away, retries with exponential
 * back-off (1 s doubling to `reconnect-delay-max`) while the queue keeps
 * the messages. The session is persistent (`clean-session` false, client
 * id `landmark-{robot}`): after a reconnection the messages that were in
 * flight are completed first (libmosquitto keeps them) and the queue
 * follows, so the order is kept; when the broker has lost the session
 * (restarted without persistence) every unacknowledged message is sent
 * again from the element's own copies. When the queue holds more than `max-queue-messages`
 * messages or `max-queue-bytes` bytes the oldest are dropped: a warning
 * once per episode and a `landmark-publish-dropped` element message with
 * the counts. At EOS the element waits up to `drain-timeout` ms for the
 * queue to be delivered.
 *
 * Element messages:
 * - `landmark-publish-connection`: `connected` (boolean), `host`, `port`,
 *   `queued` (messages waiting), `dropped` (total so far), `reason` (why
 *   not connected, when not).
 * - `landmark-publish-dropped`: `dropped` (total since start), `queued`,
 *   `max-queue-messages`, `max-queue-bytes`, `episode-over` (FALSE when
 *   dropping starts, TRUE when the queue has been delivered again).
 *
 * Configuration errors (a malformed topic, robot or client id, a TLS file
 * that cannot be read) stop the element at start with an error naming the
 * property. Network trouble (unknown host, broker away, credentials or
 * certificate refused) is a warning naming the setting to check; the
 * video keeps flowing and the element keeps trying.
 *
 * The connection (queue, network thread, reconnection) is in mqttlink.cpp,
 * with why it runs a network thread of its own; the topics and payloads
 * are in publishmessages.cpp.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=100 ! labsegment ! blobroundness !
 *     landmarkpublish host=127.0.0.1 robot=r1 ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlandmarkpublish.h"

#include <gst/video/video.h>
#include <glib/gstdio.h>

#include <cerrno>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "elementsettings.h"
#include "landmarkjson.h"
#include "landmarkmeta.h"
#include "mqttlink.h"
#include "publishmessages.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_publish_debug);
#define GST_CAT_DEFAULT gst_landmark_publish_debug

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). The
 * connection settings are read in start(); the queue bounds and the drain
 * timeout also while PLAYING. */
struct Settings {
  std::string host = "127.0.0.1";
  gint port = 1883;
  std::string topic = "landmark/{robot}/frame";
  std::string pose_topic = "landmark/{robot}/pose";
  std::string status_topic = "landmark/{robot}/status";
  std::string robot = "robot";
  std::string client_id;
  gboolean clean_session = FALSE;
  gint qos = 1;
  guint keep_alive = 30;
  std::string username, password;
  std::string tls_ca_file, tls_cert_file, tls_key_file;
  guint max_queue_messages = 10000;
  guint64 max_queue_bytes = 64 * 1024 * 1024;
  guint drain_timeout = 5000;
  guint reconnect_delay_max = 30;
};

/* The checked configuration, fixed from start() to stop(). */
struct Config {
  Settings s;
  landmark::MqttConnection connection;
  std::string topic, pose_topic;      /* placeholders replaced */
};

/* The streaming thread's. */
struct State {
  guint64 frame = 0;
  gint width = -1, height = -1;
  std::vector<GstVideoRegionOfInterestMeta *> rois;   /* reused */
};

}  // namespace

struct GstLandmarkPublishPrivate {
  landmark::SharedSettings<Settings> settings;
  /* config: written when the settings are checked (READY, start) */
  landmark::AppliedSettings<Settings, Config> applied;
  State state;
  landmark::MqttLink link;

  explicit GstLandmarkPublishPrivate (GstElement * owner):link (owner) {}
};

/* *INDENT-ON* */

LANDMARK_DEFINE_ELEMENT_WITH_PRIVATE (GstLandmarkPublish, gst_landmark_publish,
    Settings, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, landmarkpublish,
    "Landmark results to an MQTT broker");

/* ---- configuration -------------------------------------------------- */

/* Checks the settings into cfg: topics, names, credentials and TLS files. */
static bool
publish_parse (const Settings & s, Config * cfg, landmark::SettingsError * err)
{
  landmark::MqttConnection & c = cfg->connection;
  std::string why;
  if (s.host.empty ())
    return err->fail ("host", "no broker host name given");
  c.host = s.host;
  c.port = s.port;
  if (!landmark::mqtt_topic_level_ok (s.robot, &why))
    return err->fail ("robot", "\"" + s.robot + "\": " + why);
  if (s.client_id.empty () && !s.clean_session) {
    /* the same at every connection and run: the broker keeps the session
     * under it (one robot name per broker, as its topics already are) */
    c.client_id = "landmark-" + s.robot;
  } else if (s.client_id.empty ()) {
    /* unique per run: two pipelines of one robot must not take each
     * other's session */
    gchar *suffix = g_strdup_printf ("%08x", g_random_int ());
    c.client_id = "landmark-" + s.robot + "-" + suffix;
    g_free (suffix);
  } else {
    c.client_id = s.client_id;
  }
  if (!g_utf8_validate (c.client_id.c_str (), -1, nullptr) ||
      c.client_id.size () > 65535)
    return err->fail ("client-id", "\"" + c.client_id +
        "\" is not valid UTF-8 of at most 65535 bytes");
  const struct {
    const char *property;
    const std::string & tmpl;
    std::string *out;
    bool optional;
  } topics[] = {
    {"topic", s.topic, &cfg->topic, false},
    {"pose-topic", s.pose_topic, &cfg->pose_topic, true},
    {"status-topic", s.status_topic, &c.status_topic, true},
  };
  for (const auto & t : topics)
    if (!(t.optional && t.tmpl.empty ()) && !landmark::mqtt_topic_expand
        (t.tmpl, s.robot, c.client_id, t.out, &why))
      return err->fail (t.property, "\"" + t.tmpl + "\": " + why);
  if (s.keep_alive != 0 && s.keep_alive < 5)
    return err->fail ("keep-alive", std::to_string (s.keep_alive)
        + " s: use 0 (off) or 5 to 65535 s");
  if (!s.password.empty () && s.username.empty ())
    return err->fail ("username", "a 'password' is set without a user name");
  if (s.tls_cert_file.empty () != s.tls_key_file.empty ())
    return err->fail (s.tls_cert_file.empty ()? "tls-cert-file" :
        "tls-key-file", "a client certificate needs both 'tls-cert-file' "
        "and 'tls-key-file'");
  if (!s.tls_cert_file.empty () && s.tls_ca_file.empty ())
    return err->fail ("tls-ca-file", "a client certificate "
        "('tls-cert-file') is only used over TLS: set 'tls-ca-file' to the "
        "certificate authority that signed the broker's certificate");
  const std::pair < const char *, const std::string * >files[] = {
    {"tls-ca-file", &s.tls_ca_file},
    {"tls-cert-file", &s.tls_cert_file},
    {"tls-key-file", &s.tls_key_file},
  };
  for (const auto & f:files) {
    if (f.second->empty ())
      continue;
    FILE *fp = g_fopen (f.second->c_str (), "rb");
    if (!fp)
      return err->fail (f.first, "cannot read \"" + *f.second + "\": " +
          g_strerror (errno));
    fclose (fp);
  }
  c.keep_alive = (int) s.keep_alive;
  c.username = s.username;
  c.password = s.password;
  c.tls_ca_file = s.tls_ca_file;
  c.tls_cert_file = s.tls_cert_file;
  c.tls_key_file = s.tls_key_file;
  c.reconnect_delay_max = s.reconnect_delay_max;
  c.clean_session = s.clean_session;
  c.online_payload = landmark::publish_status_payload (s.robot, c.client_id,
      "online");
  c.offline_payload = landmark::publish_status_payload (s.robot,
      c.client_id, "offline");
  cfg->s = s;
  return true;
}

static const landmark::PropertyTable<Settings> &
publish_properties ()
{
  /* the connection's settings are read at start: changeable in READY */
  const guint ready = GST_PARAM_MUTABLE_READY;
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("host", "Broker host",
          "Host name or address of the MQTT broker", &Settings::host)
      .mutable_in (ready)
      .number ("port", "Broker port",
          "TCP port of the MQTT broker (1883 plain, usually 8883 for TLS)",
          &Settings::port, 1, 65535)
      .mutable_in (ready)
      .string ("topic", "Frame topic",
          "Topic of the per-frame messages; {robot} and {client-id} are "
          "replaced, no wildcards", &Settings::topic)
      .mutable_in (ready)
      .string_or_empty ("pose-topic", "Pose topic",
          "Topic of the latest pose, retained (empty: not sent)",
          &Settings::pose_topic)
      .mutable_in (ready)
      .string_or_empty ("status-topic", "Status topic",
          "Topic of the retained online/offline status and of the last will "
          "(empty: not sent)", &Settings::status_topic)
      .mutable_in (ready)
      .string ("robot", "Robot id",
          "Name of this robot or camera in messages and topics (no '/', '+' "
          "or '#')", &Settings::robot)
      .mutable_in (ready)
      .string ("client-id", "Client id",
          "MQTT client identifier (default: landmark-<robot>; with "
          "clean-session, landmark-<robot>-<random>)", &Settings::client_id)
      .mutable_in (ready)
      .boolean ("clean-session", "Clean session",
          "false: a session the broker keeps across reconnections, so QoS 2 "
          "messages cut by the link arrive exactly once; true: a new session "
          "at every connection", &Settings::clean_session)
      .mutable_in (ready)
      /* not `qos`: GstBaseTransform's own property */
      .number ("mqtt-qos", "MQTT quality of service",
          "MQTT QoS of the frame and pose messages: 0 at most once, 1 at "
          "least once, 2 exactly once", &Settings::qos, 0, 2)
      .mutable_in (ready)
      .number ("keep-alive", "Keep-alive",
          "Seconds between keep-alive pings (0: off, else at least 5)",
          &Settings::keep_alive, 0u, 65535u)
      .mutable_in (ready)
      .string ("username", "User name",
          "User name for the broker (none by default)", &Settings::username)
      .mutable_in (ready)
      .string ("password", "Password",
          "Password for the broker (write-only)", &Settings::password)
      .mutable_in (ready)
      .write_only ()
      .string ("tls-ca-file", "TLS CA file",
          "PEM file of the certificate authority that signed the broker's "
          "certificate; set: TLS with certificate and host name checks",
          &Settings::tls_ca_file)
      .mutable_in (ready)
      .string ("tls-cert-file", "TLS client certificate",
          "PEM client certificate, for brokers that require one",
          &Settings::tls_cert_file)
      .mutable_in (ready)
      .string ("tls-key-file", "TLS client key",
          "PEM private key of 'tls-cert-file' (not encrypted)",
          &Settings::tls_key_file)
      .mutable_in (ready)
      .number ("max-queue-messages", "Queue bound (messages)",
          "Messages kept while the broker is away; beyond, the oldest are "
          "dropped", &Settings::max_queue_messages, 1u, G_MAXUINT)
      .number ("max-queue-bytes", "Queue bound (bytes)",
          "Bytes of messages kept while the broker is away; beyond, the "
          "oldest are dropped", &Settings::max_queue_bytes, (guint64) 1,
          G_MAXUINT64)
      .number ("drain-timeout", "Drain timeout",
          "Milliseconds to wait at EOS for the queue to reach the broker",
          &Settings::drain_timeout, 0u, 600000u)
      .number ("reconnect-delay-max", "Longest reconnect delay",
          "Seconds: the wait between connection attempts starts at 1 s and "
          "doubles up to this", &Settings::reconnect_delay_max, 1u, 3600u)
      .mutable_in (ready);
  return table;
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_landmark_publish_init (GstLandmarkPublish * self)
{
  GstBaseTransform *trans = GST_BASE_TRANSFORM (self);
  self->priv = new GstLandmarkPublishPrivate (GST_ELEMENT (self));
  gst_base_transform_set_passthrough (trans, TRUE);
  gst_base_transform_set_prefer_passthrough (trans, TRUE);
  /* a publisher never drops late frames */
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

/* ---- start and stop ------------------------------------------------- */

static gboolean
gst_landmark_publish_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  priv->state = State ();
  const Config & c = priv->applied.config;
  if (!priv->link.start (c.connection))
    return FALSE;
  GST_INFO_OBJECT (self, "publishing to %s:%d on %s as %s",
      c.connection.host.c_str (), c.connection.port, c.topic.c_str (),
      c.connection.client_id.c_str ());
  return TRUE;
}

static gboolean
gst_landmark_publish_stop (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  if (!priv->link.running ())
    return TRUE;
  const Config & c = priv->applied.config;
  priv->link.stop (landmark::publish_status_payload (c.s.robot,
          c.connection.client_id, "offline"));
  GST_INFO_OBJECT (self, "stopped after %" G_GUINT64_FORMAT " frames",
      priv->state.frame);
  return TRUE;
}

static gboolean
gst_landmark_publish_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps *)
{
  State & st = GST_LANDMARK_PUBLISH (trans)->priv->state;
  /* any caps: the size is only reported (-1: unknown) */
  const GstStructure *s = gst_caps_get_size (incaps) > 0 ?
      gst_caps_get_structure (incaps, 0) : nullptr;
  if (!s || !gst_structure_get_int (s, "width", &st.width))
    st.width = -1;
  if (!s || !gst_structure_get_int (s, "height", &st.height))
    st.height = -1;
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static GstFlowReturn
gst_landmark_publish_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  const Config & c = priv->applied.config;
  State & st = priv->state;
  /* the queue bounds may change while playing */
  const Settings now = priv->settings.copy ();
  try {
    const std::string head = landmark::publish_frame_head (c.s.robot, buf,
        &trans->segment);
    landmark::MqttMessage frame { c.topic,
      landmark::publish_frame_payload (head, buf, st.frame, st.width,
          st.height, st.rois), c.s.qos, false };
    std::optional<landmark::MqttMessage> pose;
    const GstStructure *p;
    if (!c.pose_topic.empty () && (p = landmark_pose_meta_get (buf)))
      pose = landmark::MqttMessage { c.pose_topic,
        landmark::publish_pose_payload (head, st.frame, p), c.s.qos, true };
    st.frame++;
    priv->link.enqueue (std::move (frame), std::move (pose),
        now.max_queue_messages, now.max_queue_bytes);
  }
  catch (const std::exception & e) {
    /* out of memory building a message: the frame still goes on */
    GST_WARNING_OBJECT (self, "could not queue a message: %s", e.what ());
  }
  return GST_FLOW_OK;
}

static gboolean
gst_landmark_publish_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  auto priv = GST_LANDMARK_PUBLISH (trans)->priv;
  /* at EOS: a file run ends with its results at the broker */
  if (GST_EVENT_TYPE (event) == GST_EVENT_EOS && priv->link.running ())
    priv->link.drain (priv->settings.copy ().drain_timeout);
  return GST_BASE_TRANSFORM_CLASS (gst_landmark_publish_parent_class)->
      sink_event (trans, event);
}

static void
gst_landmark_publish_class_init (GstLandmarkPublishClass * klass)
{
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark_json::init ();
  landmark::MqttLink::init_library ();

  landmark::element_class_init<Settings,
      gst_landmark_publish_settings, publish_properties> (klass,
      gst_landmark_publish_finalize, "Landmark results publisher",
      "Filter/Analyzer/Video",
      "Sends the labels, detections and pose of every frame to an MQTT "
      "broker as JSON, passing the video through unchanged");

  trans_class->passthrough_on_same_caps = TRUE;
  trans_class->transform_ip_on_passthrough = TRUE;
  landmark::set_settings_lifecycle<GstLandmarkPublish,
      gst_landmark_publish_get_type,
      landmark::apply_parsed<GstLandmarkPublish, publish_parse>,
      gst_landmark_publish_start> (klass, gst_landmark_publish_stop);
  trans_class->set_caps = GST_DEBUG_FUNCPTR (gst_landmark_publish_set_caps);
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_publish_transform_ip);
  trans_class->sink_event =
      GST_DEBUG_FUNCPTR (gst_landmark_publish_sink_event);
}
