#include "floorprofile.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#ifdef __SSE2__
#include <emmintrin.h>
#endif


namespace landmark {

/* ---- floor boundary and ROP ------------------------------------------- */

const char *
free_state_name (FreeState s)
{
  /* by the state's value, which the floor meta carries as a byte */
  static const char *const names[] = { "not-seen", "free", "obstacle",
    "view-edge"
  };
  const size_t i = static_cast<size_t> (s);
  return i < std::size (names) ? names[i] : "not-seen";
}

bool
FloorProfile::configure (const CameraGeometry & g,
    const FloorProfileParams & params, std::string * error)
{
  width_ = height_ = 0;
  if (!g.configured ()) {
    *error = "the camera geometry is not configured";
    return false;
  }
  if (params.min_obstacle_rows < 1 || params.min_obstacle_rows > 255 ||
      params.bearing_bins < 1 ||
      !(params.max_range > 0)) {
    *error = "min-obstacle-rows must be within 1..255, bearing-bins >= 1 "
        "and max-range > 0";
    return false;
  }
  const int w = g.params ().width, h = g.params ().height;
  if (w < 1 || h < 1) {
    *error = "empty frame";
    return false;
  }
  params_ = params;
  /* every pixel edge of every column at the column's centre: rows are
   * centred on integers, so edge e lies at v = e - 1/2 */
  std::vector<double> uv ((size_t) w * (h + 1) * 2);
  size_t i = 0;
  for (int e = 0; e <= h; e++)
    for (int u = 0; u < w; u++) {
      uv[i++] = u;
      uv[i++] = e - 0.5;
    }
  std::vector<Vec3> rays;
  g.rays (uv, &rays);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  edge_x_.assign ((size_t) w * (h + 1), nan);
  edge_y_.assign ((size_t) w * (h + 1), nan);
  edge_down_.assign ((size_t) w * (h + 1), nan);
  for (size_t k = 0; k < rays.size (); k++) {
    double x, y;
    const Vec3 & d = rays[k];
    /* below the horizontal, radians (negative above): for balls taller
     * than the camera, whose upper tangent never meets the floor */
    edge_down_[k] = (float) std::atan2 (-d.z, std::hypot (d.x, d.y));
    if (g.intersect (rays[k], 0.0, &x, &y)) {
      edge_x_[k] = (float) x;
      edge_y_[k] = (float) y;
    }
  }
  stop_edge_.assign (w, -1);
  if (h + 1 > 32767) {
    *error = "frames more than 32766 rows high are not supported";
    return false;
  }
  int seen = 0;
  for (int u = 0; u < w; u++) {
    int stop = -1;
    for (int e = h; e >= 0; e--) {
      const size_t k = (size_t) e * w + u;
      if (std::isnan (edge_x_[k]))
        break;
      stop = e;
      if (std::hypot (edge_x_[k], edge_y_[k]) > params.max_range)
        break;
    }
    stop_edge_[u] = (int16_t) stop;
    seen += stop >= 0;
  }
  if (seen == 0) {
    *error = "the camera sees no floor at the bottom of the image";
    return false;
  }
  width_ = w;
  camera_height_ = g.params ().camera_height;
  height_ = h;
  cols_.assign (w, ColumnBoundary ());
  /* the columns by stop edge (counting sort), for scan's row loop */
  by_stop_start_.assign (h + 3, 0);
  for (int u = 0; u < w; u++)
    if (stop_edge_[u] >= 0)
      by_stop_start_[stop_edge_[u] + 1]++;
  for (int e = 1; e <= h + 2; e++)
    by_stop_start_[e] += by_stop_start_[e - 1];
  by_stop_.assign (w, 0);
  {
    std::vector<int> fill (by_stop_start_.begin (), by_stop_start_.end ());
    for (int u = 0; u < w; u++)
      if (stop_edge_[u] >= 0)
        by_stop_[fill[stop_edge_[u]]++] = u;
  }
  bins_.assign (params.bearing_bins, RopBin ());
  return true;
}

bool
FloorProfile::edge_point (int u, int edge, float *x, float *y) const
{
  if (u < 0 || u >= width_ || edge < 0 || edge > height_)
    return false;
  const size_t k = (size_t) edge * width_ + u;
  if (std::isnan (edge_x_[k]))
    return false;
  *x = edge_x_[k];
  *y = edge_y_[k];
  return true;
}

int
FloorProfile::bin_of (double bearing) const
{
  const int n = params_.bearing_bins;
  const double d = 2 * M_PI / n;
  long k = std::lround (std::floor (bearing / d + 0.5));
  k %= n;
  if (k < 0)
    k += n;
  return (int) k;
}

double
FloorProfile::bin_bearing (int k) const
{
  const int n = params_.bearing_bins;
  double b = k * 2 * M_PI / n;
  return b > M_PI ? b - 2 * M_PI : b;
}

void
FloorProfile::scan (const uint8_t * labels, size_t stride,
    const LabelRole role[256], const std::vector<MarkerBox> *marker_boxes)
{
  const int w = width_, h = height_;
  const int need = params_.min_obstacle_rows;
  const float max_range = (float) params_.max_range;
  /* All columns walk up together, one row at a time: the plane is read
   * row by row (a column-by-column walk reads one byte per cache line and
   * cost 0.66 ms at 640x480, this 0.1 ms). */
  /* All columns walk up together, a row at a time, 16 columns per SSE2
   * step: a column-by-column walk reads one byte per cache line and cost
   * several times more. Per column: the length of the non-floor run
   * ending at the current row (saturating at 255), whether it still
   * walks, and whether its floor has passed max-range. */
  const size_t padded = (w + 15) & ~(size_t) 15;
  run_.assign (padded, 0);
  obst_.assign (padded, 0);
  beyond_.assign (padded, 0);
  walking_.assign (padded, 0);
  marker_edge_.assign (w, -1);
  marker_run_edge_.assign (w, -1);
  ball_.assign (w, 0);
  marker_last_row_.assign (w, -2);
  const float max_marker = (float) params_.max_marker_length;
  end_edge_.assign (w, -1);
  state_.assign (w, FreeState::NotSeen);
  uint8_t obst_of[256], marker_of[256];
  /* the labels that are not obstacles, for SSE2 compares when few */
  uint8_t not_obst[16] = { 0 }, markers[16] = { 0 };
  int n_not_obst = 0, n_markers = 0;
  for (int i = 0; i < 256; i++) {
    obst_of[i] = role[i] == LabelRole::Obstacle ? 0xff : 0;
    marker_of[i] = role[i] == LabelRole::Marker;
    if (role[i] != LabelRole::Obstacle) {
      if (n_not_obst < 16)
        not_obst[n_not_obst] = (uint8_t) i;
      n_not_obst++;
    }
    if (role[i] == LabelRole::Marker && n_markers < 16)
      markers[n_markers++] = (uint8_t) i;
  }
  const bool few = n_not_obst <= 16;
  (void) few;
#ifdef __SSE2__
  __m128i not_obst_v[16], markers_v[16];
  for (int k = 0; k < 16; k++) {
    not_obst_v[k] = _mm_set1_epi8 ((char) not_obst[k]);
    markers_v[k] = _mm_set1_epi8 ((char) markers[k]);
  }
#endif
  int walking = 0;
  for (int u = 0; u < w; u++) {
    walking_[u] = stop_edge_[u] >= 0 ? 0xff : 0;
    walking += stop_edge_[u] >= 0;
  }
  uint8_t *run = run_.data (), *obst = obst_.data ();
  uint8_t *beyond = beyond_.data (), *walk = walking_.data ();
  const uint8_t need8 = (uint8_t) need;
  int v = h - 1;
  for (; v >= 0 && walking > 0; v--) {
    /* row v lies between edges v + 1 (below) and v (above); the columns
     * whose edge v + 1 lies beyond max-range (or the horizon) stop at the
     * first floor pixel from here on */
    for (int k = by_stop_start_[v + 1]; k < by_stop_start_[v + 2]; k++)
      beyond[by_stop_[k]] = 0xff;
    const uint8_t *row = labels + (size_t) v * stride;
    uint8_t any_marker = 0;
    int u0 = 0;
#ifdef __SSE2__
    if (few) {
      /* a handful of floor and marker labels: compare 16 pixels at once
       * instead of 16 table loads */
      __m128i any = _mm_setzero_si128 ();
      for (; u0 + 16 <= w; u0 += 16) {
        const __m128i px = _mm_loadu_si128 ((const __m128i *) (row + u0));
        __m128i free_px = _mm_setzero_si128 (), mark = free_px;
        for (int k = 0; k < n_not_obst; k++)
          free_px = _mm_or_si128 (free_px, _mm_cmpeq_epi8 (px,
                  not_obst_v[k]));
        for (int k = 0; k < n_markers; k++)
          mark = _mm_or_si128 (mark, _mm_cmpeq_epi8 (px, markers_v[k]));
        _mm_storeu_si128 ((__m128i *) (obst + u0), _mm_xor_si128 (free_px,
                _mm_set1_epi8 ((char) 0xff)));
        any = _mm_or_si128 (any, mark);
      }
      any_marker = _mm_movemask_epi8 (any) != 0;
    }
#endif
    for (int u = u0; u < w; u++) {
      obst[u] = obst_of[row[u]];
      any_marker |= marker_of[row[u]];
    }
    if (any_marker && marker_boxes) {
      /* marker colours are floor only inside the given boxes (accepted
       * landmarks); elsewhere something of a marker's colour stands */
      for (int u = 0; u < w; u++) {
        if (!marker_of[row[u]])
          continue;
        bool inside = false;
        for (const MarkerBox & b : *marker_boxes)
          inside = inside || (u >= b.u0 && u < b.u1 && v >= b.v0 &&
              v < b.v1);
        if (!inside)
          obst[u] = 0xff;
      }
    }
    for (const DiscSpan & e : discs_) {
      /* the row's chord of the ellipse: a du^2 + 2 b dv du + c dv^2 = 1 */
      const double dv = v - e.cy;
      const double q = e.b * dv * e.b * dv - e.a * (e.c * dv * dv - 1);
      if (q < 0)
        continue;
      const double root = std::sqrt (q);
      const int lo = std::max (0, (int) std::ceil (e.cx + (-e.b * dv - root)
              / e.a));
      const int hi = std::min (w - 1, (int) std::floor (e.cx + (-e.b * dv +
                  root) / e.a));
      for (int u = lo; u <= hi; u++)
        obst[u] = 0;
    }
    bool finish = false;
#ifdef __SSE2__
    {
      const __m128i one = _mm_set1_epi8 (1), zero = _mm_setzero_si128 ();
      const __m128i needv = _mm_set1_epi8 ((char) need8);
      __m128i fin = zero;
      for (size_t u = 0; u < padded; u += 16) {
        const __m128i o = _mm_loadu_si128 ((const __m128i *) (obst + u));
        __m128i r = _mm_loadu_si128 ((const __m128i *) (run + u));
        r = _mm_and_si128 (_mm_adds_epu8 (r, one), o);
        _mm_storeu_si128 ((__m128i *) (run + u), r);
        const __m128i tall = _mm_cmpeq_epi8 (_mm_max_epu8 (r, needv), r);
        const __m128i left = _mm_and_si128 (_mm_cmpeq_epi8 (r, zero),
            _mm_loadu_si128 ((const __m128i *) (beyond + u)));
        fin = _mm_or_si128 (fin, _mm_and_si128 (_mm_or_si128 (tall, left),
                _mm_loadu_si128 ((const __m128i *) (walk + u))));
      }
      finish = _mm_movemask_epi8 (fin) != 0;
    }
#else
    for (int u = 0; u < w; u++) {
      const uint8_t r = obst[u] ? (uint8_t) (run[u] == 255 ? 255 :
          run[u] + 1) : 0;
      run[u] = r;
      finish |= walk[u] && (r >= need8 || (r == 0 && beyond[u]));
    }
#endif
    if (finish) {
      for (int u = 0; u < w; u++) {
        if (!walk[u])
          continue;
        if (run[u] >= need8) {
          /* the run covers rows v .. v + need - 1: the floor ends at the
           * lower edge of its lowest row */
          walk[u] = 0;
          walking--;
          end_edge_[u] = v + need;
          state_[u] = FreeState::Obstacle;
        } else if (run[u] == 0 && beyond[u]) {
          walk[u] = 0;
          walking--;
          end_edge_[u] = stop_edge_[u];
          state_[u] = FreeState::Free;
        }
      }
    }
    if (any_marker)
      for (int u = 0; u < w; u++) {
        if (!walk[u] || !marker_of[row[u]] || obst[u])
          continue;
        if (marker_edge_[u] < 0)
          marker_edge_[u] = v + 1;
        /* a run of marker pixels: where it began, its length on the floor */
        if (marker_last_row_[u] != v + 1)
          marker_run_edge_[u] = v + 1;
        marker_last_row_[u] = v;
        if (max_marker > 0) {
          const size_t a = (size_t) marker_run_edge_[u] * w + u;
          const size_t b = (size_t) v * w + u;
          const float near = std::hypot (edge_x_[a], edge_y_[a]);
          const float far = std::isnan (edge_x_[b]) ? INFINITY :
              std::hypot (edge_x_[b], edge_y_[b]);
          if (far - near > max_marker) {
            /* longer on the floor than any landmark lying on it: it stands
             * up (a ball); the floor ends at its foot */
            walk[u] = 0;
            walking--;
            end_edge_[u] = marker_run_edge_[u];
            state_[u] = FreeState::Obstacle;
            ball_[u] = 1;
          }
        }
      }
  }
  for (int u = 0; u < w; u++) {
    ColumnBoundary & c = cols_[u];
    c = ColumnBoundary ();
    if (stop_edge_[u] < 0)
      continue;                 /* no floor under the bottom row */
    FreeState state = state_[u];
    int end_edge = end_edge_[u];
    if (walking_[u]) {
      /* walked off the top row */
      if (stop_edge_[u] == 0) {
        /* floor up to the top row, still within max-range: the view ends
         * there (or where a run cut by the border begins) */
        end_edge = run_[u];   /* a run over rows 0 .. run - 1 */
        state = FreeState::ViewEdge;
      } else {
        end_edge = stop_edge_[u];
        state = FreeState::Free;
      }
    }
    if (state == FreeState::Obstacle && end_edge == h)
      continue;                 /* no floor at the bottom: not seen */
    const size_t k = (size_t) end_edge * w + u;
    c.row = (float) end_edge - 0.5f;
    c.x = edge_x_[k];
    c.y = edge_y_[k];
    c.range = std::hypot (c.x, c.y);
    if (state != FreeState::Free && c.range >= max_range)
      state = FreeState::Free;
    if (state == FreeState::Free)
      c.range = max_range;
    c.state = state;
    if (state == FreeState::Obstacle && params_.max_marker_length > 0)
      ball_bulge (labels, stride, role, u, end_edge, !ball_[u], &c);
    const int me = marker_edge_[u];
    if (me >= 0 && me >= end_edge) {
      const size_t m = (size_t) me * w + u;
      c.marker_range = std::hypot (edge_x_[m], edge_y_[m]);
    }
  }
  build_rop ();
}

/* A ball resting on the floor: its foot, where the walk stopped, is the
 * floor point of the lower tangent ray; the top of its pixel run gives the
 * upper tangent. Between the two rays lies the ball: the centre on their
 * bisector, radius r = h / (1 + sin(centre angle) / sin(half angle)) so
 * that the centre is r above the floor. The robot meets its bulge at
 * d - r, nearer than the foot. */
void
FloorProfile::ball_bulge (const uint8_t * labels, size_t stride,
    const LabelRole role[256], int u, int foot_edge, bool shaded,
    ColumnBoundary * c)
{
  const int w = width_;
  const double max_marker = params_.max_marker_length;
  auto role_at = [&](int row) {
    return role[labels[(size_t) row * stride + u]];
  };
  auto edge_range = [&](int edge) {
    const size_t k = (size_t) edge * w + u;
    return std::isnan (edge_x_[k]) ? INFINITY :
        std::hypot (edge_x_[k], edge_y_[k]);
  };
  int row = foot_edge - 1;
  if (shaded) {
    /* the ordinary rule ended the floor: a ball's shaded underside, when
     * marker pixels follow within max-marker-length of the foot */
    while (row >= 0 && role_at (row) != LabelRole::Marker) {
      if (edge_range (row) - c->range > max_marker)
        return;
      row--;
    }
    if (row < 0)
      return;
  }
  int top = row;                /* the run's rows: top .. foot_edge - 1 */
  while (top > 0 && role_at (top - 1) == LabelRole::Marker)
    top--;
  if (top <= 0)
    return;                     /* cut by the image's top: no top tangent */
  const double x_top = edge_range (top);
  if (shaded && !(x_top - c->range > max_marker))
    return;                     /* a disc behind something low */
  const double h = camera_height_;
  const double x_foot = c->range;
  /* the tangent rays' angles below the horizontal (the upper one may
   * point above it: a ball taller than the camera) */
  const double a_foot = std::atan2 (h, x_foot);
  const double a_top = edge_down_[(size_t) top * w + u];
  const double half = (a_foot - a_top) / 2, mid = (a_foot + a_top) / 2;
  if (!(half > 0))
    return;
  const double r = h / (1 + std::sin (mid) / std::sin (half));
  const double d = r / std::sin (half) * std::cos (mid);
  const double bulge = d - r;
  if (!(bulge > 0 && bulge < x_foot))
    return;
  const float scale = (float) (bulge / x_foot);
  c->x *= scale;
  c->y *= scale;
  c->range = (float) bulge;
}

void
FloorProfile::build_rop ()
{
  for (RopBin & b : bins_)
    b = RopBin ();
  auto merge = [&](RopBin & b, const ColumnBoundary & c) {
    if (b.state == FreeState::NotSeen || c.range < b.range) {
      b.state = c.state;
      b.range = c.range;
    }
    if (c.marker_range >= 0 && (b.marker_range < 0 ||
            c.marker_range < b.marker_range))
      b.marker_range = c.marker_range;
  };
  const int n = params_.bearing_bins;
  int prev_bin = -1;
  const ColumnBoundary *prev = nullptr;
  for (int u = 0; u < width_; u++) {
    const ColumnBoundary & c = cols_[u];
    if (c.state == FreeState::NotSeen) {
      prev = nullptr;
      continue;
    }
    /* the bearing of the column's boundary point (Free: of its floor
     * point at max-range) */
    const int k = bin_of (std::atan2 (c.y, c.x));
    merge (bins_[k], c);
    /* bins narrower than the columns' spacing: the bins between two
     * neighbouring columns take the nearer of the two */
    if (prev) {
      int gap = (k - prev_bin + n) % n;
      int step = 1;
      if (gap > n / 2) {
        gap = n - gap;
        step = -1;
      }
      for (int j = 1; j < gap; j++) {
        RopBin & b = bins_[((prev_bin + step * j) % n + n) % n];
        merge (b, c);
        merge (b, *prev);
      }
    }
    prev = &c;
    prev_bin = k;
  }
}

void
FloorProfile::set_landmark_discs (const std::vector<ImageEllipse> & discs)
{
  discs_.clear ();
  for (const ImageEllipse & e : discs) {
    const double ra = e.major / 2 + kDiscRimPixels;
    const double rb = e.minor / 2 + kDiscRimPixels;
    if (!(ra > 0 && rb > 0) || !std::isfinite (e.cx) || !std::isfinite (e.cy)
        || !std::isfinite (e.angle))
      continue;
    const double cs = std::cos (e.angle), sn = std::sin (e.angle);
    const double ia = 1 / (ra * ra), ib = 1 / (rb * rb);
    discs_.push_back ({e.cx, e.cy, cs * cs * ia + sn * sn * ib,
            cs * sn * (ia - ib), sn * sn * ia + cs * cs * ib});
  }
}

void
FloorProfile::stand_balls (const std::vector<RangedBall> & balls)
{
  const int n = params_.bearing_bins;
  const double half_bin = M_PI / n;
  for (const RangedBall & ball : balls) {
    const double d = std::hypot (ball.x, ball.y), r = ball.radius;
    if (!(r > 0) || !(d > r))
      continue;   /* the camera's floor point inside the ball: nonsense */
    const double centre = std::atan2 (ball.y, ball.x);
    const double half_width = std::asin (r / d);
    const int first = bin_of (centre - half_width);
    const int count = (bin_of (centre + half_width) - first + n) % n + 1;
    for (int j = 0; j < count; j++) {
      RopBin & bin = bins_[(first + j) % n];
      if (bin.state == FreeState::NotSeen)
        continue;
      /* the circle's nearest point in the wedge: towards the centre when
       * the wedge holds that bearing, else on the wedge's edge nearer it */
      const double off = std::fabs (std::remainder (centre -
              bin_bearing ((first + j) % n), 2 * M_PI));
      double range = d - r;
      if (off > half_bin) {
        const double across = d * std::sin (off - half_bin);
        if (across >= r)
          continue;
        range = d * std::cos (off - half_bin) - std::sqrt (r * r -
            across * across);
      }
      if (range < bin.range) {
        bin.state = FreeState::Obstacle;
        bin.range = (float) range;
      }
    }
  }
}

/* ---- bird's-eye view -------------------------------------------------- */

bool
birdseye_maps (const CameraGeometry & g, const BirdsEyeParams & b,
    std::vector<float> *map_x, std::vector<float> *map_y,
    std::string * error)
{
  if (!g.configured ()) {
    *error = "the camera geometry is not configured";
    return false;
  }
  if (b.out_w < 1 || b.out_h < 1 || !(b.pixels_per_metre > 0)) {
    *error = "the bird's-eye size and pixels-per-metre must be positive";
    return false;
  }
  const int w = g.params ().width, h = g.params ().height;
  /* far outside: cv::remap's bilinear weights see only the border */
  map_x->assign ((size_t) b.out_w * b.out_h, -10.f);
  map_y->assign ((size_t) b.out_w * b.out_h, -10.f);
  for (int j = 0; j < b.out_h; j++)
    for (int i = 0; i < b.out_w; i++) {
      /* up is forward (+x), left is left (+y) */
      const Vec3 pt {(b.origin_v - j) / b.pixels_per_metre,
        (b.origin_u - i) / b.pixels_per_metre, 0.0};
      double u, v;
      if (!(pt.x > 0) || !g.project (pt, &u, &v))
        continue;
      if (!(u >= -0.5 && u <= w - 0.5 && v >= -0.5 && v <= h - 0.5))
        continue;
      /* a distorted lens folds far points back into the image: only
       * points whose pixel maps back to them are real */
      double bx, by;
      if (!g.pixel_to_plane (u, v, 0.0, &bx, &by) ||
          std::hypot (bx - pt.x, by - pt.y) > 1e-3 * (1 + std::hypot (pt.x,
                  pt.y)))
        continue;
      (*map_x)[(size_t) j * b.out_w + i] = (float) u;
      (*map_y)[(size_t) j * b.out_w + i] = (float) v;
    }
  return true;
}

}  // namespace landmark
