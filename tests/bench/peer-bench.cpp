/* The hand-written OpenCV program the chain is measured against
 * (`gst-landmark bench chain`, docs/performance.md "Against a hand-written
 * OpenCV program"): what an expert writes without our elements. A 6-bit
 * colour lookup table (64^3 cells, each the palette class nearest in
 * L*a*b* to the cell's centre colour, built once), then per frame the
 * table lookup into a preallocated label image and a mask of every
 * marker class's pixels (one pass), one cv::findContours over the mask,
 * each contour's class read at its first point, cv::fitEllipse on the
 * contours of at least 30 pixels that are round enough, and the ellipse
 * centre's ray to the floor (pinhole, no distortion). No pose solve: that
 * part of the chain (trilaterate) is left out of the peer, in its favour.
 *
 * Reads the raw BGRx frames chain-bench reads; prints one JSON line with
 * the median and p90 milliseconds per frame and what it found (the
 * detections, those ranged, their median range). */
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "benchtiming.h"
#include "palette.h"

namespace {

struct Options {
  std::string input, palette;
  int width = 0, height = 0, frames = 1000, warmup = 20;
  double camera_height = 0.5, tilt_deg = 20, hfov_deg = 80;
  double min_area = 30, min_roundness = 0.7;
};

bool
parse (int argc, char **argv, Options * o)
{
  for (int i = 1; i < argc; i += 2) {
    if (i + 1 >= argc) {
      std::fprintf (stderr, "peer-bench: %s needs a value\n", argv[i]);
      return false;
    }
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--input") o->input = v;
    else if (k == "--palette") o->palette = v;
    else if (k == "--width") o->width = std::atoi (v.c_str ());
    else if (k == "--height") o->height = std::atoi (v.c_str ());
    else if (k == "--frames") o->frames = std::atoi (v.c_str ());
    else if (k == "--warmup") o->warmup = std::atoi (v.c_str ());
    else if (k == "--camera-height") o->camera_height = std::atof (v.c_str ());
    else if (k == "--tilt") o->tilt_deg = std::atof (v.c_str ());
    else if (k == "--hfov") o->hfov_deg = std::atof (v.c_str ());
    else {
      std::fprintf (stderr, "peer-bench: unknown option %s\n", k.c_str ());
      return false;
    }
  }
  if (o->input.empty () || o->palette.empty () || o->width <= 0
      || o->height <= 0 || o->frames <= 0 || o->warmup < 0) {
    std::fprintf (stderr, "peer-bench: needs --input FILE --palette FILE "
        "--width W --height H [--frames N --warmup N --camera-height M "
        "--tilt DEG --hfov DEG]\n");
    return false;
  }
  return true;
}

/* label (1-based class) of each 6-bit colour cell, 0 for none */
std::vector<uint8_t>
build_table (const landmark::Palette & palette)
{
  std::vector<landmark::Lab> refs;
  std::vector<int> ref_class;
  landmark::palette_references (palette, &refs, &ref_class);
  std::vector<uint8_t> table (64 * 64 * 64);
  for (int b = 0; b < 64; b++)
    for (int g = 0; g < 64; g++)
      for (int r = 0; r < 64; r++) {
        const landmark::Lab lab = landmark::srgb_to_lab ((r * 4 + 2) / 255.0,
            (g * 4 + 2) / 255.0, (b * 4 + 2) / 255.0);
        double best = 1e300;
        int label = 0;
        for (size_t k = 0; k < refs.size (); k++) {
          const double dL = lab.L - refs[k].L, da = lab.a - refs[k].a,
              db = lab.b - refs[k].b;
          const double d = dL * dL + da * da + db * db;
          if (d < best) {
            best = d;
            label = (ref_class.empty () ? (int) k : ref_class[k]) + 1;
          }
        }
        table[(b << 12) | (g << 6) | r] = (uint8_t) label;
      }
  return table;
}

}  // namespace

