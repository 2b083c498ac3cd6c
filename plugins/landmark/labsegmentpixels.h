/* labsegment's passes over the pixels of a mapped frame: labelling through
 * the class table, the class histogram, the dominant-colour rule and the
 * false-colour view. Kept apart from the element so that gstlabsegment.cpp
 * holds only the element (properties, states, caps, metadata). The
 * labelling and its histogram are in labsegmentpixels.cpp, the passes over
 * the labels in labsegmentrule.cpp. */
#pragma once

#include <gst/video/video.h>

#include <array>
#include <cstdint>
#include <vector>

#include "classtable.h"
#include "colourdrift.h"
#include "frameformat.h"
#include "simdlevel.h"
#include "workerpool.h"

namespace landmark {

/* How the three components of a pixel are laid out in a frame. */
enum class PixelLayout { PACKED3, PACKED4, YUV420, YUY2 };

struct FrameLayout {
  PixelLayout layout = PixelLayout::PACKED4;
  int offset[3] = { 0, 1, 2 };  /* R,G,B byte offsets for packed RGB */
  int key_shift = 0;            /* bits to drop from a 4-byte pixel */
  KeyOrder order = KeyOrder::C0_LOW;
  SimdLevel simd = SimdLevel::NONE;   /* simd_level () */
  bool packed4_gathers = false;       /* packed4_gathers () */
};

/* The layout of a negotiated format, and the byte order of its table keys. */
FrameLayout frame_layout (const LandmarkFrameFormat & format);

/* The threads a frame's passes run on (horizontal slices, results identical
 * to one thread), and each slice's class histogram, kept here so that a
 * frame allocates nothing. */
struct PixelWorkers {
  WorkerPool pool;
  std::vector<std::array<guint32, 256>> slice_counts;

  /* Starts or stops workers only when the number changes. */
  void set_threads (unsigned threads) {
    pool.resize (threads);
    slice_counts.resize (pool.slices ());
  }
};

/* Pass 1: labels[] (width x height, tightly packed) = the nearest class of
 * each pixel over the whole palette of n classes, and counts[v] = pixels
 * with label v (v in 0..n). The table lookups and the histogram run in
 * slices on workers; colours of boundary cells not met before are then
 * computed on the calling thread (the table fills them). */
void label_frame (ClassTable & table, const GstVideoFrame * frame,
    const FrameLayout & layout, guint n, guint8 * labels,
    guint32 counts[256], PixelWorkers & workers);

/* What the dominant-colour rule decided for a frame. */
struct ClassRule {
  /* active[k]: class k (label k + 1) takes part in the final labelling */
  guint8 active[kMaxClasses] = { 0 };
  /* final_counts[v]: pixels with label v after the rule (v in 1..n) */
  guint32 final_counts[kMaxClasses + 1] = { 0 };
  bool any_active = false;
};

/* Pass 2, the dominant-colour rule: only classes with at least
 * min_class_pixels pixels in counts (0: every class) keep their pixels;
 * the others' pixels go to the nearest active class when to_nearest (and
 * some class is active), else to label 0. */
void dominant_colour_rule (ClassTable & table,
    const GstVideoFrame * frame, const FrameLayout & layout, guint n,
    guint min_class_pixels, bool to_nearest, const guint32 counts[256],
    guint8 * labels, ClassRule * rule, WorkerPool & pool);

/* The linear RGB of about 5,000 pixels spread over the frame (every
 * step-th row and column, step at least 8: enough for a class mean), summed per final label (label
 * k + 1 into class k; label 0 and pixels with a clipped component left
 * out): what labsegment adapt=true estimates the camera's drift from. */
void class_colour_sums (const GstVideoFrame * frame,
    const FrameLayout & layout, const InputModel & model,
    const guint8 * labels, guint n, ClassColourSums * out);

/* Writes each pixel's class colour into the frame (output=labels): display
 * holds a colour per class in the frame's own components, black is label
 * 0's. */
void draw_false_colour (GstVideoFrame * frame, const FrameLayout & layout,
    const guint8 * labels, const std::vector<std::array<uint8_t, 3>> & display,
    const std::array<uint8_t, 3> & black, WorkerPool & pool);

}  // namespace landmark
