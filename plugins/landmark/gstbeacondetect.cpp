/**
 * SECTION:element-beacondetect
 * @title: beacondetect
 *
 * Finds the coded markers of a map (beacons, posts and cones: stacks of
 * colour bands, docs/beacons.md) in the class labels that `labsegment`
 * attaches (`GstLandmarkLabelsMeta`, docs/metadata.md) and names each by
 * its code, the band classes read top to bottom.
 *
 * The blobs of the classes the map's bands use are joined where one lies
 * right under another along the marker's axis: down the image within
 * `max-roll` degrees of its vertical, the gap between them at most a
 * third of the shorter band, overlapping across the axis. A chain read
 * top to bottom whose classes are a code of the map is that marker, if
 * its shape is the kind's: every band fills at least `min-fill` of its box
 * along and across the axis (a cylinder's side is a rectangle; a cone's
 * top band is a triangle and its stripes narrow upwards), the bands of an
 * upright cylinder are within `max-width-ratio` of each other's width,
 * and their lengths share the marker's as the map's band heights do.
 *
 * Each chain that reads a code gets a `GstVideoRegionOfInterestMeta`
 * (`roi_type` = the code, the box of all its bands) with a `landmark-blob`
 * structure as blobroundness's (docs/metadata.md): `class` and `code`
 * (the code), `kind` (`beacon`, `post`, `cone`), `bands`, `area`,
 * `centroid-x`, `centroid-y`, the axis (`axis-top-x`, `axis-top-y`,
 * `axis-base-x`, `axis-base-y`: where it leaves the top band and the
 * lowest one, the floor contact's nearest point; `axis-angle`, radians
 * from the image's vertical, positive clockwise), `height-px`,
 * `width-px` (the lowest band's), the ellipse fields of a box of that
 * size on the axis (for drawing), `min-band-fill`, `kept`,
 * `reject-reason`, `frame-width`, `frame-height`. A chain that
 * reads part of a code (the frame cuts a band off, or something hides
 * it) is attached as a candidate: `kept` false, `reject-reason`
 * `partial`, `class` the bands it reads, `candidate-codes` the codes it
 * may be. Chains that read no code of the map (`reject-reason` `code`)
 * and named ones whose shape fails (`shape`) are attached only with
 * `keep-rejected`.
 *
 * Without coded markers in the map (or without a map) buffers pass
 * untouched and the labels are not read. Video passes unchanged and is
 * never mapped; frames are never dropped. Every property may change while
 * playing; a bad value set while playing is reported with a warning and
 * the previous settings stay. A band class that the labels lack is an
 * error at the first buffer (the palette is only known then).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! avidemux ! jpegdec !
 *     videoconvert ! labsegment palette=palette.json ! blobroundness !
 *     beacondetect map=map.json ! landmarklog location=found.jsonl !
 *     fakesink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstbeacondetect.h"

#include <gst/video/video.h>

#include <cmath>
#include <string>
#include <vector>

#include "beacongroup.h"
#include "elementsettings.h"
#include "landmarkmap.h"
#include "landmarkmeta.h"
#include "analyticsmeta.h"
#include "simdlevel.h"

GST_DEBUG_CATEGORY_STATIC (gst_beacon_detect_debug);
#define GST_CAT_DEFAULT gst_beacon_detect_debug

/* *INDENT-OFF* */
namespace {

/* What the user sets (the initial values are the defaults). */
struct Settings {
  std::string map;
  guint min_band_area = 12;
  gdouble max_roll = 20.0;
  gdouble min_fill = 0.6;
  gdouble max_width_ratio = 1.6;
  gboolean keep_rejected = FALSE;
};

/* Settings checked, with the map read. */
struct Config {
  Settings s;
  landmark::LandmarkMap coded;        /* the map's coded markers only */
  landmark::BeaconParams params;
};

/* Built in start(), used by the streaming thread only. */
struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  /* the labels' classes, the video size, the warnings given */
  landmark::LabelsInput input;
  landmark::BeaconFinder finder;
  landmark::WorkerPool workers;     /* one thread: bands are few pixels */
  std::string read;                 /* scratch: the bands read */
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_IN_PLACE_ELEMENT (GstBeaconDetect, gst_beacon_detect,
    Settings, State, GstBaseTransform, GST_TYPE_BASE_TRANSFORM, beacondetect,
    "Coded landmark detection");

/* ---- configuration -------------------------------------------------- */

static bool
beacon_detect_parse (const Settings & s, Config * cfg,
    landmark::SettingsError * err)
{
  *cfg = Config ();
  cfg->s = s;
  if (!s.map.empty ()) {
    landmark::LandmarkMap map;
    err->property = "map";
    if (!landmark::map_load_file (s.map, &map, &err->why))
      return false;
    for (landmark::MapLandmark & m : map.landmarks)
      if (m.coded ())
        cfg->coded.landmarks.push_back (std::move (m));
  }
  cfg->params.min_band_area = s.min_band_area;
  cfg->params.max_roll_deg = s.max_roll;
  cfg->params.min_fill = s.min_fill;
  cfg->params.max_width_ratio = s.max_width_ratio;
  return true;
}

static const landmark::PropertyTable<Settings> &
beacon_detect_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .string ("map", "Map file",
          "Landmark map JSON whose coded markers (beacon, post, cone) are "
          "searched for; none: buffers pass untouched", &Settings::map)
      .number ("min-band-area", "Minimum band area",
          "Smallest blob of a band class joined into a marker, pixels",
          &Settings::min_band_area, 1u, G_MAXUINT)
      .number ("max-roll", "Maximum roll",
          "Largest angle of a marker's axis from the image's vertical, "
          "degrees (the camera's roll, and a marker's lean)",
          &Settings::max_roll, 0.0, 60.0)
      .number ("min-fill", "Minimum band fill",
          "Smallest share of its box along and across the axis that every "
          "band of a beacon or post fills (1: a cylinder seen level; a "
          "cone's own test applies to cones)", &Settings::min_fill, 0.0, 1.0)
      .number ("max-width-ratio", "Maximum width ratio",
          "Largest ratio of the widest to the narrowest band of a beacon "
          "or post", &Settings::max_width_ratio, 1.0, 10.0)
      .boolean ("keep-rejected", "Keep rejected",
          "Also attach chains of bands that read no code of the map "
          "(kept=false, reject-reason=code) or fail their kind's shape "
          "test (shape), for tuning",
          &Settings::keep_rejected);
  return table;
}

