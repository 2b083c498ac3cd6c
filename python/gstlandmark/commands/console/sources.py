"""Where the console's video comes from: the launch fragment for a file,
a camera or the test source, and the sources a browser may switch to.
Apart from the engine because the command line checks its source here
before any pipeline exists, and because the list is the console's
safety rule (a browser names an id, never a path)."""

from __future__ import annotations

import glob
import os
from typing import Dict, Optional

from .. import runner
from .values import ConsoleError

VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".webm", ".mjpeg",
                  ".mjpg")


def source_fragment(input_path: Optional[str] = None,
                    camera: Optional[str] = None,
                    testsrc: bool = False) -> str:
    """The launch fragment that produces raw video for the chain."""
    chosen = [x for x in (input_path, camera, testsrc or None)
              if x is not None]
    if len(chosen) != 1:
        raise ConsoleError("give one of --input FILE, --camera /dev/videoN "
                           "or --testsrc")
    if input_path is not None:
        if not os.path.isfile(input_path):
            raise ConsoleError(f"{input_path}: no such file")
        return (f"filesrc location={runner.quote(os.path.abspath(input_path))}"
                " ! decodebin")
    if camera is not None:
        if not os.path.exists(camera):
            raise ConsoleError(f"{camera}: no such device")
        # decodebin passes raw video through and decodes MJPEG cameras
        return f"v4l2src device={runner.quote(camera)} ! decodebin"
    return "videotestsrc is-live=true pattern=ball ! video/x-raw,width=640," \
           "height=480,framerate=30/1"


def list_sources(out_dir: str, start_source: str
                 ) -> Dict[str, Dict[str, str]]:
    """The sources a browser may choose, by id: the one given at start,
    the test source, every V4L2 camera, and video files under the output
    folder (nothing else: a client names an id, never a path)."""
    sources = {"start": {"label": "as started", "fragment": start_source},
               "testsrc": {"label": "test source",
                           "fragment": source_fragment(testsrc=True)}}
    for device in sorted(glob.glob("/dev/video*")):
        sources[f"camera:{device}"] = {
            "label": device, "fragment": source_fragment(camera=device)}
    root = os.path.realpath(out_dir)
    for folder, dirs, files in os.walk(root):
        if folder[len(root):].count(os.sep) >= 2:
            dirs[:] = []            # two levels below the output folder
        for name in sorted(files):
            path = os.path.join(folder, name)
            # a link out of the folder is not under it
            if not name.lower().endswith(VIDEO_SUFFIXES) or \
                    not os.path.realpath(path).startswith(root + os.sep):
                continue
            rel = os.path.relpath(path, root)
            sources[f"file:{rel}"] = {
                "label": rel, "fragment": source_fragment(input_path=path)}
    return sources
