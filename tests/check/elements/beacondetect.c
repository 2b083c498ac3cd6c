/* Unit tests of beacondetect.
 *
 * Label planes of stacked rectangles are drawn here and attached by hand
 * as a GstLandmarkLabelsMeta (labels 1..7: red, green, yellow, pink, blue,
 * white, grey), so the tests do not depend on colour classification. The
 * maps are written per test. Expectations come from the drawn rows and
 * columns. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <glib/gstdio.h>

#include <math.h>
#include <string.h>

#define W 160
#define H 120
#define YELLOW 3
#define PINK 4

static const gchar *const MAP_JSON = "{\"landmarks\": ["
    "{\"id\": \"B1\", \"kind\": \"beacon\", \"x\": 2, \"y\": 0, "
    "\"diameter\": 0.1, \"height\": 0.2, \"bands\": [\"pink\", \"yellow\"]},"
    "{\"id\": \"B2\", \"kind\": \"beacon\", \"x\": 2, \"y\": 1, "
    "\"diameter\": 0.1, \"height\": 0.2, \"bands\": [\"yellow\", \"pink\"]},"
    "{\"id\": \"L1\", \"class\": \"red\", \"x\": 0, \"y\": 0}]}";

/* A GRAY8 frame with a label plane: `top` over `bottom`, each a band of
 * columns 70..89 and 16 rows from row 40. */
static GstBuffer *
stacked_frame (guint8 top, guint8 bottom)
{
  guint8 plane[W * H];
  GstBuffer *buf = gst_buffer_new_allocate (NULL, W * H, NULL);
  guint y;
  memset (plane, 0, sizeof (plane));
  for (y = 40; y < 72; y++)
    memset (plane + y * W + 70, y < 56 ? top : bottom, 20);
  gst_buffer_memset (buf, 0, 0x55, W * H);
  landmark_check_labels_attach (buf, plane, W, H, W, landmark_check_names7,
      landmark_check_markers7, G_N_ELEMENTS (landmark_check_names7));
  return buf;
}

static GstHarness *
harness_new (const gchar * map_path)
{
  gchar *desc = map_path ? g_strdup_printf ("beacondetect map=\"%s\"",
      map_path) : g_strdup ("beacondetect");
  GstHarness *h = landmark_check_harness_new (desc,
      "video/x-raw,format=GRAY8,width=160,height=120,framerate=30/1");
  g_free (desc);
  return h;
}

LANDMARK_TEST ("general", test_reads_the_code_top_to_bottom)
{
  gchar *map = landmark_check_write_tmp ("map", ".json", MAP_JSON);
  GstHarness *h = harness_new (map);
  const struct
  {
    guint8 top, bottom;
    const gchar *code, *id;
  } cases[] = {
    {PINK, YELLOW, "pink/yellow", "B1"},
    {YELLOW, PINK, "yellow/pink", "B2"},
  };
  guint i;
  for (i = 0; i < G_N_ELEMENTS (cases); i++) {
    GstBuffer *out = gst_harness_push_and_pull (h,
        stacked_frame (cases[i].top, cases[i].bottom));
    GstVideoRegionOfInterestMeta *roi;
    const GstStructure *blob;
    gboolean kept = FALSE;
    gdouble base_y = 0, height = 0;
    fail_unless (out != NULL);
    roi = gst_buffer_get_video_region_of_interest_meta_id (out, 0);
    fail_unless (roi != NULL);
    fail_unless (gst_buffer_get_video_region_of_interest_meta_id (out,
            1) == NULL);
    fail_unless_equals_string (g_quark_to_string (roi->roi_type),
        cases[i].code);
    fail_unless_equals_int (roi->x, 70);
    fail_unless_equals_int (roi->y, 40);
    fail_unless_equals_int (roi->w, 20);
    fail_unless_equals_int (roi->h, 32);
    blob = landmark_check_roi_param (out, 0, "landmark-blob");
    fail_unless (blob != NULL);
    fail_unless_equals_string (gst_structure_get_string (blob, "code"),
        cases[i].code);
    fail_unless_equals_string (gst_structure_get_string (blob, "kind"),
        "beacon");
    fail_unless (gst_structure_get_boolean (blob, "kept", &kept) && kept);
    /* rows 40..71: the base's edge at 71.5, 32 rows tall */
    fail_unless (gst_structure_get_double (blob, "axis-base-y", &base_y));
    fail_unless (fabs (base_y - 71.5) < 1e-6, "base %f", base_y);
    fail_unless (gst_structure_get_double (blob, "height-px", &height));
    fail_unless (fabs (height - 32) < 1e-6, "height %f", height);
    gst_buffer_unref (out);
  }
  gst_harness_teardown (h);
  g_unlink (map);
  g_free (map);
}

GST_END_TEST;

/* Pushes top over bottom through h: no detection comes out. Takes h. */
static void
attaches_nothing (GstHarness * h, guint8 top, guint8 bottom)
{
  GstBuffer *out = gst_harness_push_and_pull (h, stacked_frame (top,
          bottom));
  fail_unless (out != NULL);
  fail_unless (gst_buffer_get_video_region_of_interest_meta_id (out,
          0) == NULL);
  gst_buffer_unref (out);
  gst_harness_teardown (h);
}

/* A code the map lacks is not attached; nor is anything without a map */
LANDMARK_TEST ("general", test_unknown_code_and_no_map)
{
  gchar *map = landmark_check_write_tmp ("map", ".json", MAP_JSON);
  attaches_nothing (harness_new (map), PINK, 5);
  attaches_nothing (harness_new (NULL), PINK, YELLOW);
  g_unlink (map);
  g_free (map);
}

GST_END_TEST;

/* QoS is off: late frames are measured, never dropped */
LANDMARK_TEST ("frames", test_no_frame_dropped)
{
  gchar *map = landmark_check_write_tmp ("map", ".json", MAP_JSON);
  GstHarness *h = harness_new (map);
  GstBuffer *templ = stacked_frame (PINK, YELLOW);
  landmark_check_no_frame_dropped (h, templ, 50, LANDMARK_LABELS_META);
  gst_buffer_unref (templ);
  gst_harness_teardown (h);
  g_unlink (map);
  g_free (map);
}

GST_END_TEST;

LANDMARK_TEST ("general", test_bad_properties)
{
  gchar *two = landmark_check_write_tmp ("map", ".json", "{\"landmarks\": ["
      "{\"id\": \"B1\", \"kind\": \"beacon\", \"x\": 2, \"y\": 0, "
      "\"diameter\": 0.1, \"height\": 0.2, \"bands\": [\"pink\", \"blue\"]},"
      "{\"id\": \"B2\", \"kind\": \"beacon\", \"x\": 3, \"y\": 0, "
      "\"diameter\": 0.1, \"height\": 0.2, \"bands\": [\"pink\", \"blue\"]}"
      "]}");
  gchar *dup = g_strdup_printf ("map=%s", two);
  const gchar *bad[] = {
    "map=/nonexistent/map.json",
    dup,
    NULL
  };
  landmark_check_bad_settings ("beacondetect", bad);
  g_free (dup);
  g_unlink (two);
  g_free (two);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (beacondetect);
