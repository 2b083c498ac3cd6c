/* Tests of the coded markers' range (plugins/landmark/core/geometry/beaconrange.h)
 * against a pinhole written out here: a beacon and a cone straight ahead of
 * the seed robot's camera (0.2 m up, tilted 18 degrees down, hfov 54,
 * 640x480) at known ranges, whose base's nearest point and silhouette top
 * image on the middle column at cy + fy tan(angle below the horizon -
 * tilt). */
#include <cmath>
#include <cstdio>

#include "beaconrange.h"
#include "corecheck.h"

using namespace landmark;

static const double kHeight = 0.2, kTilt = 18 * M_PI / 180;

/* The image row of a point straight ahead at distance d, height z. */
static double
row_of (const CameraParams & p, double d, double z)
{
  return p.cy + p.fy * std::tan (std::atan2 (kHeight - z, d) - kTilt);
}

static void
test_straight_ahead (const CameraGeometry & g, const CameraParams & p,
    bool cone, double range)
{
  CodedMarkerSize m;
  m.cone = cone;
  m.diameter = cone ? 0.2 : 0.1;
  m.height = cone ? 0.3 : 0.16;
  const double r = m.diameter / 2;
  CodedObservation obs;
  obs.base_u = p.cx;
  obs.base_v = row_of (p, range - r, 0);
  /* the silhouette's top: the apex, or the top's far edge seen from above */
  const double top = cone ? row_of (p, range, m.height) :
      row_of (p, range + r, m.height);
  obs.height_px = obs.base_v - top;
  const RangeEstimate e = estimate_coded_range (g, obs, m, 0.5);
  CHECK (!e.no_floor, "no floor");
  CHECK (std::fabs (e.range_ground - range) < 1e-6, "%s at %.2f: ground "
      "%.6f", cone ? "cone" : "beacon", range, e.range_ground);
  CHECK (std::fabs (e.bearing) < 1e-9, "bearing %.3g", e.bearing);
  CHECK (e.has_size && std::fabs (e.range_size - range) < 1e-4 * range,
      "%s at %.2f: size %.6f", cone ? "cone" : "beacon", range,
      e.range_size);
  /* dR/dv = h / sin^2(a) x cos^2(a - tilt) / fy for the ray a below the
   * horizon through the base point */
  const double a = std::atan2 (kHeight, range - r);
  const double drdv = kHeight / (std::sin (a) * std::sin (a)) *
      std::cos (a - kTilt) * std::cos (a - kTilt) / p.fy;
  CHECK (std::fabs (e.range_ground_sigma - 0.5 * drdv) < 0.02 * 0.5 * drdv,
      "ground sigma %.5f, analytic %.5f", e.range_ground_sigma, 0.5 * drdv);
  CHECK (e.range_size_sigma > 0, "size sigma %.5f", e.range_size_sigma);

  /* the size range follows the height seen: 5 % taller reads nearer */
  obs.height_px *= 1.05;
  const RangeEstimate taller = estimate_coded_range (g, obs, m, 0.5);
  CHECK (taller.has_size && taller.range_size < 0.97 * range &&
      taller.range_size > 0.93 * range, "taller: %.4f", taller.range_size);
  /* cut by the frame: the ground range only */
  obs.whole = false;
  CHECK (!estimate_coded_range (g, obs, m, 0.5).has_size, "cut: a size");
}

int
main ()
{
  CameraParams p;
  p.width = 640;
  p.height = 480;
  p.camera_height = kHeight;
  p.tilt_deg = 18;
  intrinsics_from_hfov (54, 640, 480, &p.fx, &p.fy, &p.cx, &p.cy);
  const CameraGeometry g = corecheck_camera (p);
  for (double range : {0.8, 1.2, 2.0, 3.5}) {
    test_straight_ahead (g, p, false, range);
    test_straight_ahead (g, p, true, range);
  }
  /* the mounting's errors add: a 1 % height error is 1 % of the range */
  CodedMarkerSize m;
  m.diameter = 0.1;
  m.height = 0.16;
  CodedObservation obs;
  obs.base_u = p.cx;
  obs.base_v = row_of (p, 1.15, 0);
  MountingSigma mount;
  mount.height_rel = 0.01;
  const RangeEstimate e = estimate_coded_range (g, obs, m, 0.0, mount);
  CHECK (std::fabs (e.range_ground_sigma - 0.0115) < 1e-4,
      "height sigma %.5f", e.range_ground_sigma);
  return corecheck_summary ();
}
