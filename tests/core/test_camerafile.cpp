/* Camera files (plugins/landmark/core/geometry/camerafile.h): what OpenCV writes
 * (YAML, XML, JSON, also the extra keys of its calibration sample) reads
 * back to the values written; malformed files, among them those on which
 * OpenCV's own parser hangs or throws (tests/fuzz/regressions/calibration),
 * are refused with an error naming the file, the line or the key. */
#include "camerafile.h"
#include "corecheck.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

using namespace landmark;


static void
write_text (const std::string & path, const std::string & text)
{
  std::ofstream out (path, std::ios::binary);
  out << text;
}

/* Writes text to path and loads it as a camera file. */
static bool
load_text (const std::string & path, const std::string & text,
    CameraFile * f, std::string * err)
{
  write_text (path, text);
  return load_camera_file (path, f, err);
}

/* As OpenCV's calibration sample writes a result: a time, counts, a
 * comment, the two matrices, and per-view matrices of other types. */
static void
test_opencv_written ()
{
  const char *suffixes[] = { ".yml", ".xml", ".json" };
  for (const char *suffix : suffixes) {
    const std::string path = std::string ("test-camerafile") + suffix;
    {
      cv::FileStorage fs (path, cv::FileStorage::WRITE);
      fs << "calibration_time" << "Wed 25 Nov 2026 15:00:00 UTC";
      fs << "nr_of_frames" << 12 << "image_width" << 640 << "image_height"
          << 480 << "square_size" << 0.025;
      /* OpenCV writes a comment into JSON as // ..., which is no JSON */
      if (std::string (suffix) != ".json")
        fs.writeComment ("flags: +fix_aspectRatio");
      fs << "camera_matrix" << cv::Mat (cv::Matx33d (500.25, 0, 320.5, 0,
              502, 240.125, 0, 0, 1));
      fs << "distortion_coefficients" << cv::Mat (cv::Matx<double, 5, 1>
          (-0.2, 0.05, 0.001, -0.002, 0.01));
      cv::Mat points (4, 30, CV_32FC2, cv::Scalar (1.5f, 2.25f));
      fs << "image_points" << points;
      fs << "extrinsic_parameters" << cv::Mat (12, 6, CV_64F, cv::Scalar
          (0.123456789012345));
      fs << "camera_height" << 0.31 << "tilt_deg" << 27.5 << "roll_deg" <<
          -1.25;
    }
    CameraFile f;
    std::string err;
    CHECK (load_camera_file (path, &f, &err), "%s: %s", suffix, err.c_str ());
    CHECK (!f.seed && f.fx == 500.25 && f.fy == 502 && f.cx == 320.5 &&
        f.cy == 240.125 && f.image_width == 640 && f.image_height == 480,
        "%s: intrinsics %g %g %g %g %dx%d", suffix, f.fx, f.fy, f.cx, f.cy,
        f.image_width, f.image_height);
    CHECK (f.dist == std::vector<double> ({-0.2, 0.05, 0.001, -0.002, 0.01}),
        "%s: %zu distortion coefficients", suffix, f.dist.size ());
    CHECK (f.has_camera_height && f.camera_height == 0.31 && f.has_tilt &&
        f.tilt_deg == 27.5 && f.has_roll && f.roll_deg == -1.25,
        "%s: mounting %g %g %g", suffix, f.camera_height, f.tilt_deg,
        f.roll_deg);
    std::remove (path.c_str ());
  }
}

