"""Where a trouser leg sits on its leg, frame by frame, and which stage of the substep moves it (issue 11, d).

``python bench/trouser_climb.py CLIP.bvh [--seconds S] [--every N]`` plays the clip (1x, 60 fps) with trousers
as ``evaluate`` dresses them and prints, as JSON lines, every N-th frame and every frame whose structural p99 is
past the target: p99 and longest spring, the rings that hold the springs past 1.05 (``l3-l3``: a spring of the
left leg's ring 3, around; ``h-19``: a hip-tube point at rest height -19 cm), and per leg the knee's flexion and
where its hem and its ring 5 sit (the nearer leg bone, thigh or shin, and the fraction along it: thigh 0 at the
hip, 1 at the knee; shin 0 at the knee, 1 at the ankle).

``--stages SIDE FIRST LAST`` instead runs the reference substeps (not the fused ones) and sums, over frames
FIRST to LAST, how far each stage of a substep moves SIDE's hem along its shin volume's axis (negative: toward
the knee): the volumes moving to the substep's end under the cloth, the integration, the length correction,
the collision handling, the strain limiting.
"""

from __future__ import annotations

import argparse
import collections
import json

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import TARGETS

LONG = 1.05  # a spring past this counts as stretched (the p99 target)
FPS = 60.0


def ring_labels(model) -> np.ndarray:
    """Per point: its leg ring (``l4``: the left leg's ring 4, 0 at the crotch) or, on the hip tube, ``h`` and
    its rest height in cm."""
    labels = np.array([f"h{round(100 * z)}" for z in model.rest_positions[:, 2]], dtype=object)
    for name, rings in model.rings.items():
        if name.endswith("_leg"):
            for k, ring in enumerate(rings):
                labels[ring] = f"{name[0]}{k}"
    return labels


def place_on_leg(points: np.ndarray, hip, knee, ankle) -> str:
    """The leg bone nearest the points' mean distance, and the mean fraction along it."""
    best = None
    for name, (a, b) in (("thigh", (hip, knee)), ("shin", (knee, ankle))):
        d = b - a
        t = np.clip((points - a) @ d / (d @ d), 0.0, 1.0)
        distance = float(np.linalg.norm(points - (a + t[:, None] * d), axis=1).mean())
        if best is None or distance < best[0]:
            best = (distance, f"{name} {float(t.mean()):.2f}")
    return best[1]


def frames(args, source, character) -> None:
    solver = character.solvers[0]
    model, joints = solver.model, source.joint_map
    labels = ring_labels(model)
    times = np.arange(int(args.seconds * FPS) + 1) / FPS
    for frame, (_, pose, reports) in enumerate(simulate_frames(source, character, times)):
        if reports is None:
            continue
        report = reports[0]
        if report.structural_stretch_p99 <= TARGETS.stretch_p99 and frame % args.every:
            continue
        long = np.flatnonzero(solver.stretches > LONG)
        names, counts = np.unique([f"{labels[a]}-{labels[b]}" for a, b in model.springs[long]], return_counts=True)
        x = character.world_positions()[0]
        row = {"frame": frame, "p99": round(report.structural_stretch_p99, 3),
               "longest": round(report.structural_stretch_max, 2), "springs past 1.05": len(long),
               "rings": [[str(names[i]), int(counts[i])] for i in np.argsort(-counts)[:4]]}
        for side in ("left", "right"):
            hip, knee, ankle = (pose.frame(joints[f"{side}_{part}"])[0] for part in ("upper_leg", "lower_leg", "foot"))
            thigh, shin = knee - hip, ankle - knee
            flexion = np.degrees(np.arccos(np.clip(thigh @ shin / np.linalg.norm(thigh) / np.linalg.norm(shin), -1, 1)))
            rings = model.rings[f"{side}_leg"]
            row[side] = (f"knee {flexion:.0f} deg, hem {place_on_leg(x[rings[-1]], hip, knee, ankle)}, "
                         f"ring 5 {place_on_leg(x[rings[5]], hip, knee, ankle)}")
        print(json.dumps(row))


