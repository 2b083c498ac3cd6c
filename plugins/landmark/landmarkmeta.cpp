#include "landmarkmeta.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace {

gboolean
copy_field (GQuark field, const GValue * value, gpointer user_data)
{
  gst_structure_id_set_value ((GstStructure *) user_data, field, value);
  return TRUE;
}

void
copy_fields (const GstStructure * from, GstStructure * to)
{
  gst_structure_foreach (from, copy_field, to);
}

/* Nearest-neighbour resampling of a label plane: class labels must not be
 * blended, and each output pixel takes the class under its centre. */
GstBuffer *
resample_plane (GstBuffer * plane, guint w, guint h, guint stride,
    guint out_w, guint out_h)
{
  GstBuffer *out = gst_buffer_new_allocate (nullptr, (gsize) out_w * out_h,
      nullptr);
  GstMapInfo in_map, out_map;
  if (!gst_buffer_map (plane, &in_map, GST_MAP_READ)) {
    gst_buffer_unref (out);
    return nullptr;
  }
  gst_buffer_map (out, &out_map, GST_MAP_WRITE);
  for (guint y = 0; y < out_h; y++) {
    const guint sy = (guint) (((guint64) y * 2 + 1) * h / (2 * (guint64) out_h));
    const guint8 *src = in_map.data + (gsize) sy * stride;
    guint8 *dst = out_map.data + (gsize) y * out_w;
    for (guint x = 0; x < out_w; x++)
      dst[x] = src[((guint64) x * 2 + 1) * w / (2 * (guint64) out_w)];
  }
  gst_buffer_unmap (out, &out_map);
  gst_buffer_unmap (plane, &in_map);
  return out;
}

gboolean
labels_meta_transform (GstBuffer * dst, GstCustomMeta * meta,
    GstBuffer * src, GQuark type, gpointer data, gpointer)
{
  (void) src;
  const GstStructure *in = gst_custom_meta_get_structure (meta);
  /* Some transforms call us twice for one buffer (scale, then copy):
   * the first result stands. */
  if (gst_buffer_get_custom_meta (dst, GST_LANDMARK_LABELS_META_NAME))
    return TRUE;

  if (GST_META_TRANSFORM_IS_COPY (type)) {
    auto copy = (GstMetaTransformCopy *) data;
    if (copy->region)
      return FALSE;  /* a part of the buffer: the plane would not match */
    copy_fields (in, landmark_labels_meta_add (dst));
    return TRUE;
  }

  if (GST_VIDEO_META_TRANSFORM_IS_SCALE (type)) {
    auto t = (GstVideoMetaTransform *) data;
    const guint out_w = GST_VIDEO_INFO_WIDTH (t->out_info);
    const guint out_h = GST_VIDEO_INFO_HEIGHT (t->out_info);
    GstBuffer *plane;
    guint w, h, stride;
    if (!landmark_labels_get_plane (in, &plane, &w, &h, &stride))
      return FALSE;
    GstStructure *out = landmark_labels_meta_add (dst);
    copy_fields (in, out);
    if (out_w == w && out_h == h)
      return TRUE;
    GstBuffer *scaled = resample_plane (plane, w, h, stride, out_w, out_h);
    gst_buffer_unref (plane);
    if (!scaled)
      return FALSE;
    gst_structure_set (out,
        LANDMARK_LABELS_PLANE, GST_TYPE_BUFFER, scaled,
        LANDMARK_LABELS_WIDTH, G_TYPE_UINT, out_w,
        LANDMARK_LABELS_HEIGHT, G_TYPE_UINT, out_h,
        LANDMARK_LABELS_STRIDE, G_TYPE_UINT, out_w, nullptr);
    gst_buffer_unref (scaled);
    return TRUE;
  }
  return FALSE;  /* unknown transform: drop rather than carry stale labels */
}

/* One meta of each kind per buffer: a later result replaces an earlier one,
 * which readers would otherwise find first. */
GstStructure *
replace_custom_meta (GstBuffer * buffer, const char *name)
{
  GstCustomMeta *old;
  while ((old = gst_buffer_get_custom_meta (buffer, name)))
    gst_buffer_remove_meta (buffer, (GstMeta *) old);
  GstCustomMeta *meta = gst_buffer_add_custom_meta (buffer, name);
  return meta ? gst_custom_meta_get_structure (meta) : nullptr;
}

/* Pose, map and floor are properties of the frame, not of its pixels (world
 * coordinates; ranges; boundary rows of the analysed frame, whose size the
 * meta records as landmark-blob does): copies and scaling keep them as they
 * are. The meta's name comes as the registration's user data. */
