/* Unit tests of landmarklog.
 *
 * The expectations are independent of the element: metas are built here
 * by hand (custom metas by name, region-of-interest metas with the video
 * library), the file is read back and parsed with json-glib, and every value
 * is compared with what the test put on the buffer. Real pipelines
 * (videotestsrc ! labsegment ! landmarklog) are checked against the metas
 * seen by a sink after the logger. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <json-glib/json-glib.h>

#include <errno.h>
#include <math.h>
#include <string.h>
#include <glib/gstdio.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#define LABELS_META "GstLandmarkLabelsMeta"
#define POSE_META "GstLandmarkPoseMeta"
#define CAPS_GRAY "video/x-raw,format=GRAY8,width=8,height=4,framerate=25/1"
#define FRAME_SIZE 32
#define WAIT (10 * GST_SECOND)

/* ------------------------------------------------------------------ */
/* Files                                                              */
/* ------------------------------------------------------------------ */

/* the paths tmp_file gave out, freed when the test ends */
static GPtrArray *tmp_paths;
/* the log file of the test (each test has its own folder) */
static const gchar *log_path;

/* The path of a file in the test's folder, valid until the test ends. */
static const gchar *
tmp_file (const gchar * name)
{
  gchar *path = g_build_filename (landmark_check_tmp_dir, name, NULL);
  g_ptr_array_add (tmp_paths, path);
  return path;
}

static void
setup (void)
{
  landmark_check_tmp_dir_setup ();
  tmp_paths = g_ptr_array_new_with_free_func (g_free);
  log_path = tmp_file ("log.jsonl");
}

static void
teardown (void)
{
  g_clear_pointer (&tmp_paths, g_ptr_array_unref);
  landmark_check_tmp_dir_teardown ();
}

/* A log file read back: every line parsed (the test fails on the first
 * line that is not a JSON object) and the file must end with a newline. */
typedef struct
{
  gchar *text;
  gsize size;
  guint n;
  JsonNode **nodes;
} LogFile;

static void
log_read (const gchar * path, LogFile * lf)
{
  GError *err = NULL;
  gchar **lines;
  guint i;

  memset (lf, 0, sizeof (*lf));
  fail_unless (g_file_get_contents (path, &lf->text, &lf->size, &err),
      "%s: %s", path, err ? err->message : "?");
  fail_unless (lf->size == 0 || lf->text[lf->size - 1] == '\n',
      "%s does not end with a complete line", path);
  fail_unless (strlen (lf->text) == lf->size, "NUL byte in %s", path);
  lines = g_strsplit (lf->text, "\n", -1);
  /* after the last newline: "" (and g_strsplit gives nothing for "") */
  lf->n = lf->size ? g_strv_length (lines) - 1 : 0;
  lf->nodes = g_new0 (JsonNode *, lf->n + 1);
  for (i = 0; i < lf->n; i++) {
    lf->nodes[i] = json_from_string (lines[i], &err);
    fail_unless (lf->nodes[i] != NULL, "%s line %u is not JSON: %s\n%s",
        path, i + 1, err ? err->message : "?", lines[i]);
    fail_unless (JSON_NODE_HOLDS_OBJECT (lf->nodes[i]),
        "%s line %u is not an object", path, i + 1);
  }
  g_strfreev (lines);
}

static void
log_clear (LogFile * lf)
{
  guint i;
  for (i = 0; i < lf->n; i++)
    json_node_unref (lf->nodes[i]);
  g_free (lf->nodes);
  g_free (lf->text);
  memset (lf, 0, sizeof (*lf));
}

static JsonObject *
log_line (const LogFile * lf, guint i)
{
  fail_unless (i < lf->n);
  return json_node_get_object (lf->nodes[i]);
}

static gsize
file_size (const gchar * path)
{
  GStatBuf st;
  fail_unless (g_stat (path, &st) == 0, "%s: %s", path, g_strerror (errno));
  return st.st_size;
}

/* ------------------------------------------------------------------ */
/* JSON checks                                                        */
/* ------------------------------------------------------------------ */

static JsonNode *
member (JsonObject * o, const gchar * key)
{
  JsonNode *n = json_object_get_member (o, key);
  fail_unless (n != NULL, "member \"%s\" missing", key);
  return n;
}

/* The member key, a JSON value of the given type (what: its name). */
static JsonNode *
value_member (JsonObject * o, const gchar * key, GType type,
    const gchar * what)
{
  JsonNode *n = member (o, key);
  fail_unless (JSON_NODE_HOLDS_VALUE (n) &&
      json_node_get_value_type (n) == type, "\"%s\" is not %s", key, what);
  return n;
}

static gint64
get_int (JsonObject * o, const gchar * key)
{
  JsonNode *n = value_member (o, key, G_TYPE_INT64, "an integer");
  return json_node_get_int (n);
}

/* exact comparison: the log must read back to the very same double */
static void
check_double (JsonObject * o, const gchar * key, gdouble expected)
{
  JsonNode *n = value_member (o, key, G_TYPE_DOUBLE, "a floating-point number");
  fail_unless (json_node_get_double (n) == expected,
      "\"%s\": %.17g, expected %.17g", key, json_node_get_double (n),
      expected);
}

static void
check_bool (JsonObject * o, const gchar * key, gboolean expected)
{
  JsonNode *n = value_member (o, key, G_TYPE_BOOLEAN, "a boolean");
  fail_unless_equals_int (json_node_get_boolean (n), expected);
}

static void
check_string (JsonObject * o, const gchar * key, const gchar * expected)
{
  JsonNode *n = value_member (o, key, G_TYPE_STRING, "a string");
  fail_unless_equals_string (json_node_get_string (n), expected);
}

static void
check_null (JsonObject * o, const gchar * key)
{
  fail_unless (JSON_NODE_HOLDS_NULL (member (o, key)), "\"%s\" is not null",
      key);
}

static JsonArray *
get_array (JsonObject * o, const gchar * key, guint length)
{
  JsonNode *n = member (o, key);
  JsonArray *a;
  fail_unless (JSON_NODE_HOLDS_ARRAY (n), "\"%s\" is not an array", key);
  a = json_node_get_array (n);
  fail_unless_equals_int (json_array_get_length (a), length);
  return a;
}

/* The member key, an array of exactly these n booleans (JSON true and
 * false, not numbers). */
static void
check_bool_array (JsonObject * o, const gchar * key, const gboolean * want,
    guint n)
{
  JsonArray *a = get_array (o, key, n);
  guint i;
  for (i = 0; i < n; i++) {
    JsonNode *e = json_array_get_element (a, i);
    fail_unless (JSON_NODE_HOLDS_VALUE (e) &&
        json_node_get_value_type (e) == G_TYPE_BOOLEAN,
        "%s[%u] is not a boolean", key, i);
    fail_unless_equals_int (json_node_get_boolean (e), want[i]);
  }
}

/* The member key, an array of exactly these n unsigned integers. */
static void
check_uint_array (JsonObject * o, const gchar * key, const guint * want,
    guint n)
{
  JsonArray *a = get_array (o, key, n);
  guint i;
  for (i = 0; i < n; i++)
    fail_unless_equals_int64 (json_array_get_int_element (a, i), want[i]);
}

static JsonObject *
get_object (JsonObject * o, const gchar * key)
{
  JsonNode *n = member (o, key);
  fail_unless (JSON_NODE_HOLDS_OBJECT (n), "\"%s\" is not an object", key);
  return json_node_get_object (n);
}

