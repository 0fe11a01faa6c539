"""Where a frame of the solver goes, and the fused frame against the reference loop (issue 15 item 1).

Four cases: the one-piece on a real clip (CC walk, default parameters, 60 fps: the real-motion quality on),
the one-piece under the Table 1 protocol (memo preset, procedural walk, 0.04 s frames) and the 5 000 and
20 000-point one-piece under the same protocol (``garment-sim scale``). Per case two characters dressed
alike, one on the reference path (``GarmentSolver.use_fused = False``), one fused, stepped in turn frame by
frame (so load changes hit both alike); per path the median per frame of the solver's step
(``DressedCharacter.step``' wall time, without the quality figures) and of its stages (``FrameReport``),
and whether the garments stayed equal. Then the reference path's kernel calls per frame (counted on a third
character) and what numba's dispatch of them costs: each kernel called with its own recorded arguments into
an empty compiled function of the same arity (the typing and boxing of the arguments, no work), and each
kernel's wall time per frame (its calls timed from Python, dispatch included) and the calling thread's CPU time
in it (`--threads 1`: all of the kernel's work, which the load does not inflate as it does the wall time).

    PYTHONPATH=$PWD python bench/fused.py [--frames 120] [--large-frames 20] [--cases one_piece_cc_walk ...]
        [--profile-frames N] [--profile-from FRAME]

One JSON line per case and path, then one per case with the call profile.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
from numba import njit
from numba.core.registry import CPUDispatcher

from garment_sim_ros import benchmarking
from garment_sim_ros.body.sources import bvh_source, procedural_source
from garment_sim_ros.cloth import kernels as cloth_kernels
from garment_sim_ros.cloth import solver as solver_module
from garment_sim_ros.collision import broad_phase, crossing
from garment_sim_ros.collision import kernels as collision_kernels
from garment_sim_ros.commands.scale import resolution_for
from garment_sim_ros.commands.table1 import FRAME_S
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS, PRESETS

CLIP = Path(__file__).resolve().parent.parent / "test" / "data" / "cc_cmu_07_01_walk.bvh"
KERNEL_MODULES = (cloth_kernels, collision_kernels, crossing, broad_phase, solver_module)


CASES = ("one_piece_cc_walk", "one_piece_memo", "one_piece_5k", "one_piece_20k")
LARGE = {"one_piece_5k": 5_000, "one_piece_20k": 20_000}  # mass points, parallel collision drivers


def case_source(name: str):
    """(motion source, params, resolution, frame time s) of a case."""
    if name == "one_piece_cc_walk":
        return bvh_source(str(CLIP), loop=True), DEFAULT_PARAMS, 1.0, 1.0 / 60.0
    resolution = resolution_for(LARGE[name]) if name in LARGE else 1.0
    return procedural_source("walk"), PRESETS["memo"], resolution, FRAME_S


def dressed(name: str, fused: bool):
    source, params, resolution, frame_s = case_source(name)
    character = make_character(source.rest_pose, source.joint_map, ["one_piece"], params, resolution,
                               motion=source.fit_poses())
    for solver in character.solvers:
        solver.use_fused = fused
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    return source, character, frame_s


def step(source, character, t):
    pose, motion = source.pose(t), source.motion(t)
    tic = time.perf_counter()
    reports = character.step(pose, motion, t, measure=False)  # the solver, not the quality figures
    return time.perf_counter() - tic, reports


def compare(name: str, frames: int, warmup: int) -> list[dict]:
    """Both paths stepped in turn; one row per path, medians in ms."""
    runs = {"reference": dressed(name, False), "fused": dressed(name, True)}
    samples = {path: {k: [] for k in ("step", "integration", "correction", "collision")} for path in runs}
    max_difference = 0.0
    for frame in range(1, warmup + frames + 1):
        for path, (source, character, frame_s) in runs.items():
            wall, reports = step(source, character, frame * frame_s)
            if frame <= warmup:
                continue
            samples[path]["step"].append(wall)
            for stage in ("integration", "correction", "collision"):
                samples[path][stage].append(sum(getattr(r, f"{stage}_s") for r in reports))
        positions = [c.solvers[0].state.positions for _, c, _ in runs.values()]
        max_difference = max(max_difference, float(np.abs(positions[0] - positions[1]).max()))
    points = runs["fused"][1].solvers[0].model.num_points
    rows = []
    for path, series in samples.items():
        row = {"bench": "fused", "case": name, "path": path, "mass_points": points, "frames": frames}
        row.update({f"{k}_ms": round(statistics.median(v) * 1e3, 4) for k, v in series.items()})
        row["max_position_difference_m"] = max_difference
        row["load_1min"] = benchmarking.load_average()
        rows.append(row)
    return rows


def _empty(arity: int):
    """A compiled function of ``arity`` arguments that does nothing (numba's dispatch cost alone)."""
    names = ", ".join(f"a{k}" for k in range(arity))
    scope: dict = {}
    exec(f"def empty({names}):\n    return 0\n", scope)
    return njit(scope["empty"])


def call_profile(name: str, frames: int, first: int = 2) -> dict:
    """The reference path's kernel calls per frame and numba's dispatch cost of them, over ``frames`` frames from
    frame ``first`` (the frames before it stepped unprofiled: the garment settles onto the body and its contact
    cache fills over the first ~20, and the collision's work with it)."""
    source, character, frame_s = dressed(name, False)
    for frame in range(1, first):  # the first compiles and caches the kernels before they are wrapped
        step(source, character, frame * frame_s)
    calls: Counter = Counter()
    spent: Counter = Counter()  # s per kernel, the call's wall time with its dispatch
    busy: Counter = Counter()  # s per kernel, the calling thread's CPU time (what the load does not inflate)
    sample_args: dict[str, tuple] = {}
    originals = []
    for module in KERNEL_MODULES:
        for attribute, value in list(vars(module).items()):
            if isinstance(value, CPUDispatcher):
                def counted(*args, _kernel=value, _name=f"{module.__name__}.{attribute}"):
                    calls[_name] += 1
                    sample_args.setdefault(_name, args)
                    tic, cpu = time.perf_counter(), time.thread_time()
                    result = _kernel(*args)
                    spent[_name] += time.perf_counter() - tic
                    busy[_name] += time.thread_time() - cpu
                    return result
                originals.append((module, attribute, value))
                setattr(module, attribute, counted)
    try:
        stepped = 0.0
        for frame in range(first, first + frames):
            stepped += step(source, character, frame * frame_s)[0]
    finally:
        for module, attribute, value in originals:
            setattr(module, attribute, value)
    dispatch_s = 0.0
    per_kernel = {}
    for kernel_name, args in sample_args.items():
        empty = _empty(len(args))
        empty(*args)
        each = math.inf  # the fastest of 5 batches: another process taking the core only ever adds
        for _ in range(5):
            tic = time.perf_counter()
            for _ in range(400):
                empty(*args)
            each = min(each, (time.perf_counter() - tic) / 400)
        per_kernel[kernel_name.split(".", 1)[1]] = {
            "calls_per_frame": calls[kernel_name] / frames, "empty_call_us": round(each * 1e6, 2),
            "ms_per_frame": round(spent[kernel_name] / frames * 1e3, 4),
            "cpu_ms_per_frame": round(busy[kernel_name] / frames * 1e3, 4)}
        dispatch_s += calls[kernel_name] * each
    return {"bench": "fused_calls", "case": name, "frames": frames, "first_frame": first,
            "calls_per_frame": round(sum(calls.values()) / frames, 1),
            "dispatch_ms_per_frame": round(dispatch_s / frames * 1e3, 4),
            "kernels_ms_per_frame": round(sum(spent.values()) / frames * 1e3, 4),
            "kernels_cpu_ms_per_frame": round(sum(busy.values()) / frames * 1e3, 4),
            "step_ms_per_frame": round(stepped / frames * 1e3, 4),
            "kernels": per_kernel, "load_1min": benchmarking.load_average()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120, help="timed frames of the one-piece case")
    parser.add_argument("--large-frames", type=int, default=20, help="timed frames of the 5 000 and 20 000-point cases")
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")
    parser.add_argument("--profile-frames", type=int, default=None,
                        help="frames of the call profile (default: a quarter of the timed ones, at least 5)")
    parser.add_argument("--profile-from", type=int, default=2,
                        help="the call profile's first frame (default 2: right after the first, which compiles)")
    args = parser.parse_args()
    benchmarking.set_threads(args.threads)
    for name in args.cases:
        frames = args.large_frames if name in LARGE else args.frames
        for row in compare(name, frames, args.warmup):
            print(json.dumps(row), flush=True)
        print(json.dumps(call_profile(name, args.profile_frames or max(5, frames // 4), args.profile_from)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
