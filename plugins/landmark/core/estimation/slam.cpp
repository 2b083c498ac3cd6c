/* The landmark SLAM filter (slam.h): its state and covariance, the
 * prediction by the motion model or the odometry, the update over a
 * frame's pairings, and what the innovations show of the odometry's slip.
 * update () runs a frame's steps: the pairings are slamassociation.cpp's,
 * the landmarks' bookkeeping slamlandmarks.cpp's. */
#include "slam.h"
#include "slaminternal.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace landmark {

namespace {

/* x y th, forward speed v, camera offset d, turn rate w, then the
 * odometry's scale error (its distance over the
 * true one, minus 1) and heading drift (rad per metre) */
constexpr int kPose = 8;
constexpr int kScale = 6, kDrift = 7;
/* the odometry's scale error is a few per cent; a filter that drove it
 * near -1 would divide by zero */
constexpr double kMaxScaleError = 0.5;

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

/* H M, row by row over H's non-zero entries (slaminternal.h) */
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
  reloc_pending_ = RelocPending ();
  slot_.assign (lm_.size (), -1);
  last_view_.assign (lm_.size (), Pose2 ());
  unseen_.assign (lm_.size (), 0);
  pass_views_.assign (lm_.size (), 0);
  bias_slot_.assign (lm_.size (), -1);
  bias_left_.assign (lm_.size (), 1);
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
  /* a ground robot driving along its heading (core/estimation/groundmotion.h); the
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
  decay_biases ((std::fabs (s_[3]) + std::fabs (s_[5])) * dt);
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
  decay_biases (d + std::fabs (dth));
  if (dt > 0) {
    /* the speed and turn rate follow the odometry, for a later
     * constant-velocity prediction */
    s_[3] = dx / dt;
    s_[5] = dth / dt;
  }
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

/* One frame of observations: the first pose, the pairings (each within
 * its gate, then the jointly compatible set, or a lost pose relocalised),
 * the filter's update over them, then the landmarks' views, the new
 * landmarks and the dropped ones. */
SlamFrame
Slam::update (const std::vector<SlamObservation> & obs)
{
  SlamFrame f;
  frame_no_++;
  f.match.assign (obs.size (), -1);
  f.reasons.assign (obs.size (), "");
  if (!init_ && !place_first_pose (obs, f))
    return f;
  const int N = (int) n ();
  cv::Mat P (N, N, CV_64F, p_.data ());

  /* lost: "A lost pose", pair_relocalised () */
  const bool lost = std::sqrt (std::max (0.0, p_[2 * N + 2]))
      * std::sqrt (opt.gate_chi2) > M_PI;

  /* individually compatible pairings, by class, then the jointly
   * compatible set (a lost frame uses none) */
  std::vector<std::vector<Pairing>> cand (obs.size ());
  std::vector<const Pairing *> best;
  double best_nis = 0;
  if (!lost) {
    gate_pairings (obs, P, cand);
    best_nis = jcbb (cand, best);
  }

  std::vector<double> prior = s_;
  std::vector<Pairing> found, with_bias;
  if (lost)
    best_nis = pair_relocalised (obs, P, prior, found, best);

  if (!best.empty ()) {
    attach_biases (obs, best, with_bias, prior);
    const int N2 = (int) n ();
    filter_update (best, prior, cv::Mat (N2, N2, CV_64F, p_.data ()), lost);
    f.joint_nis = best_nis;
    for (const Pairing *pr : best) {
      f.match[pr->obs] = pr->lm;
      f.n_matched++;
    }
  }
  sync_landmarks ();

  count_views (f);
  drop_biases ();
  confirm_known ();
  f.residual = matched_residual (obs, f);
  start_landmarks (obs, f);
  confirm_known ();
  drop_unseen (f);
  sync_landmarks ();
  f.ok = true;
  return f;
}

/* The first pose of a filter without one: where the given map places it
 * (false when it does not, every observation's reason "no-pose"), or the
 * frame's origin without a map. */
bool
Slam::place_first_pose (const std::vector<SlamObservation> & obs,
    SlamFrame & f)
{
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
    if (!r.ok && !first_pose_relocalised (obs)) {
      f.why = "no-pose";
      for (auto & s : f.reasons)
        s = "no-pose";
      return false;
    }
    if (r.ok)
      init_pose (r.solution.pose, r.solution.cov);
  } else {
    /* no map: the first pose defines the frame */
    const double zero[9] = { 0 };
    init_pose (Pose2 (), zero);
  }
  return true;
}

/* The paired landmarks' slow errors as states before the update (each
 * appended uncorrelated, the pairings then made again over the grown
 * state, into store; prior grown alike) */
void
Slam::attach_biases (const std::vector<SlamObservation> & obs,
    std::vector<const Pairing *> & best, std::vector<Pairing> & store,
    std::vector<double> & prior)
{
  if (!slow_errors ())
    return;
  bool grown = false;
  for (const Pairing *pr : best)
    if (bias_slot_[pr->lm] < 0) {
      add_bias ((size_t) pr->lm);
      grown = true;
    }
  if (!grown)
    return;
  prior.resize (n (), 0);
  const int N = (int) n ();
  const cv::Mat P (N, N, CV_64F, p_.data ());
  store.assign (best.size (), Pairing ());
  for (size_t a = 0; a < best.size (); a++) {
    make_pairing (obs, best[a]->obs, best[a]->lm, P, &store[a]);
    best[a] = &store[a];
  }
}

/* The update over the jointly compatible set, linearised where the
 * pairings were made: x0 + K (z - h(x) - H (x0 - x)), x the predicted
 * state x0 or the relocalised one */
void
Slam::filter_update (const std::vector<const Pairing *> & best,
    const std::vector<double> & prior, const cv::Mat & P, bool relocalised)
{
  const int N = (int) n ();
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
  slip_evidence (H, relocalised ? cv::Mat () : Sinv, R, nu, K);
}

}  // namespace landmark
