/* Blob shape measurement on label planes, without GStreamer types.
 *
 * A BlobAnalyzer finds the 8-connected components of selected labels in an
 * 8-bit label plane (each selected label, or "slot", separately), and
 * measures each component: pixel area, a perimeter estimate, roundness
 * 4 pi A / P^2, sub-pixel centroid, bounding box, equivalent diameter, the
 * ellipse with the component's second moments, and how well the component
 * fills that ellipse.
 *
 * Components are kept as horizontal runs: one pass over the plane finds
 * the runs of selected labels (64 labels at a time with AVX2, 16 with
 * SSE2, while no selected label appears), a union-find over runs of
 * consecutive rows joins them, and every moment comes from closed-form
 * sums over runs. Only a component's own bounding box is ever painted
 * (to trace its outline), so the work grows with the marker pixels, not
 * with the frame. Scratch memory is kept
 * between calls: in steady state nothing is allocated (except inside
 * cv::fitEllipseDirect, for blobs touching the frame edge).
 *
 * Perimeter estimator (docs/blobroundness.md). The outer boundary is
 * traced through the centres of the boundary pixels (the same points as
 * cv::findContours with CHAIN_APPROX_NONE). The "line-fit polygon":
 * Douglas-Peucker with a tolerance of 0.15 x the minor semi-axis b
 * (clamped to 0.7..1.5 px) splits the outline into pieces; a least-squares
 * line is fitted to each piece's points and moved outwards by
 * 0.5 max(|n_x|, |n_y|) (where the line through boundary-pixel centres
 * lies, on average, inside the region's edge); consecutive lines are
 * intersected, or bevelled when nearly parallel or meeting far from the
 * piece's end. Its length follows straight edges without the staircase
 * error of chain codes and restores the corners digitisation rounds off.
 * Small blobs look polygonal once digitised, so below b = 11 px the
 * estimate is blended linearly (weight (b - 7) / 4) with the length of the
 * outline smoothed by a 3-point moving average plus pi (the half-pixel
 * offset of a convex outline). Measured: a digitised disc of radius >= 5 px
 * scores >= 0.94, a square of side >= 20 px <= 0.79 at any rotation
 * (tests/core/test_blobshape.cpp prints the table). Degenerate outlines
 * (one pixel thick) use the chain length + 4, exact for axis-aligned
 * rectangles.
 *
 * The runs and components are in blobruns.cpp, the measurement in
 * blobshape.cpp, the perimeter estimator in blobperimeter.cpp. */
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "workerpool.h"

namespace landmark {

/* One horizontal run of a selected label: pixels x0..x1 (inclusive) of row
 * y. slot: the caller's index of the label (1..255). */
struct BlobRun {
  int y, x0, x1;
  int slot;
};

/* Everything measured on one component. Coordinates follow OpenCV's
 * pixel-centre convention: the centre of pixel (u, v) is at (u, v). */
struct BlobShape {
  int slot = 0;
  double area = 0;                /* pixels */
  double perimeter = 0;           /* pixels, the estimator above */
  double roundness = 0;           /* 4 pi area / perimeter^2 */
  double centroid_x = 0, centroid_y = 0;
  int bbox_x = 0, bbox_y = 0, bbox_w = 0, bbox_h = 0;
  double equivalent_diameter = 0; /* sqrt (4 area / pi) */
  /* The ellipse with the blob's area moments: centre = centroid; full
   * axes 4 sqrt (eigenvalues of the covariance of the pixel squares).
   * For a blob touching the frame edge, possibly the outline fit instead
   * (ellipse_from_outline). */
  double ellipse_x = 0, ellipse_y = 0;
  double ellipse_major = 0, ellipse_minor = 0;
  double ellipse_angle = 0;       /* major axis, radians from +u to +v */
  /* Intersection over union of the blob and the pixels whose centres lie
   * in its ellipse (both clipped to the frame): 1 for a digitised
   * ellipse, about 0.83 for a large parallelogram, 0.68 for a triangle. */
  double ellipse_fit = 0;
  bool touches_border = false;    /* the bounding box meets the frame edge */
  /* true: the blob touches the frame edge and the ellipse fitted to its
   * outline away from the edge (cv::fitEllipseDirect) matched it better
   * than its moment ellipse, so the ellipse fields describe that one */
  bool ellipse_from_outline = false;
  bool has_polygon = false;       /* false: one pixel thick, chain + 4 */
};

/* Perimeter of the region bounded by a closed outer contour through
 * boundary-pixel centres (as traced by BlobAnalyzer or cv::findContours
 * with CHAIN_APPROX_NONE), by the line-fit polygon. eps: Douglas-Peucker
 * tolerance in pixels. polygon (optional) receives the polygon. Returns
 * false (and the fallback chain length + 4, exact for axis-aligned
 * rectangles) when the contour has no area to fit a polygon to. */
bool blob_perimeter (const cv::Point * contour, int n, double eps,
    double *perimeter, std::vector<cv::Point2d> *polygon = nullptr);

/* The Douglas-Peucker tolerance used for a blob whose moment ellipse has
 * minor semi-axis b: 0.15 b clamped to [0.7, 1.5] pixels. */
double blob_perimeter_tolerance (double minor_semi_axis);

/* Length of the 8-connected chain through the contour points (closed). */
double blob_chain_length (const cv::Point * contour, int n);

/* Length of the closed contour after a 3-point moving average. */
double blob_smoothed_length (const cv::Point * contour, int n);

/* Weight of the line-fit polygon in the perimeter of a blob with minor
 * semi-axis b (the rest: smoothed length + pi): (b - 7) / 4 in [0, 1]. */
double blob_polygon_weight (double minor_semi_axis);

/* Scratch memory of the line-fit polygon, reused between calls. */
struct BlobLineFit {
  struct Line {
    cv::Point2d p, t;           /* a point and the unit direction */
  };
  std::vector<uint8_t> keep;
  std::vector<std::pair<int, int>> stack;
  std::vector<int> verts;
  std::vector<Line> lines;
};

/* The perimeter BlobAnalyzer::measure gives a traced outline of a blob
 * whose moment ellipse has minor semi-axis b: the line-fit polygon (into
 * polygon) at blob_perimeter_tolerance (b), blended by
 * blob_polygon_weight (b) with the smoothed length + pi. False (the
 * chain length + 4, polygon empty) when the outline has no area. */
bool blob_outline_perimeter (const cv::Point * contour, int n,
    double minor_semi_axis, BlobLineFit & scratch,
    std::vector<cv::Point2d> & polygon, double *perimeter);

class BlobAnalyzer {
public:
  /* Starts a frame of width x height pixels: forgets all runs. */
  void begin (int width, int height);

