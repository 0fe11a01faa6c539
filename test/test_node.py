"""garment_sim_node in-process: rclpy contexts of their own (``ros_context``), no launch.

A small publisher node plays ``ProceduralCharacter(walk())`` on /tf (one TFMessage per tick, frames
under an optional prefix); the garment node under test runs in the same executor (``node_harness``).
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from node_harness import CHARACTER, Probe, SkeletonPublisher, feed, garment_node, ros_time, running, transform
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from garment_sim_ros.body.pose_buffer import PoseBuffer
from garment_sim_ros.params import DEFAULT_PARAMS, PARAMETERS
from garment_sim_ros.ros.node import GarmentSimNode, params_file_from_args
from garment_sim_ros.runtime.character_loop import CharacterLoop, Status
from garment_sim_ros.runtime.params_file import ParamsFileError, node_parameters, read_node_parameters
from garment_sim_ros.runtime.settings import ALL_PARAMETERS, NODE_PARAMETERS, check_value
from garment_sim_ros.runtime.skeleton_setup import BONE_CHECK_S
from garment_sim_ros.runtime.tf_input import ingest, seconds_to_stamp, stamp_seconds

CONFIG = Path(__file__).resolve().parents[1] / "config" / "garment_sim.yaml"


# ------------------------------------------------------------------------------------ the node
def test_node_dresses_the_walking_character_and_publishes_its_garments(graph, tmp_path):
    recording = tmp_path / "node.rrd"
    node = garment_node(graph, garments=["pants", "short_skirt"], rerun_sink="save", rerun_path=str(recording))
    player = SkeletonPublisher(graph.context)
    graph.add(player.node)
    probe = Probe(graph.context, "/garment_sim_node/markers")
    graph.add(probe.node)
    assert graph.spin_until(running(node, 40), 20.0), node.loop.detail
    assert graph.spin_until(lambda: len(probe.markers) >= 30 and probe.statuses_of(node), 5.0)

    character = node.loop.character
    assert character.garment_names == ["pants", "short_skirt"]
    received = probe.last_markers()  # CDR bytes -> deserialize_message -> MarkerArray
    by_ns = {m.ns: m for m in received.markers if m.type == Marker.TRIANGLE_LIST}
    assert sorted(by_ns) == ["garment/pants", "garment/short_skirt"]
    pelvis = None
    for solver in character.solvers:
        marker = by_ns[f"garment/{solver.model.name}"]
        assert marker.header.frame_id == "world" and marker.action == Marker.ADD
        assert len(marker.points) == 3 * len(solver.model.triangles)
        assert len(marker.colors) == len(marker.points)
        points = np.array([(p.x, p.y, p.z) for p in marker.points])
        assert np.all(np.isfinite(points))
        colors = np.array([(c.r, c.g, c.b, c.a) for c in marker.colors])
        assert np.all((colors >= 0.0) & (colors <= 1.0)) and np.ptp(colors[:, :3]) > 0.05  # shaded, not flat
        # The garment is on the character: around its pelvis at the marker's stamp.
        stamp = marker.header.stamp.sec + 1e-9 * marker.header.stamp.nanosec
        pelvis = CHARACTER.pose(stamp).frame("pelvis")[0]
        assert np.linalg.norm(points.mean(axis=0)[:2] - pelvis[:2]) < 0.3
    spheres = [m for m in received.markers if m.type == Marker.SPHERE]
    assert len(spheres) == len(character.body.volumes) and {m.ns for m in spheres} == {"garment/volumes"}
    assert all(min(m.scale.x, m.scale.y, m.scale.z) > 0.02 for m in spheres)
    # Walking, dressed: no garment point deeper than a few mm in a body volume.
    assert character.max_penetration() < 0.003

    status = probe.statuses_of(node)[-1]
    values = {kv.key: kv.value for kv in status.values}
    for key in ("fps", "substeps", "lag_s", "integration_ms", "correction_ms", "collision_ms", "publish_ms",
                "max_penetration_mm", "skeleton_age_s", "mass_points", "bones_through", "bones_through_frames",
                "legs_off", "structural_stretch_p99", "structural_stretch_max", "shear_stretch_p99",
                "shear_stretch_max", "quality_rate_hz", "quality_frames"):
        assert key in values, key
    # the quality figures come from the frames measured at quality_rate_hz (10 Hz: 1 in 6 at 60 fps); the
    # throttle is in body time, so a node starved below 10 fps (a loaded machine: 4 frames in the window) measures
    # every frame, and only a node running faster than twice the rate must have skipped some
    assert float(values["quality_rate_hz"]) == 10.0
    assert 0 < float(values["quality_frames"]) <= float(values["frames"])
    if float(values["fps"]) > 20.0:
        assert float(values["quality_frames"]) < float(values["frames"])
    assert float(values["structural_stretch_max"]) >= float(values["structural_stretch_p99"]) >= 0.9
    assert float(values["max_penetration_mm"]) < 3.0
    assert float(values["fps"]) > 0.0 and float(values["substeps"]) >= 1.0
    assert int(values["mass_points"]) == sum(s.model.num_points for s in character.solvers)
    assert abs(float(values["skeleton_age_s"])) < 0.5

    # The Rerun hook: the recording holds both garments, the stage timings, quality and the /tf input.
    graph.remove(node)
    listing = subprocess.run([str(Path(sys.executable).with_name("rerun")), "rrd", "print", "-v", str(recording)],
                             capture_output=True, text=True, timeout=60).stdout
    for entity in ("/world/garments/pants", "/world/garments/short_skirt", "/world/body/volumes",
                   "/timings/collision", "/timings/publish", "/quality/pants/bones_through",
                   "/quality/short_skirt/structural_stretch_p99", "/input/backlog", "/input/lag_ms",
                   "/frame/fps", "/frame/lag_ms", "/frame/substeps", "/frame/penetration_mm", "/world/character",
                   "/events"):
        assert f" - {entity} " in listing, entity


def test_the_rerun_recording_holds_the_nodes_events_on_the_timeline(graph, tmp_path):
    """Dressing, a stale hold, the resume and a parameter change are text entries at their times;
    rerun_every_n thins the 3D data, not the scalars."""
    from rerun.chunk import RrdReader

    recording = tmp_path / "events.rrd"
    node = garment_node(graph, rerun_sink="save", rerun_path=str(recording))
    player = SkeletonPublisher(graph.context)
    graph.add(player.node)
    assert graph.spin_until(running(node, 10), 20.0), node.loop.detail
    assert node.set_parameters([Parameter("rerun_every_n", value=4)])[0].successful
    frames = node.stats.total_frames
    assert graph.spin_until(lambda: node.stats.total_frames >= frames + 40, 5.0)
    player.running = False  # the skeleton goes stale: the garments hold
    assert graph.spin_until(lambda: node.loop.status == Status.HOLDING, 5.0)
    graph.spin_for(0.3)
    player.running = True
    assert graph.spin_until(lambda: node.loop.status == Status.RUNNING, 5.0)
    graph.remove(node)

    events, meshes, fps = [], [], []
    for chunk in RrdReader(str(recording)).stream():
        batch = chunk.to_record_batch()
        times = [t.value * 1e-9 for t in batch.column("sim_time")] if "sim_time" in batch.schema.names else None
        if chunk.entity_path == "/events":
            events += zip(times, [t[0] for t in batch.column("TextLog:text").to_pylist()])
        elif chunk.entity_path == "/world/garments/pants" and not chunk.is_static:
            meshes += times
        elif chunk.entity_path == "/frame/fps":
            fps += times
    kinds = [text.split(":")[0] for _, text in sorted(events)]
    assert kinds.count("dressed") == 1 and kinds.count("parameters") == 1
    (change,) = [text for _, text in events if text.startswith("parameters")]
    assert change == "parameters: rerun_every_n=4"
    assert kinds.count("stale") == 1  # the hold: one entry, not one per held frame
    assert kinds.index("dressed") < kinds.index("parameters") < kinds.index("stale") < len(kinds) - 1
    assert kinds[-1] == "status"  # "simulating ... " again after the hold
    # the stamps are the node's clock (now), as timestamps, and the 3D data thinned after the change
    assert abs(max(t for t, _ in events) - time.time()) < 30.0
    change_time = next(t for t, text in events if text.startswith("parameters"))
    after = [t for t in meshes if t > change_time + 0.05]
    assert len(after) < 0.4 * len([t for t in fps if t > change_time + 0.05])


def test_parameter_changes_apply_at_the_next_frame_and_bad_ones_are_refused(graph):
    node = garment_node(graph)
    graph.add(SkeletonPublisher(graph.context).node)
    client_node = graph.add(rclpy.create_node("parameter_client", context=graph.context))
    client = AsyncParameterClient(client_node, "/garment_sim_node")
    assert graph.spin_until(lambda: client.services_are_ready(), 10.0)
    assert graph.spin_until(running(node), 20.0), node.loop.detail

    def set_remotely(*parameters):
        future = client.set_parameters(list(parameters))
        assert graph.spin_until(future.done, 5.0)
        return future.result().results

    (good,) = set_remotely(Parameter("air_damping", value=2.5))
    assert good.successful
    frames = node.stats.total_frames
    assert graph.spin_until(lambda: node.stats.total_frames > frames, 2.0)
    assert all(s.params.air_damping == 2.5 for s in node.loop.character.solvers)

    out_of_range, wrong_type, read_only = set_remotely(
        Parameter("substep", value=5.0), Parameter("friction", value="high"),
        Parameter("frame_prefix", value="bob/"))
    assert not out_of_range.successful
    assert "substep" in out_of_range.reason and "5.0" in out_of_range.reason and "[1e-05, 0.1]" in out_of_range.reason
    assert not wrong_type.successful and "friction" in wrong_type.reason and "'high'" in wrong_type.reason
    assert not read_only.successful and "read-only" in read_only.reason
    assert node.get_parameter("substep").value == 0.005 and node.solver_params.substep == 0.005
    assert node.get_parameter("friction").value == 0.2 and node.get_parameter("frame_prefix").value == ""

    # An integer for a real-valued parameter is taken as that number; a bad garment list is refused.
    (integer, bad_garments) = set_remotely(Parameter("gravity", value=[0, 0, -5]),
                                           Parameter("garments", value=["pants", "kilt"]))
    assert integer.successful and node.get_parameter("gravity").value == pytest.approx([0.0, 0.0, -5.0])
    assert not bad_garments.successful and "kilt" in bad_garments.reason and "one_piece" in bad_garments.reason

    # Other garments: the character is dressed again with them.
    (garments,) = set_remotely(Parameter("garments", value=["long_skirt"]))
    assert garments.successful
    assert graph.spin_until(lambda: node.loop.character is not None
                            and node.loop.character.garment_names == ["long_skirt"], 10.0)
    assert node.loop.character.solvers[0].params.gravity == (0.0, 0.0, -5.0)


def test_node_holds_when_the_skeleton_stops_and_resumes_when_it_restarts(graph):
    node = garment_node(graph, max_skeleton_age=0.2, diagnostics_period=0.2)
    player = SkeletonPublisher(graph.context)
    graph.add(player.node)
    probe = Probe(graph.context, "/garment_sim_node/markers")
    graph.add(probe.node)
    assert graph.spin_until(running(node, 10), 20.0), node.loop.detail

    player.running = False
    assert graph.spin_until(lambda: node.loop.status == Status.HOLDING, 2.0)
    graph.spin_for(0.2)  # let in-flight marker messages arrive
    held_markers, held_frames = len(probe.markers), node.stats.total_frames
    held_positions = [p.copy() for p in node.loop.character.world_positions()]
    graph.spin_for(0.4)
    assert node.loop.status == Status.HOLDING and "stale" in node.loop.detail
    assert node.loop.counts["stale"] > 0
    assert node.stats.total_frames == held_frames  # nothing simulated...
    # ...and the held garment goes on being published at rate_hz, the same message (issue 18: late joiners)
    assert len(probe.markers) > held_markers + 5 and probe.markers[-1] == probe.markers[held_markers]
    assert all(np.array_equal(a, b) for a, b in zip(held_positions, node.loop.character.world_positions()))
    warned = [s for s in probe.statuses_of(node) if s.level == DiagnosticStatus.WARN and "stale" in s.message]
    assert warned

    player.running = True
    assert graph.spin_until(lambda: node.loop.status == Status.RUNNING
                            and node.stats.total_frames > held_frames + 10, 5.0)
    assert graph.spin_until(lambda: len(probe.markers) > held_markers, 2.0)
    assert node.frame_errors == 0
    assert all(np.all(np.isfinite(p)) for p in node.loop.character.world_positions())


def test_two_characters_in_one_process_each_wear_their_own_garments(graph):
    # 20 Hz each: two characters and two players share one executor thread here.
    alice = garment_node(graph, namespace="alice", frame_prefix="alice/", rate_hz=20.0)
    bob = garment_node(graph, namespace="bob", frame_prefix="bob/", garments=["long_skirt"], rate_hz=20.0)
    graph.add(SkeletonPublisher(graph.context, "alice/", name="alice_player").node)
    graph.add(SkeletonPublisher(graph.context, "bob/", offset=(0.0, 4.0, 0.0), name="bob_player").node)
    assert graph.spin_until(lambda: running(alice, 5)() and running(bob, 5)(), 30.0), \
        (alice.loop.detail, bob.loop.detail)

    for node, prefix, side in ((alice, "alice/", 0.0), (bob, "bob/", 4.0)):
        assert all(name.startswith(prefix) for name in node.loop.skeleton.names)
        assert node.input_counts["other_character"] > 0  # the other one's frames were on /tf too
        for positions in node.loop.character.world_positions():
            assert abs(positions[:, 1].mean() - side) < 0.5
    assert alice.loop.character.garment_names == ["pants"]
    assert bob.loop.character.garment_names == ["long_skirt"]
    topics = dict(alice.get_topic_names_and_types())
    assert "/alice/garment_sim_node/markers" in topics and "/bob/garment_sim_node/markers" in topics


def test_unmappable_skeleton_and_bad_input_are_reported_without_a_crash(graph):
    node = garment_node(graph, diagnostics_period=0.2)
    probe = Probe(graph.context, "/garment_sim_node/markers")
    graph.add(probe.node)
    source = graph.add(rclpy.create_node("bad_source", context=graph.context))
    publisher = source.create_publisher(TFMessage, "/tf", 10)

    def publish_chain():
        stamp = source.get_clock().now().to_msg()
        publisher.publish(TFMessage(transforms=[
            transform(stamp, "world", "base", (0, 0, 1), (0, 0, 0, 1)),
            transform(stamp, "base", "arm", (0, 0.2, 0), (0, 0, 0, 1)),
            transform(stamp, "arm", "hand", (float("nan"), 0, 0), (0, 0, 0, 1)),
        ]))

    source.create_timer(0.05, publish_chain)
    assert graph.spin_until(lambda: node.loop.status == Status.UNMAPPABLE, 5.0)
    assert "missing required role" in node.loop.detail and "pelvis" in node.loop.detail
    assert graph.spin_until(lambda: any(s.level == DiagnosticStatus.ERROR for s in probe.statuses_of(node)), 2.0)
    assert graph.spin_until(lambda: int(node.last_diagnostics.get("rejected_non_finite", 0)) > 0, 2.0)
    assert node.frame_errors == 0 and node.loop.character is None and not probe.markers


# ------------------------------------------------------------------------------------ the loop, ROS-free
def _hold_and_resume(catch_up_wall_s: float):
    """A loop dressed and stepped at 60 Hz, then 0.5 s without skeleton data; returns it, the
    frame that resumed, and the time."""
    buffer = PoseBuffer("world", max_age_s=0.2)
    loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["pants"], 1.0, catch_up_wall_s=catch_up_wall_s)
    t = 1.0
    feed(buffer, t)
    assert loop.frame(t) is None and loop.status == Status.WAITING  # the tree is seen once: wait a frame
    dressed = None
    while dressed is None and t < 1.0 + BONE_CHECK_S + 2 / 60:  # the bones are checked over BONE_CHECK_S first
        t += 1 / 60
        feed(buffer, t)
        dressed = loop.frame(t)
    assert dressed.dressed and loop.status == Status.RUNNING and not dressed.reports
    for _ in range(10):
        t += 1 / 60
        feed(buffer, t)
        assert loop.frame(t).reports[0].lag_s == 0.0
    last_data = t
    for _ in range(30):  # the skeleton stops for 0.5 s: the frames past max_age hold
        t += 1 / 60
        loop.frame(t)
    assert loop.status == Status.HOLDING and loop.counts["stale"] > 0 and loop.last_time < last_data + 0.21
    t += 1 / 60
    feed(buffer, t)
    resumed = loop.frame(t)
    assert loop.status == Status.RUNNING and resumed.frame_s > 0.25
    return loop, resumed, t


def test_loop_holds_through_a_gap_then_follows_the_body_across_it_in_full_frames():
    loop, resumed, t = _hold_and_resume(catch_up_wall_s=math.inf)
    buffer = loop.buffer
    # The gap was followed in frames of max_substeps x substep: nothing lags.
    assert resumed.reports[0].lag_s == 0.0 and resumed.reports[0].substeps == DEFAULT_PARAMS.max_substeps
    assert loop.character.max_penetration() < 0.003
    # After an ordinary frame, a frame longer than the solver's budget lags, as the memo's IC_max says.
    t += 1 / 60
    feed(buffer, t)
    assert loop.frame(t).reports[0].substeps < DEFAULT_PARAMS.max_substeps
    t += 0.1
    feed(buffer, t)
    slow = loop.frame(t)
    budget = DEFAULT_PARAMS.max_substeps * DEFAULT_PARAMS.substep
    assert slow.reports[0].lag_s == pytest.approx(0.1 - budget)


def test_loop_without_time_to_catch_up_crosses_the_gap_in_one_frame_and_reports_the_lag():
    loop, resumed, _ = _hold_and_resume(catch_up_wall_s=0.0)
    budget = DEFAULT_PARAMS.max_substeps * DEFAULT_PARAMS.substep
    assert resumed.reports[0].lag_s == pytest.approx(resumed.frame_s - budget)
    assert all(np.all(np.isfinite(p)) for p in loop.character.world_positions())


def test_a_step_gone_bad_in_a_catch_up_piece_is_counted_not_dropped(monkeypatch):
    """A frame that follows a gap in several pieces reports its last piece; a step the guard restored in an
    earlier piece (a loaded machine catches up often) was dropped from the diagnostics' ``solver_restored``."""
    import dataclasses

    from garment_sim_ros.cloth.solver import GarmentSolver
    from garment_sim_ros.runtime.frame_stats import FrameStats

    advance, poisoned = GarmentSolver.advance, []

    def poison_once(solver, frame):
        if not poisoned:
            poisoned.append(frame.t1)
            frame = dataclasses.replace(frame, root_acceleration=np.array([math.nan, 0.0, 0.0]))
        return advance(solver, frame)

    buffer = PoseBuffer("world", max_age_s=0.2)
    loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["pants"], 1.0, catch_up_wall_s=math.inf)
    t = 1.0
    while loop.status != Status.RUNNING or loop.character is None:
        feed(buffer, t)
        loop.frame(t)
        t += 1 / 60
    for _ in range(30):  # a 0.5 s gap: held
        loop.frame(t)
        t += 1 / 60
    assert loop.status == Status.HOLDING
    monkeypatch.setattr(GarmentSolver, "advance", poison_once)
    feed(buffer, t)
    result = loop.frame(t)
    stats = FrameStats()
    stats.record_frame(result.reports, result.frame_s, result.penetration_m, result.measured,
                       result.catch_up_recoveries)
    assert result.frame_s > 0.25 and poisoned and poisoned[0] < t  # the first piece went bad, not the last
    assert not result.reports[0].recovery and result.catch_up_recoveries == ("restored",)
    assert stats.recoveries["restored"] == 1


