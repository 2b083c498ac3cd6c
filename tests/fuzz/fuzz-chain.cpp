/* Fuzz target: random frames with random (valid) properties through the
 * whole chain, labsegment ! blobroundness ! ipmrange ! trilaterate !
 * landmarkoverlay ! landmarklog, in a GstHarness, with the plugin from the
 * build tree. The input decides the format (every one labsegment accepts),
 * the size (1..256 x 1..256), one to three frames, each element's
 * properties within the ranges that must be accepted, and the pixels:
 * either the input's bytes as they are, or discs painted from it (so that
 * blobs, ranges and poses happen). Invariants: the chain starts, every
 * frame comes out once, same size and caps, with a consistent labels meta,
 * detections inside the frame, finite ranges and poses, and no ERROR. */
#include <gst/check/gstharness.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzzcheck.h"
#include "landmarkmeta.h"

namespace {

/* Reads the input front to back; zeros once it runs out. */
class Bytes {
public:
  Bytes (const uint8_t * d, size_t n) : d_ (d), n_ (n) {}
  unsigned u8 () { return pos_ < n_ ? d_[pos_++] : 0; }
  unsigned u16 () { return u8 () | (u8 () << 8); }
  unsigned pick (unsigned n) { return u8 () % n; }
  bool flag () { return u8 () & 1; }
  /* lo..hi in 256 steps */
  double range (double lo, double hi) { return lo + (hi - lo) * u8 () / 255.0; }
  const uint8_t *rest (size_t *n) const {
    *n = n_ - std::min (pos_, n_);
    return d_ + std::min (pos_, n_);
  }
private:
  const uint8_t *d_;
  size_t n_, pos_ = 0;
};

const GstVideoFormat kFormats[] = {
  GST_VIDEO_FORMAT_RGB, GST_VIDEO_FORMAT_BGR, GST_VIDEO_FORMAT_RGBx,
  GST_VIDEO_FORMAT_BGRx, GST_VIDEO_FORMAT_xRGB, GST_VIDEO_FORMAT_xBGR,
  GST_VIDEO_FORMAT_RGBA, GST_VIDEO_FORMAT_BGRA, GST_VIDEO_FORMAT_I420,
  GST_VIDEO_FORMAT_NV12, GST_VIDEO_FORMAT_YUY2,
};

/* saturated marker-like colours and the background greys */
const uint8_t kColours[][3] = {
  {220, 30, 30}, {30, 170, 60}, {240, 220, 40}, {240, 120, 180},
  {30, 60, 200}, {245, 245, 245}, {128, 128, 128}, {10, 10, 10},
};

std::string source_root;

/* palettes the chain is tried with: the built-in one and test files */
std::string
palette_path (unsigned i)
{
  const char *files[] = { nullptr, "tests/files/palettes/good-alt.json",
    "tests/files/palettes/good-64-classes.json",
    "tests/files/clips/path-small/palette.json",
  };
  return files[i % 4] ? source_root + "/" + files[i % 4] : "";
}

void
paint_rgb (Bytes & in, int w, int h, std::vector<uint8_t> * rgb)
{
  const uint8_t *bg = kColours[in.pick (8)];
  rgb->resize ((size_t) w * h * 3);
  for (size_t i = 0; i < rgb->size (); i += 3)
    std::copy (bg, bg + 3, rgb->data () + i);
  const unsigned discs = in.pick (8);
  for (unsigned k = 0; k < discs; k++) {
    const int cx = in.u8 () * w / 256, cy = in.u8 () * h / 256;
    const int r = in.u8 () * std::max (w, h) / 512;
    const uint8_t *c = kColours[in.pick (8)];
    for (int y = std::max (0, cy - r); y <= std::min (h - 1, cy + r); y++)
      for (int x = std::max (0, cx - r); x <= std::min (w - 1, cx + r); x++)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
          std::copy (c, c + 3, rgb->data () + ((size_t) y * w + x) * 3);
  }
}

GstBuffer *
make_frame (Bytes & in, const GstVideoInfo * info, unsigned n)
{
  GstBuffer *buf = gst_buffer_new_and_alloc (GST_VIDEO_INFO_SIZE (info));
  GST_BUFFER_PTS (buf) = n * GST_SECOND / 30;
  GST_BUFFER_DURATION (buf) = GST_SECOND / 30;
  const int w = GST_VIDEO_INFO_WIDTH (info), h = GST_VIDEO_INFO_HEIGHT (info);
  if (in.flag ()) {
    /* the rest of the input, repeated over the whole buffer */
    size_t len;
    const uint8_t *p = in.rest (&len);
    GstMapInfo map;
    FUZZ_CHECK (gst_buffer_map (buf, &map, GST_MAP_WRITE), "map");
    for (size_t i = 0; i < map.size; i++)
      map.data[i] = len ? p[i % len] : 0;
    gst_buffer_unmap (buf, &map);
    return buf;
  }
  std::vector<uint8_t> rgb;
  paint_rgb (in, w, h, &rgb);
  GstVideoInfo rgb_info;
  gst_video_info_set_format (&rgb_info, GST_VIDEO_FORMAT_RGB, w, h);
  GstBuffer *src = gst_buffer_new_allocate (nullptr,
      GST_VIDEO_INFO_SIZE (&rgb_info), nullptr);
  GstVideoFrame sf, df;
  FUZZ_CHECK (gst_video_frame_map (&sf, &rgb_info, src, GST_MAP_WRITE), "map");
  for (int y = 0; y < h; y++)
    memcpy ((uint8_t *) GST_VIDEO_FRAME_PLANE_DATA (&sf, 0) +
        (size_t) y * GST_VIDEO_FRAME_PLANE_STRIDE (&sf, 0),
        rgb.data () + (size_t) y * w * 3, (size_t) w * 3);
  FUZZ_CHECK (gst_video_frame_map (&df, info, buf, GST_MAP_WRITE), "map");
  GstVideoConverter *conv = gst_video_converter_new (&rgb_info,
      (GstVideoInfo *) info, nullptr);
  FUZZ_CHECK (conv != nullptr, "no converter");
  gst_video_converter_frame (conv, &sf, &df);
  gst_video_converter_free (conv);
  gst_video_frame_unmap (&df);
  gst_video_frame_unmap (&sf);
  gst_buffer_unref (src);
  return buf;
}

void
set (GstBin * bin, const char *element, const char *prop, const char *value)
{
  GstElement *e = gst_bin_get_by_name (bin, element);
  gst_util_set_object_arg (G_OBJECT (e), prop, value);
  gst_object_unref (e);
}

std::string
num (double v)
{
  char s[G_ASCII_DTOSTR_BUF_SIZE];
  return g_ascii_dtostr (s, sizeof s, v);
}

/* Random settings within what every element must accept. */
void
configure (Bytes & in, GstBin * bin, const std::string & map)
{
  const std::string pal = palette_path (in.u8 ());
  if (!pal.empty ())
    set (bin, "seg", "palette", pal.c_str ());
  set (bin, "seg", "min-class-pixels", std::to_string (in.u16 ()).c_str ());
  set (bin, "seg", "max-distance", num (in.range (0, 1000)).c_str ());
  set (bin, "seg", "use-lightness", in.flag ()? "true" : "false");
  set (bin, "seg", "output", in.flag ()? "labels" : "passthrough");
  set (bin, "seg", "post-messages", in.flag ()? "true" : "false");
  set (bin, "seg", "rare-classes", in.flag ()? "nearest" : "unlabelled");

  const unsigned morph = in.pick (8);
  set (bin, "blob", "morphology", std::to_string (morph ? 2 * morph - 1 :
          0).c_str ());
  const unsigned min_area = in.u16 () % 2000;
  const unsigned max_area = in.flag ()? 0 : min_area + in.u16 ();
  set (bin, "blob", "min-area", std::to_string (min_area).c_str ());
  set (bin, "blob", "max-area", std::to_string (max_area).c_str ());
  set (bin, "blob", "max-aspect", num (in.range (0, 20)).c_str ());
  set (bin, "blob", "min-roundness", num (in.range (0, 1)).c_str ());
  set (bin, "blob", "min-ellipse-fit", num (in.range (0, 1)).c_str ());
  set (bin, "blob", "shape", in.flag ()? "circle" : "ellipse");
  set (bin, "blob", "keep-rejected", in.flag ()? "true" : "false");

  /* above the map's highest marker centre (a 0.1 m ball): lower is a
   * configuration error by design */
  const double cam_h = in.range (0.15, 3.0);
  set (bin, "ipm", "camera-height", num (cam_h).c_str ());
  set (bin, "ipm", "marker-height", num (in.range (0, 0.95) * cam_h).c_str ());
  set (bin, "ipm", "marker-diameter", num (in.range (0, 1)).c_str ());
  set (bin, "ipm", "marker-kind", in.flag ()? "ball" : "disc");
  const char *methods[] = { "ground", "size", "fused" };
  set (bin, "ipm", "range-method", methods[in.pick (3)]);
  set (bin, "ipm", "pixel-sigma", num (in.range (0, 5)).c_str ());
  if (in.flag ())
    set (bin, "ipm", "map", map.c_str ());
  if (in.pick (4) == 0) {
    set (bin, "ipm", "model", "seed");
    set (bin, "ipm", "blind-distance", num (in.range (0, 2)).c_str ());
    set (bin, "ipm", "view-depth", num (in.range (0.05, 10)).c_str ());
    set (bin, "ipm", "half-width", num (in.range (0.05, 5)).c_str ());
  } else {
    /* a tilt that keeps some floor in view at any of these fields of view */
    set (bin, "ipm", "tilt", num (in.range (5, 90)).c_str ());
    set (bin, "ipm", "roll", num (in.range (-30, 30)).c_str ());
    if (in.flag ())
      set (bin, "ipm", "hfov", num (in.range (20, 150)).c_str ());
    else
      set (bin, "ipm", "fx", num (in.range (20, 2000)).c_str ());
  }

  set (bin, "tri", "map", map.c_str ());
  set (bin, "tri", "filter", in.flag ()? "ekf" : "none");
  set (bin, "tri", "heading", num (in.flag ()? -361 :
          in.range (-180, 180)).c_str ());
  set (bin, "tri", "heading-sigma", num (in.range (0, 180)).c_str ());
  set (bin, "tri", "gate", num (in.range (0, 5)).c_str ());
  set (bin, "tri", "inlier-distance", num (in.range (0, 2)).c_str ());
  set (bin, "tri", "max-age", num (in.range (0, 10)).c_str ());
  set (bin, "tri", "post-messages", in.flag ()? "true" : "false");

  const unsigned show = in.u8 ();
  const char *shows[] = { "show-detections", "show-rejected", "show-pose",
    "show-histogram", "show-indicators", "show-minimap",
  };
  for (unsigned i = 0; i < 6; i++)
    set (bin, "overlay", shows[i], (show >> i) & 1 ? "true" : "false");
  if (in.flag ())
    set (bin, "overlay", "map", map.c_str ());
  set (bin, "overlay", "text-scale", num (in.range (0.25, 8)).c_str ());

  set (bin, "log", "location", "/dev/null");
  set (bin, "log", "flush-every", std::to_string (in.pick (3)).c_str ());
}

/* ERROR messages fail; warnings are allowed (e.g. a map class with two
 * different sizes) but logged. */
void
check_bus (GstBus * bus)
{
  GstMessage *msg;
  while ((msg = gst_bus_pop_filtered (bus, (GstMessageType)
              (GST_MESSAGE_ERROR | GST_MESSAGE_WARNING)))) {
    GError *err = nullptr;
    gchar *dbg = nullptr;
    const bool error = GST_MESSAGE_TYPE (msg) == GST_MESSAGE_ERROR;
    if (error)
      gst_message_parse_error (msg, &err, &dbg);
    else
      gst_message_parse_warning (msg, &err, &dbg);
    FUZZ_CHECK (!error, "ERROR from %s: %s (%s)", GST_MESSAGE_SRC_NAME (msg),
        err->message, dbg ? dbg : "");
    g_clear_error (&err);
    g_free (dbg);
    gst_message_unref (msg);
  }
}

void
check_output (GstBuffer * out, const GstVideoInfo * info, gsize in_size)
{
  const int w = GST_VIDEO_INFO_WIDTH (info), h = GST_VIDEO_INFO_HEIGHT (info);
  FUZZ_CHECK (gst_buffer_get_size (out) == in_size, "size %zu, pushed %zu",
      gst_buffer_get_size (out), in_size);

  GstCustomMeta *lm = gst_buffer_get_custom_meta (out,
      GST_LANDMARK_LABELS_META_NAME);
  FUZZ_CHECK (lm != nullptr, "no labels meta");
  const GstStructure *labels = gst_custom_meta_get_structure (lm);
  guint lw = 0, lh = 0, stride = 0, aw = 0, ah = 0, unclassified = 0;
  GstBuffer *plane = nullptr;
  FUZZ_CHECK (gst_structure_get (labels, LANDMARK_LABELS_PLANE,
          GST_TYPE_BUFFER, &plane, LANDMARK_LABELS_WIDTH, G_TYPE_UINT, &lw,
          LANDMARK_LABELS_HEIGHT, G_TYPE_UINT, &lh, LANDMARK_LABELS_STRIDE,
          G_TYPE_UINT, &stride, LANDMARK_LABELS_ANALYSIS_WIDTH, G_TYPE_UINT,
          &aw, LANDMARK_LABELS_ANALYSIS_HEIGHT, G_TYPE_UINT, &ah,
          LANDMARK_LABELS_UNCLASSIFIED, G_TYPE_UINT, &unclassified, nullptr),
      "labels meta fields missing: %" GST_PTR_FORMAT, labels);
  FUZZ_CHECK (lw >= 1 && lh >= 1 && stride >= lw && aw >= 1 && ah >= 1 &&
      (int) lw <= w && (int) lh <= h && (int) aw <= w && (int) ah <= h,
      "plane %ux%u stride %u, analysis %ux%u, frame %dx%d", lw, lh, stride,
      aw, ah, w, h);
  const GValue *names = gst_structure_get_value (labels,
      LANDMARK_LABELS_CLASS_NAMES);
  FUZZ_CHECK (names && GST_VALUE_HOLDS_ARRAY (names), "no class-names");
  const guint n_classes = gst_value_array_get_size (names);
  FUZZ_CHECK (n_classes >= 1 && n_classes <= 64, "%u classes", n_classes);
  const GValue *counts = gst_structure_get_value (labels,
      LANDMARK_LABELS_LABEL_COUNTS);
  FUZZ_CHECK (counts && GST_VALUE_HOLDS_ARRAY (counts) &&
      gst_value_array_get_size (counts) == n_classes, "label-counts");
  guint64 total = unclassified;
  for (guint i = 0; i < n_classes; i++)
    total += g_value_get_uint (gst_value_array_get_value (counts, i));
  FUZZ_CHECK (total == (guint64) aw * ah, "label counts %" G_GUINT64_FORMAT
      " for %ux%u", total, aw, ah);
  GstMapInfo pm;
  FUZZ_CHECK (gst_buffer_map (plane, &pm, GST_MAP_READ), "plane map");
  FUZZ_CHECK (pm.size >= (gsize) stride * (lh - 1) + lw, "plane %zu bytes",
      pm.size);
  for (guint y = 0; y < lh; y++)
    for (guint x = 0; x < lw; x++)
      FUZZ_CHECK (pm.data[(gsize) y * stride + x] <= n_classes,
          "label %u at %u,%u", pm.data[(gsize) y * stride + x], x, y);
  gst_buffer_unmap (plane, &pm);
  gst_buffer_unref (plane);

  gpointer state = nullptr;
  GstMeta *meta;
  while ((meta = gst_buffer_iterate_meta_filtered (out, &state,
              GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE))) {
    auto roi = (GstVideoRegionOfInterestMeta *) meta;
    FUZZ_CHECK (roi->w >= 1 && roi->h >= 1 && roi->x + roi->w <= (guint) w &&
        roi->y + roi->h <= (guint) h, "detection %u,%u %ux%u in %dx%d",
        roi->x, roi->y, roi->w, roi->h, w, h);
    bool known = false;
    for (guint i = 0; i < n_classes; i++)
      known |= g_quark_from_string (g_value_get_string
          (gst_value_array_get_value (names, i))) == roi->roi_type;
    FUZZ_CHECK (known, "detection of class %s", g_quark_to_string
        (roi->roi_type));
    const GstStructure *range =
        gst_video_region_of_interest_meta_get_param (roi,
        LANDMARK_RANGE_PARAMS);
    gboolean no_floor = FALSE;
    double r, b;
    if (range && gst_structure_get_boolean (range, "no-floor", &no_floor) &&
        !no_floor) {
      FUZZ_CHECK (gst_structure_get_double (range, "range", &r) &&
          gst_structure_get_double (range, "bearing", &b) && std::isfinite (r)
          && r >= 0 && std::isfinite (b), "range %" GST_PTR_FORMAT, range);
    }
  }

  GstCustomMeta *pm_meta = gst_buffer_get_custom_meta (out,
      GST_LANDMARK_POSE_META_NAME);
  if (pm_meta) {
    const GstStructure *pose = gst_custom_meta_get_structure (pm_meta);
    double x, y, hd;
    FUZZ_CHECK (gst_structure_get_double (pose, "x", &x) &&
        gst_structure_get_double (pose, "y", &y) &&
        gst_structure_get_double (pose, "heading", &hd) && std::isfinite (x)
        && std::isfinite (y) && std::isfinite (hd), "pose %" GST_PTR_FORMAT,
        pose);
  }
}

}  // namespace

