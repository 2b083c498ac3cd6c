/* Range estimates: see rangeestimate.h. */
#include "rangeestimate.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace landmark {

bool
fit_circle (const std::vector<double> & xy, double *cx, double *cy,
    double *radius)
{
  const size_t n = xy.size () / 2;
  if (n < 3)
    return false;
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; i++) {
    mx += xy[2 * i];
    my += xy[2 * i + 1];
  }
  mx /= n;
  my /= n;
  /* x^2 + y^2 + D x + E y + F = 0, least squares in D, E, F */
  cv::Matx33d a = cv::Matx33d::zeros ();
  cv::Vec3d b (0, 0, 0);
  for (size_t i = 0; i < n; i++) {
    const double x = xy[2 * i] - mx, y = xy[2 * i + 1] - my;
    const cv::Vec3d row (x, y, 1);
    const double rhs = -(x * x + y * y);
    for (int r = 0; r < 3; r++) {
      for (int c = 0; c < 3; c++)
        a (r, c) += row[r] * row[c];
      b[r] += row[r] * rhs;
    }
  }
  cv::Vec3d s;
  if (!cv::solve (a, b, s, cv::DECOMP_SVD))
    return false;
  const double ox = -s[0] / 2, oy = -s[1] / 2;
  const double r2 = ox * ox + oy * oy - s[2];
  if (!(r2 > 0) || !std::isfinite (r2))
    return false;
  *cx = ox + mx;
  *cy = oy + my;
  *radius = std::sqrt (r2);
  return true;
}

bool
outline_offset (const double *linear, int n, double inside, double step,
    int plateau, double *offset, double *sigma)
{
  constexpr int most = 128;
  if (plateau < 3 || n < 2 * plateau + 2 || n > most || !(step > 0))
    return false;
  /* the marker's and the background's light as lines fitted to each end's
   * samples, so that a gradient (the shading across a ball) is carried to
   * the outline rather than taken where it was sampled */
  double in0[3], in1[3], out0[3], out1[3];
  auto fit = [&](int first, double c0[3], double c1[3]) {
    double ms = 0;
    for (int i = first; i < first + plateau; i++)
      ms += (inside + step * i) / plateau;
    for (int c = 0; c < 3; c++) {
      double mc = 0, sxy = 0, sxx = 0;
      for (int i = first; i < first + plateau; i++)
        mc += linear[3 * i + c] / plateau;
      for (int i = first; i < first + plateau; i++) {
        const double ds = inside + step * i - ms;
        sxy += ds * (linear[3 * i + c] - mc);
        sxx += ds * ds;
      }
      c1[c] = sxy / sxx;
      c0[c] = mc - c1[c] * ms;
    }
  };
  fit (0, in0, in1);
  fit (n - plateau, out0, out1);
  /* the share of the marker's light in each sample, along the contrast
   * there; a crossing of one half between two samples is an outline */
  bool found = false;
  double before = 0, slope = 0;
  /* for the sigma: the share's scatter about the fitted lines at both ends
   * (1 inside, 0 outside), and the shares */
  double scatter = 0, share[most];
  for (int i = 0; i < n; i++) {
    const double si = inside + step * i;
    double d[3], dd = 0, num = 0;
    for (int c = 0; c < 3; c++) {
      const double o = out0[c] + out1[c] * si;
      d[c] = in0[c] + in1[c] * si - o;
      dd += d[c] * d[c];
      num += (linear[3 * i + c] - o) * d[c];
    }
    /* a few percent of full scale: less is noise, not an outline */
    if (!(dd > 1e-3))
      return false;
    const double f = num / dd;
    if (i < plateau)
      scatter += (f - 1) * (f - 1);
    else if (i >= n - plateau)
      scatter += f * f;
    share[i] = f;
    if (i > 0 && (before >= 0.5) != (f >= 0.5)) {
      const double s = inside + step * (i - 1 + (before - 0.5) / (before - f));
      if (!found || std::fabs (s) < std::fabs (*offset)) {
        *offset = s;
        slope = std::fabs (before - f) / step;
      }
      found = true;
    }
    before = f;
  }
  if (found && sigma) {
    /* a level crossing moves by the noise over the gradient; an edge
     * whose light is not symmetric about its half-way point (shading
     * that curves near the limb, another edge close by) has the half-way
     * crossing off the middle of its area, within a window about it, by
     * about its own error: that window's area less its half-width */
    const double noise = std::sqrt (scatter / (2 * plateau - 4));
    auto at = [&](double s) {
      const double x = std::min ((double) n - 1, std::max (0.0,
              (s - inside) / step));
      const int i = std::min (n - 2, (int) x);
      return share[i] + (x - i) * (share[i + 1] - share[i]);
    };
    constexpr double window = 1.5;
    const int parts = (int) std::ceil (2 * window / step);
    double area = (at (*offset - window) + at (*offset + window)) / 2;
    for (int j = 1; j < parts; j++)
      area += at (*offset - window + 2 * window * j / parts);
    const double skew = area * 2 * window / parts - window;
    *sigma = std::hypot (noise / slope, skew);
  }
  return found;
}

