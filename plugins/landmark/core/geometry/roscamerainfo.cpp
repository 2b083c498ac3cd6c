/* ROS camera_info YAML files: see roscamerainfo.h. */
#include "roscamerainfo.h"

#include <opencv2/core.hpp>

#include <cmath>

namespace landmark {

namespace {

const char *const kNeeds = "a ROS camera_info file needs image_width, "
    "image_height, camera_matrix and distortion_coefficients";

std::string
dims_text (int rows, int cols)
{
  return std::to_string (rows) + "x" + std::to_string (cols);
}

/* The matrix under key: its rows x cols numbers, row by row, into
 * *values. want_rows, want_cols: the size it must have (0: any). False
 * (with *error) when key is no matrix, its data do not hold rows x cols
 * values, it has another size, or a value is not finite. */
bool
read_matrix (const cv::FileStorage & fs, const std::string & path,
    const char *key, int want_rows, int want_cols,
    std::vector<double> *values, std::string * error)
{
  const cv::FileNode n = fs[key];
  if (!n.isMap () || !n["rows"].isInt () || !n["cols"].isInt ()
      || !n["data"].isSeq ()) {
    *error = path + ": " + key + " is not a matrix (indented rows, cols and "
        "data lines)";
    return false;
  }
  const int rows = (int) n["rows"], cols = (int) n["cols"];
  const cv::FileNode data = n["data"];
  if ((double) data.size () != (double) rows * cols) {
    *error = path + ": " + key + ": data has " + std::to_string (data.size ())
        + " values, rows x cols is " + dims_text (rows, cols);
    return false;
  }
  if (want_rows > 0 && (rows != want_rows || cols != want_cols)) {
    *error = path + ": " + key + " is " + dims_text (rows, cols) + ", not " +
        dims_text (want_rows, want_cols);
    return false;
  }
  values->clear ();
  for (const cv::FileNode & v : data) {
    /* the shape check lets only numbers into a list */
    const double x = v.isInt () || v.isReal ()? (double) v : NAN;
    if (!std::isfinite (x)) {
      *error = path + ": " + key + ": its data are not all finite numbers";
      return false;
    }
    values->push_back (x);
  }
  return true;
}

bool
read_size (const cv::FileStorage & fs, const std::string & path,
    CameraFile * out, std::string * error)
{
  const char *keys[] = { "image_width", "image_height" };
  int *dst[] = { &out->image_width, &out->image_height };
  for (int i = 0; i < 2; i++) {
    const cv::FileNode n = fs[keys[i]];
    if (n.empty ()) {
      *error = path + ": no " + keys[i] + " (" + kNeeds + ")";
      return false;
    }
    if (!n.isInt ()) {
      *error = path + ": " + keys[i] + " is not a whole number";
      return false;
    }
    *dst[i] = (int) n;
  }
  if (out->image_width <= 0 || out->image_height <= 0
      || out->image_width > kMaxCameraImageSize
      || out->image_height > kMaxCameraImageSize) {
    *error = path + ": image_width and image_height must be within 1.." +
        std::to_string (kMaxCameraImageSize) + ", got " +
        dims_text (out->image_width, out->image_height);
    return false;
  }
  return true;
}

}  // namespace

bool
camera_info_values (const cv::FileStorage & fs, const std::string & path,
    CameraFile * out, std::string * error)
{
  if (!read_size (fs, path, out, error))
    return false;

  std::vector<double> k;
  if (fs["camera_matrix"].empty ()) {
    *error = path + ": no camera_matrix (" + kNeeds + ")";
    return false;
  }
  if (!read_matrix (fs, path, "camera_matrix", 3, 3, &k, error))
    return false;
  if (!(k[0] > 0 && k[4] > 0) || k[3] != 0 || k[6] != 0 || k[7] != 0
      || k[8] != 1.0) {
    *error = path + ": camera_matrix is not a camera matrix (fx, fy > 0, "
        "last row 0 0 1)";
    return false;
  }
  out->fx = k[0];
  out->cx = k[2];
  out->fy = k[4];
  out->cy = k[5];

  /* ROS reads a file without distortion_model as plumb_bob */
  std::string model = "plumb_bob";
  const cv::FileNode m = fs["distortion_model"];
  if (!m.empty ()) {
    if (!m.isString ()) {
      *error = path + ": distortion_model is not a name (plumb_bob or "
          "rational_polynomial)";
      return false;
    }
    model = (std::string) m;
  }
  size_t want = 0;
  if (model == "plumb_bob") {
    want = 5;
  } else if (model == "rational_polynomial") {
    want = 8;
  } else if (model == "equidistant") {
    *error = path + ": distortion_model equidistant (the fisheye model) is "
        "not supported: the elements have no fisheye camera model (calibrate "
        "the camera with plumb_bob or rational_polynomial)";
    return false;
  } else {
    *error = path + ": unknown distortion_model '" + model + "' (expected "
        "plumb_bob or rational_polynomial)";
    return false;
  }
  if (fs["distortion_coefficients"].empty ()) {
    *error = path + ": no distortion_coefficients (" + kNeeds + ")";
    return false;
  }
  if (!read_matrix (fs, path, "distortion_coefficients", 0, 0, &out->dist,
          error))
    return false;
  /* none: a camera without distortion (or images already rectified) */
  if (!out->dist.empty () && out->dist.size () != want) {
    *error = path + ": distortion_coefficients: " + model + " takes " +
        std::to_string (want) + (want == 5 ? " (k1 k2 p1 p2 k3)" :
        " (k1 k2 p1 p2 k3 k4 k5 k6)") + ", has " +
        std::to_string (out->dist.size ());
    return false;
  }

  std::vector<double> unused;
  if (!fs["rectification_matrix"].empty ()
      && !read_matrix (fs, path, "rectification_matrix", 3, 3, &unused,
          error))
    return false;
  if (!fs["projection_matrix"].empty ()
      && !read_matrix (fs, path, "projection_matrix", 3, 4, &unused, error))
    return false;
  return true;
}

}  // namespace landmark
