/* labsegment's labelling pass (labsegmentpixels.h): each pixel's class
 * through the class table, per layout, and the class histogram, in plain
 * C++, SSE2 and AVX2 (chosen at run time), in slices on workers. */
#include "labsegmentpixels.h"
#include "labsegmentreader.h"

#include <algorithm>
#include <cstring>

namespace landmark {

namespace {

#ifdef LANDMARK_HAVE_AVX2_PATH
/* The sum of the 32 bytes of acc. */
__attribute__ ((target ("avx2"))) inline guint64
sum_bytes_avx2 (__m256i acc)
{
  const __m256i s = _mm256_sad_epu8 (acc, _mm256_setzero_si256 ());
  return (guint64) _mm256_extract_epi64 (s, 0) +
      (guint64) _mm256_extract_epi64 (s, 1) +
      (guint64) _mm256_extract_epi64 (s, 2) +
      (guint64) _mm256_extract_epi64 (s, 3);
}

/* counts[values[i]] = pixels equal to values[i] in plane[0..end), end a
 * multiple of 32: up to 8 values per pass, one load per 32 labels
 * compared with each value (8-bit per-lane counters, summed before they
 * can overflow). Built for AVX2 whatever the compiler's target; called
 * only when the processor has it. */
__attribute__ ((target ("avx2"))) void
count_values_avx2 (const guint8 * plane, gsize end, const guint8 * values,
    guint nvalues, guint32 counts[256])
{
  for (guint first = 0; first < nvalues; first += 8) {
    const guint k = MIN (8u, nvalues - first);
    __m256i v[8];
    guint64 total[8] = { 0 };
    for (guint i = 0; i < k; i++)
      v[i] = _mm256_set1_epi8 ((char) values[first + i]);
    gsize pos = 0;
    while (pos < end) {
      const gsize stop = MIN (end, pos + 255 * 32);
      __m256i acc[8];
      for (guint i = 0; i < k; i++)
        acc[i] = _mm256_setzero_si256 ();
      for (; pos < stop; pos += 32) {
        const __m256i x = _mm256_loadu_si256 ((const __m256i *) (plane + pos));
        for (guint i = 0; i < k; i++)
          acc[i] = _mm256_sub_epi8 (acc[i], _mm256_cmpeq_epi8 (x, v[i]));
      }
      for (guint i = 0; i < k; i++)
        total[i] += sum_bytes_avx2 (acc[i]);
    }
    for (guint i = 0; i < k; i++)
      counts[values[first + i]] = (guint32) total[i];
  }
}
#endif

/* counts[v] = pixels of the plane with label v, for v in 1..n and
 * kPending (other entries are left 0). Compares of 32 labels at a time
 * (AVX2, up to 8 values per pass) or 16 (SSE2, one pass per value) beat a
 * scalar histogram on any palette up to 16 classes; larger palettes, and
 * LANDMARK_SIMD=none, use four interleaved scalar histograms. */
void
count_labels (const guint8 * plane, gsize size, guint n, SimdLevel simd,
    guint32 counts[256])
{
  memset (counts, 0, sizeof (guint32) * 256);
#ifdef __SSE2__
  if (simd != SimdLevel::NONE && n <= 16) {
    guint8 values[kMaxClasses + 2];
    for (guint k = 0; k < n; k++)
      values[k] = k + 1;
    values[n] = ClassTable::kPending;
#ifdef LANDMARK_HAVE_AVX2_PATH
    if (simd == SimdLevel::AVX2) {
      const gsize end = size & ~(gsize) 31;
      count_values_avx2 (plane, end, values, n + 1, counts);
      for (gsize j = end; j < size; j++)
        for (guint i = 0; i <= n; i++)
          counts[values[i]] += plane[j] == values[i];
      return;
    }
#endif
    const gsize vec_end = size & ~(gsize) 15;
    for (guint i = 0; i <= n; i++) {
      const __m128i v = _mm_set1_epi8 ((char) values[i]);
      guint64 total = 0;
      gsize pos = 0;
      while (pos < vec_end) {
        /* 8-bit per-lane counters, summed before they can overflow */
        const gsize stop = MIN (vec_end, pos + 255 * 16);
        __m128i acc = _mm_setzero_si128 ();
        for (; pos < stop; pos += 16) {
          const __m128i x = _mm_loadu_si128 ((const __m128i *) (plane + pos));
          acc = _mm_sub_epi8 (acc, _mm_cmpeq_epi8 (x, v));
        }
        const __m128i sums = _mm_sad_epu8 (acc, _mm_setzero_si128 ());
        total += (guint64) _mm_cvtsi128_si32 (sums) +
            (guint64) _mm_extract_epi16 (sums, 4);
      }
      for (gsize j = vec_end; j < size; j++)
        total += plane[j] == values[i];
      counts[values[i]] = (guint32) total;
    }
    return;
  }
#endif
  (void) n;
  (void) simd;
  guint32 bank[4][256] = { {0} };
  gsize j = 0;
  for (; j + 4 <= size; j += 4) {
    bank[0][plane[j]]++;
    bank[1][plane[j + 1]]++;
    bank[2][plane[j + 2]]++;
    bank[3][plane[j + 3]]++;
  }
  for (; j < size; j++)
    bank[0][plane[j]]++;
  for (int k = 0; k < 256; k++)
    counts[k] = bank[0][k] + bank[1][k] + bank[2][k] + bank[3][k];
}

/* The key of a packed RGB pixel is its three colour bytes as one
 * little-endian number: a 4-byte pixel needs one load, one shift and one
 * mask (the table is built in the format's own byte order). */
inline guint32
load32 (const guint8 * p)
{
  guint32 w;
  memcpy (&w, p, 4);
  return GUINT32_FROM_LE (w);
}

void
classify_packed4 (const guint8 * table, const guint8 * row, int shift,
    guint width, guint8 * labels)
{
  guint x = 0;
  /* four pixels a step: two 8-byte loads and one 4-byte store in place of
   * four loads and four stores; the loop is bound by memory operations,
   * not by cache misses (docs/performance.md) */
  for (; x + 4 <= width; x += 4) {
    guint64 a, b;
    memcpy (&a, row + x * 4, 8);
    memcpy (&b, row + x * 4 + 8, 8);
    a = GUINT64_FROM_LE (a);
    b = GUINT64_FROM_LE (b);
    guint32 four = table[(a >> shift) & 0xffffff] |
        (table[(a >> (32 + shift)) & 0xffffff] << 8) |
        (table[(b >> shift) & 0xffffff] << 16) |
        ((guint32) table[(b >> (32 + shift)) & 0xffffff] << 24);
    four = GUINT32_TO_LE (four);
    memcpy (labels + x, &four, 4);
  }
  for (; x < width; x++)
    labels[x] = table[(load32 (row + x * 4) >> shift) & 0xffffff];
}

#ifdef LANDMARK_HAVE_AVX2_PATH
/* The 24-bit table keys of pixels x..x+7 of the reader's row, one per
 * 32-bit lane in pixel order, for each layout the gathers handle. */
struct Packed4Keys {
  __m128i shift;
  __attribute__ ((target ("avx2"))) __m256i
  operator() (const PixelReader & r, guint x) const
  {
    const __m256i px = _mm256_loadu_si256 ((const __m256i *) (r.row0 + x * 4));
    return _mm256_and_si256 (_mm256_srl_epi32 (px, shift),
        _mm256_set1_epi32 (0xffffff));
  }
};

/* The same when the colour bytes come first (RGBx, BGRx): no shift. */
struct Packed4LowKeys {
  __attribute__ ((target ("avx2"))) __m256i
  operator() (const PixelReader & r, guint x) const
  {
    return _mm256_and_si256 (_mm256_loadu_si256 ((const __m256i *)
            (r.row0 + x * 4)), _mm256_set1_epi32 (0xffffff));
  }
};

/* 3-byte pixels: the 24 bytes of 8 pixels (a masked load: nothing is
 * read past them), bytes 12-27 moved to the high lane, then each pixel's
 * three bytes to its lane. */
struct Packed3Keys {
  __attribute__ ((target ("avx2"))) __m256i
  operator() (const PixelReader & r, guint x) const
  {
    const __m256i six = _mm256_setr_epi32 (-1, -1, -1, -1, -1, -1, 0, 0);
    const __m256i bytes = _mm256_permutevar8x32_epi32 (_mm256_maskload_epi32
        ((const int *) (r.row0 + x * 3), six),
        _mm256_setr_epi32 (0, 1, 2, 3, 3, 4, 5, 6));
    const __m256i pick = _mm256_setr_epi8 (0, 1, 2, -1, 3, 4, 5, -1,
        6, 7, 8, -1, 9, 10, 11, -1, 0, 1, 2, -1, 3, 4, 5, -1,
        6, 7, 8, -1, 9, 10, 11, -1);
    return _mm256_shuffle_epi8 (bytes, pick);
  }
};

/* Y | U << 8 | V << 16, a chroma pair for two pixels: the 4 pairs as
 * 16-bit U | V << 8 words (NV12 stores them so), each twice, widened. */
struct Yuv420Keys {
  __attribute__ ((target ("avx2"))) __m256i
  operator() (const PixelReader & r, guint x) const
  {
    __m128i uv;
    if (r.upstride == 2) {
      uv = _mm_loadl_epi64 ((const __m128i *) (r.row1 + x));
    } else {
      guint32 u, v;
      memcpy (&u, r.row1 + x / 2, 4);
      memcpy (&v, r.row2 + x / 2, 4);
      uv = _mm_unpacklo_epi8 (_mm_cvtsi32_si128 ((int) u),
          _mm_cvtsi32_si128 ((int) v));
    }
    const __m256i chroma = _mm256_cvtepu16_epi32 (_mm_unpacklo_epi16 (uv, uv));
    const __m256i y = _mm256_cvtepu8_epi32 (_mm_loadl_epi64 ((const __m128i *)
            (r.row0 + x)));
    return _mm256_or_si256 (y, _mm256_slli_epi32 (chroma, 8));
  }
};

/* Y0 U Y1 V words: one byte shuffle per 128-bit lane puts Y, U, V of
 * pixels 0-3 (bytes 0-7) and 4-7 (bytes 8-15) in their lanes. */
struct Yuy2Keys {
  __attribute__ ((target ("avx2"))) __m256i
  operator() (const PixelReader & r, guint x) const
  {
    const __m256i bytes = _mm256_broadcastsi128_si256 (_mm_loadu_si128
        ((const __m128i *) (r.row0 + x * 2)));
    const __m256i pick = _mm256_setr_epi8 (0, 1, 3, -1, 2, 1, 3, -1,
        4, 5, 7, -1, 6, 5, 7, -1, 8, 9, 11, -1, 10, 9, 11, -1,
        12, 13, 15, -1, 14, 13, 15, -1);
    return _mm256_shuffle_epi8 (bytes, pick);
  }
};

/* The labels of 8 keys, one per 32-bit lane: one gather reads 4 table
 * bytes at each key (at the last key 3 of them are the table's padding)
 * and the low byte is kept. */
__attribute__ ((target ("avx2"))) inline __m256i
gather8 (const guint8 * table, __m256i keys)
{
  return _mm256_and_si256 (_mm256_i32gather_epi32 ((const int *) table,
          keys, 1), _mm256_set1_epi32 (0xff));
}

/* Counts classes 1..7 of 32 labels a step in registers: each of four
 * byte shuffles turns a label into a one in the low nibble (class 2k + 1)
 * or the high nibble (class 2k + 2) of its byte, added to 8-bit counters
 * that hold 15 steps before they are split into nibbles and summed
 * (kPending and label 0 count nowhere: the shuffle gives 0 for them). */
struct NibbleCounts {
  __m256i lut[4], acc[4], sums[4];
  guint steps = 0;

