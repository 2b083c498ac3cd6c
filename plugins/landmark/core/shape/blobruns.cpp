/* Blob runs and components (blobshape.h): the horizontal runs of
 * selected labels in a label plane (64 labels a step with AVX2, 16 with
 * SSE2), from masks and by slot, and their union into 8-connected
 * components with each one's moment sums. */
#include "blobshape.h"
#include "simdlevel.h"

#include <algorithm>
#include <cstring>
#include <utility>

namespace landmark {

namespace {

#ifdef __SSE2__
inline int
ctz32 (unsigned v)
{
  return __builtin_ctz (v);
}
#endif

/* First x >= from where row[x] != l, or w. */
inline int
run_end (const uint8_t * row, int from, int w, uint8_t l)
{
  int e = from;
#ifdef __SSE2__
  const __m128i vl = _mm_set1_epi8 ((char) l);
  while (e + 16 <= w) {
    const __m128i v = _mm_loadu_si128 ((const __m128i *) (row + e));
    const unsigned same =
        (unsigned) _mm_movemask_epi8 (_mm_cmpeq_epi8 (v, vl));
    if (same != 0xffffu)
      return e + ctz32 (~same & 0xffffu);
    e += 16;
  }
#endif
  while (e < w && row[e] == l)
    e++;
  return e;
}

/* Adds the run of pixels x..e-1 of row y to out, or extends the last run
 * when it ends at x with the same slot (two labels of one slot). */
inline void
add_run (std::vector<BlobRun> & out, int y, int x, int e, int slot)
{
  if (!out.empty () && out.back ().y == y && out.back ().x1 + 1 == x &&
      out.back ().slot == slot)
    out.back ().x1 = e - 1;
  else
    out.push_back ({y, x, e - 1, slot});
}

#ifdef LANDMARK_HAVE_AVX2_PATH
/* The run search 64 labels a step. Whether a label is selected is a
 * byte-shuffle table look-up, whatever the number of selected labels.
 * When they are all under 16 (palettes up to 15 classes): a saturating
 * add of 0x70 sets the top bit of every larger label (the shuffle gives 0
 * for those) and keeps the low nibble of the others, whose table entry
 * has its top bit set when selected. Otherwise byte lo[l & 15] of the
 * table has bit l >> 4 set when label l is selected (labels 0..127; the
 * caller checks that no larger one is), and a second shuffle turns the
 * high nibble into that bit (0 for 128..255). Built for AVX2 whatever the
 * compiler's target; called only when the processor has it. */
struct Avx2Selection {
  __m256i lo, bit, nibble;
  bool small = true;

  __attribute__ ((target ("avx2"))) explicit
  Avx2Selection (const uint8_t slot_of[256])
  {
    alignas (16) uint8_t t[16] = { 0 };
    for (int l = 16; l < 128; l++)
      small = small && !slot_of[l];
    for (int l = 0; l < 128; l++)
      if (slot_of[l])
        t[l & 15] |= small ? 0x80 : (uint8_t) (1u << (l >> 4));
    lo = _mm256_broadcastsi128_si256 (_mm_load_si128 ((const __m128i *) t));
    bit = _mm256_setr_epi8 (1, 2, 4, 8, 16, 32, 64, -128, 0, 0, 0, 0, 0, 0, 0,
        0, 1, 2, 4, 8, 16, 32, 64, -128, 0, 0, 0, 0, 0, 0, 0, 0);
    nibble = _mm256_set1_epi8 (0x0f);
  }

  /* bit i: label p[i] is selected, i in 0..31 */
  __attribute__ ((target ("avx2"))) uint32_t
  at (const uint8_t * p) const
  {
    const __m256i v = _mm256_loadu_si256 ((const __m256i *) p);
    if (small)
      return (uint32_t) _mm256_movemask_epi8 (_mm256_shuffle_epi8 (lo,
              _mm256_adds_epu8 (v, _mm256_set1_epi8 (0x70))));
    const __m256i rows = _mm256_shuffle_epi8 (lo, _mm256_and_si256 (v, nibble));
    const __m256i bits = _mm256_shuffle_epi8 (bit,
        _mm256_and_si256 (_mm256_srli_epi16 (v, 4), nibble));
    return ~(uint32_t) _mm256_movemask_epi8 (_mm256_cmpeq_epi8
        (_mm256_and_si256 (rows, bits), _mm256_setzero_si256 ()));
  }
};

/* bit i: p[i] != the label, i in 0..31. A struct rather than a lambda
 * capturing the vector: a lambda's call operator does not inherit the
 * AVX2 target, and clang refuses the vector argument without it. */
struct Avx2Differs {
  __m256i label;

