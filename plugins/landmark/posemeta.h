/* The metadata the pose elements (trilaterate, landmarkslam) read and
 * write the same way: the detections that have a range, and the fields of
 * a pose (docs/metadata.md). */
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

#include <string>
#include <utility>
#include <vector>

#include "landmarkmeta.h"
#include "posesolver.h"
#include "posetracker.h"

namespace landmark {

/* A frame's detections, split into those with a range (for a solver) and
 * those without, each with the `landmark-match` reason it gets. */
struct RangedDetections {
  std::vector<Detection> dets;
  std::vector<GstVideoRegionOfInterestMeta *> rois;   /* one per det */
  std::vector<std::pair<GstVideoRegionOfInterestMeta *, const char *>>
      skipped;
  std::vector<GstVideoRegionOfInterestMeta *> all;    /* reused */
};

/* Fills out from buf's detections: `not-kept` (rejected upstream),
 * `cut-by-border` (with skip_cut: the blob touches the frame edge, so its
 * centre, range and bearing are biased), `no-range` (no ground position
 * from ipmrange); the others in dets with ipmrange's range, bearing,
 * sigmas and marker. with_marginal: a marginal shape awaiting the map
 * (landmark_detection_awaits_map) is a candidate too. A coded marker
 * (beacondetect's `code`) has the class coded_match_class (code); without
 * with_coded it is skipped as `coded-marker`. */
void ranged_detections_collect (GstBuffer * buf, bool skip_cut,
    bool with_marginal, bool with_coded, RangedDetections * out);

/* Adds `landmark-match` {matched: false, reason} to every skipped
 * detection, through add (which may decline, e.g. when one is there). */
template <typename Add>
void
ranged_detections_mark_skipped (const RangedDetections & r, Add add)
{
  for (const auto & sk : r.skipped)
    add (sk.first, gst_structure_new (LANDMARK_MATCH_PARAMS,
            "matched", G_TYPE_BOOLEAN, FALSE,
            "reason", G_TYPE_STRING, sk.second, nullptr));
}

/* PoseFields (posetracker.h): a pose as the pose meta and the
 * landmark-pose message carry it. */
/* Writes x, y, heading, covariance, landmarks, n-landmarks, residual,
 * solver, geometry and filter into s. */
void pose_fields_set (GstStructure * s, const PoseFields & p);

}  // namespace landmark