/* Written by hand, as docs/calibration.md shows them. */
static void
test_hand_written ()
{
  const std::string path = "test-camerafile-hand.yaml";
  CameraFile f;
  std::string err;
  /* the angle-linear model, under its name and its former name (YAML and
   * XML, as OpenCV writes them) */
  for (const char *model : { "angle-linear", "seed" }) {
    write_text (path, std::string ("%YAML:1.0\n---\n# an angle-linear file\n"
            "model: ") + model + "\ncamera_height: 0.4\n"
        "blind_distance: 0.3\nview_depth: .9\nhalf_width: 6e-1\n");
    CHECK (load_camera_file (path, &f, &err) && f.seed &&
        f.camera_height == 0.4 && f.blind_distance == 0.3 &&
        f.view_depth == 0.9 && f.half_width == 0.6, "%s: %s", model,
        err.c_str ());
  }
  const std::string xml = "test-camerafile-hand.xml";
  write_text (xml, "<?xml version=\"1.0\"?>\n<opencv_storage>\n"
      "<model>angle-linear</model>\n<camera_height>0.4</camera_height>\n"
      "<blind_distance>0.3</blind_distance>\n<view_depth>0.9</view_depth>\n"
      "<half_width>0.6</half_width>\n</opencv_storage>\n");
  CHECK (load_camera_file (xml, &f, &err) && f.seed &&
      f.half_width == 0.6, "xml angle-linear: %s", err.c_str ());
  std::remove (xml.c_str ());
  /* a word may not start or end with '-' */
  write_text (path, "%YAML:1.0\n---\nmodel: angle-\n");
  CHECK (!load_camera_file (path, &f, &err), "'angle-' accepted");
  /* a list split over lines, CRLF line ends, no distortion */
  CHECK (load_text (path, "%YAML:1.0\r\n---\r\n"
      "cameraMatrix: !!opencv-matrix\r\n  rows: 3\r\n  cols: 3\r\n  dt: d\r\n"
      "  data: [ 400., 0., 160.,\r\n      0., 400., 120., 0., 0., 1. ]\r\n",
      &f, &err) && f.fx == 400 && f.cy == 120 && f.dist.empty () &&
      f.image_width == 0, "split list: %s", err.c_str ());
  std::remove (path.c_str ());
}

