/* The pose EKF with a ground robot's motion: see posefilter.h and
 * docs/positioning.md. */
#include "posefilter.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace landmark {

void
PoseFilter::init (const Pose2 & p, const double cov[9])
{
  std::fill (s_, s_ + N, 0.0);
  std::fill (p_, p_ + N * N, 0.0);
  s_[kMotionX] = p.x;
  s_[kMotionY] = p.y;
  s_[kMotionHeading] = p.heading;
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++)
      p_[r * N + c] = cov[r * 3 + c];
  p_[kMotionSpeed * N + kMotionSpeed] = speed_sigma * speed_sigma;
  p_[kMotionOffset * N + kMotionOffset] = offset_sigma * offset_sigma;
  p_[kMotionTurnRate * N + kMotionTurnRate] =
      turn_rate_sigma * turn_rate_sigma;
  init_ = true;
}

void
PoseFilter::predict (double dt)
{
  if (!init_ || !(dt > 0))
    return;
  const GroundMotionStep step = ground_motion_predict (s_, dt, motion);
  const cv::Matx<double, N, N> F (step.F), Q (step.Q), P (p_);
  const cv::Matx<double, N, N> predicted = F * P * F.t () + Q;
  std::copy (step.s, step.s + N, s_);
  std::copy (predicted.val, predicted.val + N * N, p_);
}

/* The Kalman correction of state s and covariance p (P, as a matrix) by
 * a measurement of M values: innovation innov, Jacobian H, noise R and the
 * inverse innovation covariance Si. Joseph form keeps P symmetric and
 * positive. */
template <int M, int N = kMotionStates>
static void
kalman_correct (double s[N], double p[N * N], const cv::Matx<double, N, N> & P,
    const cv::Matx<double, M, N> & H, const cv::Matx<double, M, M> & R,
    const cv::Matx<double, M, M> & Si, const cv::Vec<double, M> & innov)
{
  const cv::Matx<double, N, M> K = P * H.t () * Si;
  const cv::Vec<double, N> ds = K * innov;
  for (int i = 0; i < N; i++)
    s[i] += ds[i];
  s[kMotionHeading] = wrap_angle (s[kMotionHeading]);
  const cv::Matx<double, N, N> IKH = cv::Matx<double, N, N>::eye () - K * H;
  const cv::Matx<double, N, N> corrected = IKH * P * IKH.t () + K * R * K.t ();
  for (int i = 0; i < N * N; i++)
    p[i] = corrected.val[i];
}

int
PoseFilter::update (const std::vector<Correspondence> & cs, double gate_chi2)
{
  if (!init_)
    return 0;
  int used = 0;
  for (const auto & c : cs) {
    /* sequential updates: one landmark's range and bearing at a time */
    const double dx = c.lx - s_[kMotionX], dy = c.ly - s_[kMotionY];
    const double r2 = dx * dx + dy * dy;
    if (r2 < 1e-12)
      continue;
    const double r = std::sqrt (r2);
    cv::Matx<double, 2, N> H = cv::Matx<double, 2, N>::zeros ();
    H (0, kMotionX) = -dx / r;
    H (0, kMotionY) = -dy / r;
    H (1, kMotionX) = dy / r2;
    H (1, kMotionY) = -dx / r2;
    H (1, kMotionHeading) = -1;
    const cv::Vec2d innov (c.obs.range () - r,
        wrap_angle (c.obs.bearing () - (std::atan2 (dy, dx) - s_[kMotionHeading])));
    const double sr = c.obs.range_sigma_used ();
    const double sb = c.obs.bearing_sigma_used ();
    const cv::Matx22d R (sr * sr, 0, 0, sb * sb);
    cv::Matx<double, N, N> P (p_);
    const cv::Matx22d S = H * P * H.t () + R;
    cv::Matx22d Si;
    if (cv::invert (S, Si, cv::DECOMP_CHOLESKY) == 0)
      continue;
    const double m2 = innov.dot (Si * innov);
    if (!(m2 <= gate_chi2))
      continue;
    kalman_correct (s_, p_, P, H, R, Si, innov);
    used++;
  }
  return used;
}

bool
PoseFilter::lost (const PoseSolution & sol,
    const std::vector<Correspondence> & cs) const
{
  if (!init_)
    return false;
  cv::Matx33d c;
  pose_cov (c.val);
  const Pose2 p = pose ();
  const cv::Vec3d d (sol.pose.x - p.x, sol.pose.y - p.y,
      wrap_angle (sol.pose.heading - p.heading));
  cv::Matx33d Si;
  if (cv::invert (c + cv::Matx33d (sol.cov), Si, cv::DECOMP_SVD) == 0
      || d.dot (Si * d) <= 16.27)
    return false;
  PoseFilter tested = *this;
  return 2 * (size_t) tested.update (cs) <= cs.size ();
}

void
PoseFilter::update_pose (const Pose2 & p, const double cov[9])
{
  if (!init_) {
    init (p, cov);
    return;
  }
  cv::Matx<double, 3, N> H = cv::Matx<double, 3, N>::zeros ();
  H (0, kMotionX) = H (1, kMotionY) = H (2, kMotionHeading) = 1;
  const cv::Matx33d R (cov);
  cv::Matx<double, N, N> P (p_);
  const cv::Matx33d S = H * P * H.t () + R;
  cv::Matx33d Si;
  if (cv::invert (S, Si, cv::DECOMP_SVD) == 0)
    return;
  const cv::Vec3d innov (p.x - s_[kMotionX], p.y - s_[kMotionY],
      wrap_angle (p.heading - s_[kMotionHeading]));
  kalman_correct (s_, p_, P, H, R, Si, innov);
}

Pose2
PoseFilter::pose () const
{
  Pose2 p;
  p.x = s_[kMotionX];
  p.y = s_[kMotionY];
  p.heading = wrap_angle (s_[kMotionHeading]);
  return p;
}

void
PoseFilter::pose_cov (double cov[9]) const
{
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++)
      cov[r * 3 + c] = p_[r * N + c];
}

}  // namespace landmark
