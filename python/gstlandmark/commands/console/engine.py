"""The console's pipeline: the chain on a file, a camera or a test source,
with a tee to two appsinks (the raw frame with its metadata, and the
overlay as JPEG), live tuning checked against the elements' own
GParamSpecs, and palette teaching.

Streaming threads only hand results to the asyncio loop (``Handoff``:
the newest one, never a queue); everything else runs on the loop.
"""

from __future__ import annotations

import asyncio
import dataclasses
import glob
import json
import math
import os
import re
import threading
import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import cv2
import numpy as np

from ... import meta, palette as pal, paletteaudit, pipeline
from ... import reference
from ...camerafile import (CalibrationError, is_camera_info_file,
                           read_camera_file, read_mounting, write_camera_info)
from ...landmarkmap import MapError, read_map
from ...gicompat import caps_structure, enum_class
from .. import runner

from gi.repository import GObject  # noqa: E402  (after pipeline's gi setup)

Gst = pipeline.Gst

# The properties a user tunes from the page, per element (the ranges come
# from the elements at run time, never from here).
TUNABLE: Dict[str, Tuple[str, ...]] = {
    "labsegment": ("min-class-pixels", "max-distance", "use-lightness",
                   "rare-classes"),
    "blobroundness": ("min-area", "max-area", "max-aspect", "min-roundness",
                      "min-ellipse-fit", "shape", "morphology",
                      "keep-rejected"),
    "ipmrange": ("camera-height", "tilt", "roll", "hfov", "range-method",
                 "marker-diameter", "pixel-sigma"),
    "trilaterate": ("filter", "gate", "inlier-distance", "max-age"),
    "landmarkoverlay": ("show-detections", "show-rejected", "show-pose",
                        "show-histogram", "show-indicators", "show-minimap",
                        "text-scale"),
}
CHAIN = ("labsegment", "blobroundness", "ipmrange", "trilaterate",
         "landmarkoverlay")
PATH_LENGTH = 2000      # poses kept for browsers that join late
UNDO_DEPTH = 20
JPEG_QUALITY = 80
FROZEN_KEPT = 4         # frozen teaching frames kept (one per browser)
# what ``palette learn`` does by default, so both give one palette
TEACH_REFERENCES = "auto"
UNTAUGHT_CLASS = "untaught"
MAX_TOLERANCE = 64.0    # the palette's widest shading, 1/64 to 64
# a box's histograms: bins over L*, a*, b*
STATISTICS_BINS = 32
STATISTICS_RANGES = (("L", 0.0, 100.0), ("a", -128.0, 128.0),
                     ("b", -128.0, 128.0))
LOG_MAX_BYTES = 64 * 1024 * 1024    # a run's log file before it rotates
LOG_KEEP = 20           # log files kept in OUT/logs (the oldest go)
# The camera file's keys of the mounting properties: what the file holds
# overrides the property (ipmrange's calibration), so the console tunes
# these in a copy of the file.
CAMERA_KEYS = {"camera-height": "camera_height", "tilt": "tilt_deg",
               "roll": "roll_deg"}
# Values an element accepts but no robot has, refused by the console.
CONSOLE_MINIMUM = {
    ("ipmrange", "camera-height"): (
        0.01, "a camera less than 1 cm above the floor measures no range"),
}


class ConsoleError(ValueError):
    """A request that cannot be carried out; the message says why."""


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _plain(value):
    """A structure value as JSON-ready data."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    return str(value)


def property_spec(element: Gst.Element, name: str) -> Dict[str, Any]:
    """Type, range, default and current value of one property, read from
    the element's GParamSpec."""
    pspec = element.find_property(name)
    if pspec is None:
        raise ConsoleError(f"{element.get_name()} has no property "
                           f"{name!r}")
    vtype = pspec.value_type
    spec: Dict[str, Any] = {"name": name, "blurb": pspec.blurb}
    value = element.get_property(name)
    if vtype == GObject.TYPE_BOOLEAN:
        spec.update(type="boolean", default=bool(pspec.default_value),
                    value=bool(value))
    elif vtype in (GObject.TYPE_UINT, GObject.TYPE_INT, GObject.TYPE_UINT64,
                   GObject.TYPE_INT64, GObject.TYPE_ULONG,
                   GObject.TYPE_LONG):
        spec.update(type="integer", minimum=int(pspec.minimum),
                    maximum=int(pspec.maximum),
                    default=int(pspec.default_value), value=int(value))
    elif vtype in (GObject.TYPE_DOUBLE, GObject.TYPE_FLOAT):
        spec.update(type="number", minimum=float(pspec.minimum),
                    maximum=float(pspec.maximum),
                    default=float(pspec.default_value), value=float(value))
        factory = element.get_factory()
        floor = CONSOLE_MINIMUM.get(
            (factory.get_name() if factory else "", name))
        if floor is not None and floor[0] > spec["minimum"]:
            spec["minimum"], spec["why_minimum"] = floor
    elif vtype.is_a(GObject.TYPE_ENUM):
        enum = enum_class(vtype)
        nicks = [v.value_nick for v in
                 sorted(enum.__enum_values__.values(), key=int)]
        spec.update(type="enum", choices=nicks,
                    default=enum(int(pspec.default_value)).value_nick,
                    value=enum(int(value)).value_nick)
    else:
        spec.update(type="other", value=_plain(value))
    return spec


def check_value(element_name: str, spec: Dict[str, Any], value):
    """The value to set, or ConsoleError naming element, property and
    fault."""
    where = f"{element_name}.{spec['name']}"
    kind = spec["type"]
    if kind == "boolean":
        if not isinstance(value, bool):
            raise ConsoleError(f"{where}: expected true or false, got "
                               f"{json.dumps(value)}")
        return value
    if kind == "enum":
        if value not in spec["choices"]:
            raise ConsoleError(f"{where}: expected one of "
                               f"{', '.join(spec['choices'])}, got "
                               f"{json.dumps(value)}")
        return value
    if kind in ("integer", "number"):
        if not _is_number(value):
            raise ConsoleError(f"{where}: expected a number, got "
                               f"{json.dumps(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise ConsoleError(f"{where}: expected a finite number")
        if kind == "integer":
            if isinstance(value, float):
                if not value.is_integer():
                    raise ConsoleError(f"{where}: expected an integer, got "
                                       f"{value!r}")
                value = int(value)
        else:
            value = float(value)
        if not spec["minimum"] <= value <= spec["maximum"]:
            why = f" ({spec['why_minimum']})" if "why_minimum" in spec \
                and value < spec["minimum"] else ""
            raise ConsoleError(f"{where}: {value!r} is outside "
                               f"{spec['minimum']!r}..{spec['maximum']!r}"
                               f"{why}")
        return value
    raise ConsoleError(f"{where}: cannot be set from the console")


def read_landmarks(map_path: Optional[str]) -> List[Dict[str, Any]]:
    """The map's landmarks for the page's mini-map ([] without a map; a
    map the elements cannot read stops the pipeline with its error)."""
    if not map_path:
        return []
    try:
        return read_map(map_path)
    except MapError:
        return []


def error_text(msg: Gst.Message) -> str:
    """An error message as "element: message (debug)"."""
    err, debug = msg.parse_error()
    source = msg.src.get_name() if msg.src is not None else "?"
    text = f"{source}: {err.message}"
    return f"{text} ({debug})" if debug else text


def source_fragment(input_path: Optional[str] = None,
                    camera: Optional[str] = None,
                    testsrc: bool = False) -> str:
    """The launch fragment that produces raw video for the chain."""
    chosen = [x for x in (input_path, camera, testsrc or None)
              if x is not None]
    if len(chosen) != 1:
        raise ConsoleError("give one of --input FILE, --camera /dev/videoN "
                           "or --testsrc")
    if input_path is not None:
        if not os.path.isfile(input_path):
            raise ConsoleError(f"{input_path}: no such file")
        return (f"filesrc location={runner.quote(os.path.abspath(input_path))}"
                " ! decodebin")
    if camera is not None:
        if not os.path.exists(camera):
            raise ConsoleError(f"{camera}: no such device")
        # decodebin passes raw video through and decodes MJPEG cameras
        return f"v4l2src device={runner.quote(camera)} ! decodebin"
    return "videotestsrc is-live=true pattern=ball ! video/x-raw,width=640," \
           "height=480,framerate=30/1"


VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".webm", ".mjpeg",
                  ".mjpg")


