/* The camera properties of the elements that map pixels to the floor
 * (floorboundary, birdseye): the names, ranges and meanings of ipmrange's
 * (docs/ipmrange.md), declared in one place. The values go
 * to a landmark::CameraSettings, which camera_setup_resolve checks and
 * merges with a camera file. */
#pragma once

#include <gst/gst.h>

#include "elementsettings.h"
#include "camerasetup.h"

/* The camera properties, to add to an element's table with
 * PropertyTable::part (&Settings::camera, camera_properties ()). */
const landmark::PropertyTable<landmark::CameraSettings> &camera_properties ();
