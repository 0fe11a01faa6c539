"""Keeping up with /tf as real pipelines publish it (issue 17), with every party in its own process.

``skeleton_player`` plays the shared Character Creator clip (142 joints) at 120 Hz, the node dresses
it, and this process only listens: it keeps the raw /tf and marker bytes while the run lasts and
decodes them afterwards, so the listener takes no CPU from the two under test (2 cores).

Checked (the issue's targets): markers go on within 2 s of dressing and keep coming, the node does not
stay in catch-up frames (each a tick of several full frames: on a machine where a full frame costs about
its span that never ended, 5 marker arrays/s, 2026-12-03), and the pelvis volume marker within 5 cm of
where the pelvis volume is on the /tf tree at the marker's own stamp (the pelvis composed through every
transform from ``world``). The rate itself is a figure of the machine: ``bench/tf_throughput.py`` measures
it against the issue's 30 marker arrays/s (README, "Keeping up with /tf"); asserted here is a floor only a
stalled node misses.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from node_harness import ros_time, transform
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from garment_sim_ros.body.pose_buffer import PoseBuffer
from garment_sim_ros.body.sources import bvh_source, procedural_source
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.rerun_log import volume_ellipsoids
from garment_sim_ros.runtime.character_loop import CharacterLoop, Status
from garment_sim_ros.runtime.marker_cdr import DELETEALL, SPHERE
from garment_sim_ros.runtime.skeleton_setup import BONE_CHECK_S
from garment_sim_ros.runtime.tf_input import (
    TFDecoder,
    TransformBatch,
    ingest,
    ingest_batch,
    seconds_to_stamp,
    stamp_seconds,
)
from garment_sim_ros.transforms import compose, inverse, quat_rotate

CLIP = Path(__file__).parent / "data" / "cc_cmu_07_01_walk.bvh"
RATE_HZ = 120.0
START_TIMEOUT_S = 15.0  # both processes import numba kernels and ROS; the node dresses after BONE_CHECK_S
MEASURE_S = 6.0
FIRST_MARKERS_S = 2.0  # after dressing, the next marker array within this
MIN_MARKERS_PER_S = 8.0  # a floor: the 30/s is bench/tf_throughput.py's (~12-20/s here on 2026-12-03)
MAX_CATCH_UP_SHARE = 0.25  # of the node's frames in the measured windows: the catch-up after a re-dress only
PELVIS_TOLERANCE_M = 0.05
NEAR_REDRESS_S = 0.25  # the clip loops (its root jumps back): markers this close to the jump are not compared


def pelvis_volume(source):
    """The pelvis volume's index among the volume markers, its frame and its marker's centre in that
    frame, as the node fits them to this skeleton (the fit does not depend on the pose it is dressed at)."""
    buffer = PoseBuffer("world")
    loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["pants"], 1.0)
    skeleton = source.skeleton
    for k in range(2 + round(BONE_CHECK_S * 60) + 5):
        t = 1.0 + k / 60
        translations, rotations = source.local_transforms(t - 1.0)
        for name, parent, p, q in zip(skeleton.names, skeleton.parents, translations, rotations):
            buffer.add_transform(t, "world" if parent < 0 else skeleton.names[parent], name, p, q)
        loop.frame(t)
        if loop.status == Status.RUNNING:
            break
    assert loop.status == Status.RUNNING, loop.detail
    volumes = loop.character.body.volumes
    index = volumes.names().index("pelvis")
    frame = volumes.volumes[index].frame
    pose = buffer.sample(t, loop.skeleton).pose
    centers, _, _ = volume_ellipsoids(volumes, pose)  # what the marker shows: the kept range's centre
    position, rotation = pose.frame(frame)
    return index, frame, compose(*inverse(position, rotation), centers[index], rotation)[0]


@pytest.mark.parametrize("clip", [CLIP, None], ids=["cc_clip", "procedural"])
def test_a_skeleton_at_120_hz_from_another_process_is_dressed_and_followed(ros_context, clip):
    index, frame, offset = pelvis_volume(bvh_source(str(clip)) if clip else procedural_source("walk"))
    env = os.environ.copy()  # ros_context set the test's domain, on this machine only
    repo = Path(__file__).parents[1]
    node = subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.node", "--ros-args", "-p",
                             "diagnostics_period:=1.0"], cwd=repo, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    player = subprocess.Popen([sys.executable, "-m", "garment_sim_ros.ros.skeleton_player", "--ros-args",
                               *(["-p", f"bvh:={clip}"] if clip else []), "-p", f"rate_hz:={RATE_HZ}"],
                              cwd=repo, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    listener = rclpy.create_node("listener", context=ros_context)
    markers: list[tuple[float, bytes]] = []  # (receive time, bytes)
    transforms: list[bytes] = []
    diagnostics: list[dict[str, str]] = []
    listener.create_subscription(MarkerArray, "/garment_sim_node/markers",
                                 lambda data: markers.append((time.monotonic(), data)), 100, raw=True)
    listener.create_subscription(TFMessage, "/tf", transforms.append, QoSProfile(depth=1000), raw=True)
    listener.create_subscription(DiagnosticArray, "/diagnostics", lambda m: diagnostics.extend(
        {kv.key: kv.value for kv in s.values} for s in m.status), 10)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(listener)
    try:
        end = time.monotonic() + START_TIMEOUT_S
        while not markers and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        assert markers, "no marker array within the start timeout"
        dressed_at = markers[0][0]
        end = dressed_at + MEASURE_S
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        listener.destroy_node()
        for process in (player, node):
            process.terminate()
        node_log = node.communicate(timeout=10)[1]
        player.wait(10)

    arrival = np.array([t for t, _ in markers])
    assert len(arrival) > 1 and arrival[1] - dressed_at < FIRST_MARKERS_S, (arrival[:3] - dressed_at, node_log)
    rate = np.sum(arrival > dressed_at + FIRST_MARKERS_S) / (MEASURE_S - FIRST_MARKERS_S)

    # the whole recording: no jump drops the history before it (the clip loops), the markers are compared across
    tf_buffer = PoseBuffer("world", max_duration_s=60.0, max_count=4 * int(RATE_HZ * 60), jump_distance_m=1e9)
    decoder = TFDecoder()
    roots = []  # (stamp, position) of the root under world: where the looping clip jumps back
    for data in transforms:
        batch = decoder.decode(data)
        ingest_batch(tf_buffer, batch)
        root = batch.parents.index("world")
        roots.append((batch.stamps[root], batch.translations[root]))
    # (last stamp before, first after): a message the listener missed widens the span the jump lies in
    jumps = [(t0, t1) for (t0, p0), (t1, p1) in zip(roots, roots[1:]) if np.linalg.norm(p1 - p0) > 0.5]
    errors = []
    for _, data in markers[::3]:  # every third: deserializing a garment's points is slow
        array = deserialize_message(data, MarkerArray)
        stamp = stamp_seconds(array.markers[-1].header.stamp)
        near_jump = any(t0 - NEAR_REDRESS_S < stamp < t1 + NEAR_REDRESS_S for t0, t1 in jumps)
        if near_jump or any(m.action == DELETEALL for m in array.markers):
            continue  # dressed again (the clip jumped back): no motion to follow across the jump
        volumes = [m for m in array.markers if m.type == SPHERE]
        sample = tf_buffer.sample(stamp, [frame])
        if sample.pose is None or sample.age_s > 0.0 or stamp < roots[0][0]:
            continue  # /tf's recording ended before the marker or began after it: nothing to compare with
        position, rotation = sample.pose.positions[0], sample.pose.rotations[0]
        expected = position + quat_rotate(rotation, offset)
        p = volumes[index].pose.position
        errors.append(np.linalg.norm(np.array([p.x, p.y, p.z]) - expected))
    errors = np.array(errors)
    lags = [(float(d["input_lag_p50_ms"]), float(d["input_lag_p99_ms"])) for d in diagnostics if "input_hz" in d]
    running = [d for d in diagnostics if "total_frames" in d]
    frames = int(running[-1]["total_frames"]) - int(running[0]["total_frames"])
    catch_ups = int(running[-1].get("loop_catch_up_frames", 0)) - int(running[0].get("loop_catch_up_frames", 0))
    print(f"{clip.name if clip else 'procedural'} at {RATE_HZ:g} Hz: {rate:.1f} marker arrays/s, pelvis volume off "
          f"by median {1e3 * np.median(errors):.1f} mm, max {1e3 * errors.max():.1f} mm over {len(errors)} markers; "
          f"input lag p50, p99 per diagnostics window (ms): {lags}; {catch_ups} of {frames} frames caught up")
    assert lags, diagnostics  # the node reports its input lag
    assert frames > 0 and catch_ups <= MAX_CATCH_UP_SHARE * frames, (catch_ups, frames)
    assert rate >= MIN_MARKERS_PER_S, (rate, node_log[-2000:])
    assert len(errors) >= 10, (len(errors), len(markers))
    assert errors.max() < PELVIS_TOLERANCE_M, (np.round(errors, 3), node_log[-2000:])


# ------------------------------------------------------------------------------ the raw /tf path
def vandal_message(stamp_s: float) -> TFMessage:
    """A walker-like tree with everything ``add_transform`` refuses or adjusts, and another character."""
    stamp = ros_time(seconds_to_stamp(stamp_s))
    late = ros_time(seconds_to_stamp(stamp_s - 0.05))
    return TFMessage(transforms=[
        transform(stamp, "world", "/a/pelvis", (0, 0, 1), (0, 0, 0, 1)),
        transform(stamp, "a/pelvis", "a/hip", (0, 0.1, 0), (0, 0, 0.3826834, 0.9238795)),
        transform(stamp, "world", "b/pelvis", (0, 1, 1), (0, 0, 0, 1)),
        transform(stamp, "a/hip", "a/knee", (0, math.nan, 0), (0, 0, 0, 1)),
        transform(stamp, "a/hip", "a/knee", (0, 0, -0.4), (0, 0, 0, 0)),
        transform(stamp, "a/hip", "a/knee", (0, 0, -0.4), (0, 0, 0, 1.02)),  # normalised
        transform(late, "a/hip", "a/knee", (0, 0, -0.4), (0, 0, 0, 1)),  # out of order
        transform(stamp, "a/knee", "a/pelvis", (0, 0, 0), (0, 0, 0, 1)),  # would close a cycle
        transform(ros_time(seconds_to_stamp(stamp_s + 100.0)), "a/hip", "a/knee", (0, 0, -0.4), (0, 0, 0, 1)),
    ])


def test_raw_tf_decodes_to_what_the_message_objects_store():
    """``TFDecoder`` + ``ingest_batch`` == ``ingest`` of the deserialized message: the same frames,
    samples, refusals and adjustments; another character's frames are counted, never built."""
    by_objects, by_bytes = PoseBuffer("world"), PoseBuffer("world")
    decoder = TFDecoder("a/")
    for k in range(6):  # the second message on reuses the cached layout
        message = vandal_message(10.0 + k / 120)
        expected = ingest(by_objects, message, "a/", now_s=10.0 + k / 120)
        batch = decoder.decode(serialize_message(message))
        got = ingest_batch(by_bytes, batch, now_s=10.0 + k / 120)
        assert (got.stored, got.other_character, got.refused) == (expected.stored, expected.other_character,
                                                                  expected.refused)
        assert len(batch.children) == 8 and batch.other_character == 1
    assert by_bytes.frames == by_objects.frames and by_bytes.rejected == by_objects.rejected
    assert by_bytes.adjusted == by_objects.adjusted
    for t in (10.0, 10.02, 10.06):
        a, b = by_objects.sample(t, ["a/knee"]), by_bytes.sample(t, ["a/knee"])
        assert a.status == b.status and np.allclose(a.pose.positions, b.pose.positions)
        assert np.allclose(a.pose.rotations, b.pose.rotations)


def test_batches_of_several_messages_store_the_same_series_as_one_by_one():
    source = bvh_source(str(CLIP))
    skeleton = source.skeleton
    one, many = PoseBuffer("world"), PoseBuffer("world")
    batches = []
    for k in range(40):
        t = 5.0 + k / 240
        translations, rotations = source.local_transforms(t)
        parents = ["world" if p < 0 else skeleton.names[p] for p in skeleton.parents]
        batches.append(TransformBatch(np.full(len(parents), t), parents, list(skeleton.names), translations, rotations))
    for batch in batches:
        ingest_batch(one, batch)
    ingest_batch(many, batches[0])
    for start in range(1, 40, 7):
        ingest_batch(many, TransformBatch.concatenate(batches[start:start + 7]))
    for name in skeleton.names[::20]:
        assert one.sample_count(name) == many.sample_count(name) == 40
        for t in (5.01, 5.1, 5.2):
            assert np.allclose(one.sample(t, [name]).pose.positions, many.sample(t, [name]).pose.positions)


def test_a_garbled_message_is_refused_with_a_reason():
    with pytest.raises(ValueError, match="truncated|bad string|CDR"):
        TFDecoder().decode(b"\x00\x01\x00\x00\x05\x00\x00\x00\x01")