/* ---- states and caps ------------------------------------------------ */

static gboolean
gst_beacon_detect_start (GstBaseTransform * trans)
{
  auto self = GST_BEACON_DETECT (trans);
  const Config & cfg = self->priv->state.applied.config;
  GST_INFO_OBJECT (self, "map %s: %zu coded markers", cfg.s.map.c_str (),
      cfg.coded.landmarks.size ());
  return TRUE;
}

static gboolean
gst_beacon_detect_stop (GstBaseTransform * trans)
{
  auto self = GST_BEACON_DETECT (trans);
  self->priv->state.input.classes.reset ();
  return TRUE;
}

static gboolean
gst_beacon_detect_set_caps (GstBaseTransform * trans, GstCaps * incaps,
    GstCaps * outcaps)
{
  auto self = GST_BEACON_DETECT (trans);
  State & st = self->priv->state;
  (void) outcaps;
  st.input.set_caps (incaps);
  st.finder.analyzer ().set_avx2 (landmark::simd_level () ==
      landmark::SimdLevel::AVX2);
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

static void
gst_beacon_detect_sync_settings (GstBeaconDetect * self)
{
  State & st = self->priv->state;
  if (st.applied.sync (GST_ELEMENT (self), self->priv->settings,
          beacon_detect_parse))
    st.input.classes.valid = false;   /* the map may have changed */
}

/* The map's bands as labels of this frame's palette; FALSE (an error
 * naming the map, the landmark and the band) when the labels lack one. */
static gboolean
gst_beacon_detect_update_specs (GstBeaconDetect * self,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  if (!st.input.classes.changed (labels))
    return TRUE;
  const Config & cfg = st.applied.config;
  std::vector<landmark::BeaconSpec> specs = landmark::beacon_specs
      (cfg.coded, st.input.classes.names);
  for (const landmark::BeaconSpec & spec : specs)
    for (size_t k = 0; k < spec.labels.size (); k++)
      if (spec.labels[k] == 0) {
        GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
            ("Invalid 'map' value."),
            ("%s: landmark \"%s\" (code %s): band %s is not a class of "
                "the labels (%s)", cfg.s.map.c_str (), spec.marker.id.c_str (),
                spec.marker.code.c_str (), spec.marker.bands[k].c_str (),
                st.input.classes.list ().c_str ()));
        return FALSE;
      }
  st.finder.set_specs (specs);
  st.input.classes.valid = true;
  return TRUE;
}

