/* Helpers shared by the GstHarness tests (landmarkcheck.h). */
#include "landmarkcheck.h"

#include <glib/gstdio.h>
#include <math.h>
#include <gst/video/video.h>
#include <string.h>
#include <unistd.h>

/* ---- tests and the suite --------------------------------------------- */

typedef struct
{
  const gchar *tcase;
  TFun func;
  const gchar *name;
  gint loops, line;
} Registered;

/* filled by the constructors of LANDMARK_TEST, before main () */
static GArray *registered;

void
landmark_check_register (const gchar * tcase, TFun func, const gchar * name,
    gint loops, gint line)
{
  Registered r = { tcase, func, name, loops, line };
  if (!registered)
    registered = g_array_new (FALSE, FALSE, sizeof (Registered));
  g_array_append_val (registered, r);
}

/* the order constructors run in is not specified: the file's order */
static gint
by_line (gconstpointer a, gconstpointer b)
{
  return ((const Registered *) a)->line - ((const Registered *) b)->line;
}

int
landmark_check_run (int *argc, char ***argv, const gchar * name,
    const LandmarkCheckOptions * opt)
{
  Suite *s;
  GHashTable *cases = g_hash_table_new (g_str_hash, g_str_equal);
  gint elements = -1;
  guint i;
  int ret;

  gst_check_init (argc, argv);
  s = suite_create (name);
  g_assert (registered != NULL);
  g_array_sort (registered, by_line);
  for (i = 0; i < registered->len; i++) {
    const Registered *r = &g_array_index (registered, Registered, i);
    TCase *tc = g_hash_table_lookup (cases, r->tcase);
    gint loops = r->loops;
    if (!tc) {
      tc = tcase_create (r->tcase);
      if (opt->timeout)
        tcase_set_timeout (tc, opt->timeout);
      if (opt->setup || opt->teardown) {
        if (opt->checked)
          tcase_add_checked_fixture (tc, opt->setup, opt->teardown);
        else
          tcase_add_unchecked_fixture (tc, opt->setup, opt->teardown);
      }
      suite_add_tcase (s, tc);
      g_hash_table_insert (cases, (gpointer) r->tcase, tc);
    }
    if (loops == LANDMARK_CHECK_PER_ELEMENT) {
      g_assert (opt->elements != NULL);
      if (elements < 0)
        elements = opt->elements ();
      loops = elements;
    }
    /* through gstcheck's wrapper, so GST_CHECKS still picks tests */
    _tcase_add_test (tc, r->func, r->name, 0, 0, 0, loops);
  }
  g_hash_table_unref (cases);
  ret = gst_check_run_suite (s, name, __FILE__);
  return ret;
}

/* ---- metadata made by hand ------------------------------------------- */

const gchar *landmark_check_names7[7] = { "red", "green", "yellow", "pink",
  "blue", "white", "grey"
};

const gboolean landmark_check_markers7[7] = { TRUE, TRUE, TRUE, TRUE, TRUE,
  FALSE, FALSE
};

GstStructure *
landmark_check_meta_add (GstBuffer * buf, const gchar * name)
{
  GstCustomMeta *m = gst_buffer_add_custom_meta (buf, name);
  /* fail () only when it fails: tests/bench/element-cost.c, which runs no
   * check suite, uses this too */
  if (m == NULL)
    fail ("%s is not registered: plugin not loaded?", name);
  return gst_custom_meta_get_structure (m);
}

void
landmark_check_set_array (GstStructure * s, const gchar * field, GType type,
    gconstpointer values, guint n)
{
  GValue a = G_VALUE_INIT;
  guint i;
  gst_value_array_init (&a, n);
  for (i = 0; i < n; i++) {
    GValue x = G_VALUE_INIT;
    g_value_init (&x, type);
    if (type == G_TYPE_STRING)
      g_value_set_string (&x, ((const gchar * const *) values)[i]);
    else if (type == G_TYPE_BOOLEAN)
      g_value_set_boolean (&x, ((const gboolean *) values)[i]);
    else if (type == G_TYPE_INT)
      g_value_set_int (&x, ((const gint *) values)[i]);
    else if (type == G_TYPE_UINT)
      g_value_set_uint (&x, ((const guint *) values)[i]);
    else if (type == G_TYPE_FLOAT)
      g_value_set_float (&x, ((const gfloat *) values)[i]);
    else if (type == G_TYPE_DOUBLE)
      g_value_set_double (&x, ((const gdouble *) values)[i]);
    else
      g_assert_not_reached ();
    gst_value_array_append_and_take_value (&a, &x);
  }
  gst_structure_take_value (s, field, &a);
}

