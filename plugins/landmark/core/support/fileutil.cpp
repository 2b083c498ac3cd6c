#include "fileutil.h"

#include <sstream>

#include <sys/stat.h>

namespace landmark {

bool
config_file_size_ok (const std::string & path, std::string * error)
{
  struct stat st;
  if (stat (path.c_str (), &st) != 0 || S_ISDIR (st.st_mode))
    return true;
  if (!S_ISREG (st.st_mode)) {
    *error = path + ": not a regular file";
    return false;
  }
  if (st.st_size > kMaxConfigFileBytes) {
    *error = path + ": " + std::to_string ((long long) st.st_size) +
        " bytes; at most " + std::to_string (kMaxConfigFileBytes) +
        " are supported";
    return false;
  }
  return true;
}

std::string
number_text (double v)
{
  std::ostringstream o;
  o << v;
  return o.str ();
}

}  // namespace landmark
