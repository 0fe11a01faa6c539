"""Issue 11 item 6: fast limb swings on the procedural character, beyond its gaits -- both hips flexed
120 deg in 0.2 s (a jump's tuck: 600 deg/s) while the arms windmill at 360 deg/s -- and what the solver
does about them: substeps chosen from the limbs' speed, and the opt-in motion constraints; and the
substeps' own cap on real clips played fast (stretch (d) at 2x, 30 fps).

Checked after every frame, in the world, with the figures ``garment-sim evaluate`` judges
(``quality.GarmentMeter`` via ``DressedCharacter.step``): no limb bone through the trousers, both
trouser legs on their legs, no free point deeper than 5 mm, no guard firing.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.pose_buffer import RootMotion, SampleStatus
from garment_sim_ros.body.procedural import ProceduralCharacter, walk
from garment_sim_ros.body.root import root_frame
from garment_sim_ros.body.sources import procedural_source
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.model import build_cloth_model
from garment_sim_ros.cloth.motion_constraints import SkinBinding, limit_distance
from garment_sim_ros.cloth.solver import FrameInput, GarmentSolver, substep_plan, volume_travel
from garment_sim_ros.collision.volumes import ELLIPSOID, SPHERE, Volume, VolumeSet
from garment_sim_ros.commands.evaluate import Run, evaluate_run
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.transforms import quat_from_axis_angle, quat_multiply

FLEXION_DEG = 120.0
FLEXION_S = 0.2
ARM_DEG_S = 360.0
HOLD_S = 0.3  # then held flexed while the arms go on turning
FRAME_S = 1.0 / 60.0


def swing_pose(character: ProceduralCharacter, t: float):
    """The character standing, both hips flexing to ``FLEXION_DEG`` over ``FLEXION_S`` (smooth step: peak
    rate 1.5 x the mean, 900 deg/s) and both shoulders turning forward at ``ARM_DEG_S``."""
    translations, rotations = character._local(0.0, amplitude=0.0, travelled=0.0)
    rotations = rotations.copy()
    s = min(1.0, max(0.0, t / FLEXION_S))
    hip = -math.radians(FLEXION_DEG) * s * s * (3.0 - 2.0 * s)  # about +y, negative: the thigh forward
    arm = -math.radians(ARM_DEG_S) * t
    for joint, angle in (("hip", hip), ("shoulder", arm)):
        for side in ("left", "right"):
            i = character.skeleton.index(f"{side}_{joint}")
            rotations[i] = quat_multiply(rotations[i], quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), angle))
    return character._pose_from_local(translations, rotations)


@lru_cache(maxsize=None)
def swing(garment: str, **changes):
    """Reports of every frame of the swing, and the substeps a frame got."""
    source = procedural_source("walk")
    character = ProceduralCharacter(walk())
    dressed = make_character(source.rest_pose, source.joint_map, [garment], DEFAULT_PARAMS.replace(**dict(changes)))
    pose = swing_pose(character, 0.0)
    position, yaw = root_frame(pose, dressed.joint_map)
    still = np.zeros(3)
    motion = RootMotion(SampleStatus.OK, FRAME_S, 0, np.asarray(position, float), yaw, still, still, 0.0, 0.0)
    dressed.dress(pose, 0.0, motion)
    reports = []
    for k in range(1, int(round((FLEXION_S + HOLD_S) / FRAME_S)) + 1):
        t = k * FRAME_S
        reports.append(dressed.step(swing_pose(character, t), motion, t)[0])
    return reports


def test_the_swing_is_as_fast_as_the_issue_asks():
    character = ProceduralCharacter(walk())
    i = character.skeleton.index("left_knee")
    hip = character.skeleton.index("left_hip")
    thigh = [swing_pose(character, t).positions[i] - swing_pose(character, t).positions[hip] for t in (0.0, FLEXION_S)]
    cos = thigh[0] @ thigh[1] / np.linalg.norm(thigh[0]) / np.linalg.norm(thigh[1])
    assert math.degrees(math.acos(cos)) == pytest.approx(FLEXION_DEG, abs=0.5)


@pytest.mark.parametrize("garment", ["pants", "short_skirt"])
def test_garments_stay_on_through_a_fast_tuck_with_the_arms_windmilling(garment):
    """Through the swing (its 0.2 s). Held at 120 deg the trousers do not stay on: measured, the guard
    fires 0.1 s into the hold and the re-dress cannot put them on the tucked pose (both legs off) --
    the front of the hip tube is pinched between the thighs and the belly (see the README's limits)."""
    reports = swing(garment)[:int(round(FLEXION_S / FRAME_S))]
    assert [r.recovery for r in reports if r.recovery] == []
    assert max(r.bones_through for r in reports) == 0
    assert max(r.legs_off for r in reports) == 0
    assert max(r.max_depth_m for r in reports) < 0.005


def test_the_short_skirt_stays_on_held_in_the_tuck():
    reports = swing("short_skirt")
    assert [r.recovery for r in reports if r.recovery] == []
    assert max(r.bones_through for r in reports) == 0
    assert max(r.max_depth_m for r in reports) < 0.005


def test_fast_limbs_get_more_substeps_within_max_limb_substeps():
    reports = swing("pants", frame_retries=0)  # the plan's substeps (a retried frame has twice as many, and more)
    base, _ = substep_plan(FRAME_S, DEFAULT_PARAMS)
    counts = [r.substeps for r in reports]
    assert max(counts) > base  # the swing asked for more than the frame time does
    assert max(counts) <= DEFAULT_PARAMS.max_limb_substeps
    assert all(r.lag_s == pytest.approx(0.0, abs=1e-12) for r in reports)  # and the frame is simulated in full
    fixed = swing("pants", limb_step_ratio=0.0, frame_retries=0)
    assert {r.substeps for r in fixed} == {base}


@pytest.mark.parametrize("clip, garment", [("xia_old_13_000", "pants"), ("xia_angry_13_000", "long_skirt")])
def test_real_clips_at_double_speed_and_30_fps_keep_the_stretch_target(clip, garment):
    """Issue 11 (d): on the Xia clips at 2x and 30 fps (23 and 17 frames) the limbs ask ``limb_step_ratio``
    for 9-30 and 16-54 substeps a frame; capped at ``max_substeps`` (8) the cloth round the thighs and pelvis
    stretched (worst frame's p99 1.136 and max 4.09 on xia_old's trousers, 1.080 / 1.45 on xia_angry's long
    skirt). With the limbs' own cap ``max_limb_substeps`` (24) both stay under p99 1.05 and max 1.5 in every
    frame (1.030 / 1.18, 1.026 / 1.25; 1.039 / 1.29, 1.042 / 1.13 at 16)."""
    row = evaluate_run(Run(str(Path(__file__).parent / "data" / f"{clip}.bvh"), garment, 2.0, 30.0))
    assert row["targets"]["d"] is True, {key: row[key] for key in ("structural_stretch_p99", "structural_stretch_max",
                                                                   "shear_stretch_p99", "shear_stretch_max")}
    assert row["guard_firings"] == 0


# ----------------------------------------------------------------------------- the parts, on their own

def _thigh() -> VolumeSet:
    return VolumeSet((Volume("thigh", ELLIPSOID, "hip", (0.08, 0.08, 0.3), (-0.25, 0.25)),))


def test_volume_travel_is_the_turned_surface_chord_in_radii():
    volumes = _thigh()
    origin, start = np.zeros((1, 3)), np.array([[0.0, 0.0, 0.0, 1.0]])
    angle = math.radians(10.0)
    turned = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), angle)[None]
    # the end of the long axis (0.3 m from the centre) moves by the chord 2 r sin(angle / 2)
    assert volume_travel(volumes, origin, start, origin, turned) == pytest.approx(0.3 * 2 * math.sin(angle / 2) / 0.08)
    assert volume_travel(volumes, origin, start, origin + [0.04, 0.0, 0.0], start) == pytest.approx(0.5)


