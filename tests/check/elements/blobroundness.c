/* Unit tests of blobroundness.
 *
 * Label planes are drawn here (a pixel belongs to a shape when its centre
 * lies inside the analytic shape) and attached by hand as a
 * GstLandmarkLabelsMeta, so the tests do not depend on colour
 * classification. Expectations come from the analytic shapes and from
 * counting the drawn pixels, never from the element's own code. One test
 * runs labsegment upstream on a drawn colour frame. */

#include "landmarkcheck.h"

#include <gst/check/gstcheck.h>
#include <gst/check/gstharness.h>
#include <gst/video/video.h>

#include <math.h>
#include <string.h>

#define LABELS_META LANDMARK_LABELS_META
#define BLOB "landmark-blob"

/* ------------------------------------------------------------------ */
/* Label planes                                                       */
/* ------------------------------------------------------------------ */

typedef struct
{
  guint w, h, stride;
  guint8 *data;
} Plane;

static Plane *
plane_new (guint w, guint h, guint stride)
{
  Plane *p = g_new0 (Plane, 1);
  p->w = w;
  p->h = h;
  p->stride = stride;
  p->data = g_malloc0 ((gsize) MAX (stride * h, 1));
  return p;
}

static void
plane_free (Plane * p)
{
  g_free (p->data);
  g_free (p);
}

static void
plane_fill (Plane * p, guint8 label)
{
  guint y;
  for (y = 0; y < p->h; y++)
    memset (p->data + (gsize) y * p->stride, label, p->w);
}

/* Shapes, each as "is the point (u, v) inside". */
typedef gboolean (*InsideFunc) (const gdouble * s, gdouble u, gdouble v);

static gboolean
in_disc (const gdouble * s, gdouble u, gdouble v)
{
  return (u - s[0]) * (u - s[0]) + (v - s[1]) * (v - s[1]) <= s[2] * s[2];
}

/* s: cx, cy, full axes a, b, angle */
static gboolean
in_ellipse (const gdouble * s, gdouble u, gdouble v)
{
  const gdouble c = cos (s[4]), n = sin (s[4]);
  const gdouble x = (u - s[0]) * c + (v - s[1]) * n;
  const gdouble y = -(u - s[0]) * n + (v - s[1]) * c;
  return x * x / (s[2] * s[2] / 4) + y * y / (s[3] * s[3] / 4) <= 1;
}

/* s: cx, cy, sides sx, sy, angle */
static gboolean
in_rect (const gdouble * s, gdouble u, gdouble v)
{
  const gdouble c = cos (s[4]), n = sin (s[4]);
  const gdouble x = (u - s[0]) * c + (v - s[1]) * n;
  const gdouble y = -(u - s[0]) * n + (v - s[1]) * c;
  return fabs (x) <= s[2] / 2 && fabs (y) <= s[3] / 2;
}

/* s: cx, cy, outer radius, inner radius */
static gboolean
in_ring (const gdouble * s, gdouble u, gdouble v)
{
  const gdouble d2 = (u - s[0]) * (u - s[0]) + (v - s[1]) * (v - s[1]);
  return d2 <= s[2] * s[2] && d2 > s[3] * s[3];
}

/* s: cx, cy, side, angle: equilateral */
static gboolean
in_triangle (const gdouble * s, gdouble u, gdouble v)
{
  gint k, pos = 0, neg = 0;
  const gdouble R = s[2] / sqrt (3.0);
  for (k = 0; k < 3; k++) {
    const gdouble a0 = s[3] + k * 2 * G_PI / 3, a1 = a0 + 2 * G_PI / 3;
    const gdouble x0 = s[0] + R * cos (a0), y0 = s[1] + R * sin (a0);
    const gdouble x1 = s[0] + R * cos (a1), y1 = s[1] + R * sin (a1);
    const gdouble cr = (x1 - x0) * (v - y0) - (y1 - y0) * (u - x0);
    pos += cr >= 0;
    neg += cr <= 0;
  }
  return pos == 3 || neg == 3;
}

/* What was drawn: pixel count, box and centroid of the drawn pixels. */
typedef struct
{
  guint n;
  gint x0, y0, x1, y1;
  gdouble sx, sy;
} Drawn;

static Drawn
plane_draw (Plane * p, InsideFunc inside, const gdouble * s, guint8 label)
{
  Drawn d = { 0, G_MAXINT, G_MAXINT, -1, -1, 0, 0 };
  guint u, v;
  for (v = 0; v < p->h; v++)
    for (u = 0; u < p->w; u++)
      if (inside (s, u, v)) {
        p->data[(gsize) v * p->stride + u] = label;
        d.n++;
        d.x0 = MIN (d.x0, (gint) u);
        d.x1 = MAX (d.x1, (gint) u);
        d.y0 = MIN (d.y0, (gint) v);
        d.y1 = MAX (d.y1, (gint) v);
        d.sx += u;
        d.sy += v;
      }
  return d;
}

/* A plane of w x h (no padding) holding one disc of radius r at (cx, cy);
 * what was drawn in *drawn when asked. */
static Plane *
disc_plane (guint w, guint h, gdouble cx, gdouble cy, gdouble r,
    guint8 label, Drawn * drawn)
{
  Plane *p = plane_new (w, h, w);
  const gdouble s[3] = { cx, cy, r };
  const Drawn d = plane_draw (p, in_disc, s, label);
  if (drawn)
    *drawn = d;
  return p;
}

/* The palette of the tests: label k + 1 is names[k]. */

#define RED 1
#define GREEN 2
#define YELLOW 3
#define PINK 4
#define BLUE 5
#define WHITE 6
#define GREY 7

/* Attaches a labels meta holding a copy of the plane. */
static void
labels_attach (GstBuffer * buf, const Plane * p, const gchar ** names,
    const gboolean * markers, guint n)
{
  landmark_check_labels_attach (buf, p->data, p->w, p->h, p->stride, names,
      markers, n);
}

/* A GRAY8 frame of the plane's size (contents: a ramp, to check that the
 * element leaves them alone) with the plane attached. */
static GstBuffer *
frame_with_labels (const Plane * p)
{
  const gsize size = (gsize) GST_ROUND_UP_4 (p->w) * p->h;
  GstBuffer *buf = gst_buffer_new_allocate (NULL, MAX (size, 1), NULL);
  GstMapInfo map;
  gsize i;
  gst_buffer_map (buf, &map, GST_MAP_WRITE);
  for (i = 0; i < map.size; i++)
    map.data[i] = (guint8) (i * 7);
  gst_buffer_unmap (buf, &map);
  labels_attach (buf, p, landmark_check_names7, landmark_check_markers7,
      G_N_ELEMENTS (landmark_check_names7));
  return buf;
}

