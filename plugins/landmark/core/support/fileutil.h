/* Checks and messages for the configuration files users point the elements
 * at (palettes, maps, camera files): size checks done before a file is
 * read whole, numbers as people write them. */
#pragma once

#include <string>

namespace landmark {

/* No configuration file of ours comes near this; a larger one is a
 * mistake (a video, a log), and devices such as /dev/zero never end. */
constexpr long long kMaxConfigFileBytes = 1 << 20;

/* False with *error ("<path>: N bytes; at most ... are supported", or
 * "<path>: not a regular file") for a file too large to be read whole, or a
 * device or pipe. True otherwise, also when the path cannot be examined or
 * is a directory: the caller's own read then reports that as before. */
bool config_file_size_ok (const std::string & path, std::string * error);

/* A number as people write it in a message: 0.3, not 0.300000. */
std::string number_text (double v);

}  // namespace landmark
