"""The relative garment solver (memo §3–§5): ``GarmentSolver.advance(FrameInput)`` runs one frame.

The garment lives in the *simulation frame*: the root frame (pelvis position, heading about
z; see ``body.root``). The memo simulates in a frame that follows the root's translation and
adds the inertial force ``-m a0`` and the drag of the character's own travel (Eq. 4-2); here
the frame also turns with the heading, which adds the Euler, centrifugal and Coriolis forces
(the memo's future work). ``linear_inertia_scale`` and ``angular_inertia_scale`` (0..1) scale
how much of the root's motion the garment feels, as NvCloth and Unity expose it. Because the
state is stored relative to the root, the memo's final step (translate every point by the
root's displacement ``dx``) is the conversion to world coordinates in ``world_positions``,
using the root's actual pose rather than the estimate ``v0 dt + a0 dt^2 / 2``.

Integration. The memo's Eq. 5-1 (``x += v h + F/(2m) h^2``) combined literally with Eq. 5-2
(``v = (x_corrected - x_start) / h``) only ever adds half of ``F/m h`` to the velocity: a free
fall accelerates at g/2. We keep Eq. 5-2 and advance positions by symplectic Euler,
``x += (v + F/m h) h``, for which an unconstrained point gets exactly ``v += F/m h`` and a point
held still by the length correction or a contact ends the step with zero velocity.

Per substep (memo §3 steps 2–5): forces, explicit step, attached points set to their
segment, Provot length correction (each iteration followed by the tethers, ``cloth.model``) with
contact handling after its first iteration, velocity from the corrected positions, full collision
handling; then (beyond the memo) strain limiting as the substep's last projection. With volumes, ``advance`` runs the
substeps in one compiled call (``cloth.fused``, the same kernels in the same order); its loop is the reference.

Strain limiting after collision. Collision handling comes after the length correction and moves
points out of the volumes one by one, so it stretches the springs between a point it moved and
one it did not; more correction iterations before it do not help (measured on issue 11: a long
skirt's p99 stretch 1.42 with 4 iterations, 1.47 with 24). So after the collision handling the
length correction runs again, with the points the handling moved (in contact) taking only
``contact_mobility`` of their share, so the free cloth gives way rather than the contacts, and the
cached contacts handled after every sweep, so that the contacts are constraints of the same
projection: the correction alone shortens a spring wrapped round a limb straight through it, and
the handling after it undid its work (issue 11, xia_angry's long skirt, 8 sweeps, the worst substep's
p99 stretch 1.06 after them and 1.23 after the handling; the worst frame's 1.22, 1.10 with the
contacts handled between the sweeps). It stops once no spring is longer than
``1 + limit_ratio + strain_limit_tolerance`` times its rest length. The displacement counts as
velocity (``v += dx / h``, as the rest of the step's corrections do); the collision handling (points,
then edges) runs once more, and a point it then leaves inside a volume (squeezed where two volumes
meet) goes back to where it was; if a spring then ends longer than ``STRAIN_LIMIT_UNDONE`` and than
the longest before, the substep keeps the state from before the limiting, but for the points inside a volume
there that the limiting's handling took out (``kernels.undo_limiting``).

Frame retries and replays (``frame_retries``, ``replay_frames``, beyond the memo): a frame that tears the
cloth or lets a bone through runs again with more substeps, and the frames before it with it where that does not
mend it (``cloth.retries``).

Torn springs in a pinch (``tear_give_stretch``, beyond the memo): a spring the strain limiting leaves longer than
that, its ends held on two volumes that squeeze the cloth, is shortened into its ends' contact room, half
``collision_epsilon`` an end, no point into a volume (``Collider.give_room_to_tears``).

Sliding, opt-in (``strain_limit_slide``): the strain limiting's contact handling is static, a point the
correction pulled into a volume going out across the nearest surface, not back to the side it came from at the
substep's start, so that cloth pulled taut across a limb slides off it rather than being carried round it
(issue 11, the cartwheel's long skirt upside down over the chest and arm: springs 2.3-3.1x after every sweep's
handling, 1.3x after its correction; the whole clip's worst p99 2.03 -> 1.07 at 1x 60 fps). A garment with
limb tubes (trousers) keeps the side: slid across a thigh, its cloth takes the crotch with it (CC jump, 1x 60
fps, 3 s: 4 -> 11 bone frames). Off by default: the one-piece gets worse (the cartwheel at 1x 60 fps, bone
frames 2 -> 15; docs/real_motion.md).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..params import DEFAULT_PARAMS, SolverParams
from ..transforms import quat_conjugate, quat_multiply, transform_points, yaw_quat
from . import fused, kernels
from .frame import ClothState, FrameInput, FrameReport
from .halves import ParallelLayout
from .model import (
    BEND,
    SHEAR,
    STRETCH_MAX_TARGET,
    STRUCTURAL,
    ClothModel,
    stretch_groups,
)
from .motion_constraints import SkinBinding, limit_distance
from .retries import FrameRetries, PlannedFrame

_NO_ROTATIONS = np.zeros((0, 4))


@dataclass(frozen=True)
class DerivedConstants:
    """Parameter-dependent arrays (recomputed when parameters change)."""

    mass: np.ndarray
    inv_mass: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    limited_springs: int  # springs whose stiffness or damping was capped for stability


def derive_constants(model: ClothModel, params: SolverParams) -> DerivedConstants:
    if params.point_mass > 0.0:
        mass = np.full(model.num_points, params.point_mass)
    else:
        mass = params.areal_density * model.vertex_areas
    inv_mass = 1.0 / mass
    inv_mass[model.attached] = 0.0
    by_kind = {
        STRUCTURAL: (params.stretch_stiffness, params.stretch_damping),
        SHEAR: (params.shear_stiffness, params.shear_damping),
        BEND: (params.bend_stiffness, params.bend_damping),
    }
    stiffness = np.array([by_kind[k][0] for k in range(3)])[model.spring_kinds]
    damping = np.array([by_kind[k][1] for k in range(3)])[model.spring_kinds]
    # Explicit Euler on a spring between masses m_a, m_b is stable for k h^2 / m_min below ~1; the
    # factor keeps a margin for points with several springs. Capped springs are counted and reported.
    lighter = np.minimum(mass[model.springs[:, 0]], mass[model.springs[:, 1]])
    h = params.substep
    k_max = params.stability_factor * lighter / h**2
    c_max = 2.0 * params.stability_factor * lighter / h
    limited = (stiffness > k_max) | (damping > c_max)
    return DerivedConstants(mass, inv_mass, np.minimum(stiffness, k_max), np.minimum(damping, c_max),
                            int(np.count_nonzero(limited)))


def substep_plan(dt: float, params: SolverParams, limb_travel: float = 0.0) -> tuple[int, float]:
    """Substeps for a frame of ``dt`` seconds: ``ceil(dt / h)`` equal substeps (each <= h), at most
    ``max_substeps`` (memo's IC_max); when capped, substeps of ``h`` and the garment lags.

    ``limb_travel`` (``volume_travel``, in volume radii) asks for more when the limbs are fast: with
    ``limb_step_ratio`` > 0 at least ``limb_travel / limb_step_ratio`` substeps, up to ``max_limb_substeps``
    (never a lag for it: the frame is still simulated in full). Its own cap: at 2x playback and 30 fps
    the limbs asked for more than ``max_substeps`` in most frames, and the stretch (d) failed on it."""
    needed = max(1, math.ceil(dt / params.substep - 1e-9))
    if needed > params.max_substeps:
        return params.max_substeps, params.substep
    if params.limb_step_ratio > 0.0:
        limbs = math.ceil(limb_travel / params.limb_step_ratio - 1e-9)
        needed = max(needed, min(params.max_limb_substeps, limbs))
    return needed, dt / needed


def volume_travel(volumes, positions0, rotations0, positions1, rotations1) -> float:
    """How far the fastest point of any volume's surface moves between two poses (V, 3), (V, 4) of the
    volumes, in units of that volume's radius (``Volume.radius``, the adaptive switch's): at most its
    centre's displacement plus its bounding radius times the rotation's chord 2 sin(angle / 2)."""
    relative = quat_multiply(quat_conjugate(rotations0), rotations1)
    chord = 2.0 * np.linalg.norm(relative[:, :3], axis=1)
    travel = np.linalg.norm(positions1 - positions0, axis=1) + volumes.bounding_radii * chord
    return float(np.max(travel / volumes.switch_radii))


def wind_velocity(params: SolverParams, t: float) -> np.ndarray:
    """Constant wind plus gusts along the wind direction (or +x): two incommensurate sines."""
    wind = np.asarray(params.wind, dtype=float)
    if params.gust_amplitude == 0.0:
        return wind
    speed = np.linalg.norm(wind)
    direction = wind / speed if speed > 0.0 else np.array([1.0, 0.0, 0.0])
    phase = 2.0 * np.pi * params.gust_frequency * t
    gust = 0.6 * np.sin(phase) + 0.4 * np.sin(2.3 * phase + 1.3)
    return wind + params.gust_amplitude * gust * direction


def relative_frame_forces(params: SolverParams, yaw: float, root_velocity: np.ndarray,
                          root_acceleration: np.ndarray, wind: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Uniform parts of memo Eq. 4-2 in the simulation frame, per unit mass.

    Returns ``uniform_accel = g - s_lin a0`` and ``frame_velocity = s_lin v_root - wind`` (the drag
    then is ``-k (v_rel + frame_velocity + s_ang omega x r)``), all rotated into the root frame.
    """
    s = params.linear_inertia_scale
    c, n = math.cos(yaw), math.sin(yaw)
    to_local = np.array([[c, n, 0.0], [-n, c, 0.0], [0.0, 0.0, 1.0]])  # rotation by -yaw about z
    uniform = to_local @ (np.asarray(params.gravity) - s * np.asarray(root_acceleration))
    frame_velocity = to_local @ (s * np.asarray(root_velocity) - wind)
    return uniform, frame_velocity


