#include "slam.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>
#include <unordered_map>

namespace landmark {

namespace {

/* regularised lower incomplete gamma P(a, x), by its series */
double
gamma_p (double a, double x)
{
  if (x <= 0)
    return 0;
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 1000; n++) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * 1e-15)
      break;
  }
  return std::min (1.0, std::exp (-x + a * std::log (x) - std::lgamma (a))
      * sum);
}

/* x y th, forward speed v, camera offset d, turn rate w, then the
 * odometry's scale error (its distance over the
 * true one, minus 1) and heading drift (rad per metre) */
constexpr int kPose = 8;
constexpr int kScale = 6, kDrift = 7;
/* frames out of sight that end a pass over a landmark (half a second at
 * 30 fps): slam_observation_sigmas counts the views of one pass */
constexpr int kPassGap = 15;
/* the odometry's scale error is a few per cent; a filter that drove it
 * near -1 would divide by zero */
constexpr double kMaxScaleError = 0.5;

/* H M for a measurement Jacobian H: each row of H has a few non-zero
 * columns (the pose's and one landmark's), so H M is those rows of M
 * summed, O(rows x N) where the dense product is O(rows x N^2) */
cv::Mat
jacobian_times (const cv::Mat & H, const cv::Mat & M)
{
  cv::Mat out = cv::Mat::zeros (H.rows, M.cols, CV_64F);
  for (int r = 0; r < H.rows; r++) {
    const double *h = H.ptr<double> (r);
    double *o = out.ptr<double> (r);
    for (int c = 0; c < H.cols; c++) {
      if (h[c] == 0)
        continue;
      const double *m = M.ptr<double> (c);
      for (int j = 0; j < M.cols; j++)
        o[j] += h[c] * m[j];
    }
  }
  return out;
}

/* P <- F P F^T for F the identity but for its first kMotionStates rows
 * (the motion states, F's kMotionStates^2 block): F P over each column,
 * then (F P) F^T over each row */
void
apply_motion_jacobian (double *P, int N, const double *F)
{
  constexpr int M = kMotionStates;
  double moved[M];
  for (int pass = 0; pass < 2; pass++)
    for (int j = 0; j < N; j++) {
      double *v = pass ? P + j * N : P + j;
      const int step = pass ? 1 : N;
      for (int i = 0; i < M; i++) {
        moved[i] = 0;
        for (int k = 0; k < M; k++)
          moved[i] += F[i * M + k] * v[k * step];
      }
      for (int i = 0; i < M; i++)
        v[i * step] = moved[i];
    }
}

}  // namespace

void
slam_observation_sigmas (const SlamObservation & o, int repeat, double *sr,
    double *sb)
{
  const double r = o.obs.range ();
  *sr = o.obs.range_sigma > 0 ? o.obs.range_sigma : default_range_sigma (r);
  *sb = o.obs.bearing_sigma > 0 ? o.obs.bearing_sigma :
      default_bearing_sigma ();
  /* ipmrange's sigmas cover the pixel noise of a whole blob. A blob
   * segmented in part moves its centre, so its floor range, and shrinks,
   * so its size range; their disagreement d is then of the order of the
   * centre's error, in an unknown direction, and the same in the frames
   * that follow (the blob is cut the same way): d^2 is added to the range
   * variance and (d / r)^2 to the bearing's, times `repeat`, the views the
   * landmark already has, so an error that repeats is not averaged away
   * (its information grows as the logarithm of the views, not linearly).
   * The cut changes with the viewpoint, so `repeat` counts the views of the
   * current pass only (kPassGap): counted over a whole run it would grow
   * without bound and the measurement, and the association gate with it,
   * would come to mean nothing.
   * Measured on rendered clips: whole blobs disagree by 0.5 to 2 cm, blobs
   * missing a quarter of their pixels by 4 to 12 cm with range errors of
   * 6 to 14 cm. */
  const double d = o.range_disagreement;
  if (d != 0 && r > 0) {
    const double k = std::max (1, repeat);
    *sr = std::sqrt (*sr * *sr + k * d * d);
    *sb = std::sqrt (*sb * *sb + k * (d / r) * (d / r));
  }
}

double
max_sigma_2x2 (const double c[4])
{
  const double m = 0.5 * (c[0] + c[3]), h = 0.5 * (c[0] - c[3]),
      b = 0.5 * (c[1] + c[2]);
  return std::sqrt (std::max (0.0, m + std::sqrt (h * h + b * b)));
}

double
chi2_quantile (double p, int dof)
{
  double lo = 0, hi = 10.0 * dof + 100;
  for (int i = 0; i < 200; i++) {
    const double mid = 0.5 * (lo + hi);
    if (gamma_p (0.5 * dof, 0.5 * mid) < p)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

void
Slam::reset ()
{
  init_ = false;
  s_.clear ();
  p_.clear ();
  std::fill (frame_cov_, frame_cov_ + 9, 0.0);
  /* keep the anchors, drop what was learnt */
  std::vector<SlamLandmark> keep;
  for (const auto & l : lm_)
    if (l.anchor)
      keep.push_back (l);
  lm_ = keep;
  slip_reset ();
  slot_.assign (lm_.size (), -1);
  last_view_.assign (lm_.size (), Pose2 ());
  unseen_.assign (lm_.size (), 0);
  pass_views_.assign (lm_.size (), 0);
}

void
Slam::set_map (const std::vector<MapPoint> & map)
{
  lm_.clear ();
  for (const auto & m : map) {
    SlamLandmark l;
    static_cast < MapLandmark & >(l) = m;
    l.anchor = l.confirmed = true;
    lm_.push_back (l);
  }
  anchored_ = !lm_.empty ();
  next_id_ = 1;
  reset ();
}

Pose2
Slam::pose () const
{
  Pose2 p;
  if (init_) {
    p.x = s_[0];
    p.y = s_[1];
    p.heading = s_[2];
  }
  return p;
}

/* The frame's own uncertainty (frame_cov_, the pose's when the filter was
 * last rebased on it) moved to a point (px, py) of the state: a turn of
 * the frame about its origin moves the point by J (p - origin). */
void
Slam::frame_cov_at (double px, double py, double out[9]) const
{
  const double ax = -(py - frame_.y), ay = px - frame_.x;
  const double A[3][3] = { { 1, 0, ax }, { 0, 1, ay }, { 0, 0, 1 } };
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      double v = 0;
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
          v += A[i][a] * frame_cov_[a * 3 + b] * A[j][b];
      out[i * 3 + j] = v;
    }
}

void
Slam::pose_cov (double cov[9]) const
{
  const size_t N = n ();
  double f[9];
  frame_cov_at (init_ ? s_[0] : 0, init_ ? s_[1] : 0, f);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      cov[i * 3 + j] = init_ ? p_[i * N + j] + f[i * 3 + j] : 0;
}

void
Slam::rebase ()
{
  /* Without anchors and with no landmark in the state, nothing the
   * filter will ever measure is tied to the start: the pose's uncertainty
   * relative to it (the heading a drift of 0.05 rad/m gives over a blind
   * stretch) is the frame's. Kept in the filter, the odometry states it
   * is correlated with (the drift that made it) turn the whole map by it
   * when the landmarks reveal them, a linearised turn of tens of degrees
   * that left the landmarks' positions relative to the robot
   * over-confident (NEES mean 4.3 on the core blind-start test, 1.4
   * with the same odometry seeing landmarks at once). So the filter is
   * rebased: the pose's covariance and its correlations leave P (the
   * filter is then relative to the frame placed at this pose) and are
   * kept as frame_cov_, added back to what is reported in the first
   * pose's frame (pose_cov, the landmarks' cov). Exact for everything
   * measured (relative); the reported covariances omit the frame's
   * correlation with the odometry states' later effect. */
  const int N = (int) n ();
  double cov[9];
  pose_cov (cov);
  std::copy (cov, cov + 9, frame_cov_);
  frame_ = pose ();
  auto clear = [&](double *M) {
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < N; j++)
        M[i * N + j] = M[j * N + i] = 0;
  };
  clear (p_.data ());
  if (slip_tracked ())
    for (auto & d : dp_)
      clear (d.data ());
}

