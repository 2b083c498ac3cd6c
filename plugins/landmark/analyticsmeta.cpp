#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "analyticsmeta.h"

#ifdef HAVE_GST_ANALYTICS

#include <gst/analytics/analytics.h>
#include <gst/video/video.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "landmarkmeta.h"

namespace {

/* The label of pixels no class took (label 0) in the segmentation's
 * classification. */
constexpr const char *kUnclassified = "unclassified";

/* The class names our entries use: the labels' classes, else those of the
 * detections (region-of-interest metas from elsewhere). */
std::vector<GQuark>
our_classes (GstBuffer * buf, const GstStructure * labels)
{
  std::vector<GQuark> q {g_quark_from_static_string (kUnclassified)};
  if (labels) {
    for (guint i = 0; i < landmark_labels_n_classes (labels); i++)
      q.push_back (g_quark_from_string (landmark_labels_class_name (labels,
                  i)));
  } else {
    for (guint i = 0; i < landmark_detection_count (buf); i++)
      if (GstVideoRegionOfInterestMeta * roi = landmark_detection_get (buf, i))
        q.push_back (roi->roi_type);
  }
  return q;
}

bool
is_ours (const std::vector<GQuark> & classes, GQuark q)
{
  for (GQuark c : classes)
    if (c == q)
      return true;
  return false;
}

/* How the buffer's relation meta relates to us: none, written by one of
 * our elements (every entry a box, classification, tracking or
 * segmentation of our classes), or another producer's, with or without our
 * entries appended. */
enum class Owner { kNone, kOurs, kForeign, kForeignWithOurs };

Owner
owner_of (GstAnalyticsRelationMeta * rmeta,
    const std::vector<GQuark> & classes)
{
  if (!rmeta)
    return Owner::kNone;
  bool foreign = false, ours = false;
  gpointer state = nullptr;
  GstAnalyticsMtd mtd;
  while (gst_analytics_relation_meta_iterate (rmeta, &state,
          GST_ANALYTICS_MTD_TYPE_ANY, &mtd)) {
    const GstAnalyticsMtdType type = gst_analytics_mtd_get_mtd_type (&mtd);
    if (type == gst_analytics_od_mtd_get_mtd_type ()) {
      const bool mine = is_ours (classes,
          gst_analytics_od_mtd_get_obj_type ((GstAnalyticsODMtd *) & mtd));
      ours |= mine;
      foreign |= !mine;
    } else if (type == gst_analytics_cls_mtd_get_mtd_type ()) {
      auto *cls = (GstAnalyticsClsMtd *) & mtd;
      bool mine = true;
      for (gsize i = 0; i < gst_analytics_cls_mtd_get_length (cls); i++)
        mine &= is_ours (classes, gst_analytics_cls_mtd_get_quark (cls, i));
      ours |= mine;
      foreign |= !mine;
    } else if (type != gst_analytics_tracking_mtd_get_mtd_type ()
#ifdef HAVE_GST_ANALYTICS_SEGMENTATION
        && type != gst_analytics_segmentation_mtd_get_mtd_type ()
#endif
        ) {
      foreign = true;
    }
  }
  if (!foreign)
    return Owner::kOurs;
  return ours ? Owner::kForeignWithOurs : Owner::kForeign;
}

#ifdef HAVE_GST_ANALYTICS_SEGMENTATION
/* The label plane as a semantic segmentation (region id = label, 0 = no
 * class) with a classification naming each region, related N-to-N as
 * segmentationoverlay reads it. The mask is a second GstBuffer on the
 * plane's memory (no pixel copied) carrying the GRAY8 video meta the API
 * asks for. */
void
add_segmentation (GstAnalyticsRelationMeta * rmeta,
    const GstStructure * labels, const std::vector<GQuark> & classes)
{
  GstBuffer *plane;
  guint w, h, stride;
  if (!landmark_labels_get_plane (labels, &plane, &w, &h, &stride))
    return;
  if (w == 0 || h == 0) {
    gst_buffer_unref (plane);
    return;
  }
  GstBuffer *mask = gst_buffer_copy (plane);
  gst_buffer_unref (plane);
  gsize offset[GST_VIDEO_MAX_PLANES] = {0};
  gint strides[GST_VIDEO_MAX_PLANES] = {(gint) stride};
  gst_buffer_add_video_meta_full (mask, GST_VIDEO_FRAME_FLAG_NONE,
      GST_VIDEO_FORMAT_GRAY8, w, h, 1, offset, strides);
  guint frame_w = w, frame_h = h;
  gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_WIDTH, &frame_w);
  gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_HEIGHT, &frame_h);

  std::vector<guint> ids (classes.size ());
  std::vector<GQuark> quarks (classes);
  std::vector<gfloat> levels (classes.size (), -1.0f);  /* -1: undefined */
  for (guint i = 0; i < ids.size (); i++)
    ids[i] = i;
  GstAnalyticsSegmentationMtd seg;
  GstAnalyticsClsMtd cls;
  if (!gst_analytics_relation_meta_add_segmentation_mtd (rmeta, mask,
          GST_SEGMENTATION_TYPE_SEMANTIC, ids.size (), ids.data (), 0, 0,
          frame_w, frame_h, &seg)) {
    gst_buffer_unref (mask);
    return;
  }
  if (gst_analytics_relation_meta_add_cls_mtd (rmeta, quarks.size (),
          levels.data (), quarks.data (), &cls))
    gst_analytics_relation_meta_set_relation (rmeta,
        GST_ANALYTICS_REL_TYPE_N_TO_N, seg.id, cls.id);
}
#endif

