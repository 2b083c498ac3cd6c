#pragma once

#include <gst/video/gstvideofilter.h>

G_BEGIN_DECLS

#define GST_TYPE_LANDMARK_OVERLAY (gst_landmark_overlay_get_type ())
G_DECLARE_FINAL_TYPE (GstLandmarkOverlay, gst_landmark_overlay, GST,
    LANDMARK_OVERLAY, GstVideoFilter)

GST_ELEMENT_REGISTER_DECLARE (landmarkoverlay);

G_END_DECLS