static gchar *
gray_caps (guint w, guint h)
{
  return g_strdup_printf ("video/x-raw,format=GRAY8,width=%u,height=%u,"
      "framerate=30/1", w, h);
}

/* ------------------------------------------------------------------ */
/* Running the element and reading its output                        */
/* ------------------------------------------------------------------ */

static GstHarness *
harness_new (const gchar * props, guint w, guint h)
{
  gchar *desc = g_strdup_printf ("blobroundness %s", props ? props : "");
  gchar *caps = gray_caps (w, h);
  GstHarness *hr = landmark_check_harness_new (desc, caps);
  g_free (caps);
  g_free (desc);
  return hr;
}

typedef struct
{
  guint n;
  GstVideoRegionOfInterestMeta *roi[512];
  const GstStructure *blob[512];
} Blobs;

/* Every region-of-interest meta of buf, by id; ids must be 0..n-1. */
static void
blobs_read (GstBuffer * buf, Blobs * b)
{
  gpointer state = NULL;
  GstMeta *m;
  guint i;
  memset (b, 0, sizeof (*b));
  while ((m = gst_buffer_iterate_meta_filtered (buf, &state,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    GstVideoRegionOfInterestMeta *roi = (GstVideoRegionOfInterestMeta *) m;
    fail_unless (roi->id >= 0 && roi->id < 512, "id %d", roi->id);
    fail_unless (b->roi[roi->id] == NULL, "id %d twice", roi->id);
    b->roi[roi->id] = roi;
    b->n++;
  }
  for (i = 0; i < b->n; i++) {
    fail_unless (b->roi[i] != NULL, "ids are not 0..%u", b->n - 1);
    b->blob[i] = gst_video_region_of_interest_meta_get_param (b->roi[i],
        BLOB);
    fail_unless (b->blob[i] != NULL, "no " BLOB " on detection %u", i);
  }
}

static gdouble
dbl (const GstStructure * s, const gchar * field)
{
  gdouble v = NAN;
  fail_unless (gst_structure_get_double (s, field, &v), "no double %s",
      field);
  return v;
}

static gboolean
kept (const GstStructure * s)
{
  gboolean k = FALSE;
  fail_unless (gst_structure_get_boolean (s, "kept", &k), "no kept");
  return k;
}

/* Every field of the contract (docs/metadata.md), with its type. */
static void
check_fields (const GstStructure * s, guint w, guint h)
{
  static const gchar *doubles[] = { "area", "perimeter", "roundness",
    "centroid-x", "centroid-y", "equivalent-diameter", "ellipse-x",
    "ellipse-y", "ellipse-major", "ellipse-minor", "ellipse-angle",
    "ellipse-fit", "ellipse-fit-threshold"
  };
  guint i, fw = 0, fh = 0;
  gboolean k;
  fail_unless (gst_structure_has_name (s, BLOB));
  for (i = 0; i < G_N_ELEMENTS (doubles); i++) {
    const gdouble v = dbl (s, doubles[i]);
    fail_unless (isfinite (v), "%s is %g", doubles[i], v);
  }
  fail_unless (gst_structure_get_string (s, "class") != NULL);
  fail_unless (gst_structure_get_boolean (s, "kept", &k));
  fail_unless_equals_int (gst_structure_has_field (s, "reject-reason"), !k);
  fail_unless (gst_structure_get_uint (s, "frame-width", &fw));
  fail_unless (gst_structure_get_uint (s, "frame-height", &fh));
  fail_unless_equals_int (fw, w);
  fail_unless_equals_int (fh, h);
  /* a rejected near miss of the shape test also says shape-marginal */
  gboolean marginal = FALSE;
  if (gst_structure_has_field (s, "shape-marginal"))
    fail_unless (!k && gst_structure_get_boolean (s, "shape-marginal",
            &marginal) && marginal);
  fail_unless_equals_int (gst_structure_n_fields (s),
      (k ? 17 : 18) + (marginal ? 1 : 0));
}

/* Pushes one plane through and reads what came out. */
static GstBuffer *
run (GstHarness * hr, const Plane * p, Blobs * b)
{
  GstBuffer *out = gst_harness_push_and_pull (hr, frame_with_labels (p));
  fail_unless (out != NULL);
  blobs_read (out, b);
  return out;
}

/* run () on a frame where exactly one blob must be found */
static GstBuffer *
run_one (GstHarness * hr, const Plane * p, Blobs * b)
{
  GstBuffer *out = run (hr, p, b);
  fail_unless_equals_int (b->n, 1);
  return out;
}

static void
done (GstHarness * hr, Plane * p)
{
  plane_free (p);
  gst_harness_teardown (hr);
}

/* Exactly one warning on the bus so far, of this domain and code, its
 * message naming what. */
static void
check_one_warning (GstBus * bus, GQuark domain, gint code, const gchar * what)
{
  GError *err = NULL;
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_WARNING, &err), 1);
  fail_unless (g_error_matches (err, domain, code), "%s", err->message);
  fail_unless (strstr (err->message, what) != NULL, "%s", err->message);
  g_clear_error (&err);
}

/* The detection whose centroid is nearest (cx, cy). */
static const GstStructure *
nearest (const Blobs * b, gdouble cx, gdouble cy, guint * index)
{
  guint i, best = 0;
  gdouble bd = G_MAXDOUBLE;
  fail_unless (b->n > 0, "no detection");
  for (i = 0; i < b->n; i++) {
    const gdouble d = hypot (dbl (b->blob[i], "centroid-x") - cx,
        dbl (b->blob[i], "centroid-y") - cy);
    if (d < bd) {
      bd = d;
      best = i;
    }
  }
  if (index)
    *index = best;
  return b->blob[best];
}

