/* Pose solvers (plugins/landmark/core/estimation/posesolver.h): exact observations
 * recover the exact pose for each solver, both two-landmark ambiguities,
 * degenerate geometry reported, an outlier rejected, association with
 * repeated colours, the EKF bridging a gap and a turn on one landmark, the
 * tracker's one-landmark poses only with a measured heading (and their
 * covariance against a Monte-Carlo of the true error) and identity by
 * colour without a pose.
 * Observations are made here from docs/conventions.md directly, not with
 * the solver's helpers. */
#include "posefilter.h"
#include "posetracker.h"
#include "corecheck.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

using namespace landmark;

static double
angdiff (double a, double b)
{
  return std::remainder (a - b, 2 * M_PI);
}

/* conventions.md: gx = cos h dx + sin h dy, gy = -sin h dx + cos h dy */
static RangeBearing
observe (double x, double y, double h, double lx, double ly)
{
  RangeBearing o;
  const double dx = lx - x, dy = ly - y;
  o.gx = std::cos (h) * dx + std::sin (h) * dy;
  o.gy = -std::sin (h) * dx + std::cos (h) * dy;
  o.range_sigma = 0.01;
  o.bearing_sigma = 0.005;
  return o;
}

static Correspondence
corr (double x, double y, double h, double lx, double ly)
{
  Correspondence c;
  c.obs = observe (x, y, h, lx, ly);
  c.lx = lx;
  c.ly = ly;
  return c;
}

static void
check_pose (const PoseSolution & s, double x, double y, double h,
    double tol, const char *what)
{
  CHECK (s.ok, "%s: no solution (%s)", what, s.why.c_str ());
  if (!s.ok)
    return;
  CHECK (std::fabs (s.pose.x - x) < tol && std::fabs (s.pose.y - y) < tol
      && std::fabs (angdiff (s.pose.heading, h)) < tol,
      "%s: got (%.9f, %.9f, %.9f) want (%.9f, %.9f, %.9f)", what, s.pose.x,
      s.pose.y, s.pose.heading, x, y, h);
  /* covariance symmetric, positive diagonal */
  for (int r = 0; r < 3; r++) {
    CHECK (s.cov[r * 4] > 0 && std::isfinite (s.cov[r * 4]),
        "%s: cov[%d][%d] = %g", what, r, r, s.cov[r * 4]);
    for (int c = 0; c < 3; c++)
      CHECK (std::fabs (s.cov[r * 3 + c] - s.cov[c * 3 + r]) < 1e-9,
          "%s: covariance not symmetric", what);
  }
}

static void
test_conventions ()
{
  /* a landmark 1 m ahead-left of a robot facing +y: bearing positive */
  const RangeBearing o = observe (0, 0, M_PI / 2, -1, 1);
  CHECK (std::fabs (o.gx - 1) < 1e-12 && std::fabs (o.gy - 1) < 1e-12,
      "gx %g gy %g", o.gx, o.gy);
  CHECK (std::fabs (o.bearing () - M_PI / 4) < 1e-12, "bearing %g",
      o.bearing ());
  CHECK (std::fabs (wrap_angle (M_PI) - M_PI) < 1e-12, "wrap(pi)");
  CHECK (std::fabs (wrap_angle (-M_PI) - M_PI) < 1e-12, "wrap(-pi)");
  CHECK (std::fabs (wrap_angle (3 * M_PI / 2) + M_PI / 2) < 1e-12, "wrap");
}

static void
test_one ()
{
  const double poses[][3] = { {1, 2, 0.3}, {-2.5, 0.5, -2.9}, {4, 4, M_PI} };
  for (const auto & p : poses) {
    const Correspondence c = corr (p[0], p[1], p[2], 3.0, 1.0);
    check_pose (solve_one (c, p[2], 0.01), p[0], p[1], p[2], 1e-9, "one");
  }
  /* a heading error of e rotates the solution about the landmark: a
   * heading believed 0.1 rad left puts the robot right of the truth */
  const Correspondence c = corr (0, 0, 0, 2, 0);
  const PoseSolution s = solve_one (c, 0.1, 0.01);
  CHECK (std::fabs (std::hypot (s.pose.x - 2, s.pose.y) - 2) < 1e-9
      && std::fabs (s.pose.y + 2 * std::sin (0.1)) < 1e-9, "rotated about the landmark: (%g, %g)", s.pose.x,
      s.pose.y);
}

static void
test_two_both_sides ()
{
  /* landmarks at (0,0), (4,0); the robot left (y>0) or right (y<0) of the
   * baseline: both intersections are chosen correctly by the bearings */
  const double poses[][3] = { {2, 1.5, -1.2}, {2, -1.5, 1.9}, {1, 3, 0},
    {3, -2.5, 3.0}, {-1, 1, -0.5}, {5, -1, 2.5} };
  for (const auto & p : poses) {
    const Correspondence a = corr (p[0], p[1], p[2], 0, 0);
    const Correspondence b = corr (p[0], p[1], p[2], 4, 0);
    const PoseSolution s = solve_two (a, b);
    check_pose (s, p[0], p[1], p[2], 1e-9, "two");
    CHECK (std::string (s.solver) == "two", "solver %s", s.solver);
    CHECK (s.geometry == Geometry::Ok, "geometry %s",
        geometry_name (s.geometry));
    /* order of the landmarks does not matter */
    check_pose (solve_two (b, a), p[0], p[1], p[2], 1e-9, "two swapped");
  }
}