namespace {

/* the distance from an ellipse's centre to its outline along direction
 * phi: semi-axes a, b, the major at angle */
double
ellipse_radius (double a, double b, double angle, double phi)
{
  const double c = std::cos (phi - angle), s = std::sin (phi - angle);
  return 1 / std::sqrt (c * c / (a * a) + s * s / (b * b));
}

}  // namespace

double
ball_axis_angle (const CameraGeometry & g, const BlobObservation & blob)
{
  const CameraParams & p = g.params ();
  const bool seed = p.model == CameraModel::Seed;
  const double cx = seed ? (p.width - 1) / 2.0 : p.cx;
  const double cy = seed ? (p.height - 1) / 2.0 : p.cy;
  /* in the geometry's pixels, then back to the blob's */
  const double du = ((blob.eu + 0.5) * blob.sx - 0.5 - cx) / blob.sx;
  const double dv = ((blob.ev + 0.5) * blob.sy - 0.5 - cy) / blob.sy;
  if (std::hypot (du, dv) < 1)
    return blob.angle;
  return std::atan2 (dv, du);
}

namespace {

/* Where lo <= slope * x + at <= hi, into [*x0, *x1]; false if nowhere. */
bool
clip_to_band (double slope, double at, double lo, double hi, double *x0,
    double *x1)
{
  if (std::fabs (slope) < 1e-12)
    return at >= lo && at <= hi;
  double a = (lo - at) / slope, b = (hi - at) / slope;
  if (a > b)
    std::swap (a, b);
  *x0 = std::max (*x0, a);
  *x1 = std::min (*x1, b);
  return *x0 <= *x1;
}

}  // namespace

