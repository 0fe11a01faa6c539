"""The procedural walker: proportions, rest pose, gait kinematics against their analytic values."""

import math

import numpy as np
import pytest

from garment_sim_ros.body.procedural import (
    WALKER_JOINT_MAP,
    Gait,
    ProceduralCharacter,
    fast_motion,
    run,
    walk,
)
from garment_sim_ros.body.root import root_frame
from garment_sim_ros.params import ParameterError
from garment_sim_ros.transforms import quat_conjugate, quat_multiply, quat_rotate


def angular_speed_deg_s(character, frame, t, dt=1e-4):
    """Finite-difference angular speed of a frame's world rotation at t."""
    i = character.skeleton.index(frame)
    q0 = character.pose(t).rotations[i]
    q1 = character.pose(t + dt).rotations[i]
    relative = quat_multiply(quat_conjugate(q0), q1)
    return math.degrees(2.0 * math.asin(min(1.0, np.linalg.norm(relative[:3]))) / dt)


def in_root_frame(pose, joint_map):
    """Joint positions (J, 3) expressed in the root frame (pelvis origin, heading yaw)."""
    origin, yaw = root_frame(pose, joint_map)
    heading = np.array([0.0, 0.0, math.sin(-yaw / 2), math.cos(-yaw / 2)])
    return quat_rotate(heading, pose.positions - origin)


def test_rest_pose_is_a_standing_adult_of_the_requested_height():
    character = ProceduralCharacter(walk(), height=1.75)
    rest = character.rest_pose()
    head_position, head_rotation = rest.frame("head")
    crown = head_position + quat_rotate(head_rotation, character.head_top)
    soles = min(rest.frame(f"{s}_toe")[0][2] for s in ("left", "right"))
    assert 0.0 <= soles < 0.05  # standing on the floor z = 0
    assert 1.70 <= crown[2] <= 1.80  # the crown, with the soles at z = 0
    # identity rotations at rest; legs straight down under the hips; hands below the shoulders, out 10 deg
    np.testing.assert_allclose(rest.rotations, np.tile([0.0, 0.0, 0.0, 1.0], (len(rest.skeleton.names), 1)))
    for side in ("left", "right"):
        hip, knee, ankle = (rest.frame(f"{side}_{j}")[0] for j in ("hip", "knee", "ankle"))
        np.testing.assert_allclose([hip[:2], knee[:2]], [ankle[:2], ankle[:2]], atol=1e-12)
        shoulder, wrist = rest.frame(f"{side}_shoulder")[0], rest.frame(f"{side}_wrist")[0]
        arm = wrist - shoulder
        assert math.degrees(math.atan2(abs(arm[1]), -arm[2])) == pytest.approx(10.0, abs=1e-9)


def test_rest_pose_is_mirror_symmetric_and_scales_with_height():
    rest = ProceduralCharacter(walk()).rest_pose()
    names = rest.skeleton.names
    for i, name in enumerate(names):
        mirror = name.replace("left_", "R_").replace("right_", "left_").replace("R_", "right_")
        j = names.index(mirror)
        np.testing.assert_allclose(rest.positions[j], rest.positions[i] * [1.0, -1.0, 1.0], atol=1e-12)
    tall = ProceduralCharacter(walk(), height=2.1).rest_pose()
    np.testing.assert_allclose(tall.positions, rest.positions * 2.1 / 1.75, atol=1e-12)


def test_joint_map_names_frames_of_the_skeleton():
    character = ProceduralCharacter(walk())
    assert character.joint_map == WALKER_JOINT_MAP
    assert WALKER_JOINT_MAP["left_upper_leg"] == "left_hip" and WALKER_JOINT_MAP["right_hand"] == "right_wrist"
    for frame in WALKER_JOINT_MAP.values():
        character.skeleton.index(frame)
    assert len(WALKER_JOINT_MAP) == 5 + 2 * 6


