#include "blobshape.h"
#include "simdlevel.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

namespace landmark {

namespace {

/* 8 neighbours, clockwise on screen (v grows downwards): E, SE, S, SW, W,
 * NW, N, NE. */
const int kDx[8] = { 1, 1, 0, -1, -1, -1, 0, 1 };
const int kDy[8] = { 0, 1, 1, 1, 0, -1, -1, -1 };

/* k mod n for 0 <= k < 2n: the closed contours' indices, without a
 * division per point */
inline int
wrap (int k, int n)
{
  return k < n ? k : k - n;
}

double
point_segment_distance2 (const cv::Point & p, const cv::Point & a,
    const cv::Point & b)
{
  const double abx = b.x - a.x, aby = b.y - a.y;
  const double apx = p.x - a.x, apy = p.y - a.y;
  const double len2 = abx * abx + aby * aby;
  if (len2 <= 0)
    return apx * apx + apy * apy;
  double t = (apx * abx + apy * aby) / len2;
  t = std::min (1.0, std::max (0.0, t));
  const double dx = apx - t * abx, dy = apy - t * aby;
  return dx * dx + dy * dy;
}

double
chain_length (const cv::Point * c, int n)
{
  if (n < 2)
    return 0;
  double len = 0;
  for (int i = 0; i < n; i++) {
    const cv::Point & a = c[i];
    const cv::Point & b = c[wrap (i + 1, n)];
    len += std::hypot ((double) (b.x - a.x), (double) (b.y - a.y));
  }
  return len;
}

/* Length of the closed contour after a 3-point moving average. */
double
smoothed_length (const cv::Point * c, int n)
{
  if (n < 3)
    return chain_length (c, n);
  auto at = [&](int i) {
    const cv::Point & a = c[wrap (i + n - 1, n)];
    const cv::Point & b = c[i];
    const cv::Point & d = c[wrap (i + 1, n)];
    return cv::Point2d ((a.x + b.x + d.x) / 3.0, (a.y + b.y + d.y) / 3.0);
  };
  const cv::Point2d first = at (0);
  cv::Point2d prev = first;
  double len = 0;
  for (int i = 1; i <= n; i++) {
    const cv::Point2d cur = i < n ? at (i) : first;
    len += std::hypot (cur.x - prev.x, cur.y - prev.y);
    prev = cur;
  }
  return len;
}

/* The line-fit polygon (see blobshape.h). Returns false when the contour
 * encloses no area or simplifies to fewer than three vertices. */
bool
fit_polygon (const cv::Point * c, int n, double eps, BlobLineFit & s,
    std::vector<cv::Point2d> & poly, double *perimeter)
{
  poly.clear ();
  if (n < 3)
    return false;

  /* orientation: positive shoelace sum = clockwise on screen */
  double area2 = 0;
  for (int i = 0; i < n; i++) {
    const cv::Point & a = c[i];
    const cv::Point & b = c[wrap (i + 1, n)];
    area2 += (double) a.x * b.y - (double) b.x * a.y;
  }
  if (std::fabs (area2) < 1e-9)
    return false;
  const double orient = area2 > 0 ? 1.0 : -1.0;

  /* Douglas-Peucker on the closed contour, split first at the point
   * farthest from point 0 */
  int far = 0;
  double far_d = -1;
  for (int i = 1; i < n; i++) {
    const double dx = c[i].x - c[0].x, dy = c[i].y - c[0].y;
    const double d = dx * dx + dy * dy;
    if (d > far_d) {
      far_d = d;
      far = i;
    }
  }
  if (far_d <= 0)
    return false;
  s.keep.assign (n, 0);
  s.keep[0] = s.keep[far] = 1;
  s.stack.clear ();
  s.stack.emplace_back (0, far);
  s.stack.emplace_back (far, n);
  const double eps2 = eps * eps;
  while (!s.stack.empty ()) {
    const auto [i, j] = s.stack.back ();
    s.stack.pop_back ();
    if (j - i < 2)
      continue;
    const cv::Point & a = c[wrap (i, n)];
    const cv::Point & b = c[wrap (j, n)];
    int best = -1;
    double best_d = eps2;
    for (int k = i + 1; k < j; k++) {
      const double d = point_segment_distance2 (c[wrap (k, n)], a, b);
      if (d > best_d) {
        best_d = d;
        best = k;
      }
    }
    if (best >= 0) {
      s.keep[wrap (best, n)] = 1;
      s.stack.emplace_back (i, best);
      s.stack.emplace_back (best, j);
    }
  }
  s.verts.clear ();
  for (int i = 0; i < n; i++)
    if (s.keep[i])
      s.verts.push_back (i);
  const int m = (int) s.verts.size ();
  if (m < 3)
    return false;

  /* a least-squares line per piece, moved out to where the region's edge
   * lies on average: the boundary-pixel centres sit 0..max(|nx|,|ny|)
   * inside it */
  s.lines.resize (m);
  for (int k = 0; k < m; k++) {
    const int i = s.verts[k];
    const int j = k + 1 < m ? s.verts[k + 1] : s.verts[0] + n;
    const int cnt = j - i + 1;
    double mx = 0, my = 0;
    for (int q = i; q <= j; q++) {
      mx += c[wrap (q, n)].x;
      my += c[wrap (q, n)].y;
    }
    mx /= cnt;
    my /= cnt;
    double sxx = 0, syy = 0, sxy = 0;
    for (int q = i; q <= j; q++) {
      const double dx = c[wrap (q, n)].x - mx, dy = c[wrap (q, n)].y - my;
      sxx += dx * dx;
      syy += dy * dy;
      sxy += dx * dy;
    }
    const double theta = 0.5 * std::atan2 (2 * sxy, sxx - syy);
    cv::Point2d t (std::cos (theta), std::sin (theta));
    const cv::Point & end = c[wrap (j, n)];
    const double chx = end.x - c[i].x, chy = end.y - c[i].y;
    if (t.x * chx + t.y * chy < 0)
      t = -t;
    const cv::Point2d nrm = orient > 0 ? cv::Point2d (t.y, -t.x) :
        cv::Point2d (-t.y, t.x);
    const double delta = 0.5 * std::max (std::fabs (nrm.x), std::fabs (nrm.y));
    s.lines[k].p = cv::Point2d (mx, my) + delta * nrm;
    s.lines[k].t = t;
  }

  /* vertices: consecutive lines intersected, or bevelled (the contour
   * point projected on both) when they are nearly parallel or meet far
   * from it */
  const double max_shift = 2 * eps + 2;
  auto project = [](const cv::Point2d & v, const BlobLineFit::Line & l) {
    const cv::Point2d d = v - l.p;
    return l.p + (d.x * l.t.x + d.y * l.t.y) * l.t;
  };
  for (int k = 0; k < m; k++) {
    const BlobLineFit::Line & l1 = s.lines[(k + m - 1) % m];
    const BlobLineFit::Line & l2 = s.lines[k];
    const cv::Point2d v (c[s.verts[k]].x, c[s.verts[k]].y);
    const double cross = l1.t.x * l2.t.y - l1.t.y * l2.t.x;
    bool ok = false;
    if (std::fabs (cross) > 1e-6) {
      const cv::Point2d d = l2.p - l1.p;
      const double u = (d.x * l2.t.y - d.y * l2.t.x) / cross;
      const cv::Point2d x = l1.p + u * l1.t;
      if (std::hypot (x.x - v.x, x.y - v.y) <= max_shift) {
        poly.push_back (x);
        ok = true;
      }
    }
    if (!ok) {
      poly.push_back (project (v, l1));
      poly.push_back (project (v, l2));
    }
  }
  double len = 0;
  const int pn = (int) poly.size ();
  for (int k = 0; k < pn; k++) {
    const cv::Point2d d = poly[(k + 1) % pn] - poly[k];
    len += std::hypot (d.x, d.y);
  }
  *perimeter = len;
  return true;
}

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

/* ---- free functions ------------------------------------------------- */

double
blob_perimeter_tolerance (double minor_semi_axis)
{
  return std::min (1.5, std::max (0.7, 0.15 * minor_semi_axis));
}

double
blob_chain_length (const cv::Point * contour, int n)
{
  return chain_length (contour, n);
}

double
blob_smoothed_length (const cv::Point * contour, int n)
{
  return smoothed_length (contour, n);
}

double
blob_polygon_weight (double minor_semi_axis)
{
  return std::min (1.0, std::max (0.0, (minor_semi_axis - 7.0) / 4.0));
}

bool
blob_perimeter (const cv::Point * contour, int n, double eps,
    double *perimeter, std::vector<cv::Point2d> *polygon)
{
  BlobLineFit scratch;
  std::vector<cv::Point2d> local;
  std::vector<cv::Point2d> &poly = polygon ? *polygon : local;
  if (fit_polygon (contour, n, eps, scratch, poly, perimeter))
    return true;
  *perimeter = chain_length (contour, n) + 4.0;
  return false;
}

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

/* ---- measuring ------------------------------------------------------ */

void
BlobAnalyzer::trace (const Component & c)
{
  /* the component painted into a zeroed box with a 1-pixel margin */
  const int bw = c.x1 - c.x0 + 1, bh = c.y1 - c.y0 + 1;
  const int mw = bw + 2, mh = bh + 2;
  mask_.assign ((size_t) mw * mh, 0);
  for (int k = 0; k < c.count; k++) {
    const BlobRun & r = sorted_[c.first + k];
    memset (&mask_[(size_t) (r.y - c.y0 + 1) * mw + (r.x0 - c.x0 + 1)], 1,
        r.x1 - r.x0 + 1);
  }
  int off[8];
  for (int d = 0; d < 8; d++)
    off[d] = kDy[d] * mw + kDx[d];

  /* Moore-neighbour tracing of the outer boundary, clockwise on screen,
   * from the first pixel in raster order; stops on entering the start
   * pixel the way it was first left (Jacob's criterion) */
  const BlobRun & r0 = sorted_[c.first];
  const int start = (r0.y - c.y0 + 1) * mw + (r0.x0 - c.x0 + 1);
  contour_.clear ();
  int p = start, px = r0.x0, py = r0.y;
  int d = 0;                    /* as if entered moving east */
  int first_dir = -1;
  const size_t limit = 4 * (size_t) c.n + 16;
  while (contour_.size () <= limit) {
    /* search clockwise from the background pixel last looked at */
    const int from = (d + 6 - (d & 1)) % 8;
    int nd = -1;
    for (int k = 0; k < 8; k++) {
      const int dir = (from + k) % 8;
      if (mask_[p + off[dir]]) {
        nd = dir;
        break;
      }
    }
    if (nd < 0) {
      contour_.emplace_back (px, py);   /* a single pixel */
      break;
    }
    if (p == start) {
      if (first_dir < 0)
        first_dir = nd;
      else if (nd == first_dir)
        break;
    }
    contour_.emplace_back (px, py);
    p += off[nd];
    px += kDx[nd];
    py += kDy[nd];
    d = nd;
  }
}

void
BlobAnalyzer::measure (size_t index, BlobShape * out)
{
  const Component & c = comps_[index];
  BlobShape & b = *out;
  b = BlobShape ();
  b.slot = c.slot;
  b.area = c.n;
  b.bbox_x = c.x0;
  b.bbox_y = c.y0;
  b.bbox_w = c.x1 - c.x0 + 1;
  b.bbox_h = c.y1 - c.y0 + 1;
  b.touches_border = c.x0 == 0 || c.y0 == 0 || c.x1 == width_ - 1 ||
      c.y1 == height_ - 1;
  b.equivalent_diameter = std::sqrt (4 * c.n / M_PI);

  const double cx = c.sx / c.n, cy = c.sy / c.n;
  b.centroid_x = b.ellipse_x = cx;
  b.centroid_y = b.ellipse_y = cy;
  /* covariance of the union of pixel squares: of the centres, plus 1/12
   * for each square's own spread */
  const double mxx = c.sxx / c.n - cx * cx + 1.0 / 12;
  const double myy = c.syy / c.n - cy * cy + 1.0 / 12;
  const double mxy = c.sxy / c.n - cx * cy;
  const double half = 0.5 * (mxx + myy);
  const double root = std::sqrt (std::max (0.0,
          0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy));
  const double l1 = half + root;
  const double l2 = std::max (half - root, 1e-12);
  b.ellipse_major = 4 * std::sqrt (l1);
  b.ellipse_minor = 4 * std::sqrt (l2);
  b.ellipse_angle = 0.5 * std::atan2 (2 * mxy, mxx - myy);

  /* perimeter and roundness: the line-fit polygon, blended for small
   * blobs with the smoothed outline + pi */
  trace (c);
  const int nc = (int) contour_.size ();
  const double minor_semi = 2 * std::sqrt (l2);
  const double eps = blob_perimeter_tolerance (minor_semi);
  double perimeter = 0;
  b.has_polygon = fit_polygon (contour_.data (), nc, eps, fit_, polygon_,
      &perimeter);
  if (!b.has_polygon) {
    /* no area inside the outline (lines one pixel thick) */
    perimeter = chain_length (contour_.data (), nc) + 4;
    polygon_.clear ();
  } else {
    const double w = blob_polygon_weight (minor_semi);
    if (w < 1)
      perimeter = w * perimeter + (1 - w) *
          (smoothed_length (contour_.data (), nc) + M_PI);
  }
  b.perimeter = perimeter;
  b.roundness = perimeter > 0 ? 4 * M_PI * c.n / (perimeter * perimeter) : 0;

  /* ellipse-fit: intersection over union with the pixels whose centres
   * lie in the ellipse x^T (Sigma^-1 / 4) x <= 1, clipped to the frame */
  const double det = mxx * myy - mxy * mxy;
  b.ellipse_fit = ellipse_iou (c, cx, cy, myy / (4 * det), -mxy / (4 * det),
      mxx / (4 * det));

  /* A blob cut by the frame edge shows only part of its shape, and its
   * moments describe that part. An ellipse is also fitted to the outline
   * away from the edge (boundary-pixel centres, so each semi-axis gets
   * the half pixel to the region's edge back) and compared with the blob
   * inside the frame; the better of the two is the blob's ellipse. */
  if (b.touches_border) {
    edge_points_.clear ();
    for (const cv::Point & p : contour_)
      if (p.x > 0 && p.y > 0 && p.x < width_ - 1 && p.y < height_ - 1)
        edge_points_.emplace_back ((float) p.x, (float) p.y);
    if (edge_points_.size () >= 8) {
      const cv::RotatedRect r = cv::fitEllipseDirect (edge_points_);
      double A = 0.5 * std::max (r.size.width, r.size.height) + 0.5;
      double B = 0.5 * std::min (r.size.width, r.size.height) + 0.5;
      double ang = r.angle * M_PI / 180 +
          (r.size.width >= r.size.height ? 0 : M_PI / 2);
      ang = std::remainder (ang, M_PI);
      const double limit = 4.0 * (width_ + height_);
      if (std::isfinite (A) && std::isfinite (B) && std::isfinite (r.center.x)
          && std::isfinite (r.center.y) && B > 0.5 && A < limit &&
          std::fabs (r.center.x) < limit && std::fabs (r.center.y) < limit) {
        const double ux = std::cos (ang), uy = std::sin (ang);
        const double qxx = ux * ux / (A * A) + uy * uy / (B * B);
        const double qyy = uy * uy / (A * A) + ux * ux / (B * B);
        const double qxy = ux * uy * (1 / (A * A) - 1 / (B * B));
        const double fit = ellipse_iou (c, r.center.x, r.center.y, qxx, qxy,
            qyy);
        if (fit > b.ellipse_fit) {
          b.ellipse_x = r.center.x;
          b.ellipse_y = r.center.y;
          b.ellipse_major = 2 * A;
          b.ellipse_minor = 2 * B;
          b.ellipse_angle = ang;
          b.ellipse_fit = fit;
          b.ellipse_from_outline = true;
        }
      }
    }
  }
}

double
BlobAnalyzer::ellipse_iou (const Component & c, double cx, double cy,
    double qxx, double qxy, double qyy) const
{
  /* rows where the ellipse has points: |dy| <= 1 / sqrt (qyy - qxy^2/qxx) */
  const double hy = 1.0 / std::sqrt (std::max (1e-12, qyy - qxy * qxy / qxx));
  const int ya = std::max (0, (int) std::ceil (cy - hy));
  const int yb = std::min (height_ - 1, (int) std::floor (cy + hy));
  double inside = 0, both = 0;
  int rk = c.first;
  const int rend = c.first + c.count;
  for (int y = ya; y <= yb; y++) {
    const double dy = y - cy;
    const double disc = qxy * qxy * dy * dy - qxx * (qyy * dy * dy - 1);
    if (disc < 0)
      continue;
    const double sq = std::sqrt (disc);
    const double lo = cx + (-qxy * dy - sq) / qxx;
    const double hi = cx + (-qxy * dy + sq) / qxx;
    if (hi < 0 || lo > width_ - 1)
      continue;
    const int xa = std::max (0, (int) std::ceil (lo));
    const int xb = std::min (width_ - 1, (int) std::floor (hi));
    if (xa > xb)
      continue;
    inside += xb - xa + 1;
    while (rk < rend && sorted_[rk].y < y)
      rk++;
    for (int q = rk; q < rend && sorted_[q].y == y; q++) {
      const int a = std::max (xa, sorted_[q].x0);
      const int e = std::min (xb, sorted_[q].x1);
      if (a <= e)
        both += e - a + 1;
    }
  }
  const double uni = c.n + inside - both;
  return uni > 0 ? both / uni : 0;
}

std::vector<BlobShape>
blob_measure_mask (const cv::Mat & mask)
{
  BlobAnalyzer a;
  a.begin (mask.cols, mask.rows);
  a.add_mask_runs (mask, 0, 0, 1);
  a.label ();
  std::vector<BlobShape> out (a.count ());
  for (size_t i = 0; i < a.count (); i++)
    a.measure (i, &out[i]);
  return out;
}

}  // namespace landmark
