/* Camera files (docs/calibration.md): OpenCV FileStorage YAML, XML or JSON
 * as `gst-landmark calibrate` and OpenCV's calibration sample write them,
 * or ROS camera_info YAML (roscamerainfo.h).
 *
 * OpenCV's FileStorage parsers loop forever, overflow the stack or throw
 * on some malformed files (tests/fuzz/regressions/calibration). They are
 * only handed text of the shape OpenCV itself writes: the whole file is
 * read once (size-limited), its shape checked (camerafileshape.h), and only
 * then parsed by cv::FileStorage from memory, in this process. No GStreamer
 * types. */
#pragma once

#include <string>
#include <vector>

namespace landmark {

/* Bounds on a camera file: the largest image size it may name. */
constexpr int kMaxCameraImageSize = 16384;

/* Everything a camera file may hold. A pinhole file has `camera_matrix`
 * (or `cameraMatrix`) 3x3 and optionally `distortion_coefficients` (or
 * `distCoeffs`); an angle-linear file has `model: angle-linear` (or its former
 * name `seed`) with `camera_height`,
 * `blind_distance`, `view_depth` and `half_width`. The mounting keys
 * `camera_height`, `tilt_deg` and `roll_deg` are optional in a pinhole
 * file (has_* say which are there). A ROS camera_info file is a pinhole
 * file: its intrinsics and image size fill the same fields
 * (roscamerainfo.h), and it may hold the mounting keys too. */
struct CameraFile {
  bool seed = false;                   /* model: angle-linear */
  double fx = 0, fy = 0, cx = 0, cy = 0;   /* pinhole */
  std::vector<double> dist;
  int image_width = 0, image_height = 0;   /* 0: not in the file */
  bool has_camera_height = false, has_tilt = false, has_roll = false;
  double camera_height = 0, tilt_deg = 0, roll_deg = 0;
  double blind_distance = 0, view_depth = 0, half_width = 0;   /* seed */
};

/* Reads and checks a camera file. False with *error naming the file and
 * the key (or the line of a malformed file): unreadable, not of the shape
 * above, neither a camera_matrix nor model: angle-linear, an unknown model, an
 * angle-linear
 * file missing one of its four lengths or with a non-positive one, a
 * non-positive camera_height, tilt_deg outside [-90, 90], non-finite
 * values; for a camera_info file, what camera_info_values refuses. */
bool load_camera_file (const std::string & path, CameraFile * out,
    std::string * error);

}  // namespace landmark
