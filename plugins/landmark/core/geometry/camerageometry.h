/* Camera geometry for ranging (docs/conventions.md, docs/ipmrange.md):
 * pixel -> ray in the robot frame -> intersection with the floor or with a
 * horizontal plane at a marker's height. Two models:
 *
 * - pinhole: OpenCV intrinsics (fx, fy, cx, cy, optional distortion,
 *   undone with cv::undistortPoints), camera height, tilt and roll;
 *   exact ray-plane intersection;
 * - seed: the thesis's angle-linear model (docs/ipmrange.md) from
 *   camera height h, blind distance b, view depth d and half-width w.
 *
 * Everything that depends only on the configuration (rotation, seed
 * angles) is computed by configure(), never per point. Camera files are
 * read by camerafile.h, ranges estimated by rangeestimate.h. No GStreamer
 * types. */
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

private:
  CameraParams p_;
  bool ok_ = false;
  double r_[3][3] = { {0} };    /* rows: camera x', y', z in robot frame */
  /* seed model (radians): alpha half the vertical field of view, beta half
   * the horizontal one, gamma from the vertical to the bottom row's ray */
  double alpha_ = 0, beta_ = 0, gamma_ = 0;
};

}  // namespace landmark
