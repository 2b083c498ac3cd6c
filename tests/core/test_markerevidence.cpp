/* Tests of the detection evidence (plugins/landmark/core/shape/markerevidence.h)
 * against analytic geometry: moments of sampled ellipses, the overlap of an
 * ellipse with itself turned a quarter (4ab atan(b/a)), a disc seen
 * straight from above (f d / h), a ball on the optical axis
 * (f tan(asin(r/D))) and a disc ahead projected by a pinhole written out
 * here. */
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "arcfit.h"
#include "blobshape.h"
#include "markerevidence.h"
#include "corecheck.h"

using namespace landmark;

static std::vector<double>
sampled_ellipse (double cx, double cy, double a, double b, double phi, int n)
{
  std::vector<double> uv;
  for (int i = 0; i < n; i++) {
    const double t = 2 * M_PI * i / n;
    const double x = a * std::cos (t), y = b * std::sin (t);
    uv.push_back (cx + x * std::cos (phi) - y * std::sin (phi));
    uv.push_back (cy + x * std::sin (phi) + y * std::cos (phi));
  }
  return uv;
}

static CameraGeometry
pinhole (double hfov, double height, double tilt, int w = 640, int h = 480)
{
  CameraParams p;
  p.width = w;
  p.height = h;
  p.camera_height = height;
  p.tilt_deg = tilt;
  intrinsics_from_hfov (hfov, w, h, &p.fx, &p.fy, &p.cx, &p.cy);
  return corecheck_camera (p);
}

static void
test_boundary_share ()
{
  for (double r : {2.0, 6.0, 40.0}) {
    const double s = ellipse_boundary_share (2 * r, 2 * r);
    CHECK (std::fabs (s - 2 / r) < 1e-12, "circle r %g: %g", r, s);
  }
  CHECK (std::isinf (ellipse_boundary_share (10, 0)), "degenerate");
  /* the tolerances: large blobs near the constants, small ones looser,
   * never below the floors */
  CHECK (std::fabs (shape_fit_threshold (400, 400) - 0.9195) < 1e-3, "%g",
      shape_fit_threshold (400, 400));
  CHECK (shape_fit_threshold (12, 12) < shape_fit_threshold (40, 40),
      "smaller blob, looser shape test");
  CHECK (shape_fit_threshold (1, 0.2) == kShapeFitFloor, "floor");
  /* the marginal band lies below the test and widens with the share */
  CHECK (std::fabs (shape_marginal_threshold (40, 8) - (kShapeFitLarge -
              kShapeMarginalOutlinePx * ellipse_boundary_share (40, 8))) <
      1e-12, "%g", shape_marginal_threshold (40, 8));
  CHECK (shape_fit_threshold (40, 8) - shape_marginal_threshold (40, 8) >
      shape_fit_threshold (400, 400) - shape_marginal_threshold (400, 400),
      "band");
  CHECK (shape_marginal_threshold (1, 0.2) == kShapeFitFloor, "floor");
  ImageEllipse big {0, 0, 400, 400, 0}, small {0, 0, 12, 12, 0};
  CHECK (size_agreement_threshold (big) > 0.68, "%g",
      size_agreement_threshold (big));
  CHECK (size_agreement_threshold (small) < size_agreement_threshold (big),
      "smaller blob, looser size test");
  ImageEllipse tiny {0, 0, 2, 1, 0};
  CHECK (size_agreement_threshold (tiny) == kSizeAgreementFloor, "floor");
}

