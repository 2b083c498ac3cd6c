"""What the browsers get of each frame: the results JSON over the
WebSocket, and the overlay and class views as MJPEG.

The appsinks call in on their streaming threads, which only hand results
to the asyncio loop (``Handoff``: the newest one, never a queue);
everything else runs on the loop.
"""

from __future__ import annotations

import asyncio
import json
import math
import threading
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

import cv2
import numpy as np

from ... import meta, pipeline
from ...gicompat import caps_structure
from .values import ConsoleError, json_ready

Gst = pipeline.Gst

JPEG_QUALITY = 80
PATH_LENGTH = 2000      # poses kept for browsers that join late
COSTS_KEPT = 64         # frames timed but not yet at the results


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


class ElementCosts:
    """Per-element processing time of recent frames, by pts: pad probes
    on the chain's streaming thread write it, the results branch after
    the tee reads it. Apart so that the one lock both threads take, and
    the bound on what is kept, stay in one place."""

    def __init__(self):
        self._start: Dict[str, float] = {}
        self._by_pts: Dict[Any, Dict[str, float]] = {}
        self._lock = threading.Lock()

    def probe(self, name: str, element: Gst.Element) -> None:
        """Wall time from a buffer entering ``element`` to leaving it."""
        def entering(pad, info):
            self._start[name] = time.perf_counter()
            return Gst.PadProbeReturn.OK

        def leaving(pad, info):
            start = self._start.pop(name, None)
            if start is not None:
                pts = info.get_buffer().pts
                with self._lock:
                    costs = self._by_pts.setdefault(pts, {})
                    costs[name] = 1000 * (time.perf_counter() - start)
                    while len(self._by_pts) > COSTS_KEPT:
                        self._by_pts.pop(next(iter(self._by_pts)))
            return Gst.PadProbeReturn.OK

        element.get_static_pad("sink").add_probe(Gst.PadProbeType.BUFFER,
                                                 entering)
        element.get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER,
                                                leaving)

    def of(self, pts) -> Dict[str, float]:
        """Milliseconds by element for the frame at ``pts``."""
        with self._lock:
            # get, not pop: a prerolled frame comes again as a sample
            return dict(self._by_pts.get(pts, {}))


def pts_seconds(pts: int) -> Optional[float]:
    """A buffer's pts in seconds (None: no time)."""
    return None if pts == Gst.CLOCK_TIME_NONE else pts / 1e9


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
            "roundness": json_ready(blob.get("roundness")),
            "ellipse_fit": json_ready(blob.get("ellipse-fit"))}
        if "range" in rng:
            entry["range_m"] = json_ready(rng["range"])
            entry["range"] = f"{rng['range']:.4f}"
            entry["bearing_deg"] = json_ready(math.degrees(rng["bearing"]))
            entry["range_sigma_m"] = json_ready(rng.get("range-sigma"))
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
        # x's and y's variances on the 3x3 covariance's diagonal
        sigma_x, sigma_y = (json_ready(math.sqrt(max(cov[i], 0)))
                            if cov else None for i in (0, 4))
        pose_json = {
            "x": json_ready(f.get("x")), "y": json_ready(f.get("y")),
            "heading_deg": json_ready(math.degrees(f.get("heading", 0.0))),
            "sigma_x": sigma_x, "sigma_y": sigma_y,
            "solver": f.get("solver"),
            "landmarks": json_ready(f.get("landmarks") or [])}
    return {"type": "frame", "time": now, "pts": pts_seconds(buf.pts),
            "width": width, "height": height, "threshold": threshold,
            "classes": classes, "lamps": lamps,
            "detections": detections, "pose": pose_json}


