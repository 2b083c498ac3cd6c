/* Floor boundary and Radial Obstacle Profile (core/geometry/floorprofile.h) against
 * analytic geometry: label planes ray-cast here with the pinhole model of
 * docs/conventions.md written out independently of camerageometry.cpp. */
#include "floorscene.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

using namespace landmark;

/* Row (pixel-centre coordinates) where the floor point at distance x
 * ahead appears in the centre column. */
static double
row_of_distance (double x)
{
  const double below = std::atan2 (CAM_H, x);    /* below the horizontal */
  return CY + F * std::tan (below - TILT * M_PI / 180);
}

/* A wall across the whole view at x = X: an image row when roll is 0. The
 * floor ends exactly on a pixel edge: every column's range is X / cos b. */
static void
test_wall_on_a_pixel_edge ()
{
  FloorProfileParams fp;
  fp.max_range = 5.0;
  fp.bearing_bins = 360;
  Scanner sc (camera (), fp);
  for (int edge : {60, 150, 240, 330}) {
    std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
    std::fill (plane.begin (), plane.begin () + (size_t) edge * W, BOX);
    sc.prof.scan (plane.data (), W, sc.r);
    /* the floor point of the edge at v = edge - 1/2, by hand: h / tan */
    const double below = TILT * M_PI / 180 + std::atan ((edge - 0.5 - CY) / F);
    const double X = CAM_H / std::tan (below);
    double worst = 0;
    for (int u = 0; u < W; u++) {
      const ColumnBoundary & c = sc.prof.columns ()[u];
      CHECK (c.state == FreeState::Obstacle, "edge %d col %d: %s", edge, u,
          free_state_name (c.state));
      worst = std::max (worst, std::fabs (c.x - X) / X);
      const double truth = X / std::cos (std::atan2 (c.y, c.x));
      CHECK (std::fabs (c.range - truth) <= 1e-5 * truth, "col %d %g vs %g",
          u, c.range, truth);
    }
    CHECK (worst < 1e-5, "edge %d: x off by %g relative", edge, worst);
    /* bins: between X / cos of the bin's nearest and farthest bearing */
    const double d = 2 * M_PI / fp.bearing_bins;
    int obstacle_bins = 0;
    for (int k = 0; k < fp.bearing_bins; k++) {
      const RopBin & b = sc.prof.bins ()[k];
      const double bk = std::fabs (sc.prof.bin_bearing (k));
      if (bk > 45 * M_PI / 180) {
        CHECK (b.state == FreeState::NotSeen, "bin %d outside the view: %s",
            k, free_state_name (b.state));
        continue;
      }
      if (b.state != FreeState::Obstacle)
        continue;
      obstacle_bins++;
      const double lo = X / std::cos (std::max (0.0, bk - d / 2));
      const double hi = X / std::cos (bk + d / 2);
      CHECK (b.range >= lo - 1e-4 && b.range <= hi + 1e-4,
          "bin %d: %g not in [%g, %g]", k, b.range, lo, hi);
    }
    /* the view's bearings: hfov 60 at the bottom, wider up the image */
    CHECK (obstacle_bins >= 58, "edge %d: %d obstacle bins", edge,
        obstacle_bins);
    std::printf ("wall at %.3f m (edge %d): %d bins, x error %.2e\n", X,
        edge, obstacle_bins, worst);
  }
}

/* A box of known footprint ray-cast at pixel centres: the boundary is
 * within half a pixel of the true contact line. Specks, thin shadows and a
 * marker disc on the floor change nothing. */
