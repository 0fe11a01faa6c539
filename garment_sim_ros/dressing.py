"""A dressed character: one body, its bounding volumes, and the garments simulated on it (ROS-free).

This is what the node, the command line and the benchmarks drive. Give it skeleton poses
(``SkeletonPose``, world frame) with the root's motion, and it advances every garment:

    character = DressedCharacter(body, ["pants"], params)   # built-in names, spec files or GarmentSpecs
    character.dress(first_pose, t0)             # fit the garments from the rest pose onto the first pose
    reports = character.step(pose, motion, t)    # one frame per call

Root motion (``body.pose_buffer.RootMotion``) is the pelvis position, heading and their rates
(memo §4: v0, a0); the node gets it from the pose buffer, and ``MotionSource.motion`` estimates it
with the same least-squares quadratic over 0.1 s for motion sources that can be sampled at any time
(BVH clips, the procedural character).

Dressing goes through the canonical standing pose (``body.canonical``), on which the body was
fitted and the garments cut, so the garments start clear of every volume by construction: every
joint's rotation relative to its parent turns from the canonical pose's to the target pose's
(slerp), the skeleton is composed down the tree with its own bones, and the cloth follows.

``make_character`` is the one way to get one from a skeleton: fit the body to its rest pose, then dress
it; a one-piece needs the detailed body (``detailed_body`` in its spec), so the garments choose the fit, and
every other garment gets the memo's 10 volumes plus the forearms (a hand swinging past the hip or resting on
it, issue 11; not the feet, which would push trouser cuffs about); ``forearms=False``: the memo's 10 (Table 1).

Every garment comes from a spec (``cloth.spec``: a built-in's procedural source or the user's mesh),
with its material's parameters in place of the run's. A mesh whose free vertices start inside the
body's volumes on the rest pose is moved out before anything is simulated, and said so in ``notes``.

Outfits (several garments): the garments are worn in the order of their specs' ``layer`` (0 closest to the
skin), the outfit's order breaking ties (a garment named later is worn over one named earlier). Each
garment is kept outside every garment worn under it (``cloth.layers``: the inner surface a collider for
the outer, ``layer_thickness`` off it), once per frame after every garment's step against the body: the
garments are separate solvers with their own substeps (their materials' own plans), and the frame's path
pass catches what went through in between; the body comes first (a point the pass would push into a
volume, or a triangle it would put across a limb bone, goes back). An outer garment cut like an inner one
(a skirt's waistband on the trousers') starts moved outside it, and an attachment lying on an inner
garment's attachment of the same role is skinned as that one is (two bands carried differently would part).
"""

from __future__ import annotations

import dataclasses
from functools import cached_property
from typing import Sequence

import numpy as np

from .body.aiming import aimed_frame_poses, volume_poses
from .body.canonical import local_transforms
from .body.fitting import fit_body
from .body.overrides import BodyOverrides
from .body.pose_buffer import RootMotion, SampleStatus
from .body.root import root_frame
from .body.skeleton import SkeletonPose, forward_kinematics
from .cloth.garments import GarmentMesh
from .cloth.kernels import keep_where_inside
from .cloth.layers import REACH_M, InnerSurface
from .cloth.mesh_check import GarmentMeshError
from .cloth.model import build_cloth_model
from .cloth.motion_constraints import SkinBinding
from .cloth.outfit_rules import BONE_PASSES, carried_like, undo_bone_crossings
from .cloth.solver import FrameInput, FrameReport, GarmentSolver
from .cloth.spec import GarmentSpec, build_mesh, resolve_garment
from .collision.collider import Collider
from .params import SolverParams
from .quality import TARGETS, GarmentMeter, free_point_depth
from .transforms import compose, inverse, quat_slerp, transform_points, yaw_quat


