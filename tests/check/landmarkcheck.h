/* Helpers shared by the GstHarness tests: tests that register themselves
 * (no hand-written suite function), metadata made by hand, a reference
 * colour conversion, harnesses from a launch description, bus messages,
 * starts refused for bad settings, frames never dropped, and a temporary
 * folder. Each helper asserts what it checks, so a test stays one line per
 * behaviour. */
#ifndef LANDMARK_CHECK_H
#define LANDMARK_CHECK_H

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>

G_BEGIN_DECLS

#define LANDMARK_LABELS_META "GstLandmarkLabelsMeta"
#define LANDMARK_FLOOR_META "GstLandmarkFloorMeta"

/* ---- tests and the suite --------------------------------------------- */

/* the loop count of a test run once per element of the plugin */
#define LANDMARK_CHECK_PER_ELEMENT (-1)

void landmark_check_register (const gchar * tcase, TFun func,
    const gchar * name, gint loops, gint line);

/* A test of test case `tcase` run with __i__ = 0 .. loops - 1; it adds
 * itself to the suite LANDMARK_CHECK_MAIN builds, in the order of the file. */
#define LANDMARK_TEST_LOOP(tcase, name, loops) \
  static void name (int); \
  __attribute__ ((constructor)) static void name ## _register (void) \
  { \
    landmark_check_register (tcase, name, #name, loops, __LINE__); \
  } \
  GST_START_TEST (name)

#define LANDMARK_TEST(tcase, name) LANDMARK_TEST_LOOP (tcase, name, 1)

typedef struct
{
  /* around every test case (unchecked, once in the parent) or, when
   * `checked`, around every test in its own process */
  SFun setup, teardown;
  gboolean checked;
  /* seconds per test; 0 keeps check's default (CK_DEFAULT_TIMEOUT) */
  gint timeout;
  /* the loop count of LANDMARK_CHECK_PER_ELEMENT tests, asked once the
   * plugin can be loaded */
  gint (*elements) (void);
} LandmarkCheckOptions;

int landmark_check_run (int *argc, char ***argv, const gchar * suite,
    const LandmarkCheckOptions * options);

/* main () of a test file: LANDMARK_CHECK_MAIN (name) or, with options,
 * LANDMARK_CHECK_MAIN (name, .setup = s, .teardown = t) */
#define LANDMARK_CHECK_MAIN(name, ...) \
  int \
  main (int argc, char **argv) \
  { \
    static const LandmarkCheckOptions options = { __VA_ARGS__ }; \
    return landmark_check_run (&argc, &argv, #name, &options); \
  }

/* ---- metadata made by hand ------------------------------------------- */
/* (these and landmark_check_harness_new also serve the benchmarks, which
 * run no check suite) */

/* the default palette's seven classes, in its order, and which are markers */
extern const gchar *landmark_check_names7[7];
extern const gboolean landmark_check_markers7[7];

/* The structure of a new custom meta `name` on buf; fails when the meta is
 * not registered (the plugin is not loaded). */
GstStructure *landmark_check_meta_add (GstBuffer * buf, const gchar * name);

/* Sets field to a GstValueArray of n values of type (string, boolean, int,
 * uint, float or double) read from the C array `values`. */
void landmark_check_set_array (GstStructure * s, const gchar * field,
    GType type, gconstpointer values, guint n);

/* Attaches a labels meta (docs/metadata.md) holding a copy of the w x h
 * plane with the given class names and markers. */
GstStructure *landmark_check_labels_attach (GstBuffer * buf,
    const guint8 * plane, guint w, guint h, guint stride,
    const gchar ** names, const gboolean * markers, guint n);

/* Sets a floor-meta array field (docs/floorboundary.md) to a buffer
 * holding a copy of the n bytes at data. */
void landmark_check_floor_array (GstStructure * s, const gchar * field,
    gconstpointer data, gsize n);

/* Attaches a floor meta whose boundary is a wall across the view at x =
 * wall metres (81 columns from y = 1 to -1, obstacle) and its ROP of 360
 * bins: those within 30 degrees of ahead end at the wall, the others are
 * not seen. */
void landmark_check_floor_wall_attach (GstBuffer * buf, gdouble wall);

/* Attaches a detection of class cls that ipmrange placed at (x, y) metres
 * (landmark-range ground-x, ground-y) with the map's marker-diameter (0:
 * none given); blobroundness kept it or not; trilaterate matched it to id
 * (NULL: not matched). */
void landmark_check_ranged_attach (GstBuffer * buf, const gchar * cls,
    gdouble x, gdouble y, gdouble diameter, gboolean kept, const gchar * id);

/* Frame n of a 30 fps stream: `size` bytes, its timestamp and duration. */
GstBuffer *landmark_check_frame_new (gsize size, guint n);

/* The parameter structure `name` of buf's region-of-interest meta `id`
 * (the test fails when there is no such meta), or NULL. */
const GstStructure *landmark_check_roi_param (GstBuffer * buf, gint id,
    const gchar * name);

/* ---- colour ---------------------------------------------------------- */

/* CIE L*a*b* (D65) -> sRGB 0xRRGGBB, each linear component clipped: the
 * published formulas, written out independently of the plugin. */
guint landmark_check_lab_to_rgb24 (const gdouble lab[3]);

/* ---- running elements ------------------------------------------------ */

/* The one element `desc` describes (gst_parse_launch syntax, properties
 * set); fails on any parse error. */
GstElement *landmark_check_element (const gchar * desc);

/* A harness around the one element `desc` describes (gst_parse_launch
 * syntax, properties set) with the given source caps, or none. */
GstHarness *landmark_check_harness_new (const gchar * desc,
    const gchar * caps);

/* Sends a QoS event saying everything is very late, pushes n copies of
 * templ (pts i * 40 ms) and pulls them all: a measuring element drops
 * none, keeps their order and, unless meta is NULL, attaches that custom
 * meta to each. */
void landmark_check_no_frame_dropped (GstHarness * h, GstBuffer * templ,
    guint n, const gchar * meta);

/* A new bus set on e, to read its messages without a pipeline; detach it
 * (unset and unref) when done. */
GstBus *landmark_check_bus_attach (GstElement * e);
void landmark_check_bus_detach (GstElement * e, GstBus * bus);

/* How many messages of `type` the bus holds, popping them all; the first
 * one's error or warning in *first when asked. */
guint landmark_check_count_messages (GstBus * bus, GstMessageType type,
    GError ** first);

/* Every message of the given types on the bus, in order (free with
 * g_list_free_full (l, (GDestroyNotify) gst_message_unref)). */
GList *landmark_check_pop_all (GstBus * bus, GstMessageType types);

/* Gives e what it needs to start: a file to write (landmarklog location=)
 * in landmark_check_tmp_dir, its path kept as e's LANDMARK_CHECK_FILE data,
 * and a landmark map (trilaterate map=). */
#define LANDMARK_CHECK_FILE "landmark-check-file"
void landmark_check_configure_element (GstElement * e);

/* For each entry of the NULL-terminated `settings` ("property=value", or
 * several separated by ';'): a new `factory` element so configured fails
 * to reach READY, and one so configured while in READY fails to reach
 * PAUSED (and again when tried again), each with one RESOURCE/SETTINGS
 * error naming the first property in quotes ('property'). */
void landmark_check_bad_settings (const gchar * factory,
    const gchar * const *settings);

/* e, its bus set to bus, reaches READY but refuses PAUSED (a resource it
 * opens when it starts). */
void landmark_check_refuses_paused (GstElement * e, GstBus * bus);

/* e, its bus set to bus, refuses READY (its settings and their files are
 * checked there: landmark::check_settings_at_ready). */
void landmark_check_refuses_ready (GstElement * e, GstBus * bus);

/* After a failed start of e (its bus set to bus; e in NULL or READY):
 * setting `property` to the good `value` is enough to start, without
 * another error. Takes e and bus. */
void landmark_check_fixed_setting_starts (GstElement * e, GstBus * bus,
    const gchar * property, const gchar * value);

/* where landmark_check_start_fails looks for the words */
typedef enum
{
  LANDMARK_CHECK_IN_MESSAGE,
  LANDMARK_CHECK_IN_DEBUG,
  LANDMARK_CHECK_IN_EITHER
} LandmarkCheckWhere;

/* Taking e to `state` fails with one RESOURCE/SETTINGS error whose message,
 * debug text or either contains `what` and, unless NULL, `also`. Takes e. */
void landmark_check_start_fails (GstElement * e, GstState state,
    LandmarkCheckWhere where, const gchar * what, const gchar * also);

/* ---- files ----------------------------------------------------------- */

/* A new empty folder in the temporary folder while a test case runs (a
 * fixture), removed with its files and (possibly read-only) subfolders. */
extern gchar *landmark_check_tmp_dir;
void landmark_check_tmp_dir_setup (void);
void landmark_check_tmp_dir_teardown (void);

/* A new temporary file `prefix`-XXXXXX`suffix` holding text. */
gchar *landmark_check_write_tmp (const gchar * prefix, const gchar * suffix,
    const gchar * text);

G_END_DECLS

#endif
