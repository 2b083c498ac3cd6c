#include "landmarkmap.h"

#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "fileutil.h"
#include "jsonutil.h"
#include "palette.h"

namespace landmark {

const char *
map_kind_name (MapKind kind)
{
  /* in the enum's order */
  static const char *const names[] = { "disc", "ball", "beacon", "post",
    "cone" };
  return names[(int) kind];
}

namespace {

std::string
entry_label (guint index, const char *id)
{
  return json_entry_label ("landmarks", index, id);
}

/* An entry's "id": a non-empty string; nullptr, with *why naming the
 * entry, when it is not */
const char *
entry_id (JsonObject * obj, guint index, std::string * why)
{
  const char *id = json_string (json_object_get_member (obj, "id"));
  if (id && *id)
    return id;
  *why = entry_label (index, nullptr) + ": \"id\" must be a non-empty string";
  return nullptr;
}

/* x, y (required) and z (optional, 0) within the map's bounds. */
bool
parse_position (JsonObject * obj, const std::string & where,
    MapLandmark * out, std::string * why)
{
  double x, y;
  if (!json_number (json_object_get_member (obj, "x"), &x)) {
    *why = where + ": \"x\" must be a finite number (metres)";
    return false;
  }
  if (!json_number (json_object_get_member (obj, "y"), &y)) {
    *why = where + ": \"y\" must be a finite number (metres)";
    return false;
  }
  double z = 0;
  JsonNode *n = json_object_get_member (obj, "z");
  if (n && !json_number (n, &z)) {
    *why = where + ": \"z\" must be a finite number (metres)";
    return false;
  }
  const char *axis[] = { "x", "y", "z" };
  const double xyz[] = { x, y, z };
  for (int i = 0; i < 3; i++) {
    if (std::fabs (xyz[i]) > kMaxMapCoordinate) {
      *why = where + ": \"" + axis[i] + "\" must be within -" +
          number_text (kMaxMapCoordinate) + ".." + number_text (kMaxMapCoordinate) +
          " (metres), got " + number_text (xyz[i]);
      return false;
    }
  }
  out->x = x;
  out->y = y;
  out->z = z;
  return true;
}

/* A size member: a positive number of metres up to `max`; `required`:
 * absent is an error too. */
bool
parse_size (JsonObject * obj, const char *member, bool required, double max,
    const std::string & where, double *out, std::string * why)
{
  JsonNode *n = json_object_get_member (obj, member);
  if ((n || required) && (!n || !json_number (n, out) || *out <= 0)) {
    *why = where + ": \"" + member + "\" must be a positive number (metres)";
    return false;
  }
  if (n && *out > max) {
    *why = where + ": \"" + member + "\" must be at most " +
        number_text (max) + " (metres), got " + number_text (*out);
    return false;
  }
  return true;
}

bool
coded_kind (const char *kind, MapKind * out)
{
  const MapKind coded[] = { MapKind::Beacon, MapKind::Post, MapKind::Cone };
  for (MapKind k : coded) {
    if (kind && !strcmp (kind, map_kind_name (k))) {
      *out = k;
      return true;
    }
  }
  return false;
}

/* "bands" (class names, top first) and "band-heights" (optional: equal
 * bands) of a coded marker whose height is already read. */
bool
parse_bands (JsonObject * obj, const std::string & where, MapLandmark * out,
    std::string * why)
{
  JsonNode *n = json_object_get_member (obj, "bands");
  if (!n || !JSON_NODE_HOLDS_ARRAY (n)) {
    *why = where + ": \"bands\" must be an array of class names, top first";
    return false;
  }
  JsonArray *bands = json_node_get_array (n);
  const guint count = json_array_get_length (bands);
  /* a beacon's code is an order, which takes two colours */
  const guint fewest = out->kind == MapKind::Beacon ? 2 : 1;
  if (count < fewest || count > kMaxMarkerBands) {
    *why = where + ": \"bands\" must hold " + std::to_string (fewest) +
        " to " + std::to_string (kMaxMarkerBands) + " class names for a " +
        map_kind_name (out->kind) + ", got " + std::to_string (count);
    return false;
  }
  for (guint i = 0; i < count; i++) {
    const char *cls = json_string (json_array_get_element (bands, i));
    if (!cls || !palette_valid_class_name (cls)) {
      *why = where + ": \"bands\"[" + std::to_string (i) + "] must be a "
          "class name (1 to 32 of A-Z a-z 0-9 _ . -)";
      return false;
    }
    out->bands.push_back (cls);
    out->code += (i ? "/" : "") + std::string (cls);
  }
  n = json_object_get_member (obj, "band-heights");
  if (!n) {
    out->band_heights.assign (count, out->height / count);
    return true;
  }
  JsonArray *heights = n && JSON_NODE_HOLDS_ARRAY (n) ?
      json_node_get_array (n) : nullptr;
  double sum = 0, h;
  for (guint i = 0; heights && i < json_array_get_length (heights); i++) {
    if (!json_number (json_array_get_element (heights, i), &h) || h <= 0) {
      heights = nullptr;
      break;
    }
    out->band_heights.push_back (h);
    sum += h;
  }
  if (!heights || out->band_heights.size () != count) {
    *why = where + ": \"band-heights\" must hold one positive number "
        "(metres) per band, " + std::to_string (count) + " here, top first";
    return false;
  }
  /* a millimetre's slack for heights written in centimetres */
  if (std::fabs (sum - out->height) > 1e-3) {
    *why = where + ": \"band-heights\" must sum to \"height\" (" +
        number_text (out->height) + " m), got " + number_text (sum) + " m";
    return false;
  }
  return true;
}

/* A beacon, post or cone: "bands" in place of "class"; "diameter" and
 * "height" required. */
bool
parse_coded (JsonObject * obj, const std::string & where, MapKind kind,
    MapLandmark * out, std::string * why)
{
  out->kind = kind;
  if (json_object_get_member (obj, "class")) {
    *why = where + ": a " + map_kind_name (kind) + " has no \"class\": "
        "its classes are its \"bands\"";
    return false;
  }
  if (!parse_position (obj, where, out, why)
      || !parse_size (obj, "diameter", true, kMaxMapDiameter, where,
          &out->diameter, why)
      || !parse_size (obj, "height", true, kMaxMapHeight, where,
          &out->height, why)
      || !parse_bands (obj, where, out, why))
    return false;
  out->class_name = out->code;
  return true;
}

bool
parse_landmark (JsonNode * node, guint index, MapLandmark * out,
    std::string * why)
{
  JsonObject *obj = json_entry_object (node, "landmarks", index, why);
  const char *id = obj ? entry_id (obj, index, why) : nullptr;
  if (!id)
    return false;
  const std::string where = entry_label (index, id);
  out->id = id;
  JsonNode *n = json_object_get_member (obj, "kind");
  MapKind kind;
  if (n && coded_kind (json_string (n), &kind))
    return parse_coded (obj, where, kind, out, why);
  const char *cls = json_string (json_object_get_member (obj, "class"));
  if (!cls || !*cls) {
    *why = where + ": \"class\" must be a non-empty string";
    return false;
  }
  if (!parse_position (obj, where, out, why)
      || !parse_size (obj, "diameter", false, kMaxMapDiameter, where,
          &out->diameter, why))
    return false;
  if (n) {
    const char *name = json_string (n);
    if (!name || (strcmp (name, "disc") && strcmp (name, "ball"))) {
      *why = where + ": \"kind\" must be \"disc\" or \"ball\", or a coded "
          "marker's \"beacon\", \"post\" or \"cone\"";
      return false;
    }
    out->ball = !strcmp (name, "ball");
  }
  out->kind = out->ball ? MapKind::Ball : MapKind::Disc;
  out->class_name = cls;
  return true;
}

}  // namespace

bool
map_parse (const std::string & json, const std::string & source,
    LandmarkMap * out, std::string * error)
{
  std::map<std::string, std::string> codes;   /* code -> landmark id */
  /* identity comes from the code: two markers with one code are one */
  auto own_code = [&](guint i, const MapLandmark & lm, std::string * why) {
    if (!lm.coded () || codes.insert ({ lm.code, lm.id }).second)
      return true;
    *why = entry_label (i, lm.id.c_str ()) + ": \"bands\" give the code " +
        lm.code + " of landmark \"" + codes[lm.code] + "\" too: each coded "
        "marker needs a code of its own";
    return false;
  };
  /* *out is left as it was on failure */
  return json_parse_unique_list (json, source, "landmarks",
      kMaxMapLandmarks, "id", parse_landmark,
      [](const MapLandmark & lm) { return lm.id; }, own_code,
      &out->landmarks, error);
}

bool
map_load_file (const std::string & path, LandmarkMap * out,
    std::string * error)
{
  return json_load_file (path, out, error, map_parse);
}

std::vector<MapLandmark>
map_discs_and_balls (const LandmarkMap & map)
{
  std::vector<MapLandmark> out;
  for (const auto & lm : map.landmarks)
    if (!lm.coded ())
      out.push_back (lm);
  return out;
}

std::string
coded_match_class (const std::string & code)
{
  return "coded:" + code;
}

bool
is_coded_match_class (const std::string & cls)
{
  return cls.compare (0, 6, "coded:") == 0;
}

std::vector<MapLandmark>
map_pose_landmarks (const LandmarkMap & map)
{
  std::vector<MapLandmark> out = map.landmarks;
  for (MapLandmark & lm : out)
    if (lm.coded ())
      lm.class_name = coded_match_class (lm.code);
  return out;
}

}  // namespace landmark
