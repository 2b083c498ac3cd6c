/* Coded markers in a label plane: band blobs stacked along the axis,
 * read top to bottom and named by the map's codes (beacongroup.h). */
#include "beacongroup.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace landmark {

namespace {

constexpr double kPi = 3.14159265358979323846;
/* a cone's stripes narrow upwards; its top band is a triangle */
constexpr double kConeTopFill = 0.4;
constexpr double kConeFill = 0.6;
constexpr double kConeWidening = 1.15;   /* a band over the next, at most */
/* bands stack when the gap between them is at most this share of the
 * shorter one (a boundary pixel blends both colours), or 2 px */
constexpr double kMaxGapShare = 0.35;
/* ... and overlap along the axis by at most this share: seen from above,
 * a band's boundary is an arc whose middle dips below its ends */
constexpr double kMaxOverlapShare = 0.6;
constexpr double kMinAcrossOverlap = 0.5;
/* a band under another may be up to this much wider (a cone's) */
constexpr double kMaxWidening = 3.0;
/* the longest chain of bands followed: a marker's, and one more band on
 * either end (another marker's touching it) */
constexpr int kMaxChain = (int) kMaxMarkerBands + 2;
/* the whole marker's length / width against height / diameter */
constexpr double kMaxAspectRatio = 2.0;

}  // namespace

std::vector<BeaconSpec>
beacon_specs (const LandmarkMap & map,
    const std::vector<std::string> & class_names)
{
  std::vector<BeaconSpec> out;
  for (const MapLandmark & m : map.landmarks) {
    if (!m.coded ())
      continue;
    BeaconSpec s;
    s.marker = m;
    for (const std::string & band : m.bands) {
      auto it = std::find (class_names.begin (), class_names.end (), band);
      s.labels.push_back (it == class_names.end ()? 0 :
          (int) (it - class_names.begin ()) + 1);
    }
    out.push_back (std::move (s));
  }
  return out;
}

void
BeaconFinder::set_specs (const std::vector<BeaconSpec> & specs)
{
  specs_ = specs;
  std::fill (slot_of_, slot_of_ + 256, 0);
  has_cones_ = false;
  for (const BeaconSpec & s : specs_)
    has_cones_ |= s.marker.kind == MapKind::Cone;
  for (const BeaconSpec & s : specs_)
    for (int label : s.labels)
      if (label > 0 && label < 256)
        slot_of_[label] = (uint8_t) label;
}

void
BeaconFinder::find (const cv::Mat & labels, const BeaconParams & params)
{
  WorkerPool one;
  CV_Assert (labels.type () == CV_8UC1);
  find (labels.data, labels.step, labels.cols, labels.rows, params, one);
}

void
BeaconFinder::find (const uint8_t * plane, size_t stride, int width,
    int height, const BeaconParams & params, WorkerPool & pool)
{
  n_out_ = 0;
  width_ = width;
  height_ = height;
  blobs_.clear ();
  points_.clear ();
  if (specs_.empty ())
    return;
  analyzer_.begin (width, height);
  analyzer_.add_label_runs (plane, stride, slot_of_, pool);
  analyzer_.label ();
  collect (params);

  const int n = (int) blobs_.size ();
  below_.assign (n, -1);
  above_.assign (n, -1);
  below_score_.assign (n, std::numeric_limits<double>::infinity ());
  /* each blob's best partner below it; a blob claimed by two keeps the
   * better, so a chain never forks */
  for (int a = 0; a < n; a++) {
    double best = std::numeric_limits<double>::infinity ();
    for (int b = 0; b < n; b++) {
      double score;
      if (a != b && pair_score (blobs_[a], blobs_[b], params, &score) &&
          score < best) {
        best = score;
        below_[a] = b;
      }
    }
    below_score_[a] = best;
  }
  for (int a = 0; a < n; a++) {
    const int b = below_[a];
    if (b >= 0 && (above_[b] < 0 || below_score_[a] <
            below_score_[above_[b]]))
      above_[b] = a;
  }
  for (int a = 0; a < n; a++)
    if (below_[a] >= 0 && above_[below_[a]] != a)
      below_[a] = -1;
  for (int a = 0; a < n; a++)
    if (above_[a] < 0)
      chain (a, params);
}