int
main (int argc, char **argv)
{
  Options o;
  if (!parse (argc, argv, &o))
    return 2;
  landmark::Palette palette;
  std::string error;
  if (!landmark::palette_load_file (o.palette, &palette, &error)) {
    std::fprintf (stderr, "peer-bench: %s\n", error.c_str ());
    return 1;
  }
  std::ifstream in (o.input, std::ios::binary);
  std::vector<uint8_t> raw ((std::istreambuf_iterator<char> (in)),
      std::istreambuf_iterator<char> ());
  const size_t frame_bytes = (size_t) o.width * o.height * 4;
  if (raw.empty () || raw.size () % frame_bytes != 0) {
    std::fprintf (stderr, "peer-bench: %s is not whole %dx%d BGRx frames\n",
        o.input.c_str (), o.width, o.height);
    return 1;
  }
  const int distinct = (int) (raw.size () / frame_bytes);
  const std::vector<uint8_t> table = build_table (palette);
  /* 255 for the labels of marker classes: the mask written with the
   * labels */
  uint8_t marker_mask[256] = { 0 };
  for (size_t k = 0; k < palette.classes.size (); k++)
    if (palette.classes[k].role == landmark::PaletteRole::Marker)
      marker_mask[k + 1] = 255;

  const double fx = (o.width / 2.0) / std::tan (o.hfov_deg * M_PI / 360);
  const double cx = (o.width - 1) / 2.0, cy = (o.height - 1) / 2.0;
  const double ct = std::cos (o.tilt_deg * M_PI / 180),
      st = std::sin (o.tilt_deg * M_PI / 180);

  cv::Mat labels (o.height, o.width, CV_8U), mask (o.height, o.width, CV_8U);
  std::vector<std::vector<cv::Point>> contours;
  std::vector<gint64> times;
  std::vector<double> ranges;   /* of the timed frames, reserved */
  ranges.reserve ((size_t) o.frames * 16);
  long detections = 0, ranged = 0;
  for (int f = 0; f < o.warmup + o.frames; f++) {
    const uint8_t *src = raw.data () + (size_t) (f % distinct) * frame_bytes;
    const gint64 t0 = now_ns ();
    for (int y = 0; y < o.height; y++) {
      const uint8_t *p = src + (size_t) y * o.width * 4;
      uint8_t *l = labels.ptr<uint8_t> (y), *m = mask.ptr<uint8_t> (y);
      for (int x = 0; x < o.width; x++, p += 4) {
        l[x] = table[((p[0] >> 2) << 12) | ((p[1] >> 2) << 6) | (p[2] >> 2)];
        m[x] = marker_mask[l[x]];
      }
    }
    long found = 0, on_floor = 0;
    const bool timed = f >= o.warmup;
    cv::findContours (mask, contours, cv::RETR_EXTERNAL,
        cv::CHAIN_APPROX_NONE);
    {
      for (const auto & c : contours) {
        if (c.size () < 5)
          continue;
        /* the detection's class: the label under its outline */
        const uint8_t label = labels.at<uint8_t> (c[0].y, c[0].x);
        if (!marker_mask[label])
          continue;
        const double area = cv::contourArea (c);
        if (area < o.min_area)
          continue;
        const cv::RotatedRect e = cv::fitEllipse (c);
        const double ellipse_area = M_PI / 4 * e.size.width * e.size.height;
        if (!(ellipse_area > 0) || area / ellipse_area < o.min_roundness)
          continue;
        found++;
        /* the centre's ray (camera x right, y down, z forward) tilted down
         * by the tilt; where it meets the floor */
        const double rx = (e.center.x - cx) / fx, ry = (e.center.y - cy) / fx;
        const double forward = ct - ry * st, down = ry * ct + st;
        if (down > 1e-9) {
          const double s = o.camera_height / down;
          const double range = std::hypot (s * forward, s * rx);
          if (std::isfinite (range)) {
            on_floor++;
            if (timed && ranges.size () < ranges.capacity ())
              ranges.push_back (range);
          }
        }
      }
    }
    const gint64 t1 = now_ns ();
    if (timed) {
      times.push_back (t1 - t0);
      detections += found;
      ranged += on_floor;
    }
  }
  std::sort (times.begin (), times.end ());
  const double median = percentile (times.data (), times.size (), 0.5) / 1e6;
  const double p90 = percentile (times.data (), times.size (), 0.9) / 1e6;
  std::sort (ranges.begin (), ranges.end ());
  const double median_range = ranges.empty () ? 0 : ranges[ranges.size () / 2];
  std::printf ("{\"type\": \"peer\", \"median_ms\": %.6f, \"p90_ms\": %.6f, "
      "\"frames\": %d, \"detections\": %ld, \"ranged\": %ld, "
      "\"median_range_m\": %.6f}\n", median, p90, o.frames, detections, ranged,
      median_range);
  return 0;
}
