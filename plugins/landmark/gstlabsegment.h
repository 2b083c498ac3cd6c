#pragma once

#include <gst/video/gstvideofilter.h>

G_BEGIN_DECLS

#define GST_TYPE_LAB_SEGMENT (gst_lab_segment_get_type ())
G_DECLARE_FINAL_TYPE (GstLabSegment, gst_lab_segment, GST, LAB_SEGMENT,
    GstVideoFilter)

#define GST_TYPE_LAB_SEGMENT_OUTPUT (gst_lab_segment_output_get_type ())
GType gst_lab_segment_output_get_type (void);

typedef enum
{
  GST_LAB_SEGMENT_OUTPUT_PASSTHROUGH,
  GST_LAB_SEGMENT_OUTPUT_LABELS,
} GstLabSegmentOutput;

GST_ELEMENT_REGISTER_DECLARE (labsegment);

G_END_DECLS
