/* The JSON text of one buffer's gst-landmark metadata: landmarklog writes
 * it as one line per frame, landmarkpublish sends it as one message per
 * frame (docs/landmarklog.md has every field). */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "landmarkjson.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <mutex>

#include "landmarkmeta.h"

/* *INDENT-OFF* */
namespace {
/* *INDENT-ON* */

/* Labels meta field -> JSON key, in the order they are written. The plane
 * ("labels") and its "stride" are never written. */
struct LabelsKey {
  const char *field;
  const char *key;              /* with quotes and ": " */
  GQuark quark;
};

LabelsKey labels_keys[] = {
  {LANDMARK_LABELS_CLASS_NAMES, "\"classes\": ", 0},
  {LANDMARK_LABELS_CLASS_MARKERS, "\"markers\": ", 0},
  {LANDMARK_LABELS_CLASS_ROLES, "\"roles\": ", 0},
  {LANDMARK_LABELS_CLASS_COUNTS, "\"counts\": ", 0},
  {LANDMARK_LABELS_CLASS_ACTIVE, "\"active\": ", 0},
  {LANDMARK_LABELS_LABEL_COUNTS, "\"labelled\": ", 0},
  {LANDMARK_LABELS_UNCLASSIFIED, "\"unclassified\": ", 0},
  {LANDMARK_LABELS_MIN_CLASS_PIXELS, "\"min-class-pixels\": ", 0},
  {LANDMARK_LABELS_WIDTH, "\"width\": ", 0},
  {LANDMARK_LABELS_HEIGHT, "\"height\": ", 0},
  {LANDMARK_LABELS_ANALYSIS_WIDTH, "\"analysis-width\": ", 0},
  {LANDMARK_LABELS_ANALYSIS_HEIGHT, "\"analysis-height\": ", 0},
  {LANDMARK_LABELS_MAX_DISTANCE, "\"max-distance\": ", 0},
  {LANDMARK_LABELS_USE_LIGHTNESS, "\"use-lightness\": ", 0},
  {LANDMARK_LABELS_CLASS_RGB, "\"rgb\": ", 0},
};

GQuark blob_quark, range_quark, match_quark;

void
put_uint (std::string & o, guint64 v)
{
  char buf[24];
  auto r = std::to_chars (buf, buf + sizeof (buf), v);
  o.append (buf, r.ptr - buf);
}

void
put_int (std::string & o, gint64 v)
{
  char buf[24];
  auto r = std::to_chars (buf, buf + sizeof (buf), v);
  o.append (buf, r.ptr - buf);
}

/* Shortest text that reads back to the same value (std::to_chars: no
 * locale, no allocation); a '.' is added to integral values so readers
 * see a floating-point number. NaN and infinities are not JSON: null. */
template <typename T>
void
put_floating (std::string & o, T v)
{
  if (!std::isfinite (v)) {
    o += "null";
    return;
  }
  char buf[40];
  auto r = std::to_chars (buf, buf + sizeof (buf), v);
  const size_t n = r.ptr - buf;
  o.append (buf, n);
  if (!memchr (buf, '.', n) && !memchr (buf, 'e', n))
    o += ".0";
}

void
put_escaped (std::string & o, const char *s)
{
  static const char hex[] = "0123456789abcdef";
  const char *run = s;
  for (const char *p = s; *p; p++) {
    const unsigned char c = (unsigned char) *p;
    if (c >= 0x20 && c != '"' && c != '\\')
      continue;
    o.append (run, p - run);
    run = p + 1;
    switch (c) {
      case '"':
        o += "\\\"";
        break;
      case '\\':
        o += "\\\\";
        break;
      case '\n':
        o += "\\n";
        break;
      case '\r':
        o += "\\r";
        break;
      case '\t':
        o += "\\t";
        break;
      case '\b':
        o += "\\b";
        break;
      case '\f':
        o += "\\f";
        break;
      default:{
        const char u[] = { '\\', 'u', '0', '0', hex[c >> 4], hex[c & 15] };
        o.append (u, sizeof (u));
        break;
      }
    }
  }
  o.append (run, strlen (run));
}

/* A JSON string; invalid UTF-8 gets U+FFFD for each bad sequence. */
void
put_string (std::string & o, const char *s)
{
  if (!s) {
    o += "null";
    return;
  }
  o += '"';
  if (G_LIKELY (g_utf8_validate (s, -1, nullptr))) {
    put_escaped (o, s);
  } else {
    gchar *valid = g_utf8_make_valid (s, -1);
    put_escaped (o, valid);
    g_free (valid);
  }
  o += '"';
}

void put_value (std::string & o, const GValue * v);

struct ObjectWriter {
  std::string *out;
  bool first;
};

gboolean
put_field (GQuark field, const GValue * value, gpointer user_data)
{
  auto w = (ObjectWriter *) user_data;
  if (!w->first)
    *w->out += ", ";
  w->first = false;
  put_string (*w->out, g_quark_to_string (field));
  *w->out += ": ";
  put_value (*w->out, value);
  return TRUE;
}

/* Every field of a structure as a JSON object (the name is not written). */
void
put_structure (std::string & o, const GstStructure * s)
{
  if (!s) {
    o += "null";
    return;
  }
  ObjectWriter w { &o, true };
  o += '{';
  gst_structure_foreach (s, put_field, &w);
  o += '}';
}

void
put_value (std::string & o, const GValue * v)
{
  switch (G_TYPE_FUNDAMENTAL (G_VALUE_TYPE (v))) {
    case G_TYPE_BOOLEAN:
      o += g_value_get_boolean (v) ? "true" : "false";
      return;
    case G_TYPE_INT:
      put_int (o, g_value_get_int (v));
      return;
    case G_TYPE_UINT:
      put_uint (o, g_value_get_uint (v));
      return;
    case G_TYPE_INT64:
      put_int (o, g_value_get_int64 (v));
      return;
    case G_TYPE_UINT64:
      put_uint (o, g_value_get_uint64 (v));
      return;
    case G_TYPE_LONG:
      put_int (o, g_value_get_long (v));
      return;
    case G_TYPE_ULONG:
      put_uint (o, g_value_get_ulong (v));
      return;
    case G_TYPE_CHAR:
      put_int (o, g_value_get_schar (v));
      return;
    case G_TYPE_UCHAR:
      put_uint (o, g_value_get_uchar (v));
      return;
    case G_TYPE_DOUBLE:
      put_floating (o, g_value_get_double (v));
      return;
    case G_TYPE_FLOAT:
      put_floating (o, g_value_get_float (v));
      return;
    case G_TYPE_STRING:
      put_string (o, g_value_get_string (v));
      return;
    case G_TYPE_ENUM:{
      /* by nick, as gst-launch and the Python bindings show enums */
      GEnumClass *klass = (GEnumClass *) g_type_class_ref (G_VALUE_TYPE (v));
      GEnumValue *ev = g_enum_get_value (klass, g_value_get_enum (v));
      if (ev)
        put_string (o, ev->value_nick);
      else
        put_int (o, g_value_get_enum (v));
      g_type_class_unref (klass);
      return;
    }
    case G_TYPE_FLAGS:
      put_uint (o, g_value_get_flags (v));
      return;
    case G_TYPE_POINTER:
      o += "null";
      return;
    default:
      break;
  }
  if (GST_VALUE_HOLDS_ARRAY (v) || GST_VALUE_HOLDS_LIST (v)) {
    const bool array = GST_VALUE_HOLDS_ARRAY (v);
    const guint n = array ? gst_value_array_get_size (v) :
        gst_value_list_get_size (v);
    o += '[';
    for (guint i = 0; i < n; i++) {
      if (i)
        o += ", ";
      put_value (o, array ? gst_value_array_get_value (v, i) :
          gst_value_list_get_value (v, i));
    }
    o += ']';
    return;
  }
  if (GST_VALUE_HOLDS_STRUCTURE (v)) {
    put_structure (o, gst_value_get_structure (v));
    return;
  }
  if (G_VALUE_HOLDS (v, G_TYPE_STRV)) {
    auto strv = (const gchar * const *) g_value_get_boxed (v);
    o += '[';
    for (guint i = 0; strv && strv[i]; i++) {
      if (i)
        o += ", ";
      put_string (o, strv[i]);
    }
    o += ']';
    return;
  }
  /* Data (a label plane, a sample) is never dumped into the log. */
  if (GST_VALUE_HOLDS_BUFFER (v) || G_VALUE_HOLDS (v, GST_TYPE_SAMPLE) ||
      G_VALUE_HOLDS (v, GST_TYPE_BUFFER_LIST) ||
      G_VALUE_HOLDS (v, GST_TYPE_MEMORY)) {
    o += "null";
    return;
  }
  /* Anything else (fractions, ranges, caps, dates): GStreamer's own
   * serialisation as a string. */
  gchar *text = gst_value_serialize (v);
  put_string (o, text);
  g_free (text);
}

void
put_labels (std::string & o, const GstStructure * s)
{
  o += ", \"labels\": {";
  bool first = true;
  for (const auto & k : labels_keys) {
    const GValue *v = gst_structure_id_get_value (s, k.quark);
    if (!v)
      continue;
    if (!first)
      o += ", ";
    first = false;
    o += k.key;
    put_value (o, v);
  }
  o += '}';
}

/* The radial obstacle profile of floorboundary (docs/floorboundary.md):
 * per bin range, state (0 not seen, 1 free, 2 obstacle, 3 view edge) and
 * nearest marker range (null: none). The per-column boundary stays in the
 * meta: 640 points a frame would swamp the log. */
void
put_floor (std::string & o, const GstStructure * s)
{
  o += ", \"floor\": {";
  guint bins = 0;
  gst_structure_get_uint (s, LANDMARK_FLOOR_BEARING_BINS, &bins);
  o += "\"bearing-bins\": ";
  put_uint (o, bins);
  /* the scalar fields the meta has, under their own names */
  for (const char *field : { LANDMARK_FLOOR_BIN_WIDTH,
          LANDMARK_FLOOR_MAX_RANGE, LANDMARK_FLOOR_NEAREST_RANGE,
          LANDMARK_FLOOR_NEAREST_BEARING }) {
    gdouble v;
    if (!gst_structure_get_double (s, field, &v))
      continue;
    o += ", \"";
    o += field;
    o += "\": ";
    put_floating (o, v);
  }
  static const struct
  {
    const char *field, *key;
    bool state, none_below_zero;
  } arrays[] = {
    {LANDMARK_FLOOR_ROP_RANGE, ", \"range\": [", false, false},
    {LANDMARK_FLOOR_ROP_STATE, ", \"state\": [", true, false},
    {LANDMARK_FLOOR_ROP_MARKER_RANGE, ", \"marker-range\": [", false, true},
  };
  for (const auto & a : arrays) {
    GstBuffer *plane;
    GstMapInfo map;
    gsize n;
    if (!landmark_floor_map_array (s, a.field, a.state ? 1 : sizeof (float),
            &plane, &map, &n))
      continue;
    o += a.key;
    for (gsize i = 0; i < n; i++) {
      if (i)
        o += ", ";
      if (a.state) {
        put_uint (o, map.data[i]);
      } else {
        float f;
        memcpy (&f, map.data + i * sizeof (float), sizeof (float));
        if (a.none_below_zero && f < 0)
          o += "null";
        else
          put_floating (o, f);
      }
    }
    o += ']';
    gst_buffer_unmap (plane, &map);
    gst_buffer_unref (plane);
  }
  o += '}';
}

bool
roi_before (const GstVideoRegionOfInterestMeta * a,
    const GstVideoRegionOfInterestMeta * b)
{
  if (a->id != b->id)
    return a->id < b->id;
  return gst_meta_compare_seqnum (&a->meta, &b->meta) < 0;
}

void
put_detection (std::string & o, GstBuffer * buf,
    const GstVideoRegionOfInterestMeta * roi)
{
  o += "{\"id\": ";
  put_int (o, roi->id);
  o += ", \"class\": ";
  put_string (o, roi->roi_type ? g_quark_to_string (roi->roi_type) : nullptr);
  o += ", \"bbox\": [";
  put_uint (o, roi->x);
  o += ", ";
  put_uint (o, roi->y);
  o += ", ";
  put_uint (o, roi->w);
  o += ", ";
  put_uint (o, roi->h);
  o += ']';

  /* the chain's verdict (docs/detection.md), so a reader need not know
   * which stage rejects for which reason */
  const gchar *rejected_by = nullptr, *reject_reason = nullptr;
  const bool rejected = landmark_detection_rejected (buf, roi, &rejected_by,
      &reject_reason);
  o += rejected ? ", \"accepted\": false, \"rejected-by\": " :
      ", \"accepted\": true";
  if (rejected) {
    put_string (o, rejected_by);
    if (reject_reason) {
      o += ", \"reject-reason\": ";
      put_string (o, reject_reason);
    }
  }

  /* Ours through the contract's reader, which also finds them when a
   * converter dropped them from the region-of-interest meta. The first
   * structure of each name counts (as with
   * gst_video_region_of_interest_meta_get_param); later ones of the same
   * name would repeat a JSON key and are left out. */
  const auto [blob, range, match] = landmark_detection_params (buf, roi);
  bool others = false;
  for (GList * l = roi->params; l && !others; l = l->next) {
    const GQuark name = gst_structure_get_name_id ((GstStructure *) l->data);
    others = name != blob_quark && name != range_quark && name != match_quark;
  }
  if (blob) {
    o += ", \"blob\": ";
    put_structure (o, blob);
  }
  if (range) {
    o += ", \"range\": ";
    put_structure (o, range);
  }
  if (match) {
    o += ", \"match\": ";
    put_structure (o, match);
  }
  if (others) {
    o += ", \"params\": {";
    bool first = true;
    for (GList * l = roi->params; l; l = l->next) {
      auto s = (const GstStructure *) l->data;
      const GQuark name = gst_structure_get_name_id (s);
      if (name == blob_quark || name == range_quark || name == match_quark)
        continue;
      bool repeated = false;
      for (GList * e = roi->params; e != l && !repeated; e = e->next)
        repeated = gst_structure_get_name_id ((GstStructure *) e->data) ==
            name;
      if (repeated)
        continue;
      if (!first)
        o += ", ";
      first = false;
      put_string (o, g_quark_to_string (name));
      o += ": ";
      put_structure (o, s);
    }
    o += '}';
  }
  o += '}';
}

}  // namespace

