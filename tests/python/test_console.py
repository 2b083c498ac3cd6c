"""gst-landmark console: the server on the real chain, through aiohttp's
test client (a real socket on 127.0.0.1).

Sources: the shipped clip tests/files/clips/path-small (45 frames,
320x240, with its palette and map) played once, or a live videotestsrc of
one solid colour for teaching. Expectations come from elsewhere: the
landmarklog file of the same run, the element's own property, the CIE
formulas written out here, the JPEG decoder.
"""

import asyncio
import json
import os
import re
import time

import cv2
import numpy as np
import pytest

aiohttp = pytest.importorskip("aiohttp")
from aiohttp.test_utils import TestClient, TestServer  # noqa: E402

from gstlandmark import palette as pal  # noqa: E402
from gstlandmark.commands.console import server  # noqa: E402
from gstlandmark.commands.console.engine import Engine  # noqa: E402

from webpages import (check_loopback_guard,  # noqa: E402
                      check_self_contained, check_token_required)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
CLIP = os.path.join(ROOT, "tests", "files", "clips", "path-small")
CLIP_FRAMES = 45
with open(os.path.join(CLIP, "scene.json")) as f:
    CAMERA = json.load(f)["camera"]
# the shipped file pipeline's thresholds for this 320x240 clip, and the
# scene's true camera (as project-config properties)
CLIP_PROPERTIES = {"labsegment": {"min-class-pixels": 50},
                   "blobroundness": {"min-area": 30},
                   "ipmrange": {"camera-height": CAMERA["height_m"],
                                "tilt": CAMERA["tilt_deg"],
                                "roll": CAMERA["roll_deg"],
                                "hfov": CAMERA["hfov_deg"]}}
TIMEOUT = 20


def clip_engine(tmp_path, loop_file=False):
    return Engine(f"filesrc location={CLIP}/clip.avi ! decodebin",
                  str(tmp_path / "out"),
                  palette_path=os.path.join(CLIP, "palette.json"),
                  map_path=os.path.join(CLIP, "map.json"),
                  properties=CLIP_PROPERTIES, loop_file=loop_file)


def solid_engine(tmp_path, rgb):
    colour = 0xff000000 | (rgb[0] << 16) | (rgb[1] << 8) | rgb[2]
    return Engine("videotestsrc is-live=true pattern=solid-color "
                  f"foreground-color={colour} ! video/x-raw,width=160,"
                  "height=120,framerate=30/1", str(tmp_path / "out"))


def serve(engine, check, token=None, loopback=True, start=True):
    """Runs ``check(client)`` against the app on a real port."""
    async def main():
        app = server.make_app(engine, token=token, loopback=loopback)
        async with TestClient(TestServer(app)) as client:
            if start:
                await engine.start()
            await asyncio.wait_for(check(client), TIMEOUT)
    asyncio.run(main())


async def frames(client, n, predicate=lambda f: True, **kwargs):
    """The next ``n`` per-frame messages that satisfy ``predicate``."""
    out = []
    async with client.ws_connect("/ws", **kwargs) as ws:
        while len(out) < n:
            msg = await ws.receive_json()
            if msg["type"] == "frame" and predicate(msg):
                out.append(msg)
    return out


async def post(client, route, body, **kwargs):
    r = await client.post(route, json=body, **kwargs)
    return r.status, await r.json()


# ---------------------------------------------------------------------------
# the page


def test_page_and_static_files_have_no_external_urls(gst, tmp_path):
    async def check(client):
        await check_self_contained(
            client, ("static/console.js", "static/console.css"),
            "/static/../engine.py")

    serve(clip_engine(tmp_path), check, start=False)


# ---------------------------------------------------------------------------
# the video and the results


def test_mjpeg_stream_yields_jpeg_parts_of_the_frame_size(gst, tmp_path):
    async def check(client):
        # a browser's stream: each part's data is followed at once by the
        # next part's headers (a browser shows a part once those came)
        r = await client.get("/stream.mjpg")
        head = b"--landmarkframe\r\nContent-Type: image/jpeg\r\n\r\n"
        assert await r.content.readexactly(len(head)) == head
        sep = b"\r\n" + head
        got = b""
        while sep not in got:
            got += await r.content.read(65536)
        data = got[:got.index(sep)]
        assert data[:2] == b"\xff\xd8" and data[-2:] == b"\xff\xd9"
        r.close()
        # for tools: each part's headers with its length and time
        r = await client.get("/stream.mjpg", params={"timing": "1"})
        assert r.status == 200
        ctype = r.headers["Content-Type"]
        assert ctype.startswith("multipart/x-mixed-replace")
        boundary = ctype.split("boundary=")[1]
        reader = aiohttp.MultipartReader(r.headers, r.content)
        images = []
        while len(images) < 3:
            part = await reader.next()
            assert part.headers["Content-Type"] == "image/jpeg"
            data = await part.read()
            assert len(data) == int(part.headers["Content-Length"])
            assert data[:2] == b"\xff\xd8" and data[-2:] == b"\xff\xd9"
            images.append(cv2.imdecode(np.frombuffer(data, np.uint8),
                                       cv2.IMREAD_COLOR))
        assert boundary
        assert all(img is not None and img.shape == (240, 320, 3)
                   for img in images)
        r.close()
        # the snapshot is the newest of them, a JPEG too
        r = await client.get("/download/snapshot.jpg")
        assert r.status == 200 and (await r.read())[:2] == b"\xff\xd8"
        r = await client.get("/download/map.json")
        with open(os.path.join(CLIP, "map.json"), "rb") as f:
            assert await r.read() == f.read()

    serve(clip_engine(tmp_path, loop_file=True), check)


