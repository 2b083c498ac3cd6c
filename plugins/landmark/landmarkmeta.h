/* The metadata contract of gst-landmark (docs/metadata.md).
 *
 * Labels: GstCustomMeta "GstLandmarkLabelsMeta", the per-frame class plane.
 * Detections: GstVideoRegionOfInterestMeta, one per blob, with parameter
 *   structures "landmark-blob", "landmark-range", "landmark-match".
 * Pose: GstCustomMeta "GstLandmarkPoseMeta".
 *
 * Every element reads and writes metadata through this module only. */
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

G_BEGIN_DECLS

#define GST_LANDMARK_LABELS_META_NAME "GstLandmarkLabelsMeta"
#define GST_LANDMARK_POSE_META_NAME "GstLandmarkPoseMeta"
#define GST_LANDMARK_DETECTIONS_META_NAME "GstLandmarkDetectionsMeta"
#define GST_LANDMARK_MAP_META_NAME "GstLandmarkMapMeta"
#define GST_LANDMARK_FLOOR_META_NAME "GstLandmarkFloorMeta"

#define LANDMARK_BLOB_PARAMS "landmark-blob"
#define LANDMARK_RANGE_PARAMS "landmark-range"
#define LANDMARK_MATCH_PARAMS "landmark-match"

/* Labels meta fields (all in the structure of the custom meta). */
#define LANDMARK_LABELS_PLANE "labels"                 /* GstBuffer, uint8 */
#define LANDMARK_LABELS_WIDTH "width"                  /* guint, pixels */
#define LANDMARK_LABELS_HEIGHT "height"                /* guint, pixels */
#define LANDMARK_LABELS_STRIDE "stride"                /* guint, bytes */
#define LANDMARK_LABELS_ANALYSIS_WIDTH "analysis-width"
#define LANDMARK_LABELS_ANALYSIS_HEIGHT "analysis-height"
#define LANDMARK_LABELS_CLASS_NAMES "class-names"      /* array of strings */
#define LANDMARK_LABELS_CLASS_MARKERS "class-markers"  /* array of booleans */
#define LANDMARK_LABELS_CLASS_ROLES "class-roles"  /* array of strings: marker, floor, background */
#define LANDMARK_LABELS_CLASS_RGB "class-rgb"          /* array of 0xRRGGBB */
#define LANDMARK_LABELS_CLASS_COUNTS "class-counts"    /* array of guint */
#define LANDMARK_LABELS_CLASS_ACTIVE "class-active"    /* array of booleans */
#define LANDMARK_LABELS_LABEL_COUNTS "label-counts"    /* array of guint */
#define LANDMARK_LABELS_UNCLASSIFIED "unclassified"    /* guint */
#define LANDMARK_LABELS_MIN_CLASS_PIXELS "min-class-pixels"  /* guint */
#define LANDMARK_LABELS_MAX_DISTANCE "max-distance"    /* gdouble */
#define LANDMARK_LABELS_USE_LIGHTNESS "use-lightness"  /* gboolean */
#define LANDMARK_LABELS_COLOUR_GAINS "colour-gains"  /* array of 3 doubles, adapt=true only: linear R, G, B gains the references were re-made with */

const GstMetaInfo *gst_landmark_labels_meta_get_info (void);
const GstMetaInfo *gst_landmark_pose_meta_get_info (void);
const GstMetaInfo *gst_landmark_detections_meta_get_info (void);
const GstMetaInfo *gst_landmark_map_meta_get_info (void);
const GstMetaInfo *gst_landmark_floor_meta_get_info (void);

/* Registers every meta of the contract; called from plugin_init. */
void landmark_meta_register (void);

/* Adds an empty labels meta, replacing any the buffer had, and returns its
 * structure to fill. */
GstStructure *landmark_labels_meta_add (GstBuffer * buffer);

/* The labels meta's structure, or NULL. */
const GstStructure *landmark_labels_meta_get (GstBuffer * buffer);

/* Reads the plane fields; FALSE when they are missing or inconsistent
 * (plane smaller than stride * height). *plane is a new reference. */
gboolean landmark_labels_get_plane (const GstStructure * labels,
    GstBuffer ** plane, guint * width, guint * height, guint * stride);

