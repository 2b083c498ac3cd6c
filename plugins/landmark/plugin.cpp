#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include <gst/gst.h>

#include "gstbeacondetect.h"
#include "gstbirdseye.h"
#include "gstblobroundness.h"
#include "gstfloorboundary.h"
#include "gstipmrange.h"
#include "gstlabsegment.h"
#include "gstlandmarklog.h"
#include "gstlandmarkslam.h"
#include "gstlandmarkoverlay.h"
#include "gstlandmarkpublish.h"
#include "gsttrilaterate.h"
#include "landmarkmeta.h"

static gboolean
plugin_init (GstPlugin * plugin)
{
  gboolean ok = FALSE;

  landmark_meta_register ();
  ok |= GST_ELEMENT_REGISTER (labsegment, plugin);
  ok |= GST_ELEMENT_REGISTER (blobroundness, plugin);
  ok |= GST_ELEMENT_REGISTER (beacondetect, plugin);
  ok |= GST_ELEMENT_REGISTER (ipmrange, plugin);
  ok |= GST_ELEMENT_REGISTER (landmarklog, plugin);
  ok |= GST_ELEMENT_REGISTER (landmarkoverlay, plugin);
  ok |= GST_ELEMENT_REGISTER (landmarkpublish, plugin);
  ok |= GST_ELEMENT_REGISTER (trilaterate, plugin);
  ok |= GST_ELEMENT_REGISTER (landmarkslam, plugin);
  ok |= GST_ELEMENT_REGISTER (floorboundary, plugin);
  ok |= GST_ELEMENT_REGISTER (birdseye, plugin);
  return ok;
}

GST_PLUGIN_DEFINE (GST_VERSION_MAJOR, GST_VERSION_MINOR, landmark,
    "Colour landmark localisation: segmentation, detection, ranging, pose",
    plugin_init, VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
