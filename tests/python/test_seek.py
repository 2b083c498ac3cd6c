"""Flushing seeks and EOS through the whole chain on a file pipeline
(tests/files/clips/path-small, 45 MJPEG frames at 30 fps):

filesrc ! avidemux ! jpegdec ! videoconvert ! labsegment ! blobroundness !
ipmrange ! trilaterate ! landmarkoverlay ! landmarklog ! fakesink sync=true

While playing, the test seeks (FLUSH | ACCURATE) to the middle, back to the
start, to the middle again, and lets the clip run to EOS. After each seek
the frames reaching the sink start at the seek position and follow each
other without a gap; after the last one every frame from the seek position
to the end arrives; the landmarklog file holds whole JSON lines only, and
its last run of timestamps is exactly what reached the sink."""

import json
import threading
import time

import pytest

from shippedclip import CLIP_DIR as CLIP, CLIP_FRAMES as N_FRAMES, \
    camera_props

FPS = 30


def chain(log, sync):
    """The whole chain on the clip into landmarklog ``log`` and a sink."""
    return (f"filesrc location={CLIP}/clip.avi ! avidemux ! jpegdec ! "
            f"videoconvert ! labsegment palette={CLIP}/palette.json "
            f"min-class-pixels=0 ! blobroundness ! ipmrange {camera_props()} "
            f"! trilaterate map={CLIP}/map.json ! landmarkoverlay ! "
            f"landmarklog location={log} ! fakesink name=sink "
            f"sync={'true' if sync else 'false'}")


class SinkRecorder:
    """Buffers reaching the sink, split into runs at each flush-stop, and
    the segment that starts each run."""

    def __init__(self, Gst, pad):
        self.Gst = Gst
        self.lock = threading.Lock()
        self.runs = [[]]
        self.segments = [None]
        pad.add_probe(Gst.PadProbeType.BUFFER |
                      Gst.PadProbeType.EVENT_DOWNSTREAM |
                      Gst.PadProbeType.EVENT_FLUSH, self.probe)

    def probe(self, pad, info):
        Gst = self.Gst
        with self.lock:
            if info.type & Gst.PadProbeType.BUFFER:
                self.runs[-1].append(info.get_buffer().pts)
            else:
                ev = info.get_event()
                if ev.type == Gst.EventType.FLUSH_STOP:
                    self.runs.append([])
                    self.segments.append(None)
                elif ev.type == Gst.EventType.SEGMENT:
                    self.segments[-1] = ev.parse_segment()
        return Gst.PadProbeReturn.OK

    def frames_in_run(self, run):
        with self.lock:
            return len(self.runs[run]) if run < len(self.runs) else 0


def wait_for(pipe, Gst, cond, what, timeout_s=20):
    bus = pipe.get_bus()
    end = time.monotonic() + timeout_s
    while not cond():
        msg = bus.timed_pop_filtered(10 * Gst.MSECOND, Gst.MessageType.ERROR)
        if msg is not None:
            err, dbg = msg.parse_error()
            raise AssertionError(f"{err.message}: {dbg}")
        assert time.monotonic() < end, f"timeout waiting for {what}"


def read_log(path):
    with open(path, "rb") as f:
        data = f.read()
    assert data.endswith(b"\n"), "the log ends mid-line"
    return [json.loads(line) for line in data.decode().splitlines()]


def split_runs(pts):
    """A timestamp sequence cut wherever the next timestamp is not one frame
    later (a seek, backwards or forwards)."""
    runs = [[]]
    for p in pts:
        if runs[-1] and abs(p - runs[-1][-1] - 1e9 / FPS) >= 1e6:
            runs.append([])
        runs[-1].append(p)
    return runs


def check_consecutive(run, what):
    dur = 1e9 / FPS
    for a, b in zip(run, run[1:]):
        assert abs(b - a - dur) < 1e6, f"{what}: gap between {a} and {b}"


