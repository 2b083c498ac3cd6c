/* The robot pose filtered over time: an EKF with a ground robot's
 * constant-velocity motion (groundmotion.h) updated with range-bearing
 * observations of mapped landmarks or with whole poses
 * (docs/positioning.md, trilaterate filter=ekf). No GStreamer types. */
#pragma once

#include <vector>

#include "groundmotion.h"
#include "posesolver.h"

namespace landmark {

/* State: the camera's x, y, heading (map frame), the robot's forward
 * speed, the camera's offset ahead of the turning centre and the turn
 * rate (GroundMotionState order). */
class PoseFilter {
public:
  GroundMotionNoise motion;       /* process noise */
  /* priors of the motion states at (re)start: unknown speed and turn
   * rate within a robot's few m/s and rad/s; the offset 0 +- 0.1 m */
  double speed_sigma = 1.0;       /* m/s */
  double turn_rate_sigma = 2.0;   /* rad/s */
  double offset_sigma = 0.1;      /* m */

  bool initialised () const { return init_; }
  void reset () { init_ = false; }
  void init (const Pose2 & p, const double cov[9]);
  void predict (double dt);
  /* Range-bearing update with matched correspondences (Mahalanobis-gated
   * per measurement at `gate_chi2`); returns how many were used. */
  int update (const std::vector<Correspondence> & cs,
      double gate_chi2 = 16.0);
  /* Whether a solution from three or more landmarks (`cs` its pairings)
   * shows the filter lost: it disagrees with the prediction (chi-square,
   * 3 dof, 99.9 %) and half of its pairings or more fail the gate of a
   * trial sequential update. When more pass, the solution is the one off (a biased range pulling
   * the least squares, its covariance too small). */
  bool lost (const PoseSolution & sol,
      const std::vector<Correspondence> & cs) const;
  /* A direct pose measurement (used when a solver gave one). */
  void update_pose (const Pose2 & p, const double cov[9]);
  Pose2 pose () const;
  void pose_cov (double cov[9]) const;

private:
  bool init_ = false;
  static constexpr int N = kMotionStates;
  double s_[N] = { 0 };
  double p_[N * N] = { 0 };
};

}  // namespace landmark
