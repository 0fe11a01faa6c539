"""Issue 11's figures (garment_sim_ros.quality) on hand-made geometry, and ``garment-sim evaluate``."""

from __future__ import annotations

import json
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.sources import procedural_source
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.model import SHEAR, STRUCTURAL, build_cloth_model
from garment_sim_ros.cloth.solver import FrameReport
from garment_sim_ros.collision.volumes import ELLIPSOID, Volume, VolumeSet
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import TARGETS, GarmentMeter, LimbTubes, report_scalars, segments_through_triangles
from garment_sim_ros.transforms import IDENTITY_QUAT, quat_from_axis_angle, quat_normalize, quat_to_matrix

MOCAP = Path(__file__).resolve().parent / "data"  # the shared real clips, copied unchanged
CLIP = MOCAP / "xia_old_13_000.bvh"  # the shortest real clip


# ----------------------------------------------------------------------------- segment through triangle

# the unit right triangle in z = 0, and its mirror: together the unit square, sharing the edge x + y = 1
SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
ONE, BOTH = np.array([[0, 1, 2]]), np.array([[0, 1, 2], [1, 3, 2]])


def crossings(segments, triangles=ONE, points=SQUARE) -> list[bool]:
    segments = np.asarray(segments, dtype=float)
    crossed = np.zeros(len(segments), dtype=np.bool_)
    count = segments_through_triangles(np.ascontiguousarray(segments[:, 0]), np.ascontiguousarray(segments[:, 1]),
                                       points, triangles, crossed)
    assert count == np.count_nonzero(crossed)
    return crossed.tolist()


def test_a_segment_through_a_triangle_crosses_it_from_either_side_at_any_slant():
    assert crossings([[[0.2, 0.2, -1.0], [0.2, 0.2, 1.0]],
                      [[0.2, 0.2, 1.0], [0.2, 0.2, -1.0]],
                      [[-0.5, 0.1, -0.3], [0.9, 0.3, 0.1]]]) == [True, True, True]


def test_a_segment_beside_a_triangle_or_short_of_it_does_not_cross():
    assert crossings([[[0.8, 0.8, -1.0], [0.8, 0.8, 1.0]],  # through the plane beside the hypotenuse
                      [[-0.1, 0.5, -1.0], [-0.1, 0.5, 1.0]],  # beside a leg
                      [[0.2, 0.2, 0.01], [0.2, 0.2, 1.0]],  # ends just above it
                      [[0.2, 0.2, -1.0], [0.2, 0.2, -0.01]]]) == [False, False, False, False]
    assert crossings([[[0.8, 0.8, -1.0], [0.8, 0.8, 1.0]]], BOTH) == [True]  # the other triangle is there


def test_a_segment_parallel_to_a_triangle_does_not_cross_even_in_its_plane():
    assert crossings([[[0.2, 0.2, 0.1], [0.6, 0.1, 0.1]],
                      [[-1.0, 0.2, 0.0], [2.0, 0.2, 0.0]],
                      [[0.1, 0.1, 0.0], [0.3, 0.1, 0.0]]]) == [False, False, False]
    # in a tilted plane rounding leaves the determinant at ~1e-17, not 0: still parallel, not a crossing
    rng = np.random.default_rng(7)
    for _ in range(50):
        turn = quat_to_matrix(quat_normalize(rng.normal(size=4)))
        shift = rng.normal(size=3)
        segment = np.array([[[0.1, 0.1, 0.0], [0.3, 0.2, 0.0]]]) @ turn.T + shift
        assert crossings(segment, ONE, SQUARE @ turn.T + shift) == [False]
        assert crossings(segment + 0.05 * turn[:, 2] * [[[-1.0], [1.0]]], ONE, SQUARE @ turn.T + shift) == [True]


