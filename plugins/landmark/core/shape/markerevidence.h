/* Evidence that a blob is a landmark beyond its colour: how well its
 * outline fits an ellipse, and whether its image has the size and aspect
 * that a marker of known diameter has at the floor position the blob was
 * ranged to (docs/detection.md). Both tolerances follow the blob's size:
 * a small blob has most of its pixels on its outline, where blur, chroma
 * subsampling and compression move pixels between classes. No GStreamer
 * types. */
#pragma once

#include <vector>

#include "rangeestimate.h"

namespace landmark {

/* An ellipse in image pixels: centre, full axis lengths, angle of the
 * major axis (radians from +u towards +v). */
struct ImageEllipse {
  double cx = 0, cy = 0;
  double major = 0, minor = 0;
  double angle = 0;
};

/* Perimeter over area of an ellipse with these full axes, per pixel: the
 * share of its area within one pixel of its outline. Infinite for a
 * degenerate ellipse. */
double ellipse_boundary_share (double major, double minor);

/* The shape test's tolerance: the smallest ellipse fit (blob-vs-ellipse
 * IoU, blobshape.h) a marker of this size keeps after JPEG and blur.
 * kShapeFitLarge for a large blob, lowered by kShapeOutlinePx of outline
 * uncertainty times the boundary share, never below kShapeFitFloor. */
constexpr double kShapeFitLarge = 0.92;
constexpr double kShapeOutlinePx = 0.1;
constexpr double kShapeFitFloor = 0.5;
double shape_fit_threshold (double major, double minor);
/* A blob of fewer pixels than this is mostly outline, and chance blobs of
 * a marker's colour (an edge's blend, a patch of wall) fit their ellipse
 * well that often: shape alone accepts it only when it fits as well as a
 * large marker, kShapeFitLarge; a near miss is a marginal shape. */
constexpr double kSmallBlobPx = 100;

/* A blob that misses the shape test by less than kShapeMarginalOutlinePx
 * of outline uncertainty (a colour edge after 4:2:0 chroma, JPEG and
 * motion blur lies anywhere within a chroma sample) is a marginal shape:
 * rejected unless its size against range confirms it at
 * kSizeAgreementMarginal, above the 0.837 that the best ellipse reaches
 * against a square (so against any parallelogram, IoU being invariant
 * under affine maps). docs/detection.md. */
constexpr double kShapeMarginalOutlinePx = 0.3;
constexpr double kSizeAgreementMarginal = 0.85;
double shape_marginal_threshold (double major, double minor);

/* A blob thinner than this across (its moment ellipse's minor axis) may be
 * the blend of two other colours along an edge between them: a white line
 * on green carpet blends into a band of a yellow ball's colour, one or two
 * pixels wide, after 4:2:0 chroma (one sample is two pixels) and blur. It
 * is a marginal shape: only its size against range and the map together
 * can accept it. docs/detection.md. */
constexpr double kMinBlobThicknessPx = 4.0;

/* The size test's tolerance: the smallest IoU between the measured blob
 * ellipse and the predicted image of the marker. kSizeAgreementLarge
 * leaves room for the diameter and range errors of a large blob; each
 * pixel of outline error costs about the boundary share of the predicted
 * ellipse; never below kSizeAgreementFloor. */
constexpr double kSizeAgreementLarge = 0.70;
constexpr double kSizeOutlinePx = 1.0;
constexpr double kSizeAgreementFloor = 0.30;
double size_agreement_threshold (const ImageEllipse & predicted);

/* The ellipse with the area moments of a simple closed polygon (u, v
 * pairs): centre = centroid, full axes 4 sqrt (eigenvalues of the second
 * central moments), as blobshape.h measures blobs. False for fewer than 3
 * points or no area. */
bool polygon_moment_ellipse (const std::vector<double> & uv,
    ImageEllipse * out);

/* Where a marker of `marker.diameter` whose centre is at floor position
 * (gx, gy) (robot frame, metres; height marker.z) appears in the image:
 * a disc's rim, or a ball's outline (the circle where the camera's rays
 * touch it), projected and reduced to its moment ellipse. Pixels of the
 * geometry's frame mapped to a frame sx, sy times smaller
 * (u = (u' + 0.5) / sx - 0.5, as BlobObservation). False when the
 * diameter is unknown, the marker is not wholly in front of the camera or
 * the camera is inside the ball. scratch is reused between calls. */
bool predict_marker_image (const CameraGeometry & geometry,
    const MarkerSpec & marker, double gx, double gy, double sx, double sy,
    ImageEllipse * out, std::vector<double> *scratch);

/* The size test of a blob cut by the frame's edge, whose visible part
 * may be any part of the marker's image: neither of its axes may exceed
 * the predicted image's by more than kCutAxisSlack times plus
 * kCutOutlinePx pixels of outline blur. */
constexpr double kCutAxisSlack = 1.25;
constexpr double kCutOutlinePx = 2.0;
bool cut_blob_fits (const ImageEllipse & measured,
    const ImageEllipse & predicted);

/* Intersection over union of two ellipses placed on one centre (their
 * size, aspect and orientation compared, not their positions), by the
 * polar area integral. 0 when either is degenerate. */
double ellipse_shape_iou (const ImageEllipse & a, const ImageEllipse & b);


/* How well the blob's ellipse agrees with the image a marker m has at the
 * floor position e placed it (docs/detection.md): 0..1, or -1 when it
 * cannot tell (no diameter, no ellipse, not wholly in front); *predicted
 * is that image (predict_marker_image; scratch is its). */
double marker_size_agreement (const CameraGeometry & geometry,
    const BlobObservation & obs, const MarkerSpec & m,
    const RangeEstimate & e, ImageEllipse * predicted,
    std::vector<double> *scratch);

/* One class, several kinds of marker (a yellow disc and a yellow ball),
 * and a blob wholly in the frame: the one whose predicted image agrees
 * best with the blob's ellipse in size and aspect (a disc on the floor is
 * a flat ellipse, a ball round), its range in *e. Where no image can be
 * predicted, the one whose floor range and size range agree best. Without
 * either nothing can choose: nullptr. */
const MarkerSpec *choose_marker (const CameraGeometry & geometry,
    const BlobObservation & obs, const std::vector<MarkerSpec> & hypotheses,
    double pixel_sigma, const MountingSigma & mounting, RangeEstimate * e,
    std::vector<double> *scratch);

/* A blob cut by the frame's edge may be smaller than its marker's image,
 * never larger. Its size cannot tell which marker of its class it is (the
 * visible part's centroid biases the range each kind gives, and the test
 * is one-sided), so it is ranged as the properties' marker, as a class the
 * map lacks; but when it is larger than every marker's image it is none of
 * them (a line of mixed pixels along the horizon from the frame's edge).
 * Then: the first marker whose image could be predicted, with its range in
 * e, for the size test to reject the blob; otherwise nullptr. */
const MarkerSpec *cut_blob_fits_no_marker (const CameraGeometry & geometry,
    const BlobObservation & obs, const std::vector<MarkerSpec> & hypotheses,
    double pixel_sigma, const MountingSigma & mounting, RangeEstimate * e,
    std::vector<double> *scratch);

/* Several markers and none chosen: the range e is the properties'
 * marker's and may be any of theirs, so its kind spreads cover them all. */
void add_marker_kind_spread (const CameraGeometry & geometry,
    const BlobObservation & obs, const std::vector<MarkerSpec> & hypotheses,
    double pixel_sigma, const MountingSigma & mounting, RangeEstimate * e);

}  // namespace landmark
