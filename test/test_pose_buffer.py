"""The ROS-free pose buffer: interpolation, composition, statuses, validation, root kinematics."""

import math
import tracemalloc

import numpy as np
import pytest

from garment_sim_ros.body.pose_buffer import PoseBuffer, SampleStatus
from garment_sim_ros.body.procedural import ProceduralCharacter, fast_motion, walk
from garment_sim_ros.body.sample_series import SampleSeries
from garment_sim_ros.transforms import IDENTITY_QUAT, quat_from_axis_angle, yaw_quat

Z = np.array([0.0, 0.0, 1.0])
HIPS_MAP = {"pelvis": "pelvis", "left_upper_leg": "left_hip", "right_upper_leg": "right_hip"}


def add_hips(buffer):
    """Static hip joints under the pelvis, so the root frame's heading is the pelvis yaw."""
    buffer.add_transform(0.0, "pelvis", "left_hip", [0.0, 0.1, -0.05], IDENTITY_QUAT, static=True)
    buffer.add_transform(0.0, "pelvis", "right_hip", [0.0, -0.1, -0.05], IDENTITY_QUAT, static=True)


def feed(buffer, character, times):
    skeleton = character.skeleton
    for t in times:
        translations, rotations = character.local_transforms(t)
        for i, name in enumerate(skeleton.names):
            parent = buffer.fixed_frame if skeleton.parents[i] < 0 else skeleton.names[skeleton.parents[i]]
            assert buffer.add_transform(t, parent, name, translations[i], rotations[i]) is None


def test_midpoint_of_a_constant_velocity_translation_is_exact():
    buffer = PoseBuffer()
    p0, velocity = np.array([0.3, -1.2, 0.9]), np.array([3.0, 0.5, -0.25])
    for t in (1.0, 1.1):
        buffer.add_transform(t, "world", "pelvis", p0 + velocity * (t - 1.0), IDENTITY_QUAT)
    for t in (1.0, 1.05, 1.1):
        sample = buffer.sample(t, ["pelvis"])
        assert sample.status is SampleStatus.OK
        np.testing.assert_allclose(sample.pose.positions[0], p0 + velocity * (t - 1.0), atol=1e-14)


def test_rotation_halfway_is_the_slerp_along_the_shorter_arc():
    buffer = PoseBuffer()
    buffer.add_transform(0.0, "world", "arm", [0, 0, 0], quat_from_axis_angle(Z, 0.0))
    # the second key given with the opposite sign (same rotation): still the short way round
    buffer.add_transform(0.1, "world", "arm", [0, 0, 0], -quat_from_axis_angle(Z, math.radians(90.0)))
    rotation = buffer.sample(0.05, ["arm"]).pose.rotations[0]
    expected = quat_from_axis_angle(Z, math.radians(45.0))
    assert abs(np.dot(rotation, expected)) == pytest.approx(1.0, abs=1e-12)


