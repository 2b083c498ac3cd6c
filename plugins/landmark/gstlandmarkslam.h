#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_LANDMARK_SLAM (gst_landmark_slam_get_type ())
G_DECLARE_FINAL_TYPE (GstLandmarkSlam, gst_landmark_slam, GST, LANDMARK_SLAM,
    GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (landmarkslam);

G_END_DECLS
