/**
 * SECTION:element-blobroundness
 * @title: blobroundness
 *
 * Finds the landmark blobs in the class labels that `labsegment` attaches
 * (`GstLandmarkLabelsMeta`, docs/metadata.md) and measures them: the seed's
 * steps 4 to 6. For every selected class (`classes`, by default every class
 * the palette marks as a marker) the label plane is a binary image,
 * optionally opened then closed with a disc of `morphology` pixels; each
 * 8-connected component is one blob. Per blob: area (pixels), perimeter,
 * roundness `4 pi area / perimeter^2`, sub-pixel centroid, bounding box,
 * equivalent diameter, the ellipse with the blob's second moments and how
 * well the blob matches it (`ellipse-fit`: intersection over union of the
 * blob and the pixels inside the ellipse).
 *
 * Filters, in order: `min-area`, `max-area`, `max-aspect` (major / minor
 * axis of the ellipse), then the shape test. `shape=circle` is the seed's:
 * roundness at least `min-roundness`. `shape=ellipse` (the default) accepts
 * a disc seen at a slant, whose image is an ellipse and whose roundness
 * falls with distance: `ellipse-fit` at least `min-ellipse-fit`. Squares,
 * stripes and triangles match their ellipse worse (about 0.83, 0.83 and
 * 0.68 when large). A blob touching the frame edge may be a cut landmark:
 * an ellipse is also fitted to its outline away from the edge, and the
 * better match counts.
 *
 * The perimeter is the length of a line-fit polygon of the outline (for
 * small blobs blended with the smoothed outline): it has neither the
 * staircase error of chain codes nor the corner loss of smoothing, so a
 * digitised disc (radius >= 5 px) scores >= 0.94 and a square (side >= 20
 * px, any rotation) <= 0.79; docs/blobroundness.md has the estimator, its
 * measured table, and the evaluation behind the defaults. A blob's hole
 * counts neither as area nor as perimeter: a ring scores about
 * `1 - (r/R)^2` of a disc.
 *
 * Each kept blob gets a `GstVideoRegionOfInterestMeta` (`roi_type` = class
 * name, `id` = 0, 1, 2, ... in the buffer, the bounding box) with a
 * `landmark-blob` parameter structure: `class`, `area`, `perimeter`,
 * `roundness`, `centroid-x`, `centroid-y`, `equivalent-diameter`,
 * `ellipse-x`, `ellipse-y`, `ellipse-major`, `ellipse-minor`,
 * `ellipse-angle` (radians), `ellipse-fit`, `kept`, `reject-reason` (only
 * when not kept: `area`, `max-area`, `aspect`, `roundness`, `ellipse-fit`),
 * `frame-width`, `frame-height` (docs/metadata.md). With
 * `keep-rejected=true` rejected blobs are attached too (`kept` false).
 * With the automatic shape test a near miss is attached even without it,
 * rejected and marked `shape-marginal`: ipmrange's size and trilaterate's
 * match may still accept it (docs/detection.md).
 *
 * Video passes unchanged and is never mapped: any `video/x-raw` caps are
 * accepted. Without a labels meta, buffers pass untouched and one warning
 * is posted. Frames are never dropped (QoS is off). Every property may
 * change while playing; a bad value set while playing is reported with a
 * warning and the previous settings stay in force. A class named in
 * `classes` that the labels do not have is an error at the first buffer
 * (the palette is only known then).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! avidemux ! jpegdec !
 *     videoconvert ! labsegment palette=palette.json min-class-pixels=0 !
 *     blobroundness ! landmarklog location=blobs.jsonl ! fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstblobroundness.h"

#include <gst/video/video.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "blobshape.h"
#include "elementsettings.h"
#include "simdlevel.h"
#include "landmarkmeta.h"
#include "analyticsmeta.h"
#include "markerevidence.h"
#include "arcfit.h"

GST_DEBUG_CATEGORY_STATIC (gst_blob_roundness_debug);
#define GST_CAT_DEFAULT gst_blob_roundness_debug

#define MAX_MORPHOLOGY 255

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string classes;          /* empty: every marker class */
  guint morphology = 0;
  guint min_area = 100;
  guint max_area = 0;
  /* off: ipmrange checks the aspect a marker has at its range */
  gdouble max_aspect = 0.0;
  gdouble min_roundness = 0.85;
  /* -1: follow the blob's size (markerevidence.h, shape_fit_threshold) */
  gdouble min_ellipse_fit = -1.0;
  GstBlobRoundnessShape shape = GST_BLOB_ROUNDNESS_SHAPE_ELLIPSE;
  gboolean keep_rejected = FALSE;
  guint n_threads = 0;  /* 0: landmark::frame_threads decides */
};

