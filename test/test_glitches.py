"""The joint glitch filter (``body.glitches``): clips on load, /tf in the pose buffer, the loop's report.

A joint whose local rotation jumps faster than ``max_joint_speed`` and comes back within
``max_glitch_time`` is a glitch, replaced by the joint's motion around it; a fast move that stays is
kept. Checked on the real clips (the cartwheel's right thigh flips, the walks have none), on a spike
planted in a real clip's file, on fast swings, and through the pose buffer and the node's loop.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from node_harness import CHARACTER

from garment_sim_ros import cli
from garment_sim_ros.body.bvh import load_bvh
from garment_sim_ros.body.glitches import filter_glitches, rotation_angle
from garment_sim_ros.body.pose_buffer import PoseBuffer
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.ros.diagnostics import crowd_statuses
from garment_sim_ros.runtime.character_loop import CharacterLoop, Status
from garment_sim_ros.runtime.crowd import Member
from garment_sim_ros.transforms import quat_from_axis_angle, quat_multiply

DATA = Path(__file__).parent / "data"
CARTWHEEL = DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"
WALK = DATA / "cc_cmu_07_01_walk.bvh"
Y = np.array([0.0, 1.0, 0.0])


def knee_steps_cm(clip) -> np.ndarray:
    """How far the right knee moves between frames, cm."""
    return 100 * np.linalg.norm(np.diff(clip.joint_trajectory("CC_Base_R_Calf"), axis=0), axis=1)


def test_the_cartwheel_thigh_flips_are_replaced_and_the_knee_no_longer_jumps():
    """The Character Creator cartwheel's right thigh turns 106-179 deg between two 60 Hz frames and back
    4-5 frames later (checked by hand: its knee jumps 33-49 cm in a frame while the foot stays). Filtered,
    those frames follow the thigh's motion around them: the knee moves at most a few cm a frame there."""
    raw = load_bvh(CARTWHEEL, max_joint_speed=0.0)
    clip = load_bvh(CARTWHEEL)
    assert raw.glitches.total == 0
    assert clip.glitches.frames["CC_Base_R_Thigh"] == [*range(60, 64), *range(73, 78), *range(82, 87),
                                                       *range(229, 233)]
    flips = slice(58, 88)
    assert knee_steps_cm(raw)[flips].max() > 30.0
    assert knee_steps_cm(clip)[flips].max() < 6.0
    replaced = {(f, j) for j, name in enumerate(clip.skeleton.names) for f in clip.glitches.frames.get(name, ())}
    kept = np.ones(raw.rotations.shape[:2], dtype=bool)
    kept[tuple(np.array(sorted(replaced)).T)] = False
    assert np.array_equal(clip.rotations[kept], raw.rotations[kept])  # nothing else touched


@pytest.mark.parametrize("name", ["cc_cmu_07_01_walk", "cc_cmu_02_04_jump_balance", "cmu_01_01_jumps_turnaround",
                                  "xia_angry_13_000", "xia_strutting_01_000"])
def test_clean_real_clips_have_no_glitch(name):
    """The walks, the jumps and Xia's angry and strutting clips: up to 2900 deg/s (a CMU toe), no glitch."""
    assert load_bvh(DATA / f"{name}.bvh").glitches.total == 0


