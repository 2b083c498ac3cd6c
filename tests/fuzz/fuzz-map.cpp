/* Fuzz target: the landmark map parser (core/support/landmarkmap.cpp) on arbitrary
 * bytes. An accepted map must be one the elements can use as is (bounded
 * count, finite and bounded coordinates, unique ids; a coded marker's
 * bands, their heights and its unique code); a refused one must come with
 * an error naming the source. */
#include <cmath>
#include <cstdint>
#include <set>
#include <string>

#include "fuzzcheck.h"
#include "landmarkmap.h"

/* What an accepted map must be. */
static void
check_map (const landmark::LandmarkMap & map)
{
  std::set<std::string> ids, codes;
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
    if (!lm.coded ())
      continue;
    FUZZ_CHECK (lm.bands.size () <= landmark::kMaxMarkerBands &&
        lm.band_heights.size () == lm.bands.size () && lm.diameter > 0 &&
        lm.height > 0 && lm.height <= landmark::kMaxMapHeight,
        "coded marker \"%s\"", lm.id.c_str ());
    double sum = 0;
    for (double h : lm.band_heights)
      sum += h;
    FUZZ_CHECK (std::fabs (sum - lm.height) <= 1e-3, "band heights %g of %g",
        sum, lm.height);
    FUZZ_CHECK (codes.insert (lm.code).second && lm.class_name == lm.code,
        "code \"%s\"", lm.code.c_str ());
  }
}

FUZZ_JSON_TARGET (landmark::map_parse, &landmark::LandmarkMap::landmarks,
    landmark::kMaxMapLandmarks, check_map)