void
BeaconFinder::collect (const BeaconParams & params)
{
  for (size_t i = 0; i < analyzer_.count (); i++) {
    if (analyzer_.area (i) < params.min_band_area)
      continue;
    analyzer_.measure (i, &shape_);
    const BlobShape & s = shape_;
    Blob b;
    b.label = s.slot;
    b.area = s.area;
    b.cx = s.centroid_x;
    b.cy = s.centroid_y;
    b.x0 = s.bbox_x;
    b.y0 = s.bbox_y;
    b.x1 = s.bbox_x + s.bbox_w - 1;
    b.y1 = s.bbox_y + s.bbox_h - 1;
    b.cut_top = b.y0 <= 0;
    b.cut_bottom = b.y1 >= height_ - 1;
    b.cut_side = b.x0 <= 0 || b.x1 >= width_ - 1;
    const std::vector<cv::Point> & c = analyzer_.contour ();
    b.first = (int) points_.size ();
    b.count = (int) c.size ();
    points_.insert (points_.end (), c.begin (), c.end ());
    blobs_.push_back (b);
  }
}

/* The blob's extent along (du, dv) and across it, through the outer
 * pixels' edges (the outline runs through their centres). */
void
BeaconFinder::extent (const Blob & b, double du, double dv, double *along0,
    double *along1, double *across0, double *across1) const
{
  double a0 = std::numeric_limits<double>::infinity (), a1 = -a0;
  double c0 = a0, c1 = -a0;
  for (int k = b.first; k < b.first + b.count; k++) {
    const double u = points_[k].x, v = points_[k].y;
    const double a = u * du + v * dv, c = -u * dv + v * du;
    a0 = std::min (a0, a);
    a1 = std::max (a1, a);
    c0 = std::min (c0, c);
    c1 = std::max (c1, c);
  }
  *along0 = a0 - 0.5;
  *along1 = a1 + 0.5;
  *across0 = c0 - 0.5;
  *across1 = c1 + 0.5;
}

/* Whether b lies right under a on one marker: a score (lower is better)
 * when it does. */
bool
BeaconFinder::pair_score (const Blob & a, const Blob & b,
    const BeaconParams & params, double *score) const
{
  if (a.label == b.label)
    return false;
  const double cu = b.cx - a.cx, cv = b.cy - a.cy;
  const double len = std::hypot (cu, cv);
  if (cv <= 0 || len <= 0)
    return false;
  const double roll = std::atan2 (std::fabs (cu), cv) * 180.0 / kPi;
  if (roll > params.max_roll_deg)
    return false;
  const double du = cu / len, dv = cv / len;
  double a0, a1, ac0, ac1, b0, b1, bc0, bc1;
  extent (a, du, dv, &a0, &a1, &ac0, &ac1);
  extent (b, du, dv, &b0, &b1, &bc0, &bc1);
  const double la = a1 - a0, lb = b1 - b0;
  const double wa = ac1 - ac0, wb = bc1 - bc0;
  const double shorter = std::min (la, lb);
  const double gap = b0 - a1;
  if (gap > std::max (2.0, kMaxGapShare * shorter) ||
      gap < -kMaxOverlapShare * shorter || b1 <= a1 || a0 >= b0)
    return false;
  const double across = std::min (ac1, bc1) - std::max (ac0, bc0);
  if (across < kMinAcrossOverlap * std::min (wa, wb))
    return false;
  if (wa > params.max_width_ratio * wb || wb > (has_cones_ ? kMaxWidening :
          params.max_width_ratio) * wa)
    return false;
  *score = std::fabs (gap) / std::max (shorter, 1.0) +
      0.5 * roll / std::max (params.max_roll_deg, 1.0);
  return true;
}