def test_the_substep_count_follows_the_limbs_speed_up_to_max_limb_substeps():
    params = DEFAULT_PARAMS.replace(substep=0.005, max_substeps=8, limb_step_ratio=0.25, max_limb_substeps=16)
    assert substep_plan(1 / 60, params, limb_travel=0.0) == (4, pytest.approx(1 / 240))
    assert substep_plan(1 / 60, params, limb_travel=1.3)[0] == 6  # ceil(1.3 / 0.25)
    assert substep_plan(1 / 60, params, limb_travel=3.1)[0] == 13  # past max_substeps: the limbs' own cap
    assert substep_plan(1 / 60, params, limb_travel=50.0) == (16, pytest.approx(1 / 960))  # capped, no lag
    assert substep_plan(1 / 30, params.replace(max_limb_substeps=2), limb_travel=50.0)[0] == 7  # time's own count
    assert substep_plan(0.1, params, limb_travel=50.0) == (8, 0.005)  # the time cap (and lag) as before
    assert substep_plan(1 / 60, params.replace(limb_step_ratio=0.0), limb_travel=50.0)[0] == 4


def test_limit_distance_pulls_free_points_onto_their_sphere_and_leaves_the_rest():
    rng = np.random.default_rng(1)
    skinned0 = rng.normal(size=(50, 3))
    skinned1 = skinned0 + 0.2
    x = skinned0 + 0.1 + rng.normal(scale=0.3, size=(50, 3))
    inv_mass = np.ones(50)
    inv_mass[:5] = 0.0
    before = x.copy()
    moved = limit_distance(x, skinned0, skinned1, 0.5, 0.15, inv_mass)
    target = skinned0 + 0.1
    distance = np.linalg.norm(x - target, axis=1)
    far = np.linalg.norm(before - target, axis=1) > 0.15
    assert moved == np.count_nonzero(far[5:])
    assert np.all(distance[5:] <= 0.15 + 1e-12)
    assert np.allclose(distance[5:][far[5:]], 0.15)
    assert np.array_equal(x[~far], before[~far]) and np.array_equal(x[:5], before[:5])
    # pulled straight towards the skinned position: the direction is kept
    direction = (x - target)[5:][far[5:]], (before - target)[5:][far[5:]]
    assert np.allclose(np.sum(direction[0] * direction[1], axis=1),
                       np.linalg.norm(direction[0], axis=1) * np.linalg.norm(direction[1], axis=1))