/* ------------------------------------------------------------------ */
/* Properties                                                         */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("properties", test_properties)
{
  GstElement *e = gst_element_factory_make ("blobroundness", NULL);
  gchar *classes = NULL;
  guint morph, amin, amax;
  gdouble rmin, fmin, aspect;
  gint shape;
  gboolean keep, qos;

  fail_unless (e != NULL);
  g_object_get (e, "classes", &classes, "morphology", &morph, "min-area",
      &amin, "max-area", &amax, "min-roundness", &rmin, "min-ellipse-fit",
      &fmin, "max-aspect", &aspect, "shape", &shape, "keep-rejected", &keep,
      "qos", &qos, NULL);
  fail_unless (classes == NULL);
  fail_unless_equals_int (morph, 0);
  fail_unless_equals_int (amin, 100);
  fail_unless_equals_int (amax, 0);
  fail_unless_equals_float (rmin, 0.85);
  fail_unless_equals_float (fmin, -1.0);
  fail_unless_equals_float (aspect, 0.0);
  fail_unless_equals_int (shape, 1);    /* ellipse */
  fail_unless (!keep);
  fail_unless (!qos);

  g_object_set (e, "classes", "red, blue", "morphology", 5, "min-area", 7,
      "max-area", 900, "min-roundness", 0.5, "min-ellipse-fit", 0.75,
      "max-aspect", 4.0, "keep-rejected", TRUE, NULL);
  gst_util_set_object_arg (G_OBJECT (e), "shape", "circle");
  g_object_get (e, "classes", &classes, "morphology", &morph, "min-area",
      &amin, "max-area", &amax, "min-roundness", &rmin, "min-ellipse-fit",
      &fmin, "max-aspect", &aspect, "shape", &shape, "keep-rejected", &keep,
      NULL);
  fail_unless_equals_string (classes, "red, blue");
  fail_unless_equals_int (morph, 5);
  fail_unless_equals_int (amin, 7);
  fail_unless_equals_int (amax, 900);
  fail_unless_equals_float (rmin, 0.5);
  fail_unless_equals_float (fmin, 0.75);
  fail_unless_equals_float (aspect, 4.0);
  fail_unless_equals_int (shape, 0);
  fail_unless (keep);
  g_free (classes);
  gst_object_unref (e);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Shapes                                                             */
/* ------------------------------------------------------------------ */

/* Discs of radius 6..40 at sub-pixel centres, one per frame: found, round
 * in both modes, area and box as drawn, centroid and ellipse as analytic */
LANDMARK_TEST ("shapes", test_discs)
{
  const gchar *modes[] = { "shape=circle", "shape=ellipse" };
  guint mode, k;
  GRand *rand = g_rand_new_with_seed (5);
  for (mode = 0; mode < 2; mode++) {
    gchar *props = g_strdup_printf ("%s min-area=20", modes[mode]);
    GstHarness *hr = harness_new (props, 101, 97);
    gdouble sum_err = 0, max_err = 0;
    const guint n = 40;
    for (k = 0; k < n; k++) {
      Plane *p = plane_new (101, 97, 101);
      const gdouble r = 6 + 34.0 * k / (n - 1);
      const gdouble s[3] = { 50 + g_rand_double_range (rand, -0.5, 0.5),
        48 + g_rand_double_range (rand, -0.5, 0.5), r
      };
      Drawn d;
      Blobs b;
      GstBuffer *out;
      const GstStructure *blob;
      gdouble err;

      plane_fill (p, GREY);
      d = plane_draw (p, in_disc, s, RED);
      out = run_one (hr, p, &b);
      blob = b.blob[0];
      check_fields (blob, 101, 97);
      fail_unless (kept (blob));
      fail_unless_equals_string (gst_structure_get_string (blob, "class"),
          "red");
      fail_unless (b.roi[0]->roi_type == g_quark_from_string ("red"));
      fail_unless_equals_int (b.roi[0]->x, d.x0);
      fail_unless_equals_int (b.roi[0]->y, d.y0);
      fail_unless_equals_int (b.roi[0]->w, d.x1 - d.x0 + 1);
      fail_unless_equals_int (b.roi[0]->h, d.y1 - d.y0 + 1);
      fail_unless_equals_float (dbl (blob, "area"), d.n);
      /* the centroid of the drawn pixels, exactly */
      fail_unless (fabs (dbl (blob, "centroid-x") - d.sx / d.n) < 1e-9);
      fail_unless (fabs (dbl (blob, "centroid-y") - d.sy / d.n) < 1e-9);
      /* and near the analytic centre: binary digitisation moves it by up
       * to 0.25 px for small discs, 0.05 px on average */
      err = hypot (dbl (blob, "centroid-x") - s[0],
          dbl (blob, "centroid-y") - s[1]);
      sum_err += err;
      max_err = MAX (max_err, err);
      fail_unless (err <= 0.26, "r=%.2f centroid off by %.3f", r, err);
      fail_unless (fabs (dbl (blob, "ellipse-major") - 2 * r) <= 1.0);
      fail_unless (fabs (dbl (blob, "ellipse-minor") - 2 * r) <= 1.0);
      fail_unless (fabs (dbl (blob, "equivalent-diameter") - 2 * r) <= 1.0);
      fail_unless (dbl (blob, "roundness") >= 0.9, "r=%.2f roundness %.3f",
          r, dbl (blob, "roundness"));
      fail_unless (dbl (blob, "ellipse-fit") >= 0.95);
      /* roundness is 4 pi area / perimeter^2 of the reported values */
      fail_unless (fabs (dbl (blob, "roundness") - 4 * G_PI *
              dbl (blob, "area") / pow (dbl (blob, "perimeter"), 2)) < 1e-9);
      /* a perimeter near the circle's: within 5 % of 2 pi r */
      fail_unless (fabs (dbl (blob, "perimeter") / (2 * G_PI * r) - 1) < 0.05,
          "r=%.2f perimeter %.2f", r, dbl (blob, "perimeter"));
      gst_buffer_unref (out);
      plane_free (p);
    }
    fail_unless (sum_err / n <= 0.1, "mean centroid error %.3f",
        sum_err / n);
    GST_INFO ("%s: centroid error mean %.3f max %.3f px", modes[mode],
        sum_err / n, max_err);
    gst_harness_teardown (hr);
    g_free (props);
  }
  g_rand_free (rand);
}

GST_END_TEST;

/* A disc drawn symmetrically about a pixel centre: centroid exact */
LANDMARK_TEST ("shapes", test_disc_centroid_exact)
{
  GstHarness *hr = harness_new (NULL, 81, 81);
  gdouble r;
  for (r = 6; r < 30; r += 1.7) {
    Plane *p = plane_new (81, 81, 81);
    const gdouble s[3] = { 40, 40, r };
    Blobs b;
    GstBuffer *out;
    plane_draw (p, in_disc, s, BLUE);
    out = run_one (hr, p, &b);
    fail_unless (fabs (dbl (b.blob[0], "centroid-x") - 40) < 1e-9);
    fail_unless (fabs (dbl (b.blob[0], "centroid-y") - 40) < 1e-9);
    gst_buffer_unref (out);
    plane_free (p);
  }
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* Drawn ellipses: axes within 1 px, angle, kept by shape=ellipse and
 * rejected by shape=circle when elongated */
LANDMARK_TEST ("shapes", test_ellipses)
{
  GstHarness *he = harness_new ("keep-rejected=true", 161, 121);
  GstHarness *hc = harness_new ("keep-rejected=true shape=circle", 161, 121);
  GRand *rand = g_rand_new_with_seed (9);
  guint k;
  for (k = 0; k < 30; k++) {
    Plane *p = plane_new (161, 121, 161);
    const gdouble a = g_rand_double_range (rand, 30, 110);
    const gdouble bb = a / g_rand_double_range (rand, 1.6, 5.0);
    const gdouble ang = g_rand_double_range (rand, -1.5, 1.5);
    const gdouble s[5] = { 80.3, 60.6, a, bb, ang };
    gdouble dang;
    Blobs b;
    GstBuffer *out;
    const GstStructure *blob;

    plane_draw (p, in_ellipse, s, YELLOW);
    out = run_one (he, p, &b);
    blob = b.blob[0];
    fail_unless (fabs (dbl (blob, "ellipse-major") - a) <= 1.0,
        "major %.2f vs %.2f", dbl (blob, "ellipse-major"), a);
    fail_unless (fabs (dbl (blob, "ellipse-minor") - bb) <= 1.0,
        "minor %.2f vs %.2f", dbl (blob, "ellipse-minor"), bb);
    dang = fmod (fabs (dbl (blob, "ellipse-angle") - ang), G_PI);
    fail_unless (MIN (dang, G_PI - dang) < 0.03, "angle %.3f vs %.3f",
        dbl (blob, "ellipse-angle"), ang);
    fail_unless (hypot (dbl (blob, "ellipse-x") - s[0],
            dbl (blob, "ellipse-y") - s[1]) < 0.3);
    fail_unless (kept (blob), "ellipse %.0f x %.0f: fit %.3f", a, bb,
        dbl (blob, "ellipse-fit"));
    gst_buffer_unref (out);

    out = run_one (hc, p, &b);
    /* aspect >= 1.6: roundness at most about 0.93 of a disc's */
    if (a / bb > 2.0) {
      fail_unless (!kept (b.blob[0]), "aspect %.2f kept as a circle",
          a / bb);
      fail_unless_equals_string (gst_structure_get_string (b.blob[0],
              "reject-reason"), "roundness");
    }
    gst_buffer_unref (out);
    plane_free (p);
  }
  g_rand_free (rand);
  gst_harness_teardown (he);
  gst_harness_teardown (hc);
}

GST_END_TEST;

/* Squares of side 20..60 at rotations 0..45 degrees, stripes, triangles,
 * rings: never kept, in either mode, for the stated reason */
static void
check_rejected (InsideFunc inside, const gdouble * s, const gchar * what)
{
  const gchar *modes[] = { "shape=circle", "shape=ellipse" };
  const gchar *reasons[] = { "roundness", "ellipse-fit" };
  guint mode;
  for (mode = 0; mode < 2; mode++) {
    gchar *props = g_strdup_printf ("%s keep-rejected=true min-area=20",
        modes[mode]);
    GstHarness *hr = harness_new (props, 151, 151);
    Plane *p = plane_new (151, 151, 151);
    Blobs b;
    GstBuffer *out;
    const gchar *why;
    plane_draw (p, inside, s, GREEN);
    out = run_one (hr, p, &b);
    fail_unless (!kept (b.blob[0]), "%s kept by %s (roundness %.3f, "
        "ellipse-fit %.3f)", what, modes[mode], dbl (b.blob[0], "roundness"),
        dbl (b.blob[0], "ellipse-fit"));
    check_fields (b.blob[0], 151, 151);
    /* thin ones may already fail the aspect limit */
    why = gst_structure_get_string (b.blob[0], "reject-reason");
    fail_unless (g_str_equal (why, reasons[mode]) || g_str_equal (why,
            "aspect"), "%s: reject-reason %s", what, why);
    gst_buffer_unref (out);
    done (hr, p);
    g_free (props);
  }
}

LANDMARK_TEST ("shapes", test_squares)
{
  guint side, deg;
  for (side = 20; side <= 60; side += 20)
    for (deg = 0; deg <= 45; deg += 9) {
      const gdouble s[5] = { 75.2, 74.7, side, side, deg * G_PI / 180 };
      gchar *what = g_strdup_printf ("square %u at %u deg", side, deg);
      check_rejected (in_rect, s, what);
      g_free (what);
    }
}

GST_END_TEST;

LANDMARK_TEST ("shapes", test_stripes_and_triangles)
{
  guint k;
  for (k = 0; k < 6; k++) {
    const gdouble ang = k * 0.5;
    const gdouble stripe[5] = { 75, 75, 60 + 10 * k, 5 + k, ang };
    const gdouble tri[4] = { 75, 75, 25 + 12 * k, ang };
    check_rejected (in_rect, stripe, "stripe");
    check_rejected (in_triangle, tri, "triangle");
  }
}

GST_END_TEST;

/* A ring: its hole counts neither as area nor as perimeter, so it scores
 * about 1 - (r/R)^2 of a disc. Rings with r >= 0.4 R are not taken for
 * discs by either test; smaller holes (glare, a printed centre) fail only
 * the ellipse test, from r >= 0.3 R (IoU (1 - f^2) / (1 + f^2)). */
LANDMARK_TEST ("shapes", test_rings)
{
  gdouble frac;
  for (frac = 0.3; frac < 0.85; frac += 0.1) {
    const gdouble s[4] = { 75.3, 74.8, 40, 40 * frac };
    GstHarness *hr = harness_new ("keep-rejected=true shape=circle", 151, 151);
    GstHarness *he = harness_new ("keep-rejected=true", 151, 151);
    Plane *p = plane_new (151, 151, 151);
    Drawn d;
    Blobs b;
    GstBuffer *out;
    plane_fill (p, WHITE);
    d = plane_draw (p, in_ring, s, PINK);
    out = run_one (hr, p, &b);
    fail_unless_equals_float (dbl (b.blob[0], "area"), d.n);
    fail_unless (dbl (b.blob[0], "roundness") < 1 - frac * frac + 0.02,
        "ring %.1f: roundness %.3f", frac, dbl (b.blob[0], "roundness"));
    gst_buffer_unref (out);
    out = run_one (he, p, &b);
    fail_unless (!kept (b.blob[0]), "ring %.1f kept: ellipse-fit %.3f", frac,
        dbl (b.blob[0], "ellipse-fit"));
    gst_buffer_unref (out);
    gst_harness_teardown (hr);
    gst_harness_teardown (he);
    plane_free (p);
    if (frac > 0.35)
      check_rejected (in_ring, s, "ring");
  }
}

GST_END_TEST;

/* Specks below min-area are dropped, or kept with reason "area" */
LANDMARK_TEST ("shapes", test_specks)
{
  GstHarness *hr = harness_new ("min-area=30", 64, 48);
  GstHarness *hk = harness_new ("min-area=30 keep-rejected=true", 64, 48);
  Plane *p = plane_new (64, 48, 64);
  const gdouble big[3] = { 40, 24, 6 };
  guint i, specks = 0, kept_n = 0;
  Blobs b;
  GstBuffer *out;

  plane_fill (p, GREY);
  plane_draw (p, in_disc, big, RED);
  /* 1- and 2-pixel specks and a 3x3 block far from the disc */
  for (i = 0; i < 8; i++) {
    p->data[(2 + 5 * i) * 64 + 3] = RED;
    p->data[(2 + 5 * i) * 64 + 10] = RED;
    p->data[(2 + 5 * i) * 64 + 11] = RED;
    specks += 2;
  }
  for (i = 0; i < 9; i++)
    p->data[(40 + i / 3) * 64 + 20 + i % 3] = BLUE;
  specks++;

  out = run_one (hr, p, &b);
  fail_unless (dbl (b.blob[0], "area") > 100);
  gst_buffer_unref (out);

  out = run (hk, p, &b);
  fail_unless_equals_int (b.n, specks + 1);
  for (i = 0; i < b.n; i++) {
    check_fields (b.blob[i], 64, 48);
    if (kept (b.blob[i])) {
      kept_n++;
    } else {
      fail_unless_equals_string (gst_structure_get_string (b.blob[i],
              "reject-reason"), "area");
    }
  }
  fail_unless_equals_int (kept_n, 1);
  gst_buffer_unref (out);
  done (hr, p);
  gst_harness_teardown (hk);
}

GST_END_TEST;

/* max-area and max-aspect */
LANDMARK_TEST ("shapes", test_area_and_aspect_limits)
{
  GstHarness *hr = harness_new ("keep-rejected=true max-area=2000 "
      "min-area=50 max-aspect=10", 200, 100);
  Plane *p = plane_new (200, 100, 200);
  const gdouble small[3] = { 30, 50, 12 }, large[3] = { 100, 50, 30 };
  const gdouble thin[5] = { 170, 50, 48, 4.2, 0.3 };
  guint i;
  Blobs b;
  GstBuffer *out;
  plane_draw (p, in_disc, small, RED);
  plane_draw (p, in_disc, large, RED);
  plane_draw (p, in_ellipse, thin, RED);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 3);
  for (i = 0; i < 3; i++) {
    const gdouble x = dbl (b.blob[i], "centroid-x");
    const gchar *why = gst_structure_get_string (b.blob[i], "reject-reason");
    if (x < 60) {
      fail_unless (kept (b.blob[i]));
    } else if (x < 140) {
      fail_unless_equals_string (why, "max-area");
    } else {
      fail_unless_equals_string (why, "aspect");
    }
  }
  gst_buffer_unref (out);
  g_object_set (hr->element, "max-aspect", 0.0, NULL);
  out = run (hr, p, &b);
  fail_unless (kept (nearest (&b, 170, 50, NULL)));
  gst_buffer_unref (out);
  done (hr, p);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Classes, order, ids                                                */
/* ------------------------------------------------------------------ */

static Plane *
many_blobs_plane (guint w, guint h, guint per_class)
{
  Plane *p = plane_new (w, h, w);
  guint c, k;
  plane_fill (p, GREY);
  for (c = 0; c < 7; c++)
    for (k = 0; k < per_class; k++) {
      const gdouble s[3] = { 14 + 28.0 * k + (c % 2) * 0.4, 14 + 28.0 * c,
        9 + (c % 3)
      };
      plane_draw (p, in_disc, s, c + 1);
    }
  return p;
}

LANDMARK_TEST ("shapes", test_classes)
{
  const guint per = 12;
  Plane *p = many_blobs_plane (340, 200, per);
  GstHarness *hr = harness_new ("min-area=20", 340, 200);
  Blobs b;
  GstBuffer *out;
  guint i;
  gchar *classes;

  /* default: the 5 marker classes, by class then in raster order */
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 5 * per);
  for (i = 0; i < b.n; i++) {
    const guint c = i / per, k = i % per;
    fail_unless_equals_string (gst_structure_get_string (b.blob[i], "class"),
        landmark_check_names7[c]);
    fail_unless (fabs (dbl (b.blob[i], "centroid-x") - (14 + 28.0 * k +
                (c % 2) * 0.4)) < 0.3);
    fail_unless (kept (b.blob[i]));
  }
  gst_buffer_unref (out);

  /* a list, including a background class, in any order */
  g_object_set (hr->element, "classes", " grey,blue ", NULL);
  out = run (hr, p, &b);
  /* grey is the background: one huge blob with holes, not a disc */
  for (i = 0; i < b.n; i++)
    fail_unless_equals_string (gst_structure_get_string (b.blob[i], "class"),
        "blue");
  fail_unless_equals_int (b.n, per);
  gst_buffer_unref (out);
  g_object_set (hr->element, "keep-rejected", TRUE, NULL);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, per + 1);
  fail_unless_equals_string (gst_structure_get_string (b.blob[per], "class"),
      "grey");
  fail_unless (!kept (b.blob[per]));
  gst_buffer_unref (out);

  g_object_get (hr->element, "classes", &classes, NULL);
  fail_unless_equals_string (classes, " grey,blue ");
  g_free (classes);
  done (hr, p);
}

