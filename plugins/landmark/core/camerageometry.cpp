/* Camera geometry for ranging: see camerageometry.h. */
#include "camerageometry.h"

#include "fileutil.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

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

/* The matrix under key a (or b): 0 when absent, 1 when read into *m, -1
 * when refused unread. OpenCV allocates what a matrix declares before it
 * counts the data, so a matrix is decoded only when it declares integer
 * rows and cols with at most max_values values (*declared: rows x cols). */
static int
read_matrix (const cv::FileStorage & fs, const char *a, const char *b,
    double max_values, cv::Mat * m, double *declared)
{
  cv::FileNode n = fs[a];
  if (n.empty ())
    n = fs[b];
  if (n.empty ())
    return 0;
  m->release ();
  *declared = -1;
  const cv::FileNode rows = n["rows"], cols = n["cols"];
  if (!n.isMap () || !rows.isInt () || !cols.isInt ()
      || (int) rows < 0 || (int) cols < 0)
    return -1;
  *declared = (double) (int) rows * (double) (int) cols;
  if (*declared > max_values)
    return -1;
  n >> *m;
  return 1;
}

/* A real number under key, when present; false (with *error) when the key
 * is there but not a finite number. */
static bool
read_real (const cv::FileStorage & fs, const std::string & path,
    const char *key, bool *present, double *value, std::string * error)
{
  const cv::FileNode n = fs[key];
  *present = !n.empty ();
  if (!*present)
    return true;
  if (!n.isReal () && !n.isInt ()) {
    *error = path + ": " + key + " is not a number";
    return false;
  }
  *value = (double) n;
  if (!std::isfinite (*value)) {
    *error = path + ": " + key + " is not finite";
    return false;
  }
  return true;
}

