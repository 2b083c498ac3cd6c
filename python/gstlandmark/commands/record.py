"""``gst-landmark record``: the chain's results as an MCAP file that
robotics tools open (Foxglove Studio, ``ros2 bag`` with the MCAP storage
plugin), with ROS 2 message schemas.

Channels (docs/record.md):

- ``/landmark/overlay/compressed``: ``sensor_msgs/msg/CompressedImage``,
  one JPEG per video frame, ``frame_id`` ``camera``;
- ``/landmark/pose``: ``geometry_msgs/msg/PoseWithCovarianceStamped`` on
  frames with a pose, ``frame_id`` ``map``: x, y from the pose, z 0, the
  heading as a rotation about z, the (x, y, heading) covariance in the
  x, y and rotation-about-z rows and columns;
- ``/landmark/detections``: JSON (``gst_landmark/Detections``, JSON
  Schema in the file): ``frame``, ``pts`` and landmarklog's
  ``detections`` array, on every frame;
- ``/landmark/floor/scan``: ``sensor_msgs/msg/LaserScan``, when the log
  has floorboundary's ``floor`` profile: one range per bearing bin, bin 0
  ahead, counter-clockwise (left positive, as ROS), ``frame_id``
  ``base_link``; an obstacle at its range, ``+inf`` for free up to
  ``max-range``, NaN for not seen or free only up to the image's edge
  (REP 117: no return, no measurement).

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
from typing import Any, Dict, Iterable, Iterator, List, Optional

import cv2
import numpy as np

from .common import PROG, CliError

IMAGE_TOPIC = "/landmark/overlay/compressed"
POSE_TOPIC = "/landmark/pose"
DETECTIONS_TOPIC = "/landmark/detections"
SCAN_TOPIC = "/landmark/floor/scan"

IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
POSE_TYPE = "geometry_msgs/msg/PoseWithCovarianceStamped"
SCAN_TYPE = "sensor_msgs/msg/LaserScan"
DETECTIONS_SCHEMA = "gst_landmark/Detections"

_SEP = "=" * 80 + "\n"

_HEADER_DEFS = (
    _SEP + "MSG: std_msgs/Header\n"
    "builtin_interfaces/Time stamp\n"
    "string frame_id\n" +
    _SEP + "MSG: builtin_interfaces/Time\n"
    "int32 sec\n"
    "uint32 nanosec\n")

# ROS 2 message definitions with their dependencies, in the concatenated
# form ros2 bag and Foxglove write into MCAP schemas.
IMAGE_MSGDEF = (
    "std_msgs/Header header\n"
    "string format\n"
    "uint8[] data\n" + _HEADER_DEFS)

POSE_MSGDEF = (
    "std_msgs/Header header\n"
    "geometry_msgs/PoseWithCovariance pose\n" + _HEADER_DEFS +
    _SEP + "MSG: geometry_msgs/PoseWithCovariance\n"
    "geometry_msgs/Pose pose\n"
    "float64[36] covariance\n" +
    _SEP + "MSG: geometry_msgs/Pose\n"
    "geometry_msgs/Point position\n"
    "geometry_msgs/Quaternion orientation\n" +
    _SEP + "MSG: geometry_msgs/Point\n"
    "float64 x\n"
    "float64 y\n"
    "float64 z\n" +
    _SEP + "MSG: geometry_msgs/Quaternion\n"
    "float64 x 0\n"
    "float64 y 0\n"
    "float64 z 0\n"
    "float64 w 1\n")

SCAN_MSGDEF = (
    "std_msgs/Header header\n"
    "float32 angle_min\n"
    "float32 angle_max\n"
    "float32 angle_increment\n"
    "float32 time_increment\n"
    "float32 scan_time\n"
    "float32 range_min\n"
    "float32 range_max\n"
    "float32[] ranges\n"
    "float32[] intensities\n" + _HEADER_DEFS)

# floorboundary's bin states (docs/floorboundary.md)
_FREE, _OBSTACLE = 1, 2

DETECTIONS_JSON_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": DETECTIONS_SCHEMA,
    "description": "The detections of one frame as landmarklog writes "
                   "them (docs/landmarklog.md)",
    "type": "object",
    "properties": {
        "frame": {"type": "integer", "description": "frame index from 0"},
        "pts": {"type": "integer", "description": "nanoseconds"},
        "detections": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "id": {"type": "integer"},
                    "class": {"type": ["string", "null"]},
                    "bbox": {"type": "array", "items": {"type": "integer"},
                             "minItems": 4, "maxItems": 4},
                    "accepted": {"type": "boolean"},
                    "rejected-by": {"type": "string"},
                    "reject-reason": {"type": "string"},
                    "blob": {"type": "object"},
                    "range": {"type": "object"},
                    "match": {"type": "object"},
                    "params": {"type": "object"},
                },
                "required": ["id", "class", "bbox"],
            },
        },
    },
    "required": ["frame", "detections"],
}


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
        "header": {"stamp": _stamp(stamp_ns), "frame_id": "map"},
        "pose": {
            "pose": {
                "position": {"x": float(pose["x"]), "y": float(pose["y"]),
                             "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0,
                                "z": math.sin(heading / 2),
                                "w": math.cos(heading / 2)},
            },
            "covariance": cov6,
        },
    }


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
    return {"header": {"stamp": _stamp(stamp_ns), "frame_id": "base_link"},
            "angle_min": 0.0, "angle_max": step * (bins - 1),
            "angle_increment": step, "time_increment": 0.0,
            "scan_time": 0.0, "range_min": 0.0,
            "range_max": float(floor.get("max-range", math.inf)),
            "ranges": ranges, "intensities": []}


def _frame_time(line: Dict[str, Any], index: int, fps: float) -> int:
    if isinstance(line.get("pts"), int):
        return line["pts"]
    return int(round(index * 1e9 / fps))


def write_mcap(out_path: str, lines: List[Dict[str, Any]],
               frames: Optional[Iterable[np.ndarray]], start_ns: int = 0,
               fps: float = 30.0, jpeg_quality: int = 90) -> Dict[str, int]:
    """Writes the MCAP file; returns the message count per topic. frames
    (or None: no image channel) must give one image per log line."""
    from mcap.well_known import MessageEncoding, SchemaEncoding
    from mcap.writer import Writer
    # the ROS 2 CDR encoder of the mcap-ros2-support package (its own
    # Writer uses it the same way)
    from mcap_ros2._dynamic import serialize_dynamic

    encode_image = serialize_dynamic(IMAGE_TYPE, IMAGE_MSGDEF)[IMAGE_TYPE]
    encode_pose = serialize_dynamic(POSE_TYPE, POSE_MSGDEF)[POSE_TYPE]
    encode_scan = serialize_dynamic(SCAN_TYPE, SCAN_MSGDEF)[SCAN_TYPE]
    counts = {IMAGE_TOPIC: 0, POSE_TOPIC: 0, DETECTIONS_TOPIC: 0,
              SCAN_TOPIC: 0}
    tmp = out_path + ".part"
    with open(tmp, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="gst-landmark record")
        image_schema = w.register_schema(IMAGE_TYPE, SchemaEncoding.ROS2,
                                         IMAGE_MSGDEF.encode())
        pose_schema = w.register_schema(POSE_TYPE, SchemaEncoding.ROS2,
                                        POSE_MSGDEF.encode())
        det_schema = w.register_schema(
            DETECTIONS_SCHEMA, SchemaEncoding.JSONSchema,
            json.dumps(DETECTIONS_JSON_SCHEMA).encode())
        channels = {
            IMAGE_TOPIC: w.register_channel(IMAGE_TOPIC, MessageEncoding.CDR,
                                            image_schema),
            POSE_TOPIC: w.register_channel(POSE_TOPIC, MessageEncoding.CDR,
                                           pose_schema),
            DETECTIONS_TOPIC: w.register_channel(
                DETECTIONS_TOPIC, MessageEncoding.JSON, det_schema),
        }
        if any(isinstance(x.get("floor"), dict) for x in lines):
            channels[SCAN_TOPIC] = w.register_channel(
                SCAN_TOPIC, MessageEncoding.CDR, w.register_schema(
                    SCAN_TYPE, SchemaEncoding.ROS2, SCAN_MSGDEF.encode()))

        def add(topic, t, data):
            w.add_message(channels[topic], log_time=t, publish_time=t,
                          data=data, sequence=counts[topic])
            counts[topic] += 1

        frame_iter = iter(frames) if frames is not None else None
        for index, line in enumerate(lines):
            t = start_ns + _frame_time(line, index, fps)
            if frame_iter is not None:
                image = next(frame_iter, None)
                if image is None:
                    raise CliError(f"the video has {index} frames, the log "
                                   f"{len(lines)} lines: they must be of "
                                   f"the same run")
                ok, jpeg = cv2.imencode(
                    ".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
                if not ok:
                    raise CliError(f"frame {index}: JPEG encoding failed")
                add(IMAGE_TOPIC, t, encode_image({
                    "header": {"stamp": _stamp(t), "frame_id": "camera"},
                    "format": "jpeg", "data": jpeg.tobytes()}))
            pose = line.get("pose")
            if isinstance(pose, dict) and "x" in pose and "heading" in pose:
                add(POSE_TOPIC, t, encode_pose(pose_message(pose, t)))
            floor = line.get("floor")
            if isinstance(floor, dict) and "bearing-bins" in floor:
                add(SCAN_TOPIC, t, encode_scan(scan_message(floor, t)))
            det = {"frame": line["frame"],
                   "detections": line.get("detections", [])}
            if "pts" in line:
                det["pts"] = line["pts"]
            add(DETECTIONS_TOPIC, t, json.dumps(det).encode())
        if frame_iter is not None and next(frame_iter, None) is not None:
            raise CliError(f"the video has more frames than the log's "
                           f"{len(lines)} lines: they must be of the same "
                           f"run")
        w.finish()
    os.replace(tmp, out_path)
    if SCAN_TOPIC not in channels:
        del counts[SCAN_TOPIC]      # no floor profile, no channel
    return counts


def record(out_path: str, log: Optional[str] = None,
           video: Optional[str] = None, input_path: Optional[str] = None,
           config: Optional[str] = None, sets=(), start_ns: int = 0,
           stream=None) -> Dict[str, int]:
    """The command: runs the chain (input_path) or converts (log, video);
    returns the message count per topic."""
    stream = stream or sys.stdout
    try:
        if input_path is not None:
            if log is not None or video is not None:
                raise CliError("give either --input (run the chain) or "
                               "--log with --video (convert), not both")
            from . import runner
            with tempfile.TemporaryDirectory(prefix="gst-landmark-record-") \
                    as tmp:
                with open(os.devnull, "w") as quiet:
                    status, _ = runner.run("file", input_path, config=config,
                                           out_dir=tmp, sets=sets,
                                           progress=False, stream=quiet)
                if status != 0:
                    raise CliError("the chain did not finish", status)
                lines = read_log(os.path.join(tmp, runner.LOG_NAME))
                counts = write_mcap(out_path, lines, video_frames(
                    os.path.join(tmp, runner.VIDEO_NAME)), start_ns)
        else:
            if log is None:
                raise CliError("give --input (run the chain) or --log "
                               "(convert landmarklog's output)")
            lines = read_log(log)
            counts = write_mcap(out_path, lines,
                                video_frames(video) if video else None,
                                start_ns)
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
        description="Write the overlay frames (sensor_msgs/CompressedImage), "
                    "the pose (geometry_msgs/PoseWithCovarianceStamped) and "
                    "the detections (JSON) as an MCAP file for Foxglove "
                    "Studio or ros2 bag: either run the chain on a video "
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
                        "frame per log line (leave out for no images)")
    p.add_argument("--start-time", type=float, default=0.0, metavar="S",
                   help="seconds since 1970 added to the stream times "
                        "(default 0: stream time)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        record(args.output, log=args.log, video=args.video,
               input_path=args.input, config=args.config, sets=args.sets,
               start_ns=int(round(args.start_time * 1e9)))
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
    return 0