void
Slam::init_pose (const Pose2 & p, const double cov[9])
{
  s_.assign (kPose, 0);
  s_[0] = p.x;
  s_[1] = p.y;
  s_[2] = wrap_angle (p.heading);
  p_.assign (kPose * kPose, 0);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      p_[i * kPose + j] = cov[i * 3 + j];
  /* the robot may start moving: velocities unknown within these sigmas */
  p_[3 * kPose + 3] = 0.5 * 0.5;
  p_[4 * kPose + 4] = opt.offset_sigma * opt.offset_sigma;
  p_[5 * kPose + 5] = 1.0;
  p_[kScale * kPose + kScale] = opt.odo_scale_sigma * opt.odo_scale_sigma;
  p_[kDrift * kPose + kDrift] = opt.odo_drift_sigma * opt.odo_drift_sigma;
  dp_[0].clear ();
  dp_[1].clear ();
  init_ = true;
}

void
Slam::predict (double dt)
{
  if (!init_ || !(dt > 0))
    return;
  /* a ground robot driving along its heading (core/groundmotion.h); the
   * motion states come first, the rest of F is the identity, so
   * F P F^T + Q changes the motion rows and columns only */
  constexpr int M = kMotionStates;
  const int N = (int) n ();
  const GroundMotionStep step = ground_motion_predict (s_.data (), dt,
      opt.motion);
  apply_motion_jacobian (p_.data (), N, step.F);
  /* the slip's share of P is not the motion model's: carried only */
  if (slip_tracked ())
    for (auto & d : dp_)
      apply_motion_jacobian (d.data (), N, step.F);
  double *P = p_.data ();
  for (int i = 0; i < M; i++)
    for (int j = 0; j < M; j++)
      P[i * N + j] += step.Q[i * M + j];
  std::copy (step.s, step.s + M, s_.begin ());
}

void
Slam::predict_odometry (double mdx, double mdy, double mdth, double dt)
{
  if (!init_)
    return;
  const int N = (int) n ();
  const double c = std::cos (s_[2]), s = std::sin (s_[2]);
  /* The odometry's own systematic errors, in the state: the increment
   * corrected for its scale error k and heading drift g per metre is
   * d = m / (1 + k), dth = mdth - g |d|. Modelled as white noise per step
   * instead, a drift of 1 degree per metre over 33 steps of 3 cm would
   * have a stated sigma of a sixth of itself. */
  const double k = std::clamp (s_[kScale], -kMaxScaleError, kMaxScaleError);
  const double g = s_[kDrift];
  const double dx = mdx / (1 + k), dy = mdy / (1 + k);
  const double d = std::hypot (dx, dy);
  const double dth = mdth - g * d;
  /* Wheel odometry reports its turning centre's motion; the pose is the
   * camera's, a ahead of it, which a turn swings round: the camera moves
   * by e = d + a (cos dth - 1, sin dth) in the robot frame at the start
   * (exact for any rigid increment, so also for a frame's sum of them).
   * a is a setting, not a state: as a state with a prior of 0.1 m it let
   * the bridged odometry wander (docs/landmarkslam.md) */
  const double a = opt.odo_camera_forward;
  const double co = std::cos (dth), so = std::sin (dth);
  const double ex = dx + a * (co - 1), ey = dy + a * so;
  /* Jacobian of the pose part, its three rows (the others are the
   * identity): x' = x + R(th) e, th' = th + dth, through the heading, the
   * scale error k (d(d)/dk = -d / (1 + k), d(dth)/dk = g |d| / (1 + k))
   * and the drift g (d(dth)/dg = -|d|), de/d(dth) = a (-sin dth, cos dth).
   * Each row is the identity's plus three entries, so F P F^T changes
   * rows and columns 0-2 only, in place */
  const double tk = g * d / (1 + k);
  const double exk = -dx / (1 + k) - a * so * tk,
      eyk = -dy / (1 + k) + a * co * tk;
  const double exg = a * so * d, eyg = -a * co * d;
  const double a02 = -s * ex - c * ey, a12 = c * ex - s * ey;
  const double a0k = c * exk - s * eyk, a1k = s * exk + c * eyk, a2k = tk;
  const double a0g = c * exg - s * eyg, a1g = s * exg + c * eyg, a2g = -d;
  auto propagate = [&](double *P) {
    for (int j = 0; j < N; j++) {
      const double p2 = P[2 * N + j], pk = P[kScale * N + j],
          pg = P[kDrift * N + j];
      P[0 * N + j] += a02 * p2 + a0k * pk + a0g * pg;
      P[1 * N + j] += a12 * p2 + a1k * pk + a1g * pg;
      P[2 * N + j] += a2k * pk + a2g * pg;
    }
    for (int i = 0; i < N; i++) {
      double *row = P + i * N;
      const double p2 = row[2], pk = row[kScale], pg = row[kDrift];
      row[0] += a02 * p2 + a0k * pk + a0g * pg;
      row[1] += a12 * p2 + a1k * pk + a1g * pg;
      row[2] += a2k * pk + a2g * pg;
    }
  };
  /* the slip's evidence is gathered from the first odometry on, while
   * adapting (without odometry it costs nothing): the slip has had no
   * share in P yet, and what P holds on the pose and the landmarks is
   * taken as the measurements' */
  if (!opt.odo_slip_adapt) {
    dp_[0].clear ();
    dp_[1].clear ();
  } else if (!slip_tracked ()) {
    dp_[0].assign (p_.size (), 0);
    dp_[1] = p_;
    for (int i = 0; i < N; i++)
      for (int j = 0; j < N; j++)
        if ((i >= 3 && i < kPose) || (j >= 3 && j < kPose))
          dp_[1][i * N + j] = 0;
  }
  propagate (p_.data ());
  const bool tracked = slip_tracked ();
  if (tracked)
    for (auto & dp : dp_)
      propagate (dp.data ());
  /* The white part, slip: a wheel's travel error is a random walk over
   * the distance it rolls, so a step's variance is proportional to its
   * length (not its square) and the sigma after a given distance does not
   * depend on how often increments arrive. Isotropic in x and y: a
   * rotation leaves it as it is. The heading's slip also swings the
   * camera, by u = R(th) a (-sin dth, cos dth) per radian. The stated
   * sigmas times the slip scale in use (1 unless learnt); dp_[0] gathers
   * the stated ones. */
  const double vt = opt.odo_trans_sigma * opt.odo_trans_sigma * d;
  const double vr = opt.odo_rot_per_m * opt.odo_rot_per_m * d
      + opt.odo_rot_sigma * opt.odo_rot_sigma * std::fabs (dth);
  const double u0 = -a * (c * so + s * co), u1 = a * (c * co - s * so);
  auto add_slip = [&](double *P, double f) {
    P[0 * N + 0] += f * (vt + u0 * u0 * vr);
    P[1 * N + 1] += f * (vt + u1 * u1 * vr);
    P[0 * N + 1] += f * (u0 * u1 * vr);
    P[1 * N + 0] += f * (u0 * u1 * vr);
    P[0 * N + 2] += f * (u0 * vr);
    P[2 * N + 0] += f * (u0 * vr);
    P[1 * N + 2] += f * (u1 * vr);
    P[2 * N + 1] += f * (u1 * vr);
    P[2 * N + 2] += f * vr;
  };
  add_slip (p_.data (), opt.odo_slip_adapt ? slip_var_ : 1.0);
  if (tracked) {
    add_slip (dp_[0].data (), 1);
    slip_forget (d, std::fabs (dth));
  }
  s_[0] += c * ex - s * ey;
  s_[1] += s * ex + c * ey;
  s_[2] = wrap_angle (s_[2] + dth);
  if (dt > 0) {
    /* the speed and turn rate follow the odometry, for a later
     * constant-velocity prediction */
    s_[3] = dx / dt;
    s_[5] = dth / dt;
  }
}

