/**
 * SECTION:element-birdseye
 * @title: birdseye
 *
 * The floor seen from above: every output pixel shows the floor point
 * below it, looked up in the camera image through the camera model of
 * `ipmrange` (the same camera properties). Robot forward is up, left is
 * left; the camera's floor point is at the bottom centre (`behind` metres
 * above the bottom edge). The output is `pixels-per-metre` x (2 `side`)
 * wide and `pixels-per-metre` x (`forward` + `behind`) high; floor points
 * the camera does not see are black. The remap table is built when the
 * caps or the camera change (docs/floorboundary.md), never per frame; a
 * frame costs one `cv::remap` (bilinear).
 *
 * With `draw` (flags, default none: the plain remap) the frame's results
 * are drawn on the view at its scale, in robot-frame metres, in the colours
 * and line widths of `landmarkoverlay`: `boundary`, the floor meta's
 * boundary points (red on obstacles, cyan where the floor reaches
 * max-range or the image's top) and its free space, the seen bins of the
 * radial obstacle profile at their ranges, outlined in green around the
 * robot (red arcs at obstacles); `landmarks`, each detection that no stage
 * rejected and `ipmrange` placed on the floor (`ground-x`, `ground-y`), as
 * a disc of its diameter (ipmrange's `marker-diameter`, else the `map`
 * file's, else its ellipse's width measured on the floor) in its class
 * colour, with its landmark id when `trilaterate` matched it; `robot`, the camera's field of view on the
 * floor (dashed) and a triangle on the camera's floor point pointing
 * forward.
 *
 * Metadata that belongs to the frame rather than to its pixels travels
 * with it (`GstLandmarkPoseMeta`, `GstLandmarkFloorMeta`, the detections'
 * parameters in `GstLandmarkDetectionsMeta`); metas in image coordinates
 * (the label plane, region-of-interest boxes) are dropped, since they do
 * not describe the new image.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! decodebin ! videoconvert !
 *     labsegment ! floorboundary calibration=camera.yml !
 *     birdseye calibration=camera.yml pixels-per-metre=100
 *     draw=boundary+robot ! videoconvert ! autovideosink
 * ]|
 */

#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstbirdseye.h"

#include <gst/video/video.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "cameraprops.h"
#include "elementsettings.h"
#include "fileutil.h"
#include "floorprofile.h"
#include "landmarkmeta.h"
#include "overlaydraw.h"
#include "overlaymeta.h"

GST_DEBUG_CATEGORY_STATIC (gst_birds_eye_debug);
#define GST_CAT_DEFAULT gst_birds_eye_debug

#define MAX_OUTPUT_SIZE 8192

#define FORMATS "{ RGB, BGR, RGBx, BGRx, xRGB, xBGR, RGBA, BGRA, ARGB, " \
  "ABGR, GRAY8 }"

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE ("sink",
    GST_PAD_SINK, GST_PAD_ALWAYS,
    GST_STATIC_CAPS (GST_VIDEO_CAPS_MAKE (FORMATS)));

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE ("src",
    GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS (GST_VIDEO_CAPS_MAKE (FORMATS)));

/* *INDENT-OFF* */
namespace {

namespace ov = landmark::overlay;

/* What the user sets (the initial values are the defaults). */
struct Settings {
  landmark::CameraSettings camera;
  gdouble pixels_per_metre = 100.0;
  gdouble forward = 4.0, behind = 0.0;
  gdouble side = 2.0;
  guint draw = 0;               /* GstBirdsEyeDraw */
  std::string map;              /* landmark map: diameters; "": none */
  guint map_generation = 0;     /* sets of `map` */
};

/* Settings checked, the camera file read, and the remap table for the
 * input size (once the caps are known). */
struct Config {
  Settings s;
  landmark::CameraSetup camera;
  cv::Mat map1, map2;           /* fixed-point maps for cv::remap */
  std::vector<float> map_x, map_y;
  /* what the drawings need: the camera, the view's scale, and the image's
   * edges on the floor (runs of output pixels) */
  landmark::CameraGeometry geometry;
  ov::FloorView view;
  std::vector<cv::Point2d> fov;
  std::vector<int> fov_runs;
};

struct State {
  landmark::AppliedSettings<Settings, Config> applied;
  landmark::SettingsFile<landmark::LandmarkMap> map;  /* path "": none */
  ov::Renderer renderer;        /* canvas of the output size */
  ov::Target target;            /* the output's format */
  ov::ClassColours colours;
  std::vector<ov::Detection> detections;  /* per-frame scratch, reused */
};

}  // namespace