# ------------------------------------------------------------------------------------ parameters and files
def test_params_file_watch_applies_a_change_and_refuses_a_broken_file(graph, tmp_path):
    path = tmp_path / "tuning.yaml"
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.3\n")
    node = garment_node(graph, watch_params_file=True, params_file=str(path), watch_period=0.05)
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.3, 3.0)

    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.45\n    rate_hz: 30\n")
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.45, 3.0)
    assert node.get_parameter("rate_hz").value == 30.0 and node.frame_timer.timer_period_ns == int(1e9 / 30)

    errors = node.params_watch.errors
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: [0.9\n")  # YAML syntax error
    assert graph.spin_until(lambda: node.params_watch.errors > errors, 3.0)
    assert str(path) in node.params_watch.message and "not valid YAML" in node.params_watch.message
    assert node.get_parameter("friction").value == 0.45

    for text, expected in (
        ("    friction: 0.5\n    frictoin: 0.5\n", "frictoin: unknown parameter"),
        ("    friction: 0.5\n    substep: 2.0\n", "substep: got 2.0; allowed: [1e-05, 0.1] s"),
        ("    friction: 0.5\n    fixed_frame: map\n", "fixed_frame: read-only"),
    ):
        errors = node.params_watch.errors
        path.write_text("garment_sim_node:\n  ros__parameters:\n" + text)
        assert graph.spin_until(lambda: node.params_watch.errors > errors, 3.0)
        assert expected in node.params_watch.message and str(path) in node.params_watch.message
        assert node.get_parameter("friction").value == 0.45  # the whole file was refused


def test_watching_the_start_up_params_file_applies_only_later_edits(graph, tmp_path):
    path = tmp_path / "start.yaml"
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.3\n    watch_params_file: true\n"
                    "    watch_period: 0.05\n")
    arguments = ["--ros-args", "--params-file", str(path), "-p", "friction:=0.5"]
    node = graph.add(GarmentSimNode(context=graph.context, cli_args=arguments,
                                    params_file_hint=params_file_from_args(arguments)))
    assert node.params_watch.path() == str(path)
    graph.spin_for(0.3)
    assert node.get_parameter("friction").value == 0.5  # -p wins over the file it was started with
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.35\n    watch_params_file: true\n")
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.35, 3.0)


