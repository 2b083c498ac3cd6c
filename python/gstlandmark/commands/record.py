"""``gst-landmark record``: the chain's results as an MCAP file that
robotics tools open (Foxglove Studio, ``ros2 bag`` with the MCAP storage
plugin), with ROS 2 message schemas.

Channels (docs/record.md), every one a ROS 2 message type with its
definition (ros2msg) in the file, CDR-encoded: the overlay and the camera
images (``sensor_msgs/msg/CompressedImage``), ``sensor_msgs/msg/CameraInfo``,
the pose (``geometry_msgs/msg/PoseWithCovarianceStamped``), ``/tf`` (map ->
base_link from the pose) and ``/tf_static`` (base_link -> camera from the
camera file's mounting), ``nav_msgs/msg/Path``, the map as
``visualization_msgs/msg/MarkerArray``, floorboundary's profile as
``sensor_msgs/msg/LaserScan`` and the detections as
``gst_landmark/msg/LandmarkDetectionArray`` (modelled on
vision_msgs/Detection2DArray). Stamps are the wall clock of the run by
default.

Either the command runs the chain on a video (``--input`` with the
project config, as ``gst-landmark run``) or it converts results written
before (``--log`` from landmarklog and ``--video``, the overlay video of
the same run, frame for frame).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from typing import Any, Dict, Iterable, Iterator, List, Optional, Tuple

import cv2
import numpy as np

from .common import PROG, CliError

IMAGE_TOPIC = "/landmark/overlay/compressed"
CAMERA_IMAGE_TOPIC = "/landmark/camera/compressed"
CAMERA_INFO_TOPIC = "/landmark/camera/camera_info"
POSE_TOPIC = "/landmark/pose"
DETECTIONS_TOPIC = "/landmark/detections"
SCAN_TOPIC = "/landmark/floor/scan"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
PATH_TOPIC = "/landmark/path"
MAP_TOPIC = "/landmark/map"

IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"
POSE_TYPE = "geometry_msgs/msg/PoseWithCovarianceStamped"
SCAN_TYPE = "sensor_msgs/msg/LaserScan"
TF_TYPE = "tf2_msgs/msg/TFMessage"
PATH_TYPE = "nav_msgs/msg/Path"
MAP_TYPE = "visualization_msgs/msg/MarkerArray"
DETECTIONS_TYPE = "gst_landmark/msg/LandmarkDetectionArray"

# the frames: map (the landmark map's), base_link (the robot's floor point,
# x ahead, y left, z up), camera (the optical frame: z along the optical
# axis, x right, y down in the image, as sensor_msgs/CameraInfo)
MAP_FRAME, ROBOT_FRAME, CAMERA_FRAME = "map", "base_link", "camera"

# a path point at most every PATH_SPACING_NS of stream time, a Path message
# every PATH_EVERY_NS (and at the last pose), the last PATH_LENGTH points
PATH_SPACING_NS = 100_000_000
PATH_EVERY_NS = 1_000_000_000
PATH_LENGTH = 3000

_SEP = "=" * 80 + "\n"

# The detections' own message, modelled on vision_msgs/Detection2DArray
# (docs/record.md has it with every field's meaning); written into the
# MCAP schema with its dependencies, as ros2 bag does.
DETECTIONS_MSG = """\
# The detections of one frame (gst-landmark, modelled on
# vision_msgs/Detection2DArray). header.stamp: the frame's time;
# header.frame_id: camera.
std_msgs/Header header
uint64 frame                    # frame index from 0
gst_landmark/LandmarkDetection[] detections
"""

DETECTION_MSG = """\
# One blob the chain found (modelled on vision_msgs/Detection2D).
string id                       # the detection's index in the frame
string class_id                 # colour class (vision_msgs ObjectHypothesis.class_id)
float64 score                   # roundness 4 pi A / P^2 (0..1); 0 without a blob
gst_landmark/BoundingBox2D bbox # pixels
bool accepted                   # the chain kept it
string rejected_by              # the element that rejected it, or empty
string reject_reason            # why, or empty
float64 area                    # pixels (0 without a blob)
float64 ellipse_major           # fitted ellipse, pixels; 0 without a blob
float64 ellipse_minor
float64 ellipse_angle           # radians
bool has_range                  # ipmrange measured it
float64 range                   # metres from the robot's floor point
float64 bearing                 # radians, left positive
float64 range_sigma             # metres (0: unknown)
geometry_msgs/Point floor_point # base_link: the landmark's floor point, z 0
string range_method             # ground, size or fused
bool matched                    # trilaterate matched it to a map landmark
string landmark_id              # the map's id, or empty
float64 residual                # metres
"""

BBOX_MSG = """\
# An axis-aligned box in pixels (vision_msgs/BoundingBox2D without theta).
float64 center_x
float64 center_y
float64 size_x
float64 size_y
"""


def _ros_definitions():
    """{type: concatenated definition} for every type written, the
    standard ROS 2 ones (Humble) from rosbags' type store."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    defs = {t: store.generate_msgdef(t, ros_version=2)[0] for t in (
        IMAGE_TYPE, CAMERA_INFO_TYPE, POSE_TYPE, SCAN_TYPE, TF_TYPE,
        PATH_TYPE, MAP_TYPE)}
    point = store.generate_msgdef("geometry_msgs/msg/Point",
                                  ros_version=2)[0]
    header = store.generate_msgdef("std_msgs/msg/Header", ros_version=2)[0]
    defs[DETECTIONS_TYPE] = (
        DETECTIONS_MSG + _SEP + "MSG: gst_landmark/LandmarkDetection\n" +
        DETECTION_MSG + _SEP + "MSG: gst_landmark/BoundingBox2D\n" +
        BBOX_MSG + _SEP + "MSG: std_msgs/Header\n" + header +
        _SEP + "MSG: geometry_msgs/Point\n" + point)
    return defs