GstStructure *
landmark_check_labels_attach (GstBuffer * buf, const guint8 * plane, guint w,
    guint h, guint stride, const gchar ** names, const gboolean * markers,
    guint n)
{
  GstStructure *s = landmark_check_meta_add (buf, LANDMARK_LABELS_META);
  GstBuffer *pb = gst_buffer_new_memdup (plane, (gsize) MAX (stride * h, 1));
  gst_structure_set (s, "labels", GST_TYPE_BUFFER, pb,
      "width", G_TYPE_UINT, w, "height", G_TYPE_UINT, h,
      "stride", G_TYPE_UINT, stride,
      "analysis-width", G_TYPE_UINT, w,
      "analysis-height", G_TYPE_UINT, h, NULL);
  gst_buffer_unref (pb);
  landmark_check_set_array (s, "class-names", G_TYPE_STRING, names, n);
  landmark_check_set_array (s, "class-markers", G_TYPE_BOOLEAN, markers, n);
  return s;
}

/* A floor-meta array field holding a copy of n bytes. */
void
landmark_check_floor_array (GstStructure * s, const gchar * field, gconstpointer data,
    gsize n)
{
  GstBuffer *copy = gst_buffer_new_memdup (data, n);
  gst_structure_set (s, field, GST_TYPE_BUFFER, copy, NULL);
  gst_buffer_unref (copy);
}

#define WALL_COLUMNS 81
#define WALL_BINS 360

/* A floor meta whose boundary is a wall across the view at x = wall
 * metres (81 columns from y = 1 to -1, obstacle), and its ROP: the bins
 * within 30 degrees of ahead end at the wall, the others unseen. */
void
landmark_check_floor_wall_attach (GstBuffer * buf, gdouble wall)
{
  GstStructure *s = landmark_check_meta_add (buf, LANDMARK_FLOOR_META);
  gfloat row[WALL_COLUMNS], bx[WALL_COLUMNS], by[WALL_COLUMNS];
  gfloat range[WALL_BINS];
  guint8 cstate[WALL_COLUMNS], bstate[WALL_BINS];
  guint k;
  for (k = 0; k < WALL_COLUMNS; k++) {
    row[k] = 200;
    bx[k] = wall;
    by[k] = 1.0 - 2.0 * k / (WALL_COLUMNS - 1);
    cstate[k] = 2;
  }
  for (k = 0; k < WALL_BINS; k++) {
    /* bin k is centred on k degrees to the left */
    const gdouble phi = (k <= 180 ? k : k - 360.0) * G_PI / 180;
    const gboolean seen = fabs (phi) <= 30 * G_PI / 180;
    range[k] = seen ? wall / cos (phi) : 0;
    bstate[k] = seen ? 2 : 0;
  }
  gst_structure_set (s, "width", G_TYPE_UINT, WALL_COLUMNS, "height",
      G_TYPE_UINT, 480, "bearing-bins", G_TYPE_UINT, WALL_BINS, "bin-width",
      G_TYPE_DOUBLE, 2 * G_PI / WALL_BINS, "max-range", G_TYPE_DOUBLE, 4.0,
      NULL);
  landmark_check_floor_array (s, "boundary-row", row, sizeof (row));
  landmark_check_floor_array (s, "boundary-x", bx, sizeof (bx));
  landmark_check_floor_array (s, "boundary-y", by, sizeof (by));
  landmark_check_floor_array (s, "boundary-state", cstate, sizeof (cstate));
  landmark_check_floor_array (s, "rop-range", range, sizeof (range));
  landmark_check_floor_array (s, "rop-state", bstate, sizeof (bstate));
}

/* A detection of class cls that ipmrange placed at (x, y) metres with the
 * map's diameter (0: none given); blobroundness kept it or not;
 * trilaterate matched it to id (NULL: not matched). */
