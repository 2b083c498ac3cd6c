/* Range and bearing of one detection through a CameraGeometry
 * (docs/ipmrange.md): discs by the circle their outline maps to on the
 * marker's plane, balls by the cone tangent to them, and the size range
 * from a known diameter. No GStreamer types. */
#pragma once

#include <functional>
#include <vector>

#include "camerageometry.h"

namespace landmark {

/* A circle through points in a plane (algebraic least squares); false
 * with fewer than 3 points or a degenerate set. */
bool fit_circle (const std::vector<double> & xy, double *cx, double *cy,
    double *radius);


/* A detection as landmark-blob describes it, in pixels of the frame it was
 * measured on; sx, sy scale those to the geometry's frame
 * (u' = (u + 0.5) sx - 0.5). */
struct BlobObservation {
  double u = 0, v = 0;                 /* centroid */
  bool has_ellipse = false;
  double eu = 0, ev = 0;               /* ellipse centre */
  double major = 0, minor = 0;         /* full axis lengths */
  double angle = 0;                    /* radians, +u towards +v */
  double equivalent_diameter = 0;      /* 0: unknown */
  double sx = 1, sy = 1;
  /* a ball's outline from the frame's colours (measure_end_offsets): how
   * far it lies beyond the ellipse where the lines through the ellipse's
   * centre along end_angle (radians, +u towards +v) and across it meet
   * it: [0] along end_angle, [1] the other way, [2] at end_angle + pi/2,
   * [3] at end_angle - pi/2; pixels; end_sigma their one-sigma errors
   * (outline_offset). Not measured: has_ends false */
  bool has_ends = false;
  double end_angle = 0;
  double end_offset[4] = {0, 0, 0, 0};
  double end_sigma[4] = {0, 0, 0, 0};
};

/* What the detection is: a disc lying flat with its centre at height z
 * (0: on the floor), or a ball whose centre is at height z; diameter in
 * metres, 0 when unknown. */
struct MarkerSpec {
  double z = 0;
  double diameter = 0;
  bool ball = false;
};

/* How well the camera's mounting is known (docs/ranging.md,
 * "Uncertainty"): one-sigma errors of the camera height, relative (0.005:
 * 1 mm in 0.2 m), and of the tilt, radians. 0: the camera is as given. */
struct MountingSigma {
  double height_rel = 0;
  double tilt = 0;
};

struct RangeEstimate {
  bool no_floor = true;          /* the ray misses the marker's plane */
  double ground_x = 0, ground_y = 0;   /* ground method, metres */
  double range_ground = 0, range_ground_sigma = 0;
  bool has_size = false;         /* a diameter was known and usable */
  double range_size = 0, range_size_sigma = 0;
  double bearing = 0, bearing_sigma = 0;
  /* the part of |range_size - range_ground| that the two sigmas do not
   * explain (chi-square, 1 dof, 99 %), metres: a blob cut or merged, whose
   * centre is off by about as much in an unknown direction */
  double size_excess = 0;
  /* when the class has several markers and none could be chosen: how far
   * the others' ranges (metres) and bearings (radians) lie from this one */
  double kind_range_spread = 0, kind_bearing_spread = 0;
  /* the outline off the marker's edge (blur, the colour threshold) by the
   * offset the known diameter gives: a disc's all round, through the shift
   * of the plane circle's centre it makes; a ball's from its shaded
   * underside, the centre moved down the image by as much. Metres and
   * radians (docs/ranging.md, "Uncertainty"); 0 without a diameter, when
   * size_excess stands for a cut or merged blob, and for a ball whose
   * outline came from the frame (its ends' sigmas stand in its place) */
  double rim_range = 0, rim_bearing = 0;
  /* the sigmas with size_excess, the kind spreads and the rim added (to
   * the range, and over the range to the bearing): what ipmrange reports */
  double range_sigma_total (double sigma) const;
  double bearing_sigma_total () const;
};

/* One-sigma errors of a blob centre's image position, pixels^2: the
 * covariance (cuu, cuv, cvv) of the centroid of a region whose outline
 * points each move by edge_sigma along the normal, independently per pixel
 * of outline: (edge_sigma / A)^2 times the outline integral of x x^T about
 * the centre (A the area). A circle of diameter D gives edge_sigma^2 x
 * 2 / (pi D) per axis. The blob's ellipse when it has one, else a circle of
 * its equivalent diameter, else one pixel. In the geometry's pixels. */
void centre_covariance (const BlobObservation & blob, double edge_sigma,
    double cov[3]);

/* Where an outline lies along a line across it, from the frame's colours:
 * `linear` holds 3 linear-light components for each of n samples, taken
 * every `step` pixels from `inside` to `outside` of the outline (relative
 * to where the blob puts it). Area coverage mixes the marker's and the background's
 * light linearly, so the outline is where the colour is half-way between
 * the marker's (a line fitted to the first `plateau` samples, carried to
 * each sample) and the background's (the last's), whatever colour
 * threshold made the blob: a ball's shaded underside is no longer cut
 * short. The crossing nearest the blob's outline, in pixels outward; false
 * without contrast or a crossing. `sigma` (optional): its one-sigma error,
 * pixels: the scatter of the light about the two fitted lines over the
 * gradient at the crossing (a level crossing's noise), with the edge's
 * asymmetry about the crossing (the profile's area over 1.5 px either
 * side of it less 1.5 px: what the half-way point cannot tell of an
 * edge's shape); n at most 128, plateau at least 3 (a line fitted to
 * each end leaves 2 plateau - 4 degrees of freedom for the scatter). */
bool outline_offset (const double *linear, int n, double inside,
    double step, int plateau, double *offset, double *sigma = nullptr);

/* The direction of a ball's image's major axis, radians (+u towards +v),
 * in the blob's pixels: the cone tangent to a sphere projects to an
 * ellipse whose major axis lies on the line through the principal point
 * (the image centre for the seed's model), where the ends' rays' bisector
 * is the cone's axis; the blob's own angle where the blob sits on that
 * point. */
double ball_axis_angle (const CameraGeometry & geometry,
    const BlobObservation & blob);

/* Where a ball's outline lies along `angle` (ball_axis_angle) and across
 * it through its ellipse's centre, from the frame (outline_offset), into
 * blob's end_*:
 * the colour threshold that made the blob cuts the shaded underside
 * shorter than the lit top, which moves the centre up the image and the
 * range out (docs/ranging.md, "Uncertainty"). Per end, the light across
 * the outline, 4 px either side, from the pixels of a band 5 px wide
 * across it (3 px under 20 px of width), each read once and put in the
 * 0.25 px bin of its distance across the ellipse's outline, the bins'
 * means at their pixels' mean distance taken at even steps; with each
 * end's sigma (end_sigma). `row` gives the frame's linear light a run
 * of pixels at a time (which keeps the frame's reading in the caller's
 * loop): n pixels of row y from column x of the blob's frame, into rgb (3
 * per pixel); false when one is outside the frame. Balls under 16 px
 * across (the profile would reach past half their radius) are left
 * alone. */
using RowLight = std::function<bool (int x, int y, int n, double *rgb)>;
void measure_end_offsets (BlobObservation * blob, double angle,
    const RowLight & row);

/* A ball's shaded underside is segmented alike frame after frame, so its
 * centre carries a bias that grows with its image, not noise that shrinks:
 * one-sigma, per axis, this share of its diameter in pixels (fitted on the
 * tuning half of the sweep, docs/ranging.md "Uncertainty"). */
constexpr double kBallShadeShare = 0.00064;

/* Range and bearing of one detection. Discs: the ellipse's outline mapped
 * to the marker's plane, its centre by a circle fit; size range from the
 * fitted circle's radius against the known diameter (the plane's distance
 * scaled). Balls: the axis of the cone tangent to the ball bisects the rays
 * of the ellipse's major-axis ends (the frame's, blob.has_ends, with their
 * sigmas in place of the shading share and the rim; the blob's ellipse
 * when either gives a size_excess); its half angle gives the distance.
 * Without an ellipse, the centroid's ray. pixel_sigma: one-sigma error of
 * a point of the blob's outline, pixels (centre_covariance; the axis
 * lengths for the size range); propagated to range and bearing through the
 * camera's derivatives at the centre, with the mounting's errors and the
 * unexplained disagreement of the two ranges added (docs/ranging.md). */
RangeEstimate estimate_range (const CameraGeometry & geometry,
    const BlobObservation & blob, const MarkerSpec & marker,
    double pixel_sigma, const MountingSigma & mounting = MountingSigma ());

}  // namespace landmark
