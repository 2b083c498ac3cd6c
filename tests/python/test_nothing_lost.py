"""Nothing lost: every frame that goes into the chain comes out once, in
order, with one landmarklog line, and the log is whole JSON lines however
the run ends.

- (a) frames with known, irregular timestamps and varying content (the
  shipped clip in a shuffled order) through the whole chain, plain and
  with queues between all elements and a tee with a second log; and
  frames too late for a syncing sink (no QoS drop);
- (b) an error in the middle of the stream, upstream of the chain
  (identity error-after) and downstream of the log;
- (c) gst-launch-1.0 stopped by signals: SIGINT with -e (EOS, exit 0,
  every frame at the sink logged), SIGINT without -e, SIGTERM and SIGKILL
  (what is on disk then; see each test).

The chain is soak.chain(): the clip's palette, map and camera, the
settings of pipelines/file.pipeline.
"""

import json
import random
import re
import signal
import subprocess
import threading

import pytest

from gstlandmark import pipeline
from gstlandmark.devtools import soak

Gst = pipeline.Gst
SIZE = (320, 240)
CAPS = (f"video/x-raw,format=RGB,width={SIZE[0]},height={SIZE[1]},"
        f"framerate={soak.FPS}/1")


@pytest.fixture(scope="module")
def clip(gst):
    return soak.clip_frames(*SIZE)


def irregular_pts(n, seed=1):
    """Increasing timestamps with uneven gaps (10 to 60 ms): a check that
    the log copies each buffer's own timestamp, not a frame counter."""
    rng = random.Random(seed)
    pts, t = [], 0
    for _ in range(n):
        pts.append(t)
        t += rng.randint(10, 60) * Gst.MSECOND + rng.randint(0, 999)
    return pts


def read_lines(path):
    """The log's lines; asserts the file ends with a newline and that
    every line is JSON."""
    data = path.read_bytes()
    assert data == b"" or data.endswith(b"\n"), f"{path}: incomplete line"
    return [json.loads(line) for line in data.decode().splitlines()]


def assert_log(lines, pts):
    """One line per frame: frame numbers 0, 1, ... and the timestamps
    ``pts`` in order."""
    assert [ln["frame"] for ln in lines] == list(range(len(pts)))
    assert [ln["pts"] for ln in lines] == pts


def push_and_collect(desc, frames, pts, count=None, timeout_s=60):
    """Runs ``appsrc name=src ! <desc>`` with ``appsink name=out`` in it:
    pushes the frames with timestamps ``pts`` from a thread, pulls every
    sample; returns the timestamps seen at the appsink, the name of the
    element that posted the first error (or None) and the number of
    buffers that left the element named ``count``."""
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time block=true max-buffers=8 "
        f"caps={CAPS} ! {desc}")
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("out")
    bus = pipe.get_bus()
    seen = []
    counted = [0]
    if count is not None:
        def probe(pad, info):
            counted[0] += 1
            return Gst.PadProbeReturn.OK
        pipe.get_by_name(count).get_static_pad("src").add_probe(
            Gst.PadProbeType.BUFFER, probe)

    def push():
        for i, t in enumerate(pts):
            buf = Gst.Buffer.new_wrapped(frames[i])
            buf.pts = t
            buf.duration = 20 * Gst.MSECOND
            if src.emit("push-buffer", buf) != Gst.FlowReturn.OK:
                return          # flushing: the pipeline failed or stopped
        src.emit("end-of-stream")

    assert pipe.set_state(Gst.State.PLAYING) != Gst.StateChangeReturn.FAILURE
    pusher = threading.Thread(target=push, daemon=True)
    pusher.start()
    error = None
    try:
        while True:
            sample = sink.emit("try-pull-sample", timeout_s * Gst.SECOND)
            if sample is None:
                break
            seen.append(sample.get_buffer().pts)
        msg = bus.timed_pop_filtered(
            timeout_s * Gst.SECOND,
            Gst.MessageType.EOS | Gst.MessageType.ERROR)
        assert msg is not None, "neither EOS nor an error"
        if msg.type == Gst.MessageType.ERROR:
            error = msg.src.get_name()
    finally:
        # the stop writes every line still pending (docs/landmarklog.md)
        pipe.set_state(Gst.State.NULL)
        pusher.join(timeout_s)
    return seen, error, counted[0]


# ---------------------------------------------------------------------------
# (a) every frame in, one frame and one line out, in order

N_FRAMES = 200


