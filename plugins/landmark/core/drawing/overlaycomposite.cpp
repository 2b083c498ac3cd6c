/* Blending the canvas into the video frame in its own format (packed RGB,
 * I420, NV12, YUY2, 8-bit grey), only over the areas drawn. */
#include "overlaydraw.h"

#include <algorithm>
#include <cstring>

#include "overlayinternal.h"

namespace landmark {
namespace overlay {

/* ---- compositing ----------------------------------------------------- */

namespace {

/* dst * (1 - a) + premultiplied src, in 8 bits */
inline uint8_t
over8 (uint8_t dst, uint8_t src, int alpha)
{
  const int v = (dst * (255 - alpha) + 127) / 255 + src;
  return (uint8_t) std::min (v, 255);
}

/* RGB to Y'CbCr in fixed point: for a premultiplied colour C (0..255)
 * of coverage a (0..255) over a value v,
 *   255 v' = v (255 - a) + a offset + 255 k.C,
 * with 255 k.C computed as (K.C) >> 12. */
struct YuvCoefficients {
  int y[3], cb[3], cr[3], y_off, c_off;

  explicit YuvCoefficients (const InputModel & m) {
    const double kr = m.kr, kb = m.kb, kg = 1.0 - kr - kb;
    const double ys = m.y_scale / 255.0, cs = m.c_scale / 255.0;
    const double fy[3] = { ys * kr, ys * kg, ys * kb };
    const double fcb[3] = { cs * -kr / (2 * (1 - kb)),
      cs * -kg / (2 * (1 - kb)), cs * 0.5 };
    const double fcr[3] = { cs * 0.5, cs * -kg / (2 * (1 - kr)),
      cs * -kb / (2 * (1 - kr)) };
    for (int i = 0; i < 3; i++) {
      y[i] = (int) std::lround (fy[i] * 255 * 4096);
      cb[i] = (int) std::lround (fcb[i] * 255 * 4096);
      cr[i] = (int) std::lround (fcr[i] * 255 * 4096);
    }
    y_off = (int) std::lround (m.y_offset);
    c_off = (int) std::lround (m.c_offset);
  }

