"""The tf2_msgs built by tools/build_tf2_msgs.sh is the real Jazzy TFMessage on the wire."""

from __future__ import annotations

import rclpy
from geometry_msgs.msg import TransformStamped
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage

# tf2_msgs/msg/TFMessage of ROS 2 Jazzy (rosidl type hash, REP-2016).
JAZZY_TF_MESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def test_type_name_and_hash_advertised_by_a_publisher_are_jazzys(ros_context):
    node = rclpy.create_node("tf2_msgs_hash_probe", context=ros_context)
    try:
        node.create_publisher(TFMessage, "tf_hash_probe", 1)
        (info,) = node.get_publishers_info_by_topic("/tf_hash_probe")
        assert info.topic_type == "tf2_msgs/msg/TFMessage"
        assert str(info.topic_type_hash) == JAZZY_TF_MESSAGE_HASH
    finally:
        node.destroy_node()


def _transform(parent: str, child: str, sec: int, nanosec: int, xyz, xyzw) -> TransformStamped:
    t = TransformStamped()
    t.header.stamp.sec, t.header.stamp.nanosec = sec, nanosec
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = xyzw
    return t


def _as_tuple(t: TransformStamped):
    tr, r = t.transform.translation, t.transform.rotation
    return (t.header.stamp.sec, t.header.stamp.nanosec, t.header.frame_id, t.child_frame_id,
            tr.x, tr.y, tr.z, r.x, r.y, r.z, r.w)


def test_two_transforms_round_trip_through_cdr():
    sent = TFMessage(transforms=[
        _transform("world", "Hips", 12, 500_000_000, (0.1, -0.2, 0.95), (0.0, 0.0, 0.38268343, 0.92387953)),
        _transform("Hips", "LeftUpLeg", 12, 500_000_001, (0.0, 0.09, -0.05), (0.5, -0.5, 0.5, 0.5)),
    ])
    data = serialize_message(sent)
    received = deserialize_message(data, TFMessage)
    assert [_as_tuple(t) for t in received.transforms] == [_as_tuple(t) for t in sent.transforms]
    # 4-byte encapsulation header, then the sequence count.
    assert data[:8] == b"\x00\x01\x00\x00\x02\x00\x00\x00"
