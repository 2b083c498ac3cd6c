/* Fuzz target: the camera (calibration) file loader of ipmrange,
 * floorboundary and birdseye, core/geometry/camerafile.cpp load_camera_file
 * (OpenCV FileStorage YAML, XML or JSON, its shape checked before OpenCV
 * parses it in this process). The loader takes a path, so each input is
 * written to one temporary file. An input on which OpenCV's parser hangs
 * or crashes must be refused by the shape check: the run then times out
 * or crashes. What it accepts must be usable: finite, bounded values, and
 * CameraGeometry::configure plus a few projections must run on it (at a
 * small frame size, to keep executions fast). */
#include <glib.h>
#include <glib/gstdio.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "camerafile.h"
#include "camerageometry.h"
#include "fuzzcheck.h"

static std::string tmp_path;

extern "C" int
LLVMFuzzerInitialize (int *, char ***)
{
  gchar *path = nullptr;
  const gint fd = g_file_open_tmp ("fuzz-calibration-XXXXXX.yml", &path,
      nullptr);
  FUZZ_CHECK (fd >= 0, "cannot create a temporary file");
  close (fd);
  tmp_path = path;
  g_free (path);
  atexit ([] { g_unlink (tmp_path.c_str ()); });
  return 0;
}

static void
write_input (const uint8_t * data, size_t size)
{
  FILE *f = fopen (tmp_path.c_str (), "wb");
  FUZZ_CHECK (f != nullptr, "cannot write %s", tmp_path.c_str ());
  FUZZ_CHECK (fwrite (data, 1, size, f) == size, "short write");
  fclose (f);
}

extern "C" int
LLVMFuzzerTestOneInput (const uint8_t * data, size_t size)
{
  write_input (data, size);
  landmark::CameraFile f;
  std::string error;
  const bool ok = landmark::load_camera_file (tmp_path, &f, &error);
  if (!ok) {
    FUZZ_CHECK (error.rfind (tmp_path + ": ", 0) == 0, "error \"%s\"",
        error.c_str ());
    return 0;
  }
  FUZZ_CHECK (f.image_width >= 0 && f.image_height >= 0 &&
      f.image_width <= landmark::kMaxCameraImageSize &&
      f.image_height <= landmark::kMaxCameraImageSize, "image %dx%d",
      f.image_width, f.image_height);
  landmark::CameraParams p;
  p.width = 64;
  p.height = 48;
  if (f.seed) {
    for (double v : {f.camera_height, f.blind_distance, f.view_depth,
            f.half_width})
      FUZZ_CHECK (std::isfinite (v) && v > 0, "seed length %g", v);
    p.model = landmark::CameraModel::Seed;
    p.camera_height = f.camera_height;
    p.blind_distance = f.blind_distance;
    p.view_depth = f.view_depth;
    p.half_width = f.half_width;
  } else {
    FUZZ_CHECK (std::isfinite (f.fx) && std::isfinite (f.fy) && f.fx > 0 &&
        f.fy > 0 && std::isfinite (f.cx) && std::isfinite (f.cy),
        "intrinsics %g %g %g %g", f.fx, f.fy, f.cx, f.cy);
    const size_t nd = f.dist.size ();
    FUZZ_CHECK (nd == 0 || nd == 4 || nd == 5 || nd == 8 || nd == 12 ||
        nd == 14, "%zu distortion coefficients", nd);
    for (double d : f.dist)
      FUZZ_CHECK (std::isfinite (d), "distortion %g", d);
    FUZZ_CHECK (!f.has_tilt || (f.tilt_deg >= -90 && f.tilt_deg <= 90),
        "tilt %g", f.tilt_deg);
    FUZZ_CHECK (!f.has_camera_height || (std::isfinite (f.camera_height) &&
            f.camera_height > 0), "camera height %g", f.camera_height);
    FUZZ_CHECK (!f.has_roll || std::isfinite (f.roll_deg), "roll %g",
        f.roll_deg);
    /* as ipmrange scales a calibration to the frame size */
    const double kx = f.image_width > 0 ? 64.0 / f.image_width : 1.0;
    const double ky = f.image_height > 0 ? 48.0 / f.image_height : 1.0;
    p.fx = f.fx * kx;
    p.fy = f.fy * ky;
    p.cx = (f.cx + 0.5) * kx - 0.5;
    p.cy = (f.cy + 0.5) * ky - 0.5;
    p.dist = f.dist;
    if (f.has_camera_height)
      p.camera_height = f.camera_height;
    if (f.has_tilt)
      p.tilt_deg = f.tilt_deg;
    if (f.has_roll)
      p.roll_deg = f.roll_deg;
  }
  landmark::CameraGeometry g;
  std::string why;
  if (!g.configure (p, &why)) {
    FUZZ_CHECK (!why.empty (), "configure failed without a reason");
    return 0;
  }
  /* the corners and the centre: results are finite when reported */
  const double uv[][2] = { {0, 0}, {63, 0}, {0, 47}, {63, 47}, {32, 24} };
  for (const auto & q : uv) {
    double gx, gy;
    if (g.pixel_to_plane (q[0], q[1], 0.0, &gx, &gy))
      FUZZ_CHECK (std::isfinite (gx) && std::isfinite (gy),
          "floor point %g %g of pixel %g %g", gx, gy, q[0], q[1]);
  }
  return 0;
}