/* Number of classes, and per-class fields (index 0 is label 1). */
guint landmark_labels_n_classes (const GstStructure * labels);
const gchar *landmark_labels_class_name (const GstStructure * labels,
    guint index);
gboolean landmark_labels_class_is_marker (const GstStructure * labels,
    guint index);
/* The class's palette role ("marker", "floor", "background"), or NULL when
 * the labels do not carry roles (older producers). */
const gchar *landmark_labels_class_role (const GstStructure * labels,
    guint index);
guint landmark_labels_class_count (const GstStructure * labels, guint index);
/* Element index of a per-class array field (class-rgb, class-active, ...),
 * or NULL when the field is missing or shorter. */
const GValue *landmark_labels_class_value (const GstStructure * labels,
    const gchar * field, guint index);

/* Detections: one region-of-interest meta per blob. roi_type is the class
 * name; id is the detection's index in the buffer (0, 1, 2, ...). */
GstVideoRegionOfInterestMeta *landmark_detection_add (GstBuffer * buffer,
    const gchar * class_name, guint x, guint y, guint w, guint h);

/* The same for a box measured on a label plane of plane_w x plane_h
 * pixels: rescaled (outwards) to a frame of frame_w x frame_h when the
 * sizes differ and the frame's is known (non-zero). */
GstVideoRegionOfInterestMeta *landmark_detection_add_from_plane (GstBuffer *
    buffer, const gchar * class_name, gint x, gint y, gint w, gint h,
    guint plane_w, guint plane_h, gint frame_w, gint frame_h);

/* Adds a parameter structure (landmark-blob, -range, -match; ownership
 * taken) to a detection: on its region-of-interest meta, for other tools,
 * and on the buffer's GstLandmarkDetectionsMeta, because converters and
 * scalers (GStreamer 1.22) copy region-of-interest metas without their
 * parameters. The buffer must be writable. */
void landmark_detection_add_param (GstBuffer * buffer,
    GstVideoRegionOfInterestMeta * roi, GstStructure * param);

/* A parameter structure of a detection: from its region-of-interest meta,
 * else from the detections meta; NULL when neither has it. Valid while the
 * buffer's metas are unchanged. */
const GstStructure *landmark_detection_get_param (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi, const gchar * name);
/* A detection's parameter structures of blobroundness, ipmrange and
 * trilaterate (landmark_detection_get_param; NULL where absent). */
struct LandmarkDetectionParams
{
  const GstStructure *blob, *range, *match;
};
LandmarkDetectionParams landmark_detection_params (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi);

/* Whether a stage of the chain rejected a detection (docs/detection.md):
 * blobroundness or beacondetect (landmark-blob kept=false: area, shape, a
 * partial coded marker), ipmrange
 * (landmark-range kept=false: size against range) or trilaterate
 * (landmark-match reason outside-gate, outlier or duplicate: the map
 * disagrees).
 * TRUE with *element (the element's name) and *reason (its reject reason,
 * may be NULL) set for the first stage that rejected it. */
gboolean landmark_detection_rejected (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi, const gchar ** element,
    const gchar ** reason);
/* Whether a detection waits for the map's word: a marginal shape
 * (blobroundness) whose size against range ipmrange confirmed and that no
 * trilaterate has matched yet. landmark_detection_rejected rejects it until
 * a match in the map's consensus accepts it (docs/detection.md). */
gboolean landmark_detection_awaits_map (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi);
GstVideoRegionOfInterestMeta *landmark_detection_get (GstBuffer * buffer,
    gint id);
guint landmark_detection_count (GstBuffer * buffer);

/* Pose: adds an empty pose meta, replacing any the buffer had, and returns
 * its structure to fill. */
GstStructure *landmark_pose_meta_add (GstBuffer * buffer);
const GstStructure *landmark_pose_meta_get (GstBuffer * buffer);

/* Landmark map (landmarkslam): parallel arrays over the landmarks, `ids`,
 * `classes` (strings), `x`, `y` (metres), `covariance` (4 doubles per
 * landmark, row-major over x, y), `confirmed` (booleans), `views` (guint).
 * Adds an empty map meta, replacing any the buffer had. */
