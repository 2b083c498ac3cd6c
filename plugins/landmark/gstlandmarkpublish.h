#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_LANDMARK_PUBLISH (gst_landmark_publish_get_type ())
G_DECLARE_FINAL_TYPE (GstLandmarkPublish, gst_landmark_publish, GST,
    LANDMARK_PUBLISH, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (landmarkpublish);

G_END_DECLS
