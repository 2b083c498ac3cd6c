/* Fuzz target: the landmark map parser (core/landmarkmap.cpp) on arbitrary
 * bytes. An accepted map must be one the elements can use as is (bounded
 * count, finite and bounded coordinates, unique ids); a refused one must
 * come with an error naming the source. */
#include <cmath>
#include <cstdint>
#include <set>
#include <string>

#include "fuzzcheck.h"
#include "landmarkmap.h"

extern "C" int
LLVMFuzzerTestOneInput (const uint8_t * data, size_t size)
{
  const std::string json ((const char *) data, size);
  landmark::LandmarkMap map;
  std::string error;
  if (!landmark::map_parse (json, "fuzz.json", &map, &error)) {
    FUZZ_CHECK (error.rfind ("fuzz.json: ", 0) == 0, "error \"%s\"",
        error.c_str ());
    FUZZ_CHECK (map.landmarks.empty (), "output touched on failure");
    return 0;
  }
  FUZZ_CHECK (error.empty (), "error set on success: %s", error.c_str ());
  const size_t n = map.landmarks.size ();
  FUZZ_CHECK (n >= 1 && n <= landmark::kMaxMapLandmarks, "%zu landmarks", n);
  std::set<std::string> ids;
  for (const auto & lm : map.landmarks) {
    FUZZ_CHECK (!lm.id.empty () && !lm.class_name.empty (), "empty id/class");
    FUZZ_CHECK (ids.insert (lm.id).second, "duplicate id \"%s\"",
        lm.id.c_str ());
    for (double v : {lm.x, lm.y, lm.z})
      FUZZ_CHECK (std::isfinite (v) &&
          std::fabs (v) <= landmark::kMaxMapCoordinate, "coordinate %g", v);
    FUZZ_CHECK (std::isfinite (lm.diameter) && lm.diameter >= 0 &&
        lm.diameter <= landmark::kMaxMapDiameter, "diameter %g",
        lm.diameter);
  }
  return 0;
}