static void
test_polygon_moments ()
{
  const double phi = 0.3;
  ImageEllipse e;
  CHECK (polygon_moment_ellipse (sampled_ellipse (100, 50, 20, 10, phi,
              720), &e), "ellipse");
  CHECK (std::fabs (e.cx - 100) < 1e-9 && std::fabs (e.cy - 50) < 1e-9,
      "centre %g %g", e.cx, e.cy);
  CHECK (std::fabs (e.major - 40) < 0.01 && std::fabs (e.minor - 20) < 0.01,
      "axes %g %g", e.major, e.minor);
  CHECK (std::fabs (e.angle - phi) < 1e-6, "angle %g", e.angle);
  /* clockwise order gives the same ellipse */
  std::vector<double> cw = sampled_ellipse (0, 0, 20, 10, phi, 720), rev;
  for (size_t i = cw.size () / 2; i-- > 0;) {
    rev.push_back (cw[2 * i]);
    rev.push_back (cw[2 * i + 1]);
  }
  ImageEllipse r;
  CHECK (polygon_moment_ellipse (rev, &r) && std::fabs (r.major - 40) < 0.01,
      "clockwise axes %g", r.major);
  /* a square of side s: variance s^2 / 12, axes 4 sqrt (s^2 / 12) */
  ImageEllipse sq;
  CHECK (polygon_moment_ellipse ({0, 0, 6, 0, 6, 6, 0, 6}, &sq) &&
      std::fabs (sq.major - 4 * std::sqrt (3.0)) < 1e-9 &&
      std::fabs (sq.minor - sq.major) < 1e-9, "square %g %g", sq.major,
      sq.minor);
  CHECK (!polygon_moment_ellipse ({0, 0, 1, 1}, &sq), "two points");
  CHECK (!polygon_moment_ellipse ({0, 0, 1, 1, 2, 2}, &sq), "no area");
}

static void
test_shape_iou ()
{
  ImageEllipse a {0, 0, 40, 20, 0.2};
  CHECK (std::fabs (ellipse_shape_iou (a, a) - 1) < 1e-12, "self");
  ImageEllipse c1 {0, 0, 10, 10, 0}, c2 {5, 5, 20, 20, 1};
  CHECK (std::fabs (ellipse_shape_iou (c1, c2) - 0.25) < 1e-9,
      "circles %g", ellipse_shape_iou (c1, c2));
  /* an ellipse and itself turned a quarter: intersection 4ab atan(b/a) */
  const double sa = 20, sb = 10;
  ImageEllipse b = a;
  b.angle += M_PI / 2;
  const double inter = 4 * sa * sb * std::atan (sb / sa);
  const double expect = inter / (2 * M_PI * sa * sb - inter);
  CHECK (std::fabs (ellipse_shape_iou (a, b) - expect) < 2e-3,
      "quarter turn %g, expected %g", ellipse_shape_iou (a, b), expect);
  ImageEllipse z {0, 0, 10, 0, 0};
  CHECK (ellipse_shape_iou (a, z) == 0, "degenerate");
}

static void
test_disc_from_above ()
{
  /* looking straight down from 0.5 m: a 0.1 m disc right below images as
   * a circle f d / h across */
  CameraGeometry g = pinhole (60, 0.5, 90);
  CHECK (g.configured (), "geometry");
  const double f = 320 / std::tan (M_PI / 6);
  std::vector<double> scratch;
  ImageEllipse e;
  MarkerSpec disc;
  disc.diameter = 0.1;
  CHECK (predict_marker_image (g, disc, 0, 0, 1, 1, &e, &scratch), "disc");
  CHECK (std::fabs (e.major - f * 0.1 / 0.5) < 0.01 * e.major &&
      std::fabs (e.minor - e.major) < 0.01 * e.major, "axes %g %g, expected "
      "%g", e.major, e.minor, f * 0.1 / 0.5);
  CHECK (std::fabs (e.cx - 319.5) < 0.5 && std::fabs (e.cy - 239.5) < 0.5,
      "centre %g %g", e.cx, e.cy);
  /* a frame half the size: half the pixels */
  ImageEllipse h;
  CHECK (predict_marker_image (g, disc, 0, 0, 2, 2, &h, &scratch) &&
      std::fabs (h.major - e.major / 2) < 1e-9, "scaled %g", h.major);
  disc.diameter = 0;
  CHECK (!predict_marker_image (g, disc, 0, 0, 1, 1, &e, &scratch),
      "no diameter");
}

