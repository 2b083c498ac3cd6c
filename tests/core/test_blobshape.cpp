/* Tests of the blob shape measurement (plugins/landmark/core/shape/blobshape.h)
 * without GStreamer. Shapes are drawn here by sampling each pixel centre
 * against the analytic shape; expectations come from the analytic shapes
 * and, for outlines and moments, from OpenCV's own findContours and
 * connectedComponentsWithStats. Prints the disc / square roundness table
 * that docs/blobroundness.md quotes. */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "blobshape.h"
#include "corecheck.h"

using namespace landmark;

/* Heap allocations are counted while `counting` is set. Normally malloc,
 * calloc and realloc of this program go through here (operator new calls
 * malloc) to glibc's own; under AddressSanitizer, which owns malloc, its
 * allocation hook counts instead. */
static volatile bool counting = false;
static volatile long allocations = 0;

#if defined(__SANITIZE_ADDRESS__)
#define LANDMARK_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LANDMARK_ASAN 1
#endif
#endif

#ifdef LANDMARK_ASAN
#include <sanitizer/allocator_interface.h>

static void
count_malloc (const volatile void *, size_t)
{
  if (counting)
    allocations = allocations + 1;
}

static void
ignore_free (const volatile void *)
{
}

static const int hooks_installed =
    __sanitizer_install_malloc_and_free_hooks (count_malloc, ignore_free);
#else
extern "C" {
void *__libc_malloc (size_t);
void *__libc_calloc (size_t, size_t);
void *__libc_realloc (void *, size_t);
}

extern "C" void *
malloc (size_t n)
{
  if (counting)
    allocations = allocations + 1;
  return __libc_malloc (n);
}

extern "C" void *
calloc (size_t n, size_t m)
{
  if (counting)
    allocations = allocations + 1;
  return __libc_calloc (n, m);
}

extern "C" void *
realloc (void *p, size_t n)
{
  if (counting)
    allocations = allocations + 1;
  return __libc_realloc (p, n);
}
#endif

/* ---- drawing ---------------------------------------------------------- */

/* Pixel (u, v) is set when its centre (u, v) lies in the shape. */
template <typename Inside>
static cv::Mat
draw (int w, int h, Inside inside)
{
  cv::Mat m (h, w, CV_8UC1, cv::Scalar (0));
  for (int v = 0; v < h; v++)
    for (int u = 0; u < w; u++)
      if (inside (u, v))
        m.at<uint8_t> (v, u) = 255;
  return m;
}

static cv::Mat
draw_disc (int w, int h, double cx, double cy, double r)
{
  return draw (w, h, [=](int u, int v) {
        return (u - cx) * (u - cx) + (v - cy) * (v - cy) <= r * r;
      });
}

/* a shape given in its own axes (x along angle), centred on (cx, cy) */
template <typename Inside>
static cv::Mat
draw_turned (int w, int h, double cx, double cy, double angle, Inside inside)
{
  const double c = std::cos (angle), s = std::sin (angle);
  return draw (w, h, [=](int u, int v) {
        return inside ((u - cx) * c + (v - cy) * s,
            -(u - cx) * s + (v - cy) * c);
      });
}

/* ellipse with full axes a (along angle) and b */
static cv::Mat
draw_ellipse (int w, int h, double cx, double cy, double a, double b,
    double angle)
{
  return draw_turned (w, h, cx, cy, angle, [=](double x, double y) {
        return (x * x) / (a * a / 4) + (y * y) / (b * b / 4) <= 1;
      });
}

static cv::Mat
draw_rect (int w, int h, double cx, double cy, double sx, double sy,
    double angle)
{
  return draw_turned (w, h, cx, cy, angle, [=](double x, double y) {
        return std::fabs (x) <= sx / 2 && std::fabs (y) <= sy / 2;
      });
}

static cv::Mat
draw_triangle (int w, int h, double cx, double cy, double side,
    double angle)
{
  double px[3], py[3];
  const double R = side / std::sqrt (3.0);
  for (int k = 0; k < 3; k++) {
    px[k] = cx + R * std::cos (angle + k * 2 * M_PI / 3);
    py[k] = cy + R * std::sin (angle + k * 2 * M_PI / 3);
  }
  return draw (w, h, [=](int u, int v) {
        int pos = 0, neg = 0;
        for (int k = 0; k < 3; k++) {
          const int j = (k + 1) % 3;
          const double cr = (px[j] - px[k]) * (v - py[k]) -
              (py[j] - py[k]) * (u - px[k]);
          pos += cr >= 0;
          neg += cr <= 0;
        }
        return pos == 3 || neg == 3;
      });
}