GST_END_TEST;

/* Hundreds of blobs over several classes in one frame, every frame */
LANDMARK_TEST ("shapes", test_many_blobs)
{
  const guint per = 22;
  Plane *p = many_blobs_plane (640, 200, per);
  GstHarness *hr = harness_new ("min-area=20", 640, 200);
  guint f, i;
  for (f = 0; f < 20; f++) {
    Blobs b;
    GstBuffer *out = run (hr, p, &b);
    fail_unless_equals_int (b.n, 5 * per);
    for (i = 0; i < b.n; i++) {
      fail_unless_equals_int (b.roi[i]->id, i);
      fail_unless (kept (b.blob[i]));
    }
    gst_buffer_unref (out);
  }
  done (hr, p);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Morphology                                                         */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("shapes", test_morphology)
{
  GstHarness *hr = harness_new ("min-area=20", 120, 60);
  Plane *p = plane_new (120, 60, 120);
  const gdouble left[3] = { 30, 30, 14 }, right[3] = { 90, 30, 14 };
  Drawn dl, dr;
  guint x;
  Blobs b;
  GstBuffer *out;

  /* two discs joined by a one-pixel bridge; the left one with a hole */
  plane_fill (p, GREY);
  dl = plane_draw (p, in_disc, left, RED);
  dr = plane_draw (p, in_disc, right, RED);
  for (x = 44; x <= 76; x++)
    p->data[30 * 120 + x] = RED;
  p->data[28 * 120 + 30] = GREY;

  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 0);      /* one blob, not an ellipse */
  gst_buffer_unref (out);
  g_object_set (hr->element, "keep-rejected", TRUE, NULL);
  out = run_one (hr, p, &b);
  fail_unless_equals_float (dbl (b.blob[0], "area"), dl.n + dr.n + 33 - 2 -
      1);
  gst_buffer_unref (out);

  /* opening cuts the bridge, closing fills the hole */
  g_object_set (hr->element, "morphology", 3, "keep-rejected", FALSE, NULL);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 2);
  fail_unless (fabs (dbl (b.blob[0], "centroid-x") - 30) < 0.3);
  fail_unless (fabs (dbl (b.blob[1], "centroid-x") - 90) < 0.3);
  fail_unless (fabs (dbl (b.blob[0], "area") - dl.n) <= 8);
  fail_unless (dbl (b.blob[0], "roundness") >= 0.9);
  gst_buffer_unref (out);

  /* larger kernels still find both */
  g_object_set (hr->element, "morphology", 7, NULL);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 2);
  gst_buffer_unref (out);
  plane_free (p);

  /* frame after frame, boxes of other sizes and places: a clean disc
   * keeps its area within the kernel's rounding of the edge */
  for (x = 0; x < 12; x++) {
    const gdouble s[3] = { 20 + 6.5 * x, 30 - 0.3 * x, 6 + x };
    Plane *q = plane_new (120, 60, 120);
    Drawn d;
    plane_fill (q, GREY);
    d = plane_draw (q, in_disc, s, 1 + x % 5);
    g_object_set (hr->element, "morphology", 1 + 2 * (x % 4), NULL);
    out = run_one (hr, q, &b);
    fail_unless (fabs (dbl (b.blob[0], "area") - d.n) <= 0.03 * d.n + 2,
        "disc %u: area %.0f, drawn %u", x, dbl (b.blob[0], "area"), d.n);
    fail_unless (fabs (dbl (b.blob[0], "centroid-x") - s[0]) < 0.5,
        "disc %u (r %.0f, kernel %u): centroid %.3f, drawn at %.3f", x, s[2],
        1 + 2 * (x % 4), dbl (b.blob[0], "centroid-x"), s[0]);
    gst_buffer_unref (out);
    plane_free (q);
  }
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* Frame sizes, strides, caps                                         */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("frames", test_odd_sizes)
{
  static const guint sizes[][2] = { {1, 1}, {1, 7}, {7, 1}, {2, 3}, {17, 5},
  {641, 479}, {33, 481}
  };
  guint i;
  for (i = 0; i < G_N_ELEMENTS (sizes); i++) {
    const guint w = sizes[i][0], h = sizes[i][1];
    GstHarness *hr = harness_new ("min-area=0 keep-rejected=true", w, h);
    Plane *p = plane_new (w, h, w + 3);
    Blobs b;
    GstBuffer *out;
    /* the whole frame one class */
    plane_fill (p, BLUE);
    out = run_one (hr, p, &b);
    fail_unless_equals_float (dbl (b.blob[0], "area"), w * h);
    fail_unless_equals_int (b.roi[0]->x, 0);
    fail_unless_equals_int (b.roi[0]->y, 0);
    fail_unless_equals_int (b.roi[0]->w, w);
    fail_unless_equals_int (b.roi[0]->h, h);
    check_fields (b.blob[0], w, h);
    fail_unless (fabs (dbl (b.blob[0], "centroid-x") - (w - 1) / 2.0) < 1e-9);
    fail_unless (fabs (dbl (b.blob[0], "centroid-y") - (h - 1) / 2.0) < 1e-9);
    gst_buffer_unref (out);
    /* nothing of a marker class */
    plane_fill (p, WHITE);
    out = run (hr, p, &b);
    fail_unless_equals_int (b.n, 0);
    gst_buffer_unref (out);
    /* a disc in the corner of a large odd frame, padded stride */
    if (w > 100 && h > 100) {
      const gdouble s[3] = { w - 9.6, h - 10.2, 15 };
      Drawn d = plane_draw (p, in_disc, s, RED);
      out = run_one (hr, p, &b);
      fail_unless_equals_float (dbl (b.blob[0], "area"), d.n);
      fail_unless_equals_int (b.roi[0]->x + b.roi[0]->w, w);
      fail_unless_equals_int (b.roi[0]->y + b.roi[0]->h, h);
      gst_buffer_unref (out);
    }
    done (hr, p);
  }
}

