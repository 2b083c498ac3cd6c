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

#define GST_TYPE_LAB_SEGMENT_RARE_CLASSES \
    (gst_lab_segment_rare_classes_get_type ())
GType gst_lab_segment_rare_classes_get_type (void);

/* Where pixels of classes below the dominant-colour threshold go. */
typedef enum
{
  GST_LAB_SEGMENT_RARE_NEAREST,
  GST_LAB_SEGMENT_RARE_UNLABELLED,
} GstLabSegmentRareClasses;

GST_ELEMENT_REGISTER_DECLARE (labsegment);

G_END_DECLS
