/* The linear light of a mapped frame's pixels (framelight.h). */
#include "framelight.h"

#include <algorithm>
#include <array>

#include "colourdrift.h"

namespace landmark {

namespace {

/* The model's components to sRGB as m[row] = (3 coefficients, offset):
 * the conversion is affine until it clips, so its differences at mid-grey
 * (unclipped in every model) give it exactly */
void
affine_srgb (const InputModel & model, double m[3][4])
{
  const double mid = 128;
  double at[3];
  model.to_srgb (mid, mid, mid, at);
  for (int k = 0; k < 3; k++) {
    double c[3] = {mid, mid, mid}, step[3];
    c[k] += 1;
    model.to_srgb (c[0], c[1], c[2], step);
    for (int r = 0; r < 3; r++)
      m[r][k] = step[r] - at[r];
  }
  for (int r = 0; r < 3; r++)
    m[r][3] = at[r] - mid * (m[r][0] + m[r][1] + m[r][2]);
}

/* sRGB in [0, 1] to linear light, as a table interpolated linearly
 * (within 4e-7 of the formula; std::pow per sample was most of a ball's
 * outline's cost) */
constexpr int kDecodeSteps = 1024;

double
srgb_decode (double e)
{
  static const std::array<double, kDecodeSteps + 2> table = [] {
    std::array<double, kDecodeSteps + 2> t;
    for (int i = 0; i <= kDecodeSteps; i++)
      t[i] = srgb_to_linear ((double) i / kDecodeSteps);
    t[kDecodeSteps + 1] = t[kDecodeSteps];
    return t;
  }();
  const double x = std::min (1.0, std::max (0.0, e)) * kDecodeSteps;
  const int i = (int) x;
  return table[i] + (x - i) * (table[i + 1] - table[i]);
}

}  // namespace

/* to_srgb, then byte_light where each sRGB component is one of the
 * format's, scaled: a byte's light by one table look-up, not the affine
 * map and the decoding per pixel. */
void
FrameLight::set_model (const InputModel & model)
{
  affine_srgb (model, to_srgb);
  by_byte = true;
  for (int r = 0; r < 3 && by_byte; r++) {
    int from = -1;
    for (int k = 0; k < 3; k++)
      if (to_srgb[r][k] != 0)
        from = from < 0 ? k : 3;
    by_byte = from >= 0 && from < 3;
    if (!by_byte)
      break;
    byte_of[r] = from;
    for (int v = 0; v < 256; v++)
      byte_light[r][v] = srgb_decode (to_srgb[r][from] * v + to_srgb[r][3]);
  }
}

void
FrameLight::read_planes (const GstVideoFrame * f)
{
  const GstVideoFormatInfo *finfo = f->info.finfo;
  for (int c = 0; c < 3; c++)
    planes[c] = {(const guint8 *) GST_VIDEO_FRAME_COMP_DATA (f, c),
      GST_VIDEO_FRAME_COMP_STRIDE (f, c), GST_VIDEO_FRAME_COMP_PSTRIDE (f, c),
      (int) GST_VIDEO_FORMAT_INFO_W_SUB (finfo, c),
      (int) GST_VIDEO_FORMAT_INFO_H_SUB (finfo, c),
      GST_VIDEO_FRAME_COMP_WIDTH (f, c), GST_VIDEO_FRAME_COMP_HEIGHT (f, c)};
}

bool
FrameLight::row_light (int x, int y, int n, double *rgb) const
{
  const Plane *p = planes;
  if (x < 0 || y < 0 || x + n > p[0].width || y >= p[0].height)
    return false;
  const guint8 *row[3];
  for (int c = 0; c < 3; c++)
    row[c] = p[c].data + (y >> p[c].hsub) * p[c].stride;
  if (by_byte) {
    for (int c = 0; c < 3; c++) {
      const Plane & q = p[byte_of[c]];
      const guint8 *from = row[byte_of[c]];
      for (int i = 0; i < n; i++)
        rgb[3 * i + c] = byte_light[c][from[((x + i) >> q.wsub)
                * q.pstride]];
    }
    return true;
  }
  for (int i = 0; i < n; i++) {
    double comp[3];
    for (int c = 0; c < 3; c++)
      comp[c] = row[c][((x + i) >> p[c].wsub) * p[c].pstride];
    for (int c = 0; c < 3; c++) {
      const double *m = to_srgb[c];
      rgb[3 * i + c] = srgb_decode (m[0] * comp[0] + m[1] * comp[1]
          + m[2] * comp[2] + m[3]);
    }
  }
  return true;
}

}  // namespace landmark
