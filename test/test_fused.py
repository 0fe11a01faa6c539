"""The fused frame (``cloth.fused``) gives the same garment as the reference loop of ``GarmentSolver.advance``.

Tolerance: none. Both paths call the same kernels in the same order on the same numbers, so positions,
velocities and contact caches must be equal bit for bit after every frame, on real clips, with the strain
limiting and tethers on (the defaults), on the memo preset, with the motion constraints, and on the parallel
collision drivers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.sources import bvh_source, procedural_source
from garment_sim_ros.cloth import fused
from garment_sim_ros.cloth.garments import TEMPLATES
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.commands.table1 import FRAME_S
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS, PRESETS

DATA = Path(__file__).resolve().parent / "data"
WALK = DATA / "cc_cmu_07_01_walk.bvh"
CARTWHEEL = DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"


def run(source, garment, params, times, fused_path: bool, parallel: bool | None = None):
    """Per frame after the dressing: (positions, velocities, contacts, report fields) of every garment."""
    character = make_character(source.rest_pose, source.joint_map, [garment], params, 1.0, motion=source.fit_poses())
    for solver in character.solvers:
        solver.use_fused = fused_path
        if parallel is not None:
            solver.collider.parallel = parallel
    frames = []
    for _, _, reports in simulate_frames(source, character, times):
        if reports is None:
            continue
        frames.append([(s.state.positions.copy(), s.state.velocities.copy(), s.state.contacts.copy(),
                        r.substeps, r.static_hits, r.dynamic_hits, r.max_stretch, r.recovery)
                       for s, r in zip(character.solvers, reports)])
    return frames


def assert_same(reference, fused_frames):
    assert len(reference) == len(fused_frames) > 0
    for k, (a, b) in enumerate(zip(reference, fused_frames)):
        for garment_a, garment_b in zip(a, b):
            for field, (x, y) in enumerate(zip(garment_a, garment_b)):
                if isinstance(x, np.ndarray):
                    assert np.array_equal(x, y), f"frame {k}: field {field} differs by {np.abs(x - y).max()}"
                else:
                    assert x == y, f"frame {k}: field {field}: {x} against {y}"


@pytest.fixture
def fused_calls(monkeypatch):
    """The fused kernels' calls, by name (the serial or the parallel chain)."""
    calls = []
    for name in ("run_substeps", "run_substeps_parallel"):
        kernel = getattr(fused, name)

        def counted(*args, _kernel=kernel, _name=name):
            calls.append(_name)
            return _kernel(*args)
        monkeypatch.setattr(fused, name, counted)
    return calls


@pytest.mark.parametrize("garment", sorted(TEMPLATES))
def test_fused_frame_equals_the_reference_loop_on_a_real_clip(garment, fused_calls):
    source = bvh_source(str(WALK), loop=False)
    times = np.arange(46) / 60.0  # 0.75 s at 60 fps
    assert DEFAULT_PARAMS.strain_limit_iterations > 0 and DEFAULT_PARAMS.tethers
    reference = run(source, garment, DEFAULT_PARAMS, times, False)
    assert not fused_calls
    result = run(source, garment, DEFAULT_PARAMS, times, True)
    assert len(fused_calls) >= len(result)  # every frame ran fused (and the dressing's settling frames)
    assert_same(reference, result)
    assert sum(f[0][4] for f in result) > 0  # the garment touched the body: the collision handling did work


def test_fused_frame_equals_the_reference_loop_on_the_memo_preset(fused_calls):
    source = procedural_source("walk")
    times = np.arange(26) * FRAME_S  # the Table 1 protocol's 0.04 s frames
    reference = run(source, "one_piece", PRESETS["memo"], times, False)
    result = run(source, "one_piece", PRESETS["memo"], times, True)
    assert set(fused_calls) == {"run_substeps"}  # 720 points: the serial drivers, as the collider chooses
    assert_same(reference, result)


def test_fused_frame_equals_the_reference_loop_with_motion_constraints_and_parallel_drivers(fused_calls):
    """A fast clip, the motion constraints on (``max_distance``), the collision drivers spread over numba's
    threads (the parallel chain, ``fused.run_substeps_parallel``). Without replays: a replay runs the same frame
    path at 4-16x the substeps, and the reference loop, kernel by kernel through the threads, took minutes here."""
    source = bvh_source(str(CARTWHEEL), loop=False)
    params = DEFAULT_PARAMS.replace(max_distance=0.08, replay_frames=0)
    times = 2.0 + np.arange(31) / 30.0  # 1 s at 30 fps from the cartwheel's start: more substeps a frame
    reference = run(source, "one_piece", params, times, False, parallel=True)
    result = run(source, "one_piece", params, times, True, parallel=True)
    assert set(fused_calls) == {"run_substeps_parallel"}
    assert_same(reference, result)


def test_fused_frame_equals_the_reference_loop_where_torn_springs_take_the_contacts_room(fused_calls):
    """The cartwheel's short skirt at 60 fps through the right thigh's pinch at 1.27-1.30 s, where one spring held
    on two volumes is shortened into its ends' contact room (``tear_give_stretch``; test_real_motion.py): the
    same on both paths, and some frame ends with its longest spring at the give's 1.49."""
    source = bvh_source(str(CARTWHEEL), loop=False)
    params = DEFAULT_PARAMS.replace(tear_give_stretch=1.49)
    times = np.arange(82) / 60.0
    reference = run(source, "short_skirt", params, times, False)
    result = run(source, "short_skirt", params, times, True)
    assert fused_calls
    assert_same(reference, result)
    assert max(f[0][6] for f in result) == pytest.approx(1.49, abs=1e-9)


def test_fused_frame_reports_its_stages_and_falls_back_without_the_broad_phase():
    source = procedural_source("walk")
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], DEFAULT_PARAMS, 1.0)
    solver = character.solvers[0]
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    assert fused.usable(solver)
    report = character.step(source.pose(1 / 60), source.motion(1 / 60), 1 / 60)[0]
    assert report.integration_s > 0.0 and report.correction_s > 0.0 and report.collision_s > 0.0
    solver.collider.use_broad_phase = False  # the test-only switch: the reference loop runs it
    assert not fused.usable(solver)