def test_first_pose_with_the_ramp_is_the_rest_pose_and_the_gait_is_on_afterwards():
    character = ProceduralCharacter(fast_motion(ramp_s=0.5))
    rest = character.rest_pose()
    for t in (-1.0, 0.0):
        pose = character.pose(t)
        np.testing.assert_allclose(pose.positions, rest.positions, atol=1e-12)
        np.testing.assert_allclose(pose.rotations, rest.rotations, atol=1e-12)
    # just after the start the motion is tiny (smooth start), after the ramp it is the full gait
    assert np.abs(character.pose(0.01).positions - rest.positions).max() < 1e-4
    assert angular_speed_deg_s(character, "left_hip", 2.0 / 1.5) > 300.0  # phase 0: peak hip speed


def test_mean_root_speed_over_a_cycle_matches_the_gait_speed():
    for gait in (walk(), run(), fast_motion(), walk(speed_mps=0.0, hip_swing_deg=20.0)):
        character = ProceduralCharacter(gait)
        period = 1.0 / gait.frequency
        start = gait.ramp_s + 0.37
        travelled = character.pose(start + period).positions[0] - character.pose(start).positions[0]
        assert travelled[0] / period == pytest.approx(gait.speed_mps, abs=1e-9)
        assert abs(travelled[1]) < 1e-9 and abs(travelled[2]) < 1e-9


def test_fast_motion_meets_the_no_penetration_suite_targets():
    character = ProceduralCharacter(fast_motion())
    legs, arms = character.peak_swing_speeds_deg_s
    assert legs >= 180.0 and arms >= 360.0
    period = 1.0 / character.gait.frequency
    times = character.gait.ramp_s + np.linspace(0.0, period, 241)
    thigh = max(angular_speed_deg_s(character, "left_hip", t) for t in times)
    upper_arm = max(angular_speed_deg_s(character, "right_shoulder", t) for t in times)
    # the world rotation adds the torso twist (about z, orthogonal to the swing) to the analytic swing
    assert legs <= thigh <= 1.1 * legs
    assert arms <= upper_arm <= 1.1 * arms
    root_speed = np.linalg.norm(character.pose(times[-1]).positions[0, :2] - character.pose(times[0]).positions[0, :2])
    assert root_speed / period == pytest.approx(3.0, rel=1e-9)


def test_left_joints_stay_left_of_the_root_and_feet_stay_above_the_floor():
    for gait in (walk(turn_rate_deg_s=40.0), fast_motion()):
        character = ProceduralCharacter(gait)
        names = character.skeleton.names
        left = [i for i, n in enumerate(names) if n.startswith("left_")]
        right = [i for i, n in enumerate(names) if n.startswith("right_")]
        feet = [names.index(f"{s}_{j}") for s in ("left", "right") for j in ("ankle", "toe")]
        rest_z = character.rest_pose().positions[feet, 2]
        for t in np.linspace(0.0, gait.ramp_s + 2.0 / gait.frequency, 97):
            pose = character.pose(t)
            local = in_root_frame(pose, character.joint_map)
            assert np.all(local[left, 1] > 0.05) and np.all(local[right, 1] < -0.05)
            assert np.all(pose.positions[feet, 2] >= rest_z - 1e-9)


def test_stance_foot_slips_no_net_distance_with_the_planted_hip_swing():
    gait = walk()
    character = ProceduralCharacter(gait)
    period = 1.0 / gait.frequency
    ankle = character.skeleton.index("left_ankle")
    # the left leg is in stance while it swings back: phase from pi/2 to 3 pi/2
    start = (math.ceil(gait.ramp_s / period) + 0.25) * period
    slip = character.pose(start + 0.5 * period).positions[ankle] - character.pose(start).positions[ankle]
    assert np.linalg.norm(slip[:2]) < 1e-9
    # the hip swing alone (no twist) covers the whole step: stride = 4 L sin(A)
    still = ProceduralCharacter(walk(torso_twist_deg=0.0))
    assert 4 * still.leg_length * math.sin(math.radians(still.hip_swing_deg)) == pytest.approx(gait.stride)