/* The members of o, sorted and joined with ',' (to assert exact key sets) */
static gchar *
keys_of (JsonObject * o)
{
  GList *keys = json_object_get_members (o), *l;
  GString *s = g_string_new (NULL);
  keys = g_list_sort (keys, (GCompareFunc) g_strcmp0);
  for (l = keys; l; l = l->next)
    g_string_append_printf (s, "%s%s", s->len ? "," : "", (gchar *) l->data);
  g_list_free (keys);
  return g_string_free (s, FALSE);
}

static void
check_keys (JsonObject * o, const gchar * expected)
{
  gchar *k = keys_of (o);
  fail_unless_equals_string (k, expected);
  g_free (k);
}

/* ------------------------------------------------------------------ */
/* Buffers and metas                                                  */
/* ------------------------------------------------------------------ */

static GstBuffer *
frame_new (guint i)
{
  GstBuffer *buf = gst_buffer_new_allocate (NULL, FRAME_SIZE, NULL);
  GstMapInfo map;
  guint k;
  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  for (k = 0; k < FRAME_SIZE; k++)
    map.data[k] = (guint8) (i * 7 + k);
  gst_buffer_unmap (buf, &map);
  GST_BUFFER_PTS (buf) = i * 40 * GST_MSECOND;
  GST_BUFFER_DURATION (buf) = 40 * GST_MSECOND;
  return buf;
}

static GstVideoRegionOfInterestMeta *
roi_add (GstBuffer * buf, const gchar * cls, gint id, guint x, guint y,
    guint w, guint h)
{
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buf, cls, x, y, w, h);
  fail_unless (roi != NULL);
  roi->id = id;
  return roi;
}

/* ------------------------------------------------------------------ */
/* Running the element                                                */
/* ------------------------------------------------------------------ */

/* The element with its properties set before it starts, in a harness
 * with `caps` (NULL: CAPS_GRAY) on its input. */
static GstHarness *
log_harness_full (const gchar * path, const gchar * caps, gboolean append)
{
  GstElement *e = gst_element_factory_make ("landmarklog", NULL);
  GstHarness *h;
  fail_unless (e != NULL, "landmarklog not found");
  g_object_set (e, "location", path, "append", append, NULL);
  h = gst_harness_new_with_element (e, "sink", "src");
  gst_object_unref (e);
  gst_harness_set_src_caps_str (h, caps ? caps : CAPS_GRAY);
  return h;
}

static GstHarness *
log_harness (const gchar * path, const gchar * caps)
{
  return log_harness_full (path, caps, FALSE);
}

static void
push_eos (GstHarness * h)
{
  fail_unless (gst_harness_push_event (h, gst_event_new_eos ()));
}

/* Pushes frames first .. first + n - 1, each accepted. */
static void
push_frames (GstHarness * h, guint first, guint n)
{
  guint i;
  for (i = first; i < first + n; i++)
    fail_unless_equals_int (gst_harness_push (h, frame_new (i)), GST_FLOW_OK);
}

/* Runs a launch line to EOS (or fails on ERROR or timeout). If `keep` is
 * set the pipeline is returned still PLAYING, otherwise it is freed. */
static GstElement *
run_to_eos (const gchar * desc, gboolean keep)
{
  GError *err = NULL;
  GstElement *pipe = gst_parse_launch (desc, &err);
  GstBus *bus;
  GstMessage *msg;

  fail_unless (pipe != NULL, "%s: %s", desc, err ? err->message : "?");
  bus = gst_element_get_bus (pipe);
  fail_if (gst_element_set_state (pipe, GST_STATE_PLAYING) ==
      GST_STATE_CHANGE_FAILURE, "%s: cannot start", desc);
  msg = gst_bus_timed_pop_filtered (bus, WAIT,
      GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  fail_unless (msg != NULL, "%s: timeout", desc);
  if (GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR) {
    GError *e = NULL;
    gchar *dbg = NULL;
    gst_message_parse_error (msg, &e, &dbg);
    fail ("%s: %s (%s)", desc, e->message, dbg ? dbg : "");
  }
  gst_message_unref (msg);
  gst_object_unref (bus);
  if (keep)
    return pipe;
  gst_element_set_state (pipe, GST_STATE_NULL);
  gst_object_unref (pipe);
  return NULL;
}

/* ------------------------------------------------------------------ */
/* Tests                                                              */
/* ------------------------------------------------------------------ */

/* The element's location, append and flush-every are these. */
static void
check_properties (GstElement * e, const gchar * location, gboolean append,
    guint every)
{
  gchar *loc = (gchar *) "x";
  gboolean app = !append;
  guint ev = every + 1;
  g_object_get (e, "location", &loc, "append", &app, "flush-every", &ev,
      NULL);
  fail_unless_equals_string (loc, location);
  fail_unless_equals_int (app, append);
  fail_unless_equals_int (ev, every);
  g_free (loc);
}

LANDMARK_TEST ("format", test_properties)
{
  GstElement *e = gst_element_factory_make ("landmarklog", NULL);

  fail_unless (e != NULL);
  check_properties (e, NULL, FALSE, 0);
  g_object_set (e, "location", "/some/file.jsonl", "append", TRUE,
      "flush-every", 5, NULL);
  check_properties (e, "/some/file.jsonl", TRUE, 5);
  gst_object_unref (e);
}

GST_END_TEST;

/* N buffers in, N lines out, in order, with their timestamps; buffers
 * without timestamps have no pts/duration keys. */
LANDMARK_TEST ("format", test_every_frame_in_order)
{
  GstHarness *h = log_harness (log_path, NULL);
  const guint n = 40;
  LogFile lf;
  guint i;

  for (i = 0; i < n; i++) {
    GstBuffer *buf = frame_new (i);
    if (i == 10)
      GST_BUFFER_PTS (buf) = GST_CLOCK_TIME_NONE;
    if (i == 10 || i == 20)
      GST_BUFFER_DURATION (buf) = GST_CLOCK_TIME_NONE;
    fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
  }
  push_eos (h);
  for (i = 0; i < n; i++) {
    GstBuffer *out = gst_harness_pull (h);
    if (i != 10)
      fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * 40 * GST_MSECOND);
    gst_buffer_unref (out);
  }

  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, n);
  for (i = 0; i < n; i++) {
    JsonObject *o = log_line (&lf, i);
    fail_unless_equals_int (get_int (o, "frame"), i);
    if (i == 10) {
      check_keys (o, "detections,frame,height,width");
    } else if (i == 20) {
      check_keys (o, "detections,frame,height,pts,width");
      fail_unless_equals_int64 (get_int (o, "pts"), i * 40 * GST_MSECOND);
    } else {
      check_keys (o, "detections,duration,frame,height,pts,width");
      fail_unless_equals_int64 (get_int (o, "pts"), i * 40 * GST_MSECOND);
      fail_unless_equals_int64 (get_int (o, "duration"), 40 * GST_MSECOND);
    }
    fail_unless_equals_int (get_int (o, "width"), 8);
    fail_unless_equals_int (get_int (o, "height"), 4);
    get_array (o, "detections", 0);
  }
  /* the key order of the documented format */
  fail_unless (g_str_has_prefix (lf.text, "{\"frame\": 0, \"pts\": 0, "
          "\"duration\": 40000000, \"width\": 8, \"height\": 4, "
          "\"detections\": []}\n"));
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* Buffers come out as the same objects, with the same bytes and metas,
 * whatever video caps they carry; width/height follow the caps. */
static const struct
{
  const gchar *caps;
  gint width, height;
} any_caps[] = {
  {CAPS_GRAY, 8, 4},
  {"video/x-raw,format=I420,width=321,height=241,framerate=30/1", 321, 241},
  {"video/x-raw,format=GRAY16_LE,width=5,height=3", 5, 3},
  {"video/x-raw(memory:SystemMemory,meta:GstVideoOverlayComposition),"
        "format=BGRx,width=2,height=2", 2, 2},
  {"video/x-raw(memory:NotReallyDMABuf),format=NV12,width=1920,height=1080",
      1920, 1080},
};