/* The bands idx[0..n) as detection d, read and named. */
void
BeaconFinder::read (BeaconDetection & d, const int *idx, int n,
    const BeaconParams & params)
{
  d.n_bands = n;
  d.marker = -1;
  d.candidates.clear ();
  d.reject = nullptr;
  for (int k = 0; k < n; k++) {
    const Blob & b = blobs_[idx[k]];
    BeaconBand & band = d.bands[k];
    band = BeaconBand ();
    band.label = b.label;
    band.blob = idx[k];
    band.area = b.area;
    band.cx = b.cx;
    band.cy = b.cy;
  }
  d.cut_top = blobs_[idx[0]].cut_top;
  d.cut_bottom = blobs_[idx[n - 1]].cut_bottom;
  name (d, params);
}

/* Follows the chain down from blob top and names what it reads. A chain
 * that names nothing whole may be a marker with a band of another one
 * (further away, or nearer) touching it: the longest run of its bands,
 * lowest first, that names a marker whose shape holds is that marker. */
void
BeaconFinder::chain (int top, const BeaconParams & params)
{
  int idx[kMaxChain] = { 0 };
  int n = 0;
  for (int k = top; k >= 0 && n < kMaxChain; k = below_[k])
    idx[n++] = k;
  if (out_.size () <= n_out_)
    out_.emplace_back ();
  BeaconDetection & d = out_[n_out_];
  if (n <= (int) kMaxMarkerBands) {
    read (d, idx, n, params);
    if (!d.reject) {
      n_out_++;
      return;
    }
  }
  for (int len = std::min (n - 1, (int) kMaxMarkerBands); len >= 1; len--)
    for (int first = n - len; first >= 0; first--) {
      read (d, idx + first, len, params);
      if (!d.reject) {
        n_out_++;
        return;
      }
    }
  if (n > (int) kMaxMarkerBands)
    return;                     /* no marker has that many bands */
  read (d, idx, n, params);
  /* a lone blob that names nothing is some other blob (a disc's) */
  if (d.marker < 0 && d.candidates.empty () && n == 1)
    return;
  n_out_++;
}

/* The code the chain reads: named when one spec holds it whole, else the
 * specs it may be part of. Then the shape test of the named kind. */