/* Settings checked and parsed: what the streaming thread works with. */
struct Config {
  Settings s;
  std::vector<std::string> classes;   /* empty: every marker class */
};

/* Built in start(), used by the streaming thread only. */
struct State {
  landmark::AppliedSettings<Settings, Config> applied;

  /* the labels' classes, the video size, the warnings given */
  landmark::LabelsInput input;
  uint8_t slot_of[256] = { 0 };
  std::vector<guint> wanted_labels;

  landmark::BlobAnalyzer analyzer;
  /* threads of the run search, started on the first frame that needs them */
  landmark::WorkerPool workers;
  landmark::BlobShape shape;
  landmark::ArcCircleFit arc_fit;
  landmark::ArcCircle arc;
  std::vector<uint8_t> morph_in, morph_out;
  cv::Mat kernel;
  guint kernel_size = 0;

};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstBlobRoundness, gst_blob_roundness,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, blobroundness,
    "Landmark blob measurement");

LANDMARK_DEFINE_ENUM_TYPE (gst_blob_roundness_shape_get_type,
    "GstBlobRoundnessShape",
    {GST_BLOB_ROUNDNESS_SHAPE_CIRCLE,
        "Roundness of the image blob at least min-roundness (the seed's test)",
        "circle"},
    {GST_BLOB_ROUNDNESS_SHAPE_ELLIPSE,
          "The blob matches its moment ellipse (ellipse-fit at least "
          "min-ellipse-fit): a disc seen at a slant",
        "ellipse"});

/* ---- configuration -------------------------------------------------- */

/* Checks the settings and parses them into cfg. */
static bool
blob_roundness_parse (const Settings & s, Config * cfg,
    landmark::SettingsError * err)
{
  if (s.morphology % 2 == 0 && s.morphology != 0)
    return err->fail ("morphology", "the kernel size must be 0 (off) or "
        "odd, got " + std::to_string (s.morphology));
  if (s.max_area != 0 && s.min_area > s.max_area)
    return err->fail ("min-area", "min-area (" + std::to_string (s.min_area)
        + ") is larger than max-area (" + std::to_string (s.max_area) + ")");
  if (!landmark::parse_name_list (s.classes, "classes", &cfg->classes, err))
    return false;
  cfg->s = s;
  return true;
}

static const landmark::PropertyTable<Settings> &
blob_roundness_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("classes", "Classes",
          "Comma-separated class names to find blobs of (unset: every class "
          "the palette marks as a marker)", &Settings::classes)
      .number ("morphology", "Morphology kernel",
          "Diameter in pixels of the disc each class is opened then closed "
          "with before blobs are found; 0 = off, otherwise odd",
          &Settings::morphology, 0u, (guint) MAX_MORPHOLOGY)
      .number ("min-area", "Minimum area",
          "Smallest blob kept, in pixels (the seed's noise threshold)",
          &Settings::min_area, 0u, G_MAXUINT)
      .number ("max-area", "Maximum area",
          "Largest blob kept, in pixels (0 = no limit)",
          &Settings::max_area, 0u, G_MAXUINT)
      .number ("max-aspect", "Maximum aspect ratio",
          "Largest ratio of the ellipse's major to minor axis kept (a floor "
          "disc seen from camera height h at range r images at about r/h); "
          "0 = no limit", &Settings::max_aspect, 0.0, G_MAXDOUBLE)
      .number ("min-roundness", "Minimum roundness",
          "shape=circle: smallest roundness 4 pi A / P^2 kept, 0..1",
          &Settings::min_roundness, 0.0, 1.0)
      .number ("min-ellipse-fit", "Minimum ellipse fit",
          "shape=ellipse: smallest intersection over union of the blob and "
          "its moment ellipse kept, 0..1; -1: from the blob's size (0.92 "
          "for large blobs, lower for small ones whose outline blur and "
          "compression move)", &Settings::min_ellipse_fit, -1.0, 1.0)
      .enumeration ("shape", "Shape test",
          "Which test tells landmarks from other blobs", &Settings::shape,
          GST_TYPE_BLOB_ROUNDNESS_SHAPE)
      .boolean ("keep-rejected", "Keep rejected",
          "Also attach rejected blobs (kept=false, with reject-reason), for "
          "tuning (near misses of the automatic shape test are always "
          "attached, as shape-marginal)", &Settings::keep_rejected)
      .number ("n-threads", "Threads",
          "Threads that search the label plane for runs in horizontal "
          "slices, with results identical to one thread (0: every core for "
          "planes of 1920x1080 pixels and more, one below)",
          &Settings::n_threads, 0u, landmark::WorkerPool::kMaxThreads);
  return table;
}