gboolean
frame_meta_transform (GstBuffer * dst, GstCustomMeta * meta,
    GstBuffer * src, GQuark type, gpointer data, gpointer meta_name)
{
  (void) src;
  (void) data;
  const char *name = static_cast<const char *> (meta_name);
  if (gst_buffer_get_custom_meta (dst, name))
    return TRUE;
  if (GST_META_TRANSFORM_IS_COPY (type) ||
      GST_VIDEO_META_TRANSFORM_IS_SCALE (type)) {
    copy_fields (gst_custom_meta_get_structure (meta),
        replace_custom_meta (dst, name));
    return TRUE;
  }
  return FALSE;
}

/* No tags: no pixel coordinates, so every transform may keep it. */
const GstMetaInfo *
register_frame_meta (const char *name)
{
  static const gchar *tags[] = { nullptr };
  return gst_meta_register_custom (name, tags, frame_meta_transform,
      (gpointer) name, nullptr);
}

/* Key of a detection's entry in the detections meta. */
void
detection_key (gint id, char key[32])
{
  g_snprintf (key, 32, "detection-%d", id);
}

gboolean
detections_meta_transform (GstBuffer * dst, GstCustomMeta * meta,
    GstBuffer * src, GQuark type, gpointer data, gpointer)
{
  (void) src;
  if (gst_buffer_get_custom_meta (dst, GST_LANDMARK_DETECTIONS_META_NAME))
    return TRUE;
  /* Parameters refer to the analysed frame (they record its size), so any
   * copy or scaling keeps them as they are. */
  if (GST_META_TRANSFORM_IS_COPY (type)) {
    if (((GstMetaTransformCopy *) data)->region)
      return FALSE;
  } else if (!GST_VIDEO_META_TRANSFORM_IS_SCALE (type)) {
    return FALSE;
  }
  gst_landmark_detections_meta_get_info ();
  GstCustomMeta *out = gst_buffer_add_custom_meta (dst,
      GST_LANDMARK_DETECTIONS_META_NAME);
  if (!out)
    return FALSE;
  copy_fields (gst_custom_meta_get_structure (meta),
      gst_custom_meta_get_structure (out));
  return TRUE;
}

const GstStructure *
custom_structure (GstBuffer * buffer, const char *name)
{
  GstCustomMeta *meta = gst_buffer_get_custom_meta (buffer, name);
  return meta ? gst_custom_meta_get_structure (meta) : nullptr;
}

const GValue *
array_element (const GstStructure * s, const char *field, guint index)
{
  const GValue *array = gst_structure_get_value (s, field);
  if (!array || !GST_VALUE_HOLDS_ARRAY (array) ||
      index >= gst_value_array_get_size (array))
    return nullptr;
  return gst_value_array_get_value (array, index);
}

}  // namespace

const GstMetaInfo *
gst_landmark_labels_meta_get_info (void)
{
  /* coordinates: tagged video + size so scalers call the transform */
  static const gchar *tags[] = { GST_META_TAG_VIDEO_STR,
    GST_META_TAG_VIDEO_SIZE_STR, nullptr
  };
  static const GstMetaInfo *info = gst_meta_register_custom (
      GST_LANDMARK_LABELS_META_NAME, tags, labels_meta_transform, nullptr,
      nullptr);
  return info;
}

const GstMetaInfo *
gst_landmark_detections_meta_get_info (void)
{
  /* "video" only: no pixel coordinates that a scaler would have to change
   * (they refer to the analysed frame), so converters and scalers copy
   * it */
  static const gchar *tags[] = { GST_META_TAG_VIDEO_STR, nullptr };
  static const GstMetaInfo *info = gst_meta_register_custom (
      GST_LANDMARK_DETECTIONS_META_NAME, tags, detections_meta_transform,
      nullptr, nullptr);
  return info;
}

/* gst_landmark_NAME_meta_get_info, landmark_NAME_meta_add (replacing the
 * buffer's meta of that name, so an element run twice leaves one) and
 * landmark_NAME_meta_get, for the metas of the whole frame. */
#define DEFINE_FRAME_META(name, meta_name)                                   \
  const GstMetaInfo *gst_landmark_##name##_meta_get_info (void)               \
  {                                                                           \
    static const GstMetaInfo *info = register_frame_meta (meta_name);         \
    return info;                                                              \
  }                                                                           \
  GstStructure *landmark_##name##_meta_add (GstBuffer * buffer)               \
  {                                                                           \
    gst_landmark_##name##_meta_get_info ();                                   \
    return replace_custom_meta (buffer, meta_name);                           \
  }                                                                           \
  const GstStructure *landmark_##name##_meta_get (GstBuffer * buffer)         \
  {                                                                           \
    return custom_structure (buffer, meta_name);                              \
  }

