/* Every element of the gst-landmark plugin through all state changes, in
 * order and out of order, alone and with data flowing through it.
 *
 * The element list comes from the registry, so new elements of the plugin
 * are covered without editing this file. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <glib/gstdio.h>
#include <unistd.h>

#define PLUGIN_NAME "landmark"
/* a state is reached or the element is stuck; under the sanitizers on a
 * loaded 2-core machine a first preroll took over 10 s */
#define STATE_TIMEOUT (40 * GST_SECOND)

/* Names of the element factories of our plugin, sorted; the caller frees
 * the list with g_list_free_full (l, g_free). */
static GList *
plugin_element_names (void)
{
  GstRegistry *registry = gst_registry_get ();
  GstPlugin *plugin = gst_registry_find_plugin (registry, PLUGIN_NAME);
  GList *features, *l, *names = NULL;

  /* g_error, not fail: count_filters calls this outside any test */
  if (plugin == NULL)
    g_error ("plugin '%s' is not in the registry; is GST_PLUGIN_PATH_1_0 "
        "set to the build tree?", PLUGIN_NAME);
  gst_object_unref (plugin);

  features = gst_registry_get_feature_list_by_plugin (registry, PLUGIN_NAME);
  for (l = features; l; l = l->next) {
    if (GST_IS_ELEMENT_FACTORY (l->data))
      names = g_list_insert_sorted (names,
          g_strdup (gst_plugin_feature_get_name (l->data)),
          (GCompareFunc) g_strcmp0);
  }
  gst_plugin_feature_list_free (features);

  /* the list must at least hold the elements we know of */
  if (g_list_find_custom (names, "labsegment", (GCompareFunc) g_strcmp0)
      == NULL)
    g_error ("labsegment is not registered");
  return names;
}

/* Sets the state and waits until it is reached. */
static void
go_to_state (GstElement * element, GstState target)
{
  GstStateChangeReturn ret;
  GstState current = GST_STATE_VOID_PENDING;

  ret = gst_element_set_state (element, target);
  fail_if (ret == GST_STATE_CHANGE_FAILURE, "%s: state change to %s failed",
      GST_OBJECT_NAME (element), gst_element_state_get_name (target));
  ret = gst_element_get_state (element, &current, NULL, STATE_TIMEOUT);
  fail_unless (ret == GST_STATE_CHANGE_SUCCESS ||
      ret == GST_STATE_CHANGE_NO_PREROLL, "%s: %s not reached (%s)",
      GST_OBJECT_NAME (element), gst_element_state_get_name (target),
      gst_element_state_change_return_get_name (ret));
  fail_unless_equals_int (current, target);
}

/* Runs a sequence of target states on every element, `rounds` times. */
static void
cycle_every_element (const GstState * sequence, guint n, guint rounds)
{
  GList *names = plugin_element_names (), *l;

  for (l = names; l; l = l->next) {
    GstElement *element = gst_element_factory_make (l->data, NULL);
    guint r, i;

    fail_unless (element != NULL, "cannot create %s", (gchar *) l->data);
    landmark_check_configure_element (element);
    GST_INFO ("cycling %s", (gchar *) l->data);
    for (r = 0; r < rounds; r++)
      for (i = 0; i < n; i++)
        go_to_state (element, sequence[i]);
    go_to_state (element, GST_STATE_NULL);
    gst_object_unref (element);
  }
  g_list_free_full (names, g_free);
}

LANDMARK_TEST ("general", test_state_changes_up_and_down_seq)
{
  static const GstState seq[] = {
    GST_STATE_READY, GST_STATE_PAUSED, GST_STATE_PLAYING,
    GST_STATE_PAUSED, GST_STATE_READY, GST_STATE_NULL,
  };
  cycle_every_element (seq, G_N_ELEMENTS (seq), 5);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_state_changes_up_seq_down_jumps)
{
  /* up one step at a time, down in single jumps */
  static const GstState seq[] = {
    GST_STATE_READY, GST_STATE_PAUSED, GST_STATE_PLAYING, GST_STATE_NULL,
    GST_STATE_READY, GST_STATE_PAUSED, GST_STATE_NULL,
    GST_STATE_READY, GST_STATE_PAUSED, GST_STATE_PLAYING, GST_STATE_READY,
  };
  cycle_every_element (seq, G_N_ELEMENTS (seq), 3);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_state_changes_jumps)
{
  /* skipping states both ways: the element must handle every transition
   * GstElement walks through on its behalf */
  static const GstState seq[] = {
    GST_STATE_PLAYING, GST_STATE_NULL, GST_STATE_PAUSED, GST_STATE_NULL,
    GST_STATE_PLAYING, GST_STATE_READY, GST_STATE_PLAYING, GST_STATE_PAUSED,
    GST_STATE_PLAYING, GST_STATE_NULL,
  };
  cycle_every_element (seq, G_N_ELEMENTS (seq), 3);
}

