/* Tests of the algorithm code without GStreamer: L*a*b* conversion, the
 * exactness of the class table over every 8-bit colour, palette and map
 * parsing. */
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "classtable.h"
#include "corecheck.h"
#include "labcolour.h"
#include "landmarkmap.h"
#include "palette.h"

using namespace landmark;

/* CIE 1976 values of sRGB primaries and greys (D65), from the published
 * formulas; 0.05 covers the 6-digit matrix. */
static void
test_lab_known_values ()
{
  struct { int r, g, b; double L, a, bb; } known[] = {
    {255, 255, 255, 100.0, 0.0, 0.0},
    {0, 0, 0, 0.0, 0.0, 0.0},
    {255, 0, 0, 53.24, 80.09, 67.20},
    {0, 255, 0, 87.73, -86.18, 83.18},
    {0, 0, 255, 32.30, 79.19, -107.86},
    {128, 128, 128, 53.59, 0.0, 0.0},
  };
  LabConverter converter;
  for (const auto & k : known) {
    Lab lab = srgb_to_lab (k.r / 255.0, k.g / 255.0, k.b / 255.0);
    CHECK (std::fabs (lab.L - k.L) < 0.05 && std::fabs (lab.a - k.a) < 0.1 &&
        std::fabs (lab.b - k.bb) < 0.1, "(%d,%d,%d) -> %.3f %.3f %.3f",
        k.r, k.g, k.b, lab.L, lab.a, lab.b);
    /* OpenCV's table-based conversion, which classification uses */
    const float comps[3] = { (float) k.r, (float) k.g, (float) k.b };
    float cv[3];
    converter.convert (InputModel::rgb (), comps, 1, cv);
    CHECK (std::fabs (cv[0] - k.L) < 0.1 && std::fabs (cv[1] - k.a) < 0.1 &&
        std::fabs (cv[2] - k.bb) < 0.1, "OpenCV (%d,%d,%d) -> %.3f %.3f %.3f",
        k.r, k.g, k.b, cv[0], cv[1], cv[2]);
  }
}

/* OpenCV's conversion stays within 0.75 Delta E of the formulas (the class
 * table's cell bound relies on it) */
static void
test_opencv_conversion_error ()
{
  LabConverter converter;
  std::vector<float> comps, lab;
  double worst = 0;
  for (int r = 0; r < 256; r += 3)
    for (int g = 0; g < 256; g += 3)
      for (int b = 0; b < 256; b += 3) {
        comps.insert (comps.end (), { (float) r, (float) g, (float) b });
      }
  const int n = comps.size () / 3;
  lab.resize (comps.size ());
  converter.convert (InputModel::rgb (), comps.data (), n, lab.data ());
  for (int i = 0; i < n; i++) {
    Lab f = srgb_to_lab (comps[3 * i] / 255.0, comps[3 * i + 1] / 255.0,
        comps[3 * i + 2] / 255.0);
    const double dl = f.L - lab[3 * i], da = f.a - lab[3 * i + 1],
        db = f.b - lab[3 * i + 2];
    worst = std::fmax (worst, std::sqrt (dl * dl + da * da + db * db));
  }
  CHECK (worst < 0.75, "OpenCV differs from the formulas by %.3f", worst);
  printf ("OpenCV float L*a*b*: within %.3f Delta E of the CIE formulas\n",
      worst);
}

static void
test_lab_round_trip ()
{
  std::mt19937 rng (7);
  std::uniform_real_distribution<double> u (0.0, 1.0);
  double worst = 0;
  for (int i = 0; i < 10000; i++) {
    double rgb[3] = { u (rng), u (rng), u (rng) }, back[3];
    lab_to_srgb (srgb_to_lab (rgb[0], rgb[1], rgb[2]), back);
    for (int c = 0; c < 3; c++)
      worst = std::fmax (worst, std::fabs (rgb[c] - back[c]));
  }
  CHECK (worst < 1e-4, "worst round-trip error %g", worst);
}

