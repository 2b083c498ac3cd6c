#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_LANDMARK_LOG (gst_landmark_log_get_type ())
G_DECLARE_FINAL_TYPE (GstLandmarkLog, gst_landmark_log, GST, LANDMARK_LOG,
    GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (landmarklog);

G_END_DECLS
