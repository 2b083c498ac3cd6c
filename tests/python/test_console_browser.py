"""gst-landmark console in a real browser: Debian's headless Chromium driven
by Selenium through Debian's chromedriver (nothing downloaded at run
time). scripts/test.sh installs them; elsewhere the tests are skipped
when they are missing.

The page on the shipped clip: frames arrive (the readouts change, the
canvases are drawn), the detections table shows ranges as XX.XXXX m equal
to landmarklog's, a threshold typed into the page reaches the element, a
bad value shows the server's error and changes nothing, dragging a box
over the video and pressing Teach changes the palette; off loopback the
page without the token gets nothing.
"""

import asyncio
import json
import os
import re
import shutil
import socket
import subprocess
import threading
import time

import pytest

webdriver = pytest.importorskip("selenium.webdriver")
from selenium.webdriver.common.action_chains import ActionChains  # noqa
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

from gstlandmark.commands.console import open_urls  # noqa: E402
from gstlandmark.commands.console.engine import Engine  # noqa: E402
from test_console import clip_engine  # noqa: E402

CHROMIUM = shutil.which("chromium")
CHROMEDRIVER = shutil.which("chromedriver")
def _localhost_resolves():
    try:
        socket.getaddrinfo("localhost", None)
        return True
    except OSError:
        return False


# chromedriver reaches Chromium's renderer through the name "localhost":
# a bare system root without /etc/hosts (debootstrap's minbase) cannot
# run these tests; every installed Debian has it
pytestmark = [
    pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None,
                       reason="needs Debian's chromium and chromium-driver"),
    pytest.mark.skipif(not _localhost_resolves(),
                       reason="the name localhost does not resolve (no "
                       "/etc/hosts): chromedriver needs it"),
]
# seconds; a loaded 2-core machine has taken over 20 for a paused frame
WAIT = 40


