"""gstlandmark.devtools.valgrind: the reader of memcheck's XML report, and a
short run of the whole chain under memcheck (scripts/valgrind.sh runs 150
frames).

The short run takes 10 to 15 s of CPU, nearly all of it GStreamer's and
OpenCV's start-up under valgrind; it is skipped when valgrind is not
installed.
"""

import shutil

import pytest

from gstlandmark.devtools import valgrind


def _record(kind, objs, leaked=64):
    frames = "".join(
        f"<frame><ip>0x1</ip><obj>/usr/lib/{obj}</obj><fn>f{i}</fn></frame>"
        for i, obj in enumerate(objs))
    what = (f"<xwhat><text>lost</text><leakedbytes>{leaked}</leakedbytes>"
            "<leakedblocks>1</leakedblocks></xwhat>"
            if kind.startswith("Leak_") else "<what>bad</what>")
    return (f"<error><unique>0x1</unique><tid>1</tid><kind>{kind}</kind>"
            f"{what}<stack>{frames}</stack></error>")


def _report(tmp_path, *records, suppressed=""):
    path = tmp_path / "memcheck.xml"
    path.write_text(
        '<?xml version="1.0"?><valgrindoutput>'
        "<protocolversion>4</protocolversion>" + "".join(records) +
        f"<suppcounts>{suppressed}</suppcounts></valgrindoutput>")
    return valgrind.summarise(str(path), source_root=str(tmp_path))


def test_summary_counts_ours_apart(tmp_path):
    glib = "libglib-2.0.so.0"
    ours = "gstreamer-1.0/libgstlandmark.so"
    r = _report(tmp_path,
                _record("Leak_PossiblyLost", ["libc.so.6", glib, ours]),
                _record("Leak_DefinitelyLost", ["libc.so.6", glib], 100),
                _record("InvalidRead", ["libopencv_core.so.406"]),
                suppressed="<pair><count>3</count><name>x</name></pair>")
    assert r["total"]["Leak_DefinitelyLost"] == {"records": 1,
                                                 "bytes": 100}
    assert r["ours"] == {"Leak_PossiblyLost": {"records": 1, "bytes": 64}}
    assert r["definite_ours"] == 0 and r["errors_ours"] == 0
    assert r["invalid_accesses"] == 1
    assert r["suppressions_used"] == {"x": 3}
    assert r["ok"]


@pytest.mark.parametrize("kind", ["Leak_DefinitelyLost",
                                  "Leak_IndirectlyLost", "InvalidWrite",
                                  "UninitCondition"])
def test_summary_fails_on_ours(tmp_path, kind):
    r = _report(tmp_path, _record(kind, ["libc.so.6",
                                         "libgstlandmark.so", "libgst"]))
    assert not r["ok"]
    assert r["stacks_ours"][0]["kind"] == kind


@pytest.mark.skipif(shutil.which("valgrind") is None,
                    reason="valgrind is not installed")
def test_chain_under_memcheck(gst):
    report = valgrind.run(frames=20)
    assert report["ok"], report["stacks_ours"] or report["log_problems"]
    assert report["log_lines"] == 20
    for kind in ("Leak_DefinitelyLost", "Leak_IndirectlyLost"):
        assert kind not in report["ours"]
    assert report["invalid_accesses"] == 0
