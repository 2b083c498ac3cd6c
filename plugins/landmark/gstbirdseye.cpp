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
 * Metadata that belongs to the frame rather than to its pixels travels
 * with it (`GstLandmarkPoseMeta`, `GstLandmarkFloorMeta`, the detections'
 * parameters in `GstLandmarkDetectionsMeta`); metas in image coordinates
 * (the label plane, region-of-interest boxes) are dropped, since they do
 * not describe the new image.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 filesrc location=clip.avi ! decodebin ! videoconvert !
 *     birdseye calibration=camera.yml pixels-per-metre=100 !
 *     videoconvert ! autovideosink
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
#include "fileutil.h"
#include "floorprofile.h"

GST_DEBUG_CATEGORY_STATIC (gst_birds_eye_debug);
#define GST_CAT_DEFAULT gst_birds_eye_debug

#define DEFAULT_PIXELS_PER_METRE 100.0
#define DEFAULT_FORWARD 4.0
#define DEFAULT_BEHIND 0.0
#define DEFAULT_SIDE 2.0
#define MAX_OUTPUT_SIZE 8192

enum
{
  PROP_0,
  PROP_CAMERA_FIRST,            /* cameraprops.h: CAMERA_PROP_COUNT ids */
  PROP_PIXELS_PER_METRE = PROP_CAMERA_FIRST + CAMERA_PROP_COUNT,
  PROP_FORWARD,
  PROP_BEHIND,
  PROP_SIDE,
};

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

struct Settings {
  landmark::CameraSettings camera;
  gdouble pixels_per_metre = DEFAULT_PIXELS_PER_METRE;
  gdouble forward = DEFAULT_FORWARD, behind = DEFAULT_BEHIND;
  gdouble side = DEFAULT_SIDE;
  guint generation = 0;
};

struct State {
  landmark::CameraSetup camera;
  guint generation = G_MAXUINT;
  guint warned_generation = G_MAXUINT;
  cv::Mat map1, map2;           /* fixed-point maps for cv::remap */
  std::vector<float> map_x, map_y;
};

}  // namespace

struct GstBirdsEyePrivate {
  std::mutex lock;              /* guards settings */
  Settings settings;
  State state;
};

struct _GstBirdsEye {
  GstVideoFilter parent;
  GstBirdsEyePrivate *priv;
};
/* *INDENT-ON* */

G_DEFINE_TYPE_WITH_CODE (GstBirdsEye, gst_birds_eye, GST_TYPE_VIDEO_FILTER,
    GST_DEBUG_CATEGORY_INIT (gst_birds_eye_debug, "birdseye", 0,
        "Bird's-eye view of the floor"));
GST_ELEMENT_REGISTER_DEFINE (birdseye, "birdseye", GST_RANK_NONE,
    GST_TYPE_BIRDS_EYE);

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

static gboolean
birds_eye_check (const Settings & s, landmark::CameraSetup * camera,
    const char **property, std::string * why)
{
  if (!landmark::camera_setup_resolve (s.camera, camera, property, why))
    return FALSE;
  const landmark::BirdsEyeParams b = birds_eye_params (s);
  if (b.out_w < 1 || b.out_h < 1 || b.out_w > MAX_OUTPUT_SIZE ||
      b.out_h > MAX_OUTPUT_SIZE) {
    *property = b.out_w < 1 || b.out_w > MAX_OUTPUT_SIZE ? "side" :
        "forward";
    *why = "the output would be " + std::to_string (b.out_w) + "x" +
        std::to_string (b.out_h) + " pixels; each side must be within 1.." +
        std::to_string (MAX_OUTPUT_SIZE) + " (pixels-per-metre " +
        landmark::number_text (s.pixels_per_metre) + ")";
    return FALSE;
  }
  return TRUE;
}

/* Builds the remap table for an input frame; FALSE with *why. */
static gboolean
birds_eye_build (const Settings & s, const landmark::CameraSetup & camera,
    int in_w, int in_h, State * st, const char **property, std::string * why)
{
  landmark::CameraParams p;
  if (!landmark::camera_setup_params (camera, in_w, in_h, &p, property, why))
    return FALSE;
  landmark::CameraGeometry g;
  *property = camera.e.seed ? "model" : "tilt";
  if (!g.configure (p, why))
    return FALSE;
  const landmark::BirdsEyeParams b = birds_eye_params (s);
  std::vector<float> mx, my;
  if (!landmark::birdseye_maps (g, b, &mx, &my, why))
    return FALSE;
  bool any = false;
  for (float x : mx)
    any = any || x >= -1;
  if (!any) {
    *why = "the camera sees no floor within the view's extent";
    return FALSE;
  }
  st->map_x = std::move (mx);
  st->map_y = std::move (my);
  cv::Mat fx (b.out_h, b.out_w, CV_32FC1, st->map_x.data ());
  cv::Mat fy (b.out_h, b.out_w, CV_32FC1, st->map_y.data ());
  cv::convertMaps (fx, fy, st->map1, st->map2, CV_16SC2);
  return TRUE;
}