class ServerThread:
    """The console's server on a free port, in a thread with its own
    event loop (the browser test drives it from outside)."""

    def __init__(self, engine, token=None, host="127.0.0.1"):
        self.engine, self.token, self.host = engine, token, host
        self.ready = threading.Event()
        self.url = None
        self.error = None

    def __enter__(self):
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        assert self.ready.wait(WAIT), "server did not start"
        if self.error:
            raise self.error
        return self

    def _run(self):
        from aiohttp import web
        from gstlandmark.commands.console.server import is_loopback, make_app

        async def main():
            app = make_app(self.engine, token=self.token,
                           loopback=is_loopback(self.host))
            runner = web.AppRunner(app)
            await runner.setup()
            await web.TCPSite(runner, self.host, 0).start()
            await self.engine.start()
            self.port = port = runner.addresses[0][1]
            self.url = f"http://{self.host}:{port}/"
            self.stop = asyncio.Event()
            self.loop = asyncio.get_running_loop()
            self.ready.set()
            await self.stop.wait()
            await runner.cleanup()

        try:
            asyncio.run(main())
        except Exception as err:   # reported by __enter__
            self.error = err
            self.ready.set()

    def __exit__(self, *exc):
        self.loop.call_soon_threadsafe(self.stop.set)
        self.thread.join(WAIT)
        # the server stops promptly with a browser still watching
        assert not self.thread.is_alive(), "the server did not stop"


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def browser(tmp_path):
    """Chromium driven by chromedriver, both reached by address: Selenium's
    own Service connects to the name "localhost", which a fresh system
    without /etc/hosts cannot resolve."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu",
                "--disable-dev-shm-usage", "--window-size=1400,1000"):
        options.add_argument(arg)
    port = _free_port()
    log = open(tmp_path / "chromedriver.log", "wb")
    service = subprocess.Popen([CHROMEDRIVER, f"--port={port}"],
                               stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + WAIT
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), 0.5).close()
                break
            except OSError:
                assert service.poll() is None and \
                    time.monotonic() < deadline, "chromedriver did not start"
                time.sleep(0.05)
        driver = webdriver.Remote(command_executor=f"http://127.0.0.1:{port}",
                                  options=options)
        driver.set_page_load_timeout(WAIT)
        try:
            yield driver
        finally:
            driver.quit()
    finally:
        service.terminate()
        service.wait(WAIT)
        log.close()


def wait_for(driver, condition, what):
    return WebDriverWait(driver, WAIT, 0.1).until(
        lambda d: condition(d), message=what)


def canvas_data(driver, element_id):
    return driver.execute_script(
        f"return document.getElementById('{element_id}').toDataURL()")


def message(driver):
    el = driver.find_element(By.ID, "message")
    return el.get_attribute("class"), el.text


def test_page_shows_live_results_tunes_and_teaches(gst, tmp_path, browser):
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        browser.get(srv.url)
        wait_for(browser, lambda d: re.match(
            r"\d+\.\d frames/s", d.find_element(By.ID, "fps").text),
            "the frame rate readout")
        assert browser.find_element(By.ID, "state").text == "playing"
        # the video is a live MJPEG image of the frame size
        wait_for(browser, lambda d: d.execute_script(
            "return document.getElementById('video').naturalWidth") == 320,
            "the MJPEG video")
        # frames keep arriving: the histogram is redrawn differently
        first = canvas_data(browser, "histogram")
        wait_for(browser, lambda d: canvas_data(d, "histogram") != first,
                 "a changing histogram")
        # a range XX.XXXX m in the table equals one landmarklog wrote
        # (read in one script: the table is redrawn every frame)
        cell = wait_for(browser, lambda d: [
            t for t in d.execute_script(
                "return [...document.querySelectorAll("
                "'#detections td:nth-child(2)')].map(td => td.textContent)")
            if t.endswith(" m")], "a range in the table")[0]
        assert re.fullmatch(r"\d+\.\d{4} m", cell)
        with open(engine.log_path) as f:
            logged = {f"{d['range']['range']:.4f} m"
                      for line in f for d in json.loads(line)["detections"]
                      if "range" in d.get("range", {})}
        assert cell in logged
        # (a few frames of the clip have no pose)
        wait_for(browser, lambda d: d.find_element(By.ID, "pose").text
                 .startswith("pose: x "), "a pose")
        # the classes view: its own stream, made while watched
        browser.find_element(By.CSS_SELECTOR,
                             "input[name=view][value=labels]").click()
        wait_for(browser, lambda d: engine.views["labels"].seq > 3,
                 "false-colour frames")
        assert "view=labels" in browser.find_element(
            By.ID, "video").get_attribute("src")
        browser.find_element(By.CSS_SELECTOR,
                             "input[name=view][value=overlay]").click()
        # a file: the scrubber shows the clip's length
        wait_for(browser, lambda d: d.find_element(
            By.ID, "position").text.endswith("/ 1.50 s"), "the scrubber")

        # tune: a value typed on the page reaches the element
        box = browser.find_element(By.ID, "tune-labsegment-min-class-pixels")
        box.clear()
        box.send_keys("77\n")
        labsegment = engine.elements()["labsegment"]
        wait_for(browser, lambda d: labsegment.get_property(
            "min-class-pixels") == 77, "min-class-pixels set to 77")
        # a bad value: the server's message on the page, nothing changed
        box = browser.find_element(By.ID, "tune-blobroundness-min-roundness")
        before = engine.elements()["blobroundness"].get_property(
            "min-roundness")
        box.clear()
        box.send_keys("3\n")
        wait_for(browser, lambda d: tune_error(
            d, "blobroundness", "min-roundness"), "an error message")
        assert "blobroundness.min-roundness: 3.0 is outside 0.0..1.0" in \
            tune_error(browser, "blobroundness", "min-roundness")
        assert engine.elements()["blobroundness"].get_property(
            "min-roundness") == before

        # teach: drag a box on the video, name a new class
        layer = browser.find_element(By.ID, "box-layer")
        size = layer.size
        ActionChains(browser).move_to_element_with_offset(
            layer, -size["width"] // 4, -size["height"] // 4) \
            .click_and_hold().move_by_offset(40, 30).release().perform()
        wait_for(browser, lambda d: d.find_element(
            By.ID, "teach-box").text != "box: none", "a teach box")
        browser.find_element(By.ID, "teach-class").send_keys("floorpatch")
        browser.find_element(By.ID, "teach-marker").click()
        browser.find_element(By.ID, "teach").click()
        wait_for(browser, lambda d: "taught floorpatch" in message(d)[1],
                 "the teach confirmation")
        assert "floorpatch" in engine.palette.names
        assert "floorpatch" in engine.palette.background
        wait_for(browser, lambda d: "floorpatch" in d.find_element(
            By.ID, "palette").text, "the palette list")
        browser.find_element(By.ID, "undo").click()
        wait_for(browser, lambda d: "floorpatch" not in d.find_element(
            By.ID, "palette").text, "undo")
        assert "floorpatch" not in engine.palette.names

        shot = os.environ.get("LANDMARK_CONSOLE_SCREENSHOT")
        if shot:
            browser.save_screenshot(shot)


def test_page_without_token_gets_nothing_off_loopback(gst, tmp_path,
                                                      browser):
    token = "browser-test-token-0123456789"
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine, token=token, host="0.0.0.0") as srv:
        # the address printed for a wildcard is one a browser can open
        urls = open_urls("0.0.0.0", srv.port, token)
        assert "0.0.0.0" not in " ".join(urls)
        url = urls[0].split("?")[0]
        browser.get(url)
        assert "missing or wrong token" in browser.find_element(
            By.TAG_NAME, "body").text
        browser.get(urls[0])
        wait_for(browser, lambda d: re.match(
            r"\d+\.\d frames/s", d.find_element(By.ID, "fps").text),
            "frames with the token")
        assert browser.execute_script(
            "return document.getElementById('video').naturalWidth") == 320


# ---------------------------------------------------------------------------
# issue 31: what a first-time user gets wrong otherwise


def colour_clip(path, colours, frames_each=30):
    """An MJPEG clip of a 120x90 square in the middle of mid grey, each
    of ``colours`` (RGB) for ``frames_each`` frames in turn."""
    import cv2
    import numpy as np
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"),
                             30, (320, 240))
    assert writer.isOpened()
    for rgb in colours:
        image = np.full((240, 320, 3), 128, np.uint8)
        image[75:165, 100:220] = rgb[::-1]
        for _ in range(frames_each):
            writer.write(image)
    writer.release()


def centre_colour(engine):
    frame = engine.frame_bgr
    return None if frame is None else tuple(int(v) for v in
                                            frame[120, 160][::-1])


def is_red(rgb):
    return rgb is not None and rgb[0] > 150 and rgb[1] < 100


def is_green(rgb):
    return rgb is not None and rgb[1] > 150 and rgb[0] < 100


def drag(browser, dx, dy, w, h, release=True):
    """Presses at (dx, dy) from the video's centre (page pixels) and
    moves by (w, h); releases unless told not to."""
    layer = browser.find_element(By.ID, "box-layer")
    chain = ActionChains(browser).move_to_element_with_offset(
        layer, dx, dy).click_and_hold().move_by_offset(w, h)
    if release:
        chain = chain.release()
    chain.perform()


def open_page(browser, srv):
    browser.get(srv.url)
    wait_for(browser, lambda d: re.match(
        r"\d+\.\d frames/s", d.find_element(By.ID, "fps").text),
        "the frame rate readout")


def test_teach_learns_the_frame_the_box_was_drawn_on(gst, tmp_path,
                                                     browser):
    """The square turns from red to green while the box is dragged: the
    class learns red, the frame under the box (frozen while teaching)."""
    clip = tmp_path / "colours.avi"
    colour_clip(clip, [(0, 160, 60), (220, 30, 30)])
    engine = Engine(f"filesrc location={clip} ! decodebin",
                    str(tmp_path / "out"))
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        # just turned red: press there, hold until the server's frame
        # is green again, release and teach
        wait_for(browser, lambda d: is_green(centre_colour(engine)), "green")
        wait_for(browser, lambda d: is_red(centre_colour(engine)), "red")
        drag(browser, -20, -15, 40, 30, release=False)
        wait_for(browser, lambda d: is_green(centre_colour(engine)),
                 "green again")
        ActionChains(browser).release().perform()
        browser.find_element(By.ID, "teach-class").send_keys("square")
        browser.find_element(By.ID, "teach").click()
        wait_for(browser, lambda d: "taught square" in message(d)[1],
                 "the teach confirmation")
        lab = engine.palette.classes[engine.palette.index("square")].lab
        # red's a* is large and positive, green's negative
        assert lab[1] > 40, lab
        # the page showed that frame, still, while the box was drawn
        assert "frozen.jpg" in browser.find_element(
            By.ID, "video").get_attribute("src")
        browser.find_element(By.ID, "live").click()
        wait_for(browser, lambda d: "stream.mjpg" in d.find_element(
            By.ID, "video").get_attribute("src"), "live again")


def test_reteaching_a_background_class_keeps_its_role(gst, tmp_path,
                                                      browser):
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        assert engine.palette.classes[engine.palette.index("floor")].role \
            == "background"
        browser.find_element(By.ID, "teach-class").send_keys("floor")
        # the marker box follows the class named: floor is no marker
        wait_for(browser, lambda d: not d.find_element(
            By.ID, "teach-marker").is_selected(), "marker unticked")
        size = browser.find_element(By.ID, "box-layer").size
        drag(browser, -size["width"] // 4, size["height"] // 3, 30, 10)
        browser.find_element(By.ID, "teach").click()
        wait_for(browser, lambda d: "taught floor" in message(d)[1],
                 "the teach confirmation")
        assert engine.palette.classes[engine.palette.index("floor")].role \
            == "background"
        assert "floor" not in engine.palette.markers


def camera_file(tmp_path, height, tilt):
    import numpy as np
    from gstlandmark.camerafile import write_camera_file
    from test_console import CAMERA
    f = 160 / np.tan(np.radians(CAMERA["hfov_deg"]) / 2)
    path = str(tmp_path / "camera.yml")
    write_camera_file(path, {
        "image_width": 320, "image_height": 240,
        "camera_matrix": np.array([[f, 0, 159.5], [0, f, 119.5],
                                   [0, 0, 1]]),
        "distortion_coefficients": np.zeros(5),
        "camera_height": height, "tilt_deg": tilt, "roll_deg": 0.0})
    return path


def clip_camera_engine(tmp_path):
    from test_console import CLIP
    return Engine(f"filesrc location={CLIP}/clip.avi ! decodebin",
                  str(tmp_path / "out"),
                  palette_path=os.path.join(CLIP, "palette.json"),
                  map_path=os.path.join(CLIP, "map.json"),
                  camera_path=camera_file(tmp_path, 0.5, 20.0),
                  properties={"labsegment": {"min-class-pixels": 50},
                              "blobroundness": {"min-area": 30}},
                  loop_file=True)


def ranges_by_pts(engine, seconds):
    """{pts: [range_m, ...]} of the frames of the next ``seconds``."""
    got = {}

    def listener(m):
        if m["type"] == "frame":
            # kept or not: a camera twice as high rejects them by size
            got[round(m["pts"], 3)] = sorted(
                d["range_m"] for d in m["detections"] if "range_m" in d)
    engine.listeners.append(listener)
    time.sleep(seconds)
    engine.listeners.remove(listener)
    return got


def tune_value(browser, element, prop):
    return browser.find_element(By.ID, f"tune-{element}-{prop}") \
        .get_attribute("value")


def test_tune_shows_and_changes_the_camera_files_values(gst, tmp_path,
                                                        browser):
    engine = clip_camera_engine(tmp_path)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        wait_for(browser, lambda d: tune_value(
            d, "ipmrange", "camera-height") == "0.5", "the file's height")
        assert tune_value(browser, "ipmrange", "tilt") == "20"
        before = ranges_by_pts(engine, 1.6)
        box = browser.find_element(By.ID, "tune-ipmrange-camera-height")
        box.clear()
        box.send_keys("1\n")
        wait_for(browser, lambda d: "ipmrange.camera-height = 1" in
                 message(d)[1], "the change confirmed")
        time.sleep(0.2)             # frames already past ipmrange
        after = ranges_by_pts(engine, 1.6)
        ratios = [a / b for pts in set(before) & set(after)
                  for a, b in zip(after[pts], before[pts])
                  if len(after[pts]) == len(before[pts])]
        assert len(ratios) > 10
        # twice as high sees the same floor point twice as far
        assert 1.7 < sorted(ratios)[len(ratios) // 2] < 2.6, ratios


def tune_error(browser, element, prop):
    return browser.find_element(
        By.CSS_SELECTOR, f"#tune-{element}-{prop} ~ .tune-error").text


def test_invalid_values_are_refused_next_to_the_field(gst, tmp_path,
                                                      browser):
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        ipmrange = engine.elements()["ipmrange"]
        for bad in ("0", "1e-9"):
            box = browser.find_element(By.ID, "tune-ipmrange-camera-height")
            box.clear()
            box.send_keys(bad + "\n")
            wait_for(browser, lambda d: "ipmrange.camera-height" in
                     tune_error(d, "ipmrange", "camera-height"),
                     "the error beside the field")
            # the refused value is not left in the box
            wait_for(browser, lambda d: tune_value(
                d, "ipmrange", "camera-height") == "0.5", "reverted")
            assert ipmrange.get_property("camera-height") == 0.5
        # a batch with one bad value changes nothing
        reply = browser.execute_async_script("""
            const done = arguments[0];
            fetch("api/tune", {method: "POST",
              headers: {"Content-Type": "application/json"},
              body: JSON.stringify({changes: [
                {element: "labsegment", property: "min-class-pixels",
                 value: 61},
                {element: "ipmrange", property: "camera-height",
                 value: 0}]})})
              .then(r => r.json().then(j => done([r.status, j])));""")
        assert reply[0] == 400 and "ipmrange.camera-height" in \
            reply[1]["error"], reply
        assert engine.elements()["labsegment"].get_property(
            "min-class-pixels") == 50


def browser_pixels(browser):
    """The video as the page shows it, 80x60 RGB."""
    import numpy as np
    data = browser.execute_script("""
        const img = document.getElementById('video');
        const c = document.createElement('canvas'); c.width = 80;
        c.height = 60; const g = c.getContext('2d');
        g.drawImage(img, 0, 0, 80, 60);
        return Array.from(g.getImageData(0, 0, 80, 60).data);""")
    return np.array(data, np.float64).reshape(60, 80, 4)[:, :, :3]


def jpeg_pixels(data):
    import cv2
    import numpy as np
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    return cv2.resize(image, (80, 60),
                      interpolation=cv2.INTER_AREA)[:, :, ::-1] \
        .astype(np.float64)


def shows(browser, data, other=None):
    """The page's video is the JPEG ``data`` (mean difference below 2 of
    255 at 80x60), and nearer it than ``other``."""
    import numpy as np
    seen = browser_pixels(browser)
    near = np.abs(seen - jpeg_pixels(data)).mean()
    far = np.abs(seen - jpeg_pixels(other)).mean() if other else 255
    return near < 2 and near < 0.5 * far


def pause(browser, engine):
    browser.find_element(By.CSS_SELECTOR,
                         "button[data-action=pause]").click()
    wait_for(browser, lambda d: engine.state == "paused", "paused")
    time.sleep(0.3)                 # frames already on their way


def test_the_video_shows_the_frame_sought_to_while_paused(gst, tmp_path,
                                                         browser):
    engine = clip_engine(tmp_path, loop_file=True)
    view = engine.views["overlay"]
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        wait_for(browser, lambda d: view.pts is not None and
                 view.pts > 1.1, "late in the clip")
        pause(browser, engine)
        before = view.data
        # the newest frame, not the one before it
        wait_for(browser, lambda d: shows(d, before), "the paused frame")
        browser.execute_script("""
            const s = document.getElementById('scrub');
            s.value = 0.1; s.dispatchEvent(new Event('change'));""")
        wait_for(browser, lambda d: abs(view.pts - 0.1) < 0.02,
                 "the frame sought to")
        # each part ends with the boundary: the browser shows it at once
        wait_for(browser, lambda d: shows(d, view.data, before),
                 "the frame sought to on the page")


def test_the_position_slider_is_back_after_stop_then_start(gst, tmp_path,
                                                          browser):
    """The page opened while stopped (no duration yet), then Start, Stop,
    Start: the slider comes back each time."""
    engine = clip_engine(tmp_path, loop_file=True)

    def press(action, state):
        browser.find_element(
            By.CSS_SELECTOR, f"button[data-action={action}]").click()
        wait_for(browser, lambda d: engine.state == state, action)

    def slider_shown(d):
        return d.find_element(By.ID, "scrubber").is_displayed() and \
            d.find_element(By.ID, "position").text.endswith("/ 1.50 s")

    with ServerThread(engine) as srv:
        open_page(browser, srv)
        press("stop", "stopped")
        browser.get(srv.url)
        wait_for(browser, lambda d: d.find_element(
            By.ID, "state").text == "stopped", "the page, stopped")
        press("start", "playing")
        wait_for(browser, slider_shown, "the slider after start")
        press("stop", "stopped")
        press("start", "playing")
        wait_for(browser, slider_shown, "the slider after stop and start")


def test_the_classes_view_shows_the_paused_frame(gst, tmp_path, browser):
    engine = clip_engine(tmp_path, loop_file=True)
    labels = engine.views["labels"]
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        view_radio = "input[name=view][value={}]"
        browser.find_element(By.CSS_SELECTOR,
                             view_radio.format("labels")).click()
        wait_for(browser, lambda d: labels.seq > 2, "false-colour frames")
        old = labels.data
        old_pts = labels.pts
        browser.find_element(By.CSS_SELECTOR,
                             view_radio.format("overlay")).click()
        # the clip moves on (0.5 s: the robot turns; it loops in 1.5 s)
        wait_for(browser, lambda d: abs(
            engine.views["overlay"].pts - old_pts) > 0.5, "later frames")
        pause(browser, engine)
        paused_pts = engine.views["overlay"].pts
        browser.find_element(By.CSS_SELECTOR,
                             view_radio.format("labels")).click()
        wait_for(browser, lambda d: labels.pts == paused_pts,
                 "the paused frame's classes")
        wait_for(browser, lambda d: shows(d, labels.data, old),
                 "the paused frame's classes on the page")


def test_layout_fits_a_narrow_window(gst, tmp_path, browser):
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        browser.set_window_size(700, 1000)
        open_page(browser, srv)
        width = browser.execute_script(
            "return [document.documentElement.scrollWidth, "
            "document.documentElement.clientWidth]")
        assert width[0] <= width[1], width


def test_one_log_per_run_rotated_and_downloaded(gst, tmp_path, browser):
    """Stop then Start begins a new log file named by its start time; a
    run past the size bound goes on in a new file; the download is this
    run's file, whole JSON lines."""
    from test_console import CLIP, CLIP_PROPERTIES
    engine = Engine(f"filesrc location={CLIP}/clip.avi ! decodebin",
                    str(tmp_path / "out"),
                    palette_path=os.path.join(CLIP, "palette.json"),
                    map_path=os.path.join(CLIP, "map.json"),
                    properties=CLIP_PROPERTIES, loop_file=True,
                    log_max_bytes=60_000)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        first = engine.log_path
        for action, state in (("stop", "stopped"), ("start", "playing")):
            browser.find_element(
                By.CSS_SELECTOR, f"button[data-action={action}]").click()
            wait_for(browser, lambda d: engine.state == state, action)
        assert engine.log_path != first
        # about 4 KB a frame: 60 kB rotate within a second or two
        wait_for(browser, lambda d: len(engine.log_files()) >= 3,
                 "a rotated log")
        # a file just begun holds no frame yet
        wait_for(browser, lambda d: os.path.getsize(engine.log_path) > 0,
                 "a frame in the newest log")
        text = browser.execute_async_script("""
            const done = arguments[0];
            fetch("download/log.jsonl").then(r => r.text()).then(done);""")
    names = [os.path.basename(p) for p in engine.log_files()]
    assert all(re.fullmatch(r"log-\d{8}-\d{6}(-\d+)?\.jsonl", n)
               for n in names), names
    assert os.path.isfile(first)
    lines = [json.loads(line) for line in text.splitlines()]
    assert lines
    for path in engine.log_files():
        with open(path) as f:
            for line in f:
                json.loads(line)        # whole lines, none cut
        # checked about once a second: at most one more second of frames
        assert os.path.getsize(path) < 60_000 + 40 * 4_500


