"""Where GStreamer finds the gst-landmark plugin when it is started from
Python (``pipeline.init``), so that the installed ``gst-landmark`` command
uses the plugin the set-up built without GST_PLUGIN_PATH set by hand.

In order: a GST_PLUGIN_PATH (or GST_PLUGIN_PATH_1_0, as ``meson test``
sets it) that already holds the plugin; the build directory named by
LANDMARK_BUILD_DIR (scripts/setup.sh) or LANDMARK_BUILD_ROOT (``meson
test``); the source tree's ``build/`` next to an editable install; else
GStreamer's own registry (a ``meson install``ed plugin). Plain Python, no GStreamer: it runs before ``Gst.init``.
"""

import os
from typing import List, Optional

PLUGIN_FILE = "libgstlandmark.so"
BUILD_DIR_VARIABLES = ("LANDMARK_BUILD_DIR", "LANDMARK_BUILD_ROOT")


def _source_tree_build() -> str:
    # python/gstlandmark/plugin.py -> <source root>/build
    here = os.path.dirname(os.path.abspath(__file__))
    return os.path.normpath(os.path.join(here, os.pardir, os.pardir, "build"))


def holds_plugin(directory: str) -> bool:
    """Whether ``directory`` (searched recursively, as GStreamer does)
    holds the plugin library."""
    for _, _, files in os.walk(directory):
        if PLUGIN_FILE in files:
            return True
    return False


def build_dir_candidates() -> List[str]:
    """Build directories to look in, the named ones first."""
    named = [os.environ[v] for v in BUILD_DIR_VARIABLES if os.environ.get(v)]
    return named + [_source_tree_build()]


def find_build_dir(holding: str = os.path.join("plugins", "landmark",
                                               PLUGIN_FILE)) -> Optional[str]:
    """The first candidate build directory that holds ``holding`` (a path
    inside it), as an absolute path; None when there is none."""
    for cand in build_dir_candidates():
        if os.path.exists(os.path.join(cand, holding)):
            return os.path.abspath(cand)
    return None


def use_built_plugin() -> Optional[str]:
    """Puts the built plugin's directory on GST_PLUGIN_PATH unless that
    variable or GST_PLUGIN_PATH_1_0 already leads to the plugin; returns the directory added
    (None: GST_PLUGIN_PATH or GStreamer's registry provides it)."""
    current = [p for p in os.environ.get("GST_PLUGIN_PATH", "").split(
        os.pathsep) if p]
    versioned = os.environ.get("GST_PLUGIN_PATH_1_0", "").split(os.pathsep)
    if any(holds_plugin(p) for p in current + versioned if p):
        return None
    build = find_build_dir()
    if build is None:
        return None
    plugins = os.path.join(build, "plugins")
    os.environ["GST_PLUGIN_PATH"] = os.pathsep.join([plugins] + current)
    return plugins
