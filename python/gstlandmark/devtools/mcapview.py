"""``gst-landmark mcapview``: one frame of a recording drawn from the MCAP
file alone, as a robotics viewer shows its channels, into one PNG.

Left, the camera image (``/landmark/camera/compressed``) of the frame
with its detections (``/landmark/detections``) as boxes and the map's
landmarks re-projected into it through ``/tf``, ``/tf_static`` and
``/landmark/camera/camera_info``. Right, the map from above (a viewer's 3D
panel seen from the top): the markers of ``/landmark/map``, the path
(``/landmark/path``), the robot's pose from ``/tf`` as an arrow, the
camera's view on the floor and the floor scan (``/landmark/floor/scan``)
placed in the map. Everything is decoded from the file's ROS 2 schemas
(mcap-ros2-support); nothing is read from the log, the map file or the
camera file, so the picture shows what a viewer of the file would get.
docs/record.md has the channels and frames.
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import cv2
import numpy as np

from .. import rosmessages as rm
from ..commands.common import CliError

# what the picture is made of: topic -> ROS 2 type; the scan is drawn
# when the recording has it (``record --log`` of a chain without
# floorboundary has none)
REQUIRED = {
    rm.CAMERA_IMAGE_TOPIC: rm.IMAGE_TYPE,
    rm.CAMERA_INFO_TOPIC: rm.CAMERA_INFO_TYPE,
    rm.DETECTIONS_TOPIC: rm.DETECTIONS_TYPE,
    rm.TF_TOPIC: rm.TF_TYPE,
    rm.TF_STATIC_TOPIC: rm.TF_TYPE,
    rm.MAP_TOPIC: rm.MAP_TYPE,
    rm.PATH_TOPIC: rm.PATH_TYPE,
}
OPTIONAL = {rm.SCAN_TOPIC: rm.SCAN_TYPE}

MCAP_MAGIC = b"\x89MCAP0\r\n"
DEFAULT_WIDTH = 1200
HEADER_H = 30                   # the title strip, pixels
LEGEND_ROW = 18                 # pixels per row of the legends
LEGEND_TEXT = 0.36
MIN_WIDTH = 640
FOOTPRINT_RANGE = 5.0           # metres, when there is no scan's range_max

# visualization_msgs/Marker types the map uses
SPHERE, CYLINDER = 2, 3

# colours (BGR); none is a palette colour, so a marker's pixels are its own
BACKGROUND = (38, 36, 34)
GRID = (70, 68, 66)
GRID_TEXT = (150, 150, 150)
TEXT = (235, 235, 235)
PATH_RUN = (110, 100, 80)       # the whole run's path, faint
PATH_NOW = (255, 190, 40)       # the path up to the frame
ROBOT = (255, 255, 255)
FOOTPRINT = (200, 150, 90)
SCAN_FREE = (80, 140, 60)
SCAN_HIT = (0, 110, 255)
BOX_MATCHED = (60, 230, 60)
BOX_UNMATCHED = (0, 220, 255)
BOX_REJECTED = (150, 150, 150)
DISC_POINT = (255, 255, 0)      # a disc's floor point re-projected
BALL_POINT = (255, 0, 255)      # a ball's centre re-projected
RIM = (255, 255, 150)           # a disc's rim re-projected

SHIFT = 4                       # cv2 sub-pixel drawing: 1/16 px
ONE = 1 << SHIFT


def _fail(message: str) -> CliError:
    """Bad input: the message names the file (and the channel)."""
    return CliError(message, status=2)


# ---------------------------------------------------------------------------
# Reading the recording


def _open(path: str):
    """The file and its MCAP reader (ROS 2 decoder); CliError when it is
    not there or not an MCAP file."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    if not os.path.isfile(path):
        raise _fail(f"{path}: no such file")
    try:
        f = open(path, "rb")
    except OSError as err:
        raise _fail(f"{path}: {err.strerror}") from None
    if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
        f.close()
        raise _fail(f"{path}: not an MCAP file (it does not start with "
                    f"the MCAP magic)")
    f.seek(0)
    return f, make_reader(f, decoder_factories=[DecoderFactory()])


def _corrupt(path: str, err: Exception) -> CliError:
    return _fail(f"{path}: not a readable MCAP file (truncated or "
                 f"corrupt: {type(err).__name__}: {err})")