def read_log(path: str) -> List[Dict[str, Any]]:
    """landmarklog's lines; CliError naming the file and line when one is
    not a JSON object."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as err:
        raise CliError(f"{path}: {err.strerror}") from None
    lines = []
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
        except ValueError as err:
            raise CliError(f"{path}:{number}: not JSON ({err})") from None
        if not isinstance(obj, dict) or "frame" not in obj:
            raise CliError(f"{path}:{number}: not a landmarklog line (no "
                           f"\"frame\")")
        lines.append(obj)
    return lines


def video_frames(path: str) -> Iterator[np.ndarray]:
    """The frames of a video file (BGR), in order."""
    if not os.path.isfile(path):
        raise CliError(f"{path}: no such file")
    cap = cv2.VideoCapture(path)
    if not cap.isOpened():
        raise CliError(f"{path}: cannot read as a video")
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                return
            yield frame
    finally:
        cap.release()


def _stamp(ns: int) -> Dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


# floorboundary's bin states (docs/floorboundary.md)
_FREE, _OBSTACLE = 1, 2


def _yaw_quaternion(heading: float) -> Dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2),
            "w": math.cos(heading / 2)}


def _matrix_quaternion(r: np.ndarray) -> Dict[str, float]:
    """The unit quaternion of a rotation matrix (Shepperd's method)."""
    t = np.trace(r)
    if t > 0:
        k = 2.0 * math.sqrt(1.0 + t)
        w, x = k / 4, (r[2, 1] - r[1, 2]) / k
        y, z = (r[0, 2] - r[2, 0]) / k, (r[1, 0] - r[0, 1]) / k
    else:
        i = int(np.argmax(np.diag(r)))
        j, k_ = (i + 1) % 3, (i + 2) % 3
        k = 2.0 * math.sqrt(1.0 + r[i, i] - r[j, j] - r[k_, k_])
        q = [0.0, 0.0, 0.0]
        q[i] = k / 4
        q[j] = (r[j, i] + r[i, j]) / k
        q[k_] = (r[k_, i] + r[i, k_]) / k
        w = (r[k_, j] - r[j, k_]) / k
        x, y, z = q
    return {"x": float(x), "y": float(y), "z": float(z), "w": float(w)}


def camera_rotation(tilt_deg: float, roll_deg: float) -> np.ndarray:
    """The camera's optical frame in base_link (columns: its x right, y
    down, z along the optical axis): the axis ahead, tilted tilt_deg
    below the horizontal, then turned roll_deg about itself (clockwise
    as seen from behind the camera, as ipmrange's roll)."""
    t, r = math.radians(tilt_deg), math.radians(roll_deg)
    c, s = math.cos(t), math.sin(t)
    level = np.array([[0.0, -s, c], [-1.0, 0.0, 0.0], [0.0, -c, -s]])
    cr, sr = math.cos(r), math.sin(r)
    return level @ np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])


