"""Camera files (docs/calibration.md): OpenCV FileStorage YAML or XML
with the intrinsics (``camera_matrix``, ``distortion_coefficients``,
``image_width``, ``image_height``) and the mounting (``camera_height``,
``tilt_deg``, ``roll_deg``), as ``ipmrange`` reads them. Written by
``gst-landmark calibrate`` and by the synthetic world (``synth``).

ROS camera_info YAML files (camera_calibration_parsers' format, section
"ROS camera_info" of docs/calibration.md) are camera files too: read
with the checks and messages of the elements' loader
(plugins/landmark/core/geometry/camerafileshape.cpp, roscamerainfo.cpp), written
by ``write_camera_info``."""

import math
import os
import re

import cv2
import numpy as np

# Keys of a camera file.  The first four are the names of OpenCV's
# calibration sample and of gst-plugins-bad's cameracalibrate.
K_MATRIX = "camera_matrix"
K_DIST = "distortion_coefficients"
K_WIDTH = "image_width"
K_HEIGHT = "image_height"

# Calibration details kept when a file is read and written again
# (names of OpenCV's calibration sample), in the order they are written.
INFO_KEYS = ("calibration_time", "nr_of_frames", "board_width",
             "board_height", "square_size", "avg_reprojection_error")


class CalibrationError(Exception):
    """A camera file or calibration input that cannot be used; the
    message says what is wrong."""


def read_camera_file(path):
    """A camera file as a dict: ``camera_matrix`` (3x3), ``dist`` (1-D),
    ``image_width``, ``image_height`` and whichever calibration details
    (``INFO_KEYS``) it holds; of a ROS camera_info file, also its
    ``distortion_model`` and ``camera_name``.  Raises CalibrationError
    when the file cannot be read or lacks the intrinsics."""
    if not os.path.isfile(path):
        raise CalibrationError(f"{path}: no such file")
    text = _camera_info_text(path)
    if text is not None:
        return _read_camera_info(path, text)[0]
    try:
        fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    except cv2.error:
        fs = None
    if fs is None or not fs.isOpened():
        raise CalibrationError(f"{path}: not an OpenCV FileStorage file "
                               f"(YAML or XML)")
    try:
        matrix = fs.getNode(K_MATRIX).mat()
        dist = fs.getNode(K_DIST).mat()
        if matrix is None or matrix.shape != (3, 3):
            raise CalibrationError(
                f"{path}: no 3x3 '{K_MATRIX}' (write one with "
                f"'gst-landmark calibrate chessboard')")
        if dist is None or dist.size == 0:
            dist = np.zeros(5)
        dist = np.asarray(dist, dtype=np.float64).ravel()
        if dist.size not in (4, 5, 8, 12, 14):
            raise CalibrationError(
                f"{path}: '{K_DIST}' has {dist.size} values; OpenCV "
                f"takes 4, 5, 8, 12 or 14")
        camera = {K_MATRIX: np.asarray(matrix, dtype=np.float64),
                  "dist": dist}
        for key in (K_WIDTH, K_HEIGHT):
            node = fs.getNode(key)
            if node.empty():
                raise CalibrationError(f"{path}: no '{key}'")
            camera[key] = int(node.real())
        for key in INFO_KEYS:
            node = fs.getNode(key)
            if node.empty():
                continue
            if node.isString():
                camera[key] = node.string()
            elif node.isInt():
                camera[key] = int(node.real())
            else:
                camera[key] = node.real()
    finally:
        fs.release()
    if camera[K_MATRIX][0, 0] <= 0 or camera[K_MATRIX][1, 1] <= 0:
        raise CalibrationError(f"{path}: focal lengths must be positive")
    return camera


def write_camera_file(path, fields):
    """Write ``fields`` (an ordered dict: numbers, strings, arrays) as an
    OpenCV FileStorage file; the suffix (.yml/.yaml/.xml) picks the
    format.  Raises CalibrationError when it cannot be written."""
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise CalibrationError(f"{path}: cannot write: no directory "
                               f"{directory}")
    try:
        fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
        opened = fs.isOpened()
    except cv2.error:
        opened = False
    if not opened:
        raise CalibrationError(f"{path}: cannot write")
    try:
        for key, value in fields.items():
            if isinstance(value, np.ndarray):
                fs.write(key, np.asarray(value, dtype=np.float64))
            elif isinstance(value, (bool, np.bool_)):
                fs.write(key, int(value))
            elif isinstance(value, (int, np.integer)):
                fs.write(key, int(value))
            elif isinstance(value, (float, np.floating)):
                fs.write(key, float(value))
            else:
                fs.write(key, str(value))
    finally:
        fs.release()


