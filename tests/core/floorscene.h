/* The scene of the floor profile tests (tests/core/test_floorprofile.cpp)
 * and benchmark (tests/bench/floorprofile-bench.cpp): a 640x480 pinhole
 * camera 0.3 m above the floor tilted 25 degrees down, label roles, and
 * label planes ray-cast with the model of docs/conventions.md written out
 * independently of camerageometry.cpp. */
#pragma once

#include "floorprofile.h"
#include "corecheck.h"

#include <cmath>
#include <string>
#include <vector>

using namespace landmark;

static const int W = 640, H = 480;
static const double HFOV = 60, TILT = 25, CAM_H = 0.3;
static const double F = (W / 2.0) / std::tan (HFOV / 2 * M_PI / 180);
static const double CX = (W - 1) / 2.0, CY = (H - 1) / 2.0;

enum : uint8_t { NONE = 0, FLOOR = 1, BOX = 2, MARKER = 3, SHADOW = 4 };

static void
roles (LabelRole r[256])
{
  for (int i = 0; i < 256; i++)
    r[i] = LabelRole::Obstacle;
  r[FLOOR] = LabelRole::Floor;
  r[MARKER] = LabelRole::Marker;
}

/* A floor profile for camera g configured with fp (a refusal is a failed
 * check), and the roles of the labels above. */
struct Scanner
{
  CameraGeometry g;
  FloorProfile prof;
  LabelRole r[256];

  Scanner (const CameraGeometry & camera, const FloorProfileParams & fp)
    : g (camera)
  {
    roles (r);
    configure (fp);
  }

  void configure (const FloorProfileParams & fp)
  {
    std::string err;
    CHECK (prof.configure (g, fp, &err), "%s", err.c_str ());
  }
};

/* roll of the camera the tests ray-cast with, degrees */
static double roll_deg = 0;

static CameraGeometry
camera ()
{
  CameraParams p;
  p.roll_deg = roll_deg;
  p.width = W;
  p.height = H;
  p.camera_height = CAM_H;
  p.tilt_deg = TILT;
  p.fx = p.fy = F;
  p.cx = CX;
  p.cy = CY;
  return corecheck_camera (p);
}

/* The ray of pixel (u, v), robot frame (tilt only, roll 0). */
static void
ray (double u, double v, double d[3])
{
  const double t = TILT * M_PI / 180, r = roll_deg * M_PI / 180;
  const double xn = (u - CX) / F, yn = (v - CY) / F;
  /* x_c = (0,-1,0), y_c = (-sin t, 0, -cos t), z_c = (cos t, 0, -sin t);
   * roll turns x_c, y_c about z_c */
  const double xc[3] = {0, -1, 0}, yc[3] = {-std::sin (t), 0, -std::cos (t)},
      zc[3] = {std::cos (t), 0, -std::sin (t)};
  for (int k = 0; k < 3; k++) {
    const double x2 = std::cos (r) * xc[k] + std::sin (r) * yc[k];
    const double y2 = -std::sin (r) * xc[k] + std::cos (r) * yc[k];
    d[k] = xn * x2 + yn * y2 + zc[k];
  }
}

/* Calls f (u, v, d) for every pixel whose ray d points down. */
template <typename F>
static void
each_downward_ray (F f)
{
  for (int v = 0; v < H; v++)
    for (int u = 0; u < W; u++) {
      double d[3];
      ray (u, v, d);
      if (d[2] < 0)
        f (u, v, d);
    }
}

/* A box standing on the floor: front face at x = x0, y in [y0, y1],
 * z in [0, top], depth along x. */
struct Box {
  double x0, y0, y1, top, depth;
};

/* Ray-casts the label of each pixel centre: the box when its front face or
 * top is hit before the floor, floor below the horizon, NONE above. */
static std::vector<uint8_t>
render (const std::vector<Box> & boxes)
{
  std::vector<uint8_t> plane ((size_t) W * H, NONE);
  for (int v = 0; v < H; v++)
    for (int u = 0; u < W; u++) {
      double d[3];
      ray (u, v, d);
      double t_floor = d[2] < 0 ? CAM_H / -d[2] : INFINITY;
      uint8_t label = std::isfinite (t_floor) ? FLOOR : NONE;
      double best = t_floor;
      for (const Box & b : boxes) {
        if (d[0] > 0) {
          const double t = b.x0 / d[0];
          const double y = t * d[1], z = CAM_H + t * d[2];
          if (t < best && y >= b.y0 && y <= b.y1 && z >= 0 && z <= b.top) {
            best = t;
            label = BOX;
          }
        }
        if (d[2] < 0 && b.top < CAM_H) {
          const double t = (b.top - CAM_H) / d[2];
          const double x = t * d[0], y = t * d[1];
          if (t < best && x >= b.x0 && x <= b.x0 + b.depth && y >= b.y0 &&
              y <= b.y1) {
            best = t;
            label = BOX;
          }
        }
      }
      plane[(size_t) v * W + u] = label;
    }
  return plane;
}
