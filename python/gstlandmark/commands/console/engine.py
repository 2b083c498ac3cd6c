"""The console's pipeline: the chain on a file, a camera or a test source,
with a tee to two appsinks (the raw frame with its metadata, and the
overlay as JPEG), built, run and scrubbed here; the jobs around it live in
modules of their own, joined by ``Engine``:

- ``frames``: what browsers get of each frame (results JSON, JPEG views),
- ``tuning``: live tuning checked against the elements' own GParamSpecs,
- ``teaching``: palette teaching on frozen frames, class edits, undo,
- ``runlog``: the run's log files; ``livefiles``: the files written for
  the elements; ``sources``: the sources a browser may choose;
  ``values``: ConsoleError and the checks the parts share.

Streaming threads only hand results to the asyncio loop (``Handoff``:
the newest one, never a queue); everything else runs on the loop.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

from ... import pipeline
from ...landmarkmap import MapError, read_map
from .. import runner
from .frames import (JPEG_QUALITY, FramePublisher, Handoff,  # noqa: F401
                     LatestJpeg, frame_json)
from .livefiles import LiveFiles
from .runlog import LOG_MAX_BYTES, RunLog
from .sources import list_sources, source_fragment  # noqa: F401
from .teaching import FrozenFrames, LivePalette, Teaching  # noqa: F401
from .tuning import (TUNABLE, Tuning, check_value,  # noqa: F401
                     copy_camera_file, property_spec, read_camera_mounting,
                     trial_start)
from .values import ConsoleError, is_number

Gst = pipeline.Gst

# what the command, the server and the tests import from here, wherever
# it lives now
__all__ = ["CHAIN", "ConsoleError", "Engine", "FramePublisher",
           "FrozenFrames", "Handoff", "LatestJpeg", "LivePalette",
           "TUNABLE", "Teaching", "Tuning", "check_value",
           "copy_camera_file", "error_text", "frame_json", "list_sources",
           "property_spec", "read_camera_mounting", "read_landmarks",
           "source_fragment", "trial_start"]

CHAIN = ("labsegment", "blobroundness", "ipmrange", "trilaterate",
         "landmarkoverlay")


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


def _forwarded(part: str, name: str) -> property:
    """The attribute ``name`` of the engine's part ``part``, read as the
    engine's own (the server and the tests read it there)."""
    return property(lambda engine: getattr(getattr(engine, part), name),
                    doc=f"``{part}.{name}``")


