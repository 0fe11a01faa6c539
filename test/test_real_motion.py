"""Issue 11 item 6, the fast subset of the real-motion suite: shared clips x garments x speeds run through
``garment-sim evaluate`` (``commands.evaluate.evaluate_run``), 1 s each at 60 fps, judged by the issue's
targets (``quality.TARGETS``). The full sweep (every clip, garment, 1-3x, 60 and 30 fps) is ``make evaluate``.

Asked here: (b) no limb bone through the cloth, (c) no trouser leg off its leg, (a) depth, (d) stretch, (e) no
guard firing, on ordinary clips (on 2026-12-02 every full-protocol run of the seven ordinary clips met them with
seed 0, 501 of 504 over three starts; the CC jump and the cartwheel do not yet: README, "Real motion: measured
quality").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth.garments import GARMENT_NAMES
from garment_sim_ros.collision.collider import Collider
from garment_sim_ros.commands.evaluate import Run, evaluate_run
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import preset
from garment_sim_ros.transforms import quat_to_matrix

DATA = Path(__file__).parent / "data"
# The waistband held where it is skinned and no open-cut exit: the defaults before 2026-11-28. Tests of the crossing
# handling under a forearm on the band, and of opt-ins measured then, keep those conditions; with the band giving way
# (the default now) there is no crossing at the band to handle (docs/real_motion.md, "Two rules on by default").
HELD_BAND = (("band_gives_way", 0), ("open_cut_band", 0.0))
# No replays (``replay_frames``, the default since 2026-12-03): tests of a rule measured before then keep them off. A
# replay mends some of the events they play whatever the rule (the forearm at the hip: no bone frame with the band
# held either), so what the rule does could not be seen with them.
NO_REPLAYS = (("replay_frames", 0),)
CASES = ([("xia_strutting_01_000", garment) for garment in GARMENT_NAMES]
         + [("cc_cmu_06_14_basketball_crossover_shoot", "pants"), ("cmu_01_01_jumps_turnaround", "pants")])


@pytest.mark.parametrize("clip, garment", CASES)
def test_garments_stay_on_real_clips_at_double_speed(clip, garment):
    row = evaluate_run(Run(str(DATA / f"{clip}.bvh"), garment, 2.0, 60.0, 1.0))
    assert row["frames"] == 60
    failed = {letter: ok for letter, ok in row["targets"].items() if ok is False}
    assert failed == {}, {key: row[key] for key in ("bones_frames", "legs_off_frames", "deep_frames", "max_depth_mm",
                                                     "structural_stretch_p99", "structural_stretch_max",
                                                     "shear_stretch_p99", "shear_stretch_max", "guard_firings")}


def test_cloth_between_a_forearm_along_the_hip_and_the_pelvis_has_a_place_outside_both():
    """Issue 11, the CC jump at 0.683 s: the right forearm hangs along the hip, its axis and the pelvis'
    nearly side by side, the nearest points of the two at the wrist's end, where the two volumes are 29 mm
    apart along the line joining them; yet they overlap higher up (checked here point by point against the
    volumes' own surfaces: 36 points of a 21^3 grid over the forearm are inside both, and in no other
    volume). Measured along the lines square to the axes (``contact_planes._overlap``) the pair gets a
    contact plane, and every such point is put outside the body within 5 mm (3.8 mm measured); with the
    nearest points' line only, 14 stayed inside, 8.7 mm deep, after a move of up to 17 mm."""
    source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False)
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"], preset("si"),
                               motion=source.fit_poses())
    volumes = character.solvers[0].volumes
    pelvis, forearm = volumes.names().index("pelvis"), volumes.names().index("right_lower_arm")
    pose = source.pose(0.683)
    frames = [pose.skeleton.index(frame) for frame in volumes.frames]
    positions, quaternions = volumes.world_poses(pose.positions[frames], pose.rotations[frames])
    rotations = quat_to_matrix(np.asarray(quaternions, dtype=float))

    def inside(v, points):  # in volume v as fitted (both are cut ellipsoids), no contact plane
        local = (points - positions[v]) @ rotations[v]
        (lo, hi), radii = volumes.volumes[v].cut, np.asarray(volumes.volumes[v].radii)
        return (((local / radii) ** 2).sum(1) < 1.0) & (lo < local[:, 2]) & (local[:, 2] < hi)

    axes = [np.linspace(-r, r, 21) for r in volumes.volumes[forearm].radii]
    grid = positions[forearm] + np.stack(np.meshgrid(*axes), -1).reshape(-1, 3) @ rotations[forearm].T
    squeezed = grid[inside(pelvis, grid) & inside(forearm, grid)]
    assert len(squeezed) > 20
    assert not any(inside(v, squeezed).any() for v in range(len(volumes)) if v not in (pelvis, forearm))
    collider = Collider(volumes, len(squeezed))
    collider.begin_frame(positions, quaternions, positions, quaternions)
    x = squeezed.copy()
    collider.handle_all(squeezed.copy(), x, np.zeros_like(x), np.ones(len(x)), 1.0 / 60.0, collider.new_contacts())
    assert collider.penetration_depths(x).max() == 0.0
    assert np.linalg.norm(x - squeezed, axis=1).max() < 0.005


