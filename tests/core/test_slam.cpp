/* Landmark SLAM (plugins/landmark/core/estimation/slam.h) against simulated truth
 * with fixed seeds: a robot drives loops through a field of landmarks with
 * repeated colours; observations are made here from docs/conventions.md
 * with known Gaussian noise. Checked: map and path error bounds, no merged
 * or duplicated landmark, bearings beyond +-90 degrees, consistency
 * (NEES), a partial map anchoring the frame, odometry, a stationary robot,
 * the confirmation rule, biased ranges, a spurious detection, sharp turns
 * with one or two landmarks in view, a new landmark waiting for the
 * heading, relocalisation among many landmarks of one colour and where
 * the map repeats, and the odometry's slip learnt. */
#include "slam.h"
#include "corecheck.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <vector>

using namespace landmark;

struct TruthLandmark {
  std::string cls;
  double x, y;
};

/* 13 landmarks, four classes, each colour repeated; two red discs only
 * 0.3 m apart. Centred on the robot's circle (0, 1.2). */
static std::vector<TruthLandmark>
field ()
{
  std::vector<TruthLandmark> f;
  const char *cls[] = { "red", "blue", "green" };
  for (int i = 0; i < 12; i++) {
    const double a = 2 * M_PI * i / 12, r = i % 2 ? 2.4 : 2.9;
    f.push_back ({ cls[i % 3], r * std::cos (a), 1.2 + r * std::sin (a) });
  }
  f.push_back ({ "red", f[0].x, f[0].y + 0.3 });
  return f;
}

struct SimOptions {
  double fov = 40 * M_PI / 180;   /* half field of view */
  double max_range = 3.5;
  double radius = 1.2;            /* of the robot's circle */
  double speed = 0.3;             /* m/s; 0: stationary */
  double spin = 0;                /* rad/s turning in place (speed 0) */
  int frames = 1260;              /* two loops at 30 fps */
  unsigned seed = 1;
  bool odometry = false;
  double odo_scale = 1.02, odo_drift = M_PI / 180;   /* rad per metre */
  Pose2 start;
  int blind_after = -1;           /* frames from which nothing is seen */
  int blind_until = 0;            /* frames before which nothing is seen */
  /* nothing seen either on the last blind_frames of every blind_period */
  int blind_period = 0, blind_frames = 0;
  /* the odometry's slip: this many times the filter's stated sigmas,
   * drawn as the filter models it (random walks over distance and turn) */
  double odo_slip = 0;
  /* or of its own (synth's model, python/gstlandmark/synth/odometry.py):
   * m per sqrt(m) along and across, rad per sqrt(m), rad per sqrt(rad) */
  double slip_trans = 0, slip_heading = 0, slip_turn = 0;
  /* the measurements' noise: this many times their stated sigmas */
  double meas_noise = 1;
  /* this share of their variance an error that changes slowly with the
   * viewpoint (a first-order Gauss-Markov process per landmark over the
   * distance driven, correlation length meas_corr_length metres), the
   * rest white: docs/ranging.md, item 7 */
  double meas_corr_share = 0, meas_corr_length = 0.3;
  /* their stated sigmas: range s0 + s1 r + s2 r^2, bearing b0 + b1 r */
  double range_sigma[3] = { 0.01, 0.01, 0 };
  double bearing_sigma[2] = { 0.01, 0 };
  /* the path frame by frame instead of the circle (from start) */
  const std::vector<Pose2> *path = nullptr;
  SlamOptions slam;
};

struct SimResult {
  /* per posed frame: position error, heading error (rad), heading sigma */
  std::vector<double> pose_err, head_err, head_sigma, nees;
  std::vector<Pose2> est, true_path;
  std::vector<int> seen;          /* per truth landmark: frames seen */
  std::vector<int> in_view;       /* per posed frame: observations */
  std::vector<int> in_view_classes;   /* and their distinct classes */
  /* observations at bearings beyond +-90 degrees after the first frame,
   * and how many of them were paired with a landmark */
  int behind = 0, behind_paired = 0;
  Slam slam;
};

static Pose2
truth_pose (const SimOptions & o, int k)
{
  const double t = k / 30.0;
  Pose2 p;
  if (o.path) {
    p = (*o.path)[std::min ((size_t) k, o.path->size () - 1)];
  } else if (o.speed > 0) {
    const double w = o.speed / o.radius, a = w * t;
    /* starts at the origin heading +x, turning left around (0, r) */
    p.x = o.radius * std::sin (a);
    p.y = o.radius * (1 - std::cos (a));
    p.heading = wrap_angle (a);
  } else {
    p.heading = wrap_angle (o.spin * t);
  }
  const double c = std::cos (o.start.heading), s = std::sin (o.start.heading);
  Pose2 q;
  q.x = o.start.x + c * p.x - s * p.y;
  q.y = o.start.y + s * p.x + c * p.y;
  q.heading = wrap_angle (o.start.heading + p.heading);
  return q;
}

static void
run (const SimOptions & o, const std::vector<TruthLandmark> & truth,
    SimResult * res, const std::vector<MapPoint> & map = {})
{
  std::mt19937 rng (o.seed);
  std::normal_distribution<double> g (0, 1);
  res->slam.opt = o.slam;
  res->slam.set_map (map);
  res->seen.assign (truth.size (), 0);
  Pose2 prev = truth_pose (o, 0);
  /* without a map the estimate is in the first pose's frame */
  const Pose2 origin = map.empty ()? prev : Pose2 ();
  /* the slow part of each landmark's range and bearing errors, in
   * sigmas, drawn from a generator of its own (the white draws as
   * without it) */
  std::mt19937 slow_rng (o.seed + 7919);
  std::vector<double> slow_r (truth.size ()), slow_b (truth.size ());
  for (size_t i = 0; o.meas_corr_share > 0 && i < truth.size (); i++) {
    slow_r[i] = g (slow_rng);
    slow_b[i] = g (slow_rng);
  }
  for (int k = 0; k < o.frames; k++) {
    const Pose2 p = truth_pose (o, k);
    if (o.meas_corr_share > 0) {
      const double rho = std::exp (-std::hypot (p.x - prev.x, p.y - prev.y)
          / o.meas_corr_length), w = std::sqrt (1 - rho * rho);
      for (size_t i = 0; i < truth.size (); i++) {
        slow_r[i] = rho * slow_r[i] + w * g (slow_rng);
        slow_b[i] = rho * slow_b[i] + w * g (slow_rng);
      }
    }
    if (k > 0) {
      if (o.odometry) {
        /* the true robot-frame increment, scaled and drifting */
        const double dxw = p.x - prev.x, dyw = p.y - prev.y;
        const double c = std::cos (prev.heading), s = std::sin (prev.heading);
        const double dx = c * dxw + s * dyw, dy = -s * dxw + c * dyw;
        const double d = std::hypot (dx, dy);
        const double dth = wrap_angle (p.heading - prev.heading);
        double sx = 0, sy = 0, sh = 0;
        if (o.odo_slip > 0 || o.slip_trans > 0 || o.slip_heading > 0
            || o.slip_turn > 0) {
          const SlamOptions & so = o.slam;
          const double trans = o.odo_slip * so.odo_trans_sigma + o.slip_trans,
              per_m = o.odo_slip * so.odo_rot_per_m + o.slip_heading,
              turn = o.odo_slip * so.odo_rot_sigma + o.slip_turn;
          const double st = trans * std::sqrt (d);
          sx = st * g (rng);
          sy = st * g (rng);
          sh = std::sqrt (per_m * per_m * d + turn * turn * std::fabs (dth))
              * g (rng);
        }
        res->slam.predict_odometry ((dx + sx) * o.odo_scale,
            (dy + sy) * o.odo_scale, dth + o.odo_drift * d + sh, 1 / 30.0);
      } else {
        res->slam.predict (1 / 30.0);
      }
    }
    prev = p;
    std::vector<SlamObservation> obs;
    for (size_t i = 0; i < truth.size (); i++) {
      const double dx = truth[i].x - p.x, dy = truth[i].y - p.y;
      const double r = std::hypot (dx, dy);
      const double b = wrap_angle (std::atan2 (dy, dx) - p.heading);
      if (r > o.max_range || r < 0.3 || std::fabs (b) > o.fov
          || (o.blind_after >= 0 && k >= o.blind_after)
          || k < o.blind_until
          || (o.blind_period > 0 && k % o.blind_period
              >= o.blind_period - o.blind_frames))
        continue;
      const double sr = o.range_sigma[0] + r * (o.range_sigma[1]
          + r * o.range_sigma[2]), sb = o.bearing_sigma[0]
          + r * o.bearing_sigma[1];
      const double white = std::sqrt (1 - o.meas_corr_share),
          slow = std::sqrt (o.meas_corr_share);
      const double rn = r + o.meas_noise * sr * (white * g (rng)
          + slow * slow_r[i]),
          bn = b + o.meas_noise * sb * (white * g (rng) + slow * slow_b[i]);
      SlamObservation ob;
      ob.class_name = truth[i].cls;
      ob.obs.gx = rn * std::cos (bn);
      ob.obs.gy = rn * std::sin (bn);
      ob.obs.range_sigma = sr;
      ob.obs.bearing_sigma = sb;
      obs.push_back (ob);
      res->seen[i]++;
    }
    const SlamFrame fr = res->slam.update (obs);
    for (size_t i = 0; k > 0 && i < obs.size (); i++) {
      if (std::fabs (obs[i].obs.bearing ()) > M_PI / 2) {
        res->behind++;
        res->behind_paired += fr.match[i] >= 0 && fr.reasons[i].empty ();
      }
    }
    if (!res->slam.has_pose ())
      continue;
    const Pose2 e = res->slam.pose ();
    Pose2 pt;
    world_to_robot (origin, p.x, p.y, &pt.x, &pt.y);
    pt.heading = wrap_angle (p.heading - origin.heading);
    res->est.push_back (e);
    res->true_path.push_back (pt);
    res->in_view.push_back ((int) obs.size ());
    std::vector<std::string> classes;
    for (const auto & ob : obs)
      if (std::find (classes.begin (), classes.end (), ob.class_name)
          == classes.end ())
        classes.push_back (ob.class_name);
    res->in_view_classes.push_back ((int) classes.size ());
    const double ex = e.x - pt.x, ey = e.y - pt.y,
        eh = wrap_angle (e.heading - pt.heading);
    res->pose_err.push_back (std::hypot (ex, ey));
    res->head_err.push_back (eh);
    double c[9];
    res->slam.pose_cov (c);
    res->head_sigma.push_back (std::sqrt (std::max (0.0, c[8])));
    /* NEES = e' C^-1 e over x, y, heading */
    const double a = c[0], b = c[1], cc = c[2], d = c[4], ee = c[5], f = c[8];
    const double det = a * (d * f - ee * ee) - b * (b * f - ee * cc)
        + cc * (b * ee - d * cc);
    if (det <= 0)
      continue;
    const double i00 = (d * f - ee * ee) / det, i01 = -(b * f - cc * ee) / det,
        i02 = (b * ee - cc * d) / det, i11 = (a * f - cc * cc) / det,
        i12 = -(a * ee - b * cc) / det, i22 = (a * d - b * b) / det;
    res->nees.push_back (ex * ex * i00 + ey * ey * i11 + eh * eh * i22
        + 2 * (ex * ey * i01 + ex * eh * i02 + ey * eh * i12));
  }
}

/* Best rigid alignment (2-D Procrustes, no scale) of a onto b. */
struct Rigid {
  double c = 1, s = 0, tx = 0, ty = 0;
  void apply (double x, double y, double *ox, double *oy) const {
    *ox = c * x - s * y + tx;
    *oy = s * x + c * y + ty;
  }
};

