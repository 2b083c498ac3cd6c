/* CIE L*a*b* conversion and the input colour models labsegment reads. */
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace landmark {

struct Lab {
  double L, a, b;
};

/* sRGB (gamma-encoded, components in [0, 1]) to CIE L*a*b* (D65) by the
 * CIE formulas, with the constants of OpenCV's conversion. */
Lab srgb_to_lab (double r, double g, double b);

/* Inverse of srgb_to_lab, clipped to [0, 1]: display colours of classes. */
void lab_to_srgb (const Lab & lab, double rgb[3]);

/* How the three 8-bit components of an input pixel map to sRGB.
 * RGB: (R, G, B). YUV: (Y, U, V) with a Y'CbCr matrix and range. */
struct InputModel {
  enum class Kind { RGB, YUV };
  Kind kind = Kind::RGB;
  double kr = 0.299, kb = 0.114;        /* luma coefficients (BT.601) */
  double y_offset = 16, y_scale = 219;  /* limited range by default */
  double c_offset = 128, c_scale = 224;

  static InputModel rgb ();
  static InputModel yuv (double kr, double kb, bool full_range);

  /* components (may be fractional, for cell centres) to sRGB in [0, 1] */
  void to_srgb (double c0, double c1, double c2, double rgb[3]) const;
  /* sRGB in [0, 1] to the nearest 8-bit components (for drawing) */
  void from_srgb (const double rgb[3], uint8_t out[3]) const;

  bool operator== (const InputModel & o) const;
  bool operator!= (const InputModel & o) const { return !(*this == o); }
};

/* One pixel's components to L*a*b* by the CIE formulas, in double. */
Lab input_to_lab_exact (const InputModel & model, double c0, double c1,
    double c2);

/* Converts n pixels, given as 8-bit-scale components (3 floats each, may be
 * fractional), to L*a*b* (3 floats each) through sRGB float32 and OpenCV's
 * float conversion (cv::COLOR_RGB2Lab): bit for bit what the Python
 * reference computes. OpenCV approximates the CIE curves by tables (within
 * 0.75 Delta E). The caller's scratch matrices are reused, so steady-state
 * calls allocate nothing once they are large enough. */
class LabConverter {
public:
  void convert (const InputModel & model, const float *comps, int n,
      float *lab);

private:
  cv::Mat rgb_, lab_;
};

}  // namespace landmark