def test_a_forearm_at_the_hip_does_not_stay_caught_under_the_waistband():
    """Issue 11, the CC jump, short skirt, 1x at 60 fps: from 1.08 s the right hand is at the hip and the
    forearm reaches the skirt's row under the waistband, whose triangles have an attached corner. Left as
    they were, the bone stayed through that row to the clip's end (116 frames of 180), the skirt caught on
    the forearm after the hand left the hip; their free corners taken to the band's side of the bone
    (``crossing._attached_side``), it is through for 19 frames, 1.08-1.38 s, and never after 1.5 s. Band held, no
    replays (``NO_REPLAYS``: with them no frame has the bone through, 2026-12-03)."""
    source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False)
    character = make_character(source.rest_pose, source.joint_map, ["short_skirt"],
                               preset("si").replace(**dict(HELD_BAND + NO_REPLAYS)), motion=source.fit_poses())
    through = [reports[0].bones_through for _, _, reports in simulate_frames(source, character, np.arange(121) / 60.0)
               if reports is not None]
    assert len(through) == 120 and any(through[60:90])  # the hand at the hip
    assert not any(through[90:])


@pytest.mark.parametrize("garment", ["short_skirt", "long_skirt", "pants"])
def test_a_forearm_leaving_the_waistband_takes_no_cloth_with_it(garment):
    """Issue 11 (b), the CC jump, 1x at 60 fps, the whole clip: at 1.08-1.20 s the right forearm lies on the
    waistband (the band's attached points within 25 mm of the bone, on both sides of it) and its wrist end gets
    under the band. From 1.22 s the hand leaves the hip and the band is 34-127 mm from the bone; a band-row
    triangle the bone crossed, caught, used to stay on it (to 1.38 s, 11 frames on each garment). On the defaults
    the band gives way under the forearm (``band_gives_way``, dragging its neighbours along) and a caught
    triangle goes off past the wrist (``crossing._push_off_axis``): no bone through after 1.20 s, with every one
    of three starts (measured 2026-12-01). With the band held where it is skinned (the conditions this test was
    first written for) the frames after 1.20 s are decided by the trajectory: 0-10 by start and machine
    (docs/real_motion.md, "A band that gives way without tearing")."""
    source = bvh_source(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), loop=False)
    character = make_character(source.rest_pose, source.joint_map, [garment], preset("si"), motion=source.fit_poses())
    through = [reports[0].bones_through for _, _, reports in simulate_frames(source, character, np.arange(241) / 60.0)
               if reports is not None]
    assert len(through) == 240
    assert not any(through[72:]), [i + 1 for i, n in enumerate(through) if n and i >= 72]


def test_the_waistband_gives_way_under_a_forearm_lying_on_it():
    """Issue 11 (b), the CC jump, 1x at 60 fps, 1.6 s: at 1.08-1.42 s the right forearm lies on the waistband,
    whose skinned points are inside its volume on both sides of its bone, so no move of the free cloth clears
    the bone. With ``band_gives_way`` the attached points' targets inside a forearm's volume go out of it across
    its axis towards the trunk (``kernels.push_out_of_volumes``), dragging their neighbours along the band
    (``kernels.spread_along_band``), the band under the forearm. The short skirt: no bone through with the rule in
    each of three starts (held: 9, 9, 2 frames); the trousers, where the thighs pinch the cloth too, fewer frames
    over the three starts (measured 2026-12-01: held 3 + 3 + 11, giving way 2 + 4 + 1). No replays (``NO_REPLAYS``:
    with them the held band's skirt has no bone frame either, 2026-12-03)."""
    def frames(garment, on, nudge):
        row = evaluate_run(Run(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), garment, 1.0, 60.0, 1.6,
                               params=(("band_gives_way", on), *NO_REPLAYS), nudge=nudge))
        assert row["frames"] == 96
        return row["bones_frames"]

    skirt = [(frames("short_skirt", 0, nudge), frames("short_skirt", 1, nudge)) for nudge in (0, 1, 2)]
    assert all(held > 0 and given == 0 for held, given in skirt), skirt
    trousers = np.array([(frames("pants", 0, nudge), frames("pants", 1, nudge)) for nudge in (0, 1, 2)])
    assert trousers[:, 1].sum() < trousers[:, 0].sum(), trousers


