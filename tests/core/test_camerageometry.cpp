/* Camera geometry (plugins/landmark/core/geometry/camerageometry.h) against
 * cv::projectPoints and the seed's equations (3.1)-(3.6), and the range
 * estimate (rangeestimate.h) against known markers. */
#include "camerageometry.h"
#include "corecheck.h"
#include "rangeestimate.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <cstdio>
#include <fstream>
#include <random>
#include <random>
#include <string>
#include <vector>

using namespace landmark;


/* The world-to-camera rotation of docs/conventions.md, written out
 * independently of camerageometry.cpp: rows x_c', y_c', z_c. */
static cv::Matx33d
robot_to_camera (double tilt_deg, double roll_deg)
{
  const double t = tilt_deg * M_PI / 180, r = roll_deg * M_PI / 180;
  const cv::Vec3d xc (0, -1, 0), yc (-std::sin (t), 0, -std::cos (t)),
      zc (std::cos (t), 0, -std::sin (t));
  const cv::Vec3d x2 = std::cos (r) * xc + std::sin (r) * yc;
  const cv::Vec3d y2 = -std::sin (r) * xc + std::cos (r) * yc;
  return cv::Matx33d (x2[0], x2[1], x2[2], y2[0], y2[1], y2[2], zc[0], zc[1],
      zc[2]);
}

/* A pinhole camera of 60 degrees horizontal field of view, its
 * intrinsics from intrinsics_from_hfov. */
static CameraParams
pinhole_params (int width, int height, double camera_height, double tilt_deg)
{
  CameraParams p;
  p.width = width;
  p.height = height;
  p.camera_height = camera_height;
  p.tilt_deg = tilt_deg;
  CHECK (intrinsics_from_hfov (60, width, height, &p.fx, &p.fy, &p.cx,
          &p.cy), "hfov 60 at %dx%d", width, height);
  return p;
}

/* Random floor (or plane z0) points in view, projected with
 * cv::projectPoints, then back-projected by the geometry. */
static void
test_projectpoints_roundtrip (const CameraParams & p, double z0,
    const char *name)
{
  CameraGeometry g;
  std::string err;
  CHECK (g.configure (p, &err), "%s: %s", name, err.c_str ());
  const cv::Matx33d rot = robot_to_camera (p.tilt_deg, p.roll_deg);
  cv::Vec3d rvec;
  cv::Rodrigues (rot, rvec);
  const cv::Vec3d tvec = -(rot * cv::Vec3d (0, 0, p.camera_height));
  const cv::Matx33d k (p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1);
  std::mt19937 rng (42);
  std::uniform_real_distribution<double> fwd (0.2, 6.0), lat (-3.0, 3.0);
  int tested = 0;
  double worst = 0;
  for (int i = 0; i < 4000 && tested < 500; i++) {
    const cv::Point3d pt (fwd (rng), lat (rng), z0);
    const cv::Vec3d pc = rot * (cv::Vec3d (pt.x, pt.y, pt.z) -
        cv::Vec3d (0, 0, p.camera_height));
    /* in front, and within the radius where the distortion polynomial is
     * monotonic (farther points fold back into the image) */
    if (pc[2] < 0.05 || std::hypot (pc[0] / pc[2], pc[1] / pc[2]) > 0.8)
      continue;
    std::vector<cv::Point3d> obj {pt};
    std::vector<cv::Point2d> img;
    cv::projectPoints (obj, rvec, tvec, k, p.dist, img);
    const double u = img[0].x, v = img[0].y;
    /* keep points inside the image, where the distortion is invertible */
    if (u < 0 || v < 0 || u > p.width - 1 || v > p.height - 1)
      continue;
    double gx, gy;
    const bool ok = g.pixel_to_plane (u, v, z0, &gx, &gy);
    CHECK (ok, "%s: (%g, %g) has no floor", name, u, v);
    if (!ok)
      continue;
    const double e = std::hypot (gx - pt.x, gy - pt.y);
    worst = std::max (worst, e);
    tested++;
    /* and forward: project() agrees with cv::projectPoints */
    double pu, pv;
    CHECK (g.project (Vec3 {pt.x, pt.y, pt.z}, &pu, &pv) &&
        std::hypot (pu - u, pv - v) < 1e-6, "%s: project", name);
  }
  CHECK (tested >= 100, "%s: only %d points in view", name, tested);
  CHECK (worst < 1e-6, "%s: worst back-projection error %g m", name, worst);
  std::printf ("%-28s %3d points, worst error %.3g m\n", name, tested, worst);
}