DEFINE_FRAME_META (pose, GST_LANDMARK_POSE_META_NAME);
DEFINE_FRAME_META (map, GST_LANDMARK_MAP_META_NAME);
DEFINE_FRAME_META (floor, GST_LANDMARK_FLOOR_META_NAME);

void
landmark_meta_register (void)
{
  gst_landmark_map_meta_get_info ();
  gst_landmark_labels_meta_get_info ();
  gst_landmark_pose_meta_get_info ();
  gst_landmark_detections_meta_get_info ();
  gst_landmark_floor_meta_get_info ();
}

GstStructure *
landmark_labels_meta_add (GstBuffer * buffer)
{
  gst_landmark_labels_meta_get_info ();
  return replace_custom_meta (buffer, GST_LANDMARK_LABELS_META_NAME);
}

const GstStructure *
landmark_labels_meta_get (GstBuffer * buffer)
{
  return custom_structure (buffer, GST_LANDMARK_LABELS_META_NAME);
}

gboolean
landmark_labels_get_plane (const GstStructure * labels, GstBuffer ** plane,
    guint * width, guint * height, guint * stride)
{
  GstBuffer *buf = nullptr;
  guint w, h, s;
  if (!gst_structure_get (labels,
          LANDMARK_LABELS_PLANE, GST_TYPE_BUFFER, &buf,
          LANDMARK_LABELS_WIDTH, G_TYPE_UINT, &w,
          LANDMARK_LABELS_HEIGHT, G_TYPE_UINT, &h,
          LANDMARK_LABELS_STRIDE, G_TYPE_UINT, &s, nullptr))
    return FALSE;
  if (s < w || gst_buffer_get_size (buf) < (gsize) s * h) {
    gst_buffer_unref (buf);
    return FALSE;
  }
  *plane = buf;
  *width = w;
  *height = h;
  *stride = s;
  return TRUE;
}

guint
landmark_labels_n_classes (const GstStructure * labels)
{
  const GValue *names = gst_structure_get_value (labels,
      LANDMARK_LABELS_CLASS_NAMES);
  return names && GST_VALUE_HOLDS_ARRAY (names) ?
      gst_value_array_get_size (names) : 0;
}

const gchar *
landmark_labels_class_name (const GstStructure * labels, guint index)
{
  const GValue *v = array_element (labels, LANDMARK_LABELS_CLASS_NAMES, index);
  return v && G_VALUE_HOLDS_STRING (v) ? g_value_get_string (v) : nullptr;
}

gboolean
landmark_labels_class_is_marker (const GstStructure * labels, guint index)
{
  const GValue *v = array_element (labels, LANDMARK_LABELS_CLASS_MARKERS,
      index);
  return v && G_VALUE_HOLDS_BOOLEAN (v) && g_value_get_boolean (v);
}

const gchar *
landmark_labels_class_role (const GstStructure * labels, guint index)
{
  const GValue *v = array_element (labels, LANDMARK_LABELS_CLASS_ROLES,
      index);
  return v && G_VALUE_HOLDS_STRING (v) ? g_value_get_string (v) : nullptr;
}

guint
landmark_labels_class_count (const GstStructure * labels, guint index)
{
  const GValue *v = array_element (labels, LANDMARK_LABELS_CLASS_COUNTS,
      index);
  return v && G_VALUE_HOLDS_UINT (v) ? g_value_get_uint (v) : 0;
}

const GValue *
landmark_labels_class_value (const GstStructure * labels, const gchar * field,
    guint index)
{
  return array_element (labels, field, index);
}

GstVideoRegionOfInterestMeta *
landmark_detection_add (GstBuffer * buffer, const gchar * class_name,
    guint x, guint y, guint w, guint h)
{
  const guint id = landmark_detection_count (buffer);
  GstVideoRegionOfInterestMeta *roi =
      gst_buffer_add_video_region_of_interest_meta (buffer, class_name, x, y,
      w, h);
  if (roi)
    roi->id = (gint) id;
  return roi;
}