  __attribute__ ((target ("avx2"))) explicit NibbleCounts (guint n)
  {
#pragma GCC unroll 4
    for (guint k = 0; k < 4; k++) {
      alignas (16) guint8 one[16] = { 0 };
      if (2 * k + 1 <= n)
        one[2 * k + 1] = 0x01;
      if (2 * k + 2 <= n)
        one[2 * k + 2] = 0x10;
      lut[k] = _mm256_broadcastsi128_si256 (_mm_load_si128 ((const __m128i *)
              one));
      acc[k] = sums[k] = _mm256_setzero_si256 ();
    }
  }

  __attribute__ ((target ("avx2"))) void add (__m256i labels)
  {
#pragma GCC unroll 4
    for (guint k = 0; k < 4; k++)
      acc[k] = _mm256_add_epi8 (acc[k], _mm256_shuffle_epi8 (lut[k], labels));
    if (++steps == 15)
      flush ();
  }

  /* each 64-bit lane of sums[k]: class 2k + 1 low, 2k + 2 high */
  __attribute__ ((target ("avx2"))) void flush ()
  {
    const __m256i low = _mm256_set1_epi8 (0x0f);
    const __m256i zero = _mm256_setzero_si256 ();
#pragma GCC unroll 4
    for (guint k = 0; k < 4; k++) {
      const __m256i lo = _mm256_sad_epu8 (_mm256_and_si256 (acc[k], low), zero);
      const __m256i hi = _mm256_sad_epu8 (_mm256_and_si256 (_mm256_srli_epi16
              (acc[k], 4), low), zero);
      sums[k] = _mm256_add_epi64 (sums[k], _mm256_add_epi64 (lo,
              _mm256_slli_epi64 (hi, 32)));
      acc[k] = zero;
    }
    steps = 0;
  }

