"""Where the stretch of a garment on a real clip comes from (issue 11, target d), stage by stage.

``python bench/stretch_stages.py CLIP.bvh GARMENT [--seconds S] [--fps F] [--speed X]`` plays the clip (60 fps,
1x) and prints, as JSON lines, the structural and shear springs' p99 and maximum length / rest length (mean and
worst over the substeps) before and after each collision handling of a substep: the full handling after the length
correction, and the one that ends the strain limiting (``GarmentSolver._limit_strain``); then, over the
frames, which springs are past 1.05 at a frame's end: structural or shear, with an end in contact (the
solver state's contact cache) and with an end that touched two volumes (a pinch). With ``--where``, first a
line per frame that misses the stretch target (p99 or max): where its springs past 1.05 lie (height of the
spring's middle at rest, cm, its side, around or down the garment), the volumes their ends touch, and the
angle between the thigh bones then (a stride's width).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth.kernels import spring_stretches
from garment_sim_ros.cloth.model import STRUCTURAL
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import TARGETS

LONG = 1.05  # a spring past this counts as stretched (the p99 target)


def spring_places(model) -> np.ndarray:
    """Per correction spring, where its middle lies on the garment at rest: height (cm, root frame), side
    (front, left, back, right about the garment's vertical axis) and whether it runs around or down."""
    x = model.rest_positions
    a, b = (x[model.springs[:model.num_correction_springs, k]] for k in (0, 1))
    middle, along = 0.5 * (a + b), b - a
    axis = x[:, :2].mean(axis=0)
    azimuth = np.degrees(np.arctan2(middle[:, 1] - axis[1], middle[:, 0] - axis[0])) % 360.0
    sides = np.array(["front", "left", "back", "right"])[((azimuth + 45.0) // 90.0).astype(int) % 4]
    runs = np.where(np.abs(along[:, 2]) < np.hypot(along[:, 0], along[:, 1]), "around", "down")
    return np.array([f"z {round(100 * z):+d} cm {side} {run}" for z, side, run in zip(middle[:, 2], sides, runs)])


def thigh_angle(pose, joint_map) -> float:
    """The angle (deg) between the two thigh bones, hip to knee."""
    left, right = (pose.frame(joint_map[f"{side}_lower_leg"])[0] - pose.frame(joint_map[f"{side}_upper_leg"])[0]
                   for side in ("left", "right"))
    return float(np.degrees(np.arccos(np.clip(left @ right / np.linalg.norm(left) / np.linalg.norm(right), -1, 1))))


def most_common(labels: np.ndarray, count: int = 4) -> list:
    names, counts = np.unique(labels, return_counts=True)
    order = np.argsort(-counts)[:count]
    return [[str(names[i]), int(counts[i])] for i in order]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip")
    parser.add_argument("garment")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate the clip is played at")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed")
    parser.add_argument("--where", action="store_true", help="a line per frame that misses the stretch target")
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False, speed=args.speed)
    character = make_character(source.rest_pose, source.joint_map, [args.garment], DEFAULT_PARAMS, 1.0,
                               motion=source.fit_poses())  # as evaluate dresses it
    solver = character.solvers[0]
    solver.use_fused = False  # the reference loop, whose stages are wrapped below (the fused frame calls neither)
    model = solver.model
    stretches = np.zeros(model.num_correction_springs)
    stages: dict[str, list[tuple[float, float]]] = {}
    in_limiting = [False]

    def figures(x):
        spring_stretches(x, model.springs, model.rest_lengths, stretches)
        return float(np.percentile(stretches, 99)), float(stretches.max())

    collide, limit_strain = solver._collide, solver._limit_strain

    def recorded_collide(x, v, h, layout):
        name = "limiting" if in_limiting[0] else "handling"
        stages.setdefault(f"before the {name}'s collision handling", []).append(figures(x))
        collide(x, v, h, layout)
        stages.setdefault(f"after the {name}'s collision handling", []).append(figures(x))

    def recorded_limit_strain(*args):
        in_limiting[0] = True
        limit_strain(*args)
        in_limiting[0] = False

    solver._collide, solver._limit_strain = recorded_collide, recorded_limit_strain
    structural = model.spring_kinds[:model.num_correction_springs] == STRUCTURAL
    counts = {"springs past 1.05 (spring-frames)": 0, "structural": 0, "an end in contact": 0, "an end in a pinch": 0}
    places = spring_places(model)
    volume_names = np.array(solver.volumes.names())
    for frame, (t, pose, reports) in enumerate(simulate_frames(source, character,
                                                               np.arange(int(args.seconds * args.fps) + 1) / args.fps)):
        if reports is None:
            continue
        long = np.flatnonzero(solver.stretches > LONG)
        report = reports[0]
        worst_p99 = max(report.structural_stretch_p99, report.shear_stretch_p99)
        if args.where and (worst_p99 > TARGETS.stretch_p99
                           or max(report.structural_stretch_max, report.shear_stretch_max) > TARGETS.stretch_max):
            touched = solver.state.contacts[model.springs[long]].ravel()
            print(json.dumps({"frame": frame, "t": round(float(t), 3),
                              "structural p99/max": [round(report.structural_stretch_p99, 3),
                                                     round(report.structural_stretch_max, 2)],
                              "thighs_deg": round(thigh_angle(pose, source.joint_map), 1),
                              "where": most_common(places[long]),
                              "volumes": most_common(volume_names[touched[touched >= 0]])}))
        ends = model.springs[long]
        cache = solver.state.contacts  # (N, cache_size) volumes each point touched, most recent first
        touching = cache[:, 0] >= 0
        pinched = touching & (cache[:, -1] >= 0) & (cache[:, -1] != cache[:, 0])
        counts["springs past 1.05 (spring-frames)"] += len(long)
        counts["structural"] += int(np.count_nonzero(structural[long]))
        counts["an end in contact"] += int(np.count_nonzero(touching[ends].any(axis=1)))
        counts["an end in a pinch"] += int(np.count_nonzero(pinched[ends].any(axis=1)))
    for stage, values in stages.items():
        values = np.array(values)
        print(json.dumps({"stage": stage, "substeps": len(values), "p99_mean": round(float(values[:, 0].mean()), 3),
                          "p99_worst": round(float(values[:, 0].max()), 3),
                          "max_mean": round(float(values[:, 1].mean()), 3),
                          "max_worst": round(float(values[:, 1].max()), 3)}))
    print(json.dumps(counts))


if __name__ == "__main__":
    main()