# The mounting keys `gst-landmark calibrate floor` writes (ipmrange's
# camera-height, tilt and roll).
MOUNT_KEYS = ("camera_height", "tilt_deg", "roll_deg")


def read_mounting(path):
    """The mounting of a camera file (``MOUNT_KEYS`` it holds, numbers) as
    a dict; empty when it has none. read_camera_file checks the file."""
    text = _camera_info_text(path)
    if text is not None:
        return _read_camera_info(path, text)[1]
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    try:
        return {key: fs.getNode(key).real() for key in MOUNT_KEYS
                if not fs.getNode(key).empty()}
    finally:
        fs.release()


# ---------------------------------------------------------------------------
# ROS camera_info YAML: the checks and messages of the elements' loader
# (camerafileshape.cpp: CameraInfoShape; roscamerainfo.cpp).

# The keys only a camera_info file has
INFO_ONLY_KEYS = ("camera_name", "camera_matrix", "distortion_model",
                  "distortion_coefficients", "rectification_matrix",
                  "projection_matrix")
# ROS's distortion models the elements read: number of coefficients
DISTORTION_MODELS = {"plumb_bob": 5, "rational_polynomial": 8}
_MODEL_COEFFICIENTS = {5: "k1 k2 p1 p2 k3", 8: "k1 k2 p1 p2 k3 k4 k5 k6"}
_NEEDS = ("a ROS camera_info file needs image_width, image_height, "
          "camera_matrix and distortion_coefficients")
_INFO_HINT = ("a ROS camera_info file holds top-level keys with a number, "
              "a word or a quoted text, or a matrix as indented rows, cols "
              "and data lines, as camera_calibration_parsers writes them")
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_NAME = re.compile(r"[A-Za-z0-9_./-]+\Z")
_SPECIAL = (".nan", ".NaN", ".inf", ".Inf")
MAX_IMAGE_SIZE = 16384          # camerafile.h kMaxCameraImageSize


def _is_number(s):
    """12, -0.25, 1., .5, 1e-3, .nan, -.inf (camerafileshape.cpp)"""
    i = 1 if s[:1] in ("-", "+") else 0
    if s[i:] in _SPECIAL:
        return True
    m = re.match(r"([0-9]*)(?:\.([0-9]*))?(?:[eE][-+]?([0-9]*))?\Z", s[i:])
    if not m:
        return False
    digits = len(m.group(1)) + len(m.group(2) or "")
    if digits == 0 or digits > 40:
        return False
    exponent = m.group(3)
    return exponent is None or 1 <= len(exponent) <= 3


def _is_quoted(s):
    return (len(s) >= 2 and s[0] == '"' and s[-1] == '"' and
            not any(ord(c) < 0x20 or ord(c) == 0x7f or c in '"\\'
                    for c in s[1:-1]))


def _is_word(s):
    return (bool(re.match(r"[A-Za-z_][A-Za-z0-9_-]*\Z", s)) and
            not s.endswith("-") and "--" not in s)


def _is_scalar(s):
    return _is_number(s) or _is_word(s) or _is_quoted(s)


def _is_count(s):
    return 0 < len(s) <= 9 and s.isdigit() and s.isascii()


def _is_short_whole(s):
    """a whole number OpenCV reads as a 32-bit int: at most 9 digits"""
    digits = s[1:] if s[:1] in ("-", "+") else s
    return not (digits.isdigit() and digits.isascii()) or len(digits) <= 9


def _is_camera_name(s):
    if _is_quoted(s):
        return True
    if len(s) >= 2 and s[0] == "'" and s[-1] == "'":
        return all(c == " " or _NAME.match(c) for c in s[1:-1])
    return bool(_NAME.match(s))


def _trimmed(s):
    return s.strip(" \t\r\n")


def looks_like_camera_info(text):
    """True when ``text`` does not start as an OpenCV file does (%YAML,
    <?xml, {) and has, at the start of a line, a key only a ROS
    camera_info file has (``INFO_ONLY_KEYS``)."""
    if text.startswith(("%YAML", "<?xml", "{")):
        return False
    return any(text.startswith(key + ":") or f"\n{key}:" in text
               for key in INFO_ONLY_KEYS)


