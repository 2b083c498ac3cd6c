/* labsegment-bench: per-frame time of labsegment, beside a plain frame copy.
 *
 * Reads raw frames (packed with GStreamer's default strides, as
 * gst_video_info_set_format computes them) from a file, pushes them in turn
 * through a GstHarness running the given launch string, and times each
 * gst_harness_push + gst_harness_pull pair with CLOCK_MONOTONIC after a
 * warm-up.  Then it times a memcpy of a frame of the same size into a
 * preallocated buffer as often (the memory-bound floor).  Output: one JSON
 * object per line, one per measurement.
 *
 * This is a benchmark that prints numbers, not a test: it asserts nothing
 * about speed.  Run it pinned to one core (taskset -c 0) with the build
 * tree's plugin on GST_PLUGIN_PATH; python/gstlandmark/bench.py does both.
 *
 *   labsegment-bench --input frames.raw --format BGRx --width 640 \
 *       --height 480 [--launch "labsegment min-class-pixels=500"] \
 *       [--colorimetry bt601] [--frames 500] [--warmup 10] \
 *       [--dump-labels labels.raw]
 */

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gst/gst.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include "benchinput.h"

#define LABELS_META_NAME "GstLandmarkLabelsMeta"

static void
print_timing (const Timing * t, const gchar * launch,
    const GstVideoInfo * info, guint n_distinct, guint warmup,
    const gchar * plugin_file)
{
  GString *s = g_string_new ("{\"name\": ");
  json_string (s, t->name);
  g_string_append (s, ", \"launch\": ");
  json_string (s, launch ? launch : "");
  g_string_append (s, ", \"format\": ");
  json_string (s, GST_VIDEO_INFO_NAME (info));
  gchar *cm = gst_video_colorimetry_to_string (&info->colorimetry);
  g_string_append (s, ", \"colorimetry\": ");
  json_string (s, cm ? cm : "");
  g_free (cm);
  g_string_append_printf (s, ", \"width\": %d, \"height\": %d, "
      "\"frame_bytes\": %" G_GSIZE_FORMAT ", \"frames\": %u, "
      "\"distinct_frames\": %u, \"warmup\": %u, ",
      GST_VIDEO_INFO_WIDTH (info), GST_VIDEO_INFO_HEIGHT (info),
      GST_VIDEO_INFO_SIZE (info), t->n, n_distinct, warmup);
  g_string_append_printf (s, "\"median_ms\": %.6f, \"p10_ms\": %.6f, "
      "\"p90_ms\": %.6f, \"mean_ms\": %.6f, \"min_ms\": %.6f, "
      "\"max_ms\": %.6f", t->median_ms, t->p10_ms, t->p90_ms, t->mean_ms,
      t->min_ms, t->max_ms);
  if (plugin_file) {
    g_string_append (s, ", \"plugin_file\": ");
    json_string (s, plugin_file);
  }
  g_string_append (s, "}\n");
  fputs (s->str, stdout);
  fflush (stdout);
  g_string_free (s, TRUE);
}

/* Writes the label plane of buf (width bytes per row, stride dropped) to
 * out; FALSE when the buffer has no labels meta. */
static gboolean
dump_labels (GstBuffer * buf, FILE * out, const GstVideoInfo * info)
{
  GstCustomMeta *meta = gst_buffer_get_custom_meta (buf, LABELS_META_NAME);
  if (!meta) {
    g_printerr ("labsegment-bench: output buffer has no %s\n",
        LABELS_META_NAME);
    return FALSE;
  }
  const GstStructure *s = gst_custom_meta_get_structure (meta);
  GstBuffer *plane = NULL;
  guint w = 0, h = 0, stride = 0;
  if (!gst_structure_get (s, "labels", GST_TYPE_BUFFER, &plane,
          "width", G_TYPE_UINT, &w, "height", G_TYPE_UINT, &h,
          "stride", G_TYPE_UINT, &stride, NULL)) {
    g_printerr ("labsegment-bench: labels meta lacks plane fields: %s\n",
        gst_structure_to_string (s));
    return FALSE;
  }
  gboolean ok = TRUE;
  GstMapInfo map;
  if (w != (guint) GST_VIDEO_INFO_WIDTH (info)
      || h != (guint) GST_VIDEO_INFO_HEIGHT (info) || stride < w
      || !gst_buffer_map (plane, &map, GST_MAP_READ)) {
    g_printerr ("labsegment-bench: unexpected label plane %ux%u stride %u\n",
        w, h, stride);
    gst_buffer_unref (plane);
    return FALSE;
  }
  if (map.size < (gsize) stride * h) {
    g_printerr ("labsegment-bench: label plane too small\n");
    ok = FALSE;
  }
  for (guint y = 0; ok && y < h; y++)
    ok = fwrite (map.data + (gsize) y * stride, 1, w, out) == w;
  gst_buffer_unmap (plane, &map);
  gst_buffer_unref (plane);
  return ok;
}