# what goes wrong in a damaged file, as mcap and its ROS 2 decoder raise it
def _read_errors():
    from mcap.exceptions import McapError
    return (McapError, struct.error, ValueError, EOFError, IndexError,
            KeyError, UnicodeDecodeError)


def check_channels(path: str, reader) -> Dict[str, str]:
    """{topic: type} of the recording's channels; CliError naming the
    file and the first channel the picture needs that is missing or of
    another type."""
    try:
        summary = reader.get_summary()
    except _read_errors() as err:
        raise _corrupt(path, err) from None
    if summary is None:
        raise _fail(f"{path}: no summary section (the file was not closed "
                    f"by its writer)")
    have = {}
    for channel in summary.channels.values():
        schema = summary.schemas.get(channel.schema_id)
        have[channel.topic] = schema.name if schema else ""
    counts = {}
    if summary.statistics is not None:
        counts = {summary.channels[i].topic: n for i, n in
                  summary.statistics.channel_message_counts.items()
                  if i in summary.channels}
    for topic, typ in list(REQUIRED.items()) + list(OPTIONAL.items()):
        if topic not in have:
            if topic in OPTIONAL:
                continue
            raise _fail(f"{path}: no channel {topic} ({typ}); the view "
                        f"needs it")
        if have[topic] != typ:
            raise _fail(f"{path}: channel {topic} is "
                        f"{have[topic] or 'without a schema'}, not {typ}")
        if counts.get(topic, 1) == 0 and topic in REQUIRED:
            raise _fail(f"{path}: channel {topic} has no message")
    return have


@dataclass
class Frame:
    """What the view draws of one frame, decoded from the recording."""
    index: int                  # the detections' frame index
    stamp: int                  # log time, ns
    detections: Any
    image: np.ndarray           # BGR
    info: Any                   # sensor_msgs/CameraInfo
    robot: Optional[np.ndarray]     # fixed frame -> robot, 4x4; None: no pose
    camera: Optional[np.ndarray]    # fixed frame -> camera, 4x4
    scan: Any = None
    scan_pose: Optional[np.ndarray] = None
    markers: List[Any] = field(default_factory=list)
    path_now: List[Tuple[float, float]] = field(default_factory=list)
    path_run: List[Tuple[float, float]] = field(default_factory=list)
    fixed_frame: str = rm.MAP_FRAME
    frames: int = 0             # detections messages in the recording


def transform_matrix(transform) -> np.ndarray:
    """geometry_msgs/Transform as a 4x4 matrix (parent <- child)."""
    q, t = transform.rotation, transform.translation
    x, y, z, w = q.x, q.y, q.z, q.w
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = [t.x, t.y, t.z]
    return m


def lookup(tree: Dict[str, Tuple[str, np.ndarray]], target: str,
           source: str) -> Optional[np.ndarray]:
    """target <- source through the tree {child: (parent, parent <-
    child)}, or None when source does not lead up to target."""
    m, frame, seen = np.eye(4), source, set()
    while frame != target:
        if frame in seen or frame not in tree:
            return None
        seen.add(frame)
        parent, step = tree[frame]
        m = step @ m
        frame = parent
    return m


def _messages_at(reader, topics, t):
    """The decoded messages of topics logged at t (recent mcap releases
    name the time bounds starting_at/ending_at and deprecate the older
    start_time/end_time, which are all that older ones know)."""
    try:
        return reader.iter_decoded_messages(topics=topics, starting_at=t,
                                            ending_at=t)
    except TypeError:
        return reader.iter_decoded_messages(topics=topics, start_time=t,
                                            end_time=t + 1)


def _accepted(msg) -> int:
    return sum(1 for d in msg.detections if d.accepted)


def choose(frames: List[Tuple[int, int, int, bool]]) -> int:
    """The position in frames [(stamp, index, accepted, has pose)] of the
    frame with the most accepted detections, with a pose first, nearest
    the middle of the recording among equals."""
    mid = (len(frames) - 1) / 2
    return max(range(len(frames)),
               key=lambda i: (frames[i][2], frames[i][3], -abs(i - mid)))


def read_frame(path: str, frame: Optional[int] = None) -> Frame:
    """The frame (the detections' index; None: chosen as ``choose``
    does) of the recording at path, decoded."""
    f, reader = _open(path)
    with f:
        have = check_channels(path, reader)
        try:
            return _read_frame(path, reader, have, frame)
        except _read_errors() as err:
            raise _corrupt(path, err) from None


