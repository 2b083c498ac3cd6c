"""tools/odometrydraws.py (docs/landmarkslam.md, "Over five
odometry draws"): its arguments, and the table row it prints from the
draws' scores (median and range of the pose NEES inside)."""

import pytest

import odometrydraws


def test_arguments():
    args = odometrydraws.parse_args(["clips/v1", "--variant", "1",
                                     "--out", "out/d"])
    assert (args.clip, args.variant, args.draws, args.palette, args.out) \
        == ("clips/v1", 1, 5, None, "out/d")
    args = odometrydraws.parse_args(["c", "--draws", "3", "--palette",
                                     "p.json", "--out", "o"])
    assert (args.variant, args.draws, args.palette) == (None, 3, "p.json")
    assert args.slam == []
    args = odometrydraws.parse_args(["c", "--out", "o", "--slam",
                                     "odometry-slip-adapt=false", "--slam",
                                     "odometry-slip=0.0011"])
    assert args.slam == ["odometry-slip-adapt=false", "odometry-slip=0.0011"]


@pytest.mark.parametrize("argv, message", [
    (["c"], "--out"),
    (["c", "--out", "o", "--draws", "0"], "--draws must be >= 1"),
    (["c", "--out", "o", "--variant", "-2"], "--variant must be >= 0"),
    (["c", "--out", "o", "--draws", "two"], "--draws"),
    (["c", "--out", "o", "--slam", "odometry-slip"], "--slam 'odometry-slip'"),
    (["c", "--out", "o", "--slam", "gate=1 ! fakesink"], "NAME=VALUE"),
])
def test_bad_arguments_name_the_option(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_:
        odometrydraws.parse_args(argv)
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_summary_row():
    """Median and range of each figure; the NEES target on the median
    draw (91.0 %), the accuracy target only on the draw without a
    spurious landmark and with the map within 3 cm (1 of 3)."""
    draws = [{"inside": i, "mean": m, "ate": 0.1, "rms": r,
              "duplicated": 0, "spurious": s}
             for i, m, r, s in ((91.0, 2.0, 0.2, 0), (85.5, 3.0, 0.4, 2),
                                (97.25, 1.0, 3.5, 0))]
    assert odometrydraws.summary_row("v1", draws) == (
        "| v1 | 91.0 % (85.5..97.2) | 2.00 (1.00..3.00) | 0.10 (0.10..0.10)"
        " cm | 0.40 (0.20..3.50) cm | 0, 2 | met | 1 of 3 |")
    draws[0]["inside"] = 89.9
    assert "| not met |" in odometrydraws.summary_row("v1", draws)
    assert odometrydraws.HEADER.count("|") == \
        odometrydraws.summary_row("v1", draws).count("|")
