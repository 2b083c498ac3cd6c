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
 * the messages. After a reconnection the messages that were in flight are
 * sent again first (libmosquitto keeps them) and the queue follows, so the
 * order is kept. When the queue holds more than `max-queue-messages`
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
 * Why its own network thread rather than mosquitto_loop_start(): in
 * libmosquitto 2.0 a reconnect attempt inside mosquitto_loop_forever()
 * overwrites the "disconnecting" state set by mosquitto_disconnect(), so
 * mosquitto_loop_stop() can wait for ever while the broker is away; an
 * element must stop in bounded time.
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

#include <mosquitto.h>
#include <netdb.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "landmarkjson.h"
#include "landmarkmeta.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_publish_debug);
#define GST_CAT_DEFAULT gst_landmark_publish_debug

#define DEFAULT_HOST "127.0.0.1"
#define DEFAULT_PORT 1883
#define DEFAULT_TOPIC "landmark/{robot}/frame"
#define DEFAULT_POSE_TOPIC "landmark/{robot}/pose"
#define DEFAULT_STATUS_TOPIC "landmark/{robot}/status"
#define DEFAULT_ROBOT "robot"
#define DEFAULT_QOS 1
#define DEFAULT_KEEP_ALIVE 30
#define DEFAULT_MAX_QUEUE_MESSAGES 10000
#define DEFAULT_MAX_QUEUE_BYTES (64 * 1024 * 1024)
#define DEFAULT_DRAIN_TIMEOUT 5000
#define DEFAULT_RECONNECT_DELAY_MAX 30

/* Messages handed to libmosquitto and not yet acknowledged: its own
 * default send maximum, so it never holds back messages of its own. */
#define MAX_IN_FLIGHT 20
/* How long one mosquitto_loop() call may wait: bounds how long stop()
 * waits for the network thread when nothing wakes it sooner. */
#define LOOP_TIMEOUT_MS 200

enum
{
  PROP_0,
  PROP_HOST,
  PROP_PORT,
  PROP_TOPIC,
  PROP_POSE_TOPIC,
  PROP_STATUS_TOPIC,
  PROP_ROBOT,
  PROP_CLIENT_ID,
  PROP_QOS,
  PROP_KEEP_ALIVE,
  PROP_USERNAME,
  PROP_PASSWORD,
  PROP_TLS_CA_FILE,
  PROP_TLS_CERT_FILE,
  PROP_TLS_KEY_FILE,
  PROP_MAX_QUEUE_MESSAGES,
  PROP_MAX_QUEUE_BYTES,
  PROP_DRAIN_TIMEOUT,
  PROP_RECONNECT_DELAY_MAX,
};

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));

/* *INDENT-OFF* */
namespace {

/* What the user sets. The connection settings are read in start(); the
 * queue bounds and the drain timeout also while PLAYING. */
struct Settings {
  std::string host = DEFAULT_HOST;
  gint port = DEFAULT_PORT;
  std::string topic = DEFAULT_TOPIC;
  std::string pose_topic = DEFAULT_POSE_TOPIC;
  std::string status_topic = DEFAULT_STATUS_TOPIC;
  std::string robot = DEFAULT_ROBOT;
  std::string client_id;
  gint qos = DEFAULT_QOS;
  guint keep_alive = DEFAULT_KEEP_ALIVE;
  std::string username, password;
  std::string tls_ca_file, tls_cert_file, tls_key_file;
  guint max_queue_messages = DEFAULT_MAX_QUEUE_MESSAGES;
  guint64 max_queue_bytes = DEFAULT_MAX_QUEUE_BYTES;
  guint drain_timeout = DEFAULT_DRAIN_TIMEOUT;
  guint reconnect_delay_max = DEFAULT_RECONNECT_DELAY_MAX;
};

/* The validated connection configuration, fixed from start() to stop(). */
struct Config {
  std::string host;
  int port = DEFAULT_PORT;
  std::string topic, pose_topic, status_topic;   /* placeholders replaced */
  std::string robot, client_id;
  int qos = DEFAULT_QOS;
  int keep_alive = DEFAULT_KEEP_ALIVE;
  std::string username, password;
  std::string online_payload, offline_payload;
  guint reconnect_delay_max = DEFAULT_RECONNECT_DELAY_MAX;
};

struct Message {
  std::string topic;
  std::string payload;
  int qos;
  bool retain;
};

/* Shared by the streaming thread, the network thread and libmosquitto's
 * callbacks (which run on the network thread): guarded by lock. Lock
 * order: lock, then libmosquitto's own mutexes (mosquitto_publish). */
struct Link {
  std::deque<Message> queue;          /* in order, not yet handed over */
  size_t queue_bytes = 0;
  std::optional<Message> pose;        /* the latest pose, retained */
  std::unordered_map<int, int> in_flight;   /* mid -> qos */
  bool connected = false;             /* CONNACK accepted */
  bool resending = false;             /* old in-flight messages go first */
  bool stopping = false;
  guint64 frame = 0;
  guint64 dropped = 0;                /* since start */
  bool dropping = false;              /* a drop episode is on */
  guint64 handed = 0;                 /* messages given to libmosquitto */
  std::string last_problem;           /* the last warning posted */
  std::vector<GstVideoRegionOfInterestMeta *> rois;   /* reused */
  gint width = -1, height = -1;
};

}  // namespace

struct GstLandmarkPublishPrivate {
  std::mutex settings_lock;
  Settings settings;

  Config config;                      /* written in start() only */
  struct mosquitto *mosq = nullptr;
  std::thread network;

  std::mutex lock;
  std::condition_variable wake;       /* stopping, queue delivered */
  Link link;
};

