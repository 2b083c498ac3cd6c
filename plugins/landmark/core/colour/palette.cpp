#include "palette.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <set>

#include "default-palette.h"  /* generated: kDefaultPaletteJson */
#include "jsonutil.h"

namespace landmark {

namespace {

constexpr gsize kMaxNameLength = 32;

std::string
entry_label (guint index, const char *name)
{
  return json_entry_label ("classes", index, name);
}

/* A colour [L, a, b]; `what` names it in messages. */
bool
parse_lab (JsonNode * node, const std::string & what, Lab * out,
    std::string * why)
{
  JsonArray *lab = node && JSON_NODE_HOLDS_ARRAY (node) ?
      json_node_get_array (node) : nullptr;
  double v[3];
  bool numbers = lab && json_array_get_length (lab) == 3;
  for (guint i = 0; numbers && i < 3; i++)
    numbers = json_number (json_array_get_element (lab, i), &v[i]);
  if (!numbers) {
    *why = what + " must be an array of 3 finite numbers [L, a, b]";
    return false;
  }
  if (v[0] < 0 || v[0] > 100) {
    *why = what + " L* must be within 0..100, got " + std::to_string (v[0]);
    return false;
  }
  for (int i = 1; i < 3; i++) {
    if (v[i] < -128 || v[i] > 128) {
      *why = what + " " + (i == 1 ? "a*" : "b*") +
          " must be within -128..128, got " + std::to_string (v[i]);
      return false;
    }
  }
  *out = Lab { v[0], v[1], v[2] };
  return true;
}

bool
parse_role (const char *text, PaletteRole * out)
{
  for (PaletteRole r : {PaletteRole::Marker, PaletteRole::Floor,
          PaletteRole::Background}) {
    if (text && strcmp (text, palette_role_name (r)) == 0) {
      *out = r;
      return true;
    }
  }
  return false;
}

bool
parse_class (JsonNode * node, guint index, PaletteClass * out,
    std::string * why)
{
  JsonObject *obj = json_entry_object (node, "classes", index, why);
  if (!obj)
    return false;

  const char *name = json_string (json_object_get_member (obj, "name"));
  if (!name) {
    *why = entry_label (index, nullptr) + ": \"name\" must be a string";
    return false;
  }
  if (!palette_valid_class_name (name)) {
    *why = entry_label (index, name) + ": \"name\" must be 1 to 32 "
        "characters from A-Z a-z 0-9 _ . -";
    return false;
  }
  const std::string where = entry_label (index, name);

  GList *members = json_object_get_members (obj);
  for (GList * l = members; l; l = l->next) {
    const char *key = (const char *) l->data;
    if (strcmp (key, "name") && strcmp (key, "lab") && strcmp (key, "marker")
        && strcmp (key, "references") && strcmp (key, "role")
        && strcmp (key, "shading")) {
      *why = where + ": unknown key \"" + key +
          "\" (allowed: name, lab, references, shading, marker, role)";
      g_list_free (members);
      return false;
    }
  }
  g_list_free (members);

  Lab lab;
  if (!parse_lab (json_object_get_member (obj, "lab"), where + ": \"lab\"",
          &lab, why))
    return false;

  std::vector<Lab> references;
  JsonNode *refs_node = json_object_get_member (obj, "references");
  if (refs_node) {
    if (!JSON_NODE_HOLDS_ARRAY (refs_node)) {
      *why = where + ": \"references\" must be an array of [L, a, b] "
          "arrays";
      return false;
    }
    JsonArray *refs = json_node_get_array (refs_node);
    const guint n = json_array_get_length (refs);
    if (n == 0 || n > kMaxReferencesPerClass) {
      *why = where + ": \"references\" must hold 1 to " +
          std::to_string (kMaxReferencesPerClass) + " colours, got " +
          std::to_string (n);
      return false;
    }
    for (guint i = 0; i < n; i++) {
      Lab ref;
      if (!parse_lab (json_array_get_element (refs, i), where +
              ": \"references\"[" + std::to_string (i) + "]", &ref, why))
        return false;
      references.push_back (ref);
    }
  }

  double shade[2] = { 1.0, 1.0 };
  JsonNode *shade_node = json_object_get_member (obj, "shading");
  if (shade_node) {
    JsonArray *arr = JSON_NODE_HOLDS_ARRAY (shade_node) ?
        json_node_get_array (shade_node) : nullptr;
    bool ok = arr && json_array_get_length (arr) == 2;
    for (guint i = 0; ok && i < 2; i++) {
      JsonNode *e = json_array_get_element (arr, i);
      ok = JSON_NODE_HOLDS_VALUE (e) &&
          (json_node_get_value_type (e) == G_TYPE_DOUBLE ||
          json_node_get_value_type (e) == G_TYPE_INT64);
      if (ok)
        shade[i] = json_node_get_double (e);
    }
    if (!ok || !std::isfinite (shade[0]) || !std::isfinite (shade[1]) ||
        shade[0] < kMinShade || shade[0] > 1.0 || shade[1] < 1.0 ||
        shade[1] > kMaxShade) {
      *why = where + ": \"shading\" must be [darkest, lightest] light "
          "factors, 1/64 <= darkest <= 1 <= lightest <= 64";
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

  /* "role" wins the old flag's place; given both, they must agree */
  PaletteRole role = marker ? PaletteRole::Marker : PaletteRole::Background;
  JsonNode *role_node = json_object_get_member (obj, "role");
  if (role_node) {
    const char *text = json_string (role_node);
    if (!parse_role (text, &role)) {
      *why = where + ": \"role\" must be \"marker\", \"floor\" or "
          "\"background\"";
      return false;
    }
    if (marker_node && marker != (role == PaletteRole::Marker)) {
      *why = where + ": \"marker\": " + (marker ? "true" : "false") +
          " contradicts \"role\": \"" + text + "\"";
      return false;
    }
  }

  out->name = name;
  out->lab = lab;
  out->references = std::move (references);
  out->shade_lo = shade[0];
  out->shade_hi = shade[1];
  out->role = role;
  out->marker = role == PaletteRole::Marker;
  return true;
}

}  // namespace

bool
palette_valid_class_name (const char *name)
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

const char *
palette_role_name (PaletteRole role)
{
  /* in the enum's order */
  static const char *const names[] = { "marker", "floor", "background" };
  return names[(int) role];
}

bool
palette_parse (const std::string & json, const std::string & source,
    Palette * out, std::string * error)
{
  /* *out is left as it was on failure */
  return json_parse_unique_list (json, source, "classes",
      (unsigned) kMaxClasses, "class name", parse_class,
      [](const PaletteClass & cls) { return cls.name; },
      [](guint, const PaletteClass &, std::string *) { return true; },
      &out->classes, error);
}

bool
palette_load_file (const std::string & path, Palette * out,
    std::string * error)
{
  return json_load_file (path, out, error, palette_parse);
}

void
palette_references (const Palette & palette, std::vector<Lab> * refs,
    std::vector<int> * ref_class)
{
  refs->clear ();
  ref_class->clear ();
  for (size_t k = 0; k < palette.classes.size (); k++) {
    const PaletteClass & c = palette.classes[k];
    if (c.references.empty ()) {
      refs->push_back (c.lab);
      ref_class->push_back ((int) k);
    }
    for (const Lab & r : c.references) {
      refs->push_back (r);
      ref_class->push_back ((int) k);
    }
  }
}

Lab
lab_under_light (const Lab & lab, double k)
{
  const double base = lab.L + 16.0;
  if (base <= 0)
    return lab;
  const double s = std::clamp (std::cbrt (k), 16.0 / base, 116.0 / base);
  return Lab { base * s - 16.0, lab.a * s, lab.b * s };
}

void
palette_shading_ends (const Palette & palette, std::vector<Lab> * dark,
    std::vector<Lab> * light)
{
  std::vector<Lab> refs;
  std::vector<int> ref_class;
  palette_references (palette, &refs, &ref_class);
  dark->clear ();
  light->clear ();
  for (size_t r = 0; r < refs.size (); r++) {
    const PaletteClass & c = palette.classes[ref_class[r]];
    dark->push_back (lab_under_light (refs[r], c.shade_lo));
    light->push_back (lab_under_light (refs[r], c.shade_hi));
  }
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
