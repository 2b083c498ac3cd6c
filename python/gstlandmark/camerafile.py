"""Camera files (docs/calibration.md): OpenCV FileStorage YAML or XML
with the intrinsics (``camera_matrix``, ``distortion_coefficients``,
``image_width``, ``image_height``) and the mounting (``camera_height``,
``tilt_deg``, ``roll_deg``), as ``ipmrange`` reads them. Written by
``gst-landmark calibrate`` and by the synthetic world (``synth``)."""

import os

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
    (``INFO_KEYS``) it holds.  Raises CalibrationError when the file
    cannot be read or lacks the intrinsics."""
    if not os.path.isfile(path):
        raise CalibrationError(f"{path}: no such file")
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
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    try:
        return {key: fs.getNode(key).real() for key in MOUNT_KEYS
                if not fs.getNode(key).empty()}
    finally:
        fs.release()