def test_a_neckline_does_not_give_way_under_a_forearm():
    """Issue 11 (b), the cartwheel, one-piece, 2x at 30 fps, 3 s: only a waistband (attached points carried by the
    pelvis) gives way under a forearm (``band_gives_way``). The one-piece's neckline, carried by the chest, giving
    way too put a bone through the dress in one frame (its longest spring 2.51 -> 3.62): the run is the run without
    the rule, figure for figure."""
    rows = [evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "one_piece", 2.0, 30.0, 3.0,
                             params=(("band_gives_way", on),))) for on in (0, 1)]
    assert rows[0]["frames"] == 90
    figures = ("bones_frames", "max_depth_mm", "structural_stretch_p99", "structural_stretch_max", "shear_stretch_max")
    assert [rows[1][k] for k in figures] == [rows[0][k] for k in figures]


def test_a_hand_on_the_hip_does_not_spear_the_trousers():
    """Issue 11 (b), cmu_131 (a walk with the left hand on the hip from 1.83 s), trousers, 1x at 60 fps: the
    forearm is pressed up to 45 mm into the pelvis' and 43 mm into the left thigh's volumes and its wrist spears
    the row under the waistband. Every way off the bone put the corner beyond the wrist up to 8 mm into the thigh, past
    ``pinch_depth`` (1 mm): contact won, the crossing passed to the band's row and stayed there while the hand
    did (28 frames, 1.83-2.28 s). Into a volume pressed against the bone's the corner may go
    ``pressed_pinch_depth`` (10 mm) deep, and ``crossing.out_of_pinches`` takes it out again: no frame with a bone
    through, no point deeper than 1 mm."""
    row = evaluate_run(Run(str(DATA / "cmu_131_01_walk_mjstyle.bvh"), "pants", 1.0, 60.0, 2.4))
    assert row["frames"] == 144
    assert row["bones_frames"] == 0, row["bones_frames"]
    assert row["targets"]["a"] and row["legs_off_frames"] == 0


def test_a_skirt_flung_over_the_elbow_does_not_stay_on_the_upper_arm():
    """Issue 11 (b), cmu_131, one-piece, 3x at 60 fps: from 1.0 s the flared skirt, its rows near the hem, meets
    the right upper arm's bone 70-99 % down it, next to the elbow. Every way off the bone put a corner 1-11 mm into
    the forearm's volume, which overlaps the upper arm's round the elbow, past ``pinch_depth`` (1 mm): the crossing
    was left, then caught, and passed from triangle to triangle of the hem rows (30 frames, 1.0-1.48 s; that
    frame's longest spring 9.6 rest lengths). The next limb's volume at the bone's joint is flesh that gives way as
    a pressed one (``contact_planes.jointed_pairs``, ``pressed_pinch_depth``): no frame with a bone through."""
    row = evaluate_run(Run(str(DATA / "cmu_131_01_walk_mjstyle.bvh"), "one_piece", 3.0, 60.0, 1.6))
    assert row["frames"] == 96
    assert row["bones_frames"] == 0, row["bones_frames"]
    assert row["targets"]["a"] and row["structural_stretch_max"] < 1.5, row["structural_stretch_max"]


def test_a_skirt_caught_on_the_upper_arm_at_the_shoulder_goes_off_past_the_shoulder():
    """Issue 11 (b), the cartwheel, long skirt, 1x at 60 fps: 1.98-2.13 s the right upper arm's bone is through the
    skirt 2-33 % down it, next to the shoulder, which lies outside the chest's volume (7 mm from it). Only a free
    wrist end let caught cloth off past it: moved across the bone, each caught triangle passed the crossing to
    its neighbour and back (all 16 passes of ``crossing.handle_axes`` moving two triangles), 10 frames with a bone
    through, a spring 6-7 rest lengths long. Caught nearer a root end that is clear of the other volumes, the cloth
    goes off past that end (``crossing._bone_end_clear``): none. Since ``edge_pinch_depth`` is on by default that 1x
    window holds one bone frame with or without the rule; the run at 2x, 60 fps, to 3.3 s, holds 7 without it
    (measured with the rule's branch switched off) and none with it."""
    # one trajectory (the old defaults'): after a 1 mm nudge at frame 1, 4 runs of 11 had a bone frame
    row = evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "long_skirt", 2.0, 60.0, 3.3,
                           params=HELD_BAND))
    assert row["frames"] == 198
    assert row["bones_frames"] == 0, row["bones_frames"]


def test_cloth_moved_off_a_bone_into_a_pressed_volume_does_not_stay_there():
    """Issue 11 (a), the CC jump, trousers, 1x at 60 fps, 3 s: the right hand at the hip from 1.08 s. Corners
    the bones' handling puts up to ``pressed_pinch_depth`` into the pelvis stayed there when the bones had the
    last word (15.1 mm deep at a frame's end); ``crossing.out_of_pinches`` puts every free point deeper than
    ``pinch_depth`` out of its volume after the bones' handling: none deeper than 1 mm."""
    row = evaluate_run(Run(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), "pants", 1.0, 60.0, 3.0))
    assert row["frames"] == 180
    assert row["max_depth_mm"] <= 1.0, row["max_depth_mm"]


