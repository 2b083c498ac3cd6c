/* The constant-velocity motion of a ground robot, for the pose filters
 * (trilaterate filter=ekf, landmarkslam without odometry;
 * docs/trilaterate.md, docs/landmarkslam.md "Motion").
 *
 * A wheeled robot drives along its heading: its wheels do not slide
 * sideways, so a turn changes the direction of travel together with the
 * heading and needs no acceleration to explain it. The pose is the
 * camera's, which sits a distance d ahead of the turning centre and so
 * swings out at w d across the heading on turns. No GStreamer types. */
#pragma once

namespace landmark {

/* The motion states, first in each filter's state vector: camera
 * position (m) and heading (rad) in the map frame, forward speed (m/s),
 * the camera's offset ahead of the turning centre (m), turn rate
 * (rad/s). */
enum GroundMotionState {
  kMotionX, kMotionY, kMotionHeading, kMotionSpeed, kMotionOffset,
  kMotionTurnRate, kMotionStates
};

/* White-noise intensities at the bounds of what a small robot does. */
struct GroundMotionNoise {
  double accel_sigma = 1.0;       /* m/s^2, along the heading */
  double alpha_sigma = 3.0;       /* rad/s^2, change of the turn rate */
  double lateral_sigma = 0.1;     /* m/s^2, slip across the heading */
  double offset_drift = 0.001;    /* m/sqrt(s): the offset is fixed */
};

/* One prediction over dt seconds of the motion states s (kMotionStates
 * values): the predicted states, their Jacobian F and the process noise
 * Q (both kMotionStates^2, row-major), so that a filter's covariance
 * block becomes F P F^T + Q. */
struct GroundMotionStep {
  double s[kMotionStates];
  double F[kMotionStates * kMotionStates];
  double Q[kMotionStates * kMotionStates];
};

GroundMotionStep ground_motion_predict (const double s[kMotionStates],
    double dt, const GroundMotionNoise & noise);

}  // namespace landmark
