#include "landmarkmeta.h"

#include <algorithm>

static std::string
landmark_labels_class_list (const GstStructure * labels)
{
  std::string out;
  const guint n = landmark_labels_n_classes (labels);
  for (guint i = 0; i < n; i++) {
    const gchar *name = landmark_labels_class_name (labels, i);
    out += (i ? ", " : "") + std::string (name ? name : "?");
  }
  return out;
}

static std::string
landmark_labels_missing_classes (const GstStructure * labels,
    const std::vector<std::pair<std::string, std::string>> & map_classes)
{
  std::vector<std::string> have;
  const guint n = landmark_labels_n_classes (labels);
  for (guint i = 0; i < n; i++) {
    const gchar *name = landmark_labels_class_name (labels, i);
    if (name)
      have.push_back (name);
  }
  /* in map order, each missing class once with all its landmark ids */
  std::vector<std::pair<std::string, std::string>> missing;
  for (const auto & c : map_classes) {
    if (std::find (have.begin (), have.end (), c.first) != have.end ())
      continue;
    auto it = std::find_if (missing.begin (), missing.end (),
        [&](const auto & m) { return m.first == c.first; });
    if (it == missing.end ())
      missing.push_back ({ c.first, c.second });
    else
      it->second += ", " + c.second;
  }
  std::string out;
  for (const auto & m : missing)
    out += (out.empty ()? "" : ", ") + m.first + " (" + m.second + ")";
  return out;
}

void
landmark_warn_map_classes_missing (GstElement * element,
    const GstStructure * labels, const std::string & map_path,
    const std::vector<std::pair<std::string, std::string>> & map_classes,
    const char *consequence)
{
  const std::string missing = landmark_labels_missing_classes (labels,
      map_classes);
  if (!missing.empty ())
    GST_ELEMENT_WARNING (element, RESOURCE, SETTINGS,
        ("The map has landmarks of classes the labels do not have; %s",
            consequence), ("%s: %s; the labels have: %s", map_path.c_str (),
            missing.c_str (), landmark_labels_class_list (labels).c_str ()));
}

const GstStructure *
landmark_labels_or_warn (GstElement * element, GstBuffer * buf, bool *warned)
{
  const GstStructure *labels = landmark_labels_meta_get (buf);
  if (!labels && !*warned) {
    GST_ELEMENT_WARNING (element, STREAM, FORMAT,
        ("No class labels on the video: %s needs labsegment upstream.",
            GST_OBJECT_NAME (gst_element_get_factory (element))),
        ("no %s on buffer %" GST_PTR_FORMAT "; buffers pass unmeasured",
            GST_LANDMARK_LABELS_META_NAME, buf));
    *warned = true;
  }
  return labels;
}

bool
LandmarkLabelClasses::changed (const GstStructure * labels)
{
  const guint n = MIN (landmark_labels_n_classes (labels), 255u);
  bool same = valid && names.size () == n;
  for (guint k = 0; same && k < n; k++) {
    const gchar *name = landmark_labels_class_name (labels, k);
    const gchar *role = landmark_labels_class_role (labels, k);
    same = name && names[k] == name &&
        markers[k] == (bool) landmark_labels_class_is_marker (labels, k) &&
        roles[k] == (role ? role : "");
  }
  if (same)
    return false;
  names.clear ();
  markers.clear ();
  roles.clear ();
  for (guint k = 0; k < n; k++) {
    const gchar *name = landmark_labels_class_name (labels, k);
    const gchar *role = landmark_labels_class_role (labels, k);
    names.emplace_back (name ? name : "");
    markers.push_back (landmark_labels_class_is_marker (labels, k));
    roles.emplace_back (role ? role : "");
  }
  valid = false;
  return true;
}

void
LandmarkLabelClasses::reset ()
{
  names.clear ();
  markers.clear ();
  roles.clear ();
  valid = false;
}

bool
LandmarkLabelClasses::labels_of (GstElement * element, const char *property,
    const std::vector < std::string > &wanted,
    std::vector < guint > *labels) const
{
  labels->clear ();
  for (const std::string & want : wanted) {
    const auto it = std::find (names.begin (), names.end (), want);
    if (it == names.end ()) {
      GST_ELEMENT_ERROR (element, RESOURCE, SETTINGS,
          ("Invalid '%s' value: no class \"%s\" in the labels.", property,
              want.c_str ()), ("the palette has: %s", list ().c_str ()));
      return false;
    }
    labels->push_back ((guint) (it - names.begin ()) + 1);
  }
  return true;
}

std::string
LandmarkLabelClasses::list () const
{
  std::string known;
  for (const auto & name : names)
    known += (known.empty ()? "" : ", ") + name;
  return known;
}

LandmarkLabelPlane::~LandmarkLabelPlane ()
{
  if (data)
    gst_buffer_unmap (plane_, &map_);
  if (plane_)
    gst_buffer_unref (plane_);
}

bool
LandmarkLabelPlane::read (GstElement * element, const GstStructure * labels,
    bool *warned, bool *failed)
{
  *failed = false;
  if (!landmark_labels_get_plane (labels, &plane_, &width, &height,
          &stride)) {
    plane_ = nullptr;
    if (!*warned) {
      GST_ELEMENT_WARNING (element, STREAM, FORMAT,
          ("The labels metadata has no usable label plane."),
          ("missing or inconsistent plane fields; buffers pass "
              "unmeasured"));
      *warned = true;
    }
    return false;
  }
  if (!gst_buffer_map (plane_, &map_, GST_MAP_READ)) {
    GST_ELEMENT_ERROR (element, STREAM, FAILED,
        ("Could not read the label plane."), (nullptr));
    *failed = true;
    return false;
  }
  data = map_.data;
  return true;
}