def test_websocket_results_match_landmarklog(gst, tmp_path):
    engine = clip_engine(tmp_path)
    received = []

    async def check(client):
        async with client.ws_connect("/ws") as ws:
            first = await ws.receive_json()
            assert first["type"] == "state"
            assert [lm["id"] for lm in first["landmarks"]]
            while True:
                msg = await ws.receive_json()
                if msg["type"] == "frame":
                    received.append(msg)
                elif msg["type"] == "state" and msg["state"] == "ended":
                    break
        r = await client.get("/download/log.jsonl")
        assert r.status == 200
        received.append(await r.text())

    serve(engine, check)
    log_text = received.pop()
    log = {round(line["pts"] / 1e9, 6): line
           for line in map(json.loads, log_text.splitlines())}
    assert len(log) == CLIP_FRAMES
    # the socket joins a little after the start: most frames, not all
    assert len(received) >= CLIP_FRAMES - 10
    with_ranges = with_pose = 0
    for f in received:
        for key in ("frame", "time", "fps", "threshold", "classes", "lamps",
                    "detections", "pose", "width", "height"):
            assert key in f
        # every element of the chain timed on every frame
        assert set(f["cost_ms"]) == {"labsegment", "blobroundness",
                                     "ipmrange", "trilaterate"}
        assert all(0 < ms < 1000 for ms in f["cost_ms"].values())
        line = log[round(f["pts"], 6)]
        assert f["threshold"] == 50
        assert [c["name"] for c in f["classes"]] == \
            line["labels"]["classes"]
        assert [c["count"] for c in f["classes"]] == \
            line["labels"]["counts"]
        # the console's kept is the chain's verdict, the log's accepted
        # (a thin far disc confirmed by its size and the map is accepted,
        # its blob not kept)
        kept = [d for d in line["detections"] if d["accepted"]]
        assert [d["class"] for d in f["detections"] if d["kept"]] == \
            [d["class"] for d in kept]
        for mine, theirs in zip([d for d in f["detections"] if d["kept"]],
                                kept):
            if "range" in theirs and "range" in theirs["range"]:
                with_ranges += 1
                assert re.fullmatch(r"\d+\.\d{4}", mine["range"])
                assert mine["range"] == f"{theirs['range']['range']:.4f}"
                assert mine["bearing_deg"] == pytest.approx(
                    np.degrees(theirs["range"]["bearing"]), abs=1e-9)
        assert f["lamps"] == {c: any(d["class"] == c for d in kept)
                              for c, m in zip(line["labels"]["classes"],
                                              line["labels"]["markers"])
                              if m}
        if line.get("pose") is not None:
            with_pose += 1
            assert f["pose"]["x"] == pytest.approx(line["pose"]["x"])
            assert f["pose"]["y"] == pytest.approx(line["pose"]["y"])
        else:
            assert f["pose"] is None
    assert with_ranges > 20 and with_pose > 20
    # played at the clip's rate (30 frames/s), not as fast as possible
    fps = [f["fps"] for f in received[10:] if f["fps"]]
    assert 20 < np.median(fps) < 40


# ---------------------------------------------------------------------------
# tuning


def test_tuning_takes_effect_while_playing(gst, tmp_path):
    engine = clip_engine(tmp_path, loop_file=True)

    async def check(client):
        r = await client.get("/api/state")
        specs = {s["name"]: s for s in (await r.json())["tunables"][
            "labsegment"]}
        # the range is the element's own
        pspec = engine.elements()["labsegment"].find_property(
            "min-class-pixels")
        assert specs["min-class-pixels"]["maximum"] == pspec.maximum
        status, reply = await post(client, "/api/tune", {"changes": [
            {"element": "labsegment", "property": "min-class-pixels",
             "value": 1234},
            {"element": "blobroundness", "property": "shape",
             "value": "circle"}]})
        assert status == 200, reply
        labsegment = engine.elements()["labsegment"]
        assert labsegment.get_property("min-class-pixels") == 1234
        assert engine.elements()["blobroundness"].get_property(
            "shape").value_nick == "circle"
        # the next frames were labelled with the new threshold (the meta
        # records the one used)
        got = await frames(client, 3, lambda f: f["threshold"] == 1234)
        assert len(got) == 3
        assert engine.pipe.get_state(0)[1] == pipeline_state("PLAYING")

    serve(engine, check)


def pipeline_state(name):
    from gstlandmark import pipeline
    return getattr(pipeline.Gst.State, name)


def test_save_config_round_trip(gst, tmp_path):
    engine = clip_engine(tmp_path)

    async def check(client):
        await post(client, "/api/tune", {"element": "ipmrange",
                                         "property": "tilt", "value": 20.5})
        status, reply = await post(client, "/api/save-config", {})
        assert status == 200 and reply == {"saved": "project.json"}

    serve(engine, check)
    path = tmp_path / "out" / "project.json"
    config = json.loads(path.read_text())
    assert config["properties"]["ipmrange"]["tilt"] == 20.5
    assert config["properties"]["labsegment"]["min-class-pixels"] == 50
    from gstlandmark.commands import runner
    from gstlandmark.commands.console import read_project
    variables = runner.read_config(str(path))
    assert pal.load_palette(variables["PALETTE"]).names == \
        pal.load_palette(os.path.join(CLIP, "palette.json")).names
    assert read_project(str(path))["properties"]["ipmrange"]["tilt"] == 20.5