void
landmark_check_ranged_attach (GstBuffer * buf, const gchar * cls, gdouble x, gdouble y,
    gdouble diameter, gboolean kept, const gchar * id)
{
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, cls, 300, 200, 20,
      12);
  GstStructure *range = gst_structure_new ("landmark-range", "range",
      G_TYPE_DOUBLE, hypot (x, y), "bearing", G_TYPE_DOUBLE, atan2 (y, x),
      "ground-x", G_TYPE_DOUBLE, x, "ground-y", G_TYPE_DOUBLE, y,
      "no-floor", G_TYPE_BOOLEAN, FALSE, "kept", G_TYPE_BOOLEAN, TRUE, NULL);
  if (diameter > 0)
    gst_structure_set (range, "marker-diameter", G_TYPE_DOUBLE, diameter,
        "marker-height", G_TYPE_DOUBLE, 0.0, "marker-kind", G_TYPE_STRING,
        "disc", NULL);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, cls,
          "kept", G_TYPE_BOOLEAN, kept, NULL));
  gst_video_region_of_interest_meta_add_param (roi, range);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-match", "matched", G_TYPE_BOOLEAN,
          id != NULL, "landmark-id", G_TYPE_STRING, id, NULL));
}

GstBuffer *
landmark_check_frame_new (gsize size, guint n)
{
  GstBuffer *b = gst_buffer_new_and_alloc (size);
  GST_BUFFER_PTS (b) = gst_util_uint64_scale (n, GST_SECOND, 30);
  GST_BUFFER_DURATION (b) = GST_SECOND / 30;
  return b;
}

const GstStructure *
landmark_check_roi_param (GstBuffer * buf, gint id, const gchar * name)
{
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_get_video_region_of_interest_meta_id (buf, id);
  fail_unless (roi != NULL, "no region of interest %d", id);
  return gst_video_region_of_interest_meta_get_param (roi, name);
}

/* ---- colour ---------------------------------------------------------- */

static gdouble
cie_f_inverse (gdouble f)
{
  const gdouble d = 6.0 / 29.0;
  return f > d ? f * f * f : 3.0 * d * d * (f - 4.0 / 29.0);
}

static gdouble
srgb_encode (gdouble v)
{
  v = CLAMP (v, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * pow (v, 1.0 / 2.4) - 0.055;
}

/* CIE L*a*b* (D65) -> 0xRRGGBB, each linear component clipped */
guint
landmark_check_lab_to_rgb24 (const gdouble lab[3])
{
  const gdouble fy = (lab[0] + 16.0) / 116.0;
  const gdouble x = 0.95047 * cie_f_inverse (fy + lab[1] / 500.0);
  const gdouble y = cie_f_inverse (fy);
  const gdouble z = 1.08883 * cie_f_inverse (fy - lab[2] / 200.0);
  const gdouble r = 3.2404542 * x - 1.5371385 * y - 0.4985314 * z;
  const gdouble g = -0.9692660 * x + 1.8760108 * y + 0.0415560 * z;
  const gdouble b = 0.0556434 * x - 0.2040259 * y + 1.0572252 * z;
  return ((guint) lround (255.0 * srgb_encode (r)) << 16) |
      ((guint) lround (255.0 * srgb_encode (g)) << 8) |
      (guint) lround (255.0 * srgb_encode (b));
}

/* ---- running elements ------------------------------------------------ */

GstElement *
landmark_check_element (const gchar * desc)
{
  GError *err = NULL;
  /* one element: gst_parse_launch returns it, properties set */
  GstElement *e = gst_parse_launch (desc, &err);
  if (e == NULL || err != NULL)
    fail ("%s: %s", desc, err ? err->message : "?");
  return e;
}

GstHarness *
landmark_check_harness_new (const gchar * desc, const gchar * caps)
{
  GstElement *e = landmark_check_element (desc);
  GstHarness *h = gst_harness_new_with_element (e, "sink", "src");
  gst_object_unref (e);
  if (caps)
    gst_harness_set_src_caps_str (h, caps);
  return h;
}

void
landmark_check_no_frame_dropped (GstHarness * h, GstBuffer * templ, guint n,
    const gchar * meta)
{
  guint i;
  fail_unless (gst_harness_push_upstream_event (h,
          gst_event_new_qos (GST_QOS_TYPE_UNDERFLOW, 2.0, 60 * GST_SECOND,
              0)));
  for (i = 0; i < n; i++) {
    GstBuffer *in = gst_buffer_copy (templ);
    GST_BUFFER_PTS (in) = i * 40 * GST_MSECOND;
    GST_BUFFER_DURATION (in) = 40 * GST_MSECOND;
    fail_unless_equals_int (gst_harness_push (h, in), GST_FLOW_OK);
  }
  for (i = 0; i < n; i++) {
    GstBuffer *out = gst_harness_try_pull (h);
    fail_unless (out != NULL, "only %u of %u buffers came out", i, n);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * 40 * GST_MSECOND);
    fail_unless (!meta || gst_buffer_get_custom_meta (out, meta) != NULL,
        "buffer %u has no %s", i, meta);
    gst_buffer_unref (out);
  }
  fail_unless (gst_harness_try_pull (h) == NULL);
  fail_unless_equals_int (gst_harness_buffers_received (h), n);
}

