/* element-cost: the per-frame cost of single elements on synthetic 640x480
 * frames, each beside identity pushed the same way (the harness's own
 * cost), as wall-clock and process CPU time:
 *
 *   birdseye       RGB 640x480 -> 400x400 bird's-eye view, the plain remap
 *                  and with draw=boundary+landmarks+robot on a frame with a
 *                  floor meta (a wall at 1.5 m, 81 columns, 360 bins) and
 *                  eight ranged landmarks
 *   floorboundary  a label plane with a wall at row 120 and a speck every
 *                  53rd pixel, one plane for every frame
 *   blobroundness  ten ellipses of five marker classes over a background of
 *                  two labels with 2 % speckle (as labsegment leaves JPEG
 *                  frames); default and morphology=3
 *
 * It prints numbers (docs/blobroundness.md, docs/floorboundary.md quote
 * them) and asserts nothing about speed. Run it on one core with the build
 * tree's plugin:
 *
 *   GST_PLUGIN_PATH=build/plugins taskset -c 0 build/tests/bench/element-cost
 */

#include <math.h>
#include <time.h>

#include <gst/gst.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include "landmarkcheck.h"

#define W 640
#define H 480
#define GRAY_CAPS "video/x-raw,format=GRAY8,width=640,height=480,framerate=30/1"
/* label values: the default palette's order, 0 unlabelled */
#define WHITE 6
#define GREY 7

typedef struct
{
  gdouble wall_us, cpu_us;
} Cost;

