#include "camerasetup.h"

#include <cmath>

#include "camerafile.h"
#include "fileutil.h"

namespace landmark {

/* frame size assumed to check a geometry before the caps are known */
static constexpr int kNominalWidth = 640, kNominalHeight = 480;

bool
camera_setup_params (const CameraSetup & c, int width, int height,
    CameraParams * p, const char **property, std::string * why)
{
  const CameraSettings & s = c.e;
  *p = CameraParams ();
  p->width = width;
  p->height = height;
  p->camera_height = s.camera_height;
  if (s.seed) {
    p->model = CameraModel::Seed;
    p->blind_distance = s.blind_distance;
    p->view_depth = s.view_depth;
    p->half_width = s.half_width;
    return true;
  }
  p->model = CameraModel::Pinhole;
  p->tilt_deg = s.tilt_deg;
  p->roll_deg = s.roll_deg;
  if (c.have_calibration) {
    /* the file's intrinsics scaled to the frame (pixel-centre convention) */
    const double kx = c.calib_w > 0 ? (double) width / c.calib_w : 1.0;
    const double ky = c.calib_h > 0 ? (double) height / c.calib_h : 1.0;
    p->fx = c.cal_fx * kx;
    p->fy = c.cal_fy * ky;
    p->cx = (c.cal_cx + 0.5) * kx - 0.5;
    p->cy = (c.cal_cy + 0.5) * ky - 0.5;
    p->dist = c.cal_dist;
  } else if (s.fx > 0) {
    p->fx = s.fx;
    p->fy = s.fy > 0 ? s.fy : s.fx;
    p->cx = s.cx >= 0 ? s.cx : (width - 1) / 2.0;
    p->cy = s.cy >= 0 ? s.cy : (height - 1) / 2.0;
  } else if (!intrinsics_from_hfov (s.hfov_deg, width, height, &p->fx,
          &p->fy, &p->cx, &p->cy)) {
    *property = "hfov";
    *why = "the horizontal field of view must be within (0, 180) degrees, "
        "got " + number_text (s.hfov_deg);
    return false;
  }
  return true;
}

bool
camera_setup_resolve (const CameraSettings & s, CameraSetup * out,
    const char **property, std::string * why)
{
  *out = CameraSetup ();
  out->e = s;
  CameraSettings & e = out->e;
  if (!s.calibration.empty ()) {
    CameraFile f;
    std::string err;
    if (!load_camera_file (s.calibration, &f, &err)) {
      *property = "calibration";
      *why = err;
      return false;
    }
    out->calib_w = f.image_width;
    out->calib_h = f.image_height;
    if (f.seed) {
      e.seed = true;
      e.camera_height = f.camera_height;
      e.blind_distance = f.blind_distance;
      e.view_depth = f.view_depth;
      e.half_width = f.half_width;
    } else {
      e.seed = false;
      out->have_calibration = true;
      out->cal_fx = f.fx;
      out->cal_fy = f.fy;
      out->cal_cx = f.cx;
      out->cal_cy = f.cy;
      out->cal_dist = f.dist;
      if (f.has_camera_height)
        e.camera_height = f.camera_height;
      if (f.has_tilt)
        e.tilt_deg = f.tilt_deg;
      out->calib_has_tilt = f.has_tilt;
      if (f.has_roll)
        e.roll_deg = f.roll_deg;
    }
  }
  if (!(e.camera_height > 0)) {
    *property = "camera-height";
    *why = "the camera height must be positive, got " +
        number_text (e.camera_height);
    return false;
  }
  if (!e.seed) {
    if (!(e.hfov_deg > 0 && e.hfov_deg < 180) && e.fx <= 0 &&
        !out->have_calibration) {
      *property = "hfov";
      *why = "the horizontal field of view must be within (0, 180) "
          "degrees, got " + number_text (e.hfov_deg);
      return false;
    }
    if (!(e.tilt_deg >= -90 && e.tilt_deg <= 90)) {
      *property = "tilt";
      *why = "the tilt must be within [-90, 90] degrees, got " +
          number_text (e.tilt_deg);
      return false;
    }
  } else if (!(e.view_depth > 0) || !(e.half_width > 0)) {
    *property = e.view_depth > 0 ? "half-width" : "view-depth";
    *why = "model=angle-linear needs view-depth > 0 and half-width > 0, got " +
        number_text (e.view_depth) + " and " + number_text (e.half_width);
    return false;
  }
  CameraParams p;
  const int w = out->calib_w > 0 ? out->calib_w : kNominalWidth;
  const int h = out->calib_h > 0 ? out->calib_h : kNominalHeight;
  if (!camera_setup_params (*out, w, h, &p, property, why))
    return false;
  CameraGeometry g;
  std::string err;
  if (!g.configure (p, &err)) {
    const bool from_file = !s.calibration.empty () &&
        (out->calib_has_tilt || e.seed);
    *property = from_file ? "calibration" : e.seed ? "model" : "tilt";
    *why = err;
    if (from_file)
      *why = s.calibration + ": " + err + (out->calib_has_tilt ?
          " (tilt_deg " + number_text (e.tilt_deg) + ", camera_height " +
          number_text (e.camera_height) + " m)" : std::string ());
    else if (!s.calibration.empty ())
      *why = err + " (tilt property with the intrinsics of " +
          s.calibration + ")";
    return false;
  }
  return true;
}

}  // namespace landmark