void
measure_end_offsets (BlobObservation * blob, double angle,
    const RowLight & row)
{
  const double a = blob->major / 2, b = blob->minor / 2;
  constexpr double reach = 4, step = 0.25;
  /* the profile reaches 4 px inside: at most half way to the centre, or
   * the ball's colour there is its other side's (and, in a subsampled
   * format, the far edge's chroma) */
  if (!blob->has_ellipse || !(b >= 2 * reach) || !(a >= b))
    return;
  constexpr int n = (int) (2 * reach / step) + 1, plateau = 8;
  /* a row crosses the band over at most its diagonal */
  constexpr int widest = 32;
  double profile[3 * n], weight[n], at[n], even[3 * n], light[3 * widest];
  double found[4], sigma[4];
  /* along the axis both ways, then across it both ways */
  for (int end = 0; end < 4; end++) {
    const double phi = angle + (end < 2 ? end * M_PI : (end - 1.5) * M_PI);
    const double r = ellipse_radius (a, b, blob->angle, phi);
    const double w = ellipse_radius (a, b, blob->angle, phi + M_PI / 2);
    /* the band: up to 2.5 px either side of the line through the centre,
     * each pixel binned by its distance across the outline, the outline
     * a pixel off the line being nearer the centre */
    const double half = std::min (2, (int) (w / 5)) + 0.5;
    const double ca = std::cos (phi), sa = std::sin (phi);
    const double t0 = r * std::sqrt (1 - half * half / (w * w)) - reach
        - step, t1 = r + reach + step;
    double vmin = 1e300, vmax = -1e300;
    for (double t : {t0, t1})
      for (double k : {-half, half}) {
        vmin = std::min (vmin, blob->ev + t * sa + k * ca);
        vmax = std::max (vmax, blob->ev + t * sa + k * ca);
      }
    std::fill (profile, profile + 3 * n, 0.0);
    std::fill (weight, weight + n, 0.0);
    std::fill (at, at + n, 0.0);
    for (int y = (int) std::ceil (vmin); y <= (int) std::floor (vmax); y++) {
      const double dv = y - blob->ev;
      /* the row's pixels inside the band: t0 <= t <= t1, |k| <= half */
      double x0 = -1e300, x1 = 1e300;
      if (!clip_to_band (ca, dv * sa, t0, t1, &x0, &x1)
          || !clip_to_band (-sa, dv * ca, -half, half, &x0, &x1))
        continue;
      const int first = (int) std::ceil (x0 + blob->eu);
      const int count = (int) std::floor (x1 + blob->eu) - first + 1;
      if (count <= 0)
        continue;
      if (count > widest || !row (first, y, count, light))
        return;
      for (int i = 0; i < count; i++) {
        const double du = first + i - blob->eu;
        const double k = -du * sa + dv * ca;
        const double s = du * ca + dv * sa - r * std::sqrt (std::max (0.0,
                1 - k * k / (w * w)));
        /* the nearest bin, which keeps its pixels' mean distance too */
        const int bin = (int) std::lround ((s + reach) / step);
        if (bin < 0 || bin >= n)
          continue;
        weight[bin] += 1;
        at[bin] += s;
        for (int c = 0; c < 3; c++)
          profile[3 * bin + c] += light[3 * i + c];
      }
    }
    /* the bins' means at their pixels' mean distance, the profile taken
     * at even steps between them (a bin's pixels need not sit at its
     * middle; an edge along the pixel grid leaves bins empty) */
    int m = 0;
    for (int j = 0; j < n; j++) {
      if (!(weight[j] > 0))
        continue;
      at[m] = at[j] / weight[j];
      for (int c = 0; c < 3; c++)
        profile[3 * m + c] = profile[3 * j + c] / weight[j];
      m++;
    }
    if (m < 2)
      return;
    for (int e = 0, j = 0; e < n; e++) {
      const double s = -reach + step * e;
      while (j < m - 2 && at[j + 1] < s)
        j++;
      const double f = std::min (1.0, std::max (0.0, (s - at[j]) /
              (at[j + 1] - at[j])));
      for (int c = 0; c < 3; c++)
        even[3 * e + c] = profile[3 * j + c] + f * (profile[3 * (j + 1) + c]
            - profile[3 * j + c]);
    }
    /* beyond a couple of pixels it is another edge, not this outline */
    if (!outline_offset (even, n, -reach, step, plateau, &found[end],
            &sigma[end]) || !(std::fabs (found[end]) < 2))
      return;
  }
  blob->has_ends = true;
  blob->end_angle = angle;
  for (int end = 0; end < 4; end++) {
    blob->end_offset[end] = found[end];
    blob->end_sigma[end] = sigma[end];
  }
}

double
RangeEstimate::range_sigma_total (double sigma) const
{
  return std::sqrt (sigma * sigma + size_excess * size_excess +
      kind_range_spread * kind_range_spread + rim_range * rim_range);
}

double
RangeEstimate::bearing_sigma_total () const
{
  const double excess = range_ground > 0 ? size_excess / range_ground : 0;
  return std::sqrt (bearing_sigma * bearing_sigma + excess * excess +
      kind_bearing_spread * kind_bearing_spread + rim_bearing * rim_bearing);
}