def test_teaching_shows_palette_learns_warnings(gst, tmp_path, browser):
    """New palette, then boxes drawn on the page: the palette is the
    boxes' alone and paletteaudit's warnings are listed under Teach (a
    box over the blue square and the grey beside it holds two
    colours)."""
    from test_console import things_engine
    engine = things_engine(tmp_path)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        browser.find_element(By.ID, "new-palette").click()
        wait_for(browser, lambda d: "new palette" in d.find_element(
            By.ID, "taught").text, "the new palette announced")
        size = browser.find_element(By.ID, "box-layer").size
        scale = size["width"] / 320     # page pixels per frame pixel

        def teach(name, x, y, w, h, marker=True):
            # from the frame pixel (x, y), relative to the centre
            drag(browser, round((x - 160) * scale),
                 round((y - 120) * scale), round(w * scale),
                 round(h * scale))
            field = browser.find_element(By.ID, "teach-class")
            field.clear()
            field.send_keys(name)
            tick = browser.find_element(By.ID, "teach-marker")
            if tick.is_selected() != marker:
                tick.click()
            browser.find_element(By.ID, "teach").click()
            wait_for(browser, lambda d: f"taught {name}" in message(d)[1],
                     f"{name} taught")

        teach("ball", 88, 108, 24, 24)
        assert browser.find_element(By.ID, "teach-warnings").text == ""
        teach("tile", 200, 80, 60, 60)
        wait_for(browser, lambda d: "holds two colours" in d.find_element(
            By.ID, "teach-warnings").text, "the two-colours warning")
        assert "warning(s) below" in message(browser)[1]
        assert "rectangle tile:" in browser.find_element(
            By.ID, "teach-warnings").text
        # the boxes' classes (and the rest of the frame) only
        assert set(engine.palette.names) <= {"ball", "tile", "untaught"}
        # still frozen: both on the one frame
        assert "2 box(es) on 1 frame(s)" in browser.find_element(
            By.ID, "taught").text