static Rigid
align (const std::vector<double> &ax, const std::vector<double> &ay,
    const std::vector<double> &bx, const std::vector<double> &by)
{
  const size_t n = ax.size ();
  double max = 0, may = 0, mbx = 0, mby = 0;
  for (size_t i = 0; i < n; i++) {
    max += ax[i] / n;
    may += ay[i] / n;
    mbx += bx[i] / n;
    mby += by[i] / n;
  }
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < n; i++) {
    const double px = ax[i] - max, py = ay[i] - may, qx = bx[i] - mbx,
        qy = by[i] - mby;
    sxx += px * qx + py * qy;
    sxy += px * qy - py * qx;
  }
  const double a = std::atan2 (sxy, sxx);
  Rigid r;
  r.c = std::cos (a);
  r.s = std::sin (a);
  r.tx = mbx - (r.c * max - r.s * may);
  r.ty = mby - (r.s * max + r.c * may);
  return r;
}

/* The best rigid alignment of the estimated path onto the true one. */
static Rigid
path_alignment (const SimResult & r)
{
  std::vector<double> ax, ay, bx, by;
  for (size_t k = 0; k < r.est.size (); k++) {
    ax.push_back (r.est[k].x);
    ay.push_back (r.est[k].y);
    bx.push_back (r.true_path[k].x);
    by.push_back (r.true_path[k].y);
  }
  return align (ax, ay, bx, by);
}

/* Absolute trajectory error after the best rigid alignment, per frame. */
static std::vector<double>
aligned_path_error (const SimResult & r)
{
  const Rigid t = path_alignment (r);
  std::vector<double> err;
  for (size_t k = 0; k < r.est.size (); k++) {
    double x, y;
    t.apply (r.est[k].x, r.est[k].y, &x, &y);
    err.push_back (std::hypot (x - r.true_path[k].x, y - r.true_path[k].y));
  }
  return err;
}

/* RMS landmark error after the best rigid alignment of the confirmed
 * landmarks onto their truth (matched by map_error's nearest rule). */
static double aligned_map_rms (const Slam & slam,
    const std::vector<TruthLandmark> & truth);

static double
percentile (std::vector<double> v, double q)
{
  if (v.empty ())
    return NAN;
  std::sort (v.begin (), v.end ());
  return v[std::min (v.size () - 1, (size_t) (q * v.size ()))];
}

/* For each truth landmark seen in 90 frames or more (three seconds, enough
 * to confirm): its one estimate (same class, within
 * `tol` once moved by `to`; its index in `match`, -1). Returns the RMS
 * error; counts missing and extra confirmed. */
static double
map_error (const Slam & slam, const std::vector<TruthLandmark> & truth,
    const std::vector<int> &seen, double tol, int *missing, int *extra,
    int *merged, const Rigid & to = Rigid (), std::vector<int> *match =
    nullptr)
{
  *missing = *extra = *merged = 0;
  double sum = 0;
  int n = 0;
  std::vector<int> owner (slam.landmarks ().size (), -1);
  if (match)
    match->assign (truth.size (), -1);
  for (size_t i = 0; i < truth.size (); i++) {
    int best = -1;
    double bd = tol;
    for (size_t k = 0; k < slam.landmarks ().size (); k++) {
      const auto & l = slam.landmarks ()[k];
      if (!l.confirmed || l.class_name != truth[i].cls)
        continue;
      double x, y;
      to.apply (l.x, l.y, &x, &y);
      const double d = std::hypot (x - truth[i].x, y - truth[i].y);
      if (d < bd) {
        bd = d;
        best = (int) k;
      }
    }
    if (best < 0) {
      if (seen[i] >= 90)
        (*missing)++;
      continue;
    }
    if (owner[best] >= 0)
      (*merged)++;
    owner[best] = (int) i;
    if (match)
      (*match)[i] = best;
    sum += bd * bd;
    n++;
  }
  for (size_t k = 0; k < owner.size (); k++)
    if (owner[k] < 0 && slam.landmarks ()[k].confirmed)
      (*extra)++;
  return n ? std::sqrt (sum / n) : NAN;
}

/* RMS distance of points a to points b after the rigid transform that
 * best maps a onto b; NAN below two pairs. */
static double
aligned_rms (const std::vector<double> & ax, const std::vector<double> & ay,
    const std::vector<double> & bx, const std::vector<double> & by)
{
  if (ax.size () < 2)
    return NAN;
  const Rigid r = align (ax, ay, bx, by);
  double sum = 0;
  for (size_t i = 0; i < ax.size (); i++) {
    double x, y;
    r.apply (ax[i], ay[i], &x, &y);
    sum += std::pow (x - bx[i], 2) + std::pow (y - by[i], 2);
  }
  return std::sqrt (sum / ax.size ());
}

static double
aligned_map_rms (const Slam & slam, const std::vector<TruthLandmark> & truth)
{
  std::vector<double> ax, ay, bx, by;
  for (const auto & t : truth) {
    int best = -1;
    double bd = 0.3;
    for (size_t k = 0; k < slam.landmarks ().size (); k++) {
      const auto & l = slam.landmarks ()[k];
      const double d = std::hypot (l.x - t.x, l.y - t.y);
      if (l.confirmed && l.class_name == t.cls && d < bd) {
        bd = d;
        best = (int) k;
      }
    }
    if (best < 0)
      continue;
    ax.push_back (slam.landmarks ()[best].x);
    ay.push_back (slam.landmarks ()[best].y);
    bx.push_back (t.x);
    by.push_back (t.y);
  }
  return aligned_rms (ax, ay, bx, by);
}

static void
test_chi2 ()
{
  CHECK (std::fabs (chi2_quantile (0.95, 2) - 5.991) < 1e-3, "%f",
      chi2_quantile (0.95, 2));
  CHECK (std::fabs (chi2_quantile (0.95, 3) - 7.815) < 1e-3, "%f",
      chi2_quantile (0.95, 3));
  CHECK (std::fabs (chi2_quantile (0.999, 10) - 29.588) < 1e-2, "%f",
      chi2_quantile (0.999, 10));
}

/* map_error within 0.15 m, with "every landmark found once, none extra or
 * merged" as a check; returns the RMS error. */
static double
check_map (const SimResult & r, const std::vector<TruthLandmark> & truth,
    const char *what)
{
  int missing, extra, merged;
  const double rms = map_error (r.slam, truth, r.seen, 0.15, &missing,
      &extra, &merged);
  CHECK (missing == 0 && extra == 0 && merged == 0, "%s: missing %d extra "
      "%d merged %d", what, missing, extra, merged);
  return rms;
}

/* no map, constant-velocity model: the first pose (truth's origin)
 * defines the frame, so truth and estimate compare directly */
static void
test_loops_no_map ()
{
  const auto truth = field ();
  for (unsigned seed = 1; seed <= 3; seed++) {
    SimOptions o;
    o.seed = seed;
    SimResult r;
    run (o, truth, &r);
    int missing, extra, merged;
    const double rms = map_error (r.slam, truth, r.seen, 0.15, &missing,
        &extra, &merged);
    /* the first-pose frame carries the first observations' errors:
     * compare after the best rigid alignment, as gst-landmark evaluate */
    const double arms = aligned_map_rms (r.slam, truth);
    const auto ate = aligned_path_error (r);
    const double med = percentile (ate, 0.5), p95 = percentile (ate, 0.95);
    const double chi95 = chi2_quantile (0.95, 3);
    const double inside = std::count_if (r.nees.begin (), r.nees.end (),
        [&](double v) { return v <= chi95; }) / (double) r.nees.size ();
    std::printf ("loops seed %u: map rms %.4f m (aligned %.4f), aligned path "
        "median %.4f p95 %.4f m,"
        " NEES<=%.2f on %.1f %% of frames, %zu landmarks, missing %d extra "
        "%d merged %d\n", seed, rms, arms, med, p95, chi95, 100 * inside,
        r.slam.landmarks ().size (), missing, extra, merged);
    CHECK (missing == 0 && extra == 0 && merged == 0, "seed %u: missing %d "
        "extra %d merged %d", seed, missing, extra, merged);
    CHECK (rms < 0.1, "seed %u: map rms %f", seed, rms);
    CHECK (arms < 0.03, "seed %u: aligned map rms %f", seed, arms);
    CHECK (med < 0.03 && p95 < 0.08, "seed %u: path %f %f", seed, med, p95);
    CHECK (inside >= 0.9, "seed %u: NEES inside on %f", seed, inside);
  }
}

/* 360 degree sensor turning in place: landmarks pass through +-180
 * degrees of bearing; a wrong wrap would gate them out and add copies */
static void
test_bearing_wrap ()
{
  const auto truth = field ();
  SimOptions o;
  o.speed = 0;
  o.spin = 0.8;
  o.fov = M_PI;
  o.max_range = 10;
  o.frames = 600;
  o.start.x = 0;
  o.start.y = 1.2;
  /* turning in place gives no baseline: count every view */
  o.slam.confirm_baseline = 0;
  SimResult r;
  /* no map: the frame is the first pose, here at (0, 1.2) heading 0 */
  run (o, truth, &r);
  std::vector<TruthLandmark> shifted = truth;
  for (auto & t : shifted)
    t.y -= 1.2;
  const double rms = check_map (r, shifted, "bearing wrap");
  std::printf ("bearing wrap: %zu landmarks (truth %zu), rms %.4f m\n",
      r.slam.landmarks ().size (), truth.size (), rms);
  /* and they are used, not gated out */
  std::printf ("bearing wrap: %d of %d observations behind paired\n",
      r.behind_paired, r.behind);
  CHECK (r.behind > 1000 && r.behind_paired >= 0.99 * r.behind, "%d of %d",
      r.behind_paired, r.behind);
  CHECK (r.slam.landmarks ().size () == truth.size (), "%zu landmarks",
      r.slam.landmarks ().size ());
  CHECK (percentile (r.pose_err, 1.0) < 0.05, "pose error %f",
      percentile (r.pose_err, 1.0));
}

/* every step-th truth landmark as a map point, id L and its index */
static std::vector<MapPoint>
truth_map (const std::vector<TruthLandmark> & truth, size_t step)
{
  std::vector<MapPoint> map;
  for (size_t i = 0; i < truth.size (); i += step) {
    MapPoint m;
    m.id = "L" + std::to_string (i);
    m.class_name = truth[i].cls;
    m.x = truth[i].x;
    m.y = truth[i].y;
    map.push_back (m);
  }
  return map;
}

/* half the field as a map, the robot starting elsewhere: the anchors give
 * the frame, the others are added with new ids */
static void
test_partial_map ()
{
  const auto truth = field ();
  const std::vector<MapPoint> map = truth_map (truth, 2);
  SimOptions o;
  o.start.x = 0.2;
  o.start.y = -0.1;
  o.start.heading = 0.0;
  o.frames = 1260;
  std::vector<TruthLandmark> moved = truth;
  SimResult r;
  run (o, moved, &r, map);
  int anchors = 0, added = 0;
  for (const auto & l : r.slam.landmarks ()) {
    if (l.anchor) {
      anchors++;
      CHECK (l.id[0] == 'L', "anchor id %s", l.id.c_str ());
    } else {
      added++;
      CHECK (l.id[0] == 'S', "added id %s", l.id.c_str ());
    }
  }
  const double rms = check_map (r, truth, "partial map");
  std::printf ("partial map: %d anchors, %d added, rms %.4f m, path median "
      "%.4f m\n", anchors, added, rms, percentile (r.pose_err, 0.5));
  CHECK (anchors == (int) map.size (), "%d anchors", anchors);
  CHECK (percentile (r.pose_err, 0.5) < 0.03, "path median %f",
      percentile (r.pose_err, 0.5));
}

