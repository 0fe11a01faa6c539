"""Frame retries and replays (``frame_retries``, ``replay_frames``; beyond the memo, issue 11): the retry policy of
``GarmentSolver.advance``.

A frame that starts with the garment whole and ends with a bone through it or a spring torn past 1.5x (or the
springs' p99 past 1.05), one that ends more damaged than it started (``_worse``; with ``replay_frames``), and any
frame with a spring past the guard's 10x, runs again from its start with twice the substeps, up to
``frame_retries`` times, and the least damaged try is kept (``RETRY_STRETCH``); an adaptive step that pays only where
the cloth went wrong, as production cloth solvers retry a failed step with smaller ones. Replays (``replay_frames``,
on by default since 2026-12-03; 0 turns them off): where no retry of the frame mends it, the frames before it run
again with it from their start, with more substeps (``_replay``): the cause of a tear can lie a frame or two back.
``retry_budget`` bounds the wall clock a frame's tries take (the node's real time).

``FrameRetries`` is a mixin of ``GarmentSolver``: it runs the solver's substeps (``_substeps``) and reads its
``params``, ``state``, ``collider``, stretch figures and the frame history it keeps (``_history``, ``_whole``,
``_last_damage``).
"""

from __future__ import annotations

import time
from typing import NamedTuple

from .frame import ClothState, FrameInput, FrameReport
from .model import STRETCH_MAX_TARGET, STRETCH_P99_TARGET, stretch_figures

# ``FrameRetries._damage``'s lead when none ran away, no bone is through, none torn, the p99 within its target
_WHOLE = (False, 0, False, 0.0)


class PlannedFrame(NamedTuple):
    """A frame as ``GarmentSolver.advance`` planned it, kept for ``_replay``."""

    frame: FrameInput
    count: int  # planned substeps
    h: float  # s, their length
    dt: float  # s, the frame's length
    poses0: tuple  # the volumes' (positions, rotations) in the simulation frame at the frame's start
    poses1: tuple  # and at its end