static void
test_pinhole ()
{
  CameraParams p = pinhole_params (640, 480, 0.3, 25);
  CHECK (std::fabs (p.fx - 554.256258) < 1e-5 && p.cx == 319.5 &&
      p.cy == 239.5, "intrinsics %g %g %g", p.fx, p.cx, p.cy);
  test_projectpoints_roundtrip (p, 0.0, "pinhole floor");
  test_projectpoints_roundtrip (p, 0.05, "pinhole plane z=0.05");
  p.roll_deg = 7;
  p.tilt_deg = 35;
  p.camera_height = 0.8;
  p.fy = p.fx * 1.02;
  p.cx = 330.2;
  p.cy = 231.7;
  test_projectpoints_roundtrip (p, 0.0, "pinhole roll 7 tilt 35");
  p.dist = {-0.28, 0.09, 0.001, -0.0015, -0.012};
  test_projectpoints_roundtrip (p, 0.0, "pinhole with distortion");
  p.roll_deg = -12;
  test_projectpoints_roundtrip (p, 0.1, "distortion, roll -12, z=0.1");
  /* the rational and thin-prism terms, which project() writes out */
  p.dist = {-0.28, 0.09, 0.001, -0.0015, -0.012, 0.02, -0.01, 0.003};
  test_projectpoints_roundtrip (p, 0.0, "distortion, rational (8)");
  p.dist = {-0.28, 0.09, 0.001, -0.0015, -0.012, 0.02, -0.01, 0.003,
    0.002, -0.001, 0.0015, 0.0005};
  test_projectpoints_roundtrip (p, 0.0, "distortion, thin prism (12)");
  p.dist = {-0.28, 0.09, 0.001, -0.0015, -0.012};

  /* analytic: straight ahead, image centre row -> h / tan(tilt) */
  const CameraParams q = pinhole_params (641, 481, 0.5, 30);
  CameraGeometry g;
  std::string err;
  CHECK (g.configure (q, &err), "%s", err.c_str ());
  double gx, gy;
  CHECK (g.pixel_to_plane (320, 240, 0, &gx, &gy) &&
      std::fabs (gx - 0.5 / std::tan (M_PI / 6)) < 1e-12 &&
      std::fabs (gy) < 1e-12, "centre %g %g", gx, gy);
  /* a point to the right of centre has negative bearing */
  CHECK (g.pixel_to_plane (500, 300, 0, &gx, &gy) && gy < 0, "right %g", gy);
  double r, b;
  /* tilt 10: the top rows are above the horizon (vertical half fov 23.4) */
  CameraParams up = q;
  up.tilt_deg = 10;
  CHECK (g.configure (up, &err), "%s", err.c_str ());
  CHECK (!g.pixel_to_plane (320, 0, 0, &gx, &gy), "top row sees floor");
  CHECK (g.pixel_to_plane (320, 480, 0, &gx, &gy), "bottom row");

  /* impossible geometry */
  CameraParams bad = q;
  bad.camera_height = 0;
  CHECK (!g.configure (bad, &err) && err.find ("camera-height") !=
      std::string::npos, "zero height: %s", err.c_str ());
  bad = q;
  bad.tilt_deg = -40;   /* vertical half fov is about 24 degrees */
  CHECK (!g.configure (bad, &err) && err.find ("no floor") !=
      std::string::npos, "tilt up: %s", err.c_str ());
  CHECK (!intrinsics_from_hfov (180, 640, 480, &gx, &gy, &r, &b), "hfov 180");
  CHECK (!intrinsics_from_hfov (0, 640, 480, &gx, &gy, &r, &b), "hfov 0");
}

static void
test_seed ()
{
  /* h, b, d, w as a user measures them with a tape */
  CameraParams p;
  p.model = CameraModel::Seed;
  p.width = 640;
  p.height = 480;
  p.camera_height = 0.4;
  p.blind_distance = 0.3;
  p.view_depth = 0.9;
  p.half_width = 0.6;
  CameraGeometry g;
  std::string err;
  CHECK (g.configure (p, &err), "%s", err.c_str ());
  const double h = 0.4, b = 0.3, d = 0.9, w = 0.6;
  const double gamma = std::atan (b / h);
  const double alpha = std::atan ((b + d) / h) - gamma;
  const double beta = std::atan (w / (b + d));
  /* (3.2)-(3.6) on a grid, against the equations written out here; the
   * bottom row and the left edge below check b, d and w themselves */
  const double m = 640, n = 480;
  double worst = 0;
  for (int v = 0; v < 480; v += 7)
    for (int u = 0; u < 640; u += 9) {
      const double psi = gamma + 2 * alpha * (n - 1 - v) / (n - 1);
      /* the ray model's floor point: ground-x = y, ground-y = -x */
      double gx, gy;
      const bool floor = g.pixel_to_plane (u, v, 0, &gx, &gy);
      CHECK (floor == (psi < M_PI / 2), "horizon at v=%d", v);
      if (!floor)
        continue;
      const double ye = h * std::tan (psi);                   /* 3.5 */
      const double xe = ye * std::tan (beta * (2 * u - m + 1) / (m - 1));
      worst = std::max (worst, std::hypot (gx - ye, gy + xe));
      double pu, pv;
      CHECK (g.project (Vec3 {gx, gy, 0}, &pu, &pv) &&
          std::hypot (pu - u, pv - v) < 1e-6, "seed project");
    }
  CHECK (worst < 1e-9, "seed equations: worst %g", worst);
  /* bottom row is b ahead, centre column straight ahead (m odd: exact) */
  double y, x;
  CHECK (g.pixel_to_plane (319.5, 479, 0, &y, &x) && std::fabs (y - b) <
      1e-12 && std::fabs (x) < 1e-12, "bottom row %g %g", y, x);
  CHECK (g.pixel_to_plane (0, 239.5, 0, &y, &x) && std::fabs (y - (b + d)) <
      1e-12 && std::fabs (x - w) < 1e-12, "left edge at b + d: %g %g", y, x);
  CameraParams bad = p;
  bad.view_depth = 0;
  CHECK (!g.configure (bad, &err), "view-depth 0");
  std::printf ("seed equations worst error %.3g m\n", worst);
}

