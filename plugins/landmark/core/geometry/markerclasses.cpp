/* Marker classes: see markerclasses.h. */
#include "markerclasses.h"

#include <algorithm>
#include <cmath>

#include "fileutil.h"
#include "landmarkmap.h"

namespace landmark {

MarkerSpec
MarkerClasses::spec (const char *cls,
    const std::vector<MarkerSpec> **several) const
{
  *several = nullptr;
  MarkerSpec m = default_marker;
  if (cls) {
    auto it = markers.find (cls);
    if (it != markers.end ())
      m = it->second;
    auto h = hypotheses.find (cls);
    if (h != hypotheses.end ())
      *several = &h->second;
  }
  return m;
}

bool
marker_classes_load (const std::string & map_path,
    const MarkerSpec & default_marker, double camera_height,
    MarkerClasses * out, std::string * error)
{
  *out = MarkerClasses ();
  out->default_marker = default_marker;
  if (map_path.empty ())
    return true;
  LandmarkMap map;
  if (!map_load_file (map_path, &map, error))
    return false;
  /* ipmrange ranges discs and balls; upright coded markers are not
   * ranged yet (docs/beacons.md) */
  for (const auto & lm : map_discs_and_balls (map)) {
    /* the same rule as marker-height: a marker plane at or above the
     * camera is never seen from above */
    if (lm.z >= camera_height) {
      *error = map_path + ": landmark \"" + lm.id + "\" (class " +
          lm.class_name + ") has z " + number_text (lm.z) + " m: a marker "
          "centre must be below the camera (camera-height " +
          number_text (camera_height) + " m)";
      return false;
    }
    out->map_classes.push_back ({ lm.class_name, lm.id });
    MarkerSpec m;
    m.z = lm.z;
    m.diameter = lm.diameter;
    m.ball = lm.ball;
    auto & specs = out->hypotheses[lm.class_name];
    const bool known = std::any_of (specs.begin (), specs.end (),
        [&](const MarkerSpec & o) {
          return std::fabs (o.z - m.z) <= 1e-9
              && std::fabs (o.diameter - m.diameter) <= 1e-9
              && o.ball == m.ball;
        });
    if (!known)
      specs.push_back (m);
  }
  for (auto it = out->hypotheses.begin (); it != out->hypotheses.end ();) {
    if (it->second.size () == 1) {
      out->markers[it->first] = it->second[0];
      it = out->hypotheses.erase (it);
    } else {
      ++it;
    }
  }
  return true;
}

}  // namespace landmark
