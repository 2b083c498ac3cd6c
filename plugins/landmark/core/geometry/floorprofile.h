/* The free floor in front of the robot (docs/floorboundary.md): per image
 * column, walking up from the bottom row of a label plane, where the floor
 * ends; that point mapped to the floor through a CameraGeometry; and the
 * Radial Obstacle Profile (ROP): the free range per bearing bin. Also the
 * bird's-eye remap table. No GStreamer types. */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "camerageometry.h"
#include "camerasetup.h"
#include "markerevidence.h"

namespace landmark {

/* ---- floor boundary and ROP ------------------------------------------- */

/* What a label is for the walk. */
enum class LabelRole : uint8_t {
  Obstacle = 0,   /* not floor: a run of min-obstacle-rows ends the floor */
  Floor = 1,
  Marker = 2,     /* a landmark colour: walked over as floor, recorded */
};

/* What is known along one column or one bearing bin. */
enum class FreeState : uint8_t {
  NotSeen = 0,    /* out of view, or no floor at the bottom row */
  Free = 1,       /* free floor up to max-range */
  Obstacle = 2,   /* free up to range, where something stands */
  ViewEdge = 3,   /* free up to range, where the image ends (top border) */
};

const char *free_state_name (FreeState s);

struct FloorProfileParams {
  int min_obstacle_rows = 6;   /* non-floor run that ends the floor,
                                * 1..255 rows */
  int bearing_bins = 360;      /* over the full circle, bin 0 ahead */
  double max_range = 4.0;      /* metres */
  /* a run of walked-over marker pixels longer than this on the floor
   * (metres) stands up, a ball: it ends the floor at its bulge (from the
   * run's two ends), or at its foot when its top is not seen; 0: off */
  double max_marker_length = 0;
};

struct ColumnBoundary {
  FreeState state = FreeState::NotSeen;
  float row = -1;              /* image row of the boundary (pixel edge) */
  float x = 0, y = 0;          /* its floor point, robot frame, metres */
  float range = 0;             /* metres; max-range when Free */
  float marker_range = -1;     /* nearest marker pixel below it, -1: none */
};

struct RopBin {
  FreeState state = FreeState::NotSeen;
  float range = 0;             /* free range, metres (0 when NotSeen) */
  float marker_range = -1;     /* nearest marker floor point, -1: none */
};

/* A landmark ball a ranging stage found: its centre's floor point (robot
 * frame) and its radius, metres. */
struct RangedBall {
  double x = 0, y = 0, radius = 0;
};

/* A box of the label plane, [u0, u1) x [v0, v1) pixels. */
struct MarkerBox {
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
};

/* Per-column floor points of every pixel edge are tabulated once per
 * geometry (configure), so a frame costs one pass over the rows walked. */
class FloorProfile {
public:
  /* False with *error when the camera sees no floor at the bottom of any
   * column or the parameters are out of range. */
  bool configure (const CameraGeometry & geometry,
      const FloorProfileParams & params, std::string * error);
  bool configured () const { return width_ > 0; }
  int width () const { return width_; }
  int height () const { return height_; }
  const FloorProfileParams & params () const { return params_; }

  /* Walks every column of a width x height label plane (stride bytes per
   * row); role maps each label to its role. With marker_boxes, Marker
   * pixels are walked over only inside those boxes (the accepted
   * landmarks) and are obstacles elsewhere. Then builds the ROP. */
  void scan (const uint8_t * labels, size_t stride,
      const LabelRole role[256],
      const std::vector<MarkerBox> *marker_boxes = nullptr);

  /* Image ellipses (label plane pixels) of accepted landmark discs, for
   * the scans that follow: every pixel within kDiscRimPixels of one is
   * floor for the walk, so a disc's rim, blended with the floor into a
   * colour of neither, does not end it (at an ellipse's left and right
   * tips the rim runs down a column for several rows). */
  void set_landmark_discs (const std::vector<ImageEllipse> & discs);
  static constexpr double kDiscRimPixels = 1.5;

  /* After scan: each seen bin whose wedge meets a ball's circle ends at
   * the circle's nearest point in the wedge (where the robot would touch
   * it) when that is nearer than what the walk found. The image shows a
   * ball's foot, up to its radius behind its bulge; a ball ranged from its
   * blob with its known diameter puts the bulge where it is. */
  void stand_balls (const std::vector<RangedBall> & balls);

  const std::vector<ColumnBoundary> & columns () const { return cols_; }
  const std::vector<RopBin> & bins () const { return bins_; }

  /* Bin of a bearing (radians, left positive): bin k covers
   * [(k - 1/2) d, (k + 1/2) d) with d = 2 pi / bearing_bins. */
  int bin_of (double bearing) const;
  double bin_bearing (int k) const;

  /* Floor point of the edge between rows `edge - 1` and `edge` of column
   * u (edge 0: the top of row 0; edge = height: the bottom of the last
   * row), at the column's centre; false: no floor (above the horizon). */
  bool edge_point (int u, int edge, float *x, float *y) const;

private:
  void build_rop ();
  void ball_bulge (const uint8_t * labels, size_t stride,
      const LabelRole role[256], int u, int foot_edge, bool shaded,
      ColumnBoundary * c);

  FloorProfileParams params_;
  int width_ = 0, height_ = 0;
  double camera_height_ = 0;
  /* (height + 1) x width: x, y of each pixel edge, NaN above the horizon */
  std::vector<float> edge_x_, edge_y_;
  std::vector<float> edge_down_;  /* the edge's ray below the horizontal */
  /* per column, walking the edges up from the bottom: the first whose
   * floor point lies beyond max-range, else the topmost with a floor
   * point (0, or the last below the horizon); -1: no floor at the
   * bottom */
  std::vector<int16_t> stop_edge_;
  std::vector<ColumnBoundary> cols_;
  /* scan's per-column walk state, reused between frames */
  std::vector<int> marker_edge_, end_edge_;
  std::vector<int> marker_run_edge_, marker_last_row_;
  std::vector<uint8_t> ball_;   /* the ball rule ended the column */
  /* the discs' grown ellipses as quadratic forms of (u - cx, v - cy):
   * a du^2 + 2 b du dv + c dv^2 <= 1 inside */
  struct DiscSpan {
    double cx, cy, a, b, c;
  };
  std::vector<DiscSpan> discs_;
  std::vector<uint8_t> run_, obst_, beyond_, walking_;   /* 16-padded */
  /* columns sorted by stop edge: those of edge e are
   * by_stop_[by_stop_start_[e] .. by_stop_start_[e + 1]) */
  std::vector<int> by_stop_start_, by_stop_;
  std::vector<FreeState> state_;
  std::vector<RopBin> bins_;
};

/* ---- bird's-eye view -------------------------------------------------- */

/* The floor seen from above: an out_w x out_h image at pixels_per_metre,
 * robot forward up, left to the left, the camera's floor point at output
 * pixel (origin_u, origin_v). map_x, map_y (CV_32F layouts, row-major)
 * give for each output pixel the source pixel for cv::remap (-10: not on
 * the image, or no floor there). */
struct BirdsEyeParams {
  int out_w = 400, out_h = 400;
  double pixels_per_metre = 100;
  double origin_u = 199.5, origin_v = 399.5;
};

bool birdseye_maps (const CameraGeometry & geometry,
    const BirdsEyeParams & params, std::vector<float> *map_x,
    std::vector<float> *map_y, std::string * error);

}  // namespace landmark