def test_a_hand_poking_into_the_skirt_does_not_take_the_arm_through_it():
    """Issue 11, cmu_01_01 (jumps), long skirt, 3x at 30 fps, the whole clip: a wrist, the forearm bone's end,
    reaches the skirt from beyond it. Each triangle it reached went across the bone to a side, which only passed
    the bone on to a neighbour (all 16 passes of the crossing handling moving two triangles back and forth); the
    hand went in, the skirt slid up the forearm to the elbow and stayed caught there (with that handling only,
    on this tree: an arm through in 33 frames, 132 and 151-182). Pushed back past the wrist along the bone
    (``crossing._entered_end``), the skirt stays in front of the hand: at most one frame with a bone through
    (frame 53, a forearm grazing the skirt). (At 3x, 60 fps the same tree has an arm through in frames
    147-156: the rule does not clear every episode; the README's evaluate table counts them.)"""
    source = bvh_source(str(DATA / "cmu_01_01_jumps_turnaround.bvh"), loop=False, speed=3.0)
    character = make_character(source.rest_pose, source.joint_map, ["long_skirt"], preset("si"),
                               motion=source.fit_poses())
    reports = [r[0] for _, _, r in simulate_frames(source, character, np.arange(229) / 30.0) if r is not None]
    assert len(reports) == 228
    assert len([k for k, report in enumerate(reports) if report.bones_through]) <= 1


def test_a_thigh_raised_against_the_belly_does_not_throw_the_skirt():
    """CC cartwheel, short skirt, 1x at 60 fps, to just past where the guard first fired (t = 1.03 s; issue
    11): the right thigh raised against the belly overlaps the torso's volume by 3-7 cm and squeezes the
    skirt's front. Edges cut by the thigh were moved out of it into the torso, 10-19 cm, and back, every
    substep, until a spring was ten rest lengths long: the guard re-fitted the skirt, 146 mm deep in 3 s.
    With ``edge_pinch_depth`` contact wins in the pinch (``kernels.handle_edges``): no firing, no point deep
    inside. (Off, 0: the same run fires the guard at t = 1.03 s.) Measured on the memo's 10 volumes: with
    the forearms (12) the same pinch still throws a spring to 7.2 rest lengths at t = 1.05 s and the guard fires
    once (issue 11, left open)."""
    def pinch(character):
        for solver in character.solvers:
            solver.set_params(solver.params.replace(edge_pinch_depth=0.001))

    row = evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "short_skirt", 1.0, 60.0, 1.1,
                           forearms=False), after_dressing=pinch)
    assert row["guard_firings"] == 0 and row["structural_stretch_max"] < 10.0
    assert row["max_depth_mm"] < 5.0


def test_undoing_the_strain_limiting_does_not_put_cloth_back_into_the_body():
    """CC cartwheel, short skirt, 2x at 60 fps, to 1.3 s (issue 11 (a)): at 1.27 s (the clip's 2.53 s) the right
    forearm presses the skirt's front against the torso; a point the collision handling left 1.3 mm inside the
    torso, the strain limiting's handling took out, but the limiting was undone for the substep (a spring 1.92 ->
    1.95 rest lengths, ``GarmentSolver.STRAIN_LIMIT_UNDONE``) and the point went back in with the rest: 1.33 mm
    deep at the frame's end, the run's (a) failure. Undone, a point inside a volume before the limiting keeps where
    its handling put it (``kernels.undo_limiting``): none deeper than 1 mm. (Undone whole, as before: 1.33 mm.)"""
    row = evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "short_skirt", 2.0, 60.0, 1.3))
    assert row["frames"] == 78
    assert row["max_depth_mm"] <= 1.0, row["max_depth_mm"]


@pytest.mark.parametrize("fps", [60.0, 30.0])
def test_a_spring_held_on_two_volumes_in_a_pinch_takes_their_contacts_room(fps):
    """CC cartwheel, short skirt, 1x, to 1.4 s (issue 11 (d)): at 1.27-1.30 s the right thigh, raised 55-68 mm into
    the torso and the chest, squeezes the skirt's front under the waist, and the contact handling holds both ends of
    one spring on the two volumes: 1.53 rest lengths at 60 fps, 1.51 at 30 (``tear_give_stretch`` 0), past (d)'s
    1.5, the whole run's failure at 60 fps. With it (1.49) the spring's ends take their contacts' room
    (``Collider.give_room_to_tears``): none past 1.49, no point inside a volume, no bone through."""
    rows = {give: evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "short_skirt", 1.0, fps,
                                   1.4, params=(("tear_give_stretch", give),))) for give in (0.0, 1.49)}
    assert rows[0.0]["structural_stretch_max"] > 1.5
    given = rows[1.49]
    assert max(given["structural_stretch_max"], given["shear_stretch_max"]) <= 1.49 + 1e-9
    assert given["max_depth_mm"] == 0.0 and given["bones_frames"] == 0 and given["passed"]


