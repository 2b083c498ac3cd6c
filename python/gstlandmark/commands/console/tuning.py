"""Live tuning: the properties a user tunes from the page, read from and
checked against the elements' own GParamSpecs, and the camera file's
mounting tuned in a copy of the file."""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any, Dict, List, Optional, Sequence, Tuple

import cv2

from ... import pipeline
from ...camerafile import (CalibrationError, is_camera_info_file,
                           read_camera_file, read_mounting, write_camera_info)
from ...gicompat import enum_class
from .livefiles import LiveFiles
from .values import ConsoleError, is_number, json_ready

from gi.repository import GObject  # noqa: E402  (after pipeline's gi setup)

Gst = pipeline.Gst

# The properties a user tunes from the page, per element (the ranges come
# from the elements at run time, never from here).
TUNABLE: Dict[str, Tuple[str, ...]] = {
    "labsegment": ("min-class-pixels", "max-distance", "use-lightness",
                   "rare-classes"),
    "blobroundness": ("min-area", "max-area", "max-aspect", "min-roundness",
                      "min-ellipse-fit", "shape", "morphology",
                      "keep-rejected"),
    "ipmrange": ("camera-height", "tilt", "roll", "hfov", "range-method",
                 "marker-diameter", "pixel-sigma"),
    "trilaterate": ("filter", "gate", "inlier-distance", "max-age"),
    "landmarkoverlay": ("show-detections", "show-rejected", "show-pose",
                        "show-histogram", "show-indicators", "show-minimap",
                        "text-scale"),
}
# The camera file's keys of the mounting properties: what the file holds
# overrides the property (ipmrange's calibration), so the console tunes
# these in a copy of the file.
CAMERA_KEYS = {"camera-height": "camera_height", "tilt": "tilt_deg",
               "roll": "roll_deg"}
# Values an element accepts but no robot has, refused by the console.
CONSOLE_MINIMUM = {
    ("ipmrange", "camera-height"): (
        0.01, "a camera less than 1 cm above the floor measures no range"),
}


def property_spec(element: Gst.Element, name: str) -> Dict[str, Any]:
    """Type, range, default and current value of one property, read from
    the element's GParamSpec."""
    pspec = element.find_property(name)
    if pspec is None:
        raise ConsoleError(f"{element.get_name()} has no property "
                           f"{name!r}")
    vtype = pspec.value_type
    spec: Dict[str, Any] = {"name": name, "blurb": pspec.blurb}
    value = element.get_property(name)
    if vtype == GObject.TYPE_BOOLEAN:
        spec.update(type="boolean", default=bool(pspec.default_value),
                    value=bool(value))
    elif vtype in (GObject.TYPE_UINT, GObject.TYPE_INT, GObject.TYPE_UINT64,
                   GObject.TYPE_INT64, GObject.TYPE_ULONG,
                   GObject.TYPE_LONG):
        spec.update(type="integer", minimum=int(pspec.minimum),
                    maximum=int(pspec.maximum),
                    default=int(pspec.default_value), value=int(value))
    elif vtype in (GObject.TYPE_DOUBLE, GObject.TYPE_FLOAT):
        spec.update(type="number", minimum=float(pspec.minimum),
                    maximum=float(pspec.maximum),
                    default=float(pspec.default_value), value=float(value))
        factory = element.get_factory()
        floor = CONSOLE_MINIMUM.get(
            (factory.get_name() if factory else "", name))
        if floor is not None and floor[0] > spec["minimum"]:
            spec["minimum"], spec["why_minimum"] = floor
    elif vtype.is_a(GObject.TYPE_ENUM):
        enum = enum_class(vtype)
        nicks = [v.value_nick for v in
                 sorted(enum.__enum_values__.values(), key=int)]
        spec.update(type="enum", choices=nicks,
                    default=enum(int(pspec.default_value)).value_nick,
                    value=enum(int(value)).value_nick)
    else:
        spec.update(type="other", value=json_ready(value))
    return spec