static void
test_estimate ()
{
  /* a disc lying on the floor seen at a slant: the ellipse centre is not
   * the disc centre's image; the estimate recovers the true centre */
  const CameraParams p = pinhole_params (640, 480, 0.3, 25);
  CameraGeometry g;
  std::string err;
  g.configure (p, &err);
  const double cx = 0.9, cy = 0.25, rad = 0.05;
  std::vector<cv::Point2f> outline;
  for (int i = 0; i < 360; i++) {
    double u, v;
    const double t = 2 * M_PI * i / 360;
    g.project (Vec3 {cx + rad * std::cos (t), cy + rad * std::sin (t), 0},
        &u, &v);
    outline.emplace_back ((float) u, (float) v);
  }
  const cv::RotatedRect e = cv::fitEllipse (outline);
  BlobObservation o;
  o.has_ellipse = true;
  o.eu = e.center.x;
  o.ev = e.center.y;
  o.major = std::max (e.size.width, e.size.height);
  o.minor = std::min (e.size.width, e.size.height);
  o.angle = e.angle * M_PI / 180 + (e.size.width < e.size.height ?
      M_PI / 2 : 0);
  o.u = o.eu;
  o.v = o.ev;
  MarkerSpec disc;
  disc.diameter = 2 * rad;
  const RangeEstimate r = estimate_range (g, o, disc, 0.5);
  const double want = std::hypot (cx, cy);
  CHECK (!r.no_floor && std::fabs (r.range_ground - want) < 2e-4,
      "disc ground %g want %g", r.range_ground, want);
  CHECK (r.has_size && std::fabs (r.range_size - want) < 5e-3,
      "disc size %g want %g", r.range_size, want);
  CHECK (std::fabs (r.bearing - std::atan2 (cy, cx)) < 2e-4, "bearing");
  /* the ellipse centre's own floor point is biased (farther) */
  double gx, gy;
  g.pixel_to_plane (o.eu, o.ev, 0, &gx, &gy);
  CHECK (std::fabs (std::hypot (gx, gy) - want) > 1e-3,
      "no bias to correct?");
  std::printf ("disc: ground %.5f size %.5f (true %.5f), ellipse centre "
      "%.5f\n", r.range_ground, r.range_size, want, std::hypot (gx, gy));
  /* the same disc taken for one 30 % larger: its size range is 30 % too
   * far, beyond what the two sigmas explain, and the excess is added to
   * the sigmas reported; with the right diameter nothing is added */
  CHECK (r.size_excess == 0, "right diameter, excess %g", r.size_excess);
  MarkerSpec larger = disc;
  larger.diameter *= 1.3;
  const RangeEstimate w = estimate_range (g, o, larger, 0.5);
  const double d = w.range_size - w.range_ground;
  CHECK (std::fabs (d - 0.3 * want) < 0.02 * want, "disagreement %g", d);
  const double e2 = d * d - 6.63 * (w.range_ground_sigma *
      w.range_ground_sigma + w.range_size_sigma * w.range_size_sigma);
  CHECK (e2 > 0 && std::fabs (w.size_excess - std::sqrt (e2)) < 1e-12,
      "excess %g want %g", w.size_excess, std::sqrt (std::max (e2, 0.0)));
  CHECK (std::fabs (w.range_sigma_total (w.range_ground_sigma) -
          std::hypot (w.range_ground_sigma, w.size_excess)) < 1e-15
      && w.bearing_sigma_total () > w.bearing_sigma
      && w.range_ground == r.range_ground, "widened sigmas");
}

/* The floor point of pixel (u, v) for a pinhole of focal length f pixels,
 * principal point (cx, cy), height h and tilt t below the horizontal,
 * written out from the projection (camera x right, y down, z forward):
 * range and bearing. */
static void
pinhole_floor_polar (double f, double cx, double cy, double h, double t,
    double u, double v, double *range, double *bearing)
{
  const double xc = (u - cx) / f, yc = (v - cy) / f;
  const double fwd = std::cos (t) - yc * std::sin (t);
  const double up = -std::sin (t) - yc * std::cos (t);
  const double left = -xc;
  const double s = h / -up;
  *range = std::hypot (s * fwd, s * left);
  *bearing = std::atan2 (s * left, s * fwd);
}

/* The seed's camera: 0.2 m up, hfov 54, 640x480, tilted tilt_deg down. */
static CameraGeometry
seed_camera (double tilt_deg)
{
  CameraParams p;
  p.width = 640;
  p.height = 480;
  p.camera_height = 0.2;
  p.tilt_deg = tilt_deg;
  CHECK (intrinsics_from_hfov (54, 640, 480, &p.fx, &p.fy, &p.cx, &p.cy),
      "hfov 54");
  CameraGeometry g;
  std::string err;
  CHECK (g.configure (p, &err), "%s", err.c_str ());
  return g;
}