/* odometry with 2 % scale error and 1 degree per metre heading drift, no
 * slip: the filter learns both, and its pose covariance covers the error
 * (NEES inside the one-sided 95 % bound on 90 % of the frames or more) */
static void
test_odometry ()
{
  const auto truth = field ();
  SimOptions o;
  o.odometry = true;
  SimResult r;
  run (o, truth, &r);
  const double rms = check_map (r, truth, "odometry");
  const double med = percentile (r.pose_err, 0.5);
  const double inside = std::count_if (r.nees.begin (), r.nees.end (),
      [](double v) { return v <= chi2_quantile (0.95, 3); })
      / (double) r.nees.size ();
  std::printf ("odometry: map rms %.4f m, path median %.4f m, NEES inside "
      "%.1f %%\n", rms, med, 100 * inside);
  CHECK (rms < 0.05 && med < 0.015, "rms %f median %f", rms, med);
  CHECK (inside >= 0.9, "NEES inside on %f", inside);
}

/* The same odometry, the landmarks seen on the first loop only: the second
 * loop (7.5 m) is bridged on the odometry alone. Its scale error and drift
 * learnt on the first loop, the path holds and the covariance covers it;
 * the same errors taken as random walks of their size (the control) are
 * not learnt: the path ends more than 5 times as far off. */
static void
test_odometry_bridged ()
{
  const auto truth = field ();
  double end_with_states = 0;
  for (bool control : { false, true }) {
    SimOptions o;
    o.odometry = true;
    o.blind_after = 630;
    if (control) {
      /* the drift (1 degree per metre) and the scale error (2 %) taken
       * as random walks of that size over a metre instead of states */
      o.slam.odo_scale_sigma = o.slam.odo_drift_sigma = 1e-9;
      o.slam.odo_trans_sigma = 0.02;
      o.slam.odo_rot_per_m = 0.0175;
      o.slam.odo_rot_sigma = 0;
    }
    SimResult r;
    run (o, truth, &r);
    std::vector<double> nees (r.nees.begin () + 630, r.nees.end ());
    const double inside = std::count_if (nees.begin (), nees.end (),
        [](double v) { return v <= chi2_quantile (0.95, 3); })
        / (double) nees.size ();
    const double end = r.pose_err.back ();
    std::printf ("odometry bridging a loop%s: NEES inside %.1f %% of its "
        "frames, error at the end %.3f m\n", control ? " (drift as a "
        "random walk)" : "", 100 * inside, end);
    if (control) {
      CHECK (end > 5 * end_with_states, "control: end error %f against %f "
          "with the drift states", end, end_with_states);
    } else {
      CHECK (inside >= 0.9 && end < 0.05, "NEES inside on %f, end error %f",
          inside, end);
      end_with_states = end;
    }
  }
}

/* Odometry's white noise is a random walk over the distance driven and
 * the angle turned: a straight drive of 5 m and a turn in place of one
 * revolution on odometry alone, the increments drawn with a known slip
 * (variance sigma^2 per metre along, across and in heading; per radian
 * turned), at 30 and at 100 increments a second. The stated sigmas (x, y
 * and heading; heading of the turn) match their spread over 400 runs
 * within 15 % and their closed form within 7 % (3 % for the turn) at both
 * rates (a per-step sigma proportional to the step's
 * length would state sqrt(100 / 30) times less at the faster rate). */
static void
test_odometry_noise_over_distance ()
{
  const double trans = 0.004, rot = 0.003;      /* per sqrt(m) */
  const double turn = 0.005;                    /* rad per sqrt(rad) */
  const int runs = 400;
  for (bool spin : { false, true }) {
    /* 5 m at 0.5 m/s, or 2 pi rad at 0.5 rad/s */
    const double total = spin ? 2 * M_PI : 5;
    for (double rate : { 30.0, 100.0 }) {
      const int steps = (int) std::lround (total / 0.5 * rate);
      const double d = total / steps, sd = std::sqrt (d);
      std::mt19937 rng (11);
      std::normal_distribution<double> g (0, 1);
      double sq[3] = { 0 }, cov[9] = { 0 };
      for (int run = 0; run < runs; run++) {
        Slam slam;
        slam.opt.odo_scale_sigma = slam.opt.odo_drift_sigma = 1e-9;
        slam.opt.odo_trans_sigma = trans;
        slam.opt.odo_rot_per_m = rot;
        slam.opt.odo_rot_sigma = turn;
        slam.update ({});         /* the first pose: the origin */
        for (int k = 0; k < steps; k++) {
          if (spin)
            slam.predict_odometry (0, 0, d + turn * sd * g (rng), 1 / rate);
          else
            slam.predict_odometry (d + trans * sd * g (rng),
                trans * sd * g (rng), rot * sd * g (rng), 1 / rate);
        }
        const Pose2 p = slam.pose ();
        const double err[3] = { p.x - (spin ? 0 : total), p.y,
          wrap_angle (p.heading - (spin ? total : 0))
        };
        for (int i = 0; i < 3; i++)
          sq[i] += err[i] * err[i] / runs;
        slam.pose_cov (cov);
      }
      /* the closed form: along the drive trans sqrt(L); across it the
       * slip and the heading's random walk integrated, trans^2 L +
       * rot^2 L^3 / 3; heading rot sqrt(L); a turn turn sqrt(2 pi). On
       * the drive the filter also charges the turning term on the
       * measured |dth|, which is the heading noise itself: 2 to 5 % more,
       * growing with the rate (docs/landmarkslam.md, "Odometry
       * noise") */
      const double exact[3] = { trans * std::sqrt (total),
        std::sqrt (trans * trans * total + rot * rot * std::pow (total, 3) / 3),
        spin ? turn * std::sqrt (total) : rot * std::sqrt (total)
      };
      const char *name[3] = { "x", "y", "heading" };
      for (int i = spin ? 2 : 0; i < 3; i++) {
        const double ratio = std::sqrt (cov[i * 4] / sq[i]);
        const double to_exact = std::sqrt (cov[i * 4]) / exact[i];
        std::printf ("odometry noise, %s at %.0f Hz: %s sigma stated %.5f, "
            "closed form %.5f, spread %.5f over %d runs (ratio %.2f)\n",
            spin ? "turn" : "drive", rate, name[i], std::sqrt (cov[i * 4]),
            exact[i], std::sqrt (sq[i]), runs, ratio);
        CHECK (ratio > 1 / 1.15 && ratio < 1.15, "%s %.0f Hz %s: stated / "
            "spread %.3f", spin ? "turn" : "drive", rate, name[i], ratio);
        CHECK (std::fabs (to_exact - 1) < (spin ? 0.03 : 0.07),
            "%s %.0f Hz %s: stated / closed form %.3f", spin ? "turn" :
            "drive", rate, name[i], to_exact);
      }
    }
  }
}

/* Wheel odometry of the turning centre, the camera a = 0.1 m ahead of it
 * (odo_camera_forward). A quarter turn in place, in 10 increments: the
 * camera swings on its circle to (-a, a), a chord of a sqrt(2) = 14 cm,
 * heading pi / 2; with a = 0 it would stay put. Then the stated covariance
 * against a Monte-Carlo of the same base increments, drawn with the filter's
 * own noise model (scale error and drift from their priors, slip as a
 * random walk) and pushed through the exact rigid motion of the camera:
 * the turn in place (all of the camera's position spread is the heading's
 * slip swinging it) and a curved drive of 0.6 m. Sigmas within 5 % and
 * correlations within 0.05 of the 20000 runs' (the stated covariance
 * without the swing would give the turn in place no position spread). */
static void
odometry_base_cov (double a, const double step[3], int steps, double out[9])
{
  Slam slam;
  slam.opt.odo_camera_forward = a;
  slam.opt.odo_trans_sigma = 0.003;
  slam.opt.odo_rot_sigma = 0.05;
  slam.opt.odo_rot_per_m = 0.03;
  slam.update ({});
  for (int i = 0; i < steps; i++)
    slam.predict_odometry (step[0], step[1], step[2], 0.1);
  slam.pose_cov (out);
}

static void
odometry_base_monte_carlo (double a, const double step[3], int steps,
    double out[9])
{
  const SlamOptions o;
  const int runs = 20000;
  std::mt19937 rng (5);
  std::normal_distribution<double> g (0, 1);
  double sum[3] = { 0 }, sq[9] = { 0 };
  for (int r = 0; r < runs; r++) {
    const double k = o.odo_scale_sigma * g (rng),
        drift = o.odo_drift_sigma * g (rng);
    double bx = -a, by = 0, bh = 0;     /* the turning centre */
    for (int i = 0; i < steps; i++) {
      const double d = std::hypot (step[0], step[1]) / (1 + k);
      const double st = 0.003 * std::sqrt (d);
      const double sr = std::sqrt (0.03 * 0.03 * d + 0.05 * 0.05 *
          std::fabs (step[2] - drift * d));
      const double dx = step[0] / (1 + k) + st * g (rng),
          dy = step[1] / (1 + k) + st * g (rng);
      const double dh = step[2] - drift * d + sr * g (rng);
      bx += std::cos (bh) * dx - std::sin (bh) * dy;
      by += std::sin (bh) * dx + std::cos (bh) * dy;
      bh += dh;
    }
    const double cam[3] = { bx + a * std::cos (bh), by + a * std::sin (bh),
      bh };
    for (int i = 0; i < 3; i++) {
      sum[i] += cam[i];
      for (int j = 0; j < 3; j++)
        sq[i * 3 + j] += cam[i] * cam[j];
    }
  }
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      out[i * 3 + j] = sq[i * 3 + j] / runs - sum[i] * sum[j] / runs / runs;
}

static void
test_odometry_turning_centre ()
{
  const double a = 0.1;
  Slam slam;
  slam.opt.odo_camera_forward = a;
  slam.update ({});
  for (int i = 0; i < 10; i++)
    slam.predict_odometry (0, 0, M_PI / 20, 0.1);
  const Pose2 p = slam.pose ();
  std::printf ("odometry of the turning centre, a quarter turn in place, "
      "camera %.2f m ahead: camera at (%.4f, %.4f), moved %.4f m, heading "
      "%.2f deg\n", a, p.x, p.y, std::hypot (p.x, p.y),
      p.heading * 180 / M_PI);
  CHECK (std::fabs (p.x + a) < 1e-9 && std::fabs (p.y - a) < 1e-9
      && std::fabs (p.heading - M_PI / 2) < 1e-9, "camera at %f %f %f, "
      "expected %f %f %f", p.x, p.y, p.heading, -a, a, M_PI / 2);

  const double turn[3] = { 0, 0, M_PI / 20 }, drive[3] = { 0.06, 0.004, 0.1 };
  for (const double *step : { turn, drive }) {
    const char *name = step == turn ? "turn in place" : "curved drive";
    double stated[9], mc[9];
    odometry_base_cov (a, step, 10, stated);
    odometry_base_monte_carlo (a, step, 10, mc);
    const char *axis[3] = { "x", "y", "heading" };
    /* a turn in place moves the camera along its circle's tangent only:
     * the radial spread, second order (a sigma^2), is left out */
    const double tiny = 0.1 * std::sqrt (std::max (mc[0], mc[4]));
    bool left_out[3] = { false, false, false };
    for (int i = 0; i < 3; i++) {
      /* a variance of 0 may come out as -1e-20 */
      const double sigma = std::sqrt (std::max (0.0, stated[i * 4]));
      const double ratio = sigma / std::sqrt (mc[i * 4]);
      std::printf ("odometry of the turning centre, %s: %s sigma stated "
          "%.5f, Monte-Carlo %.5f (ratio %.3f)\n", name, axis[i], sigma,
          std::sqrt (mc[i * 4]), ratio);
      if (i < 2 && std::sqrt (mc[i * 4]) < tiny) {
        left_out[i] = true;
        CHECK (sigma < tiny, "%s %s: stated sigma %f, Monte-Carlo %f",
            name, axis[i], sigma, std::sqrt (mc[i * 4]));
        continue;
      }
      CHECK (std::fabs (ratio - 1) < 0.05, "%s %s: stated / Monte-Carlo "
          "sigma %.3f", name, axis[i], ratio);
    }
    for (int i = 0; i < 3; i++) {
      for (int j = i + 1; j < 3; j++) {
        if (left_out[i] || left_out[j])
          continue;
        const double rs = stated[i * 3 + j] / std::sqrt (stated[i * 4] *
            stated[j * 4]), rm = mc[i * 3 + j] / std::sqrt (mc[i * 4] *
            mc[j * 4]);
        CHECK (std::fabs (rs - rm) < 0.05, "%s %s-%s: correlation stated "
            "%.3f, Monte-Carlo %.3f", name, axis[i], axis[j], rs, rm);
      }
    }
  }
}

