/* Input and harness helpers shared by the benchmark programs that read raw
 * frames from a file (labsegment-bench, chain-bench): the frames, a checked
 * launch description, the plugin's file, a timed push and pull, and the
 * frame-copy floor. Each prints its own error, prefixed with the program's
 * name, and returns FALSE or NULL. */
#pragma once

#include <string.h>

#include <gst/gst.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include "benchtiming.h"

/* The options of every frame benchmark; the caller sets the defaults. */
typedef struct
{
  gchar *input, *format, *launch;
  gint width, height, frames, warmup;
  gboolean no_copy;
} BenchArgs;

/* Parses the command line: the common options into *a, the program's own
 * `extra` entries and GStreamer's. FALSE, said, when it cannot, or when
 * --input, --width, --height or a positive --frames is missing. */
static inline gboolean
bench_parse_args (const gchar * prog, const gchar * summary, BenchArgs * a,
    const gchar * launch_help, const GOptionEntry * extra, int *argc,
    char ***argv)
{
  gchar *frames_help = g_strdup_printf ("Timed frames (default %d)",
      a->frames);
  gchar *warmup_help = g_strdup_printf ("Untimed frames first; at least one "
      "per distinct input frame (default %d)", a->warmup);
  const GOptionEntry common[] = {
    {"input", 'i', 0, G_OPTION_ARG_FILENAME, &a->input,
        "Raw frames, default GStreamer strides, back to back", "FILE"},
    {"format", 'f', 0, G_OPTION_ARG_STRING, &a->format,
        "GStreamer video format name (BGRx, YUY2, I420, ...)", "FORMAT"},
    {"width", 0, 0, G_OPTION_ARG_INT, &a->width, "Frame width", "PIXELS"},
    {"height", 0, 0, G_OPTION_ARG_INT, &a->height, "Frame height", "PIXELS"},
    {"launch", 'l', 0, G_OPTION_ARG_STRING, &a->launch, launch_help, "DESC"},
    {"frames", 'n', 0, G_OPTION_ARG_INT, &a->frames, frames_help, "N"},
    {"warmup", 0, 0, G_OPTION_ARG_INT, &a->warmup, warmup_help, "N"},
    {"no-copy", 0, 0, G_OPTION_ARG_NONE, &a->no_copy,
        "Skip the frame-copy measurement", NULL},
    {NULL}
  };
  GError *err = NULL;
  GOptionContext *ctx = g_option_context_new (summary);
  g_option_context_add_main_entries (ctx, common, NULL);
  g_option_context_add_main_entries (ctx, extra, NULL);
  g_option_context_add_group (ctx, gst_init_get_option_group ());
  gboolean ok = g_option_context_parse (ctx, argc, argv, &err);
  if (!ok) {
    g_printerr ("%s: %s\n", prog, err->message);
    g_error_free (err);
  } else if (!a->input || a->width <= 0 || a->height <= 0 || a->frames <= 0
      || a->warmup < 0) {
    g_printerr ("%s: need --input, --width, --height (and positive "
        "--frames); see --help\n", prog);
    ok = FALSE;
  }
  g_option_context_free (ctx);
  g_free (frames_help);
  g_free (warmup_help);
  return ok;
}

/* The video info of packed frames of a format and size; FALSE, said, for
 * an unknown format or a bad size. */
static inline gboolean
bench_video_info (const gchar * prog, const gchar * format_name, gint width,
    gint height, GstVideoInfo * info)
{
  const GstVideoFormat format = gst_video_format_from_string (format_name);
  if (format == GST_VIDEO_FORMAT_UNKNOWN
      || !gst_video_info_set_format (info, format, width, height)) {
    g_printerr ("%s: unknown format or size %s %dx%d\n", prog, format_name,
        width, height);
    return FALSE;
  }
  return TRUE;
}

/* The whole frames of `frame_size` bytes in `path`: *data (g_free it) and
 * their number; *warmup raised to at least one pass over them. */
static inline gboolean
bench_read_frames (const gchar * prog, const gchar * path, gsize frame_size,
    guint8 ** data, guint * n_frames, gint * warmup)
{
  GError *err = NULL;
  gchar *contents = NULL;
  gsize size = 0;
  if (!g_file_get_contents (path, &contents, &size, &err)) {
    g_printerr ("%s: %s\n", prog, err->message);
    g_error_free (err);
    return FALSE;
  }
  if (size == 0 || size % frame_size != 0) {
    g_printerr ("%s: %s holds %" G_GSIZE_FORMAT " bytes, not whole frames "
        "of %" G_GSIZE_FORMAT " bytes\n", prog, path, size, frame_size);
    g_free (contents);
    return FALSE;
  }
  *data = (guint8 *) contents;
  *n_frames = size / frame_size;
  if ((guint) * warmup < *n_frames)
    *warmup = *n_frames;
  return TRUE;
}

