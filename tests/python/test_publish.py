"""landmarkpublish against a real mosquitto broker (tests/python/mqttbroker.py:
127.0.0.1, a free port, its own configuration, persistence off):

- every frame's message arrives once and in order at QoS 1, and equals
  landmarklog's line for the frame plus robot, running time and wall time;
  the pose is retained, the status goes online then offline;
- the broker is stopped for 4 s mid-run and started again: nothing is lost
  within the queue bound and the order is kept (the element's own queue
  holds the messages: the broker keeps nothing across the restart);
- a bound too small drops the oldest and reports exactly how many;
- the broker restarted at QoS 0, 1 and 2, without persistence (sessions
  lost: the element sends its unacknowledged messages again) and with it
  (the session kept): every frame arrives in order, once at QoS 2;
- a malformed topic template is an error naming `topic`; an unknown host
  and refused credentials are warnings naming the setting, and the video
  flows.
"""

import json
import os
import shutil
import time

import re

import pytest

from gi.repository import Gst

from gstlandmark.commands import calibrate

from mqttbroker import (Broker, Subscriber, make_certificates,
                        needs_mosquitto, wait_for)
from shippedclip import CLIP_DIR, CLIP_FRAMES

pytestmark = needs_mosquitto



def frames_of(messages, robot="r1"):
    """Frame indices of the frame messages, in arrival order."""
    return [json.loads(p)["frame"] for t, p, _ in messages
            if t == f"landmark/{robot}/frame"]


class Run:
    """A pipeline run in the background of the test: collects the bus
    messages and counts the buffers reaching the sink."""

    def __init__(self, gst, desc):
        self.pipe = Gst.parse_launch(desc)
        self.sunk = 0
        sink = self.pipe.get_by_name("sink")
        if sink is not None:
            sink.get_static_pad("sink").add_probe(
                Gst.PadProbeType.BUFFER, self._count)
        self.bus = self.pipe.get_bus()
        self.warnings, self.errors, self.elements = [], [], []
        self.eos = False

    def _count(self, pad, info):
        self.sunk += 1
        return Gst.PadProbeReturn.OK

    def start(self):
        self.pipe.set_state(Gst.State.PLAYING)
        return self

    def poll(self, timeout_s=0.0):
        """Reads bus messages for up to timeout_s; True at EOS or error."""
        deadline = time.monotonic() + timeout_s
        while True:
            left = max(0.0, deadline - time.monotonic())
            msg = self.bus.timed_pop_filtered(
                int(left * Gst.SECOND),
                Gst.MessageType.EOS | Gst.MessageType.ERROR |
                Gst.MessageType.WARNING | Gst.MessageType.ELEMENT)
            if msg is None:
                return False
            if msg.type == Gst.MessageType.EOS:
                self.eos = True
                return True
            if msg.type == Gst.MessageType.ERROR:
                err, dbg = msg.parse_error()
                self.errors.append(err.message)
                return True
            if msg.type == Gst.MessageType.WARNING:
                err, dbg = msg.parse_warning()
                self.warnings.append(err.message)
            elif msg.get_structure() is not None:
                s = msg.get_structure()
                if s.get_name().startswith("landmark-publish"):
                    self.elements.append((s.get_name(), {
                        k: s.get_value(k) for k in
                        ("connected", "dropped", "queued", "episode-over",
                         "reason", "resent", "session-present")
                        if s.has_field(k)}))

    def wait(self, timeout_s):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.poll(deadline - time.monotonic()):
                return self
        raise AssertionError(f"no EOS within {timeout_s} s: "
                             f"{self.warnings} {self.errors}")

    def run_through(self, timeout_s):
        """Starts, waits for EOS (or an error) and stops: a whole run."""
        self.start()
        try:
            self.wait(timeout_s)
        finally:
            self.stop()
        return self

    def stop(self):
        # READY first: what the element says when it stops is on the bus
        # until the pipeline reaches NULL, which flushes the bus
        self.pipe.set_state(Gst.State.READY)
        self.poll(0)
        self.pipe.set_state(Gst.State.NULL)