def test_the_strain_limiting_slide_is_an_opt_in_for_garments_without_limb_tubes():
    """``strain_limit_slide`` (opt-in): the strain limiting's contact handling puts a point the correction pulled into
    a volume out across the nearest surface (static), in garments without limb tubes; a trouser leg keeps the side
    it came from. On the CC cartwheel's long skirt, 1x at 60 fps, to 2.5 s (upside down from 1.9 s, the skirt over
    the chest, the band held), it changes the run (the points, frame by frame: on 2026-12-03's machine the worst
    frame's p99 came out the same, 1.0262, with it and without) and keeps it out of the body. What it was adopted
    for there (p99 2.03 -> 1.05) was one trajectory: measured 2026-12-01 on the defaults of then (48 strain-limiting
    sweeps), over three starts the worst frame's structural p99 is 1.40 / 1.35 / 1.43 without it and 2.04 / 1.45 /
    1.05 with it (docs/real_motion.md, "A band that gives way without tearing"); so it stays off by default and no
    gain is claimed."""
    params = preset("si").replace(strain_limit_slide=1)
    source = bvh_source(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), loop=False)
    character = make_character(source.rest_pose, source.joint_map, ["long_skirt", "pants"], params,
                               motion=source.fit_poses())
    assert [solver.limit_slides for solver in character.solvers] == [True, False]
    assert not any(solver.limit_slides for solver in make_character(
        source.rest_pose, source.joint_map, ["long_skirt"], preset("si"), motion=source.fit_poses()).solvers)

    ends = {0: [], 1: []}  # the skirt's points after each frame, without and with the slide

    def dressed(slides):
        def after(character):
            solver = character.solvers[0]
            solver.set_params(solver.params.replace(strain_limit_slide=slides))
            _after_each_call(character, "step", lambda _reports: ends[slides].append(solver.state.positions.copy()))
        return after

    rows = [evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "long_skirt", 1.0, 60.0, 2.5,
                             params=HELD_BAND), after_dressing=dressed(slides)) for slides in (0, 1)]
    assert rows[0]["frames"] == rows[1]["frames"] == len(ends[0]) == len(ends[1]) == 150
    assert any(not np.array_equal(a, b) for a, b in zip(ends[0], ends[1]))  # the slide acted (not only in p99)
    assert all(row["max_depth_mm"] < 5.0 for row in rows), [row["max_depth_mm"] for row in rows]


def _watch_hem(hem_stretch: list):
    """An ``after_dressing`` for ``evaluate_run`` that appends, after every frame, the stretch (length / rest
    length) of the correction springs joining two hem points to ``hem_stretch``."""
    def watch(character):
        solver = character.solvers[0]
        model = solver.model
        hem = set(model.rings["hem"][0].tolist())
        ends = model.springs[: model.num_correction_springs]
        on_hem = np.flatnonzero([a in hem and b in hem for a, b in ends])

        def measure(_report):
            x = solver.state.positions
            hem_stretch.append(np.linalg.norm(x[ends[on_hem, 1]] - x[ends[on_hem, 0]], axis=1)
                               / model.rest_lengths[on_hem])

        _after_each_call(solver, "advance", measure)

    return watch


@pytest.mark.parametrize(("garment", "fps", "frames", "widest"), [
    ("long_skirt", 60.0, 69, slice(3, 9)),
    ("one_piece", 30.0, 34, slice(1, 5)),
])
def test_a_vented_garment_goes_round_a_wide_stride(garment, fps, frames, widest):
    """xia_angry's widest strides (thighs 70-76 deg apart; frames 4-9 at 1x, 60 fps, 2-5 at 30 fps) need more hem
    than a closed tube has: the closed long skirt's hem ring was 11-13 % longer than at rest there (structural p99
    1.10), the closed one-piece's, a sheath's, went round both legs (its springs' p99 1.13-1.19, the worst frame's
    structural p99 1.055 at 30 fps, issue 11 (d)). The vent (``garments._vent``, ``garments._vented_tube``) opens
    them below the ring that goes round the stride: stretch (d) holds over the whole clip, and the hem's springs
    stay within the p99 target in those frames."""
    hem_stretch = []
    row = evaluate_run(Run(str(DATA / "xia_angry_13_000.bvh"), garment, 1.0, fps, None),
                       after_dressing=_watch_hem(hem_stretch))
    assert row["frames"] == frames and len(hem_stretch) == frames
    assert row["targets"]["d"] is True, (row["structural_stretch_p99"], row["structural_stretch_max"])
    assert np.percentile(np.concatenate(hem_stretch[widest]), 99) <= 1.05


