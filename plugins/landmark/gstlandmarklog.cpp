/**
 * SECTION:element-landmarklog
 * @title: landmarklog
 *
 * Writes the gst-landmark metadata of every buffer to a file, one JSON
 * object per buffer and per line (JSON Lines), and passes the video through
 * untouched: the element is a passthrough GstBaseTransform that accepts any
 * `video/x-raw` caps (any format, any caps features), never copies, maps or
 * modifies a buffer and never drops one (QoS is off). It can sit anywhere
 * in a chain, and several can log one pipeline to different files.
 *
 * One line per buffer, in the order buffers arrive, nothing else in the
 * file (docs/landmarklog.md has every field):
 *
 * |[
 * {"frame": 0, "pts": 0, "duration": 33333333, "width": 640, "height": 480,
 *  "labels": {"classes": ["red", ...], "markers": [true, ...],
 *             "counts": [...], "active": [...], "labelled": [...],
 *             "unclassified": 1234, "min-class-pixels": 500,
 *             "width": 640, "height": 480, ...},
 *  "detections": [{"id": 0, "class": "red", "bbox": [x, y, w, h],
 *                  "blob": {...}, "range": {...}, "match": {...},
 *                  "params": {...}}],
 *  "pose": {...}}
 * ]|
 * (shown here on several lines; in the file each object is one line).
 *
 * - `frame`: index of the buffer since the element started (READY to
 *   PAUSED), 0, 1, 2, ...; `pts`, `duration`: nanoseconds, absent when the
 *   buffer has none; `width`, `height`: from the negotiated caps.
 * - `labels`: only when the buffer has a `GstLandmarkLabelsMeta`; its
 *   fields under short names, never the label plane itself.
 * - `detections`: always present; every `GstVideoRegionOfInterestMeta` in
 *   id order, with the `landmark-blob`, `landmark-range` and
 *   `landmark-match` parameter structures as `blob`, `range`, `match`, and
 *   any other parameter structure under its own name in `params`.
 * - `pose`: only when the buffer has a `GstLandmarkPoseMeta`: every field.
 *
 * Structure fields become JSON values of their own type: integers as
 * integers, doubles with the shortest text that reads back to the same
 * double (always with a `.` or an exponent), NaN and infinities as `null`,
 * arrays as arrays. A field absent from a meta is absent from the line.
 *
 * Lines are collected in memory and handed to the file in whole lines: when
 * 64 KiB are pending, every `flush-every` frames if set, and at EOS, on a
 * flushing seek, on PLAYING to PAUSED and when the element stops (also
 * after an error). The file therefore always ends with a complete line, and
 * it is complete as soon as the EOS message is posted.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 videotestsrc num-buffers=100 ! labsegment !
 *     landmarklog location=frames.jsonl ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstlandmarklog.h"

#include <gst/video/video.h>
#include <glib/gstdio.h>

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "elementsettings.h"
#include "landmarkjson.h"
#include "landmarkmeta.h"

GST_DEBUG_CATEGORY_STATIC (gst_landmark_log_debug);
#define GST_CAT_DEFAULT gst_landmark_log_debug

/* Pending lines are handed to the file once they reach this size. */
#define CHUNK_SIZE (64 * 1024)

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults); location and
 * append are read in start(). */
struct Settings {
  std::string location;
  gboolean append = FALSE;
  guint flush_every = 0;
};

/* Every value the properties accept is valid (an unset location is an
 * error of its own at start). */
struct Config {
  Settings s;
};

/* The open file and the lines not yet written. Filled by the streaming
 * thread, flushed from events and state changes: guarded by io_lock. */
struct State {
  int fd = -1;
  std::string path;
  std::string pending;        /* complete lines only */
  guint64 frame = 0;          /* index of the next buffer */
  guint unflushed = 0;        /* frames in pending */
  gint width = -1, height = -1;
  bool failed = false;        /* a write failed: error already posted */
  std::vector<GstVideoRegionOfInterestMeta *> rois;   /* reused */

  ~State ();
};

}  // namespace

