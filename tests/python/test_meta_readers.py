"""gstlandmark.meta reads detections and poses written the way the
contract (docs/metadata.md) says elements write them."""

import gi

gi.require_version("GstVideo", "1.0")
from gi.repository import Gst, GstVideo  # noqa: E402

from gstlandmark import meta  # noqa: E402


def _load_plugin():
    # the custom metas are registered when the plugin loads
    assert Gst.ElementFactory.make("labsegment") is not None


def test_detections_in_id_order_with_params(gst):
    _load_plugin()
    buf = Gst.Buffer.new_allocate(None, 16, None)
    boxes = [("red", 10, 20, 30, 40), ("blue", 1, 2, 3, 4),
             ("red", 100, 50, 8, 9)]
    for i, (cls, x, y, w, h) in enumerate(boxes):
        roi = GstVideo.buffer_add_video_region_of_interest_meta(
            buf, cls, x, y, w, h)
        roi.id = i
        blob = Gst.Structure.new_empty("landmark-blob")
        blob.set_value("area", float(w * h))
        blob.set_value("roundness", 0.5 + i / 10)
        roi.add_param(blob)
        if i == 1:
            rng = Gst.Structure.new_empty("landmark-range")
            rng.set_value("range", 1.25)
            roi.add_param(rng)
    dets = meta.detections(buf)
    assert [d.id for d in dets] == [0, 1, 2]
    assert [(d.class_name,) + d.bbox for d in dets] == boxes
    assert [d.blob["roundness"] for d in dets] == [0.5, 0.6, 0.7]
    assert dets[1].range == {"range": 1.25}
    assert dets[0].range == {} and dets[0].match == {}


def test_absent_metas_read_as_none(gst):
    _load_plugin()
    buf = Gst.Buffer.new_allocate(None, 16, None)
    assert meta.pose(buf) is None
    assert meta.labels(buf) is None
    assert meta.detections(buf) == []


def test_pose_meta_is_registered_by_the_plugin(gst):
    # its fields are written by trilaterate through the C API; here only
    # that any process loading the plugin can attach and find it by name
    _load_plugin()
    buf = Gst.Buffer.new_allocate(None, 16, None)
    assert buf.add_custom_meta("GstLandmarkPoseMeta") is not None
    pose = meta.pose(buf)
    assert pose is not None and pose.fields == {}
