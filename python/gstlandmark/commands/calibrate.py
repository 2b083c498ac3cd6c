"""``gst-landmark calibrate``: camera files for ``ipmrange``.

Three ways to describe the camera, each writing an OpenCV FileStorage
YAML file (see docs/calibration.md), and a converter:

- ``seed``: the seed's angle-linear model from a tape on a floor grid
  (camera height, blind distance, view depth, half width), equations
  (3.1)-(3.4) of the seed (docs/calibration.md and docs/ranging.md);
- ``chessboard``: intrinsics (``camera_matrix``,
  ``distortion_coefficients``) from images of a printed chessboard,
  with OpenCV's calibration;
- ``floor``: the mounting (``camera_height``, ``tilt_deg``,
  ``roll_deg``, as docs/conventions.md defines them) from one image of
  a chessboard lying flat on the floor, with the intrinsics of a file
  the ``chessboard`` command wrote;
- ``camera-info``: a camera file written out as ROS camera_info YAML
  (camera_calibration_parsers' format), for ROS tools.

The functions here raise ``CalibrationError`` for bad input; the
command-line handlers turn it into the usual ``gst-landmark: error``.
"""

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass

import cv2
import numpy as np

from ..camerafile import (INFO_KEYS, K_DIST, K_HEIGHT, K_MATRIX, K_WIDTH,
                          CalibrationError, read_camera_file, read_mounting,
                          write_camera_file, write_camera_info)
from .common import add_actions

MIN_IMAGES = 3


# ---------------------------------------------------------------------------
# Small parsers shared by the library and the command line


def parse_pair(text, what, sep="x", kind=int):
    """"9x6" -> (9, 6); raises ValueError with a readable message."""
    parts = text.lower().split(sep)
    try:
        if len(parts) != 2:
            raise ValueError
        first, second = (kind(p) for p in parts)
    except ValueError:
        raise ValueError(f"expected {what}, got {text!r}") from None
    return first, second


def _pair_type(what, sep="x", kind=int, least=None):
    """argparse type for a pair (``parse_pair``); ``least``: (the smallest
    value either may take, what the message says then)."""
    def parse(text):
        try:
            pair = parse_pair(text, what, sep=sep, kind=kind)
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
        if least is not None and min(pair) < least[0]:
            raise argparse.ArgumentTypeError(f"{least[1]}, got {text!r}")
        return pair
    return parse


_pattern_type = _pair_type(
    "COLSxROWS (inner corners), e.g. 9x6",
    least=(2, "a pattern needs at least 2x2 inner corners"))
_size_type = _pair_type("WxH in pixels, e.g. 640x480",
                        least=(2, "image size must be at least 2x2"))
_origin_type = _pair_type("X,Y in metres, e.g. 0.5,0.1", sep=",",
                          kind=float)


