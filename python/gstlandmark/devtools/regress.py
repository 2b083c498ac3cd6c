"""``gst-landmark regress RESULT.jsonl GOLDEN.jsonl``: compare two
``landmarklog`` files field by field, with tolerances.

Every frame, key and list element of the golden file must be in the
result and equal to it: strings and booleans exactly, integers exactly
unless a tolerance names them, floating-point numbers within an absolute
plus relative tolerance. Keys present on one side only are differences
(a field that appears or vanishes is a change of behaviour).

Tolerances are per field name: ``--tol range=0.001`` applies to every
key named ``range``, ``--tol detections.range.range=0.001`` to that path
only (list indices left out). ``--ignore pts`` skips a field.
Exit status: 0 equal, 1 different, 2 unusable input.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence

from ..landmarklog import LogError, read_jsonl

DEFAULT_ABS = 1e-9
DEFAULT_REL = 1e-9


class RegressError(Exception):
    """An input file is missing or is not JSON Lines."""


@dataclass
class Difference:
    frame: int
    path: str
    result: Any
    golden: Any
    note: str = ""

    def __str__(self) -> str:
        text = (f"frame {self.frame}: {self.path or '(line)'}: "
                f"{_short(self.result)} vs golden {_short(self.golden)}")
        return text + (f" ({self.note})" if self.note else "")


@dataclass
class Tolerances:
    absolute: Dict[str, float] = field(default_factory=dict)
    ignore: Sequence[str] = ()
    default_abs: float = DEFAULT_ABS
    default_rel: float = DEFAULT_REL

    def lookup(self, path: str) -> Optional[float]:
        """The tolerance for a dotted path: the full path, else its last
        key, else None."""
        if path in self.absolute:
            return self.absolute[path]
        return self.absolute.get(path.rsplit(".", 1)[-1])

    def ignored(self, path: str) -> bool:
        return path in self.ignore or path.rsplit(".", 1)[-1] in self.ignore


def _short(value: Any, limit: int = 60) -> str:
    text = json.dumps(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def compare_values(result: Any, golden: Any, path: str, tol: Tolerances,
                   frame: int, out: List[Difference]) -> None:
    if tol.ignored(path):
        return
    if isinstance(golden, dict) and isinstance(result, dict):
        for key in golden:
            sub = f"{path}.{key}" if path else key
            if key not in result:
                if not tol.ignored(sub):
                    out.append(Difference(frame, sub, None, golden[key],
                                          "missing in result"))
                continue
            compare_values(result[key], golden[key], sub, tol, frame, out)
        for key in result:
            sub = f"{path}.{key}" if path else key
            if key not in golden and not tol.ignored(sub):
                out.append(Difference(frame, sub, result[key], None,
                                      "not in golden"))
        return
    if isinstance(golden, list) and isinstance(result, list):
        if len(golden) != len(result):
            out.append(Difference(frame, path, f"{len(result)} items",
                                  f"{len(golden)} items", "length differs"))
        for i, (r, g) in enumerate(zip(result, golden)):
            compare_values(r, g, f"{path}[{i}]", tol, frame, out)
        return
    numbers = (int, float)
    if (isinstance(golden, numbers) and isinstance(result, numbers)
            and not isinstance(golden, bool)
            and not isinstance(result, bool)):
        bare = _strip_indices(path)
        limit = tol.lookup(bare)
        if isinstance(golden, int) and isinstance(result, int) \
                and limit is None:
            if golden != result:
                out.append(Difference(frame, path, result, golden))
            return
        if limit is None:
            limit = tol.default_abs + tol.default_rel * abs(golden)
        diff = abs(result - golden)
        if not diff <= limit or math.isnan(diff):
            out.append(Difference(frame, path, result, golden,
                                  f"diff {diff:.3g} > tol {limit:.3g}"))
        return
    if result != golden or type(result) is not type(golden):
        out.append(Difference(frame, path, result, golden))


def _strip_indices(path: str) -> str:
    out, depth = [], 0
    for ch in path:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def compare_files(result_path: str, golden_path: str,
                  tol: Tolerances) -> List[Difference]:
    result = read_jsonl(result_path)
    golden = read_jsonl(golden_path)
    diffs: List[Difference] = []
    if len(result) != len(golden):
        diffs.append(Difference(-1, "frames", len(result), len(golden),
                                "frame count differs"))
    for i, (r, g) in enumerate(zip(result, golden)):
        frame = g.get("frame", i) if isinstance(g, dict) else i
        compare_values(r, g, "", tol, frame, diffs)
    return diffs


def parse_tolerances(items: Sequence[str]) -> Dict[str, float]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = -1.0
        if not sep or not name or not number >= 0:
            raise RegressError(f"--tol takes FIELD=NONNEGATIVE_NUMBER, got "
                               f"{item!r}")
        out[name] = number
    return out


def add_regress_parser(subparsers):
    p = subparsers.add_parser(
        "regress", help="compare a landmarklog file with a golden one",
        description=__doc__.split("\n\n")[0].replace("``", ""),
        epilog="Refreshing a golden on purpose: see docs/regression.md.")
    p.add_argument("result", help="landmarklog output (JSON Lines)")
    p.add_argument("golden", help="the golden file to compare with")
    p.add_argument("--tol", action="append", default=[],
                   metavar="FIELD=ABS",
                   help="absolute tolerance for a field name or dotted "
                        "path (repeatable)")
    p.add_argument("--ignore", action="append", default=[], metavar="FIELD",
                   help="skip a field name or dotted path (repeatable)")
    p.add_argument("--max-report", type=int, default=40, metavar="N",
                   help="differences to print (default 40)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        tol = Tolerances(absolute=parse_tolerances(args.tol),
                         ignore=tuple(args.ignore))
        diffs = compare_files(args.result, args.golden, tol)
    except (RegressError, LogError) as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 2
    if not diffs:
        n = len(read_jsonl(args.golden))
        print(f"{args.result}: same as {args.golden} ({n} frames)")
        return 0
    for d in diffs[:args.max_report]:
        print(d)
    more = len(diffs) - args.max_report
    if more > 0:
        print(f"... and {more} more")
    frames = sorted({d.frame for d in diffs if d.frame >= 0})
    print(f"{len(diffs)} differences in {len(frames)} frames "
          f"(first: frame {frames[0] if frames else '-'})")
    return 1
