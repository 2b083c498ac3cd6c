/* The shape of a camera file, checked before OpenCV's FileStorage parses
 * it (camerafile.h): OpenCV's parsers loop forever, overflow the stack or
 * throw on some malformed files, never on text of the shape OpenCV itself
 * writes. YAML is checked line by line, XML with GMarkup, JSON with
 * json-glib: top-level keys holding a number, a word, a quoted text, a
 * list of numbers or an opencv-matrix (rows, cols, dt, data). A ROS
 * camera_info YAML file (no header) is checked line by line too, and
 * handed to OpenCV with the header it needs. No GStreamer types. */
#pragma once

#include <string>

namespace landmark {

/* True when text (the whole file at path) has that shape; false with
 * *error naming the path and, where it can, the line and the key. The
 * format is told by the first bytes: %YAML, <?xml or {. */
bool camera_file_shape_ok (const std::string & text, const std::string & path,
    std::string * error);

/* True when text does not start as an OpenCV file does and has, at the
 * start of a line, a key only a ROS camera_info file has (camera_name,
 * camera_matrix, distortion_model, distortion_coefficients,
 * rectification_matrix, projection_matrix): read it with
 * camera_info_shape_ok, not camera_file_shape_ok. */
bool looks_like_camera_info (const std::string & text);

/* True when text (the whole file at path) has the shape of a ROS
 * camera_info YAML file as camera_calibration_parsers writes it
 * (docs/calibration.md, "ROS camera_info"), with *opencv_text set to what
 * cv::FileStorage then parses: the text after a %YAML:1.0 header, its
 * camera_name line (not read; OpenCV's parser refuses some names) left
 * empty. False with *error naming the path, the line and the key. */
bool camera_info_shape_ok (const std::string & text, const std::string & path,
    std::string * opencv_text, std::string * error);

}  // namespace landmark
