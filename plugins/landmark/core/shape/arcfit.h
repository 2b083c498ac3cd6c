/* A ball's outline as an arc of a circle: the evidence that a blob holding
 * only part of a ball (its lit side, the part a leg or a robot does not
 * hide, the part inside the frame) is a ball. The blob's moments describe
 * the part, so its ellipse fit fails; but the part of its outline that is
 * the ball's rim still lies on one circle, the blob lies inside that
 * circle and fills a good share of it. docs/detection.md. No GStreamer
 * types. */
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "blobshape.h"

namespace landmark {

/* Outline points within kArcOutlinePx of the circle are on it: a colour
 * edge after 4:2:0 chroma (one sample is two pixels) lies anywhere within
 * a pixel of where it is, and the outline runs through boundary-pixel
 * centres, half a pixel inside the edge; kArcOutlineShare of the radius
 * more for a ball that blur and its seams make not quite a circle, of the
 * radius up to half the blob's extent: what is in view of the ball sets
 * how far blur and seams move its outline, and a circle far larger than
 * the blob must not hold a ragged outline in a band it widens itself. */
constexpr double kArcOutlinePx = 1.5;
constexpr double kArcOutlineShare = 0.03;
/* The rim must cover at least half of what the frame shows of its turn
 * ("a ball is a circle even when half of it is shaded"): any smaller arc
 * fits circles of many radii. */
constexpr double kArcMinCoverage = 0.5;
/* and deep enough to fix the radius, for a ball the frame's edge cuts:
 * the arc's depth (its sagitta) at least kArcMinDepth times the tolerance
 * band, the depth a third of the turn has on the smallest circle (r 12:
 * 6 px against a band of 1.86 px). What fixes a radius is the arc's depth
 * against the band, so a larger ball needs a smaller share of its turn
 * (r 30: 0.23 of it; r 100: 0.17). */
constexpr double kArcMinDepth = 3.2;
/* The blob fills at least a third of the circle (within the frame): a
 * thin crescent along a rim is as much a ring of another colour. */
constexpr double kArcMinFill = 1.0 / 3.0;
/* Holes (pixels inside the outline that are not the blob's) at most this
 * share of what the outline encloses: a ball's missing part is its
 * shaded or hidden side, open to the outside; a ring's hole is no ball.
 * The ellipse fit already refuses rings from r = 0.3 R (a 9 % hole); a
 * 5 % hole (r = 0.22 R) it still accepts in a whole disc. */
constexpr double kArcMaxHoles = 0.05;
/* Outline points outside the circle by more than the tolerance: at most
 * this share of the outline (a blob is inside its ball). */
constexpr double kArcMaxOutside = 0.03;
/* The smallest circle whose arc is evidence (radius, pixels): the band of
 * the tolerance either side of a smaller circle is a third of its radius
 * or more, and any outline that is round at all lies in it; the
 * ellipse fit alone decides such blobs. */
constexpr double kArcMinRadius = 12.0;

struct ArcCircle {
  double cx = 0, cy = 0, r = 0;  /* pixel-centre convention */
  double coverage = 0;   /* share of the visible turn the rim sweeps */
  double fill = 0;       /* blob area over the circle's area in the frame */
  double outside = 0;    /* share of outline points outside the circle */
  double holes = 0;      /* share of the enclosed pixels in holes */
};

/* Fits the circle that most of a blob's outline lies on and tests it with
 * the thresholds above. contour: the blob's outer outline through
 * boundary-pixel centres (BlobAnalyzer::contour); points on the frame's
 * edge (width x height) are not the blob's outline: they fit no circle,
 * and a rim that reaches the edge goes on behind it.
 * blob: its measures (area and box). Deterministic (a fixed sample sequence);
 * scratch is reused between calls. True when the blob is part of a disc:
 * out holds the circle and its measures (also when false, for the log,
 * with r = 0 when no circle was found). */
class ArcCircleFit {
public:
  bool fit (const std::vector<cv::Point> & contour, const BlobShape & blob,
      int width, int height, ArcCircle * out);

private:
  double tolerance (double r) const;
  int rim_score (double cx, double cy, double r) const;
  bool refine (double *cx, double *cy, double *r) const;

  std::vector<cv::Point2d> points_;
  double extent_ = 0;    /* half the larger side of the blob's box */
};

/* Pixel centres inside a circle and a width x height frame. */
double circle_area_in_frame (double cx, double cy, double r, int width,
    int height);

}  // namespace landmark