def list_sources(out_dir: str, start_source: str
                 ) -> Dict[str, Dict[str, str]]:
    """The sources a browser may choose, by id: the one given at start,
    the test source, every V4L2 camera, and video files under the output
    folder (nothing else: a client names an id, never a path)."""
    sources = {"start": {"label": "as started", "fragment": start_source},
               "testsrc": {"label": "test source",
                           "fragment": source_fragment(testsrc=True)}}
    for device in sorted(glob.glob("/dev/video*")):
        sources[f"camera:{device}"] = {
            "label": device, "fragment": source_fragment(camera=device)}
    root = os.path.realpath(out_dir)
    for folder, dirs, files in os.walk(root):
        if folder[len(root):].count(os.sep) >= 2:
            dirs[:] = []            # two levels below the output folder
        for name in sorted(files):
            path = os.path.join(folder, name)
            # a link out of the folder is not under it
            if not name.lower().endswith(VIDEO_SUFFIXES) or \
                    not os.path.realpath(path).startswith(root + os.sep):
                continue
            rel = os.path.relpath(path, root)
            sources[f"file:{rel}"] = {
                "label": rel, "fragment": source_fragment(input_path=path)}
    return sources


def trial_start(element: Gst.Element, changes: Dict[str, Any]) -> None:
    """Starts a copy of ``element`` with ``changes`` set, alone: a value
    its own checks refuse (those its GParamSpec cannot say, such as
    camera-height 0, or min-area above max-area) is a ConsoleError naming
    element and property, and nothing is set on ``element``."""
    factory = element.get_factory()
    trial = factory.create(None)
    flags = GObject.ParamFlags
    for pspec in element.list_properties():
        if pspec.name in ("name", "parent") or \
                not pspec.flags & flags.READABLE or \
                not pspec.flags & flags.WRITABLE or \
                pspec.flags & flags.CONSTRUCT_ONLY:
            continue
        trial.set_property(pspec.name, element.get_property(pspec.name))
    for prop, value in changes.items():
        trial.set_property(prop, value)
    bus = Gst.Bus.new()
    trial.set_bus(bus)
    try:
        ret = trial.set_state(Gst.State.PAUSED)
        msg = bus.pop_filtered(Gst.MessageType.ERROR)
    finally:
        trial.set_state(Gst.State.NULL)
        trial.set_bus(None)
    if ret != Gst.StateChangeReturn.FAILURE:
        return
    name = element.get_name()
    if msg is None:
        raise ConsoleError(f"{name}: refused {', '.join(changes)}")
    err, debug = msg.parse_error()
    # "Invalid 'camera-height' value." and, last in the debug text, why
    quoted = re.search(r"'([a-z0-9-]+)'", err.message)
    prop = quoted.group(1) if quoted else next(iter(changes))
    why = (debug or "").strip().splitlines()[-1:] or [err.message]
    raise ConsoleError(f"{name}.{prop}: {why[0]}")


def copy_camera_file(source: str, path: str,
                     values: Dict[str, float]) -> None:
    """Writes the camera file ``source`` to ``path`` (the same format)
    with its top-level ``values`` (file keys) replaced."""
    if is_camera_info_file(source):
        try:
            camera = read_camera_file(source)
            mounting = read_mounting(source)
            mounting.update({key: float(v) for key, v in values.items()})
            write_camera_info(path, camera,
                              camera.get("camera_name") or "camera",
                              mounting)
        except CalibrationError as err:
            raise ConsoleError(str(err)) from None
        return
    fs = cv2.FileStorage(source, cv2.FILE_STORAGE_READ)
    out = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    try:
        for key in fs.root().keys():
            node = fs.getNode(key)
            if key in values:
                out.write(key, float(values[key]))
            elif node.isString():
                out.write(key, node.string())
            elif node.isInt():
                out.write(key, int(node.real()))
            elif node.isReal():
                out.write(key, node.real())
            elif node.isMap() and node.mat() is not None:
                out.write(key, node.mat())
            else:
                raise ConsoleError(f"{source}: cannot copy its {key!r} "
                                   f"to tune the camera")
    finally:
        fs.release()
        out.release()


def read_camera_mounting(path: Optional[str]) -> Dict[str, float]:
    """The mounting properties a camera file holds ({} without one)."""
    if not path:
        return {}
    if is_camera_info_file(path):
        try:
            mounting = read_mounting(path)
        except CalibrationError:
            return {}
        return {prop: mounting[key] for prop, key in CAMERA_KEYS.items()
                if key in mounting}
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    try:
        if not fs.isOpened():
            return {}
        return {prop: fs.getNode(key).real()
                for prop, key in CAMERA_KEYS.items()
                if not fs.getNode(key).empty()}
    finally:
        fs.release()


class Handoff:
    """From a streaming thread to the loop, the newest item only: at most
    one callback waits on the loop per channel, so a loop that falls
    behind skips items instead of piling them up in memory."""

    def __init__(self, loop: asyncio.AbstractEventLoop,
                 consumer: Callable[..., None]):
        self.loop, self.consumer = loop, consumer
        self.lock = threading.Lock()
        self.item: Optional[tuple] = None
        self.dropped = 0

    def put(self, *item) -> None:
        with self.lock:
            waiting = self.item is not None
            if waiting:
                self.dropped += 1
            self.item = item
        if not waiting:
            self.loop.call_soon_threadsafe(self._deliver)

    def _deliver(self) -> None:
        with self.lock:
            item, self.item = self.item, None
        if item is not None:
            self.consumer(*item)