/* *INDENT-ON* */

LANDMARK_DEFINE_ELEMENT (GstBirdsEye, gst_birds_eye,
    Settings, State, GstVideoFilter, GST_TYPE_VIDEO_FILTER, birdseye,
    "Bird's-eye view of the floor");

GType
gst_birds_eye_draw_get_type (void)
{
  static const GFlagsValue values[] = {
    {GST_BIRDS_EYE_DRAW_NONE, "Nothing: the plain remap", "none"},
    {GST_BIRDS_EYE_DRAW_BOUNDARY, "The floor meta's boundary points and "
          "its free space (the radial obstacle profile) outlined",
        "boundary"},
    {GST_BIRDS_EYE_DRAW_LANDMARKS, "Each accepted ranged detection as a "
          "disc of its size at its floor position, with its landmark id",
        "landmarks"},
    {GST_BIRDS_EYE_DRAW_ROBOT, "The camera's floor point and heading, and "
          "its field of view on the floor", "robot"},
    {0, nullptr, nullptr}
  };
  static const GType type = g_flags_register_static ("GstBirdsEyeDraw",
      values);
  return type;
}

/* The output geometry of the settings. */
static landmark::BirdsEyeParams
birds_eye_params (const Settings & s)
{
  landmark::BirdsEyeParams b;
  b.pixels_per_metre = s.pixels_per_metre;
  b.out_w = (int) std::lround (s.pixels_per_metre * 2 * s.side);
  b.out_h = (int) std::lround (s.pixels_per_metre * (s.forward + s.behind));
  b.origin_u = b.out_w / 2.0 - 0.5;
  b.origin_v = b.out_h - 0.5 - s.behind * s.pixels_per_metre;
  return b;
}

/* The image's left, bottom and right edges on the floor, in output
 * pixels: runs of the points that see the floor within reach, one edge at
 * most each (a run round a corner would be painted as one wide shape). */
static void
birds_eye_fov (Config & cfg, int in_w, int in_h, double reach)
{
  constexpr int kSteps = 48;    /* points along each edge */
  cfg.fov.clear ();
  cfg.fov_runs.clear ();
  int run = 0;
  for (int edge = 0; edge < 3; edge++) {
    for (int k = 0; k <= kSteps; k++) {
      const double t = (double) k / kSteps;
      /* left edge downwards, bottom edge rightwards, right edge upwards */
      const double u = edge == 0 ? -0.5 : edge == 1 ? -0.5 + t * in_w :
          in_w - 0.5;
      const double v = edge == 0 ? -0.5 + t * in_h : edge == 1 ? in_h - 0.5 :
          in_h - 0.5 - t * in_h;
      double x, y;
      if (cfg.geometry.pixel_to_plane (u, v, 0, &x, &y) &&
          std::hypot (x, y) <= reach) {
        cfg.fov.push_back (cfg.view.to_px (x, y));
        run++;
      } else if (run > 0) {
        cfg.fov_runs.push_back (run);
        run = 0;
      }
    }
    if (run > 0)
      cfg.fov_runs.push_back (run);
    run = 0;
  }
}