namespace landmark_json {

void
init (void)
{
  static std::once_flag once;
  std::call_once (once,[] {
        for (auto & k:labels_keys)
          k.quark = g_quark_from_static_string (k.field);
        blob_quark = g_quark_from_static_string (LANDMARK_BLOB_PARAMS);
        range_quark = g_quark_from_static_string (LANDMARK_RANGE_PARAMS);
        match_quark = g_quark_from_static_string (LANDMARK_MATCH_PARAMS);
      }
  );
}

void
put_uint (std::string & o, guint64 v)
{
  ::put_uint (o, v);
}

void
put_int (std::string & o, gint64 v)
{
  ::put_int (o, v);
}

void
put_double (std::string & o, double v)
{
  put_floating (o, v);
}

void
put_string (std::string & o, const char *s)
{
  ::put_string (o, s);
}

void
put_structure (std::string & o, const GstStructure * s)
{
  ::put_structure (o, s);
}

void
put_frame_fields (std::string & o, GstBuffer * buf, guint64 frame,
    gint width, gint height,
    std::vector < GstVideoRegionOfInterestMeta * >&rois)
{
  o += "\"frame\": ";
  ::put_uint (o, frame);
  if (GST_BUFFER_PTS_IS_VALID (buf)) {
    o += ", \"pts\": ";
    ::put_uint (o, GST_BUFFER_PTS (buf));
  }
  if (GST_BUFFER_DURATION_IS_VALID (buf)) {
    o += ", \"duration\": ";
    ::put_uint (o, GST_BUFFER_DURATION (buf));
  }
  if (width >= 0) {
    o += ", \"width\": ";
    ::put_int (o, width);
  }
  if (height >= 0) {
    o += ", \"height\": ";
    ::put_int (o, height);
  }

  if (const GstStructure * labels = landmark_labels_meta_get (buf))
    put_labels (o, labels);

  rois.clear ();
  gpointer iter = nullptr;
  GstMeta *m;
  while ((m = gst_buffer_iterate_meta_filtered (buf, &iter,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    /* insertion sort: a handful of detections, no allocation */
    auto roi = (GstVideoRegionOfInterestMeta *) m;
    rois.push_back (roi);
    for (size_t i = rois.size () - 1;
        i > 0 && roi_before (rois[i], rois[i - 1]); i--)
      std::swap (rois[i], rois[i - 1]);
  }
  o += ", \"detections\": [";
  for (size_t i = 0; i < rois.size (); i++) {
    if (i)
      o += ", ";
    put_detection (o, buf, rois[i]);
  }
  o += ']';

  if (const GstStructure * pose = landmark_pose_meta_get (buf)) {
    o += ", \"pose\": ";
    put_structure (o, pose);
  }
  if (const GstStructure * map = landmark_map_meta_get (buf)) {
    o += ", \"landmark_map\": ";
    put_structure (o, map);
  }

  if (const GstStructure * floor = landmark_floor_meta_get (buf))
    put_floor (o, floor);
}

}  // namespace landmark_json