def stages(args, source, character) -> None:
    side, first, last = args.stages[0], int(args.stages[1]), int(args.stages[2])
    solver = character.solvers[0]
    collider, model = solver.collider, solver.model
    solver.use_fused = False  # the reference path, whose stages can be wrapped
    names = solver.volumes.names()
    shin, thigh = names.index(f"{side}_lower_leg"), names.index(f"{side}_upper_leg")
    hem = model.rings[f"{side}_leg"][-1]
    poses = collider.arrays
    moved: dict[str, float] = collections.defaultdict(float)
    last_mark: list = [None, None]
    state = {"recording": False, "limiting": False}

    def from_knee(x) -> float:
        """The hem's mean position along the shin volume's axis, from the volume's centre (m; larger: nearer the
        ankle); "integrated" is measured against the previous substep's volume poses."""
        along = (x[hem] - poses.pos1[shin]) @ poses.rot1[shin][:, 2]
        toward_thigh = (poses.pos1[thigh] - poses.pos1[shin]) @ poses.rot1[shin][:, 2]
        return float(along.mean()) * (-1.0 if toward_thigh > 0.0 else 1.0)

    def mark(stage: str, x) -> None:
        if not state["recording"]:
            return
        value = from_knee(x)
        if last_mark[0] is not None:
            moved[f"{last_mark[1]} -> {stage}"] += value - last_mark[0]
        last_mark[:] = [value, stage]

    begin_substep, handle_contacts = collider.begin_substep, collider.handle_contacts
    collide, limit_strain = solver._collide, solver._limit_strain

    def recorded_begin_substep(f0, f1):
        mark("integrated", solver.state.positions)
        begin_substep(f0, f1)
        mark("volumes at the substep's end", solver.state.positions)

    def recorded_handle_contacts(x_start, x, *rest):
        stage = "limiting" if state["limiting"] else "correction"
        mark(f"{stage}: before contacts", x)
        handle_contacts(x_start, x, *rest)
        mark(f"{stage}: after contacts", x)

    def recorded_collide(x, *rest):
        stage = "limiting" if state["limiting"] else "handling"
        mark(f"{stage}: before collision handling", x)
        collide(x, *rest)
        mark(f"{stage}: after collision handling", x)

    def recorded_limit_strain(x, *rest):
        state["limiting"] = True
        limit_strain(x, *rest)
        state["limiting"] = False
        mark("limited", x)

    collider.begin_substep, collider.handle_contacts = recorded_begin_substep, recorded_handle_contacts
    solver._collide, solver._limit_strain = recorded_collide, recorded_limit_strain
    for frame, _ in enumerate(simulate_frames(source, character, np.arange(last + 1) / FPS)):
        state["recording"] = first <= frame < last
        if frame in (first, last):
            hem_at = round(from_knee(solver.state.positions), 3)
            print(json.dumps({"frame": frame, "hem along the shin volume (m)": hem_at}))
    for step, value in sorted(moved.items(), key=lambda item: item[1]):
        if abs(value) >= 0.001:
            print(json.dumps({"stage": step, "hem moved (cm)": round(100 * value, 1)}))
    print(json.dumps({"total (cm)": round(100 * sum(moved.values()), 1)}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--every", type=int, default=30, help="print every N-th frame too")
    parser.add_argument("--stages", nargs=3, metavar=("SIDE", "FIRST", "LAST"),
                        help="which stage moves SIDE's hem along its shin over frames FIRST..LAST")
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False)
    character = make_character(source.rest_pose, source.joint_map, ["pants"], DEFAULT_PARAMS, 1.0,
                               motion=source.fit_poses())  # as evaluate dresses it
    (stages if args.stages else frames)(args, source, character)


if __name__ == "__main__":
    main()