/* Builds the remap table for an input frame. */
static bool
birds_eye_build (Config & cfg, int in_w, int in_h,
    landmark::SettingsError * err)
{
  landmark::CameraParams p;
  if (!landmark::camera_setup_params (cfg.camera, in_w, in_h, &p,
          &err->property, &err->why))
    return false;
  landmark::CameraGeometry g;
  err->property = cfg.camera.e.seed ? "model" : "tilt";
  if (!g.configure (p, &err->why))
    return false;
  const landmark::BirdsEyeParams b = birds_eye_params (cfg.s);
  if (!landmark::birdseye_maps (g, b, &cfg.map_x, &cfg.map_y, &err->why))
    return false;
  bool any = false;
  for (float x : cfg.map_x)
    any = any || x >= -1;
  if (!any)
    return err->fail (err->property,
        "the camera sees no floor within the view's extent");
  cv::Mat fx (b.out_h, b.out_w, CV_32FC1, cfg.map_x.data ());
  cv::Mat fy (b.out_h, b.out_w, CV_32FC1, cfg.map_y.data ());
  cv::convertMaps (fx, fy, cfg.map1, cfg.map2, CV_16SC2);
  cfg.geometry = g;
  cfg.view.pixels_per_metre = b.pixels_per_metre;
  cfg.view.origin_u = b.origin_u;
  cfg.view.origin_v = b.origin_v;
  /* a little beyond the view's farthest corner, so the edges cross the
   * whole view and no farther */
  birds_eye_fov (cfg, in_w, in_h, 1.2 * std::hypot (std::max (cfg.s.forward,
              cfg.s.behind), cfg.s.side) + 0.1);
  return true;
}

/* Checks the settings and reads the camera file; with in_w > 0 also
 * checks the output against the negotiated out_w x out_h (fixed in READY)
 * and builds the remap table for in_w x in_h input. */
static bool
birds_eye_configure (const Settings & s, int in_w, int in_h, int out_w,
    int out_h, Config * cfg, landmark::SettingsError * err)
{
  cfg->s = s;
  if (!landmark::camera_setup_resolve (s.camera, &cfg->camera,
          &err->property, &err->why))
    return false;
  const landmark::BirdsEyeParams b = birds_eye_params (s);
  if (b.out_w < 1 || b.out_h < 1 || b.out_w > MAX_OUTPUT_SIZE ||
      b.out_h > MAX_OUTPUT_SIZE)
    return err->fail (b.out_w < 1 || b.out_w > MAX_OUTPUT_SIZE ? "side" :
        "forward", "the output would be " + std::to_string (b.out_w) + "x" +
        std::to_string (b.out_h) + " pixels; each side must be within 1.." +
        std::to_string (MAX_OUTPUT_SIZE) + " (pixels-per-metre " +
        landmark::number_text (s.pixels_per_metre) + ")");
  if (in_w <= 0)
    return true;
  if (b.out_w != out_w || b.out_h != out_h)
    return err->fail ("pixels-per-metre",
        "the output size changes only in the READY state");
  return birds_eye_build (*cfg, in_w, in_h, err);
}