# ---------------------------------------------------------------------------
# what OpenMV IDE and PixyMon users expect


def class_counts(engine, seconds):
    """[{class: pixels}, ...] of the frames of the next ``seconds``."""
    got = []

    def listener(m):
        if m["type"] == "frame":
            got.append({c["name"]: c["count"] for c in m["classes"]})
    engine.listeners.append(listener)
    time.sleep(seconds)
    engine.listeners.remove(listener)
    return got


def select_class(browser, name):
    from selenium.webdriver.support.ui import Select
    wait_for(browser, lambda d: name in [
        o.text for o in Select(d.find_element(By.ID, "class-select"))
        .options], f"{name} in the class list")
    Select(browser.find_element(By.ID, "class-select")) \
        .select_by_value(name)


def test_a_class_is_renamed_and_deleted_in_the_element(gst, tmp_path,
                                                       browser):
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        select_class(browser, "pink")
        browser.find_element(By.ID, "class-new-name").send_keys("magenta")
        browser.find_element(By.ID, "rename").click()
        wait_for(browser, lambda d: "rename pink -> magenta" in
                 message(d)[1], "the rename confirmed")
        # labsegment's labels meta names it so: the element took it
        wait_for(browser, lambda d: "magenta" in class_counts(engine, 0.3)
                 [-1], "magenta in the frames")
        assert "pink" not in class_counts(engine, 0.3)[-1]
        assert engine.palette.names.index("magenta") == 3
        select_class(browser, "wall")
        browser.find_element(By.ID, "delete").click()
        wait_for(browser, lambda d: "wall" not in class_counts(
            engine, 0.3)[-1], "wall gone from the frames")
        assert "wall" not in browser.find_element(By.ID, "palette").text
        # the wall's pixels went to their next nearest class
        assert len(class_counts(engine, 0.3)[-1]) == 6
        browser.find_element(By.ID, "undo").click()
        wait_for(browser, lambda d: "wall" in class_counts(engine, 0.3)
                 [-1], "wall back")