static void
test_yuv_model ()
{
  /* BT.601 limited range: Y=235, U=V=128 is white, Y=16 black; the model
   * and its inverse agree on random colours */
  InputModel m = InputModel::yuv (0.299, 0.114, false);
  double rgb[3];
  m.to_srgb (235, 128, 128, rgb);
  CHECK (std::fabs (rgb[0] - 1) < 1e-9 && std::fabs (rgb[2] - 1) < 1e-9,
      "white is %g %g %g", rgb[0], rgb[1], rgb[2]);
  m.to_srgb (16, 128, 128, rgb);
  CHECK (std::fabs (rgb[1]) < 1e-9, "black is %g %g %g", rgb[0], rgb[1],
      rgb[2]);
  std::mt19937 rng (3);
  std::uniform_real_distribution<double> u (0.05, 0.95);
  for (int i = 0; i < 1000; i++) {
    double in[3] = { u (rng), u (rng), u (rng) }, out[3];
    uint8_t c[3];
    m.from_srgb (in, c);
    m.to_srgb (c[0], c[1], c[2], out);
    for (int k = 0; k < 3; k++)
      CHECK (std::fabs (in[k] - out[k]) < 0.02, "component %d: %g vs %g", k,
          in[k], out[k]);
  }
}

/* The table must give, for every one of the 2^24 input colours, exactly
 * what the direct computation gives. */
static void
check_table_exact (const char *what, const ClassifierConfig & cfg,
    KeyOrder order = KeyOrder::C0_LOW)
{
  ClassTable table;
  const auto t0 = std::chrono::steady_clock::now ();
  table.build (cfg, order);
  const double build_ms = std::chrono::duration<double, std::milli> (
      std::chrono::steady_clock::now () - t0).count ();
  long mismatches = 0;
  std::vector<uint8_t> comps (3 * 256), exact (256);
  for (int c0 = 0; c0 < 256; c0++)
    for (int c1 = 0; c1 < 256; c1++) {
      for (int c2 = 0; c2 < 256; c2++) {
        comps[3 * c2] = c0;
        comps[3 * c2 + 1] = c1;
        comps[3 * c2 + 2] = c2;
      }
      table.classify_exact (comps.data (), 256, nullptr, exact.data ());
      for (int c2 = 0; c2 < 256; c2++) {
        uint8_t l = table.lookup (c0, c1, c2);
        if (l == ClassTable::kPending)
          l = table.resolve (c0, c1, c2);
        if (l != exact[c2] || table.lookup (c0, c1, c2) != l)
          mismatches++;
      }
    }
  CHECK (mismatches == 0, "%s: %ld of 16777216 colours differ", what,
      mismatches);
  /* labsegment's gathers read 4 bytes at a key: the last keys reach 3 bytes
   * into the padding, which must be there (sanitizer builds) and zero */
  for (size_t i = 0; i < ClassTable::kPadding; i++)
    CHECK (table.labels ()[((size_t) 1 << 24) + i] == 0,
        "%s: padding byte %zu is %d", what, i,
        table.labels ()[((size_t) 1 << 24) + i]);
  printf ("table %-28s exact over 2^24 colours; build %.1f ms, %zu boundary "
      "cells of 32768\n", what, build_ms, table.boundary_cells ());
}