/* a stationary robot: the pose stays at the origin and no copies appear.
 * Range and bearing fix a landmark from one pose, so those seen in three
 * frames and known to confirm_sigma are confirmed; asking for a baseline
 * keeps them all tentative */
static void
test_stationary ()
{
  const auto truth = field ();
  for (double baseline : { 0.0, 0.25 }) {
    SimResult r;
    SimOptions o;
    o.speed = 0;
    o.frames = 300;
    o.slam.confirm_baseline = baseline;
    run (o, truth, &r);
    size_t visible = 0, confirmed = 0;
    for (int s : r.seen)
      visible += s > 0;
    for (const auto & l : r.slam.landmarks ())
      confirmed += l.confirmed;
    CHECK (r.slam.landmarks ().size () == visible, "%zu landmarks, %zu seen",
        r.slam.landmarks ().size (), visible);
    CHECK (confirmed == (baseline > 0 ? 0 : visible), "baseline %.2f: %zu "
        "confirmed of %zu", baseline, confirmed, visible);
    /* the pose wanders with its covariance (three landmarks in view) */
    CHECK (percentile (r.pose_err, 1.0) < 0.15, "pose drift %f",
        percentile (r.pose_err, 1.0));
    const double inside = std::count_if (r.nees.begin (), r.nees.end (),
        [](double v) { return v <= chi2_quantile (0.95, 3); })
        / (double) r.nees.size ();
    CHECK (inside >= 0.9, "NEES inside on %f", inside);
  }
}

/* One landmark seen from a fixed, exactly known pose (no prediction):
 * its covariance is the measurement's over n, so with a range sigma s it
 * is confirmed at the first frame where s / sqrt(n) <= confirm_sigma (the
 * bearing's share, 0.001 rad at 1 m, is far smaller). */
static void
test_confirm_on_knowledge ()
{
  const double s = 0.2;
  const int expect = (int) std::ceil (std::pow (s / 0.03, 2));   /* 45 */
  /* white errors, stated so: from one viewpoint a slow error would never
   * average out */
  SlamOptions white;
  white.meas_slow_share = 0;
  Slam slam (white);
  int first = -1;
  for (int k = 1; k <= 80 && first < 0; k++) {
    SlamObservation a;
    a.class_name = "red";
    a.obs.gx = 1.0;
    a.obs.range_sigma = s;
    a.obs.bearing_sigma = 0.001;
    slam.update ({ a });
    CHECK (slam.landmarks ().size () == 1, "%zu landmarks",
        slam.landmarks ().size ());
    if (slam.landmarks ()[0].confirmed)
      first = k;
  }
  std::printf ("confirm on knowledge: confirmed at frame %d (sigma %.2f m "
      "over sqrt(n) <= 0.03 m at %d)\n", first, s, expect);
  CHECK (first >= expect - 1 && first <= expect + 1, "confirmed at %d, "
      "expected %d", first, expect);
}

/* A red detection at range r, bearing b with those sigmas. */
static SlamObservation
red_obs (double r, double b, double sr, double sb)
{
  SlamObservation a;
  a.class_name = "red";
  a.obs.gx = r * std::cos (b);
  a.obs.gy = r * std::sin (b);
  a.obs.range_sigma = sr;
  a.obs.bearing_sigma = sb;
  return a;
}

/* A robot driving straight at 0.9 m/s past a landmark that is in view for
 * 15 frames (0.45 m of travel), then out of view: confirmed while in view,
 * kept. A rule of three views 0.25 m apart never confirms it (the rendered
 * default field has eight such landmarks). */
static void
test_confirm_short_pass ()
{
  for (double baseline : { 0.0, 0.25 }) {
    Slam slam;
    slam.opt.confirm_baseline = baseline;
    std::mt19937 rng (7);
    std::normal_distribution<double> g (0, 1);
    const double v = 0.9, lx = 1.5, ly = 0.4;
    for (int k = 0; k < 60; k++) {
      if (k > 0)
        slam.predict_odometry (v / 30, 0, 0, 1 / 30.0);
      const double x = v * k / 30;
      std::vector<SlamObservation> obs;
      if (k < 15) {
        const double r = std::hypot (lx - x, ly), b = std::atan2 (ly, lx - x);
        const double sr = 0.005 + 0.005 * r, sb = 0.001;
        obs.push_back (red_obs (r + sr * g (rng), b + sb * g (rng), sr, sb));
      }
      slam.update (obs);
    }
    /* three views 0.25 m apart need 0.5 m: it never exists, and is
     * dropped once out of view */
    if (baseline > 0) {
      CHECK (slam.landmarks ().empty (), "baseline %.2f: %zu landmarks",
          baseline, slam.landmarks ().size ());
      continue;
    }
    CHECK (slam.landmarks ().size () == 1, "%zu landmarks",
        slam.landmarks ().size ());
    if (slam.landmarks ().empty ())
      continue;
    const auto & l = slam.landmarks ()[0];
    std::printf ("short pass: %s, %d views, error %.4f m\n",
        l.confirmed ? "confirmed" : "tentative", l.views,
        std::hypot (l.x - lx, l.y - ly));
    CHECK (l.confirmed, "not confirmed");
    CHECK (std::hypot (l.x - lx, l.y - ly) < 0.03, "error %f",
        std::hypot (l.x - lx, l.y - ly));
  }
}

/* Ranges biased by a blob's missing part: the same error in every frame.
 * Told nothing, the filter averages the bias as if it were noise and its
 * landmark NEES is far outside the chi-square bounds; given the floor and
 * size ranges' disagreement (here the bias itself, as measured), widened
 * the more the more views repeat it, its stated covariance covers the
 * error. */
static void
test_biased_ranges_widened ()
{
  const double bias = 0.10, lx = 2.0, ly = 0.3;
  for (bool told : { false, true }) {
    Slam slam;
    std::mt19937 rng (11);
    std::normal_distribution<double> g (0, 1);
    for (int k = 0; k < 100; k++) {
      const double r = std::hypot (lx, ly), b = std::atan2 (ly, lx);
      const double sr = 0.005, sb = 0.001;
      SlamObservation a = red_obs (r + bias + sr * g (rng), b + sb * g (rng),
          sr, sb);
      a.range_disagreement = told ? -bias : 0;
      slam.update ({ a });
    }
    const auto & l = slam.landmarks ()[0];
    const double ex = l.x - lx, ey = l.y - ly;
    const double det = l.cov[0] * l.cov[3] - l.cov[1] * l.cov[2];
    const double nees = (ex * ex * l.cov[3] - 2 * ex * ey * l.cov[1]
        + ey * ey * l.cov[0]) / det;
    std::printf ("biased ranges, disagreement %s: error %.3f m, NEES %.1f\n",
        told ? "given" : "not given", std::hypot (ex, ey), nees);
    /* the bias counted once per view 1/k: NEES = b^2 sum 1/(k b^2) over
     * the views, the harmonic number H_100 = 5.19, inside the 95 % bound */
    double h = 0;
    for (int k = 1; k <= 100; k++)
      h += 1.0 / k;
    if (told)
      CHECK (nees <= chi2_quantile (0.95, 2) && std::fabs (nees - h) < 0.3 * h,
          "NEES %f, H_100 %f", nees, h);
    else
      CHECK (nees > 1000, "NEES %f", nees);
  }
}

/* a detection seen once is dropped after tentative_frames */
static void
test_spurious_dropped ()
{
  Slam slam;
  SlamObservation a;
  a.class_name = "red";
  a.obs.gx = 1.0;
  a.obs.gy = 0.2;
  slam.update ({ a });
  CHECK (slam.landmarks ().size () == 1, "%zu", slam.landmarks ().size ());
  for (int k = 0; k <= slam.opt.tentative_frames; k++) {
    slam.predict (1 / 30.0);
    slam.update ({});
  }
  CHECK (slam.landmarks ().empty (), "%zu", slam.landmarks ().size ());
}


/* A rounded square driven at constant speed: straights, then quarter
 * turns whose turn rate ramps up at `alpha` to `wmax` and down again (a
 * ground robot's bounded angular acceleration). Starts at the origin
 * heading +x, turning left. */
static std::vector<Pose2>
square_path (double straight_s, double v, double alpha, double wmax,
    int frames)
{
  const double ramp = wmax / alpha;
  const double hold = (M_PI / 2 - wmax * ramp) / wmax;
  const double side = straight_s + 2 * ramp + hold;
  std::vector<Pose2> path;
  Pose2 p;
  const int sub = 20;
  const double dt = 1 / 30.0 / sub;
  double t = 0;
  for (int k = 0; k < frames; k++) {
    path.push_back (p);
    for (int i = 0; i < sub; i++, t += dt) {
      const double u = std::fmod (t, side) - straight_s;
      double w = 0;
      if (u > 0 && u < ramp)
        w = alpha * u;
      else if (u >= ramp && u < ramp + hold)
        w = wmax;
      else if (u >= ramp + hold && u < 2 * ramp + hold)
        w = alpha * (2 * ramp + hold - u);
      /* midpoint heading */
      const double h = p.heading + 0.5 * w * dt;
      p.x += v * dt * std::cos (h);
      p.y += v * dt * std::sin (h);
      p.heading = wrap_angle (p.heading + w * dt);
    }
  }
  return path;
}

static void
test_sharp_turns ()
{
  const auto path = square_path (2.5, 0.4, 4.0, 2.0, 908);
  std::vector<TruthLandmark> truth;
  const char *cls[] = { "red", "blue", "green", "yellow" };
  /* five along each wall of a square around the path, four colours:
   * one to four in view, none in some turns */
  const double lo = -0.7, hi = 2.0;
  for (int i = 0; i < 20; i++) {
    const int side = i / 5;
    const double a = lo + (hi - lo) * (i % 5 + 0.5) / 5;
    double x = 0, y = 0;
    switch (side) {
      case 0: x = a; y = lo; break;
      case 1: x = hi; y = a; break;
      case 2: x = lo + hi - a; y = hi; break;
      default: x = lo; y = lo + hi - a; break;
    }
    truth.push_back ({ cls[i % 4], x, y });
  }
  SimOptions o;
  o.path = &path;
  o.frames = (int) path.size ();
  o.fov = 27 * M_PI / 180;        /* the seed's 54 degree camera */
  o.max_range = 2.0;
  SimResult r;
  run (o, truth, &r);
  int few = 0;
  for (int v : r.in_view)
    few += v < 3;
  /* the pose once three or more are in view again after a stretch of
   * fewer: recovered */
  double worst_back = 0;
  for (size_t k = 1; k + 5 < r.in_view.size (); k++)
    if (r.in_view[k - 1] < 3 && r.in_view[k] >= 3)
      worst_back = std::max (worst_back, r.pose_err[k + 5]);
  const double rms = check_map (r, truth, "sharp turns");
  const double med = percentile (r.pose_err, 0.5);
  std::printf ("sharp turns: %d of %zu frames with fewer than 3 landmarks in "
      "view, %zu landmarks (truth %zu), map rms %.4f m, path median %.4f "
      "p95 %.4f m, worst 5 frames after 3 are back %.4f m\n", few,
      r.in_view.size (), r.slam.landmarks ().size (), truth.size (), rms,
      med, percentile (r.pose_err, 0.95), worst_back);
  CHECK (r.slam.landmarks ().size () == truth.size (), "%zu landmarks",
      r.slam.landmarks ().size ());
  CHECK (rms < 0.06, "map rms %f", rms);
  CHECK (med < 0.05, "path median %f", med);
  CHECK (worst_back < 0.3, "after the turns %f", worst_back);
}

