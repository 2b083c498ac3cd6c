"""`meson install` puts the plugin where GStreamer finds it by itself."""

import os
import subprocess
import sys

import pytest

BUILD = os.environ.get("LANDMARK_BUILD_ROOT")


@pytest.mark.skipif(not BUILD, reason="needs the meson build tree")
def test_meson_install_into_gstreamer_plugin_dir(tmp_path):
    pluginsdir = subprocess.run(
        ["pkg-config", "--variable=pluginsdir", "gstreamer-1.0"],
        check=True, capture_output=True, text=True).stdout.strip()
    subprocess.run(["meson", "install", "-C", BUILD, "--no-rebuild",
                    "--quiet", "--destdir", str(tmp_path)], check=True)
    staged = tmp_path / pluginsdir.lstrip("/") / "libgstlandmark.so"
    assert staged.is_file(), f"not installed into {pluginsdir}"
    # GStreamer, told only about that directory as its system path, finds
    # the element there
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("GST_PLUGIN_PATH")}
    env["GST_PLUGIN_SYSTEM_PATH_1_0"] = str(staged.parent)
    env["GST_REGISTRY_1_0"] = str(tmp_path / "registry.bin")
    code = ("import gi; gi.require_version('Gst', '1.0');"
            "from gi.repository import Gst; Gst.init(None);"
            "f = Gst.ElementFactory.find('labsegment');"
            "print(f.get_plugin().get_filename() if f else '')")
    found = subprocess.run([sys.executable, "-c", code], env=env,
                           check=True, capture_output=True,
                           text=True).stdout.strip()
    assert found == str(staged)