def _read_frame(path, reader, have, frame) -> Frame:
    # first the small channels: the frames, the poses, the path, the map
    dets, tf_at, static, maps, paths = [], {}, [], [], []
    small = [rm.DETECTIONS_TOPIC, rm.TF_TOPIC, rm.TF_STATIC_TOPIC,
             rm.MAP_TOPIC, rm.PATH_TOPIC]
    for _, channel, message, msg in reader.iter_decoded_messages(
            topics=small):
        t, topic = message.log_time, channel.topic
        if topic == rm.DETECTIONS_TOPIC:
            dets.append((t, msg))
        elif topic == rm.TF_TOPIC:
            tf_at.setdefault(t, []).extend(msg.transforms)
        elif topic == rm.TF_STATIC_TOPIC:
            static.append((t, msg.transforms))
        elif topic == rm.MAP_TOPIC:
            maps.append((t, msg))
        else:
            paths.append((t, msg))
    if not dets:
        raise _fail(f"{path}: channel {rm.DETECTIONS_TOPIC} has no message")
    if frame is None:
        pick = choose([(t, int(m.frame), _accepted(m), t in tf_at)
                       for t, m in dets])
    else:
        pick = next((i for i, (_, m) in enumerate(dets)
                     if int(m.frame) == frame), None)
        if pick is None:
            raise _fail(f"{path}: no frame {frame} in {rm.DETECTIONS_TOPIC} "
                        f"(frames {int(dets[0][1].frame)} to "
                        f"{int(dets[-1][1].frame)})")
    t, det_msg = dets[pick]

    # then the frame's own messages: its image, camera model and scan
    image = info = scan = None
    big = [rm.CAMERA_IMAGE_TOPIC, rm.CAMERA_INFO_TOPIC] + (
        [rm.SCAN_TOPIC] if rm.SCAN_TOPIC in have else [])
    for _, channel, message, msg in _messages_at(reader, big, t):
        if channel.topic == rm.CAMERA_IMAGE_TOPIC:
            image = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8),
                                 cv2.IMREAD_COLOR)
            if image is None:
                raise _fail(f"{path}: {rm.CAMERA_IMAGE_TOPIC}: the image "
                            f"of frame {int(det_msg.frame)} is not a "
                            f"{msg.format or 'known'} image")
        elif channel.topic == rm.CAMERA_INFO_TOPIC:
            info = msg
        else:
            scan = msg
    for topic, got in ((rm.CAMERA_IMAGE_TOPIC, image),
                       (rm.CAMERA_INFO_TOPIC, info)):
        if got is None:
            raise _fail(f"{path}: no {topic} message at frame "
                        f"{int(det_msg.frame)} (log time {t})")

    markers_msg = next((m for mt, m in reversed(maps) if mt <= t), None)
    if markers_msg is None:
        raise _fail(f"{path}: no {rm.MAP_TOPIC} message at or before frame "
                    f"{int(det_msg.frame)}")
    markers = list(markers_msg.markers)
    fixed = next((m.header.frame_id for m in markers), rm.MAP_FRAME) or \
        rm.MAP_FRAME

    tree = {}
    for _, transforms in static:    # static: for the whole recording
        for tr in transforms:
            tree[tr.child_frame_id] = (tr.header.frame_id,
                                       transform_matrix(tr.transform))
    posed = t in tf_at
    for tr in tf_at.get(t, []):
        tree[tr.child_frame_id] = (tr.header.frame_id,
                                   transform_matrix(tr.transform))
    robot = lookup(tree, fixed, rm.ROBOT_FRAME) if posed else None
    camera = lookup(tree, fixed, info.header.frame_id or rm.CAMERA_FRAME) \
        if posed else None
    scan_pose = None
    if scan is not None and posed:
        scan_pose = lookup(tree, fixed, scan.header.frame_id)

    def points(msg):
        return [(p.pose.position.x, p.pose.position.y) for p in msg.poses]

    now = next((m for pt, m in reversed(paths) if pt <= t), None)
    return Frame(index=int(det_msg.frame), stamp=t, detections=det_msg,
                 image=image, info=info, robot=robot, camera=camera,
                 scan=scan, scan_pose=scan_pose, markers=markers,
                 path_now=points(now) if now is not None else [],
                 path_run=points(paths[-1][1]) if paths else [],
                 fixed_frame=fixed, frames=len(dets))