def test_the_node_bounds_a_frames_retries_and_the_offline_commands_do_not(graph):
    """``retry_budget``'s node default (0.05 s): a real-time node must not stall on a frame's tries; the offline
    commands (``DEFAULT_PARAMS``, evaluate's figures) keep them unbounded, independent of the machine's speed."""
    node = garment_node(graph)
    assert node.get_parameter("retry_budget").value == 0.05 and node.solver_params.retry_budget == 0.05
    assert DEFAULT_PARAMS.retry_budget == 0.0
    assert [p.name for p in PARAMETERS if p.node_value != p.default] == ["retry_budget"]


def test_config_file_holds_every_parameter_at_its_default_and_loads_at_start(graph):
    data = yaml.safe_load(CONFIG.read_text())
    values = data["garment_sim_node"]["ros__parameters"]
    assert set(values) == {p.name for p in ALL_PARAMETERS}
    for row in ALL_PARAMETERS:
        assert check_value(row.name, values[row.name]) == check_value(row.name, row.node_value), row.name

    node = graph.add(GarmentSimNode(context=graph.context, cli_args=["--ros-args", "--params-file", str(CONFIG),
                                                                      "-p", "substep:=7.0", "-p", "friction:=0.3"]))
    assert node.get_parameter("gravity").value == pytest.approx([0.0, 0.0, -9.81])
    assert node.get_parameter("garments").value == ["pants"]
    assert node.get_parameter("friction").value == 0.3
    assert node.get_parameter("substep").value == 0.005  # out of range at start: the default, logged
    described = node.describe_parameter("substep")
    assert described.floating_point_range[0].from_value == 1e-05 and described.floating_point_range[0].to_value == 0.1
    assert "[s]" in described.description
    assert node.describe_parameter("max_substeps").integer_range[0].to_value == 200
    assert node.describe_parameter("frame_prefix").read_only
    assert node.describe_parameter("garments").type == ParameterType.PARAMETER_STRING_ARRAY