static void
test_two_degenerate ()
{
  /* robot on the segment between the landmarks: circles touch */
  {
    const Correspondence a = corr (1.5, 0, 0.4, 0, 0);
    const Correspondence b = corr (1.5, 0, 0.4, 4, 0);
    const PoseSolution s = solve_two (a, b);
    check_pose (s, 1.5, 0, 0.4, 1e-6, "on baseline");
    CHECK (s.geometry == Geometry::RobotOnBaseline, "geometry %s",
        geometry_name (s.geometry));
    /* noisy ranges that miss each other: still a pose, still reported */
    Correspondence a2 = a, b2 = b;
    a2.obs.gx *= 0.98;
    a2.obs.gy *= 0.98;
    const PoseSolution s2 = solve_two (a2, b2);
    CHECK (s2.ok && s2.geometry == Geometry::RobotOnBaseline,
        "noisy baseline: ok %d geometry %s", s2.ok,
        geometry_name (s2.geometry));
    CHECK (s2.ok && std::fabs (s2.pose.y) < 0.05, "y %g", s2.pose.y);
  }
  /* robot on the line beyond both */
  {
    const Correspondence a = corr (-2, 0, 0.1, 0, 0);
    const Correspondence b = corr (-2, 0, 0.1, 4, 0);
    const PoseSolution s = solve_two (a, b);
    CHECK (s.ok && s.geometry == Geometry::RobotInLine, "geometry %s",
        geometry_name (s.geometry));
  }
  /* circles far apart: no solution, with a reason */
  {
    Correspondence a = corr (2, 1, 0, 0, 0);
    Correspondence b = corr (2, 1, 0, 4, 0);
    a.obs.gx *= 0.3;
    a.obs.gy *= 0.3;
    b.obs.gx *= 0.3;
    b.obs.gy *= 0.3;
    const PoseSolution s = solve_two (a, b);
    CHECK (!s.ok && !s.why.empty (), "circles apart: ok %d", s.ok);
  }
}

static void
test_many_exact ()
{
  const double L[][2] = { {0, 0}, {5, 0}, {5, 4}, {0, 4}, {2.5, 6} };
  const double poses[][3] = { {2, 2, 0.7}, {1, 3, -2.0}, {4, 1, 3.1} };
  for (const auto & p : poses) {
    for (size_t n = 3; n <= 5; n++) {
      std::vector<Correspondence> cs;
      for (size_t i = 0; i < n; i++)
        cs.push_back (corr (p[0], p[1], p[2], L[i][0], L[i][1]));
      const PoseSolution s = solve_many (cs);
      check_pose (s, p[0], p[1], p[2], 1e-9, "many");
      CHECK (std::string (s.solver) == "lsq", "solver %s", s.solver);
      CHECK (s.residual < 1e-9, "residual %g", s.residual);
      CHECK (s.geometry == Geometry::Ok, "geometry %s",
          geometry_name (s.geometry));
    }
  }
}

static void
test_many_noise_and_covariance ()
{
  /* noisy observations: error within a few sigmas of the covariance */
  const double L[][2] = { {0, 0}, {5, 0}, {5, 4}, {0, 4} };
  std::mt19937 rng (7);
  std::normal_distribution<double> nr (0, 0.01), nb (0, 0.005);
  int within = 0;
  const int trials = 200;
  for (int t = 0; t < trials; t++) {
    std::vector<Correspondence> cs;
    for (const auto & l : L) {
      Correspondence c = corr (2, 1.5, 0.4, l[0], l[1]);
      const double r = c.obs.range () + nr (rng);
      const double b = c.obs.bearing () + nb (rng);
      c.obs.gx = r * std::cos (b);
      c.obs.gy = r * std::sin (b);
      cs.push_back (c);
    }
    const PoseSolution s = solve_many (cs);
    CHECK (s.ok, "noisy: %s", s.why.c_str ());
    const double ex = s.pose.x - 2, ey = s.pose.y - 1.5;
    /* Mahalanobis distance of the position error */
    const double a = s.cov[0], b = s.cov[1], d = s.cov[4];
    const double det = a * d - b * b;
    const double m2 = (d * ex * ex - 2 * b * ex * ey + a * ey * ey) / det;
    within += m2 < 9.21;    /* 99% for two dof */
  }
  CHECK (within > trials * 0.9, "%d of %d within the 99%% ellipse", within,
      trials);
}

static void
test_outlier_rejected ()
{
  const double L[][2] = { {0, 0}, {5, 0}, {5, 4}, {0, 4} };
  for (int bad = 0; bad < 4; bad++) {
    std::vector<Correspondence> cs;
    for (const auto & l : L)
      cs.push_back (corr (3, 1, 2.0, l[0], l[1]));
    /* one detection 0.8 m off in range */
    const double k = (cs[bad].obs.range () + 0.8) / cs[bad].obs.range ();
    cs[bad].obs.gx *= k;
    cs[bad].obs.gy *= k;
    const PoseSolution s = solve_many (cs);
    check_pose (s, 3, 1, 2.0, 1e-9, "outlier");
    for (int i = 0; i < 4; i++)
      CHECK (s.inlier[i] == (i != bad), "inlier[%d] = %d (bad %d)", i,
          (int) s.inlier[i], bad);
    CHECK (s.residuals[bad] > 0.5, "outlier residual %g", s.residuals[bad]);
  }
  /* three landmarks, one wrong in bearing: the two good ones win */
  {
    std::vector<Correspondence> cs;
    for (int i = 0; i < 3; i++)
      cs.push_back (corr (2, 2, -0.3, L[i][0], L[i][1]));
    const double r = cs[2].obs.range (), b = cs[2].obs.bearing () + 0.4;
    cs[2].obs.gx = r * std::cos (b);
    cs[2].obs.gy = r * std::sin (b);
    const PoseSolution s = solve_many (cs);
    check_pose (s, 2, 2, -0.3, 1e-9, "3 with outlier");
    CHECK (s.ok && !s.inlier[2], "outlier kept");
    CHECK (s.ok && std::string (s.solver) == "two", "solver %s", s.solver);
  }
}