  __attribute__ ((target ("avx2"))) uint32_t
  operator() (const uint8_t * p) const
  {
    return ~(uint32_t) _mm256_movemask_epi8 (_mm256_cmpeq_epi8
        (_mm256_loadu_si256 ((const __m256i *) p), label));
  }
};

/* The 32 bits of what (a look at 32 labels) for pixels x..x+31 of a row of
 * w >= 32 pixels: the last 32 pixels are read again for a row's end, and
 * only the pixels from x on are kept (bits past the end are 0). */
template <class Look> __attribute__ ((target ("avx2"))) inline uint32_t
look32 (const uint8_t * row, int x, int w, Look what)
{
  if (x + 32 <= w)
    return what (row + x);
  return what (row + w - 32) >> (x - (w - 32));
}

__attribute__ ((target ("avx2"))) void
find_runs_avx2 (const uint8_t * plane, size_t stride, int w, int y0, int y1,
    const uint8_t slot_of[256], std::vector<BlobRun> & out)
{
  const Avx2Selection sel (slot_of);
  auto selected = [&](const uint8_t * p) { return sel.at (p); };
  for (int y = y0; y < y1; y++) {
    const uint8_t *row = plane + (size_t) y * stride;
    int x = 0;
    while (x < w) {
      /* skip pixels whose label is not selected, 64 at a time */
      for (; x + 64 <= w; x += 64) {
        const uint64_t m = selected (row + x) |
            (uint64_t) selected (row + x + 32) << 32;
        if (m) {
          x += __builtin_ctzll (m);
          break;
        }
      }
      if (x >= w)
        break;
      const uint32_t m = look32 (row, x, w, selected);
      if (!m) {
        if (x + 32 >= w)
          break;
        x += 32;
        continue;
      }
      x += __builtin_ctz (m);
      /* the run of this label */
      const uint8_t l = row[x];
      const Avx2Differs other { _mm256_set1_epi8 ((char) l) };
      int e = x + 1;
      while (e < w) {
        const uint32_t d = look32 (row, e, w, other);
        if (d) {
          e += __builtin_ctz (d);
          break;
        }
        e = std::min (w, e + 32);
      }
      add_run (out, y, x, e, slot_of[l]);
      x = e;
    }
  }
}
#endif

}  // namespace

/* ---- runs ----------------------------------------------------------- */

bool
BlobAnalyzer::cpu_has_avx2 ()
{
#ifdef LANDMARK_HAVE_AVX2_PATH
  return __builtin_cpu_supports ("avx2");
#else
  return false;
#endif
}

void
BlobAnalyzer::begin (int width, int height)
{
  width_ = std::max (0, width);
  height_ = std::max (0, height);
  runs_.clear ();
  comps_.clear ();
}

void
BlobAnalyzer::find_runs (const uint8_t * plane, size_t stride, int width,
    int y0, int y1, const uint8_t slot_of[256], bool avx2,
    std::vector<BlobRun> & out)
{
  uint8_t sel[256];
  int nsel = 0;
  for (int l = 0; l < 256; l++)
    if (slot_of[l])
      sel[nsel++] = (uint8_t) l;
  if (nsel == 0 || width == 0)
    return;
#ifdef LANDMARK_HAVE_AVX2_PATH
  if (avx2 && width >= 32 && sel[nsel - 1] < 128) {
    find_runs_avx2 (plane, stride, width, y0, y1, slot_of, out);
    return;
  }
#else
  (void) avx2;
#endif
#ifdef __SSE2__
  /* up to 8 selected labels are compared 16 pixels at a time */
  const bool simd = nsel <= 8;
  __m128i vsel[8];
  for (int i = 0; i < nsel && i < 8; i++)
    vsel[i] = _mm_set1_epi8 ((char) sel[i]);
#endif
  const int w = width;
  for (int y = y0; y < y1; y++) {
    const uint8_t *row = plane + (size_t) y * stride;
    int x = 0;
    while (x < w) {
      /* skip pixels whose label is not selected */
#ifdef __SSE2__
      if (simd) {
        while (x + 16 <= w) {
          const __m128i v = _mm_loadu_si128 ((const __m128i *) (row + x));
          __m128i hit = _mm_cmpeq_epi8 (v, vsel[0]);
          for (int i = 1; i < nsel; i++)
            hit = _mm_or_si128 (hit, _mm_cmpeq_epi8 (v, vsel[i]));
          const unsigned bits = (unsigned) _mm_movemask_epi8 (hit);
          if (bits) {
            x += ctz32 (bits);
            break;
          }
          x += 16;
        }
      }
#endif
      while (x < w && !slot_of[row[x]])
        x++;
      if (x >= w)
        break;
      /* the run of this label */
      const uint8_t l = row[x];
      const int e = run_end (row, x + 1, w, l);
      add_run (out, y, x, e, slot_of[l]);
      x = e;
    }
  }
}

void
BlobAnalyzer::add_label_runs (const uint8_t * plane, size_t stride,
    const uint8_t slot_of[256])
{
  find_runs (plane, stride, width_, 0, height_, slot_of, avx2_, runs_);
}

void
BlobAnalyzer::add_label_runs (const uint8_t * plane, size_t stride,
    const uint8_t slot_of[256], WorkerPool & pool)
{
  if (pool.threads () == 1) {
    add_label_runs (plane, stride, slot_of);
    return;
  }
  /* each slice's runs keep their capacity from frame to frame */
  slice_runs_.resize (pool.slices ());
  for (auto &r : slice_runs_)
    r.clear ();
  auto slice = [&](unsigned i, unsigned y0, unsigned y1) {
    find_runs (plane, stride, width_, (int) y0, (int) y1, slot_of, avx2_,
        slice_runs_[i]);
  };
  pool.run_slices ((unsigned) height_, slice);
  for (const auto &r : slice_runs_)
    runs_.insert (runs_.end (), r.begin (), r.end ());
}

void
BlobAnalyzer::add_mask_runs (const cv::Mat & mask, int ox, int oy, int slot)
{
  CV_Assert (mask.type () == CV_8UC1);
  for (int r = 0; r < mask.rows; r++) {
    const int y = oy + r;
    if (y < 0 || y >= height_)
      continue;
    const uint8_t *row = mask.ptr<uint8_t> (r);
    int x = 0;
    while (x < mask.cols) {
      while (x < mask.cols && !row[x])
        x++;
      if (x >= mask.cols)
        break;
      int e = x + 1;
      while (e < mask.cols && row[e])
        e++;
      const int x0 = std::max (0, ox + x), x1 = std::min (width_ - 1,
          ox + e - 1);
      if (x0 <= x1)
        runs_.push_back ({y, x0, x1, slot});
      x = e;
    }
  }
}

void
BlobAnalyzer::remove_slot (int slot)
{
  runs_.erase (std::remove_if (runs_.begin (), runs_.end (),
          [slot](const BlobRun & r) { return r.slot == slot; }),
      runs_.end ());
}

cv::Rect
BlobAnalyzer::slot_bounds (int slot) const
{
  int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1;
  for (const BlobRun & r : runs_) {
    if (r.slot != slot)
      continue;
    x0 = std::min (x0, r.x0);
    x1 = std::max (x1, r.x1);
    y0 = std::min (y0, r.y);
    y1 = std::max (y1, r.y);
  }
  if (x1 < 0)
    return cv::Rect ();
  return cv::Rect (x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

void
BlobAnalyzer::paint_slot (int slot, cv::Mat & mask, int ox, int oy) const
{
  for (const BlobRun & r : runs_) {
    if (r.slot != slot)
      continue;
    const int row = r.y - oy;
    if (row < 0 || row >= mask.rows)
      continue;
    const int a = std::max (0, r.x0 - ox), b = std::min (mask.cols - 1,
        r.x1 - ox);
    if (a <= b)
      memset (mask.ptr<uint8_t> (row) + a, 255, b - a + 1);
  }
}

/* ---- labelling ------------------------------------------------------ */

void
BlobAnalyzer::label ()
{
  comps_.clear ();
  const int nr = (int) runs_.size ();
  if (nr == 0) {
    sorted_.clear ();
    return;
  }

  /* stable counting sort by slot: each slot's runs stay in raster order */
  offsets_.assign (257, 0);
  for (const BlobRun & r : runs_)
    offsets_[r.slot + 1]++;
  for (int s = 0; s < 256; s++)
    offsets_[s + 1] += offsets_[s];
  by_slot_.resize (nr);
  {
    /* offsets_[s] is now the start of slot s; use a copy as cursors */
    root_comp_.assign (offsets_.begin (), offsets_.end ());
    for (const BlobRun & r : runs_)
      by_slot_[root_comp_[r.slot]++] = r;
  }

  /* union-find over runs of consecutive rows of the same slot that touch
   * (8-connectivity: overlapping or diagonal neighbours) */
  parent_.resize (nr);
  for (int i = 0; i < nr; i++)
    parent_[i] = i;
  auto find = [this](int a) {
    while (parent_[a] != a) {
      parent_[a] = parent_[parent_[a]];
      a = parent_[a];
    }
    return a;
  };
  auto unite = [&](int a, int b) {
    a = find (a);
    b = find (b);
    if (a < b)
      parent_[b] = a;
    else if (b < a)
      parent_[a] = b;
  };
  int i = 0;
  while (i < nr) {
    const int slot = by_slot_[i].slot;
    int prev_b = i, prev_e = i;   /* runs of the previous row */
    int cur = i;
    while (cur < nr && by_slot_[cur].slot == slot) {
      const int y = by_slot_[cur].y;
      int cur_e = cur;
      while (cur_e < nr && by_slot_[cur_e].slot == slot &&
          by_slot_[cur_e].y == y)
        cur_e++;
      if (prev_e > prev_b && by_slot_[prev_b].y == y - 1) {
        int j = prev_b;
        for (int k = cur; k < cur_e; k++) {
          const BlobRun & r = by_slot_[k];
          while (j < prev_e && by_slot_[j].x1 < r.x0 - 1)
            j++;
          for (int q = j; q < prev_e && by_slot_[q].x0 <= r.x1 + 1; q++)
            unite (k, q);
        }
      }
      prev_b = cur;
      prev_e = cur_e;
      cur = cur_e;
    }
    i = cur;
  }

  /* components in order of their first run; moments from closed-form
   * sums over each run */
  comp_of_.resize (nr);
  root_comp_.assign (nr, -1);
  for (int k = 0; k < nr; k++) {
    const int root = find (k);
    int id = root_comp_[root];
    if (id < 0) {
      id = (int) comps_.size ();
      root_comp_[root] = id;
      const BlobRun & r = by_slot_[k];
      comps_.push_back ({r.slot, 0, 0, 0, 0, 0, 0, 0, 0,
            r.x0, r.y, r.x1, r.y});
    }
    comp_of_[k] = id;
    Component & c = comps_[id];
    const BlobRun & r = by_slot_[k];
    const double len = r.x1 - r.x0 + 1;
    const double x0 = r.x0, x1 = r.x1, y = r.y;
    /* sum of x and of x^2 over x0..x1 */
    const double sx = 0.5 * (x0 + x1) * len;
    auto s2 = [](double v) { return v * (v + 1) * (2 * v + 1) / 6.0; };
    const double sxx = s2 (x1) - s2 (x0 - 1);
    c.count++;
    c.n += len;
    c.sx += sx;
    c.sy += y * len;
    c.sxx += sxx;
    c.syy += y * y * len;
    c.sxy += y * sx;
    c.x0 = std::min (c.x0, r.x0);
    c.x1 = std::max (c.x1, r.x1);
    c.y1 = std::max (c.y1, r.y);
  }
  const int nc = (int) comps_.size ();
  int first = 0;
  for (int k = 0; k < nc; k++) {
    comps_[k].first = first;
    first += comps_[k].count;
  }
  sorted_.resize (nr);
  offsets_.resize (nc);
  for (int k = 0; k < nc; k++)
    offsets_[k] = comps_[k].first;
  for (int k = 0; k < nr; k++)
    sorted_[offsets_[comp_of_[k]]++] = by_slot_[k];
}

}  // namespace landmark
