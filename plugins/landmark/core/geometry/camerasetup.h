/* The camera settings shared by the elements that map pixels to the floor
 * (ipmrange, floorboundary, birdseye): what the user sets, merged with a
 * camera file (the file wins for what it holds, the properties give the
 * rest: docs/ipmrange.md "Camera files: what wins"). No GStreamer types. */
#pragma once

#include <string>
#include <vector>

#include "camerageometry.h"

namespace landmark {

/* What a user sets for the camera (the property set of ipmrange). */
struct CameraSettings {
  bool seed = false;
  double camera_height = 0.30;
  double tilt_deg = 25.0, roll_deg = 0.0, hfov_deg = 60.0;
  double fx = 0, fy = 0, cx = -1, cy = -1;   /* 0 / < 0: from hfov */
  std::string calibration;                  /* camera file, empty: none */
  double blind_distance = 0, view_depth = 0, half_width = 0;   /* seed */
};

/* The settings with the camera file read and merged: what the geometry is
 * built from at any frame size. */
struct CameraSetup {
  CameraSettings e;                 /* effective: file values applied */
  bool have_calibration = false;    /* intrinsics from the file */
  double cal_fx = 0, cal_fy = 0, cal_cx = 0, cal_cy = 0;
  std::vector<double> cal_dist;
  int calib_w = 0, calib_h = 0;     /* the file's image size, 0: none */
  bool calib_has_tilt = false;
};

/* Reads the camera file (load_camera_file) and checks the values and the
 * geometry at the file's or a 640x480 frame. False with *property (the
 * property to blame) and *why. */
bool camera_setup_resolve (const CameraSettings & s, CameraSetup * out,
    const char **property, std::string * why);

/* Camera parameters for a width x height frame (intrinsics of a file
 * scaled to the frame). */
bool camera_setup_params (const CameraSetup & c, int width, int height,
    CameraParams * p, const char **property, std::string * why);

}  // namespace landmark