struct _GstLandmarkPublish {
  GstBaseTransform parent;
  GstLandmarkPublishPrivate *priv;
};
/* *INDENT-ON* */

G_DEFINE_TYPE_WITH_CODE (GstLandmarkPublish, gst_landmark_publish,
    GST_TYPE_BASE_TRANSFORM,
    GST_DEBUG_CATEGORY_INIT (gst_landmark_publish_debug, "landmarkpublish", 0,
        "Landmark results to an MQTT broker"));
GST_ELEMENT_REGISTER_DEFINE (landmarkpublish, "landmarkpublish",
    GST_RANK_NONE, GST_TYPE_LANDMARK_PUBLISH);

/* ---- configuration -------------------------------------------------- */

namespace {

/* A topic level that may stand in a topic: no separators, no wildcards. */
bool
topic_level_ok (const std::string & s, std::string * why)
{
  if (s.empty ()) {
    *why = "it is empty";
    return false;
  }
  if (!g_utf8_validate (s.c_str (), s.size (), nullptr)) {
    *why = "it is not valid UTF-8";
    return false;
  }
  for (char c : s) {
    if (c == '/' || c == '+' || c == '#') {
      *why = std::string ("it contains '") + c + "' (topic separators and "
          "wildcards cannot be part of a name)";
      return false;
    }
  }
  return true;
}

/* The template with its placeholders replaced, or false with *why. */
bool
expand_topic (const std::string & tmpl, const Config & c, std::string * out,
    std::string * why)
{
  std::string o;
  for (size_t i = 0; i < tmpl.size ();) {
    const char ch = tmpl[i];
    if (ch == '{') {
      const size_t end = tmpl.find ('}', i);
      if (end == std::string::npos) {
        *why = "'{' at position " + std::to_string (i) + " is not closed";
        return false;
      }
      const std::string name = tmpl.substr (i + 1, end - i - 1);
      if (name == "robot")
        o += c.robot;
      else if (name == "client-id")
        o += c.client_id;
      else {
        *why = "unknown placeholder '{" + name + "}' (known: {robot}, "
            "{client-id})";
        return false;
      }
      i = end + 1;
      continue;
    }
    if (ch == '}') {
      *why = "'}' at position " + std::to_string (i) + " has no '{'";
      return false;
    }
    if (ch == '+' || ch == '#') {
      *why = std::string ("it contains the wildcard '") + ch + "', which "
          "only subscriptions may use";
      return false;
    }
    o += ch;
    i++;
  }
  if (o.empty ()) {
    *why = "it is empty";
    return false;
  }
  if (mosquitto_pub_topic_check2 (o.c_str (), o.size ()) != MOSQ_ERR_SUCCESS
      || mosquitto_validate_utf8 (o.c_str (), (int) o.size ()) !=
      MOSQ_ERR_SUCCESS) {
    *why = "\"" + o + "\" is not a valid MQTT topic";
    return false;
  }
  *out = o;
  return true;
}

bool
host_is_loopback (const std::string & host)
{
  return host == "localhost" || g_str_has_prefix (host.c_str (), "127.") ||
      host == "::1";
}

double
wall_seconds ()
{
  return g_get_real_time () / 1e6;
}

std::string
status_payload (const Config & c, const char *status)
{
  std::string o = "{\"robot\": ";
  landmark_json::put_string (o, c.robot.c_str ());
  o += ", \"client-id\": ";
  landmark_json::put_string (o, c.client_id.c_str ());
  o += ", \"status\": ";
  landmark_json::put_string (o, status);
  o += ", \"wall-time\": ";
  landmark_json::put_double (o, wall_seconds ());
  o += '}';
  return o;
}

/* The sentence a user needs for a libmosquitto result code. */
std::string
problem_text (const Config & c, int rc, int err)
{
  const std::string where = c.host + ":" + std::to_string (c.port);
  switch (rc) {
    case MOSQ_ERR_EAI:
      return "cannot resolve 'host' \"" + c.host + "\": " +
          gai_strerror (err ? err : EAI_NONAME);
    case MOSQ_ERR_ERRNO:
      return "cannot reach the broker at " + where + " ('host', 'port'): " +
          g_strerror (err);
    case MOSQ_ERR_TLS:
    case MOSQ_ERR_TLS_HANDSHAKE:
      return "TLS with the broker at " + where + " failed: check "
          "'tls-ca-file' (it must have signed the broker's certificate, "
          "whose name must match 'host'), 'tls-cert-file' and "
          "'tls-key-file'";
    case MOSQ_ERR_CONN_LOST:
      return "lost the connection to the broker at " + where;
    default:
      return std::string ("broker at ") + where + ": " +
          mosquitto_strerror (rc);
  }
}

/* The CONNACK refusals of MQTT 3.1.1, by the setting to check. */
std::string
refusal_text (const Config & c, int code)
{
  const std::string where = c.host + ":" + std::to_string (c.port);
  switch (code) {
    case 1:
      return "the broker at " + where + " refused the protocol version";
    case 2:
      return "the broker at " + where + " refused 'client-id' \"" +
          c.client_id + "\"";
    case 3:
      return "the broker at " + where + " is unavailable";
    case 4:
      return "the broker at " + where + " refused 'username' \"" +
          c.username + "\" with the given 'password' (bad user name or "
          "password)";
    case 5:
      return "the broker at " + where + " refused the connection: not "
          "authorised (check 'username' and 'password')";
    default:
      return "the broker at " + where + " refused the connection: " +
          mosquitto_connack_string (code);
  }
}

}  // namespace

/* ---- messages to the application ------------------------------------ */

