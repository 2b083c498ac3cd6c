/* Robot pose from landmark observations (docs/positioning.md): data
 * association by class with a gate, and three solvers chosen by how many
 * landmarks are matched:
 *
 * - one landmark with a known heading (seed eq. 3.7-3.8 inverted);
 * - two landmarks: two-circle intersection, the bearings choosing between
 *   the two intersections and giving the heading (seed section 3.4.3);
 * - three or more: consensus over landmark pairs, then iteratively
 *   reweighted (Huber) Gauss-Newton over all ranges and bearings.
 *
 * Plus a constant-velocity extended Kalman filter that takes the same range
 * and bearing measurements. No GStreamer types: tested on its own (suite
 * 'core'). Frames and units follow docs/conventions.md: world frame x, y,
 * heading counter-clockwise from +x; robot frame x forward, y left; bearing
 * positive to the left; metres and radians. */
#pragma once

#include <string>
#include <vector>

#include "landmarkmap.h"

namespace landmark {

struct Pose2 {
  double x = 0, y = 0, heading = 0;
};

/* One landmark seen from the robot: its robot-frame position (ground-x
 * forward, ground-y left) and one-sigma range and bearing errors. range and
 * bearing follow from gx, gy. */
struct RangeBearing {
  double gx = 0, gy = 0;
  double range_sigma = 0, bearing_sigma = 0;   /* <= 0: defaults */
  double range () const;
  double bearing () const;
  /* the sigmas used as weights: the defaults where unset, and never below
   * a floor, so that zero never means infinite confidence */
  double range_sigma_used () const;
  double bearing_sigma_used () const;
};

/* A matched observation: what was seen and the map position it is. */
struct Correspondence {
  RangeBearing obs;
  double lx = 0, ly = 0;       /* landmark position on the map */
};

/* How the geometry of a solution is conditioned. */
enum class Geometry {
  Ok,
  CollinearLandmarks,   /* three or more landmarks on one line */
  RobotOnBaseline,      /* two landmarks: robot on the segment between them */
  RobotInLine,          /* two landmarks: robot on their line, outside */
};
const char *geometry_name (Geometry g);

struct PoseSolution {
  bool ok = false;
  Pose2 pose;
  double cov[9] = { 0 };        /* x, y, heading; row-major */
  const char *solver = "";      /* "one", "two", "lsq" */
  Geometry geometry = Geometry::Ok;
  double residual = 0;          /* RMS position residual of the used, m */
  std::vector<double> residuals;   /* per correspondence, metres */
  std::vector<bool> inlier;        /* per correspondence */
  std::string why;              /* when !ok */
};

/* Default one-sigma errors when an observation gives none. */
double default_range_sigma (double range);
double default_bearing_sigma ();

/* Predicted robot-frame position of a map point seen from pose. */
void world_to_robot (const Pose2 & pose, double lx, double ly, double *gx,
    double *gy);
void robot_to_world (const Pose2 & pose, double gx, double gy, double *wx,
    double *wy);
double wrap_angle (double a);

/* Position error between what c observed and where pose predicts it, m. */
double correspondence_residual (const Pose2 & pose, const Correspondence & c);

/* One landmark, heading known (one-sigma heading_sigma, radians). */
PoseSolution solve_one (const Correspondence & c, double heading,
    double heading_sigma);

/* Two landmarks: two-circle intersection; the bearings choose the
 * intersection and give the heading; then refined over the four
 * measurements (ranges and bearings) for the covariance. Circles that miss
 * by less than `slack` metres (noise) meet at their closest points. */
PoseSolution solve_two (const Correspondence & a, const Correspondence & b,
    double slack = 0.1);

struct LsqOptions {
  double huber_k = 2.0;         /* Huber threshold, in sigmas */
  double inlier_gate = 0.25;    /* metres: consensus inlier distance */
  int max_iterations = 30;
};

/* Three or more: consensus over the pairs (two-circle hypotheses, the one
 * with most inliers within inlier_gate, then least truncated cost), then
 * Huber-weighted Gauss-Newton over ranges and bearings of the inliers. */
PoseSolution solve_many (const std::vector<Correspondence> & cs,
    const LsqOptions & opt = LsqOptions ());

/* Gauss-Newton from a starting pose over the given correspondences (all
 * used), with Huber weights; fills pose, cov, residuals. */
bool refine_pose (const std::vector<Correspondence> & cs, Pose2 * pose,
    double cov[9], double huber_k, int max_iterations);

/* Three or more landmark positions within `tol` (relative) of one line. */
bool landmarks_collinear (const std::vector<Correspondence> & cs,
    double tol = 0.02);

/* ---- association and the whole frame ------------------------------- */

/* A landmark of the map file, with its marker (`z`, `diameter`, `kind`). */
using MapPoint = MapLandmark;

struct Detection {
  std::string class_name;
  RangeBearing obs;
  /* the marker the range assumed, when the class has several (ipmrange's
   * marker-kind, -height, -diameter): only landmarks with that marker are
   * candidates */
  bool has_marker = false;
  double marker_z = 0, marker_diameter = 0;
  bool marker_ball = false;
};

struct LocaliseOptions {
  /* a pose to gate against (previous or predicted) */
  bool have_prior = false;
  Pose2 prior;
  double gate = 0.5;            /* metres, around the predicted position */
  /* a known heading for the one-landmark solver */
  bool have_heading = false;
  double heading = 0, heading_sigma = 0.035;
  LsqOptions lsq;
};

/* How a detection's landmark was decided (`landmark-match` matched-by). */
enum class MatchedBy {
  None,      /* unmatched */
  Pose,      /* used in the frame's pose, which agrees with it */
  Colour,    /* no pose: the map holds its colour (and marker) once */
  Prior,     /* no pose: a repeated colour placed by the prior, in the gate */
};
const char *matched_by_name (MatchedBy m);

struct LocaliseResult {
  bool ok = false;
  std::string why;              /* "too-few-landmarks", "no-solution" */
  PoseSolution solution;
  /* per detection: map index, -1 unmatched; without a pose, a detection
   * whose landmark the colour or the prior decides is matched too
   * (matched_by says which) */
  std::vector<int> match;
  std::vector<MatchedBy> matched_by;  /* per detection */
  std::vector<double> residual; /* per detection: metres (NaN: none) */
  /* per detection, why it is unmatched: "no-landmark-of-class",
   * "outside-gate", "ambiguous", "duplicate", "outlier",
   * "too-few-landmarks", "no-solution"; empty when matched */
  std::vector<std::string> reasons;
  /* per detection: the map index it was paired with before solving (-1:
   * none), kept when no pose was found, so that a filter can test each
   * pairing against its own prediction */
  std::vector<int> paired;
  int n_used = 0;               /* landmarks in the solution */
  int hypotheses = 0;           /* pair poses the consensus tried */
};

/* The consensus tries at most this many pair poses per frame, seeded by the
 * most precise detections first, so that clutter (many blobs of a colour
 * the map repeats) costs bounded time instead of growing with the cube of
 * detections and landmarks. */
constexpr int kMaxConsensusHypotheses = 2048;

/* Associates detections with map points by class (gated around the prior
 * where given; by consensus where not), then solves with one, two or more
 * landmarks (one only with opt.have_heading). Detections that fit nothing
 * stay unmatched. With too few landmarks for a pose, a detection of a
 * colour the map holds once is still matched (MatchedBy::Colour), one of a
 * repeated colour only when the prior placed it within the gate
 * (MatchedBy::Prior); the others get `too-few-landmarks`. */
LocaliseResult localise (const std::vector<MapPoint> & map,
    const std::vector<Detection> & dets, const LocaliseOptions & opt);

}  // namespace landmark
