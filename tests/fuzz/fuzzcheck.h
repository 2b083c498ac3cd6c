/* Shared by the fuzz targets: an invariant that must hold for every input.
 * A broken one aborts, which libFuzzer records as a crash and the replay
 * tests (replay.cpp) as a failed test. */
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#define FUZZ_CHECK(cond, ...) do { \
    if (!(cond)) { \
      fprintf (stderr, "%s:%d: invariant broken: %s: ", __FILE__, __LINE__, \
          #cond); \
      fprintf (stderr, __VA_ARGS__); \
      fprintf (stderr, "\n"); \
      abort (); \
    } \
  } while (0)

/* What every JSON parser target checks: the bytes parsed as a file named
 * "fuzz.json" by parse (json, source, &out, &error). A refusal must name the
 * file and leave the entries empty; an acceptance must leave no error and
 * hold 1 to max_entries entries, then pass check (out). */
template <typename Out, typename Parse, typename Entries, typename Check>
static void
fuzz_parse_json (const uint8_t * data, size_t size, Parse parse,
    Entries Out::*entries, size_t max_entries, Check check)
{
  const std::string json ((const char *) data, size);
  Out out;
  std::string error;
  if (!parse (json, "fuzz.json", &out, &error)) {
    FUZZ_CHECK (error.rfind ("fuzz.json: ", 0) == 0, "error \"%s\"",
        error.c_str ());
    FUZZ_CHECK ((out.*entries).empty (), "output touched on failure");
    return;
  }
  FUZZ_CHECK (error.empty (), "error set on success: %s", error.c_str ());
  const size_t n = (out.*entries).size ();
  FUZZ_CHECK (n >= 1 && n <= max_entries, "%zu entries", n);
  check (out);
}

/* The libFuzzer entry of a JSON parser target (see fuzz_parse_json). */
#define FUZZ_JSON_TARGET(parse, entries, max_entries, check) \
  extern "C" int \
  LLVMFuzzerTestOneInput (const uint8_t * data, size_t size) \
  { \
    fuzz_parse_json (data, size, parse, entries, max_entries, check); \
    return 0; \
  }