static void
test_box_specks_shadows_markers ()
{
  const Box box {1.37, -0.3, 0.2, 0.4, 0.5};
  FloorProfileParams fp;
  fp.max_range = 4.0;
  fp.min_obstacle_rows = 6;
  Scanner sc (camera (), fp);
  std::vector<uint8_t> plane = render ({box});
  sc.prof.scan (plane.data (), W, sc.r);
  const std::vector<ColumnBoundary> clean = sc.prof.columns ();
  const std::vector<RopBin> clean_bins = sc.prof.bins ();

  double worst_box = 0, worst_free = 0;
  int box_cols = 0;
  for (int u = 0; u < W; u++) {
    const ColumnBoundary & c = clean[u];
    const double bearing = std::atan2 (c.y, c.x);
    const double b0 = std::atan2 (box.y0, box.x0), b1 =
        std::atan2 (box.y1, box.x0);
    if (bearing > b0 + 0.01 && bearing < b1 - 0.01) {
      CHECK (c.state == FreeState::Obstacle, "col %d: %s", u,
          free_state_name (c.state));
      /* truth: the front face's bottom edge at this bearing */
      const double truth = box.x0 / std::cos (bearing);
      worst_box = std::max (worst_box, std::fabs (c.range - truth) / truth);
      box_cols++;
    } else if (bearing < b0 - 0.03 || bearing > b1 + 0.03) {
      /* beside the box the floor reaches max-range (4 m) */
      CHECK (c.state == FreeState::Free && c.range == 4.0f,
          "col %d beside the box: %s %g", u, free_state_name (c.state),
          c.range);
      worst_free = std::max (worst_free, (double) std::fabs (c.range - 4.0f));
    }
  }
  /* half a pixel at 1.5 m: h / (x^2 + h^2) rad per metre, 1/F rad per px */
  const double half_px = 0.5 / F * (box.x0 * box.x0 + CAM_H * CAM_H) /
      CAM_H / box.x0;
  CHECK (worst_box <= half_px + 1e-6, "box: %g relative, half a pixel is %g",
      worst_box, half_px);
  CHECK (box_cols > 100, "%d box columns", box_cols);
  std::printf ("box at %.2f m: %d columns, worst range error %.3f%% "
      "(half a pixel: %.3f%%)\n", box.x0, box_cols, 100 * worst_box,
      100 * half_px);

  /* specks (1-3 px), two-row shadow lines, a marker disc on the floor */
  std::mt19937 rng (7);
  std::uniform_int_distribution<int> ru (0, W - 4), rv (0, H - 4), rs (1, 3);
  for (int i = 0; i < 400; i++) {
    const int u = ru (rng), v = rv (rng), s = rs (rng);
    /* not touching an obstacle, which it would merely extend */
    bool alone = true;
    for (int dv = -1; dv <= s && alone; dv++)
      for (int du = -1; du <= s && alone; du++) {
        const int x = u + du, y = v + dv;
        alone = x < 0 || y < 0 || x >= W || y >= H ||
            plane[(size_t) y * W + x] == FLOOR;
      }
    if (!alone)
      continue;
    for (int dv = 0; dv < s; dv++)
      for (int du = 0; du < s; du++)
        if (plane[(size_t) (v + dv) * W + u + du] == FLOOR)
          plane[(size_t) (v + dv) * W + u + du] = (i % 2) ? NONE : SHADOW;
  }
  for (int v : {300, 380, 440})
    for (int u = 0; u < W; u++)
      for (int dv = 0; dv < 2; dv++)
        plane[(size_t) (v + dv) * W + u] = SHADOW;
  cv::Mat m (H, W, CV_8UC1, plane.data ());
  const double mv = row_of_distance (0.9);
  cv::ellipse (m, cv::Point (120, (int) mv), cv::Size (40, 12), 0, 0, 360,
      cv::Scalar (MARKER), -1);
  sc.prof.scan (plane.data (), W, sc.r);
  int changed = 0, marked = 0;
  for (int u = 0; u < W; u++) {
    const ColumnBoundary & a = clean[u], &b = sc.prof.columns ()[u];
    const bool differs = a.state != b.state ||
        std::fabs (a.range - b.range) > 1e-6;
    if (differs)
      std::fprintf (stderr, "col %d: %s %g row %g -> %s %g row %g\n", u,
          free_state_name (a.state), a.range, a.row,
          free_state_name (b.state), b.range, b.row);
    changed += differs;
    if (u >= 90 && u <= 150) {
      marked++;
      CHECK (b.marker_range > 0.8 && b.marker_range < 1.0,
          "col %d: marker range %g", u, b.marker_range);
    }
  }
  CHECK (changed == 0, "%d columns changed by specks, shadows, a marker",
      changed);
  CHECK (marked > 0, "no marker columns");

  /* a run at least min-obstacle-rows tall does end the floor */
  for (int u = 0; u < W; u++)
    for (int v = 300; v < 306; v++)
      plane[(size_t) v * W + u] = SHADOW;
  sc.prof.scan (plane.data (), W, sc.r);
  CHECK (sc.prof.columns ()[W / 2].state == FreeState::Obstacle &&
      std::fabs (sc.prof.columns ()[W / 2].row - 305.5f) < 1e-4,
      "6-row band: %s at row %g", free_state_name (sc.prof.columns ()[W /
              2].state), sc.prof.columns ()[W / 2].row);
}