LANDMARK_TEST_LOOP ("format", test_passthrough_unchanged,
    G_N_ELEMENTS (any_caps))
{
  GstHarness *h = log_harness (log_path, any_caps[__i__].caps);
  LogFile lf;
  guint i;

  for (i = 0; i < 3; i++) {
    GstBuffer *in = frame_new (i), *out;
    GstMapInfo map;
    guint8 before[FRAME_SIZE];
    guint n_meta = 0;
    gpointer state = NULL;

    roi_add (in, "red", 0, 1, 2, 3, 4);
    gst_buffer_extract (in, 0, before, FRAME_SIZE);
    /* keep a reference: the buffer is not writable, so any copy or
     * modification would show as a different buffer */
    gst_buffer_ref (in);
    fail_unless_equals_int (gst_harness_push (h, in), GST_FLOW_OK);
    out = gst_harness_pull (h);
    fail_unless (out == in, "a different buffer came out");
    fail_unless (gst_buffer_map (out, &map, GST_MAP_READ));
    fail_unless_equals_int (map.size, FRAME_SIZE);
    fail_unless (memcmp (map.data, before, FRAME_SIZE) == 0);
    gst_buffer_unmap (out, &map);
    while (gst_buffer_iterate_meta (out, &state))
      n_meta++;
    fail_unless_equals_int (n_meta, 1);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * 40 * GST_MSECOND);
    gst_buffer_unref (out);
    gst_buffer_unref (in);
  }
  push_eos (h);

  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, 3);
  for (i = 0; i < 3; i++) {
    fail_unless_equals_int (get_int (log_line (&lf, i), "width"),
        any_caps[__i__].width);
    fail_unless_equals_int (get_int (log_line (&lf, i), "height"),
        any_caps[__i__].height);
  }
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("format", test_labels_meta)
{
  GstHarness *h = log_harness (log_path, NULL);
  static const gchar *names[] = { "red", "a \"quoted\"\\name", "grey" };
  static const gboolean markers[] = { TRUE, TRUE, FALSE };
  static const guint rgb[] = { 0xaa3c28, 0x00ff00, 0x808080 };
  static const guint counts[] = { 50, 0, 4000000000u };
  static const gboolean active[] = { TRUE, FALSE, TRUE };
  static const guint labelled[] = { 55, 0, 70 };
  GstBuffer *buf, *plane;
  GstStructure *s;
  JsonObject *o, *labels;
  JsonArray *a;
  LogFile lf;
  guint i;

  /* frame 0: a full labels meta, as labsegment writes it */
  buf = frame_new (0);
  s = landmark_check_meta_add (buf, LABELS_META);
  plane = gst_buffer_new_allocate (NULL, 8 * 4, NULL);
  gst_buffer_memset (plane, 0, 2, 8 * 4);
  gst_structure_set (s, "labels", GST_TYPE_BUFFER, plane,
      "width", G_TYPE_UINT, 8, "height", G_TYPE_UINT, 4,
      "stride", G_TYPE_UINT, 8,
      "analysis-width", G_TYPE_UINT, 16, "analysis-height", G_TYPE_UINT, 8,
      "unclassified", G_TYPE_UINT, 3, "min-class-pixels", G_TYPE_UINT, 40,
      "max-distance", G_TYPE_DOUBLE, 12.3, "use-lightness", G_TYPE_BOOLEAN,
      FALSE, NULL);
  gst_buffer_unref (plane);
  landmark_check_set_array (s, "class-names", G_TYPE_STRING, names, 3);
  landmark_check_set_array (s, "class-markers", G_TYPE_BOOLEAN, markers, 3);
  landmark_check_set_array (s, "class-rgb", G_TYPE_UINT, rgb, 3);
  landmark_check_set_array (s, "class-counts", G_TYPE_UINT, counts, 3);
  landmark_check_set_array (s, "class-active", G_TYPE_BOOLEAN, active, 3);
  landmark_check_set_array (s, "label-counts", G_TYPE_UINT, labelled, 3);
  fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);

  /* frame 1: a meta with only some fields: only those are written */
  buf = frame_new (1);
  s = landmark_check_meta_add (buf, LABELS_META);
  landmark_check_set_array (s, "class-names", G_TYPE_STRING, names, 1);
  gst_structure_set (s, "unclassified", G_TYPE_UINT, 0, NULL);
  fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);

  /* frame 2: no meta, no labels */
  fail_unless_equals_int (gst_harness_push (h, frame_new (2)), GST_FLOW_OK);
  push_eos (h);

  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, 3);
  o = log_line (&lf, 0);
  labels = get_object (o, "labels");
  check_keys (labels, "active,analysis-height,analysis-width,classes,counts,"
      "height,labelled,markers,max-distance,min-class-pixels,rgb,"
      "unclassified,use-lightness,width");
  a = get_array (labels, "classes", 3);
  for (i = 0; i < 3; i++)
    fail_unless_equals_string (json_array_get_string_element (a, i),
        names[i]);
  check_bool_array (labels, "markers", markers, 3);
  check_bool_array (labels, "active", active, 3);
  check_uint_array (labels, "rgb", rgb, 3);
  check_uint_array (labels, "counts", counts, 3);
  check_uint_array (labels, "labelled", labelled, 3);
  fail_unless_equals_int (get_int (labels, "unclassified"), 3);
  fail_unless_equals_int (get_int (labels, "min-class-pixels"), 40);
  fail_unless_equals_int (get_int (labels, "width"), 8);
  fail_unless_equals_int (get_int (labels, "height"), 4);
  fail_unless_equals_int (get_int (labels, "analysis-width"), 16);
  fail_unless_equals_int (get_int (labels, "analysis-height"), 8);
  check_double (labels, "max-distance", 12.3);
  check_bool (labels, "use-lightness", FALSE);
  /* the plane never reaches the file */
  fail_if (strstr (lf.text, "stride") != NULL);
  fail_if (strstr (lf.text, "\"labels\": {") == NULL);
  fail_if (strstr (lf.text, "\"labels\": null") != NULL);

  labels = get_object (log_line (&lf, 1), "labels");
  check_keys (labels, "classes,unclassified");
  a = get_array (labels, "classes", 1);
  fail_unless_equals_string (json_array_get_string_element (a, 0), "red");
  fail_unless_equals_int (get_int (labels, "unclassified"), 0);

  fail_if (json_object_has_member (log_line (&lf, 2), "labels"));
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("format", test_detections)
{
  GstHarness *h = log_harness (log_path, NULL);
  GstBuffer *buf = frame_new (0);
  GstVideoRegionOfInterestMeta *roi;
  JsonObject *o, *d, *p;
  JsonArray *dets, *a;
  static const gdouble axes[] = { 0.5, -2.25e-7, 3.0 };
  LogFile lf;
  guint i;

  /* added out of id order: the log lists them by id */
  roi = roi_add (buf, "blue", 2, 100, 110, 5, 6);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("vendor-score", "score", G_TYPE_FLOAT, 0.1f,
          "rank", G_TYPE_INT, -3, "big", G_TYPE_UINT64, G_MAXUINT64,
          "small", G_TYPE_INT64, G_MININT64, NULL));
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("vendor-score", "score", G_TYPE_FLOAT, 0.9f, NULL));
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("other", "nothing", G_TYPE_DOUBLE, INFINITY,
          "frac", GST_TYPE_FRACTION, 30, 1, NULL));

  roi = roi_add (buf, "red", 0, 10, 20, 30, 40);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "class", G_TYPE_STRING, "red",
          "area", G_TYPE_DOUBLE, 1234.0, "roundness", G_TYPE_DOUBLE, 0.1,
          "centroid-x", G_TYPE_DOUBLE, 1.0 / 3.0,
          "centroid-y", G_TYPE_DOUBLE, -1e-300,
          "frame-width", G_TYPE_UINT, 640, "frame-height", G_TYPE_UINT, 480,
          "kept", G_TYPE_BOOLEAN, TRUE, NULL));
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-range", "range", G_TYPE_DOUBLE, 2.75,
          "bearing", G_TYPE_DOUBLE, -0.25, "method", G_TYPE_STRING, "ground",
          "range-sigma", G_TYPE_DOUBLE, NAN, "no-floor", G_TYPE_BOOLEAN,
          FALSE, NULL));
  {
    GstStructure *m = gst_structure_new ("landmark-match",
        "matched", G_TYPE_BOOLEAN, TRUE,
        "landmark-id", G_TYPE_STRING, "L\"1\"\n\t\x01/\xc3\xa9",
        "residual", G_TYPE_DOUBLE, 1e300, NULL);
    landmark_check_set_array (m, "axes", G_TYPE_DOUBLE, axes, 3);
    gst_video_region_of_interest_meta_add_param (roi, m);
  }

  roi = roi_add (buf, "green", 1, 0, 0, 1, 1);
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "area", G_TYPE_DOUBLE, 7.0,
          "kept", G_TYPE_BOOLEAN, FALSE, "reject-reason", G_TYPE_STRING,
          "too small", NULL));
  /* a second blob structure: the first one counts */
  gst_video_region_of_interest_meta_add_param (roi,
      gst_structure_new ("landmark-blob", "area", G_TYPE_DOUBLE, 99.0, NULL));

  fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
  push_eos (h);

  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, 1);
  o = log_line (&lf, 0);
  dets = get_array (o, "detections", 3);
  for (i = 0; i < 3; i++) {
    d = json_array_get_object_element (dets, i);
    fail_unless_equals_int (get_int (d, "id"), i);
  }

  /* id 0: all three parameter structures, every field */
  d = json_array_get_object_element (dets, 0);
  check_keys (d, "accepted,bbox,blob,class,id,match,range");
  check_bool (d, "accepted", TRUE);
  check_string (d, "class", "red");
  a = get_array (d, "bbox", 4);
  fail_unless_equals_int (json_array_get_int_element (a, 0), 10);
  fail_unless_equals_int (json_array_get_int_element (a, 1), 20);
  fail_unless_equals_int (json_array_get_int_element (a, 2), 30);
  fail_unless_equals_int (json_array_get_int_element (a, 3), 40);
  p = get_object (d, "blob");
  check_keys (p, "area,centroid-x,centroid-y,class,frame-height,frame-width,"
      "kept,roundness");
  check_string (p, "class", "red");
  check_double (p, "area", 1234.0);
  check_double (p, "roundness", 0.1);
  check_double (p, "centroid-x", 1.0 / 3.0);
  check_double (p, "centroid-y", -1e-300);
  fail_unless_equals_int (get_int (p, "frame-width"), 640);
  fail_unless_equals_int (get_int (p, "frame-height"), 480);
  check_bool (p, "kept", TRUE);
  p = get_object (d, "range");
  check_keys (p, "bearing,method,no-floor,range,range-sigma");
  check_double (p, "range", 2.75);
  check_double (p, "bearing", -0.25);
  check_string (p, "method", "ground");
  check_null (p, "range-sigma");        /* NaN is not JSON */
  check_bool (p, "no-floor", FALSE);
  p = get_object (d, "match");
  check_keys (p, "axes,landmark-id,matched,residual");
  check_bool (p, "matched", TRUE);
  check_string (p, "landmark-id", "L\"1\"\n\t\x01/\xc3\xa9");
  check_double (p, "residual", 1e300);
  a = get_array (p, "axes", 3);
  for (i = 0; i < 3; i++)
    fail_unless (json_array_get_double_element (a, i) == axes[i]);

  /* id 1: a blob only; no range, match or params keys at all */
  d = json_array_get_object_element (dets, 1);
  check_keys (d, "accepted,bbox,blob,class,id,reject-reason,rejected-by");
  check_bool (d, "accepted", FALSE);
  check_string (d, "rejected-by", "blobroundness");
  check_string (d, "reject-reason", "too small");
  check_string (d, "class", "green");
  p = get_object (d, "blob");
  check_keys (p, "area,kept,reject-reason");
  check_double (p, "area", 7.0);
  check_bool (p, "kept", FALSE);
  check_string (p, "reject-reason", "too small");

  /* id 2: no landmark structure; the others under "params" */
  d = json_array_get_object_element (dets, 2);
  check_keys (d, "accepted,bbox,class,id,params");
  check_bool (d, "accepted", TRUE);
  check_string (d, "class", "blue");
  p = get_object (d, "params");
  check_keys (p, "other,vendor-score");
  {
    JsonObject *v = get_object (p, "vendor-score");
    JsonObject *other = get_object (p, "other");
    check_keys (v, "big,rank,score,small");
    /* a float reads back as the same float, written with its own
     * shortest digits (not those of the double 0.10000000149011612) */
    fail_unless ((gfloat) json_object_get_double_member (v, "score") == 0.1f);
    fail_unless (strstr (lf.text, "\"score\": 0.1,") != NULL);
    fail_unless_equals_int (get_int (v, "rank"), -3);
    fail_unless_equals_int64 (get_int (v, "small"), G_MININT64);
    check_null (other, "nothing");      /* infinity */
    check_string (other, "frac", "30/1");
  }
  /* beyond gint64: checked in the text */
  fail_unless (strstr (lf.text, "\"big\": 18446744073709551615") != NULL);
  fail_if (strstr (lf.text, "nan") || strstr (lf.text, "inf"));
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