bool
parse_camera_file (const std::string & path, CameraFile * out,
    std::string * error)
{
  *out = CameraFile ();
  {
    std::ifstream f (path);
    if (!f.good ()) {
      *error = path + ": cannot open the calibration file";
      return false;
    }
  }
  /* before reading: a device such as /dev/zero never ends */
  if (!config_file_size_ok (path, error))
    return false;
  {
    /* OpenCV answers an empty file with an internal assertion text */
    std::ifstream f (path);
    std::string word;
    if (!(f >> word)) {
      struct stat st;
      *error = path + (stat (path.c_str (), &st) == 0 && S_ISDIR (st.st_mode)
          ? ": is a directory, not a calibration file"
          : ": the calibration file is empty");
      return false;
    }
  }
  try {
    cv::FileStorage fs (path, cv::FileStorage::READ);
    if (!fs.isOpened ()) {
      *error = path + ": not an OpenCV FileStorage file (YAML or XML)";
      return false;
    }
    const cv::FileNode model = fs["model"];
    if (!model.empty ()) {
      const std::string name = model.isString ()? (std::string) model : "";
      if (name == "seed") {
        out->seed = true;
      } else if (name != "pinhole") {
        *error = path + ": unknown model '" + name + "' (expected seed, or "
            "a pinhole file with camera_matrix)";
        return false;
      }
    }
    if (!fs["image_width"].empty ())
      fs["image_width"] >> out->image_width;
    if (!fs["image_height"].empty ())
      fs["image_height"] >> out->image_height;
    if (out->image_width < 0 || out->image_height < 0) {
      *error = path + ": image_width and image_height must be positive";
      return false;
    }
    if (out->image_width > kMaxCameraImageSize
        || out->image_height > kMaxCameraImageSize) {
      *error = path + ": image_width and image_height must be at most " +
          std::to_string (kMaxCameraImageSize) + ", got " +
          std::to_string (out->image_width) + "x" +
          std::to_string (out->image_height);
      return false;
    }
    double v = 0;
    bool present = false;
    if (!read_real (fs, path, "camera_height", &present, &v, error))
      return false;
    if (present) {
      if (!(v > 0)) {
        *error = path + ": camera_height must be positive (metres), got " +
            number_text (v);
        return false;
      }
      out->has_camera_height = true;
      out->camera_height = v;
    }

    if (out->seed) {
      if (!out->has_camera_height) {
        *error = path + ": a seed file (model: seed) needs camera_height";
        return false;
      }
      const char *keys[] = { "blind_distance", "view_depth", "half_width" };
      double *dst[] = { &out->blind_distance, &out->view_depth,
        &out->half_width
      };
      for (int i = 0; i < 3; i++) {
        if (!read_real (fs, path, keys[i], &present, dst[i], error))
          return false;
        if (!present) {
          *error = path + ": a seed file (model: seed) needs " + keys[i];
          return false;
        }
        if (!(*dst[i] > 0)) {
          *error = path + ": " + keys[i] + " must be positive (metres), got "
              + number_text (*dst[i]);
          return false;
        }
      }
      /* tilt_deg and the fields of view in a seed file are derived from
       * the four lengths: not read */
      return true;
    }

    if (!read_real (fs, path, "tilt_deg", &out->has_tilt, &out->tilt_deg,
            error)
        || !read_real (fs, path, "roll_deg", &out->has_roll, &out->roll_deg,
            error))
      return false;
    if (out->has_tilt && !(out->tilt_deg >= -90 && out->tilt_deg <= 90)) {
      *error = path + ": tilt_deg must be within [-90, 90] degrees, got " +
          number_text (out->tilt_deg);
      return false;
    }

    cv::Mat k, d;
    double declared = 0;
    const int have_k = read_matrix (fs, "camera_matrix", "cameraMatrix", 9,
        &k, &declared);
    if (have_k == 0) {
      *error = path + ": no camera_matrix (nor model: seed)";
      return false;
    }
    if (k.rows != 3 || k.cols != 3 || k.channels () != 1) {
      *error = path + ": camera_matrix is not 3x3";
      return false;
    }
    k.convertTo (k, CV_64F);
    out->fx = k.at<double> (0, 0);
    out->fy = k.at<double> (1, 1);
    out->cx = k.at<double> (0, 2);
    out->cy = k.at<double> (1, 2);
    if (!(out->fx > 0 && out->fy > 0) || !std::isfinite (out->fx)
        || !std::isfinite (out->fy) || !std::isfinite (out->cx)
        || !std::isfinite (out->cy) || k.at<double> (1, 0) != 0
        || k.at<double> (2, 0) != 0 || k.at<double> (2, 1) != 0
        || k.at<double> (2, 2) != 1.0) {
      *error = path + ": camera_matrix is not a camera matrix (fx, fy > 0, "
          "last row 0 0 1)";
      return false;
    }
    const int have_d = read_matrix (fs, "distortion_coefficients",
        "distCoeffs", 14, &d, &declared);
    if (have_d < 0 && declared < 0) {
      *error = path + ": distortion_coefficients is not an OpenCV matrix "
          "(rows, cols, dt, data)";
      return false;
    }
    if (have_d != 0 && (have_d < 0 || !d.empty ())) {
      const size_t n = d.total ();
      if (d.channels () != 1 || !(n == 4 || n == 5 || n == 8 || n == 12
              || n == 14)) {
        *error = path + ": distortion_coefficients must have 4, 5, 8, 12 or "
            "14 values, has " + (have_d < 0 ? number_text (declared) :
            std::to_string (n));
        return false;
      }
      d = d.reshape (1, 1);
      d.convertTo (d, CV_64F);
      for (size_t i = 0; i < n; i++) {
        const double c = d.at<double> (0, (int) i);
        if (!std::isfinite (c)) {
          *error = path + ": distortion_coefficients are not finite";
          return false;
        }
        out->dist.push_back (c);
      }
    }
  }
  catch (const cv::Exception & e) {
    *error = path + ": cannot parse the calibration file: " + e.msg;
    return false;
  }
  catch (const std::exception & e) {
    /* OpenCV's parsers also throw standard exceptions on some malformed
     * files (std::length_error from a misplaced key) */
    *error = path + ": cannot parse the calibration file: " + e.what ();
    return false;
  }
  return true;
}

