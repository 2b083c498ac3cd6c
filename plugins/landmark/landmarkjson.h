/* The JSON text of one buffer's gst-landmark metadata, shared by the
 * elements that hand it on: landmarklog (one line per frame) and
 * landmarkpublish (one MQTT message per frame). docs/landmarklog.md has
 * every field. */
#pragma once

#include <gst/video/video.h>

#include <string>
#include <vector>

namespace landmark_json {

/* Looks up the names the writer compares with; call from class_init. */
void init (void);

void put_uint (std::string & o, guint64 v);
void put_int (std::string & o, gint64 v);
/* Shortest text that reads back to the same double; NaN, inf: null. */
void put_double (std::string & o, double v);
/* A JSON string, escaped; invalid UTF-8 repaired; nullptr: null. */
void put_string (std::string & o, const char *s);

/* Every field of a structure as a JSON object; nullptr: null. */
void put_structure (std::string & o, const GstStructure * s);

/* Appends the fields of one buffer's object, from "frame" to "pose",
 * without the braces, so callers can add fields of their own. `rois` is
 * scratch space, reused between frames. */
void put_frame_fields (std::string & o, GstBuffer * buf, guint64 frame,
    gint width, gint height,
    std::vector<GstVideoRegionOfInterestMeta *> & rois);

}  // namespace landmark_json
