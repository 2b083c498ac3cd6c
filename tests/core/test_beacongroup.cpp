/* Tests of the coded-marker finder (plugins/landmark/core/shape/beacongroup.h)
 * on label planes drawn here: stacked rectangles (a cylinder's side),
 * rolled, reversed, cut by the frame, ellipses (discs) that stack but are
 * no cylinder, a cone's triangle over a trapezoid, a code the map lacks. */
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "beacongroup.h"
#include "corecheck.h"

using namespace landmark;

enum { PINK = 1, YELLOW = 2, BLUE = 3 };

static LandmarkMap
test_map ()
{
  LandmarkMap map;
  std::string err;
  const bool ok = map_parse (R"({"landmarks": [
    {"id": "B1", "kind": "beacon", "x": 1, "y": 0, "diameter": 0.1,
     "height": 0.2, "bands": ["pink", "yellow"]},
    {"id": "B2", "kind": "beacon", "x": 1, "y": 1, "diameter": 0.1,
     "height": 0.2, "bands": ["yellow", "pink"]},
    {"id": "C1", "kind": "cone", "x": 2, "y": 0, "diameter": 0.2,
     "height": 0.3, "bands": ["blue", "yellow"], "band-heights": [0.15, 0.15]},
    {"id": "L1", "class": "pink", "x": 0, "y": 0, "diameter": 0.1}]})",
      "test.json", &map, &err);
  CHECK (ok, "map: %s", err.c_str ());
  return map;
}

/* A band as a rectangle of w x h pixels whose top middle is (u, v), the
 * whole turned by roll degrees about (pu, pv). */
static void
band (cv::Mat & img, int label, double u, double v, double w, double h,
    double roll = 0, double pu = 0, double pv = 0)
{
  const double r = roll * M_PI / 180, c = std::cos (r), s = std::sin (r);
  const double xs[4] = { u - w / 2, u + w / 2, u + w / 2, u - w / 2 };
  const double ys[4] = { v, v, v + h, v + h };
  cv::Point p[4];
  for (int k = 0; k < 4; k++) {
    const double x = xs[k] - pu, y = ys[k] - pv;
    p[k] = cv::Point ((int) std::lround (pu + c * x - s * y),
        (int) std::lround (pv + s * x + c * y));
  }
  cv::fillConvexPoly (img, p, 4, cv::Scalar (label));
}

/* Two bands of w x h pixels stacked, the upper one's top middle at (u, v):
 * a two-band marker, the whole turned by roll degrees about the joint. */
static void
two_bands (cv::Mat & img, int upper, int lower, double u, double v, double w,
    double h, double roll = 0)
{
  band (img, upper, u, v, w, h, roll, u, v + h);
  band (img, lower, u, v + h, w, h, roll, u, v + h);
}

/* A cone 60 px tall, 40 px wide at its base: a triangle of label tip over
 * a trapezoid of label base. */
static void
cone (cv::Mat & img, int tip, int base)
{
  const cv::Point triangle[3] = { {160, 100}, {170, 130}, {150, 130} };
  const cv::Point trapezoid[4] = { {150, 131}, {170, 131}, {180, 160},
    {140, 160} };
  cv::fillConvexPoly (img, triangle, 3, cv::Scalar (tip));
  cv::fillConvexPoly (img, trapezoid, 4, cv::Scalar (base));
}

/* Finds markers in img: the one detection, or null (a failed check). */
static const BeaconDetection *
only (BeaconFinder & f, const cv::Mat & img, const BeaconParams & p)
{
  f.find (img, p);
  CHECK (f.count () == 1, "%zu detections, expected 1", f.count ());
  return f.count () == 1 ? &f.detection (0) : nullptr;
}

static void
test_upright_and_reversed (BeaconFinder & f, const BeaconParams & p)
{
  for (int reversed = 0; reversed < 2; reversed++) {
    cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
    two_bands (img, reversed ? YELLOW : PINK, reversed ? PINK : YELLOW, 160,
        100, 20, 16);
    const BeaconDetection *d = only (f, img, p);
    if (!d)
      continue;
    CHECK (d->marker == reversed, "named %d, expected %d", d->marker,
        reversed);
    CHECK (d->reject == nullptr, "rejected: %s", d->reject);
    CHECK (d->n_bands == 2, "%d bands", d->n_bands);
    /* the box of the drawn pixels: rows 100..132, columns 150..170 */
    CHECK (std::fabs (d->top_v - 99.5) < 0.6, "top v %.2f", d->top_v);
    CHECK (std::fabs (d->base_v - 132.5) < 0.6, "base v %.2f", d->base_v);
    CHECK (std::fabs (d->base_u - 160) < 0.6, "base u %.2f", d->base_u);
    CHECK (std::fabs (d->height_px - 33) < 1.2, "height %.2f",
        d->height_px);
    CHECK (std::fabs (d->width_px - 21) < 1.2, "width %.2f", d->width_px);
    CHECK (d->bands[0].fill > 0.95, "fill %.3f", d->bands[0].fill);
  }
}

