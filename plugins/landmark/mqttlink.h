/* landmarkpublish's connection to its MQTT broker (docs/landmarkpublish.md):
 * a bounded in-order queue that the streaming thread appends to without
 * waiting for the network, and a network thread of its own that connects,
 * hands the queue to libmosquitto in order and reconnects with back-off.
 * Problems are posted on the owning element: warnings naming the setting
 * to check, and the `landmark-publish-connection` and
 * `landmark-publish-dropped` element messages. */
#pragma once

#include <gst/gst.h>

#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

struct mosquitto;

namespace landmark {

/* Where and who: checked by the element before start(). */
struct MqttConnection {
  std::string host;
  int port = 1883;
  std::string client_id;
  int keep_alive = 30;
  std::string username, password;
  std::string tls_ca_file, tls_cert_file, tls_key_file;
  /* retained online/offline status and last will ("": none) */
  std::string status_topic, online_payload, offline_payload;
  guint reconnect_delay_max = 30;
  /* false: a session the broker keeps across connections (with a stable
   * client_id), so a QoS 2 exchange cut by the link completes exactly
   * once on reconnection */
  bool clean_session = false;
};

struct MqttMessage {
  std::string topic;
  std::string payload;
  int qos = 0;
  bool retain = false;
};

class MqttLink {
public:
  /* Initialises libmosquitto, once per process (plugins are never
   * unloaded, so no cleanup). */
  static void init_library ();

  explicit MqttLink (GstElement * owner);
  ~MqttLink ();
  MqttLink (const MqttLink &) = delete;
  MqttLink & operator= (const MqttLink &) = delete;

  /* Creates the client and starts the network thread; false with an
   * ERROR posted (naming the setting when one is at fault). */
  bool start (const MqttConnection & c);
  bool running () const { return mosq_ != nullptr; }

  /* Appends a frame's message and, when given, makes pose the retained
   * pose to send; beyond max_messages or max_bytes the oldest messages are
   * dropped (never the frame: a warning once per episode and a
   * landmark-publish-dropped message). Never waits for the network. */
  void enqueue (MqttMessage frame, std::optional<MqttMessage> pose,
      guint max_messages, guint64 max_bytes);

  /* Waits up to timeout_ms for everything queued to be delivered. */
  void drain (guint timeout_ms);

  /* Says goodbye on the status topic (goodbye: its payload) when
   * connected, disconnects and joins the network thread, within about a
   * second; a warning counts the results not delivered. */
  void stop (const std::string & goodbye);

private:
  int configure (struct mosquitto *mosq, const char **what);
  void requeue_locked (bool all);
  bool pump_locked ();
  void pump ();
  void report_problem (const std::string & text);
  void post_connection (bool connected, const std::string & reason,
      guint64 queued, guint64 dropped, guint64 resent,
      bool session_present = false);
  void post_dropped (guint64 dropped, guint64 queued, bool over);
  void network_main ();
  std::string problem_text (int rc, int err) const;
  std::string refusal_text (int code) const;
  static void on_connect (struct mosquitto *, void *obj, int code,
      int flags);
  static void on_publish (struct mosquitto *, void *obj, int mid);

  GstElement *owner_;
  MqttConnection c_;                  /* written in start() only */
  struct mosquitto *mosq_ = nullptr;
  std::thread network_;

  /* Shared by the streaming thread, the network thread and libmosquitto's
   * callbacks (which run on the network thread): guarded by lock_. Lock
   * order: lock_, then libmosquitto's own mutexes (mosquitto_publish). */
  std::mutex lock_;
  std::condition_variable wake_;      /* stopping, queue delivered */
  std::deque<MqttMessage> queue_;     /* in order, not yet handed over */
  size_t queue_bytes_ = 0;
  std::optional<MqttMessage> pose_;   /* the latest pose, retained */
  /* A message handed to libmosquitto and not yet acknowledged (QoS 0:
   * not yet written to the socket), kept so that it can be handed over
   * again when libmosquitto's copy cannot complete (below). */
  struct Flight {
    guint64 seq = 0;                  /* order of handing over */
    int qos = 0;
    bool pose = false;
    std::optional<MqttMessage> message;   /* none: the online status */
  };
  std::map<int, Flight> in_flight_;   /* by mid */
  guint64 next_seq_ = 0;
  /* The connection under way only clears the broker's session of this
   * client id (clean session, disconnected at CONNACK). */
  bool wiping_ = false;
  /* The broker lost the session with QoS 2 messages in flight: this
   * connection is closed at CONNACK and the client made anew. */
  bool start_over_ = false;
  guint64 resent_ = 0;                /* handed over again, since start */
  bool connected_ = false;            /* CONNACK accepted */
  bool resending_ = false;            /* old in-flight messages go first */
  bool stopping_ = false;
  guint64 dropped_ = 0;               /* since start */
  bool dropping_ = false;             /* a drop episode is on */
  guint64 handed_ = 0;                /* messages given to libmosquitto */
  std::string last_problem_;          /* the last warning posted */
  guint max_messages_ = 0;            /* the bounds of the last enqueue */
  guint64 max_bytes_ = 0;
};

}  // namespace landmark
