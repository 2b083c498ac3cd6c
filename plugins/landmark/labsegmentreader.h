/* What labsegment's pixel passes (labsegmentpixels.cpp,
 * labsegmentrule.cpp) share: reading a pixel's three components from a
 * mapped frame, whatever its layout. Not for use outside them. */
#pragma once

#include <gst/video/video.h>

#include "labsegmentpixels.h"

namespace landmark {

/* internal linkage, as when the passes were one file: each file that
 * includes it has its own copy, inlined into its loops */
namespace {

/* Reads the components of pixel x of the current row, whatever the
 * layout; every pass but the table lookups reads with it. */
struct PixelReader {
  const GstVideoFrame *frame;
  FrameLayout layout;
  const guint8 *row0 = nullptr, *row1 = nullptr, *row2 = nullptr;
  int upstride = 1;

  void set_row (guint y) {
    const GstVideoFrame *f = frame;
    row0 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 0) +
        (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (f, 0);
    if (layout.layout == PixelLayout::YUV420) {
      const GstVideoFormat fmt = GST_VIDEO_FRAME_FORMAT (f);
      const guint cy = y / 2;
      if (fmt == GST_VIDEO_FORMAT_NV12) {
        row1 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        row2 = row1 + 1;
        upstride = 2;
      } else {
        row1 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        row2 = (const guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 2) +
            (gsize) cy * GST_VIDEO_FRAME_PLANE_STRIDE (f, 2);
        upstride = 1;
      }
    }
  }

  inline void get (guint x, guint8 c[3]) const {
    switch (layout.layout) {
      case PixelLayout::PACKED3:
        c[0] = row0[x * 3 + layout.offset[0]];
        c[1] = row0[x * 3 + layout.offset[1]];
        c[2] = row0[x * 3 + layout.offset[2]];
        break;
      case PixelLayout::PACKED4:
        c[0] = row0[x * 4 + layout.offset[0]];
        c[1] = row0[x * 4 + layout.offset[1]];
        c[2] = row0[x * 4 + layout.offset[2]];
        break;
      case PixelLayout::YUV420:
        c[0] = row0[x];
        c[1] = row1[(x >> 1) * upstride];
        c[2] = row2[(x >> 1) * upstride];
        break;
      case PixelLayout::YUY2:
        c[0] = row0[x * 2];
        c[1] = row0[(x >> 1) * 4 + 1];
        c[2] = row0[(x >> 1) * 4 + 3];
        break;
    }
  }
};

}  // namespace

}  // namespace landmark
