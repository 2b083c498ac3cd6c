/* The shape of a camera file (camerafileshape.h): the values its keys may
 * hold, YAML and ROS camera_info line by line, JSON through json-glib;
 * XML is camerafilexml.cpp's. */
#include "camerafileshape.h"
#include "camerafileshapeinternal.h"

#include "jsonutil.h"

#include <glib.h>

#include <cstring>
#include <set>
#include <sstream>

namespace landmark {

namespace camera_file_shape {

bool
is_digit (char c)
{
  return c >= '0' && c <= '9';
}

bool
is_word_char (char c, bool first)
{
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'
      || (!first && is_digit (c));
}

/* A name as OpenCV writes keys: a letter or _, then letters, digits, _ */
bool
is_key (const std::string & s)
{
  if (s.empty () || !is_word_char (s[0], true))
    return false;
  for (char c : s)
    if (!is_word_char (c, false))
      return false;
  return true;
}

/* 12, -0.25, 1., .5, 1e-3, 5.0000000000000000e-01, .nan, -.inf */
bool
is_number (const std::string & s)
{
  size_t i = 0;
  if (i < s.size () && (s[i] == '-' || s[i] == '+'))
    i++;
  const std::string rest = s.substr (i);
  if (rest == ".nan" || rest == ".NaN" || rest == ".inf" || rest == ".Inf")
    return true;
  size_t digits = 0;
  while (i < s.size () && is_digit (s[i])) {
    i++;
    digits++;
  }
  if (i < s.size () && s[i] == '.') {
    i++;
    while (i < s.size () && is_digit (s[i])) {
      i++;
      digits++;
    }
  }
  if (digits == 0 || digits > 40)
    return false;
  if (i < s.size () && (s[i] == 'e' || s[i] == 'E')) {
    i++;
    if (i < s.size () && (s[i] == '-' || s[i] == '+'))
      i++;
    size_t e = 0;
    while (i < s.size () && is_digit (s[i])) {
      i++;
      e++;
    }
    if (e == 0 || e > 3)
      return false;
  }
  return i == s.size ();
}

/* rows and cols: a count OpenCV reads as int */
bool
is_count (const std::string & s)
{
  if (s.empty () || s.size () > 9)
    return false;
  for (char c : s)
    if (!is_digit (c))
      return false;
  return true;
}

/* "a quoted text": printable characters, no quote or backslash inside */
bool
is_quoted (const std::string & s)
{
  if (s.size () < 2 || s.front () != '"' || s.back () != '"')
    return false;
  for (size_t i = 1; i + 1 < s.size (); i++) {
    const unsigned char c = s[i];
    if (c < 0x20 || c == 0x7f || c == '"' || c == '\\')
      return false;
  }
  return true;
}

/* a matrix's element type: d, f, u, "2f", "3d" */
bool
is_dt (const std::string & s)
{
  const std::string t = is_quoted (s) ? s.substr (1, s.size () - 2) : s;
  if (t.empty () || t.size () > 4)
    return false;
  for (char c : t)
    if (!(is_digit (c) || (c >= 'a' && c <= 'z')))
      return false;
  return true;
}

/* A word value: a name, where a '-' may join two parts (angle-linear) */
bool
is_word (const std::string & s)
{
  if (s.empty () || s.back () == '-' || !is_word_char (s[0], true))
    return false;
  for (size_t i = 1; i < s.size (); i++)
    if (!is_word_char (s[i], false) && !(s[i] == '-' && s[i - 1] != '-'))
      return false;
  return true;
}

bool
is_scalar (const std::string & s)
{
  return is_number (s) || is_word (s) || is_quoted (s);
}

std::string
trimmed (const std::string & s)
{
  const size_t a = s.find_first_not_of (" \t\r\n");
  if (a == std::string::npos)
    return std::string ();
  const size_t b = s.find_last_not_of (" \t\r\n");
  return s.substr (a, b - a + 1);
}

/* A whole number OpenCV reads as a 32-bit int: at most 9 digits */
bool
is_short_whole (const std::string & s)
{
  const size_t sign = !s.empty () && (s[0] == '-' || s[0] == '+');
  return s.find_first_not_of ("0123456789", sign) != std::string::npos
      || s.size () - sign <= 9;
}

}  // namespace camera_file_shape

using namespace camera_file_shape;

namespace {

/* Numbers separated by commas between [ and ], fed line by line; the
 * first line from its [. */
struct NumberList {
  bool open = false, need_item = false;
  size_t items = 0;
  /* refuse whole numbers of more than 9 digits (a camera_info file) */
  bool short_wholes = false;

