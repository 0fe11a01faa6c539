"""skeleton_player: what arrives on /tf composes to the motion source's pose, at the playback speed."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.pose_buffer import PoseBuffer, SampleStatus
from garment_sim_ros.body.sources import bvh_source, procedural_source

CLIP = Path(__file__).parent / "data" / "cmu_131_01_walk_mjstyle.bvh"
TOLERANCE_M = 1e-3


def play(ros_context, overrides: dict, seconds: float = 0.4, min_messages: int = 10):
    """Run a player with ``overrides`` beside a /tf subscriber feeding a PoseBuffer.
    Returns (player, buffer, received stamps in ns)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile
    from tf2_msgs.msg import TFMessage

    from garment_sim_ros.ros.skeleton_player import SkeletonPlayer

    buffer = PoseBuffer(fixed_frame=overrides.get("fixed_frame", "world"), max_duration_s=10.0)
    stamps: list[int] = []

    def receive(message: TFMessage) -> None:
        for tf in message.transforms:
            stamp = tf.header.stamp.sec + tf.header.stamp.nanosec * 1e-9
            t, r = tf.transform.translation, tf.transform.rotation
            refused = buffer.add_transform(stamp, tf.header.frame_id, tf.child_frame_id, (t.x, t.y, t.z),
                                           (r.x, r.y, r.z, r.w))
            assert refused is None, refused
        stamp = message.transforms[0].header.stamp
        stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)

    listener = rclpy.create_node("tf_listener", context=ros_context)
    listener.create_subscription(TFMessage, "/tf", receive, QoSProfile(depth=100))
    player = SkeletonPlayer(context=ros_context,
                            parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(listener)
    executor.add_node(player)
    try:
        deadline = time.monotonic() + 10.0
        start = None
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
            if stamps and start is None:
                start = time.monotonic()
            if start is not None and time.monotonic() - start > seconds and len(stamps) >= min_messages:
                break
    finally:
        executor.shutdown()
        listener.destroy_node()
        player.destroy_node()
    assert len(stamps) >= min_messages, f"only {len(stamps)} /tf messages arrived"
    return player, buffer, stamps


def assert_poses_agree(player, buffer, stamps, source, prefix=""):
    names = [prefix + n for n in source.skeleton.names]
    for stamp_ns in (stamps[len(stamps) // 2], stamps[-2]):
        received = buffer.sample(stamp_ns * 1e-9, names)
        assert received.status == SampleStatus.OK, received.detail
        expected = source.pose(player.motion_time(stamp_ns))
        error = np.linalg.norm(received.pose.positions - expected.positions, axis=1)
        assert error.max() < TOLERANCE_M, f"joint {source.skeleton.names[int(error.argmax())]} off by {error.max()} m"
        # rotations too: equal up to sign
        dots = np.abs(np.sum(received.pose.rotations * expected.rotations, axis=1))
        assert dots.min() > 1.0 - 1e-9


def test_procedural_walker_on_tf_composes_to_its_pose(ros_context):
    # 3x: past the walker's 1 s start-up ramp within the run, so the poses compared are mid-gait
    overrides = {"gait": "walk", "frame_prefix": "alice/", "rate_hz": 100.0, "speed": 3.0}
    player, buffer, stamps = play(ros_context, overrides, seconds=0.5)
    assert player.motion_time(stamps[-2]) > 1.0
    assert buffer.parent("alice/pelvis") == "world" and buffer.parent("alice/left_knee") == "alice/left_hip"
    assert_poses_agree(player, buffer, stamps, procedural_source("walk"), prefix="alice/")


def test_bvh_clip_on_tf_composes_to_its_pose(ros_context):
    overrides = {"bvh": str(CLIP), "fixed_frame": "map"}
    player, buffer, stamps = play(ros_context, overrides)
    source = bvh_source(str(CLIP))
    assert buffer.parent(source.skeleton.names[0]) == "map"
    assert_poses_agree(player, buffer, stamps, source)


def test_double_speed_advances_the_motion_twice_as_fast(ros_context):
    player, buffer, stamps = play(ros_context, {"speed": 2.0, "gait": "run"})
    source = procedural_source("run")
    first, last = stamps[1], stamps[-1]
    # the pose received at `last` is the motion 2 x (last - first) after the one received at `first`
    expected = source.pose(player.motion_time(first) + 2.0 * (last - first) * 1e-9)
    received = buffer.sample(last * 1e-9, source.skeleton.names).pose
    assert np.abs(received.positions - expected.positions).max() < TOLERANCE_M
    # and it is not the 1x motion: the runner moved measurably further than 1x would
    single = source.pose(player.motion_time(first) + (last - first) * 1e-9)
    assert np.abs(received.positions - single.positions).max() > 0.05


def test_missing_or_bad_input_is_a_clear_error(ros_context, tmp_path):
    from rclpy.parameter import Parameter

    from garment_sim_ros.ros.skeleton_player import SkeletonPlayer

    missing = tmp_path / "nope.bvh"
    with pytest.raises(ValueError, match="nope.bvh"):
        SkeletonPlayer(context=ros_context, parameter_overrides=[Parameter("bvh", value=str(missing))])
    corrupt = tmp_path / "corrupt.bvh"
    corrupt.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    with pytest.raises(ValueError, match="corrupt.bvh:4"):
        SkeletonPlayer(context=ros_context, parameter_overrides=[Parameter("bvh", value=str(corrupt))])
    with pytest.raises(ValueError, match="unknown gait 'crawl'"):
        SkeletonPlayer(context=ros_context, parameter_overrides=[Parameter("gait", value="crawl")])
    with pytest.raises(ValueError, match="speed"):
        SkeletonPlayer(context=ros_context, parameter_overrides=[Parameter("speed", value=50.0)])


def test_run_time_changes_are_checked(ros_context):
    from rclpy.parameter import Parameter

    from garment_sim_ros.ros.skeleton_player import SkeletonPlayer

    player = SkeletonPlayer(context=ros_context)
    try:
        assert player.set_parameters([Parameter("speed", value=3.0)])[0].successful
        assert player.speed == 3.0
        refused = player.set_parameters([Parameter("speed", value=-1.0)])[0]
        assert not refused.successful and player.speed == 3.0
        read_only = player.set_parameters([Parameter("gait", value="run")])[0]
        assert not read_only.successful and "read-only" in read_only.reason
        descriptor = player.describe_parameter("rate_hz")
        assert descriptor.description and descriptor.floating_point_range[0].to_value == 1000.0
    finally:
        player.destroy_node()
