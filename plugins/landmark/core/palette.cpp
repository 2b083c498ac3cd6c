#include "palette.h"

#include <json-glib/json-glib.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <set>

#include "default-palette.h"  /* generated: kDefaultPaletteJson */

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

bool
json_number (JsonNode * node, double *out)
{
  if (!JSON_NODE_HOLDS_VALUE (node))
    return false;
  const GType t = json_node_get_value_type (node);
  if (t != G_TYPE_INT64 && t != G_TYPE_DOUBLE)
    return false;  /* booleans and strings are not numbers */
  *out = json_node_get_double (node);
  return std::isfinite (*out);
}

std::string
entry_label (guint index, const char *name)
{
  std::string s = "classes[" + std::to_string (index) + "]";
  if (name)
    s += std::string (" (\"") + name + "\")";
  return s;
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

  const char *name = nullptr;
  JsonNode *name_node = json_object_get_member (obj, "name");
  if (name_node && JSON_NODE_HOLDS_VALUE (name_node) &&
      json_node_get_value_type (name_node) == G_TYPE_STRING)
    name = json_node_get_string (name_node);
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
  std::unique_ptr<JsonParser, decltype (&g_object_unref)> parser (
      json_parser_new (), g_object_unref);
  GError *err = nullptr;
  if (!json_parser_load_from_data (parser.get (), json.data (),
          (gssize) json.size (), &err)) {
    *error = source + ": not valid JSON: " + err->message;
    g_error_free (err);
    return false;
  }
  JsonNode *root = json_parser_get_root (parser.get ());
  if (!root) {
    *error = source + ": the file is empty";
    return false;
  }
  if (!JSON_NODE_HOLDS_OBJECT (root)) {
    *error = source + ": the top level must be an object with \"classes\"";
    return false;
  }
  JsonNode *classes_node = json_object_get_member (
      json_node_get_object (root), "classes");
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
  gchar *contents = nullptr;
  gsize length = 0;
  GError *err = nullptr;
  if (!g_file_get_contents (path.c_str (), &contents, &length, &err)) {
    *error = path + ": cannot read: " + err->message;
    g_error_free (err);
    return false;
  }
  const std::string json (contents, length);
  g_free (contents);
  return palette_parse (json, path, out, error);
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
