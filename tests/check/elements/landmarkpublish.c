/* Unit tests of landmarkpublish without a broker (tests/python/test_publish.py
 * has the real-broker ones): the element never holds up or drops a frame
 * and never touches it, whatever the network does; its queue keeps the
 * bound it is given and says so once; a broker that is not there is a
 * warning, not an error. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>

#include <string.h>

#define CAPS_GRAY "video/x-raw,format=GRAY8,width=8,height=4,framerate=25/1"
#define FRAME_SIZE 32
/* nothing listens on port 1 of the loopback interface */
#define NO_BROKER "landmarkpublish host=127.0.0.1 port=1 "

static GstBuffer *
make_frame (guint i)
{
  GstBuffer *buf = gst_buffer_new_allocate (NULL, FRAME_SIZE, NULL);
  GstMapInfo map;
  fail_unless (gst_buffer_map (buf, &map, GST_MAP_WRITE));
  for (guint k = 0; k < FRAME_SIZE; k++)
    map.data[k] = (guint8) (i * 7 + k);
  gst_buffer_unmap (buf, &map);
  GST_BUFFER_PTS (buf) = i * GST_SECOND / 25;
  GST_BUFFER_DURATION (buf) = GST_SECOND / 25;
  return buf;
}

static gboolean
frame_intact (GstBuffer * buf, guint i)
{
  GstMapInfo map;
  gboolean ok = TRUE;
  fail_unless (gst_buffer_map (buf, &map, GST_MAP_READ));
  ok = map.size == FRAME_SIZE;
  for (guint k = 0; ok && k < FRAME_SIZE; k++)
    ok = map.data[k] == (guint8) (i * 7 + k);
  gst_buffer_unmap (buf, &map);
  return ok;
}

