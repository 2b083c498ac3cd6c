"""The live fleet map in a real browser (Debian's headless Chromium and
chromedriver, as tests/python/test_console_browser.py; skipped without
them): two robots' latest poses are drawn on the canvas where the map's
own scale puts them, in their colours, and listed in the table."""

import json
import os

import pytest

pytest.importorskip("selenium.webdriver")
from selenium.webdriver.common.by import By  # noqa: E402

from test_console_browser import (  # noqa: E402,F401
    browser, pytestmark, wait_for)

from gstlandmark.commands import fleetweb  # noqa: E402
from gstlandmark.commands.fleet import FleetState  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
MAP = os.path.join(ROOT, "tests", "files", "clips", "path-small", "map.json")
WIDTH, HEIGHT, MARGIN = 800, 600, 0.5      # the page's canvas and margin


def feed(state, name, poses):
    for i, (x, y, h) in enumerate(poses):
        state.handle(f"landmark/{name}/frame", json.dumps(
            {"frame": i, "wall-time": 1000.0 + i, "detections": [],
             "pose": {"x": x, "y": y, "heading": h,
                      "covariance": [0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01]}}
        ).encode())
    state.handle(f"landmark/{name}/status", b'{"status": "online"}')


def test_canvas_draws_two_robots(browser):  # noqa: F811
    state = FleetState(path_every=0)
    poses = {"r1": [(1.0, 1.0, 0.0), (2.0, 1.5, 0.5)],
             "r2": [(5.0, 5.0, 3.0), (4.0, 4.5, 2.0)]}
    for name, p in poses.items():
        feed(state, name, p)
    landmarks = fleetweb.read_landmarks(MAP)
    # the page's projection: everything shown, a margin, one scale, y up
    xs = [m["x"] for m in landmarks] + [p[0] for v in poses.values()
                                        for p in v]
    ys = [m["y"] for m in landmarks] + [p[1] for v in poses.values()
                                        for p in v]
    x0, y0 = min(xs) - MARGIN, min(ys) - MARGIN
    s = min(WIDTH / (max(xs) + MARGIN - x0), HEIGHT / (max(ys) + MARGIN - y0))

    server = fleetweb.MapServer(state, "127.0.0.1", 0,
                                landmarks=landmarks).start()
    try:
        browser.get(server.url)
        wait_for(browser, lambda d: d.execute_script(
            "return window.fleetDrawn.robots") == ["r1", "r2"],
            "both robots drawn")
        colours = {}
        for name, p in poses.items():
            x, y, _ = p[-1]
            u, v = int((x - x0) * s), int(HEIGHT - (y - y0) * s)
            rgba = browser.execute_script(
                "return Array.from(document.getElementById('map')"
                f".getContext('2d').getImageData({u}, {v}, 1, 1).data)")
            # the robot's dot: opaque and strongly coloured, not the
            # white background or a grey landmark
            assert rgba[3] == 255 and max(rgba[:3]) - min(rgba[:3]) > 80, \
                (name, rgba)
            colours[name] = rgba
        assert colours["r1"] != colours["r2"]
        rows = browser.find_elements(By.CSS_SELECTOR, "#robots tbody tr")
        assert [r.find_elements(By.TAG_NAME, "td")[1].text
                for r in rows] == ["online", "online"]
    finally:
        server.stop()