/* The sigma model (docs/ranging.md, "Uncertainty") against the camera
 * written out by hand: a round blob of D pixels has a centre sigma of
 * pixel_sigma sqrt (2 / (pi D)) per axis, and range and bearing sigmas of
 * that times the gradient of the projection's range and bearing, here by
 * finite differences of pinhole_floor_polar. The seed camera: 0.2 m, tilt
 * 20, hfov 54, 640x480. */
static void
test_sigma_model ()
{
  const CameraGeometry g = seed_camera (20);
  const double f = 320 / std::tan (27 * M_PI / 180);
  const double t = 20 * M_PI / 180, e = 0.5;
  const double pts[][3] = { {319.5, 300, 40}, {500, 260, 25}, {100, 400, 80},
    {320, 250, 12} };
  for (const auto & pt : pts) {
    const double u = pt[0], v = pt[1], d = pt[2];
    const double h = 1e-3;
    double r0, b0, rl, bl, rr, br, ru, bu, rd, bd;
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t, u, v, &r0, &b0);
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t, u - h, v, &rl, &bl);
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t, u + h, v, &rr, &br);
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t, u, v - h, &ru, &bu);
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t, u, v + h, &rd, &bd);
    const double sc = e * std::sqrt (2 / (M_PI * d));
    const double want_r = sc * std::hypot ((rr - rl) / (2 * h),
        (rd - ru) / (2 * h));
    const double want_b = sc * std::hypot ((br - bl) / (2 * h),
        (bd - bu) / (2 * h));
    /* a round blob: by its ellipse and by its equivalent diameter */
    for (bool ellipse : { false, true }) {
      BlobObservation o;
      o.u = o.eu = u;
      o.v = o.ev = v;
      o.has_ellipse = ellipse;
      o.major = o.minor = d;
      o.equivalent_diameter = d;
      const RangeEstimate r = estimate_range (g, o, MarkerSpec (), e);
      /* the centroid's ray (with an ellipse, the circle through its
       * outline on the floor: another point) */
      CHECK (ellipse || std::fabs (r.range_ground - r0) < 1e-6 * r0,
          "range %g want %g", r.range_ground, r0);
      /* central differences of 0.5 px against 1e-3 px: the curvature of
       * the projection, well under 1 % */
      CHECK (std::fabs (r.range_ground_sigma / want_r - 1) < 0.01,
          "(%g, %g) D %g ellipse %d: range sigma %g want %g", u, v, d,
          ellipse, r.range_ground_sigma, want_r);
      CHECK (std::fabs (r.bearing_sigma / want_b - 1) < 0.01,
          "(%g, %g) D %g ellipse %d: bearing sigma %g want %g", u, v, d,
          ellipse, r.bearing_sigma, want_b);
      CHECK (r.size_excess == 0, "no size, no excess");
    }
    /* the mounting: 1 % of the height scales the range by 1 %; 0.1 degree
     * of tilt moves it as the projection does */
    BlobObservation o;
    o.u = u;
    o.v = v;
    o.equivalent_diameter = d;
    MountingSigma m;
    m.height_rel = 0.01;
    m.tilt = 0.1 * M_PI / 180;
    double rt, bt;
    pinhole_floor_polar (f, 319.5, 239.5, 0.2, t + 1e-6, u, v, &rt, &bt);
    const double want_m = std::sqrt (want_r * want_r + 1e-4 * r0 * r0 +
        std::pow ((rt - r0) / 1e-6 * m.tilt, 2));
    const RangeEstimate rm = estimate_range (g, o, MarkerSpec (), e, m);
    CHECK (std::fabs (rm.range_ground_sigma / want_m - 1) < 0.01,
        "(%g, %g): range sigma with mounting %g want %g", u, v,
        rm.range_ground_sigma, want_m);
  }
  /* a flat ellipse (a disc far away, 2a x 2b): its long edges place the
   * centre across them (v) about as well as a circle of its major axis,
   * variance 8 / (3 pi) of the circle's as b / a -> 0, and along (u) worse
   * than that circle */
  double wide[3], round_minor[3], round_major[3];
  BlobObservation o;
  o.has_ellipse = true;
  o.major = 60;
  o.minor = 12;
  centre_covariance (o, 0.5, wide);
  o.major = o.minor = 12;
  centre_covariance (o, 0.5, round_minor);
  o.major = o.minor = 60;
  centre_covariance (o, 0.5, round_major);
  CHECK (std::fabs (round_major[0] - 0.25 * 2 / (M_PI * 60)) < 1e-4 *
      round_major[0], "circle of 60 px: %g", round_major[0]);
  CHECK (std::fabs (wide[2] / round_major[2] - 8 / (3 * M_PI)) < 0.03,
      "v variance %g, circle of the major axis %g", wide[2],
      round_major[2]);
  CHECK (wide[0] > round_major[0], "u variance %g, circle %g", wide[0],
      round_major[0]);
  CHECK (std::fabs (wide[1]) < 1e-12, "axis-aligned: no covariance");
  std::printf ("sigma model: matches the hand-written pinhole's gradient\n");
}

/* Centroids of rendered blobs against centre_covariance: pixels whose
 * centre lies inside an ellipse of 2a x 2b, axis-aligned, at 400
 * sub-pixel placements; the centroid's spread per axis, pixels. */