void
centre_covariance (const BlobObservation & blob, double edge_sigma,
    double cov[3])
{
  const double s2 = edge_sigma * edge_sigma;
  double uu, uv = 0, vv;
  if (blob.has_ellipse && blob.major > 0 && blob.minor > 0
      && std::isfinite (blob.major) && std::isfinite (blob.minor)) {
    /* at least half a pixel across: a blob is never thinner */
    const double a = std::max (blob.major, 1.0) / 2;
    const double b = std::max (blob.minor, 1.0) / 2;
    const double ca = std::cos (blob.angle), sa = std::sin (blob.angle);
    constexpr int n = 64;
    /* the points' cosines and sines once (per call they cost more than
     * the sum) */
    static const std::array<std::array<double, 2>, n> unit = [] {
      std::array<std::array<double, 2>, n> u;
      for (int i = 0; i < n; i++) {
        const double t = 2 * M_PI * (i + 0.5) / n;
        u[i] = {std::cos (t), std::sin (t)};
      }
      return u;
    }();
    double ixx = 0, ixy = 0, iyy = 0;
    for (int i = 0; i < n; i++) {
      const double ct = unit[i][0], st = unit[i][1];
      const double x = a * ct, y = b * st;
      const double du = a * st, dv = b * ct;
      const double dl = std::sqrt (du * du + dv * dv) * 2 * M_PI / n;
      const double pu = x * ca - y * sa, pv = x * sa + y * ca;
      ixx += pu * pu * dl;
      ixy += pu * pv * dl;
      iyy += pv * pv * dl;
    }
    const double area = M_PI * a * b;
    uu = s2 * ixx / (area * area);
    uv = s2 * ixy / (area * area);
    vv = s2 * iyy / (area * area);
    /* the ellipse of a whole blob is that of its moments, centred on its
     * centroid; one fitted to what the border left of a blob is centred
     * elsewhere, extrapolated beyond the pixels seen: as uncertain as the
     * extrapolation is long, in any direction */
    if (std::isfinite (blob.eu) && std::isfinite (blob.ev)) {
      const double d2 = std::pow (blob.eu - blob.u, 2) +
          std::pow (blob.ev - blob.v, 2);
      uu += d2;
      vv += d2;
    }
  } else if (blob.equivalent_diameter > 0
      && std::isfinite (blob.equivalent_diameter)) {
    uu = vv = s2 * 2 / (M_PI * std::max (blob.equivalent_diameter, 1.0));
  } else {
    uu = vv = s2;
  }
  cov[0] = uu * blob.sx * blob.sx;
  cov[1] = uv * blob.sx * blob.sy;
  cov[2] = vv * blob.sy * blob.sy;
}

namespace {

Vec3
unit (const Vec3 & d)
{
  const double n = std::sqrt (d.x * d.x + d.y * d.y + d.z * d.z);
  return Vec3 {d.x / n, d.y / n, d.z / n};
}

/* Range and bearing of the plane point of pixel (u, v), for derivatives. */
bool
polar_at (const CameraGeometry & g, double u, double v, double z0,
    double *r, double *b)
{
  double gx, gy;
  if (!g.pixel_to_plane (u, v, z0, &gx, &gy))
    return false;
  *r = std::hypot (gx, gy);
  *b = std::atan2 (gy, gx);
  return true;
}

}  // namespace

