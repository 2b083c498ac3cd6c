#include "slamio.h"

#include <json-glib/json-glib.h>

#include <cmath>

#include "jsonutil.h"

namespace landmark {

bool
odometry_parse (const std::string & text, const std::string & source,
    std::vector<OdometryStep> * out, std::string * error)
{
  out->clear ();
  size_t pos = 0;
  unsigned line = 0;
  while (pos < text.size ()) {
    size_t end = text.find ('\n', pos);
    if (end == std::string::npos)
      end = text.size ();
    const std::string l = text.substr (pos, end - pos);
    pos = end + 1;
    line++;
    if (l.find_first_not_of (" \t\r") == std::string::npos)
      continue;
    const std::string where = source + ":" + std::to_string (line);
    JsonParserPtr parser (nullptr, g_object_unref);
    JsonObject *o = json_parse_object (l, where, "\"t\", \"dx\" and "
        "\"dheading\"", parser, error);
    if (!o)
      return false;
    OdometryStep s;
    const char *need[] = { "t", "dx", "dheading" };
    double *dst[] = { &s.t, &s.dx, &s.dheading };
    for (int k = 0; k < 3; k++) {
      JsonNode *n = json_object_get_member (o, need[k]);
      if (!n || !json_number (n, dst[k])) {
        *error = where + ": \"" + need[k] + "\" must be a number";
        return false;
      }
    }
    if (JsonNode * n = json_object_get_member (o, "dy")) {
      if (!json_number (n, &s.dy)) {
        *error = where + ": \"dy\" must be a number";
        return false;
      }
    }
    if (s.t < 0) {
      *error = where + ": \"t\" must not be negative";
      return false;
    }
    if (!out->empty () && s.t < out->back ().t) {
      *error = where + ": time goes backwards (" + std::to_string (s.t)
          + " s after " + std::to_string (out->back ().t) + " s)";
      return false;
    }
    if (out->size () >= kMaxOdometrySteps) {
      *error = source + ": more than " + std::to_string (kMaxOdometrySteps)
          + " lines";
      return false;
    }
    out->push_back (s);
  }
  return true;
}

bool
odometry_load_file (const std::string & path,
    std::vector<OdometryStep> * out, std::string * error)
{
  return json_load_file (path, out, error, odometry_parse);
}

void
OdometrySum::add (double step_dx, double step_dy, double step_dheading)
{
  const double c = std::cos (dheading), s = std::sin (dheading);
  dx += c * step_dx - s * step_dy;
  dy += s * step_dx + c * step_dy;
  dheading += step_dheading;
}

void
odometry_between (const std::vector<OdometryStep> & steps, double a,
    double b, size_t * next, double *dx, double *dy, double *dheading)
{
  OdometrySum sum;
  size_t i = *next;
  while (i < steps.size () && steps[i].t <= a)
    i++;
  for (; i < steps.size () && steps[i].t <= b; i++)
    sum.add (steps[i].dx, steps[i].dy, steps[i].dheading);
  *next = i;
  *dx = sum.dx;
  *dy = sum.dy;
  *dheading = sum.dheading;
}

std::string
slam_map_json (const std::vector<SlamLandmark> & landmarks)
{
  JsonBuilder *b = json_builder_new ();
  json_builder_begin_object (b);
  json_builder_set_member_name (b, "landmarks");
  json_builder_begin_array (b);
  for (const auto & l : landmarks) {
    if (!l.confirmed && !l.anchor)
      continue;
    json_builder_begin_object (b);
    json_builder_set_member_name (b, "id");
    json_builder_add_string_value (b, l.id.c_str ());
    if (!l.coded ()) {
      json_builder_set_member_name (b, "class");
      json_builder_add_string_value (b, l.class_name.c_str ());
    }
    json_builder_set_member_name (b, "x");
    json_builder_add_double_value (b, l.x);
    json_builder_set_member_name (b, "y");
    json_builder_add_double_value (b, l.y);
    json_builder_set_member_name (b, "z");
    json_builder_add_double_value (b, l.z);
    if (l.coded ()) {
      /* an anchored coded marker, as the map gave it (docs/beacons.md) */
      json_builder_set_member_name (b, "kind");
      json_builder_add_string_value (b, map_kind_name (l.kind));
      json_builder_set_member_name (b, "diameter");
      json_builder_add_double_value (b, l.diameter);
      json_builder_set_member_name (b, "height");
      json_builder_add_double_value (b, l.height);
      json_builder_set_member_name (b, "bands");
      json_builder_begin_array (b);
      for (const std::string & band : l.bands)
        json_builder_add_string_value (b, band.c_str ());
      json_builder_end_array (b);
      json_builder_set_member_name (b, "band-heights");
      json_builder_begin_array (b);
      for (double h : l.band_heights)
        json_builder_add_double_value (b, h);
      json_builder_end_array (b);
    } else if (l.diameter > 0) {
      json_builder_set_member_name (b, "diameter");
      json_builder_add_double_value (b, l.diameter);
      json_builder_set_member_name (b, "kind");
      json_builder_add_string_value (b, l.ball ? "ball" : "disc");
    }
    json_builder_set_member_name (b, "covariance");
    json_builder_begin_array (b);
    for (double c : l.cov)
      json_builder_add_double_value (b, c);
    json_builder_end_array (b);
    json_builder_set_member_name (b, "views");
    json_builder_add_int_value (b, l.views);
    json_builder_end_object (b);
  }
  json_builder_end_array (b);
  json_builder_end_object (b);
  JsonGenerator *g = json_generator_new ();
  JsonNode *root = json_builder_get_root (b);
  json_generator_set_root (g, root);
  json_generator_set_pretty (g, TRUE);
  gchar *s = json_generator_to_data (g, nullptr);
  std::string out = s;
  out += '\n';
  g_free (s);
  json_node_unref (root);
  g_object_unref (g);
  g_object_unref (b);
  return out;
}

bool
slam_write_file (const std::string & path, const std::string & text,
    std::string * error)
{
  /* g_file_set_contents writes a temporary file and renames it */
  GError *err = nullptr;
  if (!g_file_set_contents (path.c_str (), text.data (), text.size (),
          &err)) {
    *error = path + ": cannot write the map: " + err->message;
    g_error_free (err);
    return false;
  }
  return true;
}

}  // namespace landmark