GST_END_TEST;

/* Any video/x-raw caps; the pixels are neither read nor changed */
LANDMARK_TEST ("frames", test_any_caps_video_untouched)
{
  static const gchar *caps[] = {
    "video/x-raw,format=I420,width=64,height=48,framerate=25/1",
    "video/x-raw,format=BGRx,width=64,height=48,framerate=25/1",
    "video/x-raw(memory:SystemMemory),format=NV12,width=64,height=48",
    "video/x-raw,format=GRAY16_LE,width=64,height=48",
  };
  guint i;
  for (i = 0; i < G_N_ELEMENTS (caps); i++) {
    GstHarness *hr = gst_harness_new ("blobroundness");
    Plane *p = disc_plane (64, 48, 30, 20, 8, GREEN, NULL);
    GstBuffer *in, *out;
    GstMapInfo a, c;
    Blobs b;
    gst_harness_set_src_caps_str (hr, caps[i]);
    g_object_set (hr->element, "min-area", 20, NULL);
    in = frame_with_labels (p);
    gst_buffer_ref (in);        /* keep a reference: the bytes must stay */
    gst_buffer_map (in, &a, GST_MAP_READ);
    out = gst_harness_push_and_pull (hr, gst_buffer_copy (in));
    blobs_read (out, &b);
    fail_unless_equals_int (b.n, 1);
    gst_buffer_map (out, &c, GST_MAP_READ);
    fail_unless_equals_int (a.size, c.size);
    fail_unless (memcmp (a.data, c.data, a.size) == 0);
    gst_buffer_unmap (out, &c);
    gst_buffer_unmap (in, &a);
    gst_buffer_unref (in);
    gst_buffer_unref (in);
    gst_buffer_unref (out);
    done (hr, p);
  }
}

