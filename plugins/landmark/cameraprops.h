/* The camera properties of the elements that map pixels to the floor
 * (floorboundary, birdseye): the names, ranges and meanings of ipmrange's
 * (docs/ipmrange.md), installed, set and read in one place. The values go
 * to a landmark::CameraSettings, which camera_setup_resolve checks and
 * merges with a camera file. */
#pragma once

#include <gst/gst.h>

#include "floorprofile.h"

/* Property ids relative to the first one an element gives. */
enum CameraProp
{
  CAMERA_PROP_MODEL,
  CAMERA_PROP_CAMERA_HEIGHT,
  CAMERA_PROP_TILT,
  CAMERA_PROP_ROLL,
  CAMERA_PROP_HFOV,
  CAMERA_PROP_FX,
  CAMERA_PROP_FY,
  CAMERA_PROP_CX,
  CAMERA_PROP_CY,
  CAMERA_PROP_CALIBRATION,
  CAMERA_PROP_BLIND_DISTANCE,
  CAMERA_PROP_VIEW_DEPTH,
  CAMERA_PROP_HALF_WIDTH,
  CAMERA_PROP_COUNT,
};

/* Installs the camera properties with ids first .. first + COUNT - 1. */
void camera_props_install (GObjectClass * klass, guint first,
    GParamFlags flags);

/* Sets or reads one; FALSE when prop_id is not a camera property. */
gboolean camera_props_set (landmark::CameraSettings * s, guint first,
    guint prop_id, const GValue * value);
gboolean camera_props_get (const landmark::CameraSettings & s, guint first,
    guint prop_id, GValue * value);