def test_tolerance_widens_a_class_in_the_element(gst, tmp_path, browser):
    """A solid red in a sixth of the light it was taught in is nearer
    black than red; tolerance x4 gives red "shading" [0.25, 4] and the
    element labels every pixel red."""
    from gstlandmark import palette as pal
    red = (41.25, 43.0, 32.0)
    path = tmp_path / "palette.json"
    pal.save_palette(pal.Palette([
        pal.PaletteClass("red", red), pal.PaletteClass("black", (10, 0, 0)),
        pal.PaletteClass("grey", (53.58, 0, 0), role="floor")]), str(path))
    # lab_under_light(red, 0.15) in sRGB
    engine = Engine("videotestsrc is-live=true pattern=solid-color "
                    "foreground-color=0xff45140c ! video/x-raw,width=160,"
                    "height=120,framerate=30/1", str(tmp_path / "out"),
                    palette_path=str(path))
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        assert all(f["black"] == 160 * 120
                   for f in class_counts(engine, 0.5))
        select_class(browser, "red")
        box = browser.find_element(By.ID, "tolerance")
        assert box.get_attribute("value") == "1"
        box.clear()
        box.send_keys("4\n")
        wait_for(browser, lambda d: "tolerance red -> 4" in message(d)[1],
                 "the tolerance confirmed")
        assert engine.palette.classes[0].shading == (0.25, 4.0)
        with open(engine.palette_path) as f:
            assert json.load(f)["classes"][0]["shading"] == [0.25, 4]
        wait_for(browser, lambda d: class_counts(engine, 0.2)[-1]["red"]
                 == 160 * 120, "every pixel red")
        # a factor below 1 is refused, the palette unchanged
        box.clear()
        box.send_keys("0.5\n")
        wait_for(browser, lambda d: "tolerance: red: expected a light "
                 "factor" in message(d)[1], "the refusal")
        assert engine.palette.classes[0].shading == (0.25, 4.0)