/* after a second without landmarks the heading's sigma is about a
 * radian: a new detection waits (its position would be off by the
 * heading's curvature, beyond its covariance); seen again once two known
 * landmarks have relocalised the pose (one alone, with the heading lost,
 * is not paired), it starts */
static void
test_new_waits_for_heading ()
{
  Slam slam;
  SlamObservation a, b, g;
  a.class_name = "red";
  a.obs.gx = 1.0;
  a.obs.gy = 0.0;
  b.class_name = "blue";
  b.obs.gx = 1.5;
  b.obs.gy = 0.5;
  g.class_name = "green";
  g.obs.gx = 1.5;
  g.obs.gy = -1.0;
  for (int k = 0; k < 5; k++) {
    slam.predict (1 / 30.0);
    slam.update ({ a, g });
  }
  for (int k = 0; k < 30; k++) {
    slam.predict (1 / 30.0);
    slam.update ({});
  }
  double c[9];
  slam.pose_cov (c);
  slam.predict (1 / 30.0);
  SlamFrame f = slam.update ({ b });
  std::printf ("heading sigma %.3f rad after a blind second: %s\n",
      std::sqrt (c[8]), f.reasons[0].c_str ());
  CHECK (f.reasons[0] == "uncertain-heading" && slam.landmarks ().size () == 2,
      "%s, %zu landmarks", f.reasons[0].c_str (), slam.landmarks ().size ());
  slam.predict (1 / 30.0);
  f = slam.update ({ a });
  CHECK (f.match[0] < 0, "one landmark paired with the heading lost");
  for (int k = 0; k < 10; k++) {
    slam.predict (1 / 30.0);
    f = slam.update ({ a, g });
  }
  CHECK (f.n_matched == 2, "%d paired", f.n_matched);
  slam.predict (1 / 30.0);
  f = slam.update ({ a, g, b });
  CHECK (f.reasons[2] == "new-landmark" && slam.landmarks ().size () == 3,
      "%s, %zu landmarks", f.reasons[2].c_str (), slam.landmarks ().size ());
}

/* A yellow disc never seen before, after a blind stretch: the robot drives
 * straight at 0.3 m/s past a yellow landmark A (mapped, then out of view)
 * with a red one R in view, then sees nothing for a second while it stops;
 * the constant-velocity estimate drives on 0.3 m and its heading sigma
 * grows to tens of degrees. A new yellow disc B, 1 m from A, comes into
 * view: within a gate that wide it would pair with A (and drag the pose
 * and A to B); it is more likely a landmark not yet mapped, so it is not
 * paired, and A stays where it was. Two mapped landmarks seen together
 * then relocalise the lost pose. */
static void
test_blind_stretch_new_landmark ()
{
  Slam slam;
  std::mt19937 rng (5);
  std::normal_distribution<double> g (0, 1);
  const double ax = 1.2, ay = 0.8, rx = 2.0, ry = -0.3, bx = 1.6, by = -0.1;
  auto see = [&](double x, double px, double py, const char *cls) {
    const double r = std::hypot (px - x, py), b = std::atan2 (py, px - x);
    const double sr = 0.005 + 0.01 * r, sb = 0.01;
    SlamObservation o = red_obs (r + sr * g (rng), b + sb * g (rng), sr, sb);
    o.class_name = cls;
    return o;
  };
  double x = 0;
  for (int k = 0; k < 90; k++) {
    if (k > 0)
      slam.predict (1 / 30.0);
    x = 0.3 * k / 30;
    std::vector<SlamObservation> obs { see (x, rx, ry, "red") };
    if (std::atan2 (ay, ax - x) < 0.7)
      obs.push_back (see (x, ax, ay, "yellow"));
    slam.update (obs);
  }
  CHECK (slam.landmarks ().size () == 2, "%zu landmarks",
      slam.landmarks ().size ());
  const SlamLandmark a = slam.landmarks ()[1];
  for (int k = 0; k < 30; k++) {
    slam.predict (1 / 30.0);
    slam.update ({});
  }
  double cov[9];
  slam.pose_cov (cov);
  const double drift = slam.pose ().x - x;
  slam.predict (1 / 30.0);
  const SlamFrame f = slam.update ({ see (x, bx, by, "yellow") });
  const SlamLandmark & a2 = slam.landmarks ()[1];
  std::printf ("blind stretch: pose %.2f m ahead, heading sigma %.0f deg; "
      "a new yellow 1 m from the mapped one: %s, the mapped one moved "
      "%.3f m\n", drift, std::sqrt (cov[8]) * 180 / M_PI,
      f.match[0] == 1 ? "paired with it" : f.reasons[0].c_str (),
      std::hypot (a2.x - a.x, a2.y - a.y));
  CHECK (drift > 0.25, "drift %f", drift);
  CHECK (f.match[0] != 1, "paired with the mapped yellow landmark");
  CHECK (std::hypot (a2.x - a.x, a2.y - a.y) < 0.01, "A moved %f",
      std::hypot (a2.x - a.x, a2.y - a.y));
  /* the red and the first yellow seen together: relocalised */
  slam.predict (1 / 30.0);
  const SlamFrame f2 = slam.update ({ see (x, rx, ry, "red"),
        see (x, ax, ay, "yellow") });
  const Pose2 p = slam.pose ();
  std::printf ("blind stretch: two mapped landmarks: %d paired, pose "
      "error %.3f m, %.2f deg\n", f2.n_matched, std::hypot (p.x - x, p.y),
      p.heading * 180 / M_PI);
  CHECK (f2.n_matched == 2, "%d paired", f2.n_matched);
  CHECK (std::hypot (p.x - x, p.y) < 0.05 && std::fabs (p.heading) < 0.05,
      "pose %f %f %f, truth %f 0 0", p.x, p.y, p.heading, x);
}

/* A robot that drives 7 m before it sees anything (no map, odometry whose
 * scale error and heading drift are drawn from the filter's priors, 5 %
 * and 0.05 rad/m, with the slip it states): the heading's sigma relative
 * to the start is past 15 degrees when the first landmarks come into view
 * (two loops of the core field placed at the end of the straight). They
 * are mapped, not refused as uncertain-heading: without a map the frame
 * is free and a heading error shared by the pose and the map is a turn of
 * it. Checked over fixed seeds, in the frame that puts the final
 * estimated pose on the true one: every landmark seen often mapped once
 * (none missing, extra or merged within 0.15 m); the map after the best
 * rigid alignment within 3 cm RMS; and the landmarks' positions relative
 * to the robot (free of the frame) not over-confident: their NEES (2 dof,
 * the joint covariance of the pose and the landmark) averaged over the
 * seeds and landmarks below the one-sided 99 % bound of such a mean, and
 * inside chi-square's 95 % on 90 % of them or more. */
static void
test_blind_start ()
{
  const double straight = 7.0, v = 0.3;
  const int blind = (int) std::lround (straight / v * 30);
  auto truth = field ();
  for (auto & t : truth)
    t.x += straight;
  std::vector<Pose2> path;
  for (int k = 0; k < blind; k++) {
    Pose2 p;
    p.x = v * k / 30.0;
    path.push_back (p);
  }
  SimOptions loop;
  for (int k = 0; k < loop.frames; k++) {
    Pose2 p = truth_pose (loop, k);
    p.x += straight;
    path.push_back (p);
  }
  const int seeds = 8;
  double nees_sum = 0;
  int nees_n = 0, nees_inside = 0;
  double worst_rms = 0, min_sigma = 1e9;
  int worst_missing = 0, worst_extra = 0, worst_merged = 0;
  std::mt19937 draw (34);
  std::normal_distribution<double> g (0, 1);
  for (int seed = 1; seed <= seeds; seed++) {
    SimOptions o;
    o.path = &path;
    o.frames = (int) path.size ();
    o.seed = seed;
    o.odometry = true;
    o.blind_until = blind;
    o.odo_slip = 1;
    o.odo_scale = 1 + o.slam.odo_scale_sigma * g (draw);
    o.odo_drift = o.slam.odo_drift_sigma * g (draw);
    /* the heading's sigma when the landmarks come into view */
    SimOptions before = o;
    before.frames = blind;
    SimResult b;
    run (before, truth, &b);
    double c[9];
    b.slam.pose_cov (c);
    const double sigma = std::sqrt (c[8]) * 180 / M_PI;
    min_sigma = std::min (min_sigma, sigma);
    SimResult r;
    run (o, truth, &r);
    /* the estimate in the truth's frame through the final pose */
    const Pose2 pe = r.est.back (), pt = r.true_path.back ();
    Rigid to;
    const double a = wrap_angle (pt.heading - pe.heading);
    to.c = std::cos (a);
    to.s = std::sin (a);
    to.tx = pt.x - (to.c * pe.x - to.s * pe.y);
    to.ty = pt.y - (to.s * pe.x + to.c * pe.y);
    const auto & lms = r.slam.landmarks ();
    std::vector<int> owner (lms.size (), -1);
    std::vector<double> ax, ay, bx, by;
    int missing = 0, extra = 0, merged = 0;
    for (size_t i = 0; i < truth.size (); i++) {
      int best = -1;
      double bd = 0.15;
      for (size_t k = 0; k < lms.size (); k++) {
        double x, y;
        to.apply (lms[k].x, lms[k].y, &x, &y);
        const double d = std::hypot (x - truth[i].x, y - truth[i].y);
        if (lms[k].confirmed && lms[k].class_name == truth[i].cls && d < bd) {
          bd = d;
          best = (int) k;
        }
      }
      if (best < 0) {
        missing += r.seen[i] >= 90;
        continue;
      }
      merged += owner[best] >= 0;
      owner[best] = (int) i;
      ax.push_back (lms[best].x);
      ay.push_back (lms[best].y);
      bx.push_back (truth[i].x);
      by.push_back (truth[i].y);
      /* relative to the robot: q = R(th)' (l - p), its covariance
       * J C J' with J = [-R', (q_y, -q_x), R'] over (x, y, th, lx, ly) */
      const double ch = std::cos (pe.heading), sh = std::sin (pe.heading);
      const double qx = ch * (lms[best].x - pe.x) + sh * (lms[best].y - pe.y),
          qy = -sh * (lms[best].x - pe.x) + ch * (lms[best].y - pe.y);
      const double ct = std::cos (pt.heading), st = std::sin (pt.heading);
      const double tx = ct * (truth[i].x - pt.x) + st * (truth[i].y - pt.y),
          ty = -st * (truth[i].x - pt.x) + ct * (truth[i].y - pt.y);
      double C[25];
      r.slam.joint_cov ((size_t) best, C);
      const double J[2][5] = { { -ch, -sh, qy, ch, sh },
        { sh, -ch, -qx, -sh, ch } };
      double Q[2][2] = { { 0, 0 }, { 0, 0 } };
      for (int u = 0; u < 2; u++)
        for (int w = 0; w < 2; w++)
          for (int m = 0; m < 5; m++)
            for (int n = 0; n < 5; n++)
              Q[u][w] += J[u][m] * C[m * 5 + n] * J[w][n];
      const double det = Q[0][0] * Q[1][1] - Q[0][1] * Q[1][0];
      const double ex = qx - tx, ey = qy - ty;
      const double nees = (Q[1][1] * ex * ex - 2 * Q[0][1] * ex * ey
          + Q[0][0] * ey * ey) / det;
      nees_sum += nees;
      nees_n++;
      nees_inside += nees <= chi2_quantile (0.95, 2);
    }
    for (size_t k = 0; k < owner.size (); k++)
      extra += owner[k] < 0 && lms[k].confirmed;
    const double rms = aligned_rms (ax, ay, bx, by);
    std::printf ("blind start seed %d: odometry scale %+.3f, drift %+.2f "
        "deg/m, heading sigma %.1f deg after %.0f m; %zu landmarks, %zu "
        "matched (truth %zu), missing %d extra %d merged %d, aligned map "
        "rms %.4f m\n", seed, o.odo_scale - 1, o.odo_drift * 180 / M_PI,
        sigma, straight, lms.size (), ax.size (), truth.size (), missing,
        extra, merged, rms);
    worst_rms = std::isnan (rms) ? INFINITY : std::max (worst_rms, rms);
    worst_missing = std::max (worst_missing, missing);
    worst_extra = std::max (worst_extra, extra);
    worst_merged = std::max (worst_merged, merged);
  }
  /* the mean of n chi-square(2) values: chi-square(2 n) / n */
  const double mean = nees_n ? nees_sum / nees_n : INFINITY;
  const double bound = nees_n ? chi2_quantile (0.99, 2 * nees_n) / nees_n : 0;
  const double inside = nees_n ? nees_inside / (double) nees_n : 0;
  std::printf ("blind start: heading sigma at the first landmark >= %.1f "
      "deg; landmarks relative to the robot: NEES mean %.2f over %d (bound "
      "%.2f), inside 95 %% on %.1f %%\n", min_sigma, mean, nees_n, bound,
      100 * inside);
  CHECK (min_sigma > 15, "heading sigma %f deg", min_sigma);
  CHECK (worst_missing == 0 && worst_extra == 0 && worst_merged == 0,
      "missing %d extra %d merged %d", worst_missing, worst_extra,
      worst_merged);
  CHECK (worst_rms < 0.03, "aligned map rms %f", worst_rms);
  CHECK (nees_n >= seeds * (int) truth.size () / 2 && mean < bound,
      "NEES mean %f over %d, bound %f", mean, nees_n, bound);
  CHECK (inside >= 0.9, "NEES inside on %f", inside);
}

