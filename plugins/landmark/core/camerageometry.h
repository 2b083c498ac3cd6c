/* Camera geometry for ranging (docs/conventions.md, docs/ipmrange.md):
 * pixel -> ray in the robot frame -> intersection with the floor or with a
 * horizontal plane at a marker's height. Two models:
 *
 * - pinhole: OpenCV intrinsics (fx, fy, cx, cy, optional distortion,
 *   undone with cv::undistortPoints), camera height, tilt and roll;
 *   exact ray-plane intersection;
 * - seed: the seed's angle-linear model (SEED-NOTES.md, eqs 3.1-3.6) from
 *   camera height h, blind distance b, view depth d and half-width w.
 *
 * Everything that depends only on the configuration (rotation, seed angle
 * tables, per-pixel floor lookup) is computed by configure(), never per
 * point. No GStreamer types. */
#pragma once

#include <string>
#include <vector>

namespace landmark {

enum class CameraModel { Pinhole, Seed };

struct CameraParams {
  CameraModel model = CameraModel::Pinhole;
  int width = 0, height = 0;      /* image size the parameters refer to */
  double camera_height = 0.30;    /* metres */
  /* pinhole */
  double tilt_deg = 25.0;         /* below the horizontal */
  double roll_deg = 0.0;
  double fx = 0, fy = 0, cx = 0, cy = 0;   /* pixels */
  std::vector<double> dist;       /* OpenCV k1 k2 p1 p2 [k3 ...]; empty: none */
  /* seed */
  double blind_distance = 0, view_depth = 0, half_width = 0;   /* metres */
};

/* A robot-frame point (x forward, y left, z up), metres. */
struct Vec3 {
  double x = 0, y = 0, z = 0;
};

/* Intrinsics from a horizontal field of view (conventions.md):
 * fx = fy = (W/2) / tan(hfov/2), cx = (W-1)/2, cy = (H-1)/2. False when
 * hfov is outside (0, 180). */
bool intrinsics_from_hfov (double hfov_deg, int width, int height,
    double *fx, double *fy, double *cx, double *cy);

/* Reads an OpenCV FileStorage file (YAML or XML) with `camera_matrix`
 * (or `cameraMatrix`) 3x3 and `distortion_coefficients` (or `distCoeffs`;
 * optional: none means no distortion), and `image_width`/`image_height`
 * when present (0 otherwise). False with *error naming the file. */
bool load_calibration (const std::string & path, double *fx, double *fy,
    double *cx, double *cy, std::vector<double> *dist, int *image_width,
    int *image_height, std::string * error);

/* Bounds on a camera file: the largest image size it may name (ipmrange
 * builds a per-pixel table at that size). */
constexpr int kMaxCameraImageSize = 16384;

/* Everything a camera file (`gst-landmark calibrate`, docs/calibration.md)
 * may hold. A pinhole file has `camera_matrix`; a seed file has
 * `model: seed` with `camera_height`, `blind_distance`, `view_depth` and
 * `half_width`. The mounting keys `camera_height`, `tilt_deg` and
 * `roll_deg` are optional in a pinhole file (has_* say which are there). */
struct CameraFile {
  bool seed = false;                   /* model: seed */
  double fx = 0, fy = 0, cx = 0, cy = 0;   /* pinhole */
  std::vector<double> dist;
  int image_width = 0, image_height = 0;   /* 0: not in the file */
  bool has_camera_height = false, has_tilt = false, has_roll = false;
  double camera_height = 0, tilt_deg = 0, roll_deg = 0;
  double blind_distance = 0, view_depth = 0, half_width = 0;   /* seed */
};

/* Reads and checks a camera file (OpenCV FileStorage, YAML or XML). False
 * with *error naming the file and the key: unreadable, neither a
 * camera_matrix nor model: seed, an unknown model, a seed file missing one
 * of its four lengths or with a non-positive one, a non-positive
 * camera_height, tilt_deg outside [-90, 90], non-finite values. */
bool load_camera_file (const std::string & path, CameraFile * out,
    std::string * error);

/* load_camera_file parses in a child process (OpenCV's parsers can hang or
 * crash on malformed files) and gives up after this long. */
constexpr int kCameraFileParseSeconds = 5;

/* The same in this process: for tests of the checks themselves. */
bool parse_camera_file (const std::string & path, CameraFile * out,
    std::string * error);

class CameraGeometry {
public:
  /* Checks and precomputes; false with *error (naming the parameter) on
   * impossible geometry: non-positive height or size, focal lengths, seed
   * distances, a tilt that sees no floor anywhere in the image. */
  bool configure (const CameraParams & p, std::string * error);
  bool configured () const { return ok_; }
  const CameraParams & params () const { return p_; }