GstVideoRegionOfInterestMeta *
landmark_detection_add_from_plane (GstBuffer * buffer,
    const gchar * class_name, gint x, gint y, gint w, gint h,
    guint plane_w, guint plane_h, gint frame_w, gint frame_h)
{
  if (frame_w > 0 && frame_h > 0 && plane_w > 0 && plane_h > 0 &&
      ((guint) frame_w != plane_w || (guint) frame_h != plane_h)) {
    const double sx = (double) frame_w / plane_w;
    const double sy = (double) frame_h / plane_h;
    const gint x1 = (gint) std::ceil ((x + w) * sx);
    const gint y1 = (gint) std::ceil ((y + h) * sy);
    x = (gint) std::floor (x * sx);
    y = (gint) std::floor (y * sy);
    w = MAX (1, x1 - x);
    h = MAX (1, y1 - y);
  }
  return landmark_detection_add (buffer, class_name, x, y, w, h);
}

void
landmark_detection_add_param (GstBuffer * buffer,
    GstVideoRegionOfInterestMeta * roi, GstStructure * param)
{
  gst_landmark_detections_meta_get_info ();
  GstCustomMeta *meta = gst_buffer_get_custom_meta (buffer,
      GST_LANDMARK_DETECTIONS_META_NAME);
  if (!meta)
    meta = gst_buffer_add_custom_meta (buffer,
        GST_LANDMARK_DETECTIONS_META_NAME);
  if (meta) {
    GstStructure *all = gst_custom_meta_get_structure (meta);
    char key[32];
    detection_key (roi->id, key);
    const GValue *v = gst_structure_get_value (all, key);
    GstStructure *entry = v ? gst_structure_copy (gst_value_get_structure (v))
        : gst_structure_new ("landmark-detection", "class", G_TYPE_STRING,
        g_quark_to_string (roi->roi_type), nullptr);
    gst_structure_set (entry, gst_structure_get_name (param),
        GST_TYPE_STRUCTURE, param, nullptr);
    gst_structure_set (all, key, GST_TYPE_STRUCTURE, entry, nullptr);
    gst_structure_free (entry);
  }
  gst_video_region_of_interest_meta_add_param (roi, param);
}

const GstStructure *
landmark_detection_get_param (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi, const gchar * name)
{
  const GstStructure *p = gst_video_region_of_interest_meta_get_param (
      (GstVideoRegionOfInterestMeta *) roi, name);
  if (p)
    return p;
  const GstStructure *all = custom_structure (buffer,
      GST_LANDMARK_DETECTIONS_META_NAME);
  if (!all)
    return nullptr;
  char key[32];
  detection_key (roi->id, key);
  const GValue *v = gst_structure_get_value (all, key);
  if (!v || !GST_VALUE_HOLDS_STRUCTURE (v))
    return nullptr;
  const GValue *pv = gst_structure_get_value (gst_value_get_structure (v),
      name);
  return pv && GST_VALUE_HOLDS_STRUCTURE (pv) ? gst_value_get_structure (pv)
      : nullptr;
}

namespace {

bool
param_flag (const GstStructure * p, const gchar * name)
{
  gboolean value = FALSE;
  return p && gst_structure_get_boolean (p, name, &value) && value;
}

bool
param_not_kept (const GstStructure * p)
{
  gboolean kept = TRUE;
  return p && gst_structure_get_boolean (p, "kept", &kept) && !kept;
}

}  // namespace

LandmarkDetectionParams
landmark_detection_params (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi)
{
  return { landmark_detection_get_param (buffer, roi, LANDMARK_BLOB_PARAMS),
    landmark_detection_get_param (buffer, roi, LANDMARK_RANGE_PARAMS),
    landmark_detection_get_param (buffer, roi, LANDMARK_MATCH_PARAMS) };
}

gboolean
landmark_detection_rejected (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi, const gchar ** element,
    const gchar ** reason)
{
  const auto [blob, range, match] = landmark_detection_params (buffer, roi);
  /* blobroundness's marginal shape stands when ipmrange's size against
   * range and trilaterate's map both confirmed it (docs/detection.md) */
  const bool shape_confirmed = param_flag (range, "shape-confirmed")
      && param_flag (match, "matched");
  const struct
  {
    const GstStructure *params;
    const gchar *element;
  } stages[] = {
    /* beacondetect's landmark-blob reads the bands it was made of */
    {blob, blob && gst_structure_has_field (blob, "bands") ? "beacondetect" :
          "blobroundness"},
    {range, "ipmrange"},
  };
  for (const auto & stage : stages) {
    if (shape_confirmed && param_flag (stage.params, "shape-marginal"))
      continue;
    if (param_not_kept (stage.params)) {
      *element = stage.element;
      *reason = gst_structure_get_string (stage.params, "reject-reason");
      return TRUE;
    }
  }
  const gchar *why = match ? gst_structure_get_string (match, "reason") :
      nullptr;
  /* the map disagrees: no landmark of its class where it was seen, not
   * in the consensus, or a colour the map has once seen twice (the other
   * detection took the landmark) */
  if (why && (g_str_equal (why, "outside-gate") || g_str_equal (why,
              "outlier") || g_str_equal (why, "duplicate"))) {
    *element = "trilaterate";
    *reason = why;
    return TRUE;
  }
  return FALSE;
}

