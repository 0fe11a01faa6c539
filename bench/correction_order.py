"""Which order of the length correction on two threads leaves the residual of the serial one (issue 15).

A garment from ``PARALLEL_MIN_POINTS`` up runs its length correction on two threads. Two ways to share a
Gauss-Seidel sweep: the garment cut in two halves, each swept in the model's order on its own thread, the
springs across the cut after them (``cloth.halves``, what the solver runs), or the springs grouped by colour,
each colour over the threads (``bench/length_correction.py``'s ``coloured_sweep``), which converges more
slowly per sweep. Here the same garment is stepped four ways in turn, frame by frame: the model's order on one
thread (every kernel serial: ``Collider.parallel`` off, what the garment ran before), the halves, and the
colour order with 1 and with 2 sweeps per correction iteration (the reference path with its correction
swapped for the coloured sweeps; forces and edges in halves). Per way: the median over the frames of the
largest and the 99th-percentile stretch of the structural and shear springs after each frame (the residual the
correction leaves), of the step's wall time and of the process's CPU time (all threads). Cases: the one-piece
under ``garment-sim scale``'s protocol (memo preset, procedural walk, 0.04 s frames) at ~5 000 and ~20 000
points, and at ~5 000 points with the defaults on the CC walk at 60 fps (the strain limiting on).

    PYTHONPATH=$PWD python bench/correction_order.py [--frames 20] [--cases memo_5k memo_20k walk_5k]

One JSON line per case and way.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
from length_correction import colour_order, coloured_sweep

from garment_sim_ros import benchmarking
from garment_sim_ros.body.sources import bvh_source, procedural_source
from garment_sim_ros.commands.scale import resolution_for
from garment_sim_ros.commands.table1 import FRAME_S
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS, PRESETS

CLIP = Path(__file__).resolve().parent.parent / "test" / "data" / "cc_cmu_07_01_walk.bvh"
CASES = {"memo_5k": (5_000, "memo"), "memo_20k": (20_000, "memo"), "walk_5k": (5_000, "walk")}
WAYS = ("model_order", "halves", "coloured_1", "coloured_2")


def colour_sweeps(solver, sweeps: int):
    """``solver``'s correction iteration as ``sweeps`` coloured sweeps (the reference path's hook)."""
    count, limit = solver._correct_count, solver.params.limit_ratio
    order, starts = colour_order(solver.model.springs[:count], solver.model.num_points)
    springs = np.ascontiguousarray(solver.model.springs[:count][order])
    rest = np.ascontiguousarray(solver.model.rest_lengths[:count][order])

    def correct(x, inv_mass, layout):
        worst = coloured_sweep(x, inv_mass, springs, rest, starts, limit)
        for _ in range(sweeps - 1):
            coloured_sweep(x, inv_mass, springs, rest, starts, limit)
        return worst
    return correct


def dressed(case: str, way: str):
    points, kind = CASES[case]
    if kind == "memo":
        source, params, frame_s = procedural_source("walk"), PRESETS["memo"], FRAME_S
    else:
        source, params, frame_s = bvh_source(str(CLIP), loop=True), DEFAULT_PARAMS, 1.0 / 60.0
    character = make_character(source.rest_pose, source.joint_map, ["one_piece"], params, resolution_for(points),
                               motion=source.fit_poses())
    solver = character.solvers[0]
    assert solver.collider.parallel
    if way == "model_order":
        solver.collider.parallel = False
    elif way.startswith("coloured_"):
        solver.use_fused = False
        solver._length_correction = colour_sweeps(solver, int(way.rsplit("_", 1)[1]))
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    return source, character, frame_s


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=30, help="timed frames per case")
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")
    args = parser.parse_args()
    threads = benchmarking.set_threads(args.threads)
    for case in args.cases:
        runs = {way: dressed(case, way) for way in WAYS}
        samples = {way: {"max": [], "p99": [], "wall": [], "cpu": []} for way in runs}
        for frame in range(1, args.warmup + args.frames + 1):
            for way, (source, character, frame_s) in runs.items():
                t = frame * frame_s
                pose, motion = source.pose(t), source.motion(t)
                tic, cpu = time.perf_counter(), time.process_time()
                report = character.step(pose, motion, t, measure=False)[0]
                wall, cpu = time.perf_counter() - tic, time.process_time() - cpu
                if frame > args.warmup:
                    stretches = character.solvers[0].stretches
                    for key, value in (("max", report.max_stretch), ("p99", float(np.percentile(stretches, 99))),
                                       ("wall", wall * 1e3), ("cpu", cpu * 1e3)):
                        samples[way][key].append(value)
        for way, series in samples.items():
            print(json.dumps({
                "bench": "correction_order", "case": case, "way": way, "threads": threads,
                "mass_points": runs[way][1].solvers[0].model.num_points, "frames": args.frames,
                "stretch_max_median": round(statistics.median(series["max"]), 4),
                "stretch_max_worst": round(max(series["max"]), 4),
                "stretch_p99_median": round(statistics.median(series["p99"]), 4),
                "step_ms": round(statistics.median(series["wall"]), 2),
                "step_process_cpu_ms": round(statistics.median(series["cpu"]), 2),
                "load_1min": benchmarking.load_average()}),
                flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