class GarmentSolver(FrameRetries):
    """Advances one garment on one character. ``frames`` lists the skeleton frames it needs."""

    def __init__(self, model: ClothModel, volumes=None, params: SolverParams = DEFAULT_PARAMS,
                 attachment_frame_names: tuple[str, ...] | None = None):
        self.model = model
        self.volumes = volumes
        names = tuple(attachment_frame_names or model.attachment_frames)
        if len(names) != len(model.attachment_frames):
            raise ValueError(f"{len(names)} attachment frame names for {len(model.attachment_frames)} attachments")
        frames = list(volumes.frames) if volumes is not None else []
        frames += [n for n in names if n not in frames]
        self.frames: tuple[str, ...] = tuple(frames)
        frame_rows = np.array([frames.index(n) for n in names], dtype=np.int64)
        self._attach_frame = frame_rows[model.attachment_frame_index]
        self._attach_frame2 = frame_rows[model.attachment_frame_index2]
        self._shared = bool(np.any(model.attachment_weight2 > 0.0))
        # the forearms' volumes on frames the garment does not hang from: a waistband (attached points carried by
        # the pelvis) gives way to them (``band_gives_way``; the upper arms' and legs' too changed nothing on the CC
        # jump; a one-piece's neckline, carried by the chest, giving way too put a bone through it on the cartwheel
        # at 2x 30 fps, longest spring 2.51 -> 3.62; docs/real_motion.md)
        self._forearm_volumes = np.array(
            [] if volumes is None or "pelvis" not in model.attachment_frames else
            [k for k in np.flatnonzero(volumes.forearms()) if volumes.volumes[k].frame not in names], dtype=np.int64)
        # the band's own springs (structural and shear, both ends attached), ends as indices into the attached
        # points: where the band gives way, its moved points drag their neighbours (``kernels.spread_along_band``)
        attached_index = np.full(model.num_points, -1, dtype=np.int64)
        attached_index[model.attached] = np.arange(len(model.attached))
        ends = attached_index[model.springs[:model.num_correction_springs]]
        band = np.flatnonzero((ends >= 0).all(axis=1))
        self._band_springs = np.ascontiguousarray(ends[band])
        self._band_rest = np.ascontiguousarray(model.rest_lengths[band])
        n = model.num_points
        self._x_start = np.zeros((n, 3))
        self._forces = np.zeros((n, 3))
        # strain limiting after collision (see the module docstring): positions before the collision
        # handling, and positions / velocities before the limiting; per point inverse masses for it
        self._x_collision = np.zeros((n, 3))
        self._x_kept = np.zeros((n, 3))
        self._v_kept = np.zeros((n, 3))
        self._v_scratch = np.zeros((n, 3))
        self._strain_inv_mass = np.zeros(n)
        self._x_given = np.zeros((n, 3))  # positions before the contacts' room is given to torn springs
        self._strain_stretches = np.zeros(model.num_correction_springs)
        self._correct_count = model.num_correction_springs
        # (S_c,) length / rest length of the structural and shear springs (``model.springs``' first S_c)
        # after the last frame, as ``report.max_stretch`` and ``quality`` read them
        self.stretches = np.ones(self._correct_count)
        self._stretch_groups = stretch_groups(model.spring_kinds)
        self._whole = True  # the last frame ended undamaged (``_damage``): the next may be retried
        self._last_damage: tuple | None = None  # the last frame's kept ``_damage``: what the next starts with
        # (start state, ``PlannedFrame``) of the last ``replay_frames`` frames, for ``_replay``; emptied where the
        # garment was put somewhere (reset, carry, guard) and where its motion starts (``start_motion``)
        self._history: list[tuple[ClothState, PlannedFrame]] = []
        self._edges = np.ascontiguousarray(model.springs[model.spring_kinds == STRUCTURAL])
        self._edge_rest = np.ascontiguousarray(model.rest_lengths[model.spring_kinds == STRUCTURAL])
        self._triangles = np.ascontiguousarray(model.triangles, dtype=np.int64)
        self.collider = None
        self._layout: ParallelLayout | None = None  # ``parallel_layout``, built on first use
        self.use_fused = True  # the fused frame (``cloth.fused``) where the configuration allows; off: the loop below
        self.skin: SkinBinding | None = None  # bound by ``reset`` (motion constraints, ``max_distance``)
        if volumes is not None and len(volumes):
            from ..collision.collider import Collider

            self.collider = Collider(volumes, n, cache_size=min(2, len(volumes)))
            self.collider.grip_tubes(model.limb_tubes, model.rings)
        self.state = ClothState(model.rest_positions.copy(), np.zeros((n, 3)), self._new_contacts())
        self.set_params(params)

    def set_params(self, params: SolverParams) -> None:
        self.params = params
        self.constants = derive_constants(self.model, params)
        # the strain limiting's contact handling puts points out across the nearest surface (``strain_limit_slide``);
        # a trouser leg keeps the side it came from: slid across a thigh, the cloth takes the crotch with it
        self.limit_slides = bool(params.strain_limit_slide) and not self.model.limb_tubes
        self._layout = None  # its stiffnesses and dampings are the old ones
        if self.collider is not None:
            self.collider.set_params(params)

    # -- poses -------------------------------------------------------------------------------
    def _attachment_targets(self, root_position, root_yaw, frame_positions, frame_rotations) -> np.ndarray:
        """Where the attached points belong, in the simulation frame: on their segment, or the weighted
        mean of where their two segments put them (``ClothModel.attachment_weight2``)."""
        model = self.model
        args = (np.asarray(root_position, float), float(root_yaw), np.ascontiguousarray(frame_positions, dtype=float),
                np.ascontiguousarray(frame_rotations, dtype=float))
        targets = np.empty((len(model.attached), 3))
        kernels.poses_in_root_frame(*args, self._attach_frame, model.attachment_local, _NO_ROTATIONS, targets,
                                    _NO_ROTATIONS)
        if self._shared:
            second = np.empty_like(targets)
            kernels.poses_in_root_frame(*args, self._attach_frame2, model.attachment_local2, _NO_ROTATIONS, second,
                                        _NO_ROTATIONS)
            weight = model.attachment_weight2[:, None]
            targets += weight * (second - targets)
        if self.params.band_gives_way and len(self._forearm_volumes):
            # a forearm lying on the band (a hand on the hip) would hold skinned points inside it, on both sides
            # of its bone, where no move of the free cloth clears the bone: the band gives way under it
            positions, rotations = self._local_volume_poses(root_position, root_yaw, frame_positions, frame_rotations)
            volumes, skinned = self.volumes, targets.copy()
            push = (positions, rotations, volumes.kinds, volumes.radii, volumes.cuts, self._forearm_volumes,
                    self.params.collision_epsilon)
            kernels.push_out_of_volumes(targets, *push)
            for _ in range(self.BAND_ROUNDS):  # a point dragged into the forearm goes out again, and drags on
                kernels.spread_along_band(targets, skinned, self._band_springs, self._band_rest,
                                          self.params.limit_ratio)
                kernels.push_out_of_volumes(targets, *push)
        return targets

    # Rounds of dragging the band along the moved points and pushing it out of the forearms again
    # (``_attachment_targets``); each round ends out of the forearms.
    BAND_ROUNDS = 3

    def _local_volume_poses(self, root_position, root_yaw, frame_positions, frame_rotations):
        """The volumes' poses in the simulation frame (``self.frames`` starts with ``volumes.frames``)."""
        volumes = self.volumes
        positions, rotations = np.empty((len(volumes), 3)), np.empty((len(volumes), 4))
        kernels.poses_in_root_frame(np.asarray(root_position, float), float(root_yaw),
                                    np.ascontiguousarray(frame_positions, dtype=float),
                                    np.ascontiguousarray(frame_rotations, dtype=float), volumes.frame_index,
                                    volumes.offset_positions, volumes.offset_rotations, positions, rotations)
        return positions, rotations

    def reset(self, root_position, root_yaw, frame_positions, frame_rotations, time_s: float = 0.0) -> None:
        """Put the garment at its rest shape around the root, attached points on their segments."""
        x = self.model.rest_positions.copy()
        x[self.model.attached] = self._attachment_targets(root_position, root_yaw, frame_positions, frame_rotations)
        # The contacts stay: a garment re-fitted after a runaway (``DressedCharacter``) is reset in motion, its
        # points still near the volumes they touched, which the contact handling then keeps them out of.
        self.state = ClothState(x, np.zeros_like(x), self.state.contacts, time=time_s)
        self._whole, self._last_damage = True, None
        self._history.clear()
        if self.volumes is not None and len(self.volumes):  # the motion constraints' rest binding
            self.skin = self.binding(x, root_position, root_yaw, frame_positions, frame_rotations)

    def start_motion(self, time_s: float) -> None:
        """The garment, put where no frame of it led (dressed, or carried), follows the motion from ``time_s`` s:
        the frames run before (the dressing's, at a still root on another clock) are not the motion's, and none of
        them is replayed (``_replay``): a replay from there would also undo what was done to the garment since (a
        carry, a nudge, a test's move)."""
        self.state.time = time_s
        self.state.lag = 0.0
        self._history.clear()

    CARRY_PASSES = 8  # ``carry``: length-correction passes, each with the collision handling, then as many without

    def binding(self, positions, root_position, root_yaw, frame_positions, frame_rotations) -> SkinBinding:
        """The garment at ``positions`` (N, 3) m, in the root frame of this pose, bound rigidly to the volumes
        at it: ``carry`` puts it on another pose."""
        return SkinBinding(positions, self.volumes,
                           *self._local_volume_poses(root_position, root_yaw, frame_positions, frame_rotations))

    def carry(self, binding: SkinBinding, root_position, root_yaw, frame_positions, frame_rotations,
              time_s: float) -> FrameReport:
        """Put the garment where ``binding`` skins it on this pose, its attached points on their segments,
        at rest: no simulation (``DressedCharacter`` carries a garment it cannot dress cleanly this way).
        The frame's report says ``carried``, with the stretch measured."""
        poses = self._local_volume_poses(root_position, root_yaw, frame_positions, frame_rotations)
        targets = self._attachment_targets(root_position, root_yaw, frame_positions, frame_rotations)
        report = self._put_at(binding.positions(*poses), targets, poses, time_s)
        if report.max_stretch > self.RUNAWAY_STRETCH:
            # skinned on a pose far from the one it was bound on (the cartwheel's thigh at 160 deg: 12.2 rest
            # lengths), it is what the guard would re-fit: carried from the re-fit instead, so never beyond it
            report = self._put_at(self._refit_positions(targets), targets, poses, time_s)
        return report

    def _put_at(self, positions, targets, poses, time_s: float) -> FrameReport:
        """``carry``'s garment put at ``positions`` (N, 3) m, its attached points at ``targets``, on the volume
        ``poses`` (root frame), at rest; its report (``carried``, the stretch measured)."""
        x, v = self.state.positions, self.state.velocities
        self._last_damage = None  # put somewhere: the next frame's start is not the last frame's end
        x[...] = positions
        x[self.model.attached] = targets
        v[...] = 0.0
        # Points skinned to different volumes part where the limbs turn against the trunk, and a point skinned
        # to one volume can end inside another (a thigh raised into the belly): a few passes of the length
        # correction, each followed by the collision handling with the volumes standing still, positions only
        # (no velocity comes of them: what runs away in the simulation is Eq. 5-2 turning such moves into speed).
        inv_mass = self.constants.inv_mass
        self.collider.begin_frame(*poses, *poses)
        for k in range(2 * self.CARRY_PASSES):
            if k < self.CARRY_PASSES:
                kernels.length_correction(x, inv_mass, self.model.springs, self.model.rest_lengths,
                                          self._correct_count, self.params.limit_ratio)
            self.collider.handle_all(x.copy(), x, v, inv_mass, 1.0 / 60.0, self.state.contacts)
        v[...] = 0.0
        self.start_motion(time_s)
        report = FrameReport(carried=True)
        self._measure_stretch(report)
        return report

    def _new_contacts(self) -> np.ndarray:
        """An empty contact cache for ``ClothState.contacts`` (no column without volumes)."""
        if self.collider is None:
            return np.zeros((self.model.num_points, 0), dtype=np.int64)
        return self.collider.new_contacts()

    def world_positions(self, root_position, root_yaw) -> np.ndarray:
        return transform_points(np.asarray(root_position, float), yaw_quat(root_yaw), self.state.positions)

    # -- the frame ---------------------------------------------------------------------------
    def parallel_layout(self) -> ParallelLayout | None:
        """The springs and edges cut in two halves (``cloth.halves``) when the collider spreads the points over
        numba's threads (``Collider.parallel``: from ``PARALLEL_MIN_POINTS`` up) and the garment hangs from
        attached points, built on first use; None when it runs serial. The forces, the length correction and the
        edge handling then run on two threads too, on the reference path and the fused one alike. A garment
        with no attached point (the drape's free sheet) stays serial: each half of a hanging garment runs from
        its attachments down, but a free sheet's cut lags where it lies on the body, and the drape's worst
        stretch rose from 1.097 to 1.156 (docs/benchmarks.md)."""
        if self.collider is None or not self.collider.parallel or len(self.model.attached) == 0:
            return None
        if self._layout is None:
            model, const = self.model, self.constants
            self._layout = ParallelLayout.build(model.rest_positions, self._triangles, model.springs,
                                                model.rest_lengths, const.stiffness, const.damping,
                                                self._correct_count, self._edges, self._edge_rest)
        return self._layout

    def _correction_springs(self, layout: ParallelLayout | None) -> tuple[np.ndarray, np.ndarray, int]:
        """The structural and shear springs (S, 2), their rest lengths (S,) m and how many they are, in the order
        the length correction runs them (``cloth.halves``' with a ``layout``)."""
        if layout is None:
            return self.model.springs, self.model.rest_lengths, self._correct_count
        return layout.correction_springs, layout.correction_rest, len(layout.correction_rest)

    def _length_correction(self, x: np.ndarray, inv_mass: np.ndarray, layout: ParallelLayout | None) -> float:
        """One correction iteration (``kernels.length_correction``; in halves on two threads with a ``layout``);
        the largest length / rest length it met."""
        if layout is None:
            return kernels.length_correction(x, inv_mass, self.model.springs, self.model.rest_lengths,
                                             self._correct_count, self.params.limit_ratio)
        return kernels.length_correction_halves(x, inv_mass, layout.correction_springs, layout.correction_rest,
                                                layout.correction_starts, self.params.limit_ratio)

    def advance(self, frame: FrameInput) -> FrameReport:
        params, state = self.params, self.state
        dt = float(frame.t1 - frame.t0)
        if not dt > 0.0:
            raise ValueError(f"advance: frame end {frame.t1} must be after its start {frame.t0}")
        collider, poses0, poses1 = self.collider, None, None
        if collider is not None and _finite_frame(frame):
            poses0 = self._local_volume_poses(frame.root_position0, frame.root_yaw0,
                                              frame.frame_positions0, frame.frame_rotations0)
            poses1 = self._local_volume_poses(frame.root_position1, frame.root_yaw1,
                                              frame.frame_positions1, frame.frame_rotations1)
        count, h = substep_plan(dt, params, volume_travel(self.volumes, *poses0, *poses1) if poses0 else 0.0)
        report = FrameReport(substeps=count, substep_s=h, simulated_s=count * h)
        state.lag += dt - count * h
        report.lag_s = state.lag
        last_good = state.copy()  # for the guard at the end (a bad step keeps the frame's lag and time)
        if not _finite_frame(frame):  # a bad estimate upstream: no step at all (collision would launder NaN)
            self._history.clear()
            state.velocities[...] = 0.0
            state.time = frame.t1
            report.recovery = "restored"
            self._measure_stretch(report)
            return report

        planned = PlannedFrame(frame, count, h, dt, poses0, poses1)  # this frame as ``_history`` holds it
        best = self._tries(planned, last_good, report)
        report.substeps, report.substep_s = best[2], best[3]
        report.static_hits, report.dynamic_hits, report.pressed_depth_m = best[4]
        self._guard(report, last_good, frame)
        self.state.time = frame.t1
        if report.recovery or not self._replays():
            self._history.clear()
        else:
            self._history.append((last_good, planned))
            del self._history[:-params.replay_frames]
        return report

    def _substeps(self, frame: FrameInput, count: int, h: float, dt: float, poses0, poses1,
                  report: FrameReport) -> None:
        """The frame's ``count`` substeps of ``h`` s from ``self.state`` (``advance``); the collision's counters
        into ``report``."""
        params, const, model, state, collider = self.params, self.constants, self.model, self.state, self.collider
        jump = float(np.linalg.norm(np.asarray(frame.root_position1) - np.asarray(frame.root_position0)))
        teleported = jump > params.teleport_distance
        report.teleported = teleported
        v0 = np.zeros(3) if teleported else np.asarray(frame.root_velocity, float)
        a0 = np.zeros(3) if teleported else np.asarray(frame.root_acceleration, float)
        yaw_rate = 0.0 if teleported else float(frame.yaw_rate)
        yaw_acc = 0.0 if teleported else float(frame.yaw_acceleration)
        yaw_step = math.remainder(frame.root_yaw1 - frame.root_yaw0, 2.0 * math.pi)

        targets0 = self._attachment_targets(frame.root_position0, frame.root_yaw0,
                                            frame.frame_positions0, frame.frame_rotations0)
        targets1 = self._attachment_targets(frame.root_position1, frame.root_yaw1,
                                            frame.frame_positions1, frame.frame_rotations1)
        if collider is not None:
            collider.begin_frame(*poses0, *poses1)
        constrained = params.max_distance > 0.0 and self.skin is not None
        if constrained:
            skinned0, skinned1 = self.skin.positions(*poses0), self.skin.positions(*poses1)
        x, v = state.positions, state.velocities
        layout = self.parallel_layout()
        clock = time.perf_counter
        run_fused = self.use_fused and fused.usable(self)
        if run_fused:  # the same substeps in one compiled call (``cloth.fused``)
            fused.advance_substeps(self, frame, count, h, v0, a0, yaw_rate, yaw_acc, yaw_step, targets0, targets1,
                                   (skinned0, skinned1) if constrained else None, report)
        for k in range(0 if run_fused else count):  # the reference path
            f0, f1 = k / count, (k + 1) / count
            mid = 0.5 * (f0 + f1) * dt  # body time since t0 at the substep's middle
            tic = clock()
            uniform, frame_velocity = relative_frame_forces(
                params, frame.root_yaw0 + yaw_step * 0.5 * (f0 + f1), v0 + a0 * mid, a0,
                wind_velocity(params, frame.t0 + mid))
            frame_args = (uniform, yaw_rate + yaw_acc * mid, yaw_acc, params.air_damping, frame_velocity,
                          params.angular_inertia_scale, self._forces)
            if layout is None:
                kernels.accumulate_forces(x, v, const.mass, model.springs, model.rest_lengths, const.stiffness,
                                          const.damping, *frame_args)
            else:
                kernels.accumulate_forces_halves(x, v, const.mass, layout.springs, layout.rest, layout.stiffness,
                                                 layout.damping, *frame_args, layout.spring_starts)
            if not math.isfinite(float(np.sum(self._forces))):
                x[...] = math.nan  # the guard restores; collision handling would turn NaN into garbage
                break
            kernels.integrate(x, v, self._forces, const.inv_mass, h, self._x_start)
            kernels.set_attached(x, model.attached, targets0, targets1, f1)
            tac = clock()
            report.integration_s += tac - tic
            if collider is not None:
                collider.begin_substep(f0, f1)
            for iteration in range(max(1, params.correction_iterations)):
                if iteration < params.correction_iterations:
                    tic = clock()
                    self._length_correction(x, const.inv_mass, layout)
                    if params.tethers:
                        kernels.tether_constraints(x, const.inv_mass, model.tether_anchors, model.tether_lengths,
                                                   1.0 + params.tether_slack)
                    report.correction_s += clock() - tic
                if iteration == 0 and collider is not None:
                    tic = clock()
                    collider.handle_contacts(self._x_start, x, v, const.inv_mass, h, state.contacts)
                    report.collision_s += clock() - tic
            if constrained:
                limit_distance(x, skinned0, skinned1, f1, params.max_distance, const.inv_mass)
            tic = clock()
            kernels.velocities_from_positions(x, self._x_start, h, v)
            tac = clock()
            report.integration_s += tac - tic
            if collider is not None:
                self._x_collision[...] = x
                self._collide(x, v, h, layout)
                report.collision_s += clock() - tac
                if params.strain_limit_iterations > 0:
                    self._limit_strain(x, v, h, report, (skinned0, skinned1, f1) if constrained else None, layout)
        if collider is not None:
            report.static_hits = collider.static_hits
            report.dynamic_hits = collider.dynamic_hits
            report.pressed_depth_m = collider.pressed_depth

    def _collide(self, x: np.ndarray, v: np.ndarray, h: float, layout: ParallelLayout | None) -> None:
        """Full collision handling of a substep's end (``Collider.resolve_substep``; the edges in halves on two
        threads with a ``layout``)."""
        edges = (self._edges, self._edge_rest, None) if layout is None else (layout.edges, layout.edge_rest,
                                                                             layout.edge_starts)
        self.collider.resolve_substep(self._x_start, x, v, self.constants.inv_mass, h, self.state.contacts,
                                      edges[0], edges[1], self._triangles, edge_halves=edges[2])

    def _measure_stretch(self, report: FrameReport) -> None:
        """``self.stretches`` and ``report.max_stretch`` for the garment as it is now."""
        report.max_stretch = kernels.spring_stretches(self.state.positions, self.model.springs,
                                                      self.model.rest_lengths, self.stretches)

    def _limit_strain(self, x: np.ndarray, v: np.ndarray, h: float, report: FrameReport,
                      constraint: tuple[np.ndarray, np.ndarray, float] | None, layout: ParallelLayout | None) -> None:
        """Strain limiting after the collision handling, contacts respected (see the module docstring);
        ``constraint``, the motion constraints' skinned positions at the substep's ends and its end's
        fraction of the frame, when ``max_distance`` is on: the limiting keeps within it too."""
        params, const, model, collider = self.params, self.constants, self.model, self.collider
        clock = time.perf_counter
        tic = clock()
        kernels.contact_weights(x, self._x_collision, const.inv_mass, params.contact_mobility, self._strain_inv_mass)
        self._x_kept[...] = x
        self._v_kept[...] = v
        worst_kept = kernels.spring_stretches(x, model.springs, model.rest_lengths, self._strain_stretches)
        tac = clock()
        converged = 1.0 + params.limit_ratio + params.strain_limit_tolerance
        for _ in range(params.strain_limit_iterations):
            if self._length_correction(x, self._strain_inv_mass, layout) <= converged:
                break
            # the contacts as constraints of the same projection: what the correction pulled into a volume goes
            # back out before the next sweep (its velocity response is not wanted: ``v += dx / h`` below)
            collider.handle_contacts(None if self.limit_slides else self._x_start, x, self._v_scratch, const.inv_mass,
                                     h, self.state.contacts)
        if constraint is not None:
            limit_distance(x, *constraint, params.max_distance, const.inv_mass)
        v += (x - self._x_kept) / h
        toc = clock()
        self._collide(x, v, h, layout)  # the limiting shortens springs wrapped round a limb straight through it
        kernels.keep_where_inside(x, v, self._x_kept, self._v_kept, collider.penetration_depths(x))
        bound = max(worst_kept, self.STRAIN_LIMIT_UNDONE)
        if kernels.spring_stretches(x, model.springs, model.rest_lengths, self._strain_stretches) > bound:
            # the handling threw a point off (see STRAIN_LIMIT_UNDONE): not this substep
            kernels.undo_limiting(x, v, self._x_kept, self._v_kept, collider.penetration_depths(self._x_kept),
                                  model.springs, model.rest_lengths, self._strain_stretches, bound)
        if params.tear_give_stretch > 0.0:
            collider.give_room_to_tears(x, const.inv_mass, *self._correction_springs(layout),
                                        params.tear_give_stretch, self._x_given)
        report.correction_s += toc - tac
        report.collision_s += (tac - tic) + (clock() - toc)

    # The strain limiting's result is undone for the substep when a spring ends longer than this and than
    # the longest before it: moved by the limiting, a point's path from the substep's start can cross a
    # volume, and the swept handling then throws it to the far side (CC basketball, trousers at 30 fps:
    # a point below the waistband thrown 12 rest lengths off, then the guard). The target's maximum (issue 11).
    # A point inside a volume before the limiting that its handling took out keeps that (CC cartwheel, short skirt,
    # 2x 60 fps: a point 1.33 mm in the torso, back in with an undo for a spring 1.92 -> 1.95 long).
    STRAIN_LIMIT_UNDONE = STRETCH_MAX_TARGET

    # A structural or shear spring this many times its rest length is an explosion, not a soft fabric
    # (soft springs without length correction reach about 3 under strong root accelerations).
    RUNAWAY_STRETCH = 10.0

    def _refit_positions(self, targets: np.ndarray) -> np.ndarray:
        """(N, 3) m: the rest shape moved with its attached points' mean to their ``targets`` (A, 3) m, those
        pinned there (the guard's re-fit)."""
        attached, rest = self.model.attached, self.model.rest_positions
        x = rest + (targets.mean(axis=0) - rest[attached].mean(axis=0) if len(attached) else 0.0)
        x[attached] = targets
        return x

    def _guard(self, report: FrameReport, last_good: ClothState, frame: FrameInput) -> None:
        """Never keep a non-finite or runaway garment: non-finite values restore the last good state
        (at rest); a spring beyond ``RUNAWAY_STRETCH`` times its rest length re-fits the garment (its
        rest shape moved to where its attached points now are, those on the new pose). ``report.recovery``
        names what was done."""
        x, v = self.state.positions, self.state.velocities
        if np.isfinite(x).all() and np.isfinite(v).all():
            if report.max_stretch <= self.RUNAWAY_STRETCH:
                return
            targets = self._attachment_targets(frame.root_position1, frame.root_yaw1,
                                               frame.frame_positions1, frame.frame_rotations1)
            x[...] = self._refit_positions(targets)
            report.recovery = "refitted"
        if not np.isfinite(x).all():  # the step, or the new pose the re-fit used, was not finite
            self.state = last_good  # a copy of the whole garment state (``ClothState``), contacts included
            report.recovery = "restored"
        self.state.velocities[...] = 0.0
        self._measure_stretch(report)


def _finite_frame(frame: FrameInput) -> bool:
    return all(np.all(np.isfinite(np.asarray(value, dtype=float))) for value in vars(frame).values())