GST_END_TEST;

/* A label plane whose size differs from the caps: the boxes are in
 * pixels of the frame, the landmark-blob values in the plane's */
LANDMARK_TEST ("frames", test_plane_size_differs)
{
  GstHarness *hr = harness_new ("min-area=20", 200, 100);
  Drawn d;
  Plane *p = disc_plane (100, 50, 40, 20, 8, RED, &d);
  Blobs b;
  GstBuffer *out = run_one (hr, p, &b);
  guint fw;
  fail_unless_equals_int (b.roi[0]->x, 2 * d.x0);
  fail_unless_equals_int (b.roi[0]->w, 2 * (d.x1 - d.x0 + 1));
  fail_unless (gst_structure_get_uint (b.blob[0], "frame-width", &fw));
  fail_unless_equals_int (fw, 100);
  fail_unless (fabs (dbl (b.blob[0], "centroid-x") - d.sx / d.n) < 1e-9);
  gst_buffer_unref (out);
  done (hr, p);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* No labels, bad settings, live changes                              */
/* ------------------------------------------------------------------ */

LANDMARK_TEST ("errors", test_no_labels_meta)
{
  GstHarness *hr = harness_new (NULL, 32, 24);
  GstBus *bus = gst_bus_new ();
  guint i;
  gst_element_set_bus (hr->element, bus);
  for (i = 0; i < 10; i++) {
    GstBuffer *in = gst_buffer_new_allocate (NULL, 32 * 24, NULL);
    GstBuffer *out;
    gst_buffer_memset (in, 0, (guint8) i, 32 * 24);
    GST_BUFFER_PTS (in) = i * GST_SECOND / 30;
    out = gst_harness_push_and_pull (hr, in);
    fail_unless (out != NULL);
    fail_unless_equals_uint64 (GST_BUFFER_PTS (out), i * GST_SECOND / 30);
    fail_unless (gst_buffer_get_video_region_of_interest_meta (out) == NULL);
    gst_buffer_unref (out);
  }
  check_one_warning (bus, GST_STREAM_ERROR, GST_STREAM_ERROR_FORMAT,
      "labsegment");
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_ERROR, NULL), 0);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  gst_harness_teardown (hr);
}

