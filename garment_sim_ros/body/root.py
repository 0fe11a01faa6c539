"""The root frame of a posed skeleton: where the garment's simulation frame sits.

Origin at the pelvis joint; heading (yaw about world +z) from the hip joints, so that x
points forward, y to the character's left, z up (REP-103). Only the heading is taken from
the pelvis orientation: pelvis pitch and roll in motion capture are small and noisy, and
the garment feels them through the volumes and attachments anyway.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .skeleton import SkeletonPose


def root_frame(pose: SkeletonPose, joint_map: Mapping[str, str]) -> tuple[np.ndarray, float]:
    """Root position (3,) in metres and heading yaw in radians."""
    position = pose.frame(joint_map["pelvis"])[0]
    left = pose.frame(joint_map["left_upper_leg"])[0]
    right = pose.frame(joint_map["right_upper_leg"])[0]
    lateral = left - right
    if np.hypot(lateral[0], lateral[1]) < 1e-9:
        raise ValueError("root_frame: the hip joints coincide in the horizontal plane; heading undefined")
    # x = y cross z with y the leftward hip direction.
    yaw = float(np.arctan2(-lateral[0], lateral[1]))
    return np.array(position, dtype=float), yaw