/* Relocalisation among many landmarks of one colour: 250 red discs mapped
 * over a 16 m x 16 m field (0.3 m apart or more) and a blue, a green and a
 * yellow one that place the first pose; the robot stands at the centre
 * and sees nothing for two seconds (the heading lost). Then, from that
 * state, 30 red detections of no mapped landmark (clutter in the view,
 * 0.5 to 3.5 m, 54 degrees): relocalising them would put the robot where
 * some of them fall near mapped discs by chance, so they are not paired;
 * or the mapped red discs in the view, seen: relocalised on them. The
 * worst frame's CPU time is printed (not asserted). */
static void
test_relocalise_among_many ()
{
  /* CPU time of the process (one thread here), ms */
  auto cpu_ms = [] { return std::clock () * 1e3 / CLOCKS_PER_SEC; };
  std::mt19937 rng (26);
  std::uniform_real_distribution<double> u (0, 16);
  std::normal_distribution<double> g (0, 1);
  std::vector<MapPoint> map;
  auto add = [&](const char *cls, double x, double y) {
    MapPoint m;
    m.id = "L" + std::to_string (map.size ());
    m.class_name = cls;
    m.x = x;
    m.y = y;
    map.push_back (m);
  };
  const Pose2 robot { 8.0, 8.0, 0.3 };
  const double c = std::cos (robot.heading), s = std::sin (robot.heading);
  auto world = [&](double r, double b, double *x, double *y) {
    *x = robot.x + r * (c * std::cos (b) - s * std::sin (b));
    *y = robot.y + r * (s * std::cos (b) + c * std::sin (b));
  };
  const char *unique[3] = { "blue", "green", "yellow" };
  const double ur[3] = { 1.2, 1.8, 1.5 }, ub[3] = { -0.3, 0.1, 0.35 };
  for (int k = 0; k < 3; k++) {
    double x, y;
    world (ur[k], ub[k], &x, &y);
    add (unique[k], x, y);
  }
  while (map.size () < 253) {
    const double x = u (rng), y = u (rng);
    bool free = true;
    for (const auto & m : map)
      free &= std::hypot (m.x - x, m.y - y) >= 0.3;
    if (free)
      add ("red", x, y);
  }
  auto see = [&](double wx, double wy, const std::string & cls) {
    const double dx = wx - robot.x, dy = wy - robot.y;
    const double r = std::hypot (dx, dy),
        b = std::atan2 (-s * dx + c * dy, c * dx + s * dy);
    const double sr = 0.005 + 0.01 * r, sb = 0.01;
    SlamObservation o = red_obs (r + sr * g (rng), b + sb * g (rng), sr, sb);
    o.class_name = cls;
    return o;
  };
  Slam slam;
  slam.set_map (map);
  std::vector<SlamObservation> first;
  for (int k = 0; k < 3; k++)
    first.push_back (see (map[k].x, map[k].y, unique[k]));
  CHECK (slam.update (first).ok, "the first pose not placed");
  for (int k = 0; k < 30; k++) {
    slam.predict (1 / 30.0);
    slam.update ({});
  }
  double cov[9];
  slam.pose_cov (cov);
  CHECK (std::sqrt (cov[8]) * std::sqrt (slam.opt.gate_chi2) > M_PI,
      "heading sigma %f rad: not lost", std::sqrt (cov[8]));
  slam.predict (1 / 30.0);

  /* clutter: no detection within 0.3 m of a mapped red disc */
  std::uniform_real_distribution<double> ur_ (0.5, 4.0), ub_ (-1.05, 1.05);
  /* ten frames of clutter from that state */
  int clutter_paired = 0, clutter_relocalised = 0;
  double ms_clutter = 0;
  for (int trial = 0; trial < 10; trial++) {
    std::vector<SlamObservation> clutter;
    while (clutter.size () < 30) {
      double x, y;
      world (ur_ (rng), ub_ (rng), &x, &y);
      bool free = true;
      for (const auto & m : map)
        free &= std::hypot (m.x - x, m.y - y) >= 0.3;
      if (free)
        clutter.push_back (see (x, y, "red"));
    }
    Slam a = slam;
    const double t0 = cpu_ms ();
    const SlamFrame fa = a.update (clutter);
    ms_clutter = std::max (ms_clutter, cpu_ms () - t0);
    clutter_paired += fa.n_matched;
    clutter_relocalised += fa.n_matched > 0;
  }
  /* the mapped red discs in the view */
  std::vector<SlamObservation> seen;
  for (const auto & m : map) {
    const double dx = m.x - robot.x, dy = m.y - robot.y;
    const double b = std::atan2 (-s * dx + c * dy, c * dx + s * dy);
    if (m.class_name == "red" && std::hypot (dx, dy) <= 4.0
        && std::hypot (dx, dy) >= 0.5 && std::fabs (b) <= 1.05)
      seen.push_back (see (m.x, m.y, "red"));
  }
  Slam b = slam;
  const double t0 = cpu_ms ();
  const SlamFrame fb = b.update (seen);
  const double ms_seen = cpu_ms () - t0;
  const Pose2 p = b.pose ();
  const double pos_err = std::hypot (p.x - robot.x, p.y - robot.y),
      head_err = std::fabs (p.heading - robot.heading);
  std::printf ("relocalise among 250 red discs (heading sigma %.0f deg, "
      "position sigma %.2f m): 30 clutter detections, ten frames: %d "
      "relocalised, %d pairings (worst %.2f ms); "
      "%zu mapped discs in view: %d paired, pose error %.3f m, %.2f deg "
      "(%.2f ms)\n", std::sqrt (cov[8]) * 180 / M_PI,
      std::sqrt (std::max (cov[0], cov[4])), clutter_relocalised,
      clutter_paired, ms_clutter,
      seen.size (), fb.n_matched, pos_err, head_err * 180 / M_PI, ms_seen);
  CHECK (clutter_relocalised == 0, "clutter relocalised %d times, %d "
      "pairings", clutter_relocalised, clutter_paired);
  CHECK (fb.n_matched >= (int) seen.size () - 2, "%d of %zu paired",
      fb.n_matched, seen.size ());
  CHECK (pos_err < 0.015 && head_err < 0.01, "pose %f %f %f, truth %f %f %f",
      p.x, p.y, p.heading, robot.x, robot.y, robot.heading);
}

/* A lost pose on a given map whose colours repeat (two red discs, two
 * blue, a green): placed on three, then five seconds blind without
 * odometry (the predicted position's sigma several metres, beyond the
 * detections' separation). A red and a blue detection whose distance
 * only one pair of the map has relocalise it once seen in three
 * consecutive frames (not after two), at the truth. */
static void
test_lost_relocalised_on_two ()
{
  const std::vector<TruthLandmark> marks { { "red", 2.0, 0.3 },
    { "blue", 1.6, -0.5 }, { "red", -1.0, 2.5 }, { "blue", -2.0, -2.0 },
    { "green", 3.0, 3.0 } };
  const std::vector<MapPoint> map = truth_map (marks, 1);
  Pose2 robot;
  robot.x = 0.2;
  robot.y = 0.1;
  robot.heading = 0.1;
  auto see = [&](int k) {
    double gx, gy;
    world_to_robot (robot, marks[k].x, marks[k].y, &gx, &gy);
    SlamObservation o = red_obs (std::hypot (gx, gy), std::atan2 (gy, gx),
        0.005, 0.001);
    o.class_name = marks[k].cls;
    return o;
  };
  auto lost_filter = [&](Slam * slam) {
    slam->set_map (map);
    slam->update ({ see (0), see (1), see (4) });
    for (int k = 0; k < 150; k++) {
      slam->predict (1 / 30.0);
      slam->update ({});
    }
    double c[9];
    slam->pose_cov (c);
    return std::sqrt (c[0] + c[4]);
  };
  Slam slam;
  const double sigma = lost_filter (&slam);
  int found_at = -1;
  for (int k = 1; k <= 5 && found_at < 0; k++) {
    slam.predict (1 / 30.0);
    if (slam.update ({ see (0), see (1) }).n_matched == 2)
      found_at = k;
  }
  const Pose2 p = slam.pose ();
  std::printf ("lost on a map of repeated colours (position sigma %.1f m): "
      "a red and a blue relocalise it at frame %d, %.4f m and %.2f deg "
      "off\n", sigma, found_at, std::hypot (p.x - robot.x, p.y - robot.y),
      (p.heading - robot.heading) * 180 / M_PI);
  CHECK (sigma > 2, "position sigma %f", sigma);
  CHECK (found_at == 3, "relocalised at frame %d", found_at);
  CHECK (std::hypot (p.x - robot.x, p.y - robot.y) < 0.01
      && std::fabs (p.heading - robot.heading) < 0.005, "pose %f %f %f",
      p.x, p.y, p.heading);
}

