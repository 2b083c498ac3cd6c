#include "frameformat.h"

gboolean
landmark_frame_format (const GstVideoInfo * info, LandmarkFrameFormat * out)
{
  LandmarkFrameFormat f;
  const GstVideoFormatInfo *finfo = info->finfo;
  switch (GST_VIDEO_INFO_FORMAT (info)) {
    case GST_VIDEO_FORMAT_RGB:
    case GST_VIDEO_FORMAT_BGR:
    case GST_VIDEO_FORMAT_RGBx:
    case GST_VIDEO_FORMAT_BGRx:
    case GST_VIDEO_FORMAT_xRGB:
    case GST_VIDEO_FORMAT_xBGR:
    case GST_VIDEO_FORMAT_RGBA:
    case GST_VIDEO_FORMAT_BGRA:
      f.kind = LandmarkFrameFormat::Kind::PACKED;
      f.pixel_stride = GST_VIDEO_FORMAT_INFO_PSTRIDE (finfo, 0);
      for (int c = 0; c < 3; c++)
        f.offset[c] = GST_VIDEO_FORMAT_INFO_POFFSET (finfo, c);
      f.model = landmark::InputModel::rgb ();
      break;
    case GST_VIDEO_FORMAT_I420:
    case GST_VIDEO_FORMAT_NV12:
    case GST_VIDEO_FORMAT_YUY2:{
      const GstVideoFormat fmt = GST_VIDEO_INFO_FORMAT (info);
      f.kind = fmt == GST_VIDEO_FORMAT_I420 ? LandmarkFrameFormat::Kind::I420 :
          fmt == GST_VIDEO_FORMAT_NV12 ? LandmarkFrameFormat::Kind::NV12 :
          LandmarkFrameFormat::Kind::YUY2;
      gdouble kr = 0.299, kb = 0.114;
      if (!gst_video_color_matrix_get_Kr_Kb (info->colorimetry.matrix, &kr,
              &kb)) {
        kr = 0.299;
        kb = 0.114;
      }
      f.model = landmark::InputModel::yuv (kr, kb,
          info->colorimetry.range == GST_VIDEO_COLOR_RANGE_0_255);
      break;
    }
    default:
      GST_ERROR ("unsupported format %s", GST_VIDEO_INFO_NAME (info));
      return FALSE;
  }
  *out = f;
  return TRUE;
}

void
landmark_set_pixel_element_class (GstElementClass * klass,
    const char *longname, const char *classification, const char *description)
{
  GstCaps *caps =
      gst_caps_from_string (GST_VIDEO_CAPS_MAKE (LANDMARK_VIDEO_FORMATS));
  gst_element_class_set_static_metadata (klass, longname, classification,
      description, "gst-landmark developers");
  gst_element_class_add_pad_template (klass,
      gst_pad_template_new ("sink", GST_PAD_SINK, GST_PAD_ALWAYS, caps));
  gst_element_class_add_pad_template (klass,
      gst_pad_template_new ("src", GST_PAD_SRC, GST_PAD_ALWAYS, caps));
  gst_caps_unref (caps);
}
