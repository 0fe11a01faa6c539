"""Synthetic humanoid rigs for tests, in the naming and the bind convention of real exporters.

``build_rig(convention, bind, static_root)`` gives one standing adult (1.75 m, human proportions,
T-pose, facing +x, left +y, z up: REP-103, metres) with the joint names and tree of an exporter:

- ``CONVENTIONS``: CMU as converted by cgspeed with MotionBuilder and with 3dsMax names, Character
  Creator (twist, share, finger, breast and face bones), Mixamo, Unity humanoid, Unreal mannequin
  (spine_01..05, twist bones, IK bones under the static root), SMPL, Blender Rigify (DEF- bones,
  thigh/shin/arm bones split into ``.001`` segments, no joint named head).
- ``BINDS``: where the bind orientation lives. ``"offsets"``: baked into the offsets, every bind
  rotation identity, so identity rotations give the standing figure (CMU). ``"x"``, ``"y"``,
  ``"z"``: in the rotation channels, each joint's local axis of that name along its bone (the
  offset to the joint it aims at lies on it), so identity rotations give no standing figure
  (Character Creator, Unity, Unreal, Blender exports).
- ``static_root``: a root joint on the floor above the hips (``RL_BoneRoot``, ``root``...), the
  hips moving under it.

``Rig.walk()`` is a few frames of walking (pelvis forward, hip, knee, ankle, shoulder and elbow
swings, trunk twist) as local transforms and world ``SkeletonPose``s; ``write_bvh`` writes it as a
BVH file (y up, the rig's own units and Euler order) that ``body.bvh.load_bvh`` reads back to the
same world poses. ``Rig.joint_map`` is the map the automatic mapper should give (the chest is the
spine joint the clavicles hang from, or, where that is a zero-length joint at the neck base as in
CMU, the joint below it).

How the bind enters (``G`` the motion's world rotation of a joint relative to the standing
figure, ``B`` its bind orientation, ``P`` its standing position): the world rotation is ``G B``,
the offset of a joint in its parent's frame ``B_p^-1 (P - P_p)`` and its local rotation
``B_p^-1 L B`` (``L = G_p^-1 G``), so world positions do not depend on the bind at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from garment_sim_ros.body.bvh import UNIT_SCALES
from garment_sim_ros.body.skeleton import Skeleton, SkeletonPose, forward_kinematics
from garment_sim_ros.transforms import (
    IDENTITY_QUAT,
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
)

HEIGHT_M = 1.75
CONVENTIONS: tuple[str, ...] = (
    "cmu_motionbuilder", "cmu_3dsmax", "character_creator", "mixamo", "unity", "unreal", "smpl", "rigify",
)
BINDS: tuple[str, ...] = ("offsets", "x", "y", "z")
# BVH (x left, y up, z forward) -> REP-103 (x forward, y left, z up), as body/bvh.py converts.
BVH_TO_REP = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_X, _Y, _Z = np.eye(3)

# --- the standing adult (T-pose), REP-103 metres, left side (y > 0) ------------------------------

_CENTRE = {
    "floor": (0.0, 0.0, 0.0), "pelvis": (0.0, 0.0, 0.97), "neck_base": (-0.03, 0.0, 1.46),
    "neck_mid": (-0.015, 0.0, 1.52), "skull": (0.0, 0.0, 1.59), "head_top": (0.01, 0.0, 1.75),
    "jaw": (0.05, 0.0, 1.62), "chin": (0.10, 0.0, 1.57),
}
_LEFT = {
    "hip": (0.0, 0.09, 0.90), "knee": (0.01, 0.09, 0.48), "ankle": (-0.01, 0.09, 0.07),
    "ball": (0.12, 0.10, 0.02), "toe_tip": (0.19, 0.10, 0.02),
    "clavicle": (0.02, 0.025, 1.43), "shoulder": (-0.03, 0.18, 1.43), "elbow": (-0.03, 0.47, 1.43),
    "wrist": (-0.03, 0.72, 1.43), "knuckle": (-0.03, 0.81, 1.43), "finger_mid": (-0.03, 0.855, 1.43),
    "finger_tip": (-0.03, 0.90, 1.43), "index": (0.0, 0.80, 1.43), "index_tip": (0.0, 0.88, 1.43),
    "thumb": (0.0, 0.75, 1.42), "thumb_mid": (0.03, 0.78, 1.42), "thumb_tip": (0.05, 0.81, 1.42),
    "eye": (0.09, 0.03, 1.66), "rib": (0.06, 0.08, 1.31), "breast": (0.10, 0.09, 1.29),
    "pelvis_side": (0.06, 0.11, 0.96),
}


def _spine(z: float) -> np.ndarray:
    """A point on the spine at height z (pelvis 0.97 m to neck base 1.46 m): lumbar and thoracic curve."""
    u = (z - 0.97) / (1.46 - 0.97)
    return np.array([-0.02 * math.sin(math.pi * u) - 0.03 * u, 0.0, z])


def _point(name: str, sign: float = 1.0) -> np.ndarray:
    if name in _CENTRE:
        return np.array(_CENTRE[name])
    x, y, z = _LEFT[name]
    return np.array([x, sign * y, z])


def _lerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    return (1.0 - t) * a + t * b


@dataclass(frozen=True)
class _Side:
    sign: float
    word: str  # Left
    letter: str  # L
    lower: str  # l

    def point(self, name: str) -> np.ndarray:
        """The standing figure's point ``name`` on this side."""
        return _point(name, self.sign)


