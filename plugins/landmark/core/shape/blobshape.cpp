/* Blob measurement (blobshape.h): a component's outline traced, its
 * area, centroid and moment ellipse, the perimeter estimate
 * (blobperimeter.cpp) and roundness, and how well it fills its ellipse. */
#include "blobshape.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace landmark {

namespace {

/* 8 neighbours, clockwise on screen (v grows downwards): E, SE, S, SW, W,
 * NW, N, NE. */
const int kDx[8] = { 1, 1, 0, -1, -1, -1, 0, 1 };
const int kDy[8] = { 0, 1, 1, 1, 0, -1, -1, -1 };

}  // namespace

/* ---- measuring ------------------------------------------------------ */

void
BlobAnalyzer::trace (const Component & c)
{
  /* the component painted into a zeroed box with a 1-pixel margin */
  const int bw = c.x1 - c.x0 + 1, bh = c.y1 - c.y0 + 1;
  const int mw = bw + 2, mh = bh + 2;
  mask_.assign ((size_t) mw * mh, 0);
  for (int k = 0; k < c.count; k++) {
    const BlobRun & r = sorted_[c.first + k];
    memset (&mask_[(size_t) (r.y - c.y0 + 1) * mw + (r.x0 - c.x0 + 1)], 1,
        r.x1 - r.x0 + 1);
  }
  int off[8];
  for (int d = 0; d < 8; d++)
    off[d] = kDy[d] * mw + kDx[d];

  /* Moore-neighbour tracing of the outer boundary, clockwise on screen,
   * from the first pixel in raster order; stops on entering the start
   * pixel the way it was first left (Jacob's criterion) */
  const BlobRun & r0 = sorted_[c.first];
  const int start = (r0.y - c.y0 + 1) * mw + (r0.x0 - c.x0 + 1);
  contour_.clear ();
  int p = start, px = r0.x0, py = r0.y;
  int d = 0;                    /* as if entered moving east */
  int first_dir = -1;
  const size_t limit = 4 * (size_t) c.n + 16;
  while (contour_.size () <= limit) {
    /* search clockwise from the background pixel last looked at */
    const int from = (d + 6 - (d & 1)) % 8;
    int nd = -1;
    for (int k = 0; k < 8; k++) {
      const int dir = (from + k) % 8;
      if (mask_[p + off[dir]]) {
        nd = dir;
        break;
      }
    }
    if (nd < 0) {
      contour_.emplace_back (px, py);   /* a single pixel */
      break;
    }
    if (p == start) {
      if (first_dir < 0)
        first_dir = nd;
      else if (nd == first_dir)
        break;
    }
    contour_.emplace_back (px, py);
    p += off[nd];
    px += kDx[nd];
    py += kDy[nd];
    d = nd;
  }
}