@pytest.mark.parametrize("layout", ["plain", "queues-tee"])
def test_every_frame_once_in_order(gst, clip, tmp_path, layout):
    rng = random.Random(7)
    frames = [clip[rng.randrange(len(clip))] for _ in range(N_FRAMES)]
    pts = irregular_pts(N_FRAMES)
    log, log2 = tmp_path / "log.jsonl", tmp_path / "log2.jsonl"
    chain = soak.chain(str(log))
    if layout == "plain":
        desc = f"{chain} ! appsink name=out sync=false"
    else:
        # a queue between every two elements (each its own thread), then a
        # tee: the appsink on one branch, a second log on the other
        desc = (f"{chain.replace(' ! ', ' ! queue ! ')} ! tee name=t "
                "t. ! queue ! appsink name=out sync=false "
                f"t. ! queue ! landmarklog location={log2} ! "
                "fakesink sync=false")
    seen, error, _ = push_and_collect(desc, frames, pts)
    assert error is None
    assert seen == pts
    lines = read_lines(log)
    assert_log(lines, pts)
    # the content varies and the chain really works on it
    assert sum("pose" in ln for ln in lines) > N_FRAMES * 0.9
    assert len({json.dumps(ln["labels"]["counts"]) for ln in lines}) > 20
    if layout == "queues-tee":
        assert read_lines(log2) == lines


def test_late_frames_are_not_dropped(gst, clip, tmp_path):
    """Timestamps 0.1 ms apart: the chain (about 2 ms a frame at 320x240)
    cannot keep up, and a syncing sink sends QoS events upstream saying
    every frame is late. No element of the chain drops one (QoS is off in
    all of them); the control run, with labsegment's QoS turned on, shows
    that the test would see drops."""
    n = 300
    frames = [clip[i % len(clip)] for i in range(n)]
    pts = [i * Gst.MSECOND // 10 for i in range(n)]
    sink = "appsink name=out sync=true qos=true"
    seen, error, _ = push_and_collect(
        f"{soak.chain(str(tmp_path / 'log.jsonl'))} ! {sink}", frames, pts)
    assert error is None
    assert seen == pts
    assert_log(read_lines(tmp_path / "log.jsonl"), pts)

    control = soak.chain(str(tmp_path / "control.jsonl")).replace(
        "labsegment ", "labsegment qos=true ")
    seen, error, _ = push_and_collect(f"{control} ! {sink}", frames, pts)
    assert error is None and len(seen) < n
    assert len(read_lines(tmp_path / "control.jsonl")) == len(seen)


# ---------------------------------------------------------------------------
# (b) an error in the middle of the stream


ERROR_AFTER = 37


@pytest.mark.parametrize("where", ["upstream", "downstream"])
def test_error_mid_stream(gst, clip, tmp_path, where):
    """identity error-after=K fails the stream at its K-th buffer (K - 1
    pass). Upstream of the chain the log holds exactly the frames identity
    let through; downstream of the log, every frame that left landmarklog
    (K: the K-th was logged before identity failed it). Whole lines,
    ending with a newline, once the pipeline stopped."""
    pts = irregular_pts(100, seed=3)
    frames = [clip[i % len(clip)] for i in range(100)]
    log = tmp_path / "log.jsonl"
    chain = soak.chain(str(log))
    if where == "upstream":
        desc = (f"identity name=fail error-after={ERROR_AFTER} ! {chain} ! "
                "appsink name=out sync=false")
        counted = "fail"
    else:
        desc = (f"{chain} ! identity name=fail error-after={ERROR_AFTER} ! "
                "appsink name=out sync=false")
        counted = "log"
    seen, error, passed = push_and_collect(desc, frames, pts, counted)
    assert error == "fail"
    assert seen == pts[:ERROR_AFTER - 1]
    lines = read_lines(log)
    assert len(lines) == passed
    assert passed == (ERROR_AFTER - 1 if where == "upstream" else
                      ERROR_AFTER)
    assert_log(lines, pts[:passed])


# ---------------------------------------------------------------------------
# (c) gst-launch-1.0 and signals

# fakesink silent=false and gst-launch -v print one last-message line per
# buffer that reached the sink: an independent count, with timestamps
_SINK_LINE = re.compile(r"last-message = chain .*pts: (\d+):(\d\d):(\d\d)"
                        r"\.(\d{9})")


def _sink_pts(stdout):
    out = []
    for m in _SINK_LINE.finditer(stdout):
        h, mi, s, ns = (int(g) for g in m.groups())
        out.append(((h * 60 + mi) * 60 + s) * Gst.SECOND + ns)
    return out


class Launch:
    """gst-launch-1.0 -v on a live test source through the whole chain to
    a fakesink that reports every buffer. Its stdout is read in a thread;
    ``stop()`` waits until 45 buffers have reached the sink before it
    sends the signal, so the signal comes mid-stream however slow the
    machine is."""

    def __init__(self, tmp_path, extra_args=(), flush_every=0):
        self.log = tmp_path / "log.jsonl"
        chain = soak.chain(str(self.log), flush_every=flush_every)
        cmd = ["gst-launch-1.0", *extra_args, "-v",
               "videotestsrc", "is-live=true", "pattern=smpte", "!",
               f"video/x-raw,format=RGB,width={SIZE[0]},height={SIZE[1]},"
               f"framerate={soak.FPS}/1", "!", *chain.split(), "!",
               "fakesink", "silent=false", "sync=false"]
        self.stderr = tmp_path / "stderr.txt"
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE,
                                         stderr=err, text=True)
        self.out = []
        self.seen = threading.Event()
        self.frames = 0
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.out.append(line)
            self.frames += _SINK_LINE.search(line) is not None
            if self.frames >= 45:
                self.seen.set()

    def stop(self, sig, timeout_s=30):
        """Waits for 45 frames at the sink, sends ``sig``; returns the exit
        status and the timestamps the sink reported."""
        assert self.seen.wait(30), "gst-launch-1.0 did not start"
        self.proc.send_signal(sig)
        self.proc.wait(timeout_s)
        self.reader.join(timeout_s)
        return self.proc.returncode, _sink_pts("".join(self.out))


