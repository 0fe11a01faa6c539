"""Joint maps: the built-in YAML maps, the automatic mapper on many naming conventions, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.bvh import load_bvh
from garment_sim_ros.body.joint_map import (
    REQUIRED_ROLES,
    ROLES,
    JointMapError,
    auto_joint_map,
    builtin_joint_map,
    classify_name,
    load_joint_map,
)
from garment_sim_ros.body.procedural import WALKER_JOINT_MAP, ProceduralCharacter
from garment_sim_ros.body.skeleton import Skeleton

DATA = Path(__file__).parent / "data"
BUILTIN_FOR_CLIP = {
    "cmu_01_01_jumps_turnaround.bvh": "cmu_motionbuilder",
    "cmu_131_01_walk_mjstyle.bvh": "cmu_3dsmax",
}


@pytest.fixture(scope="module", params=sorted(BUILTIN_FOR_CLIP))
def clip(request):
    return load_bvh(DATA / request.param)


def test_builtin_maps_name_every_role_with_frames_of_their_clip(clip):
    builtin = builtin_joint_map(BUILTIN_FOR_CLIP[Path(clip.path).name])
    assert set(builtin) == set(ROLES)
    assert all(frame in clip.skeleton.names for frame in builtin.values())


def test_auto_map_equals_the_builtin_map(clip):
    builtin = builtin_joint_map(BUILTIN_FOR_CLIP[Path(clip.path).name])
    # Positions only reveal zero-length bones, so any pose will do: the first frame, the last.
    assert auto_joint_map(clip.skeleton, clip.pose(0).positions) == builtin
    assert auto_joint_map(clip.skeleton, clip.pose(-1).positions) == builtin
    # Names and tree alone give every role but the chest: the collars hang from Spine1 / Chest2, and
    # only positions show that its bones have zero length (it is the neck base; the chest is below).
    by_names = auto_joint_map(clip.skeleton)
    clavicle_parent = clip.skeleton.names[clip.skeleton.parents[clip.skeleton.index(
        clip.skeleton.names[clip.skeleton.parents[clip.skeleton.index(builtin["left_upper_arm"])]])]]
    assert by_names == {**builtin, "chest": clavicle_parent}
    assert clavicle_parent in ("Spine1", "Chest2")


def test_cmu_segments_start_where_the_bone_really_starts(clip):
    rest = clip.pose(0)
    jm = auto_joint_map(clip.skeleton, rest.positions)
    pelvis = rest.frame(jm["pelvis"])[0]
    # The thigh starts at the hip joint, ~10 cm below the pelvis, not at the zero-length LHipJoint.
    assert jm["left_upper_leg"] != "LHipJoint"
    assert np.linalg.norm(rest.frame(jm["left_upper_leg"])[0] - pelvis) > 0.08
    # Every segment's joint is away from the next segment's joint (no zero-length segment).
    for a, b in [("spine", "chest"), ("chest", "neck"), ("neck", "head"), ("left_upper_leg", "left_lower_leg"),
                 ("left_lower_leg", "left_foot"), ("left_upper_arm", "left_lower_arm"),
                 ("left_lower_arm", "left_hand")]:
        assert np.linalg.norm(rest.frame(jm[a])[0] - rest.frame(jm[b])[0]) > 0.05, (a, b)


def test_walker_names_map_automatically():
    rest = ProceduralCharacter().rest_pose()
    assert auto_joint_map(rest.skeleton, rest.positions) == WALKER_JOINT_MAP


# --- synthetic skeletons of other conventions ---------------------------------------------------

def skeleton(tree: dict) -> Skeleton:
    """``{name: parent_name or None}`` in topological order."""
    names = list(tree)
    return Skeleton(tuple(names), tuple(-1 if p is None else names.index(p) for p in tree.values()))


def humanoid(pelvis, trunk, head, leg, arm, prefix="", root=None, extras=(), leg_root=None, arm_root=None):
    """A humanoid tree; ``leg``/``arm`` are functions side -> names down the limb (arm from the clavicle).

    Legs hang from ``leg_root`` (a child of the pelvis, CC style) or the pelvis; arms from ``arm_root``
    or the trunk joint below the last one.
    """
    tree = {}
    if root:
        tree[prefix + root] = None
    tree[prefix + pelvis] = prefix + root if root else None
    parent = prefix + pelvis
    for name in trunk + head:
        tree[prefix + name] = parent
        parent = prefix + name
    if leg_root:
        tree[prefix + leg_root] = prefix + pelvis
    for side in ("left", "right"):
        parent = prefix + (leg_root or pelvis)
        for name in leg(side):
            tree[prefix + name] = parent
            parent = prefix + name
        parent = prefix + (arm_root or trunk[-2])
        for name in arm(side):
            tree[prefix + name] = parent
            parent = prefix + name
    for name, parent in extras:
        tree[prefix + name] = prefix + parent
    return skeleton(tree)


def L(side, camel):  # "Left"/"Right"
    return camel.format(S="Left" if side == "left" else "Right")


CONVENTIONS = {
    "mixamo": (
        humanoid("Hips", ["Spine", "Spine1", "Spine2", "Neck"], ["Head", "HeadTop_End"],
                 lambda s: [L(s, "{S}UpLeg"), L(s, "{S}Leg"), L(s, "{S}Foot"), L(s, "{S}ToeBase")],
                 lambda s: [L(s, "{S}Shoulder"), L(s, "{S}Arm"), L(s, "{S}ForeArm"), L(s, "{S}Hand"),
                            L(s, "{S}HandIndex1")], prefix="mixamorig:"),
        dict(pelvis="Hips", spine="Spine", chest="Spine2", neck="Neck", head="Head", left_upper_leg="LeftUpLeg",
             left_lower_leg="LeftLeg", left_foot="LeftFoot", left_upper_arm="LeftArm", left_lower_arm="LeftForeArm",
             left_hand="LeftHand", right_upper_arm="RightArm"),
        "mixamorig:",
    ),
    "character_creator": (
        humanoid("CC_Base_Hip", ["CC_Base_Waist", "CC_Base_Spine01", "CC_Base_Spine02", "CC_Base_NeckTwist01",
                                    "CC_Base_NeckTwist02"], ["CC_Base_Head"],
                 lambda s: [f"CC_Base_{s[0].upper()}_{n}" for n in ("Thigh", "Calf", "Foot", "ToeBase")],
                 lambda s: [f"CC_Base_{s[0].upper()}_{n}" for n in ("Clavicle", "Upperarm", "Forearm", "Hand")],
                 root="CC_Base_BoneRoot", leg_root="CC_Base_Pelvis", arm_root="CC_Base_Spine02",
                 extras=[("CC_Base_L_UpperarmTwist01", "CC_Base_L_Upperarm"),
                         ("CC_Base_L_ForearmTwist01", "CC_Base_L_Forearm")]),
        dict(pelvis="CC_Base_Pelvis", spine="CC_Base_Waist", chest="CC_Base_Spine02", neck="CC_Base_NeckTwist01",
             head="CC_Base_Head", left_upper_leg="CC_Base_L_Thigh", left_lower_leg="CC_Base_L_Calf",
             left_foot="CC_Base_L_Foot", left_upper_arm="CC_Base_L_Upperarm", left_lower_arm="CC_Base_L_Forearm",
             left_hand="CC_Base_L_Hand", right_upper_leg="CC_Base_R_Thigh"),
        "",
    ),
    "unity_suffix": (
        humanoid("Hips", ["Spine", "Chest", "Neck"], ["Head"],
                 lambda s: [f"{n}_{s[0].upper()}" for n in ("UpperLeg", "LowerLeg", "Foot", "Toes")],
                 lambda s: [f"{n}_{s[0].upper()}" for n in ("Shoulder", "UpperArm", "LowerArm", "Hand")]),
        dict(pelvis="Hips", spine="Spine", chest="Chest", neck="Neck", head="Head", left_upper_leg="UpperLeg_L",
             left_lower_leg="LowerLeg_L", left_foot="Foot_L", left_upper_arm="UpperArm_L",
             left_lower_arm="LowerArm_L", left_hand="Hand_L", right_upper_arm="UpperArm_R"),
        "",
    ),
    "unity_humanoid": (
        humanoid("Hips", ["Spine", "Chest", "UpperChest", "Neck"], ["Head"],
                 lambda s: [L(s, "{S}UpperLeg"), L(s, "{S}LowerLeg"), L(s, "{S}Foot"), L(s, "{S}Toes")],
                 lambda s: [L(s, "{S}Shoulder"), L(s, "{S}UpperArm"), L(s, "{S}LowerArm"), L(s, "{S}Hand")]),
        dict(pelvis="Hips", spine="Spine", chest="UpperChest", neck="Neck", left_upper_leg="LeftUpperLeg",
             left_lower_leg="LeftLowerLeg", left_foot="LeftFoot", left_upper_arm="LeftUpperArm",
             left_lower_arm="LeftLowerArm", left_hand="LeftHand"),
        "",
    ),
    "unreal": (
        humanoid("pelvis", ["spine_01", "spine_02", "spine_03", "neck_01"], ["head"],
                 lambda s: [f"{n}_{s[0]}" for n in ("thigh", "calf", "foot", "ball")],
                 lambda s: [f"{n}_{s[0]}" for n in ("clavicle", "upperarm", "lowerarm", "hand")], root="root",
                 extras=[("upperarm_twist_01_l", "upperarm_l"), ("calf_twist_01_l", "calf_l")]),
        dict(pelvis="pelvis", spine="spine_01", chest="spine_03", neck="neck_01", head="head",
             left_upper_leg="thigh_l", left_lower_leg="calf_l", left_foot="foot_l", left_upper_arm="upperarm_l",
             left_lower_arm="lowerarm_l", left_hand="hand_l", right_lower_leg="calf_r"),
        "",
    ),
    "smpl": (
        humanoid("pelvis", ["spine1", "spine2", "spine3", "neck"], ["head"],
                 lambda s: [f"{s}_{n}" for n in ("hip", "knee", "ankle", "foot")],
                 lambda s: [f"{s}_{n}" for n in ("collar", "shoulder", "elbow", "wrist", "hand")]),
        dict(pelvis="pelvis", spine="spine1", chest="spine3", neck="neck", head="head", left_upper_leg="left_hip",
             left_lower_leg="left_knee", left_foot="left_ankle", left_upper_arm="left_shoulder",
             left_lower_arm="left_elbow", left_hand="left_wrist", right_hand="right_wrist"),
        "",
    ),
    "L_Thigh": (
        humanoid("Pelvis", ["Spine", "Chest", "Neck"], ["Head"],
                 lambda s: [f"{s[0].upper()}_{n}" for n in ("Thigh", "Calf", "Foot")],
                 lambda s: [f"{s[0].upper()}_{n}" for n in ("Clavicle", "UpperArm", "Forearm", "Hand")]),
        dict(pelvis="Pelvis", chest="Chest", left_upper_leg="L_Thigh", left_lower_leg="L_Calf",
             left_upper_arm="L_UpperArm", right_upper_arm="R_UpperArm"),
        "",
    ),
    "l_thigh": (
        humanoid("pelvis", ["spine", "chest", "neck"], ["head"],
                 lambda s: [f"{s[0]}_{n}" for n in ("thigh", "shin", "ankle")],
                 lambda s: [f"{s[0]}_{n}" for n in ("collar", "upperarm", "elbow", "wrist")]),
        dict(pelvis="pelvis", left_upper_leg="l_thigh", left_lower_leg="l_shin", left_foot="l_ankle",
             left_upper_arm="l_upperarm", left_hand="l_wrist"),
        "",
    ),
    "biped": (
        humanoid("Bip01 Pelvis", ["Bip01 Spine", "Bip01 Spine1", "Bip01 Neck"], ["Bip01 Head"],
                 lambda s: [f"Bip01 {s[0].upper()} {n}" for n in ("Thigh", "Calf", "Foot")],
                 lambda s: [f"Bip01 {s[0].upper()} {n}" for n in ("Clavicle", "UpperArm", "Forearm", "Hand")],
                 root="Bip01"),
        dict(pelvis="Bip01 Pelvis", spine="Bip01 Spine", chest="Bip01 Spine1", left_upper_leg="Bip01 L Thigh",
             left_upper_arm="Bip01 L UpperArm"),
        "",
    ),
}


@pytest.mark.parametrize("convention", sorted(CONVENTIONS))
def test_auto_map_recognises_convention(convention):
    sk, expected, prefix = CONVENTIONS[convention]
    jm = auto_joint_map(sk)
    for role, frame in expected.items():
        assert jm[role] == prefix + frame, (convention, role)
    assert set(REQUIRED_ROLES) <= set(jm)


def test_zero_length_joints_are_skipped_with_rest_positions():
    # Mixamo names, but Spine1 sits where Spine does (Spine's bone has zero length): with positions
    # the trunk's first point is carried by Spine1; by names alone by Spine. The chest is Spine2
    # either way: the clavicles hang from it.
    sk, _, _ = CONVENTIONS["mixamo"]
    positions = np.zeros((len(sk.names), 3))
    heights = {"Hips": 0.0, "Spine": 0.1, "Spine1": 0.1, "Spine2": 0.25, "Neck": 0.4, "Head": 0.5,
               "HeadTop_End": 0.7}
    for name, z in heights.items():
        positions[sk.index("mixamorig:" + name), 2] = z
    for side, y in (("Left", 1), ("Right", -1)):
        for k, name in enumerate(["UpLeg", "Leg", "Foot", "ToeBase"]):
            positions[sk.index(f"mixamorig:{side}{name}")] = (0.1 * (k == 3), 0.1 * y, -0.1 - 0.4 * k)
        for k, name in enumerate(["Shoulder", "Arm", "ForeArm", "Hand", "HandIndex1"]):
            positions[sk.index(f"mixamorig:{side}{name}")] = (0.0, y * (0.05 + 0.2 * k), 0.3)
    by_names = auto_joint_map(sk)
    assert (by_names["spine"], by_names["chest"]) == ("mixamorig:Spine", "mixamorig:Spine2")
    with_positions = auto_joint_map(sk, positions)
    assert (with_positions["spine"], with_positions["chest"]) == ("mixamorig:Spine1", "mixamorig:Spine2")
    assert with_positions["neck"] == "mixamorig:Neck" and with_positions["left_upper_arm"] == "mixamorig:LeftArm"


def test_unmappable_skeleton_lists_every_missing_role_and_the_names_seen():
    sk = skeleton({"Root": None, "Bone001": "Root", "Bone002": "Bone001", "Bone003": "Root", "Tail": "Root"})
    with pytest.raises(JointMapError) as info:
        auto_joint_map(sk)
    message = str(info.value)
    for role in REQUIRED_ROLES:
        assert role in message
    for name in sk.names:
        assert name in message


def test_legs_only_skeleton_reports_the_missing_arms():
    sk, _, _ = CONVENTIONS["unreal"]
    keep = [n for n in sk.names if not any(k in n for k in ("clavicle", "upperarm", "lowerarm", "hand"))]
    tree = {n: (sk.names[sk.parents[sk.index(n)]] if sk.parents[sk.index(n)] >= 0 else None) for n in keep}
    with pytest.raises(JointMapError, match=r"missing required role\(s\) left_upper_arm, right_upper_arm;"):
        auto_joint_map(skeleton(tree))


@pytest.mark.parametrize("name,side,part", [
    ("LHipJoint", "left", "upper_leg"), ("Hips", None, "pelvis"), ("lhand", "left", "hand"),
    ("lowerback", None, "spine"), ("mixamorig:RightForeArm", "right", "lower_arm"), ("thigh_r", "right", "upper_leg"),
    ("LeftHandIndex1", "left", "finger"), ("HeadTop_End", None, None), ("upperarm_twist_01_l", "left", "aux"),
    ("CC_Base_NeckTwist01", None, "neck"), ("UpperLeg_L", "left", "upper_leg"), ("right_collar", "right", "clavicle"),
])
def test_classify_name(name, side, part):
    assert classify_name(name) == (side, part)


# --- YAML loading ----------------------------------------------------------------------------------

def test_load_joint_map_errors_name_the_file_and_role(tmp_path, clip):
    path = tmp_path / "map.yaml"
    builtin = builtin_joint_map(BUILTIN_FOR_CLIP[Path(clip.path).name])

    def refused(text: str, pattern: str):
        path.write_text(text)
        with pytest.raises(JointMapError, match=pattern) as info:
            load_joint_map(path, clip.skeleton)
        assert str(path) in str(info.value)

    lines = "\n".join(f"{k}: {v}" for k, v in builtin.items())
    refused(lines + "\nleft_tail: Hips", "unknown role.*left_tail; allowed: pelvis")
    refused("\n".join(f"{k}: {v}" for k, v in builtin.items() if k != "head"), r"missing required role\(s\) head")
    refused(lines.replace(f"head: {builtin['head']}", "head: Skull"), "not in the skeleton: head: Skull")
    refused("pelvis: [Hips\nchest: Spine", "not valid YAML")
    path.write_text(lines)
    assert load_joint_map(path, clip.skeleton) == builtin
