#include "cameraprops.h"

#include "gstipmrange.h"

const landmark::PropertyTable<landmark::CameraSettings> &
camera_properties ()
{
  using landmark::CameraSettings;
  static const auto table = landmark::PropertyTable<CameraSettings> ()
      .add ([](GParamFlags f) {
          return g_param_spec_enum ("model", "Camera model",
              "How pixels map to the floor", GST_TYPE_IPM_RANGE_MODEL,
              GST_IPM_RANGE_MODEL_PINHOLE, f);
        },
        [](CameraSettings & s, const GValue * v) {
          s.seed = g_value_get_enum (v) == GST_IPM_RANGE_MODEL_SEED;
        },
        [](const CameraSettings & s, GValue * v) {
          g_value_set_enum (v, s.seed ? GST_IPM_RANGE_MODEL_SEED :
              GST_IPM_RANGE_MODEL_PINHOLE);
        })
      .number ("camera-height", "Camera height",
          "Height of the camera's optical centre above the floor, metres "
          "(must be > 0)", &CameraSettings::camera_height, 0.0, 1000.0)
      .number ("tilt", "Tilt", "model=pinhole: degrees below the horizontal",
          &CameraSettings::tilt_deg, -90.0, 90.0)
      .number ("roll", "Roll",
          "model=pinhole: degrees about the optical axis, clockwise as seen "
          "from behind the camera", &CameraSettings::roll_deg, -360.0, 360.0)
      .number ("hfov", "Horizontal field of view",
          "model=pinhole: degrees, (0, 180), principal point at the image "
          "centre; unused when fx or calibration is set",
          &CameraSettings::hfov_deg, 0.0, 180.0)
      .number ("fx", "Focal length x", "model=pinhole: pixels; 0: from hfov",
          &CameraSettings::fx, 0.0, G_MAXDOUBLE)
      .number ("fy", "Focal length y", "model=pinhole: pixels; 0: as fx",
          &CameraSettings::fy, 0.0, G_MAXDOUBLE)
      .number ("cx", "Principal point x",
          "model=pinhole with fx: pixels; < 0: (width - 1) / 2",
          &CameraSettings::cx, -1.0, G_MAXDOUBLE)
      .number ("cy", "Principal point y",
          "model=pinhole with fx: pixels; < 0: (height - 1) / 2",
          &CameraSettings::cy, -1.0, G_MAXDOUBLE)
      .string ("calibration", "Calibration file",
          "Camera file (OpenCV FileStorage YAML or XML, as gst-landmark "
          "calibrate writes it): camera_matrix and distortion_coefficients "
          "(model pinhole), or model: angle-linear with its four lengths "
          "(model angle-linear); what the file holds (also camera_height, "
          "tilt_deg, roll_deg) overrides the properties",
          &CameraSettings::calibration)
      .number ("blind-distance", "Blind distance",
          "model=angle-linear: metres along the floor from the camera's "
          "floor point to the first visible floor point (b)",
          &CameraSettings::blind_distance, 0.0, 1000.0)
      .number ("view-depth", "View depth",
          "model=angle-linear: metres of floor from the first visible "
          "point to the point seen at the image centre line (d)",
          &CameraSettings::view_depth, 0.0, 1000.0)
      .number ("half-width", "Half width",
          "model=angle-linear: half-width of the visible floor at distance "
          "b + d, metres (w)", &CameraSettings::half_width, 0.0, 1000.0);
  return table;
}