def make_character(rest_pose: SkeletonPose, joint_map: dict[str, str], garments: Sequence[str | GarmentSpec],
                   params: SolverParams, resolution: float = 1.0, *, garment_path: Sequence[str] = (),
                   decimate_to: int | None = None, overrides: BodyOverrides | None = None,
                   motion: Sequence[SkeletonPose] = (), forearms: bool = True) -> "DressedCharacter":
    """Fit a body to ``rest_pose`` (``joint_map``: role -> frame name; ``overrides``: per-volume changes,
    ``config/body.yaml``; ``motion``: poses it will be driven with, ``MotionSource.fit_poses``, so that no
    arm bone starts inside its trunk) and dress it in ``garments`` (built-in names, spec files or specs): the
    detailed 15-volume body when any garment's spec asks for it (the one-piece), else the 10-volume one with
    the forearms (12; ``forearms=False``: without, the memo's protocol)."""
    specs = [resolve_garment(g, garment_path) for g in garments]
    body = fit_body(rest_pose, joint_map, detailed=any(s.detailed_body for s in specs), overrides=overrides,
                    motion=motion, forearms=forearms)
    return DressedCharacter(body, specs, params, resolution, garment_path, decimate_to)


class DressedCharacter:
    """Garments on a fitted body. ``body`` is a ``body.fitting.Body`` (volumes, measurements, joint map, rest pose)."""

    def __init__(self, body, garments: Sequence[str | GarmentSpec], params: SolverParams, resolution: float = 1.0,
                 garment_path: Sequence[str] = (), decimate_to: int | None = None):
        if not garments:
            raise ValueError("a dressed character needs at least one garment")
        self.body = body
        self.joint_map = dict(body.joint_map)
        rest = body.rest_pose
        root_position, root_yaw = root_frame(rest, self.joint_map)
        to_root = inverse(root_position, yaw_quat(root_yaw))
        self.specs = [resolve_garment(g, garment_path) for g in garments]
        # rows of ``self.solvers`` from the skin out: by layer, then outfit order; per garment, those it is worn over
        self.layer_order = sorted(range(len(self.specs)), key=lambda r: (self.specs[r].layer, r))
        self._inner = [self.layer_order[:self.layer_order.index(row)] for row in range(len(self.specs))]
        self._tracked: dict[tuple[int, int], np.ndarray] = {}  # (outer, inner) row -> InnerSurface.separate's
        self.notes: list[str] = []  # what dressing changed on a garment (moved out of the body)
        self.solvers: list[GarmentSolver] = []
        rest_frames = [compose(*to_root, *rest.frame(f)) for f in body.volumes.frames]
        volume_poses = body.volumes.world_poses(np.array([p for p, _ in rest_frames]),
                                                np.array([q for _, q in rest_frames]))
        meshes: dict[int, GarmentMesh] = {}
        for row in self.layer_order:  # inner garments first
            spec = self.specs[row]
            mesh = self._out_of_body(build_mesh(spec, body.measurements, resolution, decimate_to), spec, volume_poses,
                                     params.replace(**spec.material))
            meshes[row] = self._outside_of(mesh, spec, [meshes[i] for i in self._inner[row]], params)
        for row, spec in enumerate(self.specs):
            mesh = meshes[row]
            carriers = [*mesh.attachments, *(second for second, _ in mesh.shared_attachments.values())]
            missing = [role for role in carriers if role not in self.joint_map]
            if missing:
                raise ValueError(f"garment {spec.name!r} is carried by {missing}, which the joint map does not name")
            rest_poses = {role: compose(*to_root, *rest.frame(self.joint_map[role])) for role in carriers}
            model = build_cloth_model(mesh, rest_poses)
            frame_names = tuple(self.joint_map[role] for role in model.attachment_frames)
            self.solvers.append(GarmentSolver(model, body.volumes, params.replace(**spec.material), frame_names))
        frames: list[str] = []
        for solver in self.solvers:
            frames += [f for f in solver.frames if f not in frames]
        self.frames = tuple(frames)
        # each solver's frames as rows of ``self.frames``
        self._rows = {id(s): [frames.index(f) for f in s.frames] for s in self.solvers}
        self._previous: tuple[SkeletonPose, RootMotion, float] | None = None
        # The guard's recoveries (``_recover``), per row of ``self.solvers``: its last clean configuration
        # (positions (N, 3) in the root frame, m; the root's position and yaw; its frames' poses), the rows
        # carried instead of simulated (row -> body time of the next re-dress tried, s; the skin binding)
        # and when each garment was last dressed, s.
        self._clean: dict[int, tuple] = {}
        self._carried: dict[int, tuple[float, SkinBinding]] = {}
        self._dressed_at: dict[int, float] = {}

    @property
    def garment_names(self) -> list[str]:
        return [s.model.name for s in self.solvers]

    def set_params(self, params: SolverParams) -> None:
        """The run's parameters; each garment's material keeps its own values in place of them."""
        for solver, spec in zip(self.solvers, self.specs):
            solver.set_params(params.replace(**spec.material))


    def _out_of_body(self, mesh: GarmentMesh, spec: GarmentSpec, volume_poses, params: SolverParams,
                     passes: int = 6) -> GarmentMesh:
        """``mesh`` with its free vertices that start inside a volume (on the rest pose, ``volume_poses`` in
        the root frame) put on the volume's surface, before anything is simulated: a garment simulated from
        inside a limb stays there. The static collision handling does it, a few passes for vertices in
        overlapping volumes; the moved vertices are the garment's rest shape, and ``notes`` says so."""
        if len(self.body.volumes) == 0:
            return mesh
        x = np.ascontiguousarray(mesh.vertices, dtype=np.float64).copy()
        collider = Collider(self.body.volumes, len(x))
        collider.set_params(params.replace(collision_mode="static", friction=0.0))
        collider.begin_frame(*volume_poses, *volume_poses)
        inv_mass = np.ones(len(x))
        for ids in mesh.attachments.values():
            inv_mass[ids] = 0.0
        free = inv_mass > 0.0
        depth = collider.penetration_depths(x)[free]
        inside = depth > params.collision_epsilon
        if not inside.any():
            return mesh
        contacts = collider.new_contacts()
        for _ in range(passes):
            collider.handle_all(x.copy(), x, np.zeros_like(x), inv_mass, 1.0 / 60.0, contacts)
        left = float(np.max(collider.penetration_depths(x)[free]))
        if left > params.collision_epsilon:
            raise GarmentMeshError(f"{spec.where}: {int(inside.sum())} vertices start inside the body, still "
                                   f"{left * 1e3:.0f} mm deep after moving out: place the garment on the body")
        self.notes.append(f"{spec.name}: {int(inside.sum())} of {int(free.sum())} free vertices started inside the "
                          f"body (deepest {float(depth.max()) * 1e3:.0f} mm); moved out onto its surface")
        return dataclasses.replace(mesh, vertices=x)

    def _outside_of(self, mesh: GarmentMesh, spec: GarmentSpec, inner_meshes: Sequence[GarmentMesh],
                    params: SolverParams, passes: int = 3) -> GarmentMesh:
        """``mesh`` moved outside the garments it is worn over (their rest shapes), ``layer_thickness`` off
        them: an outer garment cut like an inner one (a skirt's waistband on the trousers') would start in it."""
        if not inner_meshes:
            return mesh
        mesh = carried_like(mesh, inner_meshes)
        x = np.ascontiguousarray(mesh.vertices, dtype=np.float64).copy()
        still, everywhere = np.zeros_like(x), np.ones(len(x), dtype=bool)
        before = x.copy()
        for inner in inner_meshes:
            surface = InnerSurface(inner.vertices, inner.triangles, REACH_M)
            tracked = np.full(len(x), -1, dtype=np.int64)
            for _ in range(passes):
                surface.separate(x, still, everywhere, mesh.edges(), params.layer_thickness, tracked)
        moved = np.any(before != x, axis=1)
        if moved.any():
            self.notes.append(f"{spec.name}: {int(moved.sum())} vertices on or in the garments worn under it; "
                              f"moved {params.layer_thickness * 1e3:g} mm outside them")
        return dataclasses.replace(mesh, vertices=x)

    def _separate_layers(self, rows: Sequence[int], previous: dict[int, np.ndarray],
                         pose: SkeletonPose | None = None, motion: RootMotion | None = None) -> None:
        """After the frame's step against the body: every garment of ``rows`` kept outside those it is
        worn over (``cloth.layers``), its path from its positions before the step (``previous``: row -> (N, 3)).
        Inner garments first, so each outer one meets the inner ones where they end the frame. With the
        frame's ``pose`` and root ``motion``, a garment triangle the layers put across a limb bone goes back."""
        surfaces: dict[int, InnerSurface] = {}
        bones = None
        if pose is not None and rows:
            to_root = inverse(np.asarray(motion.position, float), yaw_quat(motion.yaw))
            bones = [np.ascontiguousarray(transform_points(*to_root, ends))
                     for ends in self._meters[rows[0]].bone_segments(pose)]
        for row in sorted(rows, key=lambda r: len(self._inner[r])):
            solver = self.solvers[row]
            state = solver.state
            kept = (state.positions.copy(), state.velocities.copy())
            for inner in self._inner[row]:
                tracked = self._tracked.setdefault((row, inner), np.full(solver.model.num_points, -1, np.int64))
                self._surface(inner, surfaces).separate(state.positions, state.velocities,
                                                        solver.constants.inv_mass > 0.0, solver.model.edges,
                                                        solver.params.layer_thickness, tracked, previous[row])
            if bones is not None:
                undo_bone_crossings(state.positions, state.velocities, *kept, solver.model.triangles, *bones,
                                    BONE_PASSES)
            if solver.collider is not None:
                self._body_first(solver.collider, state, *kept)

    BODY_FIRST_STEPS = (0.75, 0.5, 0.25)  # ``_body_first`` tries these fractions of a push, the largest first

    @staticmethod
    def _body_first(collider: Collider, state, x_kept: np.ndarray, v_kept: np.ndarray) -> None:
        """The body comes first: a point the layers pushed deeper into a volume than the body's handling left it
        (``x_kept``, ``v_kept`` (N, 3)) keeps the largest of ``BODY_FIRST_STEPS`` of its push that is no deeper, or
        goes back (a forearm lying on the trousers at the hip: part of the way out of the trousers may still be
        out of them, though nearer than the thickness; CC walk, trousers + long skirt, 3 s: 79 -> N crossing
        frames)."""
        x = state.positions
        depth_kept = collider.penetration_depths(x_kept) + 1e-6
        held = collider.penetration_depths(x) > depth_kept
        if not held.any():
            return
        pushed = x.copy()
        for fraction in DressedCharacter.BODY_FIRST_STEPS:
            x[held] = x_kept[held] + fraction * (pushed[held] - x_kept[held])
            held &= collider.penetration_depths(x) > depth_kept
            if not held.any():
                return
        keep_where_inside(x, state.velocities, x_kept, v_kept, np.where(held, 1.0, -1.0))

    def layer_crossings(self) -> list[int]:
        """Per garment, how many of its edges cross a triangle of a garment worn under it (0 for the
        innermost and for a garment worn alone): the layers' bone-through-cloth check."""
        surfaces: dict[int, InnerSurface] = {}
        counts = []
        for row, solver in enumerate(self.solvers):
            count = 0
            for inner in self._inner[row]:
                count += self._surface(inner, surfaces).edges_through(solver.state.positions, solver.model.edges)
            counts.append(count)
        return counts

    def _surface(self, row: int, surfaces: dict[int, InnerSurface]) -> InnerSurface:
        """Garment ``row``'s surface where it is now, as a collider for those worn over it; built once per
        pass (``surfaces``: row -> surface, filled here)."""
        if row not in surfaces:
            solver = self.solvers[row]
            surfaces[row] = InnerSurface(solver.state.positions, solver.model.triangles, REACH_M)
        return surfaces[row]

    def _layered_rows(self, solvers: Sequence[GarmentSolver]) -> list[int]:
        """Rows of ``solvers`` worn over another garment."""
        return [row for row, solver in enumerate(self.solvers) if self._inner[row] and solver in solvers]

    def _frame_poses(self, pose: SkeletonPose, frames: Sequence[str]):
        """The frames' poses at ``pose``, the trunk's aimed along the spine (``body.aiming``): the volumes and
        the attachments on them (a skirt's waistband on the spine segment) ride one frame."""
        return aimed_frame_poses(pose, frames, self.body.volumes.aims)

    def dress(self, pose: SkeletonPose, time_s: float, motion: RootMotion | None = None,
              settle_s: float = 0.6, frame_s: float = 1.0 / 60.0) -> None:
        """Put the garments on: start at the rest pose, then blend every segment (relative to the root)
        from its rest pose to ``pose`` over ``settle_s`` while the root stands still, so the garments
        start fitted and collision-free whatever the first pose is."""
        self._put_on(self.solvers, pose, time_s, settle_s, frame_s)
        self._carried.clear()
        position, yaw = root_frame(pose, self.joint_map)
        for row in range(len(self.solvers)):
            self._keep_clean(row, pose, position, yaw)
            self._dressed_at[row] = time_s
        if motion is None:
            still = np.zeros(3)
            motion = RootMotion(SampleStatus.OK, 0.0, 0, np.asarray(position, float), yaw, still, still, 0.0, 0.0)
        self._previous = (pose, motion, time_s)

    def _put_on(self, solvers: Sequence[GarmentSolver], pose: SkeletonPose, time_s: float,
                settle_s: float, frame_s: float, hold_frames: int = 60) -> list[bool]:
        """Dress ``solvers`` through the canonical pose onto ``pose`` (see ``dress``); per solver, whether
        its guard fired on the way."""
        root_position, root_yaw = root_frame(pose, self.joint_map)
        rest_t, rest_q = local_transforms(_in_root_frame(self.body.rest_pose, self.joint_map))
        pose_t, pose_q = local_transforms(_in_root_frame(pose, self.joint_map))
        to_world = (root_position, yaw_quat(root_yaw))
        skeleton = pose.skeleton

        def blended(weight: float):
            q = quat_slerp(rest_q, pose_q, np.full(len(rest_q), weight))
            # the bones are the skeleton's own (the target's, the same up to noise); only the root moves
            local = forward_kinematics(skeleton, rest_t + weight * (pose_t - rest_t), q)
            return compose(to_world[0], to_world[1], *self._frame_poses(local, self.frames))

        steps = max(1, int(round(settle_s / frame_s)))
        start = time_s - (steps + hold_frames) * frame_s
        selections = [self._rows[id(solver)] for solver in solvers]
        fp, fq = blended(0.0)
        running = [solver.params for solver in solvers]
        for solver, sel in zip(solvers, selections):
            solver.reset(root_position, root_yaw, fp[sel], fq[sel], start)
            # No strain limiting while the pose is blended in: it pulls the cloth taut across an arm
            # coming down onto it (CC 02_04: a forearm ended through the long skirt and the trousers);
            # the hold lets the springs settle without it. Nor the friction along the limbs: a trouser leg dressed
            # straight slides up a knee the pose bends (held, xia_angry's first frames stretched to p99 1.15).
            # Nor the exit through the pelvis' open bottom: it moved the CC walk's crotch seam 65 mm.
            solver.set_params(solver.params.replace(strain_limit_iterations=0, axial_friction=0.0,
                                                    open_cut_band=0.0))
        still = np.zeros(3)
        # Blend, then hold the pose so the garments come to rest on it.
        t = start
        previous = (fp, fq)
        layered = self._layered_rows(solvers)
        fired = [False] * len(solvers)
        for k in range(steps + hold_frames):
            current = blended(min(1.0, (k + 1) / steps))
            before = {row: self.solvers[row].state.positions.copy() for row in layered}
            for i, (solver, sel) in enumerate(zip(solvers, selections)):
                fired[i] |= bool(solver.advance(FrameInput(
                    t0=t, t1=t + frame_s, root_position0=root_position, root_yaw0=root_yaw,
                    root_position1=root_position, root_yaw1=root_yaw, root_velocity=still, root_acceleration=still,
                    yaw_rate=0.0, yaw_acceleration=0.0, frame_positions0=previous[0][sel],
                    frame_rotations0=previous[1][sel], frame_positions1=current[0][sel],
                    frame_rotations1=current[1][sel])).recovery)
            self._separate_layers(layered, before)
            previous = current
            t += frame_s
        for solver, params in zip(solvers, running):
            solver.set_params(params)
            solver.start_motion(time_s)
        return fired

    # A runaway within this long of the garment's last dressing is the same pose still pinching it: carried
    # without a re-dress (each re-dress onto the CC cartwheel's raised thigh ran away again within frames,
    # 30 times in 3 s), s. A carried garment tries a re-dress every RETRY_S of body time, s.
    REFIRE_S = 0.25
    RETRY_S = 0.1

    def step(self, pose: SkeletonPose, motion: RootMotion, time_s: float, measure: bool = True) -> list[FrameReport]:
        """Advance every garment from the previous pose to ``pose`` at ``time_s``; ``measure``: fill the
        reports' quality figures (``measure``; the node measures at its ``quality_rate_hz``)."""
        if self._previous is None:
            raise RuntimeError("call dress() with the first pose before step()")
        previous_pose, start_motion, previous_time = self._previous
        p0, q0 = self._frame_poses(previous_pose, self.frames)
        p1, q1 = self._frame_poses(pose, self.frames)
        reports: list[FrameReport | None] = []
        layered = [row for row in self._layered_rows(self.solvers) if row not in self._carried]
        before = {row: self.solvers[row].state.positions.copy() for row in layered}
        for row, solver in enumerate(self.solvers):
            if row in self._carried:
                reports.append(None)
                continue
            sel = self._rows[id(solver)]
            frame = FrameInput.between(t0=previous_time, motion0=start_motion, poses0=(p0[sel], q0[sel]),
                                       t1=time_s, motion1=motion, poses1=(p1[sel], q1[sel]))
            reports.append(solver.advance(frame))
        self._separate_layers(layered, before, pose, motion)
        self._recover(reports, pose, motion, time_s)
        self._previous = (pose, motion, time_s)
        if measure:
            self.measure(reports, pose)
            for row, report in enumerate(reports):
                if self._is_clean(report):
                    self._keep_clean(row, pose, motion.position, motion.yaw)
        return reports

    def _recover(self, reports: list[FrameReport | None], pose: SkeletonPose, motion: RootMotion,
                 time_s: float) -> None:
        """The guard's recoveries, after the frame's steps (``reports``: None for a carried garment, filled here).

        A garment that ran away (``recovery == "refitted"``: the solver put its rest shape on its attached
        points) is dressed again through the canonical pose onto this pose, with the collision handling of
        the first dressing (0.25 s of blending), and kept only if clean (``_is_clean``, its guard quiet on
        the way too). Otherwise, or when it ran away within ``REFIRE_S`` of its last dressing (the same pose
        pinching it again), it is carried rigidly with the body: its last clean configuration (the last
        measured frame clean on (a)-(c), or its last dressing) skinned to the nearest volumes and pushed out
        of the others (``cloth.solver.GarmentSolver.carry``), reported ``carried``, until a re-dress tried
        every ``RETRY_S`` comes out clean. So a recovery never loops on one pose, and the garment never ends
        worse than its last clean configuration moved with the body."""
        for row, report in enumerate(reports):
            solver = self.solvers[row]
            if report is not None and report.recovery == "refitted":
                recent = time_s - self._dressed_at.get(row, -np.inf) < self.REFIRE_S
                if (recent or not self._redress(row, pose, time_s)) and row in self._clean:
                    self._carried[row] = (time_s + self.RETRY_S, solver.binding(*self._clean[row]))
            elif report is None:
                retry, binding = self._carried[row]
                if time_s >= retry and self._redress(row, pose, time_s):
                    del self._carried[row]
                    reports[row] = FrameReport()
                elif time_s >= retry:
                    self._carried[row] = (time_s + self.RETRY_S, binding)
            if row in self._carried:
                carried = solver.carry(self._carried[row][1], motion.position, motion.yaw,
                                       *self._frame_poses(pose, solver.frames), time_s)
                carried.recovery = report.recovery if report is not None else ""
                reports[row] = carried

    def _redress(self, row: int, pose: SkeletonPose, time_s: float) -> bool:
        """Dress garment ``row`` again onto ``pose`` (``_put_on``); whether it came out clean."""
        solver = self.solvers[row]
        if self._put_on([solver], pose, time_s, settle_s=0.25, frame_s=1.0 / 60.0, hold_frames=15)[0]:
            return False
        report = FrameReport()
        position, yaw = root_frame(pose, self.joint_map)
        self._meters[row].measure(report, solver, solver.world_positions(position, yaw), pose,
                                  *volume_poses(self.body.volumes, pose))
        if not self._is_clean(report):
            return False
        self._keep_clean(row, pose, position, yaw)
        self._dressed_at[row] = time_s
        return True

    @staticmethod
    def _is_clean(report: FrameReport) -> bool:
        """Clean on (a)-(c): no free point deeper than ``Targets.depth_tolerance_m``, no limb bone through the
        garment, every trouser leg round its leg; a step the guard let pass."""
        return (not report.recovery and not report.carried and report.max_depth_m <= TARGETS.depth_tolerance_m
                and not report.bones_through and not report.legs_off)

    def _keep_clean(self, row: int, pose: SkeletonPose, root_position, root_yaw: float) -> None:
        """Garment ``row`` as it is now, on ``pose`` (root at ``root_position``, ``root_yaw``: the frame its
        state is in), is its last clean configuration: what it is carried with after a runaway."""
        solver = self.solvers[row]
        self._clean[row] = (solver.state.positions.copy(), root_position, root_yaw,
                            *self._frame_poses(pose, solver.frames))

    @cached_property
    def _meters(self) -> list[GarmentMeter]:
        return [GarmentMeter(s.model, self.body.volumes, self.joint_map) for s in self.solvers]

    def measure(self, reports: Sequence[FrameReport], pose: SkeletonPose) -> None:
        """Fill the reports' quality figures (``garment_sim_ros.quality``: depth, limb bones through the
        cloth, trouser legs off, stretch) for the garments as they are now, at ``pose``."""
        centres, rotations = volume_poses(self.body.volumes, pose)
        for meter, solver, report, positions in zip(self._meters, self.solvers, reports, self.world_positions()):
            meter.measure(report, solver, positions, pose, centres, rotations)
        if len(self.solvers) > 1:
            for report, crossings in zip(reports, self.layer_crossings()):
                report.layer_crossings = crossings

    @property
    def root(self) -> RootMotion | None:
        return self._previous[1] if self._previous else None

    def world_positions(self) -> list[np.ndarray]:
        motion = self.root
        if motion is None:
            raise RuntimeError("no frame yet")
        return [s.world_positions(motion.position, motion.yaw) for s in self.solvers]

    def max_penetration(self) -> float:
        """Deepest free point of any garment inside any volume at the last frame's end, m.

        Attached points are left out: they ride on their segment wherever it puts them (a strapless
        dress's neckline runs under the arms' volumes)."""
        return max((free_point_depth(solver) for solver in self.solvers), default=0.0)


def _in_root_frame(pose: SkeletonPose, joint_map) -> SkeletonPose:
    """``pose`` seen from its root frame (pelvis at the origin, heading along +x)."""
    position, yaw = root_frame(pose, joint_map)
    return SkeletonPose(pose.skeleton, *compose(*inverse(position, yaw_quat(yaw)), pose.positions, pose.rotations))