static void
test_collinear ()
{
  /* three landmarks on the line y = 0: reported; bearings still place the
   * robot on the right side */
  const double L[][2] = { {0, 0}, {2, 0}, {5, 0} };
  for (double y : { 1.5, -1.5 }) {
    std::vector<Correspondence> cs;
    for (const auto & l : L)
      cs.push_back (corr (2.5, y, 0.5, l[0], l[1]));
    const PoseSolution s = solve_many (cs);
    check_pose (s, 2.5, y, 0.5, 1e-9, "collinear");
    CHECK (s.geometry == Geometry::CollinearLandmarks, "geometry %s",
        geometry_name (s.geometry));
  }
  CHECK (!landmarks_collinear ({corr (0, 0, 0, 0, 0), corr (0, 0, 0, 1, 0),
              corr (0, 0, 0, 1, 1)}), "a triangle is not collinear");
}

static std::vector<MapPoint>
test_map ()
{
  /* red and green twice, far apart; blue once */
  return {
    {"R1", "red", 0, 0}, {"G1", "green", 4, 0}, {"B1", "blue", 4, 4},
    {"R2", "red", 8, 4}, {"G2", "green", 8, 0}, {"Y1", "yellow", 0, 4},
  };
}

static Detection
det (const std::vector<MapPoint> & map, const std::string & id, double x,
    double y, double h)
{
  for (const auto & m : map)
    if (m.id == id)
      return Detection { m.class_name, observe (x, y, h, m.x, m.y) };
  return Detection ();
}

static void
test_association ()
{
  const auto map = test_map ();
  /* no prior: consensus picks R1/G1 over R2/G2 */
  {
    std::vector<Detection> d = { det (map, "R1", 2, 2, -2.0),
      det (map, "G1", 2, 2, -2.0), det (map, "Y1", 2, 2, -2.0) };
    LocaliseOptions opt;
    const LocaliseResult r = localise (map, d, opt);
    CHECK (r.ok, "%s", r.why.c_str ());
    CHECK (r.match[0] == 0 && r.match[1] == 1 && r.match[2] == 5,
        "match %d %d %d", r.match[0], r.match[1], r.match[2]);
    check_pose (r.solution, 2, 2, -2.0, 1e-9, "associated");
    CHECK (r.n_used == 3, "n_used %d", r.n_used);
  }
  /* the other pair */
  {
    std::vector<Detection> d = { det (map, "R2", 6, 2, 0.5),
      det (map, "G2", 6, 2, 0.5), det (map, "B1", 6, 2, 0.5) };
    const LocaliseResult r = localise (map, d, LocaliseOptions ());
    CHECK (r.ok && r.match[0] == 3 && r.match[1] == 4 && r.match[2] == 2,
        "match %d %d %d", r.match[0], r.match[1], r.match[2]);
  }
  /* with a prior: two detections of repeated colours gated to the right
   * ones, solved by the two-landmark solver */
  {
    std::vector<Detection> d = { det (map, "R2", 6, 2, 0.5),
      det (map, "G2", 6, 2, 0.5) };
    LocaliseOptions opt;
    opt.have_prior = true;
    opt.prior = { 6.1, 2.1, 0.52 };
    const LocaliseResult r = localise (map, d, opt);
    CHECK (r.ok && r.match[0] == 3 && r.match[1] == 4, "match %d %d",
        r.match[0], r.match[1]);
    check_pose (r.solution, 6, 2, 0.5, 1e-9, "gated two");
    /* a prior far off: nothing in the gate, never forced */
    opt.prior = { 0.5, 3.5, 2.5 };
    const LocaliseResult r2 = localise (map, d, opt);
    CHECK (!r2.ok && r2.match[0] < 0 && r2.match[1] < 0,
        "forced match %d %d", r2.match[0], r2.match[1]);
    CHECK (r2.reasons[0] == "outside-gate", "reason %s",
        r2.reasons[0].c_str ());
  }
  /* a class not on the map, and one red too many: unmatched */
  {
    std::vector<Detection> d = { det (map, "R1", 2, 2, -2.0),
      det (map, "G1", 2, 2, -2.0), det (map, "Y1", 2, 2, -2.0),
      det (map, "B1", 2, 2, -2.0) };
    Detection pink = d[0];
    pink.class_name = "pink";
    d.push_back (pink);
    Detection ghost = d[0];      /* a red blob where there is none */
    ghost.obs.gx += 1.3;
    ghost.obs.gy -= 0.9;
    d.push_back (ghost);
    const LocaliseResult r = localise (map, d, LocaliseOptions ());
    CHECK (r.ok && r.n_used == 4, "n_used %d", r.n_used);
    CHECK (r.match[4] == -1 && r.reasons[4] == "no-landmark-of-class",
        "pink: %d %s", r.match[4], r.reasons[4].c_str ());
    CHECK (r.match[5] == -1, "ghost matched %d", r.match[5]);
    check_pose (r.solution, 2, 2, -2.0, 1e-9, "with strays");
  }
  /* one detection: needs a heading; ambiguous colour needs a prior */
  {
    std::vector<Detection> d = { det (map, "Y1", 1, 2, 1.0) };
    const LocaliseResult r = localise (map, d, LocaliseOptions ());
    CHECK (!r.ok && r.why == "too-few-landmarks", "why %s", r.why.c_str ());
    LocaliseOptions opt;
    opt.have_heading = true;
    opt.heading = 1.0;
    const LocaliseResult r2 = localise (map, d, opt);
    check_pose (r2.solution, 1, 2, 1.0, 1e-9, "one via localise");
    CHECK (std::string (r2.solution.solver) == "one", "solver");
    std::vector<Detection> dr = { det (map, "R1", 1, 2, 1.0) };
    dr[0] = det (map, "R1", 1, 1, -2.0);
    const LocaliseResult r3 = localise (map, dr, opt);
    CHECK (!r3.ok && r3.reasons[0] == "ambiguous", "reason %s",
        r3.reasons[0].c_str ());
  }
  /* one colour, two markers (a floor disc and a ball): a detection that
   * names its marker has one candidate; one naming a marker that no
   * landmark has falls back to the class */
  {
    std::vector<MapPoint> m2 = {
      { "D", "yellow", 1, 1, 0.0, 0.30, false },
      { "B", "yellow", 4, 3, 0.1, 0.20, true },
    };
    LocaliseOptions opt;
    opt.have_heading = true;
    opt.heading = 0.3;
    Detection d { "yellow", observe (2, 2, 0.3, 4, 3) };
    const LocaliseResult plain = localise (m2, { d }, opt);
    CHECK (!plain.ok && plain.reasons[0] == "ambiguous", "without marker: "
        "%s", plain.reasons[0].c_str ());
    d.has_marker = true;
    d.marker_z = 0.1;
    d.marker_diameter = 0.20;
    d.marker_ball = true;
    const LocaliseResult r = localise (m2, { d }, opt);
    CHECK (r.ok && r.match[0] == 1, "ball: match %d (%s)", r.match[0],
        r.reasons[0].c_str ());
    check_pose (r.solution, 2, 2, 0.3, 1e-9, "ball by its marker");
    d.marker_diameter = 0.25;    /* no landmark has this marker */
    const LocaliseResult r2 = localise (m2, { d }, opt);
    CHECK (!r2.ok && r2.reasons[0] == "ambiguous", "unknown marker: %s",
        r2.reasons[0].c_str ());
  }
}

