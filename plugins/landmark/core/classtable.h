/* Nearest-reference-colour classification of 8-bit pixels, through a lookup
 * table that is exact: for every input colour it returns what the direct
 * computation (OpenCV's float L*a*b* conversion, then the nearest
 * reference) returns. */
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "labcolour.h"

namespace landmark {

/* Labels are 1..kMaxClasses; 0 means "no class within max-distance". */
constexpr int kMaxClasses = 64;

struct ClassifierConfig {
  std::vector<Lab> refs;
  bool use_lightness = true;
  double max_distance = 1000.0;
  InputModel model;
};

/* Two levels: 32x32x32 cells of 8x8x8 colours hold the label when the whole
 * cell has one; cells that straddle a decision boundary point to a block of
 * 512 exact labels, computed the first time a pixel falls in the cell (a
 * frame touches few of them), in memory reserved by build(). */
class ClassTable {
public:
  /* Builds the coarse table for all classes of cfg (about 70,000 L*a*b*
   * conversions); call on configuration changes, never per frame. */
  void build (const ClassifierConfig & cfg);

  const ClassifierConfig & config () const { return cfg_; }

  /* Nearest class over all classes for one pixel. */
  inline uint8_t lookup (uint8_t c0, uint8_t c1, uint8_t c2)
  {
    const uint16_t v = coarse_[((c0 >> 3) << 10) | ((c1 >> 3) << 5) | (c2 >> 3)];
    if (v < kFineBase)
      return (uint8_t) v;
    const size_t block = v - kFineBase;
    if (!fine_ready_[block])
      fill_block (block, c0 & ~7, c1 & ~7, c2 & ~7);
    return fine_[(block << 9) | ((c0 & 7) << 6) | ((c1 & 7) << 3) | (c2 & 7)];
  }

  /* The direct computation for n pixels (3 components each), optionally
   * over a subset of classes (active[k] != 0 for label k + 1). */
  void classify_exact (const uint8_t * comps, int n, const uint8_t * active,
      uint8_t * labels);

  /* Cells of 8x8x8 colours that straddle a decision boundary, and how many
   * of them have been filled so far. */
  size_t fine_cells () const { return fine_ready_.size (); }
  size_t fine_cells_filled () const { return filled_; }

  /* Pixels classify_exact handles per conversion call. */
  static constexpr int kBatch = 512;

private:
  static constexpr uint16_t kFineBase = 256;

  uint8_t nearest (const float *lab, const uint8_t * active) const;
  void fill_block (size_t block, int b0, int b1, int b2);

  ClassifierConfig cfg_;
  double max_d2_ = 0;
  std::vector<uint16_t> coarse_;  /* 32x32x32 cells: label, or fine block */
  std::vector<uint8_t> fine_;     /* 512 exact labels per boundary cell */
  std::vector<uint8_t> fine_ready_;
  size_t filled_ = 0;

  LabConverter converter_;
  float comps_[3 * kBatch];
  float lab_[3 * kBatch];
};

}  // namespace landmark
