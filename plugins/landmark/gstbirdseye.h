#pragma once

#include <gst/video/gstvideofilter.h>

G_BEGIN_DECLS

#define GST_TYPE_BIRDS_EYE (gst_birds_eye_get_type ())
G_DECLARE_FINAL_TYPE (GstBirdsEye, gst_birds_eye, GST, BIRDS_EYE,
    GstVideoFilter)

GST_ELEMENT_REGISTER_DECLARE (birdseye);

/* What birdseye draws on its view (property `draw`, docs/birdseye.md). */
typedef enum
{
  GST_BIRDS_EYE_DRAW_NONE = 0,
  GST_BIRDS_EYE_DRAW_BOUNDARY = (1 << 0),
  GST_BIRDS_EYE_DRAW_LANDMARKS = (1 << 1),
  GST_BIRDS_EYE_DRAW_ROBOT = (1 << 2),
} GstBirdsEyeDraw;

#define GST_TYPE_BIRDS_EYE_DRAW (gst_birds_eye_draw_get_type ())
GType gst_birds_eye_draw_get_type (void);

G_END_DECLS
