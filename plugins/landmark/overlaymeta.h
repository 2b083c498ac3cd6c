/* Reading a frame's metadata (docs/metadata.md) into what the overlay's
 * Renderer draws (core/drawing/overlaydraw.h): the class colours of the labels
 * meta, the detections with their parameters and the chain's verdict, the
 * floor meta's arrays. Shared by landmarkoverlay and birdseye. */
#pragma once

#include <gst/gst.h>
#include <gst/video/video.h>

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "overlaydraw.h"
#include "palette.h"

namespace landmark {
namespace overlay {

/* A number field of any numeric type; false when absent or not finite. */
bool meta_number (const GstStructure * s, const char *field, double *out);

/* The classes of a frame's labels meta, and the built-in palette's
 * colours for frames without one. */
struct ClassColours {
  std::array<ClassInfo, landmark::kMaxClasses> classes;
  int n = 0;                    /* classes read from the labels meta */
  std::vector<std::pair<std::string, Rgb>> defaults;

  /* The built-in palette's colours (once). */
  void init_defaults ();
  /* Reads the labels meta's classes (none without it); hist, when given,
   * gets them with the threshold and the analysed size. */
  int read (const GstStructure * labels, Histogram * hist);
  /* The colour of a class: the labels meta's, the built-in palette's, or
   * white. */
  Rgb colour (const char *name) const;
};

/* The detections of buf (region-of-interest metas with their parameter
 * structures) into out, cleared first; width x height is the current
 * frame, to which the blob's pixel quantities scale. `kept` is the chain's
 * verdict (landmark_detection_rejected). Strings are borrowed from buf's
 * metas. Logs each one in category cat on object obj. */
void read_detections (GstBuffer * buf, const ClassColours & colours,
    int width, int height, std::vector<Detection> * out,
    GstDebugCategory * cat, GObject * obj);

/* The arrays of a floor meta, mapped for the frame; unmapped when it goes
 * out of scope. A part whose arrays are missing or short stays null. */
struct FloorArrays {
  Floor floor;
  struct Plane {
    GstBuffer *buf = nullptr;
    GstMapInfo map;
  } planes[6];
  int n = 0;

  FloorArrays () = default;
  FloorArrays (const FloorArrays &) = delete;
  FloorArrays & operator= (const FloorArrays &) = delete;
  ~FloorArrays ();

  const void *get (const GstStructure * s, const char *field, gsize elem,
      gsize want);
};

/* The floor meta s into fa (the boundary's floor points only when
 * with_points). */
void read_floor (const GstStructure * s, FloorArrays * fa,
    bool with_points = false);

}  // namespace overlay
}  // namespace landmark
