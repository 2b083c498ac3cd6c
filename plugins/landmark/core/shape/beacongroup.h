/* Coded markers in a label plane (docs/beacons.md, docs/beacondetect.md),
 * without GStreamer types.
 *
 * A BeaconFinder finds the blobs of the classes the map's coded markers
 * are made of, joins blobs of different classes that touch along the
 * marker's axis (down the image, within max_roll of its vertical, so a
 * rolled camera still stacks them) into chains read top to bottom, and
 * names a chain by the map's code it reads. The shape test replaces the
 * roundness test: every band fills the box along and across the axis
 * (a cylinder's side is a rectangle in the image), the bands are about as
 * wide as each other (a cone's narrow upwards instead, its top band a
 * triangle) and as long as the map's band heights say.
 *
 * A chain that reads part of a code (a band cut by the frame or hidden)
 * is kept as a candidate with every code it may be part of. Scratch
 * memory is kept between frames: in steady state nothing is allocated. */
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "blobshape.h"
#include "landmarkmap.h"

namespace landmark {

/* The finder's tolerances (the element's properties). */
struct BeaconParams {
  double min_band_area = 12;     /* pixels: smaller blobs are noise */
  double max_roll_deg = 20;      /* the axis's angle from image vertical */
  /* a band's area / its box on the axis: 1 for a cylinder seen level,
   * less from above (its edges are arcs), 0.5 for a triangle */
  double min_fill = 0.6;
  double max_width_ratio = 1.6;  /* widest / narrowest band, upright */
  /* a band's length against the map's share of the marker's height
   * (either way): the image foreshortens bands unequally, but not by 2 */
  double max_length_ratio = 2.0;
};

/* One coded marker of the map, its bands as labels of the plane. */
struct BeaconSpec {
  MapLandmark marker;               /* id, code, kind, bands, heights */
  std::vector<int> labels;          /* top first; 0: the labels lack it */
};

/* A band blob measured along the axis of the marker it is part of. */
struct BeaconBand {
  int label = 0;
  int blob = -1;                    /* index in BeaconFinder's blobs */
  double area = 0, cx = 0, cy = 0;
  double length = 0, width = 0;     /* pixels, along and across the axis */
  double fill = 0;                  /* area / (length * width) */
  bool cut = false;                 /* touches the frame edge */
};

struct BeaconDetection {
  std::array<BeaconBand, kMaxMarkerBands> bands;
  int n_bands = 0;
  int marker = -1;                  /* index in the specs when named */
  std::vector<int> candidates;      /* partial view: the specs it may be */
  const char *reject = nullptr;     /* null: named and its shape holds */
  double axis_u = 0, axis_v = 1;    /* unit vector down the axis */
  /* the axis's image at the top of the top band and the bottom of the
   * lowest one (the floor contact's nearest point for a marker standing
   * on the floor) */
  double top_u = 0, top_v = 0, base_u = 0, base_v = 0;
  double height_px = 0, width_px = 0;
  double area = 0, cx = 0, cy = 0;  /* all bands together */
  int bbox_x = 0, bbox_y = 0, bbox_w = 0, bbox_h = 0;
  bool cut_top = false, cut_bottom = false;
};

/* The specs of the map's coded markers, their band classes looked up in
 * the labels' class names (label = index + 1; 0 when missing). */
std::vector<BeaconSpec> beacon_specs (const LandmarkMap & map,
    const std::vector<std::string> & class_names);

class BeaconFinder {
public:
  /* The specs to name; slot_of[label] is set for every band class. */
  void set_specs (const std::vector<BeaconSpec> & specs);
  const std::vector<BeaconSpec> & specs () const { return specs_; }
  const uint8_t *slot_of () const { return slot_of_; }
  bool empty () const { return specs_.empty (); }

  /* Finds the coded markers of a label plane. */
  void find (const uint8_t * plane, size_t stride, int width, int height,
      const BeaconParams & params, WorkerPool & pool);
  /* The same on an 8-bit label image (tests, tools). */
  void find (const cv::Mat & labels, const BeaconParams & params);

  size_t count () const { return n_out_; }
  const BeaconDetection & detection (size_t i) const { return out_[i]; }
  BlobAnalyzer & analyzer () { return analyzer_; }

private:
  struct Blob {
    int label;
    double area, cx, cy;
    int x0, y0, x1, y1;             /* bounding box, inclusive */
    int first, count;               /* outline points in points_ */
    bool cut_top, cut_bottom, cut_side;
  };
  void collect (const BeaconParams & params);
  void extent (const Blob & b, double du, double dv, double *along0,
      double *along1, double *across0, double *across1) const;
  bool pair_score (const Blob & a, const Blob & b,
      const BeaconParams & params, double *score) const;
  void chain (int top, const BeaconParams & params);
  void read (BeaconDetection & d, const int *idx, int n,
      const BeaconParams & params);
  void name (BeaconDetection & d, const BeaconParams & params);
  bool shape_holds (BeaconDetection & d, const BeaconSpec & spec,
      const BeaconParams & params) const;

  std::vector<BeaconSpec> specs_;
  uint8_t slot_of_[256] = { 0 };
  BlobAnalyzer analyzer_;
  BlobShape shape_;
  std::vector<Blob> blobs_;
  std::vector<cv::Point> points_;
  std::vector<int> below_, above_;
  std::vector<double> below_score_;
  std::vector<BeaconDetection> out_;
  size_t n_out_ = 0;
  bool has_cones_ = false;
  int width_ = 0, height_ = 0;
};

}  // namespace landmark
