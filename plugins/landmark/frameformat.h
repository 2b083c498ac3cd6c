/* How a negotiated video format lays out the three colour components of a
 * pixel, for the elements that read or draw frames (no OpenCV here). */
#pragma once

#include <gst/video/video.h>

#include "labcolour.h"

/* The formats every pixel-reading element of the plugin accepts. */
#define LANDMARK_VIDEO_FORMATS \
    "{ RGB, BGR, RGBx, BGRx, xRGB, xBGR, RGBA, BGRA, I420, NV12, YUY2 }"

struct LandmarkFrameFormat {
  enum class Kind { PACKED, I420, NV12, YUY2 };
  Kind kind = Kind::PACKED;
  int pixel_stride = 4;              /* PACKED: bytes per pixel, 3 or 4 */
  int offset[3] = { 0, 1, 2 };       /* PACKED: bytes of R, G, B */
  landmark::InputModel model;        /* RGB, or Y'CbCr matrix and range */
};

/* Describes a negotiated format; FALSE for formats outside
 * LANDMARK_VIDEO_FORMATS (logged as an error). YUV takes the caps' matrix
 * (BT.601 when the caps name none) and range. */
gboolean landmark_frame_format (const GstVideoInfo * info,
    LandmarkFrameFormat * out);

#ifdef __cplusplus
#include <gst/video/gstvideofilter.h>

/* The set_info of a GstVideoFilter that reads or draws pixels: describes
 * the negotiated format and hands it, with the video info, to configure
 * (which returns FALSE when it cannot work with them). */
template <gboolean (*configure) (GstVideoFilter *, const LandmarkFrameFormat &,
    const GstVideoInfo *)>
gboolean
landmark_pixel_set_info (GstVideoFilter * filter, GstCaps * incaps,
    GstVideoInfo * in_info, GstCaps *, GstVideoInfo *)
{
  LandmarkFrameFormat format;
  if (!landmark_frame_format (in_info, &format) ||
      !configure (filter, format, in_info))
    return FALSE;
  GST_DEBUG_OBJECT (filter, "configured for %" GST_PTR_FORMAT, incaps);
  return TRUE;
}
#endif

/* The class set-up of an element that reads or draws pixels: sink and src
 * pads of LANDMARK_VIDEO_FORMATS, and its description. */
void landmark_set_pixel_element_class (GstElementClass * klass,
    const char *longname, const char *classification,
    const char *description);