  /* Ray direction through pixel (u, v) in the robot frame (not unit
   * length). Distortion is undone. */
  Vec3 ray (double u, double v) const;
  /* Rays of many pixels at once (one cv::undistortPoints call). */
  void rays (const std::vector<double> & uv, std::vector<Vec3> * out) const;

  /* The camera centre in the robot frame: (0, 0, camera_height). */
  Vec3 centre () const { return Vec3 {0, 0, p_.camera_height}; }

  /* Intersection of a ray from the camera centre with the plane z = z0;
   * false when the ray misses it (parallel, or meets it behind). */
  bool intersect (const Vec3 & dir, double z0, double *gx, double *gy) const;

  /* The floor point of pixel (u, v) (plane z0); false: no floor. */
  bool pixel_to_plane (double u, double v, double z0, double *gx,
      double *gy) const;

  /* Projects a robot-frame point to pixels (pinhole with distortion, via
   * the model's forward equations; the seed model inverts 3.5-3.6).
   * False when the point is behind the camera. */
  bool project (const Vec3 & point, double *u, double *v) const;

  /* The seed's lookup table (pinhole too): range and bearing of the floor
   * point of each integer pixel, NaN above the horizon. Row-major, width x
   * height. Built by the first lookup() after configure(), not by
   * configure(): ipmrange never reads it, and building it cost every caps
   * and state change 25 ms at 640x480, 1.5 s and 450 MB at 3840x2160. The
   * first call is not thread-safe. */
  bool lookup (int u, int v, double *range, double *bearing) const;

  /* Seed model derived angles (radians): alpha (half vertical fov), beta
   * (half horizontal fov), gamma, theta (tilt). */
  double seed_alpha () const { return alpha_; }
  double seed_beta () const { return beta_; }
  double seed_gamma () const { return gamma_; }
  double seed_tilt () const { return M_PI_2_ - alpha_ - gamma_; }

  /* The seed's equations (3.5)-(3.6) themselves: floor distance ahead y
   * and lateral offset x (to the right, as the seed counts) of pixel
   * (u, v). False above the horizon. */
  bool seed_floor (double u, double v, double *y_ahead, double *x_right) const;

private:
  static constexpr double M_PI_2_ = 1.57079632679489661923;
  void build_lut () const;

  CameraParams p_;
  bool ok_ = false;
  double r_[3][3] = { {0} };    /* rows: camera x', y', z in robot frame */
  double alpha_ = 0, beta_ = 0, gamma_ = 0;
  mutable std::vector<float> lut_range_, lut_bearing_;
};

/* A circle through points in a plane (algebraic least squares); false
 * with fewer than 3 points or a degenerate set. */
bool fit_circle (const std::vector<double> & xy, double *cx, double *cy,
    double *radius);


/* A detection as landmark-blob describes it, in pixels of the frame it was
 * measured on; sx, sy scale those to the geometry's frame
 * (u' = (u + 0.5) sx - 0.5). */
struct BlobObservation {
  double u = 0, v = 0;                 /* centroid */
  bool has_ellipse = false;
  double eu = 0, ev = 0;               /* ellipse centre */
  double major = 0, minor = 0;         /* full axis lengths */
  double angle = 0;                    /* radians, +u towards +v */
  double equivalent_diameter = 0;      /* 0: unknown */
  double sx = 1, sy = 1;
};

/* What the detection is: a disc lying flat with its centre at height z
 * (0: on the floor), or a ball whose centre is at height z; diameter in
 * metres, 0 when unknown. */
struct MarkerSpec {
  double z = 0;
  double diameter = 0;
  bool ball = false;
};

struct RangeEstimate {
  bool no_floor = true;          /* the ray misses the marker's plane */
  double ground_x = 0, ground_y = 0;   /* ground method, metres */
  double range_ground = 0, range_ground_sigma = 0;
  bool has_size = false;         /* a diameter was known and usable */
  double range_size = 0, range_size_sigma = 0;
  double bearing = 0, bearing_sigma = 0;
};

/* Range and bearing of one detection. Discs: the ellipse's outline mapped
 * to the marker's plane, its centre by a circle fit; size range from the
 * fitted circle's radius against the known diameter (the plane's distance
 * scaled). Balls: the axis of the cone tangent to the ball bisects the rays
 * of the ellipse's major-axis ends; its half angle gives the distance.
 * Without an ellipse, the centroid's ray. pixel_sigma: one-sigma error of
 * a measured point, pixels. */
RangeEstimate estimate_range (const CameraGeometry & geometry,
    const BlobObservation & blob, const MarkerSpec & marker,
    double pixel_sigma);

}  // namespace landmark