  /* "" when line (from line[i] on) continues the list well; else what is
   * wrong, naming key */
  std::string feed (const std::string & line, size_t i,
      const std::string & key)
  {
    if (!open) {
      open = true;
      need_item = true;
      items = 0;
      i++;                      /* the [ */
    }
    for (;;) {
      while (i < line.size () && line[i] == ' ')
        i++;
      if (i == line.size ())
        return need_item ? "" : key + ": a list line must end with a comma "
            "or ]";
      if (line[i] == ']') {
        if (need_item && items > 0)
          return key + ": a comma before ]";
        open = false;
        return i + 1 == line.size () ? "" : key + ": text after the list's ]";
      }
      if (!need_item) {
        if (line[i] != ',')
          return key + ": expected a comma between numbers";
        i++;
        need_item = true;
        continue;
      }
      size_t end = i;
      while (end < line.size () && line[end] != ',' && line[end] != ' '
          && line[end] != ']')
        end++;
      const std::string item = line.substr (i, end - i);
      if (!is_number (item))
        return key + ": `" + item + "` in its list is not a number";
      if (short_wholes && !is_short_whole (item))
        return key + ": `" + item + "` in its list is a whole number of "
            "more than 9 digits (OpenCV does not read it exactly; write it "
            "with a decimal point)";
      items++;
      need_item = false;
      i = end;
    }
  }
};

/* What the line-by-line shapes share: the file, the line reached, the
 * first fault and a list of numbers being read. */
class LineShape {
protected:
  explicit LineShape (const std::string & path) : path_ (path) { }

  bool fail_at (int line, const std::string & what)
  {
    why_ = path_ + ": line " + std::to_string (line) + ": " + what;
    return false;
  }

  bool fail (const std::string & what)
  {
    return fail_at (n_, what);
  }

  /* 1 and *indent where the line's text starts; 0 for a blank line; -1,
   * with the fault `percent`, for a '%', on which OpenCV's YAML parser
   * does not end */
  int text_start (const std::string & line, const std::string & percent,
      size_t * indent)
  {
    if (line.find ('%') != std::string::npos) {
      fail (percent);
      return -1;
    }
    *indent = line.find_first_not_of (' ');
    return *indent == std::string::npos ? 0 : 1;
  }

  /* line (from line[i] on) continues the list of key */
  bool list (const std::string & line, size_t i, const std::string & key)
  {
    const std::string why = list_.feed (line, i, key);
    return why.empty () ? true : fail (why);
  }

  const std::string & path_;
  std::string why_;
  int n_ = 0;
  NumberList list_;
};

/* YAML, line by line: the %YAML:1.0 header, `---`, then `key: value`
 * lines, `key: !!opencv-matrix` followed by indented rows, cols, dt and
 * data lines, flow lists of numbers that may continue on indented lines,
 * comments and blank lines. */
class YamlShape : LineShape {
public:
  explicit YamlShape (const std::string & path) : LineShape (path) { }