void
Slam::add_landmark (const SlamObservation & o, SlamLandmark lm)
{
  const int N = (int) n ();
  const double r = o.obs.range (), b = o.obs.bearing ();
  double sr, sb;
  slam_observation_sigmas (o, 1, &sr, &sb);
  const double a = s_[2] + b, ca = std::cos (a), sa = std::sin (a);
  lm.x = s_[0] + r * ca;
  lm.y = s_[1] + r * sa;
  /* Jacobians of the landmark position w.r.t. the pose and (r, b) */
  cv::Mat Gx = (cv::Mat_<double> (2, 3) << 1, 0, -r * sa, 0, 1, r * ca);
  cv::Mat Gz = (cv::Mat_<double> (2, 2) << ca, -r * sa, sa, r * ca);
  cv::Mat R = (cv::Mat_<double> (2, 2) << sr * sr, 0, 0, sb * sb);
  /* M (N x N) grown by the landmark's rows and columns: its correlation
   * with the rest through the pose, Gx M, its own block Gx M Gx^T, plus
   * the measurement's Gz R Gz^T where M holds it: P, and the
   * measurements' derivative of P (the slip's reaches the landmark
   * through the pose only) */
  auto grow = [&](std::vector<double> & m, bool with_measurement) {
    cv::Mat M (N, N, CV_64F, m.data ());
    cv::Mat Mlx = Gx * M.rowRange (0, 3);       /* 2 x N */
    cv::Mat Mll = Gx * M (cv::Rect (0, 0, 3, 3)) * Gx.t ();
    if (with_measurement)
      Mll += Gz * R * Gz.t ();
    cv::Mat Mn = cv::Mat::zeros (N + 2, N + 2, CV_64F);
    M.copyTo (Mn (cv::Rect (0, 0, N, N)));
    Mlx.copyTo (Mn (cv::Rect (0, N, N, 2)));
    cv::Mat Mxl = Mlx.t ();
    Mxl.copyTo (Mn (cv::Rect (N, 0, 2, N)));
    Mll.copyTo (Mn (cv::Rect (N, N, 2, 2)));
    m.assign ((double *) Mn.data, (double *) Mn.data + (N + 2) * (N + 2));
  };
  const bool tracked = slip_tracked ();
  grow (p_, true);
  if (tracked) {
    grow (dp_[0], false);
    grow (dp_[1], true);
  }
  s_.push_back (lm.x);
  s_.push_back (lm.y);
  lm.views = 1;
  lm.confirmed = false;       /* decided with the others after the update */
  if (lm.id.empty ()) {
    /* ids not taken by the given map */
    for (;;) {
      std::string id = "S" + std::to_string (next_id_++);
      bool taken = false;
      for (const auto & l : lm_)
        taken |= l.id == id;
      if (!taken) {
        lm.id = id;
        break;
      }
    }
  }
  lm_.push_back (lm);
  slot_.push_back (N);
  last_view_.push_back (pose ());
  unseen_.push_back (0);
  pass_views_.push_back (1);   /* seen once, as views */
}

void
Slam::remove_landmark (size_t k)
{
  const int N = (int) n (), sl = slot_[k];
  if (sl >= 0) {
    std::vector<int> keep;
    for (int i = 0; i < N; i++)
      if (i != sl && i != sl + 1)
        keep.push_back (i);
    const bool tracked = slip_tracked ();
    std::vector<double> s2, p2, d2[2];
    for (int i : keep) {
      s2.push_back (s_[i]);
      for (int j : keep) {
        p2.push_back (p_[i * N + j]);
        for (int c = 0; c < 2 && tracked; c++)
          d2[c].push_back (dp_[c][i * N + j]);
      }
    }
    s_ = s2;
    p_ = p2;
    dp_[0] = d2[0];
    dp_[1] = d2[1];
    for (auto & o : slot_)
      if (o > sl)
        o -= 2;
  }
  lm_.erase (lm_.begin () + k);
  slot_.erase (slot_.begin () + k);
  last_view_.erase (last_view_.begin () + k);
  unseen_.erase (unseen_.begin () + k);
  pass_views_.erase (pass_views_.begin () + k);
}

void
Slam::sync_landmarks ()
{
  const size_t N = n ();
  for (size_t k = 0; k < lm_.size (); k++) {
    const int sl = slot_[k];
    if (sl < 0)
      continue;
    lm_[k].x = s_[sl];
    lm_[k].y = s_[sl + 1];
    double f[9];
    frame_cov_at (s_[sl], s_[sl + 1], f);
    lm_[k].cov[0] = p_[sl * N + sl] + f[0];
    lm_[k].cov[1] = p_[sl * N + sl + 1] + f[1];
    lm_[k].cov[2] = p_[(sl + 1) * N + sl] + f[3];
    lm_[k].cov[3] = p_[(sl + 1) * N + sl + 1] + f[4];
  }
}

void
Slam::confirm_known ()
{
  /* known = relative to the robot: the landmark's covariance given the
   * pose, P_ll - P_lx P_xx^-1 P_xl. Its marginal in the map frame also
   * holds the drift the robot had gathered when it first saw it, which
   * the landmark shares with its neighbours and which no observation of
   * it can remove until a loop closes. */
  const int N = (int) n ();
  if (!init_)
    return;
  cv::Mat P (N, N, CV_64F, p_.data ());
  cv::Mat Pxx_inv;
  cv::invert (P (cv::Rect (0, 0, 3, 3)), Pxx_inv, cv::DECOMP_SVD);
  for (size_t k = 0; k < lm_.size (); k++) {
    SlamLandmark & l = lm_[k];
    const int sl = slot_[k];
    if (l.anchor || l.confirmed || sl < 0 || l.views < opt.confirm_views)
      continue;
    cv::Mat Plx = P (cv::Rect (0, sl, 3, 2));
    cv::Mat C = P (cv::Rect (sl, sl, 2, 2)) - Plx * Pxx_inv * Plx.t ();
    const double c[4] = { C.at<double> (0, 0), C.at<double> (0, 1),
      C.at<double> (1, 0), C.at<double> (1, 1) };
    if (max_sigma_2x2 (c) <= opt.confirm_sigma)
      l.confirmed = true;
  }
}

double
Slam::heading_var_to_map () const
{
  const int N = (int) n ();
  /* anchors are exact: the marginal is already relative to them */
  if (anchored_)
    return p_[2 * N + 2];
  /* the map's orientation: the least-squares turn of its landmarks about
   * their centroid, phi = sum_i (-d_iy dx_i + d_ix dy_i) / sum_i |d_i|^2
   * for displacements (dx_i, dy_i), d_i = l_i - centroid (the centroid's
   * own shift is a translation: sum_i J d_i = 0 takes it out) */
  std::vector<int> slots;
  double cx = 0, cy = 0;
  for (int sl : slot_)
    if (sl >= 0) {
      slots.push_back (sl);
      cx += s_[sl];
      cy += s_[sl + 1];
    }
  /* fewer than two: no orientation for a heading to be wrong against */
  if (slots.size () < 2)
    return 0;
  cx /= slots.size ();
  cy /= slots.size ();
  double D = 0;
  for (int sl : slots)
    D += std::pow (s_[sl] - cx, 2) + std::pow (s_[sl + 1] - cy, 2);
  if (!(D > 1e-12))
    return p_[2 * N + 2];
  /* a' P a over the non-zero entries of a = d(heading - phi) / d(state) */
  std::vector<std::pair<int, double>> a { { 2, 1.0 } };
  for (int sl : slots) {
    a.push_back ({ sl, (s_[sl + 1] - cy) / D });
    a.push_back ({ sl + 1, -(s_[sl] - cx) / D });
  }
  double v = 0;
  for (const auto & [i, ai] : a)
    for (const auto & [j, aj] : a)
      v += ai * aj * p_[i * N + j];
  return std::max (0.0, v);
}

void
Slam::joint_cov (size_t k, double cov[25]) const
{
  const int N = (int) n ();
  const int sl = k < slot_.size ()? slot_[k] : -1;
  const int idx[5] = { 0, 1, 2, sl, sl + 1 };
  for (int i = 0; i < 5; i++)
    for (int j = 0; j < 5; j++)
      cov[i * 5 + j] = init_ && (i < 3 || sl >= 0) && (j < 3 || sl >= 0)
          ? p_[idx[i] * N + idx[j]] : 0;
}

void
Slam::slip_reset ()
{
  dp_[0].clear ();
  dp_[1].clear ();
  slip_a_[0] = slip_a_[1] = slip_a_[2] = 0;
  slip_b_[0] = slip_b_[1] = 0;
  slip_var_ = 1;
}