static gdouble
cpu_now_us (void)
{
  struct timespec ts;
  clock_gettime (CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e6 + ts.tv_nsec / 1e3;
}

/* Mean cost of n frames (copies of `frame`, so each carries its own metas)
 * after 10 to warm up; best of `runs` runs. */
static Cost
cost_per_frame (GstHarness * h, GstBuffer * frame, guint n, guint runs)
{
  Cost best = { G_MAXDOUBLE, G_MAXDOUBLE };
  guint r, i;
  for (i = 0; i < 10; i++)
    gst_buffer_unref (gst_harness_push_and_pull (h, gst_buffer_copy (frame)));
  for (r = 0; r < runs; r++) {
    const gint64 t0 = g_get_monotonic_time ();
    const gdouble c0 = cpu_now_us ();
    for (i = 0; i < n; i++)
      gst_buffer_unref (gst_harness_push_and_pull (h,
              gst_buffer_copy (frame)));
    best.wall_us = MIN (best.wall_us,
        (g_get_monotonic_time () - t0) / (gdouble) n);
    best.cpu_us = MIN (best.cpu_us, (cpu_now_us () - c0) / n);
  }
  return best;
}

/* The element's line: its cost, identity's and the difference. */
static void
report (const gchar * what, const gchar * desc, const gchar * caps,
    GstBuffer * frame, guint n, guint runs)
{
  GstHarness *h = landmark_check_harness_new (desc, caps);
  GstHarness *ref = landmark_check_harness_new ("identity", caps);
  const Cost c = cost_per_frame (h, frame, n, runs);
  const Cost id = cost_per_frame (ref, frame, n, runs);
  g_print ("%s: %.1f us per frame (identity %.1f us, so %.1f us of work); "
      "CPU time %.1f us (identity %.1f us)\n", what, c.wall_us, id.wall_us,
      c.wall_us - id.wall_us, c.cpu_us, id.cpu_us);
  gst_harness_teardown (h);
  gst_harness_teardown (ref);
}

/* A GRAY8 frame with the plane attached as its labels. */
static GstBuffer *
labelled_frame (const guint8 * plane)
{
  GstBuffer *buf = gst_buffer_new_allocate (NULL, (gsize) W * H, NULL);
  gst_buffer_memset (buf, 0, 0x55, (gsize) W * H);
  landmark_check_labels_attach (buf, plane, W, H, W, landmark_check_names7,
      landmark_check_markers7, 7);
  return buf;
}

static void
birdseye (void)
{
  GstBuffer *frame = gst_buffer_new_allocate (NULL, (gsize) W * H * 3, NULL);
  GstMapInfo map;
  gsize i;
  gst_buffer_map (frame, &map, GST_MAP_WRITE);
  for (i = 0; i < map.size; i++)
    map.data[i] = (guint8) (i * 7 + i / (W * 3));
  gst_buffer_unmap (frame, &map);
  report ("birdseye 640x480 RGB -> 400x400",
      "birdseye camera-height=0.3 tilt=25 hfov=60",
      "video/x-raw,format=RGB,width=640,height=480,framerate=30/1", frame,
      300, 1);
  landmark_check_floor_wall_attach (frame, 1.5);
  for (i = 0; i < 8; i++)
    landmark_check_ranged_attach (frame, "red", 1.0 + 0.3 * i,
        0.8 - 0.2 * i, 0.1, TRUE, i % 2 ? "L1" : NULL);
  report ("birdseye 640x480 RGB -> 400x400, that frame with metadata, "
      "draw=none", "birdseye camera-height=0.3 tilt=25 hfov=60",
      "video/x-raw,format=RGB,width=640,height=480,framerate=30/1", frame,
      300, 1);
  report ("birdseye 640x480 RGB -> 400x400, that frame with metadata, "
      "draw=boundary+landmarks+robot",
      "birdseye camera-height=0.3 tilt=25 hfov=60 "
      "draw=boundary+landmarks+robot",
      "video/x-raw,format=RGB,width=640,height=480,framerate=30/1", frame,
      300, 1);
  gst_buffer_unref (frame);
}

static void
floorboundary (void)
{
  guint8 *plane = g_malloc ((gsize) W * H);
  GstBuffer *frame;
  gsize i;
  for (i = 0; i < (gsize) W * H; i++)
    plane[i] = (i < (gsize) W * 120 || i % 53 == 0) ? WHITE : GREY;
  frame = labelled_frame (plane);
  report ("floorboundary 640x480", "floorboundary camera-height=0.3 tilt=25 "
      "hfov=60 floor-classes=grey", GRAY_CAPS, frame, 300, 1);
  gst_buffer_unref (frame);
  g_free (plane);
}

static void
blobroundness (void)
{
  guint8 *plane = g_malloc ((gsize) W * H);
  GRand *rand = g_rand_new_with_seed (1);
  GstBuffer *frame;
  guint k, u, v;
  for (v = 0; v < H; v++)
    for (u = 0; u < W; u++)
      plane[v * W + u] = g_rand_int_range (rand, 0, 50) ? GREY : WHITE;
  /* ellipse k: centre, half axes, angle; labels 1..5 are marker classes */
  for (k = 0; k < 10; k++) {
    const gdouble cx = 60 + (k % 5) * 120, cy = 120 + (k / 5) * 220;
    const gdouble a = 24 + 7 * k, b = 9 + 3 * k, t = 0.3 * k;
    for (v = 0; v < H; v++)
      for (u = 0; u < W; u++) {
        const gdouble x = u - cx, y = v - cy;
        const gdouble p = x * cos (t) + y * sin (t), q = y * cos (t) -
            x * sin (t);
        if (p * p / (a * a) + q * q / (b * b) <= 1)
          plane[v * W + u] = 1 + k % 5;
      }
  }
  frame = labelled_frame (plane);
  report ("blobroundness 640x480, 10 blobs", "blobroundness", GRAY_CAPS,
      frame, 300, 3);
  report ("blobroundness 640x480, 10 blobs, morphology=3",
      "blobroundness morphology=3", GRAY_CAPS, frame, 100, 3);
  gst_buffer_unref (frame);
  g_rand_free (rand);
  g_free (plane);
}

int
main (int argc, char **argv)
{
  gst_init (&argc, &argv);
  birdseye ();
  floorboundary ();
  blobroundness ();
  return 0;
}