/* The border cuts the view: floor to the top row within max-range is a
 * view edge at the top row's range; a column with no floor at the bottom
 * is not seen; bins behind the robot are not seen. */
static void
test_border_cut ()
{
  FloorProfileParams fp;
  fp.max_range = 50.0;
  Scanner sc (camera (), fp);
  std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
  /* the left quarter: something right in front of the lens */
  for (int v = 0; v < H; v++)
    for (int u = 0; u < W / 4; u++)
      plane[(size_t) v * W + u] = BOX;
  sc.prof.scan (plane.data (), W, sc.r);
  const double top_x = CAM_H / std::tan (TILT * M_PI / 180 +
      std::atan ((-0.5 - CY) / F));
  for (int u = 0; u < W; u++) {
    const ColumnBoundary & c = sc.prof.columns ()[u];
    if (u < W / 4) {
      CHECK (c.state == FreeState::NotSeen, "col %d: %s", u,
          free_state_name (c.state));
    } else {
      CHECK (c.state == FreeState::ViewEdge, "col %d: %s", u,
          free_state_name (c.state));
      CHECK (std::fabs (c.x - top_x) < 1e-4 * top_x, "col %d: %g vs %g", u,
          c.x, top_x);
    }
  }
  int behind = 0;
  for (int k = 0; k < fp.bearing_bins; k++)
    if (std::fabs (sc.prof.bin_bearing (k)) > M_PI / 2) {
      behind++;
      CHECK (sc.prof.bins ()[k].state == FreeState::NotSeen, "bin %d", k);
    }
  CHECK (behind > 0, "no bins behind");
  /* left of the view (positive bearings) is where the image's left
   * quarter looks: not seen there */
  CHECK (sc.prof.bins ()[sc.prof.bin_of (25 * M_PI / 180)].state ==
      FreeState::NotSeen, "bin at +25 deg: %s",
      free_state_name (sc.prof.bins ()[sc.prof.bin_of (25 * M_PI /
                  180)].state));
  CHECK (sc.prof.bins ()[sc.prof.bin_of (-20 * M_PI / 180)].state ==
      FreeState::ViewEdge, "bin at -20 deg");

  /* a camera looking above the horizon sees no floor at all */
  CameraParams p = sc.g.params ();
  std::string err;
  p.tilt_deg = -40;
  CameraGeometry up;
  if (up.configure (p, &err)) {
    FloorProfile none;
    CHECK (!none.configure (up, fp, &err), "a camera seeing no floor");
  }
}

/* bin_of / bin_bearing: bin 0 straight ahead, positive to the left. */
static void
test_bins ()
{
  FloorProfileParams fp;
  fp.bearing_bins = 8;
  Scanner sc (camera (), fp);
  CHECK (sc.prof.bin_of (0) == 0, "0");
  CHECK (sc.prof.bin_of (M_PI / 4) == 1, "45 deg left");
  CHECK (sc.prof.bin_of (-M_PI / 4) == 7, "45 deg right");
  CHECK (sc.prof.bin_of (M_PI / 8 - 1e-9) == 0 &&
      sc.prof.bin_of (M_PI / 8) == 1,
      "edges");
  CHECK (sc.prof.bin_of (M_PI) == 4 && sc.prof.bin_of (-M_PI) == 4, "behind");
  CHECK (std::fabs (sc.prof.bin_bearing (7) + M_PI / 4) < 1e-12, "bearing 7");
}

/* The bird's-eye remap of a floor with grid lines every 0.5 m (3 cm wide),
 * ray-cast here: the lines come out straight, along output rows and
 * columns, at 100 px per metre from the camera's floor point. */