void
Slam::slip_forget (double distance, double turned)
{
  const double keep = std::exp (-(distance + turned)
      / std::max (opt.odo_slip_window, 1e-9));
  for (double &a : slip_a_)
    a *= keep;
  for (double &b : slip_b_)
    b *= keep;
}

/* The slip's and the measurements' variance scales (lambda, beta) that
 * the evidence gives, each drawn to 1, the stated value, by a prior of
 * the information (1/2) of odo_slip_prior scalar innovations that one
 * component alone makes: (A + w I) (lambda, beta) = b + w (1, 1). */
double
Slam::slip_scales (double *meas_var) const
{
  const double w = 0.5 * std::max (opt.odo_slip_prior, 1e-9);
  const double a00 = slip_a_[0] + w, a01 = slip_a_[1], a11 = slip_a_[2] + w;
  const double b0 = slip_b_[0] + w, b1 = slip_b_[1] + w;
  const double det = a00 * a11 - a01 * a01;
  if (!(det > 0)) {
    if (meas_var)
      *meas_var = std::numeric_limits<double>::quiet_NaN ();
    return std::numeric_limits<double>::quiet_NaN ();
  }
  if (meas_var)
    *meas_var = (a00 * b1 - a01 * b0) / det;
  return (a11 * b0 - a01 * b1) / det;
}

double
Slam::measurement_scale () const
{
  double beta;
  slip_scales (&beta);
  return std::sqrt (std::max (0.0, beta));
}

/* Evidence of the slip from one update (Sinv empty: none), and dp_ carried
 * through it. Two variance components of the innovation nu of the update,
 * S = H P H^T + R: the slip's, scaled by lambda (the filter's
 * slip_var_), and the measurements', scaled by beta (the filter's 1),
 * G_i = H dP/d(scale_i) H^T (+ R for the measurements'): what each scale
 * puts in S, through the pose and the landmarks alike (a landmark mapped
 * from a mis-stated measurement carries the mis-statement). Were the
 * true scales lambda*, beta*, to first order
 *   E[nu nu^T] = S + G1 (lambda* - lambda) + G2 (beta* - 1),
 * so u_i = nu^T S^-1 G_i S^-1 nu - tr(S^-1 G_i) + sum_j T_ij theta_j, with
 * T_ij = tr(S^-1 G_i S^-1 G_j) and theta = (lambda, 1), has the mean
 * sum_j T_ij theta*_j: Fisher scoring of the Gaussian likelihood, T / 2
 * its information (the variance-component estimation of Koch and Kusche
 * 2002; Mohamed and Schwarz 1999 estimate Q from the corrections K nu
 * alike). Each projects the innovation on its own component: the frames
 * after odometry bridged a stretch weigh for the slip, those seen all
 * along for the measurements, so a mis-stated measurement is not taken
 * for slip. A wrong pairing passed JCBB's joint gate, so its NIS is
 * bounded; a frame whose NIS is beyond 3 sigma of what the estimate
 * expects weighs less all the same (Huber). */
void
Slam::slip_evidence (const cv::Mat & H, const cv::Mat & Sinv,
    const cv::Mat & R, const cv::Mat & nu, const cv::Mat & K)
{
  const int N = (int) n ();
  if (!slip_tracked ())
    return;
  cv::Mat D1 (N, N, CV_64F, dp_[0].data ()), D2 (N, N, CV_64F,
      dp_[1].data ());
  const cv::Mat HD[2] = { jacobian_times (H, D1), jacobian_times (H, D2) };
  const cv::Mat G1 = HD[0] * H.t (), G2 = HD[1] * H.t () + R;
  if (opt.odo_slip_adapt && !Sinv.empty ()) {
    const cv::Mat SG1 = Sinv * G1, SG2 = Sinv * G2;
    const cv::Mat w = Sinv * nu;            /* S^-1 nu */
    const double t11 = cv::trace (SG1 * SG1)[0],
        t12 = cv::trace (SG1 * SG2)[0], t22 = cv::trace (SG2 * SG2)[0];
    const double dof = nu.rows, q = cv::trace (SG1)[0],
        r = cv::trace (SG2)[0];
    const double u1 = cv::Mat (w.t () * G1 * w).at<double> (0) - q
        + t11 * slip_var_ + t12;
    const double u2 = cv::Mat (w.t () * G2 * w).at<double> (0) - r
        + t12 * slip_var_ + t22;
    double beta;
    const double lambda = slip_scales (&beta);
    const double nis = cv::Mat (nu.t () * w).at<double> (0);
    const double e = nis - dof - q * (lambda - slip_var_) - r * (beta - 1);
    const double c = 3 * std::sqrt (2 * dof);
    const double k = 0.5 * std::min (1.0, c / std::max (std::fabs (e),
            1e-300));
    if (q > 0 && std::isfinite (u1) && std::isfinite (u2)) {
      slip_a_[0] += k * t11;
      slip_a_[1] += k * t12;
      slip_a_[2] += k * t22;
      slip_b_[0] += k * u1;
      slip_b_[1] += k * u2;
      /* a degenerate system (no prior) keeps the scale in use */
      const double scale = slip_scales (nullptr);
      if (std::isfinite (scale))
        slip_var_ = std::clamp (scale,
            opt.odo_slip_scale_min * opt.odo_slip_scale_min,
            opt.odo_slip_scale_max * opt.odo_slip_scale_max);
    }
  }
  /* dP+ = (I - K H) dP- (I - K H)^T (+ K R K^T for the measurements'):
   * the gain's own derivative drops out at the optimal gain. Expanded,
   * D - K (H D) - (H D)^T K^T + K (H D H^T) K^T, so that the cost grows
   * with N^2 times the measurements, not with N^3 (H D H^T as in G) */
  for (int c = 0; c < 2; c++)
    joseph_update (dp_[c].data (), K, HD[c], c == 0 ? G1 : G2);
}

/* M <- M - K (H M) - (H M)^T K^T + K inner K^T for a symmetric M of the
 * state's size n (): with C = K (H M - inner K^T / 2) that is M - C - C^T
 * (inner's symmetric part), one N x N product, kept in scratch_ (which
 * allocates again only when a landmark changes N), written symmetric */
void
Slam::joseph_update (double *M, const cv::Mat & K, const cv::Mat & HM,
    const cv::Mat & inner)
{
  const int N = (int) n ();
  cv::gemm (K, HM - 0.5 * inner * K.t (), 1, cv::noArray (), 0,
      scratch_.joseph);
  const cv::Mat & C = scratch_.joseph;
  for (int i = 0; i < N; i++) {
    const double *ci = C.ptr<double> (i);
    for (int j = i; j < N; j++) {
      const double v = 0.5 * (M[i * N + j] + M[j * N + i])
          - (ci[j] + C.at<double> (j, i));
      M[i * N + j] = v;
      M[j * N + i] = v;
    }
  }
}

namespace {

/* P(X >= x) for X Poisson with mean lambda, summed upward (the tail is
 * tiny where it matters, and 1 - cdf would lose it) */
double
poisson_tail (double lambda, int x)
{
  if (x <= 0)
    return 1;
  double term = std::exp (-lambda);
  for (int k = 1; k <= x; k++)
    term *= lambda / k;
  double sum = 0;
  for (int k = x; k < x + 200 && term > 1e-300; k++) {
    sum += term;
    term *= lambda / (k + 1);
  }
  return std::min (1.0, sum);
}

}  // namespace

/* Relocalisation of a lost pose. Pairings are hypothesised from what does
 * not depend on the pose: the distance between two detections against the
 * distance between two landmarks of their classes, the widest detection
 * pairs first (the best heading). Each hypothesis places the robot (the
 * rigid motion taking the two detections onto the two landmarks) and is
 * scored by the detections it then explains; the most, then the nearest
 * to the predicted pose, wins, if the prediction allows it and no other
 * that places the robot elsewhere explains as many. Explained
 * detections beyond the two seeds must be unlikely by chance: each
 * detection's chance of some landmark of its class within its tolerance,
 * from the class's density over the mapped area, summed to a Poisson mean;
 * its tail times the hypotheses (those not tried counted) must stay under
 * opt.reloc_chance. The work (landmark comparisons) is bounded per frame;
 * a search cut short accepts only on that chance test. */