def _camera_info_text(path):
    """The text of the file at ``path`` when it is a camera_info file,
    else None (an OpenCV file, or one that cannot be read as text)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return None
    text = data.decode("utf-8", errors="replace")
    return text if looks_like_camera_info(text) else None


class _InfoShape:
    """camera_info YAML line by line; ``check`` returns the text OpenCV's
    FileStorage parses (the header prepended, the --- line and the
    camera_name line left empty) and the camera_name, or raises
    CalibrationError (camerafileshape.cpp: CameraInfoShape)."""

    def __init__(self, path):
        self.path = path
        self.n = 0
        self.keys, self.fields = set(), set()
        self.block_key, self.block_line = "", 0
        self.block_indent = self.list_indent = 0
        self.list_open = self.need_item = False
        self.items = 0
        self.name = None

    def fail(self, what, line=None):
        raise CalibrationError(f"{self.path}: line "
                               f"{self.n if line is None else line}: {what}")

    def check(self, text):
        lines = text.split("\n")
        if lines and lines[-1] == "":
            lines.pop()
        out = ["%YAML:1.0", "---"]
        for raw in lines:
            self.n += 1
            line = raw[:-1] if raw.endswith("\r") else raw
            line = line.rstrip(" ")
            out.append(raw if self.line(line) else "")
        if self.list_open:
            self.fail(f"{self.block_key}: the file ends inside its data "
                      f"list")
        self.end_block()
        return "\n".join(out) + "\n", self.name

    def line(self, line):
        """Checks one line; False when it is left out of OpenCV's text."""
        if self.n == 1 and line == "---":
            return False
        if "\t" in line:
            self.fail("a tab (YAML indents with spaces)")
        if "%" in line:
            self.fail("'%' (OpenCV's parser, which reads the file, does not "
                      "end on it)")
        stripped = line.lstrip(" ")
        if not stripped:
            return True
        indent = len(line) - len(stripped)
        if self.list_open:
            if stripped[0] == "#":
                self.fail(f"{self.block_key}: a comment inside its data "
                          f"list")
            if indent < self.list_indent:
                self.fail(f"{self.block_key}: a data list continued on the "
                          f"next line must be indented at least 2 spaces "
                          f"more than `data:`")
            self.feed(line, indent)
            return True
        if stripped[0] == "#":
            return True
        if indent == 0:
            self.end_block()
            return self.top(line)
        if not self.block_key:
            self.fail(f"unexpected indentation; {_INFO_HINT}")
        self.field(line, indent)
        return True

    def top(self, line):
        colon = line.find(":")
        key = line[:colon] if colon >= 0 else line
        if colon < 0 or not _KEY.match(key):
            self.fail(f"expected `key: value`; {_INFO_HINT}")
        if key in self.keys:
            self.fail(f"{key} appears twice")
        self.keys.add(key)
        if colon + 1 == len(line):
            if key == "camera_name":
                self.name = ""
                return False
            self.block_key, self.block_line = key, self.n
            self.block_indent = 0
            self.fields = set()
            return True
        if line[colon + 1] != " ":
            self.fail(f"{key}: expected a space after `{key}:`")
        value = _trimmed(line[colon + 1:])
        if key == "camera_name":
            if not _is_camera_name(value):
                self.fail(f"camera_name: `{value}` is not a name (letters, "
                          f"digits, _ - . /) or a quoted text")
            self.name = value[1:-1] if value[0] in "'\"" else value
            return False
        if value == "!!opencv-matrix":
            self.fail(f"{key}: an opencv-matrix in a file without OpenCV's "
                      f"%YAML:1.0 header (an OpenCV file starts with it; a "
                      f"ROS camera_info matrix is indented rows, cols and "
                      f"data lines)")
        if value[0] in "[{":
            self.fail(f"{key}: `{value[:40]}`: {_INFO_HINT}")
        if not _is_scalar(value):
            self.fail(f"{key}: `{value}` is not a number, a word or a "
                      f"quoted text")
        if not _is_short_whole(value):
            self.fail(f"{key}: `{value}` is a whole number of more than 9 "
                      f"digits (OpenCV does not read it exactly)")
        return True

    def field(self, line, indent):
        key = self.block_key
        if self.block_indent == 0:
            self.block_indent = indent
        elif indent != self.block_indent:
            self.fail(f"{key}: its rows, cols and data lines must be "
                      f"indented alike")
        colon = line.find(":", indent)
        name = line[indent:colon] if colon >= 0 else ""
        if name not in ("rows", "cols", "data"):
            self.fail(f"{key}: expected `rows: `, `cols: ` or `data: ` (a "
                      f"camera_info matrix)")
        if name in self.fields:
            self.fail(f"{key}: {name} appears twice")
        self.fields.add(name)
        if colon + 1 >= len(line) or line[colon + 1] != " ":
            self.fail(f"{key}: expected a value after `{name}: `")
        value = _trimmed(line[colon + 1:])
        if name == "data":
            if value[0] != "[":
                self.fail(f"{key}: data must be a list of numbers, "
                          f"`data: [ ... ]`, starting on its line")
            self.list_indent = indent + 2
            self.feed(line, line.find("[", colon))
            return
        if not _is_count(value):
            self.fail(f"{key}: {name} `{value}` is not a whole number")

    def end_block(self):
        key = self.block_key
        if not key:
            return
        self.block_key = ""
        if not self.fields:
            self.fail(f"{key}: expected a value after `{key}:`, or indented "
                      f"rows, cols and data lines", self.block_line)
        missing = [f for f in ("rows", "cols", "data")
                   if f not in self.fields]
        if missing:
            self.fail(f"{key}: a matrix needs rows, cols and data; no "
                      f"{', '.join(missing)}", self.block_line)

    def feed(self, line, i):
        """numbers separated by commas between [ and ] (NumberList)"""
        key = self.block_key
        if not self.list_open:
            self.list_open, self.need_item, self.items = True, True, 0
            i += 1
        while True:
            while i < len(line) and line[i] == " ":
                i += 1
            if i == len(line):
                if not self.need_item:
                    self.fail(f"{key}: a list line must end with a comma "
                              f"or ]")
                return
            if line[i] == "]":
                if self.need_item and self.items > 0:
                    self.fail(f"{key}: a comma before ]")
                self.list_open = False
                if i + 1 != len(line):
                    self.fail(f"{key}: text after the list's ]")
                return
            if not self.need_item:
                if line[i] != ",":
                    self.fail(f"{key}: expected a comma between numbers")
                i += 1
                self.need_item = True
                continue
            end = i
            while end < len(line) and line[end] not in ", ]":
                end += 1
            item = line[i:end]
            if not _is_number(item):
                self.fail(f"{key}: `{item}` in its list is not a number")
            if not _is_short_whole(item):
                self.fail(f"{key}: `{item}` in its list is a whole number "
                          f"of more than 9 digits (OpenCV does not read it "
                          f"exactly; write it with a decimal point)")
            self.items += 1
            self.need_item = False
            i = end


