/* The vector instructions the pixel loops use (labsegment's passes,
 * blobroundness's run search), one choice read from LANDMARK_SIMD:
 * labsegment has scalar, SSE2 and AVX2 loops; blobroundness's run search
 * has SSE2 and AVX2 ones, so "none" leaves it on SSE2. No GStreamer
 * types. */
#pragma once

/* Where the compiler can build an AVX2 loop beside the baseline one,
 * chosen at run time (__builtin_cpu_supports). */
/* x86-64 with 64-bit pointers (not the x32 ABI): labsegment's assembly
 * loop addresses through 64-bit registers */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__ILP32__)
#define LANDMARK_HAVE_AVX2_PATH 1
#endif

/* the intrinsics of the levels the build has */
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef LANDMARK_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

namespace landmark {

/* The best level the processor has, or less when LANDMARK_SIMD is "sse2"
 * or "none" (to compare the loops; every level gives identical results;
 * "avx2-gather" is the best level, see packed4_gathers). */
enum class SimdLevel { NONE, SSE2, AVX2 };
SimdLevel simd_level ();

/* At the AVX2 level, whether labsegment looks up 4-byte pixels with the
 * AVX2 gathers rather than scalar table loads (faster here): only when
 * the processor lacks BMI1 or BMI2, or LANDMARK_SIMD is "avx2-gather" (to
 * compare the two loops). */
bool packed4_gathers ();

}  // namespace landmark