/* ---- GObject -------------------------------------------------------- */

static void
gst_birds_eye_init (GstBirdsEye * self)
{
  self->priv = new GstBirdsEyePrivate ();
  gst_base_transform_set_qos_enabled (GST_BASE_TRANSFORM (self), FALSE);
}

static void
gst_birds_eye_finalize (GObject * object)
{
  delete GST_BIRDS_EYE (object)->priv;
  G_OBJECT_CLASS (gst_birds_eye_parent_class)->finalize (object);
}

static void
gst_birds_eye_set_property (GObject * object, guint prop_id,
    const GValue * value, GParamSpec * pspec)
{
  auto priv = GST_BIRDS_EYE (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  Settings & s = priv->settings;
  if (camera_props_set (&s.camera, PROP_CAMERA_FIRST, prop_id, value)) {
    s.generation++;
    return;
  }
  switch (prop_id) {
    case PROP_PIXELS_PER_METRE:
      s.pixels_per_metre = g_value_get_double (value);
      break;
    case PROP_FORWARD:
      s.forward = g_value_get_double (value);
      break;
    case PROP_BEHIND:
      s.behind = g_value_get_double (value);
      break;
    case PROP_SIDE:
      s.side = g_value_get_double (value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      return;
  }
  s.generation++;
}

static void
gst_birds_eye_get_property (GObject * object, guint prop_id,
    GValue * value, GParamSpec * pspec)
{
  auto priv = GST_BIRDS_EYE (object)->priv;
  std::lock_guard<std::mutex> lk (priv->lock);
  const Settings & s = priv->settings;
  if (camera_props_get (s.camera, PROP_CAMERA_FIRST, prop_id, value))
    return;
  switch (prop_id) {
    case PROP_PIXELS_PER_METRE:
      g_value_set_double (value, s.pixels_per_metre);
      break;
    case PROP_FORWARD:
      g_value_set_double (value, s.forward);
      break;
    case PROP_BEHIND:
      g_value_set_double (value, s.behind);
      break;
    case PROP_SIDE:
      g_value_set_double (value, s.side);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, prop_id, pspec);
      break;
  }
}

/* ---- states and caps ------------------------------------------------ */

static GstStateChangeReturn
gst_birds_eye_change_state (GstElement * element, GstStateChange transition)
{
  auto self = GST_BIRDS_EYE (element);
  if (transition == GST_STATE_CHANGE_NULL_TO_READY) {
    Settings s;
    {
      std::lock_guard<std::mutex> lk (self->priv->lock);
      s = self->priv->settings;
    }
    landmark::CameraSetup camera;
    const char *property = nullptr;
    std::string why;
    if (!birds_eye_check (s, &camera, &property, &why)) {
      GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
          ("Invalid '%s' value.", property), ("%s", why.c_str ()));
      return GST_STATE_CHANGE_FAILURE;
    }
  }
  return GST_ELEMENT_CLASS (gst_birds_eye_parent_class)->change_state
      (element, transition);
}

/* Output caps: the input's with the bird's-eye size (square pixels);
 * input caps: any size. */
static GstCaps *
gst_birds_eye_transform_caps (GstBaseTransform * trans,
    GstPadDirection direction, GstCaps * caps, GstCaps * filter)
{
  auto self = GST_BIRDS_EYE (trans);
  landmark::BirdsEyeParams b;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    b = birds_eye_params (self->priv->settings);
  }
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
  Settings s;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    s = self->priv->settings;
  }
  const char *property = nullptr;
  std::string why;
  landmark::CameraSetup camera;
  if (!birds_eye_check (s, &camera, &property, &why) ||
      !birds_eye_build (s, camera, GST_VIDEO_INFO_WIDTH (in_info),
          GST_VIDEO_INFO_HEIGHT (in_info), &st, &property, &why)) {
    GST_ELEMENT_ERROR (self, RESOURCE, SETTINGS,
        ("Invalid '%s' value.", property), ("%s", why.c_str ()));
    return FALSE;
  }
  st.camera = camera;
  st.generation = s.generation;
  st.warned_generation = G_MAXUINT;
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
  State & st = self->priv->state;
  Settings s;
  {
    std::lock_guard<std::mutex> lk (self->priv->lock);
    if (self->priv->settings.generation == st.generation)
      return;
    s = self->priv->settings;
  }
  const landmark::BirdsEyeParams b = birds_eye_params (s);
  const char *property = nullptr;
  std::string why;
  landmark::CameraSetup camera;
  bool ok = birds_eye_check (s, &camera, &property, &why);
  if (ok && (b.out_w != GST_VIDEO_INFO_WIDTH (&filter->out_info) ||
          b.out_h != GST_VIDEO_INFO_HEIGHT (&filter->out_info))) {
    ok = false;
    property = "pixels-per-metre";
    why = "the output size changes only in the READY state";
  }
  State next;
  if (ok)
    ok = birds_eye_build (s, camera, GST_VIDEO_INFO_WIDTH (&filter->in_info),
        GST_VIDEO_INFO_HEIGHT (&filter->in_info), &next, &property, &why);
  if (!ok) {
    if (st.warned_generation != s.generation) {
      GST_ELEMENT_WARNING (self, RESOURCE, SETTINGS,
          ("Invalid '%s' value; keeping the previous settings.", property),
          ("%s", why.c_str ()));
      st.warned_generation = s.generation;
    }
    return;
  }
  st.map1 = next.map1;
  st.map2 = next.map2;
  st.map_x = std::move (next.map_x);
  st.map_y = std::move (next.map_y);
  st.camera = camera;
  st.generation = s.generation;
}