def _positive_type(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number, got {text!r}") from None
    if not math.isfinite(value) or value <= 0.0:
        raise argparse.ArgumentTypeError(
            f"must be a positive number, got {text!r}")
    return value


# ---------------------------------------------------------------------------
# Camera files (read and written by ..camerafile)


def _intrinsic_fields(camera):
    """The intrinsic part of a camera file, in writing order."""
    fields = {}
    for key in INFO_KEYS[:5]:
        if key in camera:
            fields[key] = camera[key]
    fields[K_WIDTH] = int(camera[K_WIDTH])
    fields[K_HEIGHT] = int(camera[K_HEIGHT])
    fields[K_MATRIX] = np.asarray(camera[K_MATRIX], dtype=np.float64)
    fields[K_DIST] = np.asarray(camera["dist"],
                                dtype=np.float64).reshape(1, -1)
    if "avg_reprojection_error" in camera:
        fields["avg_reprojection_error"] = camera["avg_reprojection_error"]
    return fields


# ---------------------------------------------------------------------------
# The seed's model


@dataclass(frozen=True)
class SeedGeometry:
    """The seed's camera from floor measurements, with the angles of its
    relations (3.1)-(3.4), in radians:

    - ``gamma``: from the vertical to the ray through the bottom row,
      ``tan(gamma) = b / h``;
    - ``alpha``: half the vertical field of view,
      ``tan(gamma + alpha) = (b + d) / h`` (the centre row sees the
      floor at ``b + d``: the optical axis);
    - ``theta``: tilt of the optical axis below the horizontal,
      ``alpha + gamma + theta = 90 deg``, so ``tan(theta) = h / (b + d)``;
    - ``beta``: half the horizontal field of view,
      ``tan(beta) = w / (b + d)``.
    """

    height: float
    blind: float
    depth: float
    half_width: float
    gamma: float
    alpha: float
    theta: float
    beta: float

    @property
    def tilt_deg(self):
        return math.degrees(self.theta)

    @property
    def vfov_deg(self):
        return math.degrees(2.0 * self.alpha)

    @property
    def hfov_deg(self):
        return math.degrees(2.0 * self.beta)

    def horizon_row(self, rows):
        """The row (fractional, counted from the top) whose ray is
        horizontal in the seed's angle-linear model; rows at or above it
        see no floor.  None when every row sees the floor."""
        top = self.gamma + 2.0 * self.alpha
        if top < math.pi / 2:
            return None
        return (rows - 1) * (1.0 - (math.pi / 2 - self.gamma)
                             / (2.0 * self.alpha))

    def floor_point(self, u, v, width, rows):
        """Seed equations (3.5) and (3.6): the floor distance ahead ``y``
        and the lateral offset ``x`` (to the right of the image centre
        column, as the seed counts it) of pixel ``(u, v)`` of a
        ``width`` x ``rows`` image.  NaN above the horizon."""
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        angle = self.gamma + 2.0 * self.alpha * (rows - 1 - v) / (rows - 1)
        with np.errstate(invalid="ignore"):
            y = np.where(angle < math.pi / 2,
                         self.height * np.tan(angle), np.nan)
        x = y * np.tan(self.beta * (2.0 * u - width + 1) / (width - 1))
        return x, y


def seed_geometry(height, blind, depth, half_width):
    """SeedGeometry from the camera height ``h``, blind distance ``b``,
    view depth ``d`` and half width ``w`` (metres).  All four must be
    positive: with ``b > 0`` the bottom row sees the floor, with
    ``d > 0`` the optical axis meets it ahead of that, and ``w > 0``
    gives a horizontal field of view."""
    names = (("--height", "camera height h", height),
             ("--blind", "blind distance b", blind),
             ("--depth", "view depth d", depth),
             ("--half-width", "half width w", half_width))
    for option, label, value in names:
        if not math.isfinite(value) or value <= 0.0:
            hint = ""
            if option == "--blind" and value == 0.0:
                hint = (" (b = 0 would put the bottom row of the image "
                        "straight down at the camera's foot)")
            elif option == "--depth":
                hint = (" (the image centre line must see the floor "
                        "beyond the blind area, or the camera sees no "
                        "floor ahead)")
            raise CalibrationError(f"{label} ({option}) must be a positive "
                                   f"number of metres, got {value:g}{hint}")
    gamma = math.atan2(blind, height)
    axis = math.atan2(blind + depth, height)      # gamma + alpha
    alpha = axis - gamma
    theta = math.pi / 2 - axis
    beta = math.atan2(half_width, blind + depth)
    return SeedGeometry(float(height), float(blind), float(depth),
                        float(half_width), gamma, alpha, theta, beta)


def seed_fields(geometry, size=None):
    """The camera file of a seed camera, in writing order."""
    fields = {"model": "angle-linear"}
    if size is not None:
        fields[K_WIDTH], fields[K_HEIGHT] = int(size[0]), int(size[1])
    fields.update({
        "camera_height": geometry.height,
        "blind_distance": geometry.blind,
        "view_depth": geometry.depth,
        "half_width": geometry.half_width,
        "tilt_deg": geometry.tilt_deg,
        "vfov_deg": geometry.vfov_deg,
        "hfov_deg": geometry.hfov_deg,
    })
    return fields


# ---------------------------------------------------------------------------
# Chessboards


def board_points(pattern, square):
    """Object points of a ``(cols, rows)`` inner-corner pattern in the
    board's own frame, in the order cv2.findChessboardCorners returns
    them: x along a row (``cols`` points), y down the rows, z = 0."""
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2)
    points = np.zeros((cols * rows, 3), dtype=np.float32)
    points[:, :2] = grid * float(square)
    return points