def _transform(parent: str, child: str, stamp_ns: int, xyz, rotation):
    return {"header": {"stamp": _stamp(stamp_ns), "frame_id": parent},
            "child_frame_id": child,
            "transform": {"translation": dict(zip("xyz", map(float, xyz))),
                          "rotation": rotation}}


def robot_transform(pose: Dict[str, Any], stamp_ns: int) -> Dict[str, Any]:
    """map -> base_link from the pose."""
    return _transform(MAP_FRAME, ROBOT_FRAME, stamp_ns,
                      (pose["x"], pose["y"], 0.0),
                      _yaw_quaternion(float(pose["heading"])))


def camera_transform(camera: Dict[str, Any], stamp_ns: int):
    """base_link -> camera from the camera file's mounting: the camera
    above the robot's floor point at camera_height."""
    return _transform(ROBOT_FRAME, CAMERA_FRAME, stamp_ns,
                      (0.0, 0.0, float(camera.get("camera_height", 0.0))),
                      _matrix_quaternion(camera_rotation(
                          float(camera.get("tilt_deg", 0.0)),
                          float(camera.get("roll_deg", 0.0)))))


def camera_info(camera: Dict[str, Any], width: int, height: int,
                stamp_ns: int) -> Dict[str, Any]:
    """sensor_msgs/CameraInfo of the camera file, K scaled to the
    recorded frames' size as ipmrange scales it."""
    k = np.array(camera["camera_matrix"], dtype=np.float64)
    sx = width / camera.get("image_width", width)
    sy = height / camera.get("image_height", height)
    k = np.diag([sx, sy, 1.0]) @ k
    dist = [float(d) for d in camera["dist"]]
    model = "rational_polynomial" if len(dist) == 8 else "plumb_bob"
    p = np.hstack([k, np.zeros((3, 1))])
    return {"header": {"stamp": _stamp(stamp_ns), "frame_id": CAMERA_FRAME},
            "height": int(height), "width": int(width),
            "distortion_model": model, "d": dist,
            "k": [float(v) for v in k.ravel()],
            "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            "p": [float(v) for v in p.ravel()]}


def pose_message(pose: Dict[str, Any], stamp_ns: int) -> Dict[str, Any]:
    """geometry_msgs/PoseWithCovarianceStamped from the pose meta's
    fields (x, y in metres, heading in radians, covariance 3x3 over
    x, y, heading)."""
    heading = float(pose["heading"])
    cov3 = pose.get("covariance") or [0.0] * 9
    cov3 = [0.0 if c is None else float(c) for c in cov3]
    # (x, y, heading) -> rows/columns 0, 1 and 5 of ROS's
    # (x, y, z, rot x, rot y, rot z)
    index = [0, 1, 5]
    cov6 = [0.0] * 36
    for i in range(3):
        for j in range(3):
            cov6[index[i] * 6 + index[j]] = cov3[i * 3 + j]
    return {
        "header": {"stamp": _stamp(stamp_ns), "frame_id": MAP_FRAME},
        "pose": {
            "pose": {
                "position": {"x": float(pose["x"]), "y": float(pose["y"]),
                             "z": 0.0},
                "orientation": _yaw_quaternion(heading),
            },
            "covariance": cov6,
        },
    }


def _number(value, default=0.0) -> float:
    return float(value) if isinstance(value, (int, float)) else default


def detection_message(line: Dict[str, Any], stamp_ns: int):
    """gst_landmark/LandmarkDetectionArray from landmarklog's line."""
    out = []
    for det in line.get("detections", []):
        x, y, w, h = (list(det.get("bbox") or []) + [0, 0, 0, 0])[:4]
        blob = det.get("blob") or {}
        rng = det.get("range") or {}
        match = det.get("match") or {}
        has_range = "range" in rng and "bearing" in rng
        out.append({
            "id": str(det.get("id", len(out))),
            "class_id": det.get("class") or "",
            "score": _number(blob.get("roundness")),
            "bbox": {"center_x": x + w / 2, "center_y": y + h / 2,
                     "size_x": float(w), "size_y": float(h)},
            "accepted": bool(det.get("accepted", True)),
            "rejected_by": det.get("rejected-by") or "",
            "reject_reason": det.get("reject-reason") or "",
            "area": _number(blob.get("area")),
            "ellipse_major": _number(blob.get("ellipse-major")),
            "ellipse_minor": _number(blob.get("ellipse-minor")),
            "ellipse_angle": _number(blob.get("ellipse-angle")),
            "has_range": has_range,
            "range": _number(rng.get("range")),
            "bearing": _number(rng.get("bearing")),
            "range_sigma": _number(rng.get("range-sigma")),
            "floor_point": {"x": _number(rng.get("ground-x")),
                            "y": _number(rng.get("ground-y")), "z": 0.0},
            "range_method": rng.get("method") or "",
            "matched": bool(match.get("matched", False)),
            "landmark_id": match.get("landmark-id") or "",
            "residual": _number(match.get("residual")),
        })
    return {"header": {"stamp": _stamp(stamp_ns), "frame_id": CAMERA_FRAME},
            "frame": int(line["frame"]), "detections": out}


def _class_colours(lines) -> Dict[str, Tuple[float, float, float]]:
    """Class name -> (r, g, b) 0..1 from the log's labels."""
    for line in lines:
        labels = line.get("labels")
        if isinstance(labels, dict) and "rgb" in labels:
            return {name: (((v >> 16) & 255) / 255, ((v >> 8) & 255) / 255,
                           (v & 255) / 255)
                    for name, v in zip(labels["classes"], labels["rgb"])}
    return {}


def map_markers(landmarks, colours, stamp_ns: int) -> Dict[str, Any]:
    """visualization_msgs/MarkerArray: each landmark as a flat cylinder
    (disc) or a sphere (ball) of its diameter and colour, and its id as
    text above it, in map."""
    markers = []
    for i, lm in enumerate(landmarks):
        d = lm.get("diameter") or 0.1
        ball = lm.get("kind") == "ball"
        z = lm["z"] if lm.get("z") is not None else (d / 2 if ball else 0.0)
        r, g, b = colours.get(lm["class"], (0.5, 0.5, 0.5))
        base = {"header": {"stamp": _stamp(stamp_ns), "frame_id": MAP_FRAME},
                "action": 0,
                "pose": {"position": {"x": lm["x"], "y": lm["y"], "z": z},
                         "orientation": _yaw_quaternion(0.0)},
                "color": {"r": r, "g": g, "b": b, "a": 1.0}}
        markers.append(dict(base, ns="landmarks", id=i,
                            type=2 if ball else 3,
                            scale={"x": d, "y": d, "z": d if ball else 0.01}))
        label = dict(base, ns="landmark-ids", id=i, type=9, text=lm["id"],
                     scale={"x": 0.0, "y": 0.0, "z": 0.15})
        label["pose"] = {"position": {"x": lm["x"], "y": lm["y"],
                                      "z": z + d / 2 + 0.15},
                         "orientation": _yaw_quaternion(0.0)}
        markers.append(label)
    return {"markers": markers}


def scan_message(floor: Dict[str, Any], stamp_ns: int) -> Dict[str, Any]:
    """A LaserScan from landmarklog's ``floor`` object."""
    bins = int(floor["bearing-bins"])
    step = float(floor.get("bin-width", 2 * math.pi / max(bins, 1)))
    ranges = []
    for rng, state in zip(floor.get("range", []), floor.get("state", [])):
        if state == _OBSTACLE:
            ranges.append(float(rng))
        elif state == _FREE:
            ranges.append(math.inf)
        else:
            ranges.append(math.nan)
    return {"header": {"stamp": _stamp(stamp_ns), "frame_id": ROBOT_FRAME},
            "angle_min": 0.0, "angle_max": step * (bins - 1),
            "angle_increment": step, "time_increment": 0.0,
            "scan_time": 0.0, "range_min": 0.0,
            "range_max": float(floor.get("max-range", math.inf)),
            "ranges": ranges, "intensities": []}


def _frame_time(line: Dict[str, Any], index: int, fps: float) -> int:
    if isinstance(line.get("pts"), int):
        return line["pts"]
    return int(round(index * 1e9 / fps))


def _jpeg(image: np.ndarray, index: int, quality: int) -> bytes:
    ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY,
                                            quality])
    if not ok:
        raise CliError(f"frame {index}: JPEG encoding failed")
    return jpeg.tobytes()


