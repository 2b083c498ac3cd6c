/* Drawing for landmarkoverlay, without GStreamer types.
 *
 * The overlay is drawn into a frame-sized canvas of premultiplied RGBA
 * (channel order R, G, B, A), and everything drawn there is premultiplied
 * "over" compositing. Shapes (segments with round ends, polylines, dashed
 * lines, discs, rings, convex polygons) are rasterised here with
 * anti-aliasing from the distance of each pixel centre to the shape, into
 * a coverage mask that is then blended in one colour, so overlapping
 * strokes of one shape never double-blend. Text uses OpenCV's Hershey
 * font, rendered once per size into per-character coverage masks. Nothing
 * is allocated per frame once the canvas exists.
 *
 * Every primitive marks the canvas area it touches; at the end of a frame
 * the union of those areas (aligned to 2x2 blocks) is blended into the
 * video frame in its own format (packed RGB, I420, NV12, YUY2) and cleared
 * again, so the canvas is all zero between frames and the cost follows the
 * drawn area, not the frame size.
 *
 * The Renderer's code is split by concern: primitives and text in
 * overlaydraw.cpp, the parts of the overlay in overlayparts.cpp, blending
 * into the frame in overlaycomposite.cpp. */
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "labcolour.h"

#include "landmarkmap.h"

namespace landmark {
namespace overlay {

struct Rgb {
  uint8_t r = 255, g = 255, b = 255;
};

/* the map drawn in the mini-map (landmarkmap.h) */
using landmark::LandmarkMap;
using landmark::MapLandmark;

/* ---- what is drawn --------------------------------------------------- */

/* One detection, read from its region-of-interest meta. Pointers are
 * borrowed for the frame. */
struct Detection {
  const char *class_name = nullptr;
  Rgb colour;
  double x = 0, y = 0, w = 0, h = 0;  /* bbox, current frame pixels */
  /* landmark-blob, in the analysed frame's pixels; sx, sy scale them to
   * the current frame */
  double sx = 1, sy = 1;
  bool has_ellipse = false;
  double ellipse_x = 0, ellipse_y = 0, ellipse_major = 0, ellipse_minor = 0,
      ellipse_angle = 0;
  bool has_centroid = false;
  double centroid_x = 0, centroid_y = 0;
  bool has_roundness = false;
  double roundness = 0;
  /* a coded marker (landmark-blob `code`): its ellipse fields are the box
   * of its bands along the axis, drawn as that box */
  bool coded = false;
  bool kept = true;
  const char *reject_reason = nullptr;
  /* landmark-range */
  bool has_range = false;
  double range = 0;
  bool has_bearing = false;
  double bearing = 0;
  bool no_floor = false;
  /* landmark-range: the floor position (robot frame, metres), and the
   * marker's diameter and centre height when the map gave them (0: not) */
  bool has_ground = false;
  double ground_x = 0, ground_y = 0;
  double marker_diameter = 0, marker_height = 0;
  /* landmark-match */
  bool has_match = false;
  bool matched = false;
  const char *landmark_id = nullptr;
};

struct Pose {
  double x = 0, y = 0, heading = 0;  /* metres, radians */
};

/* The text of the pose line: "pose x 1.250 m  y -3.500 m  heading 114.6
 * deg", or the compact form for narrow frames, "1.25 -3.50 115d". */
void pose_line_text (const Pose & pose, bool compact, char *out,
    size_t size);

/* The free floor of a GstLandmarkFloorMeta (docs/floorboundary.md).
 * Pointers are borrowed for the frame; states are LandmarkFloorState
 * codes (0 not seen, 1 free, 2 obstacle, 3 view edge). */
struct Floor {
  /* per column of the analysed label plane (width x height) */
  int width = 0, height = 0;
  const float *boundary_row = nullptr;   /* pixel edge, -1: not seen */
  const uint8_t *boundary_state = nullptr;
  /* per bearing bin: bin k is centred on k * bin_width, to the left */
  int bins = 0;
  double bin_width = 0;
  const float *rop_range = nullptr;      /* metres */
  const uint8_t *rop_state = nullptr;
  /* per column: the boundary's floor point, robot frame, metres (may be
   * null) */
  const float *boundary_x = nullptr, *boundary_y = nullptr;
};

/* The scale of the bird's-eye view (birdseye, docs/birdseye.md): a
 * robot-frame point (x forward, y left, metres) is drawn at output pixel
 * (origin_u - y ppm, origin_v - x ppm), pixel centres on integers, where
 * (origin_u, origin_v) is the camera's floor point. */
struct FloorView {
  double pixels_per_metre = 100;
  double origin_u = 0, origin_v = 0;

