"""BVH clips: parsing, units, the y-up -> REP-103 z-up conversion, Euler orders, sampling, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.bvh import UNIT_SCALES, BvhError, load_bvh
from garment_sim_ros.body.skeleton import forward_kinematics
from garment_sim_ros.transforms import IDENTITY_QUAT, quat_rotate

DATA = Path(__file__).parent / "data"
CLIPS = {
    "cmu_01_01_jumps_turnaround.bvh": dict(frames=2752, joints=31, end_sites=7),
    "cmu_131_01_walk_mjstyle.bvh": dict(frames=994, joints=31, end_sites=7),
}


@pytest.fixture(scope="module", params=sorted(CLIPS))
def clip(request):
    return load_bvh(DATA / request.param, keep_first_frame=True)  # every frame the file has


def write(tmp_path, text: str, name: str = "clip.bvh") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def two_joint_bvh(channels: str = "Zrotation Xrotation Yrotation", frames: str = "0 0 0 0 0 0 0 0 0",
                  count: int = 1, bone: float = 10.0) -> str:
    """A root with 6 channels and one child (3 rotation channels) ``bone`` units above it."""
    return f"""HIERARCHY
ROOT Hips
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition {channels}
  JOINT Chest
  {{
    OFFSET 0 {bone} 0
    CHANNELS 3 {channels}
    End Site
    {{
      OFFSET 0 {bone} 0
    }}
  }}
}}
MOTION
Frames: {count}
Frame Time: 0.5
{frames}
"""


# --- the two CMU clips -------------------------------------------------------------------------

def test_clips_load_with_their_frame_counts_and_rate(clip):
    expected = CLIPS[Path(clip.path).name]
    assert clip.frames == expected["frames"]
    assert clip.fps == pytest.approx(120.0, rel=1e-4)
    assert clip.duration == pytest.approx((expected["frames"] - 1) / 120.0, rel=1e-4)
    # End Sites are kept as leaf joints '<parent>_end'.
    names = clip.skeleton.names
    assert len(names) == expected["joints"] + expected["end_sites"]
    ends = [n for n in names if n.endswith("_end")]
    assert len(ends) == expected["end_sites"] and "Head_end" in ends
    assert clip.translations.shape == (clip.frames, len(names), 3)
    assert clip.rotations.shape == (clip.frames, len(names), 4)
    np.testing.assert_allclose(np.linalg.norm(clip.rotations, axis=-1), 1.0, atol=1e-9)


def test_cmu_units_are_detected_and_converted_to_metres(clip):
    assert clip.units_scale == UNIT_SCALES["cmu"]
    # The file's LeftUpLeg/LeftHip OFFSET is x=1.2..1.4 (left), y=-1.6..-1.8 (down), z=0.7..0.8 (forward)
    # CMU units: in REP-103 metres the hip joint is forward (+x), left (+y) and below (-z) the pelvis.
    hip = clip.skeleton.index("LeftUpLeg" if "LeftUpLeg" in clip.skeleton.names else "LeftHip")
    x, y, z = clip.offsets[hip]
    assert 0.03 < x < 0.06 and 0.06 < y < 0.09 and -0.11 < z < -0.08


def test_cmu_offsets_pose_is_z_up_with_head_over_pelvis_over_feet(clip):
    # CMU keeps its bind in the OFFSETS, so identity rotations stand it up: a check of the axis conversion
    # (other rigs do not stand so; see body.canonical).
    rest = forward_kinematics(clip.skeleton, clip.offsets, np.tile(IDENTITY_QUAT, (len(clip.skeleton.names), 1)))
    z = dict(zip(clip.skeleton.names, rest.positions[:, 2]))
    assert z["Head_end"] > z["Head"] > z["Hips"] == 0.0
    toes = [n for n in z if n.startswith("LeftToe")]
    assert max(z[n] for n in toes) < -0.8
    extent = rest.positions[:, 2].max() - rest.positions[:, 2].min()
    assert 1.3 < extent < 1.6  # end of the head to the toes; the standing height is checked in test_fitting


def test_feet_touch_the_ground_in_the_first_frames(clip):
    for i in range(5):
        lowest = clip.pose(i).positions[:, 2].min()
        assert 0.0 < lowest < 0.15, (i, lowest)  # the clips' floor is z = 0 after their own root offset


def test_joint_trajectory_matches_full_forward_kinematics(clip):
    head = clip.skeleton.index("Head")
    path = clip.joint_trajectory("Head")
    for i in (0, clip.frames // 2, clip.frames - 1):
        np.testing.assert_allclose(path[i], clip.pose(i).positions[head], atol=1e-12)


def test_sample_interpolates_between_frames_and_loops(clip):
    dt = clip.frame_time
    i = 100
    np.testing.assert_allclose(clip.sample(i * dt).positions, clip.pose(i).positions, atol=1e-9)
    halfway = clip.sample((i + 0.5) * dt)
    root_mid = 0.5 * (clip.translations[i, 0] + clip.translations[i + 1, 0])
    np.testing.assert_allclose(halfway.positions[0], root_mid, atol=1e-12)
    # Slerp: the root's halfway rotation is equally far (in angle) from both frames.
    a, b, m = clip.rotations[i, 0], clip.rotations[i + 1, 0], halfway.rotations[0]
    angle = lambda p, q: 2 * math.acos(min(1.0, abs(float(np.dot(p, q)))))  # noqa: E731
    assert angle(a, m) == pytest.approx(angle(m, b), abs=1e-9)
    translations, rotations = clip.sample_local((i + 0.5) * dt)
    np.testing.assert_allclose(translations, 0.5 * (clip.translations[i] + clip.translations[i + 1]), atol=1e-12)
    np.testing.assert_allclose(rotations[0], m, atol=1e-12)
    # Clamped without loop, wrapped with loop.
    np.testing.assert_allclose(clip.sample(clip.duration + 5.0).positions, clip.pose(-1).positions, atol=1e-9)
    np.testing.assert_allclose(clip.sample(clip.duration + i * dt, loop=True).positions,
                               clip.pose(i).positions, atol=1e-6)


def test_a_reference_frame_zero_is_dropped_unless_kept():
    full = load_bvh(DATA / "cmu_01_01_jumps_turnaround.bvh", keep_first_frame=True)
    skipped = load_bvh(DATA / "cmu_01_01_jumps_turnaround.bvh")
    assert skipped.dropped_reference_frame and not full.dropped_reference_frame
    assert skipped.frames == full.frames - 1
    # A clip that starts moving at once keeps its frame 0.
    walk = load_bvh(DATA / "cmu_131_01_walk_mjstyle.bvh")
    assert not walk.dropped_reference_frame
    assert walk.frames == load_bvh(DATA / "cmu_131_01_walk_mjstyle.bvh", keep_first_frame=True).frames
    np.testing.assert_allclose(skipped.pose(0).positions, full.pose(1).positions)
    # Frame 0 is the T-pose: every non-root joint of the file is at most 17 deg from rest.
    angles = 2 * np.degrees(np.arccos(np.clip(np.abs(full.rotations[0, 1:, 3]), 0, 1)))
    assert angles.max() <= 17.0 + 1e-6


# --- conversion, Euler orders, units on small hand-made files ----------------------------------

def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


BVH_TO_REP = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]])


def test_euler_order_hand_computed_quarter_turns(tmp_path):
    # Z=90 then X=90 (intrinsic, as written): the child bone (0, 1, 0) goes X->(0,0,1), then Z keeps it:
    # it points along BVH +z (forward), i.e. REP-103 +x.
    zxy = load_bvh(write(tmp_path, two_joint_bvh("Zrotation Xrotation Yrotation", "0 0 0 90 90 0 0 0 0")), units="cm")
    np.testing.assert_allclose(zxy.pose(0).positions[1], [0.1, 0.0, 0.0], atol=1e-12)
    # X=90 then Z=90 with the same values: Z first turns (0,1,0) to (-1,0,0), X keeps it: BVH -x = REP -y.
    xzy = load_bvh(write(tmp_path, two_joint_bvh("Xrotation Zrotation Yrotation", "0 0 0 90 90 0 0 0 0")), units="cm")
    np.testing.assert_allclose(xzy.pose(0).positions[1], [0.0, -0.1, 0.0], atol=1e-12)


@pytest.mark.parametrize("order", ["ZXY", "ZYX", "XYZ", "YXZ"])
def test_euler_order_matches_rotation_matrices(tmp_path, order):
    angles = {"X": 30.0, "Y": -50.0, "Z": 70.0}
    channels = " ".join(f"{a}rotation" for a in order)
    values = " ".join(str(angles[a]) for a in order)
    # Root at (1, 2, 3) cm with the rotation, the child with the same rotation again.
    clip = load_bvh(write(tmp_path, two_joint_bvh(channels, f"1 2 3 {values} {values}")), units="cm")
    matrices = {"X": rx, "Y": ry, "Z": rz}
    r = np.eye(3)
    for axis in order:
        r = r @ matrices[axis](math.radians(angles[axis]))
    root = np.array([1.0, 2.0, 3.0])
    chest = root + r @ [0, 10, 0]
    end = chest + r @ r @ [0, 10, 0]
    pose = clip.pose(0)
    for joint, expected in zip(("Hips", "Chest", "Chest_end"), (root, chest, end)):
        np.testing.assert_allclose(pose.frame(joint)[0], BVH_TO_REP @ expected * 0.01, atol=1e-12)
    # The joint frame's axes are the file's axes rotated, expressed in REP-103.
    np.testing.assert_allclose(quat_rotate(pose.rotations[0], [0.0, 0.0, 1.0]), BVH_TO_REP @ r @ [0, 1, 0],
                               atol=1e-12)


@pytest.mark.parametrize("unit,bone", [("m", 0.72), ("cm", 72.0), ("mm", 720.0), ("inch", 28.5), ("cmu", 12.8)])
def test_units_are_detected_from_the_skeleton_height(tmp_path, unit, bone):
    # Two bones of `bone` file units each: ~1.45 m in the right unit, an adult's joint span.
    clip = load_bvh(write(tmp_path, two_joint_bvh(bone=bone)))
    assert clip.units_scale == UNIT_SCALES[unit]
    assert load_bvh(write(tmp_path, two_joint_bvh(bone=bone)), units=0.5).units_scale == 0.5


def test_position_channels_replace_the_offset(tmp_path):
    text = two_joint_bvh().replace("CHANNELS 3 Zrotation", "CHANNELS 4 Yposition Zrotation")
    text = text.replace("0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 25 0 0 0")
    clip = load_bvh(write(tmp_path, text), units="cm")
    np.testing.assert_allclose(clip.pose(0).frame("Chest")[0], [0.0, 0.0, 0.25])


# --- errors --------------------------------------------------------------------------------------

def error_of(tmp_path, text: str, **kwargs) -> str:
    path = write(tmp_path, text)
    with pytest.raises(BvhError) as info:
        load_bvh(path, units="cm", **kwargs)
    message = str(info.value)
    assert str(path) in message
    return message


def test_missing_file_is_named(tmp_path):
    with pytest.raises(BvhError, match="nope.bvh: cannot read"):
        load_bvh(tmp_path / "nope.bvh")


def test_truncated_motion_names_the_count(tmp_path):
    text = two_joint_bvh(count=3, frames="0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0 0")
    assert "truncated MOTION: 'Frames: 3' but only 2 frame lines" in error_of(tmp_path, text)


def test_hierarchy_cut_short_names_the_end(tmp_path):
    text = two_joint_bvh().split("MOTION")[0].rsplit("}", 2)[0]
    assert "unexpected end of file" in error_of(tmp_path, text)


def test_wrong_channel_count_names_the_line(tmp_path):
    text = two_joint_bvh(count=2, frames="0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0 0")
    message = error_of(tmp_path, text)
    assert ":20: frame line has 8 values, the hierarchy declares 9 channels" in message


def test_non_numeric_value_names_the_line_and_token(tmp_path):
    text = two_joint_bvh(count=2, frames="0 0 0 0 0 0 0 0 0\n0 0 0 0 x1 0 0 0 0")
    assert ":20: frame values: 'x1' is not a number" in error_of(tmp_path, text)


def test_non_numeric_offset_names_the_line(tmp_path):
    text = two_joint_bvh().replace("OFFSET 0 10.0 0", "OFFSET 0 ten 0", 1)
    assert ":8: joint 'Chest' OFFSET: 'ten' is not a number" in error_of(tmp_path, text)


@pytest.mark.parametrize("old, new, message", [
    ("HIERARCHY", "HIERARCHIE", ":1: expected 'HIERARCHY', got 'HIERARCHIE'"),
    ("ROOT Hips", "ROOT Hips Pelvis", ":2: expected 'ROOT <name>', got 'ROOT Hips Pelvis'"),
    ("JOINT Chest\n  {", "JOINT Chest\n  (", ":7: expected '{' after joint 'Chest', got '('"),
    ("OFFSET 0 10.0 0", "OFFSET 0 10.0", ":8: joint 'Chest': expected 'OFFSET x y z', got 'OFFSET 0 10.0'"),
    ("CHANNELS 3 Z", "CHANNELS three Z",
     ":9: joint 'Chest': expected 'CHANNELS <count> <names...>', got 'CHANNELS three"),
    ("MOTION", "MOTIONS", ":16: expected 'MOTION' after the hierarchy, got 'MOTIONS'"),
    ("Frames: 1", "Frames: 0", ":17: expected 'Frames: <count >= 1>', got 'Frames: 0'"),
    ("Frame Time: 0.5", "FrameTime: 0.5", ":18: expected 'Frame Time: <seconds>', got 'FrameTime: 0.5'"),
])
def test_a_misspelt_line_names_the_line_what_was_expected_and_what_it_says(tmp_path, old, new, message):
    assert message in error_of(tmp_path, two_joint_bvh().replace(old, new, 1))


def test_unknown_channel_name_is_refused(tmp_path):
    text = two_joint_bvh().replace("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation")
    assert ":9: joint 'Chest': unknown channel 'Wrotation'" in error_of(tmp_path, text)


def test_channel_count_disagreeing_with_the_names(tmp_path):
    text = two_joint_bvh().replace("CHANNELS 3 Zrotation", "CHANNELS 4 Zrotation")
    assert "CHANNELS says 4 but lists 3" in error_of(tmp_path, text)


def test_unknown_units_are_refused(tmp_path):
    with pytest.raises(BvhError, match="unknown units 'furlong'"):
        load_bvh(write(tmp_path, two_joint_bvh()), units="furlong")