/* A lost pose where the map repeats: four red discs in view and a copy of
 * their pattern turned about the robot, so that two poses (the true one,
 * turned 2.2 rad while blind, and the predicted heading) each explain all
 * four. Whether the search runs to the end or its work bound cuts it
 * short, the copy must not win: the frame is refused, or relocalised on
 * the truth. Without the copy the same detections relocalise it. */
static void
test_relocalise_repeated_pattern ()
{
  std::mt19937 rng (27);
  std::normal_distribution<double> g (0, 1);
  const Pose2 first { 8.0, 8.0, 0.3 }, truth { 8.0, 8.0, 0.3 + 2.2 };
  auto world = [](const Pose2 & p, double r, double b, double *x,
      double *y) {
    *x = p.x + r * std::cos (p.heading + b);
    *y = p.y + r * std::sin (p.heading + b);
  };
  const int np = 7;
  const char *pc[np] = { "red", "red", "red", "orange", "orange", "purple",
    "cyan" };
  const double pr[np] = { 1.1, 1.6, 2.3, 1.9, 2.8, 1.4, 2.6 },
      pb[np] = { -0.4, 0.05, -0.15, 0.42, 0.3, 0.3, -0.38 };
  const char *unique[3] = { "blue", "green", "yellow" };
  const double ur[3] = { 1.2, 1.8, 1.5 }, ub[3] = { -0.3, 0.1, 0.35 };
  auto build = [&](bool copy) {
    std::vector<MapPoint> map;
    auto add = [&](const char *cls, const Pose2 & p, double r, double b) {
      MapPoint m;
      m.id = "L" + std::to_string (map.size ());
      m.class_name = cls;
      world (p, r, b, &m.x, &m.y);
      map.push_back (m);
    };
    for (int k = 0; k < 3; k++)
      add (unique[k], first, ur[k], ub[k]);
    for (int k = 0; k < np; k++) {
      add (pc[k], truth, pr[k], pb[k]);
      /* the pattern as seen from the predicted heading */
      if (copy)
        add (pc[k], first, pr[k], pb[k]);
    }
    return map;
  };
  auto obs_of = [&](const char *cls, double r, double b) {
    const double sr = 0.005 + 0.01 * r, sb = 0.01;
    SlamObservation o = red_obs (r + sr * g (rng), b + sb * g (rng), sr, sb);
    o.class_name = cls;
    return o;
  };
  for (bool copy : { true, false }) {
    for (long budget : { 60L, 120L, 250L, 500L, 1000L, 40000L }) {
      Slam slam;
      slam.opt.reloc_max_comparisons = budget;
      slam.set_map (build (copy));
      std::vector<SlamObservation> o;
      for (int k = 0; k < 3; k++)
        o.push_back (obs_of (unique[k], ur[k], ub[k]));
      CHECK (slam.update (o).ok, "the first pose not placed");
      for (int k = 0; k < 30; k++) {
        slam.predict (1 / 30.0);
        slam.update ({});
      }
      slam.predict (1 / 30.0);
      o.clear ();
      for (int k = 0; k < np; k++)
        o.push_back (obs_of (pc[k], pr[k], pb[k]));
      const SlamFrame f = slam.update (o);
      const Pose2 p = slam.pose ();
      const bool at_truth = std::hypot (p.x - truth.x, p.y - truth.y) < 0.03
          && std::fabs (wrap_angle (p.heading - truth.heading)) < 0.02;
      if (copy)
        CHECK (f.n_matched == 0 || at_truth, "budget %ld: relocalised on "
            "the copy, pose %f %f %f", budget, p.x, p.y, p.heading);
      else
        CHECK (f.n_matched == np && at_truth, "no copy, budget %ld: %d paired, "
            "pose %f %f %f", budget, f.n_matched, p.x, p.y, p.heading);
    }
  }
}

/* The odometry's slip learnt (SlamOptions::odo_slip_adapt): five loops
 * of the circle, seeing nothing on the last 2 s of every 3 s (bridges of
 * 0.6 m), the filter stating a slip of 2 cm per sqrt(m) and 0.02 rad per
 * sqrt(m) and per sqrt(rad) (a poor floor) while the odometry slips 0.5
 * and 2 times that (scale error and drift as usual), 8 runs each.
 * Learnt: the slip scale at the end within 25 % of the truth on the
 * median run and within a factor 1.6 on every run; the bridged frames'
 * median pose NEES within a factor 1.6 of chi-square's (3 dof, 2.37),
 * which as stated it is not (2x: over-confident, 0.5x: too cautious).
 * Measurements noisier than stated (1.5 times, the slip as stated) are
 * not taken for slip: the scale stays within 25 % of 1 (median run).
 * Measured: medians 0.573 (0.370..0.662), 1.839 (1.645..2.060) and 1.004
 * (0.793..1.458); NEES medians 1.74 and 3.17 learnt, 1.04 and 8.04 as
 * stated. */
static void
test_odometry_slip_learnt ()
{
  const auto truth = field ();
  const double chi2_median = chi2_quantile (0.5, 3);
  struct Case {
    double slip, meas;
  } cases[] = { { 0.5, 1 }, { 2, 1 }, { 1, 1.5 } };
  for (const Case & c : cases) {
    const int runs = 8;
    std::vector<double> scales, meas_scales, nees_median (2);
    for (int adapt = 1; adapt >= 0; adapt--) {
      std::vector<double> bridged;
      for (int run_no = 0; run_no < runs; run_no++) {
        SimOptions o;
        o.odometry = true;
        o.frames = 3150;
        o.seed = 100 + run_no;
        o.blind_period = 90;
        o.blind_frames = 60;
        o.slam.odo_trans_sigma = o.slam.odo_rot_per_m =
            o.slam.odo_rot_sigma = 0.02;
        o.slam.odo_slip_adapt = adapt;
        /* the measurements' errors are white here: stated so (their
         * scale is what is estimated beside the slip's) */
        o.slam.meas_slow_share = 0;
        o.slam.odo_slip_scale_min = 0.25;
        o.odo_slip = c.slip;
        o.meas_noise = c.meas;
        SimResult r;
        run (o, truth, &r);
        for (size_t k = 0; k < r.nees.size (); k++)
          if (k % 90 >= 30)
            bridged.push_back (r.nees[k]);
        if (adapt) {
          scales.push_back (r.slam.odometry_slip_scale ());
          meas_scales.push_back (r.slam.measurement_scale ());
          /* what was learnt is forgotten on request (stated values
           * changed): as stated until odometry brings evidence again */
          r.slam.restart_slip_learning ();
          CHECK (r.slam.odometry_slip_scale () == 1.0, "scale %f after "
              "the restart", r.slam.odometry_slip_scale ());
        }
      }
      nees_median[adapt] = percentile (bridged, 0.5);
    }
    const double median = percentile (scales, 0.5);
    const double lo = *std::min_element (scales.begin (), scales.end ()),
        hi = *std::max_element (scales.begin (), scales.end ());
    std::printf ("slip learnt, truth %.2f x, measurements %.1f x: scale "
        "median %.3f (%.3f..%.3f) over %d runs, measurements' %.2f; bridged "
        "frames' median pose NEES %.2f learnt, %.2f as stated (chi-square "
        "%.2f)\n", c.slip, c.meas, median, lo, hi, runs,
        percentile (meas_scales, 0.5), nees_median[1], nees_median[0],
        chi2_median);
    CHECK (std::fabs (median / c.slip - 1) < 0.25, "truth %.2f: median "
        "scale %.3f", c.slip, median);
    CHECK (lo > c.slip / 1.6 && hi < c.slip * 1.6, "truth %.2f: scales "
        "%.3f..%.3f", c.slip, lo, hi);
    /* the measurements' own scale, told apart from the slip's */
    const double meas = percentile (meas_scales, 0.5);
    CHECK (std::fabs (meas / c.meas - 1) < 0.25, "measurements %.2f x: "
        "their scale %.3f", c.meas, meas);
    auto consistent = [&](double m) {
      return m > chi2_median / 1.6 && m < chi2_median * 1.6;
    };
    CHECK (consistent (nees_median[1]), "truth %.2f: NEES median %.2f",
        c.slip, nees_median[1]);
    if (c.slip != 1)
      CHECK (!consistent (nees_median[0]), "truth %.2f: as stated, NEES "
          "median %.2f", c.slip, nees_median[0]);
  }
  /* the default scale floor, 1: a slip smaller than stated is not
   * learnt (as stated, cautious), a larger one is */
  for (double slip : { 0.5, 2.0 }) {
    SimOptions o;
    o.odometry = true;
    o.frames = 3150;
    o.seed = 100;
    o.slam.odo_trans_sigma = o.slam.odo_rot_per_m =
        o.slam.odo_rot_sigma = 0.02;
    o.slam.meas_slow_share = 0;
    o.odo_slip = slip;
    SimResult r;
    run (o, truth, &r);
    const double scale = r.slam.odometry_slip_scale ();
    std::printf ("slip learnt with the default floor, truth %.2f x: scale "
        "%.3f\n", slip, scale);
    CHECK (slip < 1 ? scale == 1.0 : std::fabs (scale / slip - 1) < 0.25,
        "truth %.2f, default floor: scale %.3f", slip, scale);
  }
}


/* Sparse fields (issue 34): 10 landmarks of four colours drawn over a
 * 6 m x 6 m field (0.5 m apart, 0.4 m or more off the path), the robot on
 * two loops of a 4 m rounded square (corners of 0.6 m) at 0.4 m/s, 30 fps,
 * seeing +-27 degrees (the seed robot's 54-degree camera) from 0.3 to
 * 2.5 m: about one landmark in view. Sigmas of the order ipmrange states
 * for 10 cm discs from a camera 0.2 m high (docs/ranging.md,
 * "Uncertainty"): range 2 mm + 4 mm r^2, bearing 0.2 mrad + 0.2 mrad r,
 * half their variance an error that changes only slowly with the
 * viewpoint (over 0.3 m driven), as ipmrange's bearings do (its item 7;
 * white errors at these sigmas map a tenth as far off as the rendered
 * sparse fields of issue 34 did).
 * Odometry as synth draws it by default (python/gstlandmark/synth/
 * odometry.py): 2 % long, 1 degree per metre of drift, slip 1.1 mm per
 * sqrt(m), 1.1 mrad per sqrt(m), 1.8 mrad per sqrt(rad); the filter
 * states its defaults. */
static std::vector<Pose2>
sparse_path (double v)
{
  const double half = 2.0, rc = 0.6, straight = 2 * (half - rc);
  const double side = straight + 0.5 * M_PI * rc, loop = 4 * side;
  std::vector<Pose2> path;
  for (int k = 0; v * k / 30.0 <= 2 * loop; k++) {
    const double s = std::fmod (v * k / 30.0, loop);
    const int q = (int) (s / side);
    const double u = s - q * side;
    /* side q in the frame of the first (along +x at y = -half) */
    double x, y, h;
    if (u < straight) {
      x = -half + rc + u;
      y = -half;
      h = 0;
    } else {
      const double a = (u - straight) / rc;
      x = half - rc + rc * std::sin (a);
      y = -half + rc - rc * std::cos (a);
      h = a;
    }
    const double t = q * M_PI / 2, c = std::cos (t), sn = std::sin (t);
    /* the start at the origin, heading +x: the map frame is the truth's */
    Pose2 p;
    p.x = c * x - sn * y + half - rc;
    p.y = sn * x + c * y + half;
    p.heading = wrap_angle (h + t);
    path.push_back (p);
  }
  return path;
}

