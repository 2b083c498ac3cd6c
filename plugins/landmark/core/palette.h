/* Colour palettes: the reference colours labsegment classifies against.
 * JSON format and rules: docs/palette.md (the Python loader in
 * python/gstlandmark/palette.py enforces the same rules). */
#pragma once

#include <string>
#include <vector>

#include "labcolour.h"

namespace landmark {

struct PaletteClass {
  std::string name;
  Lab lab;
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

/* The built-in palette (python/gstlandmark/data/default-palette.json). */
const Palette & palette_default ();

}  // namespace landmark
