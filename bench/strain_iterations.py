"""What the strain limiting's iterations cost on real clips (issue 11, target d): the solver's step per frame.

Each garment on each clip (1x, 60 fps, the first ``--seconds`` after dressing) is played once per
``--iterations`` value (``strain_limit_iterations``), the values in turn garment by garment so that the machine's
load falls on all of them alike, numba on one thread. Per frame the thread's CPU time of
``DressedCharacter.step(measure=False)`` (the solver alone, no quality figures; ``time.thread_time``, which other
processes do not inflate). One JSON line per clip, garment and value: median, p99 and worst ms per frame, and the
median's ratio to the first value's; then one line per value over every run: the mean of the per-run medians and
of the per-run p99s, and their ratio to the first value's. The limiting stops early once no spring is past
``1 + limit_ratio + strain_limit_tolerance``, so more iterations cost only in the frames that need them.

    PYTHONPATH=$PWD python bench/strain_iterations.py [--iterations 12 48] [--seconds 4] [--clips ...]
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
from garment_sim_ros.params import DEFAULT_PARAMS

DATA = Path(__file__).resolve().parent.parent / "test" / "data"
CLIPS = ("cc_cmu_07_01_walk", "cmu_01_01_jumps_turnaround", "cmu_131_01_walk_mjstyle",
         "cc_cmu_05_06_dance_cartwheel_pirouette")
FPS = 60.0


def frame_times(clip: str, garment: str, iterations: int, seconds: float) -> np.ndarray:
    """ms of thread CPU time per frame of the solver's step."""
    params = DEFAULT_PARAMS.replace(strain_limit_iterations=iterations)
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
    parser.add_argument("--iterations", type=int, nargs="+", default=[12, 48])
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--clips", nargs="+", default=list(CLIPS))
    args = parser.parse_args()
    benchmarking.set_threads(1)
    frame_times(args.clips[0], GARMENT_NAMES[0], args.iterations[0], 0.1)  # compile before timing
    summary: dict[int, list[tuple[float, float]]] = {n: [] for n in args.iterations}
    for clip in args.clips:
        for garment in GARMENT_NAMES:
            first = None
            for n in args.iterations:
                times = frame_times(clip, garment, n, args.seconds)
                median, p99 = float(np.median(times)), float(np.percentile(times, 99))
                first = median if first is None else first
                summary[n].append((median, p99))
                print(json.dumps({"clip": clip, "garment": garment, "strain_limit_iterations": n,
                                  "frames": len(times), "median_ms": round(median, 3), "p99_ms": round(p99, 3),
                                  "worst_ms": round(float(times.max()), 3),
                                  "median_ratio": round(median / first, 3)}), flush=True)
    base = summary[args.iterations[0]]
    for n in args.iterations:
        medians, p99s = zip(*summary[n])
        print(json.dumps({"strain_limit_iterations": n, "runs": len(medians),
                          "mean_median_ms": round(statistics.mean(medians), 3),
                          "mean_p99_ms": round(statistics.mean(p99s), 3),
                          "median_ratio": round(statistics.mean(medians) / statistics.mean(m for m, _ in base), 3),
                          "p99_ratio": round(statistics.mean(p99s) / statistics.mean(p for _, p in base), 3)}))


if __name__ == "__main__":
    main()