bool
Slam::relocalise (const std::vector<SlamObservation> & obs, Pose2 * at,
    std::vector<int> *assign) const
{
  const size_t N = n (), no = obs.size (), nl = lm_.size ();
  if (nl < 2)
    return false;
  std::vector<double> var (no);    /* detection's position variance */
  for (size_t i = 0; i < no; i++) {
    double sr, sb;
    slam_observation_sigmas (obs[i], 1, &sr, &sb);
    var[i] = sr * sr + std::pow (obs[i].obs.range () * sb, 2);
  }
  std::vector<double> lm_var (nl);
  double x0 = lm_[0].x, x1 = x0, y0 = lm_[0].y, y1 = y0;
  for (size_t k = 0; k < nl; k++) {
    lm_var[k] = std::pow (max_sigma_2x2 (lm_[k].cov), 2);
    x0 = std::min (x0, lm_[k].x);
    x1 = std::max (x1, lm_[k].x);
    y0 = std::min (y0, lm_[k].y);
    y1 = std::max (y1, lm_[k].y);
  }
  /* per detection, the landmarks of its class and their mean variance */
  std::vector<std::vector<int>> same (no);
  std::vector<double> same_var (no, 0);
  for (size_t i = 0; i < no; i++) {
    for (size_t k = 0; k < nl; k++)
      if (lm_[k].class_name == obs[i].class_name) {
        same[i].push_back ((int) k);
        same_var[i] += lm_var[k];
      }
    if (!same[i].empty ())
      same_var[i] /= same[i].size ();
  }
  double lm_var_max = 0;
  for (double v : lm_var)
    lm_var_max = std::max (lm_var_max, v);
  /* the landmarks on a grid, so that a detection is scored against those
   * near where a hypothesis puts it, not against all of its class */
  const double cell = 0.5;
  std::unordered_map<long long, std::vector<int>> grid;
  auto cell_key = [&](long long cx, long long cy) {
    return cx * 2000003LL + cy;
  };
  for (size_t k = 0; k < nl; k++)
    grid[cell_key ((long long) std::floor ((lm_[k].x - x0) / cell),
            (long long) std::floor ((lm_[k].y - y0) / cell))].push_back ((int) k);
  cv::Matx33d Pxx;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      Pxx (i, j) = p_[i * N + j];
  const cv::Matx33d Pinv = Pxx.inv (cv::DECOMP_SVD);
  const double plausible = chi2_quantile (opt.joint_probability, 3);
  const double pc[4] = { Pxx (0, 0), Pxx (0, 1), Pxx (1, 0), Pxx (1, 1) };
  const double pos_sigma = max_sigma_2x2 (pc);
  /* seed pairs, widest first */
  struct Seed {
    int i, j;
    double dz;
  };
  std::vector<Seed> seeds;
  for (size_t i = 0; i < no; i++)
    for (size_t j = i + 1; j < no; j++) {
      const double dz = std::hypot (obs[j].obs.gx - obs[i].obs.gx,
          obs[j].obs.gy - obs[i].obs.gy);
      if (dz >= opt.min_separation && !same[i].empty () && !same[j].empty ())
        seeds.push_back ({ (int) i, (int) j, dz });
    }
  std::stable_sort (seeds.begin (), seeds.end (),
      [](const Seed & a, const Seed & b) { return a.dz > b.dz; });
  struct Hyp {
    std::vector<int> assign;
    Pose2 pose;
    int inliers = 0;
    double d2 = 0;
    double lambda = 0;  /* chance inliers beyond the seeds, expected */
    int seeds[2] = { -1, -1 };
  };
  /* the best hypothesis, and the others that explain as many detections
   * with other pairings (rivals: the pose they place and its seeds'
   * lever); buffers reused */
  Hyp best, h;
  struct Rival {
    Pose2 pose;
    double seed_var, lever;
  };
  std::vector<Rival> rivals;
  double best_seed_var = 0, best_lever = 0;
  std::vector<bool> taken (nl);
  std::vector<int> cand_i, cand_j, near;
  /* work: landmark pairs compared and landmarks scored; hypotheses: those
   * the prediction allows, each scored */
  const long budget = opt.reloc_max_comparisons;
  long work = 0, compared = 0, hypotheses = 0;
  double untried = 0;   /* landmark pairs not compared */
  /* the detections a hypothesis explains, each with its nearest free
   * landmark of its class within a tolerance that adds `pose_var` (the
   * variance the hypothesis' own error adds at that detection), and the
   * inliers chance alone would give it */
  auto score = [&](Hyp * h, const std::function<double (size_t)> & pose_var) {
    const double c = std::cos (h->pose.heading),
        sn = std::sin (h->pose.heading);
    h->inliers = 0;
    h->lambda = 0;
    h->assign.assign (no, -1);
    taken.assign (nl, false);
    for (size_t m = 0; m < no; m++) {
      double nearest_e2 = std::numeric_limits<double>::infinity ();
      const double extra = pose_var (m);
      /* where the hypothesis puts the detection, and the cells its
       * widest tolerance reaches */
      const double px = h->pose.x + c * obs[m].obs.gx - sn * obs[m].obs.gy,
          py = h->pose.y + sn * obs[m].obs.gx + c * obs[m].obs.gy;
      const double reach = std::sqrt (opt.gate_chi2 * (var[m] + lm_var_max
              + extra));
      near.clear ();
      /* only the cells that hold landmarks: a wide tolerance (a detection
       * far beyond two close seeds) must not walk empty space */
      auto cell_range = [&](double p, double lo, double hi, long long *a,
          long long *b) {
        const double last = std::floor ((hi - lo) / cell);
        *a = (long long) std::clamp (std::floor ((p - reach - lo) / cell),
            0.0, last);
        *b = (long long) std::clamp (std::floor ((p + reach - lo) / cell),
            0.0, last);
        return std::isfinite (p) && std::isfinite (reach)
            && p + reach >= lo && p - reach <= hi + cell;
      };
      long long cx0, cx1, cy0, cy1;
      if (!cell_range (px, x0, x1, &cx0, &cx1)
          || !cell_range (py, y0, y1, &cy0, &cy1))
        cx1 = cx0 - 1;          /* nothing within reach */
      for (long long cx = cx0; cx <= cx1; cx++)
        for (long long cy = cy0; cy <= cy1; cy++) {
          work++;
          const auto it = grid.find (cell_key (cx, cy));
          if (it != grid.end ())
            near.insert (near.end (), it->second.begin (), it->second.end ());
        }
      /* in index order, as a scan of the class would meet them */
      std::sort (near.begin (), near.end ());
      for (int q : near) {
        work++;
        if (lm_[q].class_name != obs[m].class_name || taken[q])
          continue;
        const double wx = lm_[q].x - h->pose.x, wy = lm_[q].y - h->pose.y;
        const double ex = c * wx + sn * wy - obs[m].obs.gx,
            ey = -sn * wx + c * wy - obs[m].obs.gy;
        const double e2 = ex * ex + ey * ey;
        const double tol = opt.gate_chi2 * (var[m] + lm_var[q] + extra);
        if (e2 < tol && e2 < nearest_e2) {
          nearest_e2 = e2;
          h->assign[m] = q;
        }
      }
      if (h->assign[m] >= 0) {
        taken[h->assign[m]] = true;
        h->inliers++;
      }
      /* by chance: some landmark of its class within its tolerance disk,
       * the class spread over the mapped area grown by it */
      if ((int) m != h->seeds[0] && (int) m != h->seeds[1]
          && !same[m].empty ()) {
        const double tol = opt.gate_chi2 * (var[m] + same_var[m] + extra);
        const double grow = 2 * std::sqrt (tol);
        const double area = (x1 - x0 + grow) * (y1 - y0 + grow);
        h->lambda += 1 - std::exp (-(double) same[m].size () * M_PI * tol
            / area);
      }
    }
  };
  size_t s = 0;
  for (; s < seeds.size () && work < budget; s++) {
    const int i = seeds[s].i, j = seeds[s].j;
    const double dz = seeds[s].dz;
    const auto & zi = obs[i].obs, &zj = obs[j].obs;
    const double lever = 1 / (dz * dz);
    /* a seed's landmark at the detection's range from the predicted
     * position, within what the prediction allows (whatever the heading)
     * and half the distance mismatch the pair may have */
    const double slack = std::sqrt (plausible) * pos_sigma
        + std::sqrt (opt.gate_chi2 * (var[i] + var[j] + 2 * lm_var_max));
    auto near_range = [&](int d, std::vector<int> *out) {
      out->clear ();
      const double r = obs[d].obs.range ();
      for (int k : same[d]) {
        work++;
        const double e = std::hypot (lm_[k].x - s_[0], lm_[k].y - s_[1]) - r;
        if (e * e <= std::pow (slack + std::sqrt (lm_var[k] + var[d]), 2))
          out->push_back (k);
      }
    };
    near_range (i, &cand_i);
    near_range (j, &cand_j);
    /* pairs (cand_i[a], cand_j[b]) in order; the budget is checked
     * before each */
    size_t a = 0, b = 0;
    for (; a < cand_i.size () && work < budget; a++) {
      const int k = cand_i[a];
      for (b = 0; b < cand_j.size () && work < budget; b++) {
        const int l = cand_j[b];
        work++;
        compared++;
        if (k == l)
          continue;
        const double dl = std::hypot (lm_[l].x - lm_[k].x,
            lm_[l].y - lm_[k].y);
        const double v = var[i] + var[j] + lm_var[k] + lm_var[l];
        if ((dz - dl) * (dz - dl) > opt.gate_chi2 * v)
          continue;
        h.pose.heading = wrap_angle (std::atan2 (lm_[l].y - lm_[k].y,
                lm_[l].x - lm_[k].x) - std::atan2 (zj.gy - zi.gy,
                zj.gx - zi.gx));
        const double c = std::cos (h.pose.heading),
            sn = std::sin (h.pose.heading);
        h.pose.x = 0.5 * (lm_[k].x + lm_[l].x - c * (zi.gx + zj.gx)
            + sn * (zi.gy + zj.gy));
        h.pose.y = 0.5 * (lm_[k].y + lm_[l].y - sn * (zi.gx + zj.gx)
            - c * (zi.gy + zj.gy));
        const cv::Vec3d e (h.pose.x - s_[0], h.pose.y - s_[1],
            wrap_angle (h.pose.heading - s_[2]));
        h.d2 = e.dot (Pinv * e);
        /* one the prediction rules out can not be accepted: neither
         * scored nor counted */
        if (!(h.d2 < plausible))
          continue;
        hypotheses++;
        /* the two's heading error grows with the range over their
         * separation */
        h.seeds[0] = i;
        h.seeds[1] = j;
        score (&h, [&](size_t m) {
              return (1 + std::pow (obs[m].obs.range (), 2) * lever)
                  * (var[i] + var[j]);
            });
        /* two detections give one distance to check, weak evidence
         * among repeated colours (a spurious or unmapped one matches
         * some pair by chance): only while the predicted position is
         * known to within their separation */
        if (!(h.inliers >= 3 || (h.inliers == 2 && pos_sigma <= dz)))
          continue;
        /* as many: the nearer the prediction wins; another pairing
         * is a rival */
        const Rival mine { h.pose, var[i] + var[j], lever };
        const bool other = h.assign != best.assign;
        if (h.inliers > best.inliers)
          rivals.clear ();
        if (h.inliers > best.inliers || (h.inliers == best.inliers
                && h.d2 < best.d2)) {
          if (h.inliers == best.inliers && other)
            rivals.push_back ({ best.pose, best_seed_var, best_lever });
          best = h;
          best_seed_var = mine.seed_var;
          best_lever = mine.lever;
        } else if (h.inliers == best.inliers && other) {
          rivals.push_back (mine);
        }
      }
    }
    /* the seed pair's landmark pairs left when the budget ran out (the
     * row cut short, and the rows after it) */
    if (a > 0 && b < cand_j.size ())
      untried += (double) (cand_j.size () - b);
    untried += (double) (cand_i.size () - a) * cand_j.size ();
  }
  for (; s < seeds.size (); s++)
    untried += (double) same[seeds[s].i].size () * same[seeds[s].j].size ();
  const bool complete = untried == 0;
  /* a rival refuses the winner when it places the robot elsewhere: some
   * detection lands beyond the two poses' joint tolerance (each pose's
   * error at that detection, from its seeds' lever); one within is the
   * same place paired a little differently (near-duplicate pairings of
   * one pose), no evidence against it */
  auto elsewhere = [&](const Rival & r) {
    const double cb = std::cos (best.pose.heading),
        sb = std::sin (best.pose.heading), cr = std::cos (r.pose.heading),
        sr = std::sin (r.pose.heading);
    for (size_t m = 0; m < no; m++) {
      const double gx = obs[m].obs.gx, gy = obs[m].obs.gy,
          r2 = obs[m].obs.range () * obs[m].obs.range ();
      const double dx = best.pose.x + cb * gx - sb * gy
          - (r.pose.x + cr * gx - sr * gy),
          dy = best.pose.y + sb * gx + cb * gy
          - (r.pose.y + sr * gx + cr * gy);
      const double tol = opt.gate_chi2 * ((1 + r2 * best_lever)
          * best_seed_var + (1 + r2 * r.lever) * r.seed_var);
      if (dx * dx + dy * dy > tol)
        return true;
    }
    return false;
  };
  const bool ambiguous = std::any_of (rivals.begin (), rivals.end (),
      elsewhere);
  /* the hypotheses not tried, at the rate the compared pairs gave them */
  const double all_hypotheses = hypotheses + untried * (hypotheses + 1)
      / std::max<long> (compared, 1);
  /* the best refitted on all it explains (a rigid fit), scored again
   * with the fit's error in place of the seeds' lever: the tolerance
   * chance is judged at, and the pose accepted */
  if (best.inliers >= 3) {
    double zx = 0, zy = 0, lx = 0, ly = 0, v = 0;
    for (size_t m = 0; m < no; m++)
      if (best.assign[m] >= 0) {
        zx += obs[m].obs.gx;
        zy += obs[m].obs.gy;
        lx += lm_[best.assign[m]].x;
        ly += lm_[best.assign[m]].y;
        v += var[m] + lm_var[best.assign[m]];
      }
    const double nin = best.inliers;
    zx /= nin;
    zy /= nin;
    lx /= nin;
    ly /= nin;
    v /= nin;
    double sc = 0, ss = 0, spread = 0;
    for (size_t m = 0; m < no; m++)
      if (best.assign[m] >= 0) {
        const double ax = obs[m].obs.gx - zx, ay = obs[m].obs.gy - zy,
            bx = lm_[best.assign[m]].x - lx, by = lm_[best.assign[m]].y - ly;
        sc += ax * bx + ay * by;
        ss += ax * by - ay * bx;
        spread += ax * ax + ay * ay;
      }
    Hyp fit = best;
    fit.pose.heading = std::atan2 (ss, sc);
    const double c = std::cos (fit.pose.heading),
        sn = std::sin (fit.pose.heading);
    fit.pose.x = lx - (c * zx - sn * zy);
    fit.pose.y = ly - (sn * zx + c * zy);
    score (&fit, [&](size_t m) {
          return v / nin + v / std::max (spread, 1e-9)
              * (std::pow (obs[m].obs.gx - zx, 2)
                  + std::pow (obs[m].obs.gy - zy, 2));
        });
    /* the refitted pose answers to the prediction as the seeds' did */
    const cv::Vec3d e (fit.pose.x - s_[0], fit.pose.y - s_[1],
        wrap_angle (fit.pose.heading - s_[2]));
    fit.d2 = e.dot (Pinv * e);
    if (fit.inliers < 3 || !(fit.d2 < plausible))
      return false;
    best = fit;
  }
  const double chance = poisson_tail (best.lambda, best.inliers - 2)
      * all_hypotheses;
  if (best.inliers < 2 || ambiguous)
    return false;
  /* two: the prediction's word, taken only when every rival was tried;
   * more: those beyond the seeds unlikely by chance */
  if (best.inliers == 2 ? !complete : chance >= opt.reloc_chance)
    return false;
  *at = best.pose;
  *assign = best.assign;
  return true;
}