  static inline uint8_t clamp (int v) {
    return (uint8_t) std::min (255, std::max (0, v));
  }
  inline uint8_t luma (uint8_t v, const uint8_t * c) const {
    const int a = c[3];
    const int k = (y[0] * c[0] + y[1] * c[1] + y[2] * c[2] + 2048) >> 12;
    return clamp ((v * (255 - a) + a * y_off + k + 127) / 255);
  }
  /* n pixels: asum of their coverages, csum of their colours */
  inline uint8_t chroma (uint8_t v, const int *csum, int asum, int n,
      const int *kc) const {
    const int k = (kc[0] * csum[0] + kc[1] * csum[1] + kc[2] * csum[2] +
        2048) >> 12;
    const int den = 255 * n;
    const int num = v * (den - asum) + asum * c_off + k;
    return clamp ((num + (num >= 0 ? den / 2 : -den / 2)) / den);
  }
};

void
composite_packed (const cv::Mat & canvas, const cv::Rect & r,
    const Target & t)
{
  const int ps = t.pixel_stride;
  for (int y = r.y; y < r.y + r.height; y++) {
    const uint8_t *src = canvas.ptr<uint8_t> (y) + 4 * r.x;
    uint8_t *dst = t.data[0] + (size_t) y * t.stride[0] + (size_t) r.x * ps;
    for (int x = 0; x < r.width; x++, src += 4, dst += ps) {
      const int a = src[3];
      if (a == 0)
        continue;
      if (a == 255) {
        dst[t.offset[0]] = src[0];
        dst[t.offset[1]] = src[1];
        dst[t.offset[2]] = src[2];
      } else {
        dst[t.offset[0]] = over8 (dst[t.offset[0]], src[0], a);
        dst[t.offset[1]] = over8 (dst[t.offset[1]], src[1], a);
        dst[t.offset[2]] = over8 (dst[t.offset[2]], src[2], a);
      }
    }
  }
}

/* Adds a premultiplied canvas pixel to a chroma block's coverage and
 * colour sums; false for a transparent pixel (nothing to blend). */
inline bool
add_to_block (const uint8_t * c, int *asum, int csum[3])
{
  if (c[3] == 0)
    return false;
  *asum += c[3];
  csum[0] += c[0];
  csum[1] += c[1];
  csum[2] += c[2];
  return true;
}

/* I420 and NV12: luma per pixel, chroma per 2x2 block from the block's
 * mean coverage and mean premultiplied colour. */
void
composite_420 (const cv::Mat & canvas, const cv::Rect & r, const Target & t,
    const YuvCoefficients & k)
{
  const bool nv12 = t.kind == Target::Kind::NV12;
  for (int y = r.y; y < r.y + r.height; y += 2) {
    const int rows = std::min (2, t.height - y);
    const uint8_t *src[2] = { canvas.ptr<uint8_t> (y),
      canvas.ptr<uint8_t> (y + rows - 1)
    };
    uint8_t *yrow[2] = { t.data[0] + (size_t) y * t.stride[0],
      t.data[0] + (size_t) (y + rows - 1) * t.stride[0]
    };
    uint8_t *urow = t.data[1] + (size_t) (y / 2) * t.stride[1];
    uint8_t *vrow = nv12 ? urow + 1 : t.data[2] + (size_t) (y / 2) *
        t.stride[2];
    const int cstep = nv12 ? 2 : 1;
    for (int x = r.x; x < r.x + r.width; x += 2) {
      const int cols = std::min (2, t.width - x);
      int asum = 0;
      int csum[3] = { 0, 0, 0 };
      for (int j = 0; j < rows; j++) {
        for (int i = 0; i < cols; i++) {
          const uint8_t *c = src[j] + 4 * (x + i);
          if (!add_to_block (c, &asum, csum))
            continue;
          uint8_t *yp = yrow[j] + x + i;
          *yp = k.luma (*yp, c);
        }
      }
      if (asum == 0)
        continue;
      const int n = rows * cols;
      uint8_t *u = urow + (x / 2) * cstep, *v = vrow + (x / 2) * cstep;
      *u = k.chroma (*u, csum, asum, n, k.cb);
      *v = k.chroma (*v, csum, asum, n, k.cr);
    }
  }
}

/* YUY2 (Y0 U Y1 V): luma per pixel, chroma per horizontal pair. */
void
composite_yuy2 (const cv::Mat & canvas, const cv::Rect & r,
    const Target & t, const YuvCoefficients & k)
{
  for (int y = r.y; y < r.y + r.height; y++) {
    const uint8_t *src = canvas.ptr<uint8_t> (y);
    uint8_t *row = t.data[0] + (size_t) y * t.stride[0];
    for (int x = r.x; x < r.x + r.width; x += 2) {
      const int cols = std::min (2, t.width - x);
      uint8_t *mp = row + (x / 2) * 4;
      int asum = 0;
      int csum[3] = { 0, 0, 0 };
      for (int i = 0; i < cols; i++) {
        const uint8_t *c = src + 4 * (x + i);
        if (!add_to_block (c, &asum, csum))
          continue;
        mp[2 * i] = k.luma (mp[2 * i], c);
      }
      if (asum == 0)
        continue;
      mp[1] = k.chroma (mp[1], csum, asum, cols, k.cb);
      mp[3] = k.chroma (mp[3], csum, asum, cols, k.cr);
    }
  }
}

/* 8-bit grey: the luma of the colour (the target's model, e.g. full-range
 * BT.601) per pixel. */
void
composite_gray (const cv::Mat & canvas, const cv::Rect & r, const Target & t,
    const YuvCoefficients & k)
{
  for (int y = r.y; y < r.y + r.height; y++) {
    const uint8_t *src = canvas.ptr<uint8_t> (y) + 4 * r.x;
    uint8_t *dst = t.data[0] + (size_t) y * t.stride[0] + r.x;
    for (int x = 0; x < r.width; x++, src += 4, dst++)
      if (src[3])
        *dst = k.luma (*dst, src);
  }
}

}  // namespace

void
Renderer::composite (const Target & t)
{
  if (canvas_.empty () || rects_.empty ())
    return;
  const YuvCoefficients k (t.model);
  const int w = std::min (t.width, width_), h = std::min (t.height, height_);
  int ymin = h, ymax = 0;
  for (const cv::Rect & r : rects_) {
    ymin = std::min (ymin, r.y);
    ymax = std::max (ymax, r.y + r.height);
  }
  /* Blend the union of the drawn rectangles exactly once: row pair by row
   * pair (rectangles start on even rows and columns, so a 2x2 chroma
   * block is never split), the spans of the rectangles that cover it,
   * sorted and merged. */
  for (int y = ymin & ~1; y < std::min (ymax, h); y += 2) {
    spans_.clear ();
    for (const cv::Rect & r : rects_)
      if (r.y <= y && y < r.y + r.height)
        spans_.emplace_back (r.x, std::min (r.x + r.width, w));
    if (spans_.empty ())
      continue;
    std::sort (spans_.begin (), spans_.end ());
    const int rows = std::min (2, h - y);
    size_t i = 0;
    while (i < spans_.size ()) {
      const int x0 = spans_[i].first;
      int x1 = spans_[i].second;
      for (i++; i < spans_.size () && spans_[i].first <= x1; i++)
        x1 = std::max (x1, spans_[i].second);
      if (x1 <= x0)
        continue;
      const cv::Rect r (x0, y, x1 - x0, rows);
      switch (t.kind) {
        case Target::Kind::PACKED:
          composite_packed (canvas_, r, t);
          break;
        case Target::Kind::I420:
        case Target::Kind::NV12:
          composite_420 (canvas_, r, t, k);
          break;
        case Target::Kind::YUY2:
          composite_yuy2 (canvas_, r, t, k);
          break;
        case Target::Kind::GRAY:
          composite_gray (canvas_, r, t, k);
          break;
      }
    }
  }
  for (const cv::Rect & r : rects_)
    canvas_ (r).setTo (cv::Scalar::all (0));
  rects_.clear ();
}

void
Renderer::discard ()
{
  if (!canvas_.empty ())
    canvas_.setTo (cv::Scalar::all (0));
  rects_.clear ();
}

}  // namespace overlay
}  // namespace landmark
