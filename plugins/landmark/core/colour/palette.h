/* Colour palettes: the reference colours labsegment classifies against.
 * JSON format and rules: docs/palette.md (the Python loader in
 * python/gstlandmark/palette.py enforces the same rules). */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "labcolour.h"

namespace landmark {

/* At most this many classes per palette: labels are 8 bits, and the
 * per-frame class arrays (histogram, active flags) have this size. */
constexpr int kMaxClasses = 64;

/* At most this many reference colours per class. */
constexpr size_t kMaxReferencesPerClass = 32;

/* What a class is for (docs/palette.md, "Roles"): landmark colours,
 * the floor the robot drives on, or anything else (walls, furniture). */
enum class PaletteRole { Marker, Floor, Background };

/* "marker", "floor", "background": the palette file's spelling. */
const char *palette_role_name (PaletteRole role);

/* Whether `name` may name a class: 1 to 32 of A-Z a-z 0-9 _ . - (so a
 * coded marker's code, its band classes joined by "/", reads back
 * unambiguously). */
bool palette_valid_class_name (const char *name);

struct PaletteClass {
  std::string name;
  /* The class's colour (false-colour output, reported rgb); its only
   * reference when `references` is empty. */
  Lab lab;
  /* The class's reference colours when it has its own list (1 to
   * kMaxReferencesPerClass), e.g. a ball's lit and shaded sides. */
  std::vector<Lab> references;
  /* The light each reference is seen under, as factors of the light it
   * was taught in (docs/palette.md, "Shading"): 1, 1 = the colour itself;
   * 0.125, 2 = from an eighth of that light to twice it. */
  double shade_lo = 1.0, shade_hi = 1.0;
  PaletteRole role = PaletteRole::Marker;
  /* role == PaletteRole::Marker, kept for the readers of the flag */
  bool marker = true;
};

struct Palette {
  std::vector<PaletteClass> classes;
};

/* Parses palette JSON; on failure returns false and sets *error to a message
 * that starts with `source` and names the offending entry. */
bool palette_parse (const std::string & json, const std::string & source,
    Palette * out, std::string * error);

/* Reads and parses a palette file; errors name the file. */
bool palette_load_file (const std::string & path, Palette * out,
    std::string * error);

/* Every reference colour of the palette in class order, and the class index
 * (label - 1) of each: what ClassifierConfig's refs and ref_class take. */
void palette_references (const Palette & palette, std::vector<Lab> * refs,
    std::vector<int> * ref_class);

/* The ends of each reference's shading segment, in palette_references'
 * order: the colour under the class's least and most light (equal to the
 * reference for a class without shading). */
void palette_shading_ends (const Palette & palette, std::vector<Lab> * dark,
    std::vector<Lab> * light);

/* A surface colour under k times the light: L*+16, a* and b* all scale by
 * the cube root of k (exact where L* follows the cube root, L* > 8),
 * with L* kept within 0..100. */
Lab lab_under_light (const Lab & lab, double k);

/* Shading factors a palette may give: 1/64 (six stops darker) to 64. */
constexpr double kMinShade = 1.0 / 64, kMaxShade = 64.0;

/* The built-in palette (python/gstlandmark/data/default-palette.json). */
const Palette & palette_default ();

}  // namespace landmark
