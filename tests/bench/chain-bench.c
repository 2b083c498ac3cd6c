/* chain-bench: per-element and whole-chain time of the landmark chain.
 *
 * Reads raw frames (BGRx or any packed format, GStreamer's default strides,
 * back to back) from a file and pushes them in turn through a GstHarness
 * running a launch description such as
 *
 *   labsegment palette=p.json min-class-pixels=0 ! blobroundness !
 *   ipmrange camera-height=0.5 tilt=20 hfov=80 map=m.json !
 *   trilaterate map=m.json
 *
 * Every element of the chain gets a buffer probe on its sink pad and one on
 * its src pad; each probe stores clock_gettime (CLOCK_MONOTONIC).  An
 * element's own time for a frame is (its src probe) - (its sink probe): the
 * probes fire in the pushing thread, before the buffer goes downstream, so
 * the difference is that element's work on the frame and nothing else.
 * The chain's time is (last element's src probe) - (first element's sink
 * probe); "push+pull" is the harness round trip around it.
 *
 * Then a memcpy of a frame of the same size into a preallocated buffer
 * (the memory-bound floor), and optionally a long run that reads VmRSS from
 * /proc/self/status every --rss-every frames after a warm-up.
 *
 * Output: one JSON object per line.  This prints numbers; it asserts
 * nothing about speed.  Run it pinned to one core (taskset -c 0) with the
 * build tree's plugin on GST_PLUGIN_PATH; python/gstlandmark/chainbench.py
 * ("gst-landmark bench chain") does both.
 *
 *   chain-bench --input frames.raw --format BGRx --width 640 --height 480 \
 *       --launch "labsegment ... ! trilaterate map=m.json" \
 *       [--frames 500] [--warmup 20] [--label chain] [--no-copy] \
 *       [--rss-frames 10000] [--rss-every 1000] [--rss-warmup 500]
 */

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <gst/gst.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include "benchinput.h"

#define POSE_META_NAME "GstLandmarkPoseMeta"
#define MAX_ELEMENTS 16

/* A probe's record: the time of the current frame, and the number of
 * calls (a check of 1:1 flow). */
typedef struct
{
  gint64 t;
  guint n;
} Mark;

/* One probed element: the probes write the time of the current frame. */
typedef struct
{
  GstElement *element;
  gchar *factory;
  Mark in, out;                 /* at its sink pad and at its src pad */
} Stage;

static void
print_timing (const Timing * t, const gchar * label, const gchar * kind,
    const GstVideoInfo * info, guint n_distinct, const gchar * extra)
{
  GString *s = g_string_new ("{\"type\": ");
  json_string (s, kind);
  g_string_append (s, ", \"run\": ");
  json_string (s, label);
  g_string_append (s, ", \"name\": ");
  json_string (s, t->name);
  g_string_append_printf (s, ", \"width\": %d, \"height\": %d, "
      "\"frame_bytes\": %" G_GSIZE_FORMAT ", \"frames\": %u, "
      "\"distinct_frames\": %u, \"median_ms\": %.6f, \"p10_ms\": %.6f, "
      "\"p90_ms\": %.6f, \"mean_ms\": %.6f, \"min_ms\": %.6f, "
      "\"max_ms\": %.6f", GST_VIDEO_INFO_WIDTH (info),
      GST_VIDEO_INFO_HEIGHT (info), GST_VIDEO_INFO_SIZE (info), t->n,
      n_distinct, t->median_ms, t->p10_ms, t->p90_ms, t->mean_ms, t->min_ms,
      t->max_ms);
  if (extra)
    g_string_append (s, extra);
  g_string_append (s, "}\n");
  fputs (s->str, stdout);
  fflush (stdout);
  g_string_free (s, TRUE);
}

static GstPadProbeReturn
probe_mark (G_GNUC_UNUSED GstPad * pad,
    G_GNUC_UNUSED GstPadProbeInfo * pinfo, gpointer user_data)
{
  Mark *m = user_data;
  m->t = now_ns ();
  m->n++;
  return GST_PAD_PROBE_OK;
}

