#include "classtable.h"

#include <algorithm>
#include <cmath>
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

}  // namespace

bool
ClassifierConfig::operator== (const ClassifierConfig & o) const
{
  if (refs.size () != o.refs.size () || use_lightness != o.use_lightness ||
      max_distance != o.max_distance || model != o.model)
    return false;
  for (size_t i = 0; i < refs.size (); i++) {
    if (refs[i].L != o.refs[i].L || refs[i].a != o.refs[i].a ||
        refs[i].b != o.refs[i].b)
      return false;
  }
  return true;
}

uint8_t
ClassTable::nearest (const Lab & lab, const uint8_t * active) const
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

uint8_t
ClassTable::classify_exact (uint8_t c0, uint8_t c1, uint8_t c2,
    const uint8_t * active) const
{
  return nearest (input_to_lab (cfg_.model, c0, c1, c2), active);
}

void
ClassTable::fill_block (size_t block, int b0, int b1, int b2)
{
  uint8_t *out = &fine_[block << 9];
  for (int u = 0; u < 8; u++)
    for (int v = 0; v < 8; v++)
      for (int w = 0; w < 8; w++)
        out[(u << 6) | (v << 3) | w] = classify_exact (b0 + u, b1 + v, b2 + w);
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
   * covers [8i, 8i + 8)), shared between neighbouring cells */
  std::vector<Lab> grid (33 * 33 * 33);
  for (int i = 0; i <= 32; i++)
    for (int j = 0; j <= 32; j++)
      for (int k = 0; k <= 32; k++)
        grid[(i * 33 + j) * 33 + k] = input_to_lab (cfg.model, i * 8, j * 8,
            k * 8);

  const size_t n = cfg.refs.size ();
  size_t blocks = 0;
  for (int i = 0; i < 32; i++) {
    for (int j = 0; j < 32; j++) {
      for (int k = 0; k < 32; k++) {
        const Lab centre = input_to_lab (cfg.model, i * 8 + 4, j * 8 + 4,
            k * 8 + 4);
        /* How far L*a*b* moves inside the cell, from its corners; the
         * factor covers the curvature of the conversion between them
         * (the core test checks every 8-bit colour against the direct
         * computation). No distance to a reference moves more. */
        double radius = 0;
        for (int corner = 0; corner < 8; corner++) {
          const Lab & c = grid[((i + (corner & 1)) * 33 +
                  (j + ((corner >> 1) & 1))) * 33 + k + ((corner >> 2) & 1)];
          radius = std::max (radius, lab_distance (c, centre));
        }
        radius = radius * 1.5 + 1e-3;

        double d1 = std::numeric_limits<double>::infinity (), d2 = d1;
        int k1 = -1;
        for (size_t c = 0; c < n; c++) {
          const double dc = std::sqrt (distance2 (centre, cfg.refs[c],
                  cfg.use_lightness));
          if (dc < d1) {
            d2 = d1;
            d1 = dc;
            k1 = (int) c;
          } else if (dc < d2) {
            d2 = dc;
          }
        }
        const size_t cell = ((size_t) i << 10) | (j << 5) | k;
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