def find_corners(image, pattern):
    """Inner corners (N, 1, 2) float32 refined to sub-pixel, or None when
    the pattern is not found.  ``image`` is BGR or greyscale."""
    grey = image if image.ndim == 2 else cv2.cvtColor(image,
                                                      cv2.COLOR_BGR2GRAY)
    flags = (cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    found, corners = cv2.findChessboardCorners(grey, tuple(pattern),
                                               flags=flags)
    if not found or corners is None:
        return None
    # The refinement window must stay inside the squares around a corner.
    cols = pattern[0]
    pts = corners.reshape(-1, 2)
    grid = pts.reshape(-1, cols, 2)
    steps = np.concatenate([
        np.linalg.norm(np.diff(grid, axis=1), axis=2).ravel(),
        np.linalg.norm(np.diff(grid, axis=0), axis=2).ravel()])
    half = int(np.clip(0.4 * float(np.min(steps)), 2, 11))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100,
                1e-4)
    cv2.cornerSubPix(grey, corners, (half, half), (-1, -1), criteria)
    return corners


def _read_image(path, index):
    if not os.path.isfile(path):
        raise CalibrationError(f"image {index} ({path}): no such file")
    image = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise CalibrationError(f"image {index} ({path}): cannot read as an "
                               f"image")
    return image


def _pattern_text(pattern):
    return f"{pattern[0]}x{pattern[1]}"


@dataclass
class ChessboardResult:
    camera: dict            # as read_camera_file returns it
    rms: float              # RMS reprojection error, pixels
    used: list              # paths of the images used
    skipped: list           # (path, reason) of images left out
    per_image_rms: list     # RMS error of each used image, pixels


def calibrate_chessboard(paths, pattern, square, skip_missing=False,
                         zero_tangent=False, fix_k3=False,
                         min_images=MIN_IMAGES):
    """Intrinsic calibration from images of a chessboard with
    ``pattern = (cols, rows)`` inner corners and squares of ``square``
    metres.  An image where the pattern is not found is an error, or,
    with ``skip_missing``, left out; fewer than ``min_images`` usable
    images is an error.  Returns a ChessboardResult."""
    if not paths:
        raise CalibrationError("no images given")
    if square <= 0:
        raise CalibrationError(f"square size must be positive, got "
                               f"{square:g}")
    object_points, image_points, used, skipped = [], [], [], []
    size = None
    size_from = None
    board = board_points(pattern, square)
    for index, path in enumerate(paths, start=1):
        image = _read_image(path, index)
        image_size = (image.shape[1], image.shape[0])
        if size is None:
            size, size_from = image_size, (index, path)
        elif image_size != size:
            raise CalibrationError(
                f"image {index} ({path}) is {image_size[0]}x"
                f"{image_size[1]}, but image {size_from[0]} "
                f"({size_from[1]}) is {size[0]}x{size[1]}: calibrate "
                f"one camera mode at a time")
        corners = find_corners(image, pattern)
        if corners is None:
            reason = (f"pattern {_pattern_text(pattern)} not found in "
                      f"image {index} ({path})")
            if not skip_missing:
                raise CalibrationError(
                    reason + "; check --pattern (inner corners, "
                    "COLSxROWS), or use --skip-missing to leave such "
                    "images out")
            skipped.append((path, reason))
            continue
        object_points.append(board)
        image_points.append(corners)
        used.append(path)
    if len(used) < min_images:
        raise CalibrationError(
            f"too few images: {len(used)} usable, need at least "
            f"{min_images}")
    flags = 0
    if zero_tangent:
        flags |= cv2.CALIB_ZERO_TANGENT_DIST
    if fix_k3:
        flags |= cv2.CALIB_FIX_K3
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100,
                1e-12)
    try:
        rms, matrix, dist, rvecs, tvecs = cv2.calibrateCamera(
            object_points, image_points, size, None, None, flags=flags,
            criteria=criteria)
    except cv2.error as err:
        raise CalibrationError(f"OpenCV calibration failed: "
                               f"{str(err).strip()}") from None
    per_image = []
    for obj, img, rvec, tvec in zip(object_points, image_points, rvecs,
                                    tvecs):
        proj, _ = cv2.projectPoints(obj, rvec, tvec, matrix, dist)
        diff = proj.reshape(-1, 2) - img.reshape(-1, 2)
        per_image.append(float(np.sqrt(np.mean(np.sum(diff ** 2,
                                                      axis=1)))))
    camera = {
        "calibration_time": time.strftime("%a %b %d %H:%M:%S %Y"),
        "nr_of_frames": len(used),
        "board_width": int(pattern[0]),
        "board_height": int(pattern[1]),
        "square_size": float(square),
        K_WIDTH: int(size[0]), K_HEIGHT: int(size[1]),
        K_MATRIX: matrix, "dist": dist.ravel(),
        "avg_reprojection_error": float(rms),
    }
    return ChessboardResult(camera, float(rms), used, skipped, per_image)