def test_a_segment_touching_an_edge_or_a_vertex_crosses_so_none_slips_between_two_triangles():
    assert crossings([[[0.5, 0.0, -1.0], [0.5, 0.0, 1.0]],  # through the edge on y = 0
                      [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]],  # through a corner
                      [[0.2, 0.2, 0.0], [0.2, 0.2, 1.0]]]) == [True, True, True]  # ends on the triangle
    # exactly through the shared diagonal of the square: counted once, whichever triangle takes it
    crossed = np.zeros(1, dtype=np.bool_)
    assert segments_through_triangles(np.array([[0.5, 0.5, -1.0]]), np.array([[0.5, 0.5, 1.0]]), SQUARE, BOTH,
                                      crossed) == 1


# ----------------------------------------------------------------------------- trouser legs

@lru_cache(maxsize=None)
def dressed(garment: str):
    """A garment dressed on the procedural walker at its first pose: (character, pose)."""
    source = procedural_source("walk")
    character = make_character(source.rest_pose, source.joint_map, [garment], DEFAULT_PARAMS, 1.0)
    _, pose, _ = next(simulate_frames(source, character, [0.0]))
    return character, pose


def measured(character, pose, positions=None) -> FrameReport:
    """A report measured on the character's garment, its positions (simulation frame) replaced if given."""
    solver = character.solvers[0]
    kept = solver.state.positions.copy()
    if positions is not None:
        solver.state.positions[...] = positions
    report = FrameReport()
    try:
        character.measure([report], pose)
    finally:
        solver.state.positions[...] = kept
    return report


def test_dressed_trousers_are_on_both_legs_with_no_bone_through_them():
    character, pose = dressed("pants")
    report = measured(character, pose)
    assert (report.legs_off, report.bones_through) == (0, 0)
    assert report.max_depth_m <= 0.001
    assert GarmentMeter(character.solvers[0].model, character.body.volumes, character.joint_map).tubes.names == \
        ["left_leg", "right_leg"]


def test_a_trouser_leg_moved_off_its_leg_is_counted_and_a_leg_in_the_wrong_trouser_leg_too():
    character, pose = dressed("pants")
    model = character.solvers[0].model
    x = character.solvers[0].state.positions
    below_crotch = np.concatenate(model.rings["left_leg"][1:])
    forward = x.copy()
    forward[below_crotch] += [0.3, 0.0, 0.0]  # root frame: x forward, the left leg's tube in front of the leg
    assert measured(character, pose, forward).legs_off == 1
    # mirrored across the mid-plane, each trouser leg goes round the other leg: both are off
    mirrored = x * [1.0, -1.0, 1.0]
    assert measured(character, pose, mirrored).legs_off == 2


def test_a_ring_goes_round_a_limb_only_by_winding_within_the_limbs_cut():
    """One limb along z and a tube of four rings: the first (where a tube leaves the body tube) is not
    checked; then one round the limb, one off to its side, one round its axis but past its cut."""
    angle = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    circle = np.column_stack([0.08 * np.cos(angle), 0.08 * np.sin(angle), np.zeros(12)])
    points = np.concatenate([circle + [0.5, 0.0, 0.0], circle + [0.0, 0.0, 0.1], circle + [0.2, 0.0, 0.1],
                             circle + [0.0, 0.0, 0.45]])

    class Model:  # what LimbTubes reads of a ClothModel
        rings = {"leg": [np.arange(0, 12), np.arange(12, 24), np.arange(24, 36), np.arange(36, 48)]}
        limb_tubes = {"leg": ("thigh",)}

    def off(cut, position=(0.0, 0.0, 0.0), rotation=IDENTITY_QUAT, x=points) -> int:
        volumes = VolumeSet((Volume("thigh", ELLIPSOID, "hip", (0.06, 0.06, 0.25), cut=cut),))
        return int(LimbTubes(Model, volumes).rings_off(x, [position], [rotation])[0])

    assert off((-0.2, 0.2)) == 2  # to the side, past the cut
    assert off((-0.5, 0.5)) == 1  # to the side
    assert off((-0.5, 0.5), position=(0.2, 0.0, 0.0)) == 2  # only the side ring goes round it now
    tilt = quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), 0.3)
    turned = points @ np.array([[1.0, 0.0, 0.0], [0.0, np.cos(0.3), np.sin(0.3)], [0.0, -np.sin(0.3), np.cos(0.3)]])
    assert off((-0.2, 0.2), rotation=tilt, x=turned) == 2  # the same, all turned together


