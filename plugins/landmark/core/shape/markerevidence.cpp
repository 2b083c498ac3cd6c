#include "markerevidence.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace landmark {

namespace {

/* outline points of a predicted marker: enough that the polygon's moments
 * match the curve's to far below a pixel at any size an image holds */
constexpr int kOutlinePoints = 64;
/* polar samples over half a turn (ellipses are symmetric) */
constexpr int kIouSamples = 180;

/* cos and sin of the sample directions, computed once */
struct IouDirections {
  double c[kIouSamples], s[kIouSamples];
  IouDirections () {
    for (int i = 0; i < kIouSamples; i++) {
      const double t = M_PI * (i + 0.5) / kIouSamples;
      c[i] = std::cos (t);
      s[i] = std::sin (t);
    }
  }
};
const IouDirections kIouDirections;

/* squared radius of an ellipse (semi-axes a, b, major axis at cos_phi,
 * sin_phi) in sample direction i */
double
radius_squared (double a, double b, double cos_phi, double sin_phi, int i)
{
  const double c = kIouDirections.c[i] * cos_phi + kIouDirections.s[i] *
      sin_phi;
  const double s = kIouDirections.s[i] * cos_phi - kIouDirections.c[i] *
      sin_phi;
  const double den = b * b * c * c + a * a * s * s;
  return den > 0 ? a * a * b * b / den : 0.0;
}

}  // namespace

double
ellipse_boundary_share (double major, double minor)
{
  const double a = major / 2, b = minor / 2;
  if (!(a > 0 && b > 0))
    return std::numeric_limits<double>::infinity ();
  /* Ramanujan's perimeter, within 0.04 % for any aspect */
  const double perimeter = M_PI * (3 * (a + b) -
      std::sqrt ((3 * a + b) * (a + 3 * b)));
  return perimeter / (M_PI * a * b);
}

double
shape_fit_threshold (double major, double minor)
{
  const double share = ellipse_boundary_share (major, minor);
  return std::max (kShapeFitFloor, kShapeFitLarge - kShapeOutlinePx * share);
}

double
shape_marginal_threshold (double major, double minor)
{
  const double share = ellipse_boundary_share (major, minor);
  return std::max (kShapeFitFloor,
      kShapeFitLarge - kShapeMarginalOutlinePx * share);
}

double
size_agreement_threshold (const ImageEllipse & predicted)
{
  const double share = ellipse_boundary_share (predicted.major,
      predicted.minor);
  return std::max (kSizeAgreementFloor,
      kSizeAgreementLarge - kSizeOutlinePx * share);
}

bool
polygon_moment_ellipse (const std::vector<double> & uv, ImageEllipse * out)
{
  const size_t n = uv.size () / 2;
  if (n < 3)
    return false;
  /* Green's theorem over the edges, relative to the first vertex to keep
   * the sums well conditioned */
  const double u0 = uv[0], v0 = uv[1];
  double area2 = 0, mu = 0, mv = 0, muu = 0, mvv = 0, muv = 0;
  for (size_t i = 0; i < n; i++) {
    const size_t j = (i + 1) % n;
    const double x1 = uv[2 * i] - u0, y1 = uv[2 * i + 1] - v0;
    const double x2 = uv[2 * j] - u0, y2 = uv[2 * j + 1] - v0;
    const double c = x1 * y2 - x2 * y1;
    area2 += c;
    mu += (x1 + x2) * c;
    mv += (y1 + y2) * c;
    muu += (x1 * x1 + x1 * x2 + x2 * x2) * c;
    mvv += (y1 * y1 + y1 * y2 + y2 * y2) * c;
    muv += (x1 * y2 + 2 * x1 * y1 + 2 * x2 * y2 + x2 * y1) * c;
  }
  const double area = area2 / 2;
  if (!(std::fabs (area) > 1e-12))
    return false;
  const double cu = mu / (6 * area), cv = mv / (6 * area);
  /* second moments about the centroid, per unit area */
  const double suu = muu / (12 * area) - cu * cu;
  const double svv = mvv / (12 * area) - cv * cv;
  const double suv = muv / (24 * area) - cu * cv;
  const double mean = (suu + svv) / 2;
  const double diff = std::sqrt (std::max (0.0,
          (suu - svv) * (suu - svv) / 4 + suv * suv));
  const double l1 = mean + diff, l2 = std::max (0.0, mean - diff);
  out->cx = cu + u0;
  out->cy = cv + v0;
  out->major = 4 * std::sqrt (l1);
  out->minor = 4 * std::sqrt (l2);
  out->angle = 0.5 * std::atan2 (2 * suv, suu - svv);
  return out->major > 0;
}

