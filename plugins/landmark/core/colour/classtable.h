/* Nearest-reference-colour classification of 8-bit pixels, through a lookup
 * table that is exact: for every input colour it returns what the direct
 * computation (OpenCV's float L*a*b* conversion, then the nearest
 * reference) returns. */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "labcolour.h"
#include "palette.h"

namespace landmark {

/* Labels are 1..kMaxClasses (palette.h); 0 means "no class within
 * max-distance". */

struct ClassifierConfig {
  /* Reference colours; a pixel takes the class of the nearest one. A class
   * may have several (a ball's lit and shaded sides). */
  std::vector<Lab> refs;
  /* Class index (label - 1) of each reference, in ascending order; empty:
   * reference k is class k. */
  std::vector<int> ref_class;
  /* Optional, one per reference (both or neither): reference r stands for
   * the segment from dark[r] to light[r], its colour under less and more
   * light (palette_shading_ends), and a pixel's distance to it is its
   * distance to that segment. A distance to a convex set moves no more
   * than the pixel does, so the table's bounds hold as for points. With
   * use_lightness false the points count, not the segments. */
  std::vector<Lab> dark, light;
  bool use_lightness = true;
  double max_distance = 1000.0;
  InputModel model;
};

/* Where each component sits in the 24-bit key of a pixel: the key is the
 * pixel's three bytes read as one little-endian number, so packed formats
 * need no shuffling. BGR-ordered memory (BGR, BGRx, BGRA, xBGR >> 8) puts
 * component 0 (R) in the high byte; RGB-ordered memory and our Y,U,V keys
 * put it in the low byte. */
enum class KeyOrder { C0_LOW, C0_HIGH };

/* A label for each of the 2^24 keys (16 MB). Built from 32x32x32 cells of
 * 8x8x8 colours: a cell whose colours all have one class, by a bound on how
 * far L*a*b* moves inside it, gets that label; a cell that straddles a
 * decision boundary is marked kPending and computed by the direct
 * computation the first time a pixel falls in it (a scene touches few of
 * them). A lookup is one load; callers resolve() the rare kPending. */
class ClassTable {
public:
  static constexpr uint8_t kPending = 255;

  /* Builds the table for all classes of cfg (about 70,000 L*a*b*
   * conversions and a 16 MB fill, a few milliseconds). Call on
   * configuration changes, never per frame. */
  void build (const ClassifierConfig & cfg, KeyOrder order);

  const ClassifierConfig & config () const { return cfg_; }
  KeyOrder order () const { return order_; }

  /* The label array, indexed by key; hot loops keep it in a local. It is
   * followed by kPadding zero bytes, so a gather may read 4 bytes at any
   * key and keep the low one. */
  const uint8_t *labels () const { return direct_.get (); }
  static constexpr size_t kPadding = 64;

  uint32_t key (uint8_t c0, uint8_t c1, uint8_t c2) const
  {
    return order_ == KeyOrder::C0_LOW ? c0 | (c1 << 8) | ((uint32_t) c2 << 16)
        : c2 | (c1 << 8) | ((uint32_t) c0 << 16);
  }

  /* Nearest class over all classes, or kPending. */
  uint8_t lookup (uint8_t c0, uint8_t c1, uint8_t c2) const
  {
    return direct_.get ()[key (c0, c1, c2)];
  }

  /* Nearest class over all classes, computing the pixel's cell if pending.
   * Never returns kPending. */
  uint8_t resolve (uint8_t c0, uint8_t c1, uint8_t c2);

  /* The direct computation for n pixels (3 components each), optionally
   * over a subset of classes (active[k] != 0 for label k + 1). */
  void classify_exact (const uint8_t * comps, int n, const uint8_t * active,
      uint8_t * labels);

  /* Cells of 8x8x8 colours that straddle a decision boundary, and how many
   * of them have been computed. */
  size_t boundary_cells () const { return boundary_cells_; }
  size_t filled_cells () const { return filled_; }

  /* Pixels classify_exact handles per conversion call. */
  static constexpr int kBatch = 512;

private:
  uint8_t nearest (const float *lab, const uint8_t * active) const;
  double ref_distance2 (double L, double a, double b, size_t ref) const;
  int class_of (size_t ref) const
  {
    return cfg_.ref_class.empty ()? (int) ref : cfg_.ref_class[ref];
  }

  ClassifierConfig cfg_;
  KeyOrder order_ = KeyOrder::C0_LOW;
  double max_d2_ = 0;
  /* 2^24 labels by key, in huge pages where the system offers them: a
   * frame's lookups spread over all 16 MB, and with 4 KB pages the TLB
   * misses cost more than the lookups */
  struct FreeTable {
    void operator() (uint8_t * p) const;
  };
  std::unique_ptr<uint8_t, FreeTable> direct_;
  std::vector<uint8_t> pending_;  /* 32x32x32 cells: still to compute */
  size_t boundary_cells_ = 0, filled_ = 0;

  LabConverter converter_;
  float comps_[3 * kBatch];
  float lab_[3 * kBatch];
};

}  // namespace landmark