def test_binary_view_shows_one_class(gst, tmp_path, browser):
    import numpy as np
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        select_class(browser, "floor")
        browser.find_element(By.CSS_SELECTOR,
                             "input[name=view][value=binary]").click()
        wait_for(browser, lambda d: "class=floor" in d.find_element(
            By.ID, "video").get_attribute("src"), "the binary stream")
        view = engine.views["binary:floor"]
        wait_for(browser, lambda d: view.seq > 3, "binary frames")
        pause(browser, engine)
        counts = class_counts(engine, 0)     # nothing new while paused
        assert not counts
        buf = engine._last_buffer
        from gstlandmark import meta
        labels = meta.labels(buf)
        floor = next(c for c in labels.classes if c.name == "floor")
        share = floor.count / labels.plane.size
        wait_for(browser, lambda d: view.pts == buf.pts / 1e9,
                 "the paused frame's binary view")
        seen = browser_pixels(browser)
        # black and white only (JPEG edges aside), white where floor is
        grey = np.mean((seen > 40) & (seen < 215))
        assert grey < 0.05, grey
        white = np.mean(seen.mean(axis=2) > 127)
        assert abs(white - share) < 0.03, (white, share)


def test_statistics_of_the_box_drawn(gst, tmp_path, browser):
    """Mean and spread in L*a*b* of a box inside the orange disc: the
    disc's colour by the CIE formulas, a spread of JPEG noise."""
    from test_console import srgb_to_lab, things_engine
    engine = things_engine(tmp_path)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        size = browser.find_element(By.ID, "box-layer").size
        scale = size["width"] / 320
        drag(browser, round(-72 * scale), round(-12 * scale),
             round(24 * scale), round(24 * scale))
        wait_for(browser, lambda d: " px " in d.find_element(
            By.ID, "box-stats").text, "the statistics")
        text = browser.find_element(By.ID, "box-stats").text
        got = [float(v) for v in re.findall(
            r"[Lab]\* (-?\d+\.\d) \u00b1 (\d+\.\d)", text) for v in v]
        expected = srgb_to_lab((255, 140, 0))
        for k in range(3):
            assert abs(got[2 * k] - expected[k]) < 3, (text, expected)
            assert got[2 * k + 1] < 3, text
        assert browser.find_element(By.ID, "box-histogram").is_displayed()
        assert canvas_data(browser, "box-histogram") != \
            browser.execute_script(
                "const c = document.createElement('canvas'); c.width = 300;"
                " c.height = 96; return c.toDataURL()")


