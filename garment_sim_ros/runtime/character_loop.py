"""One character's frame loop, between the /tf pose buffer and the garments (ROS-free).

The node calls ``frame(T)`` once per timer tick with ``T = D_last + now`` (memo §3); this
module decides what happens:

1. No character yet: wait for a complete skeleton under the fixed frame within the frame prefix
   (the same tree on two consecutive frames, every frame sampled), map it (``auto_joint_map`` on
   the names without the prefix, or ``joint_map_file``), stand it up (``canonical_pose``: the bones
   seen on /tf, checked to be the same a moment earlier, in the canonical standing pose), fit the
   body (detailed volumes when a one-piece is worn), build the ``DressedCharacter`` and dress it
   at ``T``. A skeleton that cannot be mapped is logged with the
   missing roles and retried only when the tree changes; the loop keeps waiting.
2. Running: sample the skeleton and root motion at ``T`` and step every garment from the last
   frame. Stamps are the truth: the buffer extrapolates at most ``max_extrapolation`` past its
   newest data, so a frame whose ``T`` is further ahead is simulated to that pose's time instead
   (the result's ``time_s``, the stamp the node publishes), and held when that is no later than the
   last frame (``no_new_pose``); while the skeleton is older than ``max_extrapolation`` at the clock
   the status is ``BEHIND``. A ``T`` not after the last frame's (``T_next = D_last + now`` goes back
   after a slow frame) is folded into the next frame, counted (``folded_into_next``), not logged.
   Stale or missing skeleton data (``PoseBuffer`` statuses) hold: nothing is simulated, the last
   good state stays, the hold is counted and logged (throttled; not the first stale frame when the
   data was fresh at the last one: our own compute, e.g. dressing, let it age). After a pause longer
   than ``RESUME_GAP_S`` (the skeleton stopped, or
   the clock jumped back more than ``CLOCK_JUMP_BACK_S``, a looped bag) the garments are dressed
   again at the new pose instead of being dragged across the gap in one frame. Dressing takes a
   while (about a second of simulation, more on a busy machine) and a shorter hold leaves a gap
   too: the frame after either covers it in pieces the solver simulates in full (``max_substeps``
   each, at most ``MAX_CATCH_UP_FRAMES`` and ``catch_up_wall_s`` of compute), so the garment is
   not dragged across the gap in a few substeps; the frame after a catch-up catches up too while
   that gains (``CATCH_UP_GAIN``: on a machine too slow for it, it would never end). Otherwise a frame longer than
   ``max_substeps x substep`` lags (memo §3), which the diagnostics report; so does what a
   catch-up could not cover.
3. Bad input while running (each counted in ``counts`` under its reason and logged, throttled):
   the clock jumping back more than ``CLOCK_JUMP_BACK_S`` also forgets the buffer's dynamic
   transforms (their stamps are in the new clock's future) and dresses again when the skeleton
   is back (``clock_jumped_back``); a skeleton replaced mid-run (its frames stop while frames not
   in it arrive under the prefix: another clip with other names) forgets the stopped frames and
   maps, fits and dresses the new one (``skeleton_changed``); a root jump longer than the
   ``teleport_distance`` parameter within a frame, faster than ``MAX_FRAME_SPEED`` (a clip looping
   back, confirmed by the buffer: the next sample stayed there, the motion before it dropped; a lone
   outlier never reaches the loop) dresses the garments again at the new pose instead of dragging
   them along (``teleported``); a body that walked on while the data or the loop stalled is slower
   than that, and lags; a
   pose whose hips coincide horizontally has no heading and holds (``root_motion_degenerate``); a joint
   glitch the buffer dropped (``body.glitches``; the loop sets its ``max_joint_speed`` and
   ``max_glitch_time`` from the parameters) is logged with the frame and the angle; a
   node clock that has not started (``use_sim_time`` without /clock) waits (``no_clock``, from
   ``clock_not_started``). Several skeletons under the fixed frame that ``frame_prefix`` does not
   tell apart: the largest is dressed, and a warning names them all and the one picked.

Quality meters (``quality``: depth, limb bones through the cloth, trouser legs off, stretch p99) are the
largest cost of a frame outside the solver; they run on the first frame at least ``1 / quality_rate_hz``
of body time after the last measured one, on the first frame after dressing and on a frame the solver's
guard fired in (``FrameResult.measured``; the default, infinite, measures every frame; the node passes its
``quality_rate_hz`` parameter). A frame made of catch-up pieces measures its last piece only (the one
whose reports it returns). ``quality_phase`` (0-1, a fraction of the meters' period) delays the second
measurement after dressing by that much: a crowd's characters, dressed on one tick, then measure on
different ticks (``runtime.crowd.make_members``), not all on every 6th one.

Changing garments or resolution (``set_garments``) re-dresses at the next frame, and so does a
saved spec or mesh file of a worn garment (``check_specs``, from the node's file-watch timer: the
frame itself touches no file); solver parameters (``set_params``) apply from the next step on.
Finding, checking and mapping the skeleton: ``skeleton_setup``; logging: ``events``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..body.canonical import canonical_pose
from ..body.jumps import is_jump
from ..body.overrides import load_body_overrides
from ..body.pose_buffer import PoseBuffer, SampleStatus
from ..body.skeleton import Skeleton, SkeletonPose
from ..cloth.solver import FrameReport
from ..cloth.spec import resolve_garment
from ..dressing import DressedCharacter, make_character
from ..params import SolverParams
from .events import EventLog
from .file_watch import FilesWatch
from .skeleton_setup import bones_unsettled, map_joints, skeleton_roots

RESUME_GAP_S = 1.0  # a hold longer than this re-dresses (the body moved arbitrarily meanwhile)
MAX_CATCH_UP_FRAMES = 25  # a frame covers a gap in at most this many full frames (1 s by default)
CATCH_UP_WALL_S = 0.1  # ...and spends at most about this long on them (a busy machine lags instead)
# The frame after a catch-up spans the catch-up's own compute, so catching up goes on only while it gains: a catch-up
# that took more than this fraction of the time it covered stops, and the frames after it lag (reported) instead. On
# a machine where a full frame costs about its span (a 2-core EPYC, the one-piece on the 142-joint rig: ~35 ms per
# 40 ms), "the next frame catches up too" never ended: every tick was ~0.19 s of catch-up pieces, 5 fps (issue 17).
CATCH_UP_GAIN = 0.5
CLOCK_JUMP_BACK_S = 1.0  # a clock this far behind the last frame restarts (sim time reset, looped bag)
BEHIND_WARNING_S = 1.0  # running behind the clock this long is logged (the status says so at once)
_USABLE = (SampleStatus.OK, SampleStatus.EXTRAPOLATED)


class Status:
    WAITING = "waiting for skeleton"
    UNMAPPABLE = "skeleton cannot be mapped"
    RUNNING = "running"
    HOLDING = "holding (skeleton stale or missing)"
    BEHIND = "running behind the clock (skeleton older than max_extrapolation)"


@dataclass
class FrameResult:
    """A simulated frame: the garments are at ``time_s``, the time of the skeleton pose they were
    simulated on (the frame time, or the newest pose's when the skeleton is older than max_extrapolation)."""

    time_s: float
    pose: SkeletonPose
    reports: list[FrameReport]  # one per garment; empty for the frame that dressed the character
    frame_s: float  # body time since the last frame, s (0 when dressed)
    step_s: float  # wall time of stepping (or dressing), s
    penetration_m: float  # deepest free garment point inside a volume after the frame, m; nan when not measured
    dressed: bool  # this frame put the garments on (first skeleton, new garments, after a gap)
    measured: bool = True  # the quality meters ran: the reports' quality figures and penetration_m are this frame's
    # the solver guard's events (``FrameReport.recovery``) of the catch-up pieces before the last, one per event:
    # the frame's reports are its last piece's, and a step restored in an earlier piece is counted all the same
    catch_up_recoveries: tuple[str, ...] = ()


class CharacterLoop:
    """The garments on the character whose frames start with ``frame_prefix`` in ``buffer``."""

    def __init__(self, buffer: PoseBuffer, params: SolverParams, garments: Sequence[str], resolution: float,
                 frame_prefix: str = "", root_frame: str = "", joint_map_file: str = "", logger=None,
                 catch_up_wall_s: float = CATCH_UP_WALL_S, body_file: str = "", garment_path: Sequence[str] = (),
                 on_event=None, quality_rate_hz: float = math.inf, quality_phase: float = 0.0):
        self.buffer = buffer
        self.quality_rate_hz = quality_rate_hz  # quality meters at most this often in body time, Hz
        self.quality_phase = quality_phase  # the meters' schedule after dressing delayed by this part of a period
        self._measured_at: float | None = None  # body time of the last measured frame (None: measure the next)
        self.events = EventLog(logger, on_event)  # on_event(level, kind, message): the Rerun recording's text log
        self._glitches_logged = 0  # the buffer's joint glitches up to the last one logged
        self.garments = list(garments)
        self.resolution = float(resolution)
        self.garment_path = tuple(garment_path)
        self._spec_files = FilesWatch()  # the dressed garments' spec and mesh files
        self.frame_prefix = frame_prefix
        self.root_frame = root_frame
        self.joint_map_file = joint_map_file
        self.body_file = body_file
        self.catch_up_wall_s = catch_up_wall_s
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
        self._last_now_s: float | None = None  # the clock at the last frame
        self._behind_since: float | None = None  # monotonic time since the skeleton is behind the clock
        self._behind_detail = ""
        self._ambiguous: list[str] = []  # the skeletons last named as matching together
        self.set_params(params)

    # -------------------------------------------------------------------------- configuration
    def set_params(self, params: SolverParams) -> None:
        self.params = params
        # one rule for a jump: the buffer confirms it, the loop re-dresses; and one for a joint glitch
        self.buffer.jump_distance_m = params.teleport_distance
        self.buffer.max_joint_speed, self.buffer.max_glitch_time = params.max_joint_speed, params.max_glitch_time
        if self.character is not None:
            self.character.set_params(params)

    def set_garments(self, garments: Sequence[str], resolution: float,
                     garment_path: Sequence[str] | None = None) -> None:
        """Wear other garments (or the same at another resolution): re-dressed at the next frame."""
        self.garments = list(garments)
        self.resolution = float(resolution)
        if garment_path is not None:
            self.garment_path = tuple(garment_path)
        self._spec_files = FilesWatch()
        self.character = None
        self._refused = None

    def check_specs(self) -> bool:
        """Dress again (at the next frame) when a worn garment's spec or mesh file was saved since it was
        read, also after a refused spec: its fix dresses again. For a low-rate timer, not the frame: it
        looks at the files."""
        if not self._spec_files.changed():
            return False
        self.events.log("info", "spec_changed", "a garment spec or mesh file changed: dressing again")
        self.set_garments(self.garments, self.resolution)
        return True

    @property
    def mass_points(self) -> int:
        return 0 if self.character is None else sum(s.model.num_points for s in self.character.solvers)

    def skeleton_age(self, time_s: float) -> float:
        """How old the skeleton's newest data is at ``time_s`` (inf before any)."""
        if self.skeleton is None:
            return float("inf")
        return self.buffer.sample(time_s, self.skeleton).age_s

    # -------------------------------------------------------------------------- the frame
    def frame(self, time_s: float, now_s: float | None = None) -> FrameResult | None:
        """Advance the garments to ``time_s``, or to the newest pose the skeleton has when that is older
        (stamps are the truth: never simulated on a pose the buffer does not have); None when nothing
        new was simulated. ``now_s``, the clock when the frame was asked (default ``time_s``; the node's
        ``time_s`` leads it by the last frame's compute): staleness is judged there."""
        now_s = time_s if now_s is None else now_s
        last_now_s, self._last_now_s = self._last_now_s, now_s
        self._note_glitches()
        if self.character is None:
            return self._dress_when_ready(time_s)
        if time_s <= self.last_time:
            if self.last_time - time_s > CLOCK_JUMP_BACK_S:
                dropped = self.buffer.forget_dynamic()  # their stamps are in the new clock's future
                return self._redress(time_s, "clock_jumped_back", f"the clock jumped back from "
                                     f"{self.last_time:.3f} s to {time_s:.3f} s; forgot the {dropped} moving "
                                     "frames' history, dressing again")
            # T_next = D_last + now goes back a little after a slow frame: this frame's time is folded
            # into the next one's (nothing is lost: the next frame starts from last_time); counted only
            self.counts["folded_into_next"] += 1
            return None
        sample = self.buffer.sample(time_s, self.skeleton)
        lead_s = time_s - now_s
        if sample.status == SampleStatus.STALE and sample.age_s - lead_s <= self.buffer.max_age_s:
            sample = dataclasses.replace(sample, status=SampleStatus.EXTRAPOLATED)  # stale only by our lead
        if sample.status not in _USABLE:
            replaced = self._replaced_frames(time_s)
            if replaced:
                return replaced
            # the data was fresh at the last frame: it went stale during our own compute (dressing blocks
            # a player in the same process); held and counted, said when it lasts to the next frame
            quiet = (sample.status == SampleStatus.STALE and last_now_s is not None
                     and sample.age_s - (time_s - last_now_s) <= self.buffer.max_age_s)
            return self._hold(sample.status.value, f"skeleton {sample.status.value} at {time_s:.3f} s: "
                              f"{sample.detail}; holding the last frame", warn=not quiet)
        pose_time = self._pose_time(time_s, sample.age_s)
        if pose_time <= self.last_time:  # no pose newer than the garments': held, not simulated past the data
            self.counts["no_new_pose"] += 1
            return None
        self._note_behind(sample.age_s - lead_s)
        if pose_time < time_s:
            time_s, sample = pose_time, self.buffer.sample(pose_time, self.skeleton)
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
        if pieces > 1:
            self.counts["catch_up_frames"] += 1  # diagnostics loop_catch_up_frames
        self._just_dressed = False
        start = self.last_time
        catch_up_recoveries: list[str] = []
        for k in range(1, pieces + 1):
            # out of time for catching up (a busy machine): the rest in one frame, which lags (reported)
            last = k == pieces or time.perf_counter() - tic > self.catch_up_wall_s
            t = time_s if last else start + frame_s * k / pieces
            pose = sample.pose if last else self.buffer.sample(t, self.skeleton).pose
            motion = self.buffer.root_motion(t, t - self.last_time, self.joint_map)
            if motion.status == SampleStatus.DEGENERATE and not last:
                continue  # no heading inside the gap (a pose lying on its side): the next piece spans it
            if pose is None or motion.position is None:
                return self._hold("root_motion_" + motion.status.value, f"skeleton at {t:.3f} s: {motion.detail}")
            jump = float(np.linalg.norm(motion.position - self.character.root.position))
            # The buffer confirmed the jump (the next sample stayed there) and dropped the motion before it. A
            # body that walked on while the data or the loop stalled moves slower than a jump: lag.
            if is_jump(jump, t - self.last_time, self.params.teleport_distance):
                return self._redress(time_s, "teleported", f"the root jumped {jump:.2f} m by {t:.3f} s (more than "
                                     f"teleport_distance {self.params.teleport_distance} m, confirmed by the next "
                                     "sample); dressing again at the new pose")
            measured = last and self._quality_due(t)
            reports = self.character.step(pose, motion, t, measure=measured)
            if last and not measured and any(r.recovery for r in reports):  # a step gone bad: how it ended up
                self.character.measure(reports, pose)
                measured = True
            self.last_time = t
            if last:
                break
            catch_up_recoveries += [r.recovery for r in reports if r.recovery]
        step_s = time.perf_counter() - tic
        # The next frame spans this one's catch-up compute: it catches up too, if that gains (else it lags)
        self._catching_up = pieces > 1 and step_s <= CATCH_UP_GAIN * frame_s
        self._running(time_s)
        penetration_m = max((r.max_depth_m for r in reports), default=0.0) if measured else math.nan
        return FrameResult(time_s, sample.pose, reports, frame_s, step_s, penetration_m, False, measured,
                           tuple(catch_up_recoveries))

    def _note_glitches(self) -> None:
        """The joint glitches the buffer dropped since the last frame: logged (throttled; counted there)."""
        count = self.buffer.adjusted["joint_glitch"]
        if count > self._glitches_logged:
            self._glitches_logged = count
            self.events.log("warning", "joint_glitch", f"joint glitch in the skeleton input, replaced by the joint's "
                            f"motion around it ({count} so far, diagnostics glitch_<frame>): {self.buffer.last_glitch}")

    def _quality_due(self, time_s: float) -> bool:
        """Measure the frame at ``time_s``: the first after dressing, or ``1 / quality_rate_hz`` after the last
        measured one (1 us of slack: at 60 fps and 10 Hz every 6th frame, whatever the rounding)."""
        due = self._measured_at is None or time_s - self._measured_at >= 1.0 / self.quality_rate_hz - 1e-6
        if due:
            delay = self.quality_phase / self.quality_rate_hz if self._measured_at is None else 0.0
            self._measured_at = time_s + delay
        return due

    def _note_behind(self, age_s: float) -> None:
        """Running on a pose older than max_extrapolation at the clock: the status says so (diagnostics
        WARN), and the log once it lasted ``BEHIND_WARNING_S``."""
        behind = age_s > self.buffer.max_extrapolation_s
        if not behind:
            self._behind_since = None
            return
        if self._behind_since is None:
            self._behind_since = time.monotonic()
        self.counts["behind_skeleton"] += 1
        message = (f"the skeleton's newest pose is {age_s:.3f} s old at the clock (more than max_extrapolation "
                   f"{self.buffer.max_extrapolation_s} s): the garments follow it, markers carry its time")
        if time.monotonic() - self._behind_since > BEHIND_WARNING_S:
            self.events.log("warning", "behind", message)
        self._behind_detail = message

    def _running(self, time_s: float) -> None:
        if self.status not in (Status.RUNNING, Status.BEHIND):
            self.events.log("info", "status", f"simulating {', '.join(self.garments)} on the skeleton under "
                                              f"{self.skeleton.names[0]!r}")
        self.status, self.detail = Status.RUNNING, ""
        if self._behind_since is not None:
            self.status, self.detail = Status.BEHIND, self._behind_detail
        self.last_time = time_s

    def _hold(self, reason: str, message: str, warn: bool = True) -> None:
        """Nothing simulated: the garments keep their last state (the node publishes it again)."""
        self.counts[reason] += 1
        self.status, self.detail = Status.HOLDING, message
        self._catching_up = True  # when the skeleton is back, follow it across the gap in full frames
        if warn:
            self.events.log("warning", reason, message)
        return None

    def _redress(self, time_s: float, reason: str, message: str) -> FrameResult | None:
        self.counts[reason] += 1
        self.events.log("warning", reason, message)
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
        picked, skeletons = skeleton_roots(self.buffer, self.frame_prefix)
        if len(skeletons) > 1 and sorted(skeletons) != self._ambiguous:
            self._ambiguous = sorted(skeletons)  # said once per set
            self.counts["several_skeletons"] += 1
            self.events.log("warning", "several_skeletons", f"{len(skeletons)} skeletons under "
                            f"{self.buffer.fixed_frame!r} match frame_prefix {self.frame_prefix!r}: "
                            + ", ".join(f"{f!r} ({size} frames)" for f, size in skeletons.items())
                            + f"; dressing {picked!r}. Set frame_prefix (or root_frame) to choose")
        return picked

    def _wait(self, status: str, detail: str, level: str = "info") -> None:
        self.status, self.detail = status, detail
        self.events.log(level, status, detail)
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
        time_s = self._pose_time(time_s, sample.age_s)  # dressed on the newest pose the skeleton has
        reason, unsettled = bones_unsettled(self.buffer, skeleton, time_s, sample.pose)
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
        self._measured_at = None  # the first frame on the new garments is measured
        self.events.log("info", "dressed", f"dressed {', '.join(self.garments)} ({self.mass_points} mass points) "
                                           f"on {len(skeleton.names)} frames under {root!r}")
        self._running(time_s)
        return FrameResult(time_s, sample.pose, [], 0.0, time.perf_counter() - tic, character.max_penetration(), True)

    def _pose_time(self, time_s: float, age_s: float) -> float:
        """When the sampled pose is for: the buffer extrapolates at most max_extrapolation_s past its data."""
        return time_s - max(0.0, age_s - self.buffer.max_extrapolation_s)

    def _build(self, skeleton: Skeleton, pose: SkeletonPose) -> tuple[DressedCharacter, dict[str, str]]:
        joint_map = map_joints(skeleton, pose, self.frame_prefix, self.joint_map_file)
        overrides = load_body_overrides(self.body_file) if self.body_file else None
        # watched before resolving: a refused spec dresses again once it is saved
        self._spec_files = FilesWatch(Path(g) for g in self.garments if Path(g).is_file())
        specs = [resolve_garment(g, self.garment_path) for g in self.garments]
        # watched before dressing: a mesh refused while dressing is retried once its file is saved again
        self._spec_files.add(f for s in specs for f in (s.path, s.mesh) if f is not None)
        character = make_character(canonical_pose(pose, joint_map), joint_map, specs, self.params, self.resolution,
                                   overrides=overrides, motion=[pose])
        if character.body.estimated:
            self.events.log("warning", "estimated", f"body measurement(s) {', '.join(character.body.estimated)} were "
                            "out of human range for this skeleton and were estimated from its height; override them "
                            "with body_file")
        for note in character.notes:
            self.events.log("warning", "moved_out", note)
        return character, joint_map