def planted_spike(tmp_path: Path, joint: str, frames: range, degrees: float) -> Path:
    """The walk's file with ``degrees`` added to ``joint``'s first rotation channel at ``frames`` (file frames)."""
    lines = WALK.read_text().splitlines()
    motion = lines.index("MOTION")
    column, found = 0, False
    for line in lines[:motion]:
        words = line.split()
        if words[:1] in (["ROOT"], ["JOINT"]):
            found = words[1] == joint
        elif words[:1] == ["CHANNELS"]:
            if found:
                column += next(k for k, c in enumerate(words[2:]) if c.endswith("rotation"))
                break
            column += int(words[1])
    for f in frames:
        values = lines[motion + 3 + f].split()
        values[column] = f"{float(values[column]) + degrees:.4f}"
        lines[motion + 3 + f] = " ".join(values)
    path = tmp_path / "spiked.bvh"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_spike_planted_in_a_real_clip_is_found_replaced_and_reported(tmp_path, capsys):
    """Three frames of the walk's left thigh turned 120 deg: the filter finds them (file frames, the
    reference frame dropped before), puts the thigh back within a few degrees of the true motion, touches
    nothing else, and ``garment-sim skeleton`` reports it (text and JSON)."""
    true = load_bvh(WALK)
    path = planted_spike(tmp_path, "CC_Base_L_Thigh", range(40, 43), 120.0)
    raw, clip = load_bvh(path, max_joint_speed=0.0), load_bvh(path)
    thigh = clip.skeleton.index("CC_Base_L_Thigh")
    rows = np.arange(40, 43) - int(clip.dropped_reference_frame)  # clip rows of file frames 40-42
    assert np.degrees(rotation_angle(raw.rotations[rows, thigh], true.rotations[rows, thigh])).min() > 60.0
    assert clip.glitches.counts == {"CC_Base_L_Thigh": 1}
    assert clip.glitches.frames == {"CC_Base_L_Thigh": [40, 41, 42]}
    assert np.degrees(rotation_angle(clip.rotations[rows, thigh], true.rotations[rows, thigh])).max() < 3.0
    assert np.array_equal(np.delete(clip.rotations, rows, axis=0), np.delete(true.rotations, rows, axis=0))

    assert cli.main(["skeleton", str(path)]) == 0
    assert "1 joint glitches replaced: CC_Base_L_Thigh x1 (frames 40-42)" in capsys.readouterr().out
    assert cli.main(["skeleton", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["joint_glitches"]["frames"] == {"CC_Base_L_Thigh": [40, 41, 42]}
    assert cli.main(["skeleton", str(path), "--max-joint-speed", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["joint_glitches"]["total"] == 0


def hip_flexion(times: np.ndarray, degrees: float, duration: float, back_after: float | None = None) -> np.ndarray:
    """One joint's local rotations (F, 1, 4): a smooth-step flexion to ``degrees`` over ``duration`` (peak 1.5x
    the mean rate, as test_fast_swings.py's tuck), then back the same way ``back_after`` s after it began."""
    s = np.clip(times / duration, 0.0, 1.0)
    angle = degrees * s * s * (3.0 - 2.0 * s)
    if back_after is not None:
        r = np.clip((times - back_after) / duration, 0.0, 1.0)
        angle = angle - degrees * r * r * (3.0 - 2.0 * r)
    return quat_from_axis_angle(Y, np.radians(angle))[:, None, :]


@pytest.mark.parametrize("degrees, duration, back_after", [
    (120.0, 0.2, None),  # test_fast_swings.py's tuck: 900 deg/s at its peak
    (120.0, 0.2, 0.25),  # a kick out and back: 900 deg/s, back within 0.45 s
    (150.0, 0.1, 0.1),  # out and straight back in 0.2 s, 2250 deg/s at the peak
    (120.0, 1.0 / 60.0, None),  # a whole step in one frame (7200 deg/s): held, stays, kept
])
def test_real_fast_swings_are_not_filtered(degrees, duration, back_after):
    times = np.arange(0.0, 0.8, 1.0 / 60.0)
    rotations = hip_flexion(times, degrees, duration, back_after)
    filtered, report = filter_glitches(["hip"], rotations, 1.0 / 60.0, DEFAULT_PARAMS.max_joint_speed,
                                       DEFAULT_PARAMS.max_glitch_time)
    assert report.total == 0 and np.array_equal(filtered, rotations)


def stream(buffer: PoseBuffer, times, rotations, batched: bool) -> None:
    """A joint's samples as /tf: one by one (``add_transform``) or as the node takes them (``add_transforms``)."""
    for t, q in zip(times, rotations):
        if batched:
            assert buffer.add_transforms([t], ["world"], ["hip"], [[0.0, 0.0, 1.0]], [q])[1] == []
        else:
            assert buffer.add_transform(t, "world", "hip", [0.0, 0.0, 1.0], q) is None


def hip_angle(buffer: PoseBuffer, t: float) -> float:
    """The hip's flexion sampled at ``t``, deg."""
    return math.degrees(rotation_angle(buffer.sample(t, ["hip"]).pose.rotations[0], [0.0, 0.0, 0.0, 1.0]))


@pytest.mark.parametrize("batched", [False, True], ids=["one_by_one", "batched"])
def test_the_pose_buffer_holds_a_glitch_then_drops_it_and_accepts_a_move_that_stays(batched):
    """Live: a 150 deg flip of two samples is held (the joint keeps its last good rotation), dropped when the
    data comes back and reported; a 120 deg step that stays is held for max_glitch_time, then stored as it
    came."""
    dt = 1.0 / 60.0
    buffer = PoseBuffer()
    times = 1.0 + np.arange(10) * dt
    stream(buffer, times, hip_flexion(times - 1.0, 0.0, 1.0)[:, 0], batched)  # still
    flipped = quat_from_axis_angle(Y, math.radians(150.0))
    stream(buffer, [1.0 + 10 * dt, 1.0 + 11 * dt], [flipped, flipped], batched)
    assert buffer.sample_count("hip") == 10 and hip_angle(buffer, 1.0 + 11 * dt) < 1e-6  # held
    stream(buffer, [1.0 + 12 * dt], [[0.0, 0.0, 0.0, 1.0]], batched)  # back
    assert buffer.adjusted["joint_glitch"] == 1 and buffer.glitches == {"hip": 1}
    assert "'hip' turned 150 deg" in buffer.last_glitch and "2 sample(s) dropped" in buffer.last_glitch
    assert max(hip_angle(buffer, t) for t in 1.0 + np.linspace(9, 12, 13) * dt) < 1e-6

    step = quat_from_axis_angle(Y, math.radians(120.0))
    later = 1.0 + np.arange(13, 24) * dt
    stream(buffer, later[:7], [step] * 7, batched)  # 6 held: 0.1 s after the first held one
    assert buffer.sample_count("hip") == 11 and buffer.adjusted["fast_joint_move"] == 0
    stream(buffer, later[7:], [step] * 4, batched)  # past max_glitch_time: real, stored as it came
    assert buffer.adjusted["fast_joint_move"] == 1 and buffer.sample_count("hip") == 22
    assert hip_angle(buffer, later[0]) == pytest.approx(120.0) and buffer.adjusted["joint_glitch"] == 1


def test_live_and_offline_agree_on_the_cartwheel():
    """The cartwheel streamed into the pose buffer frame by frame as /tf (the node's batched path): the
    right thigh sampled at every frame is the filtered clip's, within 0.5 deg; the buffer counts its flips."""
    raw, clip = load_bvh(CARTWHEEL, max_joint_speed=0.0), load_bvh(CARTWHEEL)
    names, parents = raw.skeleton.names, raw.skeleton.parents
    parent_names = ["world" if p < 0 else names[p] for p in parents]
    thigh = names.index("CC_Base_R_Thigh")
    chain = [names[i] for i in (*reversed(raw.skeleton.ancestors(thigh)), thigh)]
    buffer = PoseBuffer(max_duration_s=10.0)  # every frame kept
    times = np.arange(raw.frames) * raw.frame_time
    for f in range(240):
        assert buffer.add_transforms(np.full(len(names), times[f]), parent_names, names, raw.translations[f],
                                     raw.rotations[f])[1] == []
    assert buffer.glitches["CC_Base_R_Thigh"] == 4
    for f in range(20, 235):
        pose = buffer.sample(times[f], chain).pose
        local = quat_multiply(pose.rotations[-2] * [-1, -1, -1, 1], pose.rotations[-1])
        assert math.degrees(rotation_angle(local, clip.rotations[f, thigh])) < 0.5, f


def test_the_loop_holds_a_glitched_knee_logs_it_and_the_diagnostics_count_it_per_joint():
    """The walker's right knee flipped 150 deg for two 60 Hz frames while the node runs: those frames are
    simulated on the held knee (the ankle within 2 cm of the true walk, 40+ cm with the flip), the loop logs
    the glitch naming the joint, and the node's diagnostics count it under glitch_right_knee."""
    buffer = PoseBuffer("world", max_age_s=0.2)
    loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["pants"], 1.0, catch_up_wall_s=math.inf)
    events = []
    loop.events.on_event = lambda level, kind, message: events.append((level, kind, message))
    names, parents = CHARACTER.skeleton.names, CHARACTER.skeleton.parents
    knee, ankle = names.index("right_knee"), names.index("right_ankle")
    flip = quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), math.radians(150.0))
    t, frame = 1.0, 1.0 / 60.0
    for k in range(14):
        translations, rotations = CHARACTER.local_transforms(t)
        if k in (10, 11):
            rotations = rotations.copy()
            rotations[knee] = quat_multiply(rotations[knee], flip)
        for i, name in enumerate(names):
            buffer.add_transform(t, "world" if parents[i] < 0 else names[parents[i]], name, translations[i],
                                 rotations[i])
        result = loop.frame(t)
        if k >= 8:
            assert loop.status == Status.RUNNING and result is not None
            assert np.linalg.norm(result.pose.frame("right_ankle")[0] - CHARACTER.pose(t).positions[ankle]) < 0.02, k
        t += frame
    glitches = [message for _, kind, message in events if kind == "joint_glitch"]
    assert len(glitches) == 1 and "'right_knee' turned 150 deg" in glitches[0]
    status = crowd_statuses("garment_sim", [Member("", buffer, loop)], {"fixed_frame": "world"}, t, {}, False)[0]
    values = {kv.key: kv.value for kv in status.values}
    assert values["glitch_right_knee"] == "1" and values["adjusted_joint_glitch"] == "1"
