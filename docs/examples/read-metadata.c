/* read-metadata: run the gst-landmark chain on a video file and print, for
 * every frame, the pose and each detection's class, box and range.
 *
 * Uses the GStreamer core and video libraries only: no gst-landmark header
 * (appsink is driven through its "pull-sample" action signal, so not even
 * libgstapp is needed).
 * The metadata contract it reads is docs/metadata.md:
 *   - pose: GstCustomMeta "GstLandmarkPoseMeta" (fields x, y, heading, ...);
 *   - detections: GstVideoRegionOfInterestMeta (roi_type = class, x y w h),
 *     parameters "landmark-range" etc. on the ROI meta or, when a converter
 *     dropped them, in GstCustomMeta "GstLandmarkDetectionsMeta" under
 *     "detection-<id>".
 *
 * Usage:
 *   read-metadata [-p palette.json] [-m map.json] [-H metres] [-t degrees]
 *                 [-f degrees] CLIP
 *   read-metadata -l 'LAUNCH LINE WITH appsink name=results'
 *
 * Output, one block per frame:
 *   frame 3 pts 100000000 pose x=1.2345 y=0.5000 heading=0.1000 n=3 solver=lsq
 *   det 0 class=red bbox=100,80,20,12 range=1.2345 bearing=0.0123 src=roi
 * ("pose none" without a pose; "range=none" for a detection without one.)
 */
#include <stdio.h>
#include <string.h>
#include <gst/gst.h>
#include <gst/video/video.h>

/* A detection's parameter structure: from its ROI meta, or else from the
 * detections custom meta. Returns a borrowed structure or NULL; *src says
 * where it came from. */
static const GstStructure *
detection_param (GstBuffer * buf, GstVideoRegionOfInterestMeta * roi,
    const gchar * name, const gchar ** src)
{
  GstStructure *s = gst_video_region_of_interest_meta_get_param (roi, name);
  GstCustomMeta *cm;
  const GValue *v;
  gchar key[32];

  if (s) {
    *src = "roi";
    return s;
  }
  cm = gst_buffer_get_custom_meta (buf, "GstLandmarkDetectionsMeta");
  if (!cm)
    return NULL;
  g_snprintf (key, sizeof key, "detection-%d", roi->id);
  v = gst_structure_get_value (gst_custom_meta_get_structure (cm), key);
  if (!v || !GST_VALUE_HOLDS_STRUCTURE (v))
    return NULL;
  v = gst_structure_get_value (gst_value_get_structure (v), name);
  if (!v || !GST_VALUE_HOLDS_STRUCTURE (v))
    return NULL;
  *src = "custom";
  return gst_value_get_structure (v);
}