struct GstLandmarkLogPrivate {
  landmark::SharedSettings<Settings> settings;
  /* start() and the streaming thread only */
  landmark::AppliedSettings<Settings, Config> applied;
  std::mutex io_lock;
  State state;
};

/* *INDENT-ON* */

LANDMARK_DEFINE_ELEMENT_WITH_PRIVATE (GstLandmarkLog, gst_landmark_log,
    Settings, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, landmarklog,
    "Landmark metadata to JSON Lines");

/* ---- JSON text ------------------------------------------------------ */

namespace {

/* Appends the line of one buffer to st.pending. */
void
put_frame (State & st, GstBuffer * buf)
{
  st.pending += '{';
  landmark_json::put_frame_fields (st.pending, buf, st.frame, st.width,
      st.height, st.rois);
  st.pending += "}\n";
}

/* ---- file output ---------------------------------------------------- */

/* After a failed write of `done` bytes of pending: cuts a partly written
 * line off the end of the file, where the file allows it, so the file
 * still ends with a complete line. */
void
trim_partial_line (State & st, size_t done)
{
  if (done == 0)
    return;
  const char *p = st.pending.data ();
  size_t keep = done;
  while (keep > 0 && p[keep - 1] != '\n')
    keep--;
  if (keep == done)
    return;
  const off_t end = lseek (st.fd, 0, SEEK_CUR);
  if (end < 0)
    return;                     /* a pipe or a terminal: nothing to do */
  const off_t cut = end - (off_t) (done - keep);
  if (ftruncate (st.fd, cut) == 0)
    lseek (st.fd, cut, SEEK_SET);
}

/* Hands every pending line to the file. Returns 0 or an errno value. */
int write_pending (State & st);

State::~State ()
{
  if (fd >= 0) {
    /* stop() closes the file; this is only a safety net */
    write_pending (*this);
    close (fd);
  }
}

/* Hands every pending line to the file. Returns 0 or an errno value. */
int
write_pending (State & st)
{
  const char *p = st.pending.data ();
  const size_t n = st.pending.size ();
  size_t done = 0;
  int err = 0;
  while (done < n) {
    const ssize_t r = write (st.fd, p + done, n - done);
    if (r < 0 && errno == EINTR)
      continue;
    if (r <= 0) {
      err = r < 0 ? errno : EIO;
      trim_partial_line (st, done);
      break;
    }
    done += (size_t) r;
  }
  /* after a failure the lines are gone either way: the element stops */
  st.pending.clear ();
  st.unflushed = 0;
  return err;
}

}  // namespace

/* ---- GObject -------------------------------------------------------- */

static void
gst_landmark_log_init (GstLandmarkLog * self)
{
  GstBaseTransform *trans = GST_BASE_TRANSFORM (self);
  self->priv = new GstLandmarkLogPrivate ();
  /* buffers go through as they are: never made writable, never copied */
  gst_base_transform_set_passthrough (trans, TRUE);
  gst_base_transform_set_prefer_passthrough (trans, TRUE);
  /* a logger never drops late frames */
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

/* ---- configuration and file life ------------------------------------ */

static const landmark::PropertyTable<Settings> &
landmark_log_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("location", "File location",
          "JSON Lines file to write, one line per buffer (required; created "
          "or truncated when the element starts)", &Settings::location)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .boolean ("append", "Append",
          "Add lines to the end of an existing file instead of truncating it",
          &Settings::append)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .number ("flush-every", "Flush every N frames",
          "Hand the pending lines to the file after every N frames (1: after "
          "each frame, for readers following the file live; 0: only when "
          "64 KiB are pending, at EOS, on flush, pause and stop)",
          &Settings::flush_every, 0u, G_MAXUINT);
  return table;
}


/* the settings (landmark::change_state_checking_settings) */
static constexpr auto gst_landmark_log_apply_settings =
    landmark::apply_parsed<GstLandmarkLog,
    landmark::accept_settings<Settings, Config>>;