static void
post_connection (GstLandmarkPublish * self, bool connected,
    const std::string & reason, guint64 queued, guint64 dropped)
{
  const Config & c = self->priv->config;
  GstStructure *s = gst_structure_new ("landmark-publish-connection",
      "connected", G_TYPE_BOOLEAN, connected,
      "host", G_TYPE_STRING, c.host.c_str (),
      "port", G_TYPE_INT, c.port,
      "queued", G_TYPE_UINT64, queued,
      "dropped", G_TYPE_UINT64, dropped, nullptr);
  if (!connected)
    gst_structure_set (s, "reason", G_TYPE_STRING, reason.c_str (), nullptr);
  gst_element_post_message (GST_ELEMENT (self),
      gst_message_new_element (GST_OBJECT (self), s));
}

static void
post_dropped (GstLandmarkPublish * self, guint64 dropped, guint64 queued,
    guint max_messages, guint64 max_bytes, bool over)
{
  GstStructure *s = gst_structure_new ("landmark-publish-dropped",
      "dropped", G_TYPE_UINT64, dropped,
      "queued", G_TYPE_UINT64, queued,
      "max-queue-messages", G_TYPE_UINT, max_messages,
      "max-queue-bytes", G_TYPE_UINT64, max_bytes,
      "episode-over", G_TYPE_BOOLEAN, over, nullptr);
  gst_element_post_message (GST_ELEMENT (self),
      gst_message_new_element (GST_OBJECT (self), s));
}

/* A network problem: a warning when it differs from the last one, so a
 * broker that stays away is reported once, not at every retry. Called
 * without the lock. */
static void
report_problem (GstLandmarkPublish * self, const std::string & text)
{
  auto priv = self->priv;
  guint64 queued, dropped;
  {
    std::lock_guard<std::mutex> lk (priv->lock);
    if (priv->link.last_problem == text || priv->link.stopping)
      return;
    priv->link.last_problem = text;
    queued = priv->link.queue.size ();
    dropped = priv->link.dropped;
  }
  GST_ELEMENT_WARNING (self, RESOURCE, OPEN_WRITE,
      ("MQTT: %s; video keeps flowing, results are queued and the element "
          "keeps trying.", text.c_str ()), ("%" G_GUINT64_FORMAT
          " messages queued", queued));
  post_connection (self, false, text, queued, dropped);
}

/* ---- handing messages to libmosquitto ------------------------------- */

/* Hands queued messages over in order while connected and the window
 * allows. Called with priv->lock held, from any thread. Returns true when
 * a drop episode ended (the caller posts that without the lock). */
static bool
pump_locked (GstLandmarkPublish * self)
{
  auto priv = self->priv;
  Link & l = priv->link;
  while (l.connected && !l.resending && l.in_flight.size () < MAX_IN_FLIGHT) {
    Message *m = nullptr;
    bool from_queue = true;
    if (!l.queue.empty ())
      m = &l.queue.front ();
    else if (l.pose) {
      m = &*l.pose;
      from_queue = false;
    } else
      break;
    int mid = 0;
    const int rc = mosquitto_publish (priv->mosq, &mid, m->topic.c_str (),
        (int) m->payload.size (), m->payload.data (), m->qos, m->retain);
    /* With QoS 1 or 2 libmosquitto keeps the message once it has given it
     * a message id, even when the socket just went (MOSQ_ERR_NO_CONN), and
     * sends it again on reconnection. */
    const bool kept = rc == MOSQ_ERR_SUCCESS ||
        (rc == MOSQ_ERR_NO_CONN && m->qos > 0 && mid != 0);
    if (!kept && rc == MOSQ_ERR_NO_CONN) {
      l.connected = false;
      break;
    }
    if (kept) {
      l.in_flight[mid] = m->qos;
      l.handed++;
    } else {
      /* too large for the broker, or similar: this message cannot go */
      GST_WARNING_OBJECT (self, "dropping a message to %s: %s",
          m->topic.c_str (), mosquitto_strerror (rc));
      l.dropped++;
    }
    if (from_queue) {
      l.queue_bytes -= m->payload.size ();
      l.queue.pop_front ();
    } else
      l.pose.reset ();
    if (rc == MOSQ_ERR_NO_CONN) {
      l.connected = false;
      break;
    }
  }
  bool episode_over = false;
  if (l.queue.empty ()) {
    episode_over = l.dropping;
    l.dropping = false;
    if (l.in_flight.empty ())
      priv->wake.notify_all ();
  }
  return episode_over;
}

static void
pump (GstLandmarkPublish * self)
{
  auto priv = self->priv;
  bool over;
  guint64 dropped;
  guint max_messages;
  guint64 max_bytes;
  {
    std::lock_guard<std::mutex> lk (priv->lock);
    over = pump_locked (self);
    dropped = priv->link.dropped;
  }
  if (over) {
    {
      std::lock_guard<std::mutex> lk (priv->settings_lock);
      max_messages = priv->settings.max_queue_messages;
      max_bytes = priv->settings.max_queue_bytes;
    }
    post_dropped (self, dropped, 0, max_messages, max_bytes, true);
  }
}

/* libmosquitto callbacks: on the network thread, inside mosquitto_loop. */

