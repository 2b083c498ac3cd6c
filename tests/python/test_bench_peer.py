"""The hand-written OpenCV program ``gst-landmark bench chain`` sets beside
the chain (tests/bench/peer-bench.cpp) does the same work on the same
frames: it finds and ranges the markers the chain ranges.

Not a timed test: the comparison is of what each finds, frame for frame
summed over the bench's rendered frames.
"""

import statistics

import pytest

from gstlandmark import meta, pipeline
from gstlandmark.devtools import chainbench


@pytest.fixture(scope="module")
def scenario(gst, tmp_path_factory):
    return chainbench.Scenario(640, 480, 8, str(tmp_path_factory.mktemp("peer")))


def test_peer_ranges_what_the_chain_ranges(scenario):
    build_dir = chainbench.find_build_dir()
    chain = chainbench.run_chain_bench(build_dir, scenario,
                                       scenario.chain_launch(), "chain", 16,
                                       8, None, copy=False)
    chain_item = next(i for i in chain if i["type"] == "chain")
    peer = chainbench.run_peer_bench(build_dir, scenario, 16, 8, None)
    assert peer["frames"] == chain_item["frames"] == 16
    # the scene shows 2 to 3 markers a frame; a wrong table (channel order,
    # bit shifts) or a wrong floor ray finds far fewer or ranges none
    assert chain_item["ranged"] >= 16 * 2
    assert abs(peer["ranged"] - chain_item["ranged"]) <= 0.2 * chain_item[
        "ranged"]
    assert peer["detections"] >= peer["ranged"] > 0
    # and at the ranges the chain gives them (its frames cycle through the
    # 8 distinct ones twice; the peer takes a ball's centre to the floor,
    # not to the ball's centre plane, so only roughly)
    caps = (f"video/x-raw,format=BGRx,width={scenario.width},"
            f"height={scenario.height},framerate=30/1")
    ranges = [d.range["range"]
              for buf in pipeline.process_frames(scenario.chain_launch(),
                                                 scenario.bgrx, caps)
              for d in meta.detections(buf)
              if d.range.get("kept", True) and "range" in d.range]
    assert ranges
    chain_median = statistics.median(ranges)
    assert abs(peer["median_range_m"] - chain_median) <= 0.2 * chain_median