def check_value(element_name: str, spec: Dict[str, Any], value):
    """The value to set, or ConsoleError naming element, property and
    fault."""
    where = f"{element_name}.{spec['name']}"
    kind = spec["type"]
    if kind == "boolean":
        if not isinstance(value, bool):
            raise ConsoleError(f"{where}: expected true or false, got "
                               f"{json.dumps(value)}")
        return value
    if kind == "enum":
        if value not in spec["choices"]:
            raise ConsoleError(f"{where}: expected one of "
                               f"{', '.join(spec['choices'])}, got "
                               f"{json.dumps(value)}")
        return value
    if kind in ("integer", "number"):
        if not is_number(value):
            raise ConsoleError(f"{where}: expected a number, got "
                               f"{json.dumps(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise ConsoleError(f"{where}: expected a finite number")
        if kind == "integer":
            if isinstance(value, float):
                if not value.is_integer():
                    raise ConsoleError(f"{where}: expected an integer, got "
                                       f"{value!r}")
                value = int(value)
        else:
            value = float(value)
        if not spec["minimum"] <= value <= spec["maximum"]:
            why = f" ({spec['why_minimum']})" if "why_minimum" in spec \
                and value < spec["minimum"] else ""
            raise ConsoleError(f"{where}: {value!r} is outside "
                               f"{spec['minimum']!r}..{spec['maximum']!r}"
                               f"{why}")
        return value
    raise ConsoleError(f"{where}: cannot be set from the console")


def trial_start(element: Gst.Element, changes: Dict[str, Any]) -> None:
    """Starts a copy of ``element`` with ``changes`` set, alone: a value
    its own checks refuse (those its GParamSpec cannot say, such as
    camera-height 0, or min-area above max-area) is a ConsoleError naming
    element and property, and nothing is set on ``element``."""
    factory = element.get_factory()
    trial = factory.create(None)
    flags = GObject.ParamFlags
    for pspec in element.list_properties():
        if pspec.name in ("name", "parent") or \
                not pspec.flags & flags.READABLE or \
                not pspec.flags & flags.WRITABLE or \
                pspec.flags & flags.CONSTRUCT_ONLY:
            continue
        trial.set_property(pspec.name, element.get_property(pspec.name))
    for prop, value in changes.items():
        trial.set_property(prop, value)
    bus = Gst.Bus.new()
    trial.set_bus(bus)
    try:
        ret = trial.set_state(Gst.State.PAUSED)
        msg = bus.pop_filtered(Gst.MessageType.ERROR)
    finally:
        trial.set_state(Gst.State.NULL)
        trial.set_bus(None)
    if ret != Gst.StateChangeReturn.FAILURE:
        return
    name = element.get_name()
    if msg is None:
        raise ConsoleError(f"{name}: refused {', '.join(changes)}")
    err, debug = msg.parse_error()
    # "Invalid 'camera-height' value." and, last in the debug text, why
    quoted = re.search(r"'([a-z0-9-]+)'", err.message)
    prop = quoted.group(1) if quoted else next(iter(changes))
    why = (debug or "").strip().splitlines()[-1:] or [err.message]
    raise ConsoleError(f"{name}.{prop}: {why[0]}")


def copy_camera_file(source: str, path: str,
                     values: Dict[str, float]) -> None:
    """Writes the camera file ``source`` to ``path`` (the same format)
    with its top-level ``values`` (file keys) replaced."""
    if is_camera_info_file(source):
        try:
            camera = read_camera_file(source)
            mounting = read_mounting(source)
            mounting.update({key: float(v) for key, v in values.items()})
            write_camera_info(path, camera,
                              camera.get("camera_name") or "camera",
                              mounting)
        except CalibrationError as err:
            raise ConsoleError(str(err)) from None
        return
    fs = cv2.FileStorage(source, cv2.FILE_STORAGE_READ)
    out = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    try:
        for key in fs.root().keys():
            node = fs.getNode(key)
            if key in values:
                out.write(key, float(values[key]))
            elif node.isString():
                out.write(key, node.string())
            elif node.isInt():
                out.write(key, int(node.real()))
            elif node.isReal():
                out.write(key, node.real())
            elif node.isMap() and node.mat() is not None:
                out.write(key, node.mat())
            else:
                raise ConsoleError(f"{source}: cannot copy its {key!r} "
                                   f"to tune the camera")
    finally:
        fs.release()
        out.release()


def read_camera_mounting(path: Optional[str]) -> Dict[str, float]:
    """The mounting properties a camera file holds ({} without one)."""
    if not path:
        return {}
    if is_camera_info_file(path):
        try:
            mounting = read_mounting(path)
        except CalibrationError:
            return {}
        return {prop: mounting[key] for prop, key in CAMERA_KEYS.items()
                if key in mounting}
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    try:
        if not fs.isOpened():
            return {}
        return {prop: fs.getNode(key).real()
                for prop, key in CAMERA_KEYS.items()
                if not fs.getNode(key).empty()}
    finally:
        fs.release()


class Tuning:
    """The tunable properties of the chain's elements: their specs for
    the page, and changes checked (the GParamSpec's range, then each
    element's own checks on a trial copy) and set all or nothing. The
    camera file's mounting wins over ipmrange's properties, so it is
    tuned in a copy of the file that ipmrange is pointed at. Apart from
    the engine because it never builds or drives a pipeline: it is given
    the elements of the one running."""

    def __init__(self, camera_path: Optional[str], live_files: LiveFiles):
        self.camera_path = camera_path
        # the file's mounting, as tuned (written to a copy of the file)
        self.camera_mounting = read_camera_mounting(camera_path)
        self.camera_live: Optional[str] = None
        self._live_files = live_files

    def camera_file(self) -> Optional[str]:
        """The camera file for ipmrange: the tuned copy, else the one
        given."""
        return self.camera_live or self.camera_path

    def tunables(self, elements: Dict[str, Gst.Element]
                 ) -> Dict[str, List[Dict[str, Any]]]:
        out = {}
        for name, element in elements.items():
            out[name] = [self.spec(name, element, p) for p in TUNABLE[name]
                         if element.find_property(p) is not None]
        return out

    def current_properties(self, elements: Dict[str, Gst.Element]
                           ) -> Dict[str, Dict[str, Any]]:
        return {name: {s["name"]: s["value"] for s in specs}
                for name, specs in self.tunables(elements).items()}

    def spec(self, name: str, element: Gst.Element,
             prop: str) -> Dict[str, Any]:
        """property_spec, with what the camera file holds: its value
        wins over the property's."""
        spec = property_spec(element, prop)
        if name == "ipmrange" and prop in self.camera_mounting:
            spec["value"] = self.camera_mounting[prop]
            spec["from"] = "camera file"
        return spec

    def _camera_copy(self, mounting: Dict[str, float]) -> str:
        """A copy of the camera file with ``mounting`` (properties), for
        ipmrange's calibration (a new name each time: the element reads
        the file when the property is set)."""
        suffix = os.path.splitext(self.camera_path)[1] or ".yml"
        path = self._live_files.new_path("camera", suffix)
        copy_camera_file(self.camera_path, path,
                         {CAMERA_KEYS[p]: v for p, v in mounting.items()})
        self._live_files.keep("camera", path)
        return path

    def set_checked(self, elements: Dict[str, Gst.Element],
                    changes: Sequence[Tuple[str, str, Any]]
                    ) -> List[Dict[str, Any]]:
        """Sets ``changes`` (element, property, value) on ``elements``,
        all or none; the new specs of the properties changed."""
        checked = []
        for element_name, prop, value in changes:
            if element_name not in TUNABLE:
                raise ConsoleError(f"unknown element {element_name!r} "
                                   f"(tunable: {', '.join(TUNABLE)})")
            if element_name not in elements:
                raise ConsoleError(f"{element_name} is not in this chain "
                                   f"(trilaterate needs --map)")
            if prop not in TUNABLE[element_name]:
                raise ConsoleError(
                    f"{element_name} has no tunable property {prop!r} "
                    f"(tunable: {', '.join(TUNABLE[element_name])})")
            element = elements[element_name]
            spec = self.spec(element_name, element, prop)
            checked.append((element_name, spec,
                            check_value(element_name, spec, value)))
        # the mounting the camera file holds goes into a copy of it
        mounting = dict(self.camera_mounting)
        per_element: Dict[str, Dict[str, Any]] = {}
        for element_name, spec, value in checked:
            if element_name == "ipmrange" and spec["name"] in mounting:
                mounting[spec["name"]] = value
            per_element.setdefault(element_name, {})[spec["name"]] = value
        camera = None
        if mounting != self.camera_mounting:
            camera = self._camera_copy(mounting)
            per_element["ipmrange"]["calibration"] = camera
        # every element tries its changes first (its own checks): all or
        # nothing
        for element_name, element_changes in per_element.items():
            trial_start(elements[element_name], element_changes)
        for element_name, element_changes in per_element.items():
            for prop, value in element_changes.items():
                elements[element_name].set_property(prop, value)
        if camera is not None:
            self.camera_mounting, self.camera_live = mounting, camera
        return [self.spec(element_name, elements[element_name],
                          spec["name"])
                for element_name, spec, _ in checked]