/* Every refusal names the file and, for the shape, the line and the key. */
static void
test_refused ()
{
  const std::string path = "test-camerafile-bad.yaml";
  const std::string head = "%YAML:1.0\n---\n";
  const std::string k = "camera_matrix: !!opencv-matrix\n   rows: 3\n"
      "   cols: 3\n   dt: d\n   data: [ 500., 0., 320., 0., 500., 240., 0., "
      "0., 1. ]\n";
  struct { std::string text, expect; } cases[] = {
    /* tests/fuzz/regressions/calibration: OpenCV loops forever on it */
    { "%YAML:1.00\n   ro: 0\n 8  %YAML:1.0\n-:t]\n--",
      path + ": line 1: not the YAML header %YAML:1.0" },
    { head + k + "note: 5%\n",
      path + ": line 8: '%' outside the header (OpenCV's parser does not "
          "end on it)" },
    /* OpenCV threw std::length_error on this one */
    { head + "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
          "m  dt:rows  data: [ 500. ]\n",
      path + ": line 6: camera_matrix: expected `dt: ` (an opencv-matrix has "
          "rows, cols, dt and data, in this order)" },
    { head + "camera_matrix: !!opencv-matrix\n   rows:@ 3\n",
      path + ": line 4: camera_matrix: expected `rows: ` (an opencv-matrix "
          "has rows, cols, dt and data, in this order)" },
    { head + "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n",
      path + ": line 5: camera_matrix: the file ends inside it" },
    { head + k + "camera_matrix: 3\n", path + ": line 8: camera_matrix "
          "appears twice" },
    { head + "camera_height: [ 1., x ]\n", path + ": line 3: camera_height: "
          "`x` in its list is not a number" },
    { head + "camera_height: 0.3 # metres\n", path + ": line 3: "
          "camera_height: `0.3 # metres` is not a number, a word or a quoted "
          "text" },
    { head + "  camera_height: 0.3\n", path + ": line 3: unexpected "
          "indentation; a camera file holds top-level keys with a number, a "
          "word, a quoted text, a list of numbers or an opencv-matrix (rows, "
          "cols, dt, data), as OpenCV writes them" },
    { head + "mounting:\n  tilt_deg: 20\n", path + ": line 3: mounting: "
          "expected a value after `mounting: `" },
    { "this is not a calibration file {\n", path + ": not an OpenCV "
          "FileStorage file (YAML starting with %YAML:1.0, XML with <?xml, or "
          "JSON with {) nor a ROS camera_info file (camera_matrix, "
          "distortion_coefficients, ... at the left margin)" },
    { "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a>&lt;</a>\n"
          "</opencv_storage>\n", path + ": '&' (an XML entity) is not read "
          "in a camera file" },
    { "<?xml version=\"1.0\"?>\n<opencv_storage>\n<camera_matrix "
          "type_id=\"opencv-matrix\"><rows>3</rows><dt>d</dt>"
          "</camera_matrix>\n</opencv_storage>\n", path + ": line 3: "
          "camera_matrix: <dt> is not expected here; a camera file holds "
          "top-level keys with a number, a word, a quoted text, a list of "
          "numbers or an opencv-matrix (rows, cols, dt, data), as OpenCV "
          "writes them" },
    { "<?xml version=\"1.0\"?>\n<!DOCTYPE x>\n<opencv_storage>\n"
          "</opencv_storage>\n", path + ": `<!DOCTYPE x>`: only the "
          "<?xml ...?> declaration and comments may accompany <opencv_storage>" },
    { "{ \"camera_matrix\": { \"rows\": 3 } }", path + ": camera_matrix: a "
          "camera file holds top-level keys with a number, a word, a quoted "
          "text, a list of numbers or an opencv-matrix (rows, cols, dt, "
          "data), as OpenCV writes them" },
    { std::string ("%YAML:1.0\n---\nmodel: \"se\x01" "ed\"\n"),
      path + ": control characters in a camera file" },
    /* the shape is right, the values are not */
    { head + "camera_matrix: !!opencv-matrix\n   rows: 100000\n"
          "   cols: 100000\n   dt: d\n   data: [ 1. ]\n",
      path + ": camera_matrix is not 3x3" },
    { head + k + "distortion_coefficients: !!opencv-matrix\n"
          "   rows: 100000\n   cols: 100000\n   dt: d\n   data: [ 0. ]\n",
      path + ": distortion_coefficients must have 4, 5, 8, 12 or 14 values, "
          "has 1e+10" },
    { head + "image_width: 100000\nimage_height: 480\n" + k,
      path + ": image_width and image_height must be at most 16384, got "
          "100000x480" },
    { head + "model: fisheye\n", path + ": unknown model 'fisheye' "
          "(expected angle-linear, or a pinhole file with camera_matrix)" },
    { head + "foo: 1\n", path + ": no camera_matrix (nor model: angle-linear)" },
    { head + k + "camera_height: \"high\"\n", path + ": camera_height is not "
          "a number" },
    { head + k + std::string (1 << 20, '#'),
      path + ": " + std::to_string ((1 << 20) + head.size () + k.size ()) +
          " bytes; at most 1048576 are supported" },
    { "  \n", path + ": the calibration file is empty" },
  };
  CameraFile f;
  std::string err;
  for (const auto & c : cases) {
    write_text (path, c.text);
    const auto t0 = std::chrono::steady_clock::now ();
    const bool ok = load_camera_file (path, &f, &err);
    const double ms = std::chrono::duration<double, std::milli>
        (std::chrono::steady_clock::now () - t0).count ();
    CHECK (!ok && err == c.expect, "got \"%s\", expected \"%s\"",
        err.c_str (), c.expect.c_str ());
    CHECK (ms < 100, "%.1f ms for \"%s\"", ms, c.expect.c_str ());
  }
  std::remove (path.c_str ());
  CHECK (!load_camera_file ("/dev/zero", &f, &err) &&
      err == "/dev/zero: not a regular file", "%s", err.c_str ());
  CHECK (!load_camera_file ("/nonexistent/cal.yaml", &f, &err) &&
      err == "/nonexistent/cal.yaml: cannot open the calibration file", "%s",
      err.c_str ());
  CHECK (!load_camera_file (".", &f, &err) &&
      err == ".: is a directory, not a calibration file", "%s", err.c_str ());
}

/* ROS camera_info YAML as ROS's tools write it: camera_calibration_parsers
 * (yaml-cpp: flow lists on one line, no quotes) and the camera_calibration
 * GUI (lists over lines, numpy's spacing); the values read are those
 * written. */
