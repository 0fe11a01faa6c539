"""The canonical standing pose of any humanoid skeleton, built from the skeleton alone.

Bodies are fitted and garments cut on one standing figure for every rig: legs straight down
under the hips, spine, neck and head straight up, clavicles rising 20 deg outwards and the arms in a fixed A-pose,
facing +x (REP-103: y left, z up), the pelvis above the origin and the lowest joint on the floor.

Why not the rig's "rest" pose: a BVH file's OFFSETS with identity rotations (or a /tf tree's
translations) is a standing figure only for rigs whose bind orientation lives in the offsets
(CMU). Character Creator, Unity and Unreal exports keep the bind in the rotation channels: with
identity rotations their legs and arms point up and the hips stack vertically. What does not
depend on the pose is each joint's translation in its parent's frame (the bone, constant for a
rigid rig) and the tree; the joint map names the roles. So the canonical pose is built as a
real pose of the skeleton, by forward kinematics with those constant translations: starting
from any observed pose's joint rotations (a real frame, or what /tf shows), each joint that
carries a body segment is turned, by the smallest rotation, so that its bone points the
canonical way; the pelvis and the chest are also turned about the vertical so that their
left/right pairs (hips, clavicles) lie along +y. Every other joint (twist bones, fingers, toes,
face) keeps its rotation relative to its parent. Because it is a pose of the skeleton, volumes
fitted on it and attached to joint frames ride on the real motion exactly.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..transforms import (
    IDENTITY_QUAT,
    quat_between,
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_multiply,
    quat_rotate,
)
from .skeleton import SkeletonPose, forward_kinematics

ARM_DROP_DEG = 45.0  # A-pose: the arms this far below horizontal
CLAVICLE_RISE_DEG = 20.0  # clavicles rise this much outwards (measured 19 deg in the CMU skeletons' bind)
FOOT_PITCH_DEG = 25.0  # the ankle-to-toe bone this far below horizontal
MIN_BONE_M = 1e-4  # shorter bones (co-located joints) have no direction
UP = np.array([0.0, 0.0, 1.0])
DOWN = -UP
LEFT = np.array([0.0, 1.0, 0.0])


class CanonicalPoseError(ValueError):
    """The pose cannot be stood up (e.g. the hip joints coincide); the message says why."""


def _arm_direction(sign: float) -> np.ndarray:
    drop = math.radians(ARM_DROP_DEG)
    return np.array([0.0, sign * math.cos(drop), -math.sin(drop)])


def _clavicle_direction(sign: float) -> np.ndarray:
    rise = math.radians(CLAVICLE_RISE_DEG)
    return np.array([0.0, sign * math.cos(rise), math.sin(rise)])


def _foot_direction() -> np.ndarray:
    pitch = math.radians(FOOT_PITCH_DEG)
    return np.array([math.cos(pitch), 0.0, -math.sin(pitch)])


class _Tree:
    def __init__(self, pose: SkeletonPose):
        self.pose = pose
        self.children = [[] for _ in pose.skeleton.parents]
        for i, p in enumerate(pose.skeleton.parents):
            if p >= 0:
                self.children[p].append(i)

    def chain(self, top: int, bottom: int) -> list[int]:
        """Joints from ``top`` down to ``bottom`` (both included); empty if ``top`` is not above ``bottom``."""
        path = [bottom, *self.pose.skeleton.ancestors(bottom)]
        return path[:path.index(top) + 1][::-1] if top in path else []

    def distance(self, a: int, b: int) -> float:
        return float(np.linalg.norm(self.pose.positions[a] - self.pose.positions[b]))

    def leaf_targets(self, i: int) -> list[int]:
        """The children that leave ``i`` (a bone continues past an end joint: hand -> fingers)."""
        return [c for c in self.children[i] if self.distance(c, i) > MIN_BONE_M]


def _bone_rules(tree: _Tree, index: Mapping[str, int]) -> dict[int, tuple[list[int], np.ndarray]]:
    """joint -> (targets, direction): turn the joint so that the mean of its targets lies along direction."""
    rules: dict[int, tuple[list[int], np.ndarray]] = {}

    def along(chain: list[int], direction: np.ndarray) -> None:
        """Each joint of ``chain`` but the last points at the next joint away from it."""
        for k, joint in enumerate(chain[:-1]):
            target = next((j for j in chain[k + 1:] if tree.distance(j, joint) > MIN_BONE_M), None)
            if target is not None:
                rules[joint] = ([target], direction)

    pelvis, head, chest = index["pelvis"], index["head"], index["chest"]
    top = tree.pose.skeleton.common_ancestor(pelvis, head)
    along(tree.chain(top, head), UP)  # spine, chest, neck: straight up from where the legs meet the trunk
    rules.pop(pelvis, None)  # the hips, not a bone to the spine, set the pelvis (level, see _pair_rules)
    head_children = tree.leaf_targets(head)
    if len(head_children) == 1:  # an end site or one head-top joint; a face rig's many bones say nothing
        rules[head] = (head_children, UP)
    def limb(joints: list[int | None], direction: np.ndarray, end_direction: np.ndarray) -> None:
        """Upper -> lower -> end joint along ``direction``; the end joint's children along ``end_direction``."""
        upper, lower, end = joints
        if lower is None:
            return
        rules[upper] = ([lower], direction)
        if end is None:
            return
        rules[lower] = ([end], direction)
        beyond = tree.leaf_targets(end)  # toes, fingers
        if beyond:
            rules[end] = (beyond, end_direction)

    for side, sign in (("left", 1.0), ("right", -1.0)):
        limb([index.get(f"{side}_{part}") for part in ("upper_leg", "lower_leg", "foot")], DOWN, _foot_direction())
        upper_arm = index[f"{side}_upper_arm"]
        along(tree.chain(chest, upper_arm)[1:], _clavicle_direction(sign))  # clavicles: outwards, rising
        arm = _arm_direction(sign)
        limb([upper_arm, index.get(f"{side}_lower_arm"), index.get(f"{side}_hand")], arm, arm)
    return rules