def test_sigint_with_eos(gst, tmp_path):
    """gst-launch-1.0 -e: Ctrl-C sends EOS, the log is flushed before EOS
    reaches the sink; exit status 0 and exactly one line per frame that
    reached the sink, same timestamps, same order."""
    run = Launch(tmp_path, ["-e"])
    status, sink = run.stop(signal.SIGINT)
    assert status == 0, run.stderr.read_text()
    assert len(sink) >= 45
    assert_log(read_lines(run.log), sink)


def test_sigint_without_eos(gst, tmp_path):
    """Without -e, Ctrl-C makes gst-launch-1.0 set the pipeline to NULL
    straight away: landmarklog's stop writes every line it holds, so the
    log is whole and has every frame that entered landmarklog; the sink
    may have missed the last frames in flight, never more than the log
    has. gst-launch exits with status 0 here as well."""
    run = Launch(tmp_path)
    status, sink = run.stop(signal.SIGINT)
    assert status == 0, run.stderr.read_text()
    lines = read_lines(run.log)
    assert len(sink) >= 45
    # landmarklog and the sink share one thread: one frame in flight
    assert len(sink) <= len(lines) <= len(sink) + 1
    assert [ln["frame"] for ln in lines] == list(range(len(lines)))
    assert [ln["pts"] for ln in lines[:len(sink)]] == sink


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
@pytest.mark.parametrize("flush_every", [0, 1])
def test_killed(gst, tmp_path, sig, flush_every):
    """gst-launch-1.0 does not catch SIGTERM: like SIGKILL, the process
    ends without stopping the pipeline. What landmarklog had handed to
    the file stays: whole lines, frames 0, 1, ... in order (the last one
    may be cut short only if the kill hits the middle of a write); lines
    still pending in memory are lost: up to 64 KiB of lines by default,
    none with flush-every=1 beyond the frame being written."""
    run = Launch(tmp_path, flush_every=flush_every)
    status, sink = run.stop(sig)
    assert status == -sig
    data = run.log.read_bytes()
    text = data.decode(errors="replace")
    complete = text.split("\n")[:-1]        # drop a partial last line
    lines = [json.loads(ln) for ln in complete]
    assert [ln["frame"] for ln in lines] == list(range(len(lines)))
    if flush_every == 1:
        # each frame's line was written before the frame went on to the
        # sink; the last line may be cut, and the sink's report may lack
        # its tail (stdout of a killed process)
        assert len(lines) >= max(45, len(sink) - 1)
        n = min(len(lines), len(sink))
        assert [ln["pts"] for ln in lines[:n]] == sink[:n]
    else:
        # lines reach the file only in 64 KiB chunks: here (45 or more
        # lines of about 650 bytes, fewer than 100) usually none at all
        assert len(data) == 0 or len(data) >= 64 * 1024
