"""``gst-landmark run --foxglove``: the channels of ``gst-landmark record``
served live over the Foxglove WebSocket protocol (``foxglove.websocket.v1``)
with the foxglove-sdk server, so Foxglove Studio shows a running chain.

The messages are the recording's (ros.RecordingChannels): the same
topics, ROS 2 types and CDR bytes, so one Foxglove layout serves a live
robot and its recordings. Each frame's source is landmarklog's line (the
element is set to hand every line to its file at once and the line is
read back when the frame leaves the chain), the overlay image is the
frame after landmarkoverlay and the camera image the frame entering
labsegment. Images are JPEG-encoded only while a client subscribes.

The server binds 127.0.0.1 by default: the protocol has no
authentication, so another address is refused unless asked for
explicitly (docs/record.md says how to reach it safely from elsewhere).
"""

from __future__ import annotations

import collections
import sys
import threading
import time
from typing import Any, Dict, Optional

import numpy as np

from .. import rosmessages as ros
from ..pipeline import elements_by_factory
from .common import PROG, CliError

DEFAULT_PORT = 8765
DEFAULT_HOST = "127.0.0.1"
# the mounting and the map go out again this often, for clients that
# join later (the protocol has no latched topics)
REPEAT_OPENING_NS = 1_000_000_000
# after the end of the run, so the clients get the last messages
DRAIN_S = 0.5

# raw video format -> (bytes per pixel, cv2 conversion to BGR, first byte)
_PACKED = {"BGR": (3, None, 0), "RGB": (3, "COLOR_RGB2BGR", 0),
           "BGRx": (4, None, 0), "BGRA": (4, None, 0),
           "RGBx": (4, "COLOR_RGB2BGR", 0), "RGBA": (4, "COLOR_RGB2BGR", 0),
           "xBGR": (4, None, 1), "ABGR": (4, None, 1),
           "xRGB": (4, "COLOR_RGB2BGR", 1), "ARGB": (4, "COLOR_RGB2BGR", 1)}


# run's options (the one table, as argparse takes them)
_OPTIONS = (
    ("--foxglove", {"metavar": "PORT", "type": int, "nargs": "?",
                    "const": DEFAULT_PORT, "default": None,
                    "help": f"serve on PORT ({DEFAULT_PORT} without a "
                            f"value; 0: any free port, printed); a file "
                            f"input plays at its own frame rate"}),
    ("--foxglove-host", {"metavar": "ADDR", "default": DEFAULT_HOST,
                         "help": "address to bind (default %(default)s; "
                                 "another needs --foxglove-expose)"}),
    ("--foxglove-expose", {"action": "store_true",
                           "help": "allow a non-loopback --foxglove-host "
                                   "(the protocol has no authentication)"}),
    ("--foxglove-wait", {"action": "store_true",
                         "help": "start the pipeline once a client "
                                 "subscribes"}),
)


def add_foxglove_arguments(parser) -> None:
    group = parser.add_argument_group(
        "Foxglove live", "serve the channels of 'gst-landmark record' live "
        "over the Foxglove WebSocket protocol (docs/record.md)")
    for flag, options in _OPTIONS:
        group.add_argument(flag, **options)


def foxglove_options(args) -> Optional[Dict[str, Any]]:
    """run's foxglove argument from the parsed options (None: not asked)."""
    if args.foxglove is None:
        return None
    return {"port": args.foxglove, "host": args.foxglove_host,
            "expose": args.foxglove_expose, "wait": args.foxglove_wait}


def check_host(host: str, expose: bool, stream=None) -> None:
    """Refuses an address other than loopback unless expose; warns when
    it serves one."""
    from ..webguard import is_loopback
    if is_loopback(host):
        return
    if not expose:
        raise CliError(
            f"--foxglove-host {host}: not a loopback address, and the "
            f"Foxglove protocol has no authentication (anyone who reaches "
            f"the port sees the camera); add --foxglove-expose to serve it "
            f"anyway, or keep 127.0.0.1 and use an SSH tunnel "
            f"(docs/record.md)")
    print(f"{PROG}: WARNING: Foxglove server on {host}: no authentication, "
          f"anyone who can reach this port sees the camera and the "
          f"robot's pose", file=stream or sys.stderr, flush=True)


def _plane(data: np.ndarray, offset: int, stride: int, rows: int,
           row_bytes: int) -> np.ndarray:
    return np.lib.stride_tricks.as_strided(
        data[offset:], shape=(rows, row_bytes), strides=(stride, 1))