double
param_double (const GstStructure * s, const char *name, double fallback)
{
  gdouble v;
  return s && gst_structure_get_double (s, name, &v) ? v : fallback;
}

/* The object box: the fitted ellipse's axes turned by its angle (clockwise
 * on screen, the API's sense) on >= 1.26, else the region of interest.
 * The ellipse is in label-plane pixels; when the plane is not the frame's
 * size the region of interest, in frame pixels, gives the scale. */
gboolean
add_box (GstAnalyticsRelationMeta * rmeta, GstBuffer * buf,
    const GstVideoRegionOfInterestMeta * roi, gfloat confidence,
    GstAnalyticsODMtd * od)
{
#ifdef HAVE_GST_ANALYTICS_ORIENTED_BOX
  const GstStructure *blob = landmark_detection_get_param (buf, roi,
      LANDMARK_BLOB_PARAMS);
  const double ex = param_double (blob, "ellipse-x", NAN);
  const double ey = param_double (blob, "ellipse-y", NAN);
  const double major = param_double (blob, "ellipse-major", 0);
  const double minor = param_double (blob, "ellipse-minor", 0);
  if (std::isfinite (ex) && std::isfinite (ey) && major > 0 && minor > 0) {
    const double cx = roi->x + roi->w / 2.0, cy = roi->y + roi->h / 2.0;
    const bool same_size = std::fabs (cx - ex) <= roi->w / 2.0 + 1
        && std::fabs (cy - ey) <= roi->h / 2.0 + 1;
    const double sx = same_size || ex <= 0 ? 1.0 : cx / ex;
    const double sy = same_size || ey <= 0 ? 1.0 : cy / ey;
    const double w = major * sx, h = minor * sy;
    double r = std::fmod (param_double (blob, "ellipse-angle", 0),
        2 * G_PI);
    if (r < 0)
      r += 2 * G_PI;
    return gst_analytics_relation_meta_add_oriented_od_mtd (rmeta,
        roi->roi_type, (gint) std::lround (ex * sx - w / 2),
        (gint) std::lround (ey * sy - h / 2), (gint) std::lround (w),
        (gint) std::lround (h), (gfloat) r, confidence, od);
  }
#endif
  return gst_analytics_relation_meta_add_od_mtd (rmeta, roi->roi_type,
      roi->x, roi->y, roi->w, roi->h, confidence, od);
}