GST_END_TEST;

/* start() fails with RESOURCE/SETTINGS naming the property */
LANDMARK_TEST ("errors", test_bad_properties)
{
  static const gchar *const bad[] = {
    "morphology=4",
    "morphology=2",
    "min-area=500;max-area=100",
    "classes=red,,blue",
    "classes= , ",
    NULL
  };
  landmark_check_bad_settings ("blobroundness", bad);
}

GST_END_TEST;

/* An unknown class is known only once the labels arrive: an error then */
LANDMARK_TEST ("errors", test_unknown_class)
{
  GstHarness *hr = harness_new ("classes=red,purple", 32, 24);
  GstBus *bus = gst_bus_new ();
  Plane *p = plane_new (32, 24, 32);
  GError *err = NULL;
  gst_element_set_bus (hr->element, bus);
  fail_unless_equals_int (gst_harness_push (hr, frame_with_labels (p)),
      GST_FLOW_ERROR);
  fail_unless_equals_int (landmark_check_count_messages (bus,
          GST_MESSAGE_ERROR, &err), 1);
  fail_unless (g_error_matches (err, GST_RESOURCE_ERROR,
          GST_RESOURCE_ERROR_SETTINGS));
  fail_unless (strstr (err->message, "'classes'") != NULL);
  fail_unless (strstr (err->message, "purple") != NULL);
  g_clear_error (&err);
  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  done (hr, p);
}

GST_END_TEST;

/* Changes while playing take effect at the next frame; a bad value is
 * reported once and the previous settings stay */
LANDMARK_TEST ("properties", test_change_while_playing)
{
  GstHarness *hr = harness_new ("min-area=20", 100, 60);
  GstBus *bus = gst_bus_new ();
  Plane *p = plane_new (100, 60, 100);
  const gdouble a[3] = { 25, 30, 6 }, c[3] = { 70, 30, 12 };
  Blobs b;
  GstBuffer *out;
  guint i;

  gst_element_set_bus (hr->element, bus);
  plane_draw (p, in_disc, a, RED);
  plane_draw (p, in_disc, c, RED);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 2);
  gst_buffer_unref (out);

  g_object_set (hr->element, "min-area", 200, NULL);
  out = run_one (hr, p, &b);
  gst_buffer_unref (out);

  g_object_set (hr->element, "morphology", 4, NULL);
  for (i = 0; i < 3; i++) {
    out = run_one (hr, p, &b);    /* min-area=200 still in force */
    gst_buffer_unref (out);
  }
  check_one_warning (bus, GST_RESOURCE_ERROR, GST_RESOURCE_ERROR_SETTINGS,
      "'morphology'");

  g_object_set (hr->element, "morphology", 0, "min-area", 20, NULL);
  out = run (hr, p, &b);
  fail_unless_equals_int (b.n, 2);
  gst_buffer_unref (out);

  gst_element_set_bus (hr->element, NULL);
  gst_object_unref (bus);
  done (hr, p);
}

GST_END_TEST;

