"""The landmark map file (docs/conventions.md), read as the elements read
it (plugins/landmark/core/support/landmarkmap.cpp): ``{"landmarks": [{"id",
"class", "x", "y", "z", "diameter", "kind"}, ...]}`` with ``id``,
``class``, ``x`` and ``y`` required, the others checked when present.
Coded markers (``kind`` beacon, post or cone; docs/beacons.md) have
``bands`` instead of ``class``, and need ``diameter`` and ``height``.

The one Python reader of map files: every command and tool uses it.
"""

import json
import math
from typing import Any, Dict, List

MAX_LANDMARKS = 256           # kMaxMapLandmarks
MAX_COORDINATE = 10000.0      # metres, |x|, |y|, |z| (kMaxMapCoordinate)
MAX_DIAMETER = 100.0          # metres (kMaxMapDiameter)
MAX_HEIGHT = 100.0            # metres, coded markers (kMaxMapHeight)
MAX_BANDS = 3                 # kMaxMarkerBands
KINDS = ("disc", "ball")
CODED_KINDS = ("beacon", "post", "cone")


class MapError(ValueError):
    """A map file that cannot be read; the message names the file and the
    entry."""


def _number(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _position(entry, where, out):
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


def _size(entry, member, where, maximum, required=False):
    """A positive number of metres up to ``maximum``, or None when absent
    and not ``required``."""
    value = entry.get(member)
    if (value is not None or required) and not (_number(value)
                                                and value > 0):
        raise MapError(f"{where}: \"{member}\" must be a positive number "
                       f"(metres)")
    if value is not None and value > maximum:
        raise MapError(f"{where}: \"{member}\" must be at most "
                       f"{maximum:g} (metres), got {value:g}")
    return float(value) if value is not None else None


def _bands(entry, where, kind, height):
    """(bands, band heights) of a coded marker, top first."""
    from .palette import valid_class_name
    bands = entry.get("bands")
    if not isinstance(bands, list):
        raise MapError(f"{where}: \"bands\" must be an array of class "
                       f"names, top first")
    # a beacon's code is an order, which takes two colours
    fewest = 2 if kind == "beacon" else 1
    if not fewest <= len(bands) <= MAX_BANDS:
        raise MapError(f"{where}: \"bands\" must hold {fewest} to "
                       f"{MAX_BANDS} class names for a {kind}, got "
                       f"{len(bands)}")
    for i, cls in enumerate(bands):
        if not valid_class_name(cls):
            raise MapError(f"{where}: \"bands\"[{i}] must be a class name "
                           f"(1 to 32 of A-Z a-z 0-9 _ . -)")
    heights = entry.get("band-heights")
    if heights is None:
        return list(bands), [height / len(bands)] * len(bands)
    if (not isinstance(heights, list) or len(heights) != len(bands)
            or not all(_number(h) and h > 0 for h in heights)):
        raise MapError(f"{where}: \"band-heights\" must hold one positive "
                       f"number (metres) per band, {len(bands)} here, top "
                       f"first")
    # a millimetre's slack for heights written in centimetres
    if abs(sum(heights) - height) > 1e-3:
        raise MapError(f"{where}: \"band-heights\" must sum to \"height\" "
                       f"({height:g} m), got {sum(heights):g} m")
    return list(bands), [float(h) for h in heights]


def _coded(entry, where, kind, out):
    if "class" in entry:
        raise MapError(f"{where}: a {kind} has no \"class\": its classes "
                       f"are its \"bands\"")
    _position(entry, where, out)
    out["diameter"] = _size(entry, "diameter", where, MAX_DIAMETER, True)
    height = _size(entry, "height", where, MAX_HEIGHT, True)
    bands, heights = _bands(entry, where, kind, height)
    code = "/".join(bands)
    out.update({"class": code, "kind": kind, "height": height,
                "bands": bands, "band_heights": heights, "code": code})
    return out


def _landmark(entry: Any, index: int) -> Dict[str, Any]:
    where = f"landmarks[{index}]"
    if not isinstance(entry, dict):
        raise MapError(f"{where}: must be an object")
    lm_id = entry.get("id")
    if not isinstance(lm_id, str) or not lm_id:
        raise MapError(f"{where}: \"id\" must be a non-empty string")
    where = f"{where} (\"{lm_id}\")"
    kind = entry.get("kind", "disc")
    if kind in CODED_KINDS:
        return _coded(entry, where, kind, {"id": lm_id})
    cls = entry.get("class")
    if not isinstance(cls, str) or not cls:
        raise MapError(f"{where}: \"class\" must be a non-empty string")
    out = {"id": lm_id, "class": cls}
    _position(entry, where, out)
    out["diameter"] = _size(entry, "diameter", where, MAX_DIAMETER)
    if kind not in KINDS:
        raise MapError(f"{where}: \"kind\" must be \"disc\" or \"ball\", "
                       f"or a coded marker's \"beacon\", \"post\" or "
                       f"\"cone\"")
    out["kind"] = kind
    return out


def parse_map(data: Any) -> List[Dict[str, Any]]:
    """The landmarks of decoded map JSON, each a dict with ``id``,
    ``class``, ``x``, ``y``, ``z`` and ``diameter`` (None when absent: the
    elements take z = 0 and the diameter from their properties) and
    ``kind``.  A coded marker's ``class`` is its ``code`` (its ``bands``
    joined by "/", top first); it also has ``height``, ``bands`` and
    ``band_heights`` (metres, top first)."""
    marks = data.get("landmarks") if isinstance(data, dict) else None
    if not isinstance(marks, list):
        raise MapError("\"landmarks\" must be an array")
    if not marks:
        raise MapError("\"landmarks\" is empty")
    if len(marks) > MAX_LANDMARKS:
        raise MapError(f"{len(marks)} landmarks; at most {MAX_LANDMARKS} "
                       f"are supported")
    out, seen, codes = [], set(), {}
    for i, entry in enumerate(marks):
        lm = _landmark(entry, i)
        if lm["id"] in seen:
            raise MapError(f"landmarks[{i}] (\"{lm['id']}\"): duplicate id")
        seen.add(lm["id"])
        # identity comes from the code: two markers with one code are one
        code = lm.get("code")
        if code is not None and code in codes:
            raise MapError(f"landmarks[{i}] (\"{lm['id']}\"): \"bands\" "
                           f"give the code {code} of landmark "
                           f"\"{codes[code]}\" too: each coded marker needs "
                           f"a code of its own")
        if code is not None:
            codes[code] = lm["id"]
        out.append(lm)
    return out


def check_band_classes(landmarks: List[Dict[str, Any]], classes,
                       source: str) -> None:
    """MapError naming ``source``, the landmark and the band when a coded
    marker's band is not one of ``classes`` (the palette's names, where
    the palette is known)."""
    names = list(classes)
    for i, lm in enumerate(landmarks):
        for k, cls in enumerate(lm.get("bands") or ()):
            if cls not in names:
                raise MapError(f"{source}: landmarks[{i}] "
                               f"(\"{lm['id']}\"): \"bands\"[{k}] {cls} is "
                               f"not a class of the palette "
                               f"({', '.join(names)})")


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
