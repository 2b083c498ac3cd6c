#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_TRILATERATE (gst_trilaterate_get_type ())
G_DECLARE_FINAL_TYPE (GstTrilaterate, gst_trilaterate, GST, TRILATERATE,
    GstBaseTransform)

#define GST_TYPE_TRILATERATE_FILTER (gst_trilaterate_filter_get_type ())
GType gst_trilaterate_filter_get_type (void);

/* Temporal filtering of the poses. */
typedef enum
{
  GST_TRILATERATE_FILTER_NONE,
  GST_TRILATERATE_FILTER_EKF,
} GstTrilaterateFilter;

GST_ELEMENT_REGISTER_DECLARE (trilaterate);

G_END_DECLS