static void
rendered_centroid_spread (double a, double b, double *su, double *sv)
{
  std::mt19937 rng (7);
  std::uniform_real_distribution<double> off (0, 1);
  double uu = 0, vv = 0;
  const int n = 400;
  for (int k = 0; k < n; k++) {
    const double cx = off (rng), cy = off (rng);
    double mu = 0, mv = 0, count = 0;
    for (int y = -(int) b - 2; y <= (int) b + 2; y++)
      for (int x = -(int) a - 2; x <= (int) a + 2; x++)
        if (std::pow ((x - cx) / a, 2) + std::pow ((y - cy) / b, 2) <= 1) {
          mu += x;
          mv += y;
          count++;
        }
    uu += std::pow (mu / count - cx, 2);
    vv += std::pow (mv / count - cy, 2);
  }
  *su = std::sqrt (uu / n);
  *sv = std::sqrt (vv / n);
}

/* The centre model's amplitude against rendered blobs (docs/ranging.md,
 * "Uncertainty", item 7): the pixel grid alone places a round blob's
 * centroid as independent errors of 1 / sqrt (12) px per pixel of outline
 * say, 1.7 times better than the default 0.5 px; a flat one's across its
 * long edges (v, the range's direction) is placed worse than that, since
 * a long edge rounds to the same row over runs of columns. */
static void
test_rendered_centre ()
{
  const double q = 1 / std::sqrt (12.0);
  for (double d : { 16.0, 40.0 }) {
    double su, sv, cq[3], c5[3];
    rendered_centroid_spread (d / 2, d / 2, &su, &sv);
    BlobObservation o;
    o.has_ellipse = true;
    o.major = o.minor = d;
    centre_covariance (o, q, cq);
    centre_covariance (o, 0.5, c5);
    for (double s : { su, sv }) {
      CHECK (s > 0.7 * std::sqrt (cq[0]) && s < 1.3 * std::sqrt (cq[0]),
          "D %g: rendered centre spread %.4f px, 1/sqrt(12) model %.4f",
          d, s, std::sqrt (cq[0]));
      CHECK (s < std::sqrt (c5[0]) / 1.4, "D %g: spread %.4f px, 0.5 px "
          "model %.4f", d, s, std::sqrt (c5[0]));
    }
  }
  const double flats[][2] = { {30, 6}, {50, 15} };
  for (const auto & ab : flats) {
    double su, sv, cq[3];
    rendered_centroid_spread (ab[0], ab[1], &su, &sv);
    BlobObservation o;
    o.has_ellipse = true;
    o.major = 2 * ab[0];
    o.minor = 2 * ab[1];
    centre_covariance (o, q, cq);
    CHECK (sv > 1.3 * std::sqrt (cq[2]), "%g x %g: across the long edges "
        "%.4f px, independent model %.4f", 2 * ab[0], 2 * ab[1], sv,
        std::sqrt (cq[2]));
  }
  std::printf ("rendered centre: the grid's error is 1/sqrt(12) px\n");
}

/* A blob from outline points (cv::fitEllipse), as blobroundness gives it. */
static BlobObservation
blob_of (const std::vector<cv::Point2f> & outline)
{
  const cv::RotatedRect e = cv::fitEllipse (outline);
  BlobObservation o;
  o.has_ellipse = true;
  o.u = o.eu = e.center.x;
  o.v = o.ev = e.center.y;
  o.major = std::max (e.size.width, e.size.height);
  o.minor = std::min (e.size.width, e.size.height);
  o.angle = e.angle * M_PI / 180 + (e.size.width < e.size.height ?
      M_PI / 2 : 0);
  return o;
}

/* Each point of a closed outline moved along its normal (outwards
 * positive) by offset (x, y): the normal from its two neighbours. */
template < typename F > static std::vector<cv::Point2f>
moved_outline (const std::vector<cv::Point2f> & in, F offset)
{
  std::vector<cv::Point2f> out;
  const size_t n = in.size ();
  double area2 = 0;             /* > 0: counter-clockwise in (u, v) */
  for (size_t i = 0; i < n; i++)
    area2 += in[i].x * in[(i + 1) % n].y - in[(i + 1) % n].x * in[i].y;
  for (size_t i = 0; i < n; i++) {
    const cv::Point2f t = in[(i + 1) % n] - in[(i + n - 1) % n];
    double nu = t.y, nv = -t.x;
    const double len = std::hypot (nu, nv) * (area2 > 0 ? 1 : -1);
    nu /= len;
    nv /= len;
    const double d = offset (nu, nv);
    out.emplace_back ((float) (in[i].x + d * nu), (float) (in[i].y + d * nv));
  }
  return out;
}

/* The outline of a ball of radius br resting on the floor at (bx, by): the
 * tangent cone's, the circle of tangent points projected. */