namespace {

/* A detection-landmark pairing: innovation, Jacobian, P H'. */
struct Pairing {
  int obs = -1, lm = -1;
  cv::Vec2d nu;
  cv::Mat H;        /* 2 x N */
  int cols[5] = {}; /* H's non-zero columns: the pose's, the landmark's */
  int n_cols = 0;
  cv::Mat PHt;      /* N x 2 */
  cv::Matx22d R;
  double d2 = 0;    /* individual Mahalanobis distance squared */
};

}  // namespace

SlamFrame
Slam::update (const std::vector<SlamObservation> & obs)
{
  SlamFrame f;
  f.match.assign (obs.size (), -1);
  f.reasons.assign (obs.size (), "");
  if (!init_) {
    if (anchored_) {
      /* the given map places the first pose */
      const std::vector<MapPoint> map (lm_.begin (), lm_.end ());
      std::vector<Detection> dets;
      for (const auto & o : obs) {
        Detection d;
        d.class_name = o.class_name;
        d.obs = o.obs;
        dets.push_back (d);
      }
      const LocaliseResult r = localise (map, dets, LocaliseOptions ());
      if (!r.ok) {
        f.why = "no-pose";
        for (auto & s : f.reasons)
          s = "no-pose";
        return f;
      }
      init_pose (r.solution.pose, r.solution.cov);
    } else {
      /* no map: the first pose defines the frame */
      const double zero[9] = { 0 };
      init_pose (Pose2 (), zero);
    }
  }
  const int N = (int) n ();
  cv::Mat P (N, N, CV_64F, p_.data ());

  auto make_pairing = [&](int i, int k, Pairing * pr) {
    const auto & o = obs[i];
    const SlamLandmark & l = lm_[k];
    const int sl = slot_[k];
    const double lx = sl >= 0 ? s_[sl] : l.x, ly = sl >= 0 ? s_[sl + 1] : l.y;
    const double dx = lx - s_[0], dy = ly - s_[1];
    const double q = dx * dx + dy * dy;
    if (q < 1e-12)
      return false;
    const double r = std::sqrt (q);
    const double zr = o.obs.range (), zb = o.obs.bearing ();
    double sr, sb;
    slam_observation_sigmas (o, pass_views_[k] + 1, &sr, &sb);
    pr->obs = i;
    pr->lm = k;
    /* bearing innovation wrapped: a landmark behind the robot is near
     * +-pi and must not look 2 pi away */
    pr->nu = cv::Vec2d (zr - r, wrap_angle (zb -
            wrap_angle (std::atan2 (dy, dx) - s_[2])));
    pr->H = cv::Mat::zeros (2, (int) n (), CV_64F);
    double *h0 = pr->H.ptr<double> (0), *h1 = pr->H.ptr<double> (1);
    h0[0] = -dx / r;
    h0[1] = -dy / r;
    h1[0] = dy / q;
    h1[1] = -dx / q;
    h1[2] = -1;
    pr->cols[0] = 0;
    pr->cols[1] = 1;
    pr->cols[2] = 2;
    pr->n_cols = 3;
    if (sl >= 0) {
      pr->cols[pr->n_cols++] = sl;
      pr->cols[pr->n_cols++] = sl + 1;
      h0[sl] = dx / r;
      h0[sl + 1] = dy / r;
      h1[sl] = -dy / q;
      h1[sl + 1] = dx / q;
    }
    pr->R = cv::Matx22d (sr * sr, 0, 0, sb * sb);
    pr->PHt = jacobian_times (pr->H, P).t ();
    cv::Mat S = pr->H * pr->PHt + cv::Mat (pr->R);
    cv::Mat nu (pr->nu);
    cv::Mat d = nu.t () * S.inv (cv::DECOMP_CHOLESKY) * nu;
    pr->d2 = d.at<double> (0);
    return true;
  };

  /* lost: below, "A lost pose" */
  const bool lost = std::sqrt (std::max (0.0, p_[2 * N + 2]))
      * std::sqrt (opt.gate_chi2) > M_PI;

  /* individually compatible pairings, by class (a lost frame uses none) */
  std::vector<std::vector<Pairing>> cand (obs.size ());
  std::vector<double> min_d2 (obs.size (),
      std::numeric_limits<double>::infinity ());
  for (size_t i = 0; i < obs.size () && !lost; i++) {
    for (size_t k = 0; k < lm_.size (); k++) {
      if (lm_[k].class_name != obs[i].class_name)
        continue;
      Pairing pr;
      if (!make_pairing ((int) i, (int) k, &pr))
        continue;
      min_d2[i] = std::min (min_d2[i], pr.d2);
      if (pr.d2 < opt.gate_chi2)
        cand[i].push_back (std::move (pr));
    }
    std::sort (cand[i].begin (), cand[i].end (),
        [](const Pairing & a, const Pairing & b) { return a.d2 < b.d2; });
  }

  /* joint NIS of a set of pairings */
  auto joint_nis = [&](const std::vector<const Pairing *> &h) {
    const int m = (int) h.size ();
    cv::Mat S (2 * m, 2 * m, CV_64F), nu (2 * m, 1, CV_64F);
    for (int a = 0; a < m; a++) {
      nu.at<double> (2 * a) = h[a]->nu[0];
      nu.at<double> (2 * a + 1) = h[a]->nu[1];
      const Pairing & pa = *h[a];
      for (int b = 0; b < m; b++) {
        /* H_a P H_b^T over H_a's non-zero columns */
        for (int r = 0; r < 2; r++)
          for (int c = 0; c < 2; c++) {
            double v = a == b ? pa.R (r, c) : 0;
            for (int t = 0; t < pa.n_cols; t++)
              v += pa.H.at<double> (r, pa.cols[t])
                  * h[b]->PHt.at<double> (pa.cols[t], c);
            S.at<double> (2 * a + r, 2 * b + c) = v;
          }
      }
    }
    cv::Mat d = nu.t () * S.inv (cv::DECOMP_CHOLESKY) * nu;
    return d.at<double> (0);
  };

  /* JCBB: most pairings, then least joint NIS */
  std::vector<const Pairing *> best, cur;
  double best_nis = 0;
  int nodes = 0;
  std::vector<bool> used (lm_.size (), false);
  /* the joint gate for m pairings, kept while the probability stays */
  if (joint_gate_p_ != opt.joint_probability) {
    joint_gate_.assign (1, 0);
    joint_gate_p_ = opt.joint_probability;
  }
  while (joint_gate_.size () <= obs.size ())
    joint_gate_.push_back (chi2_quantile (opt.joint_probability,
            2 * (int) joint_gate_.size ()));
  const std::vector<double> & thresholds = joint_gate_;
  std::function<void (size_t, double)> search = [&](size_t i, double nis) {
    if (++nodes > opt.max_jcbb_nodes)
      return;
    if (i == obs.size ()) {
      if (cur.size () > best.size () || (cur.size () == best.size ()
              && nis < best_nis)) {
        best = cur;
        best_nis = nis;
      }
      return;
    }
    size_t remaining = 0;
    for (size_t j = i; j < obs.size (); j++)
      remaining += cand[j].empty ()? 0 : 1;
    if (cur.size () + remaining < best.size ())
      return;
    for (const Pairing & pr : cand[i]) {
      if (used[pr.lm])
        continue;
      cur.push_back (&pr);
      const double d = joint_nis (cur);
      if (d < thresholds[cur.size ()]) {
        used[pr.lm] = true;
        search (i + 1, d);
        used[pr.lm] = false;
      }
      cur.pop_back ();
    }
    /* leave detection i unpaired */
    if (cur.size () + remaining - (cand[i].empty ()? 0 : 1) >= best.size ())
      search (i + 1, nis);
  };
  if (!lost)
    search (0, 0);

  /* A lost pose: the heading so uncertain (after a turn bridged on no
   * landmark) that the gate's bearing span, +-sqrt(gate) sigma, is the
   * whole circle. Any landmark of the colour at about the right range
   * then passes it, so a pairing carries no evidence that it is the same
   * landmark (a yellow disc never seen would pair with the one yellow
   * landmark mapped a metre away), and one linearised step from that far
   * off leaves the pose degrees wrong while its covariance says one.
   * Pair only what relocalisation on two or more landmarks finds, and
   * linearise the update at that pose. */
  const std::vector<double> prior = s_;
  std::vector<Pairing> found;
  if (lost) {
    Pose2 at;
    std::vector<int> assign;
    if (relocalise (obs, &at, &assign)) {
      s_[0] = at.x;
      s_[1] = at.y;
      s_[2] = at.heading;
      found.reserve (obs.size ());
      for (size_t i = 0; i < obs.size (); i++) {
        Pairing pr;
        if (assign[i] >= 0 && make_pairing ((int) i, assign[i], &pr))
          found.push_back (std::move (pr));
      }
      for (const Pairing & pr : found)
        best.push_back (&pr);
      best_nis = best.empty ()? 0 : joint_nis (best);
      if (best.empty ())
        s_ = prior;             /* nothing to update with: as predicted */
    }
  }

  /* the update over the jointly compatible set, linearised where the
   * pairings were made: x0 + K (z - h(x) - H (x0 - x)), x the predicted
   * state x0 or the relocalised one */
  if (!best.empty ()) {
    const int m = (int) best.size ();
    cv::Mat H (2 * m, N, CV_64F), R = cv::Mat::zeros (2 * m, 2 * m, CV_64F),
        nu (2 * m, 1, CV_64F), dev (N, 1, CV_64F);
    for (int a = 0; a < m; a++) {
      best[a]->H.copyTo (H.rowRange (2 * a, 2 * a + 2));
      cv::Mat (best[a]->R).copyTo (R (cv::Rect (2 * a, 2 * a, 2, 2)));
      nu.at<double> (2 * a) = best[a]->nu[0];
      nu.at<double> (2 * a + 1) = best[a]->nu[1];
    }
    for (int i = 0; i < N; i++)
      dev.at<double> (i) = prior[i] - s_[i];
    dev.at<double> (2) = wrap_angle (dev.at<double> (2));
    const cv::Mat HP = jacobian_times (H, P);
    const cv::Mat PHt = HP.t ();
    cv::Mat S = H * PHt + R;
    cv::Mat Sinv = S.inv (cv::DECOMP_CHOLESKY);
    cv::Mat K = PHt * Sinv;
    cv::Mat dx = K * (nu - H * dev);
    for (int i = 0; i < N; i++)
      s_[i] = prior[i] + dx.at<double> (i);
    s_[2] = wrap_angle (s_[2]);
    /* the Joseph form, (I - K H) P (I - K H)^T + K R K^T: an error in K
     * changes P only at second order. Expanded, P - K (H P) - (H P)^T K^T
     * + K S K^T, it costs N^2 times the measurements instead of N^3 and
     * is positive up to rounding (a difference, not a sum of positive
     * terms) */
    joseph_update (p_.data (), K, HP, S);
    /* a relocalised frame's innovation is the relocalisation's, not the
     * prediction's: no evidence of the slip */
    slip_evidence (H, lost ? cv::Mat () : Sinv, R, nu, K);
    f.joint_nis = best_nis;
    for (const Pairing *pr : best) {
      f.match[pr->obs] = pr->lm;
      f.n_matched++;
    }
  }
  sync_landmarks ();

  /* views, confirmation, the unseen count. Confirmed = exists (paired in
   * confirm_views frames: a spurious blob rarely recurs inside the gate)
   * and is known (position sigma at most confirm_sigma). Range and bearing
   * fix a landmark from one pose, so no baseline is needed for its
   * geometry. A landmark once confirmed stays so. */
  const Pose2 now = pose ();
  for (size_t k = 0; k < lm_.size (); k++) {
    bool seen = false;
    for (int mi : f.match)
      seen |= mi == (int) k;
    if (!seen) {
      unseen_[k]++;
      continue;
    }
    /* a pass ends when the landmark has been out of sight a while: the
     * blob is then cut another way (slam_observation_sigmas) */
    if (unseen_[k] > kPassGap)
      pass_views_[k] = 0;
    pass_views_[k]++;
    unseen_[k] = 0;
    if (std::hypot (now.x - last_view_[k].x, now.y - last_view_[k].y)
        >= opt.confirm_baseline) {
      lm_[k].views++;
      last_view_[k] = now;
    }
  }
  confirm_known ();

  /* residuals of the matched, with the updated pose */
  double sum = 0;
  for (size_t i = 0; i < obs.size (); i++) {
    if (f.match[i] < 0)
      continue;
    const auto & l = lm_[f.match[i]];
    double gx, gy;
    world_to_robot (now, l.x, l.y, &gx, &gy);
    sum += std::pow (gx - obs[i].obs.gx, 2) + std::pow (gy - obs[i].obs.gy, 2);
  }
  f.residual = f.n_matched ? std::sqrt (sum / f.n_matched) : 0;

  /* new landmarks: unmatched and far from every landmark of the class */
  for (size_t i = 0; i < obs.size (); i++) {
    if (f.match[i] >= 0)
      continue;
    double wx, wy;
    robot_to_world (pose (), obs[i].obs.gx, obs[i].obs.gy, &wx, &wy);
    bool near = false;
    for (const auto & l : lm_)
      near |= l.class_name == obs[i].class_name
          && std::hypot (l.x - wx, l.y - wy) < opt.min_separation;
    if (near) {
      f.reasons[i] = "ambiguous";
      continue;
    }
    /* A landmark starts from the pose: its position is off by
     * r (1 - cos e) ~ r e^2 / 2 for a heading error e, which the
     * linearised covariance leaves out. What matters is the heading's
     * error relative to the map the landmark joins: with the heading's
     * sigma at tens of degrees relative to the mapped landmarks (after a
     * turn bridged on no landmark) that is decimetres at 2 m, the copy
     * would be confirmed where the pose was wrong and later pull the
     * pose there. Wait until that error is within the map accuracy asked
     * for (confirm_sigma). The heading's error relative to the start is
     * no reason: without anchors, a heading error shared by the pose and
     * the map is a turn of the free frame (a robot that drove 7 m before
     * its first landmark, 20 degrees off the start, still maps; its
     * covariance holds that turn to first order). Tested before the
     * gates below, which cost a pairing per landmark of the class (on a
     * lost frame among many, most of its time) */
    if (0.5 * obs[i].obs.range () * heading_var_to_map ()
        > opt.confirm_sigma) {
      f.reasons[i] = "uncertain-heading";
      continue;
    }
    double d2 = std::numeric_limits<double>::infinity ();
    {
      const int N2 = (int) n ();
      P = cv::Mat (N2, N2, CV_64F, p_.data ());
      for (size_t k = 0; k < lm_.size (); k++) {
        if (lm_[k].class_name != obs[i].class_name)
          continue;
        Pairing pr;
        if (make_pairing ((int) i, (int) k, &pr))
          d2 = std::min (d2, pr.d2);
        else
          d2 = 0;
      }
    }
    if (d2 < opt.new_chi2) {
      f.reasons[i] = "ambiguous";
      continue;
    }
    if (lm_.size () >= opt.max_landmarks) {
      f.reasons[i] = "map-full";
      continue;
    }
    if (!anchored_ && std::none_of (slot_.begin (), slot_.end (),
            [](int sl) { return sl >= 0; }))
      rebase ();
    SlamLandmark l;
    l.class_name = obs[i].class_name;
    l.z = obs[i].marker_z;
    l.diameter = obs[i].marker_diameter;
    l.ball = obs[i].marker_ball;
    add_landmark (obs[i], l);
    f.match[i] = (int) lm_.size () - 1;
    f.reasons[i] = "new-landmark";
    f.n_new++;
    sync_landmarks ();
  }
  confirm_known ();

  /* landmarks that never showed they exist, unseen too long: a spurious
   * detection. One that exists but is not known well enough stays, to be
   * confirmed when seen again (a loop closing shrinks it). */
  for (size_t k = lm_.size (); k-- > 0;) {
    if (!lm_[k].confirmed && !lm_[k].anchor
        && lm_[k].views < opt.confirm_views
        && unseen_[k] > opt.tentative_frames) {
      for (auto & mi : f.match)
        if (mi > (int) k)
          mi--;
      remove_landmark (k);
    }
  }
  sync_landmarks ();
  f.ok = true;
  return f;
}

}  // namespace landmark
