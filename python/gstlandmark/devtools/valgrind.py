"""The whole chain under valgrind's memcheck, and a reader of its XML
report (scripts/valgrind.sh runs ``python -m gstlandmark.devtools.valgrind``).

``run()`` writes a few hundred frames of the shipped clip as one raw RGB
file and runs::

    valgrind --tool=memcheck --leak-check=full --xml=yes ...
        gst-launch-1.0 filesrc ! rawvideoparse ! labsegment ! blobroundness
        ! ipmrange ! trilaterate ! landmarkoverlay ! landmarklog ! fakesink

with GLib and GStreamer set up for valgrind (``G_SLICE=always-malloc``,
``G_DEBUG=gc-friendly``, ``GST_REGISTRY_FORK=no``) and the suppressions
of tests/valgrind/gstreamer.supp (plus GLib's glib.supp when installed).
gst-launch-1.0 is a C program that shuts the pipeline down and calls
``gst_deinit`` at the end, so every buffer, meta, element and file our
code made must be gone by then.

``summarise()`` counts valgrind's records by kind (``Leak_DefinitelyLost``,
``InvalidRead``, ...) in total and "ours": records with a stack frame in
libgstlandmark or in a source file of this project. ``ok`` requires no
definite or indirect leak of ours and no non-leak error (invalid read or
write, bad free, use of uninitialised memory) of ours.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from typing import Any, Dict, List, Optional

from . import soak
from .sourcetree import ROOT

SUPPRESSIONS = [
    os.path.join(ROOT, "tests", "valgrind", "gstreamer.supp"),
    "/usr/share/glib-2.0/valgrind/glib.supp",       # libglib2.0-dev
]
OUR_OBJECT = "libgstlandmark"
DEFAULT_FRAMES = 150
DEFAULT_SIZE = (320, 240)
LEAK_KINDS = ("Leak_DefinitelyLost", "Leak_IndirectlyLost",
              "Leak_PossiblyLost")


class ValgrindError(RuntimeError):
    pass


def _frames(error: ET.Element) -> List[Dict[str, str]]:
    stack = error.find("stack")
    if stack is None:
        return []
    return [{k: (f.findtext(k) or "") for k in ("obj", "fn", "dir", "file",
                                                "line")}
            for f in stack.findall("frame")]


def _is_ours(frame: Dict[str, str], source_root: str) -> bool:
    # only an absolute source folder: Debian 13's libc debug data names
    # relative ones (./elf), which would resolve into the current folder
    return (OUR_OBJECT in os.path.basename(frame["obj"]) or
            (os.path.isabs(frame["dir"]) and
             os.path.realpath(frame["dir"]).startswith(source_root)))


def summarise(xml_path: str,
              source_root: str = ROOT) -> Dict[str, Any]:
    """Counts of valgrind's XML report (protocol 4) by kind, in total and
    for records whose stack passes through our code; the suppressions
    used; and the first stacks of ours, for reading."""
    root = ET.parse(xml_path).getroot()
    source_root = os.path.realpath(source_root)
    total: Dict[str, Dict[str, int]] = {}
    ours: Dict[str, Dict[str, int]] = {}
    shown: List[Dict[str, Any]] = []
    for error in root.findall("error"):
        kind = error.findtext("kind") or "?"
        leaked = int(error.findtext("xwhat/leakedbytes") or 0)
        frames = _frames(error)
        mine = any(_is_ours(f, source_root) for f in frames)
        for table, counted in ((total, True), (ours, mine)):
            if counted:
                row = table.setdefault(kind, {"records": 0, "bytes": 0})
                row["records"] += 1
                row["bytes"] += leaked
        if mine and len(shown) < 10:
            shown.append({
                "kind": kind,
                "what": error.findtext("what") or
                error.findtext("xwhat/text") or "",
                "stack": [f"{f['fn'] or '?'} ({os.path.basename(f['obj'])}"
                          + (f" {f['file']}:{f['line']}" if f["file"]
                             else "") + ")" for f in frames[:12]]})
    suppressed = {pair.findtext("name"): int(pair.findtext("count") or 0)
                  for pair in root.iter("pair")}

    def records(table, kinds):
        return sum(table.get(k, {}).get("records", 0) for k in kinds)

    errors = [k for k in set(total) | set(ours) if not k.startswith("Leak_")]
    definite = ("Leak_DefinitelyLost", "Leak_IndirectlyLost")
    return {
        "total": total, "ours": ours, "suppressions_used": suppressed,
        "definite_ours": records(ours, definite),
        "errors_ours": records(ours, errors),
        "invalid_accesses": records(total, [k for k in errors
                                            if k.startswith("Invalid")]),
        "ok": records(ours, definite) == 0 and records(ours, errors) == 0,
        "stacks_ours": shown,
    }


def write_raw_frames(path: str, frames: int, size) -> None:
    """``frames`` frames of the shipped clip, cycled, as one raw RGB file
    for ``filesrc ! rawvideoparse``."""
    clip = soak.clip_frames(*size)
    with open(path, "wb") as f:
        for i in range(frames):
            f.write(clip[i % len(clip)])


def run(frames: int = DEFAULT_FRAMES, size=DEFAULT_SIZE,
        out_dir: Optional[str] = None, error_after: Optional[int] = None,
        timeout_s: float = 900) -> Dict:
    """Runs the chain under memcheck; returns ``summarise()``'s report
    with the run's frames, seconds, log lines and file names. Without
    ``out_dir`` the files go to a temporary folder, removed afterwards.
    ``error_after=K`` puts ``identity error-after=K`` after the log: the
    stream fails at its K-th frame (with frames in flight in the chain),
    gst-launch-1.0 exits with status 1 and the log has K lines."""
    valgrind = shutil.which("valgrind")
    launch = shutil.which("gst-launch-1.0")
    if valgrind is None or launch is None:
        raise ValgrindError("valgrind and gst-launch-1.0 are needed")
    tmp = None
    if out_dir is None:
        out_dir = tmp = tempfile.mkdtemp(prefix="gst-landmark-valgrind-")
    os.makedirs(out_dir, exist_ok=True)
    try:
        raw = os.path.join(out_dir, "frames.rgb")
        log = os.path.join(out_dir, "log.jsonl")
        xml = os.path.join(out_dir, "memcheck.xml")
        write_raw_frames(raw, frames, size)
        env = dict(os.environ, G_SLICE="always-malloc",
                   G_DEBUG="gc-friendly", GST_REGISTRY_FORK="no")
        # bring the registry up to date outside valgrind: a plugin scan
        # under memcheck takes minutes
        subprocess.run(["gst-inspect-1.0", "labsegment"], env=env,
                       stdout=subprocess.DEVNULL, check=True)
        supps = [f"--suppressions={s}" for s in SUPPRESSIONS
                 if os.path.isfile(s)]
        width, height = size
        cmd = [valgrind, "--tool=memcheck", "--leak-check=full",
               "--show-leak-kinds=definite,indirect,possible",
               "--num-callers=40", "--xml=yes", f"--xml-file={xml}",
               *supps, launch, "-q",
               "filesrc", f"location={raw}", "!", "rawvideoparse",
               f"width={width}", f"height={height}", "format=rgb",
               f"framerate={soak.FPS}/1", "!",
               *soak.chain(log).split(), "!"]
        if error_after is not None:
            cmd += ["identity", f"error-after={error_after}", "!"]
        cmd += ["fakesink", "sync=false"]
        t0 = time.perf_counter()
        res = subprocess.run(cmd, env=env, capture_output=True, text=True,
                             timeout=timeout_s)
        seconds = time.perf_counter() - t0
        expected = 0 if error_after is None else 1
        if res.returncode != expected or not os.path.isfile(xml):
            raise ValgrindError(f"gst-launch-1.0 under valgrind failed "
                                f"({res.returncode}): {res.stderr[-2000:]}")
        report = summarise(xml)
        # rawvideoparse adds up a rounded frame duration: its timestamps
        # drift from frame_pts() by a nanosecond a frame
        logged = soak.check_log(log, frames if error_after is None
                                else min(error_after, frames),
                                exact_pts=False)
        report.update(
            frames=frames, size=f"{width}x{height}",
            error_after=error_after,
            seconds=round(seconds, 1), log_lines=logged["lines"],
            poses=logged["poses"], log_problems=logged["problems"],
            suppression_files=[s.split("=", 1)[1] for s in supps])
        report["ok"] = report["ok"] and not logged["problems"]
        if tmp is None:
            report["xml"] = xml
        return report
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m gstlandmark.devtools.valgrind",
        description="The whole chain under valgrind memcheck: prints a "
                    "JSON report; exit status 1 on a definite leak or an "
                    "invalid access in our code.")
    p.add_argument("--frames", type=int, default=DEFAULT_FRAMES)
    p.add_argument("--size", default="%dx%d" % DEFAULT_SIZE,
                   help="WIDTHxHEIGHT")
    p.add_argument("--error-after", type=int, metavar="K",
                   help="fail the stream at frame K (identity error-after "
                        "after the log): the error path's clean-up")
    p.add_argument("--out", help="keep the raw frames, the log and "
                                 "memcheck.xml in this folder")
    p.add_argument("--xml", help="only summarise this memcheck XML file")
    args = p.parse_args(argv)
    if args.xml:
        report = summarise(args.xml)
    else:
        try:
            size = tuple(int(v) for v in args.size.lower().split("x"))
        except ValueError:
            p.error(f"--size must be WIDTHxHEIGHT, got {args.size!r}")
        try:
            report = run(args.frames, size, args.out, args.error_after)
        except ValgrindError as err:
            print(f"error: {err}", file=sys.stderr)
            return 1
    print(json.dumps(report, indent=2))
    return 0 if report["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