def test_flushing_seeks_then_eos(gst, tmp_path):
    Gst = gst
    log = tmp_path / "log.jsonl"
    desc = chain(log, sync=True)
    pipe = Gst.parse_launch(desc)
    sink = pipe.get_by_name("sink")
    rec = SinkRecorder(Gst, sink.get_static_pad("sink"))
    dur = Gst.SECOND // FPS
    middle = (N_FRAMES // 2) * Gst.SECOND // FPS
    # (position, frames to see before the next seek; None: up to EOS)
    plan = [(middle, 5), (0, 10), (middle, None)]
    try:
        assert pipe.set_state(Gst.State.PLAYING) != \
            Gst.StateChangeReturn.FAILURE
        wait_for(pipe, Gst, lambda: rec.frames_in_run(0) >= 8,
                 "8 frames before seeking")
        for k, (position, frames) in enumerate(plan):
            assert pipe.seek_simple(
                Gst.Format.TIME, Gst.SeekFlags.FLUSH | Gst.SeekFlags.ACCURATE,
                position), f"seek {k} to {position} refused"
            if frames:
                wait_for(pipe, Gst,
                         lambda: rec.frames_in_run(k + 1) >= frames,
                         f"{frames} frames after seek {k}")
        msg = pipe.get_bus().timed_pop_filtered(
            20 * Gst.SECOND, Gst.MessageType.EOS | Gst.MessageType.ERROR)
        assert msg is not None, "no EOS"
        if msg.type == Gst.MessageType.ERROR:
            err, dbg = msg.parse_error()
            raise AssertionError(f"{err.message}: {dbg}")
    finally:
        pipe.set_state(Gst.State.NULL)

    with rec.lock:
        runs, segments = rec.runs, rec.segments
    # a seek gives one flush; a flush on an already flushed sink may add an
    # empty run, so only runs that saw frames are compared
    assert runs[0] and runs[0][0] == 0
    check_consecutive(runs[0], "before the first seek")
    seen = [(r, s) for r, s in zip(runs[1:], segments[1:]) if r]
    assert len(seen) == len(plan), [len(r) for r in runs]
    for k, ((run, seg), (position, frames)) in enumerate(zip(seen, plan)):
        assert seg is not None and seg.start == position, \
            f"seek {k}: segment starts at {seg and seg.start}"
        assert abs(run[0] - position) < dur, \
            f"seek {k} to {position}: first frame at {run[0]}"
        check_consecutive(run, f"after seek {k}")
    # every frame from the last seek's position to the end
    last = seen[-1][0]
    assert len(last) == N_FRAMES - N_FRAMES // 2, len(last)

    lines = read_log(log)
    logged = [line["pts"] for line in lines]
    assert len(logged) >= sum(len(r) for r in runs)
    # the log was written by the frames, so each seek starts a new run
    # there too; the last is exactly what reached the sink
    log_runs = split_runs(logged)
    assert log_runs[-1] == last, (log_runs[-1], last)
    assert len(log_runs) == len(plan) + 1, [len(r) for r in log_runs]


@pytest.mark.parametrize("position_frames", [0, N_FRAMES // 2])
def test_seek_while_paused_then_play_to_eos(gst, tmp_path, position_frames):
    """Preroll, seek with FLUSH while PAUSED, play: the log has exactly the
    frames from the seek position to the end, in order."""
    Gst = gst
    log = tmp_path / "log.jsonl"
    desc = chain(log, sync=False)
    pipe = Gst.parse_launch(desc)
    rec = SinkRecorder(Gst, pipe.get_by_name("sink").get_static_pad("sink"))
    position = position_frames * Gst.SECOND // FPS
    try:
        pipe.set_state(Gst.State.PAUSED)
        ret, _, _ = pipe.get_state(10 * Gst.SECOND)
        assert ret == Gst.StateChangeReturn.SUCCESS
        assert pipe.seek_simple(
            Gst.Format.TIME, Gst.SeekFlags.FLUSH | Gst.SeekFlags.ACCURATE,
            position)
        ret, _, _ = pipe.get_state(10 * Gst.SECOND)
        assert ret == Gst.StateChangeReturn.SUCCESS
        pipe.set_state(Gst.State.PLAYING)
        msg = pipe.get_bus().timed_pop_filtered(
            20 * Gst.SECOND, Gst.MessageType.EOS | Gst.MessageType.ERROR)
        assert msg is not None and msg.type == Gst.MessageType.EOS, msg
    finally:
        pipe.set_state(Gst.State.NULL)
    with rec.lock:
        last = [r for r in rec.runs if r][-1]
    assert len(last) == N_FRAMES - position_frames
    assert abs(last[0] - position) < Gst.SECOND // FPS
    check_consecutive(last, "after the seek")
    log_runs = split_runs([line["pts"] for line in read_log(log)])
    assert log_runs[-1] == last
