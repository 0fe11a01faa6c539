"""Issue 3, "No penetration, the memo's claim": every garment on the procedural character in fast
motion (root 3 m/s, legs >= 180 deg/s, arms >= 360 deg/s), frames of 1/60 s up to 0.1 s.

Checked after every frame, in the simulation (root) frame, against the volumes' poses at the
frame's end:
- no free mass point is inside any volume by more than 1 mm (attached points ride on their
  segment and are the only ones left out);
- no tunnelling, which depth cannot show (a point pushed through a thin limb ends outside, on the
  wrong side): no structural edge of the cloth cuts through the core of any volume (the volume
  shrunk to half about its centre) -- an edge whose ends lie on opposite sides of a limb does;
  every ring of a trouser leg still goes round its thigh or shin (winding number about the volume's
  axis; a ring's centroid is no test of that: a loose hem hanging off a bent shin still goes round
  it with its centroid 1.5 shin radii off the axis); no skirt point is closer to a leg volume's axis
  than that volume's radius at its height minus 1 mm.
And static-only handling demonstrably tunnels in a fast case where the adaptive handling does not.
Then the fixes this suite needed, each on its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest

from garment_sim_ros.body.procedural import ProceduralCharacter, fast_motion
from garment_sim_ros.body.root import root_frame
from garment_sim_ros.body.sources import procedural_source
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.model import STRUCTURAL, build_cloth_model
from garment_sim_ros.collision.collider import Collider
from garment_sim_ros.collision.volumes import ELLIPSOID, Volume, VolumeSet
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import rings_off_the_legs
from garment_sim_ros.transforms import IDENTITY_QUAT, quat_conjugate, quat_multiply, transform_points, yaw_quat

START_S = 1.0  # the fast motion's start-up ramp is over: full speed from the first frame
DURATION_S = 1.0  # 1.5 strides: every leg and arm swings both ways
FRAME_TIMES = (1.0 / 60.0, 1.0 / 30.0, 0.1)
GARMENTS = ("short_skirt", "long_skirt", "pants", "one_piece")
TOLERANCE_M = 0.001
LEG_VOLUMES = tuple(f"{side}_{part}_leg" for side in ("left", "right") for part in ("upper", "lower"))
CORE = 0.5  # an edge through the volume shrunk to half about its centre goes through the body


# ----------------------------------------------------------------------------- geometry checks

def local_points(solver, volume: int, points: np.ndarray) -> np.ndarray:
    """Points of the simulation frame in the volume's local frame at the last substep's end."""
    collider = solver.collider
    return (points - collider.arrays.pos1[volume]) @ collider.arrays.rot1[volume]


def edges_through_cores(solver, volumes: list[int], core: float = CORE) -> int:
    """Structural edges (not both ends attached) whose segment enters the core of one of ``volumes``:
    the volume (ellipsoid or sphere and its cut slab) scaled by ``core`` about its centre."""
    model = solver.model
    x = solver.state.positions
    edges = model.springs[model.spring_kinds == STRUCTURAL]
    free = solver.constants.inv_mass > 0.0
    edges = edges[free[edges[:, 0]] | free[edges[:, 1]]]
    radii, cuts = solver.volumes.radii, solver.volumes.cuts
    count = 0
    for v in volumes:
        # In coordinates scaled by the core's radii the core is the unit ball within a slab in z.
        a = local_points(solver, v, x[edges[:, 0]]) / (core * radii[v])
        d = local_points(solver, v, x[edges[:, 1]]) / (core * radii[v]) - a
        low, high = np.clip(cuts[v], -radii[v, 2], radii[v, 2]) / radii[v, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t_low, t_high = (low - a[:, 2]) / d[:, 2], (high - a[:, 2]) / d[:, 2]
        level = np.abs(d[:, 2]) < 1e-12
        in_slab = (a[:, 2] >= low) & (a[:, 2] <= high)
        start = np.where(level, np.where(in_slab, 0.0, 2.0), np.maximum(0.0, np.minimum(t_low, t_high)))
        end = np.where(level, 1.0, np.minimum(1.0, np.maximum(t_low, t_high)))
        closest = np.clip(-np.sum(a * d, axis=1) / np.maximum(np.sum(d * d, axis=1), 1e-30), start, end)
        nearest = np.sum((a + closest[:, None] * d) ** 2, axis=1)
        count += int(np.count_nonzero((start <= end) & (nearest < 1.0)))
    return count


def leg_rings_off(solver) -> int:
    """Trouser-leg rings that go round neither their thigh's nor their shin's axis
    (``quality.LimbTubes``), against the volumes' poses at the last substep's end; the seam's edges
    are checked by ``edges_through_cores``."""
    collider = solver.collider
    return int(rings_off_the_legs(solver.model, solver.volumes, solver.state.positions,
                                  collider.arrays.pos1, collider.arrays.rot1).sum())


def points_inside_leg_radius(solver, names: list[str], tolerance: float = TOLERANCE_M) -> int:
    """Free points inside a leg volume's cross-section at their height shrunk by ``tolerance``, where
    they are within the volume's cut (limb sections are ellipses: narrower sideways where the legs are
    close, see ``body.fitting.THIGH_MID_PLANE_GAP_PER_STATURE``)."""
    free = solver.constants.inv_mass > 0.0
    x = solver.state.positions[free]
    count = 0
    for name in LEG_VOLUMES:
        v = names.index(name)
        ax, ay, az = solver.volumes.radii[v]
        low, high = solver.volumes.cuts[v]
        local = local_points(solver, v, x)
        within = (local[:, 2] >= low) & (local[:, 2] <= high) & (np.abs(local[:, 2]) < az)
        scale = np.sqrt(np.clip(1.0 - (local[:, 2] / az) ** 2, 0.0, None))
        rx, ry = np.maximum(ax * scale - tolerance, 1e-9), np.maximum(ay * scale - tolerance, 1e-9)
        count += int(np.count_nonzero(within & ((local[:, 0] / rx) ** 2 + (local[:, 1] / ry) ** 2 < 1.0)))
    return count


# ----------------------------------------------------------------------------- the runs

@dataclass(frozen=True)
class Run:
    penetration_m: np.ndarray  # per frame: deepest free point in any volume
    edges_through_body: np.ndarray  # per frame
    rings_off_legs: np.ndarray  # per frame (pants)
    points_inside_legs: np.ndarray  # per frame (skirts)
    stretch: np.ndarray  # per frame: largest structural/shear length / rest
    hits: int  # collision responses over the run
    recoveries: int  # frames the solver's guard restored or re-fitted (it would hide a failure)
    excluded_points: np.ndarray  # points max_penetration leaves out
    attached_points: np.ndarray


@lru_cache(maxsize=None)
def simulate(garment: str, frame_s: float, mode: str = "adaptive", max_substeps: int | None = None,
             limb_step_ratio: float = DEFAULT_PARAMS.limb_step_ratio, **changes) -> Run:
    """``changes``: further solver parameters."""
    source = procedural_source("fast")
    params = DEFAULT_PARAMS.replace(collision_mode=mode, limb_step_ratio=limb_step_ratio, **changes)
    if max_substeps is not None:
        params = params.replace(max_substeps=max_substeps)
    character = make_character(source.rest_pose, source.joint_map, [garment], params, 1.0)
    character.dress(source.pose(START_S), START_S, source.motion(START_S))
    solver = character.solvers[0]
    names = character.body.volumes.names()
    every_volume = list(range(len(names)))
    frames = int(round(DURATION_S / frame_s))
    record = {key: np.zeros(frames) for key in ("pen", "edges", "rings", "inside", "stretch")}
    hits = recoveries = 0
    for k in range(frames):
        t = START_S + (k + 1) * frame_s
        report = character.step(source.pose(t), source.motion(t), t)[0]
        assert np.all(np.isfinite(solver.state.positions)), f"{garment}: non-finite positions at t={t:.3f} s"
        hits += report.static_hits + report.dynamic_hits
        recoveries += bool(getattr(report, "recovery", ""))
        record["pen"][k] = character.max_penetration()
        record["edges"][k] = edges_through_cores(solver, every_volume)
        record["rings"][k] = leg_rings_off(solver) if garment == "pants" else 0
        record["inside"][k] = points_inside_leg_radius(solver, names) if "skirt" in garment else 0
        record["stretch"][k] = report.max_stretch
    return Run(record["pen"], record["edges"], record["rings"], record["inside"], record["stretch"], hits, recoveries,
               np.flatnonzero(solver.constants.inv_mass == 0.0), np.sort(solver.model.attached))


CASES = [pytest.param(g, dt, id=f"{g}-{1.0 / dt:.0f}fps") for g in GARMENTS for dt in FRAME_TIMES]


# ----------------------------------------------------------------------------- the motion

def test_the_motion_is_the_fast_one_the_memo_claims_for():
    source = procedural_source("fast")
    character = ProceduralCharacter(fast_motion())
    times = START_S + np.arange(0.0, DURATION_S, 0.01)
    speeds = [np.linalg.norm(source.motion(t).velocity) for t in times[::5]]
    assert min(speeds) == pytest.approx(3.0, rel=0.02)

    def peak_deg_s(joint: str) -> float:
        """Peak angular speed of a joint relative to its parent frame, by finite differences."""
        i = character.skeleton.index(joint)
        parent = character.skeleton.parents[i]
        rates = []
        for t in times:
            q = [quat_multiply(quat_conjugate(p.rotations[parent]), p.rotations[i])
                 for p in (character.pose(t), character.pose(t + 1e-4))]
            relative = quat_multiply(quat_conjugate(q[0]), q[1])
            rates.append(math.degrees(2.0 * math.asin(min(1.0, np.linalg.norm(relative[:3])))) / 1e-4)
        return max(rates)

    assert min(peak_deg_s("left_hip"), peak_deg_s("right_hip")) >= 180.0
    assert min(peak_deg_s("left_shoulder"), peak_deg_s("right_shoulder")) >= 360.0


# ----------------------------------------------------------------------------- the claims

@pytest.mark.parametrize("garment, frame_s", CASES)
def test_no_free_point_is_inside_a_volume_after_any_frame(garment, frame_s):
    run = simulate(garment, frame_s)
    assert run.hits > 0  # the garment was on the body, not floating free of it
    assert run.recoveries == 0  # no frame was reset by the solver's guard
    assert np.array_equal(run.excluded_points, run.attached_points)  # the only points left out
    worst = int(np.argmax(run.penetration_m))
    assert run.penetration_m[worst] <= TOLERANCE_M, (
        f"{run.penetration_m[worst] * 1e3:.2f} mm deep after frame {worst + 1}")


@pytest.mark.parametrize("garment, frame_s", CASES)
def test_no_cloth_edge_cuts_through_the_body(garment, frame_s):
    run = simulate(garment, frame_s)
    frames = np.flatnonzero(run.edges_through_body)
    assert frames.size == 0, (f"edges through a volume after {frames.size} frames, first after frame "
                              f"{frames[0] + 1}: {int(run.edges_through_body[frames[0]])}")


@pytest.mark.parametrize("frame_s", FRAME_TIMES)
def test_trouser_legs_stay_around_the_legs(frame_s):
    run = simulate("pants", frame_s)
    frames = np.flatnonzero(run.rings_off_legs)
    assert frames.size == 0, f"rings off the legs after {frames.size} frames, first after frame {frames[0] + 1}"


@pytest.mark.parametrize("garment", ["short_skirt", "long_skirt"])
@pytest.mark.parametrize("frame_s", FRAME_TIMES)
def test_skirts_stay_outside_both_legs(garment, frame_s):
    run = simulate(garment, frame_s)
    assert run.points_inside_legs.max() == 0


def test_static_handling_alone_lets_the_trouser_legs_slip_off_at_ten_frames_a_second():
    """The reason for the dynamic handling (memo §6.2.1): at 0.1 s frames (8 substeps of 5 ms, so the
    limbs move 2.5 times further per substep than the garment's own time) a shin moves more than its
    radius per substep; pushed out radially from where it ends, a point lands on the far side. The
    substeps are the memo's (``limb_step_ratio`` 0): more of them from the limbs' speed hide the reason.
    The strain limiting after collision, with the contacts handled between its sweeps (issue 11), pulls
    slipped points back and hides it too (measured: static handling with it, no ring off in the 10
    frames; without it, rings off in all 10), so the static handling is shown without it."""
    static = simulate("pants", 0.1, "static", limb_step_ratio=0.0, strain_limit_iterations=0, frame_retries=0)
    adaptive = simulate("pants", 0.1, limb_step_ratio=0.0, frame_retries=0)  # frames run once, as the memo's
    assert np.any(static.rings_off_legs)
    assert not np.any(adaptive.rings_off_legs) and not np.any(adaptive.edges_through_body)
    assert adaptive.penetration_m.max() <= TOLERANCE_M


# ----------------------------------------------------------------------------- the fixes, one by one

@pytest.mark.parametrize("lift_m", [0.0, 0.01])
def test_the_garments_rest_shapes_clear_the_fitted_body(lift_m):
    """Dressing starts from the rest shape, and garments ride up a little in motion: no free point may
    be inside a volume, even lifted by 1 cm. The trousers' crotch seam used to lie on the pelvis
    volume's bottom cut: lifted by a hair it was inside, and the static handling (keep z, push out
    radially in the cross-section) threw it 10 cm sideways across a thigh."""
    source = procedural_source("fast")
    body = make_character(source.rest_pose, source.joint_map, ["one_piece"], DEFAULT_PARAMS).body  # 15 volumes
    rest = body.rest_pose
    frames = [rest.skeleton.index(f) for f in body.volumes.frames]
    poses = body.volumes.world_poses(rest.positions[frames], rest.rotations[frames])
    root_position, root_yaw = root_frame(rest, body.joint_map)
    for garment in GARMENTS:
        model = build_cloth_model(build_garment(garment, body.measurements))
        collider = Collider(body.volumes, model.num_points)
        collider.begin_frame(*poses, *poses)
        lifted = model.rest_positions + [0.0, 0.0, lift_m]
        depths = collider.penetration_depths(transform_points(root_position, yaw_quat(root_yaw), lifted))
        free = np.setdiff1d(np.arange(model.num_points), model.attached)
        assert depths[free].max() == 0.0, f"{garment}: {depths[free].max() * 1e3:.1f} mm inside at rest"


def limb_collider(n_points: int, **params) -> Collider:
    """One still, thin limb: an ellipsoid of radius 5 cm along z at the origin."""
    collider = Collider(VolumeSet((Volume("shin", ELLIPSOID, "f", (0.05, 0.05, 0.3)),)), n_points, cache_size=1)
    collider.set_params(DEFAULT_PARAMS.replace(**params))
    pose = (np.zeros((1, 3)), np.array([IDENTITY_QUAT]))
    collider.begin_frame(*pose, *pose)
    return collider


@pytest.mark.parametrize("swept, side", [(True, 1.0), (False, -1.0)])
def test_a_contact_pulled_past_a_limbs_axis_goes_back_out_where_it_came_in(swept, side):
    """The length correction can pull a point in contact past a thin limb's axis (towards a neighbour
    on the far side). Handled along its trajectory from the substep's start it goes back out on its
    own side; the memo's static push (radially, from where it is) puts it on the far side."""
    collider = limb_collider(1, collision_epsilon=0.0)
    contacts = collider.new_contacts()
    contacts[0] = 0  # in contact with the limb
    x_start = np.array([[0.06, 0.0, 0.0]])
    x = np.array([[-0.02, 0.001, 0.0]])
    collider.handle_contacts(x_start if swept else None, x, np.zeros((1, 3)), np.ones(1), 0.005, contacts)
    assert np.sign(x[0, 0]) == side and np.hypot(x[0, 0], x[0, 1]) == pytest.approx(0.05)