static void
test_table_exact ()
{
  const Palette & def = palette_default ();
  ClassifierConfig cfg;
  for (const auto & c : def.classes)
    cfg.refs.push_back (c.lab);
  check_table_exact ("default rgb", cfg);
  check_table_exact ("default rgb, BGR byte order", cfg, KeyOrder::C0_HIGH);

  ClassifierConfig tight = cfg;
  tight.max_distance = 12.0;
  check_table_exact ("default rgb max-distance=12", tight);

  ClassifierConfig ab = cfg;
  ab.use_lightness = false;
  check_table_exact ("default rgb a*b* only", ab);

  ClassifierConfig yuv = cfg;
  yuv.model = InputModel::yuv (0.2126, 0.0722, true);
  check_table_exact ("default bt709 full range", yuv);

  std::mt19937 rng (11);
  std::uniform_real_distribution<double> L (0, 100), ab_ (-100, 100);
  ClassifierConfig random;
  for (int i = 0; i < 24; i++)
    random.refs.push_back (Lab { L (rng), ab_ (rng), ab_ (rng) });
  random.max_distance = 25.0;
  random.model = InputModel::yuv (0.299, 0.114, false);
  check_table_exact ("24 random bt601 limited", random);

  /* several references per class: the default palette with a lit and a
   * shaded yellow and three reds, through the palette parser */
  Palette multi;
  std::string err;
  CHECK (palette_parse ("{\"classes\": ["
          "{\"name\": \"red\", \"lab\": [41, 43, 32], \"references\": "
          "[[41, 43, 32], [30, 35, 20], [55, 50, 40]]},"
          "{\"name\": \"green\", \"lab\": [81.88, -48.6, 46.6]},"
          "{\"name\": \"yellow\", \"lab\": [75, -5, 70], \"references\": "
          "[[90, -15, 80], [55, 4, 55]]},"
          "{\"name\": \"white\", \"lab\": [92.91, 0, 0], \"marker\": false},"
          "{\"name\": \"grey\", \"lab\": [53.58, 0, 0], \"marker\": false,"
          " \"references\": [[53.58, 0, 0], [30, 0, 0]]}]}", "multi.json",
          &multi, &err), "%s", err.c_str ());
  ClassifierConfig multi_cfg;
  palette_references (multi, &multi_cfg.refs, &multi_cfg.ref_class);
  CHECK (multi_cfg.refs.size () == 9, "%zu references",
      multi_cfg.refs.size ());
  check_table_exact ("multi-reference rgb", multi_cfg);
  multi_cfg.max_distance = 15.0;
  check_table_exact ("multi-reference rgb max-distance=15", multi_cfg,
      KeyOrder::C0_HIGH);

  /* the same palette with shading: each reference a segment from its
   * colour under an eighth of the light to twice the light */
  for (auto & c : multi.classes) {
    c.shade_lo = 0.125;
    c.shade_hi = 2.0;
  }
  ClassifierConfig shaded_cfg = multi_cfg;
  palette_shading_ends (multi, &shaded_cfg.dark, &shaded_cfg.light);
  CHECK (shaded_cfg.dark.size () == 9 && shaded_cfg.light.size () == 9,
      "%zu segment ends", shaded_cfg.dark.size ());
  check_table_exact ("multi-reference rgb with shading", shaded_cfg);

  /* 8 classes of 1 to 4 random references each */
  ClassifierConfig random_multi;
  std::uniform_int_distribution<int> count (1, 4);
  for (int k = 0; k < 8; k++) {
    const int m = count (rng);
    for (int i = 0; i < m; i++) {
      random_multi.refs.push_back (Lab { L (rng), ab_ (rng), ab_ (rng) });
      random_multi.ref_class.push_back (k);
    }
  }
  random_multi.max_distance = 30.0;
  random_multi.model = InputModel::yuv (0.2126, 0.0722, false);
  check_table_exact ("8 classes x 1-4 random refs bt709", random_multi);
}

/* A palette without "references" gives the table it gave before they
 * existed: one reference per class, reference k being class k. */
static void
test_single_reference_table_unchanged ()
{
  const Palette & def = palette_default ();
  ClassifierConfig before, now;
  for (const auto & c : def.classes)
    before.refs.push_back (c.lab);
  palette_references (def, &now.refs, &now.ref_class);
  CHECK (now.refs.size () == def.classes.size (), "%zu references",
      now.refs.size ());
  for (size_t k = 0; k < now.ref_class.size (); k++)
    CHECK (now.ref_class[k] == (int) k, "reference %zu is class %d", k,
        now.ref_class[k]);
  ClassTable a, b;
  a.build (before, KeyOrder::C0_LOW);
  b.build (now, KeyOrder::C0_LOW);
  CHECK (memcmp (a.labels (), b.labels (), (size_t) 1 << 24) == 0,
      "tables differ");
  CHECK (a.boundary_cells () == b.boundary_cells (), "%zu vs %zu boundary "
      "cells", a.boundary_cells (), b.boundary_cells ());
}