static void
on_connect (struct mosquitto *, void *obj, int code)
{
  auto self = GST_LANDMARK_PUBLISH (obj);
  auto priv = self->priv;
  const Config & c = priv->config;
  if (code != 0) {
    report_problem (self, refusal_text (c, code));
    return;
  }
  guint64 queued, dropped;
  {
    std::lock_guard<std::mutex> lk (priv->lock);
    Link & l = priv->link;
    l.connected = true;
    l.last_problem.clear ();
    /* QoS 0 messages that were in flight went with the socket; the others
     * libmosquitto sends again right after this callback, and they must
     * be acknowledged before anything newer goes */
    for (auto it = l.in_flight.begin (); it != l.in_flight.end ();)
      it = it->second == 0 ? l.in_flight.erase (it) : std::next (it);
    l.resending = !l.in_flight.empty ();
    queued = l.queue.size ();
    dropped = l.dropped;
    if (!c.status_topic.empty ()) {
      int mid = 0;
      if (mosquitto_publish (priv->mosq, &mid, c.status_topic.c_str (),
              (int) c.online_payload.size (), c.online_payload.data (), 1,
              true) == MOSQ_ERR_SUCCESS && !l.resending)
        l.in_flight[mid] = 1;
    }
  }
  GST_INFO_OBJECT (self, "connected to %s:%d as %s", c.host.c_str (), c.port,
      c.client_id.c_str ());
  post_connection (self, true, "", queued, dropped);
  pump (self);
}

static void
on_publish (struct mosquitto *, void *obj, int mid)
{
  auto self = GST_LANDMARK_PUBLISH (obj);
  auto priv = self->priv;
  {
    std::lock_guard<std::mutex> lk (priv->lock);
    Link & l = priv->link;
    l.in_flight.erase (mid);
    if (l.resending && l.in_flight.empty ())
      l.resending = false;
  }
  pump (self);
}

/* ---- the network thread --------------------------------------------- */