GST_END_TEST;

/* Our elements with one always sink and one always src pad, sorted; filled
 * by count_filters once the plugin can be loaded. */
static GList *filter_names;

static gboolean
is_filter (const gchar * name)
{
  GstElementFactory *factory = gst_element_factory_find (name);
  gboolean sink = FALSE, src = FALSE;
  const GList *t;

  for (t = gst_element_factory_get_static_pad_templates (factory); t;
      t = t->next) {
    GstStaticPadTemplate *tmpl = t->data;
    if (tmpl->presence != GST_PAD_ALWAYS)
      continue;
    sink |= tmpl->direction == GST_PAD_SINK;
    src |= tmpl->direction == GST_PAD_SRC;
  }
  gst_object_unref (factory);
  return sink && src;
}

static gint
count_filters (void)
{
  GList *names = plugin_element_names (), *l;

  for (l = names; l; l = l->next)
    if (is_filter (l->data))
      filter_names = g_list_append (filter_names, g_strdup (l->data));
  g_list_free_full (names, g_free);
  if (filter_names == NULL)
    g_error ("the plugin has no filter element");
  return g_list_length (filter_names);
}

/* Each filter in a videotestsrc ! element ! fakesink pipeline, so state
 * changes also happen while buffers flow (caps negotiated, streaming thread
 * running). One test per element: each has the whole per-test time, which
 * under the sanitizers all of them together did not. */
LANDMARK_TEST_LOOP ("streaming", test_state_changes_while_streaming,
    LANDMARK_CHECK_PER_ELEMENT)
{
  static const GstState seq[] = {
    GST_STATE_READY, GST_STATE_PAUSED, GST_STATE_PLAYING,
    GST_STATE_PAUSED, GST_STATE_READY, GST_STATE_PLAYING,
    GST_STATE_NULL,
  };
  const gchar *name = g_list_nth_data (filter_names, __i__);
  gchar *desc;
  GError *err = NULL;
  GstElement *pipeline, *under;
  GstBus *bus;
  GstMessage *msg;
  guint r, i;

  fail_unless (name != NULL);
  if (gst_registry_check_feature_version (gst_registry_get (),
          "videotestsrc", 1, 0, 0) == FALSE) {
    GST_WARNING ("videotestsrc not available; skipping");
    return;
  }
  desc = g_strdup_printf ("videotestsrc ! "
      "video/x-raw,width=160,height=120,framerate=30/1 ! %s name=under "
      "! fakesink sync=true", name);
  pipeline = gst_parse_launch (desc, &err);
  fail_unless (pipeline != NULL, "%s: %s", desc, err ? err->message : "");
  under = gst_bin_get_by_name (GST_BIN (pipeline), "under");
  landmark_check_configure_element (under);
  bus = gst_element_get_bus (pipeline);
  for (r = 0; r < 3; r++) {
    for (i = 0; i < G_N_ELEMENTS (seq); i++) {
      go_to_state (pipeline, seq[i]);
      if (seq[i] == GST_STATE_PLAYING)
        g_usleep (50 * 1000);   /* let a few buffers through */
    }
  }
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  if (msg) {
    GError *error = NULL;
    gchar *debug = NULL;
    gst_message_parse_error (msg, &error, &debug);
    fail ("%s: error while cycling states: %s (%s)", desc,
        error->message, debug ? debug : "");
  }
  gst_object_unref (bus);
  gst_object_unref (under);
  gst_object_unref (pipeline);
  g_free (desc);
}

GST_END_TEST;

/* a folder for the files elements write (landmarklog) */
LANDMARK_CHECK_MAIN (states, .setup = landmark_check_tmp_dir_setup,
    .teardown = landmark_check_tmp_dir_teardown, .elements = count_filters);
