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
constexpr double kMaxMapHeight = 100.0;         /* metres, coded markers */
/* A coded marker's colour bands (docs/beacons.md): a beacon needs two to
 * read an order from, a post or a cone may be of one colour. */
constexpr unsigned kMaxMarkerBands = 3;

/* What a landmark is (the map's "kind"): a flat disc or a ball of one
 * colour, or an upright coded marker standing on the floor. */
enum class MapKind { Disc, Ball, Beacon, Post, Cone };

/* "disc", "ball", "beacon", "post", "cone": the map file's spelling. */
const char *map_kind_name (MapKind kind);

struct MapLandmark {
  std::string id;
  /* the palette class of a disc or ball; a coded marker's code */
  std::string class_name;
  double x = 0, y = 0, z = 0;  /* metres, world frame */
  double diameter = 0;         /* metres; 0 when the file gives none */
  bool ball = false;           /* kind: "ball" (true) or "disc" */
  MapKind kind = MapKind::Disc;
  /* Coded markers only (beacon, post, cone): x, y is the axis on the
   * floor, z the base's height above it (0: standing on the floor),
   * `diameter` the cylinder's or the cone's base, `height` metres. */
  double height = 0;
  std::vector<std::string> bands = {};    /* class names, top first */
  std::vector<double> band_heights = {};  /* metres, top first, sum height */
  std::string code = {};                  /* the bands joined by "/" */

  bool coded () const { return !bands.empty (); }
};

struct LandmarkMap {
  std::vector<MapLandmark> landmarks;
};

/* Parses map JSON ({"landmarks": [{"id", "class", "x", "y", "z",
 * "diameter", "kind"}, ...]}): `id`, `class`, `x`, `y` are required, the
 * others are checked when present, other keys are ignored. A coded marker
 * ("kind" "beacon", "post" or "cone") has "bands" instead of "class" and
 * needs "diameter" and "height"; "band-heights" is optional (equal bands
 * otherwise) and its code must be unique in the map. On failure returns
 * false and sets *error to a message that starts with `source` and names
 * the offending entry and field. */
bool map_parse (const std::string & json, const std::string & source,
    LandmarkMap * out, std::string * error);

/* Reads and parses a map file; errors name the file. */
bool map_load_file (const std::string & path, LandmarkMap * out,
    std::string * error);

/* The discs and balls of the map, in its order: what the elements that
 * range and position from round blobs use. */
std::vector<MapLandmark> map_discs_and_balls (const LandmarkMap & map);

/* The class a pose element matches a coded marker by: its code, kept
 * apart from the palette's classes ("coded:" + code), so that a one-band
 * post "pink" and a pink disc are never taken for each other. */
std::string coded_match_class (const std::string & code);
/* Whether a class is one coded_match_class made. */
bool is_coded_match_class (const std::string & cls);

/* Every landmark of the map, in its order, the coded markers under their
 * coded_match_class: what trilaterate positions from (a code is unique in
 * the map, so one view names its marker). */
std::vector<MapLandmark> map_pose_landmarks (const LandmarkMap & map);

}  // namespace landmark
