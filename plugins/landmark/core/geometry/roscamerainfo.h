/* ROS camera_info YAML files (docs/calibration.md, "ROS camera_info"): the
 * format of ROS's camera_calibration_parsers, read as a camera file. The
 * file's shape is checked first (camerafileshape.h, camera_info_shape_ok)
 * and OpenCV's FileStorage parses it with the header it needs
 * (camerafile.cpp); this reads the values. No GStreamer types. */
#pragma once

#include "camerafile.h"

#include <string>

namespace cv {
class FileStorage;
}

namespace landmark {

/* The intrinsics of a parsed camera_info file into *out: image_width and
 * image_height (both needed, positive), camera_matrix (3x3),
 * distortion_model (plumb_bob when absent, as ROS reads it) and
 * distortion_coefficients (plumb_bob: 5, k1 k2 p1 p2 k3; rational_polynomial:
 * 8, k1 k2 p1 p2 k3 k4 k5 k6; none: no distortion). rectification_matrix
 * (3x3) and projection_matrix (3x4), used only on rectified images, are
 * checked when present and not read. False with *error naming the file and
 * the key: a key missing, data that are not rows x cols finite numbers,
 * an unknown distortion model or equidistant (fisheye, no model here). */
bool camera_info_values (const cv::FileStorage & fs, const std::string & path,
    CameraFile * out, std::string * error);

}  // namespace landmark
