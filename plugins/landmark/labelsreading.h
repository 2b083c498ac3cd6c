/* What elements that read labsegment's labels share (part of the metadata
 * contract, docs/metadata.md; included by landmarkmeta.h): the labels'
 * classes kept across frames, the label plane mapped for reading, and the
 * warnings for labels that are missing or lack a map's classes. */
#pragma once

#include <gst/gst.h>

#include <string>
#include <utility>
#include <vector>

/* The map classes, given as (class name, landmark id) pairs, that the labels
 * do not list can never be detected. Posts one WARNING on the element that
 * names the map file, those classes with their ids ("purple (L1, L4)") and
 * the classes the labels have; the message ends with `consequence`.
 * Nothing when the labels have them all. */
void landmark_warn_map_classes_missing (GstElement * element,
    const GstStructure * labels, const std::string & map_path,
    const std::vector<std::pair<std::string, std::string>> & map_classes,
    const char *consequence);

/* The labels meta of buf; without one, posts one WARNING (while *warned
 * is false) saying that element needs labsegment upstream. */
const GstStructure *landmark_labels_or_warn (GstElement * element,
    GstBuffer * buf, bool *warned);

/* The classes of the labels meta (names and marker flags, at most 255),
 * kept from frame to frame so that an element rebuilds what it derives
 * from them (label roles, slots) only when they change. */
struct LandmarkLabelClasses
{
  std::vector < std::string > names;
  std::vector < bool > markers;
  std::vector < std::string > roles;   /* empty strings: no role given */
  bool valid = false;           /* what the element derived is current */

  /* Reads the labels' classes: true when they differ from the kept ones
   * or valid is false (then valid is cleared until the element sets it). */
  bool changed (const GstStructure * labels);
  void reset ();
  /* The label (index + 1) of every wanted class; an unknown one posts an
   * ERROR naming property and the classes the labels have. */
  bool labels_of (GstElement * element, const char *property,
      const std::vector < std::string > &wanted,
      std::vector < guint > *labels) const;
  /* "red, green, ..." */
  std::string list () const;
};

/* The label plane of a labels meta, mapped for reading while this lives. */
class LandmarkLabelPlane
{
public:
  LandmarkLabelPlane () = default;
  LandmarkLabelPlane (const LandmarkLabelPlane &) = delete;
  LandmarkLabelPlane & operator= (const LandmarkLabelPlane &) = delete;
  ~LandmarkLabelPlane ();
  /* true with the fields set. false when the labels have no usable plane
   * (one WARNING on element while *warned is false: buffers pass
   * unmeasured) or when it cannot be mapped (an ERROR, *failed set). */
  bool read (GstElement * element, const GstStructure * labels,
      bool *warned, bool *failed);
  const guint8 *data = nullptr;
  guint width = 0, height = 0, stride = 0;
private:
  GstBuffer * plane_ = nullptr;
  GstMapInfo map_ = GST_MAP_INFO_INIT;
};