# ---------------------------------------------------------------------------
# Mounting from a chessboard on the floor


@dataclass
class FloorResult:
    height: float           # camera centre above the floor, metres
    tilt_deg: float         # optical axis below the horizontal
    roll_deg: float         # per docs/conventions.md
    rms: float              # reprojection error of the pose, pixels
    centre_robot: tuple     # robot-frame (forward, left) of the centre
    #                         of the board's inner corners, metres


def mounting_from_up(up_camera):
    """Tilt and roll (radians) of a camera from the floor's up direction
    in camera coordinates.  With docs/conventions.md's axes the robot's
    up vector in camera coordinates is
    ``(-sin r cos t, -cos r cos t, -sin t)``."""
    up = np.asarray(up_camera, dtype=np.float64)
    up = up / np.linalg.norm(up)
    tilt = math.asin(float(np.clip(-up[2], -1.0, 1.0)))
    roll = math.atan2(-up[0], -up[1])
    return tilt, roll


def robot_to_camera_rotation(tilt, roll):
    """Rows: the camera axes x_c', y_c', z_c in the robot frame
    (docs/conventions.md), angles in radians."""
    ct, st = math.cos(tilt), math.sin(tilt)
    x_c = np.array([0.0, -1.0, 0.0])
    y_c = np.array([-st, 0.0, -ct])
    z_c = np.array([ct, 0.0, -st])
    return np.array([math.cos(roll) * x_c + math.sin(roll) * y_c,
                     -math.sin(roll) * x_c + math.cos(roll) * y_c,
                     z_c])


