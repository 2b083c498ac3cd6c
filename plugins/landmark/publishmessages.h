/* What landmarkpublish sends (docs/landmarkpublish.md): its MQTT topics,
 * checked and with their placeholders replaced, and the JSON payloads of
 * the frame, pose and status messages. */
#pragma once

#include <gst/gst.h>

#include <string>
#include <vector>

#include <gst/video/video.h>

namespace landmark {

/* A name that may stand as one level of a topic (`robot`): not empty,
 * UTF-8, no '/', '+' or '#'. False with *why. */
bool mqtt_topic_level_ok (const std::string & s, std::string * why);

/* The topic template with `{robot}` and `{client-id}` replaced; false with
 * *why for another placeholder, a wildcard or an invalid topic. */
bool mqtt_topic_expand (const std::string & tmpl, const std::string & robot,
    const std::string & client_id, std::string * out, std::string * why);

/* The status payload: robot, client-id, status ("online", "offline") and
 * the wall time now. */
std::string publish_status_payload (const std::string & robot,
    const std::string & client_id, const char *status);

/* The fields every message of a frame starts with, after the opening
 * brace and ending in ", ": robot, running-time (when buf has a time in a
 * time segment), wall-time (now). */
std::string publish_frame_head (const std::string & robot, GstBuffer * buf,
    const GstSegment * segment);

/* The frame message: head, then landmarklog's object for the frame. rois
 * is scratch space, reused between frames. */
std::string publish_frame_payload (const std::string & head,
    GstBuffer * buf, guint64 frame, gint width, gint height,
    std::vector<GstVideoRegionOfInterestMeta *> & rois);

/* The pose message: head, the frame index and the pose. */
std::string publish_pose_payload (const std::string & head, guint64 frame,
    const GstStructure * pose);

}  // namespace landmark