def live_source(frames):
    return (f"videotestsrc is-live=true num-buffers={frames} ! "
            "video/x-raw,format=BGRx,width=64,height=48,framerate=30/1")


@pytest.fixture
def broker(tmp_path):
    b = Broker(tmp_path).start()
    yield b
    b.stop()


@pytest.fixture(scope="module")
def camera_file(tmp_path_factory):
    """The synthetic clip's camera as `gst-landmark calibrate floor`
    writes it (as in test_pipelines.py)."""
    path = calibrate.scene_camera_file(
        os.path.join(CLIP_DIR, "scene.json"),
        tmp_path_factory.mktemp("camera") / "camera.yml")
    return path


def test_every_frame_once_in_order_as_the_log(gst, broker, tmp_path,
                                              camera_file):
    """The whole chain on the shipped clip with landmarklog and
    landmarkpublish side by side: 45 frame messages, once each, in order,
    each landmarklog's line plus robot, running-time and wall-time; the
    last pose retained; status online then offline (both retained)."""
    log = tmp_path / "log.jsonl"
    mp = os.path.join(CLIP_DIR, "map.json")
    sub = Subscriber(broker)
    try:
        before = time.time()
        run = Run(gst, f"filesrc location={CLIP_DIR}/clip.avi ! decodebin ! "
                  "videoconvert ! labsegment palette="
                  f"{CLIP_DIR}/palette.json min-class-pixels=50 ! "
                  "blobroundness min-area=30 ! "
                  f"ipmrange calibration={camera_file} map={mp} ! "
                  f"trilaterate map={mp} filter=ekf ! "
                  f"landmarklog location={log} ! "
                  f"landmarkpublish port={broker.port} robot=r1 mqtt-qos=1 ! "
                  "fakesink name=sink").run_through(60)
        after = time.time()
        # the offline status is the last thing the element sends
        assert wait_for(lambda: any(b'"offline"' in p for t, p, _ in
                                    sub.take()), 5), sub.take()
        msgs = sub.take()
    finally:
        sub.close()
    assert run.errors == [] and run.warnings == []
    assert run.sunk == CLIP_FRAMES

    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert len(lines) == CLIP_FRAMES
    frames = [json.loads(p) for t, p, _ in msgs if t == "landmark/r1/frame"]
    assert [f["frame"] for f in frames] == list(range(CLIP_FRAMES))
    for f, line in zip(frames, lines):
        assert f.pop("robot") == "r1"
        assert before <= f.pop("wall-time") <= after
        # the clip's timestamps from 0 in one segment: running time = pts
        assert f.pop("running-time") == line["pts"]
        assert f == line
    assert sum("pose" in x for x in lines) >= 40

    poses = [json.loads(p) for t, p, _ in msgs if t == "landmark/r1/pose"]
    assert poses, "no pose message"
    last_pose_line = [x for x in lines if "pose" in x][-1]
    assert poses[-1]["pose"] == last_pose_line["pose"]
    assert poses[-1]["frame"] == last_pose_line["frame"]
    status = [json.loads(p)["status"] for t, p, _ in msgs
              if t == "landmark/r1/status"]
    assert status == ["online", "offline"]

    # a subscriber arriving later gets the retained pose and status
    late = Subscriber(broker, name="late")
    try:
        assert wait_for(lambda: len(late.take()) >= 2, 5)
        got = {t: (json.loads(p), r) for t, p, r in late.take()}
    finally:
        late.close()
    assert got["landmark/r1/pose"][1] and got["landmark/r1/status"][1]
    assert got["landmark/r1/pose"][0]["pose"] == last_pose_line["pose"]
    assert got["landmark/r1/status"][0]["status"] == "offline"


