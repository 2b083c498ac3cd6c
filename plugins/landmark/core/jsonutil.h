/* Small helpers for the JSON files users write (palettes, maps): typed
 * member access and file loading with errors that name the file. */
#pragma once

#include <json-glib/json-glib.h>

#include <memory>
#include <string>

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

/* "name[index]" or "name[index] ("label")" for error messages. */
std::string json_entry_label (const char *name, unsigned index,
    const char *label);

/* The object that entry `index` of the list `name` must be; nullptr, with
 * *why "name[index]: must be an object", when it is not. */
JsonObject *json_entry_object (JsonNode * node, const char *name,
    unsigned index, std::string * why);

}  // namespace landmark