# ---------------------------------------------------------------------------
# Geometry


def camera_model(info) -> Tuple[np.ndarray, np.ndarray]:
    """K and the distortion coefficients OpenCV takes, from CameraInfo
    (plumb_bob: 5, rational_polynomial: 8; another model: none)."""
    k = np.array(info.k, dtype=np.float64).reshape(3, 3)
    d = np.array(list(info.d), dtype=np.float64)
    if info.distortion_model not in ("plumb_bob", "rational_polynomial") \
            or len(d) not in (4, 5, 8, 12, 14) or not d.any():
        d = np.zeros(5)
    return k, d


def project(frame: Frame, points: np.ndarray) -> np.ndarray:
    """Image pixels (u, v; pixel centres at integers, as K) of points in
    the fixed frame (N x 3); NaN for a point behind the camera."""
    out = np.full((len(points), 2), np.nan)
    if frame.camera is None or not len(points):
        return out
    inv = np.linalg.inv(frame.camera)
    pc = (inv[:3, :3] @ np.asarray(points, float).T).T + inv[:3, 3]
    ahead = pc[:, 2] > 1e-6
    if ahead.any():
        k, d = camera_model(frame.info)
        uv, _ = cv2.projectPoints(pc[ahead].reshape(-1, 1, 3), np.zeros(3),
                                  np.zeros(3), k, d)
        out[ahead] = uv.reshape(-1, 2)
    return out


def footprint(frame: Frame, reach: float, per_edge: int = 16):
    """The camera's view on the floor (z 0 of the fixed frame) as a
    polygon [(x, y)]: where the rays through the image's border meet the
    floor, at most reach metres from the camera's foot (a ray above the
    horizon ends there)."""
    if frame.camera is None:
        return []
    w, h = int(frame.info.width), int(frame.info.height)
    edge = np.linspace(0.0, 1.0, per_edge, endpoint=False)
    border = np.concatenate([
        np.stack([edge * (w - 1), np.zeros_like(edge)], 1),
        np.stack([np.full_like(edge, w - 1), edge * (h - 1)], 1),
        np.stack([(1 - edge) * (w - 1), np.full_like(edge, h - 1)], 1),
        np.stack([np.zeros_like(edge), (1 - edge) * (h - 1)], 1)])
    k, d = camera_model(frame.info)
    rays = cv2.undistortPoints(border.reshape(-1, 1, 2), k, d).reshape(-1, 2)
    rot, origin = frame.camera[:3, :3], frame.camera[:3, 3]
    out = []
    for x, y in rays:
        ray = rot @ np.array([x, y, 1.0])
        flat = math.hypot(ray[0], ray[1])
        if ray[2] < -1e-9 and origin[2] > 0:
            s = -origin[2] / ray[2]
            hit = origin + s * ray
            if math.hypot(hit[0] - origin[0], hit[1] - origin[1]) <= reach:
                out.append((hit[0], hit[1]))
                continue
        if flat > 1e-9:
            out.append((origin[0] + reach * ray[0] / flat,
                        origin[1] + reach * ray[1] / flat))
    return out


def scan_points(frame: Frame):
    """The floor scan in the fixed frame: (hits [(x, y)], free rays
    [((x0, y0), (x1, y1))] for the bins free up to range_max)."""
    scan, pose = frame.scan, frame.scan_pose
    if scan is None or pose is None:
        return [], []
    hits, free = [], []
    o = pose[:3, 3]
    for i, r in enumerate(scan.ranges):
        a = scan.angle_min + i * scan.angle_increment
        if math.isnan(r):
            continue
        reach = scan.range_max if math.isinf(r) else r
        local = np.array([reach * math.cos(a), reach * math.sin(a), 0.0])
        p = pose[:3, :3] @ local + o
        if math.isinf(r):
            free.append(((o[0], o[1]), (p[0], p[1])))
        elif scan.range_min <= r <= scan.range_max:
            hits.append((p[0], p[1]))
    return hits, free


# ---------------------------------------------------------------------------
# Drawing