bool
predict_marker_image (const CameraGeometry & geometry,
    const MarkerSpec & marker, double gx, double gy, double sx, double sy,
    ImageEllipse * out, std::vector<double> *scratch)
{
  if (!(marker.diameter > 0) || !(sx > 0) || !(sy > 0))
    return false;
  const double r = marker.diameter / 2;
  /* the outline: a circle with centre q, radius rho, spanned by e1, e2 */
  Vec3 q {gx, gy, marker.z}, e1 {1, 0, 0}, e2 {0, 1, 0};
  double rho = r;
  if (marker.ball) {
    const Vec3 c = geometry.centre ();
    const Vec3 d {gx - c.x, gy - c.y, marker.z - c.z};
    const double dist = std::sqrt (d.x * d.x + d.y * d.y + d.z * d.z);
    if (!(dist > r))
      return false;
    const Vec3 u {d.x / dist, d.y / dist, d.z / dist};
    /* the rays that touch the ball meet it on the circle perpendicular to
     * the line of sight, r^2 / dist nearer than the centre */
    q = Vec3 {gx - u.x * r * r / dist, gy - u.y * r * r / dist,
      marker.z - u.z * r * r / dist};
    rho = r * std::sqrt (dist * dist - r * r) / dist;
    /* e1 horizontal and perpendicular to u, e2 = u x e1 */
    const double h = std::hypot (u.x, u.y);
    e1 = h > 1e-12 ? Vec3 {-u.y / h, u.x / h, 0} : Vec3 {0, 1, 0};
    e2 = Vec3 {u.y * e1.z - u.z * e1.y, u.z * e1.x - u.x * e1.z,
      u.x * e1.y - u.y * e1.x};
  }
  std::vector<double> & uv = *scratch;
  uv.resize (2 * kOutlinePoints);
  for (int i = 0; i < kOutlinePoints; i++) {
    const double t = 2 * M_PI * i / kOutlinePoints;
    const double c = std::cos (t) * rho, s = std::sin (t) * rho;
    const Vec3 p {q.x + c * e1.x + s * e2.x, q.y + c * e1.y + s * e2.y,
      q.z + c * e1.z + s * e2.z};
    double u, v;
    if (!geometry.project (p, &u, &v))
      return false;
    uv[2 * i] = (u + 0.5) / sx - 0.5;
    uv[2 * i + 1] = (v + 0.5) / sy - 0.5;
  }
  return polygon_moment_ellipse (uv, out);
}

bool
cut_blob_fits (const ImageEllipse & measured, const ImageEllipse & predicted)
{
  return measured.major <= kCutAxisSlack * predicted.major + kCutOutlinePx
      && measured.minor <= kCutAxisSlack * predicted.minor + kCutOutlinePx;
}

double
ellipse_shape_iou (const ImageEllipse & a, const ImageEllipse & b)
{
  const double a1 = a.major / 2, b1 = a.minor / 2;
  const double a2 = b.major / 2, b2 = b.minor / 2;
  if (!(a1 > 0 && b1 > 0 && a2 > 0 && b2 > 0))
    return 0;
  const double ca = std::cos (a.angle), sa = std::sin (a.angle);
  const double cb = std::cos (b.angle), sb = std::sin (b.angle);
  double inter = 0, uni = 0;
  for (int i = 0; i < kIouSamples; i++) {
    const double r1 = radius_squared (a1, b1, ca, sa, i);
    const double r2 = radius_squared (a2, b2, cb, sb, i);
    inter += std::min (r1, r2);
    uni += std::max (r1, r2);
  }
  return uni > 0 ? inter / uni : 0;
}