bool
load_calibration (const std::string & path, double *fx, double *fy,
    double *cx, double *cy, std::vector<double> *dist, int *image_width,
    int *image_height, std::string * error)
{
  CameraFile f;
  if (!load_camera_file (path, &f, error))
    return false;
  if (f.seed) {
    *error = path + ": a seed-model file has no camera_matrix";
    return false;
  }
  *fx = f.fx;
  *fy = f.fy;
  *cx = f.cx;
  *cy = f.cy;
  *dist = f.dist;
  *image_width = f.image_width;
  *image_height = f.image_height;
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
  /* the lookup table is built on first use (lookup ()) */
  lut_range_.clear ();
  lut_bearing_.clear ();
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
CameraGeometry::seed_floor (double u, double v, double *y_ahead,
    double *x_right) const
{
  if (p_.model != CameraModel::Seed)
    return false;
  const double m = p_.width, n = p_.height;
  const double psi = gamma_ + 2 * alpha_ * (n - 1 - v) / (n - 1);
  if (psi >= M_PI_2_)
    return false;
  *y_ahead = p_.camera_height * std::tan (psi);
  *x_right = *y_ahead * std::tan (beta_ * (2 * u - m + 1) / (m - 1));
  return true;
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

void
CameraGeometry::build_lut () const
{
  const int w = p_.width, h = p_.height;
  std::vector<double> uv;
  uv.reserve ((size_t) w * h * 2);
  for (int v = 0; v < h; v++)
    for (int u = 0; u < w; u++) {
      uv.push_back (u);
      uv.push_back (v);
    }
  std::vector<Vec3> dirs;
  rays (uv, &dirs);
  lut_range_.assign ((size_t) w * h, std::numeric_limits<float>::quiet_NaN ());
  lut_bearing_.assign ((size_t) w * h,
      std::numeric_limits<float>::quiet_NaN ());
  for (size_t i = 0; i < dirs.size (); i++) {
    double gx, gy;
    if (intersect (dirs[i], 0.0, &gx, &gy)) {
      lut_range_[i] = (float) std::hypot (gx, gy);
      lut_bearing_[i] = (float) std::atan2 (gy, gx);
    }
  }
}

bool
CameraGeometry::lookup (int u, int v, double *range, double *bearing) const
{
  if (!ok_ || u < 0 || v < 0 || u >= p_.width || v >= p_.height)
    return false;
  if (lut_range_.empty ())
    build_lut ();
  const size_t i = (size_t) v * p_.width + u;
  if (std::isnan (lut_range_[i]))
    return false;
  *range = lut_range_[i];
  *bearing = lut_bearing_[i];
  return true;
}

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

}  // namespace landmark

namespace landmark {

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
    const MarkerSpec & m, double pixel_sigma)
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

  if (ellipse && m.ball) {
    std::vector<double> uv;
    to_geom (blob.eu + a * ca, blob.ev + a * sa, &uv);
    to_geom (blob.eu - a * ca, blob.ev - a * sa, &uv);
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
      size_rel_sigma = pixel_sigma / blob.major;
    }
    centre_u = (uv[0] + uv[2]) / 2;
    centre_v = (uv[1] + uv[3]) / 2;
  } else if (ellipse) {
    const int n = 48;
    std::vector<double> uv;
    for (int i = 0; i < n; i++) {
      const double t = 2 * M_PI * i / n;
      const double x = a * std::cos (t), y = b * std::sin (t);
      to_geom (blob.eu + x * ca - y * sa, blob.ev + x * sa + y * ca, &uv);
    }
    std::vector<Vec3> d;
    g.rays (uv, &d);
    std::vector<double> plane;
    for (const Vec3 & di : d) {
      double gx, gy;
      if (!g.intersect (di, m.z, &gx, &gy))
        break;
      plane.push_back (gx);
      plane.push_back (gy);
    }
    double ox, oy, radius;
    if (plane.size () == 2 * (size_t) n && fit_circle (plane, &ox, &oy,
            &radius)) {
      axis = unit (Vec3 {ox, oy, m.z - g.params ().camera_height});
      have_axis = true;
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

  /* uncertainty: a pixel_sigma error of the centre point, propagated */
  double r0, b0, ru, bu, rv, bv;
  if (polar_at (g, centre_u, centre_v, m.z, &r0, &b0)
      && polar_at (g, centre_u + 1, centre_v, m.z, &ru, &bu)
      && polar_at (g, centre_u, centre_v + 1, m.z, &rv, &bv)) {
    const double dbu = std::remainder (bu - b0, 2 * M_PI);
    const double dbv = std::remainder (bv - b0, 2 * M_PI);
    out.range_ground_sigma = pixel_sigma * std::hypot (ru - r0, rv - r0);
    out.bearing_sigma = pixel_sigma * std::hypot (dbu, dbv);
  } else {
    /* next to the horizon: the ground range is barely constrained */
    out.range_ground_sigma = out.range_ground;
    out.bearing_sigma = pixel_sigma / std::max (1.0, g.params ().fx);
  }
  if (size_distance > 0 && std::isfinite (size_distance)) {
    const double horiz = std::hypot (axis.x, axis.y);
    out.has_size = true;
    out.range_size = size_distance * horiz;
    out.range_size_sigma = out.range_size * size_rel_sigma;
  }
  return out;
}


namespace {

/* The child's answer through the pipe: fixed fields, the distortion
 * coefficients, the error text. */
struct CameraFileWire {
  uint8_t ok, seed, has_camera_height, has_tilt, has_roll;
  int32_t image_width, image_height;
  double fx, fy, cx, cy, camera_height, tilt_deg, roll_deg;
  double blind_distance, view_depth, half_width;
  uint32_t n_dist, n_error;
};

std::string
encode_camera_file (bool ok, const CameraFile & f, const std::string & error)
{
  CameraFileWire w {};
  w.ok = ok;
  w.seed = f.seed;
  w.has_camera_height = f.has_camera_height;
  w.has_tilt = f.has_tilt;
  w.has_roll = f.has_roll;
  w.image_width = f.image_width;
  w.image_height = f.image_height;
  w.fx = f.fx;
  w.fy = f.fy;
  w.cx = f.cx;
  w.cy = f.cy;
  w.camera_height = f.camera_height;
  w.tilt_deg = f.tilt_deg;
  w.roll_deg = f.roll_deg;
  w.blind_distance = f.blind_distance;
  w.view_depth = f.view_depth;
  w.half_width = f.half_width;
  w.n_dist = (uint32_t) f.dist.size ();
  w.n_error = (uint32_t) error.size ();
  std::string out ((const char *) &w, sizeof w);
  if (!f.dist.empty ())
    out.append ((const char *) f.dist.data (),
        f.dist.size () * sizeof (double));
  out += error;
  return out;
}

bool
decode_camera_file (const std::string & in, CameraFile * f,
    std::string * error, bool *ok)
{
  CameraFileWire w;
  if (in.size () < sizeof w)
    return false;
  memcpy (&w, in.data (), sizeof w);
  if (in.size () != sizeof w + w.n_dist * sizeof (double) + w.n_error)
    return false;
  *ok = w.ok;
  f->seed = w.seed;
  f->has_camera_height = w.has_camera_height;
  f->has_tilt = w.has_tilt;
  f->has_roll = w.has_roll;
  f->image_width = w.image_width;
  f->image_height = w.image_height;
  f->fx = w.fx;
  f->fy = w.fy;
  f->cx = w.cx;
  f->cy = w.cy;
  f->camera_height = w.camera_height;
  f->tilt_deg = w.tilt_deg;
  f->roll_deg = w.roll_deg;
  f->blind_distance = w.blind_distance;
  f->view_depth = w.view_depth;
  f->half_width = w.half_width;
  f->dist.resize (w.n_dist);
  if (w.n_dist)                 /* memcpy to NULL is undefined, even for 0 */
    memcpy (f->dist.data (), in.data () + sizeof w,
        w.n_dist * sizeof (double));
  error->assign (in, sizeof w + w.n_dist * sizeof (double), w.n_error);
  return true;
}

}  // namespace

bool
load_camera_file (const std::string & path, CameraFile * out,
    std::string * error)
{
  *out = CameraFile ();
  /* OpenCV's FileStorage parsers loop forever or overflow the stack on
   * some malformed files (found by fuzzing: a '%' inside a YAML
   * document); a child process parses, so that a bad file costs an error
   * message, never the application. */
  int fds[2];
  if (pipe (fds) != 0)
    return parse_camera_file (path, out, error);
  const pid_t pid = fork ();
  if (pid < 0) {
    close (fds[0]);
    close (fds[1]);
    return parse_camera_file (path, out, error);
  }
  if (pid == 0) {
    close (fds[0]);
    CameraFile f;
    std::string err;
    const bool ok = parse_camera_file (path, &f, &err);
    const std::string msg = encode_camera_file (ok, f, err);
    size_t done = 0;
    while (done < msg.size ()) {
      const ssize_t n = write (fds[1], msg.data () + done, msg.size () - done);
      if (n <= 0 && errno != EINTR)
        break;
      if (n > 0)
        done += (size_t) n;
    }
    _exit (done == msg.size ()? 0 : 1);
  }
  close (fds[1]);
  std::string msg;
  const auto deadline = std::chrono::steady_clock::now () +
      std::chrono::seconds (kCameraFileParseSeconds);
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>
        (deadline - std::chrono::steady_clock::now ()).count ();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    struct pollfd p = { fds[0], POLLIN, 0 };
    const int r = poll (&p, 1, (int) left);
    if (r < 0 && errno == EINTR)
      continue;
    if (r <= 0) {
      timed_out = r == 0;
      break;
    }
    char buf[4096];
    const ssize_t n = read (fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
      break;
    msg.append (buf, (size_t) n);
  }
  close (fds[0]);
  if (timed_out)
    kill (pid, SIGKILL);
  int status = 0;
  while (waitpid (pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    *error = path + ": OpenCV's parser did not finish within " +
        std::to_string (kCameraFileParseSeconds) + " s (a malformed file)";
    return false;
  }
  if (WIFSIGNALED (status)) {
    *error = path + ": OpenCV's parser crashed on it (signal " +
        std::to_string (WTERMSIG (status)) + "): a malformed file";
    return false;
  }
  bool ok = false;
  if (!WIFEXITED (status) || WEXITSTATUS (status) != 0
      || !decode_camera_file (msg, out, error, &ok)) {
    *error = path + ": the calibration file could not be read";
    return false;
  }
  return ok;
}

}  // namespace landmark