/* Range and bearing of landmark (lx, ly) from the true pose, with noise. */
static Correspondence
noisy_corr (double x, double y, double h, double lx, double ly,
    std::mt19937 & rng)
{
  std::normal_distribution<double> nr (0, 0.01), nb (0, 0.005);
  Correspondence c = corr (x, y, h, lx, ly);
  const double r = c.obs.range () + nr (rng);
  const double b = c.obs.bearing () + nb (rng);
  c.obs.gx = r * std::cos (b);
  c.obs.gy = r * std::sin (b);
  return c;
}

/* A ground robot on a circle: its turning centre at radius `radius`
 * round the origin, driving counter-clockwise at `speed`, the camera
 * `offset` ahead of it; the camera's pose at time t. */
struct CirclePath {
  double radius, speed, offset;
  Pose2 at (double t) const {
    const double a = speed / radius * t;     /* angle round the circle */
    Pose2 p;
    p.heading = wrap_angle (a + M_PI / 2);
    p.x = radius * std::cos (a) + offset * std::cos (p.heading);
    p.y = radius * std::sin (a) + offset * std::sin (p.heading);
    return p;
  }
};

/* The ground robot's prediction: its Jacobian against central
 * differences of the predicted states, its noise symmetric and positive
 * semi-definite, and the motion a ground robot's: a camera at the turning
 * centre (d = 0) moves along its heading at mid-interval, a camera
 * ahead of it (d > 0) swings out to the left on a left turn. */
