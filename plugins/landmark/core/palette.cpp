#include "palette.h"


#include <cmath>
#include <cstring>
#include <memory>
#include <set>

#include "default-palette.h"  /* generated: kDefaultPaletteJson */
#include "jsonutil.h"

namespace landmark {

namespace {

constexpr guint kMaxClassesInPalette = 64;
constexpr gsize kMaxNameLength = 32;

bool
valid_name (const char *name)
{
  const gsize len = strlen (name);
  if (len == 0 || len > kMaxNameLength)
    return false;
  for (const char *p = name; *p; p++) {
    if (!g_ascii_isalnum (*p) && *p != '_' && *p != '.' && *p != '-')
      return false;
  }
  return true;
}

std::string
entry_label (guint index, const char *name)
{
  return json_entry_label ("classes", index, name);
}

bool
parse_class (JsonNode * node, guint index, PaletteClass * out,
    std::string * why)
{
  if (!JSON_NODE_HOLDS_OBJECT (node)) {
    *why = entry_label (index, nullptr) + ": must be an object";
    return false;
  }
  JsonObject *obj = json_node_get_object (node);

  const char *name = json_string (json_object_get_member (obj, "name"));
  if (!name) {
    *why = entry_label (index, nullptr) + ": \"name\" must be a string";
    return false;
  }
  if (!valid_name (name)) {
    *why = entry_label (index, name) + ": \"name\" must be 1 to 32 "
        "characters from A-Z a-z 0-9 _ . -";
    return false;
  }
  const std::string where = entry_label (index, name);

  GList *members = json_object_get_members (obj);
  for (GList * l = members; l; l = l->next) {
    const char *key = (const char *) l->data;
    if (strcmp (key, "name") && strcmp (key, "lab") && strcmp (key, "marker")) {
      *why = where + ": unknown key \"" + key +
          "\" (allowed: name, lab, marker)";
      g_list_free (members);
      return false;
    }
  }
  g_list_free (members);

  JsonNode *lab_node = json_object_get_member (obj, "lab");
  JsonArray *lab = lab_node && JSON_NODE_HOLDS_ARRAY (lab_node) ?
      json_node_get_array (lab_node) : nullptr;
  double v[3];
  bool numbers = lab && json_array_get_length (lab) == 3;
  for (guint i = 0; numbers && i < 3; i++)
    numbers = json_number (json_array_get_element (lab, i), &v[i]);
  if (!numbers) {
    *why = where + ": \"lab\" must be an array of 3 finite numbers [L, a, b]";
    return false;
  }
  if (v[0] < 0 || v[0] > 100) {
    *why = where + ": \"lab\" L* must be within 0..100, got " +
        std::to_string (v[0]);
    return false;
  }
  for (int i = 1; i < 3; i++) {
    if (v[i] < -128 || v[i] > 128) {
      *why = where + ": \"lab\" " + (i == 1 ? "a*" : "b*") +
          " must be within -128..128, got " + std::to_string (v[i]);
      return false;
    }
  }

  bool marker = true;
  JsonNode *marker_node = json_object_get_member (obj, "marker");
  if (marker_node) {
    if (!JSON_NODE_HOLDS_VALUE (marker_node) ||
        json_node_get_value_type (marker_node) != G_TYPE_BOOLEAN) {
      *why = where + ": \"marker\" must be true or false";
      return false;
    }
    marker = json_node_get_boolean (marker_node);
  }

  out->name = name;
  out->lab = Lab { v[0], v[1], v[2] };
  out->marker = marker;
  return true;
}

}  // namespace

bool
palette_parse (const std::string & json, const std::string & source,
    Palette * out, std::string * error)
{
  JsonParserPtr parser (nullptr, g_object_unref);
  JsonObject *root = json_parse_object (json, source, "\"classes\"", parser,
      error);
  if (!root)
    return false;
  JsonNode *classes_node = json_object_get_member (root, "classes");
  if (!classes_node || !JSON_NODE_HOLDS_ARRAY (classes_node)) {
    *error = source + ": \"classes\" must be an array";
    return false;
  }
  JsonArray *classes = json_node_get_array (classes_node);
  const guint n = json_array_get_length (classes);
  if (n == 0) {
    *error = source + ": \"classes\" is empty";
    return false;
  }
  if (n > kMaxClassesInPalette) {
    *error = source + ": " + std::to_string (n) + " classes; at most " +
        std::to_string (kMaxClassesInPalette) + " are supported";
    return false;
  }

  Palette palette;
  std::set<std::string> names;
  for (guint i = 0; i < n; i++) {
    PaletteClass cls;
    std::string why;
    if (!parse_class (json_array_get_element (classes, i), i, &cls, &why)) {
      *error = source + ": " + why;
      return false;
    }
    if (!names.insert (cls.name).second) {
      *error = source + ": " + entry_label (i, cls.name.c_str ()) +
          ": duplicate class name";
      return false;
    }
    palette.classes.push_back (cls);
  }
  *out = std::move (palette);
  return true;
}

bool
palette_load_file (const std::string & path, Palette * out,
    std::string * error)
{
  std::string text;
  return json_read_file (path, &text, error) &&
      palette_parse (text, path, out, error);
}

const Palette &
palette_default ()
{
  static const Palette palette = [] {
    Palette p;
    std::string error;
    /* the file is validated by the unit tests; parsing cannot fail here */
    palette_parse (kDefaultPaletteJson, "built-in palette", &p, &error);
    return p;
  }();
  return palette;
}

}  // namespace landmark