def test_params_file_sections_match_nodes_like_ros_does():
    data = {
        "/**": {"ros__parameters": {"friction": 0.1, "rate_hz": 30.0}},
        "garment_sim_node": {"ros__parameters": {"friction": 0.2}},
        "alice": {"garment_sim_node": {"ros__parameters": {"friction": 0.3, "wind": [1.0, 0.0, 0.0]}}},
        "/*/other_node": {"ros__parameters": {"friction": 0.4}},
    }
    assert node_parameters(data, "/garment_sim_node", "f") == {"friction": 0.2, "rate_hz": 30.0}
    assert node_parameters(data, "/alice/garment_sim_node", "f") == {"friction": 0.3, "rate_hz": 30.0,
                                                                      "wind": [1.0, 0.0, 0.0]}
    assert node_parameters(data, "/bob/other_node", "f") == {"friction": 0.4, "rate_hz": 30.0}
    with pytest.raises(ParamsFileError, match="f: /garment_sim_node/friction: expected a node name"):
        node_parameters({"garment_sim_node": {"friction": 0.2}}, "/garment_sim_node", "f")
    assert params_file_from_args(["x", "--ros-args", "--params-file", "a.yaml", "--params-file", "b.yaml"]) == "b.yaml"


@pytest.mark.parametrize("node_key", ["garment_sim_node", "/**/garment_sim_node", "/*/garment_sim_node",
                                      "alice:\n  garment_sim_node"])