_SIDES = (_Side(1.0, "Left", "L", "l"), _Side(-1.0, "Right", "R", "r"))


class _Spec:
    """Joints in insertion order: parent, standing position, the joint its bone aims at, End Site position."""

    def __init__(self):
        self.parent: dict[str, str | None] = {}
        self.point: dict[str, np.ndarray] = {}
        self.aim: dict[str, str | None] = {}
        self.end: dict[str, np.ndarray] = {}

    def add(self, name: str, parent: str | None, point, aim: str | None = None, end=None) -> None:
        assert name not in self.parent, name
        self.parent[name] = parent
        self.point[name] = np.asarray(point, dtype=float)
        self.aim[name] = aim
        if end is not None:
            self.end[name] = np.asarray(end, dtype=float)

    def chain(self, parent: str, joints: list[tuple[str, np.ndarray]], end=None) -> None:
        """Each joint aims at the next; the last has ``end`` (its End Site, if it stays a leaf)."""
        for k, (name, point) in enumerate(joints):
            aim = joints[k + 1][0] if k + 1 < len(joints) else None
            self.add(name, parent, point, aim, end if k + 1 == len(joints) else None)
            parent = name


# --- the conventions ------------------------------------------------------------------------------

def _cmu_motionbuilder(spec: _Spec, root: str | None) -> None:
    # cgspeed's CMU: LHipJoint and LowerBack at the hips, Spine1 -> Neck and the collars zero-length.
    spec.add("Hips", root, _point("pelvis"), aim="Spine")
    for s in _SIDES:
        p = s.point
        spec.chain("Hips", [(f"{s.letter}HipJoint", p("pelvis")), (f"{s.word}UpLeg", p("hip")),
                            (f"{s.word}Leg", p("knee")),
                            (f"{s.word}Foot", p("ankle")), (f"{s.word}ToeBase", p("ball"))], end=p("toe_tip"))
    spec.chain("Hips", [("LowerBack", _point("pelvis")), ("Spine", _spine(1.21)), ("Spine1", _point("neck_base")),
                        ("Neck", _point("neck_base")), ("Neck1", _point("neck_mid")), ("Head", _point("skull"))],
               end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        spec.chain("Spine1", [(f"{s.word}Shoulder", p("neck_base")), (f"{s.word}Arm", p("shoulder")),
                              (f"{s.word}ForeArm", p("elbow")), (f"{s.word}Hand", p("wrist")),
                              (f"{s.word}FingerBase", _lerp(p("wrist"), p("knuckle"), 0.5)),
                              (f"{s.letter}Fingers", p("knuckle"))], end=p("finger_tip"))
        spec.add(f"{s.letter}Thumb", f"{s.word}Hand", p("thumb"), end=p("thumb_tip"))


def _cmu_3dsmax(spec: _Spec, root: str | None) -> None:
    spec.add("Hips", root, _point("pelvis"), aim="Chest")
    for s in _SIDES:
        p = s.point
        spec.chain("Hips", [(f"{s.letter}HipJoint", p("pelvis")), (f"{s.word}Hip", p("hip")),
                            (f"{s.word}Knee", p("knee")),
                            (f"{s.word}Ankle", p("ankle")), (f"{s.word}Toe", p("ball"))], end=p("toe_tip"))
    spec.chain("Hips", [("lowerback", _point("pelvis")), ("Chest", _spine(1.21)), ("Chest2", _point("neck_base")),
                        ("lowerneck", _point("neck_base")), ("Neck", _point("neck_mid")), ("Head", _point("skull"))],
               end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        spec.chain("Chest2", [(f"{s.word}Collar", p("neck_base")), (f"{s.word}Shoulder", p("shoulder")),
                              (f"{s.word}Elbow", p("elbow")), (f"{s.word}Wrist", p("wrist")),
                              (f"{s.lower}hand", p("wrist")), (f"{s.letter}Fingers", p("knuckle"))],
                   end=p("finger_tip"))
        spec.add(f"{s.letter}Thumb", f"{s.word}Wrist", p("thumb"), end=p("thumb_tip"))


def _character_creator(spec: _Spec, root: str | None) -> None:
    spec.add("CC_Base_Hip", root, _point("pelvis"), aim="CC_Base_Waist")
    spec.add("CC_Base_Pelvis", "CC_Base_Hip", _point("pelvis"))  # zero-length, carries the legs
    for s in _SIDES:
        p = s.point
        b = f"CC_Base_{s.letter}_"
        spec.chain("CC_Base_Pelvis", [(b + "Thigh", p("hip")), (b + "Calf", p("knee")), (b + "Foot", p("ankle")),
                                      (b + "ToeBase", p("ball"))], end=p("toe_tip"))
        spec.chain(b + "Thigh", [(b + "ThighTwist01", p("hip")), (b + "ThighTwist02", _lerp(p("hip"), p("knee"), 0.5))])
        spec.chain(b + "Calf", [(b + "CalfTwist01", p("knee")), (b + "CalfTwist02", _lerp(p("knee"), p("ankle"), 0.5))])
        spec.add(b + "KneeShareBone", b + "Calf", p("knee"))
    spec.chain("CC_Base_Hip", [("CC_Base_Waist", _spine(1.05)), ("CC_Base_Spine01", _spine(1.10)),
                               ("CC_Base_Spine02", _spine(1.24)), ("CC_Base_NeckTwist01", _point("neck_base")),
                               ("CC_Base_NeckTwist02", _point("neck_mid")), ("CC_Base_Head", _point("skull"))])
    # The face hangs from the head, starting at the head joint itself (CC_Base_FacialBone).
    spec.add("CC_Base_FacialBone", "CC_Base_Head", _point("skull"), aim="CC_Base_JawRoot")
    spec.add("CC_Base_JawRoot", "CC_Base_FacialBone", _point("jaw"), end=_point("chin"))
    for s in _SIDES:
        p = s.point
        spec.add(f"CC_Base_{s.letter}_Eye", "CC_Base_FacialBone", p("eye"), end=p("eye") + [0.02, 0.0, 0.0])
    for s in _SIDES:
        p = s.point
        b = f"CC_Base_{s.letter}_"
        spec.chain("CC_Base_Spine02", [(b + "Clavicle", p("clavicle")), (b + "Upperarm", p("shoulder")),
                                       (b + "Forearm", p("elbow")), (b + "Hand", p("wrist"))])
        spec.aim[b + "Hand"] = b + "Mid1"
        spec.chain(b + "Upperarm", [(b + "UpperarmTwist01", p("shoulder")),
                                    (b + "UpperarmTwist02", _lerp(p("shoulder"), p("elbow"), 0.5))])
        spec.chain(b + "Forearm", [(b + "ForearmTwist01", p("elbow")),
                                   (b + "ForearmTwist02", _lerp(p("elbow"), p("wrist"), 0.5))])
        spec.add(b + "ElbowShareBone", b + "Forearm", p("elbow"))
        spec.chain(b + "Hand", [(b + "Mid1", p("knuckle")), (b + "Mid2", p("finger_mid"))], end=p("finger_tip"))
        spec.chain(b + "Hand", [(b + "Index1", p("index")), (b + "Index2", _lerp(p("index"), p("index_tip"), 0.5))],
                   end=p("index_tip"))
        spec.chain(b + "Hand", [(b + "Thumb1", p("thumb")), (b + "Thumb2", p("thumb_mid"))], end=p("thumb_tip"))
        spec.chain("CC_Base_Spine02", [(b + "RibsTwist", p("rib")), (b + "Breast", p("breast"))],
                   end=p("breast") + [0.03, 0.0, 0.0])


def _mixamo(spec: _Spec, root: str | None) -> None:
    m = "mixamorig:"
    spec.add(m + "Hips", root, _point("pelvis"), aim=m + "Spine")
    for s in _SIDES:
        p = s.point
        spec.chain(m + "Hips", [(f"{m}{s.word}UpLeg", p("hip")), (f"{m}{s.word}Leg", p("knee")),
                                (f"{m}{s.word}Foot", p("ankle")), (f"{m}{s.word}ToeBase", p("ball")),
                                (f"{m}{s.word}Toe_End", p("toe_tip"))])
    spec.chain(m + "Hips", [(m + "Spine", _spine(1.05)), (m + "Spine1", _spine(1.15)), (m + "Spine2", _spine(1.27)),
                            (m + "Neck", _point("neck_base")), (m + "Head", _point("skull")),
                            (m + "HeadTop_End", _point("head_top"))])
    for s in _SIDES:
        p = s.point
        a = f"{m}{s.word}"
        spec.chain(m + "Spine2", [(a + "Shoulder", p("clavicle")), (a + "Arm", p("shoulder")),
                                  (a + "ForeArm", p("elbow")), (a + "Hand", p("wrist"))])
        spec.aim[a + "Hand"] = a + "HandMiddle1"
        spec.chain(a + "Hand", [(a + "HandMiddle1", p("knuckle")), (a + "HandMiddle2", p("finger_mid")),
                                (a + "HandMiddle3", p("finger_tip"))])
        spec.chain(a + "Hand", [(a + "HandIndex1", p("index")), (a + "HandIndex2", p("index_tip"))])
        spec.chain(a + "Hand", [(a + "HandThumb1", p("thumb")), (a + "HandThumb2", p("thumb_mid")),
                                (a + "HandThumb3", p("thumb_tip"))])


def _unity(spec: _Spec, root: str | None) -> None:
    spec.add("Hips", root, _point("pelvis"), aim="Spine")
    for s in _SIDES:
        p = s.point
        spec.chain("Hips", [(f"{s.word}UpperLeg", p("hip")), (f"{s.word}LowerLeg", p("knee")),
                            (f"{s.word}Foot", p("ankle")), (f"{s.word}Toes", p("ball"))], end=p("toe_tip"))
    spec.chain("Hips", [("Spine", _spine(1.06)), ("Chest", _spine(1.18)), ("UpperChest", _spine(1.30)),
                        ("Neck", _point("neck_base")), ("Head", _point("skull"))], end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        a = s.word
        spec.chain("UpperChest", [(a + "Shoulder", p("clavicle")), (a + "UpperArm", p("shoulder")),
                                  (a + "LowerArm", p("elbow")), (a + "Hand", p("wrist"))])
        spec.aim[a + "Hand"] = a + "MiddleProximal"
        spec.chain(a + "Hand", [(a + "MiddleProximal", p("knuckle")), (a + "MiddleIntermediate", p("finger_mid"))],
                   end=p("finger_tip"))
        spec.chain(a + "Hand", [(a + "IndexProximal", p("index"))], end=p("index_tip"))
        spec.chain(a + "Hand", [(a + "ThumbProximal", p("thumb")), (a + "ThumbIntermediate", p("thumb_mid"))],
                   end=p("thumb_tip"))


def _unreal(spec: _Spec, root: str | None) -> None:
    spec.add("pelvis", root, _point("pelvis"), aim="spine_01")
    for s in _SIDES:
        p = s.point
        x = s.lower
        spec.chain("pelvis", [(f"thigh_{x}", p("hip")), (f"calf_{x}", p("knee")), (f"foot_{x}", p("ankle")),
                              (f"ball_{x}", p("ball"))], end=p("toe_tip"))
        spec.add(f"thigh_twist_01_{x}", f"thigh_{x}", _lerp(p("hip"), p("knee"), 0.33))
        spec.add(f"calf_twist_01_{x}", f"calf_{x}", _lerp(p("knee"), p("ankle"), 0.5))
    spec.chain("pelvis", [("spine_01", _spine(1.03)), ("spine_02", _spine(1.11)), ("spine_03", _spine(1.20)),
                          ("spine_04", _spine(1.29)), ("spine_05", _spine(1.37)), ("neck_01", _point("neck_base")),
                          ("neck_02", _point("neck_mid")), ("head", _point("skull"))], end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        x = s.lower
        spec.chain("spine_05", [(f"clavicle_{x}", p("clavicle")), (f"upperarm_{x}", p("shoulder")),
                                (f"lowerarm_{x}", p("elbow")), (f"hand_{x}", p("wrist"))])
        spec.aim[f"hand_{x}"] = f"middle_01_{x}"
        spec.add(f"upperarm_twist_01_{x}", f"upperarm_{x}", _lerp(p("shoulder"), p("elbow"), 0.5))
        spec.add(f"lowerarm_twist_01_{x}", f"lowerarm_{x}", _lerp(p("elbow"), p("wrist"), 0.5))
        spec.chain(f"hand_{x}", [(f"middle_01_{x}", p("knuckle")), (f"middle_02_{x}", p("finger_mid"))],
                   end=p("finger_tip"))
        spec.chain(f"hand_{x}", [(f"thumb_01_{x}", p("thumb")), (f"thumb_02_{x}", p("thumb_mid"))], end=p("thumb_tip"))
    if root is not None:  # the mannequin's IK bones hang from the static root
        spec.add("ik_foot_root", root, _point("floor"))
        for s in _SIDES:
            spec.add(f"ik_foot_{s.lower}", "ik_foot_root", _point("ankle", s.sign))


def _smpl(spec: _Spec, root: str | None) -> None:
    spec.add("Pelvis", root, _point("pelvis"), aim="Spine1")
    for s in _SIDES:
        p = s.point
        x = s.letter
        spec.chain("Pelvis", [(f"{x}_Hip", p("hip")), (f"{x}_Knee", p("knee")), (f"{x}_Ankle", p("ankle")),
                              (f"{x}_Foot", p("ball"))], end=p("toe_tip"))
    spec.chain("Pelvis", [("Spine1", _spine(1.07)), ("Spine2", _spine(1.20)), ("Spine3", _spine(1.30)),
                          ("Neck", _point("neck_base")), ("Head", _point("skull"))], end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        x = s.letter
        spec.chain("Spine3", [(f"{x}_Collar", p("clavicle")), (f"{x}_Shoulder", p("shoulder")),
                              (f"{x}_Elbow", p("elbow")), (f"{x}_Wrist", p("wrist")), (f"{x}_Hand", p("knuckle"))],
                   end=p("finger_tip"))


def _rigify(spec: _Spec, root: str | None) -> None:
    spec.add("DEF-spine", root, _point("pelvis"), aim="DEF-spine.001")  # the hips bone
    for s in _SIDES:
        p = s.point
        x = s.letter
        spec.add(f"DEF-pelvis.{x}", "DEF-spine", p("pelvis") + [0.0, 0.0, 0.0], end=p("pelvis_side"))
        spec.chain("DEF-spine", [(f"DEF-thigh.{x}", p("hip")), (f"DEF-thigh.{x}.001", _lerp(p("hip"), p("knee"), 0.5)),
                                 (f"DEF-shin.{x}", p("knee")), (f"DEF-shin.{x}.001", _lerp(p("knee"), p("ankle"), 0.5)),
                                 (f"DEF-foot.{x}", p("ankle")), (f"DEF-toe.{x}", p("ball"))], end=p("toe_tip"))
    spec.chain("DEF-spine", [("DEF-spine.001", _spine(1.07)), ("DEF-spine.002", _spine(1.19)),
                             ("DEF-spine.003", _spine(1.31)), ("DEF-spine.004", _point("neck_base")),
                             ("DEF-spine.005", _point("neck_mid")), ("DEF-spine.006", _point("skull"))],
               end=_point("head_top"))
    for s in _SIDES:
        p = s.point
        x = s.letter
        spec.chain("DEF-spine.003", [(f"DEF-shoulder.{x}", p("clavicle")), (f"DEF-upper_arm.{x}", p("shoulder")),
                                     (f"DEF-upper_arm.{x}.001", _lerp(p("shoulder"), p("elbow"), 0.5)),
                                     (f"DEF-forearm.{x}", p("elbow")),
                                     (f"DEF-forearm.{x}.001", _lerp(p("elbow"), p("wrist"), 0.5)),
                                     (f"DEF-hand.{x}", p("wrist"))])
        spec.aim[f"DEF-hand.{x}"] = f"DEF-f_middle.01.{x}"
        spec.chain(f"DEF-hand.{x}", [(f"DEF-f_middle.01.{x}", p("knuckle")), (f"DEF-f_middle.02.{x}", p("finger_mid"))],
                   end=p("finger_tip"))
        spec.chain(f"DEF-hand.{x}", [(f"DEF-thumb.01.{x}", p("thumb")), (f"DEF-thumb.02.{x}", p("thumb_mid"))],
                   end=p("thumb_tip"))
        spec.add(f"DEF-breast.{x}", "DEF-spine.003", p("rib"), end=p("breast"))


def _roles(pelvis, spine, chest, neck, head, leg, arm) -> dict[str, str]:
    """The expected joint map; ``leg``/``arm``: side -> (upper, lower, end) names."""
    roles = dict(pelvis=pelvis, spine=spine, chest=chest, neck=neck, head=head)
    for s in _SIDES:
        side = s.word.lower()
        for part, name in zip(("upper_leg", "lower_leg", "foot"), leg(s)):
            roles[f"{side}_{part}"] = name
        for part, name in zip(("upper_arm", "lower_arm", "hand"), arm(s)):
            roles[f"{side}_{part}"] = name
    return roles


# convention -> (tree builder, static root name, units (file unit name in UNIT_SCALES), Euler order, joint map)
_CONVENTIONS = {
    "cmu_motionbuilder": (_cmu_motionbuilder, "Reference", "cmu", "ZYX", _roles(
        "Hips", "LowerBack", "Spine", "Neck", "Head",
        lambda s: (f"{s.word}UpLeg", f"{s.word}Leg", f"{s.word}Foot"),
        lambda s: (f"{s.word}Arm", f"{s.word}ForeArm", f"{s.word}Hand"))),
    "cmu_3dsmax": (_cmu_3dsmax, "Root", "cmu", "ZYX", _roles(
        "Hips", "lowerback", "Chest", "lowerneck", "Head",
        lambda s: (f"{s.word}Hip", f"{s.word}Knee", f"{s.word}Ankle"),
        lambda s: (f"{s.word}Shoulder", f"{s.word}Elbow", f"{s.word}Wrist"))),
    "character_creator": (_character_creator, "RL_BoneRoot", "cm", "ZXY", _roles(
        "CC_Base_Pelvis", "CC_Base_Waist", "CC_Base_Spine02", "CC_Base_NeckTwist01", "CC_Base_Head",
        lambda s: (f"CC_Base_{s.letter}_Thigh", f"CC_Base_{s.letter}_Calf", f"CC_Base_{s.letter}_Foot"),
        lambda s: (f"CC_Base_{s.letter}_Upperarm", f"CC_Base_{s.letter}_Forearm", f"CC_Base_{s.letter}_Hand"))),
    "mixamo": (_mixamo, "Armature", "cm", "ZXY", _roles(
        "mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine2", "mixamorig:Neck", "mixamorig:Head",
        lambda s: (f"mixamorig:{s.word}UpLeg", f"mixamorig:{s.word}Leg", f"mixamorig:{s.word}Foot"),
        lambda s: (f"mixamorig:{s.word}Arm", f"mixamorig:{s.word}ForeArm", f"mixamorig:{s.word}Hand"))),
    "unity": (_unity, "Root", "m", "ZXY", _roles(
        "Hips", "Spine", "UpperChest", "Neck", "Head",
        lambda s: (f"{s.word}UpperLeg", f"{s.word}LowerLeg", f"{s.word}Foot"),
        lambda s: (f"{s.word}UpperArm", f"{s.word}LowerArm", f"{s.word}Hand"))),
    "unreal": (_unreal, "root", "cm", "ZYX", _roles(
        "pelvis", "spine_01", "spine_05", "neck_01", "head",
        lambda s: (f"thigh_{s.lower}", f"calf_{s.lower}", f"foot_{s.lower}"),
        lambda s: (f"upperarm_{s.lower}", f"lowerarm_{s.lower}", f"hand_{s.lower}"))),
    "smpl": (_smpl, "Root", "m", "ZYX", _roles(
        "Pelvis", "Spine1", "Spine3", "Neck", "Head",
        lambda s: (f"{s.letter}_Hip", f"{s.letter}_Knee", f"{s.letter}_Ankle"),
        lambda s: (f"{s.letter}_Shoulder", f"{s.letter}_Elbow", f"{s.letter}_Wrist"))),
    "rigify": (_rigify, "root", "m", "ZXY", _roles(
        "DEF-spine", "DEF-spine.001", "DEF-spine.003", "DEF-spine.004", "DEF-spine.006",
        lambda s: (f"DEF-thigh.{s.letter}", f"DEF-shin.{s.letter}", f"DEF-foot.{s.letter}"),
        lambda s: (f"DEF-upper_arm.{s.letter}", f"DEF-forearm.{s.letter}", f"DEF-hand.{s.letter}"))),
}


# --- the rig --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Motion:
    """Per-frame local transforms (F, J, 3) / (F, J, 4) xyzw, the world poses they give, and the frame time."""

    translations: np.ndarray
    rotations: np.ndarray
    poses: list[SkeletonPose]
    frame_time: float


@dataclass(frozen=True)
class Rig:
    convention: str
    bind: str
    static_root: bool
    skeleton: Skeleton  # BVH order (depth first); End Sites are leaf joints named '<parent>_end'
    standing: np.ndarray  # (J, 3) world positions of the standing figure (T-pose), m
    offsets: np.ndarray  # (J, 3) each joint's translation in its parent's frame (the root's: world), m
    bind_rotations: np.ndarray  # (J, 4) local bind rotations (identity for bind="offsets")
    bind_world: np.ndarray  # (J, 4) world orientation of each joint in the standing figure
    end_site: tuple[bool, ...]
    joint_map: dict[str, str]  # role -> joint: what auto_joint_map should give
    units: str  # file unit (a key of body.bvh.UNIT_SCALES)
    scale: float  # metres per file unit
    euler_order: str  # BVH channel order, e.g. "ZXY": R = Rz Rx Ry (intrinsic, as written)

    @property
    def hips(self) -> int:
        return 1 if self.static_root else 0

    def standing_pose(self) -> SkeletonPose:
        """The standing figure as a pose (bind rotations in the channels, identity motion)."""
        return forward_kinematics(self.skeleton, self.offsets, self.bind_rotations)

    def identity_pose(self) -> SkeletonPose:
        """Every rotation identity (the OFFSETS pose): the standing figure only for bind='offsets'."""
        return forward_kinematics(self.skeleton, self.offsets, np.tile(IDENTITY_QUAT, (len(self.offsets), 1)))

    def walk(self, frames: int = 6, fps: float = 30.0, speed: float = 1.2) -> Motion:
        """A few frames of walking, starting mid-stride: pelvis forward at ``speed`` m/s with a bob and a
        yaw twist, hips flexing +-26 deg, knees bending in the swing, arms lowered 70 deg from the
        T-pose and swinging against the legs, elbows bent, the chest counter-twisting."""
        count = len(self.skeleton.names)
        role = {name: r for r, name in self.joint_map.items()}
        names = self.skeleton.names
        translations = np.tile(self.offsets, (frames, 1, 1))
        rotations = np.empty((frames, count, 4))
        poses = []
        for f in range(frames):
            t = f / fps
            phase = 2.0 * math.pi * 0.9 * t + 0.6
            deltas = np.tile(IDENTITY_QUAT, (count, 1))  # L: each joint's rotation from the standing figure
            for i, name in enumerate(names):
                deltas[i] = _walk_delta(role.get(name), phase)
            pelvis = self.standing[self.hips] + np.array([speed * t, 0.0, 0.015 * math.cos(2.0 * phase)])
            parents = self.skeleton.parents
            for i in range(count):
                p = parents[i]
                bind_parent = self.bind_world[p] if p >= 0 else IDENTITY_QUAT
                # local = B_p^-1 L B (see the module doc)
                rotations[f, i] = quat_multiply(quat_conjugate(bind_parent),
                                                quat_multiply(deltas[i], self.bind_world[i]))
            if self.static_root:  # the hips move in the static root's frame
                translations[f, self.hips] = quat_rotate(quat_conjugate(self.bind_world[0]), pelvis - self.standing[0])
            else:
                translations[f, self.hips] = pelvis
            poses.append(forward_kinematics(self.skeleton, translations[f], rotations[f]))
        return Motion(translations, rotations, poses, 1.0 / fps)


def _walk_delta(role: str | None, phase: float) -> np.ndarray:
    """A joint's rotation from the standing figure, in its parent's standing axes (world axes at rest)."""
    if role is None:
        return IDENTITY_QUAT
    side, _, part = role.partition("_")
    sign = 1.0 if side == "left" else -1.0
    own = phase + (0.0 if side == "left" else math.pi)  # the right limbs half a stride later
    if role == "pelvis":  # yaw twist, a slight forward lean
        return quat_multiply(quat_from_axis_angle(_Z, -0.12 * math.sin(phase)), quat_from_axis_angle(_Y, 0.04))
    if role in ("spine", "chest"):
        return quat_from_axis_angle(_Z, 0.06 * math.sin(phase))  # counter-twist
    if role == "neck":
        return quat_from_axis_angle(_Z, 0.03 * math.sin(phase))
    if role == "head":
        return quat_from_axis_angle(_Y, 0.05)
    if part == "upper_leg":
        return quat_from_axis_angle(_Y, -0.45 * math.sin(own))  # +y rotation swings the leg back
    if part == "lower_leg":
        return quat_from_axis_angle(_Y, 0.1 + 0.8 * max(0.0, math.cos(own)) ** 2)  # the knee bends backwards
    if part == "foot":
        return quat_from_axis_angle(_Y, -0.1 * math.sin(own))
    if part == "upper_arm":  # lower from the T-pose, then swing against the leg
        return quat_multiply(quat_from_axis_angle(_Y, 0.35 * math.sin(own)), quat_from_axis_angle(_X, -sign * 1.2))
    if part == "lower_arm":
        return quat_from_axis_angle(_Z, -sign * 0.35)  # bend forwards
    return IDENTITY_QUAT


def _bone_axis(bind: str) -> np.ndarray:
    """A BVH-local axis letter's direction in REP-103 axes."""
    return BVH_TO_REP @ {"x": _X, "y": _Y, "z": _Z}[bind]


def _bind_orientation(direction: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The world orientation that lays the local ``axis`` along ``direction``, the next local axis
    (cyclically) towards the body's front (up, for a bone pointing forwards)."""
    d = direction / np.linalg.norm(direction)
    reference = _X if abs(d[0]) < 0.9 else _Z
    second = reference - np.dot(reference, d) * d
    second /= np.linalg.norm(second)
    following = np.roll(axis, 1)  # the next local axis, cyclically (x -> y -> z -> x)
    local = np.column_stack([axis, following, np.cross(axis, following)])
    world = np.column_stack([d, second, np.cross(d, second)])
    return quat_from_matrix(world @ local.T)


def build_rig(convention: str, bind: str = "offsets", static_root: bool = False) -> Rig:
    """One standing adult in ``convention``'s names and tree, ``bind``'s bind convention (see the module doc)."""
    if convention not in _CONVENTIONS:
        raise ValueError(f"unknown convention {convention!r}; known: {', '.join(CONVENTIONS)}")
    if bind not in BINDS:
        raise ValueError(f"unknown bind {bind!r}; known: {', '.join(BINDS)}")
    build, root_name, units, order, roles = _CONVENTIONS[convention]
    spec = _Spec()
    root = None
    if static_root:
        spec.add(root_name, None, _point("floor"))
        root = root_name
    build(spec, root)
    if static_root:
        spec.aim[root_name] = next(n for n, p in spec.parent.items() if p == root_name)  # up to the hips
    # Depth-first order, as BVH lists joints; a leaf gets its End Site ('<name>_end').
    children: dict[str | None, list[str]] = {}
    for name, parent in spec.parent.items():
        children.setdefault(parent, []).append(name)
    names: list[str] = []
    parents: list[int] = []
    points: list[np.ndarray] = []
    end_site: list[bool] = []

    def visit(name: str, parent: int) -> None:
        names.append(name)
        parents.append(parent)
        points.append(spec.point[name])
        end_site.append(False)
        index = len(names) - 1
        for child in children.get(name, []):
            visit(child, index)
        if name not in children:
            names.append(f"{name}_end")
            parents.append(index)
            points.append(spec.end.get(name, spec.point[name]))
            end_site.append(True)

    (top,) = children[None]
    visit(top, -1)
    standing = np.array(points)
    count = len(names)
    bind_world = np.tile(IDENTITY_QUAT, (count, 1))
    if bind != "offsets":
        axis = _bone_axis(bind)
        for i, name in enumerate(names):
            target = None if end_site[i] else spec.aim.get(name)
            # A zero-length bone (CMU's Spine1 -> Neck) aims where the chain goes on.
            while target is not None and np.linalg.norm(spec.point[target] - standing[i]) < 1e-9:
                target = spec.aim.get(target)
            if target is not None:
                bind_world[i] = _bind_orientation(spec.point[target] - standing[i], axis)
            elif parents[i] >= 0:
                bind_world[i] = bind_world[parents[i]]  # leaves and helpers follow their parent
    offsets = np.empty((count, 3))
    bind_rotations = np.empty((count, 4))
    for i, p in enumerate(parents):
        if p < 0:
            offsets[i] = standing[i]
            bind_rotations[i] = bind_world[i]
        else:
            inverse = quat_conjugate(bind_world[p])
            offsets[i] = quat_rotate(inverse, standing[i] - standing[p])
            bind_rotations[i] = quat_multiply(inverse, bind_world[i])
    return Rig(
        convention=convention, bind=bind, static_root=static_root,
        skeleton=Skeleton(tuple(names), tuple(parents)), standing=standing, offsets=offsets,
        bind_rotations=bind_rotations, bind_world=bind_world, end_site=tuple(end_site), joint_map=dict(roles),
        units=units, scale=UNIT_SCALES[units],
        # Both Euler orders real exporters use, each convention in both (by static root).
        euler_order=order if not static_root else ("ZXY" if order == "ZYX" else "ZYX"),
    )


# --- BVH ------------------------------------------------------------------------------------------

def euler_angles(matrix: np.ndarray, order: str) -> np.ndarray:
    """Angles (rad) ``a, b, c`` with ``matrix = R_order[0](a) R_order[1](b) R_order[2](c)`` (three distinct axes)."""
    i, j, k = ("XYZ".index(axis) for axis in order)
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    m = np.asarray(matrix, dtype=float)
    sin_b = float(np.clip(parity * m[i, k], -1.0, 1.0))
    b = math.asin(sin_b)
    if math.sqrt(max(0.0, 1.0 - sin_b * sin_b)) > 1e-9:
        a = math.atan2(-parity * m[j, k], m[k, k])
        c = math.atan2(-parity * m[i, j], m[i, i])
    else:  # gimbal lock: only a +- c is defined; take c = 0
        a = math.atan2(parity * m[k, j], m[j, j])
        c = 0.0
    return np.array([a, b, c])


def _channel_values(rotation: np.ndarray, order: str) -> np.ndarray:
    """Euler channel values (deg) in the file's axes for a local rotation in REP-103 axes."""
    bvh = BVH_TO_REP.T @ quat_to_matrix(rotation) @ BVH_TO_REP
    return np.degrees(euler_angles(bvh, order))


def write_bvh(rig: Rig, motion: Motion, path: str | Path) -> Path:
    """The rig and its motion as a BVH file: y up, the rig's units and Euler order; the hips (and a
    static root) with position channels."""
    path = Path(path)
    names, parents = rig.skeleton.names, rig.skeleton.parents
    rotation_channels = " ".join(f"{axis}rotation" for axis in rig.euler_order)
    moving = {0, rig.hips}  # joints with position channels

    def file_vector(v: np.ndarray) -> str:
        return " ".join(f"{x:.10f}" for x in BVH_TO_REP.T @ v / rig.scale)

    children = [[] for _ in names]
    for i, p in enumerate(parents):
        if p >= 0:
            children[p].append(i)
    lines = ["HIERARCHY"]

    def emit(i: int, depth: int) -> None:
        pad = "  " * depth
        if rig.end_site[i]:
            lines.extend([f"{pad}End Site", f"{pad}{{", f"{pad}  OFFSET {file_vector(rig.offsets[i])}", f"{pad}}}"])
            return
        lines.append(f"{pad}{'ROOT' if parents[i] < 0 else 'JOINT'} {names[i]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {file_vector(rig.offsets[i])}")
        if i in moving:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition {rotation_channels}")
        else:
            lines.append(f"{pad}  CHANNELS 3 {rotation_channels}")
        for c in children[i]:
            emit(c, depth + 1)
        lines.append(f"{pad}}}")

    emit(0, 0)
    frames = motion.translations.shape[0]
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {motion.frame_time!r}"]
    for f in range(frames):
        values = []
        for i in range(len(names)):
            if rig.end_site[i]:
                continue
            if i in moving:
                values.extend(BVH_TO_REP.T @ motion.translations[f, i] / rig.scale)
            values.extend(_channel_values(motion.rotations[f, i], rig.euler_order))
        lines.append(" ".join(f"{v:.10f}" for v in values))
    path.write_text("\n".join(lines) + "\n")
    return path
