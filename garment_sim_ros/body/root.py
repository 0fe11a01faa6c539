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
    yaw = float(headings(pose.frame(joint_map["left_upper_leg"])[0], pose.frame(joint_map["right_upper_leg"])[0]))
    return np.array(position, dtype=float), yaw


def headings(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Heading yaw (...,) rad from the left and right hip joints' positions (..., 3), m (any number of
    poses at once); ``ValueError`` when they coincide in the horizontal plane in any."""
    lateral = np.asarray(left) - np.asarray(right)
    if np.any(np.hypot(lateral[..., 0], lateral[..., 1]) < 1e-9):
        raise ValueError("root_frame: the hip joints coincide in the horizontal plane; heading undefined")
    return np.arctan2(-lateral[..., 0], lateral[..., 1])  # x = y cross z with y the leftward hip direction


def fit_root_kinematics(times: np.ndarray, positions: np.ndarray, yaws: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Velocity (3,) m/s, acceleration (3,) m/s^2, yaw rate rad/s and yaw acceleration rad/s^2 at time 0
    from root samples at ``times`` (K,) s relative to it: a least-squares quadratic (a line for two
    samples). ``positions`` (K, 3) m, ``yaws`` (K,) rad, unwrapped here. One estimator for the node's
    /tf buffer and the clips: mocap's millimetre jitter would read tens of m/s^2 in a three-point
    difference (1 mm over 1/60 s is 3.6 m/s^2), the fit over a window averages it out."""
    yaws = np.unwrap(np.asarray(yaws, dtype=float))
    degree = min(2, len(times) - 1)
    design = np.vander(np.asarray(times, dtype=float), degree + 1, increasing=True)
    coefficients = np.linalg.lstsq(design, np.column_stack([positions, yaws]), rcond=None)[0]
    velocity, yaw_rate = coefficients[1, :3], float(coefficients[1, 3])
    if degree == 2:
        return velocity, 2.0 * coefficients[2, :3], yaw_rate, 2.0 * float(coefficients[2, 3])
    return velocity, np.zeros(3), yaw_rate, 0.0