def test_the_watched_file_reaches_the_same_nodes_as_params_file_at_start(ros_context, tmp_path, node_key):
    path = tmp_path / "p.yaml"
    indent = "  " * (node_key.count("\n") + 1)
    path.write_text(f"{node_key}:\n{indent}ros__parameters:\n{indent}  friction: 0.7\n")
    for namespace in ("/", "/alice"):
        node = GarmentSimNode(context=ros_context, namespace=namespace,
                              cli_args=["--ros-args", "--params-file", str(path)])
        try:
            from_rcl = node.get_parameter("friction").value
            from_watch = read_node_parameters(path, node.get_fully_qualified_name()).get("friction", 0.2)
            assert from_watch == from_rcl, (node_key, namespace)
        finally:
            node.destroy_node()


def test_every_table_row_checks_its_type_and_range():
    assert check_value("publish_volumes", False) is False
    assert check_value("rate_hz", 30) == 30.0 and isinstance(check_value("rate_hz", 30), float)
    for name, bad, allowed in (("publish_volumes", 1, "true or false"), ("rate_hz", 0.5, "[1.0, 1000.0] Hz"),
                               ("garments", [], "a non-empty list"), ("garments", ["pants", "pants"], "distinct"),
                               ("rerun_sink", "disk", "off, save, connect, serve"), ("frame_prefix", 3, "a string")):
        with pytest.raises(ValueError, match=name) as err:
            check_value(name, bad)
        assert allowed in str(err.value)
    assert {p.name for p in NODE_PARAMETERS}.isdisjoint({p.name for p in PARAMETERS})
    assert all(p.description for p in ALL_PARAMETERS)


