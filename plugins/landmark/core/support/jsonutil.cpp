#include "jsonutil.h"

#include <cmath>

#include "fileutil.h"

namespace landmark {

bool
json_number (JsonNode * node, double *out)
{
  if (!node || !JSON_NODE_HOLDS_VALUE (node))
    return false;
  const GType t = json_node_get_value_type (node);
  if (t != G_TYPE_INT64 && t != G_TYPE_DOUBLE)
    return false;
  *out = json_node_get_double (node);
  return std::isfinite (*out);
}

const char *
json_string (JsonNode * node)
{
  if (!node || !JSON_NODE_HOLDS_VALUE (node) ||
      json_node_get_value_type (node) != G_TYPE_STRING)
    return nullptr;
  return json_node_get_string (node);
}

JsonObject *
json_parse_object (const std::string & json, const std::string & source,
    const char *what, JsonParserPtr & parser, std::string * error)
{
  parser.reset (json_parser_new ());
  GError *err = nullptr;
  if (!json_parser_load_from_data (parser.get (), json.data (),
          (gssize) json.size (), &err)) {
    *error = source + ": not valid JSON: " + err->message;
    g_error_free (err);
    return nullptr;
  }
  JsonNode *root = json_parser_get_root (parser.get ());
  if (!root) {
    *error = source + ": the file is empty";
    return nullptr;
  }
  if (!JSON_NODE_HOLDS_OBJECT (root)) {
    *error = source + ": the top level must be an object with " + what;
    return nullptr;
  }
  return json_node_get_object (root);
}

JsonArray *
json_parse_list (const std::string & json, const std::string & source,
    const char *member, unsigned max, JsonParserPtr & parser,
    std::string * error)
{
  const std::string quoted = std::string ("\"") + member + "\"";
  JsonObject *root = json_parse_object (json, source, quoted.c_str (),
      parser, error);
  if (!root)
    return nullptr;
  JsonNode *list = json_object_get_member (root, member);
  if (!list || !JSON_NODE_HOLDS_ARRAY (list)) {
    *error = source + ": " + quoted + " must be an array";
    return nullptr;
  }
  JsonArray *array = json_node_get_array (list);
  const guint n = json_array_get_length (array);
  if (n == 0) {
    *error = source + ": " + quoted + " is empty";
    return nullptr;
  }
  if (n > max) {
    *error = source + ": " + std::to_string (n) + " " + member +
        "; at most " + std::to_string (max) + " are supported";
    return nullptr;
  }
  return array;
}

bool
json_read_file (const std::string & path, std::string * text,
    std::string * error)
{
  gchar *contents = nullptr;
  gsize length = 0;
  GError *err = nullptr;
  if (!config_file_size_ok (path, error))
    return false;
  if (!g_file_get_contents (path.c_str (), &contents, &length, &err)) {
    *error = path + ": cannot read: " + err->message;
    g_error_free (err);
    return false;
  }
  text->assign (contents, length);
  g_free (contents);
  return true;
}

std::string
json_entry_label (const char *name, unsigned index, const char *label)
{
  std::string s = std::string (name) + "[" + std::to_string (index) + "]";
  if (label)
    s += std::string (" (\"") + label + "\")";
  return s;
}

JsonObject *
json_entry_object (JsonNode * node, const char *name, unsigned index,
    std::string * why)
{
  if (JSON_NODE_HOLDS_OBJECT (node))
    return json_node_get_object (node);
  *why = json_entry_label (name, index, nullptr) + ": must be an object";
  return nullptr;
}

}  // namespace landmark
