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
import os
import sys
import tempfile
import time
from typing import Any, Dict, Iterable, Iterator, List, Optional

import cv2
import numpy as np

from ..rosmessages import RecordingChannels, class_colours, frame_time, \
    jpeg
from .common import PROG, CliError, camera_and_map


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

    channels_of_run = RecordingChannels(
        overlay=frames is not None, camera_images=camera_frames is not None,
        camera=camera, landmarks=landmarks,
        scan=any(isinstance(x.get("floor"), dict) for x in lines))
    topics, defs = channels_of_run.topics, channels_of_run.definitions
    encoders = channels_of_run.encoders()
    counts = {t: 0 for t in topics}
    tmp = out_path + ".part"
    with open(tmp, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="gst-landmark record")
        schemas, channels = {}, {}
        for topic, typ in topics.items():
            if typ not in schemas:
                schemas[typ] = w.register_schema(typ, SchemaEncoding.ROS2,
                                                 defs[typ].encode())
            channels[topic] = w.register_channel(topic, MessageEncoding.CDR,
                                                 schemas[typ])

        def add(t, messages):
            for topic, msg in messages:
                w.add_message(channels[topic], log_time=t, publish_time=t,
                              data=encoders[topic](msg),
                              sequence=counts[topic])
                counts[topic] += 1

        t0 = start_ns + (frame_time(lines[0], 0, fps) if lines else 0)
        add(t0, channels_of_run.opening(t0, class_colours(lines)))
        frame_iter = iter(frames) if frames is not None else None
        camera_iter = iter(camera_frames) if camera_frames is not None \
            else None
        last_pose_index = max((i for i, x in enumerate(lines)
                               if isinstance(x.get("pose"), dict)),
                              default=-1)
        for index, line in enumerate(lines):
            t = start_ns + frame_time(line, index, fps)
            images = []
            for it in (frame_iter, camera_iter):
                image = next(it, None) if it is not None else None
                if it is not None and image is None:
                    raise CliError(f"the video has {index} frames, the log "
                                   f"{len(lines)} lines: they must be of "
                                   f"the same run")
                images.append(None if image is None
                              else jpeg(image, index, jpeg_quality))
            add(t, channels_of_run.frame(line, t, *images,
                                         last_pose=index == last_pose_index))
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
        end = frame_time(last, len(lines) - 1, 30.0) + int(
            last.get("duration") or 0)
    return max(0, int(os.stat(path).st_mtime_ns) - end)


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
            camera, landmarks = camera_and_map(
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
            camera, landmarks = camera_and_map(camera_file, map_file)
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