  /* counts[1..n] += what was added */
  __attribute__ ((target ("avx2"))) void total (guint n, guint32 counts[256])
  {
    flush ();
    for (guint k = 0; k < 4; k++) {
      const guint64 both = (guint64) _mm256_extract_epi64 (sums[k], 0) +
          (guint64) _mm256_extract_epi64 (sums[k], 1) +
          (guint64) _mm256_extract_epi64 (sums[k], 2) +
          (guint64) _mm256_extract_epi64 (sums[k], 3);
      if (2 * k + 1 <= n)
        counts[2 * k + 1] += (guint32) both;
      if (2 * k + 2 <= n)
        counts[2 * k + 2] += (guint32) (both >> 32);
    }
  }
};

/* counts[v] of a slice's labels as count_labels gives it, from 32 labels
 * at a time as a loop writes them: up to 7 classes are counted as the
 * labels go by (NibbleCounts), in place of a second pass over the plane,
 * and a running maximum tells whether any kPending went by (they are
 * counted at the end, only then); larger palettes count at the end. */
struct FoldedCounts {
  NibbleCounts classes;
  __m256i largest;
  bool tail_pending = false;
  guint n;
  bool fold;

  __attribute__ ((target ("avx2"))) explicit FoldedCounts (guint classes_n)
      : classes (classes_n), largest (_mm256_setzero_si256 ()), n (classes_n),
      fold (classes_n <= 7) {}