def _info_matrix(fs, path, key, want=None):
    """The rows x cols numbers under ``key`` as an array of that shape
    (roscamerainfo.cpp read_matrix)."""
    node = fs.getNode(key)
    # (cv2's getNode asserts on a node that is no map)
    rows, cols, data = (node.getNode(k) if node.isMap() else None
                        for k in ("rows", "cols", "data"))
    if not (node.isMap() and rows.isInt() and cols.isInt() and
            data.isSeq()):
        raise CalibrationError(f"{path}: {key} is not a matrix (indented "
                               f"rows, cols and data lines)")
    r, c = int(rows.real()), int(cols.real())
    if data.size() != r * c:
        raise CalibrationError(f"{path}: {key}: data has {data.size()} "
                               f"values, rows x cols is {r}x{c}")
    if want is not None and (r, c) != want:
        raise CalibrationError(f"{path}: {key} is {r}x{c}, not "
                               f"{want[0]}x{want[1]}")
    values = []
    for i in range(data.size()):
        item = data.at(i)
        x = item.real() if item.isInt() or item.isReal() else math.nan
        if not math.isfinite(x):
            raise CalibrationError(f"{path}: {key}: its data are not all "
                                   f"finite numbers")
        values.append(x)
    return np.array(values, dtype=np.float64).reshape(r, c)


