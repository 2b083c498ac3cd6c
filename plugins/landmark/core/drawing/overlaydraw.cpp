#include "overlaydraw.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "overlayinternal.h"

namespace landmark {
namespace overlay {

using namespace internal;

/* ---- drawing primitives ---------------------------------------------- */

namespace {

inline cv::Point2d
clamp_point (cv::Point2d p)
{
  return cv::Point2d (std::max (-kFar, std::min (kFar, p.x)),
      std::max (-kFar, std::min (kFar, p.y)));
}

/* Raises the coverage m of a pixel to cov (in pixels: 1 or more is full);
 * true when the pixel is covered at all. */
inline bool
raise_coverage (uint8_t & m, double cov)
{
  if (cov <= 0)
    return false;
  const int v = cov >= 1 ? 255 : (int) (cov * 255 + 0.5);
  if (v > m)
    m = (uint8_t) v;
  return true;
}

/* premultiplied "over" of colour c at coverage a (0..255) */
inline void
over (uint8_t * d, Rgb c, int a)
{
  const int keep = 255 - a;
  d[0] = (uint8_t) ((d[0] * keep + c.r * a + 127) / 255);
  d[1] = (uint8_t) ((d[1] * keep + c.g * a + 127) / 255);
  d[2] = (uint8_t) ((d[2] * keep + c.b * a + 127) / 255);
  d[3] = (uint8_t) ((d[3] * keep + 255 * a + 127) / 255);
}

}  // namespace

void
Renderer::configure (int width, int height)
{
  width_ = std::max (width, 0);
  height_ = std::max (height, 0);
  canvas_.release ();
  cover_.release ();
  if (width_ > 0 && height_ > 0) {
    canvas_ = cv::Mat::zeros (height_, width_, CV_8UC4);
    cover_ = cv::Mat::zeros (height_, width_, CV_8UC1);
  }
  row_x0_.assign (height_, INT32_MAX);
  row_x1_.assign (height_, INT32_MIN);
  cover_y0_ = INT32_MAX;
  cover_y1_ = INT32_MIN;
  reset_clip ();
  rects_.clear ();
  rects_.reserve (512);
  spans_.reserve (128);
  reserved_.reserve (64);
  labels_.reserve (64);
  pts_.reserve (kEllipsePoints + 8);
  str_.reserve (128);
}

void
Renderer::begin_frame (double text_scale)
{
  rects_.clear ();
  reserved_.clear ();
  labels_.clear ();
  reset_clip ();
  Style s;
  s.g = std::min (height_ / 480.0, width_ / 640.0);
  s.font = std::max (0.33, 0.5 * s.g) * text_scale;
  s.text_thick = std::max (1, iround (s.font * 1.8));
  s.line = std::max (1, iround (1.5 * s.g));
  s.pad = std::max (2, iround (4 * s.g));
  s.margin = std::max (2, iround (8 * s.g));
  int base = 0;
  str_ = "Ag";
  const cv::Size sz = cv::getTextSize (str_, kFont, s.font, s.text_thick,
      &base);
  s.ascent = sz.height;
  s.line_height = sz.height + base + std::max (2, iround (3 * s.g));
  st_ = s;
  build_glyphs ();
}

/* Primitives draw only inside clip_ (canvas coordinates). */
void
Renderer::set_clip (const cv::Rect & r)
{
  clip_ = r & cv::Rect (0, 0, width_, height_);
  if (canvas_.empty ())
    clip_ = cv::Rect ();
}

void
Renderer::reset_clip ()
{
  set_clip (cv::Rect (0, 0, width_, height_));
}

/* Marks [x0, x1) x [y0, y1) (canvas coordinates) as drawn, cut to the
 * clip, widened to 2x2 blocks (so the chroma of a block is blended from
 * all of its pixels at once). */
void
Renderer::mark (int x0, int y0, int x1, int y1)
{
  x0 = std::max (clip_.x, x0);
  y0 = std::max (clip_.y, y0);
  x1 = std::min (clip_.x + clip_.width, x1);
  y1 = std::min (clip_.y + clip_.height, y1);
  if (x1 <= x0 || y1 <= y0)
    return;
  x0 &= ~1;
  y0 &= ~1;
  x1 = std::min (width_, (x1 + 1) & ~1);
  y1 = std::min (height_, (y1 + 1) & ~1);
  const cv::Rect r (x0, y0, x1 - x0, y1 - y0);
  /* drawing is mostly local: often inside the previous rectangle */
  if (!rects_.empty () && (rects_.back () & r) == r)
    return;
  rects_.push_back (r);
}

/* ---- coverage: anti-aliased shapes as an 8-bit mask ------------------- */

/* Records that row y has coverage in [x0, x1). */
inline void
Renderer::cover_row (int y, int x0, int x1)
{
  row_x0_[y] = std::min (row_x0_[y], x0);
  row_x1_[y] = std::max (row_x1_[y], x1);
  cover_y0_ = std::min (cover_y0_, y);
  cover_y1_ = std::max (cover_y1_, y + 1);
}

/* Raises the coverage of row y over [x0, x1) to coverage (x) (in pixels,
 * as raise_coverage) and marks the span when any pixel is covered. */
template <typename Coverage>
void
Renderer::cover_span (int y, int x0, int x1, Coverage coverage)
{
  uint8_t *m = cover_.ptr<uint8_t> (y);
  bool any = false;
  for (int x = x0; x < x1; x++)
    any |= raise_coverage (m[x], coverage (x));
  if (any)
    cover_row (y, x0, x1);
}

/* Coverage of a segment of half-width hw with round ends: per pixel,
 * clamp (hw + 0.5 - distance to the segment, 0, 1), kept at its maximum
 * over the shapes of one paint(). */
void
Renderer::cover_segment (cv::Point2d a, cv::Point2d b, double hw)
{
  if (clip_.area () <= 0)
    return;
  a = clamp_point (a);
  b = clamp_point (b);
  const double reach = hw + 0.5;
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  const int y0 = std::max (clip_.y,
      (int) std::floor (std::min (a.y, b.y) - reach));
  const int y1 = std::min (clip_.y + clip_.height,
      (int) std::ceil (std::max (a.y, b.y) + reach) + 1);
  const double bx0 = std::min (a.x, b.x) - reach,
      bx1 = std::max (a.x, b.x) + reach;
  const double len = std::sqrt (len2);
  const double reach2 = reach * reach;
  const double inner2 = reach > 1 ? (reach - 1) * (reach - 1) : -1;
  for (int y = y0; y < y1; y++) {
    /* the row's part of the band around the infinite line, within the
     * segment's box */
    double lo = bx0, hi = bx1;
    if (len > 1e-9 && std::fabs (dy) > 1e-9) {
      const double ux = dx / len, uy = dy / len;
      double e0 = a.x + ((y - a.y) * ux - reach) / uy;
      double e1 = a.x + ((y - a.y) * ux + reach) / uy;
      if (e0 > e1)
        std::swap (e0, e1);
      lo = std::max (lo, e0);
      hi = std::min (hi, e1);
    }
    const int x0 = std::max (clip_.x, (int) std::floor (lo));
    const int x1 = std::min (clip_.x + clip_.width, (int) std::ceil (hi) + 1);
    if (x1 <= x0)
      continue;
    cover_span (y, x0, x1, [&] (int x) {
      double px = x - a.x, py = y - a.y;
      if (len2 > 0) {
        const double t = std::max (0.0, std::min (1.0,
                (px * dx + py * dy) / len2));
        px -= t * dx;
        py -= t * dy;
      }
      /* the square root only at the anti-aliased rim */
      const double d2 = px * px + py * py;
      if (d2 >= reach2)
        return 0.0;
      return d2 <= inner2 ? 1.0 : reach - std::sqrt (d2);
    });
  }
}

/* A disc of radius r (inner = -1), or a ring between radii inner and r. */
void
Renderer::cover_disc (cv::Point2d c, double r, double inner)
{
  if (clip_.area () <= 0 || r <= 0 || r > kFar)
    return;
  c = clamp_point (c);
  const double ro = r + 0.5;
  const int y0 = std::max (clip_.y, (int) std::floor (c.y - ro));
  const int y1 = std::min (clip_.y + clip_.height,
      (int) std::ceil (c.y + ro) + 1);
  for (int y = y0; y < y1; y++) {
    const double dy = y - c.y;
    const double w2 = ro * ro - dy * dy;
    if (w2 <= 0)
      continue;
    const double wo = std::sqrt (w2);
    /* a ring leaves out the part of the row inside its inner edge */
    double wi = -1;
    if (inner > 0.5) {
      const double ri = inner - 0.5;
      if (ri * ri - dy * dy > 0)
        wi = std::sqrt (ri * ri - dy * dy) - 1;
    }
    for (int side = 0; side < (wi > 0 ? 2 : 1); side++) {
      int x0, x1;
      if (wi <= 0) {
        x0 = (int) std::floor (c.x - wo);
        x1 = (int) std::ceil (c.x + wo) + 1;
      } else if (side == 0) {
        x0 = (int) std::floor (c.x - wo);
        x1 = (int) std::ceil (c.x - wi) + 1;
      } else {
        x0 = (int) std::floor (c.x + wi);
        x1 = (int) std::ceil (c.x + wo) + 1;
      }
      x0 = std::max (x0, clip_.x);
      x1 = std::min (x1, clip_.x + clip_.width);
      if (x1 <= x0)
        continue;
      cover_span (y, x0, x1, [&] (int x) {
        const double d = std::sqrt ((x - c.x) * (x - c.x) + dy * dy);
        const double cov = r + 0.5 - d;
        return inner >= 0 ? std::min (cov, d - inner + 0.5) : cov;
      });
    }
  }
}

/* A convex polygon: the smallest signed distance to its edges. */
void
Renderer::cover_convex (const cv::Point2d * p, int n)
{
  if (clip_.area () <= 0 || n < 3)
    return;
  double x0 = kFar, y0 = kFar, x1 = -kFar, y1 = -kFar, area = 0;
  for (int i = 0; i < n; i++) {
    const cv::Point2d q = clamp_point (p[i]), r = clamp_point (p[(i + 1) % n]);
    x0 = std::min (x0, q.x);
    y0 = std::min (y0, q.y);
    x1 = std::max (x1, q.x);
    y1 = std::max (y1, q.y);
    area += q.x * r.y - r.x * q.y;
  }
  const double orient = area >= 0 ? 1 : -1;
  const int iy0 = std::max (clip_.y, (int) std::floor (y0) - 1);
  const int iy1 = std::min (clip_.y + clip_.height, (int) std::ceil (y1) + 2);
  const int ix0 = std::max (clip_.x, (int) std::floor (x0) - 1);
  const int ix1 = std::min (clip_.x + clip_.width, (int) std::ceil (x1) + 2);
  for (int y = iy0; y < iy1; y++) {
    cover_span (y, ix0, ix1, [&] (int x) {
      double d = kFar;
      for (int i = 0; i < n; i++) {
        const cv::Point2d q = p[i], r = p[(i + 1) % n];
        const double ex = r.x - q.x, ey = r.y - q.y;
        const double el = std::hypot (ex, ey);
        if (el < 1e-9)
          continue;
        d = std::min (d, orient * ((x - q.x) * ey - (y - q.y) * ex) / -el);
      }
      return d + 0.5;
    });
  }
}

void
Renderer::cover_polygon (const cv::Point2d * p, int n)
{
  if (clip_.area () <= 0 || n < 3)
    return;
  /* OpenCV fills with pixel centres on integers, as here; 4 bits of
   * sub-pixel position, coordinates relative to the clip */
  constexpr int kShift = 4;
  std::vector<cv::Point> & q = poly_;
  q.resize (n);
  double y0 = kFar, y1 = -kFar, x0 = kFar, x1 = -kFar;
  for (int i = 0; i < n; i++) {
    const cv::Point2d c = clamp_point (p[i]);
    x0 = std::min (x0, c.x);
    x1 = std::max (x1, c.x);
    y0 = std::min (y0, c.y);
    y1 = std::max (y1, c.y);
    q[i] = cv::Point (iround ((c.x - clip_.x) * (1 << kShift)),
        iround ((c.y - clip_.y) * (1 << kShift)));
  }
  cv::Mat roi = cover_ (clip_);
  const cv::Point *pts = q.data ();
  cv::fillPoly (roi, &pts, &n, 1, cv::Scalar (255), cv::LINE_AA, kShift);
  const int iy0 = std::max (clip_.y, (int) std::floor (y0) - 1);
  const int iy1 = std::min (clip_.y + clip_.height, (int) std::ceil (y1) + 2);
  const int ix0 = std::max (clip_.x, (int) std::floor (x0) - 1);
  const int ix1 = std::min (clip_.x + clip_.width, (int) std::ceil (x1) + 2);
  for (int y = iy0; y < iy1; y++)
    cover_row (y, ix0, ix1);
}

/* Blends the covered pixels in colour c at opacity alpha, clears the
 * coverage and marks the area as drawn. */
void
Renderer::paint (Rgb c, int alpha)
{
  if (cover_y0_ >= cover_y1_)
    return;
  /* the area is marked in bands of rows, each as wide as its rows' cover:
   * a long slanted line marks a thin staircase, not its whole bounding
   * box, so blending and clearing follow the line's length */
  constexpr int kBand = 16;
  const cv::Rect saved = clip_;
  clip_ = cv::Rect (0, 0, width_, height_);
  int bx0 = INT32_MAX, bx1 = INT32_MIN, by0 = cover_y0_;
  for (int y = cover_y0_; y < cover_y1_; y++) {
    if (y > by0 && y % kBand == 0) {
      if (bx0 < bx1)
        mark (bx0, by0, bx1, y);
      bx0 = INT32_MAX;
      bx1 = INT32_MIN;
      by0 = y;
    }
    const int x0 = row_x0_[y], x1 = row_x1_[y];
    if (x0 >= x1)
      continue;
    bx0 = std::min (bx0, x0);
    bx1 = std::max (bx1, x1);
    uint8_t *m = cover_.ptr<uint8_t> (y);
    uint8_t *d = canvas_.ptr<uint8_t> (y) + 4 * x0;
    for (int x = x0; x < x1; x++, d += 4) {
      if (m[x] == 0)
        continue;
      over (d, c, (alpha * m[x] + 127) / 255);
      m[x] = 0;
    }
    row_x0_[y] = INT32_MAX;
    row_x1_[y] = INT32_MIN;
  }
  /* the marks are not cut to the clip: the coverage already is */
  if (bx0 < bx1)
    mark (bx0, by0, bx1, cover_y1_);
  clip_ = saved;
  cover_y0_ = INT32_MAX;
  cover_y1_ = INT32_MIN;
}

/* ---- shapes ----------------------------------------------------------- */

void
Renderer::line (cv::Point2d a, cv::Point2d b, Rgb c, int alpha, int thick)
{
  cover_segment (a, b, thick / 2.0);
  paint (c, alpha);
}

void
Renderer::polyline (const cv::Point2d * pts, int n, bool closed, Rgb c,
    int alpha, int thick, bool dashed)
{
  if (n < 2)
    return;
  const double hw = thick / 2.0;
  const int segments = closed ? n : n - 1;
  if (!dashed) {
    for (int j = 0; j < segments; j++)
      cover_segment (pts[j], pts[(j + 1) % n], hw);
  } else {
    /* dashes and gaps measured along the line, the same for every
     * thickness (a halo and the line on it have their gaps together) */
    const double dash = std::max (4.0, 8 * st_.g) + st_.line,
        gap = 0.75 * dash + 2 * st_.line + 2;
    bool on = true;
    double left = dash;         /* of the current dash or gap */
    for (int j = 0; j < segments; j++) {
      const cv::Point2d a = clamp_point (pts[j]),
          b = clamp_point (pts[(j + 1) % n]);
      const double len = std::hypot (b.x - a.x, b.y - a.y);
      double pos = 0;
      while (pos < len) {
        const double step = std::min (left, len - pos);
        if (on && step > 0)
          cover_segment (a + (b - a) * (pos / len),
              a + (b - a) * ((pos + step) / len), hw);
        pos += step;
        left -= step;
        if (left <= 1e-9) {
          on = !on;
          left = on ? dash : gap;
        }
      }
    }
  }
  paint (c, alpha);
}

void
Renderer::circle (cv::Point2d centre, double radius, Rgb c, int alpha,
    int thick)
{
  const double hw = std::max (thick, 1) / 2.0;
  cover_disc (centre, radius + hw, radius > hw ? radius - hw : -1);
  paint (c, alpha);
}

void
Renderer::fill_circle (cv::Point2d centre, double radius, Rgb c, int alpha)
{
  cover_disc (centre, radius, -1);
  paint (c, alpha);
}

void
Renderer::fill_poly (const cv::Point2d * pts, int n, Rgb c, int alpha)
{
  cover_convex (pts, n);
  paint (c, alpha);
}

/* Text is drawn from a cache of glyph coverage masks, rendered once per
 * font size by OpenCV (Hershey simplex, anti-aliased): drawing a string
 * is then a blend of small masks, with no allocation per frame. */
void
Renderer::build_glyphs ()
{
  if (glyph_font_ == st_.font && glyph_thick_ == st_.text_thick)
    return;
  glyph_font_ = st_.font;
  glyph_thick_ = st_.text_thick;
  const int t = st_.text_thick;
  int base = 0;
  for (int c = kFirstGlyph; c <= kLastGlyph; c++) {
    Glyph & g = glyphs_[c - kFirstGlyph];
    const char s[2] = { (char) c, 0 };
    str_ = s;
    const cv::Size sz = cv::getTextSize (str_, kFont, st_.font, t, &base);
    g.advance = std::max (1, sz.width - t);
    /* room for strokes that reach beyond the nominal box */
    const int m = 2 * t + 2;
    g.ox = m;
    g.oy = sz.height + m;
    g.mask.create (sz.height + base + 2 * m, sz.width + 2 * m, CV_8UC1);
    g.mask.setTo (0);
    if (c != ' ')
      cv::putText (g.mask, str_, cv::Point (g.ox, g.oy), kFont, st_.font,
          cv::Scalar (255), t, cv::LINE_AA);
  }
}

const Renderer::Glyph *
Renderer::glyph (char c) const
{
  if (c < kFirstGlyph || c > kLastGlyph)
    c = '?';
  return &glyphs_[c - kFirstGlyph];
}

int
Renderer::text_width (const char *s) const
{
  int w = 0;
  for (; *s; s++)
    w += glyph (*s)->advance;
  return w + st_.text_thick;
}

void
Renderer::text (const char *s, int x, int baseline, Rgb c, int alpha)
{
  if (clip_.area () <= 0 || !*s)
    return;
  const int cx0 = clip_.x, cy0 = clip_.y;
  const int cx1 = clip_.x + clip_.width, cy1 = clip_.y + clip_.height;
  const int x_start = x;
  int top = INT32_MAX, bottom = INT32_MIN;
  for (; *s; s++) {
    const Glyph *g = glyph (*s);
    const int gx = x - g->ox, gy = baseline - g->oy;
    x += g->advance;
    if (*s == ' ')
      continue;
    const int y0 = std::max (gy, cy0), y1 = std::min (gy + g->mask.rows, cy1);
    const int x0 = std::max (gx, cx0), x1 = std::min (gx + g->mask.cols, cx1);
    top = std::min (top, gy);
    bottom = std::max (bottom, gy + g->mask.rows);
    for (int yy = y0; yy < y1; yy++) {
      const uint8_t *m = g->mask.ptr<uint8_t> (yy - gy) + (x0 - gx);
      uint8_t *d = canvas_.ptr<uint8_t> (yy) + 4 * x0;
      for (int xx = x0; xx < x1; xx++, m++, d += 4)
        if (*m)
          over (d, c, (alpha * *m + 127) / 255);
    }
  }
  if (top < bottom)
    mark (x_start - 2 * st_.text_thick - 2, top, x + 2 * st_.text_thick + 2,
        bottom);
}

/* Premultiplied "over" of a constant colour on [x0, x1) x [y0, y1). */
void
Renderer::fill_rect (int x0, int y0, int x1, int y1, Rgb c, int alpha)
{
  x0 = std::max (clip_.x, x0);
  y0 = std::max (clip_.y, y0);
  x1 = std::min (clip_.x + clip_.width, x1);
  y1 = std::min (clip_.y + clip_.height, y1);
  if (x1 <= x0 || y1 <= y0 || alpha <= 0)
    return;
  alpha = std::min (alpha, 255);
  const int keep = 255 - alpha;
  const int add[4] = { c.r * alpha + 127, c.g * alpha + 127,
    c.b * alpha + 127, 255 * alpha + 127
  };
  uint8_t fresh[4];             /* the result over an empty pixel */
  for (int i = 0; i < 4; i++)
    fresh[i] = (uint8_t) (add[i] / 255);
  uint32_t fresh32;
  memcpy (&fresh32, fresh, 4);
  for (int y = y0; y < y1; y++) {
    uint8_t *d = canvas_.ptr<uint8_t> (y) + 4 * x0;
    for (int x = x0; x < x1; x++, d += 4) {
      uint32_t v;
      memcpy (&v, d, 4);
      if (v == 0) {
        memcpy (d, &fresh32, 4);
        continue;
      }
      for (int i = 0; i < 4; i++)
        d[i] = (uint8_t) ((d[i] * keep + add[i]) / 255);
    }
  }
  mark (x0, y0, x1, y1);
}

}  // namespace overlay
}  // namespace landmark