def _bgr(color) -> Tuple[int, int, int]:
    return (int(round(255 * color.b)), int(round(255 * color.g)),
            int(round(255 * color.r)))


def _fixed(pt) -> Tuple[int, int]:
    return int(round(pt[0] * ONE)), int(round(pt[1] * ONE))


def _text(img, text, org, color=TEXT, scale=0.42, outline=False):
    """Text at org (its baseline's left end); outline: edged in black,
    to read on the camera's image."""
    org = (int(org[0]), int(org[1]))
    if outline:
        cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale,
                    (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1,
                cv2.LINE_AA)


class TopView:
    """Metres in the fixed frame to pixels of a panel: x right, y up,
    one scale for both."""

    def __init__(self, points, size: Tuple[int, int], margin_m=0.4,
                 pad_px=14):
        pts = np.asarray(points, float).reshape(-1, 2)
        lo, hi = pts.min(0) - margin_m, pts.max(0) + margin_m
        w, h = size
        self.scale = min((w - 2 * pad_px) / (hi[0] - lo[0]),
                         (h - 2 * pad_px) / (hi[1] - lo[1]))
        # centred in the panel
        self.x0 = w / 2 - self.scale * (lo[0] + hi[0]) / 2
        self.y0 = h / 2 + self.scale * (lo[1] + hi[1]) / 2
        self.size = size

    def px(self, x, y) -> Tuple[float, float]:
        return self.x0 + self.scale * x, self.y0 - self.scale * y

    def metres(self, u, v) -> Tuple[float, float]:
        return (u - self.x0) / self.scale, (self.y0 - v) / self.scale


@dataclass
class View:
    """The picture and where things went in it (pixels of the PNG)."""
    image: np.ndarray
    frame: Frame
    top: TopView
    top_origin: Tuple[int, int]     # the top view's panel in the PNG
    camera_scale: Tuple[float, float]   # PNG pixels per image pixel
    camera_origin: Tuple[int, int]  # the camera panel in the PNG
    # id -> PNG pixel, as drawn
    landmarks: Dict[str, Tuple[float, float]] = field(default_factory=dict)
    reprojected: Dict[str, Tuple[float, float]] = field(default_factory=dict)

    def top_px(self, x, y) -> Tuple[float, float]:
        """A point of the fixed frame (metres) in the PNG."""
        u, v = self.top.px(x, y)
        return u + self.top_origin[0], v + self.top_origin[1]

    def camera_px(self, u, v) -> Tuple[float, float]:
        """A pixel of the camera image (pixel centres at integers) in
        the PNG."""
        sx, sy = self.camera_scale
        return (self.camera_origin[0] + (u + 0.5) * sx - 0.5,
                self.camera_origin[1] + (v + 0.5) * sy - 0.5)


def _landmarks(markers):
    """[(id, marker)] of the map's landmarks (discs and balls), the id
    from the text marker of the same index."""
    names = {m.id: m.text for m in markers if m.ns == "landmark-ids"}
    return [(names.get(m.id, str(m.id)), m) for m in markers
            if m.ns == "landmarks" and m.type in (SPHERE, CYLINDER)]


