"""Recorded files people have (webcams and phones: MPEG-4 part 2 / DivX in
AVI or MP4, H.264 in MP4) decode through decodebin into the chain, with
the decoders the set-up installs (gstreamer1.0-libav). The clips are
encoded here from frames of a red disc on grey; the test fails if a
decoder is missing, a frame is lost or the colours do not survive."""
import numpy as np
import pytest

from gstlandmark import pipeline

W, H, FRAMES = 320, 240, 12

ENCODERS = [
    ("mpeg4-avi", "avenc_mpeg4 bitrate=2000000 ! avimux", "avi"),
    ("mpeg4-mp4", "avenc_mpeg4 bitrate=2000000 ! mp4mux", "mp4"),
    ("h264-mp4", "x264enc speed-preset=ultrafast ! mp4mux",
     "mp4"),
]


def _encode(tmp_path, encoder, ext):
    """A clip of a red disc moving on grey, encoded by `encoder`."""
    import cv2
    raw = tmp_path / "frames.rgb"
    with open(raw, "wb") as f:
        for i in range(FRAMES):
            img = np.full((H, W, 3), 128, np.uint8)
            cv2.circle(img, (100 + 5 * i, 120), 30, (200, 30, 30), -1)
            f.write(img.tobytes())
    out = tmp_path / f"clip.{ext}"
    pipeline.run_to_eos(
        f"filesrc location={raw} ! rawvideoparse format=rgb width={W} "
        f"height={H} framerate=30/1 ! videoconvert ! "
        f"video/x-raw,format=I420 ! {encoder} ! filesink location={out}")
    return out


@pytest.mark.parametrize("name, encoder, ext", ENCODERS,
                         ids=[e[0] for e in ENCODERS])
def test_recorded_file_plays(gst, tmp_path, name, encoder, ext):
    from gi.repository import Gst
    pipeline.init()
    element = encoder.split()[0]
    if Gst.ElementFactory.find(element) is None:
        pytest.fail(f"encoder {element} missing: the test command installs "
                    "gstreamer1.0-libav and gstreamer1.0-plugins-ugly")
    clip = _encode(tmp_path, encoder, ext)
    log = tmp_path / "log.jsonl"
    pipeline.run_to_eos(
        f"filesrc location={clip} ! decodebin ! videoconvert ! "
        f"labsegment ! landmarklog location={log} ! fakesink")
    import json
    lines = [json.loads(s) for s in log.read_text().splitlines()]
    assert len(lines) == FRAMES, name
    disc = np.pi * 30 ** 2
    for line in lines:
        labels = line["labels"]
        red = labels["labelled"][labels["classes"].index("red")]
        # the disc's pixels, within compression's edge losses
        assert 0.85 * disc <= red <= 1.15 * disc, (name, line["frame"], red)
