"""Run our elements from Python: frames in, buffers with metadata out
(``process_frames``), or a pipeline on a file with per-frame results
(``run_file``, ``iterate``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Iterable, Iterator, List, Optional

import numpy as np

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstVideo", "1.0")
from gi.repository import Gst, GstVideo  # noqa: E402

from . import meta, plugin  # noqa: E402
from .gicompat import caps_structure  # noqa: E402
from .messages import LandmarkMessage  # noqa: E402


def init() -> None:
    """Initialise GStreamer once (library modules never do it on import),
    with the plugin the set-up built on its path (``plugin``)."""
    if not Gst.is_initialized():
        plugin.use_built_plugin()
        Gst.init(None)


class PipelineError(RuntimeError):
    pass


def elements_by_factory(pipe: Gst.Bin) -> Dict[str, Gst.Element]:
    """{factory name: the first element of that factory} in the
    pipeline, bins included."""
    found: Dict[str, Gst.Element] = {}
    it = pipe.iterate_recurse()
    while True:
        res, element = it.next()
        if res != Gst.IteratorResult.OK:
            break
        factory = element.get_factory()
        if factory is not None:
            found.setdefault(factory.get_name(), element)
    return found


def frame_bytes(frame, info: GstVideo.VideoInfo) -> bytes:
    """Packs a frame into GStreamer's default layout for ``info``.

    Packed formats take an (H, W, C) array, padded to the default stride;
    other frames are taken as the raw bytes of all planes already laid out.
    """
    if isinstance(frame, (bytes, bytearray)):
        return bytes(frame)
    if frame.ndim == 3:
        h, w, c = frame.shape
        stride = info.stride[0]
        out = np.zeros((h, stride), np.uint8)
        out[:, :w * c] = frame.reshape(h, w * c)
        return out.tobytes()
    return np.ascontiguousarray(frame).tobytes()


def process_frames(element: str, frames: Iterable[np.ndarray], caps: str,
                   timeout_s: float = 30.0) -> List[Gst.Buffer]:
    """Pushes frames through ``appsrc ! <element> ! appsink``.

    ``element`` is a launch fragment (``"labsegment min-class-pixels=0"``,
    or a chain with ``!``); returns the output buffers in order.
    """
    init()
    desc = (f"appsrc name=src format=time caps={caps} ! {element} ! "
            "appsink name=sink sync=false emit-signals=false")
    pipe = Gst.parse_launch(desc)
    src = pipe.get_by_name("src")
    sink = pipe.get_by_name("sink")
    info = GstVideo.VideoInfo.new_from_caps(Gst.Caps.from_string(caps))
    bus = pipe.get_bus()
    out: List[Gst.Buffer] = []
    pipe.set_state(Gst.State.PLAYING)
    try:
        n = 0
        for frame in frames:
            buf = Gst.Buffer.new_wrapped(frame_bytes(frame, info))
            buf.pts = n * Gst.SECOND // 30
            buf.duration = Gst.SECOND // 30
            src.emit("push-buffer", buf)
            n += 1
        src.emit("end-of-stream")
        while len(out) < n:
            sample = sink.emit("try-pull-sample", int(timeout_s * Gst.SECOND))
            if sample is None:
                _raise_bus_error(bus, f"timeout after {len(out)}/{n} buffers")
            out.append(sample.get_buffer())
        _raise_bus_error(bus, None)
    finally:
        pipe.set_state(Gst.State.NULL)
    return out


def frames_through(chain: str, frames: Iterable[np.ndarray],
                   timeout_s: float = 60.0,
                   configure=None) -> Iterator["FrameResult"]:
    """Pushes 8-bit BGR frames ((H, W, 3) arrays, as ``cv2.imread`` gives
    them) one at a time through ONE pipeline ``appsrc ! <chain> !
    appsink`` and yields a FrameResult per frame, in order, with its
    buffer. The caps follow the frames: new caps whenever the size
    changes. ``configure(pipeline)`` is called before it starts (to set
    properties of named elements). Raises PipelineError on a pipeline
    error or when a frame does not come out within ``timeout_s``; closing
    the generator early stops the pipeline."""
    init()
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time ! {chain} ! "
        "appsink name=results sync=false emit-signals=false")
    if configure is not None:
        configure(pipe)
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("results")
    bus = pipe.get_bus()
    size, info = None, None
    if pipe.set_state(Gst.State.PLAYING) == Gst.StateChangeReturn.FAILURE:
        try:
            _raise_bus_error(bus, f"could not start: {chain}")
        finally:
            pipe.set_state(Gst.State.NULL)
    try:
        for n, frame in enumerate(frames):
            frame = np.asarray(frame)
            if frame.dtype != np.uint8 or frame.ndim != 3 or \
                    frame.shape[2] != 3:
                raise PipelineError(f"frame {n}: expected 8-bit BGR (H, W, "
                                    f"3), got {frame.dtype} {frame.shape}")
            if frame.shape[:2] != size:
                size = frame.shape[:2]
                caps = Gst.Caps.from_string(
                    f"video/x-raw,format=BGR,width={size[1]},"
                    f"height={size[0]},framerate=0/1")
                src.set_property("caps", caps)
                info = GstVideo.VideoInfo.new_from_caps(caps)
            buf = Gst.Buffer.new_wrapped(frame_bytes(frame, info))
            buf.pts = n * Gst.SECOND // 30
            buf.duration = Gst.SECOND // 30
            src.emit("push-buffer", buf)
            sample = sink.emit("try-pull-sample", int(timeout_s * Gst.SECOND))
            if sample is None:
                _raise_bus_error(bus, f"frame {n} did not come out within "
                                      f"{timeout_s} s")
            out = sample.get_buffer()
            yield FrameResult(
                frame=n, pts=out.pts, width=size[1], height=size[0],
                labels=meta.labels(out), detections=meta.detections(out),
                pose=meta.pose(out), buffer=out)
        _raise_bus_error(bus, None)
    finally:
        pipe.set_state(Gst.State.NULL)


def _raise_bus_error(bus: Gst.Bus, fallback: Optional[str]) -> None:
    msg = bus.pop_filtered(Gst.MessageType.ERROR)
    if msg is not None:
        err, dbg = msg.parse_error()
        raise PipelineError(f"{err.message} ({dbg})")
    if fallback:
        raise PipelineError(fallback)


# ---------------------------------------------------------------------------
# Embedding: run a pipeline on a file and iterate per-frame results


@dataclass
class FrameResult:
    """What our elements attached to one frame, plus the ``landmark-*``
    messages posted for it (matched by timestamp)."""
    frame: int
    pts: Optional[int]
    width: int
    height: int
    labels: Optional["meta.LabelsMeta"]
    detections: List["meta.Detection"]
    pose: Optional["meta.Pose"]
    messages: List[LandmarkMessage] = field(default_factory=list)
    buffer: Optional[Gst.Buffer] = None


def file_pipeline(path: str, chain: str = "labsegment") -> str:
    """A launch line that decodes ``path`` and runs ``chain`` on it."""
    return (f"filesrc location=\"{path}\" ! decodebin ! videoconvert ! "
            f"{chain} ! appsink name=results sync=false")


def iterate(description: str, timeout_s: float = 60.0,
            keep_buffers: bool = False) -> Iterator[FrameResult]:
    """Runs a launch line and yields a FrameResult per frame that reaches
    its appsink named ``results`` (appended when the line has none).

    Raises PipelineError on a pipeline error or a stall longer than
    ``timeout_s``. Closing the generator early stops the pipeline.
    """
    init()
    if "name=results" not in description:
        description += " ! appsink name=results sync=false"
    pipe = Gst.parse_launch(description)
    sink = pipe.get_by_name("results")
    if sink is None:
        raise PipelineError("no appsink named 'results' in the pipeline")
    bus = pipe.get_bus()
    pending: Dict[Optional[int], List[LandmarkMessage]] = {}

    def drain_bus() -> None:
        while True:
            msg = bus.pop_filtered(Gst.MessageType.ELEMENT |
                                   Gst.MessageType.ERROR)
            if msg is None:
                return
            if msg.type == Gst.MessageType.ERROR:
                err, dbg = msg.parse_error()
                raise PipelineError(f"{err.message} ({dbg})")
            lm = LandmarkMessage.from_message(msg)
            if lm is not None:
                pending.setdefault(lm.timestamp, []).append(lm)

    if pipe.set_state(Gst.State.PLAYING) == Gst.StateChangeReturn.FAILURE:
        drain_bus()
        pipe.set_state(Gst.State.NULL)
        raise PipelineError(f"could not start: {description}")
    try:
        n = 0
        while True:
            sample = sink.emit("try-pull-sample", int(timeout_s * Gst.SECOND))
            drain_bus()
            if sample is None:
                if sink.get_property("eos"):
                    return
                raise PipelineError(f"no frame for {timeout_s} s")
            buf = sample.get_buffer()
            caps = caps_structure(sample.get_caps())
            pts = None if buf.pts == Gst.CLOCK_TIME_NONE else buf.pts
            yield FrameResult(
                frame=n, pts=pts, width=caps.get_value("width"),
                height=caps.get_value("height"), labels=meta.labels(buf),
                detections=meta.detections(buf), pose=meta.pose(buf),
                messages=pending.pop(pts, []),
                buffer=buf if keep_buffers else None)
            n += 1
    finally:
        pipe.set_state(Gst.State.NULL)


def wait_eos(pipe: Gst.Pipeline, timeout_s: float = 60.0,
             what: str = "the pipeline") -> None:
    """Waits for a playing pipeline's end (EOS). Raises PipelineError with
    the element's message on an error, or when it has not ended after
    ``timeout_s``."""
    msg = pipe.get_bus().timed_pop_filtered(
        int(timeout_s * Gst.SECOND),
        Gst.MessageType.EOS | Gst.MessageType.ERROR)
    if msg is None:
        raise PipelineError(f"not ended after {timeout_s} s: {what}")
    if msg.type == Gst.MessageType.ERROR:
        err, dbg = msg.parse_error()
        raise PipelineError(f"{err.message}: {dbg}")


def run_to_eos(description: str, timeout_s: float = 60.0,
               on_buffer=None) -> None:
    """Runs a launch line to its end (EOS); see ``wait_eos``.
    ``on_buffer(pad, buffer)``: called with every buffer that reaches the
    element named ``sink``."""
    init()
    pipe = Gst.parse_launch(description)
    if on_buffer is not None:
        def probe(pad, info):
            on_buffer(pad, info.get_buffer())
            return Gst.PadProbeReturn.OK
        pipe.get_by_name("sink").get_static_pad("sink").add_probe(
            Gst.PadProbeType.BUFFER, probe)
    pipe.set_state(Gst.State.PLAYING)
    try:
        wait_eos(pipe, timeout_s, description)
    finally:
        pipe.set_state(Gst.State.NULL)


def run_file(path: str, chain: str = "labsegment",
             **kwargs) -> Iterator[FrameResult]:
    """Per-frame results of ``chain`` on a video file::

        for r in run_file("clip.avi", "labsegment min-class-pixels=300"):
            print(r.frame, r.labels.class_by_name("red").count)
    """
    return iterate(file_pipeline(path, chain), **kwargs)


ODOMETRY_EVENT = "landmark-odometry"


def send_odometry(element: Gst.Element, dx: float, dy: float,
                  dheading: float, out_of_band: bool = True) -> bool:
    """Gives landmarkslam live wheel odometry: the robot-frame motion since
    the previous call (dx forward, dy left, metres; dheading radians,
    counter-clockwise), as a ``landmark-odometry`` event on its sink pad.
    Out of band (the default) it reaches the element at once from any
    thread and counts for the next frame; serialized, it travels between
    the buffers (docs/embedding.md)."""
    kind = (Gst.EventType.CUSTOM_DOWNSTREAM_OOB if out_of_band
            else Gst.EventType.CUSTOM_DOWNSTREAM)
    s = Gst.Structure.new_empty(ODOMETRY_EVENT)
    for name, value in (("dx", dx), ("dy", dy), ("dheading", dheading)):
        s.set_value(name, float(value))
    return element.get_static_pad("sink").send_event(
        Gst.Event.new_custom(kind, s))
