"""The landmark map file (docs/conventions.md), read as the elements read
it (plugins/landmark/core/landmarkmap.cpp): ``{"landmarks": [{"id",
"class", "x", "y", "z", "diameter", "kind"}, ...]}`` with ``id``,
``class``, ``x`` and ``y`` required, the others checked when present.

The one Python reader of map files: every command and tool uses it.
"""

import json
import math
from typing import Any, Dict, List

MAX_LANDMARKS = 256           # kMaxMapLandmarks
MAX_COORDINATE = 10000.0      # metres, |x|, |y|, |z| (kMaxMapCoordinate)
MAX_DIAMETER = 100.0          # metres (kMaxMapDiameter)
KINDS = ("disc", "ball")


class MapError(ValueError):
    """A map file that cannot be read; the message names the file and the
    entry."""


def _number(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _landmark(entry: Any, index: int) -> Dict[str, Any]:
    where = f"landmarks[{index}]"
    if not isinstance(entry, dict):
        raise MapError(f"{where}: must be an object")
    lm_id = entry.get("id")
    if not isinstance(lm_id, str) or not lm_id:
        raise MapError(f"{where}: \"id\" must be a non-empty string")
    where = f"{where} (\"{lm_id}\")"
    cls = entry.get("class")
    if not isinstance(cls, str) or not cls:
        raise MapError(f"{where}: \"class\" must be a non-empty string")
    out = {"id": lm_id, "class": cls}
    for axis in ("x", "y", "z"):
        value = entry.get(axis)
        if axis == "z" and "z" not in entry:
            out["z"] = None
            continue
        if not _number(value):
            raise MapError(f"{where}: \"{axis}\" must be a finite number "
                           f"(metres)")
        if abs(value) > MAX_COORDINATE:
            raise MapError(f"{where}: \"{axis}\" must be within "
                           f"-{MAX_COORDINATE:g}..{MAX_COORDINATE:g} "
                           f"(metres), got {value:g}")
        out[axis] = float(value)
    diameter = entry.get("diameter")
    if diameter is not None and not (_number(diameter) and diameter > 0):
        raise MapError(f"{where}: \"diameter\" must be a positive number "
                       f"(metres)")
    if diameter is not None and diameter > MAX_DIAMETER:
        raise MapError(f"{where}: \"diameter\" must be at most "
                       f"{MAX_DIAMETER:g} (metres), got {diameter:g}")
    out["diameter"] = float(diameter) if diameter is not None else None
    kind = entry.get("kind", "disc")
    if kind not in KINDS:
        raise MapError(f"{where}: \"kind\" must be \"disc\" or \"ball\"")
    out["kind"] = kind
    return out


def parse_map(data: Any) -> List[Dict[str, Any]]:
    """The landmarks of decoded map JSON, each a dict with ``id``,
    ``class``, ``x``, ``y``, ``z`` and ``diameter`` (None when absent: the
    elements take z = 0 and the diameter from their properties) and
    ``kind``."""
    marks = data.get("landmarks") if isinstance(data, dict) else None
    if not isinstance(marks, list):
        raise MapError("\"landmarks\" must be an array")
    if not marks:
        raise MapError("\"landmarks\" is empty")
    if len(marks) > MAX_LANDMARKS:
        raise MapError(f"{len(marks)} landmarks; at most {MAX_LANDMARKS} "
                       f"are supported")
    out, seen = [], set()
    for i, entry in enumerate(marks):
        lm = _landmark(entry, i)
        if lm["id"] in seen:
            raise MapError(f"landmarks[{i}] (\"{lm['id']}\"): duplicate id")
        seen.add(lm["id"])
        out.append(lm)
    return out


def read_map(path: str) -> List[Dict[str, Any]]:
    """The landmarks of the map file ``path`` (see ``parse_map``); MapError
    naming the file when it cannot be read or is not a landmark map."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except OSError as err:
        raise MapError(f"{path}: {err.strerror or err}") from None
    except ValueError as err:
        raise MapError(f"{path}: not valid JSON: {err}") from None
    try:
        return parse_map(data)
    except MapError as err:
        raise MapError(f"{path}: {err}") from None
