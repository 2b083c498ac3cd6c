"""Typed views of the ``landmark-*`` element messages our elements post.

Each message mirrors one structure, built with ``from_structure`` so
applications and tests never parse field names by hand.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

import gi

gi.require_version("Gst", "1.0")
from gi.repository import Gst  # noqa: E402


def structure_to_dict(structure: Gst.Structure) -> Dict[str, Any]:
    """Every field of a structure as plain Python values (arrays as
    lists)."""
    out = {}
    for i in range(structure.n_fields()):
        name = structure.nth_field_name(i)
        value = structure.get_value(name)
        if isinstance(value, (Gst.ValueArray, Gst.ValueList)):
            value = [value[j] for j in range(len(value))]
        out[name] = value
    return out


@dataclass
class LandmarkMessage:
    """Any ``landmark-*`` element message: its name, source and fields."""
    name: str
    source: str
    fields: Dict[str, Any] = field(default_factory=dict)

    @property
    def timestamp(self) -> Optional[int]:
        return self.fields.get("timestamp")

    @classmethod
    def from_message(cls, msg: Gst.Message) -> Optional["LandmarkMessage"]:
        s = msg.get_structure()
        if (msg.type != Gst.MessageType.ELEMENT or s is None
                or not s.get_name().startswith("landmark-")):
            return None
        typed = MESSAGE_TYPES.get(s.get_name())
        if typed is not None:
            return typed.from_structure(s, msg.src.get_name())
        return cls(s.get_name(), msg.src.get_name(), structure_to_dict(s))


@dataclass
class HistogramMessage(LandmarkMessage):
    """``landmark-histogram`` from ``labsegment post-messages=true``."""
    class_names: List[str] = field(default_factory=list)
    class_counts: List[int] = field(default_factory=list)
    class_active: List[bool] = field(default_factory=list)
    min_class_pixels: int = 0

    @classmethod
    def from_structure(cls, s: Gst.Structure,
                       source: str = "") -> "HistogramMessage":
        fields = structure_to_dict(s)
        return cls(name=s.get_name(), source=source, fields=fields,
                   class_names=list(fields["class-names"]),
                   class_counts=list(fields["class-counts"]),
                   class_active=[bool(a) for a in fields["class-active"]],
                   min_class_pixels=fields["min-class-pixels"])

    def present(self) -> List[str]:
        """Classes that took part in the frame's labelling."""
        return [n for n, a in zip(self.class_names, self.class_active) if a]


MESSAGE_TYPES = {"landmark-histogram": HistogramMessage}