extern "C" int
LLVMFuzzerInitialize (int *, char ***)
{
  /* run alone: only our plugin, from the build tree, scanned in-process
   * (a forked scanner would dlopen a sanitized plugin); under meson test
   * the test environment sets these already */
  if (!g_getenv ("GST_PLUGIN_PATH_1_0")) {
    g_setenv ("GST_PLUGIN_PATH_1_0", LANDMARK_BUILD_ROOT "/plugins", TRUE);
    g_setenv ("GST_PLUGIN_SYSTEM_PATH_1_0", "", FALSE);
    g_setenv ("GST_REGISTRY_1_0", LANDMARK_BUILD_ROOT
        "/tests/fuzz/registry.dat", FALSE);
  }
  g_setenv ("GST_REGISTRY_FORK", "no", FALSE);
  const char *root = g_getenv ("LANDMARK_SOURCE_ROOT");
  source_root = root ? root : LANDMARK_SOURCE_ROOT;
  gst_init (nullptr, nullptr);
  GstElement *e = gst_element_factory_make ("labsegment", nullptr);
  FUZZ_CHECK (e != nullptr, "labsegment not found in %s",
      g_getenv ("GST_PLUGIN_PATH_1_0"));
  gst_object_unref (e);
  return 0;
}

extern "C" int
LLVMFuzzerTestOneInput (const uint8_t * data, size_t size)
{
  Bytes in (data, size);
  GstVideoInfo info;
  const GstVideoFormat format = kFormats[in.pick (G_N_ELEMENTS (kFormats))];
  const int w = 1 + in.u8 (), h = 1 + in.u8 ();
  const unsigned frames = 1 + in.pick (3);
  FUZZ_CHECK (gst_video_info_set_format (&info, format, w, h), "info");

  GError *err = nullptr;
  GstElement *bin = gst_parse_bin_from_description ("labsegment name=seg ! "
      "blobroundness name=blob ! ipmrange name=ipm ! trilaterate name=tri ! "
      "landmarkoverlay name=overlay ! landmarklog name=log", TRUE, &err);
  FUZZ_CHECK (bin != nullptr, "%s", err ? err->message : "parse");
  gst_object_ref_sink (bin);
  configure (in, GST_BIN (bin), source_root +
      "/tests/files/clips/path-small/map.json");
  GstBus *bus = gst_bus_new ();
  gst_element_set_bus (bin, bus);
  /* valid settings must start: checked here, as the harness would only
   * assert */
  const GstStateChangeReturn ret = gst_element_set_state (bin,
      GST_STATE_PAUSED);
  check_bus (bus);
  FUZZ_CHECK (ret != GST_STATE_CHANGE_FAILURE, "the chain did not start");

  GstHarness *harness = gst_harness_new_with_element (bin, "sink", "src");
  gst_harness_set_src_caps (harness, gst_video_info_to_caps (&info));
  for (unsigned n = 0; n < frames; n++) {
    GstBuffer *buf = make_frame (in, &info, n);
    const gsize in_size = gst_buffer_get_size (buf);
    const GstFlowReturn flow = gst_harness_push (harness, buf);
    check_bus (bus);
    FUZZ_CHECK (flow == GST_FLOW_OK, "frame %u: %s", n,
        gst_flow_get_name (flow));
    GstBuffer *out = gst_harness_try_pull (harness);
    FUZZ_CHECK (out != nullptr, "frame %u did not come out", n);
    check_output (out, &info, in_size);
    gst_buffer_unref (out);
  }
  FUZZ_CHECK (gst_harness_buffers_received (harness) == frames,
      "%u buffers for %u frames", gst_harness_buffers_received (harness),
      frames);
  gst_harness_teardown (harness);
  gst_element_set_bus (bin, nullptr);
  gst_object_unref (bus);
  gst_object_unref (bin);
  return 0;
}
