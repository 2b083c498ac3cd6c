#pragma once

#include <gst/base/gstbasetransform.h>

G_BEGIN_DECLS

#define GST_TYPE_BEACON_DETECT (gst_beacon_detect_get_type ())
G_DECLARE_FINAL_TYPE (GstBeaconDetect, gst_beacon_detect, GST,
    BEACON_DETECT, GstBaseTransform)

GST_ELEMENT_REGISTER_DECLARE (beacondetect);

G_END_DECLS