def _outage_run(gst, tmp_path, frames, outage_s, extra="", qos=1,
                persistence=False):
    """A live 30 fps run; the broker is stopped after ~1.5 s for outage_s
    and started again on the same port. The element authenticates as
    "robot": the restarted broker first knows only the test's subscriber,
    which subscribes again before "robot" is let in (password file
    reloaded), so the backlog cannot reach the broker before anyone
    listens. Returns (run, messages, timeline)."""
    users = {"sub": "sub-secret", "robot": "robot-secret"}
    broker = Broker(tmp_path, users=users, persistence=persistence).start()
    subs = [Subscriber(broker, username="sub", password="sub-secret")]
    run = Run(gst, f"{live_source(frames)} ! landmarkpublish "
              f"port={broker.port} robot=r1 mqtt-qos={qos} username=robot "
              "password=robot-secret reconnect-delay-max=1 "
              f"drain-timeout=10000 {extra} ! fakesink name=sink")
    timeline = {}
    try:
        run.start()
        run.poll(1.5)
        timeline["stop"] = run.sunk
        # the broker goes first: a subscriber leaving before it would lose
        # what the broker accepted in between
        broker.stop()
        subs[0].close()
        run.poll(outage_s)
        broker.users = {"sub": "sub-secret"}
        broker.start()
        subs.append(Subscriber(broker, username="sub",
                               password="sub-secret", name="again"))
        broker.write_passwords(users)
        broker.reload()
        timeline["restart"] = run.sunk
        run.wait(60)
        wait_for(lambda: any(b'"offline"' in p
                             for t, p, _ in subs[-1].take()), 5)
    finally:
        run.stop()
        msgs = [m for s in subs for m in s.take()]
        subs[-1].close()
        broker.stop()
    return run, msgs, timeline


def test_broker_outage_loses_nothing(gst, tmp_path):
    """300 frames at 30 fps; the broker away for 4 s (about 120 frames):
    every frame message arrives, in order. Duplicates are allowed by
    QoS 1 only for the few messages in flight when the broker went."""
    frames = 300
    run, msgs, timeline = _outage_run(gst, tmp_path, frames, 4.0)
    assert run.errors == [] and run.sunk == frames
    got = frames_of(msgs)
    distinct = list(dict.fromkeys(got))
    duplicates = len(got) - len(distinct)
    print(f"outage: {frames} frames, broker away from frame "
          f"{timeline['stop']} to {timeline['restart']}; delivered "
          f"{len(distinct)} distinct, {duplicates} duplicates, "
          f"lost {frames - len(distinct)}")
    assert distinct == list(range(frames)), (
        f"missing: {sorted(set(range(frames)) - set(distinct))[:20]}")
    assert got == sorted(got) or duplicates > 0
    assert duplicates <= 20                     # at most the in-flight window
    assert timeline["restart"] - timeline["stop"] >= 90   # a real outage
    # the outage was reported once, the return too
    conn = [e for n, e in run.elements if n == "landmark-publish-connection"]
    assert [c["connected"] for c in conn][:1] == [True]
    assert any(not c["connected"] for c in conn)
    assert conn[-1]["connected"] is True
    lost_warnings = [w for w in run.warnings if "lost the connection" in w]
    assert len(lost_warnings) == 1, run.warnings
    assert not any("dropping" in w for w in run.warnings)


def test_small_bound_drops_the_oldest_and_counts(gst, tmp_path):
    """max-queue-messages=30 with a 3 s outage (about 90 frames): the
    oldest of the backlog are dropped, the rest arrive in order, and the
    dropped count in the element message is exactly what is missing."""
    frames = 240
    run, msgs, timeline = _outage_run(gst, tmp_path, frames, 3.0,
                                      "max-queue-messages=30")
    assert run.errors == [] and run.sunk == frames
    got = list(dict.fromkeys(frames_of(msgs)))
    missing = sorted(set(range(frames)) - set(got))
    dropped = [e for n, e in run.elements if n == "landmark-publish-dropped"]
    assert dropped, run.elements
    print(f"bound 30: {len(missing)} dropped, reported "
          f"{dropped[-1]['dropped']}")
    assert got == sorted(got)
    assert len(missing) >= 30
    # one contiguous block: the oldest of the backlog, never the newest
    assert missing == list(range(missing[0], missing[-1] + 1))
    assert missing[0] >= timeline["stop"] - 25
    assert missing[-1] < timeline["restart"]
    assert dropped[-1]["dropped"] == len(missing)
    assert dropped[0]["episode-over"] is False
    assert dropped[-1]["episode-over"] is True
    drop_warnings = [w for w in run.warnings if "dropping" in w]
    assert len(drop_warnings) == 1, run.warnings
    assert "max-queue-messages" in drop_warnings[0]