def _info_real(fs, path, key):
    """A finite number under ``key``, None when absent (camerafile.cpp
    read_real)."""
    node = fs.getNode(key)
    if node.empty():
        return None
    if not (node.isInt() or node.isReal()):
        raise CalibrationError(f"{path}: {key} is not a number")
    value = node.real()
    if not math.isfinite(value):
        raise CalibrationError(f"{path}: {key} is not finite")
    return value


def _read_camera_info(path, text):
    """(camera, mounting) of the camera_info file at ``path`` holding
    ``text``: camera as read_camera_file returns it (with
    ``distortion_model`` and, when the file has one, ``camera_name``),
    mounting as read_mounting does.  The checks and messages of the
    elements' loader, in its order."""
    if any(ord(c) < 0x20 and c not in "\n\r\t" or ord(c) == 0x7f
           for c in text):
        raise CalibrationError(f"{path}: control characters in a camera "
                               f"file")
    if "\ufffd" in text:
        raise CalibrationError(f"{path}: not UTF-8 text")
    opencv_text, name = _InfoShape(path).check(text)
    try:
        fs = cv2.FileStorage(opencv_text, cv2.FILE_STORAGE_READ |
                             cv2.FILE_STORAGE_MEMORY)
    except cv2.error as err:
        raise CalibrationError(f"{path}: cannot parse the calibration "
                               f"file: {str(err).strip()}") from None
    try:
        camera = {}
        for key in (K_WIDTH, K_HEIGHT):
            node = fs.getNode(key)
            if node.empty():
                raise CalibrationError(f"{path}: no {key} ({_NEEDS})")
            if not node.isInt():
                raise CalibrationError(f"{path}: {key} is not a whole "
                                       f"number")
            camera[key] = int(node.real())
        width, height = camera[K_WIDTH], camera[K_HEIGHT]
        if not (0 < width <= MAX_IMAGE_SIZE and
                0 < height <= MAX_IMAGE_SIZE):
            raise CalibrationError(
                f"{path}: image_width and image_height must be within "
                f"1..{MAX_IMAGE_SIZE}, got {width}x{height}")
        if fs.getNode(K_MATRIX).empty():
            raise CalibrationError(f"{path}: no {K_MATRIX} ({_NEEDS})")
        k = _info_matrix(fs, path, K_MATRIX, (3, 3))
        if not (k[0, 0] > 0 and k[1, 1] > 0) or k[1, 0] != 0 or \
                k[2, 0] != 0 or k[2, 1] != 0 or k[2, 2] != 1.0:
            raise CalibrationError(f"{path}: camera_matrix is not a camera "
                                   f"matrix (fx, fy > 0, last row 0 0 1)")
        model = "plumb_bob"         # ROS reads a file without it so
        node = fs.getNode("distortion_model")
        if not node.empty():
            if not node.isString():
                raise CalibrationError(f"{path}: distortion_model is not a "
                                       f"name (plumb_bob or "
                                       f"rational_polynomial)")
            model = node.string()
        if model == "equidistant":
            raise CalibrationError(
                f"{path}: distortion_model equidistant (the fisheye model) "
                f"is not supported: the elements have no fisheye camera "
                f"model (calibrate the camera with plumb_bob or "
                f"rational_polynomial)")
        if model not in DISTORTION_MODELS:
            raise CalibrationError(f"{path}: unknown distortion_model "
                                   f"'{model}' (expected plumb_bob or "
                                   f"rational_polynomial)")
        if fs.getNode(K_DIST).empty():
            raise CalibrationError(f"{path}: no {K_DIST} ({_NEEDS})")
        dist = _info_matrix(fs, path, K_DIST).ravel()
        want = DISTORTION_MODELS[model]
        if dist.size and dist.size != want:
            raise CalibrationError(
                f"{path}: distortion_coefficients: {model} takes {want} "
                f"({_MODEL_COEFFICIENTS[want]}), has {dist.size}")
        if not fs.getNode("rectification_matrix").empty():
            _info_matrix(fs, path, "rectification_matrix", (3, 3))
        if not fs.getNode("projection_matrix").empty():
            _info_matrix(fs, path, "projection_matrix", (3, 4))
        height = _info_real(fs, path, "camera_height")
        if height is not None and not height > 0:
            raise CalibrationError(f"{path}: camera_height must be "
                                   f"positive (metres), got {height:g}")
        tilt = _info_real(fs, path, "tilt_deg")
        roll = _info_real(fs, path, "roll_deg")
        if tilt is not None and not -90 <= tilt <= 90:
            raise CalibrationError(f"{path}: tilt_deg must be within "
                                   f"[-90, 90] degrees, got {tilt:g}")
        mounting = {key: value for key, value in zip(
            MOUNT_KEYS, (height, tilt, roll)) if value is not None}
    finally:
        fs.release()
    camera.update({K_MATRIX: k, "dist": dist if dist.size else np.zeros(5),
                   "distortion_model": model})
    if name is not None:
        camera["camera_name"] = name
    return camera, mounting


