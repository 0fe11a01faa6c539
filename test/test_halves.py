"""Garments from ``PARALLEL_MIN_POINTS`` up run their forces, length correction and edge handling on two threads,
by halves of the garment (``cloth.halves``).

The halves' kernels are a serial sweep over the springs (edges) in the halves' order, the two halves at once:
they touch disjoint points, so the result equals that serial sweep bit for bit, on one thread or two. Against
the model's order (what the garment ran before, and what garments below ``PARALLEL_MIN_POINTS`` still run) the
sweep's order differs, so the garment does too: on a real clip, a 5 040-point one-piece on the CC walk, the
stretch the correction leaves and the depth in the body stay within a stated tolerance of the serial run's.
"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth import kernels
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.halves import ParallelLayout, halves, rim, split_pairs
from garment_sim_ros.cloth.model import STRUCTURAL, build_cloth_model
from garment_sim_ros.collision import kernels as collision_kernels
from garment_sim_ros.collision.collider import Collider
from garment_sim_ros.collision.volumes import SPHERE, Volume, VolumeSet
from garment_sim_ros.commands.scale import resolution_for
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS

WALK = Path(__file__).resolve().parent / "data" / "cc_cmu_07_01_walk.bvh"


@pytest.fixture(scope="module")
def garment():
    """A hanging one-piece at ~5 000 points, stretched 15 % downwards with 1 mm of noise, moving."""
    model = build_cloth_model(build_garment("one_piece", resolution=resolution_for(5_000)))
    rng = np.random.default_rng(3)
    x = model.rest_positions.copy()
    top = x[model.attached, 2].mean()
    x[:, 2] = top + 1.15 * (x[:, 2] - top)
    x += rng.normal(0.0, 1e-3, x.shape)
    v = rng.normal(0.0, 0.05, x.shape)
    inv_mass = np.full(model.num_points, 50.0)
    inv_mass[model.attached] = 0.0
    return model, x, v, inv_mass


def test_the_halves_share_no_point_and_keep_every_pair_once(garment):
    model = garment[0]
    second = halves(model.rest_positions)
    assert abs(int(second.sum()) - model.num_points // 2) <= 1  # cut at the median
    on_rim = rim(model.triangles, model.num_points)
    order, starts = split_pairs(model.springs, second, on_rim)
    assert np.array_equal(np.sort(order), np.arange(len(model.springs)))
    groups = [model.springs[order[starts[k]:starts[k + 1]]] for k in range(3)]
    assert not second[groups[0]].any() and second[groups[1]].all()  # a half's springs: both ends in it
    ends = second[groups[2]]
    assert np.all((ends[:, 0] != ends[:, 1]) | on_rim[groups[2]].any(axis=1))  # across the cut, or an opening's
    assert len(groups[2]) < 0.03 * len(model.springs)  # two seams of a tube: little left for one thread
    for group in groups:  # each group in the model's order
        assert np.all(np.diff(order[starts[0]:starts[1]]) > 0) and len(group) > 0


def test_an_opening_on_the_cut_has_its_points_springs_swept_together(garment):
    """The one-piece's walking vent opens at its back centre, where the halves cut it (``cloth.halves``): every
    spring of a point on the vent's rim with a spring across the cut is in the last group, in the model's order
    (split, the ring spring at the vent's top came out of the real-clip run below 1.51-1.91 its rest length); the
    closed seams' points keep springs in a half."""
    model = garment[0]
    second, on_rim = halves(model.rest_positions), rim(model.triangles, model.num_points)
    order, starts = split_pairs(model.springs, second, on_rim)
    last = np.zeros(len(model.springs), dtype=bool)
    last[order[starts[2]:starts[3]]] = True
    assert np.array_equal(order[starts[2]:starts[3]], np.sort(order[starts[2]:starts[3]]))
    at_cut = np.unique(model.springs[second[model.springs[:, 0]] != second[model.springs[:, 1]]])
    z = model.rest_positions[:, 2]
    vent = at_cut[on_rim[at_cut] & (z[at_cut] > z.min() + 1e-6) & ~np.isin(at_cut, model.attached)]
    assert len(vent) >= 2  # the vent's top and its edge below it, at the back centre
    assert np.all(model.rest_positions[vent, 0] < 0.0)
    assert last[np.isin(model.springs, vent).any(axis=1)].all()
    seam = at_cut[~on_rim[at_cut]]
    assert not last[np.isin(model.springs, seam).any(axis=1)].all()


@pytest.mark.parametrize("threads", [1, 2])
def test_halves_kernels_equal_the_serial_sweep_in_their_order(garment, threads):
    model, x0, v, inv_mass = garment
    count = model.num_correction_springs
    stiffness, damping = np.full(len(model.springs), 300.0), np.full(len(model.springs), 0.2)
    edges = np.ascontiguousarray(model.springs[model.spring_kinds == STRUCTURAL])
    edge_rest = np.ascontiguousarray(model.rest_lengths[model.spring_kinds == STRUCTURAL])
    layout = ParallelLayout.build(model.rest_positions, model.triangles, model.springs, model.rest_lengths,
                                  stiffness, damping, count, edges, edge_rest)
    previous = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        serial, halved = x0.copy(), x0.copy()
        worst = kernels.length_correction(serial, inv_mass, layout.correction_springs, layout.correction_rest, count,
                                          0.01)
        assert kernels.length_correction_halves(halved, inv_mass, layout.correction_springs, layout.correction_rest,
                                                layout.correction_starts, 0.01) == worst > 1.1
        assert np.array_equal(serial, halved) and not np.array_equal(serial, x0)

        frame = (np.array([0.0, 0.0, -9.81]), 0.3, 0.1, 0.5, np.array([0.2, 0.0, 0.0]), 1.0)
        forces = [np.zeros_like(x0), np.zeros_like(x0)]
        kernels.accumulate_forces(x0, v, 1.0 / np.maximum(inv_mass, 1.0), layout.springs, layout.rest,
                                  layout.stiffness, layout.damping, *frame, forces[0])
        kernels.accumulate_forces_halves(x0, v, 1.0 / np.maximum(inv_mass, 1.0), layout.springs, layout.rest,
                                         layout.stiffness, layout.damping, *frame, forces[1], layout.spring_starts)
        assert np.array_equal(forces[0], forces[1]) and np.abs(forces[0]).max() > 0.0

        arrays, xs = _volumes_through(model, x0)
        serial, halved = x0.copy(), x0.copy()
        moved = collision_kernels.handle_edges(arrays, xs, serial, inv_mass, layout.edges, layout.edge_rest, 0.0)
        assert collision_kernels.handle_edges_halves(arrays, xs, halved, inv_mass, layout.edges, layout.edge_rest,
                                                     layout.edge_starts, 0.0) == moved > 0
        assert np.array_equal(serial, halved)
    finally:
        numba.set_num_threads(previous)


def _volumes_through(model, x):
    """A 5 cm sphere's volume arrays (the collider's tuple) around a point of the cloth half way down, so that the
    stretched edges there cut into it, standing still; the start positions: the points as they are."""
    centre = x[np.argmin(np.abs(x[:, 2] - np.median(x[:, 2])))]
    collider = Collider(VolumeSet((Volume("ball", SPHERE, "pelvis", (0.05, 0.05, 0.05)),)), model.num_points,
                        cache_size=1)
    pose = (centre[None, :], np.array([[0.0, 0.0, 0.0, 1.0]]))
    collider.begin_frame(*pose, *pose)
    return collider._packed, x.copy()


def test_halves_dress_a_large_garment_as_the_serial_sweep_does_on_a_real_clip():
    """5 040-point one-piece, 40 frames of the CC walk at 60 fps from its dressing, defaults (strain limiting on):
    halves (the default from ``PARALLEL_MIN_POINTS`` up) against every kernel serial in the model's order.
    Tolerance: the median over the frames of the p99 structural/shear stretch within 0.005 (measured 1.0223
    against 1.0223), the worst frame's largest stretch at most 0.1 above the serial run's (1.311 against 1.301; with
    the vent's rim split across the groups, 1.554 at the vent's top: ``cloth.halves``), the deepest free point
    within 1 mm (0 in both), the garments' centroids within 3 cm at the end (1.99 cm; the serial run from points
    moved by 1 um after the dressing ends 0.23-1.18 cm off its own, the halves' 1.64-2.23 cm: a different sweep
    order is a larger nudge to a swinging hem, which the stretch and depth figures show is not a worse garment).
    The centroid bound is 1.5 times the floor of any two-group layout: with only the forces' sums split (the
    correction and edges in the model's order) the centroids end 1.64-2.00 cm apart over ten 1 um nudges and the
    worst spring reads 1.36-1.49 (docs/real_motion.md, "The halves against the serial sweep, measured further");
    a bound at the floor (2 cm, before) failed on rounding alone."""
    source = bvh_source(str(WALK), loop=False)
    times = np.arange(41) / 60.0
    runs = []
    for parallel in (False, True):
        character = make_character(source.rest_pose, source.joint_map, ["one_piece"], DEFAULT_PARAMS,
                                   resolution_for(5_000), motion=source.fit_poses())
        solver = character.solvers[0]
        assert solver.collider.parallel
        solver.collider.parallel = parallel
        p99, worst, depth = [], [], []
        for _, _, reports in simulate_frames(source, character, times):
            if reports is None:
                continue
            assert reports[0].recovery == ""
            p99.append(np.percentile(solver.stretches, 99))
            worst.append(reports[0].max_stretch)
            depth.append(reports[0].max_depth_m)
        assert (solver.parallel_layout() is not None) == parallel
        runs.append((np.median(p99), max(worst), max(depth), solver.state.positions.copy()))
    (p99_a, worst_a, depth_a, x_a), (p99_b, worst_b, depth_b, x_b) = runs
    assert abs(p99_a - p99_b) < 0.005, (p99_a, p99_b)
    assert worst_b < worst_a + 0.1, (worst_a, worst_b)
    assert abs(depth_a - depth_b) < 1e-3, (depth_a, depth_b)
    assert 0.0 < np.linalg.norm(x_a.mean(axis=0) - x_b.mean(axis=0)) < 0.03