def write_mcap(out_path: str, lines: List[Dict[str, Any]],
               frames: Optional[Iterable[np.ndarray]], start_ns: int = 0,
               fps: float = 30.0, jpeg_quality: int = 90,
               camera_frames: Optional[Iterable[np.ndarray]] = None,
               camera: Optional[Dict[str, Any]] = None,
               landmarks: Optional[List[Dict[str, Any]]] = None
               ) -> Dict[str, int]:
    """Writes the MCAP file; returns the message count per topic. frames
    (the overlay) and camera_frames (the camera's), each None for no such
    channel, must give one image per log line; camera (a camera file as
    camerafile reads it) adds CameraInfo and base_link -> camera;
    landmarks (the map) the MarkerArray."""
    from mcap.well_known import MessageEncoding, SchemaEncoding
    from mcap.writer import Writer
    # the ROS 2 CDR encoder of the mcap-ros2-support package (its own
    # Writer uses it the same way)
    from mcap_ros2._dynamic import serialize_dynamic

    defs = _ros_definitions()
    topics = {POSE_TOPIC: POSE_TYPE, DETECTIONS_TOPIC: DETECTIONS_TYPE,
              TF_TOPIC: TF_TYPE, PATH_TOPIC: PATH_TYPE}
    if frames is not None:
        topics[IMAGE_TOPIC] = IMAGE_TYPE
    if camera_frames is not None:
        topics[CAMERA_IMAGE_TOPIC] = IMAGE_TYPE
    if camera is not None:
        topics[CAMERA_INFO_TOPIC] = CAMERA_INFO_TYPE
        topics[TF_STATIC_TOPIC] = TF_TYPE
    if landmarks:
        topics[MAP_TOPIC] = MAP_TYPE
    if any(isinstance(x.get("floor"), dict) for x in lines):
        topics[SCAN_TOPIC] = SCAN_TYPE
    counts = {t: 0 for t in topics}
    tmp = out_path + ".part"
    with open(tmp, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="gst-landmark record")
        schemas, encoders, channels = {}, {}, {}
        for topic, typ in topics.items():
            if typ not in schemas:
                schemas[typ] = w.register_schema(typ, SchemaEncoding.ROS2,
                                                 defs[typ].encode())
                encoders[typ] = serialize_dynamic(typ, defs[typ])[typ]
            channels[topic] = w.register_channel(topic, MessageEncoding.CDR,
                                                 schemas[typ])

        def add(topic, t, msg):
            w.add_message(channels[topic], log_time=t, publish_time=t,
                          data=encoders[topics[topic]](msg),
                          sequence=counts[topic])
            counts[topic] += 1

        t0 = start_ns + (_frame_time(lines[0], 0, fps) if lines else 0)
        if camera is not None:
            add(TF_STATIC_TOPIC, t0,
                {"transforms": [camera_transform(camera, t0)]})
        if landmarks:
            add(MAP_TOPIC, t0, map_markers(landmarks, _class_colours(lines),
                                           t0))
        frame_iter = iter(frames) if frames is not None else None
        camera_iter = iter(camera_frames) if camera_frames is not None \
            else None
        path: List[Dict[str, Any]] = []
        last_point = last_path = None
        last_pose_index = max((i for i, x in enumerate(lines)
                               if isinstance(x.get("pose"), dict)),
                              default=-1)
        for index, line in enumerate(lines):
            t = start_ns + _frame_time(line, index, fps)
            for it, topic, frame_id in ((frame_iter, IMAGE_TOPIC, "camera"),
                                        (camera_iter, CAMERA_IMAGE_TOPIC,
                                         "camera")):
                if it is None:
                    continue
                image = next(it, None)
                if image is None:
                    raise CliError(f"the video has {index} frames, the log "
                                   f"{len(lines)} lines: they must be of "
                                   f"the same run")
                add(topic, t, {"header": {"stamp": _stamp(t),
                                          "frame_id": frame_id},
                               "format": "jpeg",
                               "data": _jpeg(image, index, jpeg_quality)})
            if camera is not None:
                add(CAMERA_INFO_TOPIC, t, camera_info(
                    camera, line.get("width", camera["image_width"]),
                    line.get("height", camera["image_height"]), t))
            pose = line.get("pose")
            if isinstance(pose, dict) and "x" in pose and "heading" in pose:
                msg = pose_message(pose, t)
                add(POSE_TOPIC, t, msg)
                add(TF_TOPIC, t, {"transforms": [robot_transform(pose, t)]})
                point = {"header": msg["header"],
                         "pose": msg["pose"]["pose"]}
                if last_point is None or t - last_point >= PATH_SPACING_NS:
                    path.append(point)
                    del path[:-PATH_LENGTH]
                    last_point = t
                if last_path is None or t - last_path >= PATH_EVERY_NS or \
                        index == last_pose_index:
                    # the path ends at the latest pose
                    add(PATH_TOPIC, t, {"header": {"stamp": _stamp(t),
                                                   "frame_id": MAP_FRAME},
                                        "poses": path if path[-1] is point
                                        else path + [point]})
                    last_path = t
            floor = line.get("floor")
            if isinstance(floor, dict) and "bearing-bins" in floor:
                add(SCAN_TOPIC, t, scan_message(floor, t))
            add(DETECTIONS_TOPIC, t, detection_message(line, t))
        for it in (frame_iter, camera_iter):
            if it is not None and next(it, None) is not None:
                raise CliError(f"the video has more frames than the log's "
                               f"{len(lines)} lines: they must be of the "
                               f"same run")
        w.finish()
    os.replace(tmp, out_path)
    return counts


