"""One character's frame loop, between the /tf pose buffer and the garments (ROS-free).

The node calls ``frame(T)`` once per timer tick with ``T = D_last + now`` (memo §3); this
module decides what happens:

1. No character yet: wait for a complete skeleton under the fixed frame within the frame prefix
   (the same tree on two consecutive frames, every frame sampled), map it (``auto_joint_map`` on
   the names without the prefix, or ``joint_map_file``), stand it up (``canonical_pose``: the bones
   seen on /tf, checked to be the same a moment earlier, in the canonical standing pose), fit the body (detailed volumes when a one-piece is worn), build the
   ``DressedCharacter`` and dress it at ``T``. A skeleton that cannot be mapped is logged with the
   missing roles and retried only when the tree changes; the loop keeps waiting.
2. Running: sample the skeleton and root motion at ``T`` and step every garment from the last
   frame. Stale or missing skeleton data (``PoseBuffer`` statuses) or a time that does not move
   forward skip the frame: nothing is simulated, the last good state stays, the skip is counted
   and logged (throttled). After a pause longer than ``RESUME_GAP_S`` (the skeleton stopped, or
   the clock jumped back more than ``CLOCK_JUMP_BACK_S``, a looped bag) the garments are dressed
   again at the new pose instead of being dragged across the gap in one frame. Dressing takes a
   while (about a second of simulation, more on a busy machine) and a shorter hold leaves a gap
   too: the frame after either covers it in pieces the solver simulates in full (``max_substeps``
   each, at most ``MAX_CATCH_UP_FRAMES`` and ``catch_up_wall_s`` of compute), so the garment is
   not dragged across the gap in a few substeps. Otherwise a frame longer than
   ``max_substeps x substep`` lags (memo §3), which the diagnostics report; so does what a
   catch-up could not cover.
3. Bad input while running (each counted in ``counts`` under its reason and logged, throttled):
   the clock jumping back more than ``CLOCK_JUMP_BACK_S`` also forgets the buffer's dynamic
   transforms (their stamps are in the new clock's future) and dresses again when the skeleton
   is back (``clock_jumped_back``); a skeleton replaced mid-run (its frames stop while frames not
   in it arrive under the prefix: another clip with other names) forgets the stopped frames and
   maps, fits and dresses the new one (``skeleton_changed``); a root jump longer than the
   ``teleport_distance`` parameter within a frame, faster than ``MAX_ROOT_SPEED`` (a clip looping
   back, not a body that walked on while the loop lagged) forgets the motion before the jump and
   dresses the garments again at the new pose instead of dragging them along (``teleported``); a
   pose whose hips coincide horizontally has no heading and holds (``root_motion_degenerate``); a
   node clock that has not started (``use_sim_time`` without /clock) waits (``no_clock``, from
   ``clock_not_started``).

Changing garments or resolution (``set_garments``) re-dresses at the next frame; solver
parameters (``set_params``) apply from the next step on.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..body.fitting import fit_body
from ..body.overrides import load_body_overrides
from ..body.joint_map import auto_joint_map, load_joint_map
from ..body.pose_buffer import PoseBuffer, SampleStatus
from ..body.canonical import canonical_pose, local_transforms
from ..body.skeleton import Skeleton, SkeletonPose
from ..cloth.solver import FrameReport
from ..cloth.spec import resolve_garment
from ..dressing import DressedCharacter
from ..params import SolverParams

RESUME_GAP_S = 1.0  # a hold longer than this re-dresses (the body moved arbitrarily meanwhile)
MAX_CATCH_UP_FRAMES = 25  # a frame covers a gap in at most this many full frames (1 s by default)
CATCH_UP_WALL_S = 0.1  # ...and spends at most about this long on them (a busy machine lags instead)
CLOCK_JUMP_BACK_S = 1.0  # a clock this far behind the last frame restarts (sim time reset, looped bag)
LOG_PERIOD_S = 5.0  # the same warning at most this often
MAX_ROOT_SPEED = 12.0  # m/s, faster than any sprinter: a root faster than this within a frame teleported
# Bones seen on /tf must match those BONE_CHECK_S earlier within this tolerance (m + fraction) before the
# body is fitted: a rigid skeleton's bones do not change, a retargeting or scaling one does.
BONE_CHECK_S = 0.1
BONE_TOLERANCE_M = 0.005
BONE_TOLERANCE = 0.02
_USABLE = (SampleStatus.OK, SampleStatus.EXTRAPOLATED)


class Status:
    WAITING = "waiting for skeleton"
    UNMAPPABLE = "skeleton cannot be mapped"
    RUNNING = "running"
    HOLDING = "holding (skeleton stale or missing)"


@dataclass
class FrameResult:
    """A simulated frame: the garments are at ``time_s``."""

    time_s: float
    pose: SkeletonPose
    reports: list[FrameReport]  # one per garment; empty for the frame that dressed the character
    frame_s: float  # body time since the last frame, s (0 when dressed)
    step_s: float  # wall time of stepping (or dressing), s
    penetration_m: float  # deepest garment point inside a volume after the frame, m
    dressed: bool  # this frame put the garments on (first skeleton, new garments, after a gap)
    # The time the skeleton pose is for, s: ``time_s``, or earlier when the buffer held its extrapolation
    # (its newest data more than max_extrapolation behind): the stamp to publish under, never newer than the pose.
    pose_time_s: float = math.nan


class Throttle:
    """Lets a message of a given kind (key) through at most once per ``period_s``."""

    def __init__(self, period_s: float = LOG_PERIOD_S):
        self.period_s = period_s
        self._last: dict[str, float] = {}

    def ready(self, key: str) -> bool:
        now = time.monotonic()
        if now - self._last.get(key, -float("inf")) < self.period_s:
            return False
        self._last[key] = now
        return True


class CharacterLoop:
    """The garments on the character whose frames start with ``frame_prefix`` in ``buffer``."""

    def __init__(self, buffer: PoseBuffer, params: SolverParams, garments: Sequence[str], resolution: float,
                 frame_prefix: str = "", root_frame: str = "", joint_map_file: str = "", logger=None,
                 catch_up_wall_s: float = CATCH_UP_WALL_S, body_file: str = "", garment_path: Sequence[str] = ()):
        self.buffer = buffer
        self.params = params
        self.garments = list(garments)
        self.resolution = float(resolution)
        self.garment_path = tuple(garment_path)
        self._spec_stamps: dict[Path, float] = {}  # the dressed garments' spec and mesh files -> mtime
        self.frame_prefix = frame_prefix
        self.root_frame = root_frame
        self.joint_map_file = joint_map_file
        self.body_file = body_file
        self.logger = logger
        self.catch_up_wall_s = catch_up_wall_s
        self.throttle = Throttle()
        self.character: DressedCharacter | None = None
        self.skeleton: Skeleton | None = None
        self.joint_map: dict[str, str] = {}
        self.status = Status.WAITING
        self.detail = "no transform received yet"
        self.counts: Counter[str] = Counter()  # skipped frames by reason, re-dresses, setup failures
        self.last_time: float | None = None
        self._candidate: Skeleton | None = None  # the tree seen on the previous attempt
        self._refused: Skeleton | None = None  # a tree that could not be mapped (retried when it changes)
        self._catching_up = False  # after dressing or a hold: the next frame may span a gap
        self._just_dressed = False  # the gap since the last frame is the dressing's own compute time

    # -------------------------------------------------------------------------- configuration
    def set_params(self, params: SolverParams) -> None:
        self.params = params
        if self.character is not None:
            self.character.set_params(params)

    def set_garments(self, garments: Sequence[str], resolution: float, garment_path: Sequence[str] | None = None) -> None:
        """Wear other garments (or the same at another resolution): re-dressed at the next frame."""
        self.garments = list(garments)
        self.resolution = float(resolution)
        if garment_path is not None:
            self.garment_path = tuple(garment_path)
        self._spec_stamps = {}
        self.character = None
        self._refused = None

    def _specs_changed(self) -> bool:
        """Whether a dressed garment's spec or mesh file was saved since it was read."""
        for path, stamp in self._spec_stamps.items():
            try:
                if path.stat().st_mtime != stamp:
                    return True
            except OSError:
                return True
        return False

    @property
    def mass_points(self) -> int:
        return 0 if self.character is None else sum(s.model.num_points for s in self.character.solvers)

    def skeleton_age(self, time_s: float) -> float:
        """How old the skeleton's newest data is at ``time_s`` (inf before any)."""
        if self.skeleton is None:
            return float("inf")
        return self.buffer.sample(time_s, self.skeleton).age_s

    # -------------------------------------------------------------------------- the frame
    def frame(self, time_s: float) -> FrameResult | None:
        """Advance the garments to ``time_s``; None when nothing new was simulated."""
        if self._specs_changed():  # also after a refused spec: its fix dresses again
            self._log("info", "spec_changed", "a garment spec or mesh file changed: dressing again")
            self.set_garments(self.garments, self.resolution)
        if self.character is None:
            return self._dress_when_ready(time_s)
        if time_s <= self.last_time:
            if self.last_time - time_s > CLOCK_JUMP_BACK_S:
                dropped = self.buffer.forget_dynamic()  # their stamps are in the new clock's future
                return self._redress(time_s, "clock_jumped_back", f"the clock jumped back from "
                                     f"{self.last_time:.3f} s to {time_s:.3f} s; forgot the {dropped} moving "
                                     "frames' history, dressing again")
            # T_next = D_last + now goes back a little after a slow frame: normal, counted, logged quietly
            return self._skip("time_not_advancing", f"frame time {time_s:.6f} s is not after the last "
                              f"frame's {self.last_time:.6f} s", "info")
        sample = self.buffer.sample(time_s, self.skeleton)
        if sample.status not in _USABLE:
            replaced = self._replaced_frames(time_s)
            if replaced:
                return replaced
            return self._skip(sample.status.value, f"skeleton {sample.status.value} at {time_s:.3f} s: "
                              f"{sample.detail}; holding the last frame")
        if time_s - self.last_time > RESUME_GAP_S and not self._just_dressed:
            return self._redress(time_s, "resumed_after_gap", f"{time_s - self.last_time:.2f} s since the last "
                                 "frame; dressing again at the current pose")
        tic = time.perf_counter()
        frame_s = time_s - self.last_time
        budget_s = self.params.max_substeps * self.params.substep  # what one frame can simulate
        # Right after dressing (which took a while) or a hold, cover the gap in frames the solver can
        # simulate in full instead of one frame that lags for good: the body's motion is in the buffer
        # (interpolated across a hold).
        pieces = min(math.ceil(frame_s / budget_s), MAX_CATCH_UP_FRAMES) if self._catching_up else 1
        self._catching_up = pieces > 1  # the next frame spans this one's catch-up compute: catch up too
        self._just_dressed = False
        start = self.last_time
        for k in range(1, pieces + 1):
            # out of time for catching up (a busy machine): the rest in one frame, which lags (reported)
            last = k == pieces or time.perf_counter() - tic > self.catch_up_wall_s
            t = time_s if last else start + frame_s * k / pieces
            pose = sample.pose if last else self.buffer.sample(t, self.skeleton).pose
            motion = self.buffer.root_motion(t, t - self.last_time, self.joint_map)
            if motion.status == SampleStatus.DEGENERATE and not last:
                continue  # no heading inside the gap (a pose lying on its side): the next piece spans it
            if pose is None or motion.position is None:
                return self._skip("root_motion_" + motion.status.value, f"skeleton at {t:.3f} s: {motion.detail}")
            jump = float(np.linalg.norm(motion.position - self.character.root.position))
            # a jump in the data, not the way the body walked while the loop lagged (a slow dressing)
            if jump > self.params.teleport_distance and jump > MAX_ROOT_SPEED * (t - self.last_time):
                # the history before the jump would put thousands of m/s^2 into the root's kinematics
                self.buffer.forget_dynamic()
                return self._redress(time_s, "teleported", f"the root jumped {jump:.2f} m by {t:.3f} s (more than "
                                     f"teleport_distance {self.params.teleport_distance} m); forgot the motion "
                                     "before the jump, dressing again at the new pose")
            reports = self.character.step(pose, motion, t)
            self.last_time = t
            if last:
                break
        step_s = time.perf_counter() - tic
        self._running(time_s)
        return FrameResult(time_s, sample.pose, reports, frame_s, step_s, self.character.max_penetration(), False,
                           self._pose_time(time_s, sample.age_s))

    def _running(self, time_s: float) -> None:
        if self.status != Status.RUNNING:
            self._log("info", "status", f"simulating {', '.join(self.garments)} on the skeleton under "
                                        f"{self.skeleton.names[0]!r}")
        self.status, self.detail = Status.RUNNING, ""
        self.last_time = time_s

    def _skip(self, reason: str, message: str, level: str = "warning") -> None:
        self.counts[reason] += 1
        if level == "warning":
            self.status, self.detail = Status.HOLDING, message
            self._catching_up = True  # when the skeleton is back, follow it across the gap in full frames
        self._log(level, reason, message)
        return None

    def _redress(self, time_s: float, reason: str, message: str) -> FrameResult | None:
        self.counts[reason] += 1
        self._log("warning", reason, message)
        self.character = None
        return self._dress_when_ready(time_s)

    def _replaced_frames(self, time_s: float) -> FrameResult | None:
        """Another skeleton under the prefix: ours stopped while frames not in it arrive. Forget ours, dress it."""
        fresh = self.buffer.fresh_frames(time_s - self.buffer.max_age_s)
        ours = set(self.skeleton.names)
        stopped = sorted((ours & self.buffer.fresh_frames(-math.inf)) - fresh)  # our moving frames gone quiet
        # A skeleton, not a stray frame: new frames under the fixed frame, at least half as many as ours.
        arriving = sorted(f for f in fresh - ours if f.startswith(self.frame_prefix) and self._under_fixed_frame(f))
        if not stopped or len(arriving) < len(ours) / 2:
            return None
        self.buffer.forget_frames(stopped)
        self._refused = self._candidate = None
        return self._redress(time_s, "skeleton_changed", f"the skeleton changed: {len(stopped)} frames stopped "
                             f"(e.g. {stopped[0]!r}) while {len(arriving)} new ones arrive (e.g. {arriving[0]!r}); "
                             "mapping, fitting and dressing again")

    def _under_fixed_frame(self, frame: str) -> bool:
        while frame is not None and frame != self.buffer.fixed_frame:
            frame = self.buffer.parent(frame)  # the buffer refuses cycles: this ends
        return frame is not None

    def clock_not_started(self) -> None:
        """The node's clock reads zero (``use_sim_time`` and no /clock yet): say so (the node's frame
        timer runs on that clock and does not fire)."""
        self.counts["no_clock"] += 1
        self._wait(Status.WAITING if self.character is None else Status.HOLDING,
                   "use_sim_time is on and no /clock message has arrived yet: waiting for the clock", "warning")

    # -------------------------------------------------------------------------- dressing
    def _find_root(self) -> str | None:
        if self.root_frame:
            return self.root_frame if self.root_frame in self.buffer.frames else None
        fixed = self.buffer.fixed_frame
        roots = [f for f in self.buffer.frames
                 if f.startswith(self.frame_prefix) and self.buffer.parent(f) == fixed]
        if not roots:
            return None
        # Several children of the fixed frame: the one carrying the largest tree is the skeleton.
        return max(sorted(roots), key=lambda f: len(self.buffer.skeleton_from_tree(f).names))

    def _wait(self, status: str, detail: str, level: str = "info") -> None:
        self.status, self.detail = status, detail
        self._log(level, status, detail)
        return None

    def _dress_when_ready(self, time_s: float) -> FrameResult | None:
        root = self._find_root()
        if root is None:
            where = repr(self.root_frame) if self.root_frame else f"a child of {self.buffer.fixed_frame!r}" + (
                f" named {self.frame_prefix}..." if self.frame_prefix else "")
            return self._wait(Status.WAITING, f"waiting for the skeleton: no transform of {where} yet")
        skeleton = self.buffer.skeleton_from_tree(root)
        if skeleton != self._candidate:  # still growing, or changed: wait one more frame
            self._candidate = skeleton
            return self._wait(Status.WAITING, f"waiting for the skeleton under {root!r} to be complete "
                                              f"({len(skeleton.names)} frames so far)")
        if skeleton == self._refused:
            return self._wait(Status.UNMAPPABLE, self.detail, "error")
        sample = self.buffer.sample(time_s, skeleton)
        if sample.status not in _USABLE:
            return self._wait(Status.WAITING, f"waiting for the skeleton under {root!r}: {sample.status.value}: "
                                              f"{sample.detail}")
        reason, unsettled = self._bones_settled(skeleton, time_s, sample.pose)
        if unsettled:
            if reason:
                self.counts[reason] += 1
            return self._wait(Status.WAITING, f"waiting for the skeleton under {root!r}: {unsettled}",
                              "warning" if reason else "info")
        tic = time.perf_counter()
        try:
            character, joint_map = self._build(skeleton, sample.pose)
        except (ValueError, KeyError) as err:  # JointMapError, BodyConfigError, impossible geometry
            self._refused = skeleton
            self.counts["setup_failed"] += 1
            return self._wait(Status.UNMAPPABLE, f"cannot dress the skeleton under {root!r}: {err}", "error")
        motion = self.buffer.root_motion(time_s, 1.0 / 60.0, joint_map)
        if motion.status == SampleStatus.DEGENERATE:  # no heading to dress around: wait for a usable pose
            self.counts["root_motion_degenerate"] += 1
            return self._wait(Status.WAITING, f"cannot dress the skeleton under {root!r}: {motion.detail}", "warning")
        character.dress(sample.pose, time_s, motion if motion.position is not None else None)
        self.character, self.skeleton, self.joint_map = character, skeleton, joint_map
        self._catching_up = self._just_dressed = True
        self._log("info", "dressed", f"dressed {', '.join(self.garments)} ({self.mass_points} mass points) on "
                                     f"{len(skeleton.names)} frames under {root!r}")
        self._running(time_s)
        return FrameResult(time_s, sample.pose, [], 0.0, time.perf_counter() - tic, character.max_penetration(), True,
                           self._pose_time(time_s, sample.age_s))

    def _pose_time(self, time_s: float, age_s: float) -> float:
        """When the sampled pose is for: the buffer extrapolates at most max_extrapolation_s past its data."""
        return time_s - max(0.0, age_s - self.buffer.max_extrapolation_s)

    def _build(self, skeleton: Skeleton, pose: SkeletonPose) -> tuple[DressedCharacter, dict[str, str]]:
        prefix = self.frame_prefix
        bare = Skeleton(tuple(n[len(prefix):] if n.startswith(prefix) else n for n in skeleton.names),
                        skeleton.parents)
        if self.joint_map_file:
            bare_map = load_joint_map(self.joint_map_file, bare)
        else:
            bare_map = auto_joint_map(bare, pose.positions)
        joint_map = {role: skeleton.names[bare.index(name)] for role, name in bare_map.items()}
        overrides = load_body_overrides(self.body_file) if self.body_file else None
        self._spec_stamps = {Path(g): Path(g).stat().st_mtime for g in self.garments if Path(g).is_file()}
        specs = [resolve_garment(g, self.garment_path) for g in self.garments]
        self._spec_stamps.update({f: f.stat().st_mtime for s in specs for f in (s.path, s.mesh) if f is not None})
        body = fit_body(canonical_pose(pose, joint_map), joint_map, detailed=any(s.detailed_body for s in specs),
                        overrides=overrides)
        if body.estimated:
            self._log("warning", "estimated", f"body measurement(s) {', '.join(body.estimated)} were out of human "
                      "range for this skeleton and were estimated from its height; override them with body_file")
        character = DressedCharacter(body, specs, self.params, self.resolution)
        for note in character.notes:
            self._log("warning", "moved_out", note)
        return character, joint_map

    def _bones_settled(self, skeleton: Skeleton, time_s: float, pose: SkeletonPose) -> tuple[str, str]:
        """``("", "")`` if the bones seen at ``time_s`` are those of ``BONE_CHECK_S`` earlier, else a reason
        (a counts key, or "" for a plain wait) and what is wrong: the canonical pose is built from them, so
        a skeleton that has not been seen for that long, or is still being scaled or re-rigged, is not
        fitted yet."""
        earlier = self.buffer.sample(time_s - BONE_CHECK_S, skeleton)
        if earlier.status != SampleStatus.OK:  # not seen that long ago: wait for the history
            return "", f"its bones are checked over {BONE_CHECK_S:g} s of data first"
        now_t, before_t = local_transforms(pose)[0][1:], local_transforms(earlier.pose)[0][1:]
        lengths, before = np.linalg.norm(now_t, axis=1), np.linalg.norm(before_t, axis=1)
        change = np.abs(lengths - before)
        worst = int(np.argmax(change)) if len(change) else 0
        if len(change) and change[worst] > BONE_TOLERANCE_M + BONE_TOLERANCE * before[worst]:
            return "bones_changing", (f"to hold still in shape: bone {skeleton.names[worst + 1]!r} is "
                                      f"{lengths[worst]:.4f} m long now and {before[worst]:.4f} m "
                                      f"{BONE_CHECK_S:g} s earlier")
        return "", ""

    def _log(self, level: str, key: str, message: str) -> None:
        if self.logger is None or not self.throttle.ready(key):
            return
        # one call per severity: rclpy's logger refuses two severities from one line of code
        if level == "error":
            self.logger.error(message)
        elif level == "warning":
            self.logger.warning(message)
        else:
            self.logger.info(message)