  __attribute__ ((target ("avx2"))) void add (__m256i bytes)
  {
    if (!fold)
      return;
    classes.add (bytes);
    largest = _mm256_max_epu8 (largest, bytes);
  }

  /* add() for labels[0..32 * blocks), with the counters in locals
   * between flushes: as a loop of add() calls GCC tested fold and the
   * flush count every 32 labels and copied each counter once more (22
   * instructions against 13) */
  __attribute__ ((target ("avx2"))) void add_blocks (const guint8 * labels,
      guint blocks)
  {
    if (!fold)
      return;
    while (blocks > 0) {
      const guint run = MIN (blocks, 15 - classes.steps);
      __m256i a0 = classes.acc[0], a1 = classes.acc[1], a2 = classes.acc[2],
          a3 = classes.acc[3], most = largest;
      const guint8 *end = labels + 32 * run;
      for (; labels < end; labels += 32) {
        const __m256i v = _mm256_loadu_si256 ((const __m256i *) labels);
        a0 = _mm256_add_epi8 (a0, _mm256_shuffle_epi8 (classes.lut[0], v));
        a1 = _mm256_add_epi8 (a1, _mm256_shuffle_epi8 (classes.lut[1], v));
        a2 = _mm256_add_epi8 (a2, _mm256_shuffle_epi8 (classes.lut[2], v));
        a3 = _mm256_add_epi8 (a3, _mm256_shuffle_epi8 (classes.lut[3], v));
        most = _mm256_max_epu8 (most, v);
      }
      classes.acc[0] = a0;
      classes.acc[1] = a1;
      classes.acc[2] = a2;
      classes.acc[3] = a3;
      largest = most;
      classes.steps += run;
      if (classes.steps == 15)
        classes.flush ();
      blocks -= run;
    }
  }

  /* one label of a row end (under 32 labels) */
  void add_one (guint8 label, guint32 counts[256])
  {
    if (fold && label >= 1 && label <= n)
      counts[label]++;
    tail_pending |= label == ClassTable::kPending;
  }

