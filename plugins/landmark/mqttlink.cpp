/* Why its own network thread rather than mosquitto_loop_start(): in
 * libmosquitto 2.0 a reconnect attempt inside mosquitto_loop_forever()
 * overwrites the "disconnecting" state set by mosquitto_disconnect(), so
 * mosquitto_loop_stop() can wait for ever while the broker is away; an
 * element must stop in bounded time. */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "mqttlink.h"

#include <glib/gstdio.h>
#include <mosquitto.h>
#include <netdb.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <exception>
#include <vector>

GST_DEBUG_CATEGORY_STATIC (mqtt_link_debug);
#define GST_CAT_DEFAULT mqtt_link_debug

/* Messages handed to libmosquitto and not yet acknowledged: its own
 * default send maximum, so it never holds back messages of its own. */
#define MAX_IN_FLIGHT 20
/* How long one mosquitto_loop() call may wait: bounds how long stop()
 * waits for the network thread when nothing wakes it sooner. */
#define LOOP_TIMEOUT_MS 200

namespace landmark {

static bool
host_is_loopback (const std::string & host)
{
  return host == "localhost" || g_str_has_prefix (host.c_str (), "127.") ||
      host == "::1";
}

void
MqttLink::init_library ()
{
  mosquitto_lib_init ();
  GST_DEBUG_CATEGORY_INIT (mqtt_link_debug, "landmarkpublish", 0,
      "Landmark results to an MQTT broker");
}

MqttLink::MqttLink (GstElement * owner):owner_ (owner)
{
}

MqttLink::~MqttLink ()
{
  /* the element's stop() has run unless start() never did: a safety net */
  stop (c_.offline_payload);
}

/* The sentence a user needs for a libmosquitto result code. */
std::string
MqttLink::problem_text (int rc, int err) const
{
  const std::string where = c_.host + ":" + std::to_string (c_.port);
  /* libmosquitto 2.0.21 (Debian 13) reports a refused certificate as
   * errno EPROTO, 2.0.11 (Debian 12) as MOSQ_ERR_TLS */
  if (rc == MOSQ_ERR_TLS || rc == MOSQ_ERR_TLS_HANDSHAKE ||
      (rc == MOSQ_ERR_ERRNO && err == EPROTO && !c_.tls_ca_file.empty ()))
    return "TLS with the broker at " + where + " failed: check "
        "'tls-ca-file' (it must have signed the broker's certificate, "
        "whose name must match 'host'), 'tls-cert-file' and "
        "'tls-key-file'";
  switch (rc) {
    case MOSQ_ERR_EAI:
      return "cannot resolve 'host' \"" + c_.host + "\": " +
          gai_strerror (err ? err : EAI_NONAME);
    case MOSQ_ERR_ERRNO:
      return "cannot reach the broker at " + where + " ('host', 'port'): " +
          g_strerror (err);
    case MOSQ_ERR_CONN_LOST:
      return "lost the connection to the broker at " + where;
    default:
      return std::string ("broker at ") + where + ": " +
          mosquitto_strerror (rc);
  }
}

/* The CONNACK refusals of MQTT 3.1.1, by the setting to check. */
std::string
MqttLink::refusal_text (int code) const
{
  const std::string where = c_.host + ":" + std::to_string (c_.port);
  switch (code) {
    case 1:
      return "the broker at " + where + " refused the protocol version";
    case 2:
      return "the broker at " + where + " refused 'client-id' \"" +
          c_.client_id + "\"";
    case 3:
      return "the broker at " + where + " is unavailable";
    case 4:
      return "the broker at " + where + " refused 'username' \"" +
          c_.username + "\" with the given 'password' (bad user name or "
          "password)";
    case 5:
      return "the broker at " + where + " refused the connection: not "
          "authorised (check 'username' and 'password')";
    default:
      return "the broker at " + where + " refused the connection: " +
          mosquitto_connack_string (code);
  }
}

/* ---- messages to the application ------------------------------------ */

void
MqttLink::post_connection (bool connected, const std::string & reason,
    guint64 queued, guint64 dropped, guint64 resent, bool session_present)
{
  GstStructure *s = gst_structure_new ("landmark-publish-connection",
      "connected", G_TYPE_BOOLEAN, connected,
      "host", G_TYPE_STRING, c_.host.c_str (),
      "port", G_TYPE_INT, c_.port,
      "queued", G_TYPE_UINT64, queued,
      "dropped", G_TYPE_UINT64, dropped,
      "resent", G_TYPE_UINT64, resent, nullptr);
  if (!connected)
    gst_structure_set (s, "reason", G_TYPE_STRING, reason.c_str (), nullptr);
  else
    gst_structure_set (s, "session-present", G_TYPE_BOOLEAN, session_present,
        nullptr);
  gst_element_post_message (owner_,
      gst_message_new_element (GST_OBJECT (owner_), s));
}

void
MqttLink::post_dropped (guint64 dropped, guint64 queued, bool over)
{
  guint max_messages;
  guint64 max_bytes;
  {
    std::lock_guard<std::mutex> lk (lock_);
    max_messages = max_messages_;
    max_bytes = max_bytes_;
  }
  GstStructure *s = gst_structure_new ("landmark-publish-dropped",
      "dropped", G_TYPE_UINT64, dropped,
      "queued", G_TYPE_UINT64, queued,
      "max-queue-messages", G_TYPE_UINT, max_messages,
      "max-queue-bytes", G_TYPE_UINT64, max_bytes,
      "episode-over", G_TYPE_BOOLEAN, over, nullptr);
  gst_element_post_message (owner_,
      gst_message_new_element (GST_OBJECT (owner_), s));
}

/* A network problem: a warning when it differs from the last one, so a
 * broker that stays away is reported once, not at every retry. Called
 * without the lock. */
void
MqttLink::report_problem (const std::string & text)
{
  guint64 queued, dropped, resent;
  {
    std::lock_guard<std::mutex> lk (lock_);
    if (last_problem_ == text || stopping_)
      return;
    last_problem_ = text;
    queued = queue_.size ();
    dropped = dropped_;
    resent = resent_;
  }
  GST_ELEMENT_WARNING (owner_, RESOURCE, OPEN_WRITE,
      ("MQTT: %s; video keeps flowing, results are queued and the element "
          "keeps trying.", text.c_str ()), ("%" G_GUINT64_FORMAT
          " messages queued", queued));
  post_connection (false, text, queued, dropped, resent);
}

/* ---- handing messages to libmosquitto ------------------------------- */

/* Hands queued messages over in order while connected and the window
 * allows. Called with lock_ held, from any thread. Returns true when a
 * drop episode ended (the caller posts that without the lock). */
bool
MqttLink::pump_locked ()
{
  while (connected_ && !resending_ && in_flight_.size () < MAX_IN_FLIGHT) {
    MqttMessage *m = nullptr;
    bool from_queue = true;
    if (!queue_.empty ())
      m = &queue_.front ();
    else if (pose_) {
      m = &*pose_;
      from_queue = false;
    } else
      break;
    int mid = 0;
    const int rc = mosquitto_publish (mosq_, &mid, m->topic.c_str (),
        (int) m->payload.size (), m->payload.data (), m->qos, m->retain);
    /* With QoS 1 or 2 libmosquitto keeps the message once it has given it
     * a message id, even when the socket just went (MOSQ_ERR_NO_CONN), and
     * sends it again on reconnection. */
    const bool kept = rc == MOSQ_ERR_SUCCESS ||
        (rc == MOSQ_ERR_NO_CONN && m->qos > 0 && mid != 0);
    if (!kept && rc == MOSQ_ERR_NO_CONN) {
      connected_ = false;
      break;
    }
    if (from_queue)
      queue_bytes_ -= m->payload.size ();
    if (kept) {
      Flight & f = in_flight_[mid];
      f.seq = next_seq_++;
      f.qos = m->qos;
      f.pose = !from_queue;
      f.message = std::move (*m);
      handed_++;
    } else {
      /* too large for the broker, or similar: this message cannot go */
      GST_WARNING_OBJECT (owner_, "dropping a message to %s: %s",
          m->topic.c_str (), mosquitto_strerror (rc));
      dropped_++;
    }
    if (from_queue)
      queue_.pop_front ();
    else
      pose_.reset ();
    if (rc == MOSQ_ERR_NO_CONN) {
      connected_ = false;
      break;
    }
  }
  bool episode_over = false;
  if (queue_.empty ()) {
    episode_over = dropping_;
    dropping_ = false;
    if (in_flight_.empty ())
      wake_.notify_all ();
  }
  return episode_over;
}

void
MqttLink::pump ()
{
  bool over;
  guint64 dropped;
  {
    std::lock_guard<std::mutex> lk (lock_);
    over = pump_locked ();
    dropped = dropped_;
  }
  if (over)
    post_dropped (dropped, 0, true);
}

/* libmosquitto callbacks: on the network thread, inside mosquitto_loop. */

/* Puts the in-flight messages back at the front of the queue, in the
 * order they were handed over: all of them, or only those libmosquitto
 * will not send again (QoS 0 ones not yet written to the socket, which
 * therefore never left). A pose goes back only when no newer one waits;
 * the online status is sent anew at every connection. Called with lock_
 * held. */
void
MqttLink::requeue_locked (bool all)
{
  std::vector<Flight> back;
  for (auto it = in_flight_.begin (); it != in_flight_.end ();) {
    if (all || it->second.qos == 0) {
      back.push_back (std::move (it->second));
      it = in_flight_.erase (it);
    } else
      ++it;
  }
  std::sort (back.begin (), back.end (),[](const Flight & a,
          const Flight & b) {
        return a.seq > b.seq;}
  );
  for (Flight & f:back) {
    if (!f.message)
      continue;
    if (f.qos > 0)
      resent_++;
    if (f.pose) {
      if (!pose_)
        pose_ = std::move (f.message);
      continue;
    }
    queue_bytes_ += f.message->payload.size ();
    queue_.push_front (std::move (*f.message));
  }
}

/* libmosquitto callbacks: on the network thread, inside mosquitto_loop. */

void
MqttLink::on_connect (struct mosquitto *, void *obj, int code, int flags)
{
  auto self = static_cast < MqttLink * >(obj);
  const MqttConnection & c = self->c_;
  if (code != 0) {
    self->report_problem (self->refusal_text (code));
    return;
  }
  const bool session_present = (flags & 1) != 0;
  guint64 queued, dropped, resent;
  {
    std::lock_guard<std::mutex> lk (self->lock_);
    auto & in_flight = self->in_flight_;
    if (self->wiping_) {
      /* the broker has discarded any session an earlier run left under
       * this client id (whose message ids this new client would reuse) */
      self->wiping_ = false;
      self->start_over_ = true;
      mosquitto_disconnect (self->mosq_);
      return;
    }
    const bool qos2 = std::any_of (in_flight.begin (), in_flight.end (),
        [](const auto & f) {
          return f.second.qos == 2;}
    );
    if (!session_present && qos2) {
      /* The broker lost the session (restarted without persistence, or
       * the session expired): libmosquitto would send only PUBREL for a
       * QoS 2 message whose PUBREC it had, which a broker that no longer
       * holds the message answers with PUBCOMP: lost. Hand every
       * unacknowledged message over again on a client made anew. The
       * DISCONNECT goes before anything libmosquitto queues after this
       * callback, and libmosquitto closes the socket once it is sent. */
      self->requeue_locked (true);
      self->start_over_ = true;
      mosquitto_disconnect (self->mosq_);
      GST_INFO_OBJECT (self->owner_, "the broker lost the session: %"
          G_GUINT64_FORMAT " messages handed over again so far",
          self->resent_);
      return;
    }
    self->connected_ = true;
    self->last_problem_.clear ();
    /* QoS 0 messages not yet written went with the socket; the others
     * libmosquitto sends again right after this callback, and they must
     * be acknowledged before anything newer goes */
    self->requeue_locked (false);
    self->resending_ = !in_flight.empty ();
    queued = self->queue_.size ();
    dropped = self->dropped_;
    resent = self->resent_;
    if (!c.status_topic.empty ()) {
      int mid = 0;
      if (mosquitto_publish (self->mosq_, &mid, c.status_topic.c_str (),
              (int) c.online_payload.size (), c.online_payload.data (), 1,
              true) == MOSQ_ERR_SUCCESS && !self->resending_) {
        Flight & f = in_flight[mid];
        f.seq = self->next_seq_++;
        f.qos = 1;
      }
    }
  }
  GST_INFO_OBJECT (self->owner_, "connected to %s:%d as %s (session %s)",
      c.host.c_str (), c.port, c.client_id.c_str (),
      session_present ? "kept" : "new");
  self->post_connection (true, "", queued, dropped, resent,
      session_present);
  self->pump ();
}

void
MqttLink::on_publish (struct mosquitto *, void *obj, int mid)
{
  auto self = static_cast < MqttLink * >(obj);
  {
    std::lock_guard<std::mutex> lk (self->lock_);
    self->in_flight_.erase (mid);
    if (self->resending_ && self->in_flight_.empty ())
      self->resending_ = false;
  }
  self->pump ();
}

/* ---- the network thread --------------------------------------------- */

void
MqttLink::network_main ()
{
  bool first = true;
  guint delay = 1;

  for (;;) {
    {
      std::lock_guard<std::mutex> lk (lock_);
      if (stopping_)
        break;
    }
    errno = 0;
    int rc = first ? mosquitto_connect_async (mosq_, c_.host.c_str (),
        c_.port, c_.keep_alive) : mosquitto_reconnect_async (mosq_);
    int err = errno;
    first = false;
    bool was_connected = false;
    if (rc == MOSQ_ERR_SUCCESS) {
      /* until the connection ends: CONNACK, acknowledgements, keep-alive */
      gint64 stop_deadline = 0;
      do {
        errno = 0;
        rc = mosquitto_loop (mosq_, LOOP_TIMEOUT_MS, 1);
        err = errno;
        std::lock_guard<std::mutex> lk (lock_);
        if (connected_) {
          was_connected = true;
          delay = 1;
        }
        if (stopping_ && rc == MOSQ_ERR_SUCCESS) {
          /* stop() disconnected; a connection this thread was opening at
           * that moment is closed here, and stopping never waits more
           * than a second for the DISCONNECT to go out */
          const gint64 now = g_get_monotonic_time ();
          if (stop_deadline == 0) {
            stop_deadline = now + G_USEC_PER_SEC;
            if (mosquitto_socket (mosq_) >= 0)
              mosquitto_disconnect (mosq_);
          }
          if (mosquitto_socket (mosq_) < 0 || now > stop_deadline)
            rc = MOSQ_ERR_NO_CONN;
        }
      } while (rc == MOSQ_ERR_SUCCESS);
    }
    {
      std::lock_guard<std::mutex> lk (lock_);
      connected_ = false;
      if (stopping_)
        break;
      if (start_over_) {
        /* a new client without libmosquitto's old in-flight state,
         * connecting at once */
        start_over_ = false;
        const char *what = "client options";
        rc = mosquitto_reinitialise (mosq_, c_.client_id.c_str (),
            c_.clean_session, this);
        if (rc == MOSQ_ERR_SUCCESS)
          rc = configure (mosq_, &what);
        if (rc == MOSQ_ERR_SUCCESS) {
          first = true;
          continue;
        }
        GST_ERROR_OBJECT (owner_, "cannot make the MQTT client anew (%s): "
            "%s", what, mosquitto_strerror (rc));
      }
    }
    if (rc != MOSQ_ERR_CONN_REFUSED)    /* already said in on_connect */
      report_problem (was_connected && rc == MOSQ_ERR_NO_CONN ?
          problem_text (MOSQ_ERR_CONN_LOST, 0) : problem_text (rc, err));
    GST_DEBUG_OBJECT (owner_, "next attempt in %u s", delay);
    std::unique_lock<std::mutex> lk (lock_);
    wake_.wait_for (lk, std::chrono::seconds (delay),[this] {
          return stopping_;}
    );
    delay = std::min (delay * 2, std::max (c_.reconnect_delay_max, 1u));
  }
  GST_DEBUG_OBJECT (owner_, "network thread done");
}

/* ---- start, queue, stop --------------------------------------------- */

/* The client's options, at start and whenever it is made anew: a
 * libmosquitto result, with what naming the setting at fault. */
int
MqttLink::configure (struct mosquitto *mosq, const char **what)
{
  const MqttConnection & c = c_;
  int rc = mosquitto_threaded_set (mosq, true);
  if (rc == MOSQ_ERR_SUCCESS)
    rc = mosquitto_int_option (mosq, MOSQ_OPT_SEND_MAXIMUM, MAX_IN_FLIGHT);
  *what = "client options";
  if (rc == MOSQ_ERR_SUCCESS && !c.username.empty ()) {
    *what = "username";
    rc = mosquitto_username_pw_set (mosq, c.username.c_str (),
        c.password.empty ()? nullptr : c.password.c_str ());
  }
  if (rc == MOSQ_ERR_SUCCESS && !c.status_topic.empty ()) {
    *what = "status-topic";
    rc = mosquitto_will_set (mosq, c.status_topic.c_str (),
        (int) c.offline_payload.size (), c.offline_payload.data (), 1, true);
  }
  if (rc == MOSQ_ERR_SUCCESS && !c.tls_ca_file.empty ()) {
    *what = "tls-ca-file";
    rc = mosquitto_tls_set (mosq, c.tls_ca_file.c_str (), nullptr,
        c.tls_cert_file.empty ()? nullptr : c.tls_cert_file.c_str (),
        c.tls_key_file.empty ()? nullptr : c.tls_key_file.c_str (),
        nullptr);
  }
  if (rc != MOSQ_ERR_SUCCESS)
    return rc;
  mosquitto_connect_with_flags_callback_set (mosq, on_connect);
  mosquitto_publish_callback_set (mosq, on_publish);
  return MOSQ_ERR_SUCCESS;
}

bool
MqttLink::start (const MqttConnection & c)
{
  c_ = c;
  /* a persistent session starts with a clean one: whatever an earlier
   * run left under this client id goes */
  struct mosquitto *mosq = mosquitto_new (c.client_id.c_str (), true, this);
  if (!mosq) {
    GST_ELEMENT_ERROR (owner_, RESOURCE, FAILED,
        ("Could not create the MQTT client: %s.", g_strerror (errno)),
        (nullptr));
    return false;
  }
  const char *what = nullptr;
  const int rc = configure (mosq, &what);
  if (rc != MOSQ_ERR_SUCCESS) {
    mosquitto_destroy (mosq);
    GST_ELEMENT_ERROR (owner_, RESOURCE, SETTINGS,
        ("Invalid '%s': %s.", what, mosquitto_strerror (rc)), (nullptr));
    return false;
  }

  if (!host_is_loopback (c.host) && c.tls_ca_file.empty ())
    GST_ELEMENT_WARNING (owner_, RESOURCE, SETTINGS,
        ("MQTT: results%s go to '%s' unencrypted; set 'tls-ca-file' to use "
            "TLS.", c.username.empty ()? "" : " and the password",
            c.host.c_str ()), (nullptr));

  {
    std::lock_guard<std::mutex> lk (lock_);
    queue_.clear ();
    queue_bytes_ = 0;
    pose_.reset ();
    in_flight_.clear ();
    connected_ = resending_ = stopping_ = dropping_ = start_over_ = false;
    wiping_ = !c.clean_session;
    dropped_ = handed_ = resent_ = next_seq_ = 0;
    last_problem_.clear ();
    mosq_ = mosq;
  }
  try {
    network_ = std::thread (&MqttLink::network_main, this);
  }
  catch (const std::exception & e) {
    mosq_ = nullptr;
    mosquitto_destroy (mosq);
    GST_ELEMENT_ERROR (owner_, RESOURCE, FAILED,
        ("Could not start the MQTT thread."), ("%s", e.what ()));
    return false;
  }
  return true;
}

void
MqttLink::enqueue (MqttMessage frame, std::optional<MqttMessage> pose,
    guint max_messages, guint64 max_bytes)
{
  bool started_dropping = false;
  guint64 dropped, queued;
  {
    std::lock_guard<std::mutex> lk (lock_);
    max_messages_ = max_messages;
    max_bytes_ = max_bytes;
    if (pose)
      pose_ = std::move (pose);
    queue_bytes_ += frame.payload.size ();
    queue_.push_back (std::move (frame));
    pump_locked ();
    /* the bound: drop the oldest, never the frame */
    while (!queue_.empty () && (queue_.size () > max_messages ||
            queue_bytes_ > max_bytes)) {
      queue_bytes_ -= queue_.front ().payload.size ();
      queue_.pop_front ();
      dropped_++;
      if (!dropping_) {
        dropping_ = true;
        started_dropping = true;
      }
    }
    dropped = dropped_;
    queued = queue_.size ();
  }
  if (started_dropping) {
    GST_ELEMENT_WARNING (owner_, RESOURCE, WRITE,
        ("MQTT: the queue is full (%" G_GUINT64_FORMAT " messages, at most "
            "'max-queue-messages' %u and 'max-queue-bytes' %" G_GUINT64_FORMAT
            "): dropping the oldest results until the broker takes them "
            "again.", queued, max_messages, max_bytes),
        ("%" G_GUINT64_FORMAT " dropped since start", dropped));
    post_dropped (dropped, queued, false);
  }
}

void
MqttLink::drain (guint timeout_ms)
{
  std::unique_lock<std::mutex> lk (lock_);
  auto done = [this] {
    return stopping_ || (queue_.empty () && !pose_ && in_flight_.empty ());
  };
  if (!wake_.wait_for (lk, std::chrono::milliseconds (timeout_ms), done))
    GST_WARNING_OBJECT (owner_, "EOS: %zu messages still queued, %zu in "
        "flight after %u ms", queue_.size (), in_flight_.size (),
        timeout_ms);
}

void
MqttLink::stop (const std::string & goodbye)
{
  if (!mosq_)
    return;
  guint64 lost = 0;
  {
    std::lock_guard<std::mutex> lk (lock_);
    stopping_ = true;
    lost = queue_.size () + in_flight_.size ();
    if (connected_ && !c_.status_topic.empty ()) {
      /* an orderly goodbye: the broker sends no will after DISCONNECT */
      mosquitto_publish (mosq_, nullptr, c_.status_topic.c_str (),
          (int) goodbye.size (), goodbye.data (), 0, true);
    }
    /* wakes mosquitto_loop (through libmosquitto's internal socket pair)
     * when connected, and the back-off wait otherwise */
    mosquitto_disconnect (mosq_);
    wake_.notify_all ();
  }
  if (network_.joinable ())
    network_.join ();
  mosquitto_destroy (mosq_);
  mosq_ = nullptr;
  if (lost > 0)
    GST_ELEMENT_WARNING (owner_, RESOURCE, WRITE,
        ("MQTT: %" G_GUINT64_FORMAT " results were not delivered to %s:%d "
            "before the element stopped.", lost, c_.host.c_str (), c_.port),
        (nullptr));
  std::lock_guard<std::mutex> lk (lock_);
  GST_INFO_OBJECT (owner_, "stopped: %" G_GUINT64_FORMAT " messages handed "
      "over, %" G_GUINT64_FORMAT " dropped", handed_, dropped_);
  queue_.clear ();
  queue_bytes_ = 0;
  pose_.reset ();
  in_flight_.clear ();
}

}  // namespace landmark