/* True when the element named "labsegment" in the harness draws into the
 * frame (output=labels): its input must then be a fresh copy each time. */
static gboolean
element_writes_frames (GstHarness * h)
{
  GObjectClass *klass = G_OBJECT_GET_CLASS (h->element);
  GParamSpec *pspec = g_object_class_find_property (klass, "output");
  if (!pspec || !G_IS_PARAM_SPEC_ENUM (pspec))
    return FALSE;
  gint output = 0;
  g_object_get (h->element, "output", &output, NULL);
  return output != G_PARAM_SPEC_ENUM (pspec)->default_value;
}

int
main (int argc, char **argv)
{
  BenchArgs a = {.frames = 500,.warmup = 10 };
  gchar *dump_path = NULL, *colorimetry = NULL;
  const GOptionEntry entries[] = {
    {"colorimetry", 0, 0, G_OPTION_ARG_STRING, &colorimetry,
        "Caps colorimetry, e.g. bt601 or bt709 (default: GStreamer's "
          "default for the format and size)", "NAME"},
    {"dump-labels", 0, 0, G_OPTION_ARG_FILENAME, &dump_path,
        "Write the label plane (width x height bytes) of each distinct "
          "input frame, in input order", "FILE"},
    {NULL}
  };
  if (!bench_parse_args ("labsegment-bench", "- time labsegment per frame",
          &a, "Element and properties, launch syntax (default "
          "\"labsegment\")", entries, &argc, &argv))
    return 2;
  if (!a.launch)
    a.launch = g_strdup ("labsegment");

  GstVideoInfo info;
  guint8 *data = NULL;
  guint n_distinct = 0;
  const int status = bench_load_frames ("labsegment-bench", &a, NULL,
      colorimetry, &info, &data, &n_distinct);
  if (status)
    return status;
  const gsize frame_size = GST_VIDEO_INFO_SIZE (&info);

  if (!bench_launch_ok ("labsegment-bench", a.launch))
    return 1;

  GstHarness *h = gst_harness_new_parse (a.launch);
  gst_harness_set_src_caps (h, gst_video_info_to_caps (&info));
  const gboolean fresh_input = element_writes_frames (h);
  guint8 *scratch = g_malloc (frame_size);

  GstElementFactory *factory = gst_element_factory_find ("labsegment");
  gchar *plugin_file = bench_plugin_file (factory);
  if (factory)
    gst_object_unref (factory);

  FILE *dump = NULL;
  if (dump_path && !(dump = fopen (dump_path, "wb"))) {
    g_printerr ("labsegment-bench: %s: %s\n", dump_path, g_strerror (errno));
    return 1;
  }

  Timing element = {.name = "labsegment",.ns = g_new (gint64, a.frames) };
  const GstClockTime duration = gst_util_uint64_scale_int (GST_SECOND, 1, 30);
  for (guint i = 0; i < (guint) (a.warmup + a.frames); i++) {
    guint8 *src = data + (gsize) (i % n_distinct) * frame_size;
    if (fresh_input) {
      /* output=labels draws into the frame: keep the input pristine */
      memcpy (scratch, src, frame_size);
      src = scratch;
    }
    GstBuffer *in = gst_buffer_new_wrapped_full ((GstMemoryFlags) 0, src,
        frame_size, 0, frame_size, NULL, NULL);
    GST_BUFFER_PTS (in) = i * duration;
    GST_BUFFER_DURATION (in) = duration;

    gint64 ns;
    GstBuffer *out = bench_push_pull ("labsegment-bench", h, in, i, &ns);
    if (!out)
      return 1;
    if (dump && i < n_distinct && !dump_labels (out, dump, &info))
      return 1;
    /* drops the meta, so the label plane goes back to its pool */
    gst_buffer_unref (out);
    if (i >= (guint) a.warmup)
      element.ns[element.n++] = ns;
  }
  if (dump && fclose (dump) != 0) {
    g_printerr ("labsegment-bench: %s: %s\n", dump_path, g_strerror (errno));
    return 1;
  }
  summarise (&element);
  print_timing (&element, a.launch, &info, n_distinct, a.warmup, plugin_file);
  gst_harness_teardown (h);

  if (!a.no_copy) {
    Timing copy;
    bench_time_copy (data, n_distinct, frame_size, a.warmup, a.frames, &copy);
    print_timing (&copy, "memcpy", &info, n_distinct, a.warmup, NULL);
    g_free (copy.ns);
  }

  g_free (element.ns);
  g_free (scratch);
  g_free (data);
  g_free (a.input);
  g_free (a.format);
  g_free (a.launch);
  g_free (colorimetry);
  g_free (dump_path);
  g_free (plugin_file);
  gst_deinit ();
  return 0;
}
