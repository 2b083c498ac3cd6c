/* Small helpers for the JSON files users write (palettes, maps): typed
 * member access and file loading with errors that name the file. */
#pragma once

#include <json-glib/json-glib.h>

#include <memory>
#include <set>
#include <string>
#include <vector>

namespace landmark {

/* A finite JSON number (booleans and strings are not numbers). */
bool json_number (JsonNode * node, double *out);

/* A JSON string member, or nullptr. */
const char *json_string (JsonNode * node);

/* Parses `json` and returns its top-level object, or nullptr with *error
 * starting with `source` ("not valid JSON: ...", "the file is empty", or
 * "the top level must be an object with <what>"). The parser owns the
 * nodes: keep it alive while using them. */
using JsonParserPtr = std::unique_ptr<JsonParser, decltype (&g_object_unref)>;
JsonObject *json_parse_object (const std::string & json,
    const std::string & source, const char *what, JsonParserPtr & parser,
    std::string * error);

/* The array member `member` of the document's top-level object, with 1 to
 * max entries (the lists of palette and map files), or nullptr with
 * *error naming source and the member. */
JsonArray *json_parse_list (const std::string & json,
    const std::string & source, const char *member, unsigned max,
    JsonParserPtr & parser, std::string * error);

/* Reads a whole file; on failure *error is "<path>: cannot read: ...", or
 * names a file too large or not regular (fileutil.h). */
bool json_read_file (const std::string & path, std::string * text,
    std::string * error);

/* Reads the file at path and parses it with parse (text, source, out,
 * error), the path as source: the load of every JSON file users write. */
template <typename T>
bool
json_load_file (const std::string & path, T * out, std::string * error,
    bool (*parse) (const std::string &, const std::string &, T *,
        std::string *))
{
  std::string text;
  return json_read_file (path, &text, error) &&
      parse (text, path, out, error);
}

/* "name[index]" or "name[index] ("label")" for error messages. */
std::string json_entry_label (const char *name, unsigned index,
    const char *label);

/* The object that entry `index` of the list `name` must be; nullptr, with
 * *why "name[index]: must be an object", when it is not. */
JsonObject *json_entry_object (JsonNode * node, const char *name,
    unsigned index, std::string * why);

/* The entries of the list `member` (json_parse_list) parsed one by one:
 * parse (node, index, T *, std::string *why) reads one, each must have a
 * key (key_of (T)) of its own ("member[i] (\"key\"): duplicate what"),
 * and check (index, T, std::string *why) may refuse one for what the
 * entries before it hold. Errors start with source. */
template <typename T, typename Parse, typename Key, typename Check>
bool
json_parse_unique_list (const std::string & json, const std::string & source,
    const char *member, unsigned max, const char *what, Parse parse,
    Key key_of, Check check, std::vector<T> * out, std::string * error)
{
  JsonParserPtr parser (nullptr, g_object_unref);
  JsonArray *array = json_parse_list (json, source, member, max, parser,
      error);
  if (!array)
    return false;
  const unsigned n = json_array_get_length (array);
  std::vector<T> entries;
  std::set<std::string> keys;
  for (unsigned i = 0; i < n; i++) {
    T entry;
    std::string why;
    if (!parse (json_array_get_element (array, i), i, &entry, &why)) {
      *error = source + ": " + why;
      return false;
    }
    if (!keys.insert (key_of (entry)).second) {
      *error = source + ": " + json_entry_label (member, i,
          key_of (entry).c_str ()) + ": duplicate " + what;
      return false;
    }
    if (!check (i, entry, &why)) {
      *error = source + ": " + why;
      return false;
    }
    entries.push_back (std::move (entry));
  }
  *out = std::move (entries);
  return true;
}

}  // namespace landmark