/* The elements of the harness's bin in stream order, following src pads
 * from the element behind the bin's sink ghost pad; probes attached. */
static guint
find_stages (GstHarness * h, Stage * stages)
{
  guint n = 0;
  GstElement *bin = h->element;
  GstPad *ghost = gst_element_get_static_pad (bin, "sink");
  GstPad *target = ghost ? gst_ghost_pad_get_target (GST_GHOST_PAD (ghost))
      : NULL;
  GstElement *el = target ? gst_pad_get_parent_element (target) : NULL;
  if (target)
    gst_object_unref (target);
  if (ghost)
    gst_object_unref (ghost);
  while (el && el != bin && n < MAX_ELEMENTS) {
    GstPad *sink = gst_element_get_static_pad (el, "sink");
    GstPad *src = gst_element_get_static_pad (el, "src");
    Stage *st = &stages[n++];
    st->element = el;
    st->factory = g_strdup (GST_OBJECT_NAME (gst_element_get_factory (el)));
    if (sink) {
      gst_pad_add_probe (sink, GST_PAD_PROBE_TYPE_BUFFER, probe_mark, &st->in,
          NULL);
      gst_object_unref (sink);
    }
    GstElement *next = NULL;
    if (src) {
      gst_pad_add_probe (src, GST_PAD_PROBE_TYPE_BUFFER, probe_mark, &st->out,
          NULL);
      GstPad *peer = gst_pad_get_peer (src);
      if (peer) {
        next = gst_pad_get_parent_element (peer);
        gst_object_unref (peer);
      }
      gst_object_unref (src);
    }
    el = next;
    if (el == bin) {
      gst_object_unref (el);
      el = NULL;
    }
  }
  if (el)
    gst_object_unref (el);
  return n;
}

static glong
vm_rss_kb (const gchar * key)
{
  FILE *f = fopen ("/proc/self/status", "r");
  if (!f)
    return -1;
  char line[256];
  glong kb = -1;
  const size_t klen = strlen (key);
  while (fgets (line, sizeof line, f)) {
    if (strncmp (line, key, klen) == 0 && line[klen] == ':') {
      kb = strtol (line + klen + 1, NULL, 10);
      break;
    }
  }
  fclose (f);
  return kb;
}

/* Counters of what the chain produced on one frame. */
typedef struct
{
  guint frames, with_pose, detections, ranged;
} Output;

