"""Motion constraints (game cloth's safety net, as NvCloth and Chaos call it): every free point stays
within ``max_distance`` of its *skinned position*, where rigid skinning to the body would carry it.

Opt-in (``SolverParams.max_distance``, 0 = off): a constrained garment can no longer be left behind
by a limb (a trouser leg off its leg, a hip point thrown across a thigh) however fast the motion or
however the collision handling resolves a pinch, at the price of a cloth that swings at most that far
from the body. ``max_distance`` below a limb's radius keeps a tube's points on their own side of it.

The binding is made on the pose the garment is put on from (``GarmentSolver.reset``: the rest shape
round the canonical pose), each point to the body volume whose surface is nearest, in that volume's
frame; skinned positions then follow the volumes' poses in the simulation frame.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..collision.volumes import CAPSULE, SPHERE
from ..transforms import quat_conjugate, quat_rotate


def nearest_volumes(points: np.ndarray, volumes, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """For each point (N, 3), the volume (index) whose surface is nearest, the volumes posed at
    ``positions`` (V, 3), ``rotations`` (V, 4) xyzw in the points' frame.

    The distance is the surface distance scaled along the axes (exact for spheres, the sphere-like
    estimate ``(|l / radii| - 1) * smallest radius`` for ellipsoids, the tapered-axis distance less the
    larger radius for capsules), plus how far the point lies beyond an ellipsoid's cut: a point below a
    thigh's cut belongs to the shin."""
    distance = np.empty((len(points), len(volumes)))
    for v in range(len(volumes)):
        local = quat_rotate(quat_conjugate(rotations[v]), points - positions[v])
        radii = volumes.radii[v]
        if volumes.kinds[v] == CAPSULE:
            along = np.clip(local[:, 2], -radii[2], radii[2])
            off_axis = np.hypot(np.hypot(local[:, 0], local[:, 1]), local[:, 2] - along)
            distance[:, v] = off_axis - max(radii[0], radii[1])
            continue
        scaled = np.linalg.norm(local / radii, axis=1)
        distance[:, v] = (scaled - 1.0) * radii.min()
        if volumes.kinds[v] != SPHERE:
            low, high = volumes.cuts[v]
            distance[:, v] += np.maximum(0.0, np.maximum(local[:, 2] - high, low - local[:, 2]))
    return np.argmin(distance, axis=1)


class SkinBinding:
    """Points bound rigidly to body volumes: ``volume`` (N,) index, ``local`` (N, 3) m in its frame."""

    def __init__(self, points: np.ndarray, volumes, positions: np.ndarray, rotations: np.ndarray):
        self.volume = nearest_volumes(points, volumes, positions, rotations)
        inverse = quat_conjugate(rotations[self.volume])
        self.local = quat_rotate(inverse, points - positions[self.volume])

    def positions(self, volume_positions: np.ndarray, volume_rotations: np.ndarray) -> np.ndarray:
        """Skinned positions (N, 3) with the volumes at these poses (V, 3), (V, 4)."""
        return volume_positions[self.volume] + quat_rotate(volume_rotations[self.volume], self.local)


@njit(cache=True)
def limit_distance(x, skinned0, skinned1, fraction, max_distance, inv_mass):
    """Pull every free point (``inv_mass`` > 0) of ``x`` (N, 3) that is farther than ``max_distance`` (m)
    from its skinned position -- ``fraction`` of the way from ``skinned0`` to ``skinned1`` -- back onto
    that sphere. Returns the number of points moved."""
    moved = 0
    for i in range(x.shape[0]):
        if inv_mass[i] == 0.0:
            continue
        sx = skinned0[i, 0] + fraction * (skinned1[i, 0] - skinned0[i, 0])
        sy = skinned0[i, 1] + fraction * (skinned1[i, 1] - skinned0[i, 1])
        sz = skinned0[i, 2] + fraction * (skinned1[i, 2] - skinned0[i, 2])
        dx, dy, dz = x[i, 0] - sx, x[i, 1] - sy, x[i, 2] - sz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d <= max_distance:
            continue
        scale = max_distance / d
        x[i, 0] = sx + scale * dx
        x[i, 1] = sy + scale * dy
        x[i, 2] = sz + scale * dz
        moved += 1
    return moved