# ---------------------------------------------------------------------------
# bad clients


TOKEN = "s3cret-token-for-the-test"


def test_token_required_off_loopback(gst, tmp_path):
    async def check(client):
        await check_token_required(
            client, TOKEN, ("/", "/api/state", "/static/console.js",
                            "/download/palette.json"))
        r = await client.post("/api/control", json={"action": "stop"})
        assert r.status == 401
        assert engine.state == "playing"
        # the page's address sets a cookie its files and video then use
        r = await client.get("/?token=" + TOKEN)
        assert r.status == 200
        r = await client.get("/static/console.css")
        assert r.status == 200
        client.session.cookie_jar.clear()
        for query in ("", "?token=nope"):
            with pytest.raises(aiohttp.WSServerHandshakeError) as err:
                await client.ws_connect("/ws" + query)
            assert err.value.status == 401
        r = await client.get("/stream.mjpg")
        assert r.status == 401
        got = await frames(client, 1, params={"token": TOKEN})
        assert got[0]["type"] == "frame"

    engine = clip_engine(tmp_path, loop_file=True)
    serve(engine, check, token=TOKEN, loopback=False)


def test_loopback_refuses_other_hosts_and_origins(gst, tmp_path):
    async def check(client):
        r = await client.post("/api/control", json={"action": "stop"},
                              headers={"Origin": "http://attacker.example"})
        assert r.status == 403
        assert engine.state == "playing"
        await check_loopback_guard(client, "/api/state")

    engine = clip_engine(tmp_path, loop_file=True)
    serve(engine, check)


def test_bad_requests_are_refused_and_change_nothing(gst, tmp_path):
    engine = clip_engine(tmp_path, loop_file=True)

    async def check(client):
        labsegment = engine.elements()["labsegment"]
        blob = engine.elements()["blobroundness"]

        def settings():
            return (labsegment.get_property("min-class-pixels"),
                    labsegment.get_property("max-distance"),
                    blob.get_property("min-area"),
                    blob.get_property("min-roundness"))

        before = settings()
        cases = [
            ({"element": "labsegment", "property": "max-distance",
              "value": 1000.5}, "labsegment.max-distance: 1000.5 is "
             "outside 0.0..1000.0"),
            ({"element": "labsegment", "property": "min-class-pixels",
              "value": -1}, "labsegment.min-class-pixels: -1 is outside"),
            ({"element": "labsegment", "property": "min-class-pixels",
              "value": 2.5}, "expected an integer"),
            ({"element": "labsegment", "property": "min-class-pixels",
              "value": "7"}, "expected a number"),
            ({"element": "labsegment", "property": "min-class-pixels",
              "value": True}, "expected a number"),
            ({"element": "labsegment", "property": "use-lightness",
              "value": 1}, "expected true or false"),
            ({"element": "blobroundness", "property": "shape",
              "value": "square"}, "expected one of circle, ellipse"),
            ({"element": "labsegment", "property": "palette",
              "value": "/etc/passwd"}, "no tunable property 'palette'"),
            ({"element": "labsegment", "property": "no-such",
              "value": 1}, "no tunable property 'no-such'"),
            ({"element": "filesrc", "property": "location",
              "value": "/etc/passwd"}, "unknown element 'filesrc'"),
            # one bad change in a batch: the good one is not applied
            ({"changes": [{"element": "blobroundness",
                           "property": "min-area", "value": 7},
                          {"element": "blobroundness",
                           "property": "min-roundness", "value": 2}]},
             "blobroundness.min-roundness: 2.0 is outside 0.0..1.0"),
            ({"changes": []}, "expected"),
            ({"element": "labsegment"}, "each change needs"),
        ]
        for body, expected in cases:
            status, reply = await post(client, "/api/tune", body)
            assert status == 400, body
            assert expected in reply["error"], (body, reply)
        assert settings() == before

        r = await client.post("/api/tune", data=b'{"element": "lab',
                              headers={"Content-Type": "application/json"})
        assert r.status == 400
        assert "malformed JSON" in (await r.json())["error"]
        r = await client.post("/api/tune", data=b'[1, 2]',
                              headers={"Content-Type": "application/json"})
        assert r.status == 400
        assert "JSON object" in (await r.json())["error"]
        r = await client.post("/api/tune", data=b'{}',
                              headers={"Content-Type": "text/plain"})
        assert r.status == 415
        big = json.dumps({"element": "labsegment",
                          "property": "min-class-pixels", "value": 9,
                          "pad": "x" * (server.MAX_BODY + 1)})
        r = await client.post("/api/tune", data=big,
                              headers={"Content-Type": "application/json"})
        assert r.status == 413
        assert "Maximum request body size" in (await r.json())["error"]
        await frames(client, 1)     # teaching needs a frame
        status, reply = await post(client, "/api/control",
                                   {"action": "explode"})
        assert status == 400 and "start, pause, step or stop" in reply["error"]
        for body, expected in (
                ({"class": "red", "x": 0, "y": 0, "w": 0, "h": 5},
                 "must be positive"),
                ({"class": "red", "x": 300, "y": 0, "w": 50, "h": 5},
                 "does not fit"),
                ({"class": "red", "x": "0", "y": 0, "w": 5, "h": 5},
                 "x must be an integer"),
                ({"class": "bad name!", "x": 0, "y": 0, "w": 5, "h": 5},
                 "may only contain"),
                ({"x": 0, "y": 0, "w": 5, "h": 5}, "missing class")):
            status, reply = await post(client, "/api/teach", body)
            assert status == 400 and expected in reply["error"], reply
        status, reply = await post(client, "/api/undo", {})
        assert status == 400 and reply["error"] == "nothing to undo"
        assert settings() == before
        assert engine.palette_path == os.path.join(CLIP, "palette.json")
        assert engine.state == "playing"

    serve(engine, check)