  bool check (const std::string & text, std::string * error)
  {
    std::istringstream in (text);
    std::string line;
    while (std::getline (in, line)) {
      n_++;
      if (!line.empty () && line.back () == '\r')
        line.pop_back ();
      while (!line.empty () && line.back () == ' ')
        line.pop_back ();
      if (!this->line (line))
        break;
    }
    if (why_.empty () && n_ < 2)
      fail ("the YAML header (%YAML:1.0, then ---) is incomplete");
    if (why_.empty () && (field_ >= 0 || list_.open))
      fail (key_ + ": the file ends inside it");
    if (!why_.empty ())
      *error = why_;
    return why_.empty ();
  }

private:
  bool line (const std::string & line)
  {
    if (n_ == 1)
      return line == "%YAML:1.0" || line == "%YAML 1.0" ? true :
          fail ("not the YAML header %YAML:1.0");
    if (n_ == 2)
      return line == "---" ? true : fail ("expected --- after the header");
    size_t indent = 0;
    if (const int text = text_start (line, "'%' outside the header (OpenCV's parser does not "
            "end on it)", &indent); text <= 0)
      return text == 0;
    if (line[indent] == '#' && !list_.open && field_ < 0)
      return true;
    if (list_.open) {
      if (indent == 0)
        return fail (key_ + ": its list of numbers is not closed");
      return list (line, indent);
    }
    if (field_ >= 0)
      return matrix_field (line, indent);
    if (indent != 0)
      return fail ("unexpected indentation; " + std::string (kShapeHint));
    const size_t colon = line.find (':');
    const std::string key = line.substr (0, colon);
    if (colon == std::string::npos || !is_key (key))
      return fail ("expected `key: value`; " + std::string (kShapeHint));
    key_ = key;
    if (!keys_.insert (key).second)
      return fail (key + " appears twice");
    if (colon + 1 >= line.size () || line[colon + 1] != ' ')
      return fail (key + ": expected a value after `" + key + ": `");
    const size_t v = line.find_first_not_of (' ', colon + 1);
    const std::string value = line.substr (v);
    if (value == "!!opencv-matrix") {
      field_ = 0;
      return true;
    }
    if (value[0] == '[')
      return list (line, v);
    if (!is_scalar (value))
      return fail (key + ": `" + value + "` is not a number, a word or a "
          "quoted text");
    return true;
  }

  bool matrix_field (const std::string & line, size_t indent)
  {
    const std::string want = kMatrixFields[field_];
    const std::string expect = key_ + ": expected `" + want + ": ` (an "
        "opencv-matrix has rows, cols, dt and data, in this order)";
    if (indent == 0 || line.compare (indent, want.size () + 2,
            want + ": ") != 0)
      return fail (expect);
    const std::string value = trimmed (line.substr (indent + want.size () +
            2));
    field_++;
    if (want == "data") {
      field_ = -1;
      if (value.empty () || value[0] != '[')
        return fail (key_ + ": data must be a list of numbers");
      return list (line, line.find ('[', indent));
    }
    if (want == "dt" ? !is_dt (value) : !is_count (value))
      return fail (key_ + ": " + want + " `" + value + "` is not " +
          (want == "dt" ? "an element type (d, f, \"2f\")" :
              "a whole number"));
    return true;
  }

  bool list (const std::string & line, size_t i)
  {
    return LineShape::list (line, i, key_);
  }