static void
print_frame (GstBuffer * buf, guint64 frame)
{
  GstCustomMeta *pm = gst_buffer_get_custom_meta (buf, "GstLandmarkPoseMeta");
  GstVideoRegionOfInterestMeta *roi;
  gpointer state = NULL;

  printf ("frame %" G_GUINT64_FORMAT " pts %" G_GUINT64_FORMAT, frame,
      GST_BUFFER_PTS_IS_VALID (buf) ? GST_BUFFER_PTS (buf) : G_MAXUINT64);
  if (pm) {
    GstStructure *s = gst_custom_meta_get_structure (pm);
    gdouble x = 0, y = 0, h = 0;
    guint n = 0;
    const gchar *solver = gst_structure_get_string (s, "solver");
    gst_structure_get_double (s, "x", &x);
    gst_structure_get_double (s, "y", &y);
    gst_structure_get_double (s, "heading", &h);
    gst_structure_get_uint (s, "n-landmarks", &n);
    printf (" pose x=%.4f y=%.4f heading=%.4f n=%u solver=%s\n", x, y, h, n,
        solver ? solver : "?");
  } else {
    printf (" pose none\n");
  }

  while ((roi = (GstVideoRegionOfInterestMeta *)
          gst_buffer_iterate_meta_filtered (buf, &state,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    const gchar *src = "none";
    const GstStructure *r = detection_param (buf, roi, "landmark-range", &src);
    gdouble range, bearing = 0;

    printf ("det %d class=%s bbox=%u,%u,%u,%u", roi->id,
        g_quark_to_string (roi->roi_type), roi->x, roi->y, roi->w, roi->h);
    if (r && gst_structure_get_double (r, "range", &range)) {
      gst_structure_get_double (r, "bearing", &bearing);
      printf (" range=%.4f bearing=%.4f src=%s\n", range, bearing, src);
    } else {
      printf (" range=none\n");
    }
  }
}

int
main (int argc, char **argv)
{
  gchar *palette = NULL, *map = NULL, *launch = NULL, *desc;
  gdouble height = 0.5, tilt = 20, hfov = 80;
  GOptionEntry entries[] = {
    {"palette", 'p', 0, G_OPTION_ARG_FILENAME, &palette, "palette JSON", "F"},
    {"map", 'm', 0, G_OPTION_ARG_FILENAME, &map, "landmark map JSON", "F"},
    {"height", 'H', 0, G_OPTION_ARG_DOUBLE, &height, "camera height, m", "M"},
    {"tilt", 't', 0, G_OPTION_ARG_DOUBLE, &tilt, "tilt, degrees", "D"},
    {"hfov", 'f', 0, G_OPTION_ARG_DOUBLE, &hfov, "horizontal FOV, deg", "D"},
    {"launch", 'l', 0, G_OPTION_ARG_STRING, &launch,
        "launch line with 'appsink name=results'", "L"},
    {NULL}
  };
  GOptionContext *ctx = g_option_context_new ("[CLIP]");
  GError *err = NULL;
  GstElement *pipe, *sink;
  GstSample *sample;
  GstBus *bus;
  GstMessage *msg;
  guint64 frame = 0;
  int ret = 0;

  g_option_context_add_main_entries (ctx, entries, NULL);
  g_option_context_add_group (ctx, gst_init_get_option_group ());
  if (!g_option_context_parse (ctx, &argc, &argv, &err)) {
    fprintf (stderr, "%s\n", err->message);
    return 2;
  }
  g_option_context_free (ctx);

  if (launch) {
    desc = g_strdup (launch);
  } else if (argc == 2) {
    gchar *pal = palette ? g_strdup_printf ("palette=\"%s\"", palette)
        : g_strdup ("");
    gchar *ipm_map = map ? g_strdup_printf ("map=\"%s\"", map) : g_strdup ("");
    if (!map) {
      fprintf (stderr, "trilaterate needs a map: -m map.json\n");
      return 2;
    }
    desc = g_strdup_printf ("filesrc location=\"%s\" ! decodebin ! "
        "videoconvert ! labsegment %s min-class-pixels=50 ! "
        "blobroundness min-area=30 ! ipmrange camera-height=%g tilt=%g "
        "hfov=%g %s ! trilaterate %s ! appsink name=results sync=false",
        argv[1], pal, height, tilt, hfov, ipm_map, ipm_map);
    g_free (pal);
    g_free (ipm_map);
  } else {
    fprintf (stderr, "usage: %s [-p PALETTE] -m MAP [-H M] [-t DEG] "
        "[-f DEG] CLIP | -l LAUNCH\n", argv[0]);
    return 2;
  }

  pipe = gst_parse_launch (desc, &err);
  if (!pipe) {
    fprintf (stderr, "bad pipeline: %s\n", err->message);
    return 1;
  }
  sink = gst_bin_get_by_name (GST_BIN (pipe), "results");
  if (!sink || !g_signal_lookup ("pull-sample", G_OBJECT_TYPE (sink))) {
    fprintf (stderr, "no appsink named 'results'\n");
    return 1;
  }
  gst_element_set_state (pipe, GST_STATE_PLAYING);

  /* Pull every frame; NULL at EOS or on error. */
  for (;;) {
    sample = NULL;
    g_signal_emit_by_name (sink, "pull-sample", &sample);
    if (!sample)
      break;
    print_frame (gst_sample_get_buffer (sample), frame++);
    gst_sample_unref (sample);
  }

  bus = gst_element_get_bus (pipe);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  if (msg) {
    gchar *dbg = NULL;
    gst_message_parse_error (msg, &err, &dbg);
    fprintf (stderr, "error: %s (%s)\n", err->message, dbg ? dbg : "");
    g_free (dbg);
    gst_message_unref (msg);
    ret = 1;
  }
  printf ("frames %" G_GUINT64_FORMAT "\n", frame);
  gst_object_unref (bus);
  gst_element_set_state (pipe, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipe);
  g_free (desc);
  return ret;
}