def render(frame: Frame, width: int = DEFAULT_WIDTH, name: str = "") -> View:
    """The picture of a frame: camera panel left, top view right."""
    ih, iw = frame.image.shape[:2]
    panel_h = max(120, int(round(width / (iw / ih + 1))))
    cam_w = int(round(iw * panel_h / ih))
    top_w = max(120, width - cam_w)
    reach = FOOTPRINT_RANGE
    if frame.scan is not None and math.isfinite(frame.scan.range_max):
        reach = float(frame.scan.range_max)
    legends = [
        ([(BOX_MATCHED, "box: matched"), (BOX_UNMATCHED, "unmatched"),
          (BOX_REJECTED, "rejected"), (DISC_POINT, "disc floor point"),
          (BALL_POINT, "ball centre"), (RIM, "disc rim"),
          (None, "the map re-projected via /tf, CameraInfo")], 8,
         cam_w - 8),
        ([(PATH_NOW, "path"), (PATH_RUN, "whole run"), (ROBOT, "robot"),
          (FOOTPRINT, f"camera view to {reach:g} m"),
          (SCAN_FREE, "scan: free" if frame.scan is not None
           else "no scan channel"), (SCAN_HIT, "hit"),
          (None, f"{frame.fixed_frame}, from above, 1 m grid")],
         cam_w + 8, cam_w + top_w - 8)]
    rows = max(row for items, x0, x1 in legends
               for _, row in _layout(items, x0, x1)) + 1
    canvas = np.full((HEADER_H + panel_h + 8 + LEGEND_ROW * rows,
                      cam_w + top_w, 3), BACKGROUND, np.uint8)
    cam_origin, top_origin = (0, HEADER_H), (cam_w, HEADER_H)

    # ---- camera panel
    sx, sy = cam_w / iw, panel_h / ih
    cam = cv2.resize(frame.image, (cam_w, panel_h),
                     interpolation=cv2.INTER_LINEAR if sy >= 1
                     else cv2.INTER_AREA)
    shown = View(canvas, frame, None, top_origin, (sx, sy), cam_origin)
    for det in frame.detections.detections:
        b = det.bbox
        p0 = ((b.center_x - b.size_x / 2) * sx, (b.center_y - b.size_y / 2)
              * sy)
        p1 = ((b.center_x + b.size_x / 2) * sx - 1,
              (b.center_y + b.size_y / 2) * sy - 1)
        color = (BOX_REJECTED if not det.accepted else
                 BOX_MATCHED if det.matched else BOX_UNMATCHED)
        cv2.rectangle(cam, _fixed(p0), _fixed(p1), color, 1, cv2.LINE_AA,
                      SHIFT)
        label = det.landmark_id or det.class_id
        if det.accepted and det.has_range:
            label += f" {det.range:.2f} m"
        elif not det.accepted:
            label = f"{det.class_id}: {det.rejected_by or 'rejected'}"
        tw = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.38, 1)[0][0]
        _text(cam, label, (min(max(2, p0[0]), cam_w - tw - 2),
                           max(11, p0[1] - 3)), color, 0.38, True)
    lms = _landmarks(frame.markers)
    centres = np.array([[m.pose.position.x, m.pose.position.y,
                         m.pose.position.z if m.type == SPHERE else 0.0]
                        for _, m in lms]).reshape(-1, 3)
    uv = project(frame, centres)
    for (lid, m), (u, v) in zip(lms, uv):
        if not np.isfinite(u) or not (-0.5 <= u <= iw - 0.5 and
                                      -0.5 <= v <= ih - 0.5):
            continue
        if m.type == CYLINDER:
            # the disc's rim on the floor
            rim = [(m.pose.position.x + m.scale.x / 2 * math.cos(a),
                    m.pose.position.y + m.scale.x / 2 * math.sin(a), 0.0)
                   for a in np.linspace(0, 2 * math.pi, 33)]
            ruv = project(frame, np.array(rim))
            if np.isfinite(ruv).all():
                pts = np.array([_fixed(((p[0] + 0.5) * sx - 0.5,
                                        (p[1] + 0.5) * sy - 0.5))
                                for p in ruv], np.int32)
                cv2.polylines(cam, [pts], True, RIM, 1, cv2.LINE_AA, SHIFT)
    boxed = {d.landmark_id for d in frame.detections.detections
             if d.accepted and d.matched}
    for (lid, m), (u, v) in zip(lms, uv):
        if not np.isfinite(u) or not (-0.5 <= u <= iw - 0.5 and
                                      -0.5 <= v <= ih - 0.5):
            continue
        c = ((u + 0.5) * sx - 0.5, (v + 0.5) * sy - 0.5)
        color = DISC_POINT if m.type == CYLINDER else BALL_POINT
        cv2.circle(cam, _fixed(c), int(4.5 * ONE), (0, 0, 0), -1,
                   cv2.LINE_AA, SHIFT)
        cv2.circle(cam, _fixed(c), int(3.0 * ONE), color, -1, cv2.LINE_AA,
                   SHIFT)
        if lid not in boxed:        # a box's label names the others
            _text(cam, lid, (c[0] + 6, c[1] + 14), color, 0.38, True)
        shown.reprojected[lid] = (c[0] + cam_origin[0], c[1] + cam_origin[1])
    canvas[HEADER_H:HEADER_H + panel_h, :cam_w] = cam

    # ---- top view
    top = np.full((panel_h, top_w, 3), BACKGROUND, np.uint8)
    foot = footprint(frame, reach)
    hits, free = scan_points(frame)
    # the map, the path and the robot fill the panel; the camera's view
    # and the scan reach out of it (a viewer's 3D panel framed on the map)
    extent = [(m.pose.position.x, m.pose.position.y) for _, m in lms]
    extent += frame.path_run + frame.path_now
    if frame.robot is not None:
        extent.append(tuple(frame.robot[:2, 3]))
    if not extent:
        extent = [(0.0, 0.0)]
    tv = TopView(extent, (top_w, panel_h), margin_m=0.5)
    shown.top = tv

    def P(x, y):
        return _fixed(tv.px(x, y))

    # the metre grid
    x_lo, y_hi = tv.metres(0, 0)
    x_hi, y_lo = tv.metres(top_w, panel_h)
    for gx in range(math.ceil(x_lo), math.floor(x_hi) + 1):
        u = tv.px(gx, 0)[0]
        cv2.line(top, (int(round(u)), 0), (int(round(u)), panel_h), GRID, 1)
        _text(top, f"{gx}", (u + 2, panel_h - 4), GRID_TEXT, 0.33)
    for gy in range(math.ceil(y_lo), math.floor(y_hi) + 1):
        v = tv.px(0, gy)[1]
        cv2.line(top, (0, int(round(v))), (top_w, int(round(v))), GRID, 1)
        _text(top, f"{gy}", (3, v - 3), GRID_TEXT, 0.33)
    poly = np.array([P(*p) for p in foot], np.int32)
    if len(foot) >= 3:
        layer = top.copy()
        cv2.fillPoly(layer, [poly], FOOTPRINT, cv2.LINE_AA, SHIFT)
        cv2.addWeighted(layer, 0.22, top, 0.78, 0, top)
    if free:
        layer = top.copy()
        for a, b in free:
            cv2.line(layer, P(*a), P(*b), SCAN_FREE, 1, cv2.LINE_AA, SHIFT)
        cv2.addWeighted(layer, 0.35, top, 0.65, 0, top)
    if len(foot) >= 3:
        cv2.polylines(top, [poly], True, FOOTPRINT, 1, cv2.LINE_AA, SHIFT)
    for p in hits:
        cv2.circle(top, P(*p), int(2 * ONE), SCAN_HIT, -1, cv2.LINE_AA,
                   SHIFT)
    for path, color, thick in ((frame.path_run, PATH_RUN, 1),
                               (frame.path_now, PATH_NOW, 2)):
        if len(path) >= 2:
            cv2.polylines(top, [np.array([P(*p) for p in path], np.int32)],
                          False, color, thick, cv2.LINE_AA, SHIFT)
    if frame.robot is not None:
        x, y = frame.robot[0, 3], frame.robot[1, 3]
        heading = math.atan2(frame.robot[1, 0], frame.robot[0, 0])
        length = max(0.35, 28 / tv.scale)
        tip = (x + length * math.cos(heading), y + length * math.sin(heading))
        cv2.arrowedLine(top, P(x, y), P(*tip), ROBOT, 2, cv2.LINE_AA, SHIFT,
                        0.3)
        cv2.circle(top, P(x, y), int(3 * ONE), ROBOT, -1, cv2.LINE_AA,
                   SHIFT)
    # the markers on top, their ids beside them
    for lid, m in lms:
        x, y = m.pose.position.x, m.pose.position.y
        r = max(3.0, m.scale.x / 2 * tv.scale)
        cv2.circle(top, P(x, y), int((r + 1.5) * ONE), (0, 0, 0), -1,
                   cv2.LINE_AA, SHIFT)
        cv2.circle(top, P(x, y), int(r * ONE), _bgr(m.color), -1,
                   cv2.LINE_AA, SHIFT)
        if m.type == SPHERE:        # a ball: a highlight in its middle
            cv2.circle(top, P(x, y), int(max(1.0, r / 3) * ONE),
                       (255, 255, 255), -1, cv2.LINE_AA, SHIFT)
        shown.landmarks[lid] = shown.top_px(x, y)
    for lid, m in lms:
        u, v = tv.px(m.pose.position.x, m.pose.position.y)
        r = max(3.0, m.scale.x / 2 * tv.scale)
        _text(top, lid, (u + r + 3, v - r + 2), TEXT, 0.4)
    canvas[HEADER_H:HEADER_H + panel_h, cam_w:] = top
    cv2.line(canvas, (cam_w, HEADER_H), (cam_w, HEADER_H + panel_h),
             (0, 0, 0), 1)

    # ---- the title and the legends
    dets = frame.detections.detections
    accepted = sum(1 for d in dets if d.accepted)
    title = (f"{name + '  ' if name else ''}frame {frame.index} of "
             f"{frame.frames}  {_when(frame.stamp)}  {len(dets)} "
             f"detection{'' if len(dets) == 1 else 's'}, {accepted} "
             f"accepted")
    if frame.robot is None:
        title += "  (no pose at this frame)"
    _text(canvas, title, (8, 20), TEXT, 0.48)
    for items, x0, x1 in legends:
        for (color, label), (x, row) in zip(items, _layout(items, x0, x1)):
            y = HEADER_H + panel_h + 16 + LEGEND_ROW * row
            if color is None:
                _text(canvas, label, (x, y), GRID_TEXT, LEGEND_TEXT)
            else:
                cv2.rectangle(canvas, (x, y - 8), (x + 10, y + 1), color, -1)
                _text(canvas, label, (x + 14, y), TEXT, LEGEND_TEXT)
    return shown


