"""Several characters in one process: the node's ``frame_prefixes`` (``runtime.crowd``), /tf routed to each
character in one pass (``TFDecoder``), and ``garment-sim crowd``'s output and independence."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from node_harness import CHARACTER, Probe, SkeletonPublisher, garment_node, ros_time, transform
from rclpy.executors import SingleThreadedExecutor
from rclpy.serialization import serialize_message
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from garment_sim_ros.cli import main
from garment_sim_ros.commands.crowd import Crowd
from garment_sim_ros.params import ParameterError
from garment_sim_ros.runtime.character_loop import Status
from garment_sim_ros.runtime.crowd import character_prefixes
from garment_sim_ros.runtime.tf_input import TFDecoder, seconds_to_stamp

BOB_OFFSET = (0.0, 4.0, 0.0)


def test_one_node_dresses_two_characters_each_in_its_own_namespace_on_its_own_pelvis(graph):
    # a name of its own: no other test's node can publish on its topic or under its status names
    node = garment_node(graph, "crowd_node", frame_prefixes=["alice/", "bob/"], garments=["pants"], rate_hz=30.0,
                        diagnostics_period=0.25)
    graph.add(SkeletonPublisher(graph.context, "alice/", name="alice_player").node)
    graph.add(SkeletonPublisher(graph.context, "bob/", offset=BOB_OFFSET, name="bob_player").node)
    probe = Probe(graph.context, "/crowd_node/markers")
    graph.add(probe.node)
    alice, bob = node.members

    def dressed():
        return all(m.loop.status == Status.RUNNING and m.stats.total_frames >= 5 for m in node.members)

    assert graph.spin_until(dressed, 30.0), [(m.prefix, m.loop.status, m.loop.detail) for m in node.members]

    def latest():
        return {s.name: {kv.key: kv.value for kv in s.values} for s in probe.diagnostics}

    names = [f"garment_sim: /crowd_node: {member.prefix.strip('/')}" for member in node.members]

    def reported():
        return all(latest().get(name, {}).get("status") == Status.RUNNING for name in names)

    assert graph.spin_until(lambda: len(probe.markers) >= 3 and reported(), 10.0), (len(probe.markers), latest())

    for member, prefix in ((alice, "alice/"), (bob, "bob/")):
        assert all(name.startswith(prefix) for name in member.loop.skeleton.names)
        assert member.input_counts["stored"] > 0 and member.input_counts["other_character"] > 0
    # One MarkerArray holds both; each character's garment and volumes under its own namespace, on its pelvis.
    received = probe.last_markers()
    triangles = {m.ns: m for m in received.markers if m.type == Marker.TRIANGLE_LIST}
    assert sorted(triangles) == ["garment/alice/pants", "garment/bob/pants"]
    spheres = {m.ns for m in received.markers if m.type == Marker.SPHERE}
    assert spheres == {"garment/alice/volumes", "garment/bob/volumes"}
    for ns, offset in (("garment/alice/pants", np.zeros(3)), ("garment/bob/pants", np.array(BOB_OFFSET))):
        marker = triangles[ns]
        points = np.array([(p.x, p.y, p.z) for p in marker.points])
        stamp = marker.header.stamp.sec + 1e-9 * marker.header.stamp.nanosec
        pelvis = CHARACTER.pose(stamp).frame("pelvis")[0] + offset
        assert np.linalg.norm(points.mean(axis=0)[:2] - pelvis[:2]) < 0.3, ns
    # A /diagnostics status per character (running, above), each with its own figures.
    for member, name in zip(node.members, names):
        values = latest()[name]
        assert int(values["mass_points"]) == member.loop.mass_points > 0
        assert int(values["input_stored"]) > 0


def test_tf_decoder_routes_each_transform_to_its_character_in_one_pass():
    stamp = ros_time(seconds_to_stamp(3.5))
    message = TFMessage(transforms=[
        transform(stamp, "world", "alice/pelvis", (0, 0, 1), (0, 0, 0, 1)),
        transform(stamp, "world", "/bob/pelvis", (0, 4, 1), (0, 0, 0, 1)),
        transform(stamp, "alice/pelvis", "alice/hip", (0, 0.1, 0), (0, 0, 0, 1)),
        transform(stamp, "world", "camera", (1, 1, 1), (0, 0, 0, 1)),
        transform(stamp, "bob/pelvis", "bob/hip", (0, -0.1, 0), (0, 0, 0, 1)),
    ])
    data = serialize_message(message)
    decoder = TFDecoder(["alice/", "bob/"])
    for _ in range(2):  # parsed, then from the cached layout
        alice, bob = decoder.decode_characters(data)
        assert alice.children == ["alice/pelvis", "alice/hip"] and bob.children == ["bob/pelvis", "bob/hip"]
        assert alice.parents == ["world", "alice/pelvis"] and bob.parents == ["world", "bob/pelvis"]
        assert np.allclose(bob.translations, [(0, 4, 1), (0, -0.1, 0)])
        assert np.allclose(alice.stamps, 3.5) and np.allclose(bob.stamps, 3.5)
        assert (alice.other_character, bob.other_character) == (3, 3)
        # the same rows as a decoder of that character alone
        alone = TFDecoder("bob/").decode(data)
        assert alone.children == bob.children and np.array_equal(alone.rotations, bob.rotations)


def test_overlapping_prefixes_are_refused_and_the_default_is_frame_prefix(graph):
    assert character_prefixes("alice/", [""]) == ["alice/"]
    assert character_prefixes("", ["a/", "b/"]) == ["a/", "b/"]
    for prefixes in (["a/", "a/b/"], ["", "b/"]):
        with pytest.raises(ParameterError, match="would be two characters'"):
            character_prefixes("", prefixes)
    # the node says so and dresses the one character of frame_prefix
    node = garment_node(graph, frame_prefix="carol/", frame_prefixes=["a/", "a/b/"])
    assert [member.prefix for member in node.members] == ["carol/"]


def test_crowd_command_reports_each_count_and_keeps_every_character_on_its_own_body(capsys):
    assert main(["crowd", "--characters", "1", "3", "--frames", "3", "--warmup", "1", "--json"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    rows, summary = lines[:-1], lines[-1]
    assert [row["characters"] for row in rows] == [1, 3]
    one, three = rows
    assert three["mass_points"] == 3 * one["mass_points"] > 0
    for row in rows:
        assert row["tick_ms"] > 0 and row["fps"] == pytest.approx(1e3 / row["tick_ms"], rel=0.01)
        assert row["garment_to_own_root_max_m"] < 0.3  # every garment on its own walker...
        assert row["max_penetration_m"] < 0.01
    assert one["garment_to_other_root_min_m"] is None
    assert three["garment_to_other_root_min_m"] > 1.0  # ...none on another's (they walk 1.5 m apart)
    assert summary["summary"] is True and summary["characters_at_60fps"] in (0, 1, 3)
    assert set(summary["tick_ms_by_characters"]) == {"1", "3"}
    assert isinstance(summary["characters_at_60fps_linear"], int) and summary["ms_per_character"] > 0


def test_a_crowds_quality_meters_run_on_different_ticks_each_at_quality_rate_hz():
    """Three characters dressed on one tick, meters at the node's 10 Hz (every 6th frame at 60 fps): all
    measure their first frame after dressing, then each once in 6 ticks and no two on the same tick (before
    the spread: all three on every 6th tick, none in the 5 others)."""
    group = Crowd(3, ["one_piece"])
    group.dress_all()
    assert [m.loop.quality_rate_hz for m in group.members] == [10.0] * 3
    measured = [group.tick(3)["measured"] for _ in range(25)]
    assert measured[0] == 3 and measured[1:6] == [0] * 5, measured  # the first frame after dressing
    assert max(measured[1:]) == 1, measured
    assert all(sum(measured[k:k + 6]) == 3 for k in range(5, 20)), measured  # each once in any 6 ticks


def test_crowd_split_over_processes_counts_every_character_once(capsys):
    assert main(["crowd", "--characters", "3", "--processes", "2", "--frames", "2", "--warmup", "0", "--json"]) == 0
    row, summary = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert (row["processes"], row["characters_per_process"], row["threads"]) == (2, 2, 1)
    assert row["mass_points"] > 0 and row["mass_points"] % 3 == 0 and row["garment_to_own_root_max_m"] < 0.3
    assert row["garment_to_other_root_min_m"] > 1.0  # the process with two: each on its own walker
    assert summary["processes"] == 2


def test_a_node_process_given_frame_prefixes_on_the_command_line_dresses_both_players(ros_context):
    """The documented command line: ``-p "frame_prefixes:=[alice/, bob/]"`` (a YAML list, typed as the string
    array declared) and two ``skeleton_player`` processes, each character under its own namespace."""
    env, repo = os.environ.copy(), Path(__file__).parents[1]  # ros_context set the test's domain
    command = [sys.executable, "-m", "garment_sim_ros.ros.node", "--ros-args", "-p", "frame_prefixes:=[alice/, bob/]",
               "-p", "rate_hz:=20.0", "-p", "diagnostics_period:=0.5"]
    processes = [subprocess.Popen(command, cwd=repo, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True)]
    for prefix in ("alice/", "bob/"):
        processes.append(subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.skeleton_player", "--ros-args",
                                           "-p", f"frame_prefix:={prefix}", "-r", f"__node:={prefix[:-1]}_player"],
                                          cwd=repo, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
    listener = rclpy.create_node("listener", context=ros_context)
    namespaces: set[str] = set()
    statuses: dict[str, str] = {}
    listener.create_subscription(MarkerArray, "/garment_sim_node/markers",
                                 lambda m: namespaces.update(marker.ns for marker in m.markers), 10)
    listener.create_subscription(DiagnosticArray, "/diagnostics",
                                 lambda m: statuses.update((s.name, s.message) for s in m.status), 10)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(listener)
    expected = {"garment/alice/pants", "garment/bob/pants", "garment/alice/volumes", "garment/bob/volumes"}
    try:
        end = time.monotonic() + 60.0  # three processes import numba and ROS on a shared machine
        while time.monotonic() < end and not (expected <= namespaces and len(statuses) >= 2):
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        listener.destroy_node()
        for process in processes:
            process.send_signal(signal.SIGINT)
        logs = [process.communicate(timeout=20) for process in processes]
    assert expected <= namespaces, (namespaces, logs[0][1][-2000:])
    assert {name.rsplit(": ", 1)[-1] for name in statuses} >= {"alice", "bob"}, statuses
    assert all(process.returncode == 0 for process in processes), [log[1][-1000:] for log in logs]