def record_pipeline() -> str:
    """pipelines/file.pipeline with floorboundary (the camera's) before
    landmarklog, so the log holds the floor profile for the scan."""
    from . import runner
    _, launch = runner.resolve_pipeline("file")
    marker = "! landmarklog "
    if marker not in launch:
        raise CliError("pipelines/file.pipeline has no landmarklog")
    return launch.replace(marker, "! floorboundary calibration=${CAMERA} "
                          + marker, 1)


def _log_start(path: str, lines: List[Dict[str, Any]]) -> int:
    """When the run of a log began by the wall clock: the file's last
    change (its last line) minus the last frame's end in stream time."""
    end = 0
    if lines:
        last = lines[-1]
        end = _frame_time(last, len(lines) - 1, 30.0) + int(
            last.get("duration") or 0)
    return max(0, int(os.stat(path).st_mtime_ns) - end)


def _camera_and_map(camera_path, map_path):
    from ..camerafile import CalibrationError, read_camera_file, \
        read_mounting
    from ..landmarkmap import MapError, read_map
    camera = landmarks = None
    try:
        if camera_path:
            camera = read_camera_file(camera_path)
            camera.update(read_mounting(camera_path))
        if map_path:
            landmarks = read_map(map_path)
    except (CalibrationError, MapError, OSError) as err:
        raise CliError(str(err)) from None
    if camera is not None and "camera_height" not in camera:
        raise CliError(f"{camera_path}: no camera_height (the mounting: "
                       f"write it with 'gst-landmark calibrate floor')")
    return camera, landmarks