# ---------------------------------------------------------------------------
# teaching


def srgb_to_lab(rgb):
    """CIE L*a*b* (D65) of an 8-bit sRGB colour, from the definitions."""
    c = np.array(rgb, float) / 255
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    m = np.array([[0.4124564, 0.3575761, 0.1804375],
                  [0.2126729, 0.7151522, 0.0721750],
                  [0.0193339, 0.1191920, 0.9503041]])
    xyz = m @ lin / np.array([0.95047, 1.0, 1.08883])
    d = 6 / 29
    f = np.where(xyz > d ** 3, np.cbrt(xyz), xyz / (3 * d * d) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]),
                     200 * (f[1] - f[2])])


def test_teach_sets_the_class_colour_live_and_undo_restores(gst, tmp_path):
    rgb = (51, 102, 170)
    engine = solid_engine(tmp_path, rgb)
    hex_colour = "#%02x%02x%02x" % rgb

    async def check(client):
        before = await frames(client, 1)
        red = next(c for c in before[0]["classes"] if c["name"] == "red")
        assert red["rgb"] != hex_colour
        status, reply = await post(client, "/api/teach", {
            "class": "red", "x": 10, "y": 20, "w": 30, "h": 40})
        assert status == 200, reply
        # the project's conversion (OpenCV's, which labsegment matches)
        # is within 0.2 of the exact formula
        assert reply["class"]["lab"] == pytest.approx(
            list(srgb_to_lab(rgb)), abs=0.3)
        assert reply["class"]["marker"] is True
        # the element took the palette while playing: the labels meta
        # reports the new reference, and every pixel is nearest to it
        after = await frames(client, 2, lambda f: any(
            c["name"] == "red" and c["rgb"] == hex_colour
            for c in f["classes"]))
        counts = {c["name"]: c["count"] for c in after[-1]["classes"]}
        assert counts["red"] == 160 * 120
        # a new class is added after the others
        status, reply = await post(client, "/api/teach", {
            "class": "teal", "x": 0, "y": 0, "w": 5, "h": 5,
            "marker": False})
        assert status == 200 and reply["class"]["marker"] is False
        status, reply = await post(client, "/api/save-palette", {})
        assert status == 200
        saved = pal.load_palette(tmp_path / "out" / reply["saved"])
        assert saved.names[-1] == "teal" and "teal" in saved.background
        # undo twice: the built-in palette again, in the element too
        for _ in range(2):
            status, _ = await post(client, "/api/undo", {})
            assert status == 200
        assert engine.palette.names == pal.default_palette().names
        assert [c.lab for c in engine.palette.classes] == \
            [c.lab for c in pal.default_palette().classes]
        restored = await frames(client, 1, lambda f: any(
            c["name"] == "red" and c["rgb"] == red["rgb"]
            for c in f["classes"]))
        assert "teal" not in [c["name"] for c in restored[0]["classes"]]

    serve(engine, check)


def test_console_command_refuses_a_short_token(gst, capsys):
    from gstlandmark.commands.cli import main
    assert main(["console", "--testsrc", "--listen", "0.0.0.0",
                 "--token", "short"]) == 1
    assert "--token must be at least 16 characters" in \
        capsys.readouterr().err


# ---------------------------------------------------------------------------
# controls and several browsers


def test_pause_stop_start_and_several_browsers(gst, tmp_path):
    engine = clip_engine(tmp_path, loop_file=True)
    Gst = pytest.importorskip("gstlandmark.pipeline").Gst

    async def check(client):
        a = await client.ws_connect("/ws")
        b = await client.ws_connect("/ws")

        async def next_frame(ws):
            while True:
                msg = await ws.receive_json()
                if msg["type"] == "frame":
                    return msg

        fa, fb = await next_frame(a), await next_frame(b)
        assert fa["type"] == fb["type"] == "frame"
        # one browser closing its tab stops nothing for the other
        await a.close()
        await next_frame(b)
        status, reply = await post(client, "/api/control",
                                   {"action": "pause"})
        assert status == 200 and reply == {"state": "paused"}
        assert engine.pipe.get_state(5 * Gst.SECOND)[1] == Gst.State.PAUSED
        await asyncio.sleep(0.2)        # frames already on their way
        count = engine.frame_index
        await asyncio.sleep(0.5)
        assert engine.frame_index == count
        status, reply = await post(client, "/api/control",
                                   {"action": "stop"})
        assert reply == {"state": "stopped"}
        assert engine.pipe.get_state(0)[1] == Gst.State.NULL
        status, reply = await post(client, "/api/control",
                                   {"action": "start"})
        assert reply == {"state": "playing"}
        f = await next_frame(b)
        # stopped means the file starts again from its beginning
        while f["pts"] > 0.5:
            f = await next_frame(b)
        await b.close()

    serve(engine, check)