def test_each_point_is_bound_to_the_volume_it_lies_on_and_rides_with_it():
    volumes = VolumeSet((Volume("a", ELLIPSOID, "f", (0.1, 0.1, 0.3), (-0.25, 0.25)),
                         Volume("b", ELLIPSOID, "g", (0.1, 0.1, 0.3), (-0.25, 0.25))))
    positions = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.0]])
    rotations = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
    points = np.array([[0.12, 0.0, 0.1], [0.0, 0.38, -0.2], [0.0, 0.62, 0.0]])
    skin = SkinBinding(points, volumes, positions, rotations)
    assert skin.volume.tolist() == [0, 1, 1]
    assert np.allclose(skin.positions(positions, rotations), points)
    turned = rotations.copy()
    turned[1] = quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), math.pi)
    moved = skin.positions(positions + [0.0, 0.0, 1.0], turned)
    assert np.allclose(moved[0], points[0] + [0.0, 0.0, 1.0])
    assert np.allclose(moved[2], [0.0, 0.38, 1.0])  # half a turn about b's axis at y = 0.5


def test_motion_constraints_are_off_by_default_and_hold_every_free_point_within_reach_when_on():
    """A skirt swung by a violent root acceleration, its body one sphere far off (no collision to move
    the points after the constraint): with ``max_distance`` no free point ends a frame farther than
    that from its skinned position (the sphere stands still in the root frame: the rest shape)."""
    assert DEFAULT_PARAMS.max_distance == 0.0
    model = build_cloth_model(build_garment("short_skirt", resolution=0.5))
    far_sphere = VolumeSet((Volume("far", SPHERE, "root", (0.1, 0.1, 0.1), offset_position=(5.0, 0.0, 0.0)),))

    def farthest(max_distance: float) -> float:
        solver = GarmentSolver(model, far_sphere, DEFAULT_PARAMS.replace(max_distance=max_distance), ("root",))

        def frames():
            return np.zeros((1, 3)), np.array([[0.0, 0.0, 0.0, 1.0]])

        solver.reset(np.zeros(3), 0.0, *frames())
        free = solver.constants.inv_mass > 0.0
        worst, t = 0.0, 0.0
        for k in range(30):
            push = np.array([40.0 * math.sin(0.5 * k), 25.0, 0.0])  # m/s^2
            (p0, q0), (p1, q1) = frames(), frames()
            solver.advance(FrameInput(
                t0=t, t1=t + FRAME_S, root_position0=np.zeros(3), root_yaw0=0.0, root_position1=np.zeros(3),
                root_yaw1=0.0, root_velocity=np.zeros(3), root_acceleration=push, yaw_rate=6.0, yaw_acceleration=0.0,
                frame_positions0=p0, frame_rotations0=q0, frame_positions1=p1, frame_rotations1=q1))
            t += FRAME_S
            worst = max(worst, float(np.linalg.norm(solver.state.positions - model.rest_positions, axis=1)[free].max()))
        return worst

    assert farthest(0.0) > 0.2  # unconstrained, the skirt flies out
    assert farthest(0.03) <= 0.03 + 1e-9
