/* Following a camera's exposure and white-balance drift: per-channel gains
 * in linear RGB that carry the palette's colours onto what the frames show,
 * estimated from the pixels each class is given, smoothed over frames and
 * bounded, and the references re-made with them (labsegment adapt=true). */
#pragma once

#include <array>
#include <vector>

#include "labcolour.h"

namespace landmark {

/* sRGB component in [0, 1] to linear light, and back (IEC 61966-2-1). */
double srgb_to_linear (double c);
double linear_to_srgb (double c);

/* A colour under channel gains g (linear RGB), clipped to the sRGB gamut. */
Lab lab_under_gains (const Lab & lab, const std::array<double, 3> & g);

/* What one frame's sampled pixels say, per class: the sum of their linear
 * RGB and how many there were. */
struct ClassColourSums {
  std::vector<std::array<double, 3>> sum;
  std::vector<unsigned> count;

  void reset (size_t classes) {
    sum.assign (classes, {0.0, 0.0, 0.0});
    count.assign (classes, 0);
  }
};

class ColourDrift {
public:
  /* Exposure within [1/kMaxGain, kMaxGain] (one stop each way), each of red
   * and blue within kMaxBalance of green's gain: more than a camera's auto
   * exposure and white balance leave; beyond, a scene has changed rather
   * than drifted. */
  static constexpr double kMaxGain = 2.0;
  static constexpr double kMaxBalance = 0.15;
  /* share of a frame's estimate taken in: about a third of a second at 30
   * frames per second, much faster than the drift and slow enough that one
   * frame's passing object does not move it */
  static constexpr double kSmoothing = 0.1;
  /* sampled pixels a class needs to count */
  static constexpr unsigned kMinSamples = 64;

  /* The palette's classes: its colour in linear RGB, and whether it is
   * estimated from (a class of one reference colour: a class of several,
   * a ball lit and shaded, has no single colour to compare with). */
  void reset (const std::vector<Lab> & class_lab,
      const std::vector<bool> & single_reference);

  /* Takes a frame's sums in; false when no class had enough pixels (the
   * gains stay). */
  bool update (const ClassColourSums & frame);

  const std::array<double, 3> & gains () const { return gains_; }

private:
  std::vector<std::array<double, 3>> linear_;
  std::vector<bool> use_;
  std::array<double, 3> log_gains_ {0.0, 0.0, 0.0};
  std::array<double, 3> gains_ {1.0, 1.0, 1.0};
};

}  // namespace landmark
