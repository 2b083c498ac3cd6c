/* The shape of an XML camera file (camerafileshape.h), checked through
 * GMarkup. */
#include "camerafileshapeinternal.h"

#include <glib.h>

#include <cstring>
#include <set>
#include <sstream>
#include <string>

namespace landmark {
namespace camera_file_shape {

namespace {

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

}  // namespace

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

}  // namespace camera_file_shape
}  // namespace landmark
