/* Shared by the fuzz targets: an invariant that must hold for every input.
 * A broken one aborts, which libFuzzer records as a crash and the replay
 * tests (replay.cpp) as a failed test. */
#pragma once

#include <cstdio>
#include <cstdlib>

#define FUZZ_CHECK(cond, ...) do { \
    if (!(cond)) { \
      fprintf (stderr, "%s:%d: invariant broken: %s: ", __FILE__, __LINE__, \
          #cond); \
      fprintf (stderr, __VA_ARGS__); \
      fprintf (stderr, "\n"); \
      abort (); \
    } \
  } while (0)