/* A map landmark's id as a tracking id: the number itself when the id is
 * decimal, else its 64-bit FNV-1a hash (stable across runs and machines). */
guint64
tracking_id (const char *id)
{
  char *end = nullptr;
  const guint64 n = g_ascii_strtoull (id, &end, 10);
  if (*id && end && *end == '\0')
    return n;
  guint64 hash = 14695981039346656037ull;
  for (const char *p = id; *p; p++)
    hash = (hash ^ (guchar) * p) * 1099511628211ull;
  return hash;
}

void
add_detection (GstAnalyticsRelationMeta * rmeta, GstBuffer * buf,
    const GstVideoRegionOfInterestMeta * roi)
{
  const gchar *element, *reason;
  if (landmark_detection_rejected (buf, roi, &element, &reason))
    return;
  /* the colour confidence: the share of the fitted ellipse that the class's
   * colour fills (landmark-blob ellipse-fit), 1 without it */
  const GstStructure *blob = landmark_detection_get_param (buf, roi,
      LANDMARK_BLOB_PARAMS);
  const gfloat confidence = (gfloat) CLAMP (param_double (blob, "ellipse-fit",
          1.0), 0.0, 1.0);
  GstAnalyticsODMtd od;
  GstAnalyticsClsMtd cls;
  if (!add_box (rmeta, buf, roi, confidence, &od))
    return;
  if (gst_analytics_relation_meta_add_one_cls_mtd (rmeta, confidence,
          roi->roi_type, &cls))
    gst_analytics_relation_meta_set_relation (rmeta,
        GST_ANALYTICS_REL_TYPE_RELATE_TO, od.id, cls.id);

  const GstStructure *match = landmark_detection_get_param (buf, roi,
      LANDMARK_MATCH_PARAMS);
  gboolean matched = FALSE;
  const gchar *landmark = match ? gst_structure_get_string (match,
      "landmark-id") : nullptr;
  if (!landmark || !gst_structure_get_boolean (match, "matched", &matched)
      || !matched)
    return;
  GstAnalyticsTrackingMtd trk;
  if (gst_analytics_relation_meta_add_tracking_mtd (rmeta,
          tracking_id (landmark), GST_BUFFER_PTS (buf), &trk)) {
    gst_analytics_tracking_mtd_update_last_seen (&trk, GST_BUFFER_PTS (buf));
    gst_analytics_relation_meta_set_relation (rmeta,
        GST_ANALYTICS_REL_TYPE_RELATE_TO, od.id, trk.id);
  }
}

}  // namespace

void
landmark_analytics_sync (GstBuffer * buf)
{
  const GstStructure *labels = landmark_labels_meta_get (buf);
  const guint n = landmark_detection_count (buf);
#ifdef HAVE_GST_ANALYTICS_SEGMENTATION
  const bool segmentation = labels != nullptr;
#else
  const bool segmentation = false;
#endif
  if (!segmentation && n == 0)
    return;
  const std::vector<GQuark> classes = our_classes (buf, labels);
  GstAnalyticsRelationMeta *rmeta = gst_buffer_get_analytics_relation_meta
      (buf);
  switch (owner_of (rmeta, classes)) {
    case Owner::kForeignWithOurs:
      return;                   /* appended by an earlier stage: left */
    case Owner::kOurs:
      /* entries cannot be taken out one by one: write them all again */
      gst_buffer_remove_meta (buf, (GstMeta *) rmeta);
      rmeta = nullptr;
      break;
    default:
      break;
  }
  if (!rmeta)
    rmeta = gst_buffer_add_analytics_relation_meta (buf);
  if (!rmeta)
    return;
#ifdef HAVE_GST_ANALYTICS_SEGMENTATION
  if (segmentation)
    add_segmentation (rmeta, labels, classes);
#endif
  for (guint i = 0; i < n; i++)
    if (GstVideoRegionOfInterestMeta * roi = landmark_detection_get (buf, i))
      add_detection (rmeta, buf, roi);
}

#else

void
landmark_analytics_sync (GstBuffer *)
{
}

#endif