LANDMARK_TEST ("general", test_frames_pass_untouched_and_never_wait)
{
  const guint n = 2000;
  GstHarness *h = gst_harness_new_parse (NO_BROKER
      "max-queue-messages=10 drain-timeout=0");
  GstBus *bus = gst_bus_new ();
  gint64 slowest = 0;

  gst_element_set_bus (h->element, bus);
  gst_harness_set_src_caps_str (h, CAPS_GRAY);
  for (guint i = 0; i < n; i++) {
    GstBuffer *in = make_frame (i);
    const gint64 t0 = g_get_monotonic_time ();
    GstBuffer *out = gst_harness_push_and_pull (h, gst_buffer_ref (in));
    slowest = MAX (slowest, g_get_monotonic_time () - t0);
    /* passthrough: the very buffer, its bytes unchanged */
    fail_unless (out == in, "frame %u: another buffer came out", i);
    fail_unless (frame_intact (out, i), "frame %u changed", i);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }
  /* no frame waits for the network (generous: a loaded 2-core machine) */
  fail_unless (slowest < 200 * 1000, "a frame took %" G_GINT64_FORMAT " us",
      slowest);

  /* the bound: dropping started once, when the 11th message came */
  /* popping by type drops the other types: take both kinds at once */
  GList *all = landmark_check_pop_all (bus,
      GST_MESSAGE_ELEMENT | GST_MESSAGE_WARNING), *l;
  GList *elements = NULL, *warnings = NULL;
  for (l = all; l; l = l->next) {
    if (GST_MESSAGE_TYPE (l->data) == GST_MESSAGE_ELEMENT)
      elements = g_list_append (elements, l->data);
    else
      warnings = g_list_append (warnings, l->data);
  }
  g_list_free (all);
  guint dropped_messages = 0;
  for (l = elements; l; l = l->next) {
    const GstStructure *s = gst_message_get_structure (l->data);
    if (!gst_structure_has_name (s, "landmark-publish-dropped"))
      continue;
    guint64 dropped = 0, queued = 0;
    gboolean over = TRUE;
    fail_unless (gst_structure_get_uint64 (s, "dropped", &dropped));
    fail_unless (gst_structure_get_uint64 (s, "queued", &queued));
    fail_unless (gst_structure_get_boolean (s, "episode-over", &over));
    fail_unless_equals_uint64 (dropped, 1);
    fail_unless_equals_uint64 (queued, 10);
    fail_if (over);
    dropped_messages++;
  }
  fail_unless_equals_int (dropped_messages, 1);
  g_list_free_full (elements, (GDestroyNotify) gst_message_unref);

  guint queue_full = 0, unreachable = 0;
  for (l = warnings; l; l = l->next) {
    GError *err = NULL;
    gst_message_parse_warning (l->data, &err, NULL);
    if (strstr (err->message, "the queue is full") &&
        strstr (err->message, "'max-queue-messages' 10"))
      queue_full++;
    if (strstr (err->message, "cannot reach the broker at 127.0.0.1:1"))
      unreachable++;
    g_error_free (err);
  }
  fail_unless_equals_int (queue_full, 1);
  fail_unless (unreachable <= 1);
  g_list_free_full (warnings, (GDestroyNotify) gst_message_unref);

  /* stopping says how many results never left: the 10 kept */
  gst_element_set_state (h->element, GST_STATE_NULL);
  GList *stop = landmark_check_pop_all (bus, GST_MESSAGE_WARNING);
  gboolean said = FALSE;
  for (l = stop; l; l = l->next) {
    GError *err = NULL;
    gst_message_parse_warning (l->data, &err, NULL);
    said |= strstr (err->message, "10 results were not delivered") != NULL;
    g_error_free (err);
  }
  fail_unless (said);
  g_list_free_full (stop, (GDestroyNotify) gst_message_unref);
  GstMessage *error = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (error == NULL, "the element posted an error");

  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bytes_bound)
{
  /* a message here is about 150 bytes: a 1000-byte bound keeps a few */
  GstHarness *h = gst_harness_new_parse (NO_BROKER
      "max-queue-bytes=1000 drain-timeout=0");
  GstBus *bus = gst_bus_new ();
  gst_element_set_bus (h->element, bus);
  gst_harness_set_src_caps_str (h, CAPS_GRAY);
  for (guint i = 0; i < 100; i++)
    gst_buffer_unref (gst_harness_push_and_pull (h, make_frame (i)));
  GstMessage *m = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT);
  while (m && !gst_structure_has_name (gst_message_get_structure (m),
          "landmark-publish-dropped")) {
    gst_message_unref (m);
    m = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT);
  }
  fail_unless (m != NULL, "no landmark-publish-dropped message");
  guint64 queued = 0;
  fail_unless (gst_structure_get_uint64 (gst_message_get_structure (m),
          "queued", &queued));
  fail_unless (queued >= 3 && queued <= 10, "queued %" G_GUINT64_FORMAT,
      queued);
  gst_message_unref (m);
  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_queue_bound_changes_while_playing)
{
  /* the bounds are read per frame: lowering one takes effect at once (the
   * 50 first messages fit the default bound) */
  GstHarness *h = gst_harness_new_parse (NO_BROKER "drain-timeout=0");
  GstBus *bus = gst_bus_new ();
  gst_element_set_bus (h->element, bus);
  gst_harness_set_src_caps_str (h, CAPS_GRAY);
  for (guint i = 0; i < 50; i++)
    gst_buffer_unref (gst_harness_push_and_pull (h, make_frame (i)));
  GstElement *e = gst_harness_find_element (h, "landmarkpublish");
  g_object_set (e, "max-queue-messages", 20, NULL);
  gst_object_unref (e);
  gst_buffer_unref (gst_harness_push_and_pull (h, make_frame (50)));
  GstMessage *m;
  guint64 dropped = 0;
  while ((m = gst_bus_pop_filtered (bus, GST_MESSAGE_ELEMENT))) {
    const GstStructure *s = gst_message_get_structure (m);
    if (gst_structure_has_name (s, "landmark-publish-dropped"))
      fail_unless (gst_structure_get_uint64 (s, "dropped", &dropped));
    gst_message_unref (m);
  }
  /* 51 queued, bound 20: the 31 oldest went */
  fail_unless_equals_uint64 (dropped, 31);
  gst_element_set_bus (h->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (landmarkpublish);