static void
gst_beacon_detect_attach (GstBeaconDetect * self, GstBuffer * buf,
    const landmark::BeaconDetection & d, guint plane_w, guint plane_h)
{
  State & st = self->priv->state;
  const std::vector<landmark::BeaconSpec> & specs = st.finder.specs ();
  const landmark::BeaconSpec *spec = d.marker >= 0 ? &specs[d.marker] :
      nullptr;
  st.read.clear ();
  for (int k = 0; k < d.n_bands; k++) {
    if (k)
      st.read += '/';
    st.read += st.input.classes.names[d.bands[k].label - 1];
  }
  const char *cls = spec ? spec->marker.code.c_str () : st.read.c_str ();
  GstVideoRegionOfInterestMeta *roi = landmark_detection_add_from_plane
      (buf, cls, d.bbox_x, d.bbox_y, d.bbox_w, d.bbox_h, plane_w, plane_h,
      st.input.video_width, st.input.video_height);
  if (!roi)
    return;
  double fill = 1;
  for (int k = 0; k < d.n_bands; k++)
    fill = MIN (fill, d.bands[k].fill);
  /* radians from the image's vertical, clockwise: the camera's roll */
  const double angle = std::atan2 (-d.axis_u, d.axis_v);
  GstStructure *s = gst_structure_new (LANDMARK_BLOB_PARAMS,
      "class", G_TYPE_STRING, cls,
      "bands", G_TYPE_STRING, st.read.c_str (),
      "area", G_TYPE_DOUBLE, d.area,
      "centroid-x", G_TYPE_DOUBLE, d.cx,
      "centroid-y", G_TYPE_DOUBLE, d.cy,
      "axis-top-x", G_TYPE_DOUBLE, d.top_u,
      "axis-top-y", G_TYPE_DOUBLE, d.top_v,
      "axis-base-x", G_TYPE_DOUBLE, d.base_u,
      "axis-base-y", G_TYPE_DOUBLE, d.base_v,
      "axis-angle", G_TYPE_DOUBLE, angle,
      "height-px", G_TYPE_DOUBLE, d.height_px,
      "width-px", G_TYPE_DOUBLE, d.width_px,
      "ellipse-x", G_TYPE_DOUBLE, 0.5 * (d.top_u + d.base_u),
      "ellipse-y", G_TYPE_DOUBLE, 0.5 * (d.top_v + d.base_v),
      "ellipse-major", G_TYPE_DOUBLE, d.height_px,
      "ellipse-minor", G_TYPE_DOUBLE, d.width_px,
      "ellipse-angle", G_TYPE_DOUBLE, std::atan2 (d.axis_v, d.axis_u),
      "min-band-fill", G_TYPE_DOUBLE, fill,
      "kept", G_TYPE_BOOLEAN, d.reject == nullptr,
      "frame-width", G_TYPE_UINT, plane_w,
      "frame-height", G_TYPE_UINT, plane_h, nullptr);
  if (spec)
    gst_structure_set (s, "code", G_TYPE_STRING, spec->marker.code.c_str (),
        "kind", G_TYPE_STRING, landmark::map_kind_name (spec->marker.kind),
        nullptr);
  if (d.reject)
    gst_structure_set (s, "reject-reason", G_TYPE_STRING, d.reject, nullptr);
  if (!d.candidates.empty ()) {
    GValue codes = G_VALUE_INIT;
    gst_value_array_init (&codes, d.candidates.size ());
    for (int c : d.candidates)
      landmark_value_array_append_string (&codes, specs[c].marker.code.c_str ());
    gst_structure_take_value (s, "candidate-codes", &codes);
  }
  landmark_detection_add_param (buf, roi, s);
}

static GstFlowReturn
gst_beacon_detect_process (GstBeaconDetect * self, GstBuffer * buf,
    const GstStructure * labels)
{
  State & st = self->priv->state;
  const Config & cfg = st.applied.config;
  /* no coded marker to look for: the chain runs as without this element */
  if (cfg.coded.landmarks.empty ())
    return GST_FLOW_OK;
  LandmarkLabelPlane plane;
  bool failed;
  if (!plane.read (GST_ELEMENT (self), labels, &st.input.warned_bad_plane,
          &failed))
    return failed ? GST_FLOW_ERROR : GST_FLOW_OK;
  if (!gst_beacon_detect_update_specs (self, labels))
    return GST_FLOW_ERROR;
  const guint w = plane.width, h = plane.height;
  st.finder.find (plane.data, plane.stride, (int) w, (int) h, cfg.params,
      st.workers);
  for (size_t i = 0; i < st.finder.count (); i++) {
    const landmark::BeaconDetection & d = st.finder.detection (i);
    /* kept markers and partial views travel on; the rest for tuning */
    if (d.reject && d.candidates.empty () && !cfg.s.keep_rejected)
      continue;
    gst_beacon_detect_attach (self, buf, d, w, h);
  }
  GST_LOG_OBJECT (self, "%ux%u labels: %zu chains", w, h,
      st.finder.count ());
  landmark_analytics_sync (buf);
  return GST_FLOW_OK;
}

static void
gst_beacon_detect_class_init (GstBeaconDetectClass * klass)
{
  landmark::element_class_init<Settings, gst_beacon_detect_settings,
      beacon_detect_properties> (klass, gst_beacon_detect_finalize,
      "Coded landmark detection", "Filter/Analyzer/Video",
      "Finds the coded markers of a map (stacks of colour bands: beacons, "
      "posts, cones) in the labels of labsegment and names each by its "
      "code, read top to bottom; attaches them as region-of-interest "
      "metadata");
  landmark::set_labels_measuring<GstBeaconDetect, gst_beacon_detect_get_type,
      beacon_detect_parse, gst_beacon_detect_start,
      gst_beacon_detect_sync_settings, gst_beacon_detect_process> (klass,
      gst_beacon_detect_stop, GST_DEBUG_FUNCPTR (gst_beacon_detect_set_caps));
}