static gboolean
gst_landmark_log_start (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_LOG (trans);
  auto priv = self->priv;
  const std::string & path = priv->applied.config.s.location;
  const gboolean append = priv->applied.config.s.append;

  if (path.empty ()) {
    GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
        ("No file name specified for writing: set 'location'."), (nullptr));
    return FALSE;
  }

  int flags = O_WRONLY | O_CREAT | (append ? O_APPEND : O_TRUNC);
#ifdef O_CLOEXEC
  flags |= O_CLOEXEC;
#endif
  const int fd = g_open (path.c_str (), flags, 0666);
  if (fd < 0) {
    const int err = errno;
    GST_ELEMENT_ERROR (self, RESOURCE, OPEN_WRITE,
        ("Could not open file \"%s\" for writing: %s.", path.c_str (),
            g_strerror (err)),
        ("open (\"%s\", %s): %s (errno %d)", path.c_str (),
            append ? "append" : "truncate", g_strerror (err), err));
    return FALSE;
  }

  std::lock_guard<std::mutex> lk (priv->io_lock);
  State & st = priv->state;
  st.fd = fd;
  st.path = path;
  st.pending.clear ();
  st.pending.reserve (CHUNK_SIZE + 4096);
  st.frame = 0;
  st.unflushed = 0;
  st.failed = false;
  GST_INFO_OBJECT (self, "logging to %s (%s)", path.c_str (),
      append ? "appending" : "truncated");
  return TRUE;
}

static void
gst_landmark_log_post_write_error (GstLandmarkLog * self,
    const std::string & path, int err)
{
  GST_ELEMENT_ERROR (self, RESOURCE, WRITE,
      ("Could not write to file \"%s\": %s.", path.c_str (),
          g_strerror (err)), ("errno %d", err));
}

/* Writes the pending lines now; posts the error and returns FALSE when
 * that fails. */
static gboolean
gst_landmark_log_flush (GstLandmarkLog * self, const char *why)
{
  auto priv = self->priv;
  int err = 0;
  std::string path;
  {
    std::lock_guard<std::mutex> lk (priv->io_lock);
    State & st = priv->state;
    if (st.fd < 0 || st.pending.empty ())
      return TRUE;
    GST_DEBUG_OBJECT (self, "%s: writing %zu bytes (%u frames)", why,
        st.pending.size (), st.unflushed);
    err = write_pending (st);
    if (err) {
      if (st.failed)
        return FALSE;
      st.failed = true;
      path = st.path;
    }
  }
  if (err) {
    gst_landmark_log_post_write_error (self, path, err);
    return FALSE;
  }
  return TRUE;
}

static gboolean
gst_landmark_log_stop (GstBaseTransform * trans)
{
  auto self = GST_LANDMARK_LOG (trans);
  auto priv = self->priv;
  int err = 0;
  std::string path;
  {
    std::lock_guard<std::mutex> lk (priv->io_lock);
    State & st = priv->state;
    if (st.fd >= 0) {
      if (!st.pending.empty ())
        err = write_pending (st);
      /* some file systems report write errors only on close */
      if (close (st.fd) != 0 && !err && errno != EINTR)
        err = errno;
      st.fd = -1;
      GST_INFO_OBJECT (self, "closed %s after %" G_GUINT64_FORMAT " frames",
          st.path.c_str (), st.frame);
    }
    if (err && !st.failed)
      path = st.path;
    else
      err = 0;
    st.pending.clear ();
    st.pending.shrink_to_fit ();
    st.rois.clear ();
    st.width = st.height = -1;
    st.failed = false;
  }
  if (err)
    gst_landmark_log_post_write_error (self, path, err);
  return TRUE;
}