static void
test_roll (BeaconFinder & f, BeaconParams p)
{
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
  two_bands (img, PINK, YELLOW, 160, 80, 20, 30, 12);
  const BeaconDetection *d = only (f, img, p);
  if (d) {
    CHECK (d->marker == 0 && !d->reject, "rolled: marker %d, %s",
        d->marker, d->reject ? d->reject : "kept");
    const double roll = std::atan2 (-d->axis_u, d->axis_v) * 180 / M_PI;
    CHECK (std::fabs (roll - 12) < 1.5, "axis roll %.2f", roll);
    CHECK (std::fabs (d->height_px - 61) < 2, "height %.2f", d->height_px);
  }
  p.max_roll_deg = 8;
  f.find (img, p);
  /* not stacked within 8 degrees: two lone bands, neither a code */
  CHECK (f.count () == 0, "%zu detections at max-roll 8", f.count ());
}

static void
test_unknown_code_and_partial (BeaconFinder & f, const BeaconParams & p)
{
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
  two_bands (img, PINK, BLUE, 100, 100, 20, 16);
  const BeaconDetection *d = only (f, img, p);
  if (d)
    CHECK (d->marker < 0 && d->reject && std::string (d->reject) == "code"
        && d->candidates.empty (), "pink/blue read as %d", d->marker);

  /* a lone pink band cut by the bottom edge: the top of pink/yellow */
  img.setTo (0);
  band (img, PINK, 100, 225, 20, 30);
  d = only (f, img, p);
  if (d)
    CHECK (d->marker < 0 && d->candidates.size () == 1 &&
        d->candidates[0] == 0 && std::string (d->reject) == "partial",
        "cut pink: marker %d, %zu candidates", d->marker,
        d->candidates.size ());

  /* ... and a lone pink band in the open is no coded marker */
  img.setTo (0);
  band (img, PINK, 100, 100, 20, 16);
  f.find (img, p);
  CHECK (f.count () == 0, "lone pink: %zu detections", f.count ());
}

/* a far marker's band touching the top of a near one: the chain reads
 * blue/pink/yellow, no code; its lower two bands are pink/yellow */
static void
test_band_of_another_marker_on_top (BeaconFinder & f, const BeaconParams & p)
{
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
  band (img, BLUE, 160, 88, 14, 12);
  two_bands (img, PINK, YELLOW, 160, 100, 20, 16);
  const BeaconDetection *d = only (f, img, p);
  if (d)
    CHECK (d->marker == 0 && !d->reject && d->n_bands == 2 &&
        std::fabs (d->top_v - 99.5) < 0.6, "marker %d, %d bands, top %.1f",
        d->marker, d->n_bands, d->top_v);
}

static void
test_discs_are_no_beacon (BeaconFinder & f, const BeaconParams & p)
{
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
  /* two discs on the floor, one behind the other: flat ellipses */
  cv::ellipse (img, cv::Point (160, 100), cv::Size (20, 6), 0, 0, 360,
      cv::Scalar (PINK), -1);
  cv::ellipse (img, cv::Point (160, 112), cv::Size (20, 6), 0, 0, 360,
      cv::Scalar (YELLOW), -1);
  const BeaconDetection *d = only (f, img, p);
  if (d)
    CHECK (d->marker == 0 && d->reject && std::string (d->reject) ==
        "shape", "ellipses: %s", d->reject ? d->reject : "kept");
  /* a cone's triangle over its trapezoid in a beacon's colours: the
   * triangle fills half its box */
  img.setTo (0);
  cone (img, PINK, YELLOW);
  d = only (f, img, p);
  if (d)
    CHECK (d->marker == 0 && d->reject && std::string (d->reject) ==
        "shape", "triangle as a beacon: %s, fill %.3f",
        d->reject ? d->reject : "kept", d->bands[0].fill);
}

static void
test_cone (BeaconFinder & f, const BeaconParams & p)
{
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (0));
  cone (img, BLUE, YELLOW);
  const BeaconDetection *d = only (f, img, p);
  if (d) {
    CHECK (d->marker == 2 && !d->reject, "cone: marker %d, %s", d->marker,
        d->reject ? d->reject : "kept");
    CHECK (std::fabs (d->width_px - 41) < 1.5, "cone base %.2f",
        d->width_px);
  }
}

int
main ()
{
  const LandmarkMap map = test_map ();
  const std::vector<BeaconSpec> specs = beacon_specs (map,
      {"pink", "yellow", "blue"});
  CHECK (specs.size () == 3, "%zu specs", specs.size ());
  CHECK (specs[0].marker.code == "pink/yellow" && specs[0].labels ==
      std::vector<int> ({PINK, YELLOW}), "B1 %s", specs[0].marker.code.c_str ());
  const std::vector<BeaconSpec> missing = beacon_specs (map, {"pink"});
  CHECK (missing[0].labels[1] == 0, "yellow not in the labels: label 0");

  BeaconFinder f;
  f.set_specs (specs);
  BeaconParams p;
  test_upright_and_reversed (f, p);
  test_roll (f, p);
  test_unknown_code_and_partial (f, p);
  test_band_of_another_marker_on_top (f, p);
  test_discs_are_no_beacon (f, p);
  test_cone (f, p);

  /* no coded marker in the map: nothing searched, nothing found */
  BeaconFinder none;
  none.set_specs ({});
  cv::Mat img (240, 320, CV_8UC1, cv::Scalar (PINK));
  none.find (img, p);
  CHECK (none.empty () && none.count () == 0, "empty map");
  return corecheck_summary ();
}