static void
test_ground_motion ()
{
  const int N = kMotionStates;
  const GroundMotionNoise noise;
  std::mt19937 rng (7);
  std::uniform_real_distribution<double> u (-1, 1);
  for (int trial = 0; trial < 20; trial++) {
    const double s[N] = { 3 * u (rng), 3 * u (rng), M_PI * u (rng),
      u (rng), 0.2 * u (rng), 2 * u (rng) };
    const double dt = 0.05 + 0.1 * (u (rng) + 1);
    const GroundMotionStep step = ground_motion_predict (s, dt, noise);
    double worst = 0;
    for (int j = 0; j < N; j++) {
      const double h = 1e-6;
      double sp[N], sm[N];
      std::copy (s, s + N, sp);
      std::copy (s, s + N, sm);
      sp[j] += h;
      sm[j] -= h;
      const GroundMotionStep a = ground_motion_predict (sp, dt, noise);
      const GroundMotionStep b = ground_motion_predict (sm, dt, noise);
      for (int i = 0; i < N; i++) {
        double diff = a.s[i] - b.s[i];
        if (i == kMotionHeading)
          diff = angdiff (a.s[i], b.s[i]);
        worst = std::max (worst, std::fabs (diff / (2 * h)
                - step.F[i * N + j]));
      }
    }
    CHECK (worst < 1e-6, "trial %d: Jacobian off by %g", trial, worst);
    double qmin = 1e9;
    for (int i = 0; i < N; i++)
      for (int j = 0; j < N; j++)
        CHECK (step.Q[i * N + j] == step.Q[j * N + i], "Q not symmetric");
    /* positive semi-definite: its smallest eigenvalue, to rounding */
    cv::Mat eig;
    cv::eigen (cv::Mat (N, N, CV_64F, const_cast<double *> (step.Q)), eig);
    double qmax;
    cv::minMaxLoc (eig, &qmin, &qmax);
    CHECK (qmin >= -1e-12 * std::max (qmax, 1e-30),
        "Q not positive semi-definite: eigenvalue %g", qmin);
  }
  /* heading 0.3 rad, 0.5 m/s, turning 1 rad/s over 0.1 s: the exact arc
   * is a chord of 2 (v / w) sin (w dt / 2) = 0.049979 m along the mid
   * heading 0.35; the model's step is its first order (0.05 m), within
   * 3x its 2.1e-5 m error */
  const double at_centre[N] = { 1, 2, 0.3, 0.5, 0, 1 };
  const GroundMotionStep c = ground_motion_predict (at_centre, 0.1,
      noise);
  const double chord = 2 * 0.5 * std::sin (0.05);
  CHECK (std::fabs (std::atan2 (c.s[1] - 2, c.s[0] - 1) - 0.35) < 1e-12
      && std::fabs (std::hypot (c.s[1] - 2, c.s[0] - 1) - chord) < 6e-5
      && std::fabs (c.s[kMotionHeading] - 0.4) < 1e-12,
      "at the centre: (%g, %g, %g)", c.s[0], c.s[1], c.s[2]);
  double ahead[N];
  std::copy (at_centre, at_centre + N, ahead);
  ahead[kMotionOffset] = 0.1;
  const GroundMotionStep o = ground_motion_predict (ahead, 0.1, noise);
  /* a camera d = 0.1 m ahead of the turning centre also swings by
   * d (R(0.4) - R(0.3)) (1, 0): 2 d sin (w dt / 2) = 0.0099958 m to the
   * left of the mid heading (the model: w d dt = 0.01 m, 4.2e-6 off) */
  const double swing = 2 * 0.1 * std::sin (0.05);
  CHECK (std::fabs ((o.s[0] - c.s[0]) + swing * std::sin (0.35)) < 1.3e-5
      && std::fabs ((o.s[1] - c.s[1]) - swing * std::cos (0.35)) < 1.3e-5,
      "offset: (%g, %g)", o.s[0] - c.s[0], o.s[1] - c.s[1]);
}

static void
test_ekf_bridges_gap ()
{
  /* a wide arc (0.5 m/s turning 0.2 rad/s); measurements for 1 s, a gap
   * of 0.5 s, then again */
  const double L[][2] = { {-3, -1}, {3, -1}, {3, 4}, {-3, 4} };
  const CirclePath path { 2.5, 0.5, 0.0 };
  PoseFilter f;
  /* the motion is truly constant-velocity: little process noise */
  f.motion.accel_sigma = 0.2;
  f.motion.alpha_sigma = 0.5;
  const double dt = 1.0 / 30;
  std::mt19937 rng (3);
  double worst_gap = 0, worst_after = 0;
  for (int k = 0; k < 60; k++) {
    const Pose2 truth = path.at (k * dt);
    const bool gap = k >= 30 && k < 45;
    if (f.initialised ())
      f.predict (dt);
    if (!gap) {
      std::vector<Correspondence> cs;
      for (const auto & l : L)
        cs.push_back (noisy_corr (truth.x, truth.y, truth.heading, l[0],
                l[1], rng));
      if (!f.initialised ()) {
        const PoseSolution s = solve_many (cs);
        CHECK (s.ok, "init");
        f.init (s.pose, s.cov);
      } else {
        CHECK (f.update (cs) == 4, "all four used");
      }
    }
    const Pose2 p = f.pose ();
    const double e = std::hypot (p.x - truth.x, p.y - truth.y);
    if (gap)
      worst_gap = std::max (worst_gap, e);
    else if (k > 45)
      worst_after = std::max (worst_after, e);
    if (gap) {
      double c[9];
      f.pose_cov (c);
      CHECK (std::sqrt (c[0]) > 0.001, "covariance grows in the gap");
    }
  }
  /* the velocity learnt before the gap carries the pose through it */
  CHECK (worst_gap < 0.05, "worst error in the gap %.4f m", worst_gap);
  CHECK (worst_after < 0.03, "worst error after %.4f m", worst_after);
  /* an absurd measurement is gated out */
  std::vector<Correspondence> cs = { corr (10, 10, 0, 0, 0) };
  CHECK (f.update (cs) == 0, "gross outlier accepted");
}

/* A robot turning on a tight circle (radius 1 m, 0.5 m/s, 0.5 rad/s, the
 * camera 0.1 m ahead of the turning centre) sees four landmarks for 1 s,
 * then one for 2 s (a full radian of turn). One range and bearing fixes
 * the pose only up to a slide round that landmark; the motion model has
 * to hold it. A robot that drives along its heading does (worst 2.2 cm,
 * 0.012 rad, 1.5 sigma); a constant velocity in the map frame takes the
 * turn for sideways acceleration and the pose slides round the landmark
 * (1.2 m, 0.48 rad, 6.2 sigma). */
