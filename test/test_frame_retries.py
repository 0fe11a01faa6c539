"""A frame that tears the cloth or lets a bone through it runs again with twice the substeps (``frame_retries``,
``GarmentSolver.RETRY_STRETCH``; issue 11): measured on real clips against the same frames run once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS, preset

DATA = Path(__file__).parent / "data"
# The retries' and replays' cases as they were measured, without ``tear_give_stretch``: with it their torn springs end
# at its 1.49 rest lengths and those frames are not run again (2026-12-06; the guard's case below plays with it)
TEARING = preset("si").replace(tear_give_stretch=0.0)


def _play_comparing(clip: str, garment: str, speed: float, fps: float):
    """Play ``clip`` as ``evaluate`` does with the defaults; every frame the solver ran again is also run once
    from the same state (``frame_retries`` 0), then the retried result put back; each retried frame keeps the
    least damaged of its tries and replays (asserted as it plays). Returns, per retried frame,
    (the kept try's damage, the first try's, substeps kept, substeps planned: the single run's), and per frame
    (retries, whether it ended undamaged, whether its first try ran away or ended worse than the frame started)."""
    params = TEARING
    source = bvh_source(str(DATA / f"{clip}.bvh"), loop=False, speed=speed, params=params)
    character = make_character(source.rest_pose, source.joint_map, [garment], params, motion=source.fit_poses())
    solver = character.solvers[0]
    advance, damage, once = solver.advance, solver._damage, params.replace(frame_retries=0)
    compared, tries, frames_seen = [], [], []

    def recorded_damage(report):
        tries.append(damage(report))
        return tries[-1]

    def advance_and_compare(frame):
        before, start = solver.state.copy(), solver._last_damage
        tries.clear()
        report = advance(frame)
        if report.retries:
            kept_state, kept = solver.state, damage(report)
            assert len(tries) == report.retries + report.replays + 1 and kept == min(tries), (kept, tries)
            solver.state = before.copy()
            solver.set_params(once)
            history, solver._history = solver._history, []
            single = advance(frame)
            solver._history = history
            # the frame's first try is the frame run once (the run after switching to ``frame_retries`` 0 is not always
            # that to the bit: on the cartwheel one frame in five differed, 2026-12-02; a re-run with the same
            # parameters is, for every retried frame up to it)
            compared.append((kept, tries[0], report.substeps, single.substeps))
            solver.set_params(params)
            solver.state = kept_state
        due = bool(tries) and (tries[0][0] or solver._worse(tries[0], start))  # the guard would fire, or worse
        frames_seen.append((report.retries, solver._whole, due))
        return report

    solver.advance, solver._damage = advance_and_compare, recorded_damage
    frames = int(source.duration * fps)
    for _ in simulate_frames(source, character, np.arange(frames + 1) / fps):
        pass
    return compared, frames_seen


@pytest.mark.parametrize("clip, garment, speed, fps, mends", [
    ("cc_cmu_02_04_jump_balance", "short_skirt", 2.0, 30.0, True),  # a 6.87x spring at 2x 30 fps, run once
    ("cmu_131_01_walk_mjstyle", "long_skirt", 2.0, 60.0, True),  # an ordinary clip
    # the forearm sweeping inside the torso at 2.50 s: frames no try mends (the CC jump's crouch in trousers was
    # this case until the crotch's width ease, 2026-12-02)
    ("cc_cmu_05_06_dance_cartwheel_pirouette", "short_skirt", 1.0, 60.0, False),
])
def test_a_retried_frame_keeps_its_best_try(clip, garment, speed, fps, mends):
    compared, frames_seen = _play_comparing(clip, garment, speed, fps)
    assert compared, "no frame was run again"
    # only a frame that starts undamaged runs again (or one the guard would re-fit, or one that ends worse than it
    # started): damage that lasts is not retried frame after frame
    assert all(retries == 0 for (retries, _, due), (_, whole, _) in zip(frames_seen[1:], frames_seen)
               if not whole and not due)
    for kept, single, substeps, planned in compared:
        assert kept <= single  # the single try is one of the tries: the kept one is never worse
        assert substeps in [planned * 2 ** k for k in range(DEFAULT_PARAMS.frame_retries + 1)]
    if mends:  # a frame torn when run once and whole with more substeps, no bone through it either way
        assert any(single[2] and not kept[2] and kept[1] == 0 for kept, single, _, _ in compared), compared
    else:  # frames no try nor replay mends keep their least damaged try (asserted in ``_play_comparing``); the frames
        # after them run once unless they grow worse (the assertion on ``due`` above)
        assert any(kept[:4] != (False, 0, False, 0.0) for kept, _, _, _ in compared), compared


def test_frames_run_once_without_retries():
    params = TEARING.replace(frame_retries=0)
    source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False, speed=2.0, params=params)
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], params, motion=source.fit_poses())
    frames = int(source.duration * 30.0)
    steps = list(simulate_frames(source, character, np.arange(frames + 1) / 30.0))
    reports = [r[0] for _, _, r in steps if r is not None]
    assert len(reports) == frames
    assert all(r.retries == 0 for r in reports)
    assert max(r.max_stretch for r in reports) > 1.5  # it tears here, run once
    assert preset("memo").frame_retries == 0  # the memo's experiments run each frame once


def test_a_frame_the_guard_would_re_fit_keeps_a_try_that_did_not_run_away():
    """The cartwheel's short skirt at 1x 30 fps, to its end: run once, a spring ends past ``RUNAWAY_STRETCH`` and
    the guard re-fits the garment; the retries find a try that did not run away, which is kept whatever else it has
    (a bone through it rather than a re-fit), and the guard never fires. The threshold is lowered from 10 to 5 rest
    lengths for this solver (guard and retries alike): past 10 the case is a trajectory one machine plays and
    another not (on 2026-12-02's, not on 2026-12-03's); past 5 (2.5 s: 6.69 on the first try, 1.02 kept, measured
    2026-12-03) it is there more broadly, and the mechanism does not depend on the value."""
    params = preset("si")
    source = bvh_source(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), loop=False, params=params)
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], params, motion=source.fit_poses())
    solver = character.solvers[0]
    solver.RUNAWAY_STRETCH = 5.0
    damage, tries, frames_tried = solver._damage, [], []

    def recorded_damage(report):
        tries.append(damage(report))
        return tries[-1]

    solver._damage = recorded_damage
    frames = int(source.duration * 30.0)
    for _, _, reports in simulate_frames(source, character, np.arange(frames + 1) / 30.0):
        if reports is not None:
            frames_tried.append((list(tries), damage(reports[0]), reports[0].recovery))
        tries.clear()
    ran_away = [(tried, kept) for tried, kept, _ in frames_tried if any(t[0] for t in tried)]
    assert ran_away, "no try ran away: the guard's case is not played"
    assert all(not kept[0] for tried, kept in ran_away if not all(t[0] for t in tried))
    assert all(len(tried) > 1 for tried, _ in ran_away)  # retried, whatever the frame's start
    assert not any(recovery for _, _, recovery in frames_tried)


def test_a_retry_budget_stops_the_tries_and_says_so():
    """``retry_budget`` (s of wall clock for a frame's tries): a budget no try fits in (1 ns) runs every frame once
    and reports the frames it cut (``FrameReport.retries_cut``), the first of them the first frame the unbounded
    run retries; unbounded (0), frames are retried and none is cut."""
    runs = {}
    for budget in (1e-9, 0.0):
        params = TEARING.replace(retry_budget=budget)
        source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False, speed=2.0, params=params)
        character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], params,
                                   motion=source.fit_poses())
        frames = int(source.duration * 30.0)
        steps = simulate_frames(source, character, np.arange(frames + 1) / 30.0)
        runs[budget] = [r[0] for _, _, r in steps if r is not None]
    cut, unbounded = runs[1e-9], runs[0.0]
    assert all(r.retries == 0 and r.replays == 0 for r in cut) and any(r.retries_cut for r in cut)
    assert any(r.retries > 0 for r in unbounded) and not any(r.retries_cut for r in unbounded)
    first = next(k for k, r in enumerate(unbounded) if r.retries > 0)
    assert next(k for k, r in enumerate(cut) if r.retries_cut) == first
    assert DEFAULT_PARAMS.retry_budget == 0.0  # evaluate's figures are unbounded


def test_a_replay_keeps_the_least_damaged_end_and_mends_what_the_retries_could_not():
    """``replay_frames``: a frame its retries leave damaged runs again with the frames before it from their start
    (``GarmentSolver._replay``), at 4, 8, 16 x their planned substeps. The CC jump's long skirt at 1x 60 fps, started
    nudged (seed 1, as ``evaluate --nudges``): every replayed frame keeps the least damaged of its tries and replays,
    a replay never starts from a frame older than ``replay_frames``, and a replay ends whole a frame whose tries
    all left damaged (on 2026-12-02 the run fails (d) without replays, p99 1.18, and passes with them)."""
    from garment_sim_ros.commands.evaluate import nudge_free_points

    params = TEARING
    assert params.replay_frames == 2  # the default since 2026-12-03
    source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False, params=params)
    character = make_character(source.rest_pose, source.joint_map, ["long_skirt"], params, motion=source.fit_poses())
    solver = character.solvers[0]
    advance, damage, tries, replayed = solver.advance, solver._damage, [], []

    def recorded_damage(report):
        tries.append(damage(report))
        return tries[-1]

    def advance_and_check(frame):
        tries.clear()
        history = len(solver._history)
        assert history <= params.replay_frames
        report = advance(frame)
        kept = damage(report)
        assert len(tries) == 1 + report.retries + report.replays
        if report.replays:
            own = tries[:1 + report.retries]
            assert all(t[:4] != (False, 0, False, 0.0) for t in own), own  # replayed only where no try mended it
            assert kept == min(tries), (kept, tries)
            assert history > 0
            replayed.append((min(own), kept))
        return report

    solver.advance, solver._damage = advance_and_check, recorded_damage
    frames = int(source.duration * 60.0)
    for _, _, reports in simulate_frames(source, character, np.arange(frames + 1) / 60.0):
        if reports is None:
            nudge_free_points(character, 1)
    assert replayed, "no frame was replayed"
    assert any(kept[:4] == (False, 0, False, 0.0) for _, kept in replayed), replayed
    assert all(kept <= own for own, kept in replayed)
