/* The linear light of a mapped frame's pixels, in any format the plugin
 * reads (frameformat.h): what ipmrange samples across a ball's outline
 * (core/geometry/rangeestimate.h, measure_end_offsets). Kept apart from the element
 * so that gstipmrange.cpp holds only the element. */
#pragma once

#include <gst/video/video.h>

#include "labcolour.h"

namespace landmark {

struct FrameLight {
  /* the mapped frame's component planes, read once per frame */
  struct Plane {
    const guint8 *data;
    int stride, pstride, wsub, hsub, width, height;
  } planes[3];
  /* the format's components to sRGB, an affine map (before clipping) */
  double to_srgb[3][4];
  /* where each of sRGB's components is one of the format's alone (the
   * RGB formats): that component, and its linear light per byte value */
  bool by_byte = false;
  int byte_of[3];
  double byte_light[3][256];

  /* For a format whose components model converts: to_srgb, and byte_light
   * where each sRGB component is one of the format's. */
  void set_model (const InputModel & model);
  /* The mapped frame's planes into planes. */
  void read_planes (const GstVideoFrame * frame);
  /* The frame's linear light of n pixels of row y from column x: each
   * component from its plane (a subsampled one at the sample covering the
   * pixel), then sRGB decoded. False where one is outside. */
  bool row_light (int x, int y, int n, double *rgb) const;
};

}  // namespace landmark