/* The frames of --input as --format (default_format when not given; NULL:
 * required) and --width x --height, with the caps colorimetry when given:
 * their video info, *data (g_free it) and number. 0, or the exit status
 * after saying why not: 2 for a bad format, size or colorimetry, 1 for a
 * file that cannot be read or is not whole frames. */
static inline int
bench_load_frames (const gchar * prog, BenchArgs * a,
    const gchar * default_format, const gchar * colorimetry,
    GstVideoInfo * info, guint8 ** data, guint * n_frames)
{
  const gchar *format = a->format ? a->format : default_format;
  if (!format) {
    g_printerr ("%s: need --format; see --help\n", prog);
    return 2;
  }
  if (!bench_video_info (prog, format, a->width, a->height, info))
    return 2;
  if (colorimetry && !gst_video_colorimetry_from_string (&info->colorimetry,
          colorimetry)) {
    g_printerr ("%s: unknown colorimetry %s\n", prog, colorimetry);
    return 2;
  }
  if (!bench_read_frames (prog, a->input, GST_VIDEO_INFO_SIZE (info), data,
          n_frames, &a->warmup))
    return 1;
  return 0;
}

/* gst_harness_new_parse asserts on a bad description: parse it first so
 * the user gets the parser's message. */
static inline gboolean
bench_launch_ok (const gchar * prog, const gchar * launch)
{
  GError *err = NULL;
  GstElement *e = gst_parse_launch_full (launch, NULL,
      GST_PARSE_FLAG_FATAL_ERRORS, &err);
  if (!e) {
    g_printerr ("%s: bad --launch \"%s\": %s\n", prog, launch,
        err ? err->message : "unknown error");
    g_clear_error (&err);
    return FALSE;
  }
  gst_object_unref (e);
  return TRUE;
}

/* The file the element factory was loaded from (g_free it), so the caller
 * can check the build tree's plugin ran; NULL when unknown. */
static inline gchar *
bench_plugin_file (GstElementFactory * factory)
{
  gchar *file = NULL;
  GstPlugin *plugin = factory ?
      GST_PLUGIN (gst_plugin_feature_get_plugin (GST_PLUGIN_FEATURE
          (factory))) : NULL;
  if (plugin) {
    file = g_strdup (gst_plugin_get_filename (plugin));
    gst_object_unref (plugin);
  }
  return file;
}

/* Pushes frame i and pulls its output, *ns the time of the pair; NULL when
 * either fails. */
static inline GstBuffer *
bench_push_pull (const gchar * prog, GstHarness * h, GstBuffer * in, guint i,
    gint64 * ns)
{
  const gint64 t0 = now_ns ();
  if (gst_harness_push (h, in) != GST_FLOW_OK) {
    g_printerr ("%s: push of frame %u failed\n", prog, i);
    return NULL;
  }
  GstBuffer *out = gst_harness_pull (h);
  *ns = now_ns () - t0;
  if (!out)
    g_printerr ("%s: no output for frame %u\n", prog, i);
  return out;
}

/* The memory-bound floor: a memcpy of each frame in turn into one
 * preallocated buffer, `frames` timed after `warmup` (free t->ns). */
static inline void
bench_time_copy (const guint8 * data, guint n_frames, gsize frame_size,
    guint warmup, guint frames, Timing * t)
{
  guint8 *dst = g_malloc0 (frame_size);
  t->name = "copy";
  t->ns = g_new (gint64, frames);
  t->n = 0;
  for (guint i = 0; i < warmup + frames; i++) {
    const guint8 *src = data + (gsize) (i % n_frames) * frame_size;
    const gint64 t0 = now_ns ();
    memcpy (dst, src, frame_size);
    /* keep the compiler from dropping the copy */
    __asm__ __volatile__ ("":::"memory");
    const gint64 t1 = now_ns ();
    if (i >= warmup)
      t->ns[t->n++] = t1 - t0;
  }
  summarise (t);
  g_free (dst);
}