# ------------------------------------------------------------------------------------ /tf input
def test_tf_input_takes_only_the_prefixed_character_and_counts_refusals():
    buffer = PoseBuffer("world")
    stamp = seconds_to_stamp(12.25)
    message = TFMessage(transforms=[
        transform(ros_time(stamp), "world", "/alice/pelvis", (0, 0, 1), (0, 0, 0, 1)),
        transform(ros_time(stamp), "world", "bob/pelvis", (0, 1, 1), (0, 0, 0, 1)),
        transform(ros_time(stamp), "alice/pelvis", "alice/left_hip", (0, math.nan, 0), (0, 0, 0, 1)),
        transform(ros_time(stamp), "alice/pelvis", "alice/right_hip", (0, -0.1, 0), (0, 0, 0, 0)),
    ])
    result = ingest(buffer, message, prefix="alice/")
    assert (result.stored, result.other_character, result.refused) == (1, 1, 2)
    assert "non-finite" in result.first_refusal
    assert buffer.frames == ("alice/pelvis", "world")  # leading '/' dropped, as tf2 does
    assert buffer.rejected == {"non_finite": 1, "zero_quaternion": 1}
    assert buffer.sample(12.25, ["alice/pelvis"]).pose.positions[0] == pytest.approx([0, 0, 1])