LANDMARK_TEST ("format", test_pose_meta)
{
  GstHarness *h = log_harness (log_path, NULL);
  static const gdouble cov[] = { 1e-4, 2e-6, 0.0, 2e-6, 3.5e-4, -1e-7, 0.0,
    -1e-7, 0.0025
  };
  static const gchar *used[] = { "L1", "L2", "L4" };
  GstBuffer *buf = frame_new (0);
  GstStructure *s = landmark_check_meta_add (buf, POSE_META);
  JsonObject *pose;
  JsonArray *a;
  LogFile lf;
  guint i;

  gst_structure_set (s, "x", G_TYPE_DOUBLE, 1.25, "y", G_TYPE_DOUBLE, -0.5,
      "heading", G_TYPE_DOUBLE, G_PI, "residual", G_TYPE_DOUBLE, 0.0125,
      "solver", G_TYPE_STRING, "gauss-newton",
      "n-landmarks", G_TYPE_UINT, 3, "converged", G_TYPE_BOOLEAN, TRUE, NULL);
  landmark_check_set_array (s, "covariance", G_TYPE_DOUBLE, cov, 9);
  landmark_check_set_array (s, "landmarks", G_TYPE_STRING, used, 3);
  fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
  fail_unless_equals_int (gst_harness_push (h, frame_new (1)), GST_FLOW_OK);
  push_eos (h);

  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, 2);
  pose = get_object (log_line (&lf, 0), "pose");
  check_keys (pose, "converged,covariance,heading,landmarks,n-landmarks,"
      "residual,solver,x,y");
  check_double (pose, "x", 1.25);
  check_double (pose, "y", -0.5);
  check_double (pose, "heading", G_PI);
  check_double (pose, "residual", 0.0125);
  check_string (pose, "solver", "gauss-newton");
  fail_unless_equals_int (get_int (pose, "n-landmarks"), 3);
  check_bool (pose, "converged", TRUE);
  a = get_array (pose, "covariance", 9);
  for (i = 0; i < 9; i++) {
    JsonNode *n = json_array_get_element (a, i);
    fail_unless (json_node_get_value_type (n) == G_TYPE_DOUBLE);
    fail_unless (json_node_get_double (n) == cov[i], "covariance[%u]", i);
  }
  a = get_array (pose, "landmarks", 3);
  for (i = 0; i < 3; i++)
    fail_unless_equals_string (json_array_get_string_element (a, i),
        used[i]);
  fail_if (json_object_has_member (log_line (&lf, 1), "pose"));
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* The labels meta of each buffer as a sink after the logger saw it. */
static void
collect_labels (GstElement * sink, GstBuffer * buf, GstPad * pad,
    GPtrArray * seen)
{
  GstCustomMeta *m = gst_buffer_get_custom_meta (buf, LABELS_META);
  GstStructure *copy;
  (void) sink;
  (void) pad;
  fail_unless (m != NULL);
  copy = gst_structure_copy (gst_custom_meta_get_structure (m));
  gst_structure_remove_field (copy, "labels");  /* let the plane go */
  g_ptr_array_add (seen, copy);
}