void
BeaconFinder::name (BeaconDetection & d, const BeaconParams & params)
{
  const int n = d.n_bands;
  int exact = -1;
  for (size_t s = 0; s < specs_.size (); s++) {
    const std::vector<int> & L = specs_[s].labels;
    const int m = (int) L.size ();
    for (int off = 0; off + n <= m; off++) {
      bool same = true;
      for (int k = 0; k < n && same; k++)
        same = L[off + k] == d.bands[k].label;
      if (!same)
        continue;
      const bool whole = n == m;
      /* a lone band is part of a longer marker only where the frame cuts
       * the rest off; bands of a longer chain may also hide behind
       * something */
      const bool missing_above = off > 0, missing_below = off + n < m;
      if (!whole && n == 1 && !((missing_above && !missing_below &&
                  d.cut_top) || (missing_below && !missing_above &&
                  d.cut_bottom)))
        continue;
      if (whole)
        exact = (int) s;
      d.candidates.push_back ((int) s);
      break;
    }
  }
  /* the whole code in view names it, unless the frame cuts the end where
   * a longer code would go on */
  bool ambiguous = false;
  if (exact >= 0)
    for (int s : d.candidates)
      if (s != exact)
        ambiguous |= d.cut_top || d.cut_bottom;
  if (exact >= 0 && !ambiguous) {
    d.marker = exact;
    d.candidates.clear ();
  }
  /* the axis: from the top band's centre to the lowest band's; vertical
   * for a single band */
  double du = 0, dv = 1;
  if (n > 1) {
    const double cu = d.bands[n - 1].cx - d.bands[0].cx;
    const double cv = d.bands[n - 1].cy - d.bands[0].cy;
    const double len = std::hypot (cu, cv);
    du = cu / len;
    dv = cv / len;
  }
  d.axis_u = du;
  d.axis_v = dv;
  double t0 = 0, t1 = 0, s_top = 0, s_base = 0;
  d.area = d.cx = d.cy = 0;
  int x0 = width_, y0 = height_, x1 = -1, y1 = -1;
  for (int k = 0; k < n; k++) {
    BeaconBand & band = d.bands[k];
    const Blob & b = blobs_[band.blob];
    double a0, a1, c0, c1;
    extent (b, du, dv, &a0, &a1, &c0, &c1);
    band.length = a1 - a0;
    band.width = c1 - c0;
    band.fill = band.area / std::max (band.length * band.width, 1.0);
    band.cut = b.cut_top || b.cut_bottom || b.cut_side;
    if (k == 0) {
      t0 = a0;
      s_top = 0.5 * (c0 + c1);
    }
    if (k == n - 1) {
      t1 = a1;
      s_base = 0.5 * (c0 + c1);
      d.width_px = band.width;
    }
    d.area += b.area;
    d.cx += b.area * b.cx;
    d.cy += b.area * b.cy;
    x0 = std::min (x0, b.x0);
    y0 = std::min (y0, b.y0);
    x1 = std::max (x1, b.x1);
    y1 = std::max (y1, b.y1);
  }
  d.cx /= d.area;
  d.cy /= d.area;
  d.bbox_x = x0;
  d.bbox_y = y0;
  d.bbox_w = x1 - x0 + 1;
  d.bbox_h = y1 - y0 + 1;
  /* back from (along, across) to the image: along du, dv; across -dv, du */
  d.top_u = t0 * du - s_top * dv;
  d.top_v = t0 * dv + s_top * du;
  d.base_u = t1 * du - s_base * dv;
  d.base_v = t1 * dv + s_base * du;
  d.height_px = t1 - t0;
  if (d.marker >= 0) {
    if (!shape_holds (d, specs_[d.marker], params))
      d.reject = "shape";
  } else {
    d.reject = d.candidates.empty ()? "code" : "partial";
  }
}

bool
BeaconFinder::shape_holds (BeaconDetection & d, const BeaconSpec & spec,
    const BeaconParams & params) const
{
  const int n = d.n_bands;
  const bool cone = spec.marker.kind == MapKind::Cone;
  double wmin = std::numeric_limits<double>::infinity (), wmax = 0;
  for (int k = 0; k < n; k++) {
    const BeaconBand & b = d.bands[k];
    const double need = !cone ? params.min_fill : k == 0 ? kConeTopFill :
        kConeFill;
    if (b.fill < need)
      return false;
    if (cone && k + 1 < n && b.width > kConeWidening * d.bands[k + 1].width)
      return false;
    wmin = std::min (wmin, b.width);
    wmax = std::max (wmax, b.width);
  }
  if (!cone && wmax > params.max_width_ratio * wmin)
    return false;
  /* the bands' lengths share the marker's as their heights share the
   * map's (the uncut ones) */
  double lsum = 0, hsum = 0;
  int uncut = 0;
  for (int k = 0; k < n; k++)
    if (!d.bands[k].cut) {
      lsum += d.bands[k].length;
      hsum += spec.marker.band_heights[k];
      uncut++;
    }
  if (uncut >= 2)
    for (int k = 0; k < n; k++) {
      if (d.bands[k].cut)
        continue;
      const double r = (d.bands[k].length / lsum) /
          (spec.marker.band_heights[k] / hsum);
      if (r > params.max_length_ratio || r * params.max_length_ratio < 1)
        return false;
    }
  if (!d.cut_top && !d.cut_bottom && uncut == n) {
    const double r = (d.height_px / std::max (wmax, 1.0)) /
        (spec.marker.height / spec.marker.diameter);
    if (r > kMaxAspectRatio || r * kMaxAspectRatio < 1)
      return false;
  }
  return true;
}

}  // namespace landmark
