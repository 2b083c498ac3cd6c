/* The parts of the overlay (detections and their labels, pose, class
 * panel, floor boundary, mini-map), drawn with the primitives of
 * overlaydraw.cpp. */
#include "overlaydraw.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "overlayinternal.h"

namespace landmark {
namespace overlay {

using namespace internal;

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

  /* outline: the fitted ellipse (a coded marker's box), mapped from the
   * analysed frame to this one (pixel centres: u' = (u + 0.5) sx - 0.5),
   * else the bounding box */
  pts_.clear ();
  double cx, cy;
  if (d.has_ellipse && (d.ellipse_major > 0 || d.ellipse_minor > 0)) {
    const double a = d.ellipse_major / 2, b = d.ellipse_minor / 2;
    const double ca = std::cos (d.ellipse_angle),
        sa = std::sin (d.ellipse_angle);
    /* a coded marker's box: its corners at (+-1, +-1) of the axes */
    const int n = d.coded ? 4 : kEllipsePoints;
    for (int i = 0; i < n; i++) {
      const double t = 2 * M_PI * i / n + (d.coded ? M_PI / 4 : 0);
      const double k = d.coded ? M_SQRT2 : 1.0;
      const double u = d.ellipse_x + k * (a * std::cos (t) * ca -
          b * std::sin (t) * sa);
      const double v = d.ellipse_y + k * (a * std::cos (t) * sa +
          b * std::sin (t) * ca);
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
pose_line_text (const Pose & pose, bool compact, char *out, size_t size)
{
  const double degrees = pose.heading * 180.0 / M_PI;
  if (compact)
    snprintf (out, size, "%.2f %.2f %.0fd", pose.x, pose.y, degrees);
  else
    snprintf (out, size, "pose x %.3f m  y %.3f m  heading %.1f deg",
        pose.x, pose.y, degrees);
}

void
Renderer::draw_pose_text (const Pose & pose)
{
  if (canvas_.empty ())
    return;
  char s[128];
  pose_line_text (pose, false, s, sizeof (s));
  int tw = text_width (s);
  if (tw + 2 * st_.pad > width_ - 2 * st_.margin) {
    /* a narrow frame: the short form */
    pose_line_text (pose, true, s, sizeof (s));
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
  boundary_runs (f, nullptr);
}

void
Renderer::boundary_runs (const Floor & f, const FloorView * view)
{
  /* label plane to frame: pixel centres on integers in both */
  const double sx = (double) width_ / f.width, sy = (double) height_ / f.height;
  const int thick = st_.line + 1;
  auto seen = [&](int e) {
    if (f.boundary_state[e] == 0 || !(f.boundary_row[e] >= 0))
      return false;
    return !view || (std::isfinite (f.boundary_x[e]) &&
        std::isfinite (f.boundary_y[e]));
  };
  auto at = [&](int e) {
    return view ? view->to_px (f.boundary_x[e], f.boundary_y[e]) :
        cv::Point2d ((e + 0.5) * sx - 0.5, (f.boundary_row[e] + 0.5) * sy -
        0.5);
  };
  /* runs of seen columns in one colour, each a polyline on a dark halo */
  for (int pass = 0; pass < 2; pass++) {
    int c = 0;
    while (c < f.width) {
      if (!seen (c)) {
        c++;
        continue;
      }
      const bool obstacle = f.boundary_state[c] == 2;
      pts_.clear ();
      int e = c;
      for (; e < f.width; e++) {
        if (!seen (e) || (f.boundary_state[e] == 2) != obstacle)
          break;
        if (view)
          push_point (at (e), 3);  /* columns are denser than pixels */
        else
          pts_.push_back (at (e));
      }
      /* a lone column: a short horizontal dash across its width (on the
       * floor: a dot) */
      if (pts_.size () == 1) {
        const cv::Point2d m = pts_[0];
        const double half = view ? 0 : sx / 2;
        pts_[0].x = m.x - half;
        pts_.emplace_back (m.x + half, m.y);
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

EllipseAxes
covariance_ellipse (const double cov[4], double chi2)
{
  EllipseAxes e;
  for (int i = 0; i < 4; i++)
    if (!std::isfinite (cov[i]))
      return e;
  const double scale = std::max (std::fabs (cov[0]), std::fabs (cov[3]));
  if (!(chi2 > 0) || std::fabs (cov[1] - cov[2]) > 1e-9 * scale + 1e-300)
    return e;
  /* OpenCV's symmetric eigen-decomposition: values in descending order,
   * vectors as rows */
  const cv::Matx22d p (cov[0], cov[1], cov[2], cov[3]);
  cv::Matx21d values;
  cv::Matx22d vectors;
  if (!cv::eigen (p, values, vectors) || values (1) < -1e-12 * scale)
    return e;
  e.ok = true;
  e.major = std::sqrt (chi2 * std::max (values (0), 0.0));
  e.minor = std::sqrt (chi2 * std::max (values (1), 0.0));
  e.angle = std::atan2 (vectors (0, 1), vectors (0, 0));
  return e;
}

/* The outline of a 95 % ellipse around (x, y) in world metres, mapped to
 * panel pixels by to_px, into pts. */
template <typename ToPx>
static void
ellipse_outline (double x, double y, const double cov[4], ToPx to_px,
    std::vector<cv::Point2d> & pts)
{
  pts.clear ();
  const EllipseAxes e = covariance_ellipse (cov);
  if (!e.ok)
    return;
  const double ca = std::cos (e.angle), sa = std::sin (e.angle);
  for (int i = 0; i < kEllipsePoints; i++) {
    const double t = 2 * M_PI * i / kEllipsePoints;
    const double along = e.major * std::cos (t), across = e.minor * std::sin (t);
    pts.push_back (to_px (x + along * ca - across * sa,
            y + along * sa + across * ca));
  }
}

void
Renderer::draw_minimap (const LandmarkMap & map, const Rgb * colours,
    const Pose & pose, const Detection * dets, int n_dets,
    const Floor * free_space, const Estimate * estimate)
{
  const bool floor = free_space && free_space->bins > 0 &&
      free_space->rop_range && free_space->rop_state;
  const int n_est = estimate ? estimate->n : 0;
  if (canvas_.empty () || (map.landmarks.empty () && !floor && n_est == 0))
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
  for (int i = 0; i < n_est; i++) {
    const EstimatedLandmark & lm = estimate->landmarks[i];
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

  /* the estimate: each landmark's 95 % ellipse in its class colour over a
   * dark halo, solid and with a filled dot when confirmed, dashed with a
   * ring when tentative; the pose's ellipse in white */
  for (int i = 0; i < n_est; i++) {
    const EstimatedLandmark & lm = estimate->landmarks[i];
    const cv::Point2d c = to_px (lm.x, lm.y);
    const double r = std::max (1.5, 2 * g);
    ellipse_outline (lm.x, lm.y, lm.cov, to_px, pts_);
    if (!pts_.empty ()) {
      polyline (pts_.data (), (int) pts_.size (), true, kBlack, 150, thin + 2,
          !lm.confirmed);
      polyline (pts_.data (), (int) pts_.size (), true, lm.colour, 255, thin,
          !lm.confirmed);
    }
    if (lm.confirmed) {
      fill_circle (c, r + 1, kBlack, 200);
      fill_circle (c, r, lm.colour, 255);
    } else {
      circle (c, r, kBlack, 200, thin + 2);
      circle (c, r, lm.colour, 255, thin);
    }
  }
  if (estimate && estimate->has_pose_cov) {
    ellipse_outline (pose.x, pose.y, estimate->pose_cov, to_px, pts_);
    if (!pts_.empty ()) {
      polyline (pts_.data (), (int) pts_.size (), true, kBlack, 150, thin + 2,
          false);
      polyline (pts_.data (), (int) pts_.size (), true, kWhite, 230, thin,
          false);
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

}  // namespace overlay
}  // namespace landmark
