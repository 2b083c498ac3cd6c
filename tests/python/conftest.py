import os
import sys

import pytest

import gi

gi.require_version("Gst", "1.0")
from gi.repository import Gst  # noqa: E402

# the research tools beside the package (tools/: not installed) for the
# tests of their helpers
sys.path.insert(0, os.path.join(os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.join(os.path.dirname(__file__), "..", "..")), "tools"))


@pytest.fixture(scope="session")
def gst():
    """GStreamer with our plugin from the build tree (never an installed
    copy): run through `meson test` or inside `meson devenv`."""
    Gst.init(None)
    factory = Gst.ElementFactory.find("labsegment")
    if factory is None:
        pytest.fail("labsegment not found: run via 'meson test -C build' or "
                    "inside 'meson devenv -C build'")
    build_root = os.environ.get("LANDMARK_BUILD_ROOT")
    plugin = factory.get_plugin()
    if build_root and plugin is not None:
        filename = os.path.realpath(plugin.get_filename())
        if not filename.startswith(os.path.realpath(build_root)):
            pytest.fail(f"labsegment comes from {filename}, not the build "
                        f"tree {build_root}")
    return Gst