static uint8_t
label_of_lab (ClassTable & table, const Lab & lab)
{
  double rgb[3];
  lab_to_srgb (lab, rgb);
  return table.resolve ((uint8_t) std::lround (rgb[0] * 255),
      (uint8_t) std::lround (rgb[1] * 255), (uint8_t) std::lround (rgb[2] * 255));
}

/* A ball lit and shaded: with both tones as references of "yellow", both
 * tones and a colour 40 % of the way from the shaded tone to red are
 * yellow; with the one mean colour the shaded tone and that colour are
 * not (they go to red). */
static void
test_two_tone_class ()
{
  const Lab lit { 88, -8, 80 }, shaded { 55, 4, 55 }, red { 45, 50, 40 };
  const Lab mean { (lit.L + shaded.L) / 2, (lit.a + shaded.a) / 2,
    (lit.b + shaded.b) / 2 };
  const Lab toward_red { shaded.L + 0.4 * (red.L - shaded.L),
    shaded.a + 0.4 * (red.a - shaded.a), shaded.b + 0.4 * (red.b - shaded.b) };
  ClassifierConfig two;
  two.refs = { red, lit, shaded, Lab { 53.58, 0, 0 } };
  two.ref_class = { 0, 1, 1, 2 };
  ClassifierConfig one;
  one.refs = { red, mean, Lab { 53.58, 0, 0 } };
  ClassTable t2, t1;
  t2.build (two, KeyOrder::C0_LOW);
  t1.build (one, KeyOrder::C0_LOW);
  CHECK (label_of_lab (t2, lit) == 2, "lit: %d", label_of_lab (t2, lit));
  CHECK (label_of_lab (t2, shaded) == 2, "shaded: %d",
      label_of_lab (t2, shaded));
  CHECK (label_of_lab (t2, toward_red) == 2, "toward red: %d",
      label_of_lab (t2, toward_red));
  CHECK (label_of_lab (t1, lit) == 2, "one reference, lit: %d",
      label_of_lab (t1, lit));
  CHECK (label_of_lab (t1, toward_red) == 1, "one reference, toward red: %d",
      label_of_lab (t1, toward_red));
  /* the class subset follows classes, not references */
  const uint8_t no_yellow[3] = { 1, 0, 1 };
  double rgb[3];
  lab_to_srgb (shaded, rgb);
  const uint8_t px[3] = { (uint8_t) std::lround (rgb[0] * 255),
    (uint8_t) std::lround (rgb[1] * 255), (uint8_t) std::lround (rgb[2] * 255) };
  uint8_t label = 255;
  t2.classify_exact (px, 1, no_yellow, &label);
  CHECK (label == 1 || label == 3, "without yellow, shaded is %d", label);
}

static void
test_subset_classification ()
{
  /* classify_exact over a subset equals the nearest among that subset */
  ClassifierConfig cfg;
  cfg.refs = { Lab { 50, 60, 40 }, Lab { 50, 0, 0 }, Lab { 90, 0, 0 } };
  ClassTable table;
  table.build (cfg, KeyOrder::C0_LOW);
  const uint8_t reddish[3] = { 200, 40, 40 };
  uint8_t label = 255;
  table.classify_exact (reddish, 1, nullptr, &label);
  CHECK (label == 1, "reddish is class 1, not %d", label);
  const uint8_t no_red[3] = { 0, 1, 1 };
  table.classify_exact (reddish, 1, no_red, &label);
  CHECK (label == 2, "without red, reddish goes to grey, not %d", label);
  const uint8_t none[3] = { 0, 0, 0 };
  table.classify_exact (reddish, 1, none, &label);
  CHECK (label == 0, "no class: 0, not %d", label);
}

static void
expect_palette_error (const char *json, const char *fragment)
{
  Palette p;
  std::string err;
  bool ok = palette_parse (json, "test.json", &p, &err);
  CHECK (!ok, "accepted %s", json);
  CHECK (err.find ("test.json") == 0 && err.find (fragment) != std::string::npos,
      "error \"%s\" lacks \"%s\"", err.c_str (), fragment);
}