static void
network_main (GstLandmarkPublish * self)
{
  auto priv = self->priv;
  const Config & c = priv->config;
  bool first = true;
  guint delay = 1;

  for (;;) {
    {
      std::lock_guard<std::mutex> lk (priv->lock);
      if (priv->link.stopping)
        break;
    }
    errno = 0;
    int rc = first ? mosquitto_connect_async (priv->mosq, c.host.c_str (),
        c.port, c.keep_alive) : mosquitto_reconnect_async (priv->mosq);
    int err = errno;
    first = false;
    bool was_connected = false;
    if (rc == MOSQ_ERR_SUCCESS) {
      /* until the connection ends: CONNACK, acknowledgements, keep-alive */
      gint64 stop_deadline = 0;
      do {
        errno = 0;
        rc = mosquitto_loop (priv->mosq, LOOP_TIMEOUT_MS, 1);
        err = errno;
        std::lock_guard<std::mutex> lk (priv->lock);
        if (priv->link.connected) {
          was_connected = true;
          delay = 1;
        }
        if (priv->link.stopping && rc == MOSQ_ERR_SUCCESS) {
          /* stop() disconnected; a connection this thread was opening at
           * that moment is closed here, and stopping never waits more
           * than a second for the DISCONNECT to go out */
          const gint64 now = g_get_monotonic_time ();
          if (stop_deadline == 0) {
            stop_deadline = now + G_USEC_PER_SEC;
            if (mosquitto_socket (priv->mosq) >= 0)
              mosquitto_disconnect (priv->mosq);
          }
          if (mosquitto_socket (priv->mosq) < 0 || now > stop_deadline)
            rc = MOSQ_ERR_NO_CONN;
        }
      } while (rc == MOSQ_ERR_SUCCESS);
    }
    {
      std::lock_guard<std::mutex> lk (priv->lock);
      priv->link.connected = false;
      if (priv->link.stopping)
        break;
    }
    if (rc != MOSQ_ERR_CONN_REFUSED)    /* already said in on_connect */
      report_problem (self, was_connected && rc == MOSQ_ERR_NO_CONN ?
          problem_text (c, MOSQ_ERR_CONN_LOST, 0) :
          problem_text (c, rc, err));
    GST_DEBUG_OBJECT (self, "next attempt in %u s", delay);
    std::unique_lock<std::mutex> lk (priv->lock);
    priv->wake.wait_for (lk, std::chrono::seconds (delay),[priv] {
          return priv->link.stopping;}
    );
    delay = std::min (delay * 2, std::max (c.reconnect_delay_max, 1u));
  }
  GST_DEBUG_OBJECT (self, "network thread done");
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_landmark_publish_init (GstLandmarkPublish * self)
{
  GstBaseTransform *trans = GST_BASE_TRANSFORM (self);
  self->priv = new GstLandmarkPublishPrivate ();
  gst_base_transform_set_passthrough (trans, TRUE);
  gst_base_transform_set_prefer_passthrough (trans, TRUE);
  /* a publisher never drops late frames */
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

static gboolean gst_landmark_publish_stop (GstBaseTransform * trans);

static void
gst_landmark_publish_finalize (GObject * object)
{
  auto self = GST_LANDMARK_PUBLISH (object);
  /* stop() has run unless start() never did; this is a safety net */
  gst_landmark_publish_stop (GST_BASE_TRANSFORM (self));
  delete self->priv;
  G_OBJECT_CLASS (gst_landmark_publish_parent_class)->finalize (object);
}

static void
set_string (std::string & to, const GValue * value)
{
  const gchar *s = g_value_get_string (value);
  to = s ? s : "";
}

static void
gst_landmark_publish_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  auto self = GST_LANDMARK_PUBLISH (object);
  std::lock_guard<std::mutex> lk (self->priv->settings_lock);
  Settings & s = self->priv->settings;
  switch (prop_id) {
    case PROP_HOST:
      set_string (s.host, value);
      break;
    case PROP_PORT:
      s.port = g_value_get_int (value);
      break;
    case PROP_TOPIC:
      set_string (s.topic, value);
      break;
    case PROP_POSE_TOPIC:
      set_string (s.pose_topic, value);
      break;
    case PROP_STATUS_TOPIC:
      set_string (s.status_topic, value);
      break;
    case PROP_ROBOT:
      set_string (s.robot, value);
      break;
    case PROP_CLIENT_ID:
      set_string (s.client_id, value);
      break;
    case PROP_QOS:
      s.qos = g_value_get_int (value);
      break;
    case PROP_KEEP_ALIVE:
      s.keep_alive = g_value_get_uint (value);
      break;
    case PROP_USERNAME:
      set_string (s.username, value);
      break;
    case PROP_PASSWORD:
      set_string (s.password, value);
      break;
    case PROP_TLS_CA_FILE:
      set_string (s.tls_ca_file, value);
      break;
    case PROP_TLS_CERT_FILE:
      set_string (s.tls_cert_file, value);
      break;
    case PROP_TLS_KEY_FILE:
      set_string (s.tls_key_file, value);
      break;
    case PROP_MAX_QUEUE_MESSAGES:
      s.max_queue_messages = g_value_get_uint (value);
      break;
    case PROP_MAX_QUEUE_BYTES:
      s.max_queue_bytes = g_value_get_uint64 (value);
      break;
    case PROP_DRAIN_TIMEOUT:
      s.drain_timeout = g_value_get_uint (value);
      break;
    case PROP_RECONNECT_DELAY_MAX:
      s.reconnect_delay_max = g_value_get_uint (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

static void
get_string (GValue * value, const std::string & s)
{
  g_value_set_string (value, s.empty ()? nullptr : s.c_str ());
}

static void
gst_landmark_publish_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  auto self = GST_LANDMARK_PUBLISH (object);
  std::lock_guard<std::mutex> lk (self->priv->settings_lock);
  const Settings & s = self->priv->settings;
  switch (prop_id) {
    case PROP_HOST:
      get_string (value, s.host);
      break;
    case PROP_PORT:
      g_value_set_int (value, s.port);
      break;
    case PROP_TOPIC:
      get_string (value, s.topic);
      break;
    case PROP_POSE_TOPIC:
      /* "" (off) reads back as "", not as NULL */
      g_value_set_string (value, s.pose_topic.c_str ());
      break;
    case PROP_STATUS_TOPIC:
      g_value_set_string (value, s.status_topic.c_str ());
      break;
    case PROP_ROBOT:
      get_string (value, s.robot);
      break;
    case PROP_CLIENT_ID:
      get_string (value, s.client_id);
      break;
    case PROP_QOS:
      g_value_set_int (value, s.qos);
      break;
    case PROP_KEEP_ALIVE:
      g_value_set_uint (value, s.keep_alive);
      break;
    case PROP_USERNAME:
      get_string (value, s.username);
      break;
    case PROP_TLS_CA_FILE:
      get_string (value, s.tls_ca_file);
      break;
    case PROP_TLS_CERT_FILE:
      get_string (value, s.tls_cert_file);
      break;
    case PROP_TLS_KEY_FILE:
      get_string (value, s.tls_key_file);
      break;
    case PROP_MAX_QUEUE_MESSAGES:
      g_value_set_uint (value, s.max_queue_messages);
      break;
    case PROP_MAX_QUEUE_BYTES:
      g_value_set_uint64 (value, s.max_queue_bytes);
      break;
    case PROP_DRAIN_TIMEOUT:
      g_value_set_uint (value, s.drain_timeout);
      break;
    case PROP_RECONNECT_DELAY_MAX:
      g_value_set_uint (value, s.reconnect_delay_max);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

/* ---- start and stop ------------------------------------------------- */

static gboolean
settings_error (GstLandmarkPublish * self, const char *property,
    const std::string & text)
{
  GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
      ("Invalid '%s': %s.", property, text.c_str ()), (nullptr));
  return FALSE;
}

/* Validates the settings into priv->config; posts the error. */
static gboolean
make_config (GstLandmarkPublish * self, const Settings & s)
{
  Config c;
  std::string why;
  if (s.host.empty ())
    return settings_error (self, "host", "no broker host name given");
  c.host = s.host;
  c.port = s.port;
  if (!topic_level_ok (s.robot, &why))
    return settings_error (self, "robot", "\"" + s.robot + "\": " + why);
  c.robot = s.robot;
  if (s.client_id.empty ()) {
    /* unique per run: two pipelines of one robot must not take each
     * other's session */
    gchar *suffix = g_strdup_printf ("%08x", g_random_int ());
    c.client_id = "landmark-" + c.robot + "-" + suffix;
    g_free (suffix);
  } else {
    c.client_id = s.client_id;
  }
  if (!g_utf8_validate (c.client_id.c_str (), -1, nullptr) ||
      c.client_id.size () > 65535)
    return settings_error (self, "client-id", "\"" + c.client_id +
        "\" is not valid UTF-8 of at most 65535 bytes");
  if (!expand_topic (s.topic, c, &c.topic, &why))
    return settings_error (self, "topic", "\"" + s.topic + "\": " + why);
  if (!s.pose_topic.empty () &&
      !expand_topic (s.pose_topic, c, &c.pose_topic, &why))
    return settings_error (self, "pose-topic", "\"" + s.pose_topic + "\": "
        + why);
  if (!s.status_topic.empty () &&
      !expand_topic (s.status_topic, c, &c.status_topic, &why))
    return settings_error (self, "status-topic", "\"" + s.status_topic +
        "\": " + why);
  if (s.keep_alive != 0 && s.keep_alive < 5)
    return settings_error (self, "keep-alive", std::to_string (s.keep_alive)
        + " s: use 0 (off) or 5 to 65535 s");
  if (!s.password.empty () && s.username.empty ())
    return settings_error (self, "username", "a 'password' is set without "
        "a user name");
  if (s.tls_cert_file.empty () != s.tls_key_file.empty ())
    return settings_error (self, s.tls_cert_file.empty ()? "tls-cert-file" :
        "tls-key-file", "a client certificate needs both 'tls-cert-file' "
        "and 'tls-key-file'");
  if (!s.tls_cert_file.empty () && s.tls_ca_file.empty ())
    return settings_error (self, "tls-ca-file", "a client certificate "
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
      return settings_error (self, f.first, "cannot read \"" + *f.second +
          "\": " + g_strerror (errno));
    fclose (fp);
  }
  c.qos = s.qos;
  c.keep_alive = (int) s.keep_alive;
  c.username = s.username;
  c.password = s.password;
  c.reconnect_delay_max = s.reconnect_delay_max;
  c.online_payload = status_payload (c, "online");
  c.offline_payload = status_payload (c, "offline");
  self->priv->config = c;
  return TRUE;
}

static gboolean
gst_landmark_publish_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  Settings s;
  {
    std::lock_guard<std::mutex> lk (priv->settings_lock);
    s = priv->settings;
  }
  if (!make_config (self, s))
    return FALSE;
  const Config & c = priv->config;

  struct mosquitto *mosq = mosquitto_new (c.client_id.c_str (), true, self);
  if (!mosq) {
    GST_ELEMENT_ERROR (self, RESOURCE, FAILED,
        ("Could not create the MQTT client: %s.", g_strerror (errno)),
        (nullptr));
    return FALSE;
  }
  int rc = mosquitto_threaded_set (mosq, true);
  if (rc == MOSQ_ERR_SUCCESS)
    rc = mosquitto_int_option (mosq, MOSQ_OPT_SEND_MAXIMUM, MAX_IN_FLIGHT);
  const char *what = "client options";
  if (rc == MOSQ_ERR_SUCCESS && !c.username.empty ()) {
    what = "username";
    rc = mosquitto_username_pw_set (mosq, c.username.c_str (),
        c.password.empty ()? nullptr : c.password.c_str ());
  }
  if (rc == MOSQ_ERR_SUCCESS && !c.status_topic.empty ()) {
    what = "status-topic";
    rc = mosquitto_will_set (mosq, c.status_topic.c_str (),
        (int) c.offline_payload.size (), c.offline_payload.data (), 1, true);
  }
  if (rc == MOSQ_ERR_SUCCESS && !s.tls_ca_file.empty ()) {
    what = "tls-ca-file";
    rc = mosquitto_tls_set (mosq, s.tls_ca_file.c_str (), nullptr,
        s.tls_cert_file.empty ()? nullptr : s.tls_cert_file.c_str (),
        s.tls_key_file.empty ()? nullptr : s.tls_key_file.c_str (),
        nullptr);
  }
  if (rc != MOSQ_ERR_SUCCESS) {
    mosquitto_destroy (mosq);
    return settings_error (self, what, mosquitto_strerror (rc));
  }
  mosquitto_connect_callback_set (mosq, on_connect);
  mosquitto_publish_callback_set (mosq, on_publish);

  if (!host_is_loopback (c.host) && s.tls_ca_file.empty ())
    GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
        ("MQTT: results%s go to '%s' unencrypted; set 'tls-ca-file' to use "
            "TLS.", c.username.empty ()? "" : " and the password",
            c.host.c_str ()), (nullptr));

  {
    std::lock_guard<std::mutex> lk (priv->lock);
    priv->link = Link ();
    priv->mosq = mosq;
  }
  try {
    priv->network = std::thread (network_main, self);
  }
  catch (const std::exception & e) {
    priv->mosq = nullptr;
    mosquitto_destroy (mosq);
    GST_ELEMENT_ERROR (self, RESOURCE, FAILED,
        ("Could not start the MQTT thread."), ("%s", e.what ()));
    return FALSE;
  }
  GST_INFO_OBJECT (self, "publishing to %s:%d on %s as %s", c.host.c_str (),
      c.port, c.topic.c_str (), c.client_id.c_str ());
  return TRUE;
}

static gboolean
gst_landmark_publish_stop (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  if (!priv->mosq)
    return TRUE;
  guint64 lost = 0;
  {
    std::lock_guard<std::mutex> lk (priv->lock);
    Link & l = priv->link;
    l.stopping = true;
    lost = l.queue.size () + l.in_flight.size ();
    if (l.connected && !priv->config.status_topic.empty ()) {
      /* an orderly goodbye: the broker sends no will after DISCONNECT */
      const std::string p = status_payload (priv->config, "offline");
      mosquitto_publish (priv->mosq, nullptr,
          priv->config.status_topic.c_str (), (int) p.size (), p.data (), 0,
          true);
    }
    /* wakes mosquitto_loop (through libmosquitto's internal socket pair)
     * when connected, and the back-off wait otherwise */
    mosquitto_disconnect (priv->mosq);
    priv->wake.notify_all ();
  }
  if (priv->network.joinable ())
    priv->network.join ();
  mosquitto_destroy (priv->mosq);
  priv->mosq = nullptr;
  if (lost > 0)
    GST_ELEMENT_WARNING (self, RESOURCE, WRITE,
        ("MQTT: %" G_GUINT64_FORMAT " results were not delivered to %s:%d "
            "before the element stopped.", lost, priv->config.host.c_str (),
            priv->config.port), (nullptr));
  std::lock_guard<std::mutex> lk (priv->lock);
  GST_INFO_OBJECT (self, "stopped: %" G_GUINT64_FORMAT " frames, %"
      G_GUINT64_FORMAT " messages handed over, %" G_GUINT64_FORMAT
      " dropped", priv->link.frame, priv->link.handed, priv->link.dropped);
  priv->link = Link ();
  return TRUE;
}

static gboolean
gst_landmark_publish_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps *)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  gint w = -1, h = -1;
  if (gst_caps_get_size (incaps) > 0) {
    const GstStructure *s = gst_caps_get_structure (incaps, 0);
    if (!gst_structure_get_int (s, "width", &w))
      w = -1;
    if (!gst_structure_get_int (s, "height", &h))
      h = -1;
  }
  std::lock_guard<std::mutex> lk (self->priv->lock);
  self->priv->link.width = w;
  self->priv->link.height = h;
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static GstFlowReturn
gst_landmark_publish_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  auto priv = self->priv;
  const Config & c = priv->config;
  guint max_messages;
  guint64 max_bytes;
  {
    std::lock_guard<std::mutex> lk (priv->settings_lock);
    max_messages = priv->settings.max_queue_messages;
    max_bytes = priv->settings.max_queue_bytes;
  }

  /* the message is built outside the lock: the network thread only waits
   * for the queue operations */
  std::string head = "{\"robot\": ";
  landmark_json::put_string (head, c.robot.c_str ());
  if (GST_BUFFER_PTS_IS_VALID (buf) && trans->segment.format ==
      GST_FORMAT_TIME) {
    const guint64 rt = gst_segment_to_running_time (&trans->segment,
        GST_FORMAT_TIME, GST_BUFFER_PTS (buf));
    if (GST_CLOCK_TIME_IS_VALID (rt)) {
      head += ", \"running-time\": ";
      landmark_json::put_uint (head, rt);
    }
  }
  head += ", \"wall-time\": ";
  landmark_json::put_double (head, wall_seconds ());
  head += ", ";

  bool started_dropping = false;
  guint64 dropped = 0, queued = 0;
  try {
    std::lock_guard<std::mutex> lk (priv->lock);
    Link & l = priv->link;
    Message m { c.topic, head, c.qos, false };
    landmark_json::put_frame_fields (m.payload, buf, l.frame, l.width,
        l.height, l.rois);
    m.payload += '}';
    l.frame++;
    if (!c.pose_topic.empty ())
      if (const GstStructure * pose = landmark_pose_meta_get (buf)) {
        /* the head (robot and times), the frame index, the pose */
        std::string p = head;
        p += "\"frame\": ";
        landmark_json::put_uint (p, l.frame - 1);
        p += ", \"pose\": ";
        landmark_json::put_structure (p, pose);
        p += '}';
        l.pose = Message { c.pose_topic, std::move (p), c.qos, true };
      }
    l.queue_bytes += m.payload.size ();
    l.queue.push_back (std::move (m));
    pump_locked (self);
    /* the bound: drop the oldest, never the frame */
    while (!l.queue.empty () && (l.queue.size () > max_messages ||
            l.queue_bytes > max_bytes)) {
      l.queue_bytes -= l.queue.front ().payload.size ();
      l.queue.pop_front ();
      l.dropped++;
      if (!l.dropping) {
        l.dropping = true;
        started_dropping = true;
      }
    }
    dropped = l.dropped;
    queued = l.queue.size ();
  }
  catch (const std::exception & e) {
    /* out of memory building a message: the frame still goes on */
    GST_WARNING_OBJECT (self, "could not queue a message: %s", e.what ());
    return GST_FLOW_OK;
  }
  if (started_dropping) {
    GST_ELEMENT_WARNING (self, RESOURCE, WRITE,
        ("MQTT: the queue is full (%" G_GUINT64_FORMAT " messages, at most "
            "'max-queue-messages' %u and 'max-queue-bytes' %" G_GUINT64_FORMAT
            "): dropping the oldest results until the broker takes them "
            "again.", queued, max_messages, max_bytes),
        ("%" G_GUINT64_FORMAT " dropped since start", dropped));
    post_dropped (self, dropped, queued, max_messages, max_bytes, false);
  }
  return GST_FLOW_OK;
}

