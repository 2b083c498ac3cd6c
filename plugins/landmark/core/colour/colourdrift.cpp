#include "colourdrift.h"

#include <algorithm>
#include <cmath>

namespace landmark {

double
srgb_to_linear (double c)
{
  return c <= 0.04045 ? c / 12.92 : std::pow ((c + 0.055) / 1.055, 2.4);
}

double
linear_to_srgb (double c)
{
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow (c, 1 / 2.4) - 0.055;
}

Lab
lab_under_gains (const Lab & lab, const std::array<double, 3> & g)
{
  double rgb[3];
  lab_to_srgb (lab, rgb);
  for (int c = 0; c < 3; c++)
    rgb[c] = linear_to_srgb (std::clamp (srgb_to_linear (rgb[c]) * g[c], 0.0,
            1.0));
  return srgb_to_lab (rgb[0], rgb[1], rgb[2]);
}

void
ColourDrift::reset (const std::vector<Lab> & class_lab,
    const std::vector<bool> & single_reference)
{
  linear_.clear ();
  for (const Lab & lab : class_lab) {
    double rgb[3];
    lab_to_srgb (lab, rgb);
    linear_.push_back ({srgb_to_linear (rgb[0]), srgb_to_linear (rgb[1]),
            srgb_to_linear (rgb[2])});
  }
  use_ = single_reference;
  use_.resize (linear_.size (), false);
  log_gains_ = {0.0, 0.0, 0.0};
  gains_ = {1.0, 1.0, 1.0};
}

bool
ColourDrift::update (const ClassColourSums & frame)
{
  /* per channel: what the classes' pixels hold over what their colours
   * would, weighted by how many pixels each class has */
  double seen[3] = { 0, 0, 0 }, expected[3] = { 0, 0, 0 };
  const size_t n = std::min ({linear_.size (), frame.sum.size (),
          frame.count.size ()});
  for (size_t k = 0; k < n; k++) {
    if (!use_[k] || frame.count[k] < kMinSamples)
      continue;
    for (int c = 0; c < 3; c++) {
      seen[c] += frame.sum[k][c];
      expected[c] += frame.count[k] * linear_[k][c];
    }
  }
  double log_g[3];
  for (int c = 0; c < 3; c++) {
    /* a channel the classes hardly have (a palette of pure blues) says
     * nothing about its gain */
    if (!(expected[c] > 1e-6 && seen[c] > 1e-6))
      return false;
    log_g[c] = std::log (seen[c] / expected[c]);
  }
  /* the bounds, on exposure (the mean log gain) and on red and blue
   * against green */
  const double max_e = std::log (kMaxGain);
  const double max_b = std::log (1 + kMaxBalance);
  const double min_b = std::log (1 - kMaxBalance);
  const double e = std::clamp ((log_g[0] + log_g[1] + log_g[2]) / 3, -max_e,
      max_e);
  const double r = std::clamp (log_g[0] - log_g[1], min_b, max_b);
  const double b = std::clamp (log_g[2] - log_g[1], min_b, max_b);
  const double green = e - (r + b) / 3;
  const double target[3] = { green + r, green, green + b };
  for (int c = 0; c < 3; c++) {
    log_gains_[c] += kSmoothing * (target[c] - log_gains_[c]);
    gains_[c] = std::exp (log_gains_[c]);
  }
  return true;
}

}  // namespace landmark