gboolean
landmark_detection_awaits_map (GstBuffer * buffer,
    const GstVideoRegionOfInterestMeta * roi)
{
  const GstStructure *range = landmark_detection_get_param (buffer, roi,
      LANDMARK_RANGE_PARAMS);
  return range && !param_not_kept (range)
      && param_flag (range, "shape-confirmed")
      && param_flag (landmark_detection_get_param (buffer, roi,
          LANDMARK_BLOB_PARAMS), "shape-marginal")
      && !landmark_detection_get_param (buffer, roi, LANDMARK_MATCH_PARAMS);
}

GstVideoRegionOfInterestMeta *
landmark_detection_get (GstBuffer * buffer, gint id)
{
  return gst_buffer_get_video_region_of_interest_meta_id (buffer, id);
}

guint
landmark_detection_count (GstBuffer * buffer)
{
  guint n = 0;
  gpointer state = nullptr;
  while (gst_buffer_iterate_meta_filtered (buffer, &state,
          GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))
    n++;
  return n;
}


gboolean
landmark_floor_map_array (const GstStructure * floor, const gchar * field,
    gsize elem_size, GstBuffer ** plane, GstMapInfo * map, gsize * count)
{
  GstBuffer *buf = nullptr;
  if (!gst_structure_get (floor, field, GST_TYPE_BUFFER, &buf, nullptr))
    return FALSE;
  if (!gst_buffer_map (buf, map, GST_MAP_READ)) {
    gst_buffer_unref (buf);
    return FALSE;
  }
  *plane = buf;
  *count = map->size / elem_size;
  return TRUE;
}

GstEvent *
landmark_odometry_event_new (gdouble dx, gdouble dy, gdouble dheading,
    gboolean out_of_band)
{
  return gst_event_new_custom (out_of_band ?
      GST_EVENT_CUSTOM_DOWNSTREAM_OOB : GST_EVENT_CUSTOM_DOWNSTREAM,
      gst_structure_new (GST_LANDMARK_ODOMETRY_EVENT_NAME,
          "dx", G_TYPE_DOUBLE, dx, "dy", G_TYPE_DOUBLE, dy,
          "dheading", G_TYPE_DOUBLE, dheading, nullptr));
}

GstStructure *
landmark_frame_message_new (const gchar * name, GstBuffer * buf,
    const GstSegment * segment)
{
  const GstClockTime ts = GST_BUFFER_PTS (buf);
  return gst_structure_new (name,
      "timestamp", G_TYPE_UINT64, ts,
      "stream-time", G_TYPE_UINT64,
      gst_segment_to_stream_time (segment, GST_FORMAT_TIME, ts),
      "running-time", G_TYPE_UINT64,
      gst_segment_to_running_time (segment, GST_FORMAT_TIME, ts), nullptr);
}

static void
value_array_append (GValue * array, GType type, void (*set) (GValue *,
        gconstpointer), gconstpointer x)
{
  GValue v = G_VALUE_INIT;
  g_value_init (&v, type);
  set (&v, x);
  gst_value_array_append_and_take_value (array, &v);
}

void
landmark_value_array_append_uint (GValue * array, guint x)
{
  value_array_append (array, G_TYPE_UINT,[](GValue * v, gconstpointer p) {
        g_value_set_uint (v, *(const guint *) p);}, &x);
}

void
landmark_value_array_append_double (GValue * array, gdouble x)
{
  value_array_append (array, G_TYPE_DOUBLE,[](GValue * v, gconstpointer p) {
        g_value_set_double (v, *(const gdouble *) p);}, &x);
}

void
landmark_value_array_append_boolean (GValue * array, gboolean x)
{
  value_array_append (array, G_TYPE_BOOLEAN,[](GValue * v, gconstpointer p) {
        g_value_set_boolean (v, *(const gboolean *) p);}, &x);
}

void
landmark_value_array_append_string (GValue * array, const gchar * x)
{
  value_array_append (array, G_TYPE_STRING,[](GValue * v, gconstpointer p) {
        g_value_set_string (v, (const gchar *) p);}, x);
}

void
landmark_detections_collect (GstBuffer * buffer,
    std::vector < GstVideoRegionOfInterestMeta * >*out)
{
  out->clear ();
  gpointer iter = nullptr;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (buffer, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)))
    out->push_back ((GstVideoRegionOfInterestMeta *) meta);
}
