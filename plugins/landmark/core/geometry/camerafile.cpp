/* Camera files: see camerafile.h. */
#include "camerafile.h"

#include "camerafileshape.h"
#include "fileutil.h"
#include "roscamerainfo.h"

#include <opencv2/core.hpp>

#include <sys/stat.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace landmark {

/* The matrix under key a (or b): 0 when absent, 1 when read into *m, -1
 * when refused unread. OpenCV allocates what a matrix declares before it
 * counts the data, so a matrix is decoded only when it declares integer
 * rows and cols with at most max_values values (*declared: rows x cols). */
static int
read_matrix (const cv::FileStorage & fs, const char *a, const char *b,
    double max_values, cv::Mat * m, double *declared)
{
  cv::FileNode n = fs[a];
  if (n.empty ())
    n = fs[b];
  if (n.empty ())
    return 0;
  m->release ();
  *declared = -1;
  const cv::FileNode rows = n["rows"], cols = n["cols"];
  if (!n.isMap () || !rows.isInt () || !cols.isInt ()
      || (int) rows < 0 || (int) cols < 0)
    return -1;
  *declared = (double) (int) rows * (double) (int) cols;
  if (*declared > max_values)
    return -1;
  n >> *m;
  return 1;
}

/* A real number under key, when present; false (with *error) when the key
 * is there but not a finite number. */
static bool
read_real (const cv::FileStorage & fs, const std::string & path,
    const char *key, bool *present, double *value, std::string * error)
{
  const cv::FileNode n = fs[key];
  *present = !n.empty ();
  if (!*present)
    return true;
  if (!n.isReal () && !n.isInt ()) {
    *error = path + ": " + key + " is not a number";
    return false;
  }
  *value = (double) n;
  if (!std::isfinite (*value)) {
    *error = path + ": " + key + " is not finite";
    return false;
  }
  return true;
}

/* camera_height, when present: a positive number of metres */
static bool
read_camera_height (const cv::FileStorage & fs, const std::string & path,
    CameraFile * out, std::string * error)
{
  double v = 0;
  bool present = false;
  if (!read_real (fs, path, "camera_height", &present, &v, error))
    return false;
  if (present) {
    if (!(v > 0)) {
      *error = path + ": camera_height must be positive (metres), got " +
          number_text (v);
      return false;
    }
    out->has_camera_height = true;
    out->camera_height = v;
  }
  return true;
}

/* tilt_deg (within [-90, 90]) and roll_deg, when present */
static bool
read_tilt_roll (const cv::FileStorage & fs, const std::string & path,
    CameraFile * out, std::string * error)
{
  if (!read_real (fs, path, "tilt_deg", &out->has_tilt, &out->tilt_deg,
          error)
      || !read_real (fs, path, "roll_deg", &out->has_roll, &out->roll_deg,
          error))
    return false;
  if (out->has_tilt && !(out->tilt_deg >= -90 && out->tilt_deg <= 90)) {
    *error = path + ": tilt_deg must be within [-90, 90] degrees, got " +
        number_text (out->tilt_deg);
    return false;
  }
  return true;
}

/* The values of a file whose shape was checked: OpenCV reads them. A
 * camera_info file (opencv_text made by camera_info_shape_ok) holds the
 * intrinsics under ROS's keys and may hold the mounting keys. */