  std::string key_;
  std::set<std::string> keys_;
  int field_ = -1;              /* next opencv-matrix field, -1: none */
};

/* JSON through json-glib: an object of scalars, lists of numbers and
 * {"type_id": "opencv-matrix", "rows", "cols", "dt", "data"} objects. */
bool
json_member_ok (JsonNode * node)
{
  if (JSON_NODE_HOLDS_VALUE (node)) {
    const GType t = json_node_get_value_type (node);
    return t == G_TYPE_INT64 || t == G_TYPE_DOUBLE || (t == G_TYPE_STRING
        && is_quoted ("\"" + std::string (json_node_get_string (node)) +
            "\""));
  }
  if (JSON_NODE_HOLDS_ARRAY (node)) {
    JsonArray *a = json_node_get_array (node);
    for (guint i = 0; i < json_array_get_length (a); i++) {
      JsonNode *e = json_array_get_element (a, i);
      if (!JSON_NODE_HOLDS_VALUE (e) || (json_node_get_value_type (e) !=
              G_TYPE_INT64 && json_node_get_value_type (e) != G_TYPE_DOUBLE))
        return false;
    }
    return true;
  }
  if (!JSON_NODE_HOLDS_OBJECT (node))
    return false;
  JsonObject *m = json_node_get_object (node);
  const char *type = json_object_has_member (m, "type_id") ?
      json_string (json_object_get_member (m, "type_id")) : nullptr;
  if (!type || strcmp (type, "opencv-matrix") != 0
      || json_object_get_size (m) != 5)
    return false;
  for (const char *f : kMatrixFields) {
    JsonNode *v = json_object_get_member (m, f);
    if (!v)
      return false;
    const std::string field = f;
    if (field == "data" ? !JSON_NODE_HOLDS_ARRAY (v) ||
        !json_member_ok (v) : field == "dt" ? !json_string (v) ||
        !is_dt (json_string (v)) : !JSON_NODE_HOLDS_VALUE (v) ||
        json_node_get_value_type (v) != G_TYPE_INT64 ||
        !is_count (std::to_string (json_node_get_int (v))))
      return false;
  }
  return true;
}

bool
json_shape_ok (const std::string & text, const std::string & path,
    std::string * error)
{
  if (text.find ('\\') != std::string::npos) {
    *error = path + ": a backslash escape is not read in a camera file";
    return false;
  }
  JsonParserPtr parser (nullptr, g_object_unref);
  JsonObject *root = json_parse_object (text, path, "camera file keys",
      parser, error);
  if (!root)
    return false;
  bool ok = true;
  json_object_foreach_member (root, [](JsonObject *, const gchar * name,
          JsonNode * node, gpointer data) {
        auto e = static_cast<std::string *> (data);
        if (e->empty () && (!is_key (name) || !json_member_ok (node)))
          *e = name;
      }, error);
  if (!error->empty ()) {
    *error = path + ": " + *error + ": " + kShapeHint;
    ok = false;
  }
  return ok;
}

/* The keys only a ROS camera_info file has (camera_calibration_parsers) */
const char *const kCameraInfoKeys[] = { "camera_name", "camera_matrix",
  "distortion_model", "distortion_coefficients", "rectification_matrix",
  "projection_matrix"
};

const char *const kCameraInfoHint = "a ROS camera_info file holds top-level "
    "keys with a number, a word or a quoted text, or a matrix as indented "
    "rows, cols and data lines, as camera_calibration_parsers writes them";

/* camera_name: any plain name (letters, digits, _ - . /) or a quoted one */
bool
is_camera_name (const std::string & s)
{
  if (is_quoted (s))
    return true;
  const bool single = s.size () >= 2 && s.front () == '\'' &&
      s.back () == '\'';
  const size_t a = single ? 1 : 0, b = single ? s.size () - 1 : s.size ();
  if (!single && s.empty ())
    return false;
  for (size_t i = a; i < b; i++) {
    const char c = s[i];
    if (!(is_word_char (c, false) || c == '-' || c == '.' || c == '/'
            || (single && c == ' ')))
      return false;
  }
  return true;
}

/* ROS camera_info YAML, line by line, as camera_calibration_parsers and
 * ROS's camera_calibration write it: an optional `---` first line, then
 * top-level `key: value` lines, and `key:` lines followed by a matrix:
 * rows, cols and data lines indented alike, each once, in any order,
 * data a list of numbers that may continue on lines indented at least 2
 * more than `data:` (OpenCV's YAML parser needs that much); comments and
 * blank lines outside a list. What OpenCV parses is built on the way:
 * the %YAML:1.0 header it needs, the `---` line and camera_name's line
 * left empty (a name such as 00b09d01 stops OpenCV's parser; the name is
 * not read). */
class CameraInfoShape : LineShape {
public:
  explicit CameraInfoShape (const std::string & path) : LineShape (path)
  {
    list_.short_wholes = true;
  }

