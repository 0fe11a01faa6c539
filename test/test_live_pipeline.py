"""The node in a live pipeline (issue 18): ``garment_sim_node`` and ``skeleton_player`` in processes of
their own, this process subscribing as RViz would, including late.

One run, in order: a normal start logs no WARN; the player is frozen (SIGSTOP) past
``max_skeleton_age``: the node holds and goes on publishing the held garment at ``rate_hz`` under the
time of its pose, never newer than the skeleton's newest data plus ``max_extrapolation``, a late
subscriber gets it at once (transient local) and the diagnostics say "stale"; the player resumes and
the node follows; SIGTERM to the node and SIGINT to the player end both with exit 0 and no traceback.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from garment_sim_ros.runtime.tf_input import TFDecoder, stamp_seconds

START_TIMEOUT_S = 30.0  # two processes import numba kernels and ROS on a shared machine
RATE_HZ = 20.0
MAX_EXTRAPOLATION_S = 0.1
FROZEN_S = 1.5  # longer than max_skeleton_age: a stale hold
TOPIC = "/garment_sim_node/markers"
LOG_LINE = re.compile(r"\[(INFO|WARN|ERROR)\] \[(\d+\.\d+)\]")


def test_held_garment_published_with_its_pose_time_for_late_joiners_and_a_clean_start_and_stop(ros_context):
    env = os.environ.copy()  # ros_context set the test's domain, on this machine only
    repo = Path(__file__).parents[1]
    node = subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.node", "--ros-args", "-p",
                             f"rate_hz:={RATE_HZ}", "-p", "max_skeleton_age:=0.5", "-p", "diagnostics_period:=0.25",
                             "-p", f"max_extrapolation:={MAX_EXTRAPOLATION_S}"],
                            cwd=repo, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    player = subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.skeleton_player", "--ros-args", "-p",
                               "rate_hz:=60.0"], cwd=repo, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    listener = rclpy.create_node("listener", context=ros_context)
    markers: list[tuple[float, bytes]] = []  # (receive time, bytes)
    transforms: list[tuple[float, bytes]] = []
    statuses: list[tuple[float, DiagnosticStatus]] = []
    listener.create_subscription(MarkerArray, TOPIC, lambda data: markers.append((time.monotonic(), data)), 10,
                                 raw=True)
    listener.create_subscription(TFMessage, "/tf", lambda data: transforms.append((time.monotonic(), data)),
                                 QoSProfile(depth=1000), raw=True)
    listener.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.extend(
        (time.monotonic(), s) for s in m.status), 10)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(listener)

    def spin(seconds: float, until=lambda: False) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and not until():
            executor.spin_once(timeout_sec=0.02)

    late: list[bytes] = []
    try:
        spin(START_TIMEOUT_S, lambda: len(markers) >= 5 and len(transforms) >= 10)  # this process hears both
        assert len(markers) >= 5 and len(transforms) >= 10, ("no markers or /tf within the start timeout",
                                                              len(markers), len(transforms))
        spin(1.0)
        player.send_signal(signal.SIGSTOP)
        frozen_at = time.monotonic()
        frozen_wall = time.time()
        spin(FROZEN_S)
        late_node = rclpy.create_node("late_joiner", context=ros_context)  # RViz opened during the hold
        late_node.create_subscription(MarkerArray, TOPIC, late.append,
                                      QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL), raw=True)
        executor.add_node(late_node)
        spin(1.0, lambda: bool(late))
        publishers = listener.get_publishers_info_by_topic(TOPIC)
        player.send_signal(signal.SIGCONT)
        resumed_at = time.monotonic()
        spin(2.0)
    finally:
        player.send_signal(signal.SIGCONT)
        executor.shutdown()
        listener.destroy_node()
        node.send_signal(signal.SIGTERM)
        player.send_signal(signal.SIGINT)
        node_out, node_log = node.communicate(timeout=20)
        player_out, player_log = player.communicate(timeout=20)

    # a clean start and stop
    warnings_before_freeze = [line for line in node_log.splitlines() if (m := LOG_LINE.search(line))
                              and m.group(1) != "INFO" and float(m.group(2)) < frozen_wall]
    assert not warnings_before_freeze, node_log
    for process, log in ((node, node_log + node_out), (player, player_log + player_out)):
        assert process.returncode == 0, log[-3000:]
        assert "Traceback" not in log and "context is invalid" not in log and "ExternalShutdown" not in log, log

    # held: the garment goes on being published at rate_hz under its pose's time, never past the data
    decoder = TFDecoder()
    # everything heard before the resume was sent before the freeze (the player was stopped); on a loaded
    # machine the last of it can reach this process after frozen_at, so counting only what came before
    # frozen_at would under-state the data the node had
    newest_before_freeze = max(float(decoder.decode(data).stamps.max()) for t, data in transforms if t < resumed_at)
    held = [data for t, data in markers if frozen_at + 0.7 < t < resumed_at]
    assert len(held) >= 0.5 * RATE_HZ * (resumed_at - frozen_at - 0.7), (len(held), node_log[-2000:])
    for data in held:
        stamp = stamp_seconds(deserialize_message(data, MarkerArray).markers[0].header.stamp)
        assert stamp <= newest_before_freeze + MAX_EXTRAPOLATION_S + 1e-6, (stamp, newest_before_freeze)
    assert late, "a late transient-local subscriber got nothing during the hold"
    assert [p.qos_profile.durability for p in publishers] == [DurabilityPolicy.TRANSIENT_LOCAL]
    name = "garment_sim: /garment_sim_node"
    assert any(s.level == DiagnosticStatus.WARN and "stale" in s.message and s.name == name
               for t, s in statuses if frozen_at < t < resumed_at)
    # and followed again
    assert any(t > resumed_at + 0.5 for t, _ in markers)
    assert any(s.message.startswith("running") for t, s in statuses if t > resumed_at + 0.5), [
        s.message for t, s in statuses if t > resumed_at]
