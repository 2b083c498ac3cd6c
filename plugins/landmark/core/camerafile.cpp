/* Camera files: see camerafile.h. */
#include "camerafile.h"

#include "fileutil.h"
#include "jsonutil.h"

#include <opencv2/core.hpp>

#include <glib.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

namespace landmark {

/* ---- the shape OpenCV writes, checked before OpenCV parses -------------- */

namespace {

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

bool
is_scalar (const std::string & s)
{
  return is_number (s) || is_key (s) || is_quoted (s);
}

/* "is_number" separated by white space (XML matrix data, XML lists) */
bool
is_number_list (const std::string & text)
{
  std::istringstream in (text);
  std::string word;
  while (in >> word)
    if (!is_number (word))
      return false;
  return true;
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

const char *const kMatrixFields[] = { "rows", "cols", "dt", "data" };

const char *const kShapeHint = "a camera file holds top-level keys with a "
    "number, a word, a quoted text, a list of numbers or an opencv-matrix "
    "(rows, cols, dt, data), as OpenCV writes them";

/* YAML, line by line: the %YAML:1.0 header, `---`, then `key: value`
 * lines, `key: !!opencv-matrix` followed by indented rows, cols, dt and
 * data lines, flow lists of numbers that may continue on indented lines,
 * comments and blank lines. */
class YamlShape {
public:
  explicit YamlShape (const std::string & path) : path_ (path) { }

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
    if (why_.empty () && (field_ >= 0 || in_list_))
      fail (key_ + ": the file ends inside it");
    if (!why_.empty ())
      *error = why_;
    return why_.empty ();
  }

private:
  bool fail (const std::string & what)
  {
    why_ = path_ + ": line " + std::to_string (n_) + ": " + what;
    return false;
  }

  bool line (const std::string & line)
  {
    if (n_ == 1)
      return line == "%YAML:1.0" || line == "%YAML 1.0" ? true :
          fail ("not the YAML header %YAML:1.0");
    if (n_ == 2)
      return line == "---" ? true : fail ("expected --- after the header");
    if (line.find ('%') != std::string::npos)
      return fail ("'%' outside the header (OpenCV's parser does not end "
          "on it)");
    const size_t indent = line.find_first_not_of (' ');
    if (indent == std::string::npos)
      return true;
    if (line[indent] == '#' && !in_list_ && field_ < 0)
      return true;
    if (in_list_) {
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

  /* numbers separated by commas, between [ and ], over several lines */
  bool list (const std::string & line, size_t i)
  {
    if (!in_list_) {
      in_list_ = true;
      need_item_ = true;
      items_ = 0;
      i++;                      /* the [ */
    }
    for (;;) {
      while (i < line.size () && line[i] == ' ')
        i++;
      if (i == line.size ())
        return need_item_ ? true :
            fail (key_ + ": a list line must end with a comma or ]");
      if (line[i] == ']') {
        if (need_item_ && items_ > 0)
          return fail (key_ + ": a comma before ]");
        in_list_ = false;
        return i + 1 == line.size () ? true :
            fail (key_ + ": text after the list's ]");
      }
      if (!need_item_) {
        if (line[i] != ',')
          return fail (key_ + ": expected a comma between numbers");
        i++;
        need_item_ = true;
        continue;
      }
      size_t end = i;
      while (end < line.size () && line[end] != ',' && line[end] != ' '
          && line[end] != ']')
        end++;
      if (!is_number (line.substr (i, end - i)))
        return fail (key_ + ": `" + line.substr (i, end - i) + "` in its "
            "list is not a number");
      items_++;
      need_item_ = false;
      i = end;
    }
  }

  const std::string & path_;
  std::string why_, key_;
  std::set<std::string> keys_;
  int n_ = 0;
  int field_ = -1;              /* next opencv-matrix field, -1: none */
  bool in_list_ = false, need_item_ = false;
  size_t items_ = 0;
};

/* XML through GMarkup: <opencv_storage> holding elements with a scalar
 * or a list of numbers, or type_id="opencv-matrix" with rows, cols, dt
 * and data. Only the <?xml ...?> declaration and comments besides. */
struct XmlShape {
  const std::string *path;
  std::string why, key, text;
  std::set<std::string> keys;
  int depth = 0;
  int field = -1;               /* in a matrix: the next field */
  bool root_seen = false;

  static XmlShape *of (gpointer p) { return static_cast<XmlShape *> (p); }

  static void fail (GMarkupParseContext * ctx, GError ** err, XmlShape * s,
      const std::string & what)
  {
    if (!s->why.empty () || *err)
      return;                   /* one error: the first */
    int line = 0;
    g_markup_parse_context_get_position (ctx, &line, nullptr);
    s->why = *s->path + ": line " + std::to_string (line) + ": " + what;
    g_set_error_literal (err, G_MARKUP_ERROR, G_MARKUP_ERROR_INVALID_CONTENT,
        s->why.c_str ());
  }

  static void start (GMarkupParseContext * ctx, const gchar * name,
      const gchar ** attr_names, const gchar ** attr_values, gpointer data,
      GError ** err)
  {
    XmlShape *s = of (data);
    const std::string n = name;
    if (!trimmed (s->text).empty ())
      return fail (ctx, err, s, "text outside an element's value");
    s->text.clear ();
    if (s->depth == 0) {
      if (n != "opencv_storage" || attr_names[0] || s->root_seen)
        return fail (ctx, err, s, "the top element must be one "
            "<opencv_storage> without attributes");
      s->root_seen = true;
    } else if (s->depth == 1) {
      if (!is_key (n))
        return fail (ctx, err, s, "<" + n + ">: not a key name");
      if (!s->keys.insert (n).second)
        return fail (ctx, err, s, n + " appears twice");
      s->key = n;
      s->field = -1;
      if (attr_names[0]) {
        if (strcmp (attr_names[0], "type_id") != 0 || attr_names[1]
            || strcmp (attr_values[0], "opencv-matrix") != 0)
          return fail (ctx, err, s, n + ": the only attribute read is "
              "type_id=\"opencv-matrix\"");
        s->field = 0;
      }
    } else if (s->depth == 2 && s->field >= 0 && s->field < 4
        && n == kMatrixFields[s->field] && !attr_names[0]) {
      s->field++;
    } else {
      return fail (ctx, err, s, s->key + ": <" + n + "> is not expected "
          "here; " + kShapeHint);
    }
    s->depth++;
  }

  static void end (GMarkupParseContext * ctx, const gchar * name,
      gpointer data, GError ** err)
  {
    XmlShape *s = of (data);
    const std::string n = name, value = trimmed (s->text);
    s->text.clear ();
    s->depth--;
    if (s->depth == 1 && s->field >= 0) {
      if (s->field != 4)
        return fail (ctx, err, s, s->key + ": an opencv-matrix needs rows, "
            "cols, dt and data, in this order");
      if (!value.empty ())
        return fail (ctx, err, s, s->key + ": text outside its fields");
    } else if (s->depth == 0) {
      if (!value.empty ())
        return fail (ctx, err, s, "text outside an element's value");
    } else if (s->depth == 1) {
      if (!is_scalar (value) && !is_number_list (value))
        return fail (ctx, err, s, s->key + ": `" + value + "` is not a "
            "number, a word, a quoted text or numbers");
    } else if (s->depth == 2) {
      const bool ok = n == "data" ? is_number_list (value) :
          n == "dt" ? is_dt (value) : is_count (value);
      if (!ok)
        return fail (ctx, err, s, s->key + ": <" + n + "> `" + value +
            "` is not " + (n == "data" ? "a list of numbers" : n == "dt" ?
                "an element type (d, f, \"2f\")" : "a whole number"));
    }
  }

  static void text_cb (GMarkupParseContext *, const gchar * text, gsize len,
      gpointer data, GError **)
  {
    of (data)->text.append (text, len);
  }

  static void passthrough (GMarkupParseContext *, const gchar * text,
      gsize len, gpointer data, GError ** err)
  {
    XmlShape *s = of (data);
    const std::string t (text, len);
    const bool declaration = t.rfind ("<?xml ", 0) == 0 && !s->root_seen;
    const bool comment = t.rfind ("<!--", 0) == 0;
    if (!declaration && !comment && s->why.empty () && !*err) {
      /* GMarkup's position is past it here: name it by its text */
      s->why = *s->path + ": `" + t.substr (0, 40) + "`: only the <?xml "
          "...?> declaration and comments may accompany <opencv_storage>";
      g_set_error_literal (err, G_MARKUP_ERROR,
          G_MARKUP_ERROR_INVALID_CONTENT, s->why.c_str ());
    }
  }
};

bool
xml_shape_ok (const std::string & text, const std::string & path,
    std::string * error)
{
  if (text.find ('&') != std::string::npos) {
    *error = path + ": '&' (an XML entity) is not read in a camera file";
    return false;
  }
  static const GMarkupParser parser = { XmlShape::start, XmlShape::end,
    XmlShape::text_cb, XmlShape::passthrough, nullptr
  };
  XmlShape shape;
  shape.path = &path;
  GMarkupParseContext *ctx = g_markup_parse_context_new (&parser,
      (GMarkupParseFlags) 0, &shape, nullptr);
  GError *err = nullptr;
  const bool ok = g_markup_parse_context_parse (ctx, text.data (),
      (gssize) text.size (), &err) && g_markup_parse_context_end_parse (ctx,
      &err);
  g_markup_parse_context_free (ctx);
  if (!ok) {
    *error = !shape.why.empty () ? shape.why :
        path + ": not well-formed XML: " + err->message;
    g_error_free (err);
    return false;
  }
  if (!shape.root_seen) {
    *error = path + ": no <opencv_storage> element";
    return false;
  }
  return true;
}

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

/* True when OpenCV may parse text; the format from its first bytes. */
bool
shape_ok (const std::string & text, const std::string & path,
    std::string * error)
{
  error->clear ();
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
  if (text.rfind ("%YAML", 0) == 0)
    return YamlShape (path).check (text, error);
  if (text.rfind ("<?xml", 0) == 0)
    return xml_shape_ok (text, path, error);
  if (text.rfind ("{", 0) == 0)
    return json_shape_ok (text, path, error);
  *error = path + ": not an OpenCV FileStorage file (YAML starting with "
      "%YAML:1.0, XML with <?xml, or JSON with {)";
  return false;
}

}  // namespace

/* ---- the values ---------------------------------------------------------- */

/* The matrix under key a (or b): 0 when absent, 1 when read into *m, -1
 * when refused unread. OpenCV allocates what a matrix declares before it
 * counts the data, so a matrix is decoded only when it declares integer
 * rows and cols with at most max_values values (*declared: rows x cols). */
static int
read_matrix (const cv::FileStorage & fs, const char *a, const char *b,
    double max_values, cv::Mat * m, double *declared)
{
  cv::FileNode n = fs[a];
  if (n.empty ())
    n = fs[b];
  if (n.empty ())
    return 0;
  m->release ();
  *declared = -1;
  const cv::FileNode rows = n["rows"], cols = n["cols"];
  if (!n.isMap () || !rows.isInt () || !cols.isInt ()
      || (int) rows < 0 || (int) cols < 0)
    return -1;
  *declared = (double) (int) rows * (double) (int) cols;
  if (*declared > max_values)
    return -1;
  n >> *m;
  return 1;
}

/* A real number under key, when present; false (with *error) when the key
 * is there but not a finite number. */
static bool
read_real (const cv::FileStorage & fs, const std::string & path,
    const char *key, bool *present, double *value, std::string * error)
{
  const cv::FileNode n = fs[key];
  *present = !n.empty ();
  if (!*present)
    return true;
  if (!n.isReal () && !n.isInt ()) {
    *error = path + ": " + key + " is not a number";
    return false;
  }
  *value = (double) n;
  if (!std::isfinite (*value)) {
    *error = path + ": " + key + " is not finite";
    return false;
  }
  return true;
}

/* The values of a file whose shape was checked: OpenCV reads them. */
static bool
read_values (const std::string & path, const std::string & text,
    CameraFile * out, std::string * error)
{
  try {
    cv::FileStorage fs (text, cv::FileStorage::READ |
        cv::FileStorage::MEMORY);
    if (!fs.isOpened ()) {
      *error = path + ": not an OpenCV FileStorage file (YAML or XML)";
      return false;
    }
    const cv::FileNode model = fs["model"];
    if (!model.empty ()) {
      const std::string name = model.isString ()? (std::string) model : "";
      if (name == "seed") {
        out->seed = true;
      } else if (name != "pinhole") {
        *error = path + ": unknown model '" + name + "' (expected seed, or "
            "a pinhole file with camera_matrix)";
        return false;
      }
    }
    if (!fs["image_width"].empty ())
      fs["image_width"] >> out->image_width;
    if (!fs["image_height"].empty ())
      fs["image_height"] >> out->image_height;
    if (out->image_width < 0 || out->image_height < 0) {
      *error = path + ": image_width and image_height must be positive";
      return false;
    }
    if (out->image_width > kMaxCameraImageSize
        || out->image_height > kMaxCameraImageSize) {
      *error = path + ": image_width and image_height must be at most " +
          std::to_string (kMaxCameraImageSize) + ", got " +
          std::to_string (out->image_width) + "x" +
          std::to_string (out->image_height);
      return false;
    }
    double v = 0;
    bool present = false;
    if (!read_real (fs, path, "camera_height", &present, &v, error))
      return false;
    if (present) {
      if (!(v > 0)) {
        *error = path + ": camera_height must be positive (metres), got " +
            number_text (v);
        return false;
      }
      out->has_camera_height = true;
      out->camera_height = v;
    }

    if (out->seed) {
      if (!out->has_camera_height) {
        *error = path + ": a seed file (model: seed) needs camera_height";
        return false;
      }
      const char *keys[] = { "blind_distance", "view_depth", "half_width" };
      double *dst[] = { &out->blind_distance, &out->view_depth,
        &out->half_width
      };
      for (int i = 0; i < 3; i++) {
        if (!read_real (fs, path, keys[i], &present, dst[i], error))
          return false;
        if (!present) {
          *error = path + ": a seed file (model: seed) needs " + keys[i];
          return false;
        }
        if (!(*dst[i] > 0)) {
          *error = path + ": " + keys[i] + " must be positive (metres), got "
              + number_text (*dst[i]);
          return false;
        }
      }
      /* tilt_deg and the fields of view in a seed file are derived from
       * the four lengths: not read */
      return true;
    }

    if (!read_real (fs, path, "tilt_deg", &out->has_tilt, &out->tilt_deg,
            error)
        || !read_real (fs, path, "roll_deg", &out->has_roll, &out->roll_deg,
            error))
      return false;
    if (out->has_tilt && !(out->tilt_deg >= -90 && out->tilt_deg <= 90)) {
      *error = path + ": tilt_deg must be within [-90, 90] degrees, got " +
          number_text (out->tilt_deg);
      return false;
    }

    cv::Mat k, d;
    double declared = 0;
    const int have_k = read_matrix (fs, "camera_matrix", "cameraMatrix", 9,
        &k, &declared);
    if (have_k == 0) {
      *error = path + ": no camera_matrix (nor model: seed)";
      return false;
    }
    if (k.rows != 3 || k.cols != 3 || k.channels () != 1) {
      *error = path + ": camera_matrix is not 3x3";
      return false;
    }
    k.convertTo (k, CV_64F);
    out->fx = k.at<double> (0, 0);
    out->fy = k.at<double> (1, 1);
    out->cx = k.at<double> (0, 2);
    out->cy = k.at<double> (1, 2);
    if (!(out->fx > 0 && out->fy > 0) || !std::isfinite (out->fx)
        || !std::isfinite (out->fy) || !std::isfinite (out->cx)
        || !std::isfinite (out->cy) || k.at<double> (1, 0) != 0
        || k.at<double> (2, 0) != 0 || k.at<double> (2, 1) != 0
        || k.at<double> (2, 2) != 1.0) {
      *error = path + ": camera_matrix is not a camera matrix (fx, fy > 0, "
          "last row 0 0 1)";
      return false;
    }
    const int have_d = read_matrix (fs, "distortion_coefficients",
        "distCoeffs", 14, &d, &declared);
    if (have_d < 0 && declared < 0) {
      *error = path + ": distortion_coefficients is not an OpenCV matrix "
          "(rows, cols, dt, data)";
      return false;
    }
    if (have_d != 0 && (have_d < 0 || !d.empty ())) {
      const size_t n = d.total ();
      if (d.channels () != 1 || !(n == 4 || n == 5 || n == 8 || n == 12
              || n == 14)) {
        *error = path + ": distortion_coefficients must have 4, 5, 8, 12 or "
            "14 values, has " + (have_d < 0 ? number_text (declared) :
            std::to_string (n));
        return false;
      }
      d = d.reshape (1, 1);
      d.convertTo (d, CV_64F);
      for (size_t i = 0; i < n; i++) {
        const double c = d.at<double> (0, (int) i);
        if (!std::isfinite (c)) {
          *error = path + ": distortion_coefficients are not finite";
          return false;
        }
        out->dist.push_back (c);
      }
    }
  }
  catch (const cv::Exception & e) {
    *error = path + ": cannot parse the calibration file: " + e.msg;
    return false;
  }
  catch (const std::exception & e) {
    /* OpenCV's parsers also throw standard exceptions on some malformed
     * files (std::length_error from a misplaced key) */
    *error = path + ": cannot parse the calibration file: " + e.what ();
    return false;
  }
  return true;
}


bool
load_camera_file (const std::string & path, CameraFile * out,
    std::string * error)
{
  *out = CameraFile ();
  std::ifstream f (path, std::ios::binary);
  if (!f.good ()) {
    *error = path + ": cannot open the calibration file";
    return false;
  }
  /* before reading: a device such as /dev/zero never ends */
  if (!config_file_size_ok (path, error))
    return false;
  struct stat st;
  if (stat (path.c_str (), &st) == 0 && S_ISDIR (st.st_mode)) {
    *error = path + ": is a directory, not a calibration file";
    return false;
  }
  /* read once: what was checked is what OpenCV parses */
  std::ostringstream whole;
  whole << f.rdbuf ();
  const std::string text = whole.str ();
  if (trimmed (text).empty ()) {
    *error = path + ": the calibration file is empty";
    return false;
  }
  return shape_ok (text, path, error) && read_values (path, text, out,
      error);
}

}  // namespace landmark