def frame_bgr(caps, buffer) -> Optional[np.ndarray]:
    """The frame as a BGR array (a copy), or None for a format it does not
    convert (the packed RGB family, I420, NV12 and YUY2 of even size)."""
    import cv2
    from gi.repository import Gst, GstVideo
    from ..gicompat import caps_structure
    info = GstVideo.VideoInfo.new_from_caps(caps)
    if info is None:
        return None
    fmt = caps_structure(caps).get_string("format")
    w, h = info.width, info.height
    ok, mapped = buffer.map(Gst.MapFlags.READ)
    if not ok:
        return None
    try:
        data = np.frombuffer(mapped.data, np.uint8)
        stride, offset = info.stride, info.offset
        if fmt in _PACKED:
            bpp, code, first = _PACKED[fmt]
            pixels = _plane(data, offset[0], stride[0], h, w * bpp)
            pixels = pixels.reshape(h, w, bpp)[:, :, first:first + 3]
            return cv2.cvtColor(pixels, getattr(cv2, code)) if code \
                else np.ascontiguousarray(pixels)
        if w % 2 or h % 2:
            return None
        if fmt == "YUY2":
            yuyv = _plane(data, offset[0], stride[0], h, 2 * w)
            return cv2.cvtColor(yuyv.reshape(h, w, 2),
                                cv2.COLOR_YUV2BGR_YUY2)
        if fmt == "I420":
            planes = [_plane(data, offset[0], stride[0], h, w),
                      _plane(data, offset[1], stride[1], h // 2, w // 2),
                      _plane(data, offset[2], stride[2], h // 2, w // 2)]
            code = cv2.COLOR_YUV2BGR_I420
        elif fmt == "NV12":
            planes = [_plane(data, offset[0], stride[0], h, w),
                      _plane(data, offset[1], stride[1], h // 2, w)]
            code = cv2.COLOR_YUV2BGR_NV12
        else:
            return None
        packed = np.concatenate([p.ravel() for p in planes])
        return cv2.cvtColor(packed.reshape(h * 3 // 2, w), code)
    finally:
        buffer.unmap(mapped)


def _listener():
    """The server listener: its subscribed is set at a client's first
    subscription (the SDK's ServerListener answers everything else)."""
    from foxglove.websocket import ServerListener

    class Subscriptions(ServerListener):
        def __init__(self):
            self.subscribed = threading.Event()

        def on_subscribe(self, client, channel) -> None:
            self.subscribed.set()

    return Subscriptions()


class LiveServer:
    """The Foxglove server of one run. attach(pipe) before the pipeline
    plays finds landmarklog (required), landmarkoverlay and labsegment,
    opens the channels and starts serving; stop() after the run."""

    def __init__(self, port: int = DEFAULT_PORT, host: str = DEFAULT_HOST,
                 camera: Optional[Dict[str, Any]] = None,
                 landmarks=None, wait: bool = False, pace: bool = False,
                 stream=None):
        self.port, self.host = port, host
        self.camera, self.landmarks = camera, landmarks
        self.wait, self.pace = wait, pace
        self.stream = stream or sys.stderr
        self.server = None
        self._camera_images: collections.deque = collections.deque()
        self._log = None
        self._log_path = ""
        self._partial = ""
        self._index = 0
        self._start_ns = 0
        self._last_opening: Optional[int] = None
        self._warned = set()

    def attach(self, pipe) -> None:
        import foxglove
        found = elements_by_factory(pipe)
        log = found.get("landmarklog")
        if log is None:
            raise CliError("--foxglove needs a pipeline with landmarklog "
                           "(its lines are what the channels send)")
        log.set_property("flush-every", 1)
        self._log_path = log.get_property("location")
        overlay = found.get("landmarkoverlay")
        segment = found.get("labsegment")
        self.messages = ros.RecordingChannels(
            overlay=overlay is not None, camera_images=segment is not None,
            camera=self.camera, landmarks=self.landmarks,
            scan="floorboundary" in found)
        self.encoders = self.messages.encoders()
        # the channels live as long as their context
        self.context = context = foxglove.Context()
        self.channels = {
            topic: foxglove.Channel(
                topic, message_encoding="cdr", context=context,
                schema=foxglove.Schema(
                    name=typ, encoding="ros2msg",
                    data=self.messages.definitions[typ].encode()))
            for topic, typ in self.messages.topics.items()}
        self.listener = _listener()
        try:
            self.server = foxglove.start_server(
                name="gst-landmark", host=self.host, port=self.port,
                context=context, server_listener=self.listener)
        except Exception as err:    # the SDK's RuntimeError: port in use
            raise CliError(f"--foxglove {self.port}: cannot serve on "
                           f"{self.host}: {err}") from None
        print(f"{PROG}: Foxglove: serving {len(self.channels)} channels on "
              f"ws://{self.host}:{self.server.port} (Foxglove Studio: Open "
              f"connection, Foxglove WebSocket)", file=self.stream,
              flush=True)
        if segment is not None:
            segment.get_static_pad("sink").add_probe(
                _buffer_probe(), self._on_camera_frame)
        end = overlay if overlay is not None else log
        end.get_static_pad("src").add_probe(_buffer_probe(), self._on_frame)
        if self.wait:
            print(f"{PROG}: Foxglove: waiting for a client to subscribe",
                  file=self.stream, flush=True)
            while not self.listener.subscribed.wait(0.2):
                pass
        self._start_ns = time.time_ns()

    def stop(self) -> None:
        if self.server is not None:
            time.sleep(DRAIN_S)
            self.server.stop()
            self.server = None
        if self._log is not None:
            self._log.close()
            self._log = None

    # -- streaming thread ---------------------------------------------------

    def _jpeg_if_wanted(self, topic: str, pad, buffer) -> Optional[bytes]:
        if not self.channels[topic].has_sinks():
            return None
        image = frame_bgr(pad.get_current_caps(), buffer)
        if image is None:
            self._warn_once(topic, f"{topic}: the frames' format "
                            f"({pad.get_current_caps().to_string()}) is "
                            f"not converted; no images on this channel")
            return None
        return ros.jpeg(image, self._index)

    def _on_camera_frame(self, pad, info):
        from gi.repository import Gst
        try:
            image = self._jpeg_if_wanted(ros.CAMERA_IMAGE_TOPIC, pad,
                                         info.get_buffer())
        except Exception as err:    # a viewer must never stop the robot
            # (a probe that raises returns None: DROP, and the chain
            # would see no frame)
            self._warn_once("camera", f"Foxglove: a camera image was not "
                            f"made ({type(err).__name__}: {err})")
            image = None
        self._camera_images.append(image)
        return Gst.PadProbeReturn.OK

    def _next_line(self) -> Optional[Dict[str, Any]]:
        import json
        if self._log is None:
            self._log = open(self._log_path, encoding="utf-8")
        self._partial += self._log.readline()
        if not self._partial.endswith("\n"):
            return None
        line, self._partial = self._partial, ""
        return json.loads(line)

    def _on_frame(self, pad, info):
        from gi.repository import Gst
        try:
            self._send_frame(pad, info.get_buffer())
        except Exception as err:    # a viewer must never stop the robot
            self._warn_once("send", f"Foxglove: a frame was not sent "
                            f"({type(err).__name__}: {err})")
        self._index += 1
        return Gst.PadProbeReturn.OK

    def _send_frame(self, pad, buffer) -> None:
        camera_jpeg = self._camera_images.popleft() \
            if self._camera_images else None
        line = self._next_line()
        if line is None:
            self._warn_once("line", f"Foxglove: {self._log_path} had no "
                            f"line for frame {self._index}")
            return
        overlay_jpeg = self._jpeg_if_wanted(ros.IMAGE_TOPIC, pad, buffer) \
            if ros.IMAGE_TOPIC in self.channels else None
        t = self._start_ns + ros.frame_time(line, self._index, 30.0)
        if self.pace:
            # a file plays at its own rate, as a camera would
            delay = (t - time.time_ns()) / 1e9
            if delay > 0:
                time.sleep(min(delay, 1.0))
        if self._last_opening is None or \
                t - self._last_opening >= REPEAT_OPENING_NS:
            colours = ros.class_colours([line])
            self._send(t, self.messages.opening(t, colours))
            self._last_opening = t
        self._send(t, self.messages.frame(line, t, overlay_jpeg,
                                          camera_jpeg))

    def _send(self, t: int, messages) -> None:
        for topic, msg in messages:
            self.channels[topic].log(self.encoders[topic](msg), log_time=t)

    def _warn_once(self, key: str, text: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            print(f"{PROG}: warning: {text}", file=self.stream, flush=True)


def _buffer_probe():
    from gi.repository import Gst
    return Gst.PadProbeType.BUFFER