static BlobShape
only_blob (const cv::Mat & m)
{
  std::vector<BlobShape> b = blob_measure_mask (m);
  CHECK (b.size () == 1, "%zu blobs, expected 1", b.size ());
  return b.empty ()? BlobShape () : b[0];
}

/* Classic estimators, for the comparison table only. */
static double
crack_length (const cv::Mat & m)
{
  int edges = 0;
  for (int v = 0; v < m.rows; v++)
    for (int u = 0; u < m.cols; u++) {
      if (!m.at<uint8_t> (v, u))
        continue;
      edges += u == 0 || !m.at<uint8_t> (v, u - 1);
      edges += u == m.cols - 1 || !m.at<uint8_t> (v, u + 1);
      edges += v == 0 || !m.at<uint8_t> (v - 1, u);
      edges += v == m.rows - 1 || !m.at<uint8_t> (v + 1, u);
    }
  return edges;
}

static double
opencv_arc_length (const cv::Mat & m)
{
  std::vector<std::vector<cv::Point>> cs;
  cv::findContours (m.clone (), cs, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  return cs.empty ()? 0 : cv::arcLength (cs[0], true);
}

/* ---- outlines and moments against OpenCV ------------------------------ */

static void
test_against_opencv ()
{
  int compared = 0;
  std::mt19937 rng (7);
  std::uniform_real_distribution<double> U (0, 1);
  for (int trial = 0; trial < 60; trial++) {
    const int w = 20 + (int) (U (rng) * 60), h = 15 + (int) (U (rng) * 50);
    cv::Mat m (h, w, CV_8UC1, cv::Scalar (0));
    /* unions of random discs and rectangles, and scattered pixels (thin
     * parts, diagonal contacts, holes, blobs in holes) */
    for (int k = 0; k < 6; k++) {
      const double cx = U (rng) * w, cy = U (rng) * h;
      if (k % 2)
        cv::bitwise_or (m, draw_disc (w, h, cx, cy, 1 + U (rng) * 8), m);
      else
        cv::bitwise_or (m, draw_rect (w, h, cx, cy, 1 + U (rng) * 12,
                1 + U (rng) * 4, U (rng) * M_PI), m);
    }
    for (int k = 0; k < w * h / 12; k++)
      m.at<uint8_t> ((int) (U (rng) * h), (int) (U (rng) * w)) ^= 255;

    cv::Mat labels, stats, cents;
    const int n = cv::connectedComponentsWithStats (m, labels, stats, cents,
        8, CV_32S);
    std::vector<std::vector<cv::Point>> cs;
    std::vector<cv::Vec4i> hier;
    cv::findContours (m.clone (), cs, hier, cv::RETR_CCOMP,
        cv::CHAIN_APPROX_NONE);

    BlobAnalyzer a;
    a.begin (w, h);
    a.add_mask_runs (m, 0, 0, 1);
    a.label ();
    CHECK ((int) a.count () == n - 1, "trial %d: %zu components, OpenCV %d",
        trial, a.count (), n - 1);
    for (size_t i = 0; i < a.count (); i++) {
      BlobShape b;
      a.measure (i, &b);
      const cv::Point start = a.contour ()[0];
      const int lab = labels.at<int> (start.y, start.x);
      CHECK (b.area == stats.at<int> (lab, cv::CC_STAT_AREA),
          "area %g vs %d", b.area, stats.at<int> (lab, cv::CC_STAT_AREA));
      CHECK (b.bbox_x == stats.at<int> (lab, cv::CC_STAT_LEFT) &&
          b.bbox_y == stats.at<int> (lab, cv::CC_STAT_TOP) &&
          b.bbox_w == stats.at<int> (lab, cv::CC_STAT_WIDTH) &&
          b.bbox_h == stats.at<int> (lab, cv::CC_STAT_HEIGHT), "bbox");
      CHECK (std::fabs (b.centroid_x - cents.at<double> (lab, 0)) < 1e-9 &&
          std::fabs (b.centroid_y - cents.at<double> (lab, 1)) < 1e-9,
          "centroid (%g, %g) vs (%g, %g)", b.centroid_x, b.centroid_y,
          cents.at<double> (lab, 0), cents.at<double> (lab, 1));
      /* the outer contour OpenCV finds from the same start pixel: the
       * same points in the same cyclic order, either direction */
      const std::vector<cv::Point> *ref = nullptr;
      for (size_t k = 0; k < cs.size (); k++)
        if (hier[k][3] < 0 && cs[k][0] == start)
          ref = &cs[k];
      CHECK (ref != nullptr, "no OpenCV outer contour starts at (%d, %d)",
          start.x, start.y);
      if (!ref)
        continue;
      const auto & mine = a.contour ();
      bool same = ref->size () == mine.size ();
      if (same) {
        bool fwd = true, bwd = true;
        const size_t L = mine.size ();
        for (size_t k = 0; k < L; k++) {
          fwd = fwd && mine[k] == (*ref)[k];
          bwd = bwd && mine[k] == (*ref)[(L - k) % L];
        }
        same = fwd || bwd;
      }
      CHECK (same, "trial %d blob %zu: contour of %zu points, OpenCV %zu",
          trial, i, mine.size (), ref->size ());
      compared++;
    }
  }
  printf ("outlines and moments: %d components identical to OpenCV's\n",
      compared);
}

/* ---- the estimator: discs and squares --------------------------------- */

static void
test_disc_square_table ()
{
  std::mt19937 rng (11);
  std::uniform_real_distribution<double> off (-0.5, 0.5);

  printf ("\nroundness of digitised discs (pixel centres inside the disc)\n"
      "radius px   blobroundness        | pixel edges  OpenCV arcLength  "
      "arcLength+pi   (24 sub-pixel centres per 0.25 px of radius;\n"
      "            min    mean   max    |   min          min              "
      "min             the others: their minimum)\n");
  const double bands[][2] = { {5, 6}, {6, 8}, {8, 10}, {10, 15}, {15, 20},
  {20, 30}, {30, 45}, {45, 60.01}
  };
  double worst_disc = 1e9, worst_disc_r = 0;
  for (const auto & band : bands) {
    double mn = 1e9, mx = 0, sum = 0, crack = 1e9, arc = 1e9, arcpi = 1e9;
    int cnt = 0;
    for (double r = band[0]; r < band[1]; r += 0.25) {
      for (int k = 0; k < 24; k++) {
        const int size = (int) (2 * r) + 8;
        const double cx = size / 2.0 + off (rng), cy = size / 2.0 + off (rng);
        cv::Mat m = draw_disc (size, size, cx, cy, r);
        BlobShape b = only_blob (m);
        mn = std::min (mn, b.roundness);
        mx = std::max (mx, b.roundness);
        sum += b.roundness;
        cnt++;
        if (b.roundness < worst_disc) {
          worst_disc = b.roundness;
          worst_disc_r = r;
        }
        const double A = b.area;
        const double P1 = crack_length (m), P2 = opencv_arc_length (m);
        crack = std::min (crack, 4 * M_PI * A / (P1 * P1));
        arc = std::min (arc, 4 * M_PI * A / (P2 * P2));
        arcpi = std::min (arcpi, 4 * M_PI * A / ((P2 + M_PI) * (P2 + M_PI)));
        CHECK (b.roundness >= 0.9, "disc r=%.2f at (%.2f, %.2f): %.4f", r,
            cx, cy, b.roundness);
      }
    }
    printf ("%4.0f-%-4.0f    %.3f  %.3f  %.3f  |   %.3f        %.3f"
        "            %.3f\n", band[0], std::floor (band[1]), mn, sum / cnt,
        mx, crack, arc, arcpi);
  }
  printf ("lowest disc: %.4f (radius %.2f)\n", worst_disc, worst_disc_r);

  printf ("\nroundness of digitised squares (max over 4 sub-pixel "
      "centres), rotation in degrees\nside px ");
  for (int deg = 0; deg <= 45; deg += 3)
    printf ("  %2d  ", deg);
  printf ("   max  | pixel edges  arcLength+pi (max)\n");
  double worst_sq = 0;
  int worst_side = 0, worst_deg = 0;
  for (int side = 20; side <= 100; side += (side < 40 ? 2 : 10)) {
    printf ("%4d    ", side);
    double row_max = 0, crack = 0, arcpi = 0;
    for (int deg = 0; deg <= 45; deg += 3) {
      double mx = 0;
      for (int k = 0; k < 4; k++) {
        const int size = (int) (side * 1.5) + 8;
        const double cx = size / 2.0 + off (rng), cy = size / 2.0 + off (rng);
        cv::Mat m = draw_rect (size, size, cx, cy, side, side,
            deg * M_PI / 180);
        BlobShape b = only_blob (m);
        mx = std::max (mx, b.roundness);
        const double P1 = crack_length (m), P2 = opencv_arc_length (m);
        crack = std::max (crack, 4 * M_PI * b.area / (P1 * P1));
        arcpi = std::max (arcpi, 4 * M_PI * b.area /
            ((P2 + M_PI) * (P2 + M_PI)));
        CHECK (b.roundness <= 0.8, "square %d at %d deg: %.4f", side, deg,
            b.roundness);
        if (b.roundness > worst_sq) {
          worst_sq = b.roundness;
          worst_side = side;
          worst_deg = deg;
        }
      }
      printf ("%.3f ", mx);
      row_max = std::max (row_max, mx);
    }
    printf (" %.3f |   %.3f        %.3f\n", row_max, crack, arcpi);
  }
  printf ("highest square: %.4f (side %d, %d deg); true value pi/4 = %.4f\n",
      worst_sq, worst_side, worst_deg, M_PI / 4);

  /* the full grid the claims are made on, without printing */
  for (double r = 5; r <= 60; r += 0.25)
    for (int k = 0; k < 4; k++) {
      const int size = (int) (2 * r) + 8;
      BlobShape b = only_blob (draw_disc (size, size, size / 2.0 + off (rng),
              size / 2.0 + off (rng), r));
      CHECK (b.roundness >= 0.9, "disc r=%.2f: %.4f", r, b.roundness);
    }
  for (int side = 20; side <= 100; side++)
    for (int deg = 0; deg <= 45; deg += 3) {
      const int size = (int) (side * 1.5) + 8;
      BlobShape b = only_blob (draw_rect (size, size, size / 2.0 + off (rng),
              size / 2.0 + off (rng), side, side, deg * M_PI / 180));
      CHECK (b.roundness <= 0.8, "square %d at %d deg: %.4f", side, deg,
          b.roundness);
    }
}

/* ---- geometry of the fitted values ------------------------------------ */

static void
test_centroid_and_ellipse ()
{
  std::mt19937 rng (3);
  std::uniform_real_distribution<double> U (0, 1);

  /* a disc drawn symmetrically about a pixel centre or a pixel corner:
   * the centroid is exact */
  for (double r = 5; r <= 40; r += 0.37) {
    for (double o : {0.0, 0.5}) {
      const int size = (int) (2 * r) + 10;
      const double c = size / 2 + o;
      BlobShape b = only_blob (draw_disc (size, size, c, c, r));
      CHECK (std::fabs (b.centroid_x - c) < 1e-9 &&
          std::fabs (b.centroid_y - c) < 1e-9, "symmetric disc r=%.2f: "
          "(%.4f, %.4f) vs %.2f", r, b.centroid_x, b.centroid_y, c);
    }
  }

  /* sub-pixel centres: the pixel set itself moves the centroid; the
   * error is what binary digitisation leaves (no estimator from the
   * pixels does better: boundary ellipse fits and polygon centroids give
   * the same numbers) */
  printf ("\ncentroid error of digitised discs (240 random sub-pixel "
      "centres per band), px\nradius px    mean    max\n");
  const double bands[][2] = { {5, 7}, {7, 10}, {10, 15}, {15, 25}, {25, 45} };
  for (const auto & band : bands) {
    double sum = 0, mx = 0;
    const int n = 240;
    for (int k = 0; k < n; k++) {
      const double r = band[0] + (band[1] - band[0]) * U (rng);
      const int size = (int) (2 * r) + 10;
      const double cx = size / 2.0 + U (rng) - 0.5;
      const double cy = size / 2.0 + U (rng) - 0.5;
      BlobShape b = only_blob (draw_disc (size, size, cx, cy, r));
      const double e = std::hypot (b.centroid_x - cx, b.centroid_y - cy);
      sum += e;
      mx = std::max (mx, e);
      CHECK (std::fabs (b.ellipse_major - 2 * r) <= 1 &&
          std::fabs (b.ellipse_minor - 2 * r) <= 1,
          "disc r=%.2f axes %.2f %.2f", r, b.ellipse_major, b.ellipse_minor);
      CHECK (std::fabs (b.equivalent_diameter - 2 * r) <= 1,
          "equivalent diameter %.2f for r=%.2f", b.equivalent_diameter, r);
      CHECK (b.ellipse_x == b.centroid_x && b.ellipse_y == b.centroid_y,
          "the ellipse is centred on the centroid");
    }
    printf ("%4.0f-%-4.0f    %.3f   %.3f\n", band[0], band[1], sum / n, mx);
    CHECK (sum / n <= 0.1, "mean centroid error %.3f", sum / n);
    CHECK (mx <= 0.26, "max centroid error %.3f", mx);
  }

  double worst_axis = 0, worst_angle = 0, worst_centre = 0;
  for (int k = 0; k < 300; k++) {
    const double a = 12 + U (rng) * 80, bb = 6 + U (rng) * (a - 8);
    const double angle = (U (rng) - 0.5) * M_PI;
    const int size = (int) a + 12;
    const double cx = size / 2.0 + U (rng) - 0.5, cy = size / 2.0 + U (rng) -
        0.5;
    BlobShape b = only_blob (draw_ellipse (size, size, cx, cy, a, bb, angle));
    const double da = std::fabs (b.ellipse_major - a);
    const double db = std::fabs (b.ellipse_minor - bb);
    worst_axis = std::max (worst_axis, std::max (da, db));
    worst_centre = std::max (worst_centre, std::hypot (b.ellipse_x - cx,
            b.ellipse_y - cy));
    CHECK (da <= 1 && db <= 1, "ellipse %.1f x %.1f: %.2f x %.2f", a, bb,
        b.ellipse_major, b.ellipse_minor);
    if (a > 1.5 * bb) {
      double dang = std::fmod (std::fabs (b.ellipse_angle - angle), M_PI);
      dang = std::min (dang, M_PI - dang);
      worst_angle = std::max (worst_angle, dang);
      CHECK (dang < 0.05, "ellipse angle %.3f vs %.3f", b.ellipse_angle,
          angle);
    }
    CHECK (b.ellipse_fit >= 0.9, "ellipse %.1f x %.1f fit %.3f", a, bb,
        b.ellipse_fit);
  }
  printf ("drawn ellipses (axes 6..92 px, any angle): axes within %.3f px, "
      "major-axis angle within %.4f rad (aspect > 1.5), centre within %.3f px\n",
      worst_axis, worst_angle, worst_centre);
}

/* ---- other shapes ----------------------------------------------------- */

static void
test_other_shapes ()
{
  std::mt19937 rng (5);
  std::uniform_real_distribution<double> U (0, 1);
  struct Acc {
    double mn = 1e9, mx = 0;
    void add (double v) { mn = std::min (mn, v); mx = std::max (mx, v); }
  };
  std::map<std::string, Acc[2]> acc;
  auto add = [&](const std::string & name, const BlobShape & b) {
    acc[name][0].add (b.roundness);
    acc[name][1].add (b.ellipse_fit);
  };
  for (int k = 0; k < 150; k++) {
    const double t = U (rng);
    /* discs, and ellipses as a floor disc at a slant (aspect up to 4) */
    const double r = 6 + t * 30;
    int size = (int) (2 * r) + 10;
    /* draws in named order: argument evaluation order is the compiler's
     * (gcc's right-to-left kept, so the shapes are those measured) */
    double dy = U (rng), dx = U (rng);
    add ("disc", only_blob (draw_disc (size, size, size / 2.0 + dx,
                size / 2.0 + dy, r)));
    const double a = 16 + t * 60, bb = a / (1 + 3 * U (rng));
    size = (int) a + 12;
    double angle = U (rng) * M_PI;
    dx = U (rng);
    add ("ellipse", only_blob (draw_ellipse (size, size, size / 2.0 + dx,
                size / 2.0, a, bb, angle)));
    /* squares, rectangles (stripes), triangles */
    const double side = 20 + t * 60;
    size = (int) (side * 1.5) + 8;
    angle = U (rng) * M_PI;
    dx = U (rng);
    add ("square", only_blob (draw_rect (size, size, size / 2.0 + dx,
                size / 2.0, side, side, angle)));
    angle = U (rng) * M_PI;
    dy = U (rng);
    add ("rectangle 2:1", only_blob (draw_rect (size, size, size / 2.0,
                size / 2.0 + dy, side, side / 2, angle)));
    const double len = 30 + t * 100, wid = 3 + U (rng) * 6;
    size = (int) len + 10;
    add ("stripe", only_blob (draw_rect (size, size, size / 2.0, size / 2.0,
                len, wid, U (rng) * M_PI)));
    size = (int) (side * 1.3) + 8;
    add ("triangle", only_blob (draw_triangle (size, size, size / 2.0,
                size / 2.0, side, U (rng) * M_PI)));
    /* rings: the hole does not count as blob area */
    const double R = 10 + t * 30, ri = R * (0.3 + 0.5 * U (rng));
    size = (int) (2 * R) + 10;
    const double cx = size / 2.0 + U (rng), cy = size / 2.0;
    cv::Mat ring = draw (size, size, [=](int u, int v) {
          const double d2 = (u - cx) * (u - cx) + (v - cy) * (v - cy);
          return d2 <= R * R && d2 > ri * ri;
        });
    BlobShape b = only_blob (ring);
    add ("ring (hole 0.3-0.8 R)", b);
    const double expected = 1 - (ri * ri) / (R * R);
    CHECK (b.roundness < 0.95 * expected + 0.05 && b.roundness <= 0.92,
        "ring R=%.1f r=%.1f: roundness %.3f", R, ri, b.roundness);
  }
  printf ("\nshape (150 each, random size, rotation, centre)\n"
      "                       roundness        ellipse-fit\n"
      "                       min    max       min    max\n");
  for (auto & [name, a] : acc)
    printf ("%-22s %.3f  %.3f     %.3f  %.3f\n", name.c_str (), a[0].mn,
        a[0].mx, a[1].mn, a[1].mx);
  CHECK (acc["disc"][0].mn >= 0.9, "disc");
  CHECK (acc["square"][0].mx <= 0.8, "square");
  CHECK (acc["triangle"][0].mx <= 0.7, "triangle");
  CHECK (acc["stripe"][0].mx <= 0.6, "stripe");
  CHECK (acc["ellipse"][1].mn >= 0.95, "ellipse");
  CHECK (acc["square"][1].mx <= 0.9, "square");
  CHECK (acc["rectangle 2:1"][1].mx <= 0.9, "rectangle");
  CHECK (acc["triangle"][1].mx <= 0.75, "triangle");
}

/* ---- small and degenerate blobs --------------------------------------- */

static void
test_degenerate ()
{
  /* one pixel: the fallback perimeter 4 (its square) */
  cv::Mat m (5, 5, CV_8UC1, cv::Scalar (0));
  m.at<uint8_t> (2, 3) = 255;
  BlobShape b = only_blob (m);
  CHECK (b.area == 1 && b.perimeter == 4 && !b.has_polygon, "pixel: %g %g",
      b.area, b.perimeter);
  CHECK (b.centroid_x == 3 && b.centroid_y == 2, "pixel centroid");
  /* a 1-pixel line: chain 2 (n - 1) + 4 = exact 2n + 2 */
  m.setTo (0);
  m.row (1).colRange (0, 5).setTo (255);
  b = only_blob (m);
  CHECK (b.area == 5 && std::fabs (b.perimeter - 12) < 1e-9, "line %g",
      b.perimeter);
  CHECK (b.touches_border, "line touches the border");
  /* frames of one pixel, one row, one column */
  for (int k = 0; k < 3; k++) {
    cv::Mat f (k == 1 ? 7 : 1, k == 2 ? 7 : 1, CV_8UC1, cv::Scalar (255));
    std::vector<BlobShape> all = blob_measure_mask (f);
    CHECK (all.size () == 1 && all[0].area == f.total (), "frame %dx%d",
        f.cols, f.rows);
  }
  /* empty */
  CHECK (blob_measure_mask (cv::Mat (3, 3, CV_8UC1, cv::Scalar (0))).empty (),
      "empty");
  /* an axis-aligned rectangle (short side >= 20: the line-fit polygon
   * alone) is measured exactly */
  m = cv::Mat (60, 60, CV_8UC1, cv::Scalar (0));
  m (cv::Rect (5, 7, 40, 21)).setTo (255);
  b = only_blob (m);
  CHECK (std::fabs (b.perimeter - 122) < 1e-6, "40x21 rectangle: %g",
      b.perimeter);
  CHECK (std::fabs (b.ellipse_fit - 1) > 0.05, "a rectangle is no ellipse");
}

/* ---- label planes: slots, several classes ----------------------------- */

static void
test_label_plane ()
{
  const int w = 97, h = 61;
  std::vector<uint8_t> plane ((size_t) w * h, 0);
  auto put = [&](const cv::Mat & m, uint8_t l) {
    for (int v = 0; v < h; v++)
      for (int u = 0; u < w; u++)
        if (m.at<uint8_t> (v, u))
          plane[(size_t) v * w + u] = l;
  };
  put (draw_disc (w, h, 20, 20, 9), 3);
  put (draw_disc (w, h, 70, 30, 12), 5);
  put (draw_disc (w, h, 50, 45, 6), 3);
  /* a disc of label 4 touching label 3's disc: separate components */
  put (draw_disc (w, h, 33.5, 20, 4.5), 4);
  uint8_t slot_of[256] = { 0 };
  slot_of[3] = 1;
  slot_of[5] = 2;
  BlobAnalyzer a;
  a.begin (w, h);
  a.add_label_runs (plane.data (), w, slot_of);
  a.label ();
  CHECK (a.count () == 3, "%zu components", a.count ());
  if (a.count () == 3) {
    BlobShape b[3];
    for (int i = 0; i < 3; i++)
      a.measure (i, &b[i]);
    /* by slot, then raster order */
    CHECK (b[0].slot == 1 && std::fabs (b[0].centroid_x - 20) < 0.1, "first");
    CHECK (b[1].slot == 1 && std::fabs (b[1].centroid_x - 50) < 0.1, "second");
    CHECK (b[2].slot == 2 && std::fabs (b[2].centroid_x - 70) < 0.1, "third");
  }
  /* two labels sharing one slot form one blob where they touch */
  slot_of[4] = 1;
  a.begin (w, h);
  a.add_label_runs (plane.data (), w, slot_of);
  a.label ();
  CHECK (a.count () == 3, "merged: %zu components", a.count ());
  /* the stride is honoured */
  std::vector<uint8_t> padded ((size_t) (w + 13) * h, 9);
  for (int v = 0; v < h; v++)
    std::copy_n (&plane[(size_t) v * w], w, &padded[(size_t) v * (w + 13)]);
  slot_of[4] = 0;
  a.begin (w, h);
  a.add_label_runs (padded.data (), w + 13, slot_of);
  a.label ();
  CHECK (a.count () == 3, "strided: %zu components", a.count ());
}

/* ---- the run search's vector paths ------------------------------------ */

/* Pixels, bounding box and centroid of each component, in the analyzer's
 * order. */
static std::vector<std::vector<double>>
components_of (BlobAnalyzer & a)
{
  std::vector<std::vector<double>> out;
  a.label ();
  for (size_t i = 0; i < a.count (); i++) {
    BlobShape b;
    a.measure (i, &b);
    out.push_back ({ (double) b.slot, b.area, (double) b.bbox_x,
            (double) b.bbox_y, (double) b.bbox_w, (double) b.bbox_h,
            b.centroid_x, b.centroid_y });
  }
  return out;
}

/* The AVX2 run search (64 labels a step, the row's last 32 read again for
 * its end) finds what the SSE2 / scalar one finds, and both what OpenCV
 * finds in each slot's mask: widths around the vector steps, marker
 * pixels in the first and last columns and rows, selected labels all
 * under 16 (with unselected ones sharing their low nibble) or in several
 * high nibbles (and one above 127, which takes the other path), strides. */
static void
test_label_runs_vector_paths ()
{
  const int widths[] = { 1, 7, 31, 32, 33, 63, 64, 65, 95, 96, 97, 127, 128,
    129, 200, 640 };
  std::mt19937 rng (5);
  std::uniform_int_distribution<int> U (0, 1 << 30);
  int trials = 0;
  for (int trial = 0; trial < 160; trial++) {
    const int w = widths[trial % 16], h = 1 + U (rng) % 24;
    const size_t stride = (size_t) w + (trial % 3) * 5;
    /* background labels, then runs of marker labels of random lengths */
    std::vector<uint8_t> plane (stride * h, 250);
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++)
        plane[(size_t) y * stride + x] = U (rng) % 3 ? 6 : 7;
    const uint8_t markers[] = { 1, 3, 17, 70, 127, 200, 6, 15 };
    for (int k = 0; k < w * h / 20 + 1; k++) {
      const int y = U (rng) % h, x = U (rng) % w;
      const int len = 1 + U (rng) % (k % 4 ? 3 : 70);
      const uint8_t l = markers[U (rng) % 8];
      for (int i = x; i < std::min (w, x + len); i++)
        plane[(size_t) y * stride + i] = l;
    }
    /* the corners and the last column and row */
    const uint8_t edge = markers[trial % 5];
    for (int y = 0; y < h; y++)
      if (trial % 2 || y == h - 1)
        plane[(size_t) y * stride + w - 1] = edge;
    plane[(size_t) (h - 1) * stride] = edge;
    plane[(size_t) (h - 1) * stride + w - 1] = markers[(trial + 1) % 5];
    plane[0] = edge;

    uint8_t slot_of[256] = { 0 };
    slot_of[1] = 1;
    slot_of[3] = 2;
    if (trial % 4 < 2) {
      /* labels under 16 only: 17, 70 and 127, which share their low
       * nibble with 1, 6 and 15, must not count */
      slot_of[6] = 3;
      slot_of[15] = 4;
    } else {
      slot_of[17] = 1;          /* two labels of one slot */
      slot_of[70] = 3;
      slot_of[127] = 4;
    }
    if (trial % 8 == 7)
      slot_of[200] = 5;         /* over 127: the SSE2 / scalar search */

    BlobAnalyzer wide, narrow;
    narrow.set_avx2 (false);
    wide.begin (w, h);
    wide.add_label_runs (plane.data (), stride, slot_of);
    narrow.begin (w, h);
    narrow.add_label_runs (plane.data (), stride, slot_of);
    const auto got = components_of (wide);
    CHECK (got == components_of (narrow), "trial %d (%dx%d): the vector "
        "paths differ", trial, w, h);

    /* OpenCV on each slot's mask: components and pixels */
    size_t expected = 0;
    std::map<int, double> pixels;
    for (int slot = 1; slot <= 5; slot++) {
      cv::Mat mask (h, w, CV_8UC1, cv::Scalar (0));
      for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
          if (slot_of[plane[(size_t) y * stride + x]] == slot) {
            mask.at<uint8_t> (y, x) = 255;
            pixels[slot]++;
          }
      cv::Mat cc;
      expected += cv::connectedComponents (mask, cc, 8, CV_32S) - 1;
    }
    std::map<int, double> found;
    for (const auto & c : got)
      found[(int) c[0]] += c[1];
    CHECK (got.size () == expected && found == pixels, "trial %d (%dx%d): "
        "%zu components, OpenCV %zu", trial, w, h, got.size (), expected);
    trials++;
  }
  printf ("run search: AVX2 (%s on this processor) and SSE2 paths identical "
      "and matching OpenCV on %d planes\n", BlobAnalyzer::cpu_has_avx2 () ?
      "available" : "not available", trials);
}

