"""What a solver parameter's values cost on real clips (issue 11): the solver's step per frame.

Each garment on each clip (1x, 60 fps, the first ``--seconds`` after dressing) is played once per value of
``--param`` (``--values``; default ``strain_limit_iterations`` 12 and 48), the values in turn garment by garment so
that the machine's
load falls on all of them alike, numba on one thread. Per frame the thread's CPU time of
``DressedCharacter.step(measure=False)`` (the solver alone, no quality figures; ``time.thread_time``, which other
processes do not inflate). One JSON line per clip, garment and value: median, p99 and worst ms per frame, and the
median's ratio to the first value's; then one line per value over every run: the mean of the per-run medians and
of the per-run p99s, and their ratio to the first value's. Parameters that act only where the cloth needs them
(the strain limiting stops once no spring is past ``1 + limit_ratio + strain_limit_tolerance``; ``frame_retries``
runs a frame again only when it tore the cloth or let a bone through) cost only in those frames: the p99 and the
worst frame show it.

    PYTHONPATH=$PWD python bench/param_cost.py [--param strain_limit_iterations] [--values 12 48] [--seconds 4]
                                               [--clips ...]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

from garment_sim_ros import benchmarking
from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth.garments import GARMENT_NAMES
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS, PARAMETER_TABLE

DATA = Path(__file__).resolve().parent.parent / "test" / "data"
CLIPS = ("cc_cmu_07_01_walk", "cmu_01_01_jumps_turnaround", "cmu_131_01_walk_mjstyle",
         "cc_cmu_05_06_dance_cartwheel_pirouette")
FPS = 60.0


def frame_times(clip: str, garment: str, param: str, value, seconds: float) -> np.ndarray:
    """ms of thread CPU time per frame of the solver's step with ``param`` at ``value``."""
    params = DEFAULT_PARAMS.replace(**{param: value})
    source = bvh_source(str(DATA / f"{clip}.bvh"), loop=False, params=params)
    character = make_character(source.rest_pose, source.joint_map, [garment], params, motion=source.fit_poses())
    frames = int(min(seconds, source.duration) * FPS)
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    times = np.empty(frames)
    for k in range(frames):
        t = (k + 1) / FPS
        pose, motion = source.pose(t), source.motion(t)
        tic = time.thread_time()
        character.step(pose, motion, t, measure=False)
        times[k] = (time.thread_time() - tic) * 1e3
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--param", default="strain_limit_iterations", help="a solver parameter (params.py)")
    parser.add_argument("--values", nargs="+", default=["12", "48"], help="its values, the first the baseline")
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--clips", nargs="+", default=list(CLIPS))
    args = parser.parse_args()
    if args.param not in PARAMETER_TABLE:
        parser.error(f"--param: unknown parameter {args.param!r}")
    kind = type(getattr(DEFAULT_PARAMS, args.param))
    values = [kind(float(v)) for v in args.values]
    benchmarking.set_threads(1)
    frame_times(args.clips[0], GARMENT_NAMES[0], args.param, values[0], 0.1)  # compile before timing
    summary: dict = {n: [] for n in values}
    for clip in args.clips:
        for garment in GARMENT_NAMES:
            first = None
            for n in values:
                times = frame_times(clip, garment, args.param, n, args.seconds)
                median, p99 = float(np.median(times)), float(np.percentile(times, 99))
                first = median if first is None else first
                summary[n].append((median, p99))
                print(json.dumps({"clip": clip, "garment": garment, args.param: n, "frames": len(times),
                                  "median_ms": round(median, 3), "p99_ms": round(p99, 3),
                                  "worst_ms": round(float(times.max()), 3),
                                  "median_ratio": round(median / first, 3)}), flush=True)
    base = summary[values[0]]
    for n in values:
        medians, p99s = zip(*summary[n])
        print(json.dumps({args.param: n, "runs": len(medians),
                          "mean_median_ms": round(statistics.mean(medians), 3),
                          "mean_p99_ms": round(statistics.mean(p99s), 3),
                          "median_ratio": round(statistics.mean(medians) / statistics.mean(m for m, _ in base), 3),
                          "p99_ratio": round(statistics.mean(p99s) / statistics.mean(p for _, p in base), 3)}))


if __name__ == "__main__":
    main()
