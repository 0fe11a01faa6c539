"""A trunk narrowed to the motion it is driven with.

An arm bone inside a trunk volume, or nearer it than the cloth's ease, is inside the cloth lying on it
whatever the solver does (cmu_131's first pose: the right forearm 1.2 mm inside the pelvis volume; CC
02_04's: the left forearm 3 mm off it, where the one-piece squeezed between them slid round the elbow
and ended across the upper arm). Given poses the body will be driven with (``fit_body(motion=...)``),
each trunk volume an arm bone comes within ``BONE_CLEARANCE`` of is narrowed (its cross-section scaled)
until the bones clear it, but no narrower than a slim adult's (``NARROWEST_TRUNK_PER_STATURE``);
``Body.narrowed`` says by how much.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from ..collision.volumes import Volume
from ..transforms import quat_conjugate, quat_multiply, quat_rotate
from .aiming import FrameAim, aimed_frame_poses
from .skeleton import SkeletonPose

# Fitting to the motion (``fit_body(motion=...)``). The arm bones (joint-map roles, start and end):
ARM_BONES: tuple[tuple[str, str], ...] = (
    ("left_upper_arm", "left_lower_arm"), ("right_upper_arm", "right_lower_arm"),
    ("left_lower_arm", "left_hand"), ("right_lower_arm", "right_hand"),
)
# stay this far outside the trunk volumes: the skirts' and the one-piece's ease (12 and 15 mm), so a
# bone there passes outside the cloth lying on the trunk, m
BONE_CLEARANCE = 0.015
# and a trunk volume is narrowed no further than a slim adult's half width there, per stature (ANSUR II
# about the 1st percentile: hip breadth 0.17 H, waist breadth 0.14 H, chest breadth 0.148 H)
NARROWEST_TRUNK_PER_STATURE = {"pelvis": 0.085, "torso": 0.070, "chest": 0.074}
BONE_SAMPLES = 21  # points per bone checked
SCALE_BISECTIONS = 30  # 1e-9 of the scale


def narrow_for_motion(volumes: list[Volume], joint_map: Mapping[str, str], motion: Sequence[SkeletonPose],
                       stature: float, aims: Sequence[FrameAim] = ()) -> tuple[list[Volume], dict[str, float]]:
    """``volumes`` with each trunk volume's cross-section (``radii`` x, y) scaled down so that, in every
    pose of ``motion``, the arm bones stay ``BONE_CLEARANCE`` outside it, but no narrower than
    ``NARROWEST_TRUNK_PER_STATURE``; and the scales used (volume name -> scale < 1). Such a volume is
    wider than this subject where the arm rests (a slim subject's hand by the hip). ``aims``: the frames turned
    onto the spine chain (``body.aiming``), as the volumes will ride them."""
    bones = [(joint_map[a], joint_map[b]) for a, b in ARM_BONES if a in joint_map and b in joint_map]
    if not motion or not bones:
        return volumes, {}
    skeleton = motion[0].skeleton
    ends = np.array([[skeleton.index(a), skeleton.index(b)] for a, b in bones])
    along = np.linspace(0.0, 1.0, BONE_SAMPLES)[None, None, :, None]
    positions = np.array([pose.positions for pose in motion])  # (P, J, 3)
    starts, stops = positions[:, ends[:, 0], None, :], positions[:, ends[:, 1], None, :]
    points = (starts + along * (stops - starts)).reshape(len(motion), -1, 3)  # (P, B * samples, 3) world
    narrowed: dict[str, float] = {}
    result = []
    for volume in volumes:
        if volume.name in NARROWEST_TRUNK_PER_STATURE:
            frame_poses = [aimed_frame_poses(pose, (volume.frame,), aims) for pose in motion]
            origins, rotations = np.array([p[0] for p, _ in frame_poses]), np.array([q[0] for _, q in frame_poses])
            centre = origins + quat_rotate(rotations, np.asarray(volume.offset_position))
            to_local = quat_conjugate(quat_multiply(rotations, np.asarray(volume.offset_rotation)))
            local = quat_rotate(to_local[:, None, :], points - centre[:, None, :]).reshape(-1, 3)
            narrowest = NARROWEST_TRUNK_PER_STATURE[volume.name] * stature / volume.radii[1]
            scale = max(min(1.0, narrowest), _cross_section_scale(volume, local, BONE_CLEARANCE))
            if scale < 1.0:
                rx, ry, rz = volume.radii
                volume = replace(volume, radii=(scale * rx, scale * ry, rz))
                narrowed[volume.name] = float(scale)
        result.append(volume)
    return result, narrowed


def _cross_section_scale(volume: Volume, local: np.ndarray, clearance: float) -> float:
    """The largest factor (<= 1) on the ellipsoid's x and y radii that leaves every local point (N, 3)
    within its cut at least ``clearance`` outside it (the cross-section grown by ``clearance``, a close
    bound of the distance for the long trunk volumes); 0 if a point is on its axis."""
    rx, ry, rz = volume.radii
    room = 1.0 - (local[:, 2] / rz) ** 2
    keep = (local[:, 2] >= volume.cut[0]) & (local[:, 2] <= volume.cut[1]) & (room > 0.0)
    x, y, room = np.abs(local[keep, 0]), np.abs(local[keep, 1]), room[keep]

    def outside(scale):
        return (x / (scale * rx + clearance)) ** 2 + (y / (scale * ry + clearance)) ** 2 >= room

    low, high = np.zeros(len(x)), np.ones(len(x))
    fine = outside(high)
    for _ in range(SCALE_BISECTIONS):  # the outside test is monotone in the scale: bisect per point
        middle = 0.5 * (low + high)
        out = outside(middle)
        low, high = np.where(out, middle, low), np.where(out, high, middle)
    return float(np.min(np.where(fine, 1.0, low), initial=1.0))
