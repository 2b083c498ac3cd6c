/* Camera geometry for ranging: see camerageometry.h. */
#include "camerageometry.h"

#include "fileutil.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <cmath>

namespace landmark {

namespace {

constexpr double kDeg = M_PI / 180.0;

}  // namespace

bool
intrinsics_from_hfov (double hfov_deg, int width, int height, double *fx,
    double *fy, double *cx, double *cy)
{
  if (!(hfov_deg > 0.0 && hfov_deg < 180.0) || width < 1 || height < 1)
    return false;
  *fx = *fy = (width / 2.0) / std::tan (hfov_deg * kDeg / 2.0);
  *cx = (width - 1) / 2.0;
  *cy = (height - 1) / 2.0;
  return true;
}

bool
CameraGeometry::configure (const CameraParams & p, std::string * error)
{
  ok_ = false;
  p_ = p;
  if (p.width < 2 || p.height < 2) {
    *error = "image size " + std::to_string (p.width) + "x" +
        std::to_string (p.height) + " is too small";
    return false;
  }
  if (!(p.camera_height > 0) || !std::isfinite (p.camera_height)) {
    *error = "camera-height must be positive, got " + number_text (p.camera_height);
    return false;
  }
  if (p.model == CameraModel::Seed) {
    if (!(p.blind_distance >= 0) || !std::isfinite (p.blind_distance)) {
      *error = "blind-distance must be >= 0, got " + number_text (p.blind_distance);
      return false;
    }
    if (!(p.view_depth > 0) || !std::isfinite (p.view_depth)) {
      *error = "view-depth must be positive, got " + number_text (p.view_depth);
      return false;
    }
    if (!(p.half_width > 0) || !std::isfinite (p.half_width)) {
      *error = "half-width must be positive, got " + number_text (p.half_width);
      return false;
    }
    /* (3.2) tan(gamma) = b/h; (3.3) tan(gamma + alpha) = (b + d)/h;
     * (3.4) tan(beta) = w/(b + d); (3.1) theta = 90 - alpha - gamma */
    const double h = p.camera_height;
    gamma_ = std::atan (p.blind_distance / h);
    alpha_ = std::atan ((p.blind_distance + p.view_depth) / h) - gamma_;
    beta_ = std::atan (p.half_width / (p.blind_distance + p.view_depth));
  } else {
    if (!(p.fx > 0 && p.fy > 0) || !std::isfinite (p.fx)
        || !std::isfinite (p.fy)) {
      *error = "focal lengths must be positive (fx " + number_text (p.fx) + ", fy " +
          number_text (p.fy) + ")";
      return false;
    }
    if (!std::isfinite (p.cx) || !std::isfinite (p.cy)) {
      *error = "principal point is not finite";
      return false;
    }
    if (!(p.tilt_deg >= -90.0 && p.tilt_deg <= 90.0)) {
      *error = "tilt must be within [-90, 90] degrees, got " +
          number_text (p.tilt_deg);
      return false;
    }
    if (!std::isfinite (p.roll_deg)) {
      *error = "roll is not finite";
      return false;
    }
    const double t = p.tilt_deg * kDeg, r = p.roll_deg * kDeg;
    const double xc[3] = { 0, -1, 0 };
    const double yc[3] = { -std::sin (t), 0, -std::cos (t) };
    const double zc[3] = { std::cos (t), 0, -std::sin (t) };
    for (int i = 0; i < 3; i++) {
      r_[0][i] = std::cos (r) * xc[i] + std::sin (r) * yc[i];
      r_[1][i] = -std::sin (r) * xc[i] + std::cos (r) * yc[i];
      r_[2][i] = zc[i];
    }
  }
  ok_ = true;

  /* does any part of the image see the floor? sample the border */
  std::vector<double> uv;
  const int steps = 64;
  for (int i = 0; i <= steps; i++) {
    const double fu = -0.5 + (p.width) * (double) i / steps;
    const double fv = -0.5 + (p.height) * (double) i / steps;
    uv.insert (uv.end (), { fu, -0.5, fu, p.height - 0.5, -0.5, fv,
        p.width - 0.5, fv});
  }
  std::vector<Vec3> dirs;
  rays (uv, &dirs);
  bool floor = false;
  for (const Vec3 & d : dirs)
    floor = floor || d.z < -1e-9;
  if (!floor) {
    ok_ = false;
    if (p.model == CameraModel::Seed)
      *error = "the seed geometry sees no floor";
    else
      *error = "tilt " + number_text (p.tilt_deg) + " degrees with this field of "
          "view sees no floor (the whole image is above the horizon)";
    return false;
  }
  return true;
}

void
CameraGeometry::rays (const std::vector<double> & uv,
    std::vector<Vec3> * out) const
{
  const size_t n = uv.size () / 2;
  out->resize (n);
  if (p_.model == CameraModel::Seed) {
    const double m = p_.width, rows = p_.height;
    for (size_t i = 0; i < n; i++) {
      /* (3.5)-(3.6): angle from the vertical, and lateral angle (right) */
      const double psi = gamma_ + 2 * alpha_ * (rows - 1 - uv[2 * i + 1]) /
          (rows - 1);
      const double phi = beta_ * (2 * uv[2 * i] - m + 1) / (m - 1);
      const double s = std::sin (psi);
      (*out)[i] = Vec3 {s, -s * std::tan (phi), -std::cos (psi)};
    }
    return;
  }
  std::vector<cv::Point2d> norm (n);
  if (p_.dist.empty ()) {
    for (size_t i = 0; i < n; i++)
      norm[i] = cv::Point2d ((uv[2 * i] - p_.cx) / p_.fx,
          (uv[2 * i + 1] - p_.cy) / p_.fy);
  } else if (n > 0) {
    std::vector<cv::Point2d> src (n);
    for (size_t i = 0; i < n; i++)
      src[i] = cv::Point2d (uv[2 * i], uv[2 * i + 1]);
    const cv::Matx33d k (p_.fx, 0, p_.cx, 0, p_.fy, p_.cy, 0, 0, 1);
    cv::undistortPoints (src, norm, k, p_.dist, cv::noArray (),
        cv::noArray (), cv::TermCriteria (cv::TermCriteria::COUNT |
            cv::TermCriteria::EPS, 100, 1e-14));
  }
  for (size_t i = 0; i < n; i++) {
    const double a = norm[i].x, b = norm[i].y;
    (*out)[i] = Vec3 {a * r_[0][0] + b * r_[1][0] + r_[2][0],
      a * r_[0][1] + b * r_[1][1] + r_[2][1],
      a * r_[0][2] + b * r_[1][2] + r_[2][2]};
  }
}

Vec3
CameraGeometry::ray (double u, double v) const
{
  std::vector<Vec3> out;
  rays ({u, v}, &out);
  return out[0];
}

bool
CameraGeometry::intersect (const Vec3 & d, double z0, double *gx,
    double *gy) const
{
  const double dz = z0 - p_.camera_height;
  if (std::fabs (d.z) < 1e-12 || dz == 0)
    return false;
  const double t = dz / d.z;
  if (!(t > 0) || !std::isfinite (t))
    return false;
  *gx = t * d.x;
  *gy = t * d.y;
  return std::isfinite (*gx) && std::isfinite (*gy);
}

bool
CameraGeometry::pixel_to_plane (double u, double v, double z0, double *gx,
    double *gy) const
{
  return intersect (ray (u, v), z0, gx, gy);
}

bool
CameraGeometry::project (const Vec3 & point, double *u, double *v) const
{
  const double px = point.x, py = point.y, pz = point.z - p_.camera_height;
  if (p_.model == CameraModel::Seed) {
    if (!(px > 0))
      return false;
    const double psi = std::atan2 (px, -pz);
    const double phi = std::atan (-py / px);
    const double m = p_.width, n = p_.height;
    *v = n - 1 - (psi - gamma_) * (n - 1) / (2 * alpha_);
    *u = (phi * (m - 1) / beta_ + m - 1) / 2;
    return true;
  }
  const double xc = r_[0][0] * px + r_[0][1] * py + r_[0][2] * pz;
  const double yc = r_[1][0] * px + r_[1][1] * py + r_[1][2] * pz;
  const double zc = r_[2][0] * px + r_[2][1] * py + r_[2][2] * pz;
  if (!(zc > 1e-12))
    return false;
  const std::vector<double> & d = p_.dist;
  if (d.size () > 12) {
    /* the tilted-sensor model: OpenCV's own code (allocates) */
    std::vector<cv::Point3d> obj {cv::Point3d (xc, yc, zc)};
    std::vector<cv::Point2d> img;
    const cv::Matx33d k (p_.fx, 0, p_.cx, 0, p_.fy, p_.cy, 0, 0, 1);
    cv::projectPoints (obj, cv::Vec3d (0, 0, 0), cv::Vec3d (0, 0, 0), k,
        d, img);
    *u = img[0].x;
    *v = img[0].y;
    return true;
  }
  /* OpenCV's distortion model (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]),
   * written out: called per outline point per detection, where
   * cv::projectPoints would allocate */
  auto c = [&d](size_t i) { return i < d.size () ? d[i] : 0.0; };
  const double x = xc / zc, y = yc / zc;
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = (1 + c (0) * r2 + c (1) * r4 + c (4) * r6) /
      (1 + c (5) * r2 + c (6) * r4 + c (7) * r6);
  const double xd = x * radial + 2 * c (2) * x * y + c (3) * (r2 + 2 * x * x)
      + c (8) * r2 + c (9) * r4;
  const double yd = y * radial + c (2) * (r2 + 2 * y * y) + 2 * c (3) * x * y
      + c (10) * r2 + c (11) * r4;
  *u = p_.fx * xd + p_.cx;
  *v = p_.fy * yd + p_.cy;
  return true;
}

}  // namespace landmark
