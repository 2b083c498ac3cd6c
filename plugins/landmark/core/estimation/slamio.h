/* Files of landmark SLAM (docs/landmarkslam.md): the odometry log it reads
 * and the map it writes. No GStreamer types. */
#pragma once

#include <string>
#include <vector>

#include "slam.h"

namespace landmark {

/* One odometry line: the robot-frame motion (forward, left, turn) from the
 * previous line's time to `t` (seconds of stream time). */
struct OdometryStep {
  double t = 0;
  double dx = 0, dy = 0, dheading = 0;
};

/* Robot-frame increments composed in order: the motion over all of them
 * (the odometry between two frames, from a file or live from the
 * application). */
struct OdometrySum {
  double dx = 0, dy = 0, dheading = 0;
  void add (double step_dx, double step_dy, double step_dheading);
};

/* Bounds on a log: a run of hours at 100 Hz. */
constexpr size_t kMaxOdometrySteps = 10000000;

/* Parses JSON lines {"t": s, "dx": m, "dy": m, "dheading": rad} (dy
 * optional, blank lines skipped); times must not go backwards. Errors
 * start with `source` and name the line. */
bool odometry_parse (const std::string & text, const std::string & source,
    std::vector<OdometryStep> * out, std::string * error);
bool odometry_load_file (const std::string & path,
    std::vector<OdometryStep> * out, std::string * error);

/* The increment from time a (exclusive) to b (inclusive), steps composed
 * in the robot frame; *next is the index to start from next time. */
void odometry_between (const std::vector<OdometryStep> & steps, double a,
    double b, size_t * next, double *dx, double *dy, double *dheading);

/* The map JSON of docs/conventions.md: anchors and confirmed landmarks
 * (tentative ones are left out), with `covariance` and `views` as extra
 * keys that map readers ignore. */
std::string slam_map_json (const std::vector<SlamLandmark> & landmarks);

/* Writes text to path atomically (a reader never sees half a map); errors
 * name the path. */
bool slam_write_file (const std::string & path, const std::string & text,
    std::string * error);

}  // namespace landmark