def test_turning_rate_gives_the_expected_heading_change_on_a_circle():
    gait = walk(turn_rate_deg_s=30.0)
    character = ProceduralCharacter(gait)
    period = 1.0 / gait.frequency
    t0 = gait.ramp_s + 0.2
    t1 = t0 + 3 * period  # whole cycles, so the torso twist cancels
    (p0, yaw0), (p1, yaw1) = (root_frame(character.pose(t), character.joint_map) for t in (t0, t1))
    turned = math.degrees((yaw1 - yaw0 + math.pi) % (2 * math.pi) - math.pi)
    assert turned == pytest.approx(30.0 * 3 * period, abs=1e-6)
    # the path is a circle of radius v / omega: the chord between the two points
    radius = gait.speed_mps / math.radians(30.0)
    chord = 2 * radius * math.sin(math.radians(turned) / 2)
    assert np.linalg.norm(p1[:2] - p0[:2]) == pytest.approx(chord, rel=1e-9)


def test_motion_is_a_deterministic_pure_function_of_time():
    a, b = ProceduralCharacter(run()), ProceduralCharacter(run())
    times = [2.3, 0.7, 2.3, 5.1]
    first = [a.local_transforms(t) for t in times]
    second = [b.local_transforms(t) for t in reversed(times)][::-1]
    for (ta, qa), (tb, qb) in zip(first, second):
        assert np.array_equal(ta, tb) and np.array_equal(qa, qb)
    assert np.array_equal(first[0][0], first[2][0])


def test_local_transforms_compose_to_the_world_pose():
    character = ProceduralCharacter(fast_motion())
    translations, rotations = character.local_transforms(1.234)
    pose = character.pose(1.234)
    knee, hip = character.skeleton.index("left_knee"), character.skeleton.index("left_hip")
    expected = pose.positions[hip] + quat_rotate(pose.rotations[hip], translations[knee])
    np.testing.assert_allclose(pose.positions[knee], expected, atol=1e-12)
    np.testing.assert_allclose(translations[0], pose.positions[0])  # the root's is world-relative


def test_gait_derives_stride_from_cadence_and_back():
    assert walk().stride == pytest.approx(1.3 / 0.9)
    by_length = Gait(speed_mps=1.2, stride_length_m=1.5)
    assert by_length.frequency == pytest.approx(0.8) and by_length.stride == pytest.approx(1.5)
    assert walk(speed_mps=2.0).stride == pytest.approx(2.0 / 0.9)


@pytest.mark.parametrize("changes, words", [
    ({"speed_mps": -1.0}, ["speed_mps", "-1.0", "m/s"]),
    ({"speed_mps": float("nan")}, ["speed_mps", "nan"]),
    ({"knee_bend_deg": "60"}, ["knee_bend_deg", "'60'"]),
    ({"stride_length_m": 1.4}, ["exactly one of", "stride_frequency_hz"]),
    ({"stride_frequency_hz": None}, ["exactly one of", "neither"]),
    ({"ramp_s": -0.1}, ["ramp_s", "s"]),
])
def test_gait_refuses_bad_values_with_a_message_naming_them(changes, words):
    with pytest.raises(ParameterError) as error:
        walk(**changes)
    for word in words:
        assert word in str(error.value)


def test_character_refuses_a_stride_its_legs_cannot_make_and_a_bad_height():
    with pytest.raises(ParameterError, match="hip swing beyond 60 deg"):
        ProceduralCharacter(Gait(speed_mps=6.0, stride_frequency_hz=1.0))
    with pytest.raises(ParameterError, match="stride_length_m"):
        Gait(speed_mps=0.0, stride_length_m=1.0)
    with pytest.raises(ParameterError, match="height"):
        ProceduralCharacter(walk(), height=0.0)
