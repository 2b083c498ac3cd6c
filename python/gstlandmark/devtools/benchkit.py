"""What the benchmarks share (``bench labsegment``, ``bench chain``,
``bench fleet``): their error, core pinning, frame-size arguments and the
build directory holding the C bench programs."""

import json
import os
import shutil
import subprocess
import sys

import cv2

from .. import plugin
from ..commands.common import add_json_option


class BenchError(Exception):
    """The benchmark cannot run (no build, bench program failed, ...)."""


def run_command(argv):
    """``gst-landmark ARGV...`` in a process of its own, as a user runs it
    (the dispatcher loads the developer tools: importing it from one would
    be a cycle); returns the finished process, output captured."""
    return subprocess.run(
        [sys.executable, "-m", "gstlandmark.commands.cli", *argv],
        capture_output=True, text=True)


class OneCore:
    """Run the enclosed Python code on one core with one OpenCV thread."""

    def __init__(self, cpu):
        self.cpu = cpu

    def __enter__(self):
        self.threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        self.affinity = None
        if self.cpu is not None and hasattr(os, "sched_setaffinity"):
            self.affinity = os.sched_getaffinity(0)
            os.sched_setaffinity(0, {self.cpu})
        return self

    def __exit__(self, *exc):
        cv2.setNumThreads(self.threads)
        if self.affinity is not None:
            os.sched_setaffinity(0, self.affinity)
        return False


def pin_prefix(cpu):
    """Command prefix pinning to one core, if taskset exists."""
    taskset = shutil.which("taskset")
    if taskset is None or cpu is None:
        return []
    return [taskset, "-c", str(cpu)]


def find_build_dir(program, build_dir=None):
    """The meson build directory holding ``program`` (a path inside it):
    ``build_dir`` when given, else the set-up's or meson's build directory,
    ``build`` in the current directory or the source tree's."""
    candidates = [build_dir] if build_dir else (
        plugin.build_dir_candidates() + ["build"])
    for cand in candidates:
        if os.path.isfile(os.path.join(cand, program)):
            return os.path.abspath(cand)
    raise BenchError(
        f"{os.path.join(build_dir or 'build', program)} not found: build "
        f"the project first (meson setup build && ninja -C build; the "
        f"benchmarks need gstreamer-check-1.0, package "
        f"libgstreamer1.0-dev)")


def bench_environment(build_dir):
    """Environment for a C bench program: our build's plugin first, a
    private registry so no installed copy is used."""
    env = dict(os.environ)
    plugins = os.path.join(build_dir, "plugins")
    for var in ("GST_PLUGIN_PATH_1_0", "GST_PLUGIN_PATH"):
        old = env.get(var)
        env[var] = plugins + (os.pathsep + old if old else "")
    env["GST_REGISTRY_1_0"] = os.path.join(build_dir, "tests", "bench",
                                           "registry.dat")
    return env


def add_build_dir_option(parser,
                         default="the source tree's build/, or ./build"):
    """--build-dir, the meson build directory a benchmark runs from."""
    parser.add_argument("--build-dir", metavar="DIR",
                        help=f"meson build directory with the plugin "
                             f"(default: {default})")


def add_report_options(parser):
    """--json and -q/--quiet, as every benchmark takes them."""
    add_json_option(parser)
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress lines on stderr")


def write_json(path, report):
    """Writes a tool's report to ``path`` (--json) when one is given."""
    if path:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(report, f, indent=2)