class Engine:
    """The running chain and what the server needs from it: builds the
    pipeline and drives it (start, pause, stop, another source, the bus,
    seeking and stepping a file), and joins the parts that do the rest,
    each with one job: ``frames`` (FramePublisher), ``tuning`` (Tuning),
    ``live_palette`` (LivePalette) teaching on ``frozen_frames``
    (FrozenFrames), ``log`` (RunLog). The server asks the engine only;
    what it reads of a part is forwarded below.

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
        # palettes and camera copies share one numbering
        live_files = LiveFiles(self.out_dir)
        self.tuning = Tuning(camera_path, live_files)
        self.loop_file = loop_file
        # one log file per run, named by its start time (a long run
        # rotates to a new file at log_max_bytes)
        self.log = RunLog(self.out_dir, log_max_bytes)
        self.frames = FramePublisher(lambda: self.pipe, self.duration)
        self.frozen_frames = FrozenFrames(
            lambda: (self.frames.frame_bgr, self.frames.frame_pts))
        self.live_palette = LivePalette(
            palette_path, self.out_dir, live_files, self.frozen_frames,
            lambda: self.elements().get("labsegment"))
        self.landmarks = read_landmarks(map_path)
        self.initial_properties = properties or {}
        self.loop: Optional[asyncio.AbstractEventLoop] = None
        self.pipe: Optional[Gst.Pipeline] = None
        self.state = "stopped"
        self.error: Optional[str] = None
        self._duration: Optional[float] = None
        self._bus_task: Optional[asyncio.Task] = None

    # -- what the server and the tests read of the parts -------------------

    views = _forwarded("frames", "views")
    listeners = _forwarded("frames", "listeners")
    path = _forwarded("frames", "path")
    frame_bgr = _forwarded("frames", "frame_bgr")
    frame_index = _forwarded("frames", "frame_index")
    _last_buffer = _forwarded("frames", "last_buffer")
    _notify = _forwarded("frames", "notify")
    labels_now = _forwarded("frames", "labels_now")

    palette = _forwarded("live_palette", "palette")
    palette_path = _forwarded("live_palette", "palette_path")
    teaching = _forwarded("live_palette", "teaching")
    teach_warnings = _forwarded("live_palette", "teach_warnings")
    undo_stack = _forwarded("live_palette", "undo_stack")
    palette_json = _forwarded("live_palette", "palette_json")
    teach = _forwarded("live_palette", "teach")
    edit_class = _forwarded("live_palette", "edit_class")
    new_palette = _forwarded("live_palette", "new_palette")
    box_statistics = _forwarded("live_palette", "box_statistics")
    undo = _forwarded("live_palette", "undo")
    save_palette = _forwarded("live_palette", "save_palette")

    frozen = _forwarded("frozen_frames", "by_id")
    freeze = _forwarded("frozen_frames", "freeze")
    frozen_jpeg = _forwarded("frozen_frames", "jpeg")

    log_path = _forwarded("log", "path")
    log_files = _forwarded("log", "files")

    def class_view(self, name: str, class_name: Optional[str] = None
                   ) -> Tuple[str, LatestJpeg]:
        """The view ``name`` (overlay, labels, or binary of the palette's
        class ``class_name``) and its key."""
        return self.frames.class_view(name, class_name, self.palette.names)

    # -- the pipeline ------------------------------------------------------

    def launch_line(self) -> str:
        q = runner.quote
        maps = f" map={q(self.map_path)}" if self.map_path else ""
        camera_file = self.tuning.camera_file()
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
        self.frames.connect(self.pipe)
        for name, element in self.elements().items():
            if name != "landmarkoverlay":   # after the tee, not the chain
                self.frames.costs.probe(name, element)
        self._duration = None
        errors = []
        for element_name, props in self.initial_properties.items():
            for prop, value in props.items():
                try:
                    self.tuning.set_checked(self.elements(),
                                            [(element_name, prop, value)])
                except ConsoleError as err:
                    errors.append(str(err))
        if errors:
            raise ConsoleError("project config: " + "; ".join(errors))

    async def start(self) -> None:
        """PLAYING (building the pipeline when needed)."""
        if self.loop is None:
            self.loop = asyncio.get_running_loop()
            self.frames.attach(self.loop)
        if self.pipe is None:
            self.build()
        if self.state == "ended" or self.error is not None:
            await self.stop()           # from the beginning
        if self.state == "stopped":     # a new run: its own log file
            self.log.begin_run(self.pipe)
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

    async def _watch_bus(self) -> None:
        # polling keeps GLib's main loop out of the asyncio process
        polls = 0
        while True:
            polls += 1
            # about once a second, while a run writes its log
            if polls % 20 == 0 and self.pipe is not None and \
                    self.state == "playing":
                self.log.rotate_when_full(self.pipe)
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

    # -- tuning ----------------------------------------------------------

    def tunables(self) -> Dict[str, List[Dict[str, Any]]]:
        return self.tuning.tunables(self.elements())

    def tune(self, changes: Sequence[Tuple[str, str, Any]]
             ) -> List[Dict[str, Any]]:
        if self.pipe is None:
            raise ConsoleError("no pipeline: start first")
        return self.tuning.set_checked(self.elements(), changes)

    def current_properties(self) -> Dict[str, Dict[str, Any]]:
        return self.tuning.current_properties(self.elements())

    def save_config(self) -> str:
        """project.json in the output folder: the files and the tuned
        properties (``gst-landmark run`` reads the files; ``console
        --config`` reads both)."""
        config: Dict[str, Any] = {}
        palette_file = self.save_palette()
        config["palette"] = os.path.relpath(palette_file, self.out_dir)
        if self.map_path:
            config["map"] = os.path.abspath(self.map_path)
        if self.tuning.camera_path:
            config["camera"] = os.path.abspath(self.tuning.camera_path)
        config["properties"] = self.current_properties()
        path = os.path.join(self.out_dir, "project.json")
        with open(path, "w", encoding="utf-8") as f:
            json.dump(config, f, indent=2)
            f.write("\n")
        return path

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
        if not is_number(seconds) or not math.isfinite(seconds):
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
        frame_pts, frame_period = self.frames.frame_pts, \
            self.frames.frame_period
        if frame_pts is None or not frame_period or duration is None:
            raise ConsoleError("step: no frame with a time and rate yet")
        target = frame_pts + frame_period + 1e-6
        if target >= duration:
            raise ConsoleError(f"step: {frame_pts:.3f} s is the last "
                               f"frame")
        if not self.pipe.seek_simple(
                Gst.Format.TIME,
                Gst.SeekFlags.FLUSH | Gst.SeekFlags.ACCURATE,
                int(target * Gst.SECOND)):
            raise ConsoleError("step: refused by the pipeline")
