/* What each class's markers are, for ranging (docs/ipmrange.md "One
 * class, several markers"): the map's z, diameter and kind per class, the
 * properties' marker for classes the map lacks. No GStreamer types. */
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "rangeestimate.h"

namespace landmark {

struct MarkerClasses {
  MarkerSpec default_marker;                     /* the properties' */
  std::map<std::string, MarkerSpec> markers;     /* one spec per class */
  /* classes whose landmarks differ: their distinct specs, one ranging
   * hypothesis each */
  std::map<std::string, std::vector<MarkerSpec>> hypotheses;
  /* (class, id) of every map landmark, checked against the labels */
  std::vector<std::pair<std::string, std::string>> map_classes;

  /* The spec a detection of class cls is ranged with, and its hypotheses
   * (nullptr: one spec). */
  MarkerSpec spec (const char *cls,
      const std::vector<MarkerSpec> **several) const;
};

/* Reads the map at map_path (empty: none) into out, with default_marker
 * for classes it lacks. False with *error naming the file and the
 * landmark when a marker centre is not below camera_height metres. */
bool marker_classes_load (const std::string & map_path,
    const MarkerSpec & default_marker, double camera_height,
    MarkerClasses * out, std::string * error);

}  // namespace landmark