def test_a_hem_under_a_lifted_foot_is_not_held_past_the_ankle():
    """CC basketball, long skirt, 1x at 60 fps (issue 11 (d)): at 2.1 s the right ankle, a shin's far end with no
    foot volume, came down into the hem from inside the skirt, and the rule for a limb's end poking into the cloth
    (``crossing._entered_end``) put the hem's triangles back past the end, along the bone, every substep after,
    as the foot lifted: three hem points held 3 mm past the ankle end, their springs pulled to 3.3 x their rest
    length, the frame's structural p99 1.05 -> 1.13 over 2.2-2.4 s. The rule now holds at a wrist only (the
    foot goes on from the ankle at an angle): the hem goes across the shin's bone as at any other crossing."""
    row = evaluate_run(Run(str(DATA / "cc_cmu_06_14_basketball_crossover_shoot.bvh"), "long_skirt", 1.0, 60.0, 2.4))
    assert row["frames"] == 144
    assert row["structural_stretch_p99"] <= 1.05 and row["shear_stretch_p99"] <= 1.05
    assert row["bones_frames"] == 0


def test_the_trousers_waistband_follows_the_trunk_through_the_cartwheels_bend():
    """CC cartwheel, trousers, 3x at 30 fps, the whole clip (issue 11): the pelvis turns up to 89 deg against
    the waist (0.9-1.7 s at 1x). Carried by the pelvis alone, the waistband's front went into the belly, its
    attached points 7-21 mm from the spine's bone and 105-116 mm inside the torso, the spine through the row
    under the band (on this tree: 8 bone frames here; 51 / 29 / 29 / 12 / 17 at 1x 60, 1x 30, 2x 60, 2x 30,
    3x 60 fps against 24 / 6 / 1 / 7 / 1 skinned to the spine too). Skinned to the spine too, as the skirts'
    band is (``garments._waistband``), the band follows the trunk: no bone through, no leg off, no firing."""
    row = evaluate_run(Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "pants", 3.0, 30.0))
    assert row["frames"] == 73
    assert (row["bones_frames"], row["legs_off_frames"], row["guard_firings"]) == (0, 0, 0)


def test_a_thigh_does_not_go_through_the_trousers_crotch_into_the_other_leg():
    """CC jump, trousers, 3x at 60 fps, to just past the landing (issue 11 (c)): the left thigh's bone, 11-30 %
    down from the hip joint and inside the pelvis volume, reached the crotch band, which the pelvis bulged
    through between its corners. Every way off the bone put a corner 2-108 mm into the pelvis, so the pinch
    rule left it crossed (``crossing._destinations``) and the thigh walked through the seam: from frame 33 the
    left trouser leg's first ring went round no volume. The crotch seam had 2 interior vertices (segments
    95 mm, the hip ring's 28-38 mm); with 4 (57 mm, ``garments.pants``) no leg is off."""
    row = evaluate_run(Run(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), "pants", 3.0, 60.0, 0.7))
    assert row["frames"] == 42
    assert row["legs_off_frames"] == 0, row["legs_off_frames"]


def test_the_trousers_crotch_pinched_between_the_pelvis_and_the_thighs_is_not_thrown_across_a_thigh():
    """CC jump, trousers, 2x at 60 fps, to 1.2 s (issue 11 (b), (c)): landing, the crotch lies in the pelvis' and
    both thighs' volumes. The edge handling moved its cut edges out of one volume into the next, 6-21 cm a
    substep (points 14-21 cm at 0.73 s), across the right thigh's bone, which the bones' handling could then not
    take out (every way off it into the pelvis or the other thigh): from 0.75 s a bone through the trousers in
    every frame, the right leg off (the guard fired at 1.3 s). With ``edge_pinch_depth`` (1 cm) such an edge stays
    where it is (contact wins, ``kernels.handle_edges``). Off (0): 38 bone frames, 27 with the right leg off."""
    row = evaluate_run(Run(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), "pants", 2.0, 60.0, 1.2))
    assert row["frames"] == 72
    assert row["legs_off_frames"] == 0 and row["guard_firings"] == 0
    assert row["bones_frames"] <= 3, row["bones_frames"]


def _after_each_call(owner, method: str, record) -> None:
    """Wrap ``owner.method`` (a solver's ``advance``, a character's ``step``: once per frame) so that ``record`` is
    called with its result after each call."""
    call = getattr(owner, method)

    def call_and_record(*args, **kwargs):
        result = call(*args, **kwargs)
        record(result)
        return result

    setattr(owner, method, call_and_record)


def _mean_distance_from_bone(points: np.ndarray, arrays, v: int) -> float:
    """Mean distance (m) of simulation-frame ``points`` (P, 3) from volume v's bone (its local z range, end pose)."""
    local = (points - arrays.pos1[v]) @ arrays.rot1[v]
    along = np.clip(local[:, 2], arrays.bones[v, 0], arrays.bones[v, 1])
    return float(np.mean(np.hypot(np.hypot(local[:, 0], local[:, 1]), local[:, 2] - along)))


def _watch_hem_on_thigh(hem_on_thigh: list):
    """An ``after_dressing`` for ``evaluate_run`` that appends, after every frame, whether the trousers' left hem is
    nearer the thigh's bone than the shin's to ``hem_on_thigh``."""
    def watch(character):
        solver = character.solvers[0]
        names, arrays = solver.volumes.names(), solver.collider.arrays
        shin, thigh = names.index("left_lower_leg"), names.index("left_upper_leg")
        hem = solver.model.rings["left_leg"][-1]

        def place(_report):
            x = solver.state.positions[hem]
            hem_on_thigh.append(_mean_distance_from_bone(x, arrays, thigh) < _mean_distance_from_bone(x, arrays, shin))

        _after_each_call(solver, "advance", place)

    return watch