def test_stamps_convert_both_ways():
    assert seconds_to_stamp(1.9999999999) == (2, 0)
    assert seconds_to_stamp(3.5) == (3, 500_000_000)
    assert stamp_seconds(ros_time((7, 250_000_000))) == 7.25


def test_body_file_overrides_the_fitted_volumes_and_a_bad_one_is_reported(tmp_path):
    good = tmp_path / "body.yaml"
    good.write_text("volumes:\n  left_upper_leg:\n    radii: [0.1, 0.1, 0.3]\n")
    bad = tmp_path / "bad_body.yaml"
    bad.write_text("volumes:\n  left_upper_leg:\n    radii: [-0.1, 0.1, 0.3]\n")
    for path, dressed in ((good, True), (bad, False)):
        buffer = PoseBuffer("world")
        loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["pants"], 1.0, body_file=str(path))
        for k in range(2 + round(BONE_CHECK_S * 60)):  # the bones are checked over BONE_CHECK_S first
            t = 1.0 + k / 60
            feed(buffer, t)
            loop.frame(t)
        if dressed:
            assert loop.status == Status.RUNNING
            volumes = loop.character.body.volumes
            assert tuple(volumes.volumes[volumes.names().index("left_upper_leg")].radii) == (0.1, 0.1, 0.3)
        else:
            assert loop.status == Status.UNMAPPABLE and loop.character is None
            assert "bad_body.yaml" in loop.detail and "left_upper_leg" in loop.detail