  /* Adds the runs of every label whose slot_of[label] is non-zero, from a
   * plane of height rows of stride bytes. */
  void add_label_runs (const uint8_t * plane, size_t stride,
      const uint8_t slot_of[256]);

  /* The same runs, found in horizontal slices on the pool's threads and
   * joined in raster order (label() then merges blobs across slice
   * borders as across any two rows). */
  void add_label_runs (const uint8_t * plane, size_t stride,
      const uint8_t slot_of[256], WorkerPool & pool);

  /* Whether add_label_runs may search with AVX2, 64 labels a step (the
   * default when the processor has it); false: 16 at a time (SSE2) or
   * one by one. The runs are the same either way. */
  void set_avx2 (bool on) { avx2_ = on && cpu_has_avx2 (); }
  static bool cpu_has_avx2 ();

  /* Adds the runs of the non-zero pixels of a binary 8-bit mask whose
   * top-left pixel is frame pixel (ox, oy), as the given slot. */
  void add_mask_runs (const cv::Mat & mask, int ox, int oy, int slot);

  /* Drops the runs of one slot (before adding it again from a mask). */
  void remove_slot (int slot);

  /* Bounding box of a slot's runs, empty if it has none. */
  cv::Rect slot_bounds (int slot) const;

  /* Paints the runs of a slot into mask (frame pixel (ox, oy) at the
   * mask's top-left; pixels outside the mask are skipped) as 255. */
  void paint_slot (int slot, cv::Mat & mask, int ox, int oy) const;

  /* Groups the runs into 8-connected components of one slot each. The
   * order is by slot, then by the component's first pixel in raster
   * order. */
  void label ();

  size_t count () const { return comps_.size (); }
  int slot (size_t i) const { return comps_[i].slot; }
  /* Pixel count, available right after label() (cheap filters first). */
  double area (size_t i) const { return comps_[i].n; }

  /* Measures component i. */
  void measure (size_t i, BlobShape * out);

  /* The last outline traced by measure() (boundary-pixel centres). */
  const std::vector<cv::Point> & contour () const { return contour_; }
  const std::vector<cv::Point2d> & polygon () const { return polygon_; }

  int width () const { return width_; }
  int height () const { return height_; }

private:
  struct Component {
    int slot;
    int first, count;           /* into sorted_ */
    double n, sx, sy, sxx, syy, sxy;
    int x0, y0, x1, y1;
  };

  void trace (const Component & c);
  static void find_runs (const uint8_t * plane, size_t stride, int width,
      int y0, int y1, const uint8_t slot_of[256], bool avx2,
      std::vector<BlobRun> & out);
  double ellipse_iou (const Component & c, double cx, double cy, double qxx,
      double qxy, double qyy) const;

  int width_ = 0, height_ = 0;
  bool avx2_ = cpu_has_avx2 ();
  std::vector<BlobRun> runs_;
  std::vector<std::vector<BlobRun>> slice_runs_;
  std::vector<BlobRun> by_slot_;
  std::vector<int> parent_;
  std::vector<int> comp_of_;
  std::vector<int> root_comp_;
  std::vector<int> offsets_;
  std::vector<BlobRun> sorted_;
  std::vector<Component> comps_;
  std::vector<uint8_t> mask_;
  std::vector<cv::Point> contour_;
  std::vector<cv::Point2d> polygon_;
  std::vector<cv::Point2f> edge_points_;
  BlobLineFit fit_;
};

/* Measures every 8-connected component of the non-zero pixels of an 8-bit
 * mask (a convenience for tests and tools; allocates). */
std::vector<BlobShape> blob_measure_mask (const cv::Mat & mask);

}  // namespace landmark