# ----------------------------------------------------------------------------- stretch

def test_stretch_p99_and_max_on_a_hand_stretched_model():
    model = build_cloth_model(build_garment("pants"))
    meter = GarmentMeter(model, None, {})
    x = model.rest_positions
    assert meter.stretch(x) == {"structural": (pytest.approx(1.0), pytest.approx(1.0)),
                                "shear": (pytest.approx(1.0), pytest.approx(1.0))}
    grown = meter.stretch(x * 1.1)  # every spring 10 % longer
    assert grown["structural"] == (pytest.approx(1.1), pytest.approx(1.1))
    assert grown["shear"] == (pytest.approx(1.1), pytest.approx(1.1))
    # one free point pulled 20 cm out: its few springs (well under 1 %) stretch, the 99th percentile does not
    pulled = x.copy()
    i = int(model.rings["left_leg"][5][0])
    pulled[i] += [0.2, 0.0, 0.0]
    figures = meter.stretch(pulled)
    for kind, name in ((STRUCTURAL, "structural"), (SHEAR, "shear")):
        springs = model.springs[model.spring_kinds == kind]
        ratios = np.linalg.norm(pulled[springs[:, 1]] - pulled[springs[:, 0]], axis=1) / \
            model.rest_lengths[model.spring_kinds == kind]
        touched = np.any(springs == i, axis=1)
        assert 0 < np.count_nonzero(touched) < 0.01 * len(springs)
        assert figures[name][1] == pytest.approx(ratios.max()) and figures[name][1] > 3.0
        assert figures[name][0] == pytest.approx(np.percentile(ratios, 99.0)) == pytest.approx(1.0)


def test_report_scalars_name_every_quality_field():
    report = FrameReport(max_depth_m=0.002, bones_through=3, legs_off=1, structural_stretch_max=1.7,
                         recovery="refitted")
    values = report_scalars(report)
    assert values["depth_mm"] == pytest.approx(2.0) and values["bones_through"] == 3 and values["legs_off"] == 1
    assert values["structural_stretch_max"] == 1.7 and values["guard"] == 1.0


def test_the_diagnostics_window_holds_its_worst_frame_counts_summed_over_the_garments():
    from garment_sim_ros.runtime.frame_stats import FrameStats

    stats = FrameStats()
    stats.record_frame([FrameReport(bones_through=1, structural_stretch_p99=1.2),
                        FrameReport(bones_through=2, legs_off=1, shear_stretch_max=1.4)], 1 / 60, 0.0)
    stats.record_frame([FrameReport(bones_through=1), FrameReport()], 1 / 60, 0.0)
    stats.record_frame([FrameReport(), FrameReport()], 1 / 60, 0.0)
    window = stats.window()
    assert (window["bones_through"], window["bones_through_frames"], window["legs_off"]) == (3, 2, 1)
    assert (window["structural_stretch_p99"], window["shear_stretch_max"]) == (1.2, 1.4)
    assert stats.window()["bones_through"] == 0  # a new window


# ----------------------------------------------------------------------------- targets

def row(**changes) -> dict:
    good = {"speed": 1.0, "frames": 1000, "bones_frames": 0, "legs_off_frames": 0, "limb_tubes": 2, "deep_frames": 1,
            "max_depth_mm": 4.9, "structural_stretch_p99": 1.05, "structural_stretch_max": 1.5,
            "shear_stretch_p99": 1.0, "shear_stretch_max": 1.2, "guard_firings": 0}
    return {**good, **changes}