  cv::Point2d to_px (double x, double y) const {
    return cv::Point2d (origin_u - y * pixels_per_metre,
        origin_v - x * pixels_per_metre);
  }
};

/* landmarkslam's estimate (GstLandmarkMapMeta, docs/landmarkslam.md):
 * one landmark, strings borrowed for the frame. */
struct EstimatedLandmark {
  const char *id = nullptr;
  Rgb colour;
  double x = 0, y = 0;        /* metres, map frame */
  double cov[4] = { 0, 0, 0, 0 };  /* 2x2, row-major over x, y */
  bool confirmed = false;
};

/* What the mini-map draws of the estimate: its landmarks, and the pose's
 * x, y covariance when the pose meta has one. */
struct Estimate {
  const EstimatedLandmark *landmarks = nullptr;
  int n = 0;
  bool has_pose_cov = false;
  double pose_cov[4] = { 0, 0, 0, 0 };
};

/* chi-square with 2 degrees of freedom at 95 %: a 2-D Gaussian's 95 %
 * region is the ellipse e^T P^-1 e <= this */
inline constexpr double kChi2Dof2P95 = 5.991;

/* The semi-axes (metres) of the ellipse e^T P^-1 e <= chi2 of a 2x2
 * covariance P (row-major), and the angle of the major axis from +x
 * (radians, counter-clockwise): a = sqrt(chi2 l1), b = sqrt(chi2 l2) for
 * the eigenvalues l1 >= l2 of P, along their eigenvectors. ok is false
 * (and nothing else set) for a P that is not finite, not symmetric or has
 * a negative eigenvalue. */
struct EllipseAxes {
  bool ok = false;
  double major = 0, minor = 0, angle = 0;
};
EllipseAxes covariance_ellipse (const double cov[4],
    double chi2 = kChi2Dof2P95);

/* colours of the floor drawings */
inline constexpr Rgb kFloorObstacle { 255, 40, 40 };  /* on an obstacle */
inline constexpr Rgb kFloorOpen { 0, 220, 255 };  /* max-range, top row */
inline constexpr Rgb kFreeSpace { 40, 230, 40 };  /* free-space polygon */

/* One palette class of the labels meta. */
struct ClassInfo {
  const char *name = nullptr;
  Rgb colour;
  unsigned count = 0;
  bool active = false;
  bool marker = true;
};

struct Histogram {
  const ClassInfo *classes = nullptr;
  int n = 0;
  unsigned threshold = 0;   /* min-class-pixels */
  double total = 0;         /* pixels of the analysed frame */
};

/* ---- the frame the canvas is blended into ---------------------------- */

struct Target {
  enum class Kind { PACKED, I420, NV12, YUY2, GRAY };  /* GRAY: 8-bit luma */
  Kind kind = Kind::PACKED;
  int width = 0, height = 0;
  uint8_t *data[3] = { nullptr, nullptr, nullptr };
  int stride[3] = { 0, 0, 0 };
  int pixel_stride = 4;              /* PACKED: 3 or 4 */
  int offset[3] = { 0, 1, 2 };       /* PACKED: bytes of R, G, B */
  InputModel model;                  /* YUV, GRAY: matrix and range */
};

/* ---- the renderer ---------------------------------------------------- */

class Renderer {
public:
  /* Allocates the (zeroed) canvas for frames of this size. */
  void configure (int width, int height);
  int width () const { return width_; }
  int height () const { return height_; }

  /* Sizes of text, lines and insets for this frame; text_scale multiplies
   * the automatic text size. */
  void begin_frame (double text_scale);

  /* Order: detections (outlines; their labels are queued), then the
   * insets, then draw_labels(), which places the labels where they cover
   * the fewest insets and other labels. */
  void draw_detection (const Detection & d);
  void draw_pose_text (const Pose & pose);
  void draw_class_panel (const Histogram & hist, bool histogram,
      bool indicators);
  /* The floor boundary across the image: the boundary row of each column,
   * scaled from the label plane to the frame; red where an obstacle ends
   * the floor, cyan where the floor reaches max-range or the top row. */
  void draw_boundary (const Floor & floor);
  /* colours: one per map landmark. free_space (may be null): the ROP as a
   * polygon around the robot, drawn under the map. Without landmarks the
   * inset still shows the robot and its free space. */
  /* estimate (may be null): landmarkslam's landmarks with their 95 %
   * ellipses, confirmed ones filled, tentative ones as rings with dashed
   * ellipses, and the pose's 95 % ellipse around the robot. */
  void draw_minimap (const LandmarkMap & map, const Rgb * colours,
      const Pose & pose, const Detection * dets, int n_dets,
      const Floor * free_space = nullptr, const Estimate * estimate = nullptr);
  void draw_labels ();