static void
test_birdseye_grid ()
{
  CameraGeometry g = camera ();
  std::vector<uint8_t> img ((size_t) W * H, 0);
  each_downward_ray ([&](int u, int v, const double d[3]) {
        const double t = CAM_H / -d[2], x = t * d[0], y = t * d[1];
        auto near_line = [](double a) {
          return std::fabs (a - 0.5 * std::round (a / 0.5)) < 0.015;
        };
        img[(size_t) v * W + u] = near_line (x) || near_line (y) ? 255 : 20;
      });
  BirdsEyeParams b;             /* 400x400, 100 px/m, origin bottom centre */
  std::vector<float> mx, my;
  std::string err;
  CHECK (birdseye_maps (g, b, &mx, &my, &err), "%s", err.c_str ());
  cv::Mat fx (b.out_h, b.out_w, CV_32FC1, mx.data ());
  cv::Mat fy (b.out_h, b.out_w, CV_32FC1, my.data ());
  cv::Mat src (H, W, CV_8UC1, img.data ()), dst;
  cv::remap (src, dst, fx, fy, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  /* share of the seen pixels of an output row / column that are bright,
   * leaving out where the crossing lines run */
  auto on_grid = [](double metres) {
    return std::fabs (metres - 0.5 * std::round (metres / 0.5)) < 0.03;
  };
  auto row_share = [&](int j) {
    int seen = 0, bright = 0;
    for (int i = 0; i < b.out_w; i++)
      if (mx[(size_t) j * b.out_w + i] >= -1 &&
          !on_grid ((b.origin_u - i) / 100)) {
        seen++;
        bright += dst.at<uint8_t> (j, i) > 128;
      }
    return seen ? (double) bright / seen : -1.0;
  };
  auto col_share = [&](int i, int j0, int j1) {
    int seen = 0, bright = 0;
    for (int j = j0; j <= j1; j++)
      if (mx[(size_t) j * b.out_w + i] >= -1 &&
          !on_grid ((b.origin_v - j) / 100)) {
        seen++;
        bright += dst.at<uint8_t> (j, i) > 128;
      }
    return seen ? (double) bright / seen : -1.0;
  };
  for (double x = 1.0; x <= 2.51; x += 0.5) {
    /* output row of x: origin_v - 100 x, between two pixel rows */
    const int j = (int) std::floor (b.origin_v - 100 * x);
    const double on = std::min (row_share (j), row_share (j + 1));
    const double off = row_share (j - 25);
    CHECK (on > 0.9, "line x = %.1f m: %.2f of row %d bright", x, on, j);
    CHECK (off >= 0 && off < 0.05, "between lines at x = %.2f m: %.2f",
        x + 0.25, off);
    std::printf ("bird's-eye: line x = %.1f m on rows %d-%d: %.0f%% bright, "
        "25 px off it %.0f%%\n", x, j, j + 1, 100 * on, 100 * off);
  }
  for (double y = -1.0; y <= 1.01; y += 0.5) {
    const int i = (int) std::floor (b.origin_u - 100 * y);
    /* from 1 m to 3 m ahead, where the view is wider than 1 m each side */
    const double on = std::min (col_share (i, 100, 300),
        col_share (i + 1, 100, 300));
    const double off = col_share (i + 25, 100, 300);
    CHECK (on > 0.9, "line y = %.1f m: %.2f of column %d bright", y, on, i);
    CHECK (off >= 0 && off < 0.05, "beside line y = %.1f m: %.2f", y, off);
  }
  /* points the camera does not see (behind the bottom row) stay black */
  CHECK (mx[(size_t) (b.out_h - 1) * b.out_w + b.out_w / 2] < -1,
      "the floor under the camera is not in view");
}

/* A rolled camera: image rows are no longer floor lines. A wall at 1.2 m
 * ray-cast at pixel centres: every column within half a pixel of it. */
static void
test_rolled_camera ()
{
  roll_deg = 8;
  FloorProfileParams fp;
  Scanner sc (camera (), fp);
  const double X = 1.2;
  std::vector<uint8_t> plane = render ({{X, -5, 5, 1.0, 1.0}});
  sc.prof.scan (plane.data (), W, sc.r);
  double worst = 0;
  int n = 0;
  for (const ColumnBoundary & c : sc.prof.columns ()) {
    if (c.state != FreeState::Obstacle)
      continue;
    worst = std::max (worst, std::fabs (c.x - X) / X);
    n++;
  }
  /* half a pixel at 1.2 m, and a little for the slant of the rows */
  const double half_px = 0.5 / F * (X * X + CAM_H * CAM_H) / CAM_H / X;
  CHECK (n == W, "%d of %d columns see the wall", n, W);
  CHECK (worst <= 1.2 * half_px, "rolled: %g relative, half a pixel %g",
      worst, half_px);
  std::printf ("roll 8 deg, wall at %.1f m: %d columns, worst %.3f%% "
      "(half a pixel %.3f%%)\n", X, n, 100 * worst, 100 * half_px);
  roll_deg = 0;
}

/* The seed's angle-linear model: the floor ending on the edge above row
 * e is h tan(gamma + 2 alpha (n - 1 - v) / (n - 1)) ahead (eq. 3.5) at
 * v = e - 1/2, in the centre of the image. */
static void
test_seed_model ()
{
  CameraParams p;
  p.model = CameraModel::Seed;
  p.width = W;
  p.height = H;
  p.camera_height = 0.3;
  p.blind_distance = 0.3;
  p.view_depth = 0.9;
  p.half_width = 0.6;
  FloorProfileParams fp;
  fp.max_range = 10;
  Scanner sc (corecheck_camera (p), fp);
  /* the seed's angles from b, d and h, by hand: the bottom row looks
   * gamma from the vertical (to b), the centre row gamma + alpha (to
   * b + d) */
  const double h = 0.3, b = 0.3, d = 0.9;
  const double gamma = std::atan (b / h);
  const double alpha = std::atan ((b + d) / h) - gamma;
  for (int e : {240, 300, 400}) {
    std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
    std::fill (plane.begin (), plane.begin () + (size_t) e * W, BOX);
    sc.prof.scan (plane.data (), W, sc.r);
    const double v = e - 0.5;
    const double want = h * std::tan (gamma + 2 * alpha * (H - 1 - v) /
        (H - 1));
    const ColumnBoundary & c = sc.prof.columns ()[W / 2];
    CHECK (c.state == FreeState::Obstacle && std::fabs (c.x - want) <
        1e-4 * want, "seed, edge %d: %s x %g, want %g", e,
        free_state_name (c.state), c.x, want);
  }
}

/* max_marker_length: a disc (0.1 m across, flat on the floor) is walked
 * over; a ball (radius 0.08 m, resting 1.0 m ahead), ray-cast here, spans
 * far more when read as floor: it ends the floor at its bulge, 0.92 m. */
static void
test_marker_length ()
{
  FloorProfileParams fp;
  fp.max_marker_length = 0.15;
  Scanner sc (camera (), fp);
  const double bx = 1.0, by = -0.3, br = 0.08;   /* the ball, right */
  const double dx = 1.0, dy = 0.3, dr = 0.05;    /* the disc, left */
  std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
  each_downward_ray ([&](int u, int v, const double d[3]) {
        const double t_floor = CAM_H / -d[2];
        const double fx = t_floor * d[0], fy = t_floor * d[1];
        /* the sphere: |C + t d - P|^2 = r^2, C = (0, 0, h) */
        const double o[3] = {-bx, -by, CAM_H - br};
        const double qa = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        const double qb = 2 * (o[0] * d[0] + o[1] * d[1] + o[2] * d[2]);
        const double qc = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - br * br;
        const double disc = qb * qb - 4 * qa * qc;
        const bool ball = disc >= 0 && (-qb - std::sqrt (disc)) / (2 * qa) <
            t_floor;
        if (ball || std::hypot (fx - dx, fy - dy) <= dr)
          plane[(size_t) v * W + u] = MARKER;
      });
  sc.prof.scan (plane.data (), W, sc.r);
  int disc_cols = 0, ball_cols = 0;
  double best = 1e9;
  for (const ColumnBoundary & c : sc.prof.columns ()) {
    const double bearing = std::atan2 (c.y, c.x);
    if (std::fabs (bearing - std::atan2 (dy, dx)) < 0.02) {
      disc_cols++;
      CHECK (c.state == FreeState::Free, "disc column: %s at %g",
          free_state_name (c.state), c.range);
    }
    if (c.state == FreeState::Obstacle) {
      ball_cols++;
      best = std::min (best, (double) c.range);
    }
  }
  const double bulge = std::hypot (bx, by) - br;
  CHECK (disc_cols > 0 && ball_cols > 0, "%d disc, %d ball columns",
      disc_cols, ball_cols);
  CHECK (std::fabs (best - bulge) < 0.01 * bulge, "ball: nearest %g, "
      "bulge %g", best, bulge);
  std::printf ("ball r %.2f m at %.3f m: %d columns, nearest %.4f m (bulge "
      "%.4f m)\n", br, std::hypot (bx, by), ball_cols, best, bulge);
  /* its shaded underside (the lowest 8 rows of each column) labelled no
   * class: the ordinary rule ends the floor there, the bulge is found */
  std::vector<uint8_t> shaded = plane;
  for (int u = 0; u < W; u++) {
    int seen = 0;
    for (int v = H - 1; v >= 0; v--) {
      uint8_t & px = shaded[(size_t) v * W + u];
      if (px == MARKER && seen < 8 && u > W / 2) {
        px = NONE;
        seen++;
      } else if (seen > 0 && seen < 8) {
        seen = 8;
      }
    }
  }
  sc.prof.scan (shaded.data (), W, sc.r);
  double best_shaded = 1e9;
  for (const ColumnBoundary & c : sc.prof.columns ())
    if (c.state == FreeState::Obstacle)
      best_shaded = std::min (best_shaded, (double) c.range);
  CHECK (std::fabs (best_shaded - bulge) < 0.01 * bulge, "shaded ball: "
      "nearest %g, bulge %g", best_shaded, bulge);
  fp.max_marker_length = 0;
  sc.configure (fp);
  sc.prof.scan (plane.data (), W, sc.r);
  int obstacles = 0;
  for (const ColumnBoundary & c : sc.prof.columns ())
    obstacles += c.state == FreeState::Obstacle;
  CHECK (obstacles == 0, "off: %d obstacle columns", obstacles);
}

/* stand_balls: the bins a ranged ball covers end at its circle's nearest
 * point inside each bin's wedge, found here by sampling the wedge's
 * bearings; the bins it does not cover, those not seen (a ball behind the
 * robot) and those a nearer obstacle ends stay as they were. */
static void
test_ranged_balls ()
{
  FloorProfileParams fp;
  Scanner sc (camera (), fp);
  std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
  sc.prof.scan (plane.data (), W, sc.r);
  const std::vector<RopBin> before = sc.prof.bins ();
  const RangedBall ball {1.0, -0.3, 0.08}, behind {-1.0, 0.0, 0.1};
  sc.prof.stand_balls ({ball, behind});
  const int n = fp.bearing_bins;
  int covered = 0;
  for (int k = 0; k < n; k++) {
    double want = HUGE_VAL;
    for (int j = 0; j <= 2000; j++) {
      const double a = sc.prof.bin_bearing (k) + (j / 2000.0 - 0.5) * 2 *
          M_PI / n;
      /* |t (cos a, sin a) - c| = r, the nearer root */
      const double along = ball.x * std::cos (a) + ball.y * std::sin (a);
      const double across = -ball.x * std::sin (a) + ball.y * std::cos (a);
      if (std::fabs (across) < ball.radius)
        want = std::min (want, along - std::sqrt (ball.radius *
                ball.radius - across * across));
    }
    const RopBin & b = sc.prof.bins ()[k];
    if (before[k].state == FreeState::NotSeen || want >= before[k].range) {
      CHECK (b.state == before[k].state && b.range == before[k].range,
          "bin %d changed: %s %g", k, free_state_name (b.state), b.range);
      continue;
    }
    covered++;
    CHECK (b.state == FreeState::Obstacle && std::fabs (b.range - want) <
        1e-4, "bin %d: %s %g, want %g", k, free_state_name (b.state),
        b.range, want);
  }
  const double half = std::asin (ball.radius / std::hypot (ball.x,
          ball.y)) * 180 / M_PI;
  CHECK (covered >= (int) (2 * half) && covered <= (int) (2 * half) + 2,
      "%d bins covered, the ball spans %g degrees", covered, 2 * half);
  /* a wall of boxes across the view 0.6 m ahead (the bottom rows of the
   * image see nearer floor): nearer than the ball, it stays */
  for (int v = 0; v < H; v++)
    for (int u = 0; u < W; u++)
      if (v < H - 60)
        plane[(size_t) v * W + u] = BOX;
  sc.prof.scan (plane.data (), W, sc.r);
  const std::vector<RopBin> walled = sc.prof.bins ();
  sc.prof.stand_balls ({ball});
  for (int k = 0; k < n; k++)
    CHECK (sc.prof.bins ()[k].range == walled[k].range, "bin %d behind the "
        "wall: %g, was %g", k, sc.prof.bins ()[k].range, walled[k].range);
}

/* A disc (0.15 m across, 0.9 m ahead) ray-cast with a rim one pixel wide
 * of no class around it (the floor and the disc blended): at the
 * ellipse's tips the rim runs down a column for several rows and ends the
 * floor there; with the disc's image ellipse given (from the pixels'
 * second moments here), every column walks over it. */
static void
test_disc_rim ()
{
  FloorProfileParams fp;
  Scanner sc (camera (), fp);
  const double dx = 0.9, dy = 0.1, dr = 0.075;
  std::vector<uint8_t> plane ((size_t) W * H, FLOOR);
  each_downward_ray ([&](int u, int v, const double d[3]) {
        const double t = CAM_H / -d[2];
        if (std::hypot (t * d[0] - dx, t * d[1] - dy) <= dr)
          plane[(size_t) v * W + u] = MARKER;
      });
  double n = 0, mu = 0, mv = 0, suu = 0, svv = 0, suv = 0;
  for (int v = 0; v < H; v++)
    for (int u = 0; u < W; u++)
      if (plane[(size_t) v * W + u] == MARKER) {
        n++;
        mu += u;
        mv += v;
        suu += (double) u * u;
        svv += (double) v * v;
        suv += (double) u * v;
      }
  mu /= n;
  mv /= n;
  const double cuu = suu / n - mu * mu, cvv = svv / n - mv * mv;
  const double cuv = suv / n - mu * mv;
  const double mid = (cuu + cvv) / 2, dev = std::sqrt ((cuu - cvv) *
      (cuu - cvv) / 4 + cuv * cuv);
  /* a filled ellipse's semi-axis is twice the square root of its
   * variance along it */
  const ImageEllipse disc {mu, mv, 4 * std::sqrt (mid + dev),
    4 * std::sqrt (mid - dev), 0.5 * std::atan2 (2 * cuv, cuu - cvv)};
  std::vector<uint8_t> rimmed = plane;
  for (int v = 1; v < H - 1; v++)
    for (int u = 1; u < W - 1; u++) {
      if (plane[(size_t) v * W + u] != FLOOR)
        continue;
      for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++)
          if (plane[(size_t) (v + j) * W + u + i] == MARKER)
            rimmed[(size_t) v * W + u] = NONE;
    }
  int ended = 0;
  sc.prof.scan (rimmed.data (), W, sc.r);
  for (const ColumnBoundary & c : sc.prof.columns ())
    ended += c.state == FreeState::Obstacle;
  CHECK (ended > 0, "the rim ends no column without the ellipse");
  sc.prof.set_landmark_discs ({disc});
  sc.prof.scan (rimmed.data (), W, sc.r);
  int still = 0;
  for (const ColumnBoundary & c : sc.prof.columns ())
    still += c.state == FreeState::Obstacle;
  CHECK (still == 0, "%d columns end at the rim with the ellipse", still);
  std::printf ("disc rim: %d columns ended without its ellipse (%.1f x %.1f "
      "px), %d with\n", ended, disc.major, disc.minor, still);
  /* the ellipses stay for later scans; cleared, the rim ends them again */
  sc.prof.set_landmark_discs ({});
  sc.prof.scan (rimmed.data (), W, sc.r);
  int again = 0;
  for (const ColumnBoundary & c : sc.prof.columns ())
    again += c.state == FreeState::Obstacle;
  CHECK (again == ended, "cleared: %d columns, %d before", again, ended);
}

int
main ()
{
  test_bins ();
  test_wall_on_a_pixel_edge ();
  test_box_specks_shadows_markers ();
  test_border_cut ();
  test_birdseye_grid ();
  test_rolled_camera ();
  test_seed_model ();
  test_marker_length ();
  test_ranged_balls ();
  test_disc_rim ();
  return corecheck_summary ();
}