def test_the_targets_table_judges_each_letter_and_asks_less_at_fast_playback():
    assert TARGETS.judge(row()) == {"b": True, "c": True, "a": True, "d": True, "e": True, "f": None}
    assert TARGETS.judge(row(layer_crossing_frames=0))["f"] is True  # an outfit
    assert TARGETS.judge(row(layer_crossing_frames=1))["f"] is False
    assert TARGETS.judge(row(limb_tubes=0))["c"] is None  # a skirt has no trouser legs
    assert TARGETS.judge(row(bones_frames=1))["b"] is False
    assert TARGETS.judge(row(legs_off_frames=1))["c"] is False
    assert TARGETS.judge(row(deep_frames=2))["a"] is False  # 0.2 % of the frames
    assert TARGETS.judge(row(max_depth_mm=5.1))["a"] is False
    assert TARGETS.judge(row(shear_stretch_p99=1.051))["d"] is False
    assert TARGETS.judge(row(structural_stretch_max=1.51))["d"] is False
    assert TARGETS.judge(row(guard_firings=1))["e"] is False
    fast = TARGETS.judge(row(speed=3.0, deep_frames=500, structural_stretch_max=4.0))
    assert fast == {"b": True, "c": True, "a": True, "d": None, "e": True, "f": None}
    assert TARGETS.judge(row(speed=3.0, max_depth_mm=5.0))["a"] is False  # under 5 mm at 3x


def test_surface_depth_sees_a_sphere_bulging_between_cloth_points_that_are_all_outside():
    # a 1 m square of two triangles through a 0.25 m sphere's centre: its four corners are 0.71 m out, so the
    # point depth (a) reads 0, while each triangle's centre lies 14 mm inside (0.25 - sqrt(2)/6 m)
    from garment_sim_ros.cloth.solver import GarmentSolver
    from garment_sim_ros.collision.volumes import SPHERE
    from garment_sim_ros.commands.drape import square_cloth
    from garment_sim_ros.quality import free_point_depth, surface_depth

    model = build_cloth_model(square_cloth(2))
    solver = GarmentSolver(model, VolumeSet((Volume("ball", SPHERE, "ball", (0.25,) * 3),)), DEFAULT_PARAMS)
    solver.reset(np.zeros(3), 0.0, np.zeros((1, 3)), np.array([IDENTITY_QUAT]), 0.0)
    triangles = np.asarray(model.triangles, dtype=np.int64)
    assert free_point_depth(solver) == 0.0
    assert surface_depth(solver, triangles) == pytest.approx(0.25 - np.sqrt(2.0) / 6.0, abs=1e-9)
    solver.state.positions[:, 2] += 0.3  # lifted clear of the sphere
    assert surface_depth(solver, triangles) == 0.0


# ----------------------------------------------------------------------------- garment-sim evaluate

ROW_KEYS = {"clip", "garment", "speed", "fps", "nudge", "frames", "bones_frames", "bones_max", "limb_tubes",
            "legs_off_frames", "deep_frames", "deep_share", "max_depth_mm", "pressed_mm", "surface_depth_mm",
            "structural_stretch_p99", "structural_stretch_max", "shear_stretch_p99", "shear_stretch_max",
            "guard_firings", "carried_frames", "retried_frames", "replayed_frames", "joint_glitches",
            "joint_glitches_text", "targets",
            "passed", "wall_s"}


