/* The check macro and closing line of the core suites. Every CHECK counts;
 * a failed one prints where and why and the suite goes on. main() ends with
 * `return corecheck_summary ();`, whose "N passed, N failed" line is the
 * form scripts/count-tests.py reads for the test command's totals. */
#pragma once

#include <cstdio>

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