GstStructure *landmark_map_meta_add (GstBuffer * buffer);
const GstStructure *landmark_map_meta_get (GstBuffer * buffer);
/* Free floor (floorboundary, docs/floorboundary.md): per image column the
 * floor boundary, per bearing bin the Radial Obstacle Profile. Arrays are
 * GstBuffers of native-endian float32 or uint8 values. */
#define LANDMARK_FLOOR_WIDTH "width"                  /* guint, columns */
#define LANDMARK_FLOOR_HEIGHT "height"                /* guint, rows */
#define LANDMARK_FLOOR_BEARING_BINS "bearing-bins"    /* guint */
#define LANDMARK_FLOOR_BIN_WIDTH "bin-width"          /* gdouble, radians */
#define LANDMARK_FLOOR_MAX_RANGE "max-range"          /* gdouble, metres */
#define LANDMARK_FLOOR_ROP_RANGE "rop-range"          /* float32 x bins */
#define LANDMARK_FLOOR_ROP_STATE "rop-state"          /* uint8 x bins */
#define LANDMARK_FLOOR_ROP_MARKER_RANGE "rop-marker-range"  /* float32 */
#define LANDMARK_FLOOR_BOUNDARY_ROW "boundary-row"    /* float32 x width */
#define LANDMARK_FLOOR_BOUNDARY_X "boundary-x"        /* float32 x width */
#define LANDMARK_FLOOR_BOUNDARY_Y "boundary-y"        /* float32 x width */
#define LANDMARK_FLOOR_BOUNDARY_STATE "boundary-state"  /* uint8 x width */
#define LANDMARK_FLOOR_NEAREST_RANGE "nearest-range"  /* gdouble, metres */
#define LANDMARK_FLOOR_NEAREST_BEARING "nearest-bearing"  /* gdouble */

/* State codes of rop-state and boundary-state. */
typedef enum
{
  LANDMARK_FLOOR_NOT_SEEN = 0,
  LANDMARK_FLOOR_FREE = 1,
  LANDMARK_FLOOR_OBSTACLE = 2,
  LANDMARK_FLOOR_VIEW_EDGE = 3,
} LandmarkFloorState;

/* Adds an empty floor meta, replacing any the buffer had, and returns its
 * structure to fill. */
GstStructure *landmark_floor_meta_add (GstBuffer * buffer);
const GstStructure *landmark_floor_meta_get (GstBuffer * buffer);

/* Maps an array field of the floor meta for reading: TRUE with *plane (a
 * new reference, to unmap and unref) and *map; *count elements of
 * elem_size bytes. */
gboolean landmark_floor_map_array (const GstStructure * floor,
    const gchar * field, gsize elem_size, GstBuffer ** plane,
    GstMapInfo * map, gsize * count);

/* Live odometry for landmarkslam: a custom downstream event (serialized,
 * or out-of-band to reach the element at once) carrying the robot-frame
 * motion since the previous one: dx forward and dy left (metres), dheading
 * (radians, counter-clockwise). Send it to landmarkslam's sink pad
 * (docs/embedding.md). */
#define GST_LANDMARK_ODOMETRY_EVENT_NAME "landmark-odometry"
GstEvent *landmark_odometry_event_new (gdouble dx, gdouble dy,
    gdouble dheading, gboolean out_of_band);

/* An element message structure about the frame buf: name with its
 * `timestamp`, `stream-time` and `running-time` (ns, in segment). */
GstStructure *landmark_frame_message_new (const gchar * name,
    GstBuffer * buf, const GstSegment * segment);

/* Appends one value to a GstValueArray. */
void landmark_value_array_append_uint (GValue * array, guint x);
void landmark_value_array_append_double (GValue * array, gdouble x);
void landmark_value_array_append_boolean (GValue * array, gboolean x);
void landmark_value_array_append_string (GValue * array, const gchar * x);

G_END_DECLS

#ifdef __cplusplus
#include <string>
#include <utility>
#include <vector>

#include "labelsreading.h"

/* The region-of-interest metas of buffer, in its order (out is cleared
 * first; its storage is kept, so a reused vector does not allocate). */
void landmark_detections_collect (GstBuffer * buffer,
    std::vector < GstVideoRegionOfInterestMeta * >*out);
#endif