/* ---- states and caps ------------------------------------------------ */

static gboolean
gst_blob_roundness_start (GstBaseTransform * trans)
{
  auto self = GST_BLOB_ROUNDNESS (trans);
  const Settings & s = self->priv->state.applied.config.s;
  GST_INFO_OBJECT (self, "shape %s, min-area %u, max-area %u, max-aspect "
      "%.2f, min-roundness %.3f, min-ellipse-fit %.3f, morphology %u, "
      "classes %s", s.shape == GST_BLOB_ROUNDNESS_SHAPE_CIRCLE ?
      "circle" : "ellipse", s.min_area, s.max_area, s.max_aspect,
      s.min_roundness, s.min_ellipse_fit, s.morphology,
      s.classes.empty ()? "(markers)" : s.classes.c_str ());
  return TRUE;
}

static gboolean
gst_blob_roundness_stop (GstBaseTransform * trans)
{
  auto self = GST_BLOB_ROUNDNESS (trans);
  State & st = self->priv->state;
  st.input.classes.reset ();
  st.workers.resize (1);
  return TRUE;
}

static gboolean
gst_blob_roundness_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps * outcaps)
{
  auto self = GST_BLOB_ROUNDNESS (trans);
  State & st = self->priv->state;
  (void) outcaps;
  st.input.set_caps (incaps);
  /* the run search's vector level follows labsegment's (LANDMARK_SIMD) */
  st.analyzer.set_avx2 (landmark::simd_level () == landmark::SimdLevel::AVX2);
  GST_DEBUG_OBJECT (self, "caps %" GST_PTR_FORMAT, incaps);
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

/* Brings the state up to date with settings changed while running (a
 * bad value: a warning, and the previous settings stay). */
static void
gst_blob_roundness_sync_settings (GstBlobRoundness * self)
{
  State & st = self->priv->state;
  if (st.applied.sync (GST_ELEMENT (self), self->priv->settings,
          blob_roundness_parse)) {
    st.input.classes.valid = false;   /* `classes` may have changed */
    GST_INFO_OBJECT (self, "settings changed");
  }
}

/* Maps labels to slots for this frame's palette. Slot = label, so a slot
 * names its class directly. FALSE (error posted) on an unknown class. */
static gboolean
gst_blob_roundness_update_slots (GstBlobRoundness * self,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  if (!st.input.classes.changed (labels))
    return TRUE;
  memset (st.slot_of, 0, sizeof (st.slot_of));
  if (st.applied.config.classes.empty ()) {
    for (size_t k = 0; k < st.input.classes.markers.size (); k++)
      if (st.input.classes.markers[k])
        st.slot_of[k + 1] = k + 1;
  } else {
    if (!st.input.classes.labels_of (GST_ELEMENT (self), "classes",
            st.applied.config.classes, &st.wanted_labels))
      return FALSE;
    for (guint label : st.wanted_labels)
      st.slot_of[label] = label;
  }
  st.input.classes.valid = true;
  GST_DEBUG_OBJECT (self, "%zu classes in the labels",
      st.input.classes.names.size ());
  return TRUE;
}

/* Opens then closes each selected class with a disc of `size` pixels,
 * inside the class's bounding box plus a margin, and replaces its runs. */
static void
gst_blob_roundness_morphology (GstBlobRoundness * self, guint size)
{
  State & st = self->priv->state;
  landmark::BlobAnalyzer & a = st.analyzer;
  if (st.kernel_size != size) {
    st.kernel = cv::getStructuringElement (cv::MORPH_ELLIPSE,
        cv::Size (size, size));
    st.kernel_size = size;
  }
  const cv::Rect frame (0, 0, a.width (), a.height ());
  for (int slot = 1; slot < 256; slot++) {
    if (!st.slot_of[slot])
      continue;
    const cv::Rect box = a.slot_bounds (slot);
    if (box.empty ())
      continue;
    const int m = (int) size;
    const cv::Rect roi = cv::Rect (box.x - m, box.y - m, box.width + 2 * m,
        box.height + 2 * m) & frame;
    /* scratch grows to the largest box seen, then is reused; the Mats are
     * whole images of the box's size (not views into a larger image, whose
     * pixels outside the view OpenCV would read as the border) */
    const size_t need = (size_t) roi.width * roi.height;
    if (st.morph_in.size () < need) {
      st.morph_in.resize (need);
      st.morph_out.resize (need);
    }
    cv::Mat in (roi.height, roi.width, CV_8UC1, st.morph_in.data ());
    cv::Mat out (roi.height, roi.width, CV_8UC1, st.morph_out.data ());
    in.setTo (0);
    a.paint_slot (slot, in, roi.x, roi.y);
    /* outside the box: the frame edge, or a margin of background at least
     * the kernel wide; the default border value leaves it out of both */
    cv::morphologyEx (in, out, cv::MORPH_OPEN, st.kernel, cv::Point (-1, -1),
        1, cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
    cv::morphologyEx (out, in, cv::MORPH_CLOSE, st.kernel, cv::Point (-1, -1),
        1, cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
    a.remove_slot (slot);
    a.add_mask_runs (in, roi.x, roi.y, slot);
  }
}

static void
gst_blob_roundness_attach (GstBlobRoundness * self, GstBuffer * buf,
    const landmark::BlobShape & b, const char *class_name,
    const char *reject, bool marginal, double fit_threshold,
    const landmark::ArcCircle * arc, guint plane_w, guint plane_h)
{
  State & st = self->priv->state;
  /* the box in pixels of the current frame (the plane normally is) */
  GstVideoRegionOfInterestMeta *roi = landmark_detection_add_from_plane (buf,
      class_name, b.bbox_x, b.bbox_y, b.bbox_w, b.bbox_h, plane_w, plane_h,
      st.input.video_width, st.input.video_height);
  if (!roi)
    return;
  GstStructure *s = gst_structure_new (LANDMARK_BLOB_PARAMS,
      "class", G_TYPE_STRING, class_name,
      "area", G_TYPE_DOUBLE, b.area,
      "perimeter", G_TYPE_DOUBLE, b.perimeter,
      "roundness", G_TYPE_DOUBLE, b.roundness,
      "centroid-x", G_TYPE_DOUBLE, b.centroid_x,
      "centroid-y", G_TYPE_DOUBLE, b.centroid_y,
      "equivalent-diameter", G_TYPE_DOUBLE, b.equivalent_diameter,
      "ellipse-x", G_TYPE_DOUBLE, b.ellipse_x,
      "ellipse-y", G_TYPE_DOUBLE, b.ellipse_y,
      "ellipse-major", G_TYPE_DOUBLE, b.ellipse_major,
      "ellipse-minor", G_TYPE_DOUBLE, b.ellipse_minor,
      "ellipse-angle", G_TYPE_DOUBLE, b.ellipse_angle,
      "ellipse-fit", G_TYPE_DOUBLE, b.ellipse_fit,
      "ellipse-fit-threshold", G_TYPE_DOUBLE, fit_threshold,
      "kept", G_TYPE_BOOLEAN, reject == nullptr,
      "frame-width", G_TYPE_UINT, plane_w,
      "frame-height", G_TYPE_UINT, plane_h, nullptr);
  if (reject)
    gst_structure_set (s, "reject-reason", G_TYPE_STRING, reject, nullptr);
  if (marginal)
    gst_structure_set (s, "shape-marginal", G_TYPE_BOOLEAN, TRUE, nullptr);
  if (arc)
    gst_structure_set (s, "shape-evidence", G_TYPE_STRING, "arc",
        "arc-coverage", G_TYPE_DOUBLE, arc->coverage,
        "arc-fill", G_TYPE_DOUBLE, arc->fill, nullptr);
  landmark_detection_add_param (buf, roi, s);
}

static GstFlowReturn
gst_blob_roundness_process (GstBlobRoundness * self, GstBuffer * buf,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  const Settings & cfg = st.applied.config.s;

  LandmarkLabelPlane plane;
  bool failed;
  if (!plane.read (GST_ELEMENT (self), labels, &st.input.warned_bad_plane,
          &failed))
    return failed ? GST_FLOW_ERROR : GST_FLOW_OK;
  if (!gst_blob_roundness_update_slots (self, labels))
    return GST_FLOW_ERROR;
  const guint w = plane.width, h = plane.height;

  landmark::BlobAnalyzer & a = st.analyzer;
  a.begin (w, h);
  st.workers.resize (landmark::frame_threads (cfg.n_threads, (gsize) w * h));
  a.add_label_runs (plane.data, plane.stride, st.slot_of, st.workers);
  if (cfg.morphology > 0)
    gst_blob_roundness_morphology (self, cfg.morphology);
  a.label ();

  guint kept = 0, rejected = 0;
  for (size_t i = 0; i < a.count (); i++) {
    const double area = a.area (i);
    const char *reject = nullptr;
    if (area < cfg.min_area)
      reject = "area";
    else if (cfg.max_area && area > cfg.max_area)
      reject = "max-area";
    if (reject && !cfg.keep_rejected) {
      rejected++;
      continue;
    }
    landmark::BlobShape & b = st.shape;
    a.measure (i, &b);
    if (!reject && cfg.max_aspect > 0 &&
        b.ellipse_major > cfg.max_aspect * b.ellipse_minor)
      reject = "aspect";
    /* auto: the tolerance follows the blob's size, except for a blob cut
     * by the frame's edge (ipmrange cannot check its size, so its shape
     * alone must convince) and a small one (kSmallBlobPx) */
    const bool small = b.area < landmark::kSmallBlobPx;
    const double fit_threshold = cfg.min_ellipse_fit >= 0 ?
        cfg.min_ellipse_fit : b.touches_border || small ?
        landmark::kShapeFitLarge :
        landmark::shape_fit_threshold (b.ellipse_major, b.ellipse_minor);
    bool marginal = false;
    const landmark::ArcCircle *arc = nullptr;
    if (!reject) {
      if (cfg.shape == GST_BLOB_ROUNDNESS_SHAPE_CIRCLE) {
        if (b.roundness < cfg.min_roundness)
          reject = "roundness";
      } else if (b.ellipse_fit < fit_threshold) {
        reject = "ellipse-fit";
        /* part of a ball (its lit side, what a leg leaves, what the frame
         * holds): its moments describe the part, but its rim is an arc of
         * the ball's circle, whose image then is the blob's ellipse */
        if (cfg.min_ellipse_fit < 0 && st.arc_fit.fit (a.contour (), b,
                (int) w, (int) h, &st.arc)) {
          reject = nullptr;
          arc = &st.arc;
          b.ellipse_x = st.arc.cx;
          b.ellipse_y = st.arc.cy;
          /* the outline runs through boundary-pixel centres, half a pixel
           * inside the disc's edge */
          b.ellipse_major = b.ellipse_minor = 2 * st.arc.r + 1;
          b.ellipse_angle = 0;
        } else if (cfg.min_ellipse_fit < 0) {
          GST_LOG_OBJECT (self, "blob at %.0f,%.0f (%.0f px, fit %.3f): no "
              "rim, circle r %.1f coverage %.2f fill %.2f outside %.3f "
              "holes %.3f", b.centroid_x, b.centroid_y, b.area,
              b.ellipse_fit, st.arc.r, st.arc.coverage, st.arc.fill,
              st.arc.outside, st.arc.holes);
        }
        /* a near miss travels on as a candidate that only ipmrange's size
         * test and trilaterate's match together can accept; a cut blob has
         * no size to confirm it by */
        marginal = reject && cfg.min_ellipse_fit < 0 && !b.touches_border &&
            b.ellipse_fit >= landmark::shape_marginal_threshold
            (b.ellipse_major, b.ellipse_minor);
      } else if (cfg.min_ellipse_fit < 0 &&
          b.ellipse_minor < landmark::kMinBlobThicknessPx) {
        /* elliptical but thin: an edge's blend as much as a far disc */
        reject = "thin";
        marginal = !b.touches_border;
      }
    }
    if (reject)
      rejected++;
    else
      kept++;
    if (reject && !marginal && !cfg.keep_rejected)
      continue;
    const std::string & name = st.input.classes.names[b.slot - 1];
    gst_blob_roundness_attach (self, buf, b, name.c_str (), reject,
        marginal, fit_threshold, arc, w, h);
  }
  GST_LOG_OBJECT (self, "%ux%u labels: %zu blobs, %u kept, %u rejected", w,
      h, a.count (), kept, rejected);
  landmark_analytics_sync (buf);
  return GST_FLOW_OK;
}

static void
gst_blob_roundness_class_init (GstBlobRoundnessClass * klass)
{
  landmark::element_class_init<Settings, gst_blob_roundness_settings,
      blob_roundness_properties> (klass, gst_blob_roundness_finalize,
      "Landmark blob roundness", "Filter/Analyzer/Video",
      "Finds the blobs of marker classes in the labels of labsegment, "
      "measures area, perimeter, roundness and a fitted ellipse, keeps the "
      "round ones and attaches them as region-of-interest metadata");
  landmark::set_labels_measuring<GstBlobRoundness, gst_blob_roundness_get_type,
      blob_roundness_parse, gst_blob_roundness_start,
      gst_blob_roundness_sync_settings, gst_blob_roundness_process> (klass,
      gst_blob_roundness_stop, GST_DEBUG_FUNCPTR (gst_blob_roundness_set_caps));

  gst_type_mark_as_plugin_api (GST_TYPE_BLOB_ROUNDNESS_SHAPE,
      (GstPluginAPIFlags) 0);
}
