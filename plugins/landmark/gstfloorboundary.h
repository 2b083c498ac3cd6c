#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_FLOOR_BOUNDARY (gst_floor_boundary_get_type ())
G_DECLARE_FINAL_TYPE (GstFloorBoundary, gst_floor_boundary, GST,
    FLOOR_BOUNDARY, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (floorboundary);

G_END_DECLS