static bool
read_values (const std::string & path, const std::string & text,
    bool camera_info, CameraFile * out, std::string * error)
{
  try {
    cv::FileStorage fs (text, cv::FileStorage::READ |
        cv::FileStorage::MEMORY);
    if (!fs.isOpened ()) {
      *error = path + ": not an OpenCV FileStorage file (YAML or XML)";
      return false;
    }
    if (camera_info)
      return camera_info_values (fs, path, out, error)
          && read_camera_height (fs, path, out, error)
          && read_tilt_roll (fs, path, out, error);
    const cv::FileNode model = fs["model"];
    if (!model.empty ()) {
      const std::string name = model.isString ()? (std::string) model : "";
      /* "seed": the angle-linear model's former name */
      if (name == "angle-linear" || name == "seed") {
        out->seed = true;
      } else if (name != "pinhole") {
        *error = path + ": unknown model '" + name + "' (expected "
            "angle-linear, or a pinhole file with camera_matrix)";
        return false;
      }
    }
    if (!fs["image_width"].empty ())
      fs["image_width"] >> out->image_width;
    if (!fs["image_height"].empty ())
      fs["image_height"] >> out->image_height;
    if (out->image_width < 0 || out->image_height < 0) {
      *error = path + ": image_width and image_height must be positive";
      return false;
    }
    if (out->image_width > kMaxCameraImageSize
        || out->image_height > kMaxCameraImageSize) {
      *error = path + ": image_width and image_height must be at most " +
          std::to_string (kMaxCameraImageSize) + ", got " +
          std::to_string (out->image_width) + "x" +
          std::to_string (out->image_height);
      return false;
    }
    if (!read_camera_height (fs, path, out, error))
      return false;

    if (out->seed) {
      if (!out->has_camera_height) {
        *error = path + ": an angle-linear file (model: angle-linear) "
            "needs camera_height";
        return false;
      }
      const char *keys[] = { "blind_distance", "view_depth", "half_width" };
      double *dst[] = { &out->blind_distance, &out->view_depth,
        &out->half_width
      };
      for (int i = 0; i < 3; i++) {
        bool present = false;
        if (!read_real (fs, path, keys[i], &present, dst[i], error))
          return false;
        if (!present) {
          *error = path + ": an angle-linear file (model: angle-linear) "
              "needs " + keys[i];
          return false;
        }
        if (!(*dst[i] > 0)) {
          *error = path + ": " + keys[i] + " must be positive (metres), got "
              + number_text (*dst[i]);
          return false;
        }
      }
      /* tilt_deg and the fields of view in a seed file are derived from
       * the four lengths: not read */
      return true;
    }

    if (!read_tilt_roll (fs, path, out, error))
      return false;

    cv::Mat k, d;
    double declared = 0;
    const int have_k = read_matrix (fs, "camera_matrix", "cameraMatrix", 9,
        &k, &declared);
    if (have_k == 0) {
      *error = path + ": no camera_matrix (nor model: angle-linear)";
      return false;
    }
    if (k.rows != 3 || k.cols != 3 || k.channels () != 1) {
      *error = path + ": camera_matrix is not 3x3";
      return false;
    }
    k.convertTo (k, CV_64F);
    out->fx = k.at<double> (0, 0);
    out->fy = k.at<double> (1, 1);
    out->cx = k.at<double> (0, 2);
    out->cy = k.at<double> (1, 2);
    if (!(out->fx > 0 && out->fy > 0) || !std::isfinite (out->fx)
        || !std::isfinite (out->fy) || !std::isfinite (out->cx)
        || !std::isfinite (out->cy) || k.at<double> (1, 0) != 0
        || k.at<double> (2, 0) != 0 || k.at<double> (2, 1) != 0
        || k.at<double> (2, 2) != 1.0) {
      *error = path + ": camera_matrix is not a camera matrix (fx, fy > 0, "
          "last row 0 0 1)";
      return false;
    }
    const int have_d = read_matrix (fs, "distortion_coefficients",
        "distCoeffs", 14, &d, &declared);
    if (have_d < 0 && declared < 0) {
      *error = path + ": distortion_coefficients is not an OpenCV matrix "
          "(rows, cols, dt, data)";
      return false;
    }
    if (have_d != 0 && (have_d < 0 || !d.empty ())) {
      const size_t n = d.total ();
      if (d.channels () != 1 || !(n == 4 || n == 5 || n == 8 || n == 12
              || n == 14)) {
        *error = path + ": distortion_coefficients must have 4, 5, 8, 12 or "
            "14 values, has " + (have_d < 0 ? number_text (declared) :
            std::to_string (n));
        return false;
      }
      d = d.reshape (1, 1);
      d.convertTo (d, CV_64F);
      for (size_t i = 0; i < n; i++) {
        const double c = d.at<double> (0, (int) i);
        if (!std::isfinite (c)) {
          *error = path + ": distortion_coefficients are not finite";
          return false;
        }
        out->dist.push_back (c);
      }
    }
  }
  catch (const cv::Exception & e) {
    *error = path + ": cannot parse the calibration file: " + e.msg;
    return false;
  }
  catch (const std::exception & e) {
    /* OpenCV's parsers also throw standard exceptions on some malformed
     * files (std::length_error from a misplaced key) */
    *error = path + ": cannot parse the calibration file: " + e.what ();
    return false;
  }
  return true;
}


bool
load_camera_file (const std::string & path, CameraFile * out,
    std::string * error)
{
  *out = CameraFile ();
  std::ifstream f (path, std::ios::binary);
  if (!f.good ()) {
    *error = path + ": cannot open the calibration file";
    return false;
  }
  /* before reading: a device such as /dev/zero never ends */
  if (!config_file_size_ok (path, error))
    return false;
  struct stat st;
  if (stat (path.c_str (), &st) == 0 && S_ISDIR (st.st_mode)) {
    *error = path + ": is a directory, not a calibration file";
    return false;
  }
  /* read once: what was checked is what OpenCV parses */
  std::ostringstream whole;
  whole << f.rdbuf ();
  const std::string text = whole.str ();
  if (text.find_first_not_of (" \t\r\n") == std::string::npos) {
    *error = path + ": the calibration file is empty";
    return false;
  }
  if (looks_like_camera_info (text)) {
    std::string opencv_text;
    return camera_info_shape_ok (text, path, &opencv_text, error)
        && read_values (path, opencv_text, true, out, error);
  }
  return camera_file_shape_ok (text, path, error)
      && read_values (path, text, false, out, error);
}

}  // namespace landmark