static std::vector<cv::Point2f>
ball_outline (const CameraGeometry & g, double bx, double by, double br)
{
  const Vec3 c = g.centre ();
  const Vec3 a {bx - c.x, by - c.y, br - c.z};
  const double len = std::sqrt (a.x * a.x + a.y * a.y + a.z * a.z);
  const Vec3 k {a.x / len, a.y / len, a.z / len};
  /* two unit vectors across the axis */
  Vec3 e1 {-k.y, k.x, 0};
  const double n1 = std::hypot (e1.x, e1.y);
  e1 = Vec3 {e1.x / n1, e1.y / n1, 0};
  const Vec3 e2 {k.y * e1.z - k.z * e1.y, k.z * e1.x - k.x * e1.z,
    k.x * e1.y - k.y * e1.x};
  const double back = br * br / len, across = br * std::sqrt (len * len -
      br * br) / len;
  std::vector<cv::Point2f> ball;
  for (int i = 0; i < 720; i++) {
    const double t = 2 * M_PI * i / 720;
    const double s1 = across * std::cos (t), s2 = across * std::sin (t);
    double u, v;
    g.project (Vec3 {bx - back * k.x + s1 * e1.x + s2 * e2.x,
            by - back * k.y + s1 * e1.y + s2 * e2.y,
            br - back * k.z + s1 * e1.z + s2 * e2.z}, &u, &v);
    ball.emplace_back ((float) u, (float) v);
  }
  return ball;
}

/* The rim (docs/ranging.md, "Uncertainty"): the seed camera (0.2 m, tilt
 * 18, hfov 54). A near disc whose outline is eroded by 0.3 px all round,
 * as blur and a colour threshold do, comes out short by a shift of its
 * plane centre that the pixel term (0.05 mm at 0.4 m) does not cover; a
 * ball whose outline lost 0.5 px underneath, 0.25 px on the sides and none
 * on top (its shading) comes out long. The rim term,
 * from the known diameter, must account for each error, and is nil for
 * the exact outlines. */
static void
test_rim ()
{
  const CameraGeometry g = seed_camera (18);
  /* a disc of 0.1 m, 0.4 m ahead and 0.1 m to the left */
  const double dx = 0.4, dy = 0.1, rad = 0.05;
  std::vector<cv::Point2f> disc;
  for (int i = 0; i < 720; i++) {
    const double t = 2 * M_PI * i / 720;
    double u, v;
    g.project (Vec3 {dx + rad * std::cos (t), dy + rad * std::sin (t), 0},
        &u, &v);
    disc.emplace_back ((float) u, (float) v);
  }
  MarkerSpec dspec;
  dspec.diameter = 2 * rad;
  const double want = std::hypot (dx, dy);
  const RangeEstimate exact = estimate_range (g, blob_of (disc), dspec, 0.5);
  const RangeEstimate eroded = estimate_range (g, blob_of (moved_outline (
              disc, [](double, double) { return -0.3; })), dspec, 0.5);
  const double e_disc = eroded.range_ground - want;
  std::printf ("rim, disc at %.3f m: exact %+.4f mm (rim %.4f), eroded "
      "0.3 px %+.4f mm, pixel sigma %.4f, rim %.4f mm\n", want,
      1e3 * (exact.range_ground - want), 1e3 * exact.rim_range,
      1e3 * e_disc, 1e3 * eroded.range_ground_sigma,
      1e3 * eroded.rim_range);
  CHECK (std::fabs (exact.range_ground - want) < 5e-6
      && exact.rim_range < 0.1 * eroded.rim_range, "exact disc: error %g, "
      "rim %g", exact.range_ground - want, exact.rim_range);
  CHECK (e_disc < -1.5 * eroded.range_ground_sigma, "eroded disc: error %g "
      "beyond the pixel sigma %g", e_disc, eroded.range_ground_sigma);
  CHECK (std::fabs (eroded.rim_range / std::fabs (e_disc) - 1) < 0.25
      && eroded.size_excess == 0, "rim %g for an error of %g (excess %g)",
      eroded.rim_range, e_disc, eroded.size_excess);
  CHECK (std::fabs (eroded.range_sigma_total (eroded.range_ground_sigma) -
          std::hypot (eroded.range_ground_sigma, eroded.rim_range)) <
      1e-12, "reported range sigma with the rim");

  /* a ball of 0.08 m resting on the floor 0.7 m ahead */
  const double bx = 0.7, by = -0.1, br = 0.04;
  const std::vector<cv::Point2f> ball = ball_outline (g, bx, by, br);
  MarkerSpec bspec;
  bspec.ball = true;
  bspec.z = br;
  bspec.diameter = 2 * br;
  const double bwant = std::hypot (bx, by);
  const RangeEstimate bexact = estimate_range (g, blob_of (ball), bspec, 0.5);
  /* the shading grows towards the underside: the outline loses 0.5 px
   * where it faces down the image, 0.25 px on the sides, nothing on top */
  const RangeEstimate shaded = estimate_range (g, blob_of (moved_outline (
              ball, [](double, double nv) {
                return -0.25 * (1 + nv); })), bspec, 0.5);
  const double e_ball = shaded.range_ground - bwant;
  std::printf ("rim, ball at %.3f m: exact %+.4f mm (rim %.4f), shaded "
      "%+.4f mm, pixel and shading sigma %.4f, rim %.4f mm\n", bwant,
      1e3 * (bexact.range_ground - bwant), 1e3 * bexact.rim_range,
      1e3 * e_ball, 1e3 * shaded.range_ground_sigma, 1e3 * shaded.rim_range);
  CHECK (std::fabs (bexact.range_ground - bwant) < 2e-5
      && bexact.rim_range < 0.1 * shaded.rim_range, "exact ball: error %g, "
      "rim %g", bexact.range_ground - bwant, bexact.rim_range);
  CHECK (e_ball > 1.5 * shaded.range_ground_sigma, "shaded ball: error %g "
      "beyond the pixel sigma %g", e_ball, shaded.range_ground_sigma);
  CHECK (shaded.rim_range > 0.7 * e_ball && shaded.rim_range < 2.5 * e_ball
      && shaded.size_excess == 0, "rim %g for an error of %g (excess %g)",
      shaded.rim_range, e_ball, shaded.size_excess);
}