static void
test_palette_parsing ()
{
  const Palette & def = palette_default ();
  CHECK (def.classes.size () == 7, "default has %zu classes",
      def.classes.size ());
  const char *markers[] = { "red", "green", "yellow", "pink", "blue" };
  for (int i = 0; i < 5; i++)
    CHECK (def.classes[i].name == markers[i] && def.classes[i].marker,
        "class %d is %s", i, def.classes[i].name.c_str ());
  CHECK (!def.classes[5].marker && !def.classes[6].marker,
      "white and grey are not markers");
  CHECK (def.classes[5].role == PaletteRole::Floor &&
      def.classes[6].role == PaletteRole::Floor, "white and grey are floor");

  Palette p;
  std::string err;
  CHECK (palette_parse ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 1, 2]},"
          " {\"name\": \"b\", \"lab\": [60, -3, 4.5], \"marker\": false}],"
          " \"description\": \"x\"}", "t", &p, &err), "%s", err.c_str ());
  CHECK (p.classes.size () == 2 && p.classes[0].marker && !p.classes[1].marker
      && p.classes[1].lab.b == 4.5, "parsed values");

  /* roles: "role" as written, the old flag read as before (true: marker,
   * false: background), both given only when they agree */
  CHECK (palette_parse ("{\"classes\": ["
          "{\"name\": \"m\", \"lab\": [50, 1, 2], \"role\": \"marker\"},"
          "{\"name\": \"f\", \"lab\": [50, 1, 2], \"role\": \"floor\"},"
          "{\"name\": \"w\", \"lab\": [50, 1, 2], \"role\": \"background\"},"
          "{\"name\": \"f2\", \"lab\": [50, 1, 2], \"role\": \"floor\","
          " \"marker\": false},"
          "{\"name\": \"old\", \"lab\": [50, 1, 2], \"marker\": false},"
          "{\"name\": \"old2\", \"lab\": [50, 1, 2], \"marker\": true},"
          "{\"name\": \"none\", \"lab\": [50, 1, 2]}]}", "t", &p, &err),
      "%s", err.c_str ());
  {
    const PaletteRole want[] = { PaletteRole::Marker, PaletteRole::Floor,
      PaletteRole::Background, PaletteRole::Floor, PaletteRole::Background,
      PaletteRole::Marker, PaletteRole::Marker };
    const bool want_marker[] = { true, false, false, false, false, true, true };
    for (int i = 0; i < 7; i++)
      CHECK (p.classes[i].role == want[i] &&
          p.classes[i].marker == want_marker[i], "class %s: role %s",
          p.classes[i].name.c_str (), palette_role_name (p.classes[i].role));
  }
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"role\": \"floor\", \"marker\": true}]}",
      "classes[0] (\"a\"): \"marker\": true contradicts \"role\": \"floor\"");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"role\": \"marker\", \"marker\": false}]}",
      "classes[0] (\"a\"): \"marker\": false contradicts \"role\": \"marker\"");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"role\": \"wall\"}]}",
      "\"role\" must be \"marker\", \"floor\" or \"background\"");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"role\": true}]}", "\"role\" must be");

  expect_palette_error ("{\"classes\": [", "not valid JSON");
  expect_palette_error ("[1, 2]", "top level");
  expect_palette_error ("{\"colours\": []}", "\"classes\" must be an array");
  expect_palette_error ("{\"classes\": []}", "empty");
  expect_palette_error ("{\"classes\": [{\"lab\": [1, 2, 3]}]}",
      "classes[0]: \"name\" must be a string");
  expect_palette_error ("{\"classes\": [{\"name\": \"a b\", \"lab\": [1,2,3]}]}",
      "\"name\" must be 1 to 32");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [1, 2]}]}",
      "classes[0] (\"a\"): \"lab\" must be an array of 3");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [1, true, 2]}]}",
      "\"lab\" must be an array of 3");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [120, 0, 0]}]}",
      "L* must be within 0..100");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, -200]}]}",
      "b* must be within -128..128");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"markr\": true}]}", "unknown key \"markr\"");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0],"
      " \"marker\": 1}]}", "\"marker\" must be true or false");
  expect_palette_error ("{\"classes\": [{\"name\": \"a\", \"lab\": [50, 0, 0]},"
      " {\"name\": \"a\", \"lab\": [40, 0, 0]}]}",
      "classes[1] (\"a\"): duplicate class name");
  std::string many = "{\"classes\": [";
  for (int i = 0; i < 65; i++)
    many += std::string (i ? "," : "") + "{\"name\": \"c" + std::to_string (i) +
        "\", \"lab\": [50, 0, 0]}";
  many += "]}";
  expect_palette_error (many.c_str (), "at most 64");

  /* references */
  CHECK (palette_parse ("{\"classes\": [{\"name\": \"y\", \"lab\": [70, 0, 60],"
          " \"references\": [[90, -10, 80], [50, 5, 50]]}]}", "t", &p, &err),
      "%s", err.c_str ());
  CHECK (p.classes[0].references.size () == 2 &&
      p.classes[0].references[1].L == 50 && p.classes[0].lab.L == 70,
      "parsed references");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [[50, \"0\", 0]]}]}",
      "classes[0] (\"y\"): \"references\"[0] must be an array of 3 finite");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [[50, 0, 0], [50, 0]]}]}",
      "classes[0] (\"y\"): \"references\"[1] must be an array of 3");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [[50, 0, 0], [50, 0, 130]]}]}",
      "classes[0] (\"y\"): \"references\"[1] b* must be within -128..128");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [[-1, 0, 0]]}]}",
      "\"references\"[0] L* must be within 0..100");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": []}]}",
      "classes[0] (\"y\"): \"references\" must hold 1 to 32 colours, got 0");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [50, 0, 0]}]}", "\"references\"[0] must be an array");
  expect_palette_error ("{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": {}}]}", "\"references\" must be an array of");
  std::string nine = "{\"classes\": [{\"name\": \"y\", \"lab\": [50, 0, 0],"
      " \"references\": [";
  for (int i = 0; i < 33; i++)
    nine += std::string (i ? "," : "") + "[50, 0, 0]";
  nine += "]}]}";
  expect_palette_error (nine.c_str (),
      "classes[0] (\"y\"): \"references\" must hold 1 to 32 colours, got 33");

  CHECK (!palette_load_file ("/nonexistent/palette.json", &p, &err) &&
      err.find ("/nonexistent/palette.json: cannot read") == 0, "%s",
      err.c_str ());
}

