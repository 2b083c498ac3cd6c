/* GStreamer's own analytics metadata for our results (docs/metadata.md),
 * beside our metas, for the elements of gst-plugins-bad that read it
 * (objectdetectionoverlay, segmentationoverlay, trackers, encoders).
 *
 * Built against GStreamer >= 1.24 (gstreamer-analytics-1.0 found by meson,
 * HAVE_GST_ANALYTICS): one GstAnalyticsRelationMeta per buffer holding, per
 * detection that no stage rejected, an object-detection box (oriented from
 * the fitted ellipse on >= 1.26), a classification (class, colour
 * confidence) and, once trilaterate matched it, a tracking entry with the
 * map landmark; on >= 1.26 also the label plane as a segmentation.
 * Against 1.22 the function does nothing. */
#pragma once

#include <gst/gst.h>

/* (Re)writes the buffer's analytics entries from its labels and detections
 * metas as they are now; each of labsegment, blobroundness, ipmrange and
 * trilaterate calls it last, so a later stage's verdict (a range that
 * rejects, a map match that accepts) replaces an earlier one's. A relation
 * meta another producer wrote is kept: our entries are appended to it once.
 * The buffer must be writable. */
void landmark_analytics_sync (GstBuffer * buffer);