static void
test_camera_info ()
{
  const std::string path = "test-camerafile-info.yaml";
  CameraFile f;
  std::string err;
  /* a serial number for a name: OpenCV's parser alone stops on it */
  CHECK (load_text (path, "image_width: 640\nimage_height: 480\n"
      "camera_name: 00b09d0100990bb6\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [538.63, 0, 317.698, 0, 539.723, 241.003, 0, 0, 1]\n"
      "distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n"
      "  cols: 5\n  data: [-0.30678, 0.0825017, 0.0028784, -1.5829e-05, 0]\n"
      "rectification_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nprojection_matrix:\n  rows: 3\n"
      "  cols: 4\n  data: [538.63, 0, 317.698, 0, 0, 539.723, 241.003, 0, 0, "
      "0, 1, 0]\n", &f, &err), "yaml-cpp: %s", err.c_str ());
  CHECK (!f.seed && f.fx == 538.63 && f.fy == 539.723 && f.cx == 317.698 &&
      f.cy == 241.003 && f.image_width == 640 && f.image_height == 480,
      "yaml-cpp: intrinsics %g %g %g %g %dx%d", f.fx, f.fy, f.cx, f.cy,
      f.image_width, f.image_height);
  CHECK (f.dist == std::vector<double> ({-0.30678, 0.0825017, 0.0028784,
              -1.5829e-05, 0}), "yaml-cpp: %zu coefficients",
      f.dist.size ());
  CHECK (!f.has_camera_height && !f.has_tilt && !f.has_roll,
      "yaml-cpp: a mounting read");

  /* the calibration GUI's layout, 4-space indents, a --- line, comments,
   * CRLF, rational_polynomial, and the mounting keys of our files */
  CHECK (load_text (path, "---\r\n# left camera\r\nimage_width: 1280\r\n"
      "image_height: 800\r\ncamera_name: 'elp left'\r\ncamera_matrix: \r\n"
      "    rows: 3\r\n    cols: 3\r\n"
      "    data: [ 415.12614,    0.     ,  665.52373,\r\n"
      "              0.     ,  410.49986,  460.14929,\r\n"
      "              0.     ,    0.     ,    1.     ]\r\n"
      "distortion_model: rational_polynomial\r\n"
      "distortion_coefficients:\r\n    cols: 8\r\n    rows: 1\r\n"
      "    data: [-0.017697, -0.007270, 0.005751, -0.000139, 0., 0.1, 0.2, "
      "0.3]\r\n\r\ncamera_height: 0.31\r\ntilt_deg: 27.5\r\n"
      "roll_deg: -1.25\r\n", &f, &err), "GUI: %s", err.c_str ());
  CHECK (f.fx == 415.12614 && f.fy == 410.49986 && f.cx == 665.52373 &&
      f.cy == 460.14929 && f.image_width == 1280 && f.image_height == 800,
      "GUI: intrinsics %g %g %g %g %dx%d", f.fx, f.fy, f.cx, f.cy,
      f.image_width, f.image_height);
  CHECK (f.dist == std::vector<double> ({-0.017697, -0.007270, 0.005751,
              -0.000139, 0., 0.1, 0.2, 0.3}), "GUI: %zu coefficients",
      f.dist.size ());
  CHECK (f.has_camera_height && f.camera_height == 0.31 && f.has_tilt &&
      f.tilt_deg == 27.5 && f.has_roll && f.roll_deg == -1.25,
      "GUI: mounting %g %g %g", f.camera_height, f.tilt_deg, f.roll_deg);

  /* no distortion_model: plumb_bob, as ROS reads it; no coefficients */
  const bool loaded = load_text (path, "image_width: 320\nimage_height: 240\n"
      "camera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [300, 0, 160, 0, 300, 120, 0, 0, 1]\ndistortion_coefficients:\n"
      "  rows: 1\n  cols: 0\n  data: []\n", &f, &err);
  std::remove (path.c_str ());
  CHECK (loaded && f.fx == 300 && f.dist.empty (),
      "no model, no coefficients: %s", err.c_str ());
}

/* A bad camera_info file is refused with the file, the key and (for the
 * shape) the line; the same cases and messages are in
 * tests/python/test_camerainfo.py for the Python reader. */
