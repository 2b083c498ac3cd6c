"""The shipped synthetic clip (tests/files/clips/path-small: 45 frames of
the robot driving past landmarks, with its palette, map, scene and truth)
and what the tests build from it."""

import json
import os

SOURCE_ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
CLIP_DIR = os.path.join(SOURCE_ROOT, "tests", "files", "clips", "path-small")
CLIP_FRAMES = 45


def scene():
    """The clip's scene.json: camera, walls, palette, ..."""
    with open(os.path.join(CLIP_DIR, "scene.json")) as f:
        return json.load(f)


def camera():
    """The scene's camera: height_m, tilt_deg, hfov_deg, ..."""
    return scene()["camera"]


def true_poses():
    """{frame: the robot's true pose} from truth.jsonl."""
    with open(os.path.join(CLIP_DIR, "truth.jsonl")) as f:
        return {t["frame"]: t["robot"] for t in map(json.loads, f)}


def camera_props():
    """ipmrange properties for the scene's camera."""
    cam = camera()
    return (f"camera-height={cam['height_m']} tilt={cam['tilt_deg']} "
            f"hfov={cam['hfov_deg']}")


def write_project(folder):
    """A project config in ``folder`` for the clip: its palette and map
    (absolute), and its camera as `gst-landmark calibrate floor` writes
    it (camera.yml, relative); returns the config's path."""
    from gstlandmark.commands import calibrate
    calibrate.scene_camera_file(os.path.join(CLIP_DIR, "scene.json"),
                                os.path.join(str(folder), "camera.yml"))
    config = os.path.join(str(folder), "project.json")
    with open(config, "w") as f:
        json.dump({"palette": os.path.join(CLIP_DIR, "palette.json"),
                   "map": os.path.join(CLIP_DIR, "map.json"),
                   "camera": "camera.yml"}, f)
    return config