class FramePublisher:
    """Turns what the two appsinks pull into what the browsers get: the
    results of each frame to every listener, the overlay JPEG and the
    class views (made only while someone watches them) to their readers;
    keeps the newest frame (to freeze, step and measure on) and the pose
    path. Apart from the engine because it runs on the streaming threads
    and the loop, never builds or drives the pipeline: it reads the
    pipeline's clock and the file's duration through the two callables
    it is given."""

    def __init__(self, pipe: Callable[[], Optional[Gst.Pipeline]],
                 duration: Callable[[], Optional[float]]):
        self._pipe, self._duration = pipe, duration
        self.loop: Optional[asyncio.AbstractEventLoop] = None
        self._handoffs: Dict[str, Handoff] = {}
        self.views = {"overlay": LatestJpeg(), "labels": LatestJpeg()}
        self.frame_bgr: Optional[np.ndarray] = None
        self.frame_pts: Optional[float] = None
        self.frame_period: Optional[float] = None     # seconds, files
        # the newest results buffer: the classes view of a paused frame
        self.last_buffer: Optional[Gst.Buffer] = None
        self.frame_index = 0
        self.path: List[Tuple[float, float]] = []
        self.listeners: List[Callable[[Dict[str, Any]], None]] = []
        self._times: List[float] = []
        self.costs = ElementCosts()

    def attach(self, loop: asyncio.AbstractEventLoop) -> None:
        """Hands frames to ``loop`` from now on."""
        self.loop = loop
        self._handoffs = {
            "results": Handoff(loop, self._publish_results),
            "overlay": Handoff(loop, self.views["overlay"].publish),
            "labels": Handoff(loop, self.views["labels"].publish)}

    def connect(self, pipe: Gst.Pipeline) -> None:
        """Takes the samples of the pipeline's two appsinks."""
        # preroll too: a frame sought to while paused is shown
        for sink, handler in (("results", self._on_results),
                              ("jpeg", self._on_jpeg)):
            element = pipe.get_by_name(sink)
            element.connect("new-sample", handler, "pull-sample")
            element.connect("new-preroll", handler, "pull-preroll")

    # -- streaming-thread callbacks -------------------------------------

    def _on_jpeg(self, sink, pull: str) -> Gst.FlowReturn:
        sample = sink.emit(pull)
        if sample is None:
            return Gst.FlowReturn.OK
        buf = sample.get_buffer()
        data = buf.extract_dup(0, buf.get_size())
        now = time.time()
        if self.loop is not None:
            self._handoffs["overlay"].put(data, now, pts_seconds(buf.pts))
        return Gst.FlowReturn.OK

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
        result = frame_json(buf, width, height, now)
        self.last_buffer = buf
        self._watched_class_views(buf, now)
        result["delay_ms"] = self._delay_ms(sample)
        result["cost_ms"] = self.costs.of(buf.pts)
        if self.loop is not None:
            self._handoffs["results"].put(result, frame)
        return Gst.FlowReturn.OK

    def _delay_ms(self, sample) -> Optional[float]:
        """How far behind its time on the pipeline clock the frame
        reached the results (for a live source: from capture)."""
        pipe, buf = self._pipe(), sample.get_buffer()
        clock = pipe.get_clock() if pipe is not None else None
        if clock is None or buf.pts == Gst.CLOCK_TIME_NONE:
            return None
        running = sample.get_segment().to_running_time(Gst.Format.TIME,
                                                       buf.pts)
        now = clock.get_time() - pipe.get_base_time()
        return (now - running) / 1e6

    # -- the class views -------------------------------------------------

    def class_view(self, name: str, class_name: Optional[str],
                   class_names: List[str]) -> Tuple[str, LatestJpeg]:
        """The view ``name`` (overlay, labels, or binary: white where the
        palette's class ``class_name``, one of ``class_names``, is, black
        elsewhere) and its key; the binary views nobody watches are
        dropped."""
        if name != "binary":
            if name not in self.views:
                raise ConsoleError(f"view must be one of overlay, labels, "
                                   f"binary, got {name!r}")
            return name, self.views[name]
        if class_name not in class_names:
            raise ConsoleError(f"binary view: no class "
                               f"{json.dumps(class_name)} (classes: "
                               f"{', '.join(class_names)})")
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
        buf, view = self.last_buffer, self.views[key]
        if buf is None:
            return
        pts = pts_seconds(buf.pts)
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
            handoff_to.put(jpg.tobytes(), now, pts_seconds(buf.pts))
        return jpg.tobytes()

    # -- on the loop -----------------------------------------------------

    def _publish_results(self, result: Dict[str, Any],
                         frame: Optional[np.ndarray]) -> None:
        if frame is not None:
            self.frame_bgr, self.frame_pts = frame, result["pts"]
        self.frame_index += 1
        result["frame"] = self.frame_index
        result["duration"] = self._duration()
        self._times.append(result["time"])
        del self._times[:-31]
        span = self._times[-1] - self._times[0]
        result["fps"] = (len(self._times) - 1) / span if span > 0 else None
        pose = result.get("pose")
        if pose is not None and pose["x"] is not None:
            self.path.append((pose["x"], pose["y"]))
            del self.path[:-PATH_LENGTH]
        self.notify(result)

    def notify(self, message: Dict[str, Any]) -> None:
        """Sends ``message`` to every listener (the WebSockets)."""
        for listener in list(self.listeners):
            listener(message)
