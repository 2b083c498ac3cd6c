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
WAIT = 20


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
            port = runner.addresses[0][1]
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
        wait_for(browser, lambda d: message(d)[0] == "error",
                 "an error message")
        assert "blobroundness.min-roundness: 3.0 is outside 0.0..1.0" in \
            message(browser)[1]
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
        assert engine.palette.names[-1] == "floorpatch"
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
        url = srv.url.replace("0.0.0.0", "127.0.0.1")
        browser.get(url)
        assert "missing or wrong token" in browser.find_element(
            By.TAG_NAME, "body").text
        browser.get(url + "?token=" + token)
        wait_for(browser, lambda d: re.match(
            r"\d+\.\d frames/s", d.find_element(By.ID, "fps").text),
            "frames with the token")
        assert browser.execute_script(
            "return document.getElementById('video').naturalWidth") == 320