void
BlobAnalyzer::measure (size_t index, BlobShape * out)
{
  const Component & c = comps_[index];
  BlobShape & b = *out;
  b = BlobShape ();
  b.slot = c.slot;
  b.area = c.n;
  b.bbox_x = c.x0;
  b.bbox_y = c.y0;
  b.bbox_w = c.x1 - c.x0 + 1;
  b.bbox_h = c.y1 - c.y0 + 1;
  b.touches_border = c.x0 == 0 || c.y0 == 0 || c.x1 == width_ - 1 ||
      c.y1 == height_ - 1;
  b.equivalent_diameter = std::sqrt (4 * c.n / M_PI);

  const double cx = c.sx / c.n, cy = c.sy / c.n;
  b.centroid_x = b.ellipse_x = cx;
  b.centroid_y = b.ellipse_y = cy;
  /* covariance of the union of pixel squares: of the centres, plus 1/12
   * for each square's own spread */
  const double mxx = c.sxx / c.n - cx * cx + 1.0 / 12;
  const double myy = c.syy / c.n - cy * cy + 1.0 / 12;
  const double mxy = c.sxy / c.n - cx * cy;
  const double half = 0.5 * (mxx + myy);
  const double root = std::sqrt (std::max (0.0,
          0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy));
  const double l1 = half + root;
  const double l2 = std::max (half - root, 1e-12);
  b.ellipse_major = 4 * std::sqrt (l1);
  b.ellipse_minor = 4 * std::sqrt (l2);
  b.ellipse_angle = 0.5 * std::atan2 (2 * mxy, mxx - myy);
  /* perimeter and roundness: the line-fit polygon, blended for small
   * blobs with the smoothed outline + pi (blob_outline_perimeter) */
  trace (c);
  double perimeter = 0;
  b.has_polygon = blob_outline_perimeter (contour_.data (),
      (int) contour_.size (), 2 * std::sqrt (l2), fit_, polygon_,
      &perimeter);
  b.perimeter = perimeter;
  b.roundness = perimeter > 0 ? 4 * M_PI * c.n / (perimeter * perimeter) : 0;

  /* ellipse-fit: intersection over union with the pixels whose centres
   * lie in the ellipse x^T (Sigma^-1 / 4) x <= 1, clipped to the frame */
  const double det = mxx * myy - mxy * mxy;
  b.ellipse_fit = ellipse_iou (c, cx, cy, myy / (4 * det), -mxy / (4 * det),
      mxx / (4 * det));

  /* A blob cut by the frame edge shows only part of its shape, and its
   * moments describe that part. An ellipse is also fitted to the outline
   * away from the edge (boundary-pixel centres, so each semi-axis gets
   * the half pixel to the region's edge back) and compared with the blob
   * inside the frame; the better of the two is the blob's ellipse. */
  if (b.touches_border) {
    edge_points_.clear ();
    for (const cv::Point & p : contour_)
      if (p.x > 0 && p.y > 0 && p.x < width_ - 1 && p.y < height_ - 1)
        edge_points_.emplace_back ((float) p.x, (float) p.y);
    if (edge_points_.size () >= 8) {
      const cv::RotatedRect r = cv::fitEllipseDirect (edge_points_);
      double A = 0.5 * std::max (r.size.width, r.size.height) + 0.5;
      double B = 0.5 * std::min (r.size.width, r.size.height) + 0.5;
      double ang = r.angle * M_PI / 180 +
          (r.size.width >= r.size.height ? 0 : M_PI / 2);
      ang = std::remainder (ang, M_PI);
      const double limit = 4.0 * (width_ + height_);
      if (std::isfinite (A) && std::isfinite (B) && std::isfinite (r.center.x)
          && std::isfinite (r.center.y) && B > 0.5 && A < limit &&
          std::fabs (r.center.x) < limit && std::fabs (r.center.y) < limit) {
        const double ux = std::cos (ang), uy = std::sin (ang);
        const double qxx = ux * ux / (A * A) + uy * uy / (B * B);
        const double qyy = uy * uy / (A * A) + ux * ux / (B * B);
        const double qxy = ux * uy * (1 / (A * A) - 1 / (B * B));
        const double fit = ellipse_iou (c, r.center.x, r.center.y, qxx, qxy,
            qyy);
        if (fit > b.ellipse_fit) {
          b.ellipse_x = r.center.x;
          b.ellipse_y = r.center.y;
          b.ellipse_major = 2 * A;
          b.ellipse_minor = 2 * B;
          b.ellipse_angle = ang;
          b.ellipse_fit = fit;
          b.ellipse_from_outline = true;
        }
      }
    }
  }
}

double
BlobAnalyzer::ellipse_iou (const Component & c, double cx, double cy,
    double qxx, double qxy, double qyy) const
{
  /* rows where the ellipse has points: |dy| <= 1 / sqrt (qyy - qxy^2/qxx) */
  const double hy = 1.0 / std::sqrt (std::max (1e-12, qyy - qxy * qxy / qxx));
  const int ya = std::max (0, (int) std::ceil (cy - hy));
  const int yb = std::min (height_ - 1, (int) std::floor (cy + hy));
  double inside = 0, both = 0;
  int rk = c.first;
  const int rend = c.first + c.count;
  for (int y = ya; y <= yb; y++) {
    const double dy = y - cy;
    const double disc = qxy * qxy * dy * dy - qxx * (qyy * dy * dy - 1);
    if (disc < 0)
      continue;
    const double sq = std::sqrt (disc);
    const double lo = cx + (-qxy * dy - sq) / qxx;
    const double hi = cx + (-qxy * dy + sq) / qxx;
    if (hi < 0 || lo > width_ - 1)
      continue;
    const int xa = std::max (0, (int) std::ceil (lo));
    const int xb = std::min (width_ - 1, (int) std::floor (hi));
    if (xa > xb)
      continue;
    inside += xb - xa + 1;
    while (rk < rend && sorted_[rk].y < y)
      rk++;
    for (int q = rk; q < rend && sorted_[q].y == y; q++) {
      const int a = std::max (xa, sorted_[q].x0);
      const int e = std::min (xb, sorted_[q].x1);
      if (a <= e)
        both += e - a + 1;
    }
  }
  const double uni = c.n + inside - both;
  return uni > 0 ? both / uni : 0;
}

std::vector<BlobShape>
blob_measure_mask (const cv::Mat & mask)
{
  BlobAnalyzer a;
  a.begin (mask.cols, mask.rows);
  a.add_mask_runs (mask, 0, 0, 1);
  a.label ();
  std::vector<BlobShape> out (a.count ());
  for (size_t i = 0; i < a.count (); i++)
    a.measure (i, &out[i]);
  return out;
}

}  // namespace landmark