def _when(ns: int) -> str:
    """A log time: UTC for a wall-clock stamp, seconds for stream time
    (``record --start-time 0``)."""
    if ns < 10**9 * 10**9:          # before 2001: stream time
        return f"t {ns / 1e9:.3f} s"
    import datetime
    t = datetime.datetime.fromtimestamp(ns // 10**9, datetime.timezone.utc)
    return t.strftime("%Y-%m-%d %H:%M:%S") + f".{ns % 10**9 // 10**6:03d} UTC"


def _layout(items, x0: int, x1: int) -> List[Tuple[int, int]]:
    """Where each legend item (colour swatch and label; colour None: a
    note on a row of its own) goes: (x, row), wrapped before x1."""
    out, x, row = [], x0, 0
    for color, label in items:
        width = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX,
                                LEGEND_TEXT, 1)[0][0] + (
                                    14 if color is not None else 0)
        if x > x0 and (color is None or x + width > x1):
            x, row = x0, row + 1
        out.append((x, row))
        x += width + 8
        if color is None:
            x, row = x1, row        # nothing after a note on its row
    return out


# ---------------------------------------------------------------------------
# The command


def view(path: str, out: str, frame: Optional[int] = None,
         width: int = DEFAULT_WIDTH) -> View:
    """Reads the frame of the recording, draws it and writes the PNG."""
    if width < MIN_WIDTH:
        raise _fail(f"--width {width}: at least {MIN_WIDTH} pixels")
    if not out.lower().endswith(".png"):
        raise _fail(f"{out}: the picture is a PNG file: name it .png")
    folder = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(folder):
        raise _fail(f"{folder}: no such folder")
    shown = render(read_frame(path, frame), width, os.path.basename(path))
    if not cv2.imwrite(out, shown.image, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise CliError(f"{out}: cannot write")
    return shown


def add_mcapview_parser(subparsers):
    p = subparsers.add_parser(
        "mcapview", help="draw one frame of an MCAP recording as a viewer "
                         "shows it (PNG)",
        description="Draw one frame of a 'gst-landmark record' file from "
                    "its ROS 2 channels alone: the camera image with the "
                    "detections and the map re-projected (through /tf, "
                    "/tf_static and CameraInfo) beside the map from above "
                    "with the path, the robot, the camera's view on the "
                    "floor and the floor scan. See docs/record.md.")
    p.add_argument("recording", metavar="RUN.mcap")
    p.add_argument("-o", "--output", metavar="VIEW.png", required=True)
    p.add_argument("--frame", type=int, metavar="N",
                   help="the frame index (the detections' frame; default: "
                        "the frame with the most accepted detections, the "
                        "one nearest the middle among equals)")
    p.add_argument("--width", type=int, default=DEFAULT_WIDTH, metavar="PX",
                   help=f"the picture's width (default {DEFAULT_WIDTH})")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    shown = view(args.recording, args.output, args.frame, args.width)
    h, w = shown.image.shape[:2]
    print(f"frame {shown.frame.index} of {shown.frame.frames}: wrote "
          f"{args.output} ({w}x{h})")
    return 0
