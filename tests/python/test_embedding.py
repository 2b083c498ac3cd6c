"""The Python embedding API: a pipeline on a file, per-frame results with
their metadata and landmark-* messages."""

import pytest

from gstlandmark import pipeline
from gstlandmark.devtools import bench
from gstlandmark.messages import HistogramMessage


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    path = tmp_path_factory.mktemp("clip") / "clip.avi"
    bench.write_clip(str(path), 160, 120, 15)
    return str(path)


def test_run_file_yields_every_frame_with_metadata(gst, clip):
    results = list(pipeline.run_file(
        clip, "labsegment post-messages=true min-class-pixels=50"))
    assert [r.frame for r in results] == list(range(15))
    assert [r.pts for r in results] == [i * 10**9 // 30 for i in range(15)]
    for r in results:
        assert (r.width, r.height) == (160, 120)
        assert r.labels is not None and r.detections == [] and r.pose is None
        hist = [m for m in r.messages if isinstance(m, HistogramMessage)]
        assert len(hist) == 1, r.messages
        assert hist[0].class_counts == [c.count for c in r.labels.classes]
        assert hist[0].present() == [c.name for c in r.labels.classes
                                     if c.active]


def test_closing_early_stops_the_pipeline(gst, clip, monkeypatch):
    made = []
    parse_launch = pipeline.Gst.parse_launch

    def keep(description):
        made.append(parse_launch(description))
        return made[-1]

    monkeypatch.setattr(pipeline.Gst, "parse_launch", keep)
    gen = pipeline.run_file(clip)
    first = next(gen)
    assert first.frame == 0
    pipe = made[0]
    # the first frame can arrive while PAUSED->PLAYING is still going on
    # (the sink prerolls on it), so wait for that change to finish
    change, state, _ = pipe.get_state(5 * pipeline.Gst.SECOND)
    assert (change, state) == (pipeline.Gst.StateChangeReturn.SUCCESS,
                               pipeline.Gst.State.PLAYING)
    gen.close()
    # stopped (streaming threads joined), and nothing but this test holds it
    assert pipe.get_state(0)[1] == pipeline.Gst.State.NULL
    del gen, first
    assert pipe.__grefcount__ == 1


def test_errors_raise(gst, tmp_path):
    with pytest.raises(pipeline.PipelineError):
        list(pipeline.run_file(str(tmp_path / "missing.avi")))
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(pipeline.PipelineError, match="bad.json"):
        list(pipeline.iterate(
            f"videotestsrc num-buffers=2 ! labsegment palette={bad}"))
