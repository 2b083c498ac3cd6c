/* The check macro and closing line of the core suites. Every CHECK counts;
 * a failed one prints where and why and the suite goes on. main() ends with
 * `return corecheck_summary ();`, whose "N passed, N failed" line is the
 * form scripts/count-tests.py reads for the test command's totals. */
#pragma once

#include <cstdio>
#include <string>

#include "camerageometry.h"

namespace corecheck {
inline int passed = 0;
inline int failures = 0;
}

#define CHECK(cond, ...) do { \
    if (cond) { \
      corecheck::passed++; \
    } else { \
      corecheck::failures++; \
      std::fprintf (stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
      std::fprintf (stderr, __VA_ARGS__); \
      std::fprintf (stderr, "\n"); \
    } \
  } while (0)

/* prints the closing line; the exit status of the suite */
static inline int
corecheck_summary ()
{
  std::printf ("%d passed, %d failed\n", corecheck::passed,
      corecheck::failures);
  return corecheck::failures ? 1 : 0;
}

/* The camera geometry of p; parameters it refuses are a failed check. */
static inline landmark::CameraGeometry
corecheck_camera (const landmark::CameraParams & p)
{
  landmark::CameraGeometry g;
  std::string err;
  CHECK (g.configure (p, &err), "camera: %s", err.c_str ());
  return g;
}