# ------------------------------------------------------------------------------------ saying what is wrong
def test_misconfiguration_is_said_naming_what_to_use(graph, tmp_path, capfd):
    """Issue 18: a params file keyed for another name, two skeletons that frame_prefix does not tell apart,
    an undeclared parameter and refused sets were silent or said nothing useful."""
    path = tmp_path / "wrong_key.yaml"
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.3\n")  # the node runs as /alice/...
    arguments = ["--ros-args", "--params-file", str(path)]
    node = graph.add(GarmentSimNode(context=graph.context, namespace="alice", cli_args=arguments,
                                    params_file_hint=params_file_from_args(arguments)))
    graph.add(SkeletonPublisher(graph.context, "a/", name="a_player").node)
    graph.add(SkeletonPublisher(graph.context, "b/", offset=(0.0, 4.0, 0.0), name="b_player").node)
    probe = Probe(graph.context, "/alice/garment_sim_node/markers")
    graph.add(probe.node)
    client_node = graph.add(rclpy.create_node("parameter_client", context=graph.context))
    client = AsyncParameterClient(client_node, "/alice/garment_sim_node")
    assert graph.spin_until(lambda: client.services_are_ready(), 10.0)
    assert graph.spin_until(running(node, 3), 20.0), node.loop.detail

    def set_remotely(*parameters):
        future = client.set_parameters(list(parameters))
        assert graph.spin_until(future.done, 5.0)
        return future.result().results

    (undeclared,) = set_remotely(Parameter("frictoin", value=0.3))
    assert not undeclared.successful and "frictoin" in undeclared.reason and "friction" in undeclared.reason
    (bad,) = set_remotely(Parameter("substep", value=5.0))
    assert not bad.successful

    # publish_volumes off: the volume markers are deleted, not left in RViz
    assert any(m.type == Marker.SPHERE for m in probe.last_markers().markers)
    seen = len(probe.markers)
    (volumes_off,) = set_remotely(Parameter("publish_volumes", value=False))
    assert volumes_off.successful
    assert graph.spin_until(lambda: len(probe.markers) > seen + 3, 3.0)
    after = [deserialize_message(data, MarkerArray).markers for data in probe.markers[seen:]]
    first = next(k for k, markers in enumerate(after) if not any(m.type == Marker.SPHERE for m in markers))
    assert after[first][0].action == Marker.DELETEALL  # the spheres' first message without them deletes them
    assert not any(m.type == Marker.SPHERE for markers in after[first:] for m in markers)

    log = capfd.readouterr().err
    assert "/alice/garment_sim_node" in log and "'alice/garment_sim_node'" in log and str(path) in log
    assert "'a/pelvis'" in log and "'b/pelvis'" in log and f"dressing {node.loop.skeleton.names[0]!r}" in log
    refusals = [line for line in log.splitlines() if "parameter set refused" in line]
    assert len(refusals) == 2 and "frictoin" in refusals[0] and "substep" in refusals[1]  # each said once


def test_watching_turned_on_at_run_time_survives_a_file_that_says_false(graph, tmp_path):
    """Issue 18: turned on through the parameter service, the watch turned itself off at the first edit of a
    file that still said ``watch_params_file: false``. The watch's switches apply only when an edit changes them."""
    path = tmp_path / "tuning.yaml"
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.3\n    watch_params_file: false\n")
    node = garment_node(graph, watch_period=0.05)
    assert node.set_parameters([Parameter("params_file", value=str(path))])[0].successful
    assert node.set_parameters([Parameter("watch_params_file", value=True)])[0].successful
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.3, 3.0)
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.4\n    watch_params_file: false\n")
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.4, 3.0)
    assert node.get_parameter("watch_params_file").value is True
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.5\n    watch_params_file: true\n")
    assert graph.spin_until(lambda: node.get_parameter("friction").value == 0.5, 3.0)
    path.write_text("garment_sim_node:\n  ros__parameters:\n    friction: 0.5\n    watch_params_file: false\n")
    assert graph.spin_until(lambda: node.get_parameter("watch_params_file").value is False, 3.0)  # an edit of it


def test_unknown_start_up_parameters_are_named(graph, tmp_path, capfd):
    """Start-up values go through rclpy's public parameter callbacks: a typo in the params file or the
    overrides is named (rclpy keeps it as an override nobody declares), a bad value falls back to the default."""
    path = tmp_path / "start.yaml"
    path.write_text("garment_sim_node:\n  ros__parameters:\n    frictoin: 0.3\n    friction: 0.35\n")
    arguments = ["--ros-args", "--params-file", str(path), "-p", "rate_hz:=5000.0"]
    node = graph.add(GarmentSimNode(context=graph.context, cli_args=arguments, parameter_overrides=[
        Parameter("substeps_max", value=3)], params_file_hint=params_file_from_args(arguments)))
    assert node.get_parameter("friction").value == 0.35 and node.values["friction"] == 0.35
    assert node.get_parameter("rate_hz").value == node.values["rate_hz"] == 60.0  # out of range: the default
    log = capfd.readouterr().err
    assert "frictoin" in log and "substeps_max" in log and "rate_hz" in log