class FrameRetries:
    """``GarmentSolver``'s frame retries and replays (see the module docstring)."""

    def _tries(self, planned: PlannedFrame, last_good: ClothState, report: FrameReport) -> tuple:
        """Run ``planned`` from ``last_good`` (the solver's state on entry), again with twice the substeps while
        the retry policy asks (see the module docstring), then with the frames before it (``_replay``); leave the
        least damaged try in ``self.state`` and return it as (damage, state, substeps, substep length, the
        collision's counters)."""
        params = self.params
        count, h = planned.count, planned.h
        checked = self._checked()
        retries = params.frame_retries if checked and self._whole else 0
        start = self._last_damage  # what the frame starts with (``_worse``)
        replaying = self._replays()  # frames that grow worse retried, replays
        best = None  # (damage, state, substeps, substep length, the collision's counters) of the best try
        started = time.perf_counter()
        while True:
            try_started = time.perf_counter()
            self._substeps(planned.frame, count, h, planned.dt, planned.poses0, planned.poses1, report)
            self._measure_stretch(report)
            damage = self._damage(report) if checked else None
            if best is None or damage < best[0]:
                best = self._try_result(damage, count, h, report)
            if report.retries == 0 and checked and (damage[0] or (replaying and self._worse(damage, start))):
                retries = params.frame_retries  # the guard would fire, or it grew worse: again whatever the start
            if retries == 0 or damage[:4] == _WHOLE:
                break
            now = time.perf_counter()  # the next try has twice the substeps: about twice this one's time
            if params.retry_budget > 0.0 and now - started + 2.0 * (now - try_started) > params.retry_budget:
                report.retries_cut = True
                break
            retries -= 1  # again from the frame's start, substeps half as long (see RETRY_STRETCH)
            self.state = last_good.copy()
            count, h = 2 * count, 0.5 * h
            report.retries += 1
        if (checked and replaying and self._history and best[0][:4] != _WHOLE and not report.retries_cut
                and (self._whole or self._worse(best[0], start))):
            best = self._replay(planned, last_good, best, report, started)
        if best[1] is not self.state:  # an earlier try was better: it is kept
            self.state = best[1]
            self._measure_stretch(report)
        if checked:
            self._whole, self._last_damage = best[0][:4] == _WHOLE, best[0]
        return best

    def _checked(self) -> bool:
        """Frames are judged and retried (``frame_retries`` on, the garment collides)."""
        return self.params.frame_retries > 0 and self.collider is not None

    def _replays(self) -> bool:
        """Frames that grow worse are retried and frames no retry mends replayed (``replay_frames`` on, checked)."""
        return self._checked() and self.params.replay_frames > 0

    # Replays (``replay_frames``; issue 11, 2026-12-02): the cartwheel's skirts at 1x 30 fps tear at 2.5 s, the skirt
    # flipped over the chest falling back onto a forearm that lies across the belly at the waistband; no retry of
    # that frame mends it (at 32x its substeps too the cloth starts the frame already caught under the forearm), but
    # the frame before it or the two before it run again with 4x or 8x their substeps do. The frames already shown
    # are not taken back: only the state the frame ends with changes.
    REPLAY_SCALES = (4, 8, 16)

    def _replay(self, planned: PlannedFrame, last_good: ClothState, best: tuple, report: FrameReport,
                started: float) -> tuple:
        """Run ``_history``'s frames and this one (``planned``, which started at ``last_good``) again from the
        first's start, at each of ``REPLAY_SCALES`` times their planned substeps, until one ends whole; returns
        ``advance``'s ``best`` with the least damaged end of these and of the frame's own tries."""
        frames = [earlier for _, earlier in self._history] + [planned]
        substeps = sum(f.count for f in frames)
        run = planned.count * (2 ** (report.retries + 1) - 1)  # substeps the frame's tries ran
        for scale in self.REPLAY_SCALES:
            spent = time.perf_counter() - started  # the replay's substeps at the tries' cost per substep
            if self.params.retry_budget > 0.0 and spent * (1.0 + scale * substeps / run) > self.params.retry_budget:
                report.retries_cut = True
                break
            run += scale * substeps
            self.state = self._history[0][0].copy()
            for f in frames:
                self._substeps(f.frame, scale * f.count, f.h / scale, f.dt, f.poses0, f.poses1, report)
            self.state.lag = last_good.lag
            self._measure_stretch(report)
            damage = self._damage(report)
            report.replays += 1
            if damage < best[0]:
                best = self._try_result(damage, scale * planned.count, planned.h / scale, report)
            if damage[:4] == _WHOLE:
                break
        return best

    def _try_result(self, damage: tuple, count: int, h: float, report: FrameReport) -> tuple:
        """``advance``'s ``best`` for the garment as a try of ``count`` substeps of ``h`` s left it: (damage, state,
        substeps, substep length, the collision's counters in ``report``)."""
        return damage, self.state, count, h, (report.static_hits, report.dynamic_hits, report.pressed_depth_m)

    def _worse(self, damage: tuple, start: tuple | None) -> bool:
        """``damage`` (``_damage``) is worse than ``start``, the damage the frame started with (None: unknown, after
        a reset or a carry): newly run away, more bones through, newly torn, or the springs' p99 further past its
        target by more than ``WORSE_P99``."""
        return start is not None and (damage[:3] > start[:3] or damage[3] > start[3] + self.WORSE_P99)

    # How much further past RETRY_P99 the springs' p99 must end than the frame started for the frame to count as
    # worse (``_worse``): a lasting stretch that drifts a little from frame to frame is not retried every frame
    WORSE_P99 = 0.01

    # Frame retries (``frame_retries``; issue 11): a frame that starts with the cloth whole and ends torn -- a
    # structural or shear spring longer than RETRY_STRETCH (the target (d)'s maximum, visible tearing), their 99th
    # percentile past RETRY_P99 (its p99) -- or with a volume's bone through a triangle (target (b)) runs again from
    # its start with twice the substeps, up to ``frame_retries`` times, and the least damaged try is kept
    # (``_damage``'s order). Only from a whole start: where the damage lasts (the CC jump's crouch, its trousers'
    # seat short of cloth for 19 frames) retrying every frame cost those runs 1.7x their time, and passed no more
    # runs of the full protocol (200 of 216 either way, docs/real_motion.md). But a try the guard would re-fit (a
    # spring past RUNAWAY_STRETCH) is retried whatever the start, and ranks below every try that did not run away:
    # the cartwheel's skirts at 1x 30 fps kept a 0-bone try at 11.7x over a 1-bone one at 4.6x, and the guard
    # fired; with five retries a try at 16x and 32x the substeps mends both (2026-12-02, second session). And a frame
    # that ends worse than it started (``_worse``) is retried too: damage that lasts is not retried frame after frame,
    # but damage that grows is (2026-12-02, fourth session, with ``replay_frames``; docs/real_motion.md).
    RETRY_STRETCH = STRETCH_MAX_TARGET
    RETRY_P99 = STRETCH_P99_TARGET

    def _damage(self, report: FrameReport) -> tuple[bool, int, bool, float, float]:
        """How damaged the garment is now, in the order the retries compare tries: run away (a spring past
        ``RUNAWAY_STRETCH``, which the guard would re-fit), the volumes' bones through a triangle
        (``Collider.bones_through``), torn (a spring past ``RETRY_STRETCH``), how far the worst 99th percentile is
        past ``RETRY_P99``, the longest spring (length / rest length); ``_WHOLE`` leads it when nothing is damaged.
        ``report.max_stretch`` is the garment's now (``_measure_stretch``)."""
        crossed = self.collider.bones_through(self.state.positions, self._triangles)
        return (report.max_stretch > self.RUNAWAY_STRETCH, crossed, report.max_stretch > self.RETRY_STRETCH,
                max(self._worst_p99() - self.RETRY_P99, 0.0), report.max_stretch)

    def _worst_p99(self) -> float:
        """The larger of the structural and the shear springs' 99th percentile of length / rest length now (the
        metric's, ``model.stretch_figures``)."""
        return max(p99 for p99, _ in stretch_figures(self.stretches, self._stretch_groups).values())
