/* The bird's-eye view's drawings (birdseye, docs/birdseye.md): the floor
 * boundary and free space, the ranged landmarks and the robot, in
 * robot-frame metres at the view's scale, with the primitives and colours
 * of the overlay (overlaydraw.cpp). */
#include "overlaydraw.h"

#include <algorithm>
#include <cmath>

#include "overlayinternal.h"

namespace landmark {
namespace overlay {

using namespace internal;

namespace {

/* a bin that shows free floor up to a known range */
inline bool
bin_seen (const Floor & f, int b)
{
  return f.rop_state[b] != 0 && f.rop_range[b] > 0 &&
      std::isfinite (f.rop_range[b]);
}

}  // namespace

void
Renderer::push_point (cv::Point2d p, double min_step)
{
  const size_t n = pts_.size ();
  if (n >= 2 && std::hypot (pts_[n - 1].x - pts_[n - 2].x,
          pts_[n - 1].y - pts_[n - 2].y) < min_step)
    pts_[n - 1] = p;
  else
    pts_.push_back (p);
}

void
Renderer::draw_floor_boundary (const Floor & f, const FloorView & v)
{
  if (canvas_.empty ())
    return;
  const int thick = st_.line;
  constexpr double kMinStep = 3;  /* pixels */
  if (f.bins > 0 && f.rop_range && f.rop_state && f.bin_width > 0 &&
      std::isfinite (f.bin_width)) {
    /* the free space: from an unseen bin round the circle, each run of
     * seen bins as a line from the robot out to its first bin, the bins'
     * edges at their ranges, and back; all seen: one closed line. Drawn
     * in pieces, each painted on its own, so that a wedge's paint does not
     * sweep its whole inside. */
    int first = 0;
    while (first < f.bins && bin_seen (f, first))
      first++;
    const bool all = first == f.bins;
    const cv::Point2d robot = v.to_px (0, 0);
    auto edge = [&](int b, int side) {
      const double phi = (b + 0.5 * side) * f.bin_width;
      const double r = f.rop_range[b];
      return v.to_px (r * std::cos (phi), r * std::sin (phi));
    };
    auto piece = [&](bool closed) {
      if (pts_.size () >= 2) {
        polyline (pts_.data (), (int) pts_.size (), closed, kBlack, 150,
            thick + 2, false);
        polyline (pts_.data (), (int) pts_.size (), closed, kFreeSpace, 255,
            thick, false);
      }
      pts_.clear ();
    };
    pts_.clear ();
    for (int k = 0; k < f.bins; k++) {
      const int b = (first + k) % f.bins;
      if (!bin_seen (f, b))
        continue;
      if (!all && !bin_seen (f, (b + f.bins - 1) % f.bins)) {
        pts_.push_back (robot);
        pts_.push_back (edge (b, -1));
        piece (false);
      }
      push_point (edge (b, -1), kMinStep);
      push_point (edge (b, 1), kMinStep);
      if (!all && !bin_seen (f, (b + 1) % f.bins)) {
        piece (false);
        pts_.push_back (edge (b, 1));
        pts_.push_back (robot);
        piece (false);
      }
    }
    piece (all);
    /* where an obstacle ends a bin, its arc in red */
    for (int b = 0; b < f.bins; b++)
      if (bin_seen (f, b) && f.rop_state[b] == 2)
        cover_segment (edge (b, -1), edge (b, 1), thick / 2.0 + 0.5);
    paint (kFloorObstacle, 255);
  }
  if (f.width > 0 && f.boundary_row && f.boundary_state && f.boundary_x &&
      f.boundary_y)
    boundary_runs (f, &v);
}

void
Renderer::draw_floor_landmark (const Detection & d, double diameter,
    const FloorView & v)
{
  if (canvas_.empty () || !d.has_ground || !std::isfinite (d.ground_x) ||
      !std::isfinite (d.ground_y))
    return;
  const cv::Point2d c = v.to_px (d.ground_x, d.ground_y);
  const double r = diameter > 0 && std::isfinite (diameter) ?
      diameter / 2 * v.pixels_per_metre : std::max (2.0, 3 * st_.g);
  fill_circle (c, r + 1, kBlack, 200);
  fill_circle (c, r, d.colour, 255);
  if (d.has_match && d.matched && d.landmark_id)
    text (d.landmark_id, iround (c.x + r + 3), iround (c.y + st_.ascent / 2.0),
        kWhite, 230);
}

void
Renderer::draw_floor_robot (const FloorView & v, const cv::Point2d * fov,
    const int *run_lengths, int n_runs)
{
  if (canvas_.empty ())
    return;
  const cv::Point2d *p = fov;
  for (int i = 0; i < n_runs; p += run_lengths[i], i++) {
    /* near the robot an edge's points crowd */
    pts_.clear ();
    for (int k = 0; k < run_lengths[i]; k++)
      push_point (p[k], 4);
    polyline (pts_.data (), (int) pts_.size (), false, kBlack, 150,
        st_.line + 2, true);
    polyline (pts_.data (), (int) pts_.size (), false, kWhite, 220, st_.line,
        true);
  }
  /* the camera's floor point, and a triangle standing on it, pointing
   * forward (up) */
  const cv::Point2d o = v.to_px (0, 0);
  const double len = std::max (8.0, 14 * st_.g);
  const cv::Point2d tri[3] = { { o.x, o.y - len }, { o.x - 0.45 * len, o.y },
    { o.x + 0.45 * len, o.y }
  };
  fill_poly (tri, 3, kWhite, 255);
  polyline (tri, 3, true, kBlack, 255, 1, false);
  fill_circle (o, std::max (1.5, 2 * st_.g), kFloorObstacle, 255);
}

}  // namespace overlay
}  // namespace landmark
