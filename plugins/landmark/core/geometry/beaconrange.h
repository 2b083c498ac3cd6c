/* Range and bearing of an upright coded marker (beacon, post, cone:
 * docs/beacons.md) through a CameraGeometry, without GStreamer types.
 *
 * Ground: the ray through the image of its base's nearest point (where
 * beacondetect's axis leaves the lowest band) meets the base's plane; the
 * axis lies a radius further along the bearing. Size: the range at which
 * the marker of the map's height and diameter, standing on that bearing,
 * images as tall as it is seen (from the base's nearest point to the top
 * of its silhouette: the far or near edge of a cylinder's top, a cone's
 * apex). Sigmas from the pixel sigma by the camera's derivatives, as for
 * discs (docs/ranging.md). */
#pragma once

#include "camerageometry.h"
#include "rangeestimate.h"

namespace landmark {

/* What beacondetect saw, in the geometry's pixels. */
struct CodedObservation {
  double base_u = 0, base_v = 0;    /* axis-base-x, axis-base-y */
  double height_px = 0;             /* axis top to base */
  /* how much longer the blob is than the marker's image: blur and the
   * colour threshold take pixels it partly covers at either end */
  double outline_growth_px = 0;
  bool whole = true;                /* neither end cut by the frame */
};

/* The marker: its base at height z, height and diameter in metres (the
 * cone's at its base); diameter 0: unknown (no size range, and the axis
 * taken at the base's nearest point). */
struct CodedMarkerSize {
  double z = 0, height = 0, diameter = 0;
  bool cone = false;
};

/* The image length, pixels, from the base's nearest point to the top of
 * the silhouette of the marker whose axis stands at (x, y); false when a
 * point is behind the camera. */
bool coded_marker_image_height (const CameraGeometry & geometry,
    const CodedMarkerSize & m, double x, double y, double *height_px);

RangeEstimate estimate_coded_range (const CameraGeometry & geometry,
    const CodedObservation & obs, const CodedMarkerSize & marker,
    double pixel_sigma, const MountingSigma & mounting = MountingSigma ());

}  // namespace landmark