static void
check_uint_array_matches (JsonObject * o, const gchar * key,
    const GstStructure * s, const gchar * field, guint64 * sum)
{
  const GValue *v = gst_structure_get_value (s, field);
  guint n, i;
  JsonArray *a;

  fail_unless (v != NULL && GST_VALUE_HOLDS_ARRAY (v));
  n = gst_value_array_get_size (v);
  a = get_array (o, key, n);
  for (i = 0; i < n; i++) {
    const guint x = g_value_get_uint (gst_value_array_get_value (v, i));
    fail_unless_equals_int64 (json_array_get_int_element (a, i), x);
    if (sum)
      *sum += x;
  }
}

LANDMARK_TEST ("pipelines", test_labsegment_pipeline)
{
  const guint n = 12, w = 160, h = 120;
  gchar *desc = g_strdup_printf ("videotestsrc num-buffers=%u "
      "pattern=smpte ! video/x-raw,format=BGRx,width=%u,height=%u ! "
      "labsegment ! landmarklog location=\"%s\" ! "
      "fakesink name=sink signal-handoffs=true", n, w, h, log_path);
  GPtrArray *seen = g_ptr_array_new_with_free_func ((GDestroyNotify)
      gst_structure_free);
  GError *err = NULL;
  GstElement *pipe = gst_parse_launch (desc, &err), *sink;
  GstBus *bus;
  GstMessage *msg;
  LogFile lf;
  guint i;

  fail_unless (pipe != NULL, "%s", err ? err->message : "?");
  sink = gst_bin_get_by_name (GST_BIN (pipe), "sink");
  g_signal_connect (sink, "handoff", G_CALLBACK (collect_labels), seen);
  gst_object_unref (sink);
  bus = gst_element_get_bus (pipe);
  fail_if (gst_element_set_state (pipe, GST_STATE_PLAYING) ==
      GST_STATE_CHANGE_FAILURE);
  msg = gst_bus_timed_pop_filtered (bus, WAIT,
      GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  fail_unless (msg != NULL && GST_MESSAGE_TYPE (msg) == GST_MESSAGE_EOS);
  gst_message_unref (msg);

  /* read at EOS, before the pipeline stops */
  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, n);
  fail_unless_equals_int (seen->len, n);
  for (i = 0; i < n; i++) {
    JsonObject *o = log_line (&lf, i), *labels = get_object (o, "labels");
    const GstStructure *s = g_ptr_array_index (seen, i);
    const GValue *names = gst_structure_get_value (s, "class-names");
    guint64 labelled = 0, unclassified;
    guint k;
    JsonArray *a;

    fail_unless_equals_int (get_int (o, "frame"), i);
    fail_unless_equals_int (get_int (o, "width"), w);
    fail_unless_equals_int (get_int (o, "height"), h);
    a = get_array (labels, "classes", gst_value_array_get_size (names));
    fail_unless (json_array_get_length (a) > 0);
    for (k = 0; k < json_array_get_length (a); k++)
      fail_unless_equals_string (json_array_get_string_element (a, k),
          g_value_get_string (gst_value_array_get_value (names, k)));
    check_uint_array_matches (labels, "counts", s, "class-counts", NULL);
    check_uint_array_matches (labels, "labelled", s, "label-counts",
        &labelled);
    unclassified = get_int (labels, "unclassified");
    fail_unless_equals_int64 (labelled + unclassified, (guint64) w * h);
    fail_unless_equals_int (get_int (labels, "width"), w);
    fail_unless_equals_int (get_int (labels, "height"), h);
    get_array (o, "detections", 0);
  }
  log_clear (&lf);

  gst_element_set_state (pipe, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (pipe);
  g_ptr_array_unref (seen);
  g_free (desc);
}

GST_END_TEST;

/* Lines are buffered (flush-every=0); EOS writes them out before it goes
 * downstream, so the file is complete while the element still runs. */
LANDMARK_TEST ("output", test_eos_completes_file)
{
  GstHarness *h = log_harness (log_path, NULL);
  GstEvent *ev;
  gboolean eos = FALSE;
  LogFile lf;
  guint i;

  for (i = 0; i < 5; i++)
    fail_unless_equals_int (gst_harness_push (h, frame_new (i)), GST_FLOW_OK);
  fail_unless_equals_int (file_size (log_path), 0);
  push_eos (h);
  /* EOS went downstream after the lines were written */
  while ((ev = gst_harness_try_pull_event (h))) {
    eos = GST_EVENT_TYPE (ev) == GST_EVENT_EOS;
    gst_event_unref (ev);
    if (eos)
      break;
  }
  fail_unless (eos, "EOS did not go downstream");
  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, 5);
  for (i = 0; i < 5; i++)
    fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), i);
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

static guint
count_lines (const gchar * path)
{
  LogFile lf;
  guint n;
  log_read (path, &lf);
  n = lf.n;
  log_clear (&lf);
  return n;
}

/* flush-every: whole frames reach the file every N frames; a flushing
 * seek and pausing also write the pending lines. */
LANDMARK_TEST ("output", test_flush_every)
{
  GstHarness *h = log_harness (log_path, NULL);
  guint i, frame = 0;

  g_object_set (h->element, "flush-every", 1, NULL);
  for (i = 0; i < 4; i++) {
    fail_unless_equals_int (gst_harness_push (h, frame_new (frame++)),
        GST_FLOW_OK);
    fail_unless_equals_int (count_lines (log_path), frame);
  }
  /* changed while playing */
  g_object_set (h->element, "flush-every", 3, NULL);
  for (i = 0; i < 6; i++) {
    fail_unless_equals_int (gst_harness_push (h, frame_new (frame++)),
        GST_FLOW_OK);
    fail_unless_equals_int (count_lines (log_path), 4 + (i + 1) / 3 * 3);
  }
  g_object_set (h->element, "flush-every", 0, NULL);
  fail_unless_equals_int (gst_harness_push (h, frame_new (frame++)),
      GST_FLOW_OK);
  fail_unless_equals_int (count_lines (log_path), 10);
  /* a flushing seek writes what is pending */
  fail_unless (gst_harness_push_event (h, gst_event_new_flush_start ()));
  fail_unless (gst_harness_push_event (h, gst_event_new_flush_stop (TRUE)));
  fail_unless_equals_int (count_lines (log_path), 11);
  /* so does pausing */
  {
    GstSegment seg;
    gst_segment_init (&seg, GST_FORMAT_TIME);
    fail_unless (gst_harness_push_event (h, gst_event_new_segment (&seg)));
  }
  fail_unless_equals_int (gst_harness_push (h, frame_new (frame++)),
      GST_FLOW_OK);
  fail_unless_equals_int (count_lines (log_path), 11);
  fail_unless_equals_int (gst_element_set_state (h->element,
          GST_STATE_PAUSED), GST_STATE_CHANGE_SUCCESS);
  fail_unless_equals_int (count_lines (log_path), 12);
  gst_harness_teardown (h);
  fail_unless_equals_int (count_lines (log_path), 12);
}

