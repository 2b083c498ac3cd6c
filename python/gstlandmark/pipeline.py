"""Run our elements from Python: frames in, buffers with metadata out."""

from __future__ import annotations

from typing import Iterable, List, Optional

import numpy as np

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstVideo", "1.0")
from gi.repository import Gst, GstVideo  # noqa: E402


def init() -> None:
    """Initialise GStreamer once (library modules never do it on import)."""
    if not Gst.is_initialized():
        Gst.init(None)


class PipelineError(RuntimeError):
    pass


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


def _raise_bus_error(bus: Gst.Bus, fallback: Optional[str]) -> None:
    msg = bus.pop_filtered(Gst.MessageType.ERROR)
    if msg is not None:
        err, dbg = msg.parse_error()
        raise PipelineError(f"{err.message} ({dbg})")
    if fallback:
        raise PipelineError(fallback)