/* At EOS: waits up to drain-timeout for the queue to be delivered, so a
 * file run ends with its results at the broker. */
static void
drain (GstLandmarkPublish * self)
{
  auto priv = self->priv;
  guint timeout_ms;
  {
    std::lock_guard<std::mutex> lk (priv->settings_lock);
    timeout_ms = priv->settings.drain_timeout;
  }
  std::unique_lock<std::mutex> lk (priv->lock);
  Link & l = priv->link;
  auto done = [&l] {
    return l.stopping || (l.queue.empty () && !l.pose && l.in_flight.empty ());
  };
  if (!priv->wake.wait_for (lk, std::chrono::milliseconds (timeout_ms), done))
    GST_WARNING_OBJECT (self, "EOS: %zu messages still queued, %zu in flight "
        "after %u ms", l.queue.size (), l.in_flight.size (), timeout_ms);
}

static gboolean
gst_landmark_publish_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  auto self = GST_LANDMARK_PUBLISH (trans);
  if (GST_EVENT_TYPE (event) == GST_EVENT_EOS && self->priv->mosq)
    drain (self);
  return GST_BASE_TRANSFORM_CLASS (gst_landmark_publish_parent_class)->
      sink_event (trans, event);
}

static void
gst_landmark_publish_class_init (GstLandmarkPublishClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark_json::init ();
  /* once per process; plugins are never unloaded, so no cleanup */
  mosquitto_lib_init ();

  gobject_class->set_property = gst_landmark_publish_set_property;
  gobject_class->get_property = gst_landmark_publish_get_property;
  gobject_class->finalize = gst_landmark_publish_finalize;

  const auto ready = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  const auto playing = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);

  g_object_class_install_property (gobject_class, PROP_HOST,
      g_param_spec_string ("host", "Broker host",
          "Host name or address of the MQTT broker", DEFAULT_HOST, ready));
  g_object_class_install_property (gobject_class, PROP_PORT,
      g_param_spec_int ("port", "Broker port",
          "TCP port of the MQTT broker (1883 plain, usually 8883 for TLS)",
          1, 65535, DEFAULT_PORT, ready));
  g_object_class_install_property (gobject_class, PROP_TOPIC,
      g_param_spec_string ("topic", "Frame topic",
          "Topic of the per-frame messages; {robot} and {client-id} are "
          "replaced, no wildcards", DEFAULT_TOPIC, ready));
  g_object_class_install_property (gobject_class, PROP_POSE_TOPIC,
      g_param_spec_string ("pose-topic", "Pose topic",
          "Topic of the latest pose, retained (empty: not sent)",
          DEFAULT_POSE_TOPIC, ready));
  g_object_class_install_property (gobject_class, PROP_STATUS_TOPIC,
      g_param_spec_string ("status-topic", "Status topic",
          "Topic of the retained online/offline status and of the last will "
          "(empty: not sent)", DEFAULT_STATUS_TOPIC, ready));
  g_object_class_install_property (gobject_class, PROP_ROBOT,
      g_param_spec_string ("robot", "Robot id",
          "Name of this robot or camera in messages and topics (no '/', '+' "
          "or '#')", DEFAULT_ROBOT, ready));
  g_object_class_install_property (gobject_class, PROP_CLIENT_ID,
      g_param_spec_string ("client-id", "Client id",
          "MQTT client identifier (default: landmark-<robot>-<random>)",
          nullptr, ready));
  g_object_class_install_property (gobject_class, PROP_QOS,
      g_param_spec_int ("mqtt-qos", "MQTT quality of service",
          "MQTT QoS of the frame and pose messages: 0 at most once, 1 at "
          "least once, 2 exactly once", 0, 2, DEFAULT_QOS, ready));
  g_object_class_install_property (gobject_class, PROP_KEEP_ALIVE,
      g_param_spec_uint ("keep-alive", "Keep-alive",
          "Seconds between keep-alive pings (0: off, else at least 5)",
          0, 65535, DEFAULT_KEEP_ALIVE, ready));
  g_object_class_install_property (gobject_class, PROP_USERNAME,
      g_param_spec_string ("username", "User name",
          "User name for the broker (none by default)", nullptr, ready));
  g_object_class_install_property (gobject_class, PROP_PASSWORD,
      g_param_spec_string ("password", "Password",
          "Password for the broker (write-only)", nullptr,
          (GParamFlags) (G_PARAM_WRITABLE | G_PARAM_STATIC_STRINGS |
              GST_PARAM_MUTABLE_READY)));
  g_object_class_install_property (gobject_class, PROP_TLS_CA_FILE,
      g_param_spec_string ("tls-ca-file", "TLS CA file",
          "PEM file of the certificate authority that signed the broker's "
          "certificate; set: TLS with certificate and host name checks",
          nullptr, ready));
  g_object_class_install_property (gobject_class, PROP_TLS_CERT_FILE,
      g_param_spec_string ("tls-cert-file", "TLS client certificate",
          "PEM client certificate, for brokers that require one",
          nullptr, ready));
  g_object_class_install_property (gobject_class, PROP_TLS_KEY_FILE,
      g_param_spec_string ("tls-key-file", "TLS client key",
          "PEM private key of 'tls-cert-file' (not encrypted)",
          nullptr, ready));
  g_object_class_install_property (gobject_class, PROP_MAX_QUEUE_MESSAGES,
      g_param_spec_uint ("max-queue-messages", "Queue bound (messages)",
          "Messages kept while the broker is away; beyond, the oldest are "
          "dropped", 1, G_MAXUINT, DEFAULT_MAX_QUEUE_MESSAGES, playing));
  g_object_class_install_property (gobject_class, PROP_MAX_QUEUE_BYTES,
      g_param_spec_uint64 ("max-queue-bytes", "Queue bound (bytes)",
          "Bytes of messages kept while the broker is away; beyond, the "
          "oldest are dropped", 1, G_MAXUINT64, DEFAULT_MAX_QUEUE_BYTES,
          playing));
  g_object_class_install_property (gobject_class, PROP_DRAIN_TIMEOUT,
      g_param_spec_uint ("drain-timeout", "Drain timeout",
          "Milliseconds to wait at EOS for the queue to reach the broker",
          0, 600000, DEFAULT_DRAIN_TIMEOUT, playing));
  g_object_class_install_property (gobject_class, PROP_RECONNECT_DELAY_MAX,
      g_param_spec_uint ("reconnect-delay-max", "Longest reconnect delay",
          "Seconds: the wait between connection attempts starts at 1 s and "
          "doubles up to this", 1, 3600, DEFAULT_RECONNECT_DELAY_MAX, ready));

  gst_element_class_set_static_metadata (element_class,
      "Landmark results publisher", "Filter/Analyzer/Video",
      "Sends the labels, detections and pose of every frame to an MQTT "
      "broker as JSON, passing the video through unchanged",
      "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  trans_class->passthrough_on_same_caps = TRUE;
  trans_class->transform_ip_on_passthrough = TRUE;
  trans_class->start = GST_DEBUG_FUNCPTR (gst_landmark_publish_start);
  trans_class->stop = GST_DEBUG_FUNCPTR (gst_landmark_publish_stop);
  trans_class->set_caps = GST_DEBUG_FUNCPTR (gst_landmark_publish_set_caps);
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_publish_transform_ip);
  trans_class->sink_event =
      GST_DEBUG_FUNCPTR (gst_landmark_publish_sink_event);
}