def test_evaluate_json_rows_and_summary_on_a_real_clip():
    result = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "evaluate", str(CLIP), "--garments",
                             "pants,short_skirt", "--fps", "60,30", "--duration", "0.2", "--json"],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode in (0, 1), result.stderr[-2000:]
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    rows, summary = lines[:-1], lines[-1]["summary"]
    assert [(r["garment"], r["fps"]) for r in rows] == [("pants", 60), ("pants", 30), ("short_skirt", 60),
                                                        ("short_skirt", 30)]
    for r in rows:
        assert set(r) == ROW_KEYS
        assert r["clip"] == "xia_old_13_000" and r["speed"] == 1.0 and r["nudge"] == 0
        assert r["joint_glitches"] == 1 and "RightToeBase x1 (frames 5-9)" in r["joint_glitches_text"]  # its toe flip
        assert r["frames"] == round(0.2 * r["fps"])
        assert set(r["targets"]) == {"a", "b", "c", "d", "e", "f"} and r["targets"]["f"] is None  # one garment
        assert r["passed"] == all(v is not False for v in r["targets"].values())
        assert r["structural_stretch_max"] >= r["structural_stretch_p99"] >= 0.9
    assert [r["limb_tubes"] for r in rows] == [2, 2, 0, 0] and rows[2]["targets"]["c"] is None
    assert summary["runs"] == 4 and summary["passed"] == sum(r["passed"] for r in rows)
    assert result.returncode == (0 if summary["passed"] == 4 else 1)
    assert "[4/4]" in result.stderr  # progress


def test_evaluate_reports_cloth_moved_through_the_legs_as_failing_b():
    """After dressing, the trouser legs are swung 60 degrees forward about the crotch, as if on legs raised
    in front while the legs hang down: both thighs go through the trouser legs' backs. And no replay
    (``replay_frames``) undoes the move: the garment's motion starts with no frame to replay
    (``GarmentSolver.start_motion``; before it, the first frame's replay ran from the dressing's last frames and
    put the legs back: 0 bone frames)."""
    from garment_sim_ros.commands.evaluate import Run, evaluate_run

    def swing_forward(character, angle=np.radians(60.0)):
        solver = character.solvers[0]
        x = solver.state.positions  # root frame: x forward, z up
        crotch = x[solver.model.rings["left_leg"][0], 2].min()
        below = (solver.constants.inv_mass > 0.0) & (x[:, 2] < crotch)
        d = x[below] - [0.0, 0.0, crotch]
        c, s = np.cos(angle), np.sin(angle)
        x[below] = np.column_stack([c * d[:, 0] - s * d[:, 2], d[:, 1], s * d[:, 0] + c * d[:, 2]]) + [0, 0, crotch]
        solver.state.velocities[...] = 0.0

    result = evaluate_run(Run(str(CLIP), "pants", 1.0, 60.0, 0.1), after_dressing=swing_forward)
    assert result["frames"] == 6
    assert result["bones_frames"] == 6 and result["bones_max"] >= 2  # both thighs, every frame
    assert result["legs_off_frames"] == 6
    assert result["targets"]["b"] is False and result["targets"]["c"] is False and not result["passed"]


def test_evaluate_param_changes_the_parameters_of_every_run_and_refuses_bad_values():
    import argparse

    from garment_sim_ros.commands.evaluate import add_arguments, evaluate_run, plan

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args([str(CLIP), "--garments", "pants,short_skirt", "--duration", "0.05",
                              "--param", "collision_epsilon=0.005", "--param", "gravity=0,0,-5",
                              "--param", "strain_limit_iterations=6", "--param", "collision_mode=static"])
    runs = plan(args)
    changes = {"collision_epsilon": 0.005, "gravity": (0.0, 0.0, -5.0), "strain_limit_iterations": 6,
               "collision_mode": "static"}
    assert len(runs) == 2 and all(dict(run.params) == changes for run in runs)
    worn = []
    evaluate_run(runs[1], after_dressing=lambda character: worn.extend(s.params for s in character.solvers))
    assert len(worn) == 1 and {name: getattr(worn[0], name) for name in changes} == changes
    assert worn[0].friction == DEFAULT_PARAMS.friction  # the others stay the preset's

    for text, message in [("contact_margin=0.2", r"contact_margin: got 0.2; allowed: \[0.0, 0.05\] m"),
                          ("strain_limit_iterations=1.5", "strain_limit_iterations: .*a whole number"),
                          ("gravity=0,1", "gravity: .*a list of 3 numbers"),
                          ("collision_mode=fast", "collision_mode: .*one of adaptive"),
                          ("friction=high", r"friction: got 'high'; allowed: \[0.0, 100.0\]"),
                          ("bogus=1", "unknown parameter 'bogus'"), ("friction", "expected NAME=VALUE")]:
        with pytest.raises(ValueError, match=message):
            plan(parser.parse_args([str(CLIP), "--param", text]))
    result = subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", "evaluate", str(CLIP), "--param",
                             "contact_margin=0.2"], capture_output=True, text=True, timeout=600)
    assert result.returncode == 2 and "contact_margin: got 0.2; allowed: [0.0, 0.05] m" in result.stderr
    assert "Traceback" not in result.stderr