GstBus *
landmark_check_bus_attach (GstElement * e)
{
  GstBus *bus = gst_bus_new ();
  gst_element_set_bus (e, bus);
  return bus;
}

void
landmark_check_bus_detach (GstElement * e, GstBus * bus)
{
  gst_element_set_bus (e, NULL);
  gst_object_unref (bus);
}

guint
landmark_check_count_messages (GstBus * bus, GstMessageType type,
    GError ** first)
{
  GstMessage *msg;
  guint n = 0;
  while ((msg = gst_bus_pop_filtered (bus, type))) {
    if (n == 0 && first) {
      if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_WARNING)
        gst_message_parse_warning (msg, first, NULL);
      else if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR)
        gst_message_parse_error (msg, first, NULL);
    }
    n++;
    gst_message_unref (msg);
  }
  return n;
}

GList *
landmark_check_pop_all (GstBus * bus, GstMessageType types)
{
  GList *out = NULL;
  GstMessage *m;
  while ((m = gst_bus_pop_filtered (bus, types)))
    out = g_list_append (out, m);
  return out;
}

void
landmark_check_configure_element (GstElement * e)
{
  static gint counter = 0;
  GParamSpec *p = g_object_class_find_property (G_OBJECT_GET_CLASS (e),
      "location");
  GstElementFactory *f = gst_element_get_factory (e);
  if (p && G_PARAM_SPEC_VALUE_TYPE (p) == G_TYPE_STRING) {
    gchar *name = g_strdup_printf ("%s-%d-%d.out", GST_OBJECT_NAME (e),
        (gint) getpid (), g_atomic_int_add (&counter, 1));
    gchar *path = g_build_filename (landmark_check_tmp_dir, name, NULL);
    g_assert (landmark_check_tmp_dir != NULL);
    g_object_set (e, "location", path, NULL);
    g_object_set_data_full (G_OBJECT (e), LANDMARK_CHECK_FILE, path, g_free);
    g_free (name);
  }
  if (f && !g_strcmp0 (GST_OBJECT_NAME (f), "trilaterate"))
    g_object_set (e, "map", GST_TEST_FILES_PATH "/clips/path-small/map.json",
        NULL);
}

void
landmark_check_bad_settings (const gchar * factory,
    const gchar * const *settings)
{
  for (; *settings; settings++) {
    gchar **words = g_strsplit (*settings, ";", -1);
    gchar **kv = NULL, *named;
    guint i, in_ready;

    /* set in NULL the values fail READY; set in READY, they fail PAUSED */
    for (in_ready = 0; in_ready < 2; in_ready++) {
      GstElement *e = gst_element_factory_make (factory, NULL);
      fail_unless (e != NULL, "no element %s", factory);
      if (in_ready)
        fail_unless_equals_int (gst_element_set_state (e, GST_STATE_READY),
            GST_STATE_CHANGE_SUCCESS);
      for (i = 0; words[i]; i++) {
        g_strfreev (kv);
        kv = g_strsplit (words[i], "=", 2);
        fail_unless (kv[0] && kv[1], "not property=value: %s", words[i]);
        gst_util_set_object_arg (G_OBJECT (e), kv[0], kv[1]);
      }
      g_strfreev (kv);
      kv = g_strsplit (words[0], "=", 2);
      named = g_strdup_printf ("'%s'", kv[0]);
      /* refused, then refused again when tried again (no bus yet: the
       * first error is dropped) */
      if (in_ready)
        fail_unless_equals_int (gst_element_set_state (e, GST_STATE_PAUSED),
            GST_STATE_CHANGE_FAILURE);
      landmark_check_start_fails (e,
          in_ready ? GST_STATE_PAUSED : GST_STATE_READY,
          LANDMARK_CHECK_IN_MESSAGE, named, NULL);
      g_free (named);
      g_strfreev (kv);
      kv = NULL;
    }
    g_strfreev (words);
  }
}