def test_static_and_dynamic_transforms_compose_into_the_fixed_frame():
    buffer = PoseBuffer()
    buffer.add_transform(0.0, "world", "pelvis", [1.0, 0.0, 1.0], yaw_quat(0.0))
    buffer.add_transform(1.0, "world", "pelvis", [2.0, 0.0, 1.0], yaw_quat(math.pi / 2))
    buffer.add_transform(0.0, "pelvis", "hip", [0.0, 0.1, -0.1], IDENTITY_QUAT, static=True)  # static, stamp 0
    buffer.add_transform(0.0, "hip", "knee", [0.0, 0.0, -0.4], IDENTITY_QUAT)
    buffer.add_transform(1.0, "hip", "knee", [0.0, 0.0, -0.4], IDENTITY_QUAT)
    pose = buffer.sample(1.0, ["pelvis", "hip", "knee"]).pose
    # pelvis turned 90 deg left: its +y (the hip offset) points along world -x
    np.testing.assert_allclose(pose.frame("hip")[0], [2.0 - 0.1, 0.0, 0.9], atol=1e-12)
    np.testing.assert_allclose(pose.frame("knee")[0], [1.9, 0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(abs(np.dot(pose.frame("knee")[1], yaw_quat(math.pi / 2))), 1.0, atol=1e-12)
    # the static transform holds at any time, including long before its stamp
    early = buffer.sample(0.5, ["hip"]).pose.frame("hip")[0]
    half = 0.1 * math.sqrt(0.5)  # the pelvis is halfway: at x = 1.5, turned 45 deg
    np.testing.assert_allclose(early, [1.5 - half, half, 0.9], atol=1e-12)


def test_fixed_frame_anywhere_in_the_tree():
    buffer = PoseBuffer(fixed_frame="world")
    buffer.add_transform(0.0, "map", "world", [5.0, 0.0, 0.0], yaw_quat(math.pi), static=True)
    buffer.add_transform(0.0, "map", "pelvis", [4.0, 0.0, 1.0], IDENTITY_QUAT, static=True)
    pose = buffer.sample(0.0, ["pelvis", "world"]).pose
    np.testing.assert_allclose(pose.frame("pelvis")[0], [1.0, 0.0, 1.0], atol=1e-12)  # 1 m behind world's back
    np.testing.assert_allclose(pose.frame("world")[0], [0.0, 0.0, 0.0], atol=1e-12)


def test_extrapolation_is_bounded_then_held_and_old_data_is_stale():
    buffer = PoseBuffer(max_extrapolation_s=0.1, max_age_s=0.5)
    velocity = np.array([2.0, 0.0, 0.0])
    for t in (0.0, 0.1):
        buffer.add_transform(t, "world", "pelvis", velocity * t, yaw_quat(t))  # 1 rad/s yaw
    ahead = buffer.sample(0.15, ["pelvis"])
    assert ahead.status is SampleStatus.EXTRAPOLATED and ahead.age_s == pytest.approx(0.05)
    np.testing.assert_allclose(ahead.pose.positions[0], velocity * 0.15, atol=1e-12)
    assert abs(np.dot(ahead.pose.rotations[0], yaw_quat(0.15))) == pytest.approx(1.0, abs=1e-12)
    held = buffer.sample(0.4, ["pelvis"])
    assert held.status is SampleStatus.EXTRAPOLATED
    np.testing.assert_allclose(held.pose.positions[0], velocity * 0.2, atol=1e-12)  # newest + max_extrapolation
    stale = buffer.sample(0.7, ["pelvis"])
    assert stale.status is SampleStatus.STALE and stale.age_s == pytest.approx(0.6)
    assert "pelvis" in stale.detail
    np.testing.assert_allclose(stale.pose.positions[0], velocity * 0.2, atol=1e-12)
    before = buffer.sample(-1.0, ["pelvis"])  # before the oldest stamp: the oldest, held
    assert before.status is SampleStatus.EXTRAPOLATED
    np.testing.assert_allclose(before.pose.positions[0], [0.0, 0.0, 0.0], atol=1e-12)


def test_no_data_and_missing_frames_are_reported_with_their_names():
    buffer = PoseBuffer()
    empty = buffer.sample(0.0, ["pelvis"])
    assert empty.status is SampleStatus.NO_DATA and empty.pose is None and empty.missing == ("pelvis",)
    buffer.add_transform(0.0, "world", "pelvis", [0, 0, 1], IDENTITY_QUAT)
    buffer.add_transform(0.0, "camera_rig", "camera", [0, 0, 1], IDENTITY_QUAT)  # a tree of its own
    missing = buffer.sample(0.0, ["pelvis", "head", "camera"])
    assert missing.status is SampleStatus.MISSING_FRAMES and missing.pose is None
    assert missing.missing == ("head", "camera")
    assert "'head': no transform names it" in missing.detail
    assert "camera -> camera_rig does not reach 'world'" in missing.detail
    elsewhere = PoseBuffer(fixed_frame="odom")
    elsewhere.add_transform(0.0, "world", "pelvis", [0, 0, 1], IDENTITY_QUAT)
    assert "fixed frame 'odom' is not in the tree" in elsewhere.sample(0.0, ["pelvis"]).detail


def test_out_of_order_stamps_are_inserted_in_place_and_duplicates_replace():
    buffer = PoseBuffer()
    for t in (0.0, 0.2, 0.1, 0.3):
        buffer.add_transform(t, "world", "pelvis", [t, 0.0, 0.0], IDENTITY_QUAT)
    buffer.add_transform(0.2, "world", "pelvis", [0.25, 0.0, 0.0], IDENTITY_QUAT)  # replaces the 0.2 key
    assert buffer.sample_count("pelvis") == 4
    assert buffer.adjusted["out_of_order"] == 1 and buffer.adjusted["duplicate_replaced"] == 1
    assert buffer.sample(0.15, ["pelvis"]).pose.positions[0, 0] == pytest.approx(0.175)
    assert buffer.sample(0.05, ["pelvis"]).pose.positions[0, 0] == pytest.approx(0.05)
    assert buffer.sample(0.25, ["pelvis"]).pose.positions[0, 0] == pytest.approx(0.275)


def test_memory_is_bounded_under_a_1khz_flood():
    buffer = PoseBuffer(max_count=500, max_duration_s=2.0)
    for k in range(1000):
        buffer.add_transform(k * 1e-3, "world", "pelvis", [k * 1e-3, 0, 0], IDENTITY_QUAT)
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    for k in range(1000, 11000):
        buffer.add_transform(k * 1e-3, "world", "pelvis", [k * 1e-3, 0, 0], IDENTITY_QUAT)
    grown = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    assert buffer.sample_count("pelvis") == 500  # max_count binds (2 s at 1 kHz would be 2000)
    assert grown < 20_000  # bytes: nothing accumulates per insert
    assert buffer.sample(10.9995, ["pelvis"]).pose.positions[0, 0] == pytest.approx(10.9995)
    by_time = PoseBuffer(max_count=5000, max_duration_s=0.25)
    for k in range(10_000):
        by_time.add_transform(k * 1e-3, "world", "pelvis", [0, 0, 0], IDENTITY_QUAT)
    assert by_time.sample_count("pelvis") == 251  # max_duration binds: stamps 9.749 .. 9.999
    assert by_time.add_transform(9.0, "world", "pelvis", [0, 0, 0], IDENTITY_QUAT) is not None
    assert by_time.rejected["too_old"] == 1


@pytest.mark.parametrize("args, reason", [
    ((0.0, "world", "pelvis", [math.nan, 0, 0], IDENTITY_QUAT), "non_finite"),
    ((math.inf, "world", "pelvis", [0, 0, 0], IDENTITY_QUAT), "non_finite"),
    ((0.0, "world", "pelvis", [0, 0, 0], [0, 0, 0, math.inf]), "non_finite"),
    ((0.0, "world", "pelvis", [0, 0, 0], [0, 0, 0, 0]), "zero_quaternion"),
    ((0.0, "world", "pelvis", [0, 0, 0], [0, 0, 0, 1.5]), "non_unit_quaternion"),
    ((0.0, "world", "pelvis", [0, 0], IDENTITY_QUAT), "malformed"),
    ((0.0, "world", "pelvis", "abc", IDENTITY_QUAT), "malformed"),
    (("now", "world", "pelvis", [0, 0, 0], IDENTITY_QUAT), "malformed"),
    ((0.0, "pelvis", "pelvis", [0, 0, 0], IDENTITY_QUAT), "bad_frame_name"),
    ((0.0, "", "pelvis", [0, 0, 0], IDENTITY_QUAT), "bad_frame_name"),
])
def test_bad_transforms_are_refused_counted_and_leave_the_buffer_unchanged(args, reason):
    buffer = PoseBuffer()
    message = buffer.add_transform(*args)
    assert message and "'pelvis'" in message
    assert buffer.rejected == {reason: 1}
    assert buffer.sample(0.0, ["pelvis"]).status is SampleStatus.NO_DATA


def test_nearly_unit_quaternions_are_normalised_within_the_tolerance():
    buffer = PoseBuffer(quaternion_tolerance=0.1)
    assert buffer.add_transform(0.0, "world", "a", [0, 0, 0], [0, 0, 0, 1.0004]) is None  # rounding: silent
    assert buffer.add_transform(0.0, "world", "b", [0, 0, 0], [0, 0, 0.6, 0.85]) is None  # |q| = 1.040
    assert buffer.adjusted["normalised_quaternion"] == 1
    rotation = buffer.sample(0.0, ["b"]).pose.rotations[0]
    assert np.linalg.norm(rotation) == pytest.approx(1.0, abs=1e-12)
    lenient = PoseBuffer(quaternion_tolerance=0.6)
    assert lenient.add_transform(0.0, "world", "c", [0, 0, 0], [0, 0, 0, 1.5]) is None


def test_a_new_parent_wins_and_is_counted():
    buffer = PoseBuffer()
    buffer.add_transform(0.0, "world", "hand", [1, 0, 0], IDENTITY_QUAT)
    buffer.add_transform(0.0, "world", "cup", [0, 5, 0], IDENTITY_QUAT, static=True)
    assert buffer.add_transform(0.1, "cup", "hand", [0, 0, 1], IDENTITY_QUAT) is None
    assert buffer.parent("hand") == "cup" and buffer.adjusted["reparented"] == 1
    assert buffer.sample_count("hand") == 1  # the history under the old parent is dropped
    np.testing.assert_allclose(buffer.sample(0.1, ["hand"]).pose.positions[0], [0, 5, 1])


def test_a_transform_closing_a_cycle_is_refused_naming_the_frames():
    buffer = PoseBuffer()
    buffer.add_transform(0.0, "world", "a", [0, 0, 0], IDENTITY_QUAT)
    buffer.add_transform(0.0, "a", "b", [0, 0, 0], IDENTITY_QUAT)
    buffer.add_transform(0.0, "b", "c", [0, 0, 0], IDENTITY_QUAT)
    message = buffer.add_transform(0.0, "c", "a", [0, 0, 0], IDENTITY_QUAT)
    assert message and "a -> c -> b -> a" in message
    assert buffer.rejected["cycle"] == 1 and buffer.parent("a") == "world"
    assert buffer.sample(0.0, ["c"]).status is SampleStatus.OK


def test_skeleton_from_tree_lists_the_subtree_parents_first():
    buffer = PoseBuffer()
    feed(buffer, ProceduralCharacter(walk()), [0.0])
    skeleton = buffer.skeleton_from_tree("pelvis")
    assert set(skeleton.names) == set(ProceduralCharacter(walk()).skeleton.names)
    assert skeleton.names[0] == "pelvis" and skeleton.parents[0] == -1
    for name, parent in zip(skeleton.names[1:], skeleton.parents[1:]):
        assert buffer.parent(name) == skeleton.names[parent]
    with pytest.raises(KeyError, match="'hips'"):
        buffer.skeleton_from_tree("hips")


@pytest.mark.parametrize("gait, halfway_tolerance_m", [
    # Halfway between 120 Hz stamps, lerp/slerp differ from the true motion by about
    # (angular acceleration) h^2 / 8 times the lever arm, h = 1/120 s, summed along the chain.
    # Walk: the knee (60 deg bend, 0.9 Hz) peaks at 2 K (2 pi f)^2 = 67 rad/s^2 -> 0.6 mrad on a
    # 0.4 m shank; measured 0.33 mm at the toe.
    (walk(), 1e-3),
    # Fast motion: knee 100 deg at 1.5 Hz peaks at 310 rad/s^2 -> 2.7 mrad, 1.1 mm on the shank
    # plus the hip's 57 rad/s^2 over 0.9 m; measured 1.44 mm at the toe.
    (fast_motion(), 2e-3),
])
def test_procedural_character_round_trips_through_the_buffer(gait, halfway_tolerance_m):
    character = ProceduralCharacter(gait)
    buffer = PoseBuffer(max_duration_s=4.0)  # keeps all 3 s: the ramp and two seconds of full gait
    stamps = np.arange(0, 361) / 120.0
    feed(buffer, character, stamps)
    for t in stamps[::5]:
        sample = buffer.sample(t, character.skeleton)
        assert sample.status is SampleStatus.OK
        assert np.abs(sample.pose.positions - character.pose(t).positions).max() < 1e-9
        assert np.abs(np.abs(np.sum(sample.pose.rotations * character.pose(t).rotations, axis=1)) - 1).max() < 1e-12
    halfway = [np.linalg.norm(buffer.sample(t, character.skeleton).pose.positions - character.pose(t).positions, axis=1)
               for t in stamps[:-1] + 0.5 / 120.0]
    assert np.max(halfway) < halfway_tolerance_m


def test_root_motion_is_exact_for_constant_acceleration():
    buffer = PoseBuffer(kinematics_window_s=0.1)
    add_hips(buffer)
    p0, v0, a0 = np.array([1.0, 2.0, 0.9]), np.array([1.5, -0.5, 0.2]), np.array([-2.0, 3.0, 1.0])
    yaw_rate, yaw_acceleration = 0.7, -1.5

    def trajectory(t):
        return p0 + v0 * t + 0.5 * a0 * t * t, 0.2 + yaw_rate * t + 0.5 * yaw_acceleration * t * t

    for k in range(121):
        position, yaw = trajectory(k / 120.0)
        buffer.add_transform(k / 120.0, "world", "pelvis", position, yaw_quat(yaw))
    T, dt = 0.9, 1.0 / 60.0
    motion = buffer.root_motion(T, dt, HIPS_MAP)
    assert motion.status is SampleStatus.OK and motion.samples >= 12
    np.testing.assert_allclose(motion.velocity, v0 + a0 * T, atol=1e-9)
    np.testing.assert_allclose(motion.acceleration, a0, atol=1e-7)
    assert motion.yaw_rate == pytest.approx(yaw_rate + yaw_acceleration * T, abs=1e-9)
    assert motion.yaw_acceleration == pytest.approx(yaw_acceleration, abs=1e-7)
    np.testing.assert_allclose(motion.position, trajectory(T)[0], atol=1e-9)
    np.testing.assert_allclose(motion.dx, trajectory(T + dt)[0] - trajectory(T)[0], atol=1e-9)
    assert motion.dyaw == pytest.approx(trajectory(T + dt)[1] - trajectory(T)[1], abs=1e-9)


def test_root_acceleration_from_noisy_mocap_stays_bounded():
    """+-2 mm uniform noise at 120 Hz, T at the newest stamp (the one-sided window, the worst case).

    The fitted a0 is linear in the samples, a0 = sum_i w_i p_i, so its error is at most
    2 mm * sum_i |w_i| for any noise within +-2 mm. For the 0.1 s window (13 samples) that bound
    is 4.03 m/s^2 per axis, against 4 * 2 mm / h^2 = 115 m/s^2 for a second difference of one
    noisy pair. The test asserts the bound (computed here from the window's design matrix) and
    that it is below 5 m/s^2."""
    rate, window = 120.0, 0.1
    buffer = PoseBuffer(kinematics_window_s=window)
    add_hips(buffer)
    rng = np.random.default_rng(7)
    a0, v0 = np.array([0.0, 0.0, -3.0]), np.array([1.3, 0.0, 0.0])
    stamps = np.arange(0, 61) / rate
    for t in stamps:
        noise = rng.uniform(-0.002, 0.002, size=3)
        buffer.add_transform(t, "world", "pelvis", v0 * t + 0.5 * a0 * t * t + [0, 0, 1] + noise, IDENTITY_QUAT)
    T = stamps[-1]
    used = stamps[stamps >= T - window - 1e-12] - T
    weights = 2.0 * np.linalg.pinv(np.vander(used, 3, increasing=True))[2]
    bound = 0.002 * np.abs(weights).sum()
    assert bound < 5.0
    motion = buffer.root_motion(T, 1.0 / 60.0, HIPS_MAP)
    assert motion.samples == len(used) == 13
    assert np.all(np.abs(motion.acceleration - a0) <= bound)
    assert np.all(np.abs(motion.velocity - (v0 + a0 * T)) <= 0.002 * np.abs(np.linalg.pinv(
        np.vander(used, 3, increasing=True))[1]).sum())


def test_root_yaw_rate_is_unwrapped_across_pi():
    buffer = PoseBuffer()
    add_hips(buffer)
    for k in range(25):
        t = k / 120.0
        buffer.add_transform(t, "world", "pelvis", [0, 0, 1], yaw_quat(math.pi - 0.1 + 3.0 * t))
    motion = buffer.root_motion(0.1, 1.0 / 60.0, HIPS_MAP)
    assert motion.yaw_rate == pytest.approx(3.0, abs=1e-8)
    assert motion.yaw_acceleration == pytest.approx(0.0, abs=1e-6)
    assert motion.yaw == pytest.approx(math.pi - 0.1 + 0.3 - 2 * math.pi, abs=1e-9)  # wrapped into (-pi, pi]


def test_root_motion_without_the_root_frames_reports_why():
    buffer = PoseBuffer()
    missing = buffer.root_motion(0.0, 0.01, HIPS_MAP)
    assert missing.status is SampleStatus.NO_DATA and missing.velocity is None
    buffer.add_transform(0.0, "world", "pelvis", [0, 0, 1], IDENTITY_QUAT)
    missing = buffer.root_motion(0.0, 0.01, HIPS_MAP)
    assert missing.status is SampleStatus.MISSING_FRAMES and "left_hip" in missing.detail


def test_constructor_refuses_bad_settings():
    with pytest.raises(ValueError, match="max_count"):
        PoseBuffer(max_count=1)
    with pytest.raises(ValueError, match="max_age_s"):
        PoseBuffer(max_age_s=math.nan)
    with pytest.raises(ValueError, match="fixed_frame"):
        PoseBuffer(fixed_frame="")


@pytest.mark.parametrize("batched", [False, True], ids=["one_by_one", "batched"])
def test_a_lone_root_outlier_is_dropped_and_a_confirmed_jump_forgets_the_history_before_it(batched):
    """Issue 18: one bad root sample 25 m away re-dressed the character. A jump counts only when the next
    sample stays there; a lone outlier never reaches a sample, and is counted."""
    buffer = PoseBuffer(jump_distance_m=1.0)

    def add(t, x):
        if batched:
            buffer.add_transforms([t], ["world"], ["pelvis"], [[x, 0.0, 1.0]], [IDENTITY_QUAT])
        else:
            buffer.add_transform(t, "world", "pelvis", [x, 0.0, 1.0], IDENTITY_QUAT)

    for k in range(10):
        add(1.0 + k / 100, 1.3 * k / 100)  # walking at 1.3 m/s
    add(1.10, 25.0)  # the outlier: held back, not sampled
    assert buffer.sample(1.10, ["pelvis"]).pose.positions[0][0] < 0.2
    add(1.11, 0.143)  # the next sample is back on the path: the outlier is dropped
    assert buffer.rejected == {"root_outlier": 1} and buffer.sample_count("pelvis") == 11
    assert all(buffer.sample(t, ["pelvis"]).pose.positions[0][0] < 0.2 for t in np.linspace(1.0, 1.11, 12))

    add(1.12, -4.0)  # a clip looping back: held until...
    add(1.13, -3.99)  # ...the next sample confirms it: the history before the jump is dropped
    assert buffer.adjusted["jump_confirmed"] == 1 and buffer.rejected["root_outlier"] == 1
    assert buffer.sample_count("pelvis") == 2
    assert buffer.sample(1.125, ["pelvis"]).pose.positions[0][0] == pytest.approx(-3.995)

    add(1.63, -3.99 + 1.3 * 0.5)  # a publisher stalled for 0.5 s while the body walked on: no jump
    assert buffer.sample_count("pelvis") == 3 and buffer.adjusted["jump_confirmed"] == 1


def test_bracketing_one_time_gives_what_the_vector_path_gives():
    """The scalar path (one time, every frame's sample) and the vector one (root kinematics' window) agree
    exactly: before the oldest, between stamps, at a stamp, extrapolating and past the bound, one sample."""
    rng = np.random.default_rng(3)
    for count in (1, 2, 5, 40):
        series = SampleSeries(64)
        for stamp in np.cumsum(rng.uniform(0.001, 0.02, count)):
            rotation = rng.normal(size=4)
            series.insert(float(stamp), rng.normal(size=3), rotation / np.linalg.norm(rotation))
        stamps = series.stamps
        for time in (stamps[0] - 0.1, stamps[0], stamps[-1], stamps[-1] + 0.05, stamps[-1] + 0.5,
                     *rng.uniform(stamps[0], stamps[-1], 5)):
            one = series.bracket(np.array([time]), 0.1)
            vector = series.bracket(np.array([time, time]), 0.1)
            for a, b in zip(one, vector):
                np.testing.assert_array_equal(a[0], b[0])
