"""Quadric bounding volumes attached to skeleton frames (memo §6.1).

Each volume has its own local frame, fixed relative to the skeleton frame it is attached to
(``offset_position``, ``offset_rotation``). In that local frame:

- ``SPHERE``: centre at the origin, radius ``radii[0]`` (``radii = (r, r, r)``).
- ``ELLIPSOID``: ``(x/a_x)^2 + (y/a_y)^2 + (z/a_z)^2 < 1`` with ``radii = (a_x, a_y, a_z)``,
  elongated along z (the segment axis), both ends cut: a point counts only where
  ``cut[0] <= z <= cut[1]`` (memo Eq. 6-3, 6-4).
- ``CAPSULE``: tapered capsule, the union of spheres swept from ``z = -radii[2]`` (radius
  ``radii[0]``) to ``z = +radii[2]`` (radius ``radii[1]``) — NvCloth/Unity style.

Lengths are metres. ``VolumeSet`` packs the volumes into flat arrays for the numba kernels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..transforms import IDENTITY_QUAT, quat_multiply, quat_normalize, quat_rotate

SPHERE = 0
ELLIPSOID = 1
CAPSULE = 2
KIND_NAMES = {"sphere": SPHERE, "ellipsoid": ELLIPSOID, "capsule": CAPSULE}


@dataclass(frozen=True)
class Volume:
    name: str
    kind: int
    frame: str  # skeleton frame the volume is attached to
    radii: tuple[float, float, float]
    cut: tuple[float, float] = (-np.inf, np.inf)  # ELLIPSOID only: kept z range, local metres
    offset_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset_rotation: tuple[float, float, float, float] = tuple(IDENTITY_QUAT)
    # local z range of the bone the volume is fitted round (limbs, the spine), on its local z axis; None: none.
    # A bone may not pass through the cloth (``crossing.handle_axes``).
    bone: tuple[float, float] | None = None

    def __post_init__(self):
        if self.kind not in (SPHERE, ELLIPSOID, CAPSULE):
            raise ValueError(f"volume {self.name!r}: kind must be one of {sorted(KIND_NAMES)}, got {self.kind!r}")
        radii = np.asarray(self.radii, dtype=float)
        if radii.shape != (3,) or not np.all(np.isfinite(radii)) or np.any(radii <= 0.0):
            raise ValueError(f"volume {self.name!r}: radii must be three positive finite lengths (m), got {self.radii}")
        if self.kind == SPHERE and not np.allclose(radii, radii[0]):
            raise ValueError(f"volume {self.name!r}: a sphere has equal radii, got {self.radii}")
        lo, hi = self.cut
        if not lo < hi:
            raise ValueError(f"volume {self.name!r}: cut must satisfy cut[0] < cut[1], got {self.cut}")
        if self.kind == ELLIPSOID and (hi <= -radii[2] or lo >= radii[2]):
            raise ValueError(f"volume {self.name!r}: cut {self.cut} leaves nothing of an ellipsoid with a_z={radii[2]}")
        if self.bone is not None and not (len(self.bone) == 2 and np.all(np.isfinite(self.bone))
                                          and self.bone[0] < self.bone[1]):
            raise ValueError(f"volume {self.name!r}: bone must be None or a local z range (lo, hi), lo < hi, "
                             f"got {self.bone}")
        q = np.asarray(self.offset_rotation, dtype=float)
        if q.shape != (4,) or abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise ValueError(f"volume {self.name!r}: offset_rotation must be a unit quaternion (x, y, z, w)")

    @property
    def bounding_radius(self) -> float:
        """Radius of a sphere about the local origin that encloses the volume (broad phase)."""
        r = np.asarray(self.radii, dtype=float)
        if self.kind == SPHERE:
            return float(r[0])
        if self.kind == ELLIPSOID:
            return float(r.max())
        return float(r[2] + max(r[0], r[1]))

    @property
    def radius(self) -> float:
        """The radius used by the adaptive switch (memo §6.2.1): the smallest cross-section radius."""
        r = np.asarray(self.radii, dtype=float)
        if self.kind == ELLIPSOID:
            return float(min(r[0], r[1]))
        if self.kind == CAPSULE:
            return float(min(r[0], r[1]))
        return float(r[0])


@dataclass(frozen=True)
class VolumeSet:
    """An immutable set of volumes and the flat arrays the kernels read."""

    volumes: tuple[Volume, ...]
    # the volumes' poses in the pose they were fitted on (the canonical standing pose): positions (V, 3) m and
    # xyzw quaternions (V, 4), world frame; None: unknown. Which volumes are disjoint there decides which may be
    # pressed together in motion (``collision.contact_planes``); without them no pair is.
    rest_poses: tuple[np.ndarray, np.ndarray] | None = field(default=None, compare=False, repr=False)
    # frames turned onto a joint of the spine chain at every pose (``body.aiming.FrameAim``): the poses given to
    # ``world_poses`` are ``body.aiming.aimed_frame_poses``'; empty: every frame as the skeleton has it
    aims: tuple = ()
    frames: tuple[str, ...] = field(init=False)  # distinct skeleton frames, in first-use order
    frame_index: np.ndarray = field(init=False)  # (V,) index into ``frames``
    kinds: np.ndarray = field(init=False)  # (V,) int64
    radii: np.ndarray = field(init=False)  # (V, 3)
    cuts: np.ndarray = field(init=False)  # (V, 2)
    bounding_radii: np.ndarray = field(init=False)  # (V,)
    switch_radii: np.ndarray = field(init=False)  # (V,)
    bones: np.ndarray = field(init=False)  # (V, 2) local z range of each volume's bone, m; NaN: none
    offset_positions: np.ndarray = field(init=False)  # (V, 3)
    offset_rotations: np.ndarray = field(init=False)  # (V, 4)

    def __post_init__(self):
        names = [v.name for v in self.volumes]
        if len(set(names)) != len(names):
            raise ValueError(f"volume names must be unique: {names}")
        frames: list[str] = []
        for v in self.volumes:
            if v.frame not in frames:
                frames.append(v.frame)
        set_ = object.__setattr__
        set_(self, "frames", tuple(frames))
        set_(self, "frame_index", np.array([frames.index(v.frame) for v in self.volumes], dtype=np.int64))
        set_(self, "kinds", np.array([v.kind for v in self.volumes], dtype=np.int64))
        set_(self, "radii", np.array([v.radii for v in self.volumes], dtype=float).reshape(-1, 3))
        set_(self, "cuts", np.array([v.cut for v in self.volumes], dtype=float).reshape(-1, 2))
        set_(self, "bounding_radii", np.array([v.bounding_radius for v in self.volumes], dtype=float))
        set_(self, "switch_radii", np.array([v.radius for v in self.volumes], dtype=float))
        set_(self, "bones", np.array([v.bone if v.bone is not None else (np.nan, np.nan) for v in self.volumes],
                                     dtype=float).reshape(-1, 2))
        set_(self, "offset_positions", np.array([v.offset_position for v in self.volumes], dtype=float).reshape(-1, 3))
        set_(self, "offset_rotations", quat_normalize(
            np.array([v.offset_rotation for v in self.volumes], dtype=float).reshape(-1, 4)))

    def __len__(self) -> int:
        return len(self.volumes)

    def at_rest_in(self, frame_positions: np.ndarray, frame_rotations: np.ndarray) -> VolumeSet:
        """The same volumes, with ``rest_poses`` the poses the frames (``self.frames``' order) put them in."""
        return VolumeSet(self.volumes, self.world_poses(frame_positions, frame_rotations), self.aims)

    def names(self) -> list[str]:
        return [v.name for v in self.volumes]

    def forearms(self) -> np.ndarray:
        """(V,) bool: the forearms' volumes (``body.fitting`` names them ``<side>_lower_arm``), whose bone ends at
        a hand: cloth is pushed past that end (``crossing``), a waistband gives way under them (``band_gives_way``)."""
        return np.array([v.name.endswith("_lower_arm") for v in self.volumes], dtype=np.bool_)

    def world_poses(self, frame_positions: np.ndarray, frame_rotations: np.ndarray):
        """Volume poses from the poses of ``self.frames`` (arrays (F, 3), (F, 4), same order)."""
        fp = np.asarray(frame_positions, dtype=float)[self.frame_index]
        fq = np.asarray(frame_rotations, dtype=float)[self.frame_index]
        return fp + quat_rotate(fq, self.offset_positions), quat_multiply(fq, self.offset_rotations)