RangeEstimate
estimate_range (const CameraGeometry & g, const BlobObservation & blob,
    const MarkerSpec & m, double pixel_sigma, const MountingSigma & mounting)
{
  RangeEstimate out;
  auto to_geom = [&](double u, double v, std::vector<double> *uv) {
    uv->push_back ((u + 0.5) * blob.sx - 0.5);
    uv->push_back ((v + 0.5) * blob.sy - 0.5);
  };
  const bool ellipse = blob.has_ellipse && blob.major > 0 && blob.minor > 0
      && std::isfinite (blob.major) && std::isfinite (blob.minor);
  const double ca = std::cos (blob.angle), sa = std::sin (blob.angle);
  const double a = blob.major / 2, b = blob.minor / 2;

  Vec3 axis;                    /* direction of the marker centre */
  bool have_axis = false;
  double size_distance = 0;     /* slant distance from size, metres */
  double size_rel_sigma = 0;
  double centre_u, centre_v;    /* for derivatives, geometry pixels */

  /* a ball's major axis between the outline's ends where the frame showed
   * them (measure_end_offsets), else the ellipse's */
  const bool ends = ellipse && blob.has_ends;
  const double ra = ends ? ellipse_radius (a, b, blob.angle,
      blob.end_angle) : a;
  const double a_plus = ra + (ends ? blob.end_offset[0] : 0);
  const double a_minus = ra + (ends ? blob.end_offset[1] : 0);
  const double ea = ends ? std::cos (blob.end_angle) : ca;
  const double eb = ends ? std::sin (blob.end_angle) : sa;
  /* the axis through the middle of the outline's width, not the blob's */
  const double across = ends ? (blob.end_offset[2] - blob.end_offset[3]) / 2
      : 0;
  const double mu = blob.eu - across * eb, mv = blob.ev + across * ea;
  const double major = a_plus + a_minus;
  if (ellipse && m.ball) {
    std::vector<double> uv;
    to_geom (mu + a_plus * ea, mv + a_plus * eb, &uv);
    to_geom (mu - a_minus * ea, mv - a_minus * eb, &uv);
    std::vector<Vec3> d;
    g.rays (uv, &d);
    const Vec3 d1 = unit (d[0]), d2 = unit (d[1]);
    axis = unit (Vec3 {d1.x + d2.x, d1.y + d2.y, d1.z + d2.z});
    have_axis = true;
    const double cosang = std::min (1.0, d1.x * d2.x + d1.y * d2.y +
        d1.z * d2.z);
    const double half = std::acos (cosang) / 2;
    if (m.diameter > 0 && half > 0) {
      size_distance = (m.diameter / 2) / std::sin (half);
      /* with the frame's ends, their own errors too */
      size_rel_sigma = (ends ? std::hypot (pixel_sigma, std::hypot
              (blob.end_sigma[0], blob.end_sigma[1])) : pixel_sigma) / major;
    }
    centre_u = (uv[0] + uv[2]) / 2;
    centre_v = (uv[1] + uv[3]) / 2;
  } else if (ellipse) {
    /* the circle on the marker's plane through the outline grown by
     * `grow` pixels along both axes */
    auto fit_disc = [&](double grow, double *ox, double *oy, double *radius) {
      const int n = 48;
      std::vector<double> uv;
      for (int i = 0; i < n; i++) {
        const double t = 2 * M_PI * i / n;
        const double x = (a + grow) * std::cos (t);
        const double y = (b + grow) * std::sin (t);
        to_geom (blob.eu + x * ca - y * sa, blob.ev + x * sa + y * ca, &uv);
      }
      std::vector<Vec3> d;
      g.rays (uv, &d);
      std::vector<double> plane;
      for (const Vec3 & di : d) {
        double gx, gy;
        if (!g.intersect (di, m.z, &gx, &gy))
          return false;
        plane.push_back (gx);
        plane.push_back (gy);
      }
      return fit_circle (plane, ox, oy, radius);
    };
    double ox, oy, radius;
    if (fit_disc (0, &ox, &oy, &radius)) {
      axis = unit (Vec3 {ox, oy, m.z - g.params ().camera_height});
      have_axis = true;
      /* the rim: blur and the colour threshold put the outline off the
       * disc's edge by the same amount all round, which the plane's
       * perspective turns into a shift of the centre (the far side's
       * pixels are wider); the known diameter measures that offset */
      double gx, gy, grown;
      const double h = 0.5;
      if (m.diameter > 0 && fit_disc (h, &gx, &gy, &grown)
          && grown > radius) {
        /* the offset in pixels (positive: eroded), times the centre's
         * move per pixel of growth */
        const double offset_px = h * (m.diameter / 2 - radius)
            / (grown - radius);
        const double range_per_px = (std::hypot (gx, gy)
            - std::hypot (ox, oy)) / h;
        const double bearing_per_px = std::remainder (std::atan2 (gy, gx)
            - std::atan2 (oy, ox), 2 * M_PI) / h;
        out.rim_range = std::fabs (offset_px * range_per_px);
        out.rim_bearing = std::fabs (offset_px * bearing_per_px);
      }
      if (m.diameter > 0) {
        /* the plane's distance below the camera scales the circle: the
         * size estimate needs no camera height */
        const double slant = std::sqrt (ox * ox + oy * oy +
            std::pow (m.z - g.params ().camera_height, 2));
        size_distance = slant * (m.diameter / 2) / radius;
        size_rel_sigma = pixel_sigma / blob.minor;
      }
    }
    std::vector<double> c;
    to_geom (blob.eu, blob.ev, &c);
    centre_u = c[0];
    centre_v = c[1];
  }
  if (!have_axis) {
    std::vector<double> c;
    to_geom (blob.u, blob.v, &c);
    centre_u = c[0];
    centre_v = c[1];
    axis = unit (g.ray (c[0], c[1]));
    have_axis = true;
    if (m.diameter > 0 && blob.equivalent_diameter > 0) {
      /* apparent angular size from the equivalent diameter */
      const Vec3 d1 = unit (g.ray (c[0] - blob.equivalent_diameter *
              blob.sx / 2, c[1]));
      const Vec3 d2 = unit (g.ray (c[0] + blob.equivalent_diameter *
              blob.sx / 2, c[1]));
      const double half = std::acos (std::min (1.0, d1.x * d2.x +
              d1.y * d2.y + d1.z * d2.z)) / 2;
      if (half > 0) {
        size_distance = (m.diameter / 2) / std::tan (half);
        size_rel_sigma = pixel_sigma / blob.equivalent_diameter + 0.05;
      }
    }
  }

  /* bearing from the axis's horizontal direction */
  double gx, gy;
  const bool hit = g.intersect (axis, m.z, &gx, &gy);
  out.no_floor = !hit;
  if (!hit)
    return out;
  out.ground_x = gx;
  out.ground_y = gy;
  out.range_ground = std::hypot (gx, gy);
  out.bearing = std::atan2 (gy, gx);

  /* uncertainty: the centre's image covariance through the derivatives of
   * range and bearing at the centre (central differences) */
  double cov[3];
  centre_covariance (blob, pixel_sigma, cov);
  if (m.ball && ends) {
    /* the ends' own errors (outline_offset's sigmas): the centre along the
     * axis is the mean of the two ends along it, across it of the two
     * across; in place of the shading's share, which the frame's outline
     * measures */
    const double s_along = std::hypot (blob.end_sigma[0], blob.end_sigma[1])
        / 2;
    const double s_across = std::hypot (blob.end_sigma[2],
        blob.end_sigma[3]) / 2;
    const double al = s_along * s_along, ac = s_across * s_across;
    cov[0] += (al * ea * ea + ac * eb * eb) * blob.sx * blob.sx;
    cov[1] += (al - ac) * ea * eb * blob.sx * blob.sy;
    cov[2] += (al * eb * eb + ac * ea * ea) * blob.sy * blob.sy;
  } else if (m.ball) {
    const double shade = kBallShadeShare * (ellipse ? major :
        blob.equivalent_diameter);
    cov[0] += shade * shade * blob.sx * blob.sx;
    cov[2] += shade * shade * blob.sy * blob.sy;
  }
  const double h = 0.5;
  double rl, bl, rr, br, ru, bu, rd, bd;
  double range_v = 0, bearing_v = 0;    /* per geometry pixel down */
  if (polar_at (g, centre_u - h, centre_v, m.z, &rl, &bl)
      && polar_at (g, centre_u + h, centre_v, m.z, &rr, &br)
      && polar_at (g, centre_u, centre_v - h, m.z, &ru, &bu)
      && polar_at (g, centre_u, centre_v + h, m.z, &rd, &bd)) {
    const double r_u = (rr - rl) / (2 * h), r_v = (rd - ru) / (2 * h);
    const double b_u = std::remainder (br - bl, 2 * M_PI) / (2 * h);
    const double b_v = std::remainder (bd - bu, 2 * M_PI) / (2 * h);
    range_v = r_v;
    bearing_v = b_v;
    out.range_ground_sigma = std::sqrt (std::max (0.0, r_u * r_u * cov[0]
            + 2 * r_u * r_v * cov[1] + r_v * r_v * cov[2]));
    out.bearing_sigma = std::sqrt (std::max (0.0, b_u * b_u * cov[0]
            + 2 * b_u * b_v * cov[1] + b_v * b_v * cov[2]));
  } else {
    /* next to the horizon: the ground range is barely constrained */
    out.range_ground_sigma = out.range_ground;
    out.bearing_sigma = pixel_sigma / std::max (1.0, g.params ().fx);
  }
  /* the mounting: a height error scales the plane's distance below the
   * camera, and so the range; a tilt error turns every ray's angle of
   * depression phi, and r = H / tan phi moves by (r^2 + H^2) / H per
   * radian (H the height above the marker's plane). The bearing moves
   * with the tilt only off the optical axis, to second order: left out. */
  const double below = g.params ().camera_height - m.z;
  if (below > 0) {
    const double r = out.range_ground;
    const double s_h = r * mounting.height_rel * g.params ().camera_height
        / below;
    const double s_t = (r * r + below * below) / below * mounting.tilt;
    out.range_ground_sigma = std::sqrt (out.range_ground_sigma *
        out.range_ground_sigma + s_h * s_h + s_t * s_t);
  }
  if (size_distance > 0 && std::isfinite (size_distance)) {
    const double horiz = std::hypot (axis.x, axis.y);
    out.has_size = true;
    out.range_size = size_distance * horiz;
    out.range_size_sigma = out.range_size * size_rel_sigma;
    /* whole blobs disagree by less than 0.5 px of their axis (docs/
     * ranging.md); beyond what both sigmas explain at 99 % the blob is cut
     * or merged and its centre is off by about that much */
    const double d = out.range_size - out.range_ground;
    const double excess = d * d - 6.63 * (out.range_ground_sigma *
        out.range_ground_sigma + out.range_size_sigma *
        out.range_size_sigma);
    if (excess > 0)
      out.size_excess = std::sqrt (excess);
  }
  /* a ball's rim: its outline is off its edge by the offset its size
   * range gives (the major axis against the one the floor range predicts,
   * per side), but the shading takes it from the underside rather than all
   * round, so the centre may move down the image by as much */
  if (m.ball && ellipse && !ends && out.has_size && out.range_ground > 0) {
    const double offset = major / 2 *
        (out.range_size / out.range_ground - 1) * blob.sy;
    out.rim_range = std::fabs (offset * range_v);
    out.rim_bearing = std::fabs (offset * bearing_v);
  }
  /* a blob cut or merged shows in its own ellipse, or in the frame's
   * outline (which may agree with a wrong centre where the outline found
   * ends where the blob ended, or run off into a blur or a neighbour):
   * then the frame's ends are no better than the blob's, and the blob's
   * ellipse ranges it, with its excess */
  if (m.ball && ends) {
    BlobObservation own = blob;
    own.has_ends = false;
    const RangeEstimate by_blob = estimate_range (g, own, m, pixel_sigma,
        mounting);
    if (out.size_excess > 0 || by_blob.size_excess > 0)
      return by_blob;
  }
  /* a disagreement beyond the bound is a cut or merged blob, not a rim:
   * size_excess stands for it */
  if (out.size_excess > 0)
    out.rim_range = out.rim_bearing = 0;
  return out;
}

}  // namespace landmark
