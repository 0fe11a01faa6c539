"""Where the stretch of a garment on a real clip comes from (issue 11, target d), stage by stage.

``python bench/stretch_stages.py CLIP.bvh GARMENT [--seconds S]`` plays the clip at 60 fps and prints, as
JSON lines, the structural and shear springs' p99 and maximum length / rest length (mean and worst over the
substeps) before and after each collision handling of a substep: the full handling after the length
correction, and the one that ends the strain limiting (``GarmentSolver._limit_strain``); then, over the
frames, which springs are past 1.05 at a frame's end: structural or shear, with an end in contact (the
solver state's contact cache) and with an end that touched two volumes (a pinch).
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

LONG = 1.05  # a spring past this counts as stretched (the p99 target)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip")
    parser.add_argument("garment")
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False)
    character = make_character(source.rest_pose, source.joint_map, [args.garment], DEFAULT_PARAMS, 1.0)
    solver = character.solvers[0]
    model = solver.model
    stretches = np.zeros(model.num_correction_springs)
    stages: dict[str, list[tuple[float, float]]] = {}
    in_limiting = [False]

    def figures(x):
        spring_stretches(x, model.springs, model.rest_lengths, stretches)
        return float(np.percentile(stretches, 99)), float(stretches.max())

    collide, limit_strain = solver._collide, solver._limit_strain

    def recorded_collide(x, v, h):
        name = "limiting" if in_limiting[0] else "handling"
        stages.setdefault(f"before the {name}'s collision handling", []).append(figures(x))
        collide(x, v, h)
        stages.setdefault(f"after the {name}'s collision handling", []).append(figures(x))

    def recorded_limit_strain(*args):
        in_limiting[0] = True
        limit_strain(*args)
        in_limiting[0] = False

    solver._collide, solver._limit_strain = recorded_collide, recorded_limit_strain
    structural = model.spring_kinds[:model.num_correction_springs] == STRUCTURAL
    counts = {"springs past 1.05 (spring-frames)": 0, "structural": 0, "an end in contact": 0, "an end in a pinch": 0}
    for _, _, reports in simulate_frames(source, character, np.arange(int(args.seconds * 60) + 1) / 60.0):
        if reports is None:
            continue
        long = np.flatnonzero(solver.stretches > LONG)
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