static gboolean
gst_landmark_log_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps * outcaps)
{
  auto self = GST_LANDMARK_LOG (trans);
  (void) outcaps;
  gint w = -1, h = -1;
  if (gst_caps_get_size (incaps) > 0) {
    const GstStructure *s = gst_caps_get_structure (incaps, 0);
    if (!gst_structure_get_int (s, "width", &w))
      w = -1;
    if (!gst_structure_get_int (s, "height", &h))
      h = -1;
  }
  GST_DEBUG_OBJECT (self, "caps %" GST_PTR_FORMAT, incaps);
  std::lock_guard<std::mutex> lk (self->priv->io_lock);
  self->priv->state.width = w;
  self->priv->state.height = h;
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static GstFlowReturn
gst_landmark_log_transform_ip (GstBaseTransform * trans, GstBuffer * buf)
{
  auto self = GST_LANDMARK_LOG (trans);
  auto priv = self->priv;
  priv->applied.sync (GST_ELEMENT (self), priv->settings);
  const guint flush_every = priv->applied.config.s.flush_every;

  int err = 0;
  std::string path;
  try {
    std::lock_guard<std::mutex> lk (priv->io_lock);
    State & st = priv->state;
    if (st.failed)
      return GST_FLOW_ERROR;    /* already reported */
    if (G_UNLIKELY (st.fd < 0))
      err = EBADF;              /* cannot happen: start() opened it */
    else
      put_frame (st, buf);
    GST_LOG_OBJECT (self, "frame %" G_GUINT64_FORMAT " pts %" GST_TIME_FORMAT,
        st.frame, GST_TIME_ARGS (GST_BUFFER_PTS (buf)));
    st.frame++;
    st.unflushed++;
    if (!err && (st.pending.size () >= CHUNK_SIZE ||
            (flush_every > 0 && st.unflushed >= flush_every)))
      err = write_pending (st);
    if (err) {
      st.failed = true;
      path = st.path;
    }
  }
  catch (const std::exception & e) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("Could not log a frame."),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
  if (err) {
    gst_landmark_log_post_write_error (self, path, err);
    return GST_FLOW_ERROR;
  }
  return GST_FLOW_OK;
}

static gboolean
gst_landmark_log_sink_event (GstBaseTransform * trans, GstEvent * event)
{
  auto self = GST_LANDMARK_LOG (trans);
  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_EOS:
      /* before forwarding: the file is complete when EOS reaches the sink
       * and the application hears of it */
      gst_landmark_log_flush (self, "EOS");
      break;
    case GST_EVENT_FLUSH_STOP:
      gst_landmark_log_flush (self, "flush-stop");
      break;
    default:
      break;
  }
  return GST_BASE_TRANSFORM_CLASS (gst_landmark_log_parent_class)->sink_event
      (trans, event);
}

static GstStateChangeReturn
gst_landmark_log_change_state (GstElement * element,
    GstStateChange transition)
{
  auto self = GST_LANDMARK_LOG (element);
  GstStateChangeReturn ret =
      landmark::change_state_checking_settings<GstLandmarkLog,
      gst_landmark_log_get_type, gst_landmark_log_apply_settings> (element,
      transition);
  /* a paused pipeline has its file up to date */
  if (ret != GST_STATE_CHANGE_FAILURE &&
      transition == GST_STATE_CHANGE_PLAYING_TO_PAUSED)
    gst_landmark_log_flush (self, "paused");
  return ret;
}

static void
gst_landmark_log_class_init (GstLandmarkLogClass * klass)
{
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);

  landmark_json::init ();

  landmark::element_class_init<Settings, gst_landmark_log_settings,
      landmark_log_properties> (klass, gst_landmark_log_finalize,
      "Landmark metadata logger", "Filter/Analyzer/Video",
      "Writes the labels, detections and pose metadata of every buffer as "
      "one JSON line per frame, passing the video through unchanged");

  element_class->change_state =
      GST_DEBUG_FUNCPTR (gst_landmark_log_change_state);
  trans_class->passthrough_on_same_caps = TRUE;
  trans_class->transform_ip_on_passthrough = TRUE;
  trans_class->start = landmark::start_checking_settings<GstLandmarkLog,
      gst_landmark_log_apply_settings, gst_landmark_log_start>;
  trans_class->stop = GST_DEBUG_FUNCPTR (gst_landmark_log_stop);
  trans_class->set_caps = GST_DEBUG_FUNCPTR (gst_landmark_log_set_caps);
  trans_class->transform_ip =
      GST_DEBUG_FUNCPTR (gst_landmark_log_transform_ip);
  trans_class->sink_event = GST_DEBUG_FUNCPTR (gst_landmark_log_sink_event);
}
