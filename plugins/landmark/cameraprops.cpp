#include "cameraprops.h"

#include "gstipmrange.h"

void
camera_props_install (GObjectClass * klass, guint first, GParamFlags flags)
{
  const landmark::CameraSettings d;
  g_object_class_install_property (klass, first + CAMERA_PROP_MODEL,
      g_param_spec_enum ("model", "Camera model",
          "How pixels map to the floor", GST_TYPE_IPM_RANGE_MODEL,
          GST_IPM_RANGE_MODEL_PINHOLE, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_CAMERA_HEIGHT,
      g_param_spec_double ("camera-height", "Camera height",
          "Height of the camera's optical centre above the floor, metres "
          "(must be > 0)", 0.0, 1000.0, d.camera_height, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_TILT,
      g_param_spec_double ("tilt", "Tilt",
          "model=pinhole: degrees below the horizontal",
          -90.0, 90.0, d.tilt_deg, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_ROLL,
      g_param_spec_double ("roll", "Roll",
          "model=pinhole: degrees about the optical axis, clockwise as seen "
          "from behind the camera", -360.0, 360.0, d.roll_deg, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_HFOV,
      g_param_spec_double ("hfov", "Horizontal field of view",
          "model=pinhole: degrees, (0, 180), principal point at the image "
          "centre; unused when fx or calibration is set", 0.0, 180.0,
          d.hfov_deg, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_FX,
      g_param_spec_double ("fx", "Focal length x",
          "model=pinhole: pixels; 0: from hfov", 0.0, G_MAXDOUBLE, d.fx,
          flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_FY,
      g_param_spec_double ("fy", "Focal length y",
          "model=pinhole: pixels; 0: as fx", 0.0, G_MAXDOUBLE, d.fy, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_CX,
      g_param_spec_double ("cx", "Principal point x",
          "model=pinhole with fx: pixels; < 0: (width - 1) / 2", -1.0,
          G_MAXDOUBLE, d.cx, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_CY,
      g_param_spec_double ("cy", "Principal point y",
          "model=pinhole with fx: pixels; < 0: (height - 1) / 2", -1.0,
          G_MAXDOUBLE, d.cy, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_CALIBRATION,
      g_param_spec_string ("calibration", "Calibration file",
          "Camera file (OpenCV FileStorage YAML or XML, as gst-landmark "
          "calibrate writes it): camera_matrix and distortion_coefficients "
          "(model pinhole), or model: seed with its four lengths (model "
          "seed); what the file holds (also camera_height, tilt_deg, "
          "roll_deg) overrides the properties", nullptr, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_BLIND_DISTANCE,
      g_param_spec_double ("blind-distance", "Blind distance",
          "model=seed: metres along the floor from the camera's floor point "
          "to the first visible floor point (b)", 0.0, 1000.0,
          d.blind_distance, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_VIEW_DEPTH,
      g_param_spec_double ("view-depth", "View depth",
          "model=seed: metres of floor from the first visible point to the "
          "point seen at the image centre line (d)", 0.0, 1000.0,
          d.view_depth, flags));
  g_object_class_install_property (klass, first + CAMERA_PROP_HALF_WIDTH,
      g_param_spec_double ("half-width", "Half width",
          "model=seed: half-width of the visible floor at distance b + d, "
          "metres (w)", 0.0, 1000.0, d.half_width, flags));
}

gboolean
camera_props_set (landmark::CameraSettings * s, guint first, guint prop_id,
    const GValue * value)
{
  if (prop_id < first || prop_id >= first + CAMERA_PROP_COUNT)
    return FALSE;
  switch ((CameraProp) (prop_id - first)) {
    case CAMERA_PROP_MODEL:
      s->seed = g_value_get_enum (value) == GST_IPM_RANGE_MODEL_SEED;
      break;
    case CAMERA_PROP_CAMERA_HEIGHT:
      s->camera_height = g_value_get_double (value);
      break;
    case CAMERA_PROP_TILT:
      s->tilt_deg = g_value_get_double (value);
      break;
    case CAMERA_PROP_ROLL:
      s->roll_deg = g_value_get_double (value);
      break;
    case CAMERA_PROP_HFOV:
      s->hfov_deg = g_value_get_double (value);
      break;
    case CAMERA_PROP_FX:
      s->fx = g_value_get_double (value);
      break;
    case CAMERA_PROP_FY:
      s->fy = g_value_get_double (value);
      break;
    case CAMERA_PROP_CX:
      s->cx = g_value_get_double (value);
      break;
    case CAMERA_PROP_CY:
      s->cy = g_value_get_double (value);
      break;
    case CAMERA_PROP_CALIBRATION:{
      const gchar *v = g_value_get_string (value);
      s->calibration = v ? v : "";
      break;
    }
    case CAMERA_PROP_BLIND_DISTANCE:
      s->blind_distance = g_value_get_double (value);
      break;
    case CAMERA_PROP_VIEW_DEPTH:
      s->view_depth = g_value_get_double (value);
      break;
    case CAMERA_PROP_HALF_WIDTH:
      s->half_width = g_value_get_double (value);
      break;
    default:
      return FALSE;
  }
  return TRUE;
}

gboolean
camera_props_get (const landmark::CameraSettings & s, guint first,
    guint prop_id, GValue * value)
{
  if (prop_id < first || prop_id >= first + CAMERA_PROP_COUNT)
    return FALSE;
  switch ((CameraProp) (prop_id - first)) {
    case CAMERA_PROP_MODEL:
      g_value_set_enum (value, s.seed ? GST_IPM_RANGE_MODEL_SEED :
          GST_IPM_RANGE_MODEL_PINHOLE);
      break;
    case CAMERA_PROP_CAMERA_HEIGHT:
      g_value_set_double (value, s.camera_height);
      break;
    case CAMERA_PROP_TILT:
      g_value_set_double (value, s.tilt_deg);
      break;
    case CAMERA_PROP_ROLL:
      g_value_set_double (value, s.roll_deg);
      break;
    case CAMERA_PROP_HFOV:
      g_value_set_double (value, s.hfov_deg);
      break;
    case CAMERA_PROP_FX:
      g_value_set_double (value, s.fx);
      break;
    case CAMERA_PROP_FY:
      g_value_set_double (value, s.fy);
      break;
    case CAMERA_PROP_CX:
      g_value_set_double (value, s.cx);
      break;
    case CAMERA_PROP_CY:
      g_value_set_double (value, s.cy);
      break;
    case CAMERA_PROP_CALIBRATION:
      g_value_set_string (value, s.calibration.empty ()? nullptr :
          s.calibration.c_str ());
      break;
    case CAMERA_PROP_BLIND_DISTANCE:
      g_value_set_double (value, s.blind_distance);
      break;
    case CAMERA_PROP_VIEW_DEPTH:
      g_value_set_double (value, s.view_depth);
      break;
    case CAMERA_PROP_HALF_WIDTH:
      g_value_set_double (value, s.half_width);
      break;
    default:
      return FALSE;
  }
  return TRUE;
}
