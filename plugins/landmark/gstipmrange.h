#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_IPM_RANGE (gst_ipm_range_get_type ())
G_DECLARE_FINAL_TYPE (GstIpmRange, gst_ipm_range, GST, IPM_RANGE,
    GstBaseTransform)

#define GST_TYPE_IPM_RANGE_MODEL (gst_ipm_range_model_get_type ())
GType gst_ipm_range_model_get_type (void);

/* Which camera model maps pixels to the floor. */
typedef enum
{
  GST_IPM_RANGE_MODEL_PINHOLE,
  GST_IPM_RANGE_MODEL_SEED,
} GstIpmRangeModel;

#define GST_TYPE_IPM_RANGE_METHOD (gst_ipm_range_method_get_type ())
GType gst_ipm_range_method_get_type (void);

/* What `range` reports. */
typedef enum
{
  GST_IPM_RANGE_METHOD_GROUND,
  GST_IPM_RANGE_METHOD_SIZE,
  GST_IPM_RANGE_METHOD_FUSED,
} GstIpmRangeMethod;

#define GST_TYPE_IPM_RANGE_MARKER_KIND (gst_ipm_range_marker_kind_get_type ())
GType gst_ipm_range_marker_kind_get_type (void);

/* The markers' shape when no map gives it per class. */
typedef enum
{
  GST_IPM_RANGE_MARKER_DISC,
  GST_IPM_RANGE_MARKER_BALL,
} GstIpmRangeMarkerKind;

GST_ELEMENT_REGISTER_DECLARE (ipmrange);

G_END_DECLS