/* Properties hammered from another thread while frames stream */
LANDMARK_TEST ("properties", test_property_stress)
{
  GstHarness *hr = harness_new (NULL, 160, 120);
  Plane *p = many_blobs_plane (160, 120, 5);
  GValue v = G_VALUE_INIT;
  GstHarnessThread *t1, *t2, *t3;
  guint i;

  g_value_init (&v, G_TYPE_UINT);
  g_value_set_uint (&v, 3);
  t1 = gst_harness_stress_property_start_full (hr, "morphology", &v, 100);
  g_value_unset (&v);
  g_value_init (&v, G_TYPE_STRING);
  g_value_set_string (&v, "red,blue");
  t2 = gst_harness_stress_property_start_full (hr, "classes", &v, 100);
  g_value_unset (&v);
  g_value_init (&v, G_TYPE_DOUBLE);
  g_value_set_double (&v, 0.5);
  t3 = gst_harness_stress_property_start_full (hr, "min-ellipse-fit", &v,
      100);
  g_value_unset (&v);
  for (i = 0; i < 200; i++) {
    Blobs b;
    GstBuffer *out = run (hr, p, &b);
    gst_buffer_unref (out);
  }
  gst_harness_stress_thread_stop (t1);
  gst_harness_stress_thread_stop (t2);
  gst_harness_stress_thread_stop (t3);
  done (hr, p);
}

GST_END_TEST;

/* QoS is off: late frames are measured, never dropped */
LANDMARK_TEST ("frames", test_no_frame_dropped)
{
  GstHarness *hr = harness_new ("min-area=20", 64, 48);
  Plane *p = disc_plane (64, 48, 30, 20, 8, RED, NULL);
  GstBuffer *templ = frame_with_labels (p);
  landmark_check_no_frame_dropped (hr, templ, 50, LABELS_META);
  gst_buffer_unref (templ);
  done (hr, p);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* A busy frame (its cost: tests/bench/element-cost.c)                */
/* ------------------------------------------------------------------ */

/* 640x480, five marker classes, ten ellipses of 150 to 3000 pixels over a
 * background of two labels with 2 % speckle (as labsegment leaves JPEG
 * frames): the ten blobs are found and kept, with and without morphology. */
LANDMARK_TEST ("pipelines", test_speckled_background)
{
  Plane *p = plane_new (640, 480, 640);
  GRand *rand = g_rand_new_with_seed (1);
  const gchar *props[] = { NULL, "morphology=3" };
  gsize i;
  guint k, j;

  for (i = 0; i < (gsize) 640 * 480; i++)
    p->data[i] = g_rand_int_range (rand, 0, 50) ? GREY : WHITE;
  for (k = 0; k < 10; k++) {
    const gdouble s[5] = { 60 + (k % 5) * 120, 120 + (k / 5) * 220,
      24 + 7 * k, 9 + 3 * k, 0.3 * k
    };
    plane_draw (p, in_ellipse, s, 1 + k % 5);
  }
  for (k = 0; k < G_N_ELEMENTS (props); k++) {
    GstHarness *hr = harness_new (props[k], 640, 480);
    Blobs b;
    GstBuffer *out = run (hr, p, &b);
    fail_unless_equals_int (b.n, 10);
    for (j = 0; j < b.n; j++)
      fail_unless (kept (b.blob[j]), "%s: blob %u",
          props[k] ? props[k] : "defaults", j);
    gst_buffer_unref (out);
    gst_harness_teardown (hr);
  }
  g_rand_free (rand);
  plane_free (p);
}

GST_END_TEST;

/* ------------------------------------------------------------------ */
/* With labsegment upstream                                           */
/* ------------------------------------------------------------------ */

/* Grey #808080 and blue #1E50C8 are exactly the built-in palette's grey
 * and blue; pink #FF69B4 its pink. */
LANDMARK_TEST ("pipelines", test_labsegment_pipeline)
{
  GstHarness *hr = gst_harness_new_parse ("labsegment min-class-pixels=0 ! "
      "blobroundness min-area=50");
  const guint w = 321, h = 241, stride = GST_ROUND_UP_4 (w * 3);
  const gdouble d1[3] = { 100.4, 120.7, 20 };
  const gdouble e2[5] = { 230.2, 80.5, 70, 22, 0.2 };
  const gdouble sq[5] = { 240, 190, 40, 40, 0.5 };
  GstBuffer *in, *out;
  GstMapInfo map;
  guint u, v;
  Blobs b;
  const GstStructure *blob;
  guint idx;

  gst_harness_set_src_caps_str (hr, "video/x-raw,format=BGR,width=321,"
      "height=241,framerate=30/1");
  in = gst_buffer_new_allocate (NULL, (gsize) stride * h, NULL);
  gst_buffer_map (in, &map, GST_MAP_WRITE);
  for (v = 0; v < h; v++)
    for (u = 0; u < w; u++) {
      guint8 *px = map.data + (gsize) v * stride + 3 * u;
      guint8 r = 0x80, g = 0x80, bl = 0x80;
      if (in_disc (d1, u, v) || in_rect (sq, u, v)) {
        r = 0x1e;
        g = 0x50;
        bl = 0xc8;
      } else if (in_ellipse (e2, u, v)) {
        r = 0xff;
        g = 0x69;
        bl = 0xb4;
      }
      px[0] = bl;
      px[1] = g;
      px[2] = r;
    }
  gst_buffer_unmap (in, &map);
  out = gst_harness_push_and_pull (hr, in);
  blobs_read (out, &b);
  /* the disc and the ellipse; the blue square is no ellipse */
  fail_unless_equals_int (b.n, 2);
  blob = nearest (&b, d1[0], d1[1], &idx);
  fail_unless_equals_string (gst_structure_get_string (blob, "class"),
      "blue");
  fail_unless (hypot (dbl (blob, "centroid-x") - d1[0],
          dbl (blob, "centroid-y") - d1[1]) < 0.26);
  fail_unless (fabs (dbl (blob, "equivalent-diameter") - 40) < 1);
  fail_unless (dbl (blob, "roundness") > 0.9);
  blob = nearest (&b, e2[0], e2[1], &idx);
  fail_unless_equals_string (gst_structure_get_string (blob, "class"),
      "pink");
  fail_unless (fabs (dbl (blob, "ellipse-major") - 70) < 1);
  fail_unless (fabs (dbl (blob, "ellipse-minor") - 22) < 1);
  fail_unless (fabs (dbl (blob, "ellipse-angle") - 0.2) < 0.03);
  fail_unless (gst_buffer_get_custom_meta (out, LABELS_META) != NULL);
  gst_buffer_unref (out);
  gst_harness_teardown (hr);
}

GST_END_TEST;

LANDMARK_CHECK_MAIN (blobroundness);
