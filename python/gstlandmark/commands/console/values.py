"""The console's refusal (``ConsoleError``) and the checks and
conversions of request values that its parts share: tuning, teaching,
the frames and scrubbing each take numbers and boxes from a browser, and
refuse them in the same words."""

from __future__ import annotations

import json
import math


class ConsoleError(ValueError):
    """A request that cannot be carried out; the message says why."""


def is_number(value) -> bool:
    """An int or a float, not a bool (JSON true is no number)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def json_ready(value):
    """A structure value as JSON-ready data."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    return str(value)


def check_box(what: str, *xywh) -> None:
    """x, y, w, h must be integers (frame pixels)."""
    for label, v in zip("xywh", xywh):
        if not isinstance(v, int) or isinstance(v, bool):
            raise ConsoleError(f"{what}: {label} must be an integer "
                               f"(frame pixels), got {json.dumps(v)}")
