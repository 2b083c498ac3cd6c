/* Landmark maps: the JSON file of landmark positions (docs/conventions.md)
 * that trilaterate, ipmrange and landmarkoverlay read and gst-landmark
 * synth writes. */
#pragma once

#include <string>
#include <vector>

namespace landmark {

/* Bounds on what a map may hold: a map is hand-written or made by
 * gst-landmark synth for one arena, and trilaterate's association costs
 * grow with the count (docs/conventions.md). */
constexpr unsigned kMaxMapLandmarks = 256;
constexpr double kMaxMapCoordinate = 10000.0;   /* metres, |x|, |y|, |z| */
constexpr double kMaxMapDiameter = 100.0;       /* metres */

struct MapLandmark {
  std::string id;
  std::string class_name;
  double x = 0, y = 0, z = 0;  /* metres, world frame */
  double diameter = 0;         /* metres; 0 when the file gives none */
  bool ball = false;           /* kind: "ball" (true) or "disc" */
};

struct LandmarkMap {
  std::vector<MapLandmark> landmarks;
};

/* Parses map JSON ({"landmarks": [{"id", "class", "x", "y", "z",
 * "diameter", "kind"}, ...]}): `id`, `class`, `x`, `y` are required, the
 * others are checked when present, other keys are ignored. On failure
 * returns false and sets *error to a message that starts with `source` and
 * names the offending entry. */
bool map_parse (const std::string & json, const std::string & source,
    LandmarkMap * out, std::string * error);

/* Reads and parses a map file; errors name the file. */
bool map_load_file (const std::string & path, LandmarkMap * out,
    std::string * error);

}  // namespace landmark
