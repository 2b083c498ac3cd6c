"""The chain's results as ROS 2 messages: what ``gst-landmark record``
writes into an MCAP file and ``gst-landmark run --foxglove`` serves live
(docs/record.md has every channel). Each landmarklog line (one frame)
becomes the messages of that frame, as plain dicts in the ROS 2 types'
field names; RecordingChannels holds the channels' topics, types and
definitions (the standard ones from rosbags' ROS 2 Humble type store, the
detections' our own) and the path across frames."""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Tuple

import cv2
import numpy as np

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


def class_colours(lines) -> Dict[str, Tuple[float, float, float]]:
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


class RecordingChannels:
    """The recording's channels and the messages of each frame, built
    once for the MCAP file (write_mcap) and the live Foxglove server
    alike. overlay, camera_images: whether those image channels exist;
    camera (a camera file as camerafile reads it, with its mounting)
    adds CameraInfo and /tf_static; landmarks (the map) the markers;
    scan the floor scan."""

    def __init__(self, overlay: bool = False, camera_images: bool = False,
                 camera: Optional[Dict[str, Any]] = None,
                 landmarks: Optional[List[Dict[str, Any]]] = None,
                 scan: bool = False):
        self.camera, self.landmarks = camera, landmarks
        topics = {POSE_TOPIC: POSE_TYPE, DETECTIONS_TOPIC: DETECTIONS_TYPE,
                  TF_TOPIC: TF_TYPE, PATH_TOPIC: PATH_TYPE}
        if overlay:
            topics[IMAGE_TOPIC] = IMAGE_TYPE
        if camera_images:
            topics[CAMERA_IMAGE_TOPIC] = IMAGE_TYPE
        if camera is not None:
            topics[CAMERA_INFO_TOPIC] = CAMERA_INFO_TYPE
            topics[TF_STATIC_TOPIC] = TF_TYPE
        if landmarks:
            topics[MAP_TOPIC] = MAP_TYPE
        if scan:
            topics[SCAN_TOPIC] = SCAN_TYPE
        self.topics = topics
        self.definitions = _ros_definitions()
        self._path: List[Dict[str, Any]] = []
        self._last_point = self._last_path = None

    def encoders(self):
        """{topic: function from a message to its CDR bytes}."""
        # the ROS 2 CDR encoder of the mcap-ros2-support package (its own
        # Writer uses it the same way)
        from mcap_ros2._dynamic import serialize_dynamic
        by_type = {}
        for typ in set(self.topics.values()):
            by_type[typ] = serialize_dynamic(typ, self.definitions[typ])[typ]
        return {topic: by_type[typ] for topic, typ in self.topics.items()}

    def opening(self, t0: int, colours) -> List[Tuple[str, Dict[str, Any]]]:
        """The messages sent once at the start: the camera's mounting and
        the map (colours: class -> (r, g, b) 0..1)."""
        out = []
        if self.camera is not None:
            out.append((TF_STATIC_TOPIC,
                        {"transforms": [camera_transform(self.camera, t0)]}))
        if self.landmarks:
            out.append((MAP_TOPIC, map_markers(self.landmarks, colours, t0)))
        return out

    def frame(self, line: Dict[str, Any], t: int,
              overlay_jpeg: Optional[bytes] = None,
              camera_jpeg: Optional[bytes] = None,
              last_pose: bool = False) -> List[Tuple[str, Dict[str, Any]]]:
        """The messages of one landmarklog line stamped t; an image None
        is not sent; last_pose: the path goes out with this pose."""
        out = []
        for topic, data in ((IMAGE_TOPIC, overlay_jpeg),
                            (CAMERA_IMAGE_TOPIC, camera_jpeg)):
            if data is not None and topic in self.topics:
                out.append((topic, {"header": {"stamp": _stamp(t),
                                               "frame_id": CAMERA_FRAME},
                                    "format": "jpeg", "data": data}))
        if self.camera is not None:
            out.append((CAMERA_INFO_TOPIC, camera_info(
                self.camera, line.get("width", self.camera["image_width"]),
                line.get("height", self.camera["image_height"]), t)))
        pose = line.get("pose")
        if isinstance(pose, dict) and "x" in pose and "heading" in pose:
            msg = pose_message(pose, t)
            out.append((POSE_TOPIC, msg))
            out.append((TF_TOPIC, {"transforms": [robot_transform(pose, t)]}))
            point = {"header": msg["header"], "pose": msg["pose"]["pose"]}
            path = self._path
            if self._last_point is None or \
                    t - self._last_point >= PATH_SPACING_NS:
                path.append(point)
                del path[:-PATH_LENGTH]
                self._last_point = t
            if self._last_path is None or \
                    t - self._last_path >= PATH_EVERY_NS or last_pose:
                # the path ends at the latest pose
                out.append((PATH_TOPIC, {
                    "header": {"stamp": _stamp(t), "frame_id": MAP_FRAME},
                    "poses": path if path[-1] is point else path + [point]}))
                self._last_path = t
        floor = line.get("floor")
        if isinstance(floor, dict) and "bearing-bins" in floor and \
                SCAN_TOPIC in self.topics:
            out.append((SCAN_TOPIC, scan_message(floor, t)))
        out.append((DETECTIONS_TOPIC, detection_message(line, t)))
        return out


def frame_time(line: Dict[str, Any], index: int, fps: float) -> int:
    if isinstance(line.get("pts"), int):
        return line["pts"]
    return int(round(index * 1e9 / fps))


def jpeg(image: np.ndarray, index: int, quality: int = 90) -> bytes:
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY,
                                            quality])
    if not ok:
        raise ValueError(f"frame {index}: JPEG encoding failed")
    return data.tobytes()
