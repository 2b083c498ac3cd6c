#pragma once

#include <gst/video/gstvideofilter.h>

G_BEGIN_DECLS

#define GST_TYPE_BIRDS_EYE (gst_birds_eye_get_type ())
G_DECLARE_FINAL_TYPE (GstBirdsEye, gst_birds_eye, GST, BIRDS_EYE,
    GstVideoFilter)

GST_ELEMENT_REGISTER_DECLARE (birdseye);

G_END_DECLS