  bool check (const std::string & text, std::string * opencv_text,
      std::string * error)
  {
    std::istringstream in (text);
    std::string raw;
    std::string out = "%YAML:1.0\n---\n";
    while (std::getline (in, raw)) {
      n_++;
      std::string line = raw;
      if (!line.empty () && line.back () == '\r')
        line.pop_back ();
      while (!line.empty () && line.back () == ' ')
        line.pop_back ();
      keep_ = true;
      if (!this->line (line))
        break;
      out += (keep_ ? raw : std::string ()) + "\n";
    }
    if (why_.empty () && list_.open)
      fail (block_key_ + ": the file ends inside its data list");
    if (why_.empty ())
      end_block ();
    if (!why_.empty ()) {
      *error = why_;
      return false;
    }
    *opencv_text = out;
    return true;
  }

private:
  bool line (const std::string & line)
  {
    if (n_ == 1 && line == "---") {
      keep_ = false;
      return true;
    }
    if (line.find ('\t') != std::string::npos)
      return fail ("a tab (YAML indents with spaces)");
    size_t indent = 0;
    if (const int text = text_start (line, "'%' (OpenCV's parser, which reads the file, does "
            "not end on it)", &indent); text <= 0)
      return text == 0;
    if (list_.open) {
      if (line[indent] == '#')
        return fail (block_key_ + ": a comment inside its data list");
      if (indent < list_indent_)
        return fail (block_key_ + ": a data list continued on the next "
            "line must be indented at least 2 spaces more than `data:`");
      return list (line, indent);
    }
    if (line[indent] == '#')
      return true;
    if (indent == 0)
      return end_block () && top (line);
    if (block_key_.empty ())
      return fail ("unexpected indentation; " + std::string (kCameraInfoHint));
    return field (line, indent);
  }

  bool top (const std::string & line)
  {
    const size_t colon = line.find (':');
    const std::string key = line.substr (0, colon);
    if (colon == std::string::npos || !is_key (key))
      return fail ("expected `key: value`; " + std::string (kCameraInfoHint));
    if (!keys_.insert (key).second)
      return fail (key + " appears twice");
    if (colon + 1 == line.size ()) {
      if (key == "camera_name") {
        keep_ = false;
        return true;
      }
      block_key_ = key;
      block_line_ = n_;
      block_indent_ = 0;
      fields_.clear ();
      return true;
    }
    if (line[colon + 1] != ' ')
      return fail (key + ": expected a space after `" + key + ":`");
    const std::string value = trimmed (line.substr (colon + 1));
    if (key == "camera_name") {
      keep_ = false;
      return is_camera_name (value) ? true : fail ("camera_name: `" + value +
          "` is not a name (letters, digits, _ - . /) or a quoted text");
    }
    if (value == "!!opencv-matrix")
      return fail (key + ": an opencv-matrix in a file without OpenCV's "
          "%YAML:1.0 header (an OpenCV file starts with it; a ROS "
          "camera_info matrix is indented rows, cols and data lines)");
    if (value[0] == '[' || value[0] == '{')
      return fail (key + ": `" + value.substr (0, 40) + "`: " +
          kCameraInfoHint);
    if (!is_scalar (value))
      return fail (key + ": `" + value + "` is not a number, a word or a "
          "quoted text");
    if (!is_short_whole (value))
      return fail (key + ": `" + value + "` is a whole number of more than "
          "9 digits (OpenCV does not read it exactly)");
    return true;
  }

