/* The per-frame half of the element pattern (elementsettings.h): a
 * frame's work run so that an exception becomes an element ERROR, and what
 * the elements that measure labsegment's labels share while streaming. */
#pragma once

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include <exception>

#include "landmarkmeta.h"

namespace landmark {

/* Runs a frame's work; an exception (e.g. from OpenCV) becomes an element
 * ERROR with what failed, instead of unwinding into GStreamer's C. */
template <typename Work>
GstFlowReturn
run_frame (GstElement *element, const char *what, Work work)
{
  try {
    return work ();
  }
  catch (const std::exception &e) {
    GST_ELEMENT_ERROR (element, STREAM, FAILED, ("%s", what),
        ("%s", e.what ()));
    return GST_FLOW_ERROR;
  }
}

/* What an element that measures labsegment's labels keeps of its input:
 * the classes the labels name (the element derives its tables from them
 * and sets classes.valid), the video's size from the caps (0: unknown)
 * and the warnings it gives once a run. */
struct LabelsInput {
  LandmarkLabelClasses classes;
  gint video_width = 0, video_height = 0;
  bool warned_no_meta = false;
  bool warned_bad_plane = false;

  void start ()
  {
    classes.reset ();
    warned_no_meta = warned_bad_plane = false;
  }

  /* any caps are fine: their size only scales boxes to the label plane */
  void set_caps (GstCaps *caps)
  {
    GstVideoInfo info;
    const bool video = gst_video_info_from_caps (&info, caps);
    video_width = video ? GST_VIDEO_INFO_WIDTH (&info) : 0;
    video_height = video ? GST_VIDEO_INFO_HEIGHT (&info) : 0;
  }
};

/* run_frame for an element that draws on a canvas (discard (): forget
 * what was drawn): a frame that failed half drawn leaves nothing on it. */
template <typename Canvas, typename Work>
GstFlowReturn
run_drawing_frame (GstElement *element, const char *what, Canvas &canvas,
    Work work)
{
  const GstFlowReturn ret = run_frame (element, what, work);
  if (ret != GST_FLOW_OK)
    canvas.discard ();
  return ret;
}

/* transform_ip of an element that measures labsegment's labels: its
 * settings brought up to date (sync), then process (self, buf, labels)
 * under run_frame; a buffer without labels passes unmeasured, with one
 * warning. Self's priv->state has a LabelsInput `input`. */
template <typename Self, void (*sync) (Self *),
    GstFlowReturn (*process) (Self *, GstBuffer *, const GstStructure *)>
GstFlowReturn
measure_labels_ip (GstBaseTransform *trans, GstBuffer *buf)
{
  Self *self = (Self *) trans;
  sync (self);
  const GstStructure *labels = landmark_labels_or_warn (GST_ELEMENT (trans),
      buf, &self->priv->state.input.warned_no_meta);
  if (!labels)
    return GST_FLOW_OK;
  return run_frame (GST_ELEMENT (trans),
      "Could not measure the labels of a frame.",
      [&] { return process (self, buf, labels); });
}

}  // namespace landmark
