/* The robot pose filtered over time: a constant-velocity EKF updated with
 * range-bearing observations of mapped landmarks or with whole poses
 * (docs/positioning.md, trilaterate filter=ekf). No GStreamer types. */
#pragma once

#include <vector>

#include "posesolver.h"

namespace landmark {

/* State x, y, heading, vx, vy, omega (world frame). */
class PoseFilter {
public:
  double accel_sigma = 1.0;     /* m/s^2, process noise */
  double alpha_sigma = 3.0;     /* rad/s^2 */

  bool initialised () const { return init_; }
  void reset () { init_ = false; }
  void init (const Pose2 & p, const double cov[9]);
  void predict (double dt);
  /* Range-bearing update with matched correspondences (Mahalanobis-gated
   * per measurement at `gate_chi2`); returns how many were used. */
  int update (const std::vector<Correspondence> & cs,
      double gate_chi2 = 16.0);
  /* A direct pose measurement (used when a solver gave one). */
  void update_pose (const Pose2 & p, const double cov[9]);
  Pose2 pose () const;
  void pose_cov (double cov[9]) const;

private:
  bool init_ = false;
  double s_[6] = { 0 };
  double p_[36] = { 0 };
};

}  // namespace landmark
