import os

import pytest

import gi

gi.require_version("Gst", "1.0")
from gi.repository import Gst  # noqa: E402


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
