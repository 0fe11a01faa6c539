"""The volumes as the collision kernels read them: one bundle of flat arrays, ``VolumeArrays``.

A named tuple of arrays, which numba passes to a kernel as one argument and reads by field name: every
kernel takes the volumes first, then the points in one order (start positions, positions, velocities,
inverse masses, substep length), and a field added here reaches the kernels without touching their
callers. The shape arrays come from the ``VolumeSet``; the pose arrays belong to the ``Collider``, which
rewrites them in place every substep (``Collider.begin_substep``), so the bundle itself never changes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .broad_phase import local_boxes
from .volumes import VolumeSet

MAX_PLANES = 4  # contact planes per volume (``collision.contact_planes``): a forearm on the hip and the chest, ...


class VolumeArrays(NamedTuple):
    """Volumes (V of them) and their poses over one substep; lengths in metres, the simulation frame."""

    kinds: np.ndarray  # (V,) int64: SPHERE, ELLIPSOID or CAPSULE (``volumes``)
    radii: np.ndarray  # (V, 3) m, local geometry as in ``volumes``
    cuts: np.ndarray  # (V, 2) m, an ellipsoid's kept local z range
    bounding_radii: np.ndarray  # (V,) m, a sphere about the local origin holding the volume; inf: broad phase off
    switch_radii: np.ndarray  # (V,) m, the adaptive static/dynamic switch's radius (``Volume.radius``)
    bones: np.ndarray  # (V, 2) m, local z range of the volume's bone; NaN: none
    boxes: np.ndarray  # (V, 6) m, local box (``broad_phase.local_boxes``); infinite: broad phase off
    pos0: np.ndarray  # (V, 3) m, positions at the substep's start
    rot0: np.ndarray  # (V, 3, 3) rotation matrices (local -> simulation frame) at the substep's start
    pos1: np.ndarray  # (V, 3) m, positions at the substep's end
    rot1: np.ndarray  # (V, 3, 3) rotation matrices at the substep's end
    displacement: np.ndarray  # (V,) m, centre displacement over the substep (``broad_phase.substep_motion``)
    chord: np.ndarray  # (V,) rotation chord 2 sin(angle / 2) over the substep, with a rounding margin
    reach: np.ndarray  # (V,) m, beyond this from a volume's end centre no point can touch it (``reach_radii``)
    # (V, MAX_PLANES, 4) contact planes in the local frame, (unit normal out of the kept side, offset m): a point
    # p is beyond one where n . p > offset; used rows first, an offset of +inf ends them (``contact_planes``)
    planes: np.ndarray
    # (V, V) m: how deep a corner of a triangle moved off volume v's bone may be put into volume o (row v,
    # column o; ``crossing``): ``pinch_depth``, or ``pressed_pinch_depth`` for a pair that may be pressed together
    pinch_depths: np.ndarray
    # (V,) bool: the bone's far end is a hand's, which pushes the cloth it pokes into ahead of it (``crossing``)
    pushes_ahead: np.ndarray

    @classmethod
    def at_rest(cls, volumes: VolumeSet) -> VolumeArrays:
        """Fresh arrays for ``volumes``: their shapes and local boxes, every pose the identity."""
        n = len(volumes)
        kinds = np.ascontiguousarray(volumes.kinds, dtype=np.int64)
        radii = np.ascontiguousarray(volumes.radii, dtype=np.float64)
        cuts = np.ascontiguousarray(volumes.cuts, dtype=np.float64)
        boxes = np.zeros((n, 6))
        local_boxes(kinds, radii, cuts, boxes)
        return cls(kinds, radii, cuts, np.ascontiguousarray(volumes.bounding_radii, dtype=np.float64),
                   np.ascontiguousarray(volumes.switch_radii, dtype=np.float64),
                   np.ascontiguousarray(volumes.bones, dtype=np.float64), boxes,
                   np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                   np.zeros(n), np.zeros(n), np.zeros(n), no_planes(n), np.zeros((n, n)),
                   volumes.forearms())

    def unbounded(self) -> VolumeArrays:
        """The same arrays (poses shared) with infinite bounding radii and boxes: every broad-phase test
        passes, to check that the broad phase changes nothing."""
        n = len(self.kinds)
        return self._replace(bounding_radii=np.full(n, np.inf),
                             boxes=np.repeat([[-np.inf] * 3 + [np.inf] * 3], n, axis=0))


def no_planes(n_volumes: int) -> np.ndarray:
    """Contact planes (``VolumeArrays.planes``) of ``n_volumes`` volumes, none used."""
    planes = np.zeros((n_volumes, MAX_PLANES, 4))
    planes[:, :, 3] = np.inf
    return planes