static const landmark::PropertyTable<Settings> &
birds_eye_properties ()
{
  static const auto table = landmark::PropertyTable<Settings> ()
      .part (&Settings::camera, camera_properties ())
      /* the output size is negotiated in READY */
      .number ("pixels-per-metre", "Pixels per metre",
          "Scale of the output: pixels per metre of floor",
          &Settings::pixels_per_metre, 1.0, 10000.0)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .number ("forward", "Forward extent",
          "Metres of floor shown ahead of the camera's floor point",
          &Settings::forward, 0.0, 1000.0)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .number ("behind", "Behind extent",
          "Metres shown behind the camera's floor point (the robot)",
          &Settings::behind, 0.0, 1000.0)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .number ("side", "Side extent",
          "Metres shown on each side of the robot's axis", &Settings::side,
          0.0, 1000.0)
      .mutable_in (GST_PARAM_MUTABLE_READY)
      .add ([](GParamFlags f) {
            return g_param_spec_flags ("draw", "Draw",
                "What to draw on the view, at its scale: boundary (the floor "
                "meta's boundary and free space), landmarks (accepted ranged "
                "detections at their floor positions and sizes), robot (the "
                "camera's floor point, heading and field of view); none: the "
                "plain remap", GST_TYPE_BIRDS_EYE_DRAW, 0, f);
          },
          [](Settings & s, const GValue * v) { s.draw = g_value_get_flags (v); },
          [](const Settings & s, GValue * v) { g_value_set_flags (v, s.draw); })
      .file ("map", "Map file",
          "JSON landmark map (docs/conventions.md): the diameters of the "
          "landmarks drawn (the matched landmark's, or its class's when all "
          "of the class share one); unset: ipmrange's, else measured",
          &Settings::map, &Settings::map_generation);
  return table;
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_birds_eye_init (GstBirdsEye * self)
{
  self->priv = new GstBirdsEyePrivate ();
  gst_base_transform_set_qos_enabled (GST_BASE_TRANSFORM (self), FALSE);
}


/* ---- states and caps ------------------------------------------------ */

/* The map file; the empty path is no map. */
static bool
birds_eye_load_map (const std::string & path, landmark::LandmarkMap * map,
    std::string * why)
{
  return path.empty () || landmark::map_load_file (path, map, why);
}

/* the settings (those that need no frame size; set_info checks the rest)
 * and the map file (landmark::change_state_checking_settings) */
static bool
gst_birds_eye_apply_settings (GstBirdsEye * self)
{
  auto check = [](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    return birds_eye_configure (s, 0, 0, 0, 0, cfg, err);
  };
  State & st = self->priv->state;
  if (!st.applied.start (GST_ELEMENT (self), self->priv->settings, check))
    return false;
  const Settings & s = st.applied.config.s;
  return st.map.start (GST_ELEMENT (self), "map", s.map, s.map_generation,
      birds_eye_load_map);
}

/* Output caps: the input's with the bird's-eye size (square pixels);
 * input caps: any size. */
static GstCaps *
gst_birds_eye_transform_caps (GstBaseTransform * trans,
    GstPadDirection direction, GstCaps * caps, GstCaps * filter)
{
  auto self = GST_BIRDS_EYE (trans);
  const landmark::BirdsEyeParams b =
      birds_eye_params (self->priv->settings.copy ());
  GstCaps *out = gst_caps_copy (caps);
  for (guint i = 0; i < gst_caps_get_size (out); i++) {
    GstStructure *st = gst_caps_get_structure (out, i);
    if (direction == GST_PAD_SINK) {
      gst_structure_set (st, "width", G_TYPE_INT, MAX (b.out_w, 1),
          "height", G_TYPE_INT, MAX (b.out_h, 1), "pixel-aspect-ratio",
          GST_TYPE_FRACTION, 1, 1, nullptr);
    } else {
      gst_structure_set (st, "width", GST_TYPE_INT_RANGE, 1, G_MAXINT,
          "height", GST_TYPE_INT_RANGE, 1, G_MAXINT, nullptr);
      gst_structure_remove_field (st, "pixel-aspect-ratio");
    }
  }
  if (filter) {
    GstCaps *f = gst_caps_intersect_full (filter, out,
        GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref (out);
    out = f;
  }
  return out;
}

static gboolean
gst_birds_eye_set_info (GstVideoFilter * filter, GstCaps * incaps,
    GstVideoInfo * in_info, GstCaps * outcaps, GstVideoInfo * out_info)
{
  auto self = GST_BIRDS_EYE (filter);
  State & st = self->priv->state;
  (void) incaps;
  (void) outcaps;
  if (GST_VIDEO_INFO_FORMAT (in_info) != GST_VIDEO_INFO_FORMAT (out_info)) {
    GST_ERROR_OBJECT (self, "input and output formats differ");
    return FALSE;
  }
  const int in_w = GST_VIDEO_INFO_WIDTH (in_info);
  const int in_h = GST_VIDEO_INFO_HEIGHT (in_info);
  const int out_w = GST_VIDEO_INFO_WIDTH (out_info);
  const int out_h = GST_VIDEO_INFO_HEIGHT (out_info);
  auto configure = [=](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    return birds_eye_configure (s, in_w, in_h, out_w, out_h, cfg, err);
  };
  if (!st.applied.start (GST_ELEMENT (self), self->priv->settings,
          configure))
    return FALSE;
  /* the drawings' target: packed RGB in any byte order, or grey (luma) */
  ov::Target t;
  t.width = out_w;
  t.height = out_h;
  if (GST_VIDEO_INFO_FORMAT (out_info) == GST_VIDEO_FORMAT_GRAY8) {
    t.kind = ov::Target::Kind::GRAY;
    t.model = landmark::InputModel::yuv (0.299, 0.114, true);
  } else {
    t.pixel_stride = GST_VIDEO_INFO_COMP_PSTRIDE (out_info, 0);
    for (int c = 0; c < 3; c++)
      t.offset[c] = GST_VIDEO_INFO_COMP_POFFSET (out_info, c);
  }
  st.target = t;
  st.colours.init_defaults ();
  st.detections.reserve (64);
  try {
    if (st.renderer.width () != out_w || st.renderer.height () != out_h)
      st.renderer.configure (out_w, out_h);
  }
  catch (const std::exception & e) {
    GST_ERROR_OBJECT (self, "cannot allocate the drawing canvas: %s",
        e.what ());
    return FALSE;
  }
  GST_INFO_OBJECT (self, "remap %dx%d -> %dx%d", GST_VIDEO_INFO_WIDTH
      (in_info), GST_VIDEO_INFO_HEIGHT (in_info),
      GST_VIDEO_INFO_WIDTH (out_info), GST_VIDEO_INFO_HEIGHT (out_info));
  return TRUE;
}

/* ---- streaming ------------------------------------------------------ */

/* Camera settings changed while playing: a new table, or a warning and
 * the previous one. The output size is fixed by the caps (READY). */
static void
gst_birds_eye_sync_settings (GstBirdsEye * self)
{
  GstVideoFilter *filter = GST_VIDEO_FILTER (self);
  auto configure = [filter](const Settings & s, Config * cfg,
      landmark::SettingsError * err) {
    return birds_eye_configure (s, GST_VIDEO_INFO_WIDTH (&filter->in_info),
        GST_VIDEO_INFO_HEIGHT (&filter->in_info),
        GST_VIDEO_INFO_WIDTH (&filter->out_info),
        GST_VIDEO_INFO_HEIGHT (&filter->out_info), cfg, err);
  };
  State & st = self->priv->state;
  if (st.applied.sync (GST_ELEMENT (self), self->priv->settings, configure)) {
    const Settings & s = st.applied.config.s;
    st.map.sync (GST_ELEMENT (self), "map", s.map, s.map_generation,
        birds_eye_load_map);
  }
}

/* A detection's diameter from the map: its matched landmark's, else the
 * one every landmark of its class shares; 0: none. */
static double
birds_eye_map_diameter (const landmark::LandmarkMap & map,
    const ov::Detection & d)
{
  double shared = -1;
  for (const auto & lm : map.landmarks) {
    if (d.matched && d.landmark_id && lm.id == d.landmark_id)
      return lm.diameter;
    if (d.class_name && lm.class_name == d.class_name)
      shared = shared < 0 || shared == lm.diameter ? lm.diameter : 0;
  }
  return std::max (shared, 0.0);
}

/* A detection's diameter on the floor, metres: ipmrange's (from the map's
 * marker specs), the map's, else measured: the width of its ellipse across
 * the image (a disc's or ball's diameter across the line of sight) on the
 * plane of its centre, unless the frame's edge cuts its box; 0: none. */
static double
birds_eye_diameter (const ov::Detection & d, const landmark::LandmarkMap & map,
    const landmark::CameraGeometry & g, int width, int height)
{
  if (d.marker_diameter > 0)
    return d.marker_diameter;
  const double from_map = birds_eye_map_diameter (map, d);
  if (from_map > 0)
    return from_map;
  if (!d.has_ellipse || !(d.ellipse_major > 0) || d.x <= 0 || d.y <= 0 ||
      d.x + d.w >= width || d.y + d.h >= height)
    return 0;
  const double a = d.ellipse_major / 2, b = d.ellipse_minor / 2;
  const double half = std::hypot (a * std::cos (d.ellipse_angle),
      b * std::sin (d.ellipse_angle));
  const double v = (d.ellipse_y + 0.5) * d.sy - 0.5;
  double x[2], y[2];
  for (int e = 0; e < 2; e++) {
    const double u = (d.ellipse_x + (e ? half : -half) + 0.5) * d.sx - 0.5;
    if (!g.pixel_to_plane (u, v, d.marker_height, &x[e], &y[e]))
      return 0;
  }
  return std::hypot (x[1] - x[0], y[1] - y[0]);
}

/* Draws what `draw` asks for from the input buffer's metadata onto the
 * output frame. */
static void
gst_birds_eye_draw (GstBirdsEye * self, GstBuffer * buf, int in_w, int in_h,
    GstVideoFrame * out)
{
  State & st = self->priv->state;
  const Config & cfg = st.applied.config;
  const guint draw = cfg.s.draw;
  ov::Renderer & r = st.renderer;
  r.begin_frame (1.0);
  if (draw & GST_BIRDS_EYE_DRAW_BOUNDARY) {
    const GstStructure *fs = landmark_floor_meta_get (buf);
    ov::FloorArrays fa;
    if (fs) {
      ov::read_floor (fs, &fa, true);
      r.draw_floor_boundary (fa.floor, cfg.view);
    }
  }
  if (draw & GST_BIRDS_EYE_DRAW_ROBOT)
    r.draw_floor_robot (cfg.view, cfg.fov.data (), cfg.fov_runs.data (),
        (int) cfg.fov_runs.size ());
  if ((draw & GST_BIRDS_EYE_DRAW_LANDMARKS) && gst_buffer_get_meta (buf,
          GST_VIDEO_REGION_OF_INTEREST_META_API_TYPE)) {
    st.colours.read (landmark_labels_meta_get (buf), nullptr);
    ov::read_detections (buf, st.colours, in_w, in_h, &st.detections,
        GST_CAT_DEFAULT, G_OBJECT (self));
    for (const auto & d : st.detections)
      if (d.kept && !d.no_floor && d.has_ground)
        r.draw_floor_landmark (d, birds_eye_diameter (d, st.map.contents,
                cfg.geometry, in_w, in_h), cfg.view);
  }
  if (!r.dirty ())
    return;
  ov::Target t = st.target;
  t.data[0] = (uint8_t *) GST_VIDEO_FRAME_PLANE_DATA (out, 0);
  t.stride[0] = GST_VIDEO_FRAME_PLANE_STRIDE (out, 0);
  r.composite (t);
}

static GstFlowReturn
gst_birds_eye_transform_frame (GstVideoFilter * filter,
    GstVideoFrame * in, GstVideoFrame * out)
{
  auto self = GST_BIRDS_EYE (filter);
  State & st = self->priv->state;
  gst_birds_eye_sync_settings (self);
  const int type = CV_8UC (GST_VIDEO_FRAME_COMP_PSTRIDE (in, 0));
  return landmark::run_drawing_frame (GST_ELEMENT (self),
      "Bird's-eye remap failed.", st.renderer, [&] {
        /* views of the mapped frames with their strides: no copy */
        const cv::Mat src (GST_VIDEO_FRAME_HEIGHT (in),
            GST_VIDEO_FRAME_WIDTH (in), type, GST_VIDEO_FRAME_PLANE_DATA (in, 0),
            GST_VIDEO_FRAME_PLANE_STRIDE (in, 0));
        cv::Mat dst (GST_VIDEO_FRAME_HEIGHT (out), GST_VIDEO_FRAME_WIDTH (out),
            type, GST_VIDEO_FRAME_PLANE_DATA (out, 0),
            GST_VIDEO_FRAME_PLANE_STRIDE (out, 0));
        const Config & cfg = st.applied.config;
        cv::remap (src, dst, cfg.map1, cfg.map2, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar::all (0));
        if (cfg.s.draw)
          gst_birds_eye_draw (self, in->buffer, src.cols, src.rows, out);
        return GST_FLOW_OK;
      });
}

static void
gst_birds_eye_class_init (GstBirdsEyeClass * klass)
{
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  GstVideoFilterClass *filter_class = GST_VIDEO_FILTER_CLASS (klass);

  landmark::install_element_properties<Settings, gst_birds_eye_settings,
      birds_eye_properties> (klass, gst_birds_eye_finalize);

  gst_element_class_set_static_metadata (element_class,
      "Bird's-eye view of the floor", "Filter/Converter/Video",
      "Shows the floor seen from above at a chosen scale, through the "
      "camera model of ipmrange, by a remap table built once per caps or "
      "camera change", "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  landmark::set_settings_lifecycle<GstBirdsEye, gst_birds_eye_get_type,
      gst_birds_eye_apply_settings> (klass);
  gst_type_mark_as_plugin_api (GST_TYPE_BIRDS_EYE_DRAW, (GstPluginAPIFlags) 0);
  trans_class->transform_caps =
      GST_DEBUG_FUNCPTR (gst_birds_eye_transform_caps);
  filter_class->set_info = GST_DEBUG_FUNCPTR (gst_birds_eye_set_info);
  filter_class->transform_frame =
      GST_DEBUG_FUNCPTR (gst_birds_eye_transform_frame);
}
