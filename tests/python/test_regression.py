"""File-based regression: each shipped clip through its shipped pipeline
gives the golden landmarklog output (docs/regression.md)."""

import os

import pytest

from gstlandmark.devtools import goldens, regress


@pytest.mark.parametrize("golden", goldens.GOLDENS, ids=lambda g: g.name)
def test_pipeline_output_equals_golden(gst, golden, tmp_path):
    _, clip, expected = golden.paths()
    assert os.path.isfile(clip), f"shipped clip missing: {clip}"
    out = tmp_path / "result.jsonl"
    goldens.produce(golden, str(out))
    diffs = regress.compare_files(str(out), expected, regress.Tolerances())
    assert not diffs, "\n".join(str(d) for d in diffs[:20])


def test_a_changed_chain_is_caught(gst, tmp_path):
    """The comparison sees a change of behaviour: the same clip with the
    dominant-colour rule off differs from the golden."""
    golden = goldens.GOLDENS[0]
    pipeline_file, _, expected = golden.paths()
    changed = tmp_path / "changed.pipeline"
    changed.write_text(goldens.launch_line(pipeline_file).replace(
        "labsegment", "labsegment min-class-pixels=0") + "\n")
    out = tmp_path / "result.jsonl"
    goldens.run_pipeline_file(str(changed),
                              goldens.variables(golden, str(out)))
    diffs = regress.compare_files(str(out), expected, regress.Tolerances())
    assert any("min-class-pixels" in d.path for d in diffs)