def test_labels_view_shows_the_classes_in_their_colours(gst, tmp_path):
    rgb = (51, 102, 170)
    engine = solid_engine(tmp_path, rgb)

    async def check(client):
        # nobody watching: no false-colour frames are made
        await frames(client, 3)
        assert engine.views["labels"].seq == 0
        r = await client.get("/stream.mjpg", params={"view": "labels"})
        assert r.status == 200
        reader = aiohttp.MultipartReader(r.headers, r.content)
        part = await reader.next()
        image = cv2.imdecode(np.frombuffer(await part.read(), np.uint8),
                             cv2.IMREAD_COLOR)
        r.close()
        # every pixel is nearest to the built-in blue: its class colour
        blue = pal.default_palette().index("blue")
        state = await (await client.get("/api/state")).json()
        got = await frames(client, 1)
        colour = got[0]["classes"][blue]["rgb"]
        assert got[0]["classes"][blue]["count"] == 160 * 120
        expected = [int(colour[i:i + 2], 16) for i in (5, 3, 1)]   # BGR
        assert image.shape == (120, 160, 3)
        assert np.abs(image.reshape(-1, 3).astype(int) -
                      expected).max() <= 3
        assert state["palette"]["classes"][blue]["name"] == "blue"
        r = await client.get("/stream.mjpg", params={"view": "x"})
        assert r.status == 400
        assert "view must be one of overlay, labels" in \
            (await r.json())["error"]

    serve(engine, check)


def test_a_file_can_be_scrubbed(gst, tmp_path):
    engine = clip_engine(tmp_path, loop_file=True)

    async def check(client):
        await frames(client, 2)
        state = await (await client.get("/api/state")).json()
        assert state["duration"] == pytest.approx(CLIP_FRAMES / 30, abs=0.04)
        for seconds in (1.2, 0.3):
            status, reply = await post(client, "/api/seek",
                                       {"seconds": seconds})
            assert status == 200, reply
            got = await frames(client, 1, lambda f: abs(
                f["pts"] - seconds) < 0.02)
            assert got
        # paused: the frame sought to still arrives (the socket is open
        # before the seek: no other frame follows it)
        await post(client, "/api/control", {"action": "pause"})
        await asyncio.sleep(0.3)
        async with client.ws_connect("/ws") as ws:
            await post(client, "/api/seek", {"seconds": 0.9})
            while True:
                msg = await ws.receive_json()
                if msg["type"] == "frame" and abs(msg["pts"] - 0.9) < 0.02:
                    break
        for body, expected in (({"seconds": -1}, "outside 0..1.500 s"),
                               ({"seconds": 99}, "outside 0..1.500 s"),
                               ({"seconds": "1"}, "must be a number"),
                               ({}, "missing seconds")):
            status, reply = await post(client, "/api/seek", body)
            assert status == 400 and expected in reply["error"], reply

    serve(engine, check)


def test_only_a_file_can_be_scrubbed(gst, tmp_path):
    engine = solid_engine(tmp_path, (0, 0, 0))

    async def check(client):
        r = await client.get("/download/map.json")
        assert r.status == 400
        assert "no map" in (await r.json())["error"]
        status, reply = await post(client, "/api/seek", {"seconds": 0})
        assert status == 400
        assert reply["error"] == "seek: only a file can be scrubbed"
        state = await (await client.get("/api/state")).json()
        assert state["duration"] is None

    serve(engine, check)


# ---------------------------------------------------------------------------
# the command


