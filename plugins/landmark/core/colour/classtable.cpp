#include "classtable.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <stdexcept>

#ifdef __linux__
#include <sys/mman.h>
#endif
#include <limits>

namespace landmark {

namespace {

double
distance2 (const Lab & p, const Lab & r, bool use_lightness)
{
  const double dl = use_lightness ? p.L - r.L : 0.0;
  const double da = p.a - r.a, db = p.b - r.b;
  return dl * dl + da * da + db * db;
}

double
lab_distance (const Lab & p, const Lab & q)
{
  return std::sqrt (distance2 (p, q, true));
}

/* OpenCV's table-based conversion stays within this of the CIE formulas
 * (0.55 measured by the core test, which fails above this bound). */
constexpr double kConversionError = 0.75;

}  // namespace

double
ClassTable::ref_distance2 (double L, double a, double b, size_t r) const
{
  const Lab & ref = cfg_.refs[r];
  if (!cfg_.use_lightness) {
    const double da = a - ref.a, db = b - ref.b;
    return da * da + db * db;
  }
  if (cfg_.dark.empty ()) {
    const double dl = L - ref.L, da = a - ref.a, db = b - ref.b;
    return dl * dl + da * da + db * db;
  }
  /* the nearest point of the segment dark -> light */
  const Lab & p0 = cfg_.dark[r], &p1 = cfg_.light[r];
  const double ul = p1.L - p0.L, ua = p1.a - p0.a, ub = p1.b - p0.b;
  const double len2 = ul * ul + ua * ua + ub * ub;
  double t = len2 > 0 ? ((L - p0.L) * ul + (a - p0.a) * ua +
      (b - p0.b) * ub) / len2 : 0.0;
  t = std::clamp (t, 0.0, 1.0);
  const double dl = L - (p0.L + t * ul), da = a - (p0.a + t * ua),
      db = b - (p0.b + t * ub);
  return dl * dl + da * da + db * db;
}

uint8_t
ClassTable::nearest (const float *lab, const uint8_t * active) const
{
  /* strict '<' keeps the lowest index on ties, as numpy's argmin does;
   * references are in class order, so a tie goes to the lowest class */
  double best = std::numeric_limits<double>::infinity ();
  int best_k = -1;
  for (size_t r = 0; r < cfg_.refs.size (); r++) {
    const int k = class_of (r);
    if (active && !active[k])
      continue;
    const double d2 = ref_distance2 (lab[0], lab[1], lab[2], r);
    if (d2 < best) {
      best = d2;
      best_k = k;
    }
  }
  if (best_k < 0 || best > max_d2_)
    return 0;
  return (uint8_t) (best_k + 1);
}

void
ClassTable::classify_exact (const uint8_t * comps, int n,
    const uint8_t * active, uint8_t * labels)
{
  for (int start = 0; start < n; start += kBatch) {
    const int m = std::min (kBatch, n - start);
    for (int i = 0; i < 3 * m; i++)
      comps_[i] = comps[3 * start + i];
    converter_.convert (cfg_.model, comps_, m, lab_);
    for (int i = 0; i < m; i++)
      labels[start + i] = nearest (lab_ + 3 * i, active);
  }
}

void
ClassTable::build (const ClassifierConfig & cfg, KeyOrder order)
{
  if (!cfg.ref_class.empty () && cfg.ref_class.size () != cfg.refs.size ())
    throw std::invalid_argument ("ref_class must give one class per "
        "reference");
  for (size_t r = 0; r < cfg.ref_class.size (); r++) {
    if (cfg.ref_class[r] < 0 || cfg.ref_class[r] >= kMaxClasses ||
        (r > 0 && cfg.ref_class[r] < cfg.ref_class[r - 1]))
      throw std::invalid_argument ("ref_class must be ascending class "
          "indices below kMaxClasses");
  }
  if (cfg.dark.size () != cfg.light.size () ||
      (!cfg.dark.empty () && cfg.dark.size () != cfg.refs.size ()))
    throw std::invalid_argument ("dark and light must give one segment end "
        "per reference, or none");
  cfg_ = cfg;
  order_ = order;
  max_d2_ = cfg.max_distance * cfg.max_distance;
  const size_t n = cfg.refs.size ();
  std::vector<double> dist (n);
  std::vector<uint8_t> cell_label (32 * 32 * 32, 0);
  pending_.assign (32 * 32 * 32, 0);
  boundary_cells_ = 0;

  /* L*a*b* by the CIE formulas at the cell corners 0, 8, ..., 256 of each
   * component (cell i covers [8i, 8i + 8)), shared between neighbouring
   * cells */
  std::vector<Lab> grid (33 * 33 * 33);
  for (int i = 0; i <= 32; i++)
    for (int j = 0; j <= 32; j++)
      for (int k = 0; k <= 32; k++)
        grid[(i * 33 + j) * 33 + k] = input_to_lab_exact (cfg.model, i * 8,
            j * 8, k * 8);

  for (int i = 0; i < 32; i++) {
    for (int j = 0; j < 32; j++) {
      for (int k = 0; k < 32; k++) {
        const size_t cell = ((size_t) i << 10) | (j << 5) | k;
        const Lab centre = input_to_lab_exact (cfg.model, i * 8 + 4,
            j * 8 + 4, k * 8 + 4);
        /* Labels come from OpenCV's conversion g, within kConversionError
         * of the formulas f. For a colour p of the cell, |g(p) - f(centre)|
         * <= kConversionError + |f(p) - f(centre)|, and the latter is
         * bounded from the corners, with a factor for the curvature of the
         * curves between them (the core test checks every 8-bit colour
         * against the direct computation). No distance to a reference
         * moves more than that radius. */
        double spread = 0;
        for (int corner = 0; corner < 8; corner++) {
          const int gi = ((i + (corner & 1)) * 33 + (j + ((corner >> 1) & 1)))
              * 33 + k + ((corner >> 2) & 1);
          spread = std::max (spread, lab_distance (grid[gi], centre));
        }
        const double radius = 1.5 * spread + kConversionError + 1e-3;

        /* d1: the nearest reference (class k1); d2: the nearest reference
         * of any other class. Another reference of class k1 cannot change
         * a colour's class, so only d2 - d1 decides the cell. */
        double d1 = std::numeric_limits<double>::infinity (), d2 = d1;
        int k1 = -1;
        for (size_t r = 0; r < n; r++) {
          dist[r] = std::sqrt (ref_distance2 (centre.L, centre.a,
                  centre.b, r));
          if (dist[r] < d1) {
            d1 = dist[r];
            k1 = class_of (r);
          }
        }
        for (size_t r = 0; r < n; r++) {
          if (class_of (r) != k1 && dist[r] < d2)
            d2 = dist[r];
        }
        if (k1 < 0 || d1 - radius > cfg.max_distance) {
          cell_label[cell] = 0;  /* every colour of the cell is beyond reach */
        } else if (d2 - d1 > 2.0 * radius && d1 + radius < cfg.max_distance) {
          cell_label[cell] = (uint8_t) (k1 + 1);
        } else {
          cell_label[cell] = kPending;
          pending_[cell] = 1;
          boundary_cells_++;
        }
      }
    }
  }
  filled_ = 0;

  /* Fill the keys in memory order: each row of 256 keys (fixed high and
   * middle bytes) is 32 runs of 8 keys in one cell. */
  constexpr size_t kTableSize = (size_t) 1 << 24;
  if (!direct_) {
    void *p = nullptr;
    /* 2 MB aligned, so the table can sit in eight huge pages */
    if (posix_memalign (&p, (size_t) 2 << 20, kTableSize + kPadding) != 0)
      throw std::bad_alloc ();
#ifdef MADV_HUGEPAGE
    madvise (p, kTableSize, MADV_HUGEPAGE);
#endif
    memset ((uint8_t *) p + kTableSize, 0, kPadding);
    direct_.reset ((uint8_t *) p);
  }
  uint8_t *out = direct_.get ();
  for (int hi = 0; hi < 256; hi++) {
    for (int mid = 0; mid < 256; mid++) {
      for (int run = 0; run < 32; run++, out += 8) {
        /* the run's low-byte component is run * 8 .. run * 8 + 7 */
        const int c0 = order == KeyOrder::C0_LOW ? run : hi >> 3;
        const int c2 = order == KeyOrder::C0_LOW ? hi >> 3 : run;
        const uint8_t label = cell_label[(c0 << 10) | ((mid >> 3) << 5) | c2];
        memset (out, label, 8);
      }
    }
  }
}

void
ClassTable::FreeTable::operator() (uint8_t * p) const
{
  free (p);
}

uint8_t
ClassTable::resolve (uint8_t c0, uint8_t c1, uint8_t c2)
{
  const size_t cell = ((c0 >> 3) << 10) | ((c1 >> 3) << 5) | (c2 >> 3);
  if (pending_[cell]) {
    const int b0 = c0 & ~7, b1 = c1 & ~7, b2 = c2 & ~7;
    float *comp = comps_;
    for (int u = 0; u < 8; u++)
      for (int v = 0; v < 8; v++)
        for (int w = 0; w < 8; w++, comp += 3) {
          comp[0] = b0 + u;
          comp[1] = b1 + v;
          comp[2] = b2 + w;
        }
    static_assert (kBatch >= 512, "one cell per conversion");
    converter_.convert (cfg_.model, comps_, 512, lab_);
    int i = 0;
    for (int u = 0; u < 8; u++)
      for (int v = 0; v < 8; v++)
        for (int w = 0; w < 8; w++, i++)
          direct_.get ()[key (b0 + u, b1 + v, b2 + w)] = nearest (lab_ + 3 * i,
              nullptr);
    pending_[cell] = 0;
    filled_++;
  }
  return lookup (c0, c1, c2);
}

}  // namespace landmark