static void
test_camera_info_refused ()
{
  const std::string path = "test-camerafile-info-bad.yaml";
  const std::string size = "image_width: 640\nimage_height: 480\n";
  const std::string k = "camera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\n";
  const std::string d = "distortion_model: plumb_bob\n"
      "distortion_coefficients:\n  rows: 1\n  cols: 5\n"
      "  data: [0.1, -0.2, 0, 0, 0.05]\n";
  const std::string needs = " (a ROS camera_info file needs image_width, "
      "image_height, camera_matrix and distortion_coefficients)";
  struct { std::string text, expect; } cases[] = {
    /* the values */
    { "image_height: 480\n" + k + d, path + ": no image_width" + needs },
    { size + d, path + ": no camera_matrix" + needs },
    { size + k + "distortion_model: plumb_bob\n",
      path + ": no distortion_coefficients" + needs },
    { "image_width: wide\nimage_height: 480\n" + k + d,
      path + ": image_width is not a whole number" },
    { "image_width: 0\nimage_height: 480\n" + k + d,
      path + ": image_width and image_height must be within 1..16384, got "
          "0x480" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320, 0, "
          "500, 240, 0, 0]\n" + d,
      path + ": camera_matrix: data has 8 values, rows x cols is 3x3" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 4\n  data: [500, 0, 320, 0, "
          "0, 500, 240, 0, 0, 0, 1, 0]\n" + d,
      path + ": camera_matrix is 3x4, not 3x3" },
    { size + "camera_matrix: 500\n" + d,
      path + ": camera_matrix is not a matrix (indented rows, cols and data "
          "lines)" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320, 0, "
          "500, 240, 0, 0, 2]\n" + d,
      path + ": camera_matrix is not a camera matrix (fx, fy > 0, last row "
          "0 0 1)" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [.nan, 0, 320, 0, "
          "500, 240, 0, 0, 1]\n" + d,
      path + ": camera_matrix: its data are not all finite numbers" },
    { size + k + "distortion_model: fisheye\ndistortion_coefficients:\n"
          "  rows: 1\n  cols: 4\n  data: [0, 0, 0, 0]\n",
      path + ": unknown distortion_model 'fisheye' (expected plumb_bob or "
          "rational_polynomial)" },
    { size + k + "distortion_model: equidistant\ndistortion_coefficients:\n"
          "  rows: 1\n  cols: 4\n  data: [0.1, 0.01, 0, 0]\n",
      path + ": distortion_model equidistant (the fisheye model) is not "
          "supported: the elements have no fisheye camera model (calibrate "
          "the camera with plumb_bob or rational_polynomial)" },
    { size + k + "distortion_model: 5\ndistortion_coefficients:\n"
          "  rows: 1\n  cols: 0\n  data: []\n",
      path + ": distortion_model is not a name (plumb_bob or "
          "rational_polynomial)" },
    { size + k + "distortion_model: plumb_bob\ndistortion_coefficients:\n"
          "  rows: 1\n  cols: 5\n  data: [0.1, -0.2, 0, 0]\n",
      path + ": distortion_coefficients: data has 4 values, rows x cols is "
          "1x5" },
    { size + k + "distortion_model: rational_polynomial\n"
          "distortion_coefficients:\n  rows: 1\n  cols: 5\n"
          "  data: [0.1, -0.2, 0, 0, 0]\n",
      path + ": distortion_coefficients: rational_polynomial takes 8 (k1 k2 "
          "p1 p2 k3 k4 k5 k6), has 5" },
    { size + k + d + "projection_matrix:\n  rows: 3\n  cols: 3\n"
          "  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\n",
      path + ": projection_matrix is 3x3, not 3x4" },
    { size + k + d + "camera_height: -0.3\n",
      path + ": camera_height must be positive (metres), got -0.3" },
    /* the shape: line and key */
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320, 0, "
          "500, x, 0, 0, 1]\n" + d,
      path + ": line 6: camera_matrix: `x` in its list is not a number" },
    { size + "camera_matrix:\n  rows: 3.0\n  cols: 3\n", path + ": line 4: "
          "camera_matrix: rows `3.0` is not a whole number" },
    { size + "camera_matrix:\n  cols: 3\n  data: [500, 0, 320, 0, 500, 240, "
          "0, 0, 1]\n" + d, path + ": line 3: camera_matrix: a matrix needs "
          "rows, cols and data; no rows" },
    { size + "camera_matrix:\n" + d, path + ": line 3: camera_matrix: "
          "expected a value after `camera_matrix:`, or indented rows, cols "
          "and data lines" },
    { size + "camera_matrix: {rows: 3, cols: 3}\n" + d, path + ": line 3: "
          "camera_matrix: `{rows: 3, cols: 3}`: a ROS camera_info file holds "
          "top-level keys with a number, a word or a quoted text, or a matrix "
          "as indented rows, cols and data lines, as "
          "camera_calibration_parsers writes them" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320,\n"
          "   0, 500, 240, 0, 0, 1]\n" + d, path + ": line 7: camera_matrix: "
          "a data list continued on the next line must be indented at least "
          "2 spaces more than `data:`" },
    { size + "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320,\n",
      path + ": line 6: camera_matrix: the file ends inside its data list" },
    { size + "camera_matrix:\n  rows: 3\n   cols: 3\n", path + ": line 5: "
          "camera_matrix: its rows, cols and data lines must be indented "
          "alike" },
    { size + "camera_matrix:\n  rows: 3\n  dt: d\n", path + ": line 5: "
          "camera_matrix: expected `rows: `, `cols: ` or `data: ` (a "
          "camera_info matrix)" },
    { "image_width: 99999999999\nimage_height: 480\n" + k + d,
      path + ": line 1: image_width: `99999999999` is a whole number of "
          "more than 9 digits (OpenCV does not read it exactly)" },
    { size + "camera_matrix: !!opencv-matrix\n", path + ": line 3: "
          "camera_matrix: an opencv-matrix in a file without OpenCV's "
          "%YAML:1.0 header (an OpenCV file starts with it; a ROS camera_info "
          "matrix is indented rows, cols and data lines)" },
    { size + k + d + "image_width: 320\n", path + ": line 12: image_width "
          "appears twice" },
    { size + "camera_name: left camera\n" + k + d, path + ": line 3: "
          "camera_name: `left camera` is not a name (letters, digits, "
          "_ - . /) or a quoted text" },
    { size + "camera_name: cam%1\n" + k + d, path + ": line 3: '%' "
          "(OpenCV's parser, which reads the file, does not end on it)" },
    { size + k + "distortion_model:\tplumb_bob\n", path + ": line 7: a tab "
          "(YAML indents with spaces)" },
    { size + k + d + "image_points: [1, 2]\n", path + ": line 12: "
          "image_points: `[1, 2]`: a ROS camera_info file holds top-level "
          "keys with a number, a word or a quoted text, or a matrix as "
          "indented rows, cols and data lines, as camera_calibration_parsers "
          "writes them" },
  };
  CameraFile f;
  std::string err;
  for (const auto & c : cases) {
    write_text (path, c.text);
    const bool ok = load_camera_file (path, &f, &err);
    CHECK (!ok && err == c.expect, "got \"%s\", expected \"%s\"",
        err.c_str (), c.expect.c_str ());
  }
  std::remove (path.c_str ());
}

/* Random files inside the accepted shape (keys, scalars, number lists and
 * matrices of any declared size and type, odd spacing, comments, special
 * numbers): each is handed to OpenCV, which must answer (load or refuse
 * on the values) without hanging, crashing or throwing past the loader. */
static std::mt19937 rng (7);

static int
pick (int n)
{
  return (int) (rng () % (unsigned) n);
}

static std::string
random_number ()
{
  const char *special[] = { ".nan", "-.inf", "1e308", "-1e-308", "0", "-0.",
    ".5", "1.", "+3", "1e999", "2147483647", "99999999999999999999"
  };
  if (pick (4) == 0)
    return special[pick (12)];
  return std::to_string (pick (2000001) / 1000.0 - 1000.0) +
      (pick (3) ? "" : "e" + std::to_string (pick (41) - 20));
}

static std::string
random_numbers (const char *sep, int n)
{
  std::string out;
  for (int j = 0; j < n; j++)
    out += (j ? sep : "") + random_number ();
  return out;
}

static std::string
random_file (int format)
{
  const char *keys[] = { "camera_matrix", "cameraMatrix",
    "distortion_coefficients", "distCoeffs", "image_width", "image_height",
    "camera_height", "tilt_deg", "roll_deg", "model", "blind_distance",
    "view_depth", "half_width", "image_points", "calibration_time"
  };
  const char *scalars[] = { "seed", "pinhole", "fisheye", "\"a b: [c]\"",
    "7", "-3", "0.25"
  };
  const char *counts[] = { "0", "1", "3", "5", "14", "100000", "999999999" };
  const char *dts[] = { "d", "f", "i", "u", "\"2f\"", "\"3d\"", "c", "w" };
  std::string text = format == 0 ? "%YAML:1.0\n---\n# a comment\n" :
      format == 1 ? "<?xml version=\"1.0\"?>\n<opencv_storage>\n" : "{\n";
  std::set<std::string> used;
  for (int i = 0, n = 1 + pick (8); i < n; i++) {
    const std::string key = keys[pick (15)];
    if (!used.insert (key).second)
      continue;
    const int kind = pick (3), items = pick (16);
    const std::string rows = counts[pick (7)], cols = counts[pick (7)];
    const std::string dt = dts[pick (format == 2 ? 2 : 8)];
    std::string v;
    if (format == 0) {
      const std::string list = "[ " + random_numbers (",\n      ", items) +
          " ]";
      v = kind == 0 ? std::string (scalars[pick (7)]) : kind == 1 ? list :
          "!!opencv-matrix\n   rows: " + rows + "\n   cols: " + cols +
          "\n   dt: " + dt + "\n   data: " + list;
      text += key + ": " + v + "\n";
    } else if (format == 1) {
      v = kind == 0 ? std::string (scalars[pick (7)]) : kind == 1 ?
          random_numbers ("\n  ", items) : "\n  <rows>" + rows +
          "</rows><cols>" + cols + "</cols><dt>" + dt + "</dt><data>" +
          random_numbers (" ", items) + "</data>";
      text += "<" + key + (kind == 2 ? " type_id=\"opencv-matrix\">" : ">")
          + v + "</" + key + ">\n";
    } else {
      /* JSON numbers: no .nan, no leading + or . */
      std::string list = "[";
      for (int j = 0; j < items; j++)
        list += std::string (j ? ", " : "") + std::to_string (pick (2001) -
            1000) + "." + std::to_string (pick (1000));
      v = kind == 0 ? std::string ("\"seed\"") : kind == 1 ? list + "]" :
          "{ \"type_id\": \"opencv-matrix\", \"rows\": " + rows +
          ", \"cols\": " + cols + ", \"dt\": " + (dt[0] == '"' ? dt : "\""
          + dt + "\"") + ", \"data\": " + list + "] }";
      text += std::string (used.size () > 1 ? ",\n" : "") + "\"" + key +
          "\": " + v;
    }
  }
  return text + (format == 1 ? "</opencv_storage>\n" : format == 2 ?
      "\n}\n" : "");
}

static void
test_random_files_in_shape ()
{
  const std::string path = "test-camerafile-random.txt";
  int shape_ok = 0, loaded = 0;
  const int n = 500;
  const auto t0 = std::chrono::steady_clock::now ();
  for (int i = 0; i < n; i++) {
    write_text (path, random_file (i % 3));
    CameraFile f;
    std::string err;
    const bool ok = load_camera_file (path, &f, &err);
    loaded += ok;
    /* refused by the shape: the messages with a line, or JSON's */
    shape_ok += ok || (err.find (": line ") == std::string::npos &&
        err.find ("a camera file holds") == std::string::npos);
  }
  std::remove (path.c_str ());
  const double s = std::chrono::duration<double> (
      std::chrono::steady_clock::now () - t0).count ();
  /* most pass the shape and reach OpenCV (a few repeat an element type
   * JSON or XML cannot hold) */
  CHECK (shape_ok > n * 8 / 10, "%d of %d random files passed the shape",
      shape_ok, n);
  std::printf ("random files in shape: %d of %d reached OpenCV, %d loaded, "
      "%.1f s\n", shape_ok, n, loaded, s);
}

/* random_number, but no whole number of more than 9 digits (the
 * camera_info shape refuses those) */
static std::string
random_short_number ()
{
  const std::string v = random_number ();
  const bool whole = v.find_first_not_of ("+-0123456789") ==
      std::string::npos;
  return whole && v.size () > 9 ? "1e9" : v;
}

/* A random file inside the camera_info shape: ROS's keys, ours and others,
 * scalars and matrices of any declared size over one or several lines,
 * names OpenCV's parser alone refuses, special numbers. */
static std::string
random_camera_info ()
{
  const char *keys[] = { "image_width", "image_height", "camera_name",
    "camera_matrix", "distortion_model", "distortion_coefficients",
    "rectification_matrix", "projection_matrix", "camera_height", "tilt_deg",
    "roll_deg", "binning_x", "model"
  };
  const char *scalars[] = { "plumb_bob", "rational_polynomial",
    "equidistant", "\"plumb_bob\"", "640", "-3", "0.25", ".nan", "null" };
  const char *names[] = { "00b09d0100990bb6", "narrow_stereo", "/cam/rgb",
    "'a b'", "\"x: [y]\"", "8mm", "a.b-c" };
  const char *counts[] = { "0", "1", "3", "4", "5", "8", "100000" };
  std::string text = pick (2) ? "---\n" : "";
  std::set<std::string> used;
  if (pick (2)) {
    /* a usable camera, so that some files load */
    text += "image_width: 640\nimage_height: 480\ncamera_matrix:\n  rows: 3\n"
        "  cols: 3\n  data: [" + std::to_string (1 + pick (900)) + ", 0, 320, "
        "0, 500, 240, 0, 0, 1]\ndistortion_coefficients:\n  rows: 1\n"
        "  cols: 5\n  data: [" + random_short_number () + ", 0, 0, 0, 0]\n";
    used.insert ({ "image_width", "image_height", "camera_matrix",
            "distortion_coefficients" });
  }
  for (int i = 0, n = 1 + pick (10); i < n; i++) {
    const std::string key = keys[pick (13)];
    if (!used.insert (key).second)
      continue;
    if (key == "camera_name") {
      text += key + ": " + names[pick (7)] + "\n";
      continue;
    }
    if (pick (3) == 0) {
      text += key + ": " + scalars[pick (9)] + "\n";
      continue;
    }
    const std::string indent (1 + pick (4), ' ');
    const std::string more (indent.size () + 2 + pick (8), ' ');
    std::string list;
    for (int j = 0, items = pick (16); j < items; j++) {
      list += (j ? (pick (4) ? ", " : " ,\n" + more) : "") +
          random_short_number ();
    }
    std::string fields[] = { indent + "rows: " + counts[pick (7)] + "\n",
      indent + "cols: " + counts[pick (7)] + "\n",
      indent + "data: [" + list + "]\n"
    };
    std::shuffle (fields, fields + 3, rng);
    text += key + ":" + (pick (2) ? " " : "") + "\n" + fields[0] + fields[1]
        + (pick (3) ? indent + "# c\n" : "") + fields[2];
  }
  return text;
}

static void
test_random_camera_info_in_shape ()
{
  const std::string path = "test-camerafile-random-info.yaml";
  int shape_ok = 0, loaded = 0;
  const int n = 300;
  double worst = 0;
  for (int i = 0; i < n; i++) {
    write_text (path, random_camera_info ());
    CameraFile f;
    std::string err;
    const auto t0 = std::chrono::steady_clock::now ();
    const bool ok = load_camera_file (path, &f, &err);
    worst = std::max (worst, std::chrono::duration<double, std::milli>
        (std::chrono::steady_clock::now () - t0).count ());
    loaded += ok;
    shape_ok += ok || err.find (": line ") == std::string::npos;
    if (!ok)
      CHECK (err.rfind (path + ": ", 0) == 0 &&
          err.find ("cannot parse") == std::string::npos,
          "OpenCV refused a file in shape: %s", err.c_str ());
  }
  std::remove (path.c_str ());
  /* every one passes the shape: its values are OpenCV's to read */
  CHECK (shape_ok == n, "%d of %d random camera_info files passed the shape",
      shape_ok, n);
  CHECK (worst < 100, "%.1f ms for one file", worst);
  std::printf ("random camera_info files in shape: %d of %d reached OpenCV, "
      "%d loaded\n", shape_ok, n, loaded);
}

int
main ()
{
  test_opencv_written ();
  test_hand_written ();
  test_refused ();
  test_camera_info ();
  test_camera_info_refused ();
  test_random_files_in_shape ();
  test_random_camera_info_in_shape ();
  return corecheck_summary ();
}