  /* the slice's labels, first..first+size */
  __attribute__ ((target ("avx2"))) void total (const guint8 * first,
      gsize size, guint32 counts[256])
  {
    if (!fold) {
      count_labels (first, size, n, SimdLevel::AVX2, counts);
      return;
    }
    classes.total (n, counts);
    const __m256i pending = _mm256_set1_epi8 ((char) ClassTable::kPending);
    if (tail_pending || _mm256_movemask_epi8 (_mm256_cmpeq_epi8 (largest,
                pending)))
      counts[ClassTable::kPending] += (guint32) std::count (first,
          first + size, ClassTable::kPending);
  }
};

/* Pass 1 for rows y0..y1-1 of a slice with gathers, 32 pixels (four
 * gathers packed to 32 labels, one store) a step, and counts[v] as
 * count_labels gives it (FoldedCounts). The table holds kPending for cells
 * not computed yet, as the scalar loops read it: label_frame resolves
 * them. Row ends (under 32 pixels) go pixel by pixel. */
template <class Keys> __attribute__ ((target ("avx2"))) void
label_rows_avx2 (const ClassTable & table, PixelReader & reader, Keys keys,
    guint width, guint y0, guint y1, guint8 * labels, guint n,
    guint32 counts[256])
{
  const guint8 *t = table.labels ();
  /* packs work within 128-bit lanes: this puts the 8-byte groups back in
   * pixel order */
  const __m256i order = _mm256_setr_epi32 (0, 4, 1, 5, 2, 6, 3, 7);
  FoldedCounts folded (n);
  for (guint y = y0; y < y1; y++) {
    reader.set_row (y);
    guint8 *out = labels + (gsize) y * width;
    guint x = 0;
    for (; x + 32 <= width; x += 32) {
      const __m256i a = gather8 (t, keys (reader, x));
      const __m256i b = gather8 (t, keys (reader, x + 8));
      const __m256i c = gather8 (t, keys (reader, x + 16));
      const __m256i d = gather8 (t, keys (reader, x + 24));
      const __m256i bytes = _mm256_permutevar8x32_epi32 (_mm256_packus_epi16
          (_mm256_packus_epi32 (a, b), _mm256_packus_epi32 (c, d)), order);
      _mm256_storeu_si256 ((__m256i *) (out + x), bytes);
      folded.add (bytes);
    }
    for (; x < width; x++) {
      guint8 c[3] = { 0, 0, 0 };
      reader.get (x, c);
      out[x] = table.lookup (c[0], c[1], c[2]);
      folded.add_one (out[x], counts);
    }
  }
  folded.total (labels + (gsize) y0 * width, (gsize) (y1 - y0) * width,
      counts);
}

/* One label pair of label_row_packed4: the two keys of word w (the low
 * one by LOW into r?x, the high one into rsi), a zero-extending table load
 * for the low label and a load straight into the high byte of the same
 * register for the high one (no shift, no or), one 16-bit store. The high
 * byte registers (ah, bh) cannot be used with a REX prefix: the table
 * pointer is in rdi and the keys in rax/rbx and rsi. */
#define P4_PAIR(LOW, w, a, off) \
  LOW (w, r##a##x) \
  "bextr %[high], %[" #w "], %%rsi\n\t" \
  "movzbl (%%rdi,%%r" #a "x), %%e" #a "x\n\t" \
  "movb (%%rdi,%%rsi), %%" #a "h\n\t" \
  "movw %%" #a "x, " #off "(%[out],%[i])\n\t"
#define P4_LOW_BZHI(w, k) "bzhi %[low], %[" #w "], %%" #k "\n\t"
#define P4_LOW_BEXTR(w, k) "bextr %[low], %[" #w "], %%" #k "\n\t"
#define P4_WORDS(off) \
  "mov " #off "(%[row],%[i],4), %[w0]\n\t" \
  "mov " #off "+8(%[row],%[i],4), %[w1]\n\t"
#define P4_STEP(LOW) \
  "1:\n\t" \
  "prefetcht0 2560(%[row],%[i],4)\n\t" \
  P4_WORDS (0) P4_PAIR (LOW, w0, a, 0) P4_PAIR (LOW, w1, b, 2) \
  P4_WORDS (16) P4_PAIR (LOW, w0, a, 4) P4_PAIR (LOW, w1, b, 6) \
  P4_WORDS (32) P4_PAIR (LOW, w0, a, 8) P4_PAIR (LOW, w1, b, 10) \
  P4_WORDS (48) P4_PAIR (LOW, w0, a, 12) P4_PAIR (LOW, w1, b, 14) \
  "add $16, %[i]\n\t" \
  "jnz 1b\n\t"

/* The labels of a row's first 16 * steps 4-byte pixels, 16 a step: two
 * pixels an 8-byte load, each key one bit-field extract (BMI1/BMI2), one
 * table byte load a pixel, two labels a 16-bit store. 3.1 instructions a
 * pixel against 4.9 for the same loop in C (the label pairs joined by a
 * shift and an or, and GCC's loop counting): written in assembly because
 * no C form gets the compiler to load a label into a high byte register
 * (docs/performance.md has the variants measured). The frame is
 * prefetched 2,560 bytes (a 640-pixel row) ahead, one cache line a step
 * (a prefetch past the frame's end never faults): the hardware prefetcher
 * alone left the loop waiting on it. */
template <unsigned kShift> __attribute__ ((target ("avx2,bmi,bmi2"))) void
label_row_packed4 (const guint8 * table, const guint8 * row, guint8 * out,
    guint steps)
{
  if (steps == 0)
    return;
  /* counts up to 0: pixel i of the row is row[4 * i], label out[i] */
  gint64 i = -(gint64) steps * 16;
  const guint8 *row_end = row + (gsize) steps * 64;
  guint8 *out_end = out + (gsize) steps * 16;
  /* bextr controls: start bit | length << 8 */
  const guint64 low = kShift == 0 ? 24 : (kShift | (24 << 8));
  const guint64 high = (kShift + 32) | (24 << 8);
  guint64 w0, w1;
  if (kShift == 0)
    __asm__ volatile (P4_STEP (P4_LOW_BZHI)
        : [i] "+r" (i), [w0] "=&r" (w0), [w1] "=&r" (w1)
        : [row] "r" (row_end), [out] "r" (out_end), [low] "r" (low),
          [high] "r" (high), "D" (table)
        : "rax", "rbx", "rsi", "memory", "cc");
  else
    __asm__ volatile (P4_STEP (P4_LOW_BEXTR)
        : [i] "+r" (i), [w0] "=&r" (w0), [w1] "=&r" (w1)
        : [row] "r" (row_end), [out] "r" (out_end), [low] "r" (low),
          [high] "r" (high), "D" (table)
        : "rax", "rbx", "rsi", "memory", "cc");
}

/* Pass 1 for 4-byte pixels without gathers: the colour bytes at bit
 * kShift of each 4-byte pixel looked up 16 a step (label_row_packed4), the
 * row end pixel by pixel; then the row, still in L1, counted 32 labels at
 * a time (FoldedCounts). Faster than the gathers on the AMD EPYC measured
 * (docs/performance.md). */
template <unsigned kShift> __attribute__ ((target ("avx2,bmi,bmi2"))) void
label_rows_packed4 (const ClassTable & table, PixelReader & reader,
    guint width, guint y0, guint y1, guint8 * labels, guint n,
    guint32 counts[256])
{
  const guint8 *t = table.labels ();
  FoldedCounts folded (n);
  for (guint y = y0; y < y1; y++) {
    reader.set_row (y);
    const guint8 *row = reader.row0;
    guint8 *out = labels + (gsize) y * width;
    label_row_packed4<kShift> (t, row, out, width / 16);
    guint x = width & ~15u;
    for (; x < width; x++)
      out[x] = t[(load32 (row + x * 4) >> kShift) & 0xffffff];
    folded.add_blocks (out, width / 32);
    for (x = width & ~31u; x < width; x++)
      folded.add_one (out[x], counts);
  }
  folded.total (labels + (gsize) y0 * width, (gsize) (y1 - y0) * width,
      counts);
}

/* label_rows_avx2 with the layout's keys. */
void
label_rows_gather (const ClassTable & table, PixelReader & reader,
    guint width, guint y0, guint y1, guint8 * labels, guint n,
    guint32 counts[256])
{
  const auto label_with = [&] (auto keys) {
    label_rows_avx2 (table, reader, keys, width, y0, y1, labels, n, counts);
  };
  switch (reader.layout.layout) {
    case PixelLayout::PACKED4:
      if (reader.layout.key_shift == 0)
        label_with (Packed4LowKeys ());
      else
        label_with (Packed4Keys {
                _mm_cvtsi32_si128 (reader.layout.key_shift)});
      break;
    case PixelLayout::YUV420:
      label_with (Yuv420Keys ());
      break;
    case PixelLayout::YUY2:
      label_with (Yuy2Keys ());
      break;
    case PixelLayout::PACKED3:
      label_with (Packed3Keys ());
      break;
  }
}
#endif

void
classify_packed3 (const guint8 * table, const guint8 * row, guint width,
    guint8 * labels)
{
  for (guint x = 0; x < width; x++) {
    const guint8 *p = row + x * 3;
    labels[x] = table[p[0] | (p[1] << 8) | ((guint32) p[2] << 16)];
  }
}

#ifdef __SSE2__
/* The 4:2:0 lookups 16 pixels at a time: the keys Y | U << 8 | V << 16
 * are built by byte unpacking (each chroma byte twice) and stored, then
 * looked up one by one; building them pixel by pixel took half the time
 * of the loop. ps: 1 for planar chroma, 2 for NV12's interleaved UV (ur
 * then points at U, vr at V). Returns the pixels done (a multiple of 16). */
guint
classify_yuv420_sse2 (const guint8 * t, const guint8 * yr, const guint8 * ur,
    const guint8 * vr, int ps, guint width, guint8 * out)
{
  alignas (16) guint32 keys[16];
  const __m128i zero = _mm_setzero_si128 ();
  const __m128i low = _mm_set1_epi16 (0xff);
  guint x = 0;
  for (; x + 16 <= width; x += 16) {
    __m128i u, v;
    if (ps == 2) {
      /* U0 V0 U1 V1 ...: U from the low bytes of 16-bit lanes, V high */
      const __m128i uv = _mm_loadu_si128 ((const __m128i *) (ur + x));
      u = _mm_packus_epi16 (_mm_and_si128 (uv, low), zero);
      v = _mm_packus_epi16 (_mm_srli_epi16 (uv, 8), zero);
    } else {
      u = _mm_loadl_epi64 ((const __m128i *) (ur + x / 2));
      v = _mm_loadl_epi64 ((const __m128i *) (vr + x / 2));
    }
    u = _mm_unpacklo_epi8 (u, u);
    v = _mm_unpacklo_epi8 (v, v);
    const __m128i y = _mm_loadu_si128 ((const __m128i *) (yr + x));
    const __m128i yu0 = _mm_unpacklo_epi8 (y, u), yu1 = _mm_unpackhi_epi8 (y,
        u);
    const __m128i v0 = _mm_unpacklo_epi8 (v, zero), v1 =
        _mm_unpackhi_epi8 (v, zero);
    _mm_store_si128 ((__m128i *) keys, _mm_unpacklo_epi16 (yu0, v0));
    _mm_store_si128 ((__m128i *) (keys + 4), _mm_unpackhi_epi16 (yu0, v0));
    _mm_store_si128 ((__m128i *) (keys + 8), _mm_unpacklo_epi16 (yu1, v1));
    _mm_store_si128 ((__m128i *) (keys + 12), _mm_unpackhi_epi16 (yu1, v1));
    for (int i = 0; i < 16; i++)
      out[x + i] = t[keys[i]];
  }
  return x;
}

/* YUY2 the same way, 8 pixels (four Y0 U Y1 V words) at a time. */
guint
classify_yuy2_sse2 (const guint8 * t, const guint8 * row, guint width,
    guint8 * out)
{
  alignas (16) guint32 keys[8];
  const __m128i y_mask = _mm_set1_epi32 (0xff);
  const __m128i u_mask = _mm_set1_epi32 (0xff00);
  const __m128i v_mask = _mm_set1_epi32 (0xff0000);
  guint x = 0;
  for (; x + 8 <= width; x += 8) {
    const __m128i w = _mm_loadu_si128 ((const __m128i *) (row + x * 2));
    const __m128i uv = _mm_or_si128 (_mm_and_si128 (w, u_mask),
        _mm_and_si128 (_mm_srli_epi32 (w, 8), v_mask));
    const __m128i k0 = _mm_or_si128 (uv, _mm_and_si128 (w, y_mask));
    const __m128i k1 = _mm_or_si128 (uv, _mm_and_si128 (_mm_srli_epi32 (w,
                16), y_mask));
    _mm_store_si128 ((__m128i *) keys, _mm_unpacklo_epi32 (k0, k1));
    _mm_store_si128 ((__m128i *) (keys + 4), _mm_unpackhi_epi32 (k0, k1));
    for (int i = 0; i < 8; i++)
      out[x + i] = t[keys[i]];
  }
  return x;
}
#endif

/* Rows y0..y1-1; labels points at the plane's row 0. YUV keys are
 * Y | U << 8 | V << 16; two pixels share one chroma pair. */
void
classify_rows (const ClassTable & table, PixelReader & reader,
    guint width, guint y0, guint y1, guint8 * labels)
{
  const guint8 *t = table.labels ();
  const FrameLayout & layout = reader.layout;
  for (guint y = y0; y < y1; y++) {
    reader.set_row (y);
    guint8 *out = labels + (gsize) y * width;
    switch (layout.layout) {
      case PixelLayout::PACKED3:
        classify_packed3 (t, reader.row0, width, out);
        break;
      case PixelLayout::PACKED4:
        classify_packed4 (t, reader.row0, layout.key_shift, width, out);
        break;
      case PixelLayout::YUV420:{
        const guint8 *yr = reader.row0, *ur = reader.row1, *vr = reader.row2;
        const int ps = reader.upstride;
        guint x = 0;
#ifdef __SSE2__
        if (layout.simd != SimdLevel::NONE)
          x = classify_yuv420_sse2 (t, yr, ur, vr, ps, width, out);
#endif
        for (; x < width; x++) {
          const guint32 uv = (ur[(x >> 1) * ps] << 8) |
              ((guint32) vr[(x >> 1) * ps] << 16);
          out[x] = t[yr[x] | uv];
        }
        break;
      }
      case PixelLayout::YUY2:{
        const guint8 *r = reader.row0;
        guint x = 0;
#ifdef __SSE2__
        if (layout.simd != SimdLevel::NONE)
          x = classify_yuy2_sse2 (t, r, width, out);
#endif
        for (; x + 2 <= width; x += 2) {
          const guint32 w = load32 (r + x * 2);   /* Y0 U Y1 V */
          const guint32 uv = (w & 0xff00) | ((w >> 8) & 0xff0000);
          out[x] = t[(w & 0xff) | uv];
          out[x + 1] = t[((w >> 16) & 0xff) | uv];
        }
        if (x < width) {
          const guint8 *p = r + x * 2;
          out[x] = t[p[0] | (p[1] << 8) | ((guint32) p[3] << 16)];
        }
        break;
      }
    }
  }
}

}  // namespace

FrameLayout
frame_layout (const LandmarkFrameFormat & format)
{
  FrameLayout layout;
  switch (format.kind) {
    case LandmarkFrameFormat::Kind::PACKED:
      layout.layout = format.pixel_stride == 3 ? PixelLayout::PACKED3 :
          PixelLayout::PACKED4;
      for (int c = 0; c < 3; c++)
        layout.offset[c] = format.offset[c];
      /* G is always between R and B: the key is the three bytes from the
       * first of R and B, R low in RGB order and high in BGR order */
      layout.key_shift = 8 * MIN (layout.offset[0], layout.offset[2]);
      layout.order = layout.offset[0] < layout.offset[2] ?
          KeyOrder::C0_LOW : KeyOrder::C0_HIGH;
      break;
    case LandmarkFrameFormat::Kind::YUY2:
      layout.layout = PixelLayout::YUY2;
      break;
    default:
      layout.layout = PixelLayout::YUV420;
      break;
  }
  layout.simd = simd_level ();
  layout.packed4_gathers = packed4_gathers ();
  return layout;
}

void
label_frame (ClassTable & table, const GstVideoFrame * frame,
    const FrameLayout & layout, guint n, guint8 * labels, guint32 counts[256],
    PixelWorkers & workers)
{
  const guint w = GST_VIDEO_FRAME_WIDTH (frame);
  const guint h = GST_VIDEO_FRAME_HEIGHT (frame);
  PixelReader reader { frame, layout };
  /* the table is only read here: cells are filled below, on this thread */
  auto slice = [&](unsigned i, guint y0, guint y1) {
    PixelReader rows { frame, layout };
#ifdef LANDMARK_HAVE_AVX2_PATH
    if (layout.simd == SimdLevel::AVX2) {
      if (layout.layout == PixelLayout::PACKED4 && !layout.packed4_gathers)
        (layout.key_shift == 0 ? label_rows_packed4<0> :
            label_rows_packed4<8>) (table, rows, w, y0, y1, labels, n,
            workers.slice_counts[i].data ());
      else
        label_rows_gather (table, rows, w, y0, y1, labels, n,
            workers.slice_counts[i].data ());
      return;
    }
#endif
    classify_rows (table, rows, w, y0, y1, labels);
    count_labels (labels + (gsize) y0 * w, (gsize) (y1 - y0) * w, n,
        layout.simd,
        workers.slice_counts[i].data ());
  };
  const unsigned slices = workers.pool.slices ();
  for (unsigned i = 0; i < slices; i++)
    workers.slice_counts[i].fill (0);
  workers.pool.run_slices (h, slice);
  memset (counts, 0, sizeof (guint32) * 256);
  for (unsigned i = 0; i < slices; i++)
    for (int v = 0; v < 256; v++)
      counts[v] += workers.slice_counts[i][v];

  /* pixels in boundary cells not met before: fill those cells now */
  for (guint y = 0; y < h && counts[ClassTable::kPending] > 0; y++) {
    guint8 *row = labels + (gsize) y * w;
    if (!memchr (row, ClassTable::kPending, w))
      continue;
    reader.set_row (y);
    for (guint x = 0; x < w; x++) {
      if (row[x] != ClassTable::kPending)
        continue;
      guint8 c[3] = { 0, 0, 0 };
      reader.get (x, c);
      row[x] = table.resolve (c[0], c[1], c[2]);
      counts[row[x]]++;
      counts[ClassTable::kPending]--;
    }
  }
}

}  // namespace landmark