static void
test_ekf_turn_on_one_landmark ()
{
  const double L[][2] = { {2.5, 0.5}, {-2, 2}, {-2, -2}, {2, -2} };
  const CirclePath path { 1.0, 0.5, 0.1 };
  PoseFilter f;                   /* the element's noise and priors */
  const double dt = 1.0 / 30;
  std::mt19937 rng (11);
  double worst = 0, worst_heading = 0, worst_sigma = 0;
  for (int k = 0; k < 90; k++) {
    const Pose2 truth = path.at (k * dt);
    if (f.initialised ())
      f.predict (dt);
    std::vector<Correspondence> cs;
    for (int i = 0; i < (k < 30 ? 4 : 1); i++)
      cs.push_back (noisy_corr (truth.x, truth.y, truth.heading, L[i][0],
              L[i][1], rng));
    if (!f.initialised ()) {
      const PoseSolution s = solve_many (cs);
      CHECK (s.ok, "init");
      f.init (s.pose, s.cov);
      continue;
    }
    CHECK (f.update (cs) == (int) cs.size (), "frame %d: a pairing gated "
        "out", k);
    if (k < 30)
      continue;
    const Pose2 p = f.pose ();
    double c[9];
    f.pose_cov (c);
    const double e = std::hypot (p.x - truth.x, p.y - truth.y);
    worst = std::max (worst, e);
    worst_heading = std::max (worst_heading,
        std::fabs (angdiff (p.heading, truth.heading)));
    /* the error stays within what the filter states (3 sigma) */
    worst_sigma = std::max (worst_sigma, e / std::sqrt (c[0] + c[4]));
  }
  CHECK (worst < 0.06, "worst position error on one landmark %.4f m",
      worst);
  CHECK (worst_heading < 0.04, "worst heading error %.4f rad",
      worst_heading);
  CHECK (worst_sigma < 3, "error %.2f sigma", worst_sigma);
}

/* When a solution from three landmarks disagrees with the filter, the
 * filter is lost only if the landmarks reject it one by one too; a
 * solution pulled off by one biased range is the one that is wrong. */
static void
test_ekf_lost ()
{
  const double L[][2] = { {0, 0}, {5, 0}, {5, 4} };
  const double x = 2, y = 1.5, h = 0.3;
  std::vector<Correspondence> cs;
  for (const auto & l : L)
    cs.push_back (corr (x, y, h, l[0], l[1]));
  const double tight[9] = { 1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4 };
  PoseSolution sol;
  sol.ok = true;
  std::copy (tight, tight + 9, sol.cov);

  /* the filter on the truth; the solution 0.15 m and 0.05 rad off, 10
   * sigma of the two together: the pairings pass, the filter stays */
  PoseFilter f;
  f.init (Pose2 { x, y, h }, tight);
  sol.pose = Pose2 { x + 0.15, y, h + 0.05 };
  CHECK (!f.lost (sol, cs), "a pulled solution restarts the filter");
  /* the filter 0.5 m off the truth, the solution on it: lost */
  f.init (Pose2 { x + 0.5, y, h }, tight);
  sol.pose = Pose2 { x, y, h };
  CHECK (f.lost (sol, cs), "a drifted filter is kept");
  /* the two agree: not lost */
  f.init (Pose2 { x + 0.01, y, h }, tight);
  CHECK (!f.lost (sol, cs), "agreeing solution");
}

/* Clutter: a map with 253 landmarks of one colour and three of their own,
 * 40 blobs of the repeated colour at random places beside the three true
 * ones. The consensus stays within its budget of pair poses and still
 * finds the pose from the three precise detections, and from them alone:
 * their ranges are exact, so the pose is the truth to rounding (1e-16 m
 * here); 1e-6 m and rad leave room for the solver's iterations, while
 * one clutter blob in the fit, or a true detection 1 cm off, moves the
 * pose by millimetres. */
static void
test_consensus_budget ()
{
  std::mt19937 rng (5);
  std::uniform_real_distribution<double> u (-20, 20), r (2.0, 6.0),
      b (-0.6, 0.6);
  std::vector<MapPoint> map = {
    { "R", "red", 3, 1 }, { "G", "green", 2, -1.5 }, { "B", "blue", 4, 0.5 },
  };
  for (int k = 0; map.size () < 256; k++)
    map.push_back ({ "Y" + std::to_string (k), "yellow", u (rng), u (rng) });
  const double x = 0.5, y = 0.2, h = 0.1;
  std::vector<Detection> d;
  for (int k = 0; k < 3; k++)
    d.push_back ({ map[k].class_name, observe (x, y, h, map[k].x,
                map[k].y) });
  for (int k = 0; k < 40; k++) {
    const double rr = r (rng), bb = b (rng);
    RangeBearing o;
    o.gx = rr * std::cos (bb);
    o.gy = rr * std::sin (bb);
    d.push_back ({ "yellow", o });
  }
  const LocaliseResult res = localise (map, d, LocaliseOptions ());
  CHECK (res.hypotheses > 0 && res.hypotheses <= kMaxConsensusHypotheses,
      "hypotheses %d", res.hypotheses);
  CHECK (res.ok && res.match[0] == 0 && res.match[1] == 1
      && res.match[2] == 2, "ok %d match %d %d %d (%s)", res.ok,
      res.match[0], res.match[1], res.match[2], res.why.c_str ());
  CHECK (res.n_used == 3, "landmarks in the solution %d", res.n_used);
  if (res.ok) {
    CHECK (std::hypot (res.solution.pose.x - x, res.solution.pose.y - y)
        < 1e-6, "pose %.9g %.9g", res.solution.pose.x, res.solution.pose.y);
    CHECK (std::fabs (angdiff (res.solution.pose.heading, h)) < 1e-6,
        "heading %.9g", res.solution.pose.heading);
  }
}