def is_camera_info_file(path):
    """True when the file at ``path`` is (meant as) a ROS camera_info
    file: ``looks_like_camera_info`` of its text."""
    return _camera_info_text(path) is not None


def _info_number(value):
    """A finite number as the shortest text that reads back to it, with
    a decimal point (1.0e-05, not 1e-05: YAML 1.1 readers such as PyYAML,
    which ROS's Python tools use, read the latter as a string)."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(value)
    text = repr(value)
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:
        text = f"{mantissa}.0e{exponent}"
    return text


def camera_info_text(camera, name="camera", mounting=None):
    """``camera`` (as read_camera_file returns it: intrinsics, image
    size, distortion) as ROS camera_info YAML, laid out as
    camera_calibration_parsers writes it: ``distortion_model`` plumb_bob
    for 4 or 5 coefficients (k3 = 0 added), rational_polynomial for 8
    (or more, when those past the eighth are 0); ``rectification_matrix``
    the identity, ``projection_matrix`` [K | 0] (the writer does not
    rectify).  ``mounting`` (``MOUNT_KEYS`` values) is added under our
    keys, which ROS's readers ignore.  Raises CalibrationError for what
    camera_info cannot hold."""
    if not _NAME.match(name or ""):
        raise CalibrationError(f"camera name {name!r}: use letters, digits "
                               f"and _ - . / (ROS's camera_info_manager "
                               f"names)")
    k = np.asarray(camera[K_MATRIX], dtype=np.float64)
    dist = [float(d) for d in np.asarray(camera["dist"]).ravel()]
    if len(dist) > 8 and not any(dist[8:]):
        dist = dist[:8]
    if len(dist) == 4:
        dist.append(0.0)
    if len(dist) not in (5, 8):
        raise CalibrationError(
            f"{len(dist)} distortion coefficients have no ROS distortion "
            f"model: camera_info takes plumb_bob (5: k1 k2 p1 p2 k3) or "
            f"rational_polynomial (8: k1 k2 p1 p2 k3 k4 k5 k6)")
    p = np.hstack([k, np.zeros((3, 1))])

    def matrix(key, values, rows, cols):
        return [f"{key}:", f"  rows: {rows}", f"  cols: {cols}",
                "  data: [" + ", ".join(_info_number(v) for v in values)
                + "]"]

    try:
        lines = [f"{K_WIDTH}: {int(camera[K_WIDTH])}",
                 f"{K_HEIGHT}: {int(camera[K_HEIGHT])}",
                 f"camera_name: {name}"]
        lines += matrix(K_MATRIX, k.ravel(), 3, 3)
        lines.append("distortion_model: " +
                     ("plumb_bob" if len(dist) == 5 else
                      "rational_polynomial"))
        lines += matrix(K_DIST, dist, 1, len(dist))
        lines += matrix("rectification_matrix", np.eye(3).ravel(), 3, 3)
        lines += matrix("projection_matrix", p.ravel(), 3, 4)
        for key in MOUNT_KEYS:
            if mounting and key in mounting:
                lines.append(f"{key}: {_info_number(mounting[key])}")
    except ValueError:
        raise CalibrationError("the camera has a value that is not a finite "
                               "number") from None
    return "\n".join(lines) + "\n"


def write_camera_info(path, camera, name="camera", mounting=None):
    """Writes ``camera_info_text(camera, name, mounting)`` to ``path``.
    Raises CalibrationError when it cannot be written."""
    text = camera_info_text(camera, name, mounting)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise CalibrationError(f"{path}: cannot write: no directory "
                               f"{directory}")
    try:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    except OSError as err:
        raise CalibrationError(f"{path}: cannot write: "
                               f"{err.strerror}") from None
