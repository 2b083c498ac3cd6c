/* The blob perimeter estimator (blobshape.h): the line-fit polygon
 * through an outline's boundary-pixel centres, the chain and smoothed
 * lengths it falls back on or is blended with, and the perimeter that
 * BlobAnalyzer::measure takes from them. */
#include "blobshape.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace landmark {

namespace {

/* k mod n for 0 <= k < 2n: the closed contours' indices, without a
 * division per point */
inline int
wrap (int k, int n)
{
  return k < n ? k : k - n;
}

double
point_segment_distance2 (const cv::Point & p, const cv::Point & a,
    const cv::Point & b)
{
  const double abx = b.x - a.x, aby = b.y - a.y;
  const double apx = p.x - a.x, apy = p.y - a.y;
  const double len2 = abx * abx + aby * aby;
  if (len2 <= 0)
    return apx * apx + apy * apy;
  double t = (apx * abx + apy * aby) / len2;
  t = std::min (1.0, std::max (0.0, t));
  const double dx = apx - t * abx, dy = apy - t * aby;
  return dx * dx + dy * dy;
}

double
chain_length (const cv::Point * c, int n)
{
  if (n < 2)
    return 0;
  double len = 0;
  for (int i = 0; i < n; i++) {
    const cv::Point & a = c[i];
    const cv::Point & b = c[wrap (i + 1, n)];
    len += std::hypot ((double) (b.x - a.x), (double) (b.y - a.y));
  }
  return len;
}

/* Length of the closed contour after a 3-point moving average. */
double
smoothed_length (const cv::Point * c, int n)
{
  if (n < 3)
    return chain_length (c, n);
  auto at = [&](int i) {
    const cv::Point & a = c[wrap (i + n - 1, n)];
    const cv::Point & b = c[i];
    const cv::Point & d = c[wrap (i + 1, n)];
    return cv::Point2d ((a.x + b.x + d.x) / 3.0, (a.y + b.y + d.y) / 3.0);
  };
  const cv::Point2d first = at (0);
  cv::Point2d prev = first;
  double len = 0;
  for (int i = 1; i <= n; i++) {
    const cv::Point2d cur = i < n ? at (i) : first;
    len += std::hypot (cur.x - prev.x, cur.y - prev.y);
    prev = cur;
  }
  return len;
}

/* The line-fit polygon (see blobshape.h). Returns false when the contour
 * encloses no area or simplifies to fewer than three vertices. */
bool
fit_polygon (const cv::Point * c, int n, double eps, BlobLineFit & s,
    std::vector<cv::Point2d> & poly, double *perimeter)
{
  poly.clear ();
  if (n < 3)
    return false;

  /* orientation: positive shoelace sum = clockwise on screen */
  double area2 = 0;
  for (int i = 0; i < n; i++) {
    const cv::Point & a = c[i];
    const cv::Point & b = c[wrap (i + 1, n)];
    area2 += (double) a.x * b.y - (double) b.x * a.y;
  }
  if (std::fabs (area2) < 1e-9)
    return false;
  const double orient = area2 > 0 ? 1.0 : -1.0;

  /* Douglas-Peucker on the closed contour, split first at the point
   * farthest from point 0 */
  int far = 0;
  double far_d = -1;
  for (int i = 1; i < n; i++) {
    const double dx = c[i].x - c[0].x, dy = c[i].y - c[0].y;
    const double d = dx * dx + dy * dy;
    if (d > far_d) {
      far_d = d;
      far = i;
    }
  }
  if (far_d <= 0)
    return false;
  s.keep.assign (n, 0);
  s.keep[0] = s.keep[far] = 1;
  s.stack.clear ();
  s.stack.emplace_back (0, far);
  s.stack.emplace_back (far, n);
  const double eps2 = eps * eps;
  while (!s.stack.empty ()) {
    const auto [i, j] = s.stack.back ();
    s.stack.pop_back ();
    if (j - i < 2)
      continue;
    const cv::Point & a = c[wrap (i, n)];
    const cv::Point & b = c[wrap (j, n)];
    int best = -1;
    double best_d = eps2;
    for (int k = i + 1; k < j; k++) {
      const double d = point_segment_distance2 (c[wrap (k, n)], a, b);
      if (d > best_d) {
        best_d = d;
        best = k;
      }
    }
    if (best >= 0) {
      s.keep[wrap (best, n)] = 1;
      s.stack.emplace_back (i, best);
      s.stack.emplace_back (best, j);
    }
  }
  s.verts.clear ();
  for (int i = 0; i < n; i++)
    if (s.keep[i])
      s.verts.push_back (i);
  const int m = (int) s.verts.size ();
  if (m < 3)
    return false;

  /* a least-squares line per piece, moved out to where the region's edge
   * lies on average: the boundary-pixel centres sit 0..max(|nx|,|ny|)
   * inside it */
  s.lines.resize (m);
  for (int k = 0; k < m; k++) {
    const int i = s.verts[k];
    const int j = k + 1 < m ? s.verts[k + 1] : s.verts[0] + n;
    const int cnt = j - i + 1;
    double mx = 0, my = 0;
    for (int q = i; q <= j; q++) {
      mx += c[wrap (q, n)].x;
      my += c[wrap (q, n)].y;
    }
    mx /= cnt;
    my /= cnt;
    double sxx = 0, syy = 0, sxy = 0;
    for (int q = i; q <= j; q++) {
      const double dx = c[wrap (q, n)].x - mx, dy = c[wrap (q, n)].y - my;
      sxx += dx * dx;
      syy += dy * dy;
      sxy += dx * dy;
    }
    const double theta = 0.5 * std::atan2 (2 * sxy, sxx - syy);
    cv::Point2d t (std::cos (theta), std::sin (theta));
    const cv::Point & end = c[wrap (j, n)];
    const double chx = end.x - c[i].x, chy = end.y - c[i].y;
    if (t.x * chx + t.y * chy < 0)
      t = -t;
    const cv::Point2d nrm = orient > 0 ? cv::Point2d (t.y, -t.x) :
        cv::Point2d (-t.y, t.x);
    const double delta = 0.5 * std::max (std::fabs (nrm.x), std::fabs (nrm.y));
    s.lines[k].p = cv::Point2d (mx, my) + delta * nrm;
    s.lines[k].t = t;
  }

  /* vertices: consecutive lines intersected, or bevelled (the contour
   * point projected on both) when they are nearly parallel or meet far
   * from it */
  const double max_shift = 2 * eps + 2;
  auto project = [](const cv::Point2d & v, const BlobLineFit::Line & l) {
    const cv::Point2d d = v - l.p;
    return l.p + (d.x * l.t.x + d.y * l.t.y) * l.t;
  };
  for (int k = 0; k < m; k++) {
    const BlobLineFit::Line & l1 = s.lines[(k + m - 1) % m];
    const BlobLineFit::Line & l2 = s.lines[k];
    const cv::Point2d v (c[s.verts[k]].x, c[s.verts[k]].y);
    const double cross = l1.t.x * l2.t.y - l1.t.y * l2.t.x;
    bool ok = false;
    if (std::fabs (cross) > 1e-6) {
      const cv::Point2d d = l2.p - l1.p;
      const double u = (d.x * l2.t.y - d.y * l2.t.x) / cross;
      const cv::Point2d x = l1.p + u * l1.t;
      if (std::hypot (x.x - v.x, x.y - v.y) <= max_shift) {
        poly.push_back (x);
        ok = true;
      }
    }
    if (!ok) {
      poly.push_back (project (v, l1));
      poly.push_back (project (v, l2));
    }
  }
  double len = 0;
  const int pn = (int) poly.size ();
  for (int k = 0; k < pn; k++) {
    const cv::Point2d d = poly[(k + 1) % pn] - poly[k];
    len += std::hypot (d.x, d.y);
  }
  *perimeter = len;
  return true;
}

}  // namespace

