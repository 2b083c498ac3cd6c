/* labsegment's passes over a labelled frame (labsegmentpixels.h): the
 * dominant-colour rule, the class colour sums drift is estimated from, and
 * the false-colour view. */
#include "labsegmentpixels.h"
#include "labsegmentreader.h"

#include <algorithm>
#include <cmath>

namespace landmark {

namespace {

/* Rows y0..y1-1 of draw_false_colour; y0 is even, so the rows of 2x2
 * subsampled chroma it writes are its own. */
void
draw_rows (GstVideoFrame * f, const FrameLayout & layout,
    const guint8 * labels, const std::vector<std::array<uint8_t, 3>> & display,
    const std::array<uint8_t, 3> & black, guint y0, guint y1)
{
  const guint width = GST_VIDEO_FRAME_WIDTH (f);
  /* label 0 is black */
  const uint8_t *none = black.data ();
  auto colour = [&](guint8 l) -> const uint8_t * {
    return l == 0 ? none : display[l - 1].data ();
  };
  for (guint y = y0; y < y1; y++) {
    const guint8 *lab = labels + (gsize) y * width;
    guint8 *r0 = (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 0) +
        (gsize) y * GST_VIDEO_FRAME_PLANE_STRIDE (f, 0);
    switch (layout.layout) {
      case PixelLayout::PACKED3:
      case PixelLayout::PACKED4:{
        const int ps = layout.layout == PixelLayout::PACKED3 ? 3 : 4;
        for (guint x = 0; x < width; x++) {
          const uint8_t *c = colour (lab[x]);
          guint8 *p = r0 + x * ps;
          p[layout.offset[0]] = c[0];
          p[layout.offset[1]] = c[1];
          p[layout.offset[2]] = c[2];
        }
        break;
      }
      case PixelLayout::YUV420:{
        for (guint x = 0; x < width; x++) {
          r0[x] = colour (lab[x])[0];
        }
        if (y % 2)
          break;
        const bool nv12 = GST_VIDEO_FRAME_FORMAT (f) == GST_VIDEO_FORMAT_NV12;
        guint8 *u = (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f, 1) +
            (gsize) (y / 2) * GST_VIDEO_FRAME_PLANE_STRIDE (f, 1);
        guint8 *v = nv12 ? u + 1 : (guint8 *) GST_VIDEO_FRAME_PLANE_DATA (f,
            2) + (gsize) (y / 2) * GST_VIDEO_FRAME_PLANE_STRIDE (f, 2);
        const int ps = nv12 ? 2 : 1;
        for (guint x = 0; x < width; x += 2) {
          const uint8_t *c = colour (lab[x]);
          u[(x / 2) * ps] = c[1];
          v[(x / 2) * ps] = c[2];
        }
        break;
      }
      case PixelLayout::YUY2:{
        for (guint x = 0; x < width; x++) {
          const uint8_t *c = colour (lab[x]);
          guint8 *p = r0 + (x >> 1) * 4;
          p[(x & 1) * 2] = c[0];
          if ((x & 1) == 0) {
            p[1] = c[1];
            p[3] = c[2];
          }
        }
        break;
      }
    }
  }
}

}  // namespace

void
draw_false_colour (GstVideoFrame * f, const FrameLayout & layout,
    const guint8 * labels, const std::vector<std::array<uint8_t, 3>> & display,
    const std::array<uint8_t, 3> & black, WorkerPool & pool)
{
  auto slice = [&](unsigned, guint y0, guint y1) {
    draw_rows (f, layout, labels, display, black, y0, y1);
  };
  pool.run_slices (GST_VIDEO_FRAME_HEIGHT (f), slice);
}

void
dominant_colour_rule (ClassTable & table, const GstVideoFrame * frame,
    const FrameLayout & layout, guint n, guint min_class_pixels,
    bool to_nearest, const guint32 counts[256], guint8 * labels,
    ClassRule * rule, WorkerPool & pool)
{
  const guint w = GST_VIDEO_FRAME_WIDTH (frame);
  const guint h = GST_VIDEO_FRAME_HEIGHT (frame);
  guint8 demoted[kMaxClasses + 1] = { 0 };
  bool any_demoted = false;
  *rule = ClassRule ();
  for (guint k = 0; k < n; k++) {
    rule->active[k] = min_class_pixels == 0 ||
        counts[k + 1] >= min_class_pixels;
    rule->any_active |= rule->active[k] != 0;
    demoted[k + 1] = !rule->active[k] && counts[k + 1] > 0;
    any_demoted |= demoted[k + 1] != 0;
    rule->final_counts[k + 1] = rule->active[k] ? counts[k + 1] : 0;
  }
  if (!any_demoted)
    return;

  /* pixels of classes too rare to count go to the nearest active class,
   * converted in batches like the table's boundary cells, or lose their
   * label */
  if (!to_nearest || !rule->any_active) {
    auto slice = [&](unsigned, guint y0, guint y1) {
      const gsize end = (gsize) y1 * w;
      for (gsize i = (gsize) y0 * w; i < end; i++)
        if (demoted[labels[i]])
          labels[i] = 0;
    };
    pool.run_slices (h, slice);
    return;
  }
  /* the direct computation uses the table's scratch: one thread */
  PixelReader reader { frame, layout };
  guint8 comps[3 * ClassTable::kBatch];
  guint8 *where[ClassTable::kBatch];
  guint8 relabel[ClassTable::kBatch];
  int pending = 0;
  auto flush = [&]() {
    if (pending == 0)
      return;
    table.classify_exact (comps, pending, rule->active, relabel);
    for (int i = 0; i < pending; i++) {
      *where[i] = relabel[i];
      rule->final_counts[relabel[i]]++;
    }
    pending = 0;
  };
  for (guint y = 0; y < h; y++) {
    guint8 *row = labels + (gsize) y * w;
    bool row_set = false;
    for (guint x = 0; x < w; x++) {
      if (!demoted[row[x]])
        continue;
      if (!row_set) {
        reader.set_row (y);
        row_set = true;
      }
      reader.get (x, comps + 3 * pending);
      where[pending++] = row + x;
      if (pending == ClassTable::kBatch)
        flush ();
    }
  }
  flush ();
}

void
class_colour_sums (const GstVideoFrame * frame, const FrameLayout & layout,
    const InputModel & model, const guint8 * labels, guint n,
    ClassColourSums * out)
{
  /* sRGB to linear light by table: 4096 steps are finer than any 8-bit
   * input's */
  static const std::array<float, 4097> linear = [] {
    std::array<float, 4097> t {};
    for (int i = 0; i <= 4096; i++)
      t[i] = (float) srgb_to_linear (i / 4096.0);
    return t;
  }();
  /* a component this close to full scale may be clipped: its gain is
   * unknown */
  constexpr double kClipped = 250.0 / 255.0;
  const guint w = GST_VIDEO_FRAME_WIDTH (frame);
  const guint h = GST_VIDEO_FRAME_HEIGHT (frame);
  out->reset (n);
  const guint step = std::max (8u, (guint) std::sqrt ((double) w * h /
          5000.0));
  PixelReader reader { frame, layout };
  for (guint y = step / 2; y < h; y += step) {
    reader.set_row (y);
    const guint8 *row = labels + (gsize) y * w;
    for (guint x = step / 2; x < w; x += step) {
      const guint label = row[x];
      if (label == 0 || label > n)
        continue;
      guint8 c[3] = { 0, 0, 0 };
      reader.get (x, c);
      double rgb[3];
      model.to_srgb (c[0], c[1], c[2], rgb);
      if (rgb[0] >= kClipped || rgb[1] >= kClipped || rgb[2] >= kClipped)
        continue;
      auto & sum = out->sum[label - 1];
      for (int k = 0; k < 3; k++)
        sum[k] += linear[(int) (std::clamp (rgb[k], 0.0, 1.0) * 4096 + 0.5)];
      out->count[label - 1]++;
    }
  }
}

}  // namespace landmark
