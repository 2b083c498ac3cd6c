#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "posemeta.h"

#include "landmarkmap.h"

#include "landmarkmeta.h"

namespace landmark {

/* A blob touching the frame's edge (blobroundness's frame size). */
static bool
cut_by_border (GstBuffer * buf, const GstVideoRegionOfInterestMeta * roi)
{
  const GstStructure *blob = landmark_detection_get_param (buf, roi,
      LANDMARK_BLOB_PARAMS);
  guint fw = 0, fh = 0;
  return blob && gst_structure_get_uint (blob, "frame-width", &fw)
      && gst_structure_get_uint (blob, "frame-height", &fh)
      && (roi->x == 0 || roi->y == 0 || roi->x + roi->w >= fw
      || roi->y + roi->h >= fh);
}

void
ranged_detections_collect (GstBuffer * buf, bool skip_cut,
    bool with_marginal, bool with_coded, RangedDetections * out)
{
  out->dets.clear ();
  out->rois.clear ();
  out->skipped.clear ();
  landmark_detections_collect (buf, &out->all);
  for (GstVideoRegionOfInterestMeta * roi : out->all) {
    /* rejected upstream: by shape (blobroundness) or size (ipmrange);
     * a marginal shape the size confirmed waits for the map's word */
    const gchar *by, *why;
    if (landmark_detection_rejected (buf, roi, &by, &why) && !(with_marginal
            && landmark_detection_awaits_map (buf, roi))) {
      out->skipped.push_back ({ roi, "not-kept" });
      continue;
    }
    if (skip_cut && cut_by_border (buf, roi)) {
      out->skipped.push_back ({ roi, "cut-by-border" });
      continue;
    }
    const GstStructure *r = landmark_detection_get_param (buf, roi,
        LANDMARK_RANGE_PARAMS);
    gboolean no_floor = FALSE;
    Detection d;
    if (!r || (gst_structure_get_boolean (r, "no-floor", &no_floor)
            && no_floor)
        || !gst_structure_get_double (r, "ground-x", &d.obs.gx)
        || !gst_structure_get_double (r, "ground-y", &d.obs.gy)) {
      out->skipped.push_back ({ roi, "no-range" });
      continue;
    }
    gst_structure_get_double (r, "range-sigma", &d.obs.range_sigma);
    gst_structure_get_double (r, "bearing-sigma", &d.obs.bearing_sigma);
    const gchar *cls = g_quark_to_string (roi->roi_type);
    d.class_name = cls ? cls : "";
    /* beacondetect's coded markers match by their code alone */
    const GstStructure *blob = landmark_detection_get_param (buf, roi,
        LANDMARK_BLOB_PARAMS);
    if (const gchar *code = blob ? gst_structure_get_string (blob, "code") :
        nullptr) {
      if (!with_coded) {
        out->skipped.push_back ({ roi, "coded-marker" });
        continue;
      }
      d.class_name = coded_match_class (code);
    }
    const gchar *kind = gst_structure_get_string (r, "marker-kind");
    d.has_marker = kind
        && gst_structure_get_double (r, "marker-height", &d.marker_z)
        && gst_structure_get_double (r, "marker-diameter",
        &d.marker_diameter);
    d.marker_ball = d.has_marker && g_str_equal (kind, "ball");
    out->dets.push_back (d);
    out->rois.push_back (roi);
  }
}

void
pose_fields_set (GstStructure * s, const PoseFields & p)
{
  GValue cov = G_VALUE_INIT, ids = G_VALUE_INIT;
  gst_value_array_init (&cov, 9);
  for (double c : p.cov)
    landmark_value_array_append_double (&cov, c);
  gst_value_array_init (&ids, p.ids.size ());
  for (const auto & id : p.ids)
    landmark_value_array_append_string (&ids, id.c_str ());
  gst_structure_set (s,
      "x", G_TYPE_DOUBLE, p.pose.x,
      "y", G_TYPE_DOUBLE, p.pose.y,
      "heading", G_TYPE_DOUBLE, p.pose.heading,
      "n-landmarks", G_TYPE_UINT, (guint) p.ids.size (),
      "residual", G_TYPE_DOUBLE, p.residual,
      "solver", G_TYPE_STRING, p.solver.c_str (),
      "geometry", G_TYPE_STRING, p.geometry.c_str (),
      "filter", G_TYPE_STRING, p.filter.c_str (), nullptr);
  gst_structure_take_value (s, "covariance", &cov);
  gst_structure_take_value (s, "landmarks", &ids);
}

}  // namespace landmark
