"""Synthetic rigs of every naming and bind convention (test/rigs.py): the builder itself, the BVH
round trip, the automatic joint map on each, the shared real clips' chest, and the canonical pose
and body fitted on each."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from rigs import BINDS, CONVENTIONS, build_rig, write_bvh

from garment_sim_ros.body.bvh import load_bvh
from garment_sim_ros.body.canonical import canonical_pose
from garment_sim_ros.body.fitting import fit_body
from garment_sim_ros.body.joint_map import auto_joint_map, builtin_joint_map, classify_name
from garment_sim_ros.body.skeleton import forward_kinematics
from garment_sim_ros.cloth.garments import GARMENT_NAMES, build_garment
from garment_sim_ros.transforms import IDENTITY_QUAT

DATA = Path(__file__).parent / "data"  # the shared real clips, copied unchanged
CASES = list(itertools.product(CONVENTIONS, BINDS, (False, True)))
CASE_IDS = [f"{c}-{b}-{'root' if r else 'noroot'}" for c, b, r in CASES]
SIDES = (("left", 1.0), ("right", -1.0))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """(convention, bind, static_root) -> (rig, motion, clip loaded from the BVH written), built once."""
    cache = {}
    directory = tmp_path_factory.mktemp("rigs")

    def get(convention: str, bind: str, static_root: bool):
        key = (convention, bind, static_root)
        if key not in cache:
            rig = build_rig(convention, bind, static_root)
            motion = rig.walk()
            path = write_bvh(rig, motion, directory / f"{convention}_{bind}_{int(static_root)}.bvh")
            cache[key] = rig, motion, load_bvh(path)
        return cache[key]

    return get


def z_of(pose, name: str) -> float:
    return float(pose.frame(name)[0][2])


# --- the builder ------------------------------------------------------------------------------------

@pytest.mark.parametrize("convention", CONVENTIONS)
def test_standing_figure_is_an_adult(convention):
    rig = build_rig(convention)
    standing = rig.standing_pose()
    jm = rig.joint_map
    assert 1.6 < standing.positions[:, 2].max() <= 1.75 + 1e-9  # head top (CC: its eyes; no crown joint)
    assert -1e-9 < standing.positions[:, 2].min() < 0.03  # soles on the floor
    for side, sign in SIDES:
        hip, knee, ankle = (z_of(standing, jm[f"{side}_{p}"]) for p in ("upper_leg", "lower_leg", "foot"))
        assert ankle < knee < hip
        leg = hip - ankle
        assert 0.45 < leg / 1.75 < 0.52  # Winter: hip to ankle 0.491 of the stature
        for role in jm:
            if role.startswith(side):
                assert sign * standing.frame(jm[role])[0][1] > 0.05, role
    # (CMU's spine joint, LowerBack, sits at the hips: its bone is the lower back)
    assert z_of(standing, jm["pelvis"]) <= z_of(standing, jm["spine"]) < z_of(standing, jm["chest"]) \
        < z_of(standing, jm["neck"]) < z_of(standing, jm["head"])
    shoulders = standing.frame(jm["left_upper_arm"])[0] - standing.frame(jm["right_upper_arm"])[0]
    assert 0.3 < np.linalg.norm(shoulders) < 0.45


@pytest.mark.parametrize("convention,bind", list(itertools.product(CONVENTIONS, BINDS)))
def test_bind_lives_where_the_convention_says(convention, bind):
    rig = build_rig(convention, bind, static_root=True)
    count = len(rig.skeleton.names)
    identity = rig.identity_pose()
    np.testing.assert_allclose(rig.standing_pose().positions, rig.standing, atol=1e-12)
    if bind == "offsets":
        np.testing.assert_allclose(rig.bind_rotations, np.tile(IDENTITY_QUAT, (count, 1)), atol=1e-12)
        np.testing.assert_allclose(identity.positions, rig.standing, atol=1e-12)
        return
    # Identity rotations lay the bones along one axis: no standing figure (joints metres off).
    assert np.abs(identity.positions - rig.standing).max() > 0.5
    # Each limb bone lies along the chosen local axis of the joint it starts from.
    axis = {"x": [0, 1, 0], "y": [0, 0, 1], "z": [1, 0, 0]}[bind]  # the BVH axis in REP-103 axes
    for side, _ in SIDES:
        for part in ("lower_leg", "foot", "lower_arm", "hand"):
            offset = rig.offsets[rig.skeleton.index(rig.joint_map[f"{side}_{part}"])]
            np.testing.assert_allclose(offset / np.linalg.norm(offset), axis, atol=1e-12)


@pytest.mark.parametrize("convention,static_root", list(itertools.product(CONVENTIONS, (False, True))))
def test_walk_is_the_same_motion_in_every_bind(convention, static_root):
    motions = {bind: build_rig(convention, bind, static_root).walk() for bind in BINDS}
    reference = motions["offsets"]
    for bind, motion in motions.items():
        for pose, expected in zip(motion.poses, reference.poses):
            np.testing.assert_allclose(pose.positions, expected.positions, atol=1e-9, err_msg=bind)
    rig = build_rig(convention, "x", static_root)
    jm = rig.joint_map
    poses = reference.poses
    # It walks: the pelvis moves forward at about 1.2 m/s, one thigh swings forward while the other
    # is behind, and the knees stay above the ankles.
    step = poses[1].frame(jm["pelvis"])[0] - poses[0].frame(jm["pelvis"])[0]
    assert 0.03 < step[0] < 0.05 and abs(step[1]) < 0.01
    for pose in poses:
        forward = [pose.frame(jm[f"{side}_lower_leg"])[0][0] - pose.frame(jm[f"{side}_upper_leg"])[0][0]
                   for side, _ in SIDES]
        assert forward[0] * forward[1] < 0
        for side, _ in SIDES:
            assert z_of(pose, jm[f"{side}_foot"]) < z_of(pose, jm[f"{side}_lower_leg"]) \
                < z_of(pose, jm[f"{side}_upper_leg"])
    # The bind orientations differ (in the channels), the positions do not.
    agreement = np.abs(np.sum(motions["x"].poses[0].rotations * reference.poses[0].rotations, axis=1))
    assert agreement.min() < 0.9


# --- BVH round trip and the automatic map --------------------------------------------------------

@pytest.mark.parametrize("convention,bind,static_root", CASES, ids=CASE_IDS)
def test_bvh_round_trips_to_the_same_world_poses(written, convention, bind, static_root):
    rig, motion, clip = written(convention, bind, static_root)
    assert clip.skeleton == rig.skeleton
    assert clip.units_scale == rig.scale  # the units were detected, not given
    assert clip.frames == len(motion.poses)  # a walking frame 0 is no reference pose: kept
    assert clip.frame_time == pytest.approx(motion.frame_time, rel=1e-9)
    np.testing.assert_allclose(clip.offsets, rig.offsets, atol=1e-9)
    for f, expected in enumerate(motion.poses):
        pose = clip.pose(f)
        np.testing.assert_allclose(pose.positions, expected.positions, atol=1e-6)
        # rotations too (q and -q are one rotation)
        np.testing.assert_allclose(np.abs(np.sum(pose.rotations * expected.rotations, axis=1)), 1.0, atol=1e-9)


@pytest.mark.parametrize("convention,bind,static_root", CASES, ids=CASE_IDS)
def test_auto_map_of_the_loaded_clip_is_the_expected_map(written, convention, bind, static_root):
    rig, _, clip = written(convention, bind, static_root)
    count = len(clip.skeleton.names)
    identity = forward_kinematics(clip.skeleton, clip.offsets, np.tile(IDENTITY_QUAT, (count, 1)))
    # Any pose serves to find the zero-length bones: walking frames, or identity rotations (for a bind
    # in the channels, bones stacked along one axis).
    for positions in (clip.pose(0).positions, clip.pose(clip.frames - 1).positions, identity.positions):
        assert auto_joint_map(clip.skeleton, positions) == rig.joint_map
    # The chest is where the clavicles hang (CMU: the joint below the zero-length Spine1 / Chest2).
    sk = clip.skeleton
    clavicle = sk.parents[sk.index(rig.joint_map["left_upper_arm"])]
    hang = sk.names[sk.parents[clavicle]]
    if convention.startswith("cmu"):
        assert sk.names[sk.parents[sk.index(hang)]] == rig.joint_map["chest"]
    else:
        assert hang == rig.joint_map["chest"]


def test_cmu_expected_maps_are_the_builtin_ones():
    assert build_rig("cmu_motionbuilder").joint_map == builtin_joint_map("cmu_motionbuilder")
    assert build_rig("cmu_3dsmax").joint_map == builtin_joint_map("cmu_3dsmax")


# --- the shared real clips -----------------------------------------------------------------------

SHARED = sorted(DATA.glob("*.bvh"))


@pytest.mark.parametrize("path", SHARED, ids=[p.name for p in SHARED])
def test_shared_clip_chest_is_where_the_clavicles_hang(path):
    clip = load_bvh(path)
    sk = clip.skeleton
    jm = auto_joint_map(sk, clip.pose(0).positions)
    assert jm == auto_joint_map(sk, clip.pose(clip.frames - 1).positions)
    position = dict(zip(sk.names, clip.pose(0).positions))
    for side, _ in SIDES:
        clavicle = sk.names[sk.parents[sk.index(jm[f"{side}_upper_arm"])]]
        assert classify_name(clavicle)[1] in ("clavicle", "shoulder"), clavicle
        hang = sk.names[sk.parents[sk.index(clavicle)]]
        if hang != jm["chest"]:
            # Only where the clavicles hang from a zero-length joint at the neck base (CMU's Spine1 /
            # Chest2): the chest is the joint whose bone ends there.
            assert sk.names[sk.parents[sk.index(hang)]] == jm["chest"]
            assert np.linalg.norm(position[hang] - position[jm["neck"]]) < 1e-6
            assert np.linalg.norm(position[hang] - position[jm["chest"]]) > 0.05
    if path.name.startswith("cc_"):
        assert (jm["spine"], jm["chest"], jm["neck"]) == ("CC_Base_Waist", "CC_Base_Spine02", "CC_Base_NeckTwist01")
        assert jm["pelvis"] == "CC_Base_Pelvis" and jm["left_upper_leg"] == "CC_Base_L_Thigh"
    else:  # CMU skeletons, both cgspeed namings (Xia: MotionBuilder names)
        names = "cmu_3dsmax" if "lowerback" in sk.names else "cmu_motionbuilder"
        assert jm == builtin_joint_map(names)


# --- the canonical pose and the body on it -------------------------------------------------------

@pytest.mark.parametrize("convention,bind,static_root", CASES, ids=CASE_IDS)
def test_canonical_pose_stands_and_dresses(written, convention, bind, static_root):
    rig, _, clip = written(convention, bind, static_root)
    jm = auto_joint_map(clip.skeleton, clip.pose(1).positions)
    pose = canonical_pose(clip.pose(1), jm)
    at = {role: pose.frame(name)[0] for role, name in jm.items()}
    for side, sign in SIDES:
        assert at[f"{side}_foot"][2] < at[f"{side}_lower_leg"][2] < at[f"{side}_upper_leg"][2]
        for role in jm:
            if role.startswith(side):
                assert sign * at[role][1] > 0.0, role
    assert at["head"][2] > at["chest"][2] > at["pelvis"][2]
    body = fit_body(pose, jm, detailed=True)
    for name in GARMENT_NAMES:
        mesh = build_garment(name, body.measurements)
        assert len(mesh.triangles) and np.isfinite(mesh.vertices).all(), name


# --- the node's path: the same rigs on /tf ------------------------------------------------------

@pytest.mark.parametrize("convention", CONVENTIONS)
def test_the_node_dresses_every_convention_from_tf_as_a_game_export_publishes_it(convention):
    """Bones along +X, the bind in the rotations, a static root at the floor (a common Unity/game
    export, which the identity-rotation rest pose used to collapse onto one line): from what /tf shows,
    the node maps the rig, stands it up and dresses it, with the body the clip path fits."""
    import math

    from garment_sim_ros.body.pose_buffer import PoseBuffer
    from garment_sim_ros.params import DEFAULT_PARAMS
    from garment_sim_ros.runtime.character_loop import CharacterLoop, Status

    rig = build_rig(convention, "x", static_root=True)
    motion = rig.walk(frames=12, fps=60.0)
    names, parents = rig.skeleton.names, rig.skeleton.parents
    buffer = PoseBuffer("world", max_age_s=0.5)
    loop = CharacterLoop(buffer, DEFAULT_PARAMS, ["one_piece"], 1.0, catch_up_wall_s=math.inf)
    for f in range(len(motion.poses)):
        t = f * motion.frame_time
        for i, name in enumerate(names):
            buffer.add_transform(t, "world" if parents[i] < 0 else names[parents[i]], name,
                                 motion.translations[f, i], motion.rotations[f, i])
        loop.frame(t)
    assert loop.status == Status.RUNNING, loop.detail
    body = loop.character.body
    assert body.joint_map == rig.joint_map and body.estimated == ()
    expected = fit_body(canonical_pose(motion.poses[0], rig.joint_map), rig.joint_map, detailed=True)
    np.testing.assert_allclose(body.volumes.radii, expected.volumes.radii, rtol=0.02)
    assert 1.6 < body.measurements.height < 1.95


# --- a curved spine: the trunk volumes follow the chain they span ------------------------------------

@pytest.mark.parametrize("convention", CONVENTIONS)
def test_trunk_volumes_follow_a_curved_spine_over_all_its_bones(convention):
    """Every spine joint from the spine role up to the neck bent back and forth (a lumbar curve, as CC's
    Waist -> Spine01 leans 40 deg off the trunk in the shared clips): the torso, chest and neck volumes
    lie along the line from their first joint to the joint at their top, whatever the number of bones
    between (1 for CMU, 4 for Unreal's spine_01 -> spine_05), and start at their first joint."""
    from garment_sim_ros.body.aiming import aimed_frame_poses
    from garment_sim_ros.transforms import quat_conjugate, quat_from_axis_angle, quat_multiply, quat_rotate

    rig = build_rig(convention, "x")
    sk, jm = rig.skeleton, rig.joint_map
    spine, head = sk.index(jm["spine"]), sk.index(jm["head"])
    chain = [head, *sk.ancestors(head)]
    chain = chain[1:chain.index(spine) + 1]  # the trunk joints from the spine up to below the head
    rotations = rig.bind_rotations.copy()
    for k, joint in enumerate(chain):  # L_j about the left axis, alternating: B_p^-1 L B (rigs' module doc)
        bend = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(35.0 if k % 2 else -25.0))
        parent = sk.parents[joint]
        rotations[joint] = quat_multiply(quat_conjugate(rig.bind_world[parent]),
                                         quat_multiply(bend, rig.bind_world[joint]))
    bent = forward_kinematics(sk, rig.offsets, rotations)
    body = fit_body(canonical_pose(bent, jm), jm, detailed=True)
    positions, turned = body.volumes.world_poses(*aimed_frame_poses(bent, body.volumes.frames, body.volumes.aims))
    names = body.volumes.names()
    spans = {"torso": ("spine", "chest"), "chest": ("chest", "neck"), "neck": ("neck", "head")}
    for name, (start_role, end_role) in spans.items():
        start, end = bent.frame(jm[start_role])[0], bent.frame(jm[end_role])[0]
        chord = (end - start) / np.linalg.norm(end - start)
        k = names.index(name)
        axis = quat_rotate(turned[k], np.array([0.0, 0.0, 1.0]))
        np.testing.assert_allclose(axis, chord, atol=1e-9, err_msg=name)
        if body.volumes.volumes[k].bone is not None:  # the torso's lower end at the spine joint
            np.testing.assert_allclose(positions[k] + body.volumes.volumes[k].bone[0] * axis, start, atol=1e-9)
    # the torso's bones (joints apart): its first one leans off the line when there are several, so a volume
    # riding that bone alone would not lie along it
    torso = [sk.index(jm["chest"]), *sk.ancestors(sk.index(jm["chest"]))]
    torso = torso[:torso.index(spine) + 1][::-1]
    steps = np.diff(bent.positions[torso], axis=0)
    steps = steps[np.linalg.norm(steps, axis=1) > 1e-6]
    chord = bent.positions[torso[-1]] - bent.positions[spine]
    cosine = steps[0] @ chord / np.linalg.norm(steps[0]) / np.linalg.norm(chord)
    lean = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    assert lean > 5.0 if len(steps) > 1 else lean < 1e-6
    assert len(steps) == {"unreal": 4, "cmu_motionbuilder": 1, "cmu_3dsmax": 1}.get(convention, len(steps))
