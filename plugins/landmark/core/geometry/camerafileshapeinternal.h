/* What the camera file shape checks (camerafileshape.cpp,
 * camerafilexml.cpp) share: the values a key may hold, as OpenCV writes
 * them, and the XML check. Not for use outside them. */
#pragma once

#include <string>

namespace landmark {
namespace camera_file_shape {

/* an opencv-matrix's fields, in their order */
constexpr const char *kMatrixFields[] = { "rows", "cols", "dt", "data" };

constexpr const char *kShapeHint = "a camera file holds top-level keys "
    "with a number, a word, a quoted text, a list of numbers or an "
    "opencv-matrix (rows, cols, dt, data), as OpenCV writes them";

/* The values (camerafileshape.cpp) */
bool is_digit (char c);
bool is_word_char (char c, bool first);
bool is_key (const std::string & s);
bool is_number (const std::string & s);
bool is_count (const std::string & s);
bool is_quoted (const std::string & s);
bool is_dt (const std::string & s);
bool is_word (const std::string & s);
bool is_scalar (const std::string & s);
std::string trimmed (const std::string & s);
bool is_short_whole (const std::string & s);

/* XML through GMarkup (camerafilexml.cpp) */
bool xml_shape_ok (const std::string & text, const std::string & path,
    std::string * error);

}  // namespace camera_file_shape
}  // namespace landmark
