/* Reading a frame's metadata for the drawings (overlaymeta.h). */
#include "overlaymeta.h"

#include <cmath>
#include <cstring>

#include "landmarkmeta.h"

namespace landmark {
namespace overlay {

namespace {

bool
get_bool (const GstStructure * s, const char *field, bool *out)
{
  gboolean b;
  if (!s || !gst_structure_get_boolean (s, field, &b))
    return false;
  *out = b;
  return true;
}

Rgb
rgb_from_uint (guint v)
{
  Rgb c;
  c.r = (v >> 16) & 0xff;
  c.g = (v >> 8) & 0xff;
  c.b = v & 0xff;
  return c;
}

}  // namespace

bool
meta_number (const GstStructure * s, const char *field, double *out)
{
  const GValue *v = s ? gst_structure_get_value (s, field) : nullptr;
  if (!v)
    return false;
  if (G_VALUE_HOLDS_DOUBLE (v))
    *out = g_value_get_double (v);
  else if (G_VALUE_HOLDS_FLOAT (v))
    *out = g_value_get_float (v);
  else if (G_VALUE_HOLDS_INT (v))
    *out = g_value_get_int (v);
  else if (G_VALUE_HOLDS_UINT (v))
    *out = g_value_get_uint (v);
  else
    return false;
  return std::isfinite (*out);
}

void
ClassColours::init_defaults ()
{
  if (!defaults.empty ())
    return;
  for (const auto & c : landmark::palette_default ().classes) {
    double rgb[3];
    landmark::lab_to_srgb (c.lab, rgb);
    Rgb col;
    col.r = (guint8) (rgb[0] * 255 + 0.5);
    col.g = (guint8) (rgb[1] * 255 + 0.5);
    col.b = (guint8) (rgb[2] * 255 + 0.5);
    defaults.emplace_back (c.name, col);
  }
}

int
ClassColours::read (const GstStructure * labels, Histogram * hist)
{
  n = labels ? (int) MIN (landmark_labels_n_classes (labels),
      (guint) landmark::kMaxClasses) : 0;
  for (int k = 0; k < n; k++) {
    ClassInfo & ci = classes[k];
    ci = ClassInfo ();
    ci.name = landmark_labels_class_name (labels, k);
    const GValue *v = landmark_labels_class_value (labels,
        LANDMARK_LABELS_CLASS_RGB, k);
    if (v && G_VALUE_HOLDS_UINT (v))
      ci.colour = rgb_from_uint (g_value_get_uint (v));
    ci.count = landmark_labels_class_count (labels, k);
    v = landmark_labels_class_value (labels, LANDMARK_LABELS_CLASS_ACTIVE,
        k);
    ci.active = v && G_VALUE_HOLDS_BOOLEAN (v) && g_value_get_boolean (v);
    v = landmark_labels_class_value (labels, LANDMARK_LABELS_CLASS_MARKERS,
        k);
    ci.marker = !(v && G_VALUE_HOLDS_BOOLEAN (v)) || g_value_get_boolean (v);
  }
  if (!hist || !labels)
    return n;
  hist->classes = classes.data ();
  hist->n = n;
  guint threshold = 0, aw = 0, ah = 0;
  gst_structure_get_uint (labels, LANDMARK_LABELS_MIN_CLASS_PIXELS,
      &threshold);
  hist->threshold = threshold;
  if (!gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_WIDTH, &aw) ||
      !gst_structure_get_uint (labels, LANDMARK_LABELS_ANALYSIS_HEIGHT, &ah)) {
    gst_structure_get_uint (labels, LANDMARK_LABELS_WIDTH, &aw);
    gst_structure_get_uint (labels, LANDMARK_LABELS_HEIGHT, &ah);
  }
  hist->total = (double) aw * ah;
  return n;
}

Rgb
ClassColours::colour (const char *name) const
{
  if (name) {
    for (int k = 0; k < n; k++)
      if (classes[k].name && !strcmp (classes[k].name, name))
        return classes[k].colour;
    for (const auto & dc : defaults)
      if (dc.first == name)
        return dc.second;
  }
  return Rgb ();
}

void
read_detections (GstBuffer * buf, const ClassColours & colours, int width,
    int height, std::vector<Detection> * out, GstDebugCategory * cat,
    GObject * obj)
{
  out->clear ();
  gpointer iter = nullptr;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (buf, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    auto roi = (GstVideoRegionOfInterestMeta *) meta;
    Detection d;
    d.class_name = g_quark_to_string (roi->roi_type);
    d.x = roi->x;
    d.y = roi->y;
    d.w = roi->w;
    d.h = roi->h;
    const GstStructure *blob =
        landmark_detection_get_param (buf, roi, LANDMARK_BLOB_PARAMS);
    if (blob) {
      if (const char *cls = gst_structure_get_string (blob, "class"))
        d.class_name = cls;
      d.coded = gst_structure_has_field (blob, "code");
      double fw = 0, fh = 0;
      if (meta_number (blob, "frame-width", &fw) && fw > 0)
        d.sx = width / fw;
      if (meta_number (blob, "frame-height", &fh) && fh > 0)
        d.sy = height / fh;
      d.has_ellipse = meta_number (blob, "ellipse-x", &d.ellipse_x) &&
          meta_number (blob, "ellipse-y", &d.ellipse_y) &&
          meta_number (blob, "ellipse-major", &d.ellipse_major) &&
          meta_number (blob, "ellipse-minor", &d.ellipse_minor) &&
          d.ellipse_major >= 0 && d.ellipse_minor >= 0;
      if (d.has_ellipse && !meta_number (blob, "ellipse-angle",
              &d.ellipse_angle))
        d.ellipse_angle = 0;
      d.has_centroid = meta_number (blob, "centroid-x", &d.centroid_x) &&
          meta_number (blob, "centroid-y", &d.centroid_y);
      d.has_roundness = meta_number (blob, "roundness", &d.roundness);
      get_bool (blob, "kept", &d.kept);
      d.reject_reason = gst_structure_get_string (blob, "reject-reason");
    }
    const GstStructure *range =
        landmark_detection_get_param (buf, roi, LANDMARK_RANGE_PARAMS);
    if (range) {
      get_bool (range, "no-floor", &d.no_floor);
      d.has_range = meta_number (range, "range", &d.range) && d.range >= 0;
      d.has_bearing = meta_number (range, "bearing", &d.bearing);
      d.has_ground = meta_number (range, "ground-x", &d.ground_x) &&
          meta_number (range, "ground-y", &d.ground_y);
      if (!meta_number (range, "marker-diameter", &d.marker_diameter) ||
          d.marker_diameter < 0)
        d.marker_diameter = 0;
      if (!meta_number (range, "marker-height", &d.marker_height))
        d.marker_height = 0;
    }
    const GstStructure *match =
        landmark_detection_get_param (buf, roi, LANDMARK_MATCH_PARAMS);
    if (match) {
      d.has_match = true;
      get_bool (match, "matched", &d.matched);
      d.landmark_id = gst_structure_get_string (match, "landmark-id");
    }
    /* rejected by any stage (shape, size, map) draws as rejected */
    const gchar *rejected_by;
    d.kept = !landmark_detection_rejected (buf, roi, &rejected_by,
        &d.reject_reason);
    d.colour = colours.colour (d.class_name);
    GST_CAT_LOG_OBJECT (cat, obj, "detection %d %s bbox %g,%g %gx%g blob:%d "
        "ellipse:%d range:%d match:%d kept:%d", roi->id, d.class_name, d.x,
        d.y, d.w, d.h, blob != nullptr, d.has_ellipse, d.has_range,
        d.has_match, d.kept);
    out->push_back (d);
  }
}

FloorArrays::~FloorArrays ()
{
  for (int i = 0; i < n; i++) {
    gst_buffer_unmap (planes[i].buf, &planes[i].map);
    gst_buffer_unref (planes[i].buf);
  }
}

const void *
FloorArrays::get (const GstStructure * s, const char *field, gsize elem,
    gsize want)
{
  if (n >= (int) G_N_ELEMENTS (planes))
    return nullptr;
  Plane & p = planes[n];
  gsize count = 0;
  if (!landmark_floor_map_array (s, field, elem, &p.buf, &p.map, &count))
    return nullptr;
  n++;
  return count >= want && want > 0 ? p.map.data : nullptr;
}

void
read_floor (const GstStructure * s, FloorArrays * fa, bool with_points)
{
  guint width = 0, height = 0, bins = 0;
  gdouble bin_width = 0;
  if (!gst_structure_get_uint (s, LANDMARK_FLOOR_WIDTH, &width) ||
      !gst_structure_get_uint (s, LANDMARK_FLOOR_HEIGHT, &height) ||
      !gst_structure_get_uint (s, LANDMARK_FLOOR_BEARING_BINS, &bins) ||
      !gst_structure_get_double (s, LANDMARK_FLOOR_BIN_WIDTH, &bin_width))
    return;
  Floor & f = fa->floor;
  auto row = (const float *) fa->get (s, LANDMARK_FLOOR_BOUNDARY_ROW,
      sizeof (float), width);
  auto col_state = (const uint8_t *) fa->get (s,
      LANDMARK_FLOOR_BOUNDARY_STATE, 1, width);
  if (row && col_state && height > 0) {
    f.width = (int) width;
    f.height = (int) height;
    f.boundary_row = row;
    f.boundary_state = col_state;
  }
  auto range = (const float *) fa->get (s, LANDMARK_FLOOR_ROP_RANGE,
      sizeof (float), bins);
  auto bin_state = (const uint8_t *) fa->get (s, LANDMARK_FLOOR_ROP_STATE, 1,
      bins);
  if (range && bin_state && bin_width > 0) {
    f.bins = (int) bins;
    f.bin_width = bin_width;
    f.rop_range = range;
    f.rop_state = bin_state;
  }
  if (with_points && f.boundary_row) {
    f.boundary_x = (const float *) fa->get (s, LANDMARK_FLOOR_BOUNDARY_X,
        sizeof (float), width);
    f.boundary_y = (const float *) fa->get (s, LANDMARK_FLOOR_BOUNDARY_Y,
        sizeof (float), width);
  }
}

}  // namespace overlay
}  // namespace landmark