def settings_error(settings):
    """The message and debug text of the SETTINGS error landmarkpublish
    with ``settings`` posts when it fails to reach PAUSED (it must fail;
    it fails READY, as every element: the message names the property,
    the debug text says why)."""
    e = Gst.ElementFactory.make("landmarkpublish", None)
    for key, value in settings.items():
        e.set_property(key, value)
    bus = Gst.Bus.new()
    e.set_bus(bus)
    try:
        assert e.set_state(Gst.State.PAUSED) == \
            Gst.StateChangeReturn.FAILURE
        msg = bus.timed_pop_filtered(Gst.SECOND, Gst.MessageType.ERROR)
        assert msg is not None
        err, debug = msg.parse_error()
        assert err.matches(Gst.ResourceError.quark(),
                           Gst.ResourceError.SETTINGS)
        assert re.fullmatch(r"Invalid '[a-z-]+' value\.", err.message), \
            err.message
        return f"{err.message}\n{debug}"
    finally:
        e.set_state(Gst.State.NULL)


@pytest.mark.parametrize("topic, needle", [
    ("landmark/{robt}/frame", "{robt}"),
    ("landmark/+/frame", "'+'"),
    ("landmark/{robot}/#", "'#'"),
    ("landmark/{robot/frame", "not closed"),
])
def test_bad_topic_is_an_error_naming_topic(gst, topic, needle):
    message = settings_error({"topic": topic})
    assert "'topic'" in message and needle in message, message


@pytest.mark.parametrize("settings, name, needle", [
    ({"robot": "r1/left"}, "robot", "'/'"),
    ({"robot": ""}, "robot", "empty"),
    ({"pose-topic": "landmark/{robot}/#"}, "pose-topic", "'#'"),
    ({"status-topic": "x/{id}"}, "status-topic", "{id}"),
    ({"keep-alive": 3}, "keep-alive", "5 to 65535"),
    ({"password": "secret"}, "username", "without a user name"),
    ({"tls-ca-file": "/nonexistent/ca.pem"}, "tls-ca-file",
     "/nonexistent/ca.pem"),
    ({"tls-ca-file": __file__, "tls-cert-file": __file__}, "tls-key-file",
     "both"),
    ({"tls-cert-file": __file__, "tls-key-file": __file__}, "tls-ca-file",
     "only used over TLS"),
    ({"host": ""}, "host", "no broker host"),
])
def test_bad_settings_are_errors_naming_the_property(gst, settings, name,
                                                     needle):
    message = settings_error(settings)
    assert f"Invalid '{name}'" in message and needle in message, message


def test_unknown_host_is_a_warning_and_video_flows(gst):
    run = Run(gst, "videotestsrc num-buffers=30 ! "
              "video/x-raw,width=64,height=48 ! landmarkpublish "
              "host=no-such-host.invalid drain-timeout=200 ! "
              "fakesink name=sink").run_through(20)
    assert run.errors == [] and run.eos and run.sunk == 30
    host = [w for w in run.warnings if "'host'" in w]
    assert len(host) == 1, run.warnings
    assert "no-such-host.invalid" in host[0]
    # what was never delivered is said when the element stops
    assert any("30 results were not delivered" in w for w in run.warnings), \
        run.warnings


@pytest.mark.parametrize("username, password", [
    ("robot", "wrong"), ("stranger", "robot-secret")])
def test_refused_credentials_are_a_clear_warning(gst, tmp_path, username,
                                                 password):
    broker = Broker(tmp_path, users={"robot": "robot-secret"}).start()
    try:
        run = Run(gst, f"{live_source(20)} ! landmarkpublish "
                  f"port={broker.port} username={username} "
                  f"password={password} drain-timeout=100 ! "
                  "fakesink name=sink").run_through(20)
    finally:
        broker.stop()
    assert run.errors == [] and run.sunk == 20
    refused = [w for w in run.warnings if "refused" in w]
    assert len(refused) == 1, run.warnings
    assert "'username'" in refused[0] and "'password'" in refused[0]
    conn = [e for n, e in run.elements if n == "landmark-publish-connection"]
    assert conn and not any(c["connected"] for c in conn)


