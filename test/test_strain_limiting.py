"""Bounding stretch (issue 11, target d): the tethers (long-range attachments) and the strain limiting
that runs after the collision handling, contacts respected (``cloth.solver``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_cloth import still_frame, strip_mesh

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth import kernels
from garment_sim_ros.cloth.garments import GarmentMesh, build_garment
from garment_sim_ros.cloth.model import build_cloth_model
from garment_sim_ros.cloth.solver import GarmentSolver
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import TARGETS

CLIP = Path(__file__).resolve().parent / "data" / "xia_old_13_000.bvh"  # the shortest real clip
SPACING = 0.05  # m, ``strip_mesh``'s grid


def with_island(mesh: GarmentMesh) -> GarmentMesh:
    """``mesh`` plus a triangle joined to nothing."""
    n = len(mesh.vertices)
    vertices = np.concatenate([mesh.vertices, [[1.0, 0.0, 0.0], [1.1, 0.0, 0.0], [1.0, 0.0, -0.1]]])
    return GarmentMesh(mesh.name, vertices, np.concatenate([mesh.triangles, [[n, n + 2, n + 1]]]), mesh.attachments)


# ----------------------------------------------------------------------------- tethers

def test_tether_anchor_is_the_nearest_attached_point_along_the_cloth():
    model = build_cloth_model(with_island(strip_mesh(width=4, length=8, spacing=SPACING)))
    width, grid = 4, 4 * 8
    for i in range(width, grid):  # straight up the column, one edge per row
        assert model.tether_anchors[i] == i % width
        assert model.tether_lengths[i] == pytest.approx((i // width) * SPACING)
    assert np.all(model.tether_anchors[model.attached] == -1)
    assert np.all(model.tether_anchors[grid:] == -1) and np.all(model.tether_lengths[grid:] == 0.0)  # not joined


@pytest.mark.parametrize("name", ["long_skirt", "pants", "one_piece"])
def test_a_tether_is_never_shorter_than_the_straight_line_at_rest(name):
    model = build_cloth_model(build_garment(name))
    free = model.tether_anchors >= 0
    assert np.all(np.isin(model.tether_anchors[free], model.attached))
    assert np.count_nonzero(free) == model.num_points - len(model.attached)  # every free point is tethered
    straight = np.linalg.norm(model.rest_positions[free] - model.rest_positions[model.tether_anchors[free]], axis=1)
    assert np.all(model.tether_lengths[free] >= straight - 1e-12)


def test_tether_kernel_hand_computed():
    x = np.array([[0.0, 0.0, 0.0],  # the anchor
                  [0.0, 0.0, -0.3],  # 0.3 m away, allowed 0.2 x 1.1: back along the line to 0.22 m
                  [0.1, 0.0, 0.0],  # within its length: untouched
                  [0.0, 0.5, 0.0],  # attached itself (inverse mass 0): never moves
                  [0.0, 0.0, 5.0]])  # no anchor
    inv_mass = np.array([0.0, 1.0, 1.0, 0.0, 1.0])
    anchors = np.array([-1, 0, 0, 0, -1])
    lengths = np.array([0.0, 0.2, 0.2, 0.1, 0.0])
    before = x.copy()
    assert kernels.tether_constraints(x, inv_mass, anchors, lengths, 1.1) == 1
    assert np.allclose(x[1], [0.0, 0.0, -0.22])
    assert np.array_equal(np.delete(x, 1, axis=0), np.delete(before, 1, axis=0))


def test_tethers_hold_a_swinging_strip_without_adding_energy():
    """A strip lifted sideways and let go swings undamped on soft springs whose correction only acts past
    twice their length: the tethers (no slack) are what hold it, and they take energy out, never put it in."""
    params = DEFAULT_PARAMS.replace(air_damping=0.0, stretch_damping=0.0, shear_damping=0.0, bend_damping=0.0,
                                    correction_iterations=1, limit_ratio=1.0, substep=0.001, max_substeps=20,
                                    stretch_stiffness=0.5, shear_stiffness=0.2, bend_stiffness=0.05,
                                    tether_slack=0.0)
    model = build_cloth_model(strip_mesh(width=4, length=8, spacing=SPACING))
    free = model.tether_anchors >= 0

    def swing(tethers: int):
        solver = GarmentSolver(model, None, params.replace(tethers=tethers))
        x = solver.state.positions
        depth = -x[free, 2]
        x[free, 1] += 0.6 * depth
        x[free, 2] = -0.8 * depth
        m = solver.constants.mass

        def energy():
            x, v = solver.state.positions, solver.state.velocities
            d = np.linalg.norm(x[model.springs[:, 1]] - x[model.springs[:, 0]], axis=1) - model.rest_lengths
            return (0.5 * np.sum(m[free] * np.sum(v[free] ** 2, axis=1)) + np.sum(m[free] * 9.81 * x[free, 2])
                    + 0.5 * np.sum(solver.constants.stiffness * d ** 2))

        start, energies, reach = energy(), [], []
        for k in range(200):
            solver.advance(still_frame(k * 0.01, (k + 1) * 0.01))
            x = solver.state.positions
            energies.append(energy())
            reach.append(np.max(np.linalg.norm(x[free] - x[model.tether_anchors[free]], axis=1)
                                / model.tether_lengths[free]))
        return start, np.array(energies), max(reach)

    start, energies, reach = swing(tethers=1)
    assert reach <= 1.0 + 1e-9  # no point farther from its anchor than its rest distance along the cloth
    assert energies.max() <= start + 1e-9
    assert swing(tethers=0)[2] > 1.1  # without them the points do go farther: the tethers were at work


# ----------------------------------------------------------------------------- strain limiting after collision

def test_contact_weights_and_keep_where_inside_hand_computed():
    x = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    before = x.copy()
    before[1, 2] = -0.01  # the collision handling moved point 1
    out = np.zeros(3)
    kernels.contact_weights(x, before, np.array([2.0, 2.0, 0.0]), 0.25, out)
    assert np.array_equal(out, [2.0, 0.5, 0.0])

    kept_x, kept_v = x.copy(), np.zeros((3, 3))
    v = np.ones((3, 3))
    moved = x + 0.1
    assert kernels.keep_where_inside(moved, v, kept_x, kept_v, np.array([0.0, 0.0, 0.004])) == 1
    assert np.allclose(moved[:2], x[:2] + 0.1) and np.array_equal(moved[2], x[2])  # only the one inside went back
    assert np.array_equal(v[2], [0.0, 0.0, 0.0]) and np.array_equal(v[:2], np.ones((2, 3)))


def test_undo_limiting_keeps_what_it_took_out_of_a_volume_hand_computed():
    """Points 0-2 in a row, springs 0-1 and 1-2 (rest 1 m): undone, point 1, inside a volume before the limiting
    (depth 2 mm there), keeps where the limiting put it; the others go back. When that leaves a spring longer than
    the bound, every point goes back."""
    springs, rest = np.array([[0, 1], [1, 2]]), np.ones(2)
    kept_x = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    kept_v, stretches = np.zeros((3, 3)), np.zeros(2)
    limited = kept_x + [[0.0, 0.0, 0.5], [0.0, 0.0, 0.1], [0.0, 0.0, -0.5]]
    x, v = limited.copy(), np.ones((3, 3))
    assert kernels.undo_limiting(x, v, kept_x, kept_v, np.array([0.0, 0.002, 0.0]), springs, rest, stretches, 1.5)
    assert np.array_equal(x[[0, 2]], kept_x[[0, 2]]) and np.array_equal(x[1], limited[1])
    assert np.array_equal(v[[0, 2]], kept_v[[0, 2]]) and np.array_equal(v[1], [1.0, 1.0, 1.0])
    x, v = kept_x + [[0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, 0.0]], np.ones((3, 3))  # then sqrt(5) > 1.5 long
    assert not kernels.undo_limiting(x, v, kept_x, kept_v, np.array([0.0, 0.002, 0.0]), springs, rest, stretches, 1.5)
    assert np.array_equal(x, kept_x) and np.array_equal(v, kept_v)


def frame_figures(garment: str, strain_limit_iterations: int, seconds: float = 1.0, clip: Path = CLIP,
                  frame_retries: int = 0):
    """Per frame after dressing on a real clip: the worse of the structural and shear p99 stretch, the
    worse of their longest springs, the deepest free point (m) and the limb bones through the cloth. Frames run
    once unless ``frame_retries`` says otherwise: a retried frame would mend some of what the unlimited runs show."""
    source = bvh_source(str(clip), loop=False)
    params = DEFAULT_PARAMS.replace(strain_limit_iterations=strain_limit_iterations, frame_retries=frame_retries)
    character = make_character(source.rest_pose, source.joint_map, [garment], params, 1.0)
    rows = []
    for _, _, reports in simulate_frames(source, character, np.arange(int(seconds * 60) + 1) / 60.0):
        if reports is not None:
            r = reports[0]
            rows.append((max(r.structural_stretch_p99, r.shear_stretch_p99),
                         max(r.structural_stretch_max, r.shear_stretch_max), r.max_depth_m, r.bones_through))
    return np.array(rows).T


@pytest.mark.parametrize("garment, median_bound, worst_bound", [
    # measured (1 s of xia_old at 60 fps), without -> with: median p99 1.129 -> 1.031, worst 1.200 -> 1.068
    ("pants", 1.05, 1.10),
    # median 1.087 -> 1.026, worst 1.136 -> 1.043
    ("long_skirt", 1.04, 1.07),
])
def test_strain_limiting_after_collision_bounds_stretch_on_a_real_clip(garment, median_bound, worst_bound):
    p99, _, depth, bones = frame_figures(garment, DEFAULT_PARAMS.strain_limit_iterations)
    assert np.median(p99) <= median_bound and p99.max() <= worst_bound
    assert depth.max() <= 1e-3 and bones.max() == 0  # not bought with the cloth going into the body
    unlimited = frame_figures(garment, 0)[0]
    assert np.median(unlimited) > median_bound  # the bound is the strain limiting's doing


@pytest.mark.parametrize("clip", ["xia_strutting_01_000", "xia_angry_13_000"])
def test_trousers_meet_the_stretch_target_on_real_walks(clip):
    """Issue 11's target (d) in every frame of the first second of two real walks, the trousers (the garment
    the legs pinch most): p99 of structural and shear stretch <= 1.05, no spring past 1.5. Measured, worst
    frame's p99 / longest spring: strut 1.051 / 1.38 and angry 1.120 / 1.49 with the contacts handled only
    after the strain limiting's sweeps; 1.025 / 1.11 and 1.037 / 1.36 with them between the sweeps, frames run
    once. With the crotch's width ease (2026-12-02) a frame of angry run once reaches 1.56; the product's frame
    retries (``frame_retries``, on here) mend it: 1.20."""
    p99, longest, depth, bones = frame_figures("pants", DEFAULT_PARAMS.strain_limit_iterations, 1.0,
                                               CLIP.parent / f"{clip}.bvh", DEFAULT_PARAMS.frame_retries)
    assert p99.max() <= TARGETS.stretch_p99 and longest.max() <= TARGETS.stretch_max
    assert depth.max() <= TARGETS.depth_tolerance_m and bones.max() == 0  # not bought with the body through


def test_length_correction_returns_the_longest_spring_it_met():
    """The strain limiting stops on it (``strain_limit_tolerance``): the ratio before shortening."""
    x = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.5], [0.0, 0.0, -2.0]])
    springs = np.array([[0, 1], [1, 2]])
    inv_mass = np.array([0.0, 1.0, 1.0])
    assert kernels.length_correction(x, inv_mass, springs, np.array([1.0, 1.0]), 2, 0.0) == pytest.approx(1.5)
    assert np.allclose(x[1], [0.0, 0.0, -1.0])  # the first spring back to its rest length, the anchor kept
    assert kernels.length_correction(x, inv_mass, springs, np.array([1.0, 1.0]), 2, 0.0) == pytest.approx(1.0)


# ----------------------------------------------------------------------------- a waistband that gives way

def test_a_band_moved_in_one_place_drags_its_neighbours_into_a_ramp_hand_computed():
    """``kernels.spread_along_band``: a band of 24 points on a 15 cm circle (springs 39 mm), one point moved 30 mm
    inwards (as ``push_out_of_volumes`` moves a target out of a forearm towards the trunk): its two springs were at
    1.18 rest lengths; after, every spring is within 1.01 of its rest length, the moved point has not moved again,
    its neighbours followed it (less and less with their distance along the band) and the far side of the band is
    where it was."""
    count, radius = 24, 0.15
    angles = 2.0 * np.pi * np.arange(count) / count
    skinned = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(count)], axis=1)
    springs = np.stack([np.arange(count), (np.arange(count) + 1) % count], axis=1).astype(np.int64)
    rest = np.linalg.norm(skinned[springs[:, 1]] - skinned[springs[:, 0]], axis=1)
    targets = skinned.copy()
    targets[0] *= (radius - 0.03) / radius
    lengths = np.linalg.norm(targets[springs[:, 1]] - targets[springs[:, 0]], axis=1) / rest
    inner, step = radius - 0.03, 2.0 * np.pi / count  # the law of cosines across the moved point's spring
    assert lengths[0] == pytest.approx(np.sqrt(inner ** 2 + radius ** 2 - 2 * inner * radius * np.cos(step)) / rest[0])
    assert lengths[0] > 1.15
    moved = targets[0].copy()
    worst = kernels.spread_along_band(targets, skinned, springs, rest, 0.01)
    lengths = np.linalg.norm(targets[springs[:, 1]] - targets[springs[:, 0]], axis=1) / rest
    assert lengths.max() <= 1.01 + 1e-9 and worst <= 1.01 + 1e-9
    assert np.array_equal(targets[0], moved)
    shift = np.linalg.norm(targets - skinned, axis=1)
    for side in (np.arange(1, 6), (count - np.arange(1, 6)) % count):  # the neighbours on each side, nearest first
        assert shift[side[0]] > 0.005 and np.all(np.diff(shift[side]) <= 1e-12)
    assert np.array_equal(targets[count // 2 - 2:count // 2 + 3], skinned[count // 2 - 2:count // 2 + 3])


def test_a_band_no_target_moved_stays_as_skinned():
    """A spring whose ends are both where they are skinned is left alone, even one longer than the limit (a band
    skinned to two segments)."""
    skinned = np.array([[0.0, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.10, 0.0]])
    springs, rest = np.array([[0, 1], [1, 2]], dtype=np.int64), np.array([0.04, 0.05])
    targets = skinned.copy()
    kernels.spread_along_band(targets, skinned, springs, rest, 0.01)
    assert np.array_equal(targets, skinned)


def test_the_waistband_gives_way_without_tearing_on_a_real_clip():
    """Issue 11 (d), the CC jump, short skirt, 1x at 60 fps, 0.9-1.5 s: the right forearm lies on the waistband and
    its skinned points inside the forearm's volume go out of it (``band_gives_way``). Moved alone, the band's own
    springs (both ends attached) reached 3.40 rest lengths (frame 68), the skirt's longest spring; with the moved
    points dragging their neighbours (``kernels.spread_along_band``) none is past 1.02 in any frame. (That the
    band still gives way, no bone through it: ``test_real_motion.test_the_waistband_gives_way_under_a_forearm_...``.)"""
    source = bvh_source(str(CLIP.parent / "cc_cmu_02_04_jump_balance.bvh"), loop=False)
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], DEFAULT_PARAMS,
                               motion=source.fit_poses())
    solver = character.solvers[0]
    model = solver.model
    attached = np.zeros(model.num_points, dtype=bool)
    attached[model.attached] = True
    band = np.flatnonzero(attached[model.springs[:model.num_correction_springs]].all(axis=1))
    assert len(band) > 40
    worst = [solver.stretches[band].max() for frame, (_, _, reports) in
             enumerate(simulate_frames(source, character, np.arange(91) / 60.0)) if reports is not None and frame >= 54]
    assert len(worst) == 37
    assert max(worst) <= 1.02, [round(float(w), 3) for w in worst]
