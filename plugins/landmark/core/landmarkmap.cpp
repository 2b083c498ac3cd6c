#include "landmarkmap.h"

#include <cmath>
#include <cstring>
#include <set>
#include <sstream>

#include "fileutil.h"
#include "jsonutil.h"

namespace landmark {

namespace {

std::string
entry_label (guint index, const char *id)
{
  return json_entry_label ("landmarks", index, id);
}

bool
parse_landmark (JsonNode * node, guint index, MapLandmark * out,
    std::string * why)
{
  if (!JSON_NODE_HOLDS_OBJECT (node)) {
    *why = entry_label (index, nullptr) + ": must be an object";
    return false;
  }
  JsonObject *obj = json_node_get_object (node);
  const char *id = json_string (json_object_get_member (obj, "id"));
  if (!id || !*id) {
    *why = entry_label (index, nullptr) +
        ": \"id\" must be a non-empty string";
    return false;
  }
  const std::string where = entry_label (index, id);
  const char *cls = json_string (json_object_get_member (obj, "class"));
  if (!cls || !*cls) {
    *why = where + ": \"class\" must be a non-empty string";
    return false;
  }
  double x, y;
  if (!json_number (json_object_get_member (obj, "x"), &x)) {
    *why = where + ": \"x\" must be a finite number (metres)";
    return false;
  }
  if (!json_number (json_object_get_member (obj, "y"), &y)) {
    *why = where + ": \"y\" must be a finite number (metres)";
    return false;
  }
  double z = 0, diameter = 0;
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
  n = json_object_get_member (obj, "diameter");
  if (n && (!json_number (n, &diameter) || diameter <= 0)) {
    *why = where + ": \"diameter\" must be a positive number (metres)";
    return false;
  }
  if (diameter > kMaxMapDiameter) {
    *why = where + ": \"diameter\" must be at most " +
        number_text (kMaxMapDiameter) + " (metres), got " + number_text (diameter);
    return false;
  }
  bool ball = false;
  n = json_object_get_member (obj, "kind");
  if (n) {
    const char *kind = json_string (n);
    if (!kind || (strcmp (kind, "disc") && strcmp (kind, "ball"))) {
      *why = where + ": \"kind\" must be \"disc\" or \"ball\"";
      return false;
    }
    ball = !strcmp (kind, "ball");
  }
  out->id = id;
  out->class_name = cls;
  out->x = x;
  out->y = y;
  out->z = z;
  out->diameter = diameter;
  out->ball = ball;
  return true;
}

}  // namespace

bool
map_parse (const std::string & json, const std::string & source,
    LandmarkMap * out, std::string * error)
{
  JsonParserPtr parser (nullptr, g_object_unref);
  JsonArray *array = json_parse_list (json, source, "landmarks",
      kMaxMapLandmarks, parser, error);
  if (!array)
    return false;
  const guint n = json_array_get_length (array);
  LandmarkMap map;
  std::set<std::string> ids;
  for (guint i = 0; i < n; i++) {
    MapLandmark lm;
    std::string why;
    if (!parse_landmark (json_array_get_element (array, i), i, &lm, &why)) {
      *error = source + ": " + why;
      return false;
    }
    if (!ids.insert (lm.id).second) {
      *error = source + ": " + entry_label (i, lm.id.c_str ()) +
          ": duplicate id";
      return false;
    }
    map.landmarks.push_back (std::move (lm));
  }
  *out = std::move (map);
  return true;
}

bool
map_load_file (const std::string & path, LandmarkMap * out,
    std::string * error)
{
  std::string text;
  return json_read_file (path, &text, error) &&
      map_parse (text, path, out, error);
}

}  // namespace landmark