@pytest.mark.skipif(shutil.which("openssl") is None,
                    reason="openssl makes the test certificates")
def test_tls_with_the_right_and_a_wrong_authority(gst, tmp_path):
    """A TLS-only broker: with its authority the frames arrive; with
    another authority the element warns naming 'tls-ca-file', delivers
    nothing, and the video flows."""
    ca, cert, key = make_certificates(tmp_path, "broker")
    other_ca, _, _ = make_certificates(tmp_path, "other")
    broker = Broker(tmp_path, tls=(ca, cert, key)).start()
    try:
        runs = {}
        for name, authority in (("right", ca), ("wrong", other_ca)):
            run = Run(gst, f"{live_source(15)} ! landmarkpublish "
                      f"port={broker.port} robot={name} "
                      f"tls-ca-file={authority} drain-timeout=3000 ! "
                      "fakesink name=sink").run_through(20)
            runs[name] = run
        # what the broker kept: the retained status of each robot
        sub = Subscriber(broker, ca=ca)
        try:
            wait_for(lambda: len(sub.take()) >= 1, 3)
            time.sleep(0.3)
            topics = {t for t, _, _ in sub.take()}
        finally:
            sub.close()
    finally:
        broker.stop()
    right, wrong = runs["right"], runs["wrong"]
    assert right.errors == [] and right.warnings == [] and right.sunk == 15
    assert [e["connected"] for n, e in right.elements
            if n == "landmark-publish-connection"] == [True]
    assert wrong.errors == [] and wrong.sunk == 15
    tls = [w for w in wrong.warnings if "'tls-ca-file'" in w]
    assert len(tls) == 1, wrong.warnings
    assert "TLS with the broker" in tls[0]
    assert any("15 results were not delivered" in w for w in wrong.warnings)
    assert "landmark/right/status" in topics
    assert "landmark/wrong/status" not in topics


@pytest.mark.parametrize("qos,persistence", [(0, False), (1, False),
                                             (2, False), (2, True)])
def test_broker_restart_at_each_qos(gst, tmp_path, qos, persistence):
    """The broker stopped for 1 s and started again mid-run, 150 frames at
    30 fps. Without persistence the broker forgets every session: the
    element hands every unacknowledged message over again from its own
    copies. With persistence the broker keeps the element's session (a
    QoS 2 message half through its exchange included) and libmosquitto
    completes it. QoS 1 and 2: every frame arrives, in order, at QoS 2
    exactly once; QoS 0: in order, never twice, and the element's count
    of what it dropped is 0 (a message written to the socket the broker
    never read is the one loss QoS 0 allows)."""
    frames = 150
    run, msgs, timeline = _outage_run(gst, tmp_path, frames, 1.0, qos=qos,
                                      persistence=persistence)
    got = frames_of(msgs)
    distinct = list(dict.fromkeys(got))
    conn = [e for n, e in run.elements if n == "landmark-publish-connection"]
    print(f"QoS {qos}, persistence {persistence}: {len(got)} received, "
          f"{len(distinct)} distinct, missing "
          f"{sorted(set(range(frames)) - set(distinct))}; connections "
          f"{[(c.get('session-present'), c.get('resent')) for c in conn if c['connected']]}")
    assert run.errors == [] and run.sunk == frames
    assert conn[-1]["connected"] and conn[-1]["dropped"] == 0
    assert len(conn) >= 3                        # connected, lost, again
    if qos == 0:
        assert got == distinct == sorted(got)
        assert len(distinct) >= frames - 20
        return
    assert distinct == list(range(frames)), (
        f"missing: {sorted(set(range(frames)) - set(distinct))}")
    if qos == 2:                                 # and so in order
        assert got == distinct
    if persistence:                     # the broker kept the session
        assert conn[-1]["session-present"] and conn[-1]["resent"] == 0