/* Map bounds: landmark count, coordinates and diameters (tests/fuzz). */
static void
test_map_bounds ()
{
  std::string many = "{\"landmarks\": [";
  for (unsigned i = 0; i <= kMaxMapLandmarks; i++)
    many += std::string (i ? "," : "") + "{\"id\": \"L" + std::to_string (i) +
        "\", \"class\": \"red\", \"x\": 0, \"y\": 0}";
  many += "]}";
  struct { std::string json, expect; } cases[] = {
    { many, "m.json: 257 landmarks; at most 256 are supported" },
    { "{\"landmarks\": [{\"id\": \"L1\", \"class\": \"red\", \"x\": 1e300, "
          "\"y\": 0}]}", "m.json: landmarks[0] (\"L1\"): \"x\" must be within "
          "-10000..10000 (metres), got 1e+300" },
    { "{\"landmarks\": [{\"id\": \"L1\", \"class\": \"red\", \"x\": 0, "
          "\"y\": 0, \"z\": -20000}]}", "m.json: landmarks[0] (\"L1\"): \"z\" "
          "must be within -10000..10000 (metres), got -20000" },
    { "{\"landmarks\": [{\"id\": \"L1\", \"class\": \"red\", \"x\": 0, "
          "\"y\": 0, \"diameter\": 500}]}", "m.json: landmarks[0] (\"L1\"): "
          "\"diameter\" must be at most 100 (metres), got 500" },
  };
  LandmarkMap map;
  std::string err;
  /* not a file: refused before reading */
  CHECK (!map_load_file ("/dev/zero", &map, &err) &&
      err == "/dev/zero: not a regular file", "%s", err.c_str ());
  for (const auto & c : cases) {
    err.clear ();
    CHECK (!map_parse (c.json, "m.json", &map, &err) && err == c.expect,
        "got \"%s\", expected \"%s\"", err.c_str (), c.expect.c_str ());
  }
}

