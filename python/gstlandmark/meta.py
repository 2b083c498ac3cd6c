"""Read gst-landmark metadata from a ``Gst.Buffer`` (docs/metadata.md).

Plain dataclasses and numpy arrays, so applications and tests never parse
structure fields by hand::

    labels = meta.labels(buf)      # LabelsMeta or None
    labels.plane                   # 2-D uint8 array, 0 = no class
    for det in meta.detections(buf):
        det.class_name, det.bbox, det.params["landmark-blob"]
    meta.pose(buf)                 # Pose or None
    meta.landmark_map(buf)         # list of MapLandmark (landmarkslam) or None
    meta.analytics(buf)            # GStreamer >= 1.24: AnalyticsObject list
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstVideo", "1.0")
from gi.repository import GLib, Gst, GstVideo  # noqa: E402

from .messages import structure_to_dict  # noqa: E402

LABELS_META = "GstLandmarkLabelsMeta"
POSE_META = "GstLandmarkPoseMeta"
DETECTIONS_META = "GstLandmarkDetectionsMeta"
MAP_META = "GstLandmarkMapMeta"
PARAM_NAMES = ("landmark-blob", "landmark-range", "landmark-match")


class _MappedPlane(np.ndarray):
    """A read-only view of a mapped GstBuffer that keeps the mapping alive.

    Slices and views of it hold it through their ``base``; the buffer is
    unmapped when the last of them goes away.
    """

    def __array_finalize__(self, obj):
        self._mapping = getattr(obj, "_mapping", None)


class _Mapping:
    def __init__(self, buffer: Gst.Buffer):
        # A value read from a structure is borrowed: it dies with the
        # structure. A (shallow) copy owns a reference to the same memory,
        # and a pool never recycles memory that is still shared.
        self.buffer = buffer.copy()
        self.info = self.buffer.map(Gst.MapFlags.READ)
        if not self.info.__parent__:
            raise RuntimeError("cannot map the label plane")

    def __del__(self):
        info = getattr(self, "info", None)
        if info is not None and info.__parent__:
            self.buffer.unmap(info)


def _plane_array(buffer: Gst.Buffer, width: int, height: int,
                 stride: int) -> np.ndarray:
    """Label plane as a (height, width) uint8 array without copying."""
    if width == 0 or height == 0:
        return np.zeros((height, width), np.uint8)
    mapping = _Mapping(buffer)
    flat = np.frombuffer(mapping.info.data, np.uint8, count=stride * height)
    arr = flat.view(_MappedPlane)
    arr._mapping = mapping
    plane = arr.reshape(height, stride)[:, :width]
    return plane


def _values(structure: Gst.Structure, name: str) -> list:
    if not structure.has_field(name):
        return []
    value = structure.get_value(name)
    return [value[i] for i in range(len(value))]


@dataclass
class ClassInfo:
    label: int          # value in the plane (index + 1)
    name: str
    marker: bool
    rgb: Tuple[int, int, int]
    count: int          # first-pass histogram (the dominant-colour rule)
    active: bool        # took part in the final labelling
    labelled: int       # pixels with this label in the plane
    role: str = ""      # palette role: marker, floor, background ("" unknown)


@dataclass
class LabelsMeta:
    plane: np.ndarray   # (height, width) uint8, read-only, 0 = no class
    width: int
    height: int
    stride: int
    analysis_width: int
    analysis_height: int
    classes: List[ClassInfo]
    unclassified: int
    min_class_pixels: int
    max_distance: float
    use_lightness: bool

    @property
    def class_names(self) -> List[str]:
        return [c.name for c in self.classes]

    def class_by_name(self, name: str) -> ClassInfo:
        for c in self.classes:
            if c.name == name:
                return c
        raise KeyError(name)


@dataclass
class Detection:
    id: int
    class_name: str
    bbox: Tuple[int, int, int, int]      # x, y, w, h in pixels
    params: Dict[str, Dict[str, Any]] = field(default_factory=dict)

    @property
    def blob(self) -> Dict[str, Any]:
        return self.params.get("landmark-blob", {})

    @property
    def range(self) -> Dict[str, Any]:
        return self.params.get("landmark-range", {})

    @property
    def match(self) -> Dict[str, Any]:
        return self.params.get("landmark-match", {})

    def rejected(self) -> Optional[Tuple[str, Optional[str]]]:
        """(element, reason) of the first stage that rejected it, or None:
        the chain's verdict as landmark_detection_rejected gives it in C
        (docs/detection.md): a blob or range not kept, or a match the map
        disagrees with; a marginal shape whose size and match confirmed
        it stands."""
        confirmed = (self.range.get("shape-confirmed") is True
                     and self.match.get("matched") is True)
        blob_stage = "beacondetect" if "bands" in self.blob else \
            "blobroundness"
        for params, element in ((self.blob, blob_stage),
                                (self.range, "ipmrange")):
            if confirmed and params.get("shape-marginal") is True:
                continue
            if params.get("kept") is False:
                return element, params.get("reject-reason")
        if self.match.get("reason") in ("outside-gate", "outlier",
                                        "duplicate"):
            return "trilaterate", self.match["reason"]
        return None


@dataclass
class Pose:
    fields: Dict[str, Any]

    @property
    def x(self) -> float:
        return self.fields["x"]

    @property
    def y(self) -> float:
        return self.fields["y"]

    @property
    def heading(self) -> float:
        return self.fields["heading"]


def labels(buf: Gst.Buffer) -> Optional[LabelsMeta]:
    """The labels meta of a buffer, or None."""
    meta = buf.get_custom_meta(LABELS_META)
    if meta is None:
        return None
    s = meta.get_structure()
    width = s.get_value("width")
    height = s.get_value("height")
    stride = s.get_value("stride")
    plane = _plane_array(s.get_value("labels"), width, height, stride)
    names = _values(s, "class-names")
    markers = _values(s, "class-markers")
    roles = _values(s, "class-roles")
    rgb = _values(s, "class-rgb")
    counts = _values(s, "class-counts")
    active = _values(s, "class-active")
    labelled = _values(s, "label-counts")
    classes = [
        ClassInfo(label=i + 1, name=names[i], marker=bool(markers[i]),
                  rgb=((rgb[i] >> 16) & 255, (rgb[i] >> 8) & 255,
                       rgb[i] & 255),
                  count=counts[i], active=bool(active[i]),
                  labelled=labelled[i],
                  role=roles[i] if i < len(roles) else "")
        for i in range(len(names))
    ]
    return LabelsMeta(
        plane=plane, width=width, height=height, stride=stride,
        analysis_width=s.get_value("analysis-width"),
        analysis_height=s.get_value("analysis-height"),
        classes=classes, unclassified=s.get_value("unclassified"),
        min_class_pixels=s.get_value("min-class-pixels"),
        max_distance=s.get_value("max-distance"),
        use_lightness=s.get_value("use-lightness"))


def detections(buf: Gst.Buffer) -> List[Detection]:
    """Every detection (region-of-interest meta) of a buffer, by id, with
    its landmark-* parameters: from the region-of-interest meta, else from
    the detections meta (converters and scalers drop the former's)."""
    out = []
    dmeta = buf.get_custom_meta(DETECTIONS_META)
    entries = dmeta.get_structure() if dmeta is not None else None
    # ids are 0, 1, 2, ... per buffer (the contract), so look them up
    # in order; iterate_meta is not usable from Python
    i = 0
    while True:
        roi = GstVideo.buffer_get_video_region_of_interest_meta_id(buf, i)
        if roi is None:
            break
        params = {}
        entry = None
        if entries is not None and entries.has_field(f"detection-{i}"):
            entry = entries.get_value(f"detection-{i}")
        for name in PARAM_NAMES:
            s = roi.get_param(name)
            if s is None and entry is not None and entry.has_field(name):
                s = entry.get_value(name)
            if s is not None:
                params[name] = structure_to_dict(s)
        out.append(Detection(
            id=roi.id, class_name=GLib.quark_to_string(roi.roi_type),
            bbox=(roi.x, roi.y, roi.w, roi.h), params=params))
        i += 1
    return out


def pose(buf: Gst.Buffer) -> Optional[Pose]:
    """The pose meta of a buffer, or None."""
    meta = buf.get_custom_meta(POSE_META)
    if meta is None:
        return None
    return Pose(fields=structure_to_dict(meta.get_structure()))


@dataclass
class MapLandmark:
    """One landmark of landmarkslam's map meta: world position (metres),
    its 2x2 covariance (row-major), whether it is confirmed, and from how
    many distinct poses it was seen."""
    id: str
    class_name: str
    x: float
    y: float
    covariance: List[float]
    confirmed: bool
    views: int


def landmark_map(buf: Gst.Buffer) -> Optional[List[MapLandmark]]:
    """The landmark map meta of a buffer (landmarkslam), or None."""
    meta = buf.get_custom_meta(MAP_META)
    if meta is None:
        return None
    f = structure_to_dict(meta.get_structure())
    return [MapLandmark(id=f["ids"][i], class_name=f["classes"][i],
                        x=f["x"][i], y=f["y"][i],
                        covariance=list(f["covariance"][4 * i:4 * i + 4]),
                        confirmed=bool(f["confirmed"][i]),
                        views=int(f["views"][i]))
            for i in range(len(f["ids"]))]


FLOOR_META = "GstLandmarkFloorMeta"
#: rop-state / boundary-state codes (docs/floorboundary.md)
FLOOR_STATES = ("not-seen", "free", "obstacle", "view-edge")


@dataclass
class FloorMeta:
    """floorboundary's result: the floor boundary per image column and the
    radial obstacle profile (ROP) per bearing bin (docs/floorboundary.md).
    Bin k is centred on bearing k * bin_width (left positive, wrapped)."""
    width: int                  # columns of the analysed label plane
    height: int
    bearing_bins: int
    bin_width: float            # radians
    max_range: float            # metres
    rop_range: np.ndarray       # (bins,) float32, metres; 0 when not seen
    rop_state: np.ndarray       # (bins,) uint8, index into FLOOR_STATES
    rop_marker_range: np.ndarray  # (bins,) float32, -1: no marker
    boundary_row: np.ndarray    # (width,) float32, image row, -1: none
    boundary_x: np.ndarray      # (width,) float32, metres forward
    boundary_y: np.ndarray      # (width,) float32, metres left
    boundary_state: np.ndarray  # (width,) uint8
    nearest_range: Optional[float] = None
    nearest_bearing: Optional[float] = None

    def bin_bearing(self, k: int) -> float:
        """Centre bearing of bin k, radians in (-pi, pi]."""
        b = k * self.bin_width
        return b - 2 * np.pi if b > np.pi else b

    def bin_of(self, bearing: float) -> int:
        """Bin of a bearing (radians, left positive)."""
        return int(np.floor(bearing / self.bin_width + 0.5)) \
            % self.bearing_bins

    def state_name(self, k: int) -> str:
        return FLOOR_STATES[int(self.rop_state[k])]


def _floor_array(s: Gst.Structure, name: str, dtype) -> np.ndarray:
    b = s.get_value(name)
    data = b.extract_dup(0, b.get_size())
    return np.frombuffer(data, dtype).copy()


def floor(buf: Gst.Buffer) -> Optional[FloorMeta]:
    """The floor meta of a buffer (floorboundary), or None."""
    meta = buf.get_custom_meta(FLOOR_META)
    if meta is None:
        return None
    s = meta.get_structure()
    ok_r, nearest = s.get_double("nearest-range")
    ok_b, bearing = s.get_double("nearest-bearing")
    return FloorMeta(
        width=s.get_value("width"), height=s.get_value("height"),
        bearing_bins=s.get_value("bearing-bins"),
        bin_width=s.get_value("bin-width"),
        max_range=s.get_value("max-range"),
        rop_range=_floor_array(s, "rop-range", np.float32),
        rop_state=_floor_array(s, "rop-state", np.uint8),
        rop_marker_range=_floor_array(s, "rop-marker-range", np.float32),
        boundary_row=_floor_array(s, "boundary-row", np.float32),
        boundary_x=_floor_array(s, "boundary-x", np.float32),
        boundary_y=_floor_array(s, "boundary-y", np.float32),
        boundary_state=_floor_array(s, "boundary-state", np.uint8),
        nearest_range=nearest if ok_r else None,
        nearest_bearing=bearing if ok_b else None)


# GStreamer's analytics metadata (GStreamer >= 1.24, docs/metadata.md):
# the GstAnalytics typelib comes with gst-plugins-bad's introspection data
# (Debian 13: gir1.2-gst-plugins-bad-1.0); without it analytics() is None.
try:
    gi.require_version("GstAnalytics", "1.0")
    from gi.repository import GstAnalytics  # noqa: E402
except (ValueError, ImportError):
    GstAnalytics = None


@dataclass
class AnalyticsObject:
    """One object-detection box of the analytics relation meta with what
    is related to it: its classification and, for a detection trilaterate
    matched, its tracking entry (the map landmark, docs/metadata.md)."""
    id: int                     # the box's id in the relation meta
    class_name: str
    box: Tuple[int, int, int, int]  # x, y, w, h before rotation, pixels
    rotation: float             # radians, clockwise about the box centre
    confidence: float           # location confidence
    class_confidence: Optional[float] = None
    tracking_id: Optional[int] = None


def _box(od) -> Tuple[Tuple[int, int, int, int], float, float]:
    if hasattr(od, "get_oriented_location"):   # GStreamer >= 1.26
        ok, x, y, w, h, r, conf = od.get_oriented_location()
    else:
        ok, x, y, w, h, conf = od.get_location()
        r = 0.0
    return (x, y, w, h), r, conf


def analytics(buf: Gst.Buffer) -> Optional[List[AnalyticsObject]]:
    """The object boxes of a buffer's GstAnalyticsRelationMeta, in id
    order; None when the buffer has none or GstAnalytics is not
    available."""
    if GstAnalytics is None:
        return None
    rmeta = GstAnalytics.buffer_get_analytics_relation_meta(buf)
    if rmeta is None:
        return None
    mtds = list(rmeta)
    related = GstAnalytics.RelTypes.RELATE_TO
    out = []
    for od in mtds:
        if not isinstance(od, GstAnalytics.ODMtd):
            continue
        box, r, conf = _box(od)
        obj = AnalyticsObject(
            id=od.id, class_name=GLib.quark_to_string(od.get_obj_type()),
            box=box, rotation=r, confidence=conf)
        for other in mtds:
            if not rmeta.get_relation(od.id, other.id) & related:
                continue
            if isinstance(other, GstAnalytics.ClsMtd):
                obj.class_confidence = other.get_level(0)
            elif isinstance(other, GstAnalytics.TrackingMtd):
                obj.tracking_id = other.get_info()[1]
        out.append(obj)
    return out


def analytics_segmentation(buf: Gst.Buffer) -> Optional[Tuple[np.ndarray,
                                                              List[str]]]:
    """labsegment's segmentation entry (GStreamer >= 1.26): the mask (2-D
    uint8, region id = label) and the name of each region id; None when
    absent."""
    if GstAnalytics is None or not hasattr(GstAnalytics, "SegmentationMtd"):
        return None
    rmeta = GstAnalytics.buffer_get_analytics_relation_meta(buf)
    if rmeta is None:
        return None
    mtds = list(rmeta)
    for seg in mtds:
        if not isinstance(seg, GstAnalytics.SegmentationMtd):
            continue
        mask, _x, _y, _w, _h = seg.get_mask()
        vmeta = GstVideo.buffer_get_video_meta(mask)
        plane = _plane_array(mask, vmeta.width, vmeta.height,
                             vmeta.stride[0]).copy()
        names = [""] * seg.get_region_count()
        for cls in mtds:
            if (isinstance(cls, GstAnalytics.ClsMtd) and rmeta.get_relation(
                    seg.id, cls.id) & GstAnalytics.RelTypes.N_TO_N):
                names = [GLib.quark_to_string(cls.get_quark(i))
                         for i in range(cls.get_length())]
        return plane, names
    return None
