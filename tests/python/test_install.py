"""`meson install` puts the plugin where GStreamer finds it by itself, and
the `gst-landmark` command the set-up installs finds the plugin it built."""

import json
import os
import subprocess
import sys

import pytest

from shippedclip import CLIP_DIR, CLIP_FRAMES, SOURCE_ROOT, write_project

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


# The command the set-up installs, tried as a new user would: from a
# folder outside the source tree, GST_PLUGIN_PATH unset, a registry of its
# own (nothing cached from a run that had the variable set).
INSTALLED = os.path.join(os.path.dirname(sys.executable), "gst-landmark")


def user_environment(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("GST_PLUGIN_PATH")
           and k not in ("LANDMARK_BUILD_ROOT", "LANDMARK_BUILD_DIR",
                         "LANDMARK_SOURCE_ROOT", "PYTHONPATH")}
    env["GST_REGISTRY_1_0"] = str(tmp_path / "registry.bin")
    env.update(extra)
    return env


def installed_run(tmp_path, env):
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    write_project(cwd)
    return subprocess.run(
        [INSTALLED, "run", "file", "--input",
         os.path.join(CLIP_DIR, "clip.avi"), "--config", "project.json",
         "--out", "out", "--no-progress"],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=300), cwd


@pytest.mark.skipif(not os.path.isfile(INSTALLED),
                    reason=f"no installed command {INSTALLED}")
@pytest.mark.parametrize("found_by", ["LANDMARK_BUILD_DIR", "source tree"])
def test_installed_run_finds_the_built_plugin(tmp_path, found_by):
    """`gst-landmark run file` (a shipped pipeline, package data) on the
    shipped clip. The plugin comes from LANDMARK_BUILD_DIR, or with no
    variable at all from the source tree's build/ next to the editable
    install (skipped when the build directory is elsewhere)."""
    extra = {}
    if found_by == "LANDMARK_BUILD_DIR":
        if not BUILD:
            pytest.skip("needs the meson build tree")
        extra["LANDMARK_BUILD_DIR"] = BUILD
    elif not os.path.isfile(os.path.join(SOURCE_ROOT, "build", "plugins",
                                         "landmark", "libgstlandmark.so")):
        pytest.skip("the plugin is not built in the source tree's build/")
    done, cwd = installed_run(tmp_path, user_environment(tmp_path, **extra))
    assert done.returncode == 0, done.stderr
    assert 'no element "labsegment"' not in done.stderr
    summary = json.loads((cwd / "out" / "summary.json").read_text())
    assert summary["frames"] == CLIP_FRAMES
    assert summary["frames_with_pose"] >= 40
    log = (cwd / "out" / "log.jsonl").read_text().splitlines()
    assert len(log) == CLIP_FRAMES and any(json.loads(line)["detections"]
                                  for line in log)


def fake_build(root):
    library = root / "plugins" / "landmark" / "libgstlandmark.so"
    library.parent.mkdir(parents=True)
    library.write_bytes(b"")
    return root


def test_the_plugin_search_order(tmp_path, monkeypatch):
    """What pipeline.init puts on GST_PLUGIN_PATH before GStreamer starts:
    nothing when the variable already leads to the plugin, else the first
    build directory that holds it, else nothing (GStreamer's registry)."""
    from gstlandmark import plugin
    named = fake_build(tmp_path / "named")
    tree = fake_build(tmp_path / "tree")
    for var in ("GST_PLUGIN_PATH", "GST_PLUGIN_PATH_1_0") + \
            plugin.BUILD_DIR_VARIABLES:
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(plugin, "build_dir_candidates",
                        lambda: [os.environ[v] for v in
                                 plugin.BUILD_DIR_VARIABLES
                                 if os.environ.get(v)] + [str(tree)])

    assert plugin.use_built_plugin() == str(tree / "plugins")
    assert os.environ["GST_PLUGIN_PATH"] == str(tree / "plugins")

    monkeypatch.setenv("GST_PLUGIN_PATH", "/elsewhere")
    monkeypatch.setenv("LANDMARK_BUILD_DIR", str(named))
    assert plugin.use_built_plugin() == str(named / "plugins")
    assert os.environ["GST_PLUGIN_PATH"] == os.pathsep.join(
        [str(named / "plugins"), "/elsewhere"])

    assert plugin.use_built_plugin() is None    # already on the path
    monkeypatch.setenv("GST_PLUGIN_PATH", "")
    monkeypatch.setenv("GST_PLUGIN_PATH_1_0", str(tree / "plugins"))
    assert plugin.use_built_plugin() is None    # as under meson test
    monkeypatch.delenv("GST_PLUGIN_PATH_1_0")

    monkeypatch.setenv("GST_PLUGIN_PATH", "")
    monkeypatch.setenv("LANDMARK_BUILD_DIR", str(tmp_path / "nothing"))
    (tree / "plugins" / "landmark" / "libgstlandmark.so").unlink()
    assert plugin.use_built_plugin() is None
    assert os.environ["GST_PLUGIN_PATH"] == ""


@pytest.mark.skipif(not os.path.isfile(INSTALLED),
                    reason=f"no installed command {INSTALLED}")
def test_installed_soak_finds_the_built_plugin(tmp_path):
    """`gst-landmark soak` (a developer tool: it reads the shipped clip of
    the source tree) from elsewhere, GST_PLUGIN_PATH unset."""
    if not BUILD:
        pytest.skip("needs the meson build tree")
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    done = subprocess.run(
        [INSTALLED, "soak", "--frames", "200", "--every", "50",
         "--warmup", "50", "--max-growth-kb", "65536"],
        cwd=cwd, env=user_environment(tmp_path, LANDMARK_BUILD_DIR=BUILD),
        capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["sink_frames"] == report["log_lines"] == 200
    assert report["poses"] >= 190


def test_the_shipped_pipelines_are_package_data():
    """Every pipelines/*.pipeline is in the package (what `run` reads
    wherever it is started), with its one launch line."""
    from gstlandmark import pipelinefile
    shipped = sorted(f[:-len(".pipeline")] for f in
                     os.listdir(os.path.join(SOURCE_ROOT, "pipelines"))
                     if f.endswith(".pipeline"))
    assert len(shipped) >= 10
    assert pipelinefile.names() == shipped
    for name in shipped:
        line = pipelinefile.launch_line(os.path.join(
            pipelinefile.pipelines_dir(), name + ".pipeline"))
        assert "!" in line and not line.startswith("#"), name
