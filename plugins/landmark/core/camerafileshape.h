/* The shape of a camera file, checked before OpenCV's FileStorage parses
 * it (camerafile.h): OpenCV's parsers loop forever, overflow the stack or
 * throw on some malformed files, never on text of the shape OpenCV itself
 * writes. YAML is checked line by line, XML with GMarkup, JSON with
 * json-glib: top-level keys holding a number, a word, a quoted text, a
 * list of numbers or an opencv-matrix (rows, cols, dt, data). No
 * GStreamer types. */
#pragma once

#include <string>

namespace landmark {

/* True when text (the whole file at path) has that shape; false with
 * *error naming the path and, where it can, the line and the key. The
 * format is told by the first bytes: %YAML, <?xml or {. */
bool camera_file_shape_ok (const std::string & text, const std::string & path,
    std::string * error);

}  // namespace landmark