def floor_pose(corners, pattern, square, camera, thickness=0.0):
    """Camera height, tilt and roll from the image ``corners`` of a flat
    chessboard on the floor (``camera`` as read_camera_file returns
    it).  ``thickness`` (metres) is the board's: its top is the plane
    measured, so the floor is that much lower.  Returns a FloorResult."""
    board = board_points(pattern, square)
    matrix, dist = camera[K_MATRIX], camera["dist"]
    ok, rvec, tvec = cv2.solvePnP(board, corners, matrix, dist,
                                  flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        ok, rvec, tvec = cv2.solvePnP(board, corners, matrix, dist,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise CalibrationError("cannot find the board's pose "
                               "(cv2.solvePnP failed)")
    rvec, tvec = cv2.solvePnPRefineLM(board, corners, matrix, dist, rvec,
                                      tvec)
    proj, _ = cv2.projectPoints(board, rvec, tvec, matrix, dist)
    diff = proj.reshape(-1, 2) - corners.reshape(-1, 2)
    rms = float(np.sqrt(np.mean(np.sum(diff ** 2, axis=1))))
    rot, _ = cv2.Rodrigues(rvec)
    tvec = tvec.ravel()
    # Camera centre in the board frame; the board's z axis points up or
    # down depending on which corner the detector started from.
    centre = -rot.T @ tvec
    side = 1.0 if centre[2] > 0 else -1.0
    height = abs(float(centre[2])) + float(thickness)
    up_camera = side * rot[:, 2]
    tilt, roll = mounting_from_up(up_camera)
    if math.cos(tilt) < 1e-6:
        raise CalibrationError("the camera looks straight down; tilt and "
                               "roll are not defined (use a tilt below 90 "
                               "degrees)")
    # The centre of the inner corners (the same point whichever corner
    # the detector started from) in the robot frame: camera coordinates
    # to robot coordinates with the transpose of the robot-to-camera
    # rotation, about the camera centre at (0, 0, height).
    middle = rot @ board.mean(axis=0).astype(np.float64) + tvec
    robot = robot_to_camera_rotation(tilt, roll).T @ middle
    return FloorResult(height, math.degrees(tilt), math.degrees(roll), rms,
                       (float(robot[0]), float(robot[1])))


def calibrate_floor(path, pattern, square, camera, thickness=0.0):
    """FloorResult from the image at ``path`` of a chessboard on the
    floor, seen by ``camera`` (as read_camera_file returns it)."""
    image = _read_image(path, 1)
    width, height = image.shape[1], image.shape[0]
    if (width, height) != (camera[K_WIDTH], camera[K_HEIGHT]):
        raise CalibrationError(
            f"{path} is {width}x{height} but the camera file was "
            f"calibrated at {camera[K_WIDTH]}x{camera[K_HEIGHT]}: use an "
            f"image of the same camera mode")
    corners = find_corners(image, pattern)
    if corners is None:
        raise CalibrationError(
            f"pattern {_pattern_text(pattern)} not found in image 1 "
            f"({path}); check --pattern (inner corners, COLSxROWS) and "
            f"that the whole board is in view")
    return floor_pose(corners, pattern, square, camera, thickness)


def floor_fields(camera, result):
    """The camera file with the mounting added, in writing order."""
    fields = _intrinsic_fields(camera)
    fields["camera_height"] = result.height
    fields["tilt_deg"] = result.tilt_deg
    fields["roll_deg"] = result.roll_deg
    fields["floor_reprojection_error"] = result.rms
    return fields


def scene_camera_file(scene_json, path):
    """Writes the camera of a synthetic clip (its ``scene.json``) as
    `gst-landmark calibrate floor` writes a real one: intrinsics, no
    distortion, the mounting; returns ``path``."""
    with open(scene_json, encoding="utf-8") as f:
        cam = json.load(f)["camera"]
    camera = {
        K_WIDTH: cam["width"], K_HEIGHT: cam["height"],
        K_MATRIX: [[cam["fx"], 0.0, cam["cx"]], [0.0, cam["fy"], cam["cy"]],
                   [0.0, 0.0, 1.0]],
        "dist": [0.0] * 5,
    }
    mounting = FloorResult(cam["height_m"], cam["tilt_deg"],
                           cam["roll_deg"], 0.0, (0.0, 0.0))
    write_camera_file(str(path), floor_fields(camera, mounting))
    return str(path)


# ---------------------------------------------------------------------------
# Command line


def _fail(err):
    """Report bad input as ``gst-landmark: error: ...``; exit status 1."""
    print(f"gst-landmark: error: {err}", file=sys.stderr)
    return 1


def _handle_seed(args):
    try:
        geometry = seed_geometry(args.height, args.blind, args.depth,
                                 args.half_width)
        write_camera_file(args.output, seed_fields(geometry, args.size))
    except CalibrationError as err:
        return _fail(err)
    print(f"tilt      {geometry.tilt_deg:8.3f} deg below horizontal")
    print(f"vfov      {geometry.vfov_deg:8.3f} deg "
          f"(alpha = {math.degrees(geometry.alpha):.3f})")
    print(f"hfov      {geometry.hfov_deg:8.3f} deg "
          f"(beta = {math.degrees(geometry.beta):.3f})")
    print(f"gamma     {math.degrees(geometry.gamma):8.3f} deg from the "
          f"vertical to the bottom row")
    top = math.degrees(geometry.gamma + 2.0 * geometry.alpha)
    if args.size is not None:
        horizon = geometry.horizon_row(args.size[1])
        if horizon is not None:
            print(f"note: rows 0..{math.floor(horizon)} of "
                  f"{args.size[1]} are at or above the horizon (no floor)")
    elif top >= 90.0:
        print(f"note: the top row is {top - 90.0:.3f} deg above the "
              f"horizon; rows near the top see no floor")
    print(f"wrote {args.output}")
    return 0


def _handle_chessboard(args):
    try:
        result = calibrate_chessboard(
            args.images, args.pattern, args.square,
            skip_missing=args.skip_missing, zero_tangent=args.zero_tangent,
            fix_k3=args.fix_k3)
        write_camera_file(args.output, _intrinsic_fields(result.camera))
    except CalibrationError as err:
        return _fail(err)
    for path, reason in result.skipped:
        print(f"warning: {reason}; left out", file=sys.stderr)
    camera = result.camera
    matrix = camera[K_MATRIX]
    print(f"images    {len(result.used)} used, {len(result.skipped)} "
          f"left out")
    for path, err in zip(result.used, result.per_image_rms):
        print(f"  {err:7.3f} px  {path}")
    print(f"fx {matrix[0, 0]:.3f}  fy {matrix[1, 1]:.3f}  "
          f"cx {matrix[0, 2]:.3f}  cy {matrix[1, 2]:.3f}")
    print("distortion " + " ".join(f"{k:.6g}" for k in camera["dist"]))
    print(f"RMS reprojection error {result.rms:.4f} px")
    print(f"wrote {args.output}")
    return 0


def _handle_floor(args):
    try:
        camera = read_camera_file(args.camera)
        result = calibrate_floor(args.image, args.pattern, args.square,
                                 camera, args.thickness)
        write_camera_file(args.output, floor_fields(camera, result))
    except CalibrationError as err:
        return _fail(err)
    print(f"height    {result.height:8.4f} m")
    print(f"tilt      {result.tilt_deg:8.3f} deg below horizontal")
    print(f"roll      {result.roll_deg:8.3f} deg")
    print(f"RMS reprojection error {result.rms:.4f} px")
    fwd, left = result.centre_robot
    print(f"board centre at forward {fwd:.4f} m, left {left:.4f} m of "
          f"the camera's floor point")
    if args.origin is not None:
        dx, dy = args.origin[0] - fwd, args.origin[1] - left
        print(f"camera's floor point at forward {dx:.4f} m, left "
              f"{dy:.4f} m of the point --origin is measured from")
    print(f"wrote {args.output}")
    return 0


def _handle_camera_info(args):
    try:
        camera = read_camera_file(args.camera)
        mounting = read_mounting(args.camera)
        name = args.name or camera.get("camera_name") or "camera"
        write_camera_info(args.output, camera, name, mounting)
    except CalibrationError as err:
        return _fail(err)
    matrix = camera[K_MATRIX]
    print(f"camera    {name}, {camera[K_WIDTH]}x{camera[K_HEIGHT]}")
    print(f"fx {matrix[0, 0]:.3f}  fy {matrix[1, 1]:.3f}  "
          f"cx {matrix[0, 2]:.3f}  cy {matrix[1, 2]:.3f}")
    if mounting:
        print("mounting  " + ", ".join(f"{key} {value:g}"
                                       for key, value in mounting.items()))
    print(f"wrote {args.output}")
    return 0


def _camera_name_type(text):
    if not text or not all(c.isascii() and (c.isalnum() or c in "_./-")
                           for c in text):
        raise argparse.ArgumentTypeError(
            f"a camera name takes letters, digits and _ - . /, got {text!r}")
    return text


def _add_output_option(parser, help="camera file to write"):
    parser.add_argument("-o", "--output", required=True, metavar="OUT.yml",
                        help=help)


def _add_board_options(parser, pattern_help):
    """--pattern and --square, the board both chessboard actions read."""
    parser.add_argument("--pattern", type=_pattern_type, required=True,
                        metavar="COLSxROWS", help=pattern_help)
    parser.add_argument("--square", type=_positive_type, required=True,
                        metavar="METRES", help="side of one square (m)")


def add_calibrate_parser(subparsers):
    parser = subparsers.add_parser(
        "calibrate", help="write camera files for ipmrange",
        description="Write camera files (OpenCV FileStorage YAML) for "
                    "ipmrange: the seed's model from floor measurements, "
                    "intrinsics from chessboard images, or the mounting "
                    "from a chessboard on the floor; or a camera file as "
                    "ROS camera_info YAML.")
    actions = add_actions(parser)

    seed = actions.add_parser(
        "seed", help="the seed's camera model from floor measurements",
        description="The seed's angle-linear camera model (its equations "
                    "3.1-3.4): tilt and fields of view from the camera "
                    "height h, the blind distance b (camera foot to the "
                    "floor seen at the bottom row), the view depth d "
                    "(from there to the floor seen at the image centre "
                    "line) and the half width w of the floor seen at "
                    "b + d.  All in metres.")
    seed.add_argument("--height", type=float, required=True, metavar="H",
                      help="camera height above the floor h (m)")
    seed.add_argument("--blind", type=float, required=True, metavar="B",
                      help="blind distance b (m)")
    seed.add_argument("--depth", type=float, required=True, metavar="D",
                      help="view depth d (m)")
    seed.add_argument("--half-width", type=float, required=True,
                      metavar="W", help="half width w of the floor seen "
                                        "at b + d (m)")
    seed.add_argument("--size", type=_size_type, metavar="WxH",
                      help="image size in pixels, written to the file")
    _add_output_option(seed)
    seed.set_defaults(handler=_handle_seed, parser=seed)

    board = actions.add_parser(
        "chessboard", help="intrinsics from chessboard images",
        description="""Intrinsic calibration (camera_matrix,
            distortion_coefficients) from images of a flat chessboard seen
            from several directions, with OpenCV.  Prints the RMS
            reprojection error.""")
    board.add_argument("images", nargs="+", metavar="IMAGE",
                       help=f"chessboard images (at least {MIN_IMAGES}; "
                            f"10-20 from varied directions work best)")
    _add_board_options(board, "inner corners per row and per column, e.g. "
                              "9x6 for a board of 10x7 squares")
    board.add_argument("--skip-missing", action="store_true",
                       help="leave out images where the pattern is not "
                            "found instead of failing")
    board.add_argument("--zero-tangent", action="store_true",
                       help="fix the tangential distortion p1, p2 at 0")
    board.add_argument("--fix-k3", action="store_true",
                       help="fix the radial coefficient k3 at 0 (few "
                            "images, mild lenses)")
    _add_output_option(board)
    board.set_defaults(handler=_handle_chessboard, parser=board)

    floor = actions.add_parser(
        "floor", help="camera height, tilt and roll from a floor board",
        description="""Camera height, tilt (below horizontal) and roll (per
            docs/conventions.md) from one image of a chessboard lying flat
            on the floor, with the intrinsics of --camera.  Writes the
            camera file with the mounting added.""")
    floor.add_argument("image", metavar="IMAGE",
                       help="image of the board on the floor")
    _add_board_options(floor, "inner corners per row and per column")
    floor.add_argument("--camera", required=True, metavar="CAMERA.yml",
                       help="camera file with the intrinsics")
    floor.add_argument("--thickness", type=float, default=0.0,
                       metavar="METRES",
                       help="board thickness, added to the height "
                            "(default 0)")
    floor.add_argument("--origin", type=_origin_type, metavar="X,Y",
                       help="where you measured the centre of the board "
                            "(of its inner corners; forward, left, m) "
                            "from a reference point on the robot: "
                            "prints the camera's floor point relative "
                            "to it")
    _add_output_option(floor, "camera file to write (may be --camera)")
    floor.set_defaults(handler=_handle_floor, parser=floor)

    info = actions.add_parser(
        "camera-info", help="a camera file as ROS camera_info YAML",
        description="""Write a pinhole camera file (what chessboard or
            floor wrote, or a camera_info file) as ROS camera_info YAML, as
            camera_calibration_parsers writes it: image size, camera_matrix,
            distortion_model (plumb_bob, or rational_polynomial for 8
            coefficients), distortion_coefficients, an identity
            rectification_matrix and projection_matrix [K | 0]. The
            mounting (camera_height, tilt_deg, roll_deg) goes along under
            its own keys, which ROS ignores and ipmrange reads.""")
    info.add_argument("camera", metavar="CAMERA.yml",
                      help="camera file to convert")
    info.add_argument("--name", type=_camera_name_type, metavar="NAME",
                      help="camera_name (default: the file's own, or "
                           "'camera')")
    _add_output_option(info, "camera_info YAML file to write")
    info.set_defaults(handler=_handle_camera_info, parser=info)
