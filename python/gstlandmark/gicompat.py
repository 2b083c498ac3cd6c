"""What moved between the GStreamer and PyGObject versions we support
(Debian 12: gst-python 1.22, PyGObject 3.42; Debian 13: 1.26, 3.50), read
one way on both."""

from __future__ import annotations

import gi

gi.require_version("Gst", "1.0")
from gi import _gi  # noqa: E402
from gi.repository import GObject, Gst  # noqa: E402


def caps_structure(caps: Gst.Caps, index: int = 0) -> Gst.Structure:
    """The structure at ``index`` of caps (or of an event, query or context
    when ``index`` is None), as a plain Gst.Structure on every gst-python:
    1.26 wraps it in a context manager (``with caps.get_structure(0) as
    s``); the copy outlives the wrapper and the caps."""
    got = caps.get_structure() if index is None else caps.get_structure(index)
    if hasattr(got, "__enter__"):
        with got as structure:
            return structure.copy()
    return got


def enum_class(gtype: GObject.GType) -> type:
    """The Python class of an enum or flags GType (its values have
    ``value_nick``, the class ``__enum_values__`` or ``__flags_values__``).
    PyGObject 3.50 gives a param spec's ``default_value`` as a plain int
    and its ``enum_class`` as the C struct, so ``enum_class(pspec.value_type)
    (pspec.default_value)`` is the one spelling for both."""
    if gtype.pytype is not None:
        return gtype.pytype
    add = _gi.flags_add if gtype.is_a(GObject.TYPE_FLAGS) else _gi.enum_add
    return add(gtype)