def record(out_path: str, log: Optional[str] = None,
           video: Optional[str] = None, input_path: Optional[str] = None,
           config: Optional[str] = None, sets=(),
           start_ns: Optional[int] = None, stream=None,
           camera_video: Optional[str] = None,
           camera_file: Optional[str] = None,
           map_file: Optional[str] = None) -> Dict[str, int]:
    """The command: runs the chain (input_path) or converts (log, video,
    camera_video); returns the message count per topic. start_ns: added
    to the stream times; None: the wall clock of the run's start."""
    stream = stream or sys.stdout
    try:
        if input_path is not None:
            if log is not None or video is not None or \
                    camera_video is not None:
                raise CliError("give either --input (run the chain) or "
                               "--log with --video (convert), not both")
            from . import runner
            variables = dict(runner.read_config(config)) if config else {}
            variables.update(runner.parse_set(sets))
            camera, landmarks = _camera_and_map(
                camera_file or variables.get("CAMERA"),
                map_file or variables.get("MAP"))
            with tempfile.TemporaryDirectory(prefix="gst-landmark-record-") \
                    as tmp:
                began = time.time_ns()
                with open(os.devnull, "w") as quiet:
                    status, _ = runner.run(record_pipeline(), input_path,
                                           config=config, out_dir=tmp,
                                           sets=sets, progress=False,
                                           stream=quiet)
                if status != 0:
                    raise CliError("the chain did not finish", status)
                lines = read_log(os.path.join(tmp, runner.LOG_NAME))
                counts = write_mcap(
                    out_path, lines,
                    video_frames(os.path.join(tmp, runner.VIDEO_NAME)),
                    began if start_ns is None else start_ns,
                    camera_frames=video_frames(input_path), camera=camera,
                    landmarks=landmarks)
        else:
            if log is None:
                raise CliError("give --input (run the chain) or --log "
                               "(convert landmarklog's output)")
            lines = read_log(log)
            camera, landmarks = _camera_and_map(camera_file, map_file)
            counts = write_mcap(
                out_path, lines, video_frames(video) if video else None,
                _log_start(log, lines) if start_ns is None else start_ns,
                camera_frames=video_frames(camera_video) if camera_video
                else None, camera=camera, landmarks=landmarks)
    except BaseException:
        try:
            os.remove(out_path + ".part")
        except OSError:
            pass
        raise
    for topic, n in counts.items():
        print(f"{topic}: {n} messages", file=stream)
    print(f"wrote {out_path}", file=stream)
    return counts