/* ---- speed ------------------------------------------------------------ */

static void
test_speed ()
{
  const int w = 640, h = 480;
  std::vector<uint8_t> plane ((size_t) w * h);
  std::mt19937 rng (1);
  /* background of two labels with speckle, as labsegment leaves it */
  for (auto & p : plane)
    p = (rng () % 50) ? 6 : 7;
  for (int k = 0; k < 10; k++) {
    const double cx = 40 + (k % 5) * 120, cy = 100 + (k / 5) * 220;
    const double rx = 12 + 4 * k, ry = 8 + 2 * k;
    for (int v = 0; v < h; v++)
      for (int u = 0; u < w; u++)
        if ((u - cx) * (u - cx) / (rx * rx) + (v - cy) * (v - cy) / (ry * ry)
            <= 1)
          plane[(size_t) v * w + u] = 1 + k % 5;
  }
  uint8_t slot_of[256] = { 0 };
  for (int l = 1; l <= 5; l++)
    slot_of[l] = l;
  BlobAnalyzer a;
  BlobShape b;
  const int reps = 300;
  double best = 1e9, total = 0;
  for (int r = 0; r < reps; r++) {
    const auto t0 = std::chrono::steady_clock::now ();
    a.begin (w, h);
    a.add_label_runs (plane.data (), w, slot_of);
    a.label ();
    for (size_t i = 0; i < a.count (); i++)
      a.measure (i, &b);
    const double ms = std::chrono::duration<double, std::milli> (
        std::chrono::steady_clock::now () - t0).count ();
    best = std::min (best, ms);
    total += ms;
  }
  CHECK (a.count () == 10, "%zu blobs", a.count ());
  printf ("\nspeed: 640x480 label plane, 5 classes, 10 blobs: %.3f ms best, "
      "%.3f ms mean per frame (timing is not asserted)\n", best,
      total / reps);

  /* steady state: the same analyzer on frames with other blobs allocates
   * nothing once its buffers have grown */
  std::vector<uint8_t> other (plane);
  for (size_t i = 0; i < other.size (); i += 7919)
    other[i] = 1 + i % 5;               /* extra specks */
  {
    /* the counter itself works (through a pointer the compiler cannot
     * see through, so the allocation is not elided) */
    void *(*volatile alloc) (size_t) = malloc;
    allocations = 0;
    counting = true;
    void *probe = alloc (64);
    counting = false;
    free (probe);
    CHECK (allocations == 1, "the counter saw %ld allocations, not 1",
        (long) allocations);
  }
  for (int r = 0; r < 102; r++) {
    if (r == 2) {               /* both frames seen once: buffers grown */
      allocations = 0;
      counting = true;
    }
    const std::vector<uint8_t> & p = r % 2 ? other : plane;
    a.begin (w, h);
    a.add_label_runs (p.data (), w, slot_of);
    a.label ();
    for (size_t i = 0; i < a.count (); i++)
      a.measure (i, &b);
  }
  counting = false;
#ifdef LANDMARK_ASAN
  CHECK (hooks_installed == 1, "the allocation hook was not installed");
#endif
  printf ("heap allocations in 100 steady-state frames: %ld\n",
      (long) allocations);
  CHECK (allocations == 0, "%ld allocations", (long) allocations);
}

int
main ()
{
  test_against_opencv ();
  test_disc_square_table ();
  test_centroid_and_ellipse ();
  test_other_shapes ();
  test_degenerate ();
  test_label_plane ();
  test_label_runs_vector_paths ();
  test_speed ();
  return corecheck_summary ();
}