GST_END_TEST;

/* Frames big enough that the pending lines go out mid-stream: whenever the
 * file is looked at, it holds only complete lines, frames 0..k-1. */
LANDMARK_TEST ("output", test_whole_lines_mid_stream)
{
  GstHarness *h = log_harness (log_path, NULL);
  const guint n = 40, per_frame = 30;
  guint i, j;
  gboolean spilled = FALSE, buffered = FALSE;
  LogFile lf;

  for (i = 0; i < n; i++) {
    GstBuffer *buf = frame_new (i);
    for (j = 0; j < per_frame; j++) {
      GstVideoRegionOfInterestMeta *roi = roi_add (buf, "red", j, j, j, 4, 4);
      gst_video_region_of_interest_meta_add_param (roi,
          gst_structure_new ("landmark-blob", "area", G_TYPE_DOUBLE,
              j + 0.123456789, "roundness", G_TYPE_DOUBLE, 1.0 / (j + 3),
              "centroid-x", G_TYPE_DOUBLE, j * 1.1, "centroid-y",
              G_TYPE_DOUBLE, j * 2.2, "reject-reason", G_TYPE_STRING,
              "a reason long enough to make the lines long", NULL));
    }
    fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
    log_read (log_path, &lf);
    for (j = 0; j < lf.n; j++)
      fail_unless_equals_int (get_int (log_line (&lf, j), "frame"), j);
    fail_unless (lf.n <= i + 1);
    spilled |= lf.n > 0;
    buffered |= lf.n < i + 1;
    log_clear (&lf);
  }
  fail_unless (spilled, "nothing was written before EOS");
  fail_unless (buffered, "every line was written at once");
  push_eos (h);
  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, n);
  for (i = 0; i < n; i++)
    get_array (log_line (&lf, i), "detections", per_frame);
  log_clear (&lf);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* READY->PAUSED fails with a message naming the file and the reason. */
static void
expect_start_error (const gchar * location, GQuark domain, gint code,
    const gchar * reason)
{
  GstElement *e = gst_element_factory_make ("landmarklog", NULL);
  GstBus *bus = gst_bus_new ();
  GstMessage *msg;
  GError *err = NULL;
  gchar *dbg = NULL;
  const gchar *good = tmp_file ("good.jsonl");

  if (location)
    g_object_set (e, "location", location, NULL);
  landmark_check_refuses_paused (e, bus);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL, "no error message");
  fail_unless (GST_MESSAGE_SRC (msg) == GST_OBJECT (e));
  gst_message_parse_error (msg, &err, &dbg);
  fail_unless (g_error_matches (err, domain, code), "got %s %d: %s",
      g_quark_to_string (err->domain), err->code, err->message);
  if (location)
    fail_unless (strstr (err->message, location) != NULL,
        "the message does not name the file: %s", err->message);
  if (reason)
    fail_unless (strstr (err->message, reason) != NULL,
        "the message does not give the reason \"%s\": %s", reason,
        err->message);
  g_error_free (err);
  g_free (dbg);
  gst_message_unref (msg);

  /* a usable location is enough to start (and makes the file) */
  landmark_check_fixed_setting_starts (e, bus, "location", good);
  fail_unless (g_file_test (good, G_FILE_TEST_IS_REGULAR));
}

LANDMARK_TEST ("errors", test_missing_directory)
{
  gchar *path = g_build_filename (landmark_check_tmp_dir, "no-such-dir",
      "x.jsonl", NULL);
  expect_start_error (path, GST_RESOURCE_ERROR, GST_RESOURCE_ERROR_OPEN_WRITE,
      g_strerror (ENOENT));
  fail_if (g_file_test (path, G_FILE_TEST_EXISTS));
  g_free (path);
}

GST_END_TEST;

LANDMARK_TEST ("errors", test_location_is_a_directory)
{
  expect_start_error (landmark_check_tmp_dir, GST_RESOURCE_ERROR,
      GST_RESOURCE_ERROR_OPEN_WRITE, g_strerror (EISDIR));
}

GST_END_TEST;

LANDMARK_TEST ("errors", test_no_permission)
{
  const gchar *dir = tmp_file ("read-only");
  gchar *path = g_build_filename (dir, "x.jsonl", NULL);

  if (geteuid () == 0) {
    /* root writes anywhere: nothing to test */
    g_free (path);
    return;
  }
  fail_unless (g_mkdir (dir, 0500) == 0);
  expect_start_error (path, GST_RESOURCE_ERROR, GST_RESOURCE_ERROR_OPEN_WRITE,
      g_strerror (EACCES));
  g_free (path);
}

GST_END_TEST;

LANDMARK_TEST ("errors", test_no_location)
{
  expect_start_error (NULL, GST_RESOURCE_ERROR, GST_RESOURCE_ERROR_SETTINGS,
      "location");
}

GST_END_TEST;

/* A write that fails (a full disk: /dev/full) is a RESOURCE WRITE error
 * naming the file, and stops the stream. */
LANDMARK_TEST ("errors", test_write_error)
{
  const gchar *full = "/dev/full";
  GstHarness *h;
  GstBus *bus;
  GstMessage *msg;
  GError *err = NULL;

  if (!g_file_test (full, G_FILE_TEST_EXISTS)) {
    GST_WARNING ("no %s: skipping", full);
    return;
  }
  h = log_harness (full, NULL);
  bus = gst_bus_new ();
  gst_element_set_bus (h->element, bus);
  g_object_set (h->element, "flush-every", 2, NULL);
  fail_unless_equals_int (gst_harness_push (h, frame_new (0)), GST_FLOW_OK);
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR) == NULL);
  fail_unless_equals_int (gst_harness_push (h, frame_new (1)),
      GST_FLOW_ERROR);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL);
  gst_message_parse_error (msg, &err, NULL);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_WRITE), "%s", err->message);
  fail_unless (strstr (err->message, full) != NULL, "%s", err->message);
  fail_unless (strstr (err->message, g_strerror (ENOSPC)) != NULL, "%s",
      err->message);
  g_error_free (err);
  gst_message_unref (msg);
  /* reported once */
  fail_unless_equals_int (gst_harness_push (h, frame_new (2)),
      GST_FLOW_ERROR);
  gst_harness_teardown (h);
  fail_unless (gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR) == NULL);
  gst_object_unref (bus);
}

GST_END_TEST;

/* A write cut short by a file size limit: the partial line is cut off,
 * so the file still ends with the last complete line. */