/* The tracker's scene: four landmarks of their own colour and a pink
 * pair; the robot on the tight circle of test_ekf_turn_on_one_landmark. */
static const std::vector<MapPoint> kTrackerMap = {
  { "A", "red", 2.5, 0.5 }, { "B", "green", -2, 2 }, { "C", "blue", -2, -2 },
  { "D", "yellow", 2, -2 }, { "P1", "pink", 0, 3 }, { "P2", "pink", 0, -3 },
};

static std::vector<Detection>
tracker_seen (const Pose2 & t, const std::vector<int> & which,
    std::mt19937 * rng)
{
  std::vector<Detection> d;
  for (int i : which) {
    const MapPoint & m = kTrackerMap[i];
    Correspondence c = rng ? noisy_corr (t.x, t.y, t.heading, m.x, m.y, *rng)
        : corr (t.x, t.y, t.heading, m.x, m.y);
    d.push_back ({ m.class_name, c.obs });
  }
  return d;
}

/* filter=none: a one-landmark pose needs a measured heading. Four
 * landmarks for 1 s, then one: no pose (the previous pose's heading is
 * stale: the robot turns 0.5 rad/s), the detection still named by its
 * colour; a repeated colour named only where a fresh prior places it.
 * With the heading property the pose is reported, the heading's variance
 * in the position's (rho^2 sigma_h^2 across the line of sight). */
static void
test_tracker_one_landmark_needs_heading ()
{
  const CirclePath path { 1.0, 0.5, 0.1 };
  PoseTracker tr;
  PoseTrackerOptions opt;
  int poses_on_one = 0, named = 0;
  for (int k = 0; k < 60; k++) {
    const Pose2 truth = path.at (k / 30.0);
    const bool all = k < 30;
    const TrackedFrame f = tr.step (kTrackerMap, tracker_seen (truth,
            all ? std::vector<int> { 0, 1, 2, 3 } : std::vector<int> { 0 },
            nullptr), k / 30.0, opt);
    if (all) {
      CHECK (f.ok && std::hypot (f.pose.pose.x - truth.x,
              f.pose.pose.y - truth.y) < 1e-6, "frame %d: four landmarks",
          k);
      continue;
    }
    poses_on_one += f.ok;
    named += f.res.match[0] == 0
        && f.res.matched_by[0] == MatchedBy::Colour
        && f.res.reasons[0].empty ();
    CHECK (f.ok || f.why == "too-few-landmarks", "frame %d: why %s", k,
        f.why.c_str ());
  }
  CHECK (poses_on_one == 0, "%d one-landmark poses without a measured "
      "heading", poses_on_one);
  CHECK (named == 30, "named by colour on %d of 30 frames", named);

  /* a pink detection 0.1 s after the last pose: the prior tells P1 from
   * P2; on a fresh tracker (no prior) it stays unmatched */
  PoseTracker t2;
  const Pose2 p0 { 0.2, 0.1, 0.3 };
  CHECK (t2.step (kTrackerMap, tracker_seen (p0, { 0, 1, 2 }, nullptr), 0,
          opt).ok, "three landmarks");
  const TrackedFrame pink = t2.step (kTrackerMap, tracker_seen (p0, { 4 },
          nullptr), 0.1, opt);
  CHECK (!pink.ok && pink.res.match[0] == 4
      && pink.res.matched_by[0] == MatchedBy::Prior,
      "pink after a pose: match %d by %s", pink.res.match[0],
      matched_by_name (pink.res.matched_by[0]));
  /* the robot has turned 0.6 rad since: the stale prior places pink off
   * both landmarks; unnamed, not rejected (no pose says it is wrong) */
  const TrackedFrame turned = t2.step (kTrackerMap, tracker_seen (Pose2 {
              p0.x, p0.y, p0.heading + 0.6 }, { 4 }, nullptr), 0.2, opt);
  CHECK (turned.res.match[0] < 0
      && turned.res.reasons[0] == "too-few-landmarks",
      "pink after a turn: match %d (%s)", turned.res.match[0],
      turned.res.reasons[0].c_str ());
  PoseTracker t3;
  const TrackedFrame alone = t3.step (kTrackerMap, tracker_seen (p0, { 4 },
          nullptr), 0, opt);
  CHECK (!alone.ok && alone.res.match[0] < 0
      && alone.res.reasons[0] == "ambiguous", "pink alone: match %d (%s)",
      alone.res.match[0], alone.res.reasons[0].c_str ());
  /* the prior expires: max-age after the last pose, pink is unnamed */
  const TrackedFrame stale = t2.step (kTrackerMap, tracker_seen (p0, { 4 },
          nullptr), 1.5, opt);
  CHECK (stale.res.match[0] < 0, "pink after the prior expired: %d",
      stale.res.match[0]);

  /* a known heading (a compass): the pose, exact on exact data */
  PoseTracker t4;
  opt.have_heading = true;
  opt.heading = p0.heading;
  opt.heading_sigma = 0.05;
  const TrackedFrame h = t4.step (kTrackerMap, tracker_seen (p0, { 0 },
          nullptr), 0, opt);
  CHECK (h.ok && h.pose.solver == "one"
      && std::hypot (h.pose.pose.x - p0.x, h.pose.pose.y - p0.y) < 1e-9,
      "known heading: ok %d", h.ok);
  const double rho = std::hypot (kTrackerMap[0].x - p0.x,
      kTrackerMap[0].y - p0.y);
  const double want = 0.01 * 0.01 + rho * rho * (0.005 * 0.005 + 0.05 * 0.05);
  CHECK (std::fabs (h.pose.cov[0] + h.pose.cov[4] - want) < 1e-9 * want
      + 1e-12, "known heading: position variance %g, want %g",
      h.pose.cov[0] + h.pose.cov[4], want);
}

