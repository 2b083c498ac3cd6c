#include "arcfit.h"

#include <algorithm>
#include <cmath>

namespace landmark {

namespace {

/* circle samples tried; the best holds a rim of more than half the
 * outline's points from the first few on any blob these thresholds
 * accept */
constexpr int kSamples = 96;
/* directions in which the visible part of the turn is counted: 64 of 5.6
 * degrees */
constexpr int kBins = 64;
/* outline points off the circle a rim may bridge */
constexpr int kGapPoints = 3;
constexpr uint32_t kSeed = 0x2545F491u;

/* the circle through three points; false when they are (nearly) on a
 * line */
bool
circle_through (const cv::Point2d & a, const cv::Point2d & b,
    const cv::Point2d & c, double *cx, double *cy, double *r)
{
  const double bx = b.x - a.x, by = b.y - a.y;
  const double qx = c.x - a.x, qy = c.y - a.y;
  const double d = 2 * (bx * qy - by * qx);
  if (std::fabs (d) < 1e-9)
    return false;
  const double b2 = bx * bx + by * by, q2 = qx * qx + qy * qy;
  const double ux = (qy * b2 - by * q2) / d, uy = (bx * q2 - qx * b2) / d;
  *cx = a.x + ux;
  *cy = a.y + uy;
  *r = std::sqrt (ux * ux + uy * uy);
  return true;
}

}  // namespace

double
circle_area_in_frame (double cx, double cy, double r, int width, int height)
{
  double n = 0;
  const int y0 = std::max (0, (int) std::ceil (cy - r));
  const int y1 = std::min (height - 1, (int) std::floor (cy + r));
  for (int y = y0; y <= y1; y++) {
    const double h = std::sqrt (std::max (0.0, r * r - (y - cy) * (y - cy)));
    const int x0 = std::max (0, (int) std::ceil (cx - h));
    const int x1 = std::min (width - 1, (int) std::floor (cx + h));
    if (x1 >= x0)
      n += x1 - x0 + 1;
  }
  return n;
}

double
ArcCircleFit::tolerance (double r) const
{
  return kArcOutlinePx + kArcOutlineShare * std::min (r, extent_);
}

/* How well the circle holds the outline: its points on the circle less
 * those outside it. A blob lies inside its ball, so a point outside is
 * evidence against the circle as one on it is for it: a circle through
 * part of a ragged outline and across the rest often holds more points
 * than the ball's own does. */
int
ArcCircleFit::rim_score (double cx, double cy, double r) const
{
  const double tol = tolerance (r);
  int score = 0;
  for (const cv::Point2d & p : points_) {
    const double d = std::hypot (p.x - cx, p.y - cy) - r;
    if (std::fabs (d) <= tol)
      score++;
    else if (d > tol)
      score--;
  }
  return score;
}

/* Least squares (the algebraic circle fit) over the rim's points. */
bool
ArcCircleFit::refine (double *cx, double *cy, double *r) const
{
  const double tol = tolerance (*r);
  double mx = 0, my = 0;
  int n = 0;
  for (const cv::Point2d & p : points_)
    if (std::fabs (std::hypot (p.x - *cx, p.y - *cy) - *r) <= tol) {
      mx += p.x;
      my += p.y;
      n++;
    }
  if (n < 3)
    return false;
  mx /= n;
  my /= n;
  /* x^2 + y^2 + D x + E y + F = 0 about the mean point */
  double sxx = 0, sxy = 0, syy = 0, sxz = 0, syz = 0, sz = 0;
  for (const cv::Point2d & p : points_) {
    if (std::fabs (std::hypot (p.x - *cx, p.y - *cy) - *r) > tol)
      continue;
    const double x = p.x - mx, y = p.y - my, z = x * x + y * y;
    sxx += x * x;
    sxy += x * y;
    syy += y * y;
    sxz += x * z;
    syz += y * z;
    sz += z;
  }
  /* with centred points the normal equations split: F = -mean z */
  const double det = sxx * syy - sxy * sxy;
  if (std::fabs (det) < 1e-9)
    return false;
  const double D = -(sxz * syy - syz * sxy) / det;
  const double E = -(syz * sxx - sxz * sxy) / det;
  const double F = -sz / n;
  const double rr = (D * D + E * E) / 4 - F;
  if (!(rr > 0))
    return false;
  *cx = mx - D / 2;
  *cy = my - E / 2;
  *r = std::sqrt (rr);
  return true;
}

bool
ArcCircleFit::fit (const std::vector<cv::Point> & contour,
    const BlobShape & blob, int width, int height, ArcCircle * out)
{
  *out = ArcCircle ();
  /* outline points on the frame's edge are not the blob's outline */
  points_.clear ();
  for (const cv::Point & p : contour)
    if (p.x > 0 && p.y > 0 && p.x < width - 1 && p.y < height - 1)
      points_.emplace_back (p.x, p.y);
  const int n = (int) points_.size ();
  if (n < 12)
    return false;
  const double area = blob.area;
  extent_ = 0.5 * std::max (blob.bbox_w, blob.bbox_h);

  /* three points a sixth to a half of the outline apart: on a rim they
   * span an arc wide enough to fix the radius */
  const double max_r = 2.0 * std::max (width, height);
  uint32_t state = kSeed;
  auto next = [&state] () {
    state = state * 1664525u + 1013904223u;
    return state >> 8;
  };
  /* Only a circle the blob could be part of is a candidate: one it fills
   * a kArcMinFill share of (a circle many times the blob's size, nearly
   * straight along it, holds much of a ragged outline in its band and
   * would win the count with an arc too short to pass), and one
   * that holds, with its band, at least the blob's pixels (a small circle
   * through a bulge of the outline holds that bulge's points, not the
   * ball's rim). Both within the frame. */
  auto could_be_part_of = [&] (double cx, double cy, double r) {
    return area >= kArcMinFill * circle_area_in_frame (cx, cy, r + 0.5,
        width, height) && area <= circle_area_in_frame (cx, cy,
        r + 0.5 + tolerance (r), width, height);
  };
  double best_x = 0, best_y = 0, best_r = 0;
  int best = 0;
  for (int s = 0; s < kSamples; s++) {
    const int i = next () % n;
    const int j = (i + n / 6 + next () % (n / 3 + 1)) % n;
    const int k = (j + n / 6 + next () % (n / 3 + 1)) % n;
    double cx, cy, r;
    if (!circle_through (points_[i], points_[j], points_[k], &cx, &cy, &r)
        || r < kArcMinRadius / 2 || r > max_r
        || !could_be_part_of (cx, cy, r))
      continue;
    const int rim = rim_score (cx, cy, r);
    if (rim > best) {
      best = rim;
      best_x = cx;
      best_y = cy;
      best_r = r;
    }
  }
  if (best == 0)
    return false;
  for (int round = 0; round < 2; round++) {
    double cx = best_x, cy = best_y, r = best_r;
    if (!refine (&cx, &cy, &r) || r < kArcMinRadius || r > max_r ||
        !could_be_part_of (cx, cy, r))
      break;
    const int rim = rim_score (cx, cy, r);
    if (rim < best)
      break;
    best = rim;
    best_x = cx;
    best_y = cy;
    best_r = r;
  }

  if (best_r < kArcMinRadius)
    return false;
  out->cx = best_x;
  out->cy = best_y;
  out->r = best_r;
  const double tol = tolerance (best_r);
  /* The rim is one arc of the outline: the longest run of consecutive
   * outline points on the circle, bridging gaps of up to kGapPoints
   * points (a blemish of JPEG or chroma); its turn is the angle it sweeps
   * about the centre. An outline that only crosses the circle here and
   * there (a shirt's) has no long run. The rim goes on behind the
   * frame's edge: a run that reaches the edge goes on where the outline
   * leaves it on the circle (a ball the edge cuts whose top is missing
   * holds its rim on both sides of the cut), without the edge's sweep.
   * A run holds each outline point once. */
  const int m = (int) contour.size ();
  int outside = 0;
  double best_turn = 0, turn = 0, pending = 0;
  int gap = kGapPoints + 1, run_start = 0;
  double last_t = 0;
  bool have_last = false;
  for (int k = 0; k < 2 * m; k++) {
    const cv::Point & p = contour[k % m];
    const bool on_edge = !(p.x > 0 && p.y > 0 && p.x < width - 1 &&
        p.y < height - 1);
    const double d = std::hypot (p.x - best_x, p.y - best_y);
    if (k < m && !on_edge && d > best_r + tol)
      outside++;
    const double t = std::atan2 (p.y - best_y, p.x - best_x);
    const double step = have_last ? std::remainder (t - last_t, 2 * M_PI) :
        0.0;
    last_t = t;
    have_last = true;
    if (on_edge) {
      pending = 0;
      continue;
    }
    if (std::fabs (d - best_r) <= tol) {
      /* a bridged gap's sweep counts once the run goes on */
      if (gap <= kGapPoints && k - run_start < m) {
        turn += pending + step;
      } else {
        turn = 0;
        run_start = k;
      }
      pending = 0;
      gap = 0;
      best_turn = std::max (best_turn, std::fabs (turn));
    } else if (++gap <= kGapPoints) {
      pending += step;
    } else {
      turn = pending = 0;
    }
  }
  best_turn = std::min (best_turn, 2 * M_PI);
  /* the turn the frame can show: a direction whose rim point lies outside
   * the frame cannot hold outline points */
  int visible = 0;
  for (int bin = 0; bin < kBins; bin++) {
    const double t = -M_PI + (bin + 0.5) * 2 * M_PI / kBins;
    const double x = best_x + best_r * std::cos (t);
    const double y = best_y + best_r * std::sin (t);
    visible += x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1;
  }
  const double visible_turn = 2 * M_PI * visible / kBins;
  out->coverage = visible ? std::min (1.0, best_turn / visible_turn) : 0.0;
  out->outside = (double) outside / n;
  /* the disc's edge is half a pixel outside the outline's points */
  const double circle = circle_area_in_frame (best_x, best_y, best_r + 0.5,
      width, height);
  out->fill = circle > 0 ? area / circle : 0.0;
  /* the pixels the outline encloses: the polygon through boundary-pixel
   * centres plus the half pixel outside it (half the chain's length, and
   * a pixel for the turn) */
  double twice = 0, chain = 0;
  for (int i = 0; i < m; i++) {
    const cv::Point & p = contour[i], & q = contour[(i + 1) % m];
    twice += (double) p.x * q.y - (double) q.x * p.y;
    chain += std::hypot (q.x - p.x, q.y - p.y);
  }
  const double enclosed = std::fabs (twice) / 2 + chain / 2 + 1;
  out->holes = std::max (0.0, 1.0 - area / enclosed);
  return out->coverage >= kArcMinCoverage &&
      best_r * (1 - std::cos (std::min (best_turn, M_PI) / 2)) >=
      kArcMinDepth * tol &&
      out->fill >= kArcMinFill && out->outside <= kArcMaxOutside &&
      out->holes <= kArcMaxHoles;
}

}  // namespace landmark