/* Coded markers (docs/beacons.md): beacons, posts and cones read with their
 * bands, band heights and code; discs and balls beside them as before. */
static void
test_map_coded_markers ()
{
  const std::string good = "{\"landmarks\": ["
      "{\"id\": \"D1\", \"class\": \"red\", \"x\": 0, \"y\": 0, "
      "\"diameter\": 0.1},"
      "{\"id\": \"B1\", \"kind\": \"beacon\", \"x\": 1, \"y\": 2, "
      "\"diameter\": 0.1, \"height\": 0.3, \"bands\": [\"pink\", \"yellow\"]},"
      "{\"id\": \"B2\", \"kind\": \"beacon\", \"x\": 1, \"y\": -2, "
      "\"diameter\": 0.1, \"height\": 0.3, \"bands\": [\"yellow\", \"pink\"],"
      " \"band-heights\": [0.1, 0.2]},"
      "{\"id\": \"P1\", \"kind\": \"post\", \"x\": 3, \"y\": 0, \"z\": 0.05,"
      " \"diameter\": 0.04, \"height\": 1.0, \"bands\": [\"blue\"]},"
      "{\"id\": \"C1\", \"kind\": \"cone\", \"x\": 4, \"y\": 1, "
      "\"diameter\": 0.2, \"height\": 0.3, "
      "\"bands\": [\"yellow\", \"blue\", \"yellow\"]}]}";
  LandmarkMap map;
  std::string err;
  CHECK (map_parse (good, "m.json", &map, &err) && map.landmarks.size () == 5,
      "%s", err.c_str ());
  if (map.landmarks.size () == 5) {
    const MapLandmark & d = map.landmarks[0], &b1 = map.landmarks[1],
        &b2 = map.landmarks[2], &p = map.landmarks[3], &c = map.landmarks[4];
    CHECK (d.kind == MapKind::Disc && !d.coded () && d.class_name == "red"
        && d.code.empty (), "disc %s", d.class_name.c_str ());
    CHECK (b1.kind == MapKind::Beacon && b1.coded () && b1.code ==
        "pink/yellow" && b1.class_name == b1.code && b1.z == 0 &&
        b1.height == 0.3 && b1.band_heights.size () == 2 &&
        std::fabs (b1.band_heights[0] - 0.15) < 1e-12 &&
        std::fabs (b1.band_heights[1] - 0.15) < 1e-12, "beacon %s",
        b1.code.c_str ());
    CHECK (b2.code == "yellow/pink" && b2.band_heights[0] == 0.1 &&
        b2.band_heights[1] == 0.2, "band heights as given");
    CHECK (p.kind == MapKind::Post && p.code == "blue" && p.z == 0.05 &&
        p.band_heights.size () == 1 && p.band_heights[0] == 1.0, "post");
    CHECK (c.kind == MapKind::Cone && c.bands.size () == 3 &&
        c.code == "yellow/blue/yellow" && !c.ball, "cone %s", c.code.c_str ());
    const auto round = map_discs_and_balls (map);
    CHECK (round.size () == 1 && round[0].id == "D1", "%zu discs and balls",
        round.size ());
  }
  for (MapKind k : { MapKind::Disc, MapKind::Ball, MapKind::Beacon,
        MapKind::Post, MapKind::Cone })
    CHECK (map_kind_name (k) != nullptr, "kind %d", (int) k);

  /* one entry B1 with these members, after a beacon "pink/yellow" A1 */
  auto beacon = [](const std::string & members) {
    return "{\"landmarks\": [{\"id\": \"A1\", \"kind\": \"beacon\", \"x\": 0,"
        " \"y\": 0, \"diameter\": 0.1, \"height\": 0.2, \"bands\": [\"pink\","
        " \"yellow\"]}, {\"id\": \"B1\", \"x\": 1, \"y\": 1, " + members +
        "}]}";
  };
  const std::string at = "m.json: landmarks[1] (\"B1\"): ";
  struct { std::string json, expect; } cases[] = {
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"pink\"]"), at + "\"bands\" must hold 2 to 3 class "
          "names for a beacon, got 1" },
    { beacon ("\"kind\": \"post\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": []"), at + "\"bands\" must hold 1 to 3 class names for "
          "a post, got 0" },
    { beacon ("\"kind\": \"cone\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"a\", \"b\", \"c\", \"d\"]"), at + "\"bands\" must "
          "hold 1 to 3 class names for a cone, got 4" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2"),
      at + "\"bands\" must be an array of class names, top first" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": \"pink/yellow\""), at + "\"bands\" must be an array of "
          "class names, top first" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"pink\", \"a/b\"]"), at + "\"bands\"[1] must be a "
          "class name (1 to 32 of A-Z a-z 0-9 _ . -)" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"pink\", 3]"), at + "\"bands\"[1] must be a class "
          "name (1 to 32 of A-Z a-z 0-9 _ . -)" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"pink\", \"yellow\"]"), at + "\"bands\" give the "
          "code pink/yellow of landmark \"A1\" too: each coded marker needs "
          "a code of its own" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"yellow\", \"pink\"], \"band-heights\": [0.1]"),
      at + "\"band-heights\" must hold one positive number (metres) per "
          "band, 2 here, top first" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"yellow\", \"pink\"], \"band-heights\": [0.3, -0.1]"),
      at + "\"band-heights\" must hold one positive number (metres) per "
          "band, 2 here, top first" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": 0.1, \"height\": 0.2, "
          "\"bands\": [\"yellow\", \"pink\"], \"band-heights\": [0.1, 0.2]"),
      at + "\"band-heights\" must sum to \"height\" (0.2 m), got 0.3 m" },
    { beacon ("\"kind\": \"beacon\", \"height\": 0.2, "
          "\"bands\": [\"yellow\", \"pink\"]"), at + "\"diameter\" must be a "
          "positive number (metres)" },
    { beacon ("\"kind\": \"beacon\", \"diameter\": -0.1, \"height\": 0.2, "
          "\"bands\": [\"yellow\", \"pink\"]"), at + "\"diameter\" must be a "
          "positive number (metres)" },
    { beacon ("\"kind\": \"post\", \"diameter\": 0.05, \"height\": 0, "
          "\"bands\": [\"blue\"]"), at + "\"height\" must be a positive "
          "number (metres)" },
    { beacon ("\"kind\": \"post\", \"diameter\": 0.05, "
          "\"bands\": [\"blue\"]"), at + "\"height\" must be a positive "
          "number (metres)" },
    { beacon ("\"kind\": \"post\", \"diameter\": 0.05, \"height\": 500, "
          "\"bands\": [\"blue\"]"), at + "\"height\" must be at most 100 "
          "(metres), got 500" },
    { beacon ("\"kind\": \"post\", \"class\": \"blue\", \"diameter\": 0.05, "
          "\"height\": 1, \"bands\": [\"blue\"]"), at + "a post has no "
          "\"class\": its classes are its \"bands\"" },
    { beacon ("\"class\": \"red\", \"kind\": \"pyramid\""), at + "\"kind\" "
          "must be \"disc\" or \"ball\", or a coded marker's \"beacon\", "
          "\"post\" or \"cone\"" },
  };
  for (const auto & c : cases) {
    err.clear ();
    CHECK (!map_parse (c.json, "m.json", &map, &err) && err == c.expect,
        "got \"%s\", expected \"%s\"", err.c_str (), c.expect.c_str ());
  }
}

int
main ()
{
  test_lab_known_values ();
  test_lab_round_trip ();
  test_opencv_conversion_error ();
  test_yuv_model ();
  test_subset_classification ();
  test_palette_parsing ();
  test_map_bounds ();
  test_map_coded_markers ();
  test_single_reference_table_unchanged ();
  test_two_tone_class ();
  test_table_exact ();
  return corecheck_summary ();
}
