#include "classtable.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace landmark {

namespace {

double
distance2 (const float *p, const Lab & r, bool use_lightness)
{
  const double dl = use_lightness ? p[0] - r.L : 0.0;
  const double da = p[1] - r.a, db = p[2] - r.b;
  return dl * dl + da * da + db * db;
}

double
lab_distance (const float *p, const float *q)
{
  const double dl = p[0] - q[0], da = p[1] - q[1], db = p[2] - q[2];
  return std::sqrt (dl * dl + da * da + db * db);
}

/* OpenCV's table-based conversion stays within this of the CIE formulas
 * (0.55 measured by the core test, which fails above this bound). */
constexpr double kConversionError = 0.75;

}  // namespace

uint8_t
ClassTable::nearest (const float *lab, const uint8_t * active) const
{
  /* strict '<' keeps the lowest index on ties, as numpy's argmin does */
  double best = std::numeric_limits<double>::infinity ();
  int best_k = -1;
  for (size_t k = 0; k < cfg_.refs.size (); k++) {
    if (active && !active[k])
      continue;
    const double d2 = distance2 (lab, cfg_.refs[k], cfg_.use_lightness);
    if (d2 < best) {
      best = d2;
      best_k = (int) k;
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
ClassTable::fill_block (size_t block, int b0, int b1, int b2)
{
  static_assert (kBatch >= 512, "one block per conversion");
  for (int u = 0; u < 8; u++)
    for (int v = 0; v < 8; v++)
      for (int w = 0; w < 8; w++) {
        float *c = comps_ + 3 * ((u << 6) | (v << 3) | w);
        c[0] = b0 + u;
        c[1] = b1 + v;
        c[2] = b2 + w;
      }
  converter_.convert (cfg_.model, comps_, 512, lab_);
  uint8_t *out = &fine_[block << 9];
  for (int i = 0; i < 512; i++)
    out[i] = nearest (lab_ + 3 * i, nullptr);
  fine_ready_[block] = 1;
  filled_++;
}

void
ClassTable::build (const ClassifierConfig & cfg)
{
  cfg_ = cfg;
  max_d2_ = cfg.max_distance * cfg.max_distance;
  coarse_.assign (32 * 32 * 32, 0);
  fine_ready_.clear ();
  filled_ = 0;

  /* L*a*b* at the cell corners 0, 8, ..., 256 of each component (cell i
   * covers [8i, 8i + 8)), shared between neighbouring cells, and at the
   * cell centres */
  const int n_grid = 33 * 33 * 33, n_cells = 32 * 32 * 32;
  std::vector<float> comps (3 * (n_grid + n_cells));
  float *g = comps.data (), *c = g + 3 * n_grid;
  for (int i = 0; i <= 32; i++)
    for (int j = 0; j <= 32; j++)
      for (int k = 0; k <= 32; k++, g += 3) {
        g[0] = i * 8;
        g[1] = j * 8;
        g[2] = k * 8;
      }
  for (int i = 0; i < 32; i++)
    for (int j = 0; j < 32; j++)
      for (int k = 0; k < 32; k++, c += 3) {
        c[0] = i * 8 + 4;
        c[1] = j * 8 + 4;
        c[2] = k * 8 + 4;
      }
  std::vector<float> lab (comps.size ());
  LabConverter converter;
  converter.convert (cfg.model, comps.data (), n_grid + n_cells, lab.data ());
  const float *grid = lab.data (), *centres = grid + 3 * n_grid;

  const size_t n = cfg.refs.size ();
  size_t blocks = 0;
  for (int i = 0; i < 32; i++) {
    for (int j = 0; j < 32; j++) {
      for (int k = 0; k < 32; k++) {
        const size_t cell = ((size_t) i << 10) | (j << 5) | k;
        const float *centre = centres + 3 * cell;
        /* How far L*a*b* moves inside the cell, from its corners: the
         * factor covers the curvature of the CIE curves between corners,
         * the margins OpenCV's approximation of them (the core test checks
         * every 8-bit colour against the direct computation). No distance
         * to a reference moves more than that. */
        double spread = 0;
        for (int corner = 0; corner < 8; corner++) {
          const int gi = ((i + (corner & 1)) * 33 + (j + ((corner >> 1) & 1)))
              * 33 + k + ((corner >> 2) & 1);
          spread = std::max (spread, lab_distance (grid + 3 * gi, centre));
        }
        const double radius = 1.5 * (spread + 2 * kConversionError) +
            2 * kConversionError;

        double d1 = std::numeric_limits<double>::infinity (), d2 = d1;
        int k1 = -1;
        for (size_t r = 0; r < n; r++) {
          const double dr = std::sqrt (distance2 (centre, cfg.refs[r],
                  cfg.use_lightness));
          if (dr < d1) {
            d2 = d1;
            d1 = dr;
            k1 = (int) r;
          } else if (dr < d2) {
            d2 = dr;
          }
        }
        if (k1 < 0 || d1 - radius > cfg.max_distance)
          coarse_[cell] = 0;  /* every colour of the cell is beyond reach */
        else if (d2 - d1 > 2.0 * radius && d1 + radius < cfg.max_distance)
          coarse_[cell] = (uint16_t) (k1 + 1);
        else
          coarse_[cell] = (uint16_t) (kFineBase + blocks++);
      }
    }
  }
  /* all the memory the lazy fills may need, now rather than per frame */
  fine_.assign (blocks * 512, 0);
  fine_ready_.assign (blocks, 0);
}

}  // namespace landmark