def run_command(args, tmp_path):
    """Starts ``gst-landmark console ARGS``; returns (process, address)."""
    import subprocess
    import sys
    proc = subprocess.Popen(
        [sys.executable, "-m", "gstlandmark.commands.cli", "console", *args,
         "--port", "0", "--out", str(tmp_path / "out")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    match = re.match(r"gst-landmark console: (http://\S+)", line)
    if match is None:
        proc.kill()
        raise AssertionError(f"no address: {line!r} {proc.stderr.read()}")
    return proc, match.group(1)


def test_command_prints_its_address_and_stops_on_ctrl_c(gst, tmp_path):
    import signal
    import urllib.error
    import urllib.request
    proc, url = run_command(["--testsrc"], tmp_path)
    try:
        assert url.startswith("http://127.0.0.1:") and "token" not in url
        with urllib.request.urlopen(url + "api/state", timeout=10) as r:
            assert json.load(r)["state"] == "playing"
        # an open video stream does not keep the server from stopping
        stream = urllib.request.urlopen(url + "stream.mjpg", timeout=10)
        assert stream.read(100).startswith(b"--landmarkframe")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 0
        stream.close()
    finally:
        proc.kill()
        proc.wait()

    # off loopback: a token is made and printed, and required
    proc, url = run_command(["--testsrc", "--listen", "0.0.0.0"], tmp_path)
    try:
        token = re.search(r"\?token=([\w-]+)$", url).group(1)
        assert len(token) >= 16
        base = url.split("?")[0].replace("0.0.0.0", "127.0.0.1")
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(base + "api/state", timeout=10)
        assert err.value.code == 401
        with urllib.request.urlopen(base + "api/state?token=" + token,
                                    timeout=10) as r:
            assert r.status == 200
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        proc.kill()
        proc.wait()


# ---------------------------------------------------------------------------
# many browsers for a while


def rss_mib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS")


def test_ten_browsers_keep_up_and_memory_stays_flat(gst, tmp_path):
    """Ten WebSockets and ten MJPEG readers (half on the classes view) on
    the clip in a loop. LANDMARK_CONSOLE_SOAK_SECONDS sets the length
    (default 8; 600 for the reliability run); the server and the
    clients share this process, so its RSS covers both."""
    seconds = float(os.environ.get("LANDMARK_CONSOLE_SOAK_SECONDS", "8"))
    engine = clip_engine(tmp_path, loop_file=True)
    counts = {}

    async def check(client):
        async def socket(i):
            async with client.ws_connect("/ws") as ws:
                while True:
                    if (await ws.receive_json())["type"] == "frame":
                        counts[f"ws{i}"] = counts.get(f"ws{i}", 0) + 1

        async def stream(i):
            view = "labels" if i % 2 else "overlay"
            # (the client's default limit is 300 s for a whole response)
            r = await client.get("/stream.mjpg", params={"view": view},
                                 timeout=aiohttp.ClientTimeout(total=None))
            reader = aiohttp.MultipartReader(r.headers, r.content)
            while True:
                part = await reader.next()
                assert (await part.read())[:2] == b"\xff\xd8"
                counts[f"mjpeg{i}"] = counts.get(f"mjpeg{i}", 0) + 1

        tasks = [asyncio.ensure_future(socket(i)) for i in range(10)] + \
            [asyncio.ensure_future(stream(i)) for i in range(10)]
        try:
            await asyncio.sleep(4)              # everything allocated
            start, before = dict(counts), rss_mib()
            t0 = time.monotonic()
            while time.monotonic() - t0 < seconds:
                await asyncio.sleep(1)
                assert not [t for t in tasks if t.done()], "a client ended"
            elapsed = time.monotonic() - t0
            growth = rss_mib() - before
        finally:
            for t in tasks:
                t.cancel()
        rates = {k: (counts[k] - start.get(k, 0)) / elapsed for k in counts}
        # the figures docs/console.md quotes (pytest -s shows them)
        print(f"console soak: {elapsed:.0f} s, RSS {before:.1f} MiB "
              f"{growth:+.2f}, clients {min(rates.values()):.1f}-"
              f"{max(rates.values()):.1f} frames/s")
        assert len(rates) == 20
        # nobody starves (the clip is 30 frames/s; a loaded machine may
        # make a reader skip frames, never stop)
        assert min(rates.values()) > 5, rates
        # 600 s measured 0.41 MiB in all: 0.32 in the first 5 s, then
        # flat; the margin is for other allocators and loaded machines
        assert growth < 4, f"RSS grew {growth:.2f} MiB in {elapsed:.0f} s"

    async def main():
        app = server.make_app(engine)
        async with TestClient(TestServer(app)) as client:
            await engine.start()
            await asyncio.wait_for(check(client), seconds + 60)
    asyncio.run(main())


def settled_rss_mib():
    """RSS once the collector has run and glibc has given back its free
    pages (what is left is held, not merely not yet returned)."""
    import ctypes
    import gc
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass                    # another C library: RSS as it is
    return rss_mib()


def test_stop_start_and_source_switches_free_what_they_replace(gst,
                                                               tmp_path):
    """Thirty stop/start cycles and source switches with a browser
    watching (its socket, the overlay and the classes streams): every
    replaced pipeline is finalized and no thread is left behind; with
    LANDMARK_CONSOLE_RSS=1 (run alone) the process holds no more memory
    per cycle than noise. Measured on the
    clip: 0.03-0.13 MiB per cycle after the warm-up (the issue measured
    1-2 MiB)."""
    # the first cycles load the test source's plugins and warm the
    # allocator (123 to 137 MiB); RSS then wanders by +-3 MiB, so the
    # medians of five cycles at either end are compared
    cycles, warmup = 30, 10
    engine = clip_engine(tmp_path, loop_file=True)
    replaced, finalized, rss = [], [], []

    async def check(client):
        async def socket():
            async with client.ws_connect("/ws") as ws:
                while True:
                    await ws.receive_json()

        async def stream(view):
            async with client.get(
                    "/stream.mjpg", params={"view": view},
                    timeout=aiohttp.ClientTimeout(total=None)) as r:
                reader = aiohttp.MultipartReader(r.headers, r.content)
                while await reader.next() is not None:
                    pass

        watchers = [asyncio.ensure_future(socket()),
                    asyncio.ensure_future(stream("overlay")),
                    asyncio.ensure_future(stream("labels"))]
        try:
            for i in range(warmup + cycles):
                if i == warmup:
                    threads = len(os.listdir("/proc/self/task"))
                if i >= warmup:
                    replaced.append(engine.pipe.get_name())
                    engine.pipe.weak_ref(finalized.append, 1)
                if i % 3 == 2:      # the test source and back
                    source = "testsrc" if i % 2 else "start"
                    status, reply = await post(client, "/api/source",
                                               {"id": source})
                    assert status == 200, reply
                else:
                    for action in ("stop", "start"):
                        status, reply = await post(
                            client, "/api/control", {"action": action})
                        assert status == 200, reply
                await asyncio.sleep(0.3)    # frames to every watcher
                if i >= warmup:
                    rss.append(settled_rss_mib())
            assert not [w for w in watchers if w.done()], "a watcher ended"
            assert len(os.listdir("/proc/self/task")) <= threads + 2
        finally:
            for w in watchers:
                w.cancel()
        assert len(finalized) == len(replaced) == cycles
        growth = float(np.median(rss[-5:]) - np.median(rss[:5]))
        # 25 cycles apart: 1 MiB a cycle would be 25 MiB. Only in a
        # process of its own: after the whole suite the process's RSS also
        # follows what earlier tests left (seen: 68 MiB over these cycles
        # at 270 MiB, against 0.03-0.13 MiB a cycle alone)
        if os.environ.get("LANDMARK_CONSOLE_RSS") == "1":
            assert growth < 0.25 * (cycles - 5), \
                f"RSS grew {growth:.2f} MiB in {cycles - 5} cycles: {rss}"

    async def main():
        app = server.make_app(engine)
        async with TestClient(TestServer(app)) as client:
            await engine.start()
            await asyncio.wait_for(check(client), 120)
        await engine.close()
    asyncio.run(main())


def disc_clip(path, rgb, centre=(160, 120), radius=30, frames=30):
    """An MJPEG clip of one still disc of ``rgb`` on mid grey."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"),
                             30, (320, 240))
    assert writer.isOpened()
    image = np.full((240, 320, 3), 128, np.uint8)
    cv2.circle(image, centre, radius, rgb[::-1], -1, cv2.LINE_AA)
    for _ in range(frames):
        writer.write(image)
    writer.release()


def test_a_taught_marker_class_is_detected(gst, tmp_path):
    """An orange disc (no class of the built-in palette): teach "orange"
    from a box inside it, then the disc is detected as orange where it
    was drawn."""
    clip = tmp_path / "disc.avi"
    disc_clip(clip, (255, 140, 0))
    engine = Engine(f"filesrc location={clip} ! decodebin",
                    str(tmp_path / "out"),
                    properties={"labsegment": {"min-class-pixels": 50},
                                "blobroundness": {"min-area": 30}})

    async def check(client):
        before = (await frames(client, 1))[0]
        assert "orange" not in before["lamps"]
        status, reply = await post(client, "/api/teach", {
            "class": "orange", "x": 150, "y": 110, "w": 20, "h": 20})
        assert status == 200, reply
        after = (await frames(client, 1, lambda f: "orange" in f["lamps"]))[0]
        found = [d for d in after["detections"]
                 if d["kept"] and d["class"] == "orange"]
        assert len(found) == 1, after["detections"]
        x, y, w, h = found[0]["bbox"]
        assert abs(x + w / 2 - 160) <= 1 and abs(y + h / 2 - 120) <= 1
        assert 58 <= w <= 62 and 58 <= h <= 62
        assert after["lamps"]["orange"] is True

    serve(engine, check)


def two_things_clip(path, frames=30):
    """An MJPEG clip, still: an orange disc and a blue square on mid
    grey."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"),
                             30, (320, 240))
    assert writer.isOpened()
    image = np.full((240, 320, 3), 128, np.uint8)
    cv2.circle(image, (100, 120), 30, (0, 140, 255), -1, cv2.LINE_AA)
    image[90:150, 220:280] = (200, 60, 30)
    for _ in range(frames):
        writer.write(image)
    writer.release()