class LatestJpeg:
    """The newest JPEG of one video view, for any number of MJPEG
    readers on the loop (each takes the newest, skipping what it
    missed)."""

    def __init__(self):
        self.data: Optional[bytes] = None
        self.seq = 0
        self.time = 0.0
        self.pts: Optional[float] = None
        self.readers = 0
        self.closed = False
        self._waiter: Optional[asyncio.Future] = None

    def publish(self, data: bytes, now: float,
                pts: Optional[float]) -> None:
        self.data, self.time, self.pts = data, now, pts
        self.seq += 1
        self._wake()

    def close(self) -> None:
        """Ends every reader (the server is shutting down)."""
        self.closed = True
        self._wake()

    def _wake(self) -> None:
        waiter, self._waiter = self._waiter, None
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    async def next(self, after_seq: int
                   ) -> Tuple[int, bytes, float, Optional[float]]:
        """The newest JPEG newer than ``after_seq`` (waits for one);
        EOFError once closed."""
        while self.seq <= after_seq or self.data is None:
            if self.closed:
                raise EOFError("closed")
            if self._waiter is None:
                self._waiter = asyncio.get_running_loop().create_future()
            await asyncio.shield(self._waiter)
        return self.seq, self.data, self.time, self.pts



def _check_box(what: str, *xywh) -> None:
    """x, y, w, h must be integers (frame pixels)."""
    for label, v in zip("xywh", xywh):
        if not isinstance(v, int) or isinstance(v, bool):
            raise ConsoleError(f"{what}: {label} must be an integer "
                               f"(frame pixels), got {json.dumps(v)}")


def _keep_newest(paths: List[str], path: str, keep: int = 3) -> None:
    """Appends path to the files the console wrote for the elements and
    removes the oldest beyond ``keep``: an element may still be reading
    the one before the newest."""
    paths.append(path)
    while len(paths) > keep:
        try:
            os.remove(paths.pop(0))
        except OSError:
            pass

class Teaching:
    """The boxes taught so far, on the frames they were drawn on, and the
    palette they are learned beside (immutable: each box makes a new
    one, so undo takes the one before).

    The boxes are learned together by ``palette.learn_from_images`` with
    ``palette learn``'s defaults (several references per class, the rest
    of the frames as "untaught"), then take their places in the base
    palette: a class taught keeps its place, a new one comes after. The
    rest of the frames is learned only when no class of the base is left
    beside the taught ones (it would take their colours)."""

    def __init__(self, base: pal.Palette, lessons=(), roles=None,
                 shading=None):
        self.base = base
        # (frame id, frame, (name, x, y, w, h)) in the order taught
        self.lessons: Tuple[Tuple[int, np.ndarray, tuple], ...] = \
            tuple(lessons)
        self.roles: Dict[str, str] = dict(roles or {})
        # the tolerances set on the page, kept when a class is re-taught
        self.shading: Dict[str, Tuple[float, float]] = dict(shading or {})

    def add(self, frame_id: int, frame: np.ndarray, rect: tuple,
            role: str) -> "Teaching":
        return Teaching(self.base, self.lessons + ((frame_id, frame, rect),),
                        {**self.roles, rect[0]: role}, self.shading)

    def edited(self, palette: pal.Palette, rename: Dict[str, str],
               shading=None) -> "Teaching":
        """The teaching after the user edited the palette into
        ``palette`` (a class renamed by ``rename``, old: new): the boxes
        of the classes still in it, learned beside it (so an edited class
        stays as edited, and the classes keep their places), except the
        untaught rest, which is learned again."""
        def keep(by_name):
            return {rename.get(n, n): v for n, v in by_name.items()
                    if rename.get(n, n) in palette.names}
        lessons = [(i, f, (rename.get(r[0], r[0]),) + tuple(r[1:]))
                   for i, f, r in self.lessons]
        base = [c for c in palette.classes if c.name != UNTAUGHT_CLASS or
                c.name in self.base.names]
        return Teaching(pal.Palette(base),
                        [x for x in lessons if x[2][0] in palette.names],
                        keep(self.roles), {**keep(self.shading),
                                           **(shading or {})})

    def frames(self) -> List[Tuple[int, np.ndarray, List[tuple]]]:
        """(frame id, frame, its boxes) in the order first taught on."""
        grouped: Dict[int, Tuple[int, np.ndarray, List[tuple]]] = {}
        for frame_id, frame, rect in self.lessons:
            grouped.setdefault(frame_id, (frame_id, frame, []))[2] \
                .append(rect)
        return list(grouped.values())

    def learn(self) -> Tuple[pal.Palette, List[str], Dict[str, float]]:
        """The palette, the warnings of paletteaudit (texts) and the
        spreads of the taught classes."""
        frames = self.frames()
        kept = [c for c in self.base.classes if c.name not in self.roles]
        by_role = {r: [n for n, role in self.roles.items() if role == r]
                   for r in ("background", "floor")}
        learned = pal.learn_from_images(
            [(frame, rects) for _, frame, rects in frames],
            background=by_role["background"], floor=by_role["floor"],
            references=TEACH_REFERENCES,
            untaught_class=None if kept else UNTAUGHT_CLASS,
            sources=[f"frame {frame_id}" for frame_id, _, _ in frames])
        findings, spread = paletteaudit.teaching_findings(learned, [
            (f"frame {frame_id}",
             reference.rgb_to_lab(np.ascontiguousarray(frame[:, :, ::-1])),
             rects) for frame_id, frame, rects in frames])
        new = {c.name: dataclasses.replace(
            c, shading=self.shading.get(c.name, c.shading))
            for c in learned.classes}
        classes = [new.pop(c.name, c) for c in self.base.classes]
        palette = pal.parse_palette(pal.palette_to_json(
            pal.Palette(classes + list(new.values()))), "teach")
        return palette, [f.text for f in findings], spread