static GstFlowReturn
gst_birds_eye_transform_frame (GstVideoFilter * filter,
    GstVideoFrame * in, GstVideoFrame * out)
{
  auto self = GST_BIRDS_EYE (filter);
  State & st = self->priv->state;
  gst_birds_eye_sync_settings (self);
  const int type = CV_8UC (GST_VIDEO_FRAME_COMP_PSTRIDE (in, 0));
  try {
    /* views of the mapped frames with their strides: no copy */
    const cv::Mat src (GST_VIDEO_FRAME_HEIGHT (in), GST_VIDEO_FRAME_WIDTH (in),
        type, GST_VIDEO_FRAME_PLANE_DATA (in, 0),
        GST_VIDEO_FRAME_PLANE_STRIDE (in, 0));
    cv::Mat dst (GST_VIDEO_FRAME_HEIGHT (out), GST_VIDEO_FRAME_WIDTH (out),
        type, GST_VIDEO_FRAME_PLANE_DATA (out, 0),
        GST_VIDEO_FRAME_PLANE_STRIDE (out, 0));
    cv::remap (src, dst, st.map1, st.map2, cv::INTER_LINEAR,
        cv::BORDER_CONSTANT, cv::Scalar::all (0));
  }
  catch (const std::exception & e) {
    GST_ELEMENT_ERROR (self, STREAM, FAILED, ("Bird's-eye remap failed."),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
  return GST_FLOW_OK;
}

static void
gst_birds_eye_class_init (GstBirdsEyeClass * klass)
{
  GObjectClass *gobject_class = G_OBJECT_CLASS (klass);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  GstBaseTransformClass *trans_class = GST_BASE_TRANSFORM_CLASS (klass);
  GstVideoFilterClass *filter_class = GST_VIDEO_FILTER_CLASS (klass);

  gobject_class->set_property = gst_birds_eye_set_property;
  gobject_class->get_property = gst_birds_eye_get_property;
  gobject_class->finalize = gst_birds_eye_finalize;

  const GParamFlags playing = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);
  const GParamFlags ready = (GParamFlags) (G_PARAM_READWRITE |
      G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
  camera_props_install (gobject_class, PROP_CAMERA_FIRST, playing);
  g_object_class_install_property (gobject_class, PROP_PIXELS_PER_METRE,
      g_param_spec_double ("pixels-per-metre", "Pixels per metre",
          "Scale of the output: pixels per metre of floor", 1.0, 10000.0,
          DEFAULT_PIXELS_PER_METRE, ready));
  g_object_class_install_property (gobject_class, PROP_FORWARD,
      g_param_spec_double ("forward", "Forward extent",
          "Metres of floor shown ahead of the camera's floor point", 0.0,
          1000.0, DEFAULT_FORWARD, ready));
  g_object_class_install_property (gobject_class, PROP_BEHIND,
      g_param_spec_double ("behind", "Behind extent",
          "Metres shown behind the camera's floor point (the robot)", 0.0,
          1000.0, DEFAULT_BEHIND, ready));
  g_object_class_install_property (gobject_class, PROP_SIDE,
      g_param_spec_double ("side", "Side extent",
          "Metres shown on each side of the robot's axis", 0.0, 1000.0,
          DEFAULT_SIDE, ready));

  gst_element_class_set_static_metadata (element_class,
      "Bird's-eye view of the floor", "Filter/Converter/Video",
      "Shows the floor seen from above at a chosen scale, through the "
      "camera model of ipmrange, by a remap table built once per caps or "
      "camera change", "gst-landmark developers");
  gst_element_class_add_static_pad_template (element_class, &sink_template);
  gst_element_class_add_static_pad_template (element_class, &src_template);

  element_class->change_state = GST_DEBUG_FUNCPTR (gst_birds_eye_change_state);
  trans_class->transform_caps =
      GST_DEBUG_FUNCPTR (gst_birds_eye_transform_caps);
  filter_class->set_info = GST_DEBUG_FUNCPTR (gst_birds_eye_set_info);
  filter_class->transform_frame =
      GST_DEBUG_FUNCPTR (gst_birds_eye_transform_frame);
}