def test_a_trouser_leg_stays_on_the_shin_through_a_kneel(monkeypatch):
    """cmu_131, trousers, 1x at 60 fps, to the end of the kneel (frames 170-215: the pelvis 0.89 -> 0.53 m, the
    left knee flexed 95-121 deg; issue 11 (d)). The walk before it had walked the left hem up to 0.43-0.57 of the
    shin, and the kneel, the leg moving along itself under the cloth, took it over the knee onto the thigh (0.54-0.90
    along it, frames 190-215), the leg's rings stacked at the hip, stretched round it: the worst frame's p99
    1.94. Friction along the bones for the trouser legs (``axial_friction`` 0.5, opt-in) carries the leg a limb
    presses on along it and keeps a stretched spring from sliding a ring it grips up the limb: the hem ends the kneel
    on the shin, on the thigh in a few frames at its start at most, and the p99 is lower. Measured 2026-12-03 over
    three starts (seeds 0 / 1 / 2): with it on the thigh in 3 / 5 / 0 frames (171-177), p99 1.53 / 1.54 / 1.50;
    without, 20 / 35 / 22 frames, still there at 205-214, p99 1.79 / 2.00 / 1.77 (on 2026-12-02's machine seed 0
    with it never, without 188-214). Played on the trousers cut before the crotch's width ease
    (``_CROTCH_WIDTH_EASE_PER_THIGH`` 0), without replays (``NO_REPLAYS``), as when it was measured first (with
    them, 2026-12-03, the hem with friction was on the thigh at frames 173-179 and from 199)."""
    from garment_sim_ros.cloth import garments

    monkeypatch.setattr(garments, "_CROTCH_WIDTH_EASE_PER_THIGH", 0.0)
    on_thigh, rows = {}, {}  # per axial_friction: the hem on the thigh after each frame; the run's row
    for friction in (0.5, 0.0):
        on_thigh[friction] = []
        rows[friction] = evaluate_run(Run(str(DATA / "cmu_131_01_walk_mjstyle.bvh"), "pants", 1.0, 60.0, 3.6,
                                          params=(("axial_friction", friction), *HELD_BAND, *NO_REPLAYS)),
                                      after_dressing=_watch_hem_on_thigh(on_thigh[friction]))
        assert rows[friction]["frames"] == 216 and len(on_thigh[friction]) == 216
    held, slid = np.array(on_thigh[0.5]), np.array(on_thigh[0.0])
    assert not held[186:].any() and slid[186:].any(), (np.flatnonzero(held), np.flatnonzero(slid))
    assert held.sum() <= 0.25 * slid.sum(), (np.flatnonzero(held), np.flatnonzero(slid))
    p99 = [rows[friction]["structural_stretch_p99"] for friction in (0.5, 0.0)]
    assert p99[0] < 1.6 and p99[0] < p99[1] - 0.1, p99
    row = rows[0.5]
    assert (row["bones_frames"], row["legs_off_frames"], row["deep_frames"]) == (0, 0, 0)


def test_the_trousers_seat_goes_round_the_flexed_thighs_of_a_crouch():
    """cmu_01_01, trousers, 1x at 30 fps, over its two crouches (frames 360-445, both hips and knees flexed; issue
    11 (d)). Cut to the hips' girth plus 12 mm, the hip tube's rings at the seat and the crotch (rest heights -6 and
    -19 cm) and the right leg's top ring went round the flexed thighs stretched: the worst frame's p99 1.19 (frame
    378), and 1.19 / 1.21 over the whole clip at 30 / 60 fps. With the seat ease (``garments._SEAT_EASE_PER_THIGH``,
    17 mm on the standard body) 1.046 over the crouches."""
    p99 = []

    def record_stretch(character):
        _after_each_call(character, "step", lambda reports: p99.append(reports[0].structural_stretch_p99))

    row = evaluate_run(Run(str(DATA / "cmu_01_01_jumps_turnaround.bvh"), "pants", 1.0, 30.0, 14.9),
                       after_dressing=record_stretch)
    assert len(p99) == row["frames"] == 447
    crouches = np.array(p99[360:446])
    assert crouches.max() <= 1.06, (crouches.max(), 360 + int(crouches.argmax()))
    assert (row["bones_frames"], row["legs_off_frames"], row["deep_frames"]) == (0, 0, 0)


