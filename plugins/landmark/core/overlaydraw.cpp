#include "overlaydraw.h"

#include <json-glib/json-glib.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <set>

namespace landmark {
namespace overlay {

/* ---- drawing primitives ---------------------------------------------- */

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kEllipsePoints = 72;
constexpr double kFar = 1e5;          /* coordinates are clamped to this */

const Rgb kBlack { 0, 0, 0 };
const Rgb kWhite { 255, 255, 255 };
const Rgb kGrey { 160, 160, 160 };
const Rgb kMuted { 175, 175, 175 };
const Rgb kDark { 40, 40, 40 };
const Rgb kThreshold { 255, 255, 255 };

inline int
iround (double v)
{
  return (int) std::lround (v);
}

inline double
overlap (const cv::Rect & a, const cv::Rect & b)
{
  return (double) (a & b).area ();
}

inline cv::Point2d
clamp_point (cv::Point2d p)
{
  return cv::Point2d (std::max (-kFar, std::min (kFar, p.x)),
      std::max (-kFar, std::min (kFar, p.y)));
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
  rects_.reserve (128);
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
    uint8_t *m = cover_.ptr<uint8_t> (y);
    bool any = false;
    for (int x = x0; x < x1; x++) {
      double px = x - a.x, py = y - a.y;
      if (len2 > 0) {
        const double t = std::max (0.0, std::min (1.0,
                (px * dx + py * dy) / len2));
        px -= t * dx;
        py -= t * dy;
      }
      const double cov = reach - std::sqrt (px * px + py * py);
      if (cov <= 0)
        continue;
      const int v = cov >= 1 ? 255 : (int) (cov * 255 + 0.5);
      if (v > m[x])
        m[x] = (uint8_t) v;
      any = true;
    }
    if (any)
      cover_row (y, x0, x1);
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
    uint8_t *m = cover_.ptr<uint8_t> (y);
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
      bool any = false;
      for (int x = x0; x < x1; x++) {
        const double d = std::sqrt ((x - c.x) * (x - c.x) + dy * dy);
        double cov = r + 0.5 - d;
        if (inner >= 0)
          cov = std::min (cov, d - inner + 0.5);
        if (cov <= 0)
          continue;
        const int v = cov >= 1 ? 255 : (int) (cov * 255 + 0.5);
        if (v > m[x])
          m[x] = (uint8_t) v;
        any = true;
      }
      if (any)
        cover_row (y, x0, x1);
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
    uint8_t *m = cover_.ptr<uint8_t> (y);
    bool any = false;
    for (int x = ix0; x < ix1; x++) {
      double d = kFar;
      for (int i = 0; i < n; i++) {
        const cv::Point2d q = p[i], r = p[(i + 1) % n];
        const double ex = r.x - q.x, ey = r.y - q.y;
        const double el = std::hypot (ex, ey);
        if (el < 1e-9)
          continue;
        d = std::min (d, orient * ((x - q.x) * ey - (y - q.y) * ex) / -el);
      }
      const double cov = d + 0.5;
      if (cov <= 0)
        continue;
      const int v = cov >= 1 ? 255 : (int) (cov * 255 + 0.5);
      if (v > m[x])
        m[x] = (uint8_t) v;
      any = true;
    }
    if (any)
      cover_row (y, ix0, ix1);
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
  int bx0 = INT32_MAX, bx1 = INT32_MIN;
  for (int y = cover_y0_; y < cover_y1_; y++) {
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
  if (bx0 < bx1) {
    /* the mark is not cut to the clip: the coverage already is */
    const cv::Rect saved = clip_;
    clip_ = cv::Rect (0, 0, width_, height_);
    mark (bx0, cover_y0_, bx1, cover_y1_);
    clip_ = saved;
  }
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

/* ---- labels ---------------------------------------------------------- */

cv::Size
Renderer::label_size (const Label & l) const
{
  const int stripe = std::max (2, iround (3 * st_.g));
  int tw = 0;
  for (int i = 0; i < l.n_lines; i++)
    tw = std::max (tw, text_width (l.lines[i]));
  return cv::Size (stripe + 2 * st_.pad + tw,
      l.n_lines * st_.line_height + st_.pad);
}

/* Places each queued label next to its detection where it covers the
 * fewest insets and earlier labels: above, below, right or left of the
 * bounding box, moved into the frame. Optional labels (rejected blobs)
 * are left out when every place covers something. */
void
Renderer::draw_labels ()
{
  reset_clip ();
  const int stripe = std::max (2, iround (3 * st_.g));
  const int gap = std::max (1, st_.line);
  for (int pass = 0; pass < 2; pass++) {
    for (const Label & l : labels_) {
      if (l.optional != (pass == 1))
        continue;
      const cv::Size sz = label_size (l);
      auto lim = [](double v) {
        return (int) std::floor (std::max (-kFar, std::min (kFar, v)));
      };
      const cv::Rect anchor (lim (l.x), lim (l.y), lim (std::ceil (l.w)),
          lim (std::ceil (l.h)));
      const cv::Point cand[4] = {
        { anchor.x, anchor.y - gap - sz.height },
        { anchor.x, anchor.y + anchor.height + gap },
        { anchor.x + anchor.width + gap, anchor.y },
        { anchor.x - gap - sz.width, anchor.y },
      };
      double best_score = -1;
      cv::Rect best;
      for (const cv::Point & c : cand) {
        cv::Rect r (std::max (0, std::min (c.x, width_ - sz.width)),
            std::max (0, std::min (c.y, height_ - sz.height)),
            sz.width, sz.height);
        double score = overlap (r, anchor);
        for (const cv::Rect & o : reserved_)
          score += 4 * overlap (r, o);
        if (best_score < 0 || score < best_score) {
          best_score = score;
          best = r;
        }
      }
      if (l.optional && (best_score > 0 || sz.width > width_ ||
              sz.height > height_))
        continue;
      fill_rect (best.x, best.y, best.x + best.width, best.y + best.height,
          kBlack, 150 * l.alpha / 255);
      fill_rect (best.x, best.y, best.x + stripe, best.y + best.height,
          l.accent, l.alpha);
      for (int i = 0; i < l.n_lines; i++)
        text (l.lines[i], best.x + stripe + st_.pad,
            best.y + st_.pad / 2 + st_.ascent + i * st_.line_height +
            (st_.line_height - st_.ascent) / 4, kWhite, l.alpha);
      reserved_.push_back (best);
    }
  }
  labels_.clear ();
}

/* ---- parts of the overlay -------------------------------------------- */

void
Renderer::draw_detection (const Detection & d)
{
  if (canvas_.empty ())
    return;
  const bool kept = d.kept;
  const Rgb colour = kept ? d.colour : kMuted;
  const int alpha = kept ? 255 : 190;
  const int thick = kept ? st_.line : std::max (1, st_.line - 1);

  /* outline: the fitted ellipse, mapped from the analysed frame to this
   * one (pixel centres: u' = (u + 0.5) sx - 0.5), else the bounding box */
  pts_.clear ();
  double cx, cy;
  if (d.has_ellipse && (d.ellipse_major > 0 || d.ellipse_minor > 0)) {
    const double a = d.ellipse_major / 2, b = d.ellipse_minor / 2;
    const double ca = std::cos (d.ellipse_angle),
        sa = std::sin (d.ellipse_angle);
    for (int i = 0; i < kEllipsePoints; i++) {
      const double t = 2 * M_PI * i / kEllipsePoints;
      const double u = d.ellipse_x + a * std::cos (t) * ca -
          b * std::sin (t) * sa;
      const double v = d.ellipse_y + a * std::cos (t) * sa +
          b * std::sin (t) * ca;
      pts_.emplace_back ((u + 0.5) * d.sx - 0.5, (v + 0.5) * d.sy - 0.5);
    }
    cx = (d.ellipse_x + 0.5) * d.sx - 0.5;
    cy = (d.ellipse_y + 0.5) * d.sy - 0.5;
  } else {
    const double x0 = d.x, y0 = d.y;
    const double x1 = d.x + std::max (d.w - 1, 0.0),
        y1 = d.y + std::max (d.h - 1, 0.0);
    pts_.emplace_back (x0, y0);
    pts_.emplace_back (x1, y0);
    pts_.emplace_back (x1, y1);
    pts_.emplace_back (x0, y1);
    cx = (x0 + x1) / 2;
    cy = (y0 + y1) / 2;
  }
  if (d.has_centroid) {
    cx = (d.centroid_x + 0.5) * d.sx - 0.5;
    cy = (d.centroid_y + 0.5) * d.sy - 0.5;
  }
  const int n = (int) pts_.size ();
  /* a dark halo keeps the outline visible on a blob of its own colour */
  polyline (pts_.data (), n, true, kBlack, kept ? 170 : 110, thick + 2,
      !kept);
  polyline (pts_.data (), n, true, colour, alpha, thick, !kept);
  if (kept) {
    const double arm = std::max (2.0, 4 * st_.g);
    line ({cx - arm, cy}, {cx + arm, cy}, kBlack, 170, thick + 2);
    line ({cx, cy - arm}, {cx, cy + arm}, kBlack, 170, thick + 2);
    line ({cx - arm, cy}, {cx + arm, cy}, kWhite, 255, thick);
    line ({cx, cy - arm}, {cx, cy + arm}, kWhite, 255, thick);
  }

  /* the label, placed by draw_labels() */
  Label l;
  l.accent = colour;
  l.alpha = alpha;
  l.optional = !kept;
  l.x = d.x;
  l.y = d.y;
  l.w = d.w;
  l.h = d.h;
  char *l1 = l.lines[0], *l2 = l.lines[1];
  const size_t size = sizeof (l.lines[0]);
  const char *cls = d.class_name ? d.class_name : "?";
  if (!kept) {
    snprintf (l1, size, "%.32s rejected%s%.40s", cls,
        d.reject_reason ? ": " : "", d.reject_reason ? d.reject_reason : "");
    l.n_lines = 1;
    labels_.push_back (l);
    return;
  }
  int len = 0;
  if (d.has_match && d.matched && d.landmark_id)
    len = snprintf (l1, size, "%.24s ", d.landmark_id);
  len += snprintf (l1 + len, size - len, "%.32s", cls);
  if (d.has_roundness && len < (int) size)
    snprintf (l1 + len, size - len, " rnd %.2f", d.roundness);
  l.n_lines = 2;
  if (d.no_floor) {
    snprintf (l2, size, "no floor");
  } else if (d.has_range && d.has_bearing) {
    /* the seed printed distances as XX.XXXX */
    snprintf (l2, size, "%.4f m %+.1f deg", d.range,
        d.bearing * 180.0 / M_PI);
  } else if (d.has_range) {
    snprintf (l2, size, "%.4f m", d.range);
  } else if (d.has_bearing) {
    snprintf (l2, size, "%+.1f deg", d.bearing * 180.0 / M_PI);
  } else {
    l.n_lines = 1;
  }
  labels_.push_back (l);
}

void
Renderer::draw_pose_text (const Pose & pose)
{
  if (canvas_.empty ())
    return;
  char s[128];
  snprintf (s, sizeof (s), "pose x %.3f m  y %.3f m  heading %.1f deg",
      pose.x, pose.y, pose.heading * 180.0 / M_PI);
  int tw = text_width (s);
  if (tw + 2 * st_.pad > width_ - 2 * st_.margin) {
    /* a narrow frame: the short form */
    snprintf (s, sizeof (s), "%.2f %.2f %.0fd", pose.x, pose.y,
        pose.heading * 180.0 / M_PI);
    tw = text_width (s);
  }
  const int bh = st_.line_height + st_.pad;
  const int x = st_.margin, y1 = height_ - st_.margin;
  fill_rect (x, y1 - bh, x + tw + 2 * st_.pad, y1, kBlack, 160);
  text (s, x + st_.pad, y1 - bh + st_.pad / 2 + st_.ascent +
      (st_.line_height - st_.ascent) / 4, kWhite, 255);
  reserved_.push_back (cv::Rect (x, y1 - bh, tw + 2 * st_.pad, bh));
}

void
Renderer::draw_class_panel (const Histogram & hist, bool histogram,
    bool indicators)
{
  if (canvas_.empty () || hist.n <= 0 || (!histogram && !indicators))
    return;
  const double g = st_.g;
  const int p = st_.pad, m = st_.margin;
  const int x = m, y = m;

  int n_markers = 0;
  for (int k = 0; k < hist.n; k++)
    n_markers += hist.classes[k].marker;
  if (!histogram && n_markers == 0)
    return;

  char title[32] = "pixels (log)", thr[32];
  snprintf (thr, sizeof (thr), "min %u", hist.threshold);
  int pw = iround (220 * g);
  if (histogram)
    pw = std::max (pw, text_width (title) + text_width (thr) + 4 * p);
  pw = std::min (pw, width_ / 2 - m);
  if (pw < 24 || height_ < 2 * m + 16)
    return;

  /* rows: title, plot, names, indicators */
  const int plot_h = histogram ? std::max (12, iround (80 * g)) : 0;
  const int inner_w = pw - 2 * p;
  const double pitch = (double) inner_w / hist.n;
  /* bar names: full, three letters, one, or none, whatever fits all */
  int name_len = 0;
  if (histogram) {
    for (int len : {32, 3, 1}) {
      bool fit = true;
      for (int k = 0; k < hist.n && fit; k++) {
        char buf[40];
        snprintf (buf, sizeof (buf), "%.*s", len,
            hist.classes[k].name ? hist.classes[k].name : "?");
        fit = text_width (buf) <= pitch - 1;
      }
      if (fit) {
        name_len = len;
        break;
      }
    }
  }
  int r = std::max (3, iround (7 * g));
  if (indicators && n_markers > 0) {
    const int fit = (int) std::floor (inner_w / (2.6 * n_markers));
    r = std::max (2, std::min (r, fit));
  }
  int h = p;
  if (histogram)
    h += st_.line_height + plot_h + p + (name_len ? st_.line_height : 0);
  if (indicators && n_markers > 0)
    h += 2 * r + p;
  h = std::min (h, height_ - 2 * m);
  const cv::Rect panel (x, y, pw, h);
  set_clip (panel);
  fill_rect (x, y, x + pw, y + h, kBlack, 150);

  int cy = y + p;
  if (histogram) {
    const int tb = cy + st_.ascent;
    /* the threshold always; the title when there is room for both */
    if (text_width (title) + text_width (thr) + 3 * p <= pw)
      text (title, x + p, tb, kWhite, 230);
    text (thr, x + pw - p - text_width (thr), tb, kThreshold, 255);
    cy += st_.line_height;

    const int px0 = x + p, py1 = cy + plot_h;
    double total = std::max (hist.total, (double) hist.threshold);
    for (int k = 0; k < hist.n; k++)
      total = std::max (total, (double) hist.classes[k].count);
    const double top = std::log10 (1.0 + std::max (total, 1.0));
    auto frac = [&](double c) {
      return std::min (1.0, std::log10 (1.0 + c) / top);
    };
    const int gap = pitch >= 4 ? std::max (1, iround (pitch * 0.15)) : 0;
    for (int k = 0; k < hist.n; k++) {
      const ClassInfo & ci = hist.classes[k];
      const int bx0 = px0 + iround (k * pitch) + gap;
      const int bx1 = std::max (bx0 + 1, px0 + iround ((k + 1) * pitch) - gap);
      const int bt = py1 - iround (frac (ci.count) * plot_h);
      if (ci.count > 0 && bt < py1)
        fill_rect (bx0, bt, bx1, py1, ci.colour, ci.active ? 255 : 90);
      if (name_len) {
        char buf[40];
        snprintf (buf, sizeof (buf), "%.*s", name_len,
            ci.name ? ci.name : "?");
        const int tx = (bx0 + bx1) / 2 - text_width (buf) / 2;
        text (buf, tx, py1 + p / 2 + st_.ascent, kWhite,
            ci.active ? 230 : 130);
      }
    }
    line ({(double) px0, py1 + 0.5}, {(double) px0 + inner_w, py1 + 0.5},
        kGrey, 200, 1);
    if (hist.threshold > 0) {
      /* on a pixel row, so a thin line stays crisp */
      const double ty = py1 - iround (frac (hist.threshold) * plot_h);
      pts_.clear ();
      const double dash = std::max (2.0, 3 * g);
      for (double tx = px0; tx <= px0 + inner_w; tx += dash)
        pts_.emplace_back (tx, ty);
      polyline (pts_.data (), (int) pts_.size (), false, kThreshold, 255,
          st_.line, true);
    }
    cy = py1 + p + (name_len ? st_.line_height : 0);
  }
  if (indicators && n_markers > 0) {
    const double step = (double) inner_w / n_markers;
    int i = 0;
    for (int k = 0; k < hist.n; k++) {
      const ClassInfo & ci = hist.classes[k];
      if (!ci.marker)
        continue;
      const cv::Point2d c (x + p + step * (i + 0.5), cy + r);
      if (ci.active) {
        fill_circle (c, r, ci.colour, 255);
        circle (c, r, kWhite, 220, 1);
      } else {
        fill_circle (c, r, kDark, 220);
        circle (c, r - 0.5, ci.colour, 170, std::max (1, r / 4));
      }
      i++;
    }
  }
  reset_clip ();
  reserved_.push_back (panel & cv::Rect (0, 0, width_, height_));
}

void
Renderer::draw_boundary (const Floor & f)
{
  if (canvas_.empty () || f.width <= 0 || f.height <= 0 || !f.boundary_row ||
      !f.boundary_state)
    return;
  /* label plane to frame: pixel centres on integers in both */
  const double sx = (double) width_ / f.width, sy = (double) height_ / f.height;
  const int thick = st_.line + 1;
  /* runs of seen columns in one colour, each a polyline on a dark halo */
  for (int pass = 0; pass < 2; pass++) {
    int c = 0;
    while (c < f.width) {
      const uint8_t state = f.boundary_state[c];
      if (f.boundary_row[c] < 0 || state == 0) {
        c++;
        continue;
      }
      const bool obstacle = state == 2;
      pts_.clear ();
      int e = c;
      for (; e < f.width; e++) {
        if (f.boundary_row[e] < 0 || f.boundary_state[e] == 0 ||
            (f.boundary_state[e] == 2) != obstacle)
          break;
        pts_.emplace_back ((e + 0.5) * sx - 0.5,
            (f.boundary_row[e] + 0.5) * sy - 0.5);
      }
      /* a lone column: a short horizontal dash across its width */
      if (pts_.size () == 1) {
        const cv::Point2d m = pts_[0];
        pts_[0].x = m.x - sx / 2;
        pts_.emplace_back (m.x + sx / 2, m.y);
      }
      if (pass == 0)
        polyline (pts_.data (), (int) pts_.size (), false, kBlack, 150,
            thick + 2, false);
      else
        polyline (pts_.data (), (int) pts_.size (), false,
            obstacle ? kFloorObstacle : kFloorOpen, 255, thick, false);
      c = e;
    }
  }
}

void
Renderer::draw_minimap (const LandmarkMap & map, const Rgb * colours,
    const Pose & pose, const Detection * dets, int n_dets,
    const Floor * free_space)
{
  const bool floor = free_space && free_space->bins > 0 &&
      free_space->rop_range && free_space->rop_state;
  if (canvas_.empty () || (map.landmarks.empty () && !floor))
    return;
  const double g = st_.g;
  const int p = st_.pad, m = st_.margin;
  const int side = std::min ({ iround (170 * g), width_ / 2 - m,
      height_ - 2 * m });
  if (side < 32)
    return;
  const int x0 = width_ - m - side, y0 = m;
  const cv::Rect panel (x0, y0, side, side);
  set_clip (panel);
  fill_rect (x0, y0, x0 + side, y0 + side, kBlack, 150);

  /* world window: the map, padded, the robot and its free space; the
   * free space's corners are bin edges at each bin's range (map frame) */
  double wx0 = pose.x, wx1 = pose.x, wy0 = pose.y, wy1 = pose.y;
  for (const auto & lm : map.landmarks) {
    wx0 = std::min (wx0, lm.x);
    wx1 = std::max (wx1, lm.x);
    wy0 = std::min (wy0, lm.y);
    wy1 = std::max (wy1, lm.y);
  }
  free_pts_.clear ();
  if (floor) {
    const Floor & f = *free_space;
    for (int b = 0; b < f.bins; b++) {
      if (f.rop_state[b] == 0 || !(f.rop_range[b] > 0))
        continue;
      const double r = f.rop_range[b];
      for (int edge = -1; edge <= 1; edge += 2) {
        const double phi = pose.heading + (b + 0.5 * edge) * f.bin_width;
        const cv::Point2d q (pose.x + r * std::cos (phi),
            pose.y + r * std::sin (phi));
        free_pts_.push_back (q);
        wx0 = std::min (wx0, q.x);
        wx1 = std::max (wx1, q.x);
        wy0 = std::min (wy0, q.y);
        wy1 = std::max (wy1, q.y);
      }
    }
  }
  const double pad_w = std::max (0.5, 0.08 * std::max (wx1 - wx0, wy1 - wy0));
  wx0 -= pad_w;
  wx1 += pad_w;
  wy0 -= pad_w;
  wy1 += pad_w;
  const double inner = side - 2.0 * p;
  const double k = inner / std::max (wx1 - wx0, wy1 - wy0);
  const double mx = (wx0 + wx1) / 2, my = (wy0 + wy1) / 2;
  const double pcx = x0 + side / 2.0, pcy = y0 + side / 2.0;
  auto to_px = [&](double wx, double wy) {
    return cv::Point2d (pcx + (wx - mx) * k, pcy - (wy - my) * k);
  };

  /* grid: 1 m, or coarser so that lines are at least 8 px apart */
  double spacing = 1.0;
  for (double s : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 1000.0}) {
    spacing = s;
    if (s * k >= 8)
      break;
  }
  if (spacing * k >= 8) {
    const double half = side / 2.0 / k;
    for (double gx = std::ceil ((mx - half) / spacing) * spacing;
        gx <= mx + half; gx += spacing) {
      const double px = pcx + (gx - mx) * k;
      line ({px, (double) y0}, {px, (double) y0 + side}, kGrey, 60, 1);
    }
    for (double gy = std::ceil ((my - half) / spacing) * spacing;
        gy <= my + half; gy += spacing) {
      const double py = pcy - (gy - my) * k;
      line ({(double) x0, py}, {(double) x0 + side, py}, kGrey, 60, 1);
    }
  }

  /* free space: one wedge per seen bin, from the robot to the bin's
   * range, filled as one polygon (seen bins separated by unseen ones
   * close back to the robot); obstacle bins' far edges in red */
  const cv::Point2d robot = to_px (pose.x, pose.y);
  const int thin = std::max (1, iround (g));
  if (floor && !free_pts_.empty ()) {
    const Floor & f = *free_space;
    pts_.clear ();
    size_t j = 0;
    bool open = false;
    for (int b = 0; b < f.bins; b++) {
      if (f.rop_state[b] == 0 || !(f.rop_range[b] > 0)) {
        if (open)
          pts_.push_back (robot);
        open = false;
        continue;
      }
      if (!open)
        pts_.push_back (robot);
      pts_.push_back (to_px (free_pts_[j].x, free_pts_[j].y));
      pts_.push_back (to_px (free_pts_[j + 1].x, free_pts_[j + 1].y));
      j += 2;
      open = true;
    }
    cover_polygon (pts_.data (), (int) pts_.size ());
    paint (kFreeSpace, 110);
    j = 0;
    for (int b = 0; b < f.bins; b++) {
      if (f.rop_state[b] == 0 || !(f.rop_range[b] > 0))
        continue;
      if (f.rop_state[b] == 2)
        cover_segment (to_px (free_pts_[j].x, free_pts_[j].y),
            to_px (free_pts_[j + 1].x, free_pts_[j + 1].y), thin / 2.0 + 0.5);
      j += 2;
    }
    paint (kFloorObstacle, 255);
  }

  /* observations: range circles around matched landmarks, rays from the
   * robot along each bearing */
  for (int i = 0; i < n_dets; i++) {
    const Detection & d = dets[i];
    if (!d.kept || !d.has_range || d.no_floor)
      continue;
    if (d.has_match && d.matched && d.landmark_id) {
      for (const auto & lm : map.landmarks) {
        if (lm.id != d.landmark_id)
          continue;
        circle (to_px (lm.x, lm.y), d.range * k, d.colour, 190, thin);
        break;
      }
    }
    if (d.has_bearing) {
      const double phi = pose.heading + d.bearing;
      const cv::Point2d end = to_px (pose.x + d.range * std::cos (phi),
          pose.y + d.range * std::sin (phi));
      line (robot, end, d.colour, 230, thin);
      fill_circle (end, std::max (1.5, 2 * g), d.colour, 255);
    }
  }

  /* landmarks */
  const bool ids = side >= 140;
  for (size_t i = 0; i < map.landmarks.size (); i++) {
    const auto & lm = map.landmarks[i];
    const cv::Point2d c = to_px (lm.x, lm.y);
    const double r = std::max (std::max (2.0, 3 * g), lm.diameter / 2 * k);
    fill_circle (c, r + 1, kBlack, 200);
    fill_circle (c, r, colours ? colours[i] : kWhite, 255);
    if (ids) {
      /* right of the landmark, or left of it near the panel's edge */
      const int tw = text_width (lm.id.c_str ());
      int tx = iround (c.x + r + 2);
      if (tx + tw > x0 + side - 1)
        tx = iround (c.x - r - 2) - tw;
      text (lm.id.c_str (), tx, iround (c.y + st_.ascent / 2.0), kWhite, 200);
    }
  }

  /* the robot: a triangle pointing along its heading */
  const double len = std::max (6.0, 10 * g);
  const double ch = std::cos (pose.heading), sh = std::sin (pose.heading);
  auto body = [&](double fwd, double left) {
    /* robot frame (forward, left) to panel pixels (y down) */
    return cv::Point2d (robot.x + fwd * ch - left * sh,
        robot.y - (fwd * sh + left * ch));
  };
  const cv::Point2d tri[3] = { body (len, 0), body (-0.6 * len, 0.5 * len),
    body (-0.6 * len, -0.5 * len)
  };
  fill_poly (tri, 3, kWhite, 255);
  polyline (tri, 3, true, kBlack, 255, 1, false);
  reset_clip ();
  reserved_.push_back (panel & cv::Rect (0, 0, width_, height_));
}

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
          if (c[3] == 0)
            continue;
          asum += c[3];
          csum[0] += c[0];
          csum[1] += c[1];
          csum[2] += c[2];
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
        if (c[3] == 0)
          continue;
        asum += c[3];
        csum[0] += c[0];
        csum[1] += c[1];
        csum[2] += c[2];
        mp[2 * i] = k.luma (mp[2 * i], c);
      }
      if (asum == 0)
        continue;
      mp[1] = k.chroma (mp[1], csum, asum, cols, k.cb);
      mp[3] = k.chroma (mp[3], csum, asum, cols, k.cr);
    }
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
