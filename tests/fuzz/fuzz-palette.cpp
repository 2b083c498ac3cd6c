/* Fuzz target: the palette parser (core/colour/palette.cpp) on arbitrary bytes.
 * Whatever it accepts must satisfy docs/palette.md's rules; whatever it
 * refuses must come with an error naming the source. */
#include <glib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "fuzzcheck.h"
#include "palette.h"

/* What an accepted palette must satisfy. */
static void
check_palette (const landmark::Palette & palette)
{
  const size_t n = palette.classes.size ();
  std::set<std::string> names;
  for (const auto & c : palette.classes) {
    const char *name = c.name.c_str ();
    FUZZ_CHECK (!c.name.empty () && c.name.size () <= 32 &&
        strlen (name) == c.name.size (), "name length %zu", c.name.size ());
    for (const char *p = name; *p; p++)
      FUZZ_CHECK (g_ascii_isalnum (*p) || strchr ("_.-", *p), "name \"%s\"",
          name);
    FUZZ_CHECK (names.insert (c.name).second, "duplicate \"%s\"", name);
    FUZZ_CHECK (c.references.size () <= landmark::kMaxReferencesPerClass,
        "%zu references", c.references.size ());
    std::vector<landmark::Lab> colours = c.references;
    colours.push_back (c.lab);
    for (const auto & lab : colours) {
      FUZZ_CHECK (std::isfinite (lab.L) && lab.L >= 0 && lab.L <= 100,
          "L* %g", lab.L);
      FUZZ_CHECK (std::isfinite (lab.a) && std::fabs (lab.a) <= 128,
          "a* %g", lab.a);
      FUZZ_CHECK (std::isfinite (lab.b) && std::fabs (lab.b) <= 128,
          "b* %g", lab.b);
    }
  }
  /* the classifier's view: every class keeps at least one reference */
  std::vector<landmark::Lab> refs;
  std::vector<int> ref_class;
  landmark::palette_references (palette, &refs, &ref_class);
  FUZZ_CHECK (refs.size () == ref_class.size () && refs.size () >= n,
      "%zu references for %zu classes", refs.size (), n);
  for (size_t r = 0; r < ref_class.size (); r++)
    FUZZ_CHECK (ref_class[r] >= 0 && (size_t) ref_class[r] < n &&
        (r == 0 || ref_class[r] >= ref_class[r - 1]), "ref_class[%zu] = %d",
        r, ref_class[r]);
}

FUZZ_JSON_TARGET (landmark::palette_parse, &landmark::Palette::classes, 64,
    check_palette)