def test_step_shows_the_next_frame(gst, tmp_path, browser):
    engine = clip_engine(tmp_path, loop_file=True)
    view = engine.views["overlay"]
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        wait_for(browser, lambda d: view.pts is not None and
                 0.3 < view.pts < 1.0, "mid clip")
        pause(browser, engine)
        for _ in range(3):
            before, data = view.pts, view.data
            browser.find_element(By.CSS_SELECTOR,
                                 "button[data-action=step]").click()
            wait_for(browser, lambda d: view.pts != before, "a step")
            # the next frame of the 30 frames/s clip, still paused
            assert abs(view.pts - before - 1 / 30) < 0.002, \
                (before, view.pts)
            assert engine.state == "paused"
            wait_for(browser, lambda d: shows(d, view.data, data),
                     "the next frame on the page")


def test_zoom_enlarges_the_video_and_keeps_boxes_in_frame_pixels(
        gst, tmp_path, browser):
    from selenium.webdriver.support.ui import Select
    engine = clip_engine(tmp_path, loop_file=True)
    with ServerThread(engine) as srv:
        open_page(browser, srv)
        width = browser.find_element(By.ID, "video").size["width"]
        Select(browser.find_element(By.ID, "zoom")).select_by_value("2")
        # twice the panel's width inside its scroll bar
        wait_for(browser, lambda d: d.find_element(
            By.ID, "video").size["width"] > 1.9 * width and abs(
            d.find_element(By.ID, "video").size["width"] - 2 *
            d.execute_script("return document.getElementById("
                             "'video-scroll').clientWidth")) <= 2,
            "twice as wide")
        layer = browser.find_element(By.ID, "box-layer")
        scale = layer.size["width"] / 320
        # a box in the visible top-left corner of the enlarged video (the
        # offsets from the centre of the panel that scrolls it)
        panel = browser.find_element(By.ID, "video-scroll")
        browser.execute_script("arguments[0].scrollIntoView()", panel)
        ActionChains(browser).move_to_element_with_offset(
            panel, round(-panel.size["width"] / 2 + 20 * scale),
            round(-panel.size["height"] / 2 + 10 * scale)) \
            .click_and_hold().move_by_offset(round(40 * scale),
                                             round(30 * scale)) \
            .release().perform()
        text = browser.find_element(By.ID, "teach-box").text
        x, y, w, h = (int(v) for v in re.findall(r"\d+", text))
        assert abs(x - 20) <= 1 and abs(y - 10) <= 1, text
        assert abs(w - 40) <= 1 and abs(h - 30) <= 1, text
