#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_FLOOR_BOUNDARY (gst_floor_boundary_get_type ())
G_DECLARE_FINAL_TYPE (GstFloorBoundary, gst_floor_boundary, GST,
    FLOOR_BOUNDARY, GstBaseTransform)

#define GST_TYPE_FLOOR_BOUNDARY_MARKERS (gst_floor_boundary_markers_get_type ())
GType gst_floor_boundary_markers_get_type (void);

/* What pixels of marker colours are for the walk. */
typedef enum
{
  GST_FLOOR_BOUNDARY_MARKERS_FLOOR,
  GST_FLOOR_BOUNDARY_MARKERS_DETECTIONS,
  GST_FLOOR_BOUNDARY_MARKERS_OBSTACLES,
} GstFloorBoundaryMarkers;

GST_ELEMENT_REGISTER_DECLARE (floorboundary);

G_END_DECLS