def test_an_edge_a_limb_cuts_through_goes_back_out_on_the_side_it_came_from():
    """Two points outside a shin on either side of it, the edge between them through it: moved out,
    towards where the edge was at the substep's start, to the dip its rest length allows."""
    rest = np.array([0.06])
    allowed_dip = 0.05 - math.sqrt(0.05**2 - 0.03**2)  # sagitta of a 6 cm chord on a 5 cm radius
    for came_from in (1.0, -1.0):
        collider = limb_collider(2)
        x = np.array([[0.01, 0.06, 0.0], [0.01, -0.06, 0.0]])
        x_start = x + [came_from * 0.07, 0.0, 0.0]
        moved = collider.handle_edges(x_start, x, np.ones(2), np.array([[0, 1]]), rest)
        assert moved == 1
        assert np.sign(x[0, 0]) == came_from and x[0, 0] == pytest.approx(x[1, 0])
        assert abs(x[0, 0]) == pytest.approx(0.05 - allowed_dip)  # the edge's deepest point, on the axis' level
    # an edge wrapping the limb within its sagitta is left alone, and an attached end stays
    collider = limb_collider(2)
    chord = np.array([[0.041, 0.03, 0.0], [0.041, -0.03, 0.0]])
    x = chord.copy()
    assert collider.handle_edges(x, x, np.ones(2), np.array([[0, 1]]), rest) == 0
    np.testing.assert_array_equal(x, chord)
    x = np.array([[0.01, 0.06, 0.0], [0.01, -0.06, 0.0]])
    collider.handle_edges(x + [0.07, 0.0, 0.0], x, np.array([0.0, 1.0]), np.array([[0, 1]]), rest)
    np.testing.assert_array_equal(x[0], [0.01, 0.06, 0.0])
    assert x[1, 0] > 0.01


