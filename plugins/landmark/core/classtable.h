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

namespace landmark {

/* Labels are 1..kMaxClasses; 0 means "no class within max-distance". */
constexpr int kMaxClasses = 64;

struct ClassifierConfig {
  /* Reference colours; a pixel takes the class of the nearest one. A class
   * may have several (a ball's lit and shaded sides). */
  std::vector<Lab> refs;
  /* Class index (label - 1) of each reference, in ascending order; empty:
   * reference k is class k. */
  std::vector<int> ref_class;
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

/* A label for each of the 2^24 keys, in two levels so that a frame's
 * lookups stay in cache. The coarse level has one byte for each of the
 * 32x32x32 cells of 8x8x8 colours (32 KB): a cell whose colours all have one
 * class, by a bound on how far L*a*b* moves inside it, holds that label; a
 * cell that straddles a decision boundary holds kFine, and its 512 labels sit
 * together in the fine level (512 bytes per boundary cell), computed by the
 * direct computation the first time a pixel falls in the cell (a scene
 * touches few of them; until then they read kPending). A lookup is one load,
 * two for a pixel in a boundary cell; callers resolve() the rare kPending. */
class ClassTable {
public:
  static constexpr uint8_t kPending = 255;
  /* coarse entry of a boundary cell: the label is in the fine level */
  static constexpr uint8_t kFine = 254;

  /* Builds the table for all classes of cfg (about 70,000 L*a*b*
   * conversions and a fill of the boundary cells, a few milliseconds). Call
   * on configuration changes, never per frame. */
  void build (const ClassifierConfig & cfg, KeyOrder order);

  const ClassifierConfig & config () const { return cfg_; }
  KeyOrder order () const { return order_; }

  uint32_t key (uint8_t c0, uint8_t c1, uint8_t c2) const
  {
    return order_ == KeyOrder::C0_LOW ? c0 | (c1 << 8) | ((uint32_t) c2 << 16)
        : c2 | (c1 << 8) | ((uint32_t) c0 << 16);
  }

  /* The cell of a key (the top 5 bits of each byte) and the key's place in
   * the cell's fine block (the low 3 bits of each byte). */
  static uint32_t cell_of_key (uint32_t key)
  {
    return ((key >> 3) & 0x1f) | ((key >> 6) & 0x3e0) | ((key >> 9) & 0x7c00);
  }
  static uint32_t offset_in_cell (uint32_t key)
  {
    return (key & 7) | ((key >> 5) & 0x38) | ((key >> 10) & 0x1c0);
  }

  /* What a hot loop keeps in locals: label (or kPending) by key. */
  struct View {
    const uint8_t *coarse;
    const uint16_t *slot;
    const uint8_t *fine;

    uint8_t operator() (uint32_t key) const
    {
      const uint32_t cell = cell_of_key (key);
      const uint8_t c = coarse[cell];
      if (__builtin_expect (c != kFine, 1))
        return c;
      return fine[((size_t) slot[cell] << 9) | offset_in_cell (key)];
    }
  };
  View view () const { return View { coarse_.data (), slot_.data (),
        fine_.data () }; }

  /* Nearest class over all classes, or kPending. */
  uint8_t lookup (uint8_t c0, uint8_t c1, uint8_t c2) const
  {
    return view () (key (c0, c1, c2));
  }

  /* Whether the colour's cell is a boundary cell (its label is read from
   * the fine level). */
  bool in_fine_level (uint8_t c0, uint8_t c1, uint8_t c2) const
  {
    return coarse_[cell_of_key (key (c0, c1, c2))] == kFine;
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
  int class_of (size_t ref) const
  {
    return cfg_.ref_class.empty ()? (int) ref : cfg_.ref_class[ref];
  }

  ClassifierConfig cfg_;
  KeyOrder order_ = KeyOrder::C0_LOW;
  double max_d2_ = 0;
  /* by cell_of_key: a label or kFine */
  std::vector<uint8_t> coarse_;
  /* by cell_of_key: the boundary cell's block in fine_ */
  std::vector<uint16_t> slot_;
  /* 512 labels per boundary cell, by offset_in_cell */
  std::vector<uint8_t> fine_;
  std::vector<uint8_t> pending_;  /* by cell_of_key: still to compute */
  size_t boundary_cells_ = 0, filled_ = 0;

  LabConverter converter_;
  float comps_[3 * kBatch];
  float lab_[3 * kBatch];
};

}  // namespace landmark