  /* rows, cols or data of the matrix under block_key_ */
  bool field (const std::string & line, size_t indent)
  {
    if (block_indent_ == 0)
      block_indent_ = indent;
    else if (indent != block_indent_)
      return fail (block_key_ + ": its rows, cols and data lines must be "
          "indented alike");
    const size_t colon = line.find (':', indent);
    const std::string name = colon == std::string::npos ? std::string () :
        line.substr (indent, colon - indent);
    if (name != "rows" && name != "cols" && name != "data")
      return fail (block_key_ + ": expected `rows: `, `cols: ` or `data: ` "
          "(a camera_info matrix)");
    if (!fields_.insert (name).second)
      return fail (block_key_ + ": " + name + " appears twice");
    if (colon + 1 >= line.size () || line[colon + 1] != ' ')
      return fail (block_key_ + ": expected a value after `" + name + ": `");
    const std::string value = trimmed (line.substr (colon + 1));
    if (name == "data") {
      if (value[0] != '[')
        return fail (block_key_ + ": data must be a list of numbers, "
            "`data: [ ... ]`, starting on its line");
      list_indent_ = indent + 2;
      return list (line, line.find ('[', colon));
    }
    if (!is_count (value))
      return fail (block_key_ + ": " + name + " `" + value + "` is not a "
          "whole number");
    return true;
  }

  /* the matrix under block_key_ (if one was open) has all its fields */
  bool end_block ()
  {
    if (block_key_.empty ())
      return true;
    const std::string key = block_key_;
    block_key_.clear ();
    if (fields_.empty ())
      return fail_at (block_line_, key + ": expected a value after `" + key +
          ":`, or indented rows, cols and data lines");
    std::string missing;
    for (const char *f : { "rows", "cols", "data" })
      if (!fields_.count (f))
        missing += std::string (missing.empty ()? "" : ", ") + f;
    if (!missing.empty ())
      return fail_at (block_line_, key + ": a matrix needs rows, cols and "
          "data; no " + missing);
    return true;
  }

  bool list (const std::string & line, size_t i)
  {
    return LineShape::list (line, i, block_key_);
  }

  std::string block_key_;
  std::set<std::string> keys_, fields_;
  int block_line_ = 0;
  size_t block_indent_ = 0, list_indent_ = 0;
  bool keep_ = true;
};

/* Bytes no camera file holds: control characters, text that is not UTF-8 */
bool
text_ok (const std::string & text, const std::string & path,
    std::string * error)
{
  for (unsigned char c : text)
    if ((c < 0x20 && c != '\n' && c != '\r' && c != '\t') || c == 0x7f) {
      *error = path + ": control characters in a camera file";
      return false;
    }
  if (!g_utf8_validate (text.data (), (gssize) text.size (), nullptr)) {
    /* GMarkup goes on after its own error on some of these */
    *error = path + ": not UTF-8 text";
    return false;
  }
  return true;
}

}  // namespace

bool
camera_file_shape_ok (const std::string & text, const std::string & path,
    std::string * error)
{
  error->clear ();
  if (!text_ok (text, path, error))
    return false;
  if (text.rfind ("%YAML", 0) == 0)
    return YamlShape (path).check (text, error);
  if (text.rfind ("<?xml", 0) == 0)
    return xml_shape_ok (text, path, error);
  if (text.rfind ("{", 0) == 0)
    return json_shape_ok (text, path, error);
  *error = path + ": not an OpenCV FileStorage file (YAML starting with "
      "%YAML:1.0, XML with <?xml, or JSON with {) nor a ROS camera_info "
      "file (camera_matrix, distortion_coefficients, ... at the left margin)";
  return false;
}

bool
looks_like_camera_info (const std::string & text)
{
  if (text.rfind ("%YAML", 0) == 0 || text.rfind ("<?xml", 0) == 0
      || text.rfind ("{", 0) == 0)
    return false;
  for (const char *key : kCameraInfoKeys) {
    const std::string k = std::string (key) + ":";
    for (size_t at = text.find (k); at != std::string::npos;
        at = text.find (k, at + 1))
      if (at == 0 || text[at - 1] == '\n')
        return true;
  }
  return false;
}

bool
camera_info_shape_ok (const std::string & text, const std::string & path,
    std::string * opencv_text, std::string * error)
{
  error->clear ();
  return text_ok (text, path, error)
      && CameraInfoShape (path).check (text, opencv_text, error);
}

}  // namespace landmark
