"""The files landmarklog writes while the console runs."""

from __future__ import annotations

import glob
import os
import time
from typing import List

from ... import pipeline

Gst = pipeline.Gst

LOG_MAX_BYTES = 64 * 1024 * 1024    # a run's log file before it rotates
LOG_KEEP = 20           # log files kept in OUT/logs (the oldest go)


class RunLog:
    """One log file per run in OUT/logs, named by its start time; a long
    run goes on in a new file past ``max_bytes``; the oldest beyond
    LOG_KEEP are removed. Apart from the engine because naming, bounding
    and swapping the file are one job that the rest of the pipeline never
    sees (landmarklog is restarted between two frames)."""

    def __init__(self, out_dir: str, max_bytes: int = LOG_MAX_BYTES):
        self.dir = os.path.join(out_dir, "logs")
        os.makedirs(self.dir, exist_ok=True)
        self.max_bytes = max_bytes
        self.path = self.new_path()

    def new_path(self) -> str:
        """OUT/logs/log-YYYYmmdd-HHMMSS.jsonl by the time now (-2, -3...
        when taken); the oldest beyond LOG_KEEP files are removed."""
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = os.path.join(self.dir, f"log-{stamp}.jsonl")
        n = 1
        while os.path.exists(path):
            n += 1
            path = os.path.join(self.dir, f"log-{stamp}-{n}.jsonl")
        old = sorted(self.files(), key=os.path.getmtime)
        for stale in old[:max(0, len(old) - LOG_KEEP + 1)]:
            try:
                os.remove(stale)
            except OSError:
                pass
        return path

    def files(self) -> List[str]:
        return sorted(glob.glob(os.path.join(self.dir, "log-*.jsonl")))

    def begin_run(self, pipe: Gst.Pipeline) -> None:
        """A new run writes a file of its own (the pipeline not playing:
        the element takes the name when it starts)."""
        self.path = self.new_path()
        pipe.get_by_name("log").set_property("location", self.path)

    def rotate_when_full(self, pipe: Gst.Pipeline) -> None:
        """A log file past max_bytes: landmarklog goes on in a new file
        (restarted with its new name between two frames)."""
        try:
            if os.path.getsize(self.path) < self.max_bytes:
                return
        except OSError:
            return
        log = pipe.get_by_name("log")
        sink = log.get_static_pad("sink")
        upstream = sink.get_peer()
        path = self.new_path()
        self.path = path

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