/* ---- free functions ------------------------------------------------- */

double
blob_perimeter_tolerance (double minor_semi_axis)
{
  return std::min (1.5, std::max (0.7, 0.15 * minor_semi_axis));
}

double
blob_chain_length (const cv::Point * contour, int n)
{
  return chain_length (contour, n);
}

double
blob_smoothed_length (const cv::Point * contour, int n)
{
  return smoothed_length (contour, n);
}

double
blob_polygon_weight (double minor_semi_axis)
{
  return std::min (1.0, std::max (0.0, (minor_semi_axis - 7.0) / 4.0));
}

bool
blob_perimeter (const cv::Point * contour, int n, double eps,
    double *perimeter, std::vector<cv::Point2d> *polygon)
{
  BlobLineFit scratch;
  std::vector<cv::Point2d> local;
  std::vector<cv::Point2d> &poly = polygon ? *polygon : local;
  if (fit_polygon (contour, n, eps, scratch, poly, perimeter))
    return true;
  *perimeter = chain_length (contour, n) + 4.0;
  return false;
}

bool
blob_outline_perimeter (const cv::Point * contour, int n,
    double minor_semi_axis, BlobLineFit & scratch,
    std::vector<cv::Point2d> & polygon, double *perimeter)
{
  const double eps = blob_perimeter_tolerance (minor_semi_axis);
  *perimeter = 0;
  const bool has_polygon = fit_polygon (contour, n, eps, scratch, polygon,
      perimeter);
  if (!has_polygon) {
    /* no area inside the outline (lines one pixel thick) */
    *perimeter = chain_length (contour, n) + 4;
    polygon.clear ();
  } else {
    const double w = blob_polygon_weight (minor_semi_axis);
    if (w < 1)
      *perimeter = w * *perimeter + (1 - w) *
          (smoothed_length (contour, n) + M_PI);
  }
  return has_polygon;
}

}  // namespace landmark
