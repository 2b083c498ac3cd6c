#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_BLOB_ROUNDNESS (gst_blob_roundness_get_type ())
G_DECLARE_FINAL_TYPE (GstBlobRoundness, gst_blob_roundness, GST,
    BLOB_ROUNDNESS, GstBaseTransform)

#define GST_TYPE_BLOB_ROUNDNESS_SHAPE (gst_blob_roundness_shape_get_type ())
GType gst_blob_roundness_shape_get_type (void);

/* Which shape test decides whether a blob is a landmark. */
typedef enum
{
  GST_BLOB_ROUNDNESS_SHAPE_CIRCLE,
  GST_BLOB_ROUNDNESS_SHAPE_ELLIPSE,
} GstBlobRoundnessShape;

GST_ELEMENT_REGISTER_DECLARE (blobroundness);

G_END_DECLS