/* measure_end_offsets with the light given a pixel at a time (the frames
 * here are drawn analytically, pixel by pixel) */
static void
end_offsets_per_pixel (BlobObservation * blob, double angle,
    const std::function<bool (double, double, double[3])> & light)
{
  measure_end_offsets (blob, angle, [&](int x, int y, int n, double *rgb) {
        for (int i = 0; i < n; i++)
          if (!light (x + i, y, rgb + 3 * i))
            return false;
        return true;
      });
}

/* A shaded ball's outline from the frame (measure_end_offsets): the frame
 * drawn analytically (the exact outline blurred over a pixel, the ball's
 * light falling from top to bottom as Lambert shading makes it, a grey
 * floor), and the blob a colour threshold made of it, which lost 0.6 px at
 * the dark bottom, 0.3 px on the sides and none at the top: its centre is
 * up the image and the range long. The outline found where the light is
 * half-way between ball and floor takes that back. Near, far, off to the
 * side; the geometry itself is exact (test_rim's ball). */
static void
test_shaded_ball ()
{
  const CameraGeometry g = seed_camera (18);
  const double br = 0.0678;
  const double pos[][2] = { {0.6, 0.05}, {1.0, 0.3}, {1.5, -0.35} };
  for (const auto & p : pos) {
    const std::vector<cv::Point2f> exact = ball_outline (g, p[0], p[1], br);
    const cv::RotatedRect e = cv::fitEllipse (exact);
    const double ea = e.size.width / 2, eb = e.size.height / 2;
    const double ec = std::cos (e.angle * M_PI / 180), es = std::sin
        (e.angle * M_PI / 180);
    double top = 1e9, bottom = -1e9;
    for (const cv::Point2f & q : exact) {
      top = std::min (top, (double) q.y);
      bottom = std::max (bottom, (double) q.y);
    }
    /* the frame: coverage a 1-px ramp across the outline (the signed
     * distance to the ellipse, to first order), the ball's light from 0.9
     * at its top to 0.3 at its bottom */
    auto light = [&](double u, double v, double rgb[3]) {
      const double x = (u - e.center.x) * ec + (v - e.center.y) * es;
      const double y = -(u - e.center.x) * es + (v - e.center.y) * ec;
      const double rho = std::hypot (x / ea, y / eb);
      const double grad = std::hypot (x / (ea * ea), y / (eb * eb)) /
          std::max (rho, 1e-9);
      const double cover = std::min (1.0, std::max (0.0, 0.5 + (1 - rho) /
              grad));
      const double lit = 0.9 - 0.6 * std::min (1.0, std::max (0.0,
              (v - top) / (bottom - top)));
      const double ball[3] = {0.2 * lit, 0.8 * lit, 0.25 * lit};
      for (int k = 0; k < 3; k++)
        rgb[k] = cover * ball[k] + (1 - cover) * 0.3;
      return true;
    };
    BlobObservation blob = blob_of (moved_outline (exact,
            [](double, double nv) { return -0.3 * (1 + nv); }));
    MarkerSpec spec;
    spec.ball = true;
    spec.z = br;
    spec.diameter = 2 * br;
    const double want = std::hypot (p[0], p[1]);
    const RangeEstimate before = estimate_range (g, blob, spec, 0.5);
    end_offsets_per_pixel (&blob, ball_axis_angle (g, blob), light);
    const RangeEstimate after = estimate_range (g, blob, spec, 0.5);
    const double e0 = before.range_ground - want;
    const double e1 = after.range_ground - want;
    std::printf ("shaded ball at %.3f m: the blob's outline %+.3f mm (pixel "
        "and shading sigma %.3f), the frame's (ends %+.3f, %+.3f px) "
        "%+.3f mm\n", want, 1e3 * e0, 1e3 * before.range_ground_sigma,
        blob.end_offset[0], blob.end_offset[1], 1e3 * e1);
    CHECK (e0 > 1.5 * before.range_ground_sigma, "the blob's outline: error "
        "%g within the sigma %g", e0, before.range_ground_sigma);
    CHECK (std::fabs (e1) < 0.15 * e0, "the frame's outline: error %g "
        "(the blob's %g)", e1, e0);
    CHECK (after.size_excess == 0, "no excess for a whole ball: %g",
        after.size_excess);
    /* an end run off into a blur or a neighbour puts the frame's outline
     * at odds with its floor range: the blob's ellipse ranges it */
    BlobObservation off = blob;
    off.end_offset[0] += 1.5;
    BlobObservation own = off;
    own.has_ends = false;
    const RangeEstimate r_off = estimate_range (g, off, spec, 0.5);
    const RangeEstimate r_own = estimate_range (g, own, spec, 0.5);
    CHECK (r_off.range_ground == r_own.range_ground
        && r_off.range_ground_sigma == r_own.range_ground_sigma,
        "an end 1.5 px off: range %g (sigma %g), the blob's %g (%g)",
        r_off.range_ground, r_off.range_ground_sigma, r_own.range_ground,
        r_own.range_ground_sigma);
    if (&p != &pos[1])
      continue;
    /* the ends' sigmas against their scatter over frames of independent
     * noise per pixel and component (the analytic frame's light at pixel
     * centres, the noise bilinear between them), and through the range
     * (the range's sigma less the pixel term's, which this blob's whole
     * outline does not move: the ends' part). Pure noise
     * also makes the light about each crossing uneven, which the sigma
     * takes for an edge's shape: about 1.6x the scatter */
    int left = 1 << 20, up = 1 << 20;
    for (const cv::Point2f & q : exact) {
      left = std::min (left, (int) q.x - 8);
      up = std::min (up, (int) q.y - 8);
    }
    const int gw = (int) (2 * ea) + 24, gh = (int) (2 * ea) + 24;
    std::vector<double> grain (3 * gw * gh);
    std::mt19937 rng (11);
    std::normal_distribution<double> normal (0, 0.02);
    auto noisy = [&](double u, double v, double rgb[3]) {
      light (u, v, rgb);
      const double x = u - left, y = v - up;
      const int i = (int) x, j = (int) y;
      const double fx = x - i, fy = y - j;
      for (int k = 0; k < 3; k++) {
        auto at = [&](int di, int dj) {
          return grain[3 * ((j + dj) * gw + i + di) + k];
        };
        rgb[k] += (1 - fy) * ((1 - fx) * at (0, 0) + fx * at (1, 0))
            + fy * ((1 - fx) * at (0, 1) + fx * at (1, 1));
      }
      return x >= 0 && y >= 0 && i + 1 < gw && j + 1 < gh;
    };
    const int trials = 60;
    double sum[4] = {0, 0, 0, 0}, sum2[4] = {0, 0, 0, 0}, sigma2 = 0;
    double r_sum = 0, r_sum2 = 0, r_sigma2 = 0;
    for (int t = 0; t < trials; t++) {
      for (double & x : grain)
        x = normal (rng);
      BlobObservation b = blob_of (moved_outline (exact,
              [](double, double nv) { return -0.3 * (1 + nv); }));
      end_offsets_per_pixel (&b, ball_axis_angle (g, b), noisy);
      CHECK (b.has_ends, "ends with noise, trial %d", t);
      for (int k = 0; k < 4; k++) {
        sum[k] += b.end_offset[k];
        sum2[k] += b.end_offset[k] * b.end_offset[k];
        sigma2 += b.end_sigma[k] * b.end_sigma[k] / 4;
      }
      /* the ends' part of the range's sigma: less the same ends' without
       * their sigmas (the pixel term's alone) */
      const RangeEstimate r = estimate_range (g, b, spec, 0.5);
      BlobObservation exact_ends = b;
      std::fill (exact_ends.end_sigma, exact_ends.end_sigma + 4, 0.0);
      const RangeEstimate r0 = estimate_range (g, exact_ends, spec, 0.5);
      r_sum += r.range_ground;
      r_sum2 += r.range_ground * r.range_ground;
      r_sigma2 += r.range_ground_sigma * r.range_ground_sigma
          - r0.range_ground_sigma * r0.range_ground_sigma;
    }
    double scatter2 = 0;
    for (int k = 0; k < 4; k++)
      scatter2 += (sum2[k] / trials - std::pow (sum[k] / trials, 2)) / 4;
    const double scatter = std::sqrt (scatter2);
    const double said = std::sqrt (sigma2 / trials);
    const double r_scatter = std::sqrt (r_sum2 / trials - std::pow (r_sum /
            trials, 2));
    const double r_said = std::sqrt (r_sigma2 / trials);
    std::printf ("shaded ball at %.3f m with noise: ends scatter %.4f px, "
        "sigma %.4f px; range scatter %.4f mm, sigma %.4f mm\n", want,
        scatter, said, 1e3 * r_scatter, 1e3 * r_said);
    CHECK (said > 0.9 * scatter && said < 2.5 * scatter, "ends' sigma %g "
        "for a scatter of %g px", said, scatter);
    CHECK (r_said > 0.9 * r_scatter && r_said < 2.5 * r_scatter, "range "
        "sigma %g for a scatter of %g", r_said, r_scatter);
  }
  /* no contrast, or the ends off the frame: the blob's ellipse stays */
  BlobObservation flat = blob_of (ball_outline (g, 1.0, 0.3, br));
  end_offsets_per_pixel (&flat, flat.angle, [](double, double,
          double rgb[3]) {
        rgb[0] = rgb[1] = rgb[2] = 0.5;
        return true;
      });
  CHECK (!flat.has_ends, "no contrast: %g %g", flat.end_offset[0],
      flat.end_offset[1]);
  end_offsets_per_pixel (&flat, flat.angle, [](double, double, double[3]) {
        return false;
      });
  CHECK (!flat.has_ends, "off the frame");
}

int
main ()
{
  test_pinhole ();
  test_seed ();
  test_estimate ();
  test_sigma_model ();
  test_rendered_centre ();
  test_rim ();
  test_shaded_ball ();
  return corecheck_summary ();
}