@pytest.mark.parametrize("edge_pinch_depth", [0.001, 0.05, 0.0])
def test_an_edge_cut_by_a_limb_pressed_into_the_belly_stays_in_the_pinch(edge_pinch_depth):
    """The edge through the shin as above, came from +x, where a belly (a 20 cm sphere) presses against the
    shin: back out on its side, its ends would be 11 mm inside the belly. Past ``pinch_depth`` contact wins
    and the edge stays where it is (a thigh raised against the belly, CC cartwheel: edges moved 10-19 cm
    from one volume into the other threw the skirt between them); allowed deeper, or off (0),
    it goes out of the shin."""
    belly_centre = np.array([0.22, 0.0, 0.0])
    collider = Collider(VolumeSet((Volume("shin", ELLIPSOID, "f", (0.05, 0.05, 0.3)),
                                   Volume("belly", ELLIPSOID, "f", (0.2, 0.2, 0.2)))), 2, cache_size=1)
    collider.set_params(DEFAULT_PARAMS.replace(edge_pinch_depth=edge_pinch_depth))
    pose = (np.array([[0.0, 0.0, 0.0], belly_centre]), np.array([IDENTITY_QUAT, IDENTITY_QUAT]))
    collider.begin_frame(*pose, *pose)
    cut = np.array([[0.01, 0.06, 0.0], [0.01, -0.06, 0.0]])
    x = cut.copy()
    moved = collider.handle_edges(x + [0.07, 0.0, 0.0], x, np.ones(2), np.array([[0, 1]]), np.array([0.06]))
    if 0.0 < edge_pinch_depth < 0.011:
        assert moved == 0 and np.array_equal(x, cut)
    else:  # out of the shin into the belly, then the edge dipping into the belly back towards the shin
        assert moved == 2 and not np.array_equal(x, cut)
