#include "labcolour.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

namespace landmark {

namespace {

/* OpenCV's sRGB->XYZ (D65) matrix and white point (color_lab.cpp). */
constexpr double kRgbToXyz[9] = {
  0.412453, 0.357580, 0.180423,
  0.212671, 0.715160, 0.072169,
  0.019334, 0.119193, 0.950227,
};
constexpr double kWhiteX = 0.950456, kWhiteZ = 1.088754;
constexpr double kLabThreshold = 0.008856;

double
srgb_to_linear (double v)
{
  return v <= 0.04045 ? v / 12.92 : std::pow ((v + 0.055) / 1.055, 2.4);
}

double
linear_to_srgb (double v)
{
  return v <= 0.0031308 ? v * 12.92 : 1.055 * std::pow (v, 1.0 / 2.4) - 0.055;
}

double
lab_f (double t)
{
  return t > kLabThreshold ? std::cbrt (t) : 7.787 * t + 16.0 / 116.0;
}

double
lab_f_inverse (double f)
{
  double t = f * f * f;
  return t > kLabThreshold ? t : (f - 16.0 / 116.0) / 7.787;
}

double
clamp01 (double v)
{
  return std::min (1.0, std::max (0.0, v));
}

}  // namespace

Lab
srgb_to_lab (double r, double g, double b)
{
  const double lr = srgb_to_linear (r), lg = srgb_to_linear (g),
      lb = srgb_to_linear (b);
  const double x = (kRgbToXyz[0] * lr + kRgbToXyz[1] * lg +
      kRgbToXyz[2] * lb) / kWhiteX;
  const double y = kRgbToXyz[3] * lr + kRgbToXyz[4] * lg + kRgbToXyz[5] * lb;
  const double z = (kRgbToXyz[6] * lr + kRgbToXyz[7] * lg +
      kRgbToXyz[8] * lb) / kWhiteZ;
  const double fx = lab_f (x), fy = lab_f (y), fz = lab_f (z);
  const double L = y > kLabThreshold ? 116.0 * fy - 16.0 : 903.3 * y;
  return Lab { L, 500.0 * (fx - fy), 200.0 * (fy - fz) };
}

void
lab_to_srgb (const Lab & lab, double rgb[3])
{
  const double fy = (lab.L + 16.0) / 116.0;
  const double y = lab.L > 903.3 * kLabThreshold ? fy * fy * fy : lab.L / 903.3;
  const double x = lab_f_inverse (fy + lab.a / 500.0) * kWhiteX;
  const double z = lab_f_inverse (fy - lab.b / 200.0) * kWhiteZ;
  /* inverse of kRgbToXyz */
  const double lr = 3.240479 * x - 1.53715 * y - 0.498535 * z;
  const double lg = -0.969256 * x + 1.875991 * y + 0.041556 * z;
  const double lb = 0.055648 * x - 0.204043 * y + 1.057311 * z;
  rgb[0] = clamp01 (linear_to_srgb (clamp01 (lr)));
  rgb[1] = clamp01 (linear_to_srgb (clamp01 (lg)));
  rgb[2] = clamp01 (linear_to_srgb (clamp01 (lb)));
}

InputModel
InputModel::rgb ()
{
  return InputModel ();
}

InputModel
InputModel::yuv (double kr, double kb, bool full_range)
{
  InputModel m;
  m.kind = Kind::YUV;
  m.kr = kr;
  m.kb = kb;
  if (full_range) {
    m.y_offset = 0;
    m.y_scale = 255;
    m.c_offset = 128;
    m.c_scale = 255;
  }
  return m;
}

void
InputModel::to_srgb (double c0, double c1, double c2, double rgb[3]) const
{
  if (kind == Kind::RGB) {
    rgb[0] = c0 / 255.0;
    rgb[1] = c1 / 255.0;
    rgb[2] = c2 / 255.0;
    return;
  }
  const double kg = 1.0 - kr - kb;
  const double y = (c0 - y_offset) / y_scale;
  const double cb = (c1 - c_offset) / c_scale;
  const double cr = (c2 - c_offset) / c_scale;
  rgb[0] = clamp01 (y + 2.0 * (1.0 - kr) * cr);
  rgb[1] = clamp01 (y - 2.0 * kb * (1.0 - kb) / kg * cb -
      2.0 * kr * (1.0 - kr) / kg * cr);
  rgb[2] = clamp01 (y + 2.0 * (1.0 - kb) * cb);
}

void
InputModel::from_srgb (const double rgb[3], uint8_t out[3]) const
{
  auto to8 = [](double v) {
    return (uint8_t) std::lround (std::min (255.0, std::max (0.0, v)));
  };
  if (kind == Kind::RGB) {
    for (int i = 0; i < 3; i++)
      out[i] = to8 (rgb[i] * 255.0);
    return;
  }
  const double y = kr * rgb[0] + (1.0 - kr - kb) * rgb[1] + kb * rgb[2];
  const double cb = (rgb[2] - y) / (2.0 * (1.0 - kb));
  const double cr = (rgb[0] - y) / (2.0 * (1.0 - kr));
  out[0] = to8 (y * y_scale + y_offset);
  out[1] = to8 (cb * c_scale + c_offset);
  out[2] = to8 (cr * c_scale + c_offset);
}

bool
InputModel::operator== (const InputModel & o) const
{
  return kind == o.kind && kr == o.kr && kb == o.kb &&
      y_offset == o.y_offset && y_scale == o.y_scale &&
      c_offset == o.c_offset && c_scale == o.c_scale;
}

Lab
input_to_lab_exact (const InputModel & model, double c0, double c1, double c2)
{
  double rgb[3];
  model.to_srgb (c0, c1, c2, rgb);
  return srgb_to_lab (rgb[0], rgb[1], rgb[2]);
}

void
LabConverter::convert (const InputModel & model, const float *comps, int n,
    float *lab)
{
  if (n <= 0)
    return;
  if (rgb_.cols < n) {
    rgb_.create (1, n, CV_32FC3);
    lab_.create (1, n, CV_32FC3);
  }
  float *rgb = rgb_.ptr<float> ();
  for (int i = 0; i < n; i++) {
    const float *c = comps + 3 * i;
    if (model.kind == InputModel::Kind::RGB) {
      /* as numpy's uint8.astype(float32) / 255.0 */
      for (int k = 0; k < 3; k++)
        rgb[3 * i + k] = c[k] / 255.0f;
    } else {
      double v[3];
      model.to_srgb (c[0], c[1], c[2], v);
      for (int k = 0; k < 3; k++)
        rgb[3 * i + k] = (float) v[k];
    }
  }
  /* column ranges of the scratch rows: headers only, no allocation */
  cv::Mat out = lab_.colRange (0, n);
  cv::cvtColor (rgb_.colRange (0, n), out, cv::COLOR_RGB2Lab);
  memcpy (lab, lab_.ptr<float> (), sizeof (float) * 3 * n);
}

}  // namespace landmark
