/* trilaterate frame by frame (docs/trilaterate.md): the prior (the
 * previous pose, or the EKF's prediction), association and solution
 * (localise), the EKF's update or restart, and what is reported. No
 * GStreamer types: tested on its own (suite 'core').
 *
 * A one-landmark pose needs a measured heading: the `heading` property
 * (a compass) or, with the EKF, the filter's prediction with its own
 * growing uncertainty. The previous pose's heading (filter=none) is not
 * one: it goes stale as the robot turns, and each pose made with it would
 * keep it alive. Without one there is no pose; a detection of a colour the
 * map holds once is still that landmark (matched by colour). */
#pragma once

#include <string>
#include <vector>

#include "posefilter.h"
#include "posesolver.h"

namespace landmark {

/* A pose as the pose meta and the landmark-pose message carry it. */
struct PoseFields {
  Pose2 pose;
  double cov[9] = { 0 };                /* row-major over x, y, heading */
  std::vector<std::string> ids;         /* map ids of the landmarks used */
  double residual = 0;                  /* metres, RMS */
  std::string solver, geometry = "ok", filter;
};

struct PoseTrackerOptions {
  bool ekf = false;
  /* a measured heading (radians, one-sigma radians) for one landmark */
  bool have_heading = false;
  double heading = 0, heading_sigma = 0.035;
  double gate = 0.5;                    /* metres */
  double inlier_distance = 0.25;        /* metres */
  double max_age = 1.0;                 /* seconds */
};

struct TrackedFrame {
  bool ok = false;                      /* a pose */
  std::string why;                      /* when not: the reason */
  PoseFields pose;
  /* per detection: match, matched_by, reasons, residual */
  LocaliseResult res;
};

class PoseTracker {
public:
  PoseFilter ekf;                       /* filter=ekf */

  /* forgets the previous pose and the filter (new map, stream start) */
  void reset ();
  /* forgets the filter only (filter changed) */
  void reset_filter ();
  /* One frame at time t (seconds, increasing). */
  TrackedFrame step (const std::vector<MapPoint> & map,
      const std::vector<Detection> & dets, double t,
      const PoseTrackerOptions & opt);

private:
  bool fresh (double since, double now, double max_age) const;
  /* the previous pose (filter=none) */
  bool have_last_ = false;
  Pose2 last_;
  double last_time_ = 0;
  /* filter=ekf */
  bool have_ekf_time_ = false;
  double ekf_time_ = 0;                 /* the state's time */
  double ekf_measured_ = 0;             /* its last update */
};

}  // namespace landmark
