"""Trunk frames aimed along the spine chain they carry a volume over (issue 11).

A trunk volume spans a segment of the spine that a rig may split into several bones: Character
Creator's torso runs from ``CC_Base_Waist`` over ``Spine01`` to ``Spine02`` (the chest), and its first
bone, 5 cm long, leans 38-47 deg off the trunk in the clips' motion while the 15 cm bone above it
stays within 11 deg. A volume riding rigidly on the first joint's frame follows that short bone, and
the torso stood 40-56 deg off the pelvis-to-neck line on every CC clip. So such a frame is aimed: at
every pose its rotation is turned, by the smallest rotation, so that the direction it had to the
segment's top joint in the rest pose points at that joint again. The frame keeps its joint's position
and its twist about the segment; volumes and garment attachments (a skirt's waistband on the spine
segment) on the frame follow the chain's chord. In the rest pose the turn is the identity.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..collision.volumes import VolumeSet
from ..transforms import quat_between, quat_multiply, quat_rotate
from .skeleton import SkeletonPose

MIN_AIM_M = 1e-6  # a target this close to its frame's joint gives no direction: the frame is left as is


@dataclass(frozen=True)
class FrameAim:
    """Frame ``frame`` turned to keep ``direction`` (unit, in its own axes: where ``target``'s joint lay in the
    rest pose) pointing at the joint ``target``."""

    frame: str
    target: str
    direction: tuple[float, float, float]


def aimed_frame_poses(pose: SkeletonPose, frames: Sequence[str], aims: Sequence[FrameAim] = ()
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Positions (F, 3) and rotations (F, 4) of ``frames`` at ``pose``, the ones ``aims`` names turned onto their
    targets."""
    skeleton = pose.skeleton
    index = [skeleton.index(f) for f in frames]
    positions, rotations = pose.positions[index], pose.rotations[index].copy()
    for aim in aims:
        if aim.frame not in frames:
            continue
        row = frames.index(aim.frame)
        towards = pose.positions[skeleton.index(aim.target)] - positions[row]
        if np.linalg.norm(towards) > MIN_AIM_M:
            was = quat_rotate(rotations[row], np.asarray(aim.direction))
            rotations[row] = quat_multiply(quat_between(was, towards), rotations[row])
    return positions, rotations


def volume_poses(volumes: VolumeSet, pose: SkeletonPose) -> tuple[np.ndarray, np.ndarray]:
    """Every volume's centre (V, 3) and rotation (V, 4) xyzw in the world at ``pose``, on its frame aimed as
    ``volumes.aims`` says."""
    return volumes.world_poses(*aimed_frame_poses(pose, volumes.frames, volumes.aims))