LANDMARK_TEST ("errors", test_partial_write_trimmed)
{
  const rlim_t limit = 100000;
  struct rlimit old_limit, rl;
  GstHarness *h;
  GstBus *bus = gst_bus_new ();
  GstMessage *msg;
  GError *err = NULL;
  GstFlowReturn ret = GST_FLOW_OK;
  void (*old_handler) (int);
  LogFile lf;
  guint i, j;

  fail_unless (getrlimit (RLIMIT_FSIZE, &old_limit) == 0);
  rl = old_limit;
  rl.rlim_cur = limit;
  old_handler = signal (SIGXFSZ, SIG_IGN);
  fail_unless (setrlimit (RLIMIT_FSIZE, &rl) == 0);

  h = log_harness (log_path, NULL);
  gst_element_set_bus (h->element, bus);
  for (i = 0; i < 100 && ret == GST_FLOW_OK; i++) {
    GstBuffer *buf = frame_new (i);
    for (j = 0; j < 20; j++) {
      GstVideoRegionOfInterestMeta *roi = roi_add (buf, "red", j, j, j, 4, 4);
      gst_video_region_of_interest_meta_add_param (roi,
          gst_structure_new ("landmark-blob", "area", G_TYPE_DOUBLE,
              i + j / 7.0, "reject-reason", G_TYPE_STRING,
              "padding padding padding padding padding padding", NULL));
    }
    ret = gst_harness_push (h, buf);
  }
  fail_unless_equals_int (ret, GST_FLOW_ERROR);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL);
  gst_message_parse_error (msg, &err, NULL);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_WRITE), "%s", err->message);
  g_error_free (err);
  gst_message_unref (msg);
  /* messages left on the bus hold the element, which holds the bus
   * (GStreamer 1.26 posts more after the error): drop them */
  gst_bus_set_flushing (bus, TRUE);
  gst_harness_teardown (h);
  gst_object_unref (bus);

  fail_unless (setrlimit (RLIMIT_FSIZE, &old_limit) == 0);
  signal (SIGXFSZ, old_handler);

  log_read (log_path, &lf);
  fail_unless (lf.n > 0 && lf.size <= limit);
  for (i = 0; i < lf.n; i++)
    fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), i);
  log_clear (&lf);
}

GST_END_TEST;

/* Two loggers on one stream (in a chain and on the branches of a tee)
 * write the same lines to their own files. */
LANDMARK_TEST ("pipelines", test_two_loggers)
{
  const gchar *a = tmp_file ("a.jsonl"), *b = tmp_file ("b.jsonl");
  const gchar *c = tmp_file ("c.jsonl"), *d = tmp_file ("d.jsonl");
  gchar *chain = g_strdup_printf ("videotestsrc num-buffers=15 ! "
      "video/x-raw,width=64,height=48 ! labsegment ! "
      "landmarklog location=\"%s\" ! queue ! landmarklog location=\"%s\" ! "
      "fakesink", a, b);
  gchar *tee = g_strdup_printf ("videotestsrc num-buffers=9 ! "
      "video/x-raw,width=32,height=24 ! labsegment ! tee name=t "
      "t. ! queue ! landmarklog location=\"%s\" ! fakesink "
      "t. ! queue ! landmarklog location=\"%s\" flush-every=1 ! fakesink",
      c, d);
  LogFile la, lb;
  guint i;

  run_to_eos (chain, FALSE);
  log_read (a, &la);
  log_read (b, &lb);
  fail_unless_equals_int (la.n, 15);
  fail_unless_equals_int (lb.n, 15);
  fail_unless_equals_string (la.text, lb.text);
  for (i = 0; i < 15; i++)
    get_object (log_line (&la, i), "labels");
  log_clear (&la);
  log_clear (&lb);

  run_to_eos (tee, FALSE);
  log_read (c, &la);
  log_read (d, &lb);
  fail_unless_equals_int (la.n, 9);
  fail_unless_equals_string (la.text, lb.text);
  log_clear (&la);
  log_clear (&lb);

  g_free (chain);
  g_free (tee);
}

GST_END_TEST;

/* append=true keeps what the file had; append=false starts it anew. */
LANDMARK_TEST ("output", test_append)
{
  guint run, i;
  LogFile lf;

  for (run = 0; run < 3; run++) {
    GstHarness *h = log_harness_full (log_path, NULL, run == 1);
    push_frames (h, 0, 4);
    push_eos (h);
    gst_harness_teardown (h);
    log_read (log_path, &lf);
    /* run 0: 4 lines; run 1 appends 4; run 2 truncates */
    fail_unless_equals_int (lf.n, run == 1 ? 8 : 4);
    for (i = 0; i < lf.n; i++)
      fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), i % 4);
    log_clear (&lf);
  }
}

GST_END_TEST;

/* Restarting the element (PLAYING -> READY -> PLAYING) starts the frame
 * count again and truncates the file, or appends with append=true. */
LANDMARK_TEST ("output", test_restart)
{
  guint append, i;
  LogFile lf;

  for (append = 0; append < 2; append++) {
    GstHarness *h = log_harness_full (log_path, NULL, append);
    push_frames (h, 0, 3);
    fail_unless_equals_int (gst_element_set_state (h->element,
            GST_STATE_READY), GST_STATE_CHANGE_SUCCESS);
    fail_unless_equals_int (count_lines (log_path), 3);
    fail_unless_equals_int (gst_element_set_state (h->element,
            GST_STATE_PLAYING), GST_STATE_CHANGE_SUCCESS);
    gst_harness_set_src_caps_str (h, CAPS_GRAY);
    push_frames (h, 10, 2);
    push_eos (h);
    log_read (log_path, &lf);
    fail_unless_equals_int (lf.n, append ? 5 : 2);
    for (i = 0; i < lf.n; i++) {
      const guint k = append && i < 3 ? i : i - (append ? 3 : 0);
      fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), k);
      fail_unless_equals_int64 (get_int (log_line (&lf, i), "pts"),
          (append && i < 3 ? k : 10 + k) * 40 * GST_MSECOND);
    }
    log_clear (&lf);
    gst_harness_teardown (h);
    g_remove (log_path);
  }
}

GST_END_TEST;

/* QoS events do not make the logger drop late frames. */
LANDMARK_TEST ("output", test_no_frame_dropped)
{
  GstHarness *h = log_harness (log_path, NULL);
  GstBuffer *templ = frame_new (0);

  landmark_check_no_frame_dropped (h, templ, 30, NULL);
  push_eos (h);
  fail_unless_equals_int (count_lines (log_path), 30);
  gst_buffer_unref (templ);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* Downstream fails at buffer `fail_at`: the pipeline errors out; after it
 * is stopped, every buffer that went through the logger has its line. */
typedef struct
{
  guint count, fail_at;
} FailProbe;

static GstPadProbeReturn
fail_probe (GstPad * pad, GstPadProbeInfo * info, gpointer user_data)
{
  FailProbe *fp = user_data;
  (void) pad;
  if (fp->count++ < fp->fail_at)
    return GST_PAD_PROBE_OK;
  gst_buffer_unref (GST_PAD_PROBE_INFO_BUFFER (info));
  GST_PAD_PROBE_INFO_DATA (info) = NULL;
  GST_PAD_PROBE_INFO_FLOW_RETURN (info) = GST_FLOW_ERROR;
  return GST_PAD_PROBE_HANDLED;
}

LANDMARK_TEST ("errors", test_downstream_error)
{
  gchar *desc = g_strdup_printf ("appsrc name=src format=time "
      "caps=\"" CAPS_GRAY "\" ! landmarklog location=\"%s\" ! "
      "fakesink name=sink", log_path);
  GstElement *pipe = gst_parse_launch (desc, NULL), *src, *sink;
  FailProbe fp = { 0, 7 };
  GstPad *pad;
  GstBus *bus;
  GstMessage *msg;
  GstFlowReturn ret;
  LogFile lf;
  guint i;

  fail_unless (pipe != NULL);
  src = gst_bin_get_by_name (GST_BIN (pipe), "src");
  sink = gst_bin_get_by_name (GST_BIN (pipe), "sink");
  pad = gst_element_get_static_pad (sink, "sink");
  gst_pad_add_probe (pad, GST_PAD_PROBE_TYPE_BUFFER, fail_probe, &fp, NULL);
  gst_object_unref (pad);
  bus = gst_element_get_bus (pipe);
  fail_if (gst_element_set_state (pipe, GST_STATE_PLAYING) ==
      GST_STATE_CHANGE_FAILURE);
  for (i = 0; i < 20; i++) {
    GstBuffer *buf = frame_new (i);
    g_signal_emit_by_name (src, "push-buffer", buf, &ret);
    gst_buffer_unref (buf);
    if (ret != GST_FLOW_OK)
      break;
  }
  msg = gst_bus_timed_pop_filtered (bus, WAIT, GST_MESSAGE_ERROR);
  fail_unless (msg != NULL, "no error from the failing sink");
  gst_message_unref (msg);
  gst_element_set_state (pipe, GST_STATE_NULL);

  /* buffers 0..fail_at went through the logger, the last one failing
   * downstream of it */
  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, fp.fail_at + 1);
  for (i = 0; i < lf.n; i++) {
    fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), i);
    fail_unless_equals_int64 (get_int (log_line (&lf, i), "pts"),
        i * 40 * GST_MSECOND);
  }
  log_clear (&lf);

  gst_object_unref (bus);
  gst_object_unref (src);
  gst_object_unref (sink);
  gst_object_unref (pipe);
  g_free (desc);
}