class Engine:
    """The running chain and what the server needs from it.

    ``source`` is a launch fragment ending in raw video (see
    ``source_fragment``); ``loop_file`` seeks back to the start at EOS.
    """

    def __init__(self, source: str, out_dir: str,
                 palette_path: Optional[str] = None,
                 map_path: Optional[str] = None,
                 camera_path: Optional[str] = None,
                 properties: Optional[Dict[str, Dict[str, Any]]] = None,
                 loop_file: bool = True,
                 log_max_bytes: int = LOG_MAX_BYTES):
        self.source = source
        self.start_source, self.source_id = source, "start"
        self.out_dir = os.path.abspath(out_dir)
        os.makedirs(self.out_dir, exist_ok=True)
        self.map_path = map_path
        self.camera_path = camera_path
        # the file's mounting, as tuned (written to a copy of the file)
        self.camera_mounting = read_camera_mounting(camera_path)
        self.camera_live: Optional[str] = None
        self._live_cameras: List[str] = []
        self.loop_file = loop_file
        # one log file per run, named by its start time (a long run
        # rotates to a new file at log_max_bytes)
        self.log_dir = os.path.join(self.out_dir, "logs")
        os.makedirs(self.log_dir, exist_ok=True)
        self.log_max_bytes = log_max_bytes
        self.log_path = self._new_log_path()
        self.palette = (pal.load_palette(palette_path) if palette_path
                        else pal.default_palette())
        self.palette_path = palette_path
        self.undo_stack: List[Tuple[pal.Palette, Optional[str],
                                    "Teaching"]] = []
        # the boxes taught so far and the palette they are learned beside
        self.teaching = Teaching(self.palette)
        self.teach_warnings: List[str] = []
        self.palette_spread: Dict[str, float] = {}
        self._live_palettes: List[str] = []
        self._palette_serial = 0
        self.landmarks = read_landmarks(map_path)
        self.initial_properties = properties or {}
        self.loop: Optional[asyncio.AbstractEventLoop] = None
        self._handoffs: Dict[str, Handoff] = {}
        self.pipe: Optional[Gst.Pipeline] = None
        self.state = "stopped"
        self.error: Optional[str] = None
        # the newest overlay JPEG and false-colour classes (made only
        # while someone watches them)
        self.views = {"overlay": LatestJpeg(), "labels": LatestJpeg()}
        self.frame_bgr: Optional[np.ndarray] = None
        self.frame_pts: Optional[float] = None
        self.frame_period: Optional[float] = None     # seconds, files
        # frames frozen for teaching, by id (a few, the newest kept)
        self.frozen: Dict[int, Dict[str, Any]] = {}
        self._freeze_serial = 0
        # the newest results buffer: the classes view of a paused frame
        self._last_buffer: Optional[Gst.Buffer] = None
        self._duration: Optional[float] = None
        self.frame_index = 0
        self.path: List[Tuple[float, float]] = []
        self.listeners: List[Callable[[Dict[str, Any]], None]] = []
        self._times: List[float] = []
        self._bus_task: Optional[asyncio.Task] = None
        # per-element processing time of recent frames, by pts (written
        # by the chain's streaming thread, read by the results branch)
        self._cost_start: Dict[str, float] = {}
        self._costs: Dict[Any, Dict[str, float]] = {}
        self._costs_lock = threading.Lock()

    # -- the pipeline ------------------------------------------------------

    def launch_line(self) -> str:
        q = runner.quote
        maps = f" map={q(self.map_path)}" if self.map_path else ""
        camera_file = self.camera_live or self.camera_path
        camera = (f" calibration={q(camera_file)}" if camera_file else "")
        palette = (f" palette={q(self.palette_path)}"
                   if self.palette_path else "")
        pose = (f" ! trilaterate name=trilaterate{maps} post-messages=false"
                if self.map_path else "")
        queue = "queue max-size-buffers=2 max-size-bytes=0 max-size-time=0"
        sink = ("emit-signals=true max-buffers=1 drop=true sync="
                + ("true" if self.is_file else "false"))
        return (
            f"{self.source} ! videoconvert ! video/x-raw,format=BGR ! "
            f"labsegment name=labsegment{palette} ! "
            "blobroundness name=blobroundness ! "
            f"ipmrange name=ipmrange{camera}{maps}{pose} ! "
            # every line on disk at once: the download is current
            f"landmarklog name=log location={q(self.log_path)} "
            "flush-every=1 ! "
            "tee name=t "
            # For a file both sinks keep the clock (it plays at its own
            # rate, results and video together) and preroll (a frame
            # sought to while paused is shown). A live source keeps its
            # own pace: its frames go on as soon as they are done. A
            # browser never holds the sinks: the server hands it the
            # newest frame.
            f"t. ! {queue} ! appsink name=results {sink} "
            f"t. ! {queue} ! landmarkoverlay name=landmarkoverlay{maps} ! "
            f"videoconvert ! jpegenc quality={JPEG_QUALITY} ! "
            f"appsink name=jpeg {sink}")

    def elements(self) -> Dict[str, Gst.Element]:
        if self.pipe is None:
            return {}
        found = {}
        for name in CHAIN:
            element = self.pipe.get_by_name(name)
            if element is not None:
                found[name] = element
        return found

    def build(self) -> None:
        pipeline.init()
        try:
            self.pipe = Gst.parse_launch(self.launch_line())
        except Exception as err:    # GLib.Error: unknown element, syntax
            raise ConsoleError(f"cannot build the pipeline: "
                               f"{getattr(err, 'message', err)}") from None
        # preroll too: a frame sought to while paused is shown
        for sink, handler in (("results", self._on_results),
                              ("jpeg", self._on_jpeg)):
            element = self.pipe.get_by_name(sink)
            element.connect("new-sample", handler, "pull-sample")
            element.connect("new-preroll", handler, "pull-preroll")
        for name, element in self.elements().items():
            if name != "landmarkoverlay":   # after the tee, not the chain
                self._probe_cost(name, element)
        self._duration = None
        errors = []
        for element_name, props in self.initial_properties.items():
            for prop, value in props.items():
                try:
                    self._set_checked([(element_name, prop, value)])
                except ConsoleError as err:
                    errors.append(str(err))
        if errors:
            raise ConsoleError("project config: " + "; ".join(errors))

    async def start(self) -> None:
        """PLAYING (building the pipeline when needed)."""
        if self.loop is None:
            self.loop = asyncio.get_running_loop()
            self._handoffs = {
                "results": Handoff(self.loop, self._publish_results),
                "overlay": Handoff(self.loop, self.views["overlay"].publish),
                "labels": Handoff(self.loop, self.views["labels"].publish)}
        if self.pipe is None:
            self.build()
        if self.state == "ended" or self.error is not None:
            await self.stop()           # from the beginning
        if self.state == "stopped":     # a new run: its own log file
            self.log_path = self._new_log_path()
            self.pipe.get_by_name("log").set_property("location",
                                                      self.log_path)
        self.error = None
        ret = self.pipe.set_state(Gst.State.PLAYING)
        if ret == Gst.StateChangeReturn.FAILURE:
            msg = self.pipe.get_bus().pop_filtered(Gst.MessageType.ERROR)
            text = error_text(msg) if msg else "could not start"
            self.pipe.set_state(Gst.State.NULL)
            self.error = text
            raise ConsoleError(f"the pipeline could not start: {text}")
        self.state = "playing"
        if self._bus_task is None:
            self._bus_task = asyncio.ensure_future(self._watch_bus())

    async def pause(self) -> None:
        if self.pipe is None or self.state == "stopped":
            raise ConsoleError("not running: start first")
        self.pipe.set_state(Gst.State.PAUSED)
        self.state = "paused"

    async def stop(self) -> None:
        """NULL: the source closes; start plays from the beginning.
        A new pipeline with the same settings replaces the old one
        (decodebin's delayed link from the launch line is not made a
        second time)."""
        if self.pipe is not None:
            settings = self.current_properties()
            self.pipe.set_state(Gst.State.NULL)
            self.pipe = None
            self.initial_properties = settings
            self.build()
        self.state = "stopped"

    def sources(self) -> Dict[str, Dict[str, str]]:
        return list_sources(self.out_dir, self.start_source)

    async def set_source(self, source_id) -> None:
        """Plays the source ``source_id`` (an id of ``sources()``) with
        the same settings and palette."""
        sources = self.sources()
        if not isinstance(source_id, str) or source_id not in sources:
            raise ConsoleError(f"unknown source {json.dumps(source_id)}; "
                               f"one of {', '.join(sources)}")
        settings = self.current_properties() if self.pipe else \
            self.initial_properties
        if self.pipe is not None:
            self.pipe.set_state(Gst.State.NULL)
            self.pipe = None
        self.source, self.source_id = sources[source_id]["fragment"], \
            source_id
        self.initial_properties = settings
        self.path.clear()
        self.state = "stopped"
        await self.start()

    async def close(self) -> None:
        if self.pipe is not None:
            self.pipe.set_state(Gst.State.NULL)
        self.state = "stopped"
        if self._bus_task is not None:
            self._bus_task.cancel()
            self._bus_task = None
        self.pipe = None

    def _check_log(self) -> None:
        """A log file past log_max_bytes: landmarklog goes on in a new
        file (restarted with its new name between two frames)."""
        if self.pipe is None or self.state != "playing":
            return
        try:
            if os.path.getsize(self.log_path) < self.log_max_bytes:
                return
        except OSError:
            return
        log = self.pipe.get_by_name("log")
        sink = log.get_static_pad("sink")
        upstream = sink.get_peer()
        path = self._new_log_path()
        self.log_path = path

        def idle(pad, info):
            log.set_state(Gst.State.NULL)
            log.set_property("location", path)
            log.sync_state_with_parent()
            # the restarted element has lost the stream's sticky events
            for kind in (Gst.EventType.STREAM_START, Gst.EventType.CAPS,
                         Gst.EventType.SEGMENT):
                event = pad.get_sticky_event(kind, 0)
                if event is not None:
                    sink.send_event(event)
            return Gst.PadProbeReturn.REMOVE

        upstream.add_probe(Gst.PadProbeType.IDLE, idle)

    async def _watch_bus(self) -> None:
        # polling keeps GLib's main loop out of the asyncio process
        polls = 0
        while True:
            polls += 1
            if polls % 20 == 0:         # about once a second
                self._check_log()
            pipe = self.pipe
            msg = None
            if pipe is not None:
                msg = pipe.get_bus().pop_filtered(
                    Gst.MessageType.ERROR | Gst.MessageType.EOS)
            if msg is None:
                await asyncio.sleep(0.05)
                continue
            if msg.type == Gst.MessageType.ERROR:
                error = error_text(msg)
                await self.stop()
                self.error = error
                self._notify({"type": "error", "error": error})
            elif self.loop_file and self.is_file:
                self.path.clear()
                pipe.seek_simple(Gst.Format.TIME, Gst.SeekFlags.FLUSH, 0)
            else:
                self.state = "ended"
                self._notify({"type": "state", "state": self.state})

    # -- streaming-thread callbacks -------------------------------------

    def _on_jpeg(self, sink, pull: str) -> Gst.FlowReturn:
        sample = sink.emit(pull)
        if sample is None:
            return Gst.FlowReturn.OK
        buf = sample.get_buffer()
        data = buf.extract_dup(0, buf.get_size())
        now = time.time()
        pts = None if buf.pts == Gst.CLOCK_TIME_NONE else buf.pts / 1e9
        if self.loop is not None:
            self._handoffs["overlay"].put(data, now, pts)
        return Gst.FlowReturn.OK

    def _probe_cost(self, name: str, element: Gst.Element) -> None:
        """Wall time from a buffer entering ``element`` to leaving it."""
        def entering(pad, info):
            self._cost_start[name] = time.perf_counter()
            return Gst.PadProbeReturn.OK

        def leaving(pad, info):
            start = self._cost_start.pop(name, None)
            if start is not None:
                pts = info.get_buffer().pts
                with self._costs_lock:
                    costs = self._costs.setdefault(pts, {})
                    costs[name] = 1000 * (time.perf_counter() - start)
                    while len(self._costs) > 64:    # frames dropped later
                        self._costs.pop(next(iter(self._costs)))
            return Gst.PadProbeReturn.OK

        element.get_static_pad("sink").add_probe(Gst.PadProbeType.BUFFER,
                                                 entering)
        element.get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER,
                                                leaving)

    def _on_results(self, sink, pull: str) -> Gst.FlowReturn:
        sample = sink.emit(pull)
        if sample is None:
            return Gst.FlowReturn.OK
        now = time.time()
        buf = sample.get_buffer()
        caps = caps_structure(sample.get_caps())
        width, height = caps.get_value("width"), caps.get_value("height")
        ok, num, den = caps.get_fraction("framerate")
        self.frame_period = den / num if ok and num > 0 else None
        ok, info = buf.map(Gst.MapFlags.READ)
        frame = None
        if ok:
            try:
                stride = len(info.data) // height if height else 0
                rows = np.frombuffer(info.data, np.uint8,
                                     count=stride * height)
                frame = rows.reshape(height, stride)[:, :width * 3] \
                    .reshape(height, width, 3).copy()
            finally:
                buf.unmap(info)
        result = self.frame_json(buf, width, height, now)
        self._last_buffer = buf
        self._watched_class_views(buf, now)
        result["delay_ms"] = self._delay_ms(sample)
        with self._costs_lock:
            # get, not pop: a prerolled frame comes again as a sample
            result["cost_ms"] = dict(self._costs.get(buf.pts, {}))
        if self.loop is not None:
            self._handoffs["results"].put(result, frame)
        return Gst.FlowReturn.OK

    def _delay_ms(self, sample) -> Optional[float]:
        """How far behind its time on the pipeline clock the frame
        reached the results (for a live source: from capture)."""
        pipe, buf = self.pipe, sample.get_buffer()
        clock = pipe.get_clock() if pipe is not None else None
        if clock is None or buf.pts == Gst.CLOCK_TIME_NONE:
            return None
        running = sample.get_segment().to_running_time(Gst.Format.TIME,
                                                       buf.pts)
        now = clock.get_time() - pipe.get_base_time()
        return (now - running) / 1e6

    def class_view(self, name: str, class_name: Optional[str] = None
                   ) -> Tuple[str, LatestJpeg]:
        """The view ``name`` (overlay, labels, or binary: white where the
        palette's class ``class_name`` is, black elsewhere) and its key;
        the binary views nobody watches are dropped."""
        if name != "binary":
            if name not in self.views:
                raise ConsoleError(f"view must be one of overlay, labels, "
                                   f"binary, got {name!r}")
            return name, self.views[name]
        if class_name not in self.palette.names:
            raise ConsoleError(f"binary view: no class "
                               f"{json.dumps(class_name)} (classes: "
                               f"{', '.join(self.palette.names)})")
        key = f"binary:{class_name}"
        for stale in [k for k, v in self.views.items()
                      if k.startswith("binary:") and k != key and
                      not v.readers]:
            del self.views[stale]
            self._handoffs.pop(stale, None)
        if key not in self.views:
            self.views[key] = LatestJpeg()
            if self.loop is not None:
                self._handoffs[key] = Handoff(self.loop,
                                              self.views[key].publish)
        return key, self.views[key]

    def _watched_class_views(self, buf: Gst.Buffer, now: float) -> None:
        for key, view in list(self.views.items()):
            if key != "overlay" and view.readers > 0:
                self._class_jpeg(buf, now, key)

    def labels_now(self, key: str = "labels") -> None:
        """The view ``key`` of the newest frame, at once (on the loop:
        while paused no new frame would make it)."""
        buf, view = self._last_buffer, self.views[key]
        if buf is None:
            return
        pts = None if buf.pts == Gst.CLOCK_TIME_NONE else buf.pts / 1e9
        if view.data is None or view.pts != pts:
            jpeg = self._class_jpeg(buf, time.time(), key, handoff=False)
            if jpeg is not None:
                view.publish(jpeg, time.time(), pts)

    def _class_jpeg(self, buf: Gst.Buffer, now: float, key: str,
                    handoff: bool = True) -> Optional[bytes]:
        """The label plane as JPEG: "labels" in class colours (black: no
        class), "binary:NAME" white where the class NAME is."""
        labels = meta.labels(buf)
        if labels is None or self.loop is None:
            return None
        lut = np.zeros((256, 3), np.uint8)
        for c in labels.classes:
            if key == "labels":
                lut[c.label] = c.rgb[::-1]      # BGR for OpenCV
            elif key == f"binary:{c.name}":
                lut[c.label] = 255
        ok, jpg = cv2.imencode(".jpg", lut[labels.plane],
                               [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            return None
        handoff_to = self._handoffs.get(key) if handoff else None
        if handoff_to is not None:
            pts = None if buf.pts == Gst.CLOCK_TIME_NONE else buf.pts / 1e9
            handoff_to.put(jpg.tobytes(), now, pts)
        return jpg.tobytes()

    @staticmethod
    def frame_json(buf: Gst.Buffer, width: int, height: int,
                   now: float) -> Dict[str, Any]:
        """The per-frame results a browser draws (docs/console.md)."""
        labels = meta.labels(buf)
        classes = []
        threshold = None
        if labels is not None:
            threshold = labels.min_class_pixels
            classes = [{"name": c.name, "marker": c.marker,
                        "rgb": "#%02x%02x%02x" % c.rgb, "count": c.count,
                        "active": c.active, "labelled": c.labelled}
                       for c in labels.classes]
        detections = []
        for det in meta.detections(buf):
            blob, rng, match = det.blob, det.range, det.match
            entry: Dict[str, Any] = {
                "id": det.id, "class": det.class_name,
                "bbox": list(det.bbox), "kept": det.rejected() is None,
                "roundness": _plain(blob.get("roundness")),
                "ellipse_fit": _plain(blob.get("ellipse-fit"))}
            if "range" in rng:
                entry["range_m"] = _plain(rng["range"])
                entry["range"] = f"{rng['range']:.4f}"
                entry["bearing_deg"] = _plain(math.degrees(rng["bearing"]))
                entry["range_sigma_m"] = _plain(rng.get("range-sigma"))
            if match:
                entry["matched"] = bool(match.get("matched", False))
                entry["landmark"] = match.get("landmark-id")
            detections.append(entry)
        lamps = {c["name"]: False for c in classes if c["marker"]}
        for d in detections:
            if d["kept"] and d["class"] in lamps:
                lamps[d["class"]] = True
        pose = meta.pose(buf)
        pose_json = None
        if pose is not None:
            f = pose.fields
            cov = f.get("covariance") or []
            pose_json = {
                "x": _plain(f.get("x")), "y": _plain(f.get("y")),
                "heading_deg": _plain(math.degrees(f.get("heading", 0.0))),
                "sigma_x": _plain(math.sqrt(max(cov[0], 0))) if cov else None,
                "sigma_y": _plain(math.sqrt(max(cov[4], 0))) if cov else None,
                "solver": f.get("solver"),
                "landmarks": _plain(f.get("landmarks") or [])}
        pts = None if buf.pts == Gst.CLOCK_TIME_NONE else buf.pts / 1e9
        return {"type": "frame", "time": now, "pts": pts, "width": width,
                "height": height, "threshold": threshold,
                "classes": classes, "lamps": lamps,
                "detections": detections, "pose": pose_json}

    # -- on the loop -----------------------------------------------------

    def _publish_results(self, result: Dict[str, Any],
                         frame: Optional[np.ndarray]) -> None:
        if frame is not None:
            self.frame_bgr, self.frame_pts = frame, result["pts"]
        self.frame_index += 1
        result["frame"] = self.frame_index
        result["duration"] = self.duration()
        self._times.append(result["time"])
        del self._times[:-31]
        span = self._times[-1] - self._times[0]
        result["fps"] = (len(self._times) - 1) / span if span > 0 else None
        pose = result.get("pose")
        if pose is not None and pose["x"] is not None:
            self.path.append((pose["x"], pose["y"]))
            del self.path[:-PATH_LENGTH]
        self._notify(result)

    def _notify(self, message: Dict[str, Any]) -> None:
        for listener in list(self.listeners):
            listener(message)

    # -- tuning ----------------------------------------------------------

    # -- scrubbing a file --------------------------------------------

    @property
    def is_file(self) -> bool:
        return self.source.startswith("filesrc")

    def duration(self) -> Optional[float]:
        """Seconds, for a file whose length is known."""
        if not self.is_file or self.pipe is None:
            return None
        if self._duration is None:      # known once it plays
            ok, value = self.pipe.query_duration(Gst.Format.TIME)
            self._duration = value / 1e9 if ok and value > 0 else None
        return self._duration

    def seek(self, seconds) -> None:
        if not self.is_file:
            raise ConsoleError("seek: only a file can be scrubbed")
        if self.state not in ("playing", "paused"):
            raise ConsoleError("seek: start first")
        if not _is_number(seconds) or not math.isfinite(seconds):
            raise ConsoleError(f"seek: seconds must be a number, got "
                               f"{json.dumps(seconds)}")
        duration = self.duration()
        if duration is None:
            raise ConsoleError("seek: the file's duration is not known")
        if not 0 <= seconds <= duration:
            raise ConsoleError(f"seek: {seconds!r} is outside "
                               f"0..{duration:.3f} s")
        self.path.clear()
        if not self.pipe.seek_simple(
                Gst.Format.TIME,
                Gst.SeekFlags.FLUSH | Gst.SeekFlags.ACCURATE,
                int(seconds * Gst.SECOND)):
            raise ConsoleError("seek: refused by the pipeline")

    async def step(self) -> None:
        """Pauses and shows the next frame of a file (a seek to its time,
        and a microsecond: the frame that covers it is shown)."""
        if not self.is_file:
            raise ConsoleError("step: only a file steps frame by frame")
        if self.state not in ("playing", "paused"):
            raise ConsoleError("step: start first")
        if self.state == "playing":
            await self.pause()
        duration = self.duration()
        if self.frame_pts is None or not self.frame_period or \
                duration is None:
            raise ConsoleError("step: no frame with a time and rate yet")
        target = self.frame_pts + self.frame_period + 1e-6
        if target >= duration:
            raise ConsoleError(f"step: {self.frame_pts:.3f} s is the last "
                               f"frame")
        if not self.pipe.seek_simple(
                Gst.Format.TIME,
                Gst.SeekFlags.FLUSH | Gst.SeekFlags.ACCURATE,
                int(target * Gst.SECOND)):
            raise ConsoleError("step: refused by the pipeline")

    def tunables(self) -> Dict[str, List[Dict[str, Any]]]:
        out = {}
        for name, element in self.elements().items():
            out[name] = [self._spec(name, element, p) for p in TUNABLE[name]
                         if element.find_property(p) is not None]
        return out

    def _spec(self, name: str, element: Gst.Element,
              prop: str) -> Dict[str, Any]:
        """property_spec, with what the camera file holds: its value
        wins over the property's."""
        spec = property_spec(element, prop)
        if name == "ipmrange" and prop in self.camera_mounting:
            spec["value"] = self.camera_mounting[prop]
            spec["from"] = "camera file"
        return spec

    def _camera_copy(self, mounting: Dict[str, float]) -> str:
        """A copy of the camera file with ``mounting`` (properties), for
        ipmrange's calibration (a new name each time: the element reads
        the file when the property is set)."""
        self._palette_serial += 1
        suffix = os.path.splitext(self.camera_path)[1] or ".yml"
        path = os.path.join(self.out_dir, f"camera-live-"
                            f"{self._palette_serial}{suffix}")
        copy_camera_file(self.camera_path, path,
                         {CAMERA_KEYS[p]: v for p, v in mounting.items()})
        _keep_newest(self._live_cameras, path)
        return path

    def _set_checked(self, changes: Sequence[Tuple[str, str, Any]]
                     ) -> List[Dict[str, Any]]:
        elements = self.elements()
        checked = []
        for element_name, prop, value in changes:
            if element_name not in TUNABLE:
                raise ConsoleError(f"unknown element {element_name!r} "
                                   f"(tunable: {', '.join(TUNABLE)})")
            if element_name not in elements:
                raise ConsoleError(f"{element_name} is not in this chain "
                                   f"(trilaterate needs --map)")
            if prop not in TUNABLE[element_name]:
                raise ConsoleError(
                    f"{element_name} has no tunable property {prop!r} "
                    f"(tunable: {', '.join(TUNABLE[element_name])})")
            element = elements[element_name]
            spec = self._spec(element_name, element, prop)
            checked.append((element_name, spec,
                            check_value(element_name, spec, value)))
        # the mounting the camera file holds goes into a copy of it
        mounting = dict(self.camera_mounting)
        per_element: Dict[str, Dict[str, Any]] = {}
        for element_name, spec, value in checked:
            if element_name == "ipmrange" and spec["name"] in mounting:
                mounting[spec["name"]] = value
            per_element.setdefault(element_name, {})[spec["name"]] = value
        camera = None
        if mounting != self.camera_mounting:
            camera = self._camera_copy(mounting)
            per_element["ipmrange"]["calibration"] = camera
        # every element tries its changes first (its own checks): all or
        # nothing
        for element_name, changes in per_element.items():
            trial_start(elements[element_name], changes)
        for element_name, changes in per_element.items():
            for prop, value in changes.items():
                elements[element_name].set_property(prop, value)
        if camera is not None:
            self.camera_mounting, self.camera_live = mounting, camera
        return [self._spec(element_name, elements[element_name],
                           spec["name"])
                for element_name, spec, _ in checked]

    def tune(self, changes: Sequence[Tuple[str, str, Any]]
             ) -> List[Dict[str, Any]]:
        if self.pipe is None:
            raise ConsoleError("no pipeline: start first")
        return self._set_checked(changes)

    def current_properties(self) -> Dict[str, Dict[str, Any]]:
        return {name: {s["name"]: s["value"] for s in specs}
                for name, specs in self.tunables().items()}

    def save_config(self) -> str:
        """project.json in the output folder: the files and the tuned
        properties (``gst-landmark run`` reads the files; ``console
        --config`` reads both)."""
        config: Dict[str, Any] = {}
        palette_file = self.save_palette()
        config["palette"] = os.path.relpath(palette_file, self.out_dir)
        if self.map_path:
            config["map"] = os.path.abspath(self.map_path)
        if self.camera_path:
            config["camera"] = os.path.abspath(self.camera_path)
        config["properties"] = self.current_properties()
        path = os.path.join(self.out_dir, "project.json")
        with open(path, "w", encoding="utf-8") as f:
            json.dump(config, f, indent=2)
            f.write("\n")
        return path

    # -- teaching ------------------------------------------------------

    def palette_json(self) -> Dict[str, Any]:
        return pal.palette_to_json(self.palette)

    def _apply_palette(self, palette: pal.Palette) -> None:
        """Writes ``palette`` to a new file and points labsegment at it
        (a new name each time: the element reads the file on the next
        frame)."""
        self._palette_serial += 1
        path = os.path.join(self.out_dir,
                            f"palette-live-{self._palette_serial}.json")
        pal.save_palette(palette, path)
        labsegment = self.elements().get("labsegment")
        if labsegment is not None:
            labsegment.set_property("palette", path)
        self.palette, self.palette_path = palette, path
        _keep_newest(self._live_palettes, path)

    def freeze(self) -> Dict[str, Any]:
        """Keeps the newest frame to teach on; its id, pts and size (the
        page shows ``frozen_jpeg(id)`` while a box is drawn on it)."""
        frame = self.frame_bgr
        if frame is None:
            raise ConsoleError("freeze: no frame yet")
        ok, jpg = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, 90])
        self._freeze_serial += 1
        self.frozen[self._freeze_serial] = {
            "frame": frame, "pts": self.frame_pts, "jpeg": jpg.tobytes()}
        while len(self.frozen) > FROZEN_KEPT:
            self.frozen.pop(next(iter(self.frozen)))
        return {"frame": self._freeze_serial, "pts": self.frame_pts,
                "width": frame.shape[1], "height": frame.shape[0]}

    def frozen_jpeg(self, frame_id) -> bytes:
        return self._frozen(frame_id)["jpeg"]

    def _frozen(self, frame_id) -> Dict[str, Any]:
        if not isinstance(frame_id, int) or isinstance(frame_id, bool):
            raise ConsoleError(f"frame must be the id freeze returned, got "
                               f"{json.dumps(frame_id)}")
        if frame_id not in self.frozen:
            raise ConsoleError(f"frame {frame_id} is no longer kept (the "
                               f"newest {FROZEN_KEPT} are): freeze again")
        return self.frozen[frame_id]

    def teach(self, name: str, x, y, w, h,
              marker: Optional[bool] = None, frame_id=None,
              role: Optional[str] = None) -> Dict[str, Any]:
        """Adds the box of class ``name`` on the frozen frame ``frame_id``
        (None: the newest frame, frozen now) to the boxes taught so far,
        learns the palette from all of them as ``palette learn --rect``
        does and applies it; returns the class's new entry. ``role`` (or
        the older ``marker``) None: a new class is a marker, a known one
        keeps its role."""
        _check_box("teach", x, y, w, h)
        if marker is not None and not isinstance(marker, bool):
            raise ConsoleError("teach: marker must be true or false")
        if not isinstance(name, str):
            raise ConsoleError("teach: class must be a string")
        if role is not None and role not in pal.ROLES:
            raise ConsoleError(f"teach: role must be one of "
                               f"{', '.join(pal.ROLES)}, got "
                               f"{json.dumps(role)}")
        if frame_id is None:
            if self.frame_bgr is None:
                raise ConsoleError("teach: no frame yet")
            frame_id = self.freeze()["frame"]
        frame = self._frozen(frame_id)["frame"]
        lessons = self.teaching.add(frame_id, frame, (name, x, y, w, h),
                                    self._role(name, role, marker))
        try:
            palette, warnings, spread = lessons.learn()
        except pal.PaletteError as err:
            raise ConsoleError(f"teach: {err}") from None
        self.undo_stack.append((self.palette, self.palette_path,
                                self.teaching))
        del self.undo_stack[:-UNDO_DEPTH]
        self.teaching = lessons
        self.teach_warnings, self.palette_spread = warnings, spread
        self._apply_palette(palette)
        return next(c for c in self.palette_json()["classes"]
                    if c["name"] == name)

    def _role(self, name: str, role: Optional[str],
              marker: Optional[bool]) -> str:
        """The role ``name`` is taught with: ``role``; else a known class
        keeps its own (marker false keeps floor or background, makes a
        marker background); else a marker unless marker is false."""
        if role is not None:
            return role
        known = self.teaching.roles.get(name)
        if known is None and name in self.palette.names:
            known = self.palette.classes[self.palette.index(name)].role
        if known is None:
            return "background" if marker is False else "marker"
        return "background" if marker is False and known == "marker" \
            else known

    def new_palette(self) -> None:
        """The next boxes taught make a palette of their own (as
        ``palette learn`` does, the rest of the frame learned as
        "untaught"); the palette in force stays until then."""
        self.undo_stack.append((self.palette, self.palette_path,
                                self.teaching))
        del self.undo_stack[:-UNDO_DEPTH]
        self.teaching = Teaching(pal.Palette([]))
        self.teach_warnings, self.palette_spread = [], {}

    def edit_class(self, name, action: str, to=None) -> Dict[str, Any]:
        """Deletes the class ``name`` (``action`` "delete"), renames it
        ``to`` ("rename") or sets its tolerance ``to`` ("tolerance": it
        stands for its colours from 1/to to to times the light taught in,
        the palette's "shading"); applies the palette (undo takes it
        back)."""
        names = self.palette.names
        if not isinstance(name, str) or name not in names:
            raise ConsoleError(f"{action}: no class {json.dumps(name)} "
                               f"(classes: {', '.join(names)})")
        rename, shading, change = {}, None, {}
        if action == "delete":
            if len(names) == 1:
                raise ConsoleError(f"delete: {name} is the only class")
        elif action == "rename":
            if not isinstance(to, str) or to in names:
                raise ConsoleError(f"rename: the new name must be a string "
                                   f"that no class has, got "
                                   f"{json.dumps(to)}")
            rename, change = {name: to}, {"name": to}
        elif action == "tolerance":
            if not _is_number(to) or not 1 <= to <= MAX_TOLERANCE:
                raise ConsoleError(f"tolerance: {name}: expected a light "
                                   f"factor from 1 (the taught colours "
                                   f"only) to {MAX_TOLERANCE:g}, got "
                                   f"{json.dumps(to)}")
            shading = {name: (1 / to, float(to))}
            change = {"shading": shading[name]}
        else:
            raise ConsoleError(f"action must be delete, rename or "
                               f"tolerance, got {json.dumps(action)}")

        # the class changed, or without a change deleted
        classes = [dataclasses.replace(c, **change) if c.name == name
                   else c for c in self.palette.classes
                   if change or c.name != name]
        try:
            palette = pal.parse_palette(pal.palette_to_json(
                pal.Palette(classes)), action)
        except pal.PaletteError as err:
            raise ConsoleError(f"{action}: {err}") from None
        self.undo_stack.append((self.palette, self.palette_path,
                                self.teaching))
        del self.undo_stack[:-UNDO_DEPTH]
        self.teaching = self.teaching.edited(palette, rename, shading)
        self.palette_spread = {rename.get(n, n): v for n, v in
                               self.palette_spread.items()
                               if rename.get(n, n) in palette.names}
        self._apply_palette(palette)
        return {"palette": self.palette_json()}

    def box_statistics(self, frame_id, x, y, w, h) -> Dict[str, Any]:
        """Mean, spread (standard deviation) and histograms in L*a*b* of
        the pixels in a box of a frozen frame (None: the newest frame)."""
        frame = self.frame_bgr if frame_id is None else \
            self._frozen(frame_id)["frame"]
        if frame is None:
            raise ConsoleError("statistics: no frame yet")
        _check_box("statistics", x, y, w, h)
        try:
            pal.check_rects(frame.shape, [("box", x, y, w, h)])
        except pal.PaletteError as err:
            raise ConsoleError(f"statistics: {err}") from None
        rgb = np.ascontiguousarray(frame[y:y + h, x:x + w, ::-1])
        pixels = reference.rgb_to_lab(rgb).reshape(-1, 3) \
            .astype(np.float64)
        out: Dict[str, Any] = {"pixels": len(pixels),
                               "mean": pixels.mean(axis=0).tolist(),
                               "std": pixels.std(axis=0).tolist(),
                               "histograms": {}}
        for k, (channel, lo, hi) in enumerate(STATISTICS_RANGES):
            counts, edges = np.histogram(pixels[:, k], STATISTICS_BINS,
                                         (lo, hi))
            out["histograms"][channel] = {"from": lo, "to": hi,
                                          "counts": counts.tolist()}
        return out

    def undo(self) -> None:
        if not self.undo_stack:
            raise ConsoleError("nothing to undo")
        previous, _, self.teaching = self.undo_stack.pop()
        self.teach_warnings = []
        if previous is not self.palette:
            self._apply_palette(previous)

    def save_palette(self) -> str:
        path = os.path.join(self.out_dir, "palette.json")
        # the spreads as palette learn writes them: palette check reads
        extra = {"spread": self.palette_spread} if self.palette_spread \
            else {}
        pal.save_palette(self.palette, path,
                         description="Saved by gst-landmark console.",
                         **extra)
        return path

    # -- the log ---------------------------------------------------------

    def _new_log_path(self) -> str:
        """OUT/logs/log-YYYYmmdd-HHMMSS.jsonl by the time now (-2, -3...
        when taken); the oldest beyond LOG_KEEP files are removed."""
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = os.path.join(self.log_dir, f"log-{stamp}.jsonl")
        n = 1
        while os.path.exists(path):
            n += 1
            path = os.path.join(self.log_dir, f"log-{stamp}-{n}.jsonl")
        old = sorted(self.log_files(), key=os.path.getmtime)
        for stale in old[:max(0, len(old) - LOG_KEEP + 1)]:
            try:
                os.remove(stale)
            except OSError:
                pass
        return path

    def log_files(self) -> List[str]:
        return sorted(glob.glob(os.path.join(self.log_dir, "log-*.jsonl")))