def _pair_rules(tree: _Tree, index: Mapping[str, int]) -> dict[int, tuple[int, int]]:
    """joint -> (left, right): after its bone rule, turn the joint about the vertical so left - right is +y."""
    rules = {index["pelvis"]: (index["left_upper_leg"], index["right_upper_leg"])}
    chest = index["chest"]
    sides = []
    for side in ("left", "right"):
        chain = tree.chain(chest, index[f"{side}_upper_arm"])
        # the first joint away from the chest on the way to the arm: the clavicle's base, else the shoulder
        sides.append(next((j for j in chain[1:] if tree.distance(j, chest) > MIN_BONE_M), chain[-1] if chain else None))
    if None not in sides and sides[0] != sides[1]:
        rules[chest] = (sides[0], sides[1])
    return rules


def _body_alignment(pose: SkeletonPose, index: Mapping[str, int]) -> np.ndarray:
    """The rotation that stands the observed body up: hips' left-right to +y, pelvis-to-chest to +z."""
    p = pose.positions
    lateral = p[index["left_upper_leg"]] - p[index["right_upper_leg"]]
    if np.linalg.norm(lateral) < MIN_BONE_M:
        raise CanonicalPoseError("the left and right hip joints coincide; the pelvis has no left-right direction")
    y = lateral / np.linalg.norm(lateral)
    up = p[index["chest"]] - p[index["pelvis"]]
    z = up - np.dot(up, y) * y
    if np.linalg.norm(z) < MIN_BONE_M:
        z = np.cross(np.array([1.0, 0.0, 0.0]), y)  # chest at the pelvis or along the hips: any upright frame
        if np.linalg.norm(z) < 0.5:
            z = np.cross(y, np.array([0.0, 1.0, 0.0]))
    z /= np.linalg.norm(z)
    body = np.column_stack([np.cross(y, z), y, z])  # the body's axes in the world
    return quat_from_matrix(body.T)