def things_engine(tmp_path):
    """The console on ``two_things_clip`` with the built-in palette."""
    clip = tmp_path / "things.avi"
    two_things_clip(clip)
    return Engine(f"filesrc location={clip} ! decodebin",
                  str(tmp_path / "out"))


# the boxes a user draws: inside the disc (two, pooled), a floor patch,
# and one over the square and the grey beside it (two colours: a warning)
TAUGHT_BOXES = [("ball", 85, 105, 30, 30, "marker"),
                ("ball", 90, 125, 20, 15, "marker"),
                ("floor", 10, 10, 60, 40, "floor"),
                ("tile", 200, 80, 60, 60, "marker")]


def test_teaching_gives_the_palette_palette_learn_gives(gst, tmp_path,
                                                        capsys):
    """The same boxes on the same frame: the console's palette equals
    ``gst-landmark palette learn --rect``'s, and its warnings are the
    command's (the frame named instead of the file)."""
    from gstlandmark.commands.cli import main
    engine = things_engine(tmp_path)
    got = {}

    async def check(client):
        await frames(client, 1)
        status, reply = await post(client, "/api/new-palette", {})
        assert status == 200, reply
        # the built-in palette stays until the first box
        assert engine.palette.names == pal.default_palette().names
        status, still = await post(client, "/api/freeze", {})
        for name, x, y, w, h, role in TAUGHT_BOXES:
            status, reply = await post(client, "/api/teach", {
                "class": name, "x": x, "y": y, "w": w, "h": h,
                "role": role, "frame": still["frame"]})
            assert status == 200, reply
        got["warnings"] = reply["warnings"]
        async with client.get("/api/state") as r:
            got["state"] = await r.json()
        cv2.imwrite(str(tmp_path / "frame.png"),
                    engine.frozen[still["frame"]]["frame"])
        got["frame"] = still["frame"]

    serve(engine, check)
    argv = ["palette", "learn", str(tmp_path / "frame.png")]
    for name, x, y, w, h, _ in TAUGHT_BOXES:
        argv += ["--rect", f"{name}:{x},{y},{w},{h}"]
    argv += ["--floor", "floor", "-o", str(tmp_path / "learned.json")]
    capsys.readouterr()
    assert main(argv) == 0
    printed = [line[len("warning: "):] for line in
               capsys.readouterr().err.splitlines()
               if line.startswith("warning: ")]
    learned = pal.load_palette(tmp_path / "learned.json")
    assert pal.palette_to_json(engine.palette) == \
        pal.palette_to_json(learned)
    assert learned.classes[learned.index("floor")].role == "floor"
    assert printed, "palette learn warned of nothing"
    assert got["warnings"] == [
        w.replace(str(tmp_path / "frame.png"), f"frame {got['frame']}")
        for w in printed]
    assert got["state"]["teaching"]["warnings"] == got["warnings"]
    assert got["state"]["teaching"] | {"warnings": None} == {
        "boxes": 4, "frames": 1, "beside": [], "warnings": None}
    # saved with its spreads, as palette learn writes them
    engine.save_palette()
    with open(tmp_path / "out" / "palette.json") as f:
        saved = json.load(f)
    with open(tmp_path / "learned.json") as f:
        assert saved["spread"] == json.load(f)["spread"]