/* filter=ekf, one landmark: the filter's prediction is the measured
 * heading. Over a fixed-seed Monte-Carlo (200 runs: four landmarks for
 * 1 s, then one for 2 s while the robot turns a radian), the stated
 * covariance holds the true error: the pose's normalised error squared
 * (3 dof) within chi^2 95 % (7.81) on >= 90 % of the runs at every frame
 * of the stretch. The heading's variance grows and is carried into the
 * position's: the bearing ties the slide round the landmark to the heading,
 * so the position's largest sigma is at least rho (sigma_h - sigma_b), and
 * it grows with the heading's. */
static void
test_tracker_ekf_one_landmark_covariance ()
{
  const CirclePath path { 1.0, 0.5, 0.1 };
  const int runs = 200, frames = 90, first = 30;
  std::vector<int> within (frames, 0);
  std::vector<double> var_h (frames, 0), var_pos (frames, 0);
  int reported = 0, carried = 0;
  std::mt19937 rng (29);
  PoseTrackerOptions opt;
  opt.ekf = true;
  for (int run = 0; run < runs; run++) {
    PoseTracker tr;
    for (int k = 0; k < frames; k++) {
      const Pose2 truth = path.at (k / 30.0);
      const TrackedFrame f = tr.step (kTrackerMap, tracker_seen (truth,
              k < first ? std::vector<int> { 0, 1, 2, 3 } :
              std::vector<int> { 0 }, &rng), k / 30.0, opt);
      if (k < first || !f.ok)
        continue;
      reported++;
      const cv::Matx33d C (f.pose.cov);
      const cv::Vec3d e (f.pose.pose.x - truth.x, f.pose.pose.y - truth.y,
          angdiff (f.pose.pose.heading, truth.heading));
      cv::Matx33d Ci;
      cv::invert (C, Ci, cv::DECOMP_SVD);
      within[k] += e.dot (Ci * e) <= 7.815;
      var_h[k] += C (2, 2) / runs;
      /* the position's largest variance */
      const double a = C (0, 0), b = C (0, 1), d = C (1, 1);
      const double big = (a + d) / 2 + std::sqrt ((a - d) * (a - d) / 4 +
          b * b);
      var_pos[k] += big / runs;
      /* the bearing ties the slide round the landmark to the heading
       * (to within one bearing sigma): sigma_pos >= rho (sigma_h -
       * sigma_b) */
      const double rho = std::hypot (kTrackerMap[0].x - truth.x,
          kTrackerMap[0].y - truth.y);
      const double tied = rho * std::max (0.0, std::sqrt (C (2, 2)) - 0.005);
      carried += big >= tied * tied;
    }
  }
  const int stretch = runs * (frames - first);
  CHECK (reported == stretch, "one-landmark poses %d of %d", reported,
      stretch);
  int worst = runs;
  for (int k = first; k < frames; k++)
    worst = std::min (worst, within[k]);
  CHECK (worst >= 0.9 * runs, "NEES within chi^2(3) 95 %% on %d of %d runs "
      "at the worst frame", worst, runs);
  CHECK (carried == stretch, "the heading's variance in the position's on "
      "%d of %d", carried, stretch);
  /* both grow over the stretch, the position's with the heading's */
  int together = 0;
  for (int k = first + 1; k < frames; k++)
    together += (var_pos[k] > var_pos[k - 1]) == (var_h[k] > var_h[k - 1]);
  CHECK (var_h[frames - 1] > 2 * var_h[first]
      && var_pos[frames - 1] > 4 * var_pos[first],
      "variances grow: heading %g -> %g rad^2, position %g -> %g m^2",
      var_h[first], var_h[frames - 1], var_pos[first], var_pos[frames - 1]);
  CHECK (together >= 0.9 * (frames - first - 1), "position and heading "
      "variances grow together on %d of %d frames", together,
      frames - first - 1);
  std::printf ("ekf one landmark: NEES within on >= %d/%d runs; sigma_h "
      "%.4f -> %.4f rad, position %.4f -> %.4f m\n", worst, runs,
      std::sqrt (var_h[first]), std::sqrt (var_h[frames - 1]),
      std::sqrt (var_pos[first]), std::sqrt (var_pos[frames - 1]));
}

int
main ()
{
  test_conventions ();
  test_one ();
  test_two_both_sides ();
  test_two_degenerate ();
  test_many_exact ();
  test_many_noise_and_covariance ();
  test_outlier_rejected ();
  test_collinear ();
  test_association ();
  test_consensus_budget ();
  test_ground_motion ();
  test_ekf_bridges_gap ();
  test_ekf_turn_on_one_landmark ();
  test_ekf_lost ();
  test_tracker_one_landmark_needs_heading ();
  test_tracker_ekf_one_landmark_covariance ();
  return corecheck_summary ();
}