static void
test_ball_on_axis ()
{
  /* a ball whose centre is on the optical axis images as a circle of
   * angular radius asin (r / D) */
  const double h = 0.2, r = 0.04, x = 1.5;
  const double tilt = std::atan2 (h - r, x) * 180 / M_PI;
  CameraGeometry g = pinhole (54, h, tilt);
  const double f = 320 / std::tan (27 * M_PI / 180);
  const double dist = std::hypot (x, h - r);
  const double expect = 2 * f * std::tan (std::asin (r / dist));
  MarkerSpec ball;
  ball.ball = true;
  ball.diameter = 2 * r;
  ball.z = r;
  ImageEllipse e;
  std::vector<double> scratch;
  CHECK (predict_marker_image (g, ball, x, 0, 1, 1, &e, &scratch), "ball");
  CHECK (std::fabs (e.major - expect) < 0.005 * expect &&
      std::fabs (e.minor - expect) < 0.005 * expect,
      "axes %g %g, expected %g", e.major, e.minor, expect);
  /* the camera inside the ball */
  ball.diameter = 2 * h + 1;
  CHECK (!predict_marker_image (g, ball, 0.01, 0, 1, 1, &e, &scratch),
      "camera inside");
}

static void
test_disc_ahead ()
{
  /* the seed's camera: 54 degrees, 0.2 m up, tilted 18 degrees; a 0.1 m
   * disc 1.2 m ahead and 0.3 m left, projected here by the pinhole
   * written out: x' = -y, y' = down the image, z' = the optical axis */
  const double hgt = 0.2, tilt = 18 * M_PI / 180;
  CameraGeometry g = pinhole (54, hgt, 18);
  const double f = 320 / std::tan (27 * M_PI / 180);
  std::vector<double> uv;
  for (int i = 0; i < 2000; i++) {
    const double t = 2 * M_PI * i / 2000;
    const double px = 1.2 + 0.05 * std::cos (t), py = 0.3 + 0.05 *
        std::sin (t), pz = -hgt;
    const double xc = -py;
    const double yc = -std::sin (tilt) * px - std::cos (tilt) * pz;
    const double zc = std::cos (tilt) * px - std::sin (tilt) * pz;
    uv.push_back (f * xc / zc + 319.5);
    uv.push_back (f * yc / zc + 239.5);
  }
  ImageEllipse want, got;
  polygon_moment_ellipse (uv, &want);
  std::vector<double> scratch;
  MarkerSpec disc;
  disc.diameter = 0.1;
  CHECK (predict_marker_image (g, disc, 1.2, 0.3, 1, 1, &got, &scratch),
      "disc ahead");
  CHECK (std::fabs (got.major - want.major) < 0.01 * want.major &&
      std::fabs (got.minor - want.minor) < 0.01 * want.minor &&
      std::fabs (got.cx - want.cx) < 0.3 && std::fabs (got.cy - want.cy) <
      0.3, "predicted %g x %g at (%g, %g), expected %g x %g at (%g, %g)",
      got.major, got.minor, got.cx, got.cy, want.major, want.minor, want.cx,
      want.cy);
  CHECK (ellipse_shape_iou (got, want) > 0.99, "iou %g",
      ellipse_shape_iou (got, want));
  /* the size test: the true marker passes, a speck of a fifth of its size
   * and a blob three times as large fail */
  const double thr = size_agreement_threshold (got);
  ImageEllipse speck = want, large = want;
  speck.major /= 5;
  speck.minor /= 5;
  large.major *= 3;
  large.minor *= 3;
  CHECK (ellipse_shape_iou (want, got) >= thr, "true marker");
  CHECK (ellipse_shape_iou (speck, got) < thr, "speck %g vs %g",
      ellipse_shape_iou (speck, got), thr);
  CHECK (ellipse_shape_iou (large, got) < thr, "large %g vs %g",
      ellipse_shape_iou (large, got), thr);
  /* a stripe as long as the disc is wide but a third as tall */
  ImageEllipse stripe = want;
  stripe.minor = want.minor / 3;
  stripe.major = want.major;
  CHECK (ellipse_shape_iou (stripe, got) < thr, "stripe %g vs %g",
      ellipse_shape_iou (stripe, got), thr);
  /* cut by the frame edge: any smaller part fits, a larger blob not */
  ImageEllipse half = want;
  half.major = want.major / 2;
  CHECK (cut_blob_fits (half, got), "half a marker");
  CHECK (cut_blob_fits (want, got), "the whole marker");
  CHECK (!cut_blob_fits (large, got), "three times as large");
  ImageEllipse tall = want;
  tall.minor = want.major;
  CHECK (!cut_blob_fits (tall, got), "round where the disc is flat");
  /* behind the camera: no image */
  CHECK (!predict_marker_image (g, disc, -1, 0, 1, 1, &got, &scratch),
      "behind");
}