double
marker_size_agreement (const CameraGeometry & geometry,
    const BlobObservation & obs, const MarkerSpec & m,
    const RangeEstimate & e, ImageEllipse * predicted,
    std::vector<double> *scratch)
{
  if (!obs.has_ellipse || !predict_marker_image (geometry, m,
          e.ground_x, e.ground_y, obs.sx, obs.sy, predicted, scratch))
    return -1;
  const ImageEllipse measured {obs.eu, obs.ev, obs.major,
    obs.minor, obs.angle};
  return ellipse_shape_iou (measured, *predicted);
}

const MarkerSpec *
choose_marker (const CameraGeometry & geometry, const BlobObservation & obs,
    const std::vector<MarkerSpec> & hypotheses, double pixel_sigma,
    const MountingSigma & mounting, RangeEstimate * e,
    std::vector<double> *scratch)
{
  const MarkerSpec *chosen = nullptr;
  double best_agreement = -1, best_score = HUGE_VAL;
  for (const MarkerSpec & h : hypotheses) {
    const RangeEstimate t = estimate_range (geometry, obs, h, pixel_sigma,
        mounting);
    if (t.no_floor)
      continue;
    ImageEllipse predicted;
    const double agreement = marker_size_agreement (geometry, obs, h, t,
        &predicted, scratch);
    if (agreement >= 0 || best_agreement >= 0) {
      if (agreement > best_agreement) {
        best_agreement = agreement;
        *e = t;
        chosen = &h;
      }
      continue;
    }
    if (!t.has_size)
      continue;
    const double spread = std::hypot (t.range_ground_sigma,
        t.range_size_sigma);
    const double score = std::fabs (t.range_ground - t.range_size) /
        (spread > 0 ? spread : 1e-9);
    if (score < best_score) {
      best_score = score;
      *e = t;
      chosen = &h;
    }
  }
  return chosen;
}

const MarkerSpec *
cut_blob_fits_no_marker (const CameraGeometry & geometry,
    const BlobObservation & obs, const std::vector<MarkerSpec> & hypotheses,
    double pixel_sigma, const MountingSigma & mounting, RangeEstimate * e,
    std::vector<double> *scratch)
{
  const MarkerSpec *first = nullptr;
  RangeEstimate first_range;
  const ImageEllipse measured {obs.eu, obs.ev, obs.major,
    obs.minor, obs.angle};
  for (const MarkerSpec & h : hypotheses) {
    const RangeEstimate t = estimate_range (geometry, obs, h, pixel_sigma,
        mounting);
    ImageEllipse predicted;
    if (t.no_floor || marker_size_agreement (geometry, obs, h, t,
            &predicted, scratch) < 0)
      continue;
    if (cut_blob_fits (measured, predicted))
      return nullptr;
    if (!first) {
      first = &h;
      first_range = t;
    }
  }
  if (first)
    *e = first_range;
  return first;
}

void
add_marker_kind_spread (const CameraGeometry & geometry,
    const BlobObservation & obs, const std::vector<MarkerSpec> & hypotheses,
    double pixel_sigma, const MountingSigma & mounting, RangeEstimate * e)
{
  for (const MarkerSpec & h : hypotheses) {
    const RangeEstimate t = estimate_range (geometry, obs, h, pixel_sigma,
        mounting);
    if (t.no_floor)
      continue;
    e->kind_range_spread = std::max (e->kind_range_spread,
        std::fabs (t.range_ground - e->range_ground));
    e->kind_bearing_spread = std::max (e->kind_bearing_spread,
        std::fabs (std::remainder (t.bearing - e->bearing, 2 * M_PI)));
  }
}

}  // namespace landmark
