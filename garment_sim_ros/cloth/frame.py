"""The frame contract of the garment solver (Warp's ``State`` / ``Control`` split): what the solver
reads per frame (``FrameInput``: the character between two frames), what changes on the garment
(``ClothState``: all of it, so that a copy is a snapshot) and what a frame reports (``FrameReport``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class ClothState:
    """All that changes from frame to frame on one garment (Warp's ``State``): a copy is the whole of it,
    which is what the step's guard keeps as the last good state and puts back."""

    positions: np.ndarray  # (N, 3) simulation (root) frame, m
    velocities: np.ndarray  # (N, 3) relative to the simulation frame, m/s
    # (N, C) int64: per point, the volumes it touched lately, most recent first, -1 empty -- the collision's
    # temporal coherence (``Collider.new_contacts``); C = 0 for a garment without volumes
    contacts: np.ndarray
    time: float = 0.0  # body time of the last frame, s
    lag: float = 0.0  # how far the simulated time is behind the body's time, s

    def copy(self) -> ClothState:
        """An independent copy."""
        return ClothState(self.positions.copy(), self.velocities.copy(), self.contacts.copy(), self.time, self.lag)


@dataclass(frozen=True, kw_only=True)
class FrameInput:
    """The character between two frames (Warp's ``Control``); world frame, SI units. Keyword-only:
    fourteen fields of like types are too easy to swap by position; ``between`` builds it from the
    two ends' (root motion, frame poses) pairs.

    ``frame_positions*``/``frame_rotations*`` are the poses of ``GarmentSolver.frames``, in that order.
    """

    t0: float  # s
    t1: float  # s
    root_position0: np.ndarray  # (3,) m, at t0
    root_yaw0: float  # rad, at t0
    root_position1: np.ndarray  # (3,) m, at t1
    root_yaw1: float  # rad, at t1
    root_velocity: np.ndarray  # (3,) v0 at t0, m/s
    root_acceleration: np.ndarray  # (3,) a0, m/s^2
    yaw_rate: float  # rad/s at t0
    yaw_acceleration: float  # rad/s^2
    frame_positions0: np.ndarray  # (F, 3) m, at t0
    frame_rotations0: np.ndarray  # (F, 4) xyzw, at t0
    frame_positions1: np.ndarray  # (F, 3) m, at t1
    frame_rotations1: np.ndarray  # (F, 4) xyzw, at t1

    @classmethod
    def between(cls, *, t0: float, motion0, poses0: tuple[np.ndarray, np.ndarray], t1: float, motion1,
                poses1: tuple[np.ndarray, np.ndarray]) -> FrameInput:
        """From the root motions at both ends (``body.pose_buffer.RootMotion``: position, yaw, and at
        the start velocity, acceleration, yaw rate and yaw acceleration: the memo's v0, a0) and the
        frames' (positions, rotations) at both ends."""
        return cls(t0=t0, t1=t1, root_position0=motion0.position, root_yaw0=motion0.yaw,
                   root_position1=motion1.position, root_yaw1=motion1.yaw, root_velocity=motion0.velocity,
                   root_acceleration=motion0.acceleration, yaw_rate=motion0.yaw_rate,
                   yaw_acceleration=motion0.yaw_acceleration, frame_positions0=poses0[0],
                   frame_rotations0=poses0[1], frame_positions1=poses1[0], frame_rotations1=poses1[1])


@dataclass
class FrameReport:
    substeps: int = 0  # of the try kept (``GarmentSolver.advance``'s frame retries)
    retries: int = 0  # times the frame ran again with twice the substeps (``GarmentSolver.RETRY_STRETCH``)
    retries_cut: bool = False  # a further try was due but ``retry_budget`` (s) would have been passed
    replays: int = 0  # times this frame and those before it ran again with more substeps (``replay_frames``)
    substep_s: float = 0.0
    simulated_s: float = 0.0
    lag_s: float = 0.0
    teleported: bool = False
    integration_s: float = 0.0  # forces + explicit step + velocities (wall time)
    correction_s: float = 0.0  # Provot length correction (wall time)
    collision_s: float = 0.0  # contact + full collision handling (wall time)
    static_hits: int = 0
    dynamic_hits: int = 0
    # m, the deepest overlap of two body volumes pressed onto a contact plane during the frame (flesh given way,
    # ``collision.contact_planes``): depth (a) is measured against the volumes as pressed
    pressed_depth_m: float = 0.0
    max_stretch: float = 0.0  # largest structural/shear length / rest length after the frame
    # the step's guard (``GarmentSolver.advance``): "" (a good step), "restored" (the step went
    # non-finite: the last good state is back) or "refitted" (runaway stretch: the rest shape at the new pose)
    recovery: str = ""
    # the garment was carried rigidly with the body this frame, not simulated: a runaway whose re-dress onto
    # the pose was not clean (``DressedCharacter``); its last clean dressing skinned onto the pose
    carried: bool = False
    # How well the garment stays on after the frame (``garment_sim_ros.quality``); filled by
    # ``DressedCharacter.step``, which has the pose (0 where the solver runs alone).
    max_depth_m: float = 0.0  # (a) deepest free point inside a body volume, m
    # deepest centre of a triangle with no attached vertex inside a body volume, m: the body bulging through the
    # cloth between points that are all outside (reported, not a target; ``quality``)
    surface_depth_m: float = 0.0
    bones_through: int = 0  # (b) limb bone segments (thighs, shins, upper arms, forearms, spine) crossing a triangle
    legs_off: int = 0  # (c) trouser legs (limb tubes) with a ring round none of their limb's volumes; 0 without
    structural_stretch_p99: float = 0.0  # (d) 99th percentile of structural spring length / rest length
    structural_stretch_max: float = 0.0  # (d) largest structural length / rest length
    shear_stretch_p99: float = 0.0  # (d) 99th percentile of shear spring length / rest length
    shear_stretch_max: float = 0.0  # (d) largest shear length / rest length
    layer_crossings: int = 0  # (f) edges of the garment crossing a triangle of one worn under it (outfits)