/* The arc test on one blob drawn into a width x height mask: a disc of
 * radius r at (cx, cy), of which the pixels below the line v = keep_below
 * (a ball's shaded side) are cleared, or any shape drawn by the caller. */
static bool
arc_of_mask (const cv::Mat & mask, ArcCircle * arc)
{
  BlobAnalyzer a;
  a.begin (mask.cols, mask.rows);
  a.add_mask_runs (mask, 0, 0, 1);
  a.label ();
  if (a.count () != 1)
    return false;
  BlobShape b;
  a.measure (0, &b);
  ArcCircleFit fit;
  return fit.fit (a.contour (), b, mask.cols, mask.rows, arc);
}

static void
test_arc_circle ()
{
  ArcCircle arc;
  /* the lit upper 60 % of a ball of radius 20: accepted, with the ball's
   * circle (the outline half a pixel inside the edge) to within the rim's
   * tolerance, kArcOutlinePx */
  cv::Mat m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 60), 20, 255, cv::FILLED);
  m.rowRange (68, 120).setTo (0);
  CHECK (arc_of_mask (m, &arc), "lit top refused (coverage %.2f, fill %.2f)",
      arc.coverage, arc.fill);
  CHECK (std::hypot (arc.cx - 80, arc.cy - 60) < kArcOutlinePx &&
      std::fabs (arc.r + 0.5 - 20) < kArcOutlinePx, "circle (%.2f, %.2f) r %.2f",
      arc.cx, arc.cy, arc.r);
  /* a ball whose lower half the frame's edge cuts */
  m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 110), 30, 255, cv::FILLED);
  CHECK (arc_of_mask (m, &arc) && std::fabs (arc.cy - 110) < 1.5,
      "cut ball: cy %.2f", arc.cy);
  /* a ball with a bite out of its side (a leg in front) */
  m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 60), 25, 255, cv::FILLED);
  cv::rectangle (m, cv::Rect (90, 40, 30, 40), 0, cv::FILLED);
  CHECK (arc_of_mask (m, &arc) && std::hypot (arc.cx - 80, arc.cy - 60) <
      1.5, "bitten ball: (%.2f, %.2f)", arc.cx, arc.cy);
  /* a large ball whose lit cap went to another class (a pale ball under
   * a ceiling light): the bite's edge lies inside the circle; the ball's
   * own circle is found (a real frame whose ragged outline let a far
   * larger circle win before is in test_evaluate_images.py) */
  m = cv::Mat::zeros (300, 400, CV_8UC1);
  cv::circle (m, cv::Point (200, 150), 50, 255, cv::FILLED);
  cv::circle (m, cv::Point (212, 108), 28, 0, cv::FILLED);
  CHECK (arc_of_mask (m, &arc) && std::hypot (arc.cx - 200, arc.cy - 150) <
      2 && std::fabs (arc.r + 0.5 - 50) < 2, "ball without its lit cap: "
      "(%.2f, %.2f) r %.2f, coverage %.2f", arc.cx, arc.cy, arc.r,
      arc.coverage);
  /* a ball at the frame's foot, cut by the edge, whose lit top went to
   * another class: its rim lies on both sides of the missing top and
   * goes on behind the edge (each arc alone holds a third of the turn
   * the frame shows, both 0.6 of it); its centre within two tolerance
   * bands (3.5 px each) and its radius within one, as two low side arcs
   * fix its height less well */
  m = cv::Mat::zeros (300, 400, CV_8UC1);
  cv::circle (m, cv::Point (200, 299), 66, 255, cv::FILLED);
  cv::ellipse (m, cv::Point (200, 240), cv::Size (40, 25), 0, 0, 360, 0,
      cv::FILLED);
  m.rowRange (0, 240).setTo (0);
  {
    const bool ok = arc_of_mask (m, &arc);
    CHECK (ok && std::hypot (arc.cx - 200, arc.cy - 299) < 7 &&
        std::fabs (arc.r + 0.5 - 66) < 3.5, "foot ball without its top (%s): "
        "(%.2f, %.2f) r %.2f, coverage %.2f fill %.2f outside %.3f holes "
        "%.3f", ok ? "kept" : "refused", arc.cx, arc.cy, arc.r,
        arc.coverage, arc.fill, arc.outside, arc.holes);
  }
  /* a large ball of which the frame shows a cap a third of its radius
   * deep: an arc of a quarter of the turn (a third was the rule before),
   * about 8 tolerance bands deep (the band 3.5 px, of half the blob's
   * extent), fixes the radius */
  m = cv::Mat::zeros (300, 400, CV_8UC1);
  cv::circle (m, cv::Point (200, 360), 90, 255, cv::FILLED);
  CHECK (arc_of_mask (m, &arc) && std::fabs (arc.r + 0.5 - 90) < 4,
      "shallow cap of a large ball: r %.2f, coverage %.2f", arc.r,
      arc.coverage);
  /* a cap 7 px deep of a circle of radius 90 (under 3.2 bands of 2.6
   * px, the band of half the blob's extent): no radius is fixed, refused */
  m = cv::Mat::zeros (300, 400, CV_8UC1);
  cv::circle (m, cv::Point (200, 383), 90, 255, cv::FILLED);
  CHECK (!arc_of_mask (m, &arc), "a 7 px cap accepted (r %.2f)", arc.r);
  /* a square, an upright and a turned rectangle, a triangle: no arc */
  const std::vector<std::vector<cv::Point>> shapes = {
    {{60, 30}, {100, 30}, {100, 70}, {60, 70}},
    {{40, 50}, {120, 50}, {120, 75}, {40, 75}},
    {{50, 40}, {110, 80}, {95, 102}, {35, 62}},
    {{50, 90}, {110, 90}, {80, 30}},
  };
  for (const auto & poly : shapes) {
    m = cv::Mat::zeros (120, 160, CV_8UC1);
    cv::fillPoly (m, std::vector<std::vector<cv::Point>> {poly}, 255);
    CHECK (!arc_of_mask (m, &arc), "polygon of %zu corners accepted "
        "(coverage %.2f, fill %.2f, r %.1f)", poly.size (), arc.coverage,
        arc.fill, arc.r);
  }
  /* a thin crescent along a rim: fills too little of its circle */
  m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 60), 30, 255, cv::FILLED);
  cv::circle (m, cv::Point (80, 68), 27, 0, cv::FILLED);
  CHECK (!arc_of_mask (m, &arc), "crescent accepted (fill %.2f)", arc.fill);
  /* a ring: its hole is no shaded side */
  m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 60), 25, 255, cv::FILLED);
  cv::circle (m, cv::Point (80, 60), 12, 0, cv::FILLED);
  CHECK (!arc_of_mask (m, &arc), "ring accepted (holes %.2f)", arc.holes);
  /* a small disc: below kArcMinRadius the arc is no evidence */
  m = cv::Mat::zeros (120, 160, CV_8UC1);
  cv::circle (m, cv::Point (80, 60), 8, 255, cv::FILLED);
  m.rowRange (62, 120).setTo (0);
  CHECK (!arc_of_mask (m, &arc), "8 px radius accepted");
  /* the area of a circle inside a frame: pi r^2 inside, a half when the
   * edge runs through its centre */
  CHECK (std::fabs (circle_area_in_frame (80, 60, 20, 160, 120) -
          M_PI * 400) < 0.01 * M_PI * 400, "whole circle's area");
  CHECK (std::fabs (circle_area_in_frame (80, 119.5, 20, 160, 120) -
          M_PI * 200) < 0.03 * M_PI * 200, "half circle's area");
}

int
main ()
{
  test_arc_circle ();
  test_boundary_share ();
  test_polygon_moments ();
  test_shape_iou ();
  test_disc_from_above ();
  test_ball_on_axis ();
  test_disc_ahead ();
  return corecheck_summary ();
}