void
landmark_check_refuses_paused (GstElement * e, GstBus * bus)
{
  gst_element_set_bus (e, bus);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_READY),
      GST_STATE_CHANGE_SUCCESS);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_PAUSED),
      GST_STATE_CHANGE_FAILURE);
}

void
landmark_check_refuses_ready (GstElement * e, GstBus * bus)
{
  gst_element_set_bus (e, bus);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_READY),
      GST_STATE_CHANGE_FAILURE);
}

void
landmark_check_fixed_setting_starts (GstElement * e, GstBus * bus,
    const gchar * property, const gchar * value)
{
  g_object_set (e, property, value, NULL);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_PAUSED),
      GST_STATE_CHANGE_SUCCESS);
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR) == NULL);
  fail_unless_equals_int (gst_element_set_state (e, GST_STATE_NULL),
      GST_STATE_CHANGE_SUCCESS);
  gst_element_set_bus (e, NULL);
  gst_object_unref (bus);
  gst_object_unref (e);
}

static gboolean
has_words (const gchar * text, const gchar * what, const gchar * also)
{
  return text && strstr (text, what) && (!also || strstr (text, also));
}

void
landmark_check_start_fails (GstElement * e, GstState state,
    LandmarkCheckWhere where, const gchar * what, const gchar * also)
{
  GstBus *bus = gst_bus_new ();
  GstMessage *msg;
  GError *err = NULL;
  gchar *dbg = NULL;
  gboolean found;

  fail_unless (e != NULL);
  gst_element_set_bus (e, bus);
  fail_unless_equals_int (gst_element_set_state (e, state),
      GST_STATE_CHANGE_FAILURE);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL, "no error from %s", GST_OBJECT_NAME (e));
  gst_message_parse_error (msg, &err, &dbg);
  gst_message_unref (msg);
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_ERROR, NULL), 0);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS), "%s", err->message);
  found = (where != LANDMARK_CHECK_IN_DEBUG &&
      has_words (err->message, what, also)) ||
      (where != LANDMARK_CHECK_IN_MESSAGE && has_words (dbg, what, also));
  fail_unless (found, "'%s' / '%s' not in '%s' / '%s'", what,
      also ? also : "", err->message, dbg ? dbg : "");
  g_error_free (err);
  g_free (dbg);
  gst_element_set_state (e, GST_STATE_NULL);
  gst_element_set_bus (e, NULL);
  gst_object_unref (bus);
  gst_object_unref (e);
}

/* ---- files ----------------------------------------------------------- */

gchar *landmark_check_tmp_dir;

void
landmark_check_tmp_dir_setup (void)
{
  GError *err = NULL;
  landmark_check_tmp_dir = g_dir_make_tmp ("landmark-check-XXXXXX", &err);
  fail_unless (landmark_check_tmp_dir != NULL, "%s",
      err ? err->message : "?");
}

static void
remove_tree (const gchar * dir)
{
  GDir *d = g_dir_open (dir, 0, NULL);
  const gchar *name;
  while (d && (name = g_dir_read_name (d))) {
    gchar *p = g_build_filename (dir, name, NULL);
    if (g_file_test (p, G_FILE_TEST_IS_DIR)) {
      /* tests make unwritable folders to see writes fail */
      g_chmod (p, 0700);
      remove_tree (p);
    } else {
      g_remove (p);
    }
    g_free (p);
  }
  if (d)
    g_dir_close (d);
  g_rmdir (dir);
}

void
landmark_check_tmp_dir_teardown (void)
{
  remove_tree (landmark_check_tmp_dir);
  g_clear_pointer (&landmark_check_tmp_dir, g_free);
}

gchar *
landmark_check_write_tmp (const gchar * prefix, const gchar * suffix,
    const gchar * text)
{
  gchar *tmpl = g_strconcat (prefix, "-XXXXXX", suffix, NULL);
  gchar *path = NULL;
  GError *err = NULL;
  gint fd = g_file_open_tmp (tmpl, &path, &err);
  fail_unless (fd >= 0, "%s", err ? err->message : "?");
  g_close (fd, NULL);
  fail_unless (g_file_set_contents (path, text, -1, &err), "%s: %s", path,
      err ? err->message : "?");
  g_free (tmpl);
  return path;
}