static void
inspect_output (GstBuffer * out, Output * o)
{
  o->frames++;
  if (gst_buffer_get_custom_meta (out, POSE_META_NAME))
    o->with_pose++;
  gpointer state = NULL;
  GstMeta *m;
  while ((m = gst_buffer_iterate_meta_filtered (out, &state,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *) m;
    o->detections++;
    GstStructure *r = gst_video_region_of_interest_meta_get_param (roi,
        "landmark-range");
    if (r && gst_structure_has_field (r, "ground-x"))
      o->ranged++;
  }
}

typedef struct
{
  guint8 *data;
  gsize frame_size;
  guint n_distinct;
  guint8 *scratch;              /* fresh copy per frame when writing */
  gboolean fresh;
  GstClockTime duration;
  guint64 pushed;
} Feeder;

static GstBuffer *
next_buffer (Feeder * f)
{
  guint8 *src = f->data + (gsize) (f->pushed % f->n_distinct) * f->frame_size;
  if (f->fresh) {
    /* an overlay draws into the frame: keep the input frames pristine */
    memcpy (f->scratch, src, f->frame_size);
    src = f->scratch;
  }
  GstBuffer *in = gst_buffer_new_wrapped_full ((GstMemoryFlags) 0, src,
      f->frame_size, 0, f->frame_size, NULL, NULL);
  GST_BUFFER_PTS (in) = f->pushed * f->duration;
  GST_BUFFER_DURATION (in) = f->duration;
  f->pushed++;
  return in;
}

static gboolean
chain_has_writer (Stage * stages, guint n)
{
  for (guint i = 0; i < n; i++)
    if (g_str_equal (stages[i].factory, "landmarkoverlay"))
      return TRUE;
  return FALSE;
}

int
main (int argc, char **argv)
{
  BenchArgs a = {.frames = 500,.warmup = 20 };
  gchar *label = NULL;
  gint rss_frames = 0, rss_every = 1000, rss_warmup = 500;
  const GOptionEntry entries[] = {
    {"label", 0, 0, G_OPTION_ARG_STRING, &label,
        "Name of this run in the output (default \"chain\")", "NAME"},
    {"rss-frames", 0, 0, G_OPTION_ARG_INT, &rss_frames,
        "Then push this many more frames and sample VmRSS (default 0: "
          "no memory run)", "N"},
    {"rss-every", 0, 0, G_OPTION_ARG_INT, &rss_every,
        "VmRSS sample period in frames (default 1000)", "N"},
    {"rss-warmup", 0, 0, G_OPTION_ARG_INT, &rss_warmup,
        "Frames of the memory run before the first sample (default 500)",
        "N"},
    {NULL}
  };
  if (!bench_parse_args ("chain-bench",
          "- time the landmark chain per element", &a,
          "The chain, launch syntax (required)", entries, &argc, &argv))
    return 2;
  if (!a.launch || rss_frames < 0 || rss_every <= 0 || rss_warmup < 0) {
    g_printerr ("chain-bench: need --launch (and --rss-every above 0); see "
        "--help\n");
    return 2;
  }
  if (!label)
    label = g_strdup ("chain");

  GstVideoInfo info;
  guint8 *contents = NULL;
  guint n_frames = 0;
  const int status = bench_load_frames ("chain-bench", &a, "BGRx", NULL,
      &info, &contents, &n_frames);
  if (status)
    return status;
  const gsize frame_size = GST_VIDEO_INFO_SIZE (&info);
  Feeder feed = {.data = contents,.frame_size = frame_size,
    .n_distinct = n_frames,
    .duration = gst_util_uint64_scale_int (GST_SECOND, 1, 30)
  };

  if (!bench_launch_ok ("chain-bench", a.launch))
    return 1;

  GstHarness *h = gst_harness_new_parse (a.launch);
  Stage stages[MAX_ELEMENTS] = { {0} };
  const guint n_stages = find_stages (h, stages);
  if (n_stages == 0) {
    g_printerr ("chain-bench: no elements found in \"%s\"\n", a.launch);
    return 1;
  }
  gst_harness_set_src_caps (h, gst_video_info_to_caps (&info));
  feed.fresh = chain_has_writer (stages, n_stages);
  feed.scratch = g_malloc (frame_size);

  /* where the plugin came from, so the caller can check the build tree */
  gchar *plugin_file =
      bench_plugin_file (gst_element_get_factory (stages[0].element));

  Timing per[MAX_ELEMENTS];
  for (guint k = 0; k < n_stages; k++)
    per[k] = (Timing) {
    .name = stages[k].factory,.ns = g_new (gint64, a.frames)};
  Timing chain = {.name = "chain",.ns = g_new (gint64, a.frames) };
  Timing round = {.name = "push+pull",.ns = g_new (gint64, a.frames) };
  Output produced = { 0 };

  for (guint i = 0; i < (guint) (a.warmup + a.frames); i++) {
    GstBuffer *in = next_buffer (&feed);
    for (guint k = 0; k < n_stages; k++)
      stages[k].in.t = stages[k].out.t = 0;
    gint64 ns;
    GstBuffer *out = bench_push_pull ("chain-bench", h, in, i, &ns);
    if (!out)
      return 1;
    if (i >= (guint) a.warmup) {
      for (guint k = 0; k < n_stages; k++)
        per[k].ns[per[k].n++] = stages[k].out.t - stages[k].in.t;
      chain.ns[chain.n++] = stages[n_stages - 1].out.t - stages[0].in.t;
      round.ns[round.n++] = ns;
      inspect_output (out, &produced);
    }
    gst_buffer_unref (out);
  }
  for (guint k = 0; k < n_stages; k++) {
    if (stages[k].in.n != stages[k].out.n
        || stages[k].in.n != (guint) (a.warmup + a.frames)) {
      g_printerr ("chain-bench: %s saw %u buffers in, %u out for %u "
          "frames\n", stages[k].factory, stages[k].in.n, stages[k].out.n,
          a.warmup + a.frames);
      return 1;
    }
  }

  GString *extra = g_string_new (NULL);
  g_string_append (extra, ", \"launch\": ");
  json_string (extra, a.launch);
  g_string_append (extra, ", \"plugin_file\": ");
  json_string (extra, plugin_file ? plugin_file : "");
  g_string_append_printf (extra, ", \"warmup\": %d, \"output_frames\": %u, "
      "\"frames_with_pose\": %u, \"detections\": %u, \"ranged\": %u",
      a.warmup, produced.frames, produced.with_pose, produced.detections,
      produced.ranged);
  for (guint k = 0; k < n_stages; k++) {
    summarise (&per[k]);
    print_timing (&per[k], label, "element", &info, feed.n_distinct, NULL);
  }
  summarise (&chain);
  print_timing (&chain, label, "chain", &info, feed.n_distinct, extra->str);
  summarise (&round);
  print_timing (&round, label, "harness", &info, feed.n_distinct, NULL);
  g_string_free (extra, TRUE);

  if (rss_frames > 0) {
    /* steady state: warm up, then sample VmRSS every rss_every frames */
    GString *s = g_string_new ("{\"type\": \"rss\", \"run\": ");
    json_string (s, label);
    g_string_append_printf (s, ", \"width\": %d, \"height\": %d, "
        "\"frames\": %d, \"every\": %d, \"warmup\": %d, \"samples_kb\": [",
        a.width, a.height, rss_frames, rss_every, rss_warmup);
    glong first = -1, last = -1, peak = -1;
    Output mem = { 0 };
    const gint64 start = now_ns ();
    for (guint i = 0; i < (guint) (rss_warmup + rss_frames); i++) {
      if (gst_harness_push (h, next_buffer (&feed)) != GST_FLOW_OK) {
        g_printerr ("chain-bench: memory run: push failed\n");
        return 1;
      }
      GstBuffer *out = gst_harness_pull (h);
      if (!out) {
        g_printerr ("chain-bench: memory run: no output\n");
        return 1;
      }
      inspect_output (out, &mem);
      gst_buffer_unref (out);
      const guint done = i + 1;
      if (done >= (guint) rss_warmup
          && (done - rss_warmup) % (guint) rss_every == 0) {
        const glong kb = vm_rss_kb ("VmRSS");
        if (first < 0)
          first = kb;
        else
          g_string_append (s, ", ");
        g_string_append_printf (s, "%ld", kb);
        last = kb;
        peak = MAX (peak, kb);
      }
    }
    const gdouble secs = (now_ns () - start) / 1e9;
    g_string_append_printf (s, "], \"first_kb\": %ld, \"last_kb\": %ld, "
        "\"max_kb\": %ld, \"growth_kb\": %ld, \"vm_hwm_kb\": %ld, "
        "\"frames_with_pose\": %u, \"seconds\": %.3f}\n", first, last, peak,
        last - first, vm_rss_kb ("VmHWM"), mem.with_pose, secs);
    fputs (s->str, stdout);
    fflush (stdout);
    g_string_free (s, TRUE);
  }
  gst_harness_teardown (h);

  if (!a.no_copy) {
    Timing copy;
    bench_time_copy (feed.data, feed.n_distinct, frame_size, a.warmup, a.frames,
        &copy);
    print_timing (&copy, "memcpy", "copy", &info, feed.n_distinct, NULL);
    g_free (copy.ns);
  }

  for (guint k = 0; k < n_stages; k++) {
    g_free (per[k].ns);
    g_free (stages[k].factory);
  }
  g_free (chain.ns);
  g_free (round.ns);
  g_free (feed.scratch);
  g_free (contents);
  g_free (plugin_file);
  g_free (a.input);
  g_free (a.format);
  g_free (a.launch);
  g_free (label);
  gst_deinit ();
  return 0;
}
