/* The vector level of the pixel loops: see simdlevel.h. */
#include "simdlevel.h"

#include <cstdlib>
#include <cstring>

namespace landmark {

SimdLevel
simd_level ()
{
  SimdLevel best = SimdLevel::NONE;
#ifdef __SSE2__
  best = SimdLevel::SSE2;
#endif
#ifdef LANDMARK_HAVE_AVX2_PATH
  if (__builtin_cpu_supports ("avx2"))
    best = SimdLevel::AVX2;
#endif
  const char *want = std::getenv ("LANDMARK_SIMD");
  if (want && std::strcmp (want, "none") == 0)
    return SimdLevel::NONE;
  if (want && std::strcmp (want, "sse2") == 0 && best != SimdLevel::NONE)
    return SimdLevel::SSE2;
  return best;
}

bool
packed4_gathers ()
{
#ifdef LANDMARK_HAVE_AVX2_PATH
  const char *want = std::getenv ("LANDMARK_SIMD");
  return !__builtin_cpu_supports ("bmi") || !__builtin_cpu_supports ("bmi2")
      || (want && std::strcmp (want, "avx2-gather") == 0);
#else
  return true;
#endif
}

}  // namespace landmark