static std::vector<TruthLandmark>
sparse_field (unsigned seed, const std::vector<Pose2> & path)
{
  std::mt19937 rng (seed);
  /* the field centred on the square's centre, (1.4, 2) */
  std::uniform_real_distribution<double> ux (-1.6, 4.4), uy (-1, 5);
  const char *cls[] = { "red", "blue", "green", "yellow" };
  std::vector<TruthLandmark> f;
  while (f.size () < 10) {
    const TruthLandmark t { cls[rng () % 4], ux (rng), uy (rng) };
    bool ok = true;
    for (const auto & o : f)
      ok &= std::hypot (o.x - t.x, o.y - t.y) >= 0.5;
    for (size_t k = 0; k < path.size (); k += 5)
      ok &= std::hypot (path[k].x - t.x, path[k].y - t.y) >= 0.4;
    if (ok)
      f.push_back (t);
  }
  return f;
}

static SimOptions
sparse_options (unsigned seed, bool odometry,
    const std::vector<Pose2> & path)
{
  SimOptions o;
  o.path = &path;
  o.frames = (int) path.size ();
  o.seed = seed;
  o.fov = 27 * M_PI / 180;
  o.max_range = 2.5;
  o.range_sigma[0] = 0.002;
  o.range_sigma[1] = 0;
  o.range_sigma[2] = 0.004;
  o.bearing_sigma[0] = 0.0002;
  o.bearing_sigma[1] = 0.0002;
  o.odometry = odometry;
  o.odo_scale = 1.02;
  o.odo_drift = M_PI / 180;
  o.slip_trans = o.slip_heading = 0.0011;
  o.slip_turn = 0.0018;
  /* half the measurements' variance slow, over 0.3 m */
  o.meas_corr_share = 0.5;
  o.meas_corr_length = 0.3;
  return o;
}

struct SparseFigures {
  int landmarks = 0, missing = 0, extra = 0, merged = 0;
  double map_rms = NAN, path_median = NAN;
  /* pose NEES: inside chi-square's two-sided 95 % band (3 dof, as
   * gst-landmark evaluate), above it, its mean */
  double nees_inside = 0, nees_above = 0, nees_mean = 0;
  double in_view = 0;   /* mean detections per frame */
  /* the pose off (10 cm or 5 degrees from the truth) on this share of the
   * frames; of its stretches off, those in which two landmarks of two
   * colours came into view for 0.1 s (events), those back within 2 s of
   * it, and the longest wait; and those in which only two of one colour
   * were ever in view, or for less */
  double off = 0;
  int events = 0, recovered = 0, one_colour = 0;
  double worst_wait = 0;  /* s; infinite: never back */
  /* frames placed wrongly with confidence: 0.3 m off while the stated
   * heading sigma is under 5 degrees (a wrong relocalisation) */
  int confident_wrong = 0;
};

static SparseFigures
sparse_figures (const SimResult & r, const std::vector<TruthLandmark> & truth)
{
  SparseFigures f;
  const Rigid to = path_alignment (r);
  std::vector<int> match;
  map_error (r.slam, truth, r.seen, 0.15, &f.missing, &f.extra, &f.merged,
      to, &match);
  std::vector<double> ax, ay, bx, by;
  for (size_t i = 0; i < truth.size (); i++)
    if (match[i] >= 0) {
      ax.push_back (r.slam.landmarks ()[match[i]].x);
      ay.push_back (r.slam.landmarks ()[match[i]].y);
      bx.push_back (truth[i].x);
      by.push_back (truth[i].y);
    }
  f.landmarks = (int) ax.size ();
  f.map_rms = aligned_rms (ax, ay, bx, by);
  f.path_median = percentile (aligned_path_error (r), 0.5);
  const double lo = chi2_quantile (0.025, 3), hi = chi2_quantile (0.975, 3);
  for (double v : r.nees) {
    f.nees_inside += v >= lo && v <= hi;
    f.nees_above += v > hi;
    f.nees_mean += v;
  }
  if (!r.nees.empty ()) {
    f.nees_inside /= r.nees.size ();
    f.nees_above /= r.nees.size ();
    f.nees_mean /= r.nees.size ();
  }
  for (int n : r.in_view)
    f.in_view += n;
  f.in_view /= std::max<size_t> (r.in_view.size (), 1);
  const size_t n = r.pose_err.size ();
  auto good = [&](size_t k) {
    return r.pose_err[k] < 0.1 && std::fabs (r.head_err[k]) < 5 * M_PI / 180;
  };
  /* two colours in view from frame k for a tenth of a second (3 frames) */
  auto pair_held = [&](size_t k) {
    for (size_t j = k; j < k + 3; j++)
      if (j >= n || r.in_view_classes[j] < 2)
        return false;
    return true;
  };
  for (size_t k = 0; k < n; k++)
    f.confident_wrong += r.pose_err[k] > 0.3
        && r.head_sigma[k] < 5 * M_PI / 180;
  for (size_t k = 0; k < n;) {
    if (good (k)) {
      k++;
      continue;
    }
    size_t end = k, two = n;
    bool pair = false;
    for (; end < n && !good (end); end++) {
      if (two == n && pair_held (end))
        two = end;
      pair |= r.in_view[end] >= 2;
    }
    /* the frame found again may be the pair's first */
    if (two == n && end < n && pair_held (end))
      two = end;
    f.off += end - k;
    f.one_colour += pair && two == n;
    if (two < n) {
      f.events++;
      const double wait = end < n ? (end - two) / 30.0 : INFINITY;
      f.recovered += wait <= 2;
      f.worst_wait = std::max (f.worst_wait, wait);
    }
    k = end;
  }
  f.off /= std::max<size_t> (n, 1);
  return f;
}

static SparseFigures
sparse_run (unsigned seed, bool odometry, SimResult * out = nullptr,
    double slow_share = -1, double slow_length = -1, bool mapped = false)
{
  const std::vector<Pose2> path = sparse_path (0.4);
  const auto truth = sparse_field (seed, path);
  SimOptions o = sparse_options (seed, odometry, path);
  if (slow_share >= 0)
    o.meas_corr_share = slow_share;
  if (slow_length > 0)
    o.meas_corr_length = slow_length;
  /* mapped: the true map given (anchors) */
  const std::vector<MapPoint> map = mapped ? truth_map (truth, 1)
      : std::vector<MapPoint> ();
  SimResult r;
  run (o, truth, &r, map);
  const SparseFigures f = sparse_figures (r, truth);
  std::printf ("sparse field %u, %s odometry%s: %.2f in view, %d of %zu "
      "mapped (missing %d extra %d merged %d), map rms %.2f cm, path median "
      "%.2f cm, pose NEES inside %.1f %% (above %.1f %%, mean %.2f); off on "
      "%.1f %% of %zu frames, two colours in view while off %d times, "
      "back within 2 s %d, longest wait %.1f s (one colour only: %d); "
      "confidently wrong on %d frames\n",
      seed, odometry ? "with" : "without",
      mapped ? ", map given" : "", f.in_view, f.landmarks, truth.size (),
      f.missing, f.extra, f.merged, 100 * f.map_rms, 100 * f.path_median,
      100 * f.nees_inside, 100 * f.nees_above, f.nees_mean, 100 * f.off,
      r.pose_err.size (), f.events, f.recovered, f.worst_wait,
      f.one_colour, f.confident_wrong);
  if (out)
    *out = r;
  return f;
}


/* The sparse fields' pose consistency with odometry, on the seeds held
 * out (101..116; the slow errors' states were developed on 1..8): the
 * pose NEES above chi-square's two-sided 95 % band on at most 4 % of the
 * frames (1.2 % measured; 10.9 % with every error taken as white, the
 * pose over-confident on up to 42 % of a run's frames), inside it on
 * 80 % of the frames or more in at least 13 of the 16 runs (15 measured;
 * 12 with white errors), and every landmark seen long enough mapped
 * once within 3 cm RMS (0.4-1.1 cm). */
static void
test_sparse_consistency ()
{
  int good = 0, runs = 0, bad_maps = 0;
  double above = 0, worst_rms = 0;
  for (unsigned seed = 101; seed <= 116; seed++) {
    const SparseFigures f = sparse_run (seed, true);
    runs++;
    good += f.nees_inside >= 0.8;
    above += f.nees_above;
    bad_maps += f.missing + f.extra + f.merged > 0;
    worst_rms = std::max (worst_rms, std::isnan (f.map_rms) ? INFINITY
        : f.map_rms);
  }
  above /= runs;
  std::printf ("sparse fields, held out: NEES inside on >= 80 %% of the "
      "frames in %d of %d runs, above the band on %.1f %% of the frames; "
      "maps: %d with a landmark missing, extra or merged, worst rms %.2f "
      "cm\n", good, runs, 100 * above, bad_maps, 100 * worst_rms);
  CHECK (above <= 0.04, "NEES above the band on %f", above);
  CHECK (good >= 13, "NEES inside on >= 80 %% in %d of %d runs", good,
      runs);
  CHECK (bad_maps == 0 && worst_rms < 0.03, "%d bad maps, worst rms %f",
      bad_maps, worst_rms);
}

/* Without odometry on the sparse fields, the true map given: the pose is
 * lost within seconds of one landmark in view, and found again once two
 * of two colours are in view (for 0.1 s or more): back within 10 cm and
 * 5 degrees in 2 s on 22 of 26 such stretches over the held-out seeds
 * 101..116, most in 0.1 s (before: 0 of 13; the rest: the map holds
 * another pair of those colours at about that distance). At least 60 %
 * asserted. */
static void
test_sparse_recovery ()
{
  int events = 0, recovered = 0;
  for (unsigned seed = 101; seed <= 116; seed++) {
    const SparseFigures f = sparse_run (seed, false, nullptr, -1, -1, true);
    events += f.events;
    recovered += f.recovered;
  }
  std::printf ("sparse fields without odometry, map given, held out: two "
      "colours in view while off %d times, back within 2 s %d\n", events,
      recovered);
  CHECK (events >= 10 && recovered >= 0.6 * events, "back within 2 s in "
      "%d of %d", recovered, events);
}

int
main (int argc, char **argv)
{
  /* test-slam --sparse FIRST LAST [--no-odometry] [--map] [--slow SHARE]
   * [--slow-length METRES]: the sparse fields' figures over seeds
   * FIRST..LAST (SHARE of the measurements' variance slow over METRES,
   * default 0.5 over 0.3), nothing checked */
  if (argc >= 4 && std::string (argv[1]) == "--sparse") {
    bool odometry = true;
    double share = -1, length = -1;
    bool mapped = false;
    for (int a = 4; a < argc; a++) {
      if (std::string (argv[a]) == "--no-odometry")
        odometry = false;
      else if (std::string (argv[a]) == "--slow" && a + 1 < argc)
        share = std::atof (argv[++a]);
      else if (std::string (argv[a]) == "--slow-length" && a + 1 < argc)
        length = std::atof (argv[++a]);
      else if (std::string (argv[a]) == "--map")
        mapped = true;
    }
    for (int seed = std::atoi (argv[2]); seed <= std::atoi (argv[3]); seed++)
      sparse_run ((unsigned) seed, odometry, nullptr, share, length, mapped);
    return 0;
  }
  test_chi2 ();
  test_loops_no_map ();
  test_bearing_wrap ();
  test_partial_map ();
  test_odometry ();
  test_odometry_bridged ();
  test_odometry_noise_over_distance ();
  test_odometry_turning_centre ();
  test_stationary ();
  test_confirm_on_knowledge ();
  test_confirm_short_pass ();
  test_biased_ranges_widened ();
  test_spurious_dropped ();
  test_sharp_turns ();
  test_new_waits_for_heading ();
  test_blind_stretch_new_landmark ();
  test_blind_start ();
  test_lost_relocalised_on_two ();
  test_relocalise_among_many ();
  test_relocalise_repeated_pattern ();
  test_odometry_slip_learnt ();
  test_sparse_consistency ();
  test_sparse_recovery ();
  return corecheck_summary ();
}