def test_evaluate_nudges_repeat_each_run_from_a_start_moved_1_um_and_say_which_rows_pass_with_every_seed():
    """``--nudges``: one run per seed, its free points moved ``NUDGE_M`` after dressing (the attached ones not);
    the summary counts the rows (clip x garment x speed x frame rate) that pass with every seed and with some."""
    import argparse

    from garment_sim_ros.commands.evaluate import (
        NUDGE_M,
        add_arguments,
        format_summary,
        nudge_free_points,
        plan,
        summarize,
    )

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    runs = plan(parser.parse_args([str(CLIP), "--garments", "pants,short_skirt", "--nudges", "0,3"]))
    assert [(r.garment, r.nudge) for r in runs] == [("pants", 0), ("pants", 3), ("short_skirt", 0),
                                                    ("short_skirt", 3)]
    assert {r.nudge for r in plan(parser.parse_args([str(CLIP)]))} == {0}  # not nudged by default
    for text in ("1,1", "-1", "a", ""):
        with pytest.raises(ValueError, match="--nudges"):
            plan(parser.parse_args([str(CLIP), "--nudges", text]))

    source = procedural_source()
    character = make_character(source.rest_pose, source.joint_map, ["pants"], DEFAULT_PARAMS)
    solver = character.solvers[0]
    before = solver.state.positions.copy()
    nudge_free_points(character, 3)
    moved = np.linalg.norm(solver.state.positions - before, axis=1)
    free = solver.constants.inv_mass > 0
    assert np.allclose(moved[free], NUDGE_M, rtol=1e-6) and not moved[~free].any()
    nudged = solver.state.positions.copy()
    for seed, same in ((3, True), (4, False)):  # seeded: the same seed moves them the same way
        solver.state.positions[...] = before
        nudge_free_points(character, seed)
        assert np.array_equal(solver.state.positions, nudged) == same

    def row(garment, nudge, bones_ok, stretch_ok):
        targets = {"a": True, "b": bones_ok, "c": None, "d": stretch_ok, "e": True, "f": None}
        return {"clip": "c", "garment": garment, "speed": 1.0, "fps": 60.0, "nudge": nudge, "targets": targets,
                "passed": bones_ok and stretch_ok}

    rows = [row("pants", 0, True, True), row("pants", 1, True, False), row("skirt", 0, False, True),
            row("skirt", 1, False, True), row("cape", 0, True, True), row("cape", 1, True, True)]
    nudges = summarize(rows)["nudges"]
    assert nudges["seeds"] == [0, 1] and nudges["rows"] == 3 and nudges["passed_by_seed"] == [2, 1]
    assert nudges["passed"] == {"every": 1, "some": 2, "asked": 3}
    assert nudges["targets"]["b"] == {"every": 2, "some": 2, "asked": 3}
    assert nudges["targets"]["d"] == {"every": 2, "some": 3, "asked": 3}
    assert nudges["targets"]["c"]["asked"] == 0
    assert "passing with every seed - with some: 1-2/3" in format_summary(summarize(rows))
    assert "nudges" not in summarize([r for r in rows if r["nudge"] == 0])
