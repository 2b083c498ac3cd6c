/* Range and bearing of an upright coded marker (beaconrange.h). */
#include "beaconrange.h"

#include <algorithm>
#include <cmath>

namespace landmark {

namespace {

/* The axis of a marker whose base's nearest point images at (u, v). */
struct Axis {
  bool ok = false;
  double x = 0, y = 0, range = 0, bearing = 0;
};

Axis
axis_at (const CameraGeometry & g, const CodedMarkerSize & m, double u,
    double v)
{
  Axis a;
  double fx, fy;
  if (!g.pixel_to_plane (u, v, m.z, &fx, &fy))
    return a;
  a.bearing = std::atan2 (fy, fx);
  a.range = std::hypot (fx, fy) + 0.5 * m.diameter;
  a.x = a.range * std::cos (a.bearing);
  a.y = a.range * std::sin (a.bearing);
  a.ok = true;
  return a;
}

/* A central difference of f over +-step, one-sided where one side fails;
 * false when both do. */
template <typename F>
bool
derivative (F f, double step, double *out)
{
  double lo, hi, mid;
  const bool l = f (-step, &lo), h = f (step, &hi);
  if (l && h) {
    *out = (hi - lo) / (2 * step);
    return true;
  }
  if (!f (0.0, &mid) || (!l && !h))
    return false;
  *out = h ? (hi - mid) / step : (mid - lo) / step;
  return true;
}

}  // namespace

bool
coded_marker_image_height (const CameraGeometry & g,
    const CodedMarkerSize & m, double x, double y, double *height_px)
{
  const double r = 0.5 * m.diameter, range = std::hypot (x, y);
  if (range <= r)
    return false;
  const double cb = x / range, sb = y / range, top = m.z + m.height;
  double ub, vb;
  if (!g.project (Vec3 {(range - r) * cb, (range - r) * sb, m.z}, &ub, &vb))
    return false;
  /* the top of the silhouette: a cone's apex; a cylinder's top edge,
   * whose far side is highest in the image seen from above it and its
   * near side seen from below */
  const double tops[2] = { m.cone ? range : range - r, m.cone ? range :
        range + r };
  double best = -1;
  for (double t : tops) {
    double u, v;
    if (g.project (Vec3 {t * cb, t * sb, top}, &u, &v))
      best = std::max (best, std::hypot (u - ub, v - vb));
  }
  *height_px = best;
  return best >= 0;
}

RangeEstimate
estimate_coded_range (const CameraGeometry & g, const CodedObservation & obs,
    const CodedMarkerSize & m, double pixel_sigma,
    const MountingSigma & mounting)
{
  RangeEstimate e;
  const Axis a = axis_at (g, m, obs.base_u, obs.base_v);
  if (!a.ok)
    return e;
  e.no_floor = false;
  e.ground_x = a.x;
  e.ground_y = a.y;
  e.range_ground = a.range;
  e.bearing = a.bearing;

  /* the base point's error moves the range and bearing by the camera's
   * derivatives; a tilt error moves it by fy pixels a radian */
  double dr_dv = 0, db_du = 0;
  derivative ([&](double d, double *out) {
        const Axis s = axis_at (g, m, obs.base_u, obs.base_v + d);
        *out = s.range;
        return s.ok;
      }, 1.0, &dr_dv);
  derivative ([&](double d, double *out) {
        const Axis s = axis_at (g, m, obs.base_u + d, obs.base_v);
        *out = s.bearing;
        return s.ok;
      }, 1.0, &db_du);
  const double fy = g.params ().fy > 0 ? g.params ().fy : g.params ().height;
  const double pix = dr_dv * pixel_sigma;
  const double height = (a.range - 0.5 * m.diameter) * mounting.height_rel;
  const double tilt = dr_dv * fy * mounting.tilt;
  e.range_ground_sigma = std::sqrt (pix * pix + height * height +
      tilt * tilt);
  e.bearing_sigma = std::fabs (db_du) * pixel_sigma;

  if (!obs.whole || m.diameter <= 0 || m.height <= 0 || obs.height_px <= 2)
    return e;
  /* the range along the bearing at which the marker images as tall as
   * seen: the image shrinks with range, so bisect (geometrically) */
  const double cb = std::cos (a.bearing), sb = std::sin (a.bearing);
  const double seen = obs.height_px - obs.outline_growth_px;
  auto excess = [&](double range, double *out) {
    double h;
    if (!coded_marker_image_height (g, m, range * cb, range * sb, &h))
      return false;
    *out = h - seen;
    return true;
  };
  double lo = 0.5 * m.diameter + 0.01, hi = 1000.0, f;
  while (lo < hi && !(excess (lo, &f) && f > 0))
    lo *= 1.25;
  if (!(excess (hi, &f) && f < 0) || lo >= hi)
    return e;
  for (int i = 0; i < 60; i++) {
    const double mid = std::sqrt (lo * hi);
    if (excess (mid, &f) && f > 0)
      lo = mid;
    else
      hi = mid;
  }
  const double range = std::sqrt (lo * hi);
  double dh_dr;
  if (!derivative ([&](double d, double *out) {
            return excess (range + d, out);
          }, 1e-3 * range, &dh_dr) || dh_dr >= 0)
    return e;
  e.has_size = true;
  e.range_size = range;
  /* both ends of the length are outline points */
  e.range_size_sigma = std::sqrt (2.0) * pixel_sigma / -dh_dr;
  return e;
}

}  // namespace landmark