def test_a_loop_that_falls_behind_gets_the_newest_item_only():
    """1,000 frames handed over while the loop is busy: one callback, the
    newest frame; nothing piles up."""
    import threading
    from gstlandmark.commands.console.engine import Handoff

    async def main():
        got = []
        handoff = Handoff(asyncio.get_running_loop(), got.append)
        thread = threading.Thread(
            target=lambda: [handoff.put(i) for i in range(1000)])
        thread.start()
        thread.join()           # the loop was busy all along (this test)
        await asyncio.sleep(0.05)
        assert got == [999] and handoff.dropped == 999
        handoff.put(1000)
        await asyncio.sleep(0.05)
        assert got == [999, 1000]

    asyncio.run(main())


def test_the_source_is_chosen_by_id_never_by_path(gst, tmp_path):
    engine = clip_engine(tmp_path, loop_file=True)
    (tmp_path / "out" / "clips").mkdir(parents=True)
    disc_clip(tmp_path / "out" / "clips" / "disc.avi", (255, 140, 0))
    os.symlink(os.path.join(CLIP, "clip.avi"),
               tmp_path / "out" / "outside.avi")     # a link out: not listed

    async def check(client):
        r = await client.get("/api/sources")
        listing = await r.json()
        ids = [s["id"] for s in listing["sources"]]
        assert listing["current"] == "start"
        assert ids[:2] == ["start", "testsrc"]
        assert "file:clips/disc.avi" in ids
        assert not [i for i in ids if "outside" in i]
        for bad in ("/etc/passwd", "file:../../clip.avi", "file:outside.avi",
                    f"file:{CLIP}/clip.avi", 3, None):
            status, reply = await post(client, "/api/source", {"id": bad})
            assert status == 400 and "unknown source" in reply["error"]
        assert engine.source_id == "start" and engine.state == "playing"
        # tuned settings survive a change of source
        await post(client, "/api/tune", {"element": "labsegment",
                                          "property": "min-class-pixels",
                                          "value": 42})
        status, reply = await post(client, "/api/source", {"id": "testsrc"})
        assert status == 200 and reply == {"current": "testsrc",
                                           "state": "playing"}
        got = await frames(client, 1, lambda f: f["width"] == 640)
        assert got[0]["threshold"] == 42
        status, reply = await post(client, "/api/source",
                                   {"id": "file:clips/disc.avi"})
        assert status == 200
        await frames(client, 1, lambda f: f["width"] == 320 and
                     f["pts"] is not None)
        state = await (await client.get("/api/state")).json()
        assert state["source"] == "file:clips/disc.avi"
        assert state["duration"] == pytest.approx(1.0, abs=0.04)

    serve(engine, check)


def test_class_edits_carry_into_the_next_teaching(gst, tmp_path):
    """A new palette taught, its untaught rest renamed and a class's
    tolerance set: teaching one more box keeps both (a class taught is
    learned again, the others stay as edited)."""
    engine = things_engine(tmp_path)

    async def check(client):
        await frames(client, 1)
        await post(client, "/api/new-palette", {})
        status, still = await post(client, "/api/freeze", {})
        for name, x, y, w, h, role in TAUGHT_BOXES[:2]:
            status, reply = await post(client, "/api/teach", {
                "class": name, "x": x, "y": y, "w": w, "h": h,
                "role": role, "frame": still["frame"]})
            assert status == 200, reply
        assert engine.palette.names == ["ball", "untaught"]
        for edit in ({"class": "untaught", "action": "rename", "to": "rest"},
                     {"class": "ball", "action": "tolerance", "to": 2},
                     {"class": "ball", "action": "rename", "to": "disc"}):
            status, reply = await post(client, "/api/class", edit)
            assert status == 200, reply
        status, reply = await post(client, "/api/teach", {
            "class": "disc", "x": 92, "y": 110, "w": 10, "h": 10,
            "frame": still["frame"]})
        assert status == 200, reply
        disc = engine.palette.classes[engine.palette.index("disc")]
        assert engine.palette.names == ["disc", "rest"]
        assert disc.shading == (0.5, 2.0) and disc.role == "marker"
        # three boxes of disc, pooled
        assert engine.teaching.lessons[-1][2][0] == "disc"
        assert len(engine.teaching.lessons) == 3
        for bad, why in (
                ({"class": "nope", "action": "delete"}, "no class \"nope\""),
                ({"class": "disc", "action": "rename", "to": "rest"},
                 "no class has"),
                ({"class": "disc", "action": "rename", "to": "a b"},
                 "may only contain"),
                ({"class": "disc", "action": "tolerance", "to": 65},
                 "to 64"),
                ({"class": "disc", "action": "paint"}, "action must be")):
            status, reply = await post(client, "/api/class", bad)
            assert status == 400 and why in reply["error"], (bad, reply)
        assert engine.palette.names == ["disc", "rest"]

    serve(engine, check)