GST_END_TEST;

/* Stopping a pipeline mid-stream (no EOS) keeps every line of every buffer
 * that reached the logger, each complete. */
static GstPadProbeReturn
count_probe (GstPad * pad, GstPadProbeInfo * info, gpointer user_data)
{
  (void) pad;
  (void) info;
  g_atomic_int_inc ((gint *) user_data);
  return GST_PAD_PROBE_OK;
}

/* A pipeline of `head ! landmarklog name=log location=log_path ! tail`. */
static GstElement *
log_pipeline (const gchar * head, const gchar * tail)
{
  gchar *desc = g_strdup_printf ("%s ! landmarklog name=log "
      "location=\"%s\" ! %s", head, log_path, tail);
  GstElement *pipe = gst_parse_launch (desc, NULL);
  fail_unless (pipe != NULL, "%s", desc);
  g_free (desc);
  return pipe;
}

/* Counts the buffers through the logger's pad (sink or src) in *counter. */
static void
count_buffers (GstElement * pipe, const gchar * pad_name, gint * counter)
{
  GstElement *log = gst_bin_get_by_name (GST_BIN (pipe), "log");
  GstPad *pad = gst_element_get_static_pad (log, pad_name);
  gst_pad_add_probe (pad, GST_PAD_PROBE_TYPE_BUFFER, count_probe, counter,
      NULL);
  gst_object_unref (pad);
  gst_object_unref (log);
}

LANDMARK_TEST ("errors", test_stop_mid_stream)
{
  GstElement *pipe = log_pipeline ("videotestsrc ! video/x-raw,width=64,"
      "height=48,framerate=100/1 ! labsegment", "fakesink sync=true");
  gint entered = 0, left = 0;
  LogFile lf;
  guint i;

  count_buffers (pipe, "sink", &entered);
  count_buffers (pipe, "src", &left);
  fail_if (gst_element_set_state (pipe, GST_STATE_PLAYING) ==
      GST_STATE_CHANGE_FAILURE);
  for (i = 0; i < 500 && g_atomic_int_get (&left) < 10; i++)
    g_usleep (10 * 1000);
  fail_unless (g_atomic_int_get (&left) >= 10);
  gst_element_set_state (pipe, GST_STATE_NULL);

  /* Every buffer that went out was logged, and nothing that did not come
   * in. (Stopping can catch a buffer between the pad's probe and the
   * element, or between the element and the next pad: hence a range.) */
  log_read (log_path, &lf);
  fail_unless (lf.n >= (guint) left && lf.n <= (guint) entered,
      "%u lines for %d buffers in, %d out", lf.n, entered, left);
  fail_unless (left >= 10);
  for (i = 0; i < lf.n; i++) {
    fail_unless_equals_int (get_int (log_line (&lf, i), "frame"), i);
    get_object (log_line (&lf, i), "labels");
  }
  log_clear (&lf);
  gst_object_unref (pipe);
}

GST_END_TEST;

/* Never PLAYING: the prerolled buffer is logged, and written when the
 * element stops (PAUSED to READY), the only flush on this path. */
LANDMARK_TEST ("errors", test_stop_while_paused)
{
  GstElement *pipe = log_pipeline ("videotestsrc num-buffers=50 ! "
      "video/x-raw,width=64,height=48", "fakesink");
  gint entered = 0;
  LogFile lf;

  count_buffers (pipe, "sink", &entered);
  fail_unless_equals_int (gst_element_set_state (pipe, GST_STATE_PAUSED),
      GST_STATE_CHANGE_ASYNC);
  fail_unless_equals_int (gst_element_get_state (pipe, NULL, NULL, WAIT),
      GST_STATE_CHANGE_SUCCESS);
  /* the sink holds the preroll buffer; nothing written yet */
  fail_unless_equals_int (file_size (log_path), 0);
  fail_unless_equals_int (gst_element_set_state (pipe, GST_STATE_NULL),
      GST_STATE_CHANGE_SUCCESS);
  log_read (log_path, &lf);
  fail_unless (lf.n >= 1);
  fail_unless_equals_int (lf.n, g_atomic_int_get (&entered));
  fail_unless_equals_int (get_int (log_line (&lf, 0), "frame"), 0);
  log_clear (&lf);
  gst_object_unref (pipe);
}

GST_END_TEST;

/* 10,000 frames: all written, and the element's own cost per frame (over
 * an identity element pushed the same way) is a few microseconds. */
static gdouble
push_many (GstHarness * h, GstBuffer * templ, guint n)
{
  gint64 t0 = g_get_monotonic_time ();
  guint i;
  for (i = 0; i < n; i++) {
    GstBuffer *buf = gst_buffer_ref (templ);
    GstBuffer *out;
    fail_unless_equals_int (gst_harness_push (h, buf), GST_FLOW_OK);
    out = gst_harness_pull (h);
    gst_buffer_unref (out);
  }
  return (g_get_monotonic_time () - t0) / (gdouble) n;
}

LANDMARK_TEST ("output", test_many_frames)
{
  GstHarness *h = log_harness (log_path, NULL);
  GstHarness *ref = gst_harness_new ("identity");
  GstBuffer *templ = frame_new (0);
  const guint n = 10000;
  gdouble us_log, us_ref;
  LogFile lf;

  gst_harness_set_src_caps_str (ref, CAPS_GRAY);
  push_many (h, templ, 200);    /* warm up; counted in the file */
  push_many (ref, templ, 200);
  us_log = push_many (h, templ, n);
  us_ref = push_many (ref, templ, n);
  GST_INFO ("landmarklog %.2f us/frame, identity %.2f us/frame", us_log,
      us_ref);
  push_eos (h);
  log_read (log_path, &lf);
  fail_unless_equals_int (lf.n, n + 200);
  fail_unless_equals_int (get_int (log_line (&lf, n + 199), "frame"),
      n + 199);
  log_clear (&lf);
  /* generous bound: tests may run on a loaded machine or under valgrind */
  fail_unless (us_log - us_ref < 50.0, "%.2f us per frame over identity",
      us_log - us_ref);
  gst_buffer_unref (templ);
  gst_harness_teardown (ref);
  gst_harness_teardown (h);
}

GST_END_TEST;

/* a fresh folder for every test's log files */
/* test_whole_lines_mid_stream reads the file back after each of its 40
 * frames: under the sanitizers on a loaded 2-core machine it passed 60 s */
LANDMARK_CHECK_MAIN (landmarklog,
    .setup = setup, .teardown = teardown, .checked = TRUE, .timeout = 180);