def add_record_parser(subparsers):
    p = subparsers.add_parser(
        "record", help="write the results as an MCAP file (ROS 2 schemas)",
        description="Write the run as an MCAP file of ROS 2 messages for "
                    "Foxglove Studio, ros2 bag and rosbags: camera and "
                    "overlay images, CameraInfo, pose, /tf, path, "
                    "detections, the map as markers, the floor scan. "
                    "Either run the chain on a video "
                    "(--input, with --config as for 'run') or convert a "
                    "landmarklog file and its overlay video (--log, "
                    "--video). See docs/record.md.")
    p.add_argument("-o", "--output", metavar="OUT.mcap", required=True)
    p.add_argument("--input", "-i", metavar="VIDEO",
                   help="video to run the chain on (pipelines/file.pipeline)")
    p.add_argument("--config", "-c", metavar="project.json",
                   help="with --input: project config (palette, map, camera)")
    p.add_argument("--set", metavar="VAR=VALUE", action="append",
                   default=[], dest="sets",
                   help="with --input: set a pipeline variable (repeatable)")
    p.add_argument("--log", metavar="LOG.jsonl",
                   help="landmarklog output to convert")
    p.add_argument("--video", metavar="VIDEO",
                   help="with --log: the overlay video of the same run, one "
                        "frame per log line (leave out for no overlay)")
    p.add_argument("--camera-video", metavar="VIDEO",
                   help="with --log: the camera's video of the same run, one "
                        "frame per log line (--input records its input)")
    p.add_argument("--camera-file", metavar="CAMERA.yml",
                   help="the camera file (default with --input: the "
                        "config's camera): CameraInfo and base_link -> "
                        "camera")
    p.add_argument("--map", metavar="MAP.json", dest="map_file",
                   help="the landmark map (default with --input: the "
                        "config's map): the map as markers")
    p.add_argument("--start-time", type=float, default=None, metavar="S",
                   help="seconds since 1970 added to the stream times "
                        "(default: the wall clock when the run began; 0: "
                        "stream time)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        record(args.output, log=args.log, video=args.video,
               input_path=args.input, config=args.config, sets=args.sets,
               start_ns=None if args.start_time is None
               else int(round(args.start_time * 1e9)),
               camera_video=args.camera_video, camera_file=args.camera_file,
               map_file=args.map_file)
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
    return 0
