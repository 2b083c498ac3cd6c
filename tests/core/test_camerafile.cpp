/* Camera files (plugins/landmark/core/camerafile.h): what OpenCV writes
 * (YAML, XML, JSON, also the extra keys of its calibration sample) reads
 * back to the values written; malformed files, among them those on which
 * OpenCV's own parser hangs or throws (tests/fuzz/regressions/calibration),
 * are refused with an error naming the file, the line or the key. */
#include "camerafile.h"
#include "corecheck.h"

#include <opencv2/core.hpp>

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
  write_text (path, "%YAML:1.0\r\n---\r\ncameraMatrix: !!opencv-matrix\r\n"
      "  rows: 3\r\n  cols: 3\r\n  dt: d\r\n  data: [ 400., 0., 160.,\r\n"
      "      0., 400., 120., 0., 0., 1. ]\r\n");
  CHECK (load_camera_file (path, &f, &err) && f.fx == 400 && f.cy == 120 &&
      f.dist.empty () && f.image_width == 0, "split list: %s", err.c_str ());
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
          "JSON with {)" },
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

int
main ()
{
  test_opencv_written ();
  test_hand_written ();
  test_refused ();
  test_random_files_in_shape ();
  return corecheck_summary ();
}
