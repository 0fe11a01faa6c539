"""Skeleton topology and posed skeletons, the common currency of every motion source.

A ``Skeleton`` is the joint tree; a ``SkeletonPose`` is that tree posed in the fixed (world)
frame: z up, metres (REP-103). Motion sources (BVH player, procedural walker, the /tf pose
buffer) all produce ``SkeletonPose`` objects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .. import quat_kernels as quat
from ..transforms import quat_rotate


@dataclass(frozen=True)
class Skeleton:
    """Joint tree. ``parents[i] < i`` (topological order); ``-1`` marks the root."""

    names: tuple[str, ...]
    parents: tuple[int, ...]

    def __post_init__(self):
        if len(self.names) != len(self.parents):
            raise ValueError("Skeleton: names and parents differ in length")
        if len(set(self.names)) != len(self.names):
            raise ValueError("Skeleton: joint names must be unique")
        for i, p in enumerate(self.parents):
            if not -1 <= p < i:
                raise ValueError(f"Skeleton: joint {self.names[i]!r} has parent index {p}, must be in [-1, {i})")

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"unknown joint {name!r}; known: {', '.join(self.names)}") from None

    def children(self, i: int) -> list[int]:
        return [j for j, p in enumerate(self.parents) if p == i]

    def ancestors(self, i: int) -> list[int]:
        """Joint ``i``'s parent, its parent's parent, ... up to the root."""
        chain = []
        while self.parents[i] >= 0:
            i = self.parents[i]
            chain.append(i)
        return chain

    def common_ancestor(self, a: int, b: int) -> int:
        """The deepest joint with both ``a`` and ``b`` below it (or one of them)."""
        above_a = {a, *self.ancestors(a)}
        for j in (b, *self.ancestors(b)):
            if j in above_a:
                return j
        raise ValueError(f"Skeleton: joints {self.names[a]!r} and {self.names[b]!r} are in different trees")


@dataclass
class SkeletonPose:
    """A skeleton posed in the world frame: joint positions (J, 3) in metres, rotations (J, 4) xyzw."""

    skeleton: Skeleton
    positions: np.ndarray
    rotations: np.ndarray

    def frame(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        i = self.skeleton.index(name)
        return self.positions[i], self.rotations[i]


def forward_kinematics(
    skeleton: Skeleton, local_positions: np.ndarray, local_rotations: np.ndarray
) -> SkeletonPose:
    """Compose local joint transforms (relative to the parent; the root's relative to the world)."""
    count = len(skeleton.names)
    positions = np.empty((count, 3))
    rotations = np.empty((count, 4))
    compose_tree(np.asarray(skeleton.parents, dtype=np.int64), np.ascontiguousarray(local_positions, dtype=float),
                   np.ascontiguousarray(local_rotations, dtype=float), positions, rotations)
    return SkeletonPose(skeleton, positions, rotations)


@njit(cache=True)
def compose_tree(parents, local_positions, local_rotations, positions, rotations):
    """Forward kinematics in topological order (parents before children, -1 for a root, whose pose
    is its local one); quaternions xyzw; writes ``positions`` (J, 3) and ``rotations`` (J, 4)."""
    for i in range(parents.shape[0]):
        p = parents[i]
        if p < 0:
            positions[i] = local_positions[i]
            rotations[i] = local_rotations[i]
            continue
        qx, qy, qz, qw = rotations[p, 0], rotations[p, 1], rotations[p, 2], rotations[p, 3]
        ox, oy, oz = quat.rotate(qx, qy, qz, qw, local_positions[i, 0], local_positions[i, 1], local_positions[i, 2])
        positions[i, 0] = positions[p, 0] + ox
        positions[i, 1] = positions[p, 1] + oy
        positions[i, 2] = positions[p, 2] + oz
        bx, by, bz, bw = local_rotations[i, 0], local_rotations[i, 1], local_rotations[i, 2], local_rotations[i, 3]
        rotations[i, 0], rotations[i, 1], rotations[i, 2], rotations[i, 3] = quat.multiply(qx, qy, qz, qw,
                                                                                          bx, by, bz, bw)


def offsets_pose(pose: SkeletonPose) -> SkeletonPose:
    """The rest pose of a posed skeleton: its bone offsets (each child's position in its parent's
    frame, constant for a rigid skeleton) with every rotation identity, the root at the origin.

    For BVH clips this is the OFFSETS pose (a T-pose for CMU); it lets a consumer that only sees
    posed skeletons (the node, from /tf) fit bodies and garments to the same rest pose as the clip's.
    """
    from ..transforms import IDENTITY_QUAT, quat_conjugate

    skeleton = pose.skeleton
    count = len(skeleton.names)
    local = np.zeros((count, 3))
    for i, parent in enumerate(skeleton.parents):
        if parent >= 0:
            local[i] = quat_rotate(quat_conjugate(pose.rotations[parent]), pose.positions[i] - pose.positions[parent])
    return forward_kinematics(skeleton, local, np.tile(IDENTITY_QUAT, (count, 1)))