def local_transforms(pose: SkeletonPose) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's translation (J, 3) and rotation (J, 4) in its parent's frame (the root's: world)."""
    parents = np.asarray(pose.skeleton.parents)
    translations = pose.positions.copy()
    rotations = pose.rotations.copy()
    child = parents >= 0
    inverse = quat_conjugate(pose.rotations[parents[child]])
    translations[child] = quat_rotate(inverse, pose.positions[child] - pose.positions[parents[child]])
    rotations[child] = quat_multiply(inverse, pose.rotations[child])
    return translations, rotations


def canonical_pose(pose: SkeletonPose, joint_map: Mapping[str, str]) -> SkeletonPose:
    """The standing figure of ``pose``'s skeleton (see the module doc); world frame, metres.

    ``pose``: any pose of the skeleton (a clip's frame, what /tf shows); only its bone translations
    and, for joints that carry no body segment, its parent-relative rotations are used.
    ``joint_map``: role -> joint name (``body.joint_map``); pelvis, chest, head, the upper and lower
    legs and the upper arms are required.
    """
    skeleton = pose.skeleton
    index = {role: skeleton.index(name) for role, name in joint_map.items()}
    tree = _Tree(pose)
    bones = _bone_rules(tree, index)
    pairs = _pair_rules(tree, index)
    translations, rotations = local_transforms(pose)
    # Where each rule's targets sit in the joint's own frame under the observed pose: fixed while the
    # joints between keep their relative rotations (rules on them act later, top-down).
    def in_frame(joint: int, targets: list[int]) -> np.ndarray:
        offsets = pose.positions[targets] - pose.positions[joint]
        return quat_rotate(quat_conjugate(pose.rotations[joint]), offsets.mean(axis=0))

    count = len(skeleton.names)
    world_q, local_q = np.empty((count, 4)), np.empty((count, 4))
    alignment = _body_alignment(pose, index)
    for i, parent in enumerate(skeleton.parents):
        q = quat_multiply(alignment, pose.rotations[i]) if parent < 0 else quat_multiply(world_q[parent], rotations[i])
        if i in bones:
            targets, direction = bones[i]
            bone = quat_rotate(q, in_frame(i, targets))
            if np.linalg.norm(bone) > MIN_BONE_M:
                q = quat_multiply(quat_between(bone, direction), q)
        if i in pairs:
            left, right = pairs[i]
            lateral = quat_rotate(q, in_frame(i, [left]) - in_frame(i, [right]))
            # about its bone when it has one (the chest: keep it upright), else level the pair outright
            turn = _turn_about(bones[i][1], lateral, LEFT) if i in bones else quat_between(lateral, LEFT)
            q = quat_multiply(turn, q)
        world_q[i] = q / np.linalg.norm(q)
        local_q[i] = world_q[i] if parent < 0 else quat_multiply(quat_conjugate(world_q[parent]), world_q[i])
    translations[np.asarray(skeleton.parents) < 0] = 0.0  # the root: placed by the shift below
    standing = forward_kinematics(skeleton, translations, local_q)
    shift = np.array([-standing.positions[index["pelvis"], 0], -standing.positions[index["pelvis"], 1],
                      -standing.positions[:, 2].min()])
    return SkeletonPose(skeleton, standing.positions + shift, standing.rotations)


def _turn_about(axis: np.ndarray, vector: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The rotation about ``axis`` that brings ``vector``'s part across the axis onto ``goal``'s."""
    axis = axis / np.linalg.norm(axis)
    a = vector - np.dot(vector, axis) * axis
    b = goal - np.dot(goal, axis) * axis
    if np.linalg.norm(a) < MIN_BONE_M or np.linalg.norm(b) < 1e-9:
        return IDENTITY_QUAT
    angle = math.atan2(float(np.dot(np.cross(a, b), axis)), float(np.dot(a, b)))
    return quat_from_axis_angle(axis, angle)