@pytest.mark.parametrize("nudge", [0, 2])
def test_the_trousers_crotch_goes_round_the_thighs_of_a_straddle(monkeypatch, nudge):
    """The cartwheel, trousers, 1x at 60 fps, its first 1.6 s (the legs spread past 90 deg; issue 11 (d)). Cut to
    the hips' ease, the ring the legs' tops share went round the spread thighs stretched, front and back: the worst
    frame's p99 1.22 / 1.15 / 1.42 with seeds 0 / 1 / 2 (measured 2026-12-02). With the crotch's width ease
    (``garments._CROTCH_WIDTH_EASE_PER_THIGH``, side to side only) 1.12 / 1.05 / 1.06: lower in each start."""
    from garment_sim_ros.cloth import garments

    run = Run(str(DATA / "cc_cmu_05_06_dance_cartwheel_pirouette.bvh"), "pants", 1.0, 60.0, 1.6, nudge=nudge)
    eased = evaluate_run(run)
    monkeypatch.setattr(garments, "_CROTCH_WIDTH_EASE_PER_THIGH", 0.0)
    tight = evaluate_run(run)
    figures = [round(row["structural_stretch_p99"], 3) for row in (tight, eased)]
    assert figures[0] > 1.14 and figures[1] < 1.13 and figures[1] < figures[0] - 0.03, figures
    for row in (tight, eased):
        assert (row["bones_frames"], row["legs_off_frames"], row["guard_firings"]) == (0, 0, 0)


def test_the_trousers_seat_on_the_pelvis_open_bottom_leaves_through_it(monkeypatch):
    """CC jump, trousers, 3x at 30 fps, 3 s (issue 11 (b), (d)): in the crouch before the take-off the taut seat lies
    on the pelvis' bottom cut (open to the thighs below); each length-correction sweep pulled a seat point a few mm
    up through it and the contact handling put it 31-72 mm sideways onto the rim, and the edges then left springs
    at 4-7 rest lengths (bone frames, longest spring 7.40). A point within ``open_cut_band`` (3 mm, the default) of
    that cut leaves through it. With it off (and the band held, as when the runaway was recorded) the runaway is
    there in each of three starts; with it, a shorter longest spring and a lower p99 in each, and fewer bone frames
    over the three (measured 2026-12-01: bone frames 3 / 4 / 3 -> 2 / 3 / 1, longest 7.4 / 4.75 / 5.89 -> 1.93 / 2.8 /
    3.94; 2026-12-03, another machine: bone frames 3 / 3 / 2 -> 2 / 2 / 3, longest 5.93 / 6.53 / 4.70 -> 3.61 / 2.73 /
    3.41, p99 2.00 / 1.82 / 1.76 -> 1.36 / 1.28 / 1.02). On the trousers cut so, before the crotch's width ease
    (``_CROTCH_WIDTH_EASE_PER_THIGH`` 0): with it the runaway the rule mends is not there (seed 0, the rule off / on:
    1 bone frame, longest 3.47 / 4.70; docs/real_motion.md)."""
    from garment_sim_ros.cloth import garments

    monkeypatch.setattr(garments, "_CROTCH_WIDTH_EASE_PER_THIGH", 0.0)
    bone_frames = [0, 0]  # summed over the starts, the rule off and on
    for nudge in (0, 1, 2):
        rows = [evaluate_run(Run(str(DATA / "cc_cmu_02_04_jump_balance.bvh"), "pants", 3.0, 30.0, 3.0,
                                 params=(("open_cut_band", band), ("band_gives_way", 0), ("frame_retries", 0)),
                                 nudge=nudge))
                for band in (0.0, 0.003)]
        figures = [(row["bones_frames"], round(row["structural_stretch_max"], 2)) for row in rows]
        assert rows[0]["bones_frames"] > 0 and rows[0]["structural_stretch_max"] > 4.0, (nudge, figures)
        assert rows[1]["structural_stretch_max"] < rows[0]["structural_stretch_max"], (nudge, figures)
        assert rows[1]["structural_stretch_p99"] < rows[0]["structural_stretch_p99"], (nudge, figures)
        bone_frames[0] += rows[0]["bones_frames"]
        bone_frames[1] += rows[1]["bones_frames"]
    assert bone_frames[1] < bone_frames[0], bone_frames


def test_dressing_does_not_use_the_open_cut_exit():
    """CC walk, trousers, dressed on the first pose: the open-cut exit acting while the pose is blended in moved
    the crotch seam up to 65 mm, and the walk's worst frame (the hem, 0.28 s) stretched past (d) at 1x 60 fps
    (p99 1.041 -> 1.057-1.084). Off while dressing, the dressed state is the one without the rule."""
    source = bvh_source(str(DATA / "cc_cmu_07_01_walk.bvh"), loop=False)
    dressed = []
    for band in (0.0, 0.003):
        params = preset("si").replace(open_cut_band=band)
        character = make_character(source.rest_pose, source.joint_map, ["pants"], params, 1.0,
                                   motion=source.fit_poses())
        character.dress(source.pose(0.0), 0.0, source.motion(0.0))
        dressed.append(character.solvers[0].state.positions.copy())
    assert np.array_equal(dressed[0], dressed[1]), np.abs(dressed[0] - dressed[1]).max()