  /* The bird's-eye view: what is drawn in robot-frame metres at the
   * view's scale. The floor meta's boundary points as a line (red on
   * obstacles, cyan where the floor reaches max-range or the image's
   * top), and its free space, the ROP's seen bins at their ranges, as an
   * outline around the robot (red at obstacles); unseen bins are not
   * free. */
  void draw_floor_boundary (const Floor & floor, const FloorView & view);
  /* A ranged landmark as a disc of its diameter (metres; <= 0: a small
   * dot) at its floor position, in its class colour over a dark rim, with
   * its id when matched. */
  void draw_floor_landmark (const Detection & d, double diameter,
      const FloorView & view);
  /* The robot: the camera's field of view on the floor (dashed runs of
   * output pixels, run_lengths[i] points each), and a triangle from the
   * camera's floor point pointing forward. */
  void draw_floor_robot (const FloorView & view, const cv::Point2d * fov,
      const int *run_lengths, int n_runs);

  /* True when something was drawn since begin_frame(). */
  bool dirty () const { return !rects_.empty (); }

  /* Blends what was drawn into the frame and clears the canvas. */
  void composite (const Target & target);

  /* Clears the canvas without blending (after an error). */
  void discard ();

private:
  struct Style {
    double g = 1;          /* geometry scale: 1 at 640x480 */
    double font = 0.5;     /* OpenCV font scale */
    int text_thick = 1;
    int line = 1;          /* outline thickness */
    int pad = 2;
    int margin = 4;
    int line_height = 12;  /* text line advance */
    int ascent = 9;
  };

  /* a detection's label, waiting for draw_labels() */
  struct Label {
    char lines[2][96];
    int n_lines = 0;
    Rgb accent;
    int alpha = 255;
    bool optional = false;
    double x = 0, y = 0, w = 0, h = 0;  /* the detection's box */
  };

  /* coverage mask of one character, origin at (ox, oy) on its baseline */
  struct Glyph {
    cv::Mat mask;
    int ox = 0, oy = 0, advance = 0;
  };
  static constexpr char kFirstGlyph = ' ', kLastGlyph = '~';

  void build_glyphs ();
  const Glyph *glyph (char c) const;
  void set_clip (const cv::Rect & r);
  void reset_clip ();
  void mark (int x0, int y0, int x1, int y1);
  /* anti-aliased coverage into cover_, then paint() blends it */
  void cover_row (int y, int x0, int x1);
  template <typename Coverage>
  void cover_span (int y, int x0, int x1, Coverage coverage);
  void cover_segment (cv::Point2d a, cv::Point2d b, double half_width);
  void cover_disc (cv::Point2d c, double r, double inner);
  void cover_convex (const cv::Point2d * p, int n);
  /* any simple or self-touching polygon (OpenCV's scanline fill) */
  void cover_polygon (const cv::Point2d * p, int n);
  void paint (Rgb c, int alpha);
  int text_width (const char *s) const;
  void text (const char *s, int x, int baseline, Rgb c, int alpha);
  void fill_rect (int x0, int y0, int x1, int y1, Rgb c, int alpha);
  void line (cv::Point2d a, cv::Point2d b, Rgb c, int alpha, int thick);
  void polyline (const cv::Point2d * pts, int n, bool closed, Rgb c,
      int alpha, int thick, bool dashed);
  void circle (cv::Point2d centre, double radius, Rgb c, int alpha,
      int thick);
  void fill_circle (cv::Point2d centre, double radius, Rgb c, int alpha);
  void fill_poly (const cv::Point2d * pts, int n, Rgb c, int alpha);
  cv::Size label_size (const Label & l) const;
  /* the boundary's runs of seen columns, at their image rows (view null)
   * or at their floor points */
  void boundary_runs (const Floor & f, const FloorView * view);
  /* appends p to pts_, or moves the last point there while it is within
   * min_step of the one before (dense points cost strokes, not detail) */
  void push_point (cv::Point2d p, double min_step);

  int width_ = 0, height_ = 0;
  cv::Mat canvas_;
  cv::Mat cover_;                    /* coverage of the shape being drawn */
  std::vector<int> row_x0_, row_x1_; /* its extent per row */
  int cover_y0_ = 0, cover_y1_ = 0;
  cv::Rect clip_;
  Style st_;
  std::vector<cv::Rect> rects_;      /* drawn areas, to blend and clear */
  std::vector<std::pair<int, int>> spans_;  /* scratch of composite() */
  std::vector<cv::Rect> reserved_;   /* insets and placed labels */
  std::vector<Label> labels_;
  std::vector<cv::Point2d> pts_;     /* scratch polygon */
  std::vector<cv::Point2d> free_pts_;  /* free-space corners, map frame */
  std::vector<cv::Point> poly_;      /* scratch of cover_polygon() */
  mutable std::string str_;          /* scratch for OpenCV's text API */
  Glyph glyphs_[kLastGlyph - kFirstGlyph + 1];
  double glyph_font_ = -1;
  int glyph_thick_ = -1;
};

}  // namespace overlay
}  // namespace landmark
