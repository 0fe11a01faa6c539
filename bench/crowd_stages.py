"""Where a crowd character's 60 Hz tick goes, per stage: ``garment-sim crowd``'s ``Crowd`` with the
stages' methods wrapped in wall-clock timers (no profiler: cProfile inflates the Python parts).

``python bench/crowd_stages.py [CHARACTERS] [TICKS]`` (default 4, 120) prints one JSON object: the tick
median and the solver stages' median per character, the process's CPU time per character-frame (all its
threads), and each stage's mean wall and CPU (its thread's, which the load does not inflate) ms per
character-frame.
Stages nest: ``loop.frame`` holds ``pose sample``, ``root motion`` and ``character.step``, which holds
``solver.advance`` and ``quality meters``; ``markers (hold)`` and ``serialize`` are the publish.
"""

import json
import os
import sys
import time
from collections import defaultdict

import numpy as np

from garment_sim_ros.benchmarking import set_threads
from garment_sim_ros.body.pose_buffer import PoseBuffer
from garment_sim_ros.cloth.solver import GarmentSolver
from garment_sim_ros.commands import crowd
from garment_sim_ros.dressing import DressedCharacter
from garment_sim_ros.runtime.character_loop import CharacterLoop
from garment_sim_ros.runtime.crowd import Member

STAGES = ((PoseBuffer, "sample", "pose sample"), (PoseBuffer, "root_motion", "root motion"),
          (GarmentSolver, "advance", "solver.advance"), (DressedCharacter, "step", "character.step"),
          (DressedCharacter, "measure", "quality meters"), (DressedCharacter, "max_penetration", "max_penetration"),
          (CharacterLoop, "frame", "loop.frame"), (Member, "hold", "markers (hold)"),
          (crowd, "serialize_marker_array", "serialize"), (crowd.Crowd, "feed", "feed (input)"))


def timed(function, totals: dict, cpu: dict, label: str):
    def wrapper(*args, **kwargs):
        tic, cpu_tic = time.perf_counter(), time.thread_time()
        try:
            return function(*args, **kwargs)
        finally:
            totals[label] += time.perf_counter() - tic
            cpu[label] += time.thread_time() - cpu_tic
    return wrapper


def main() -> None:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 4
    ticks = int(sys.argv[2]) if len(sys.argv) > 2 else 120
    set_threads(None)
    totals: dict[str, float] = defaultdict(float)
    cpu: dict[str, float] = defaultdict(float)
    for owner, name, label in STAGES:
        setattr(owner, name, timed(getattr(owner, name), totals, cpu, label))
    group = crowd.Crowd(count, ["one_piece"])
    group.dress_all()
    for _ in range(5):
        group.tick(count)
    totals.clear()
    cpu.clear()
    cpu_start = time.process_time()
    samples = [group.tick(count) for _ in range(ticks)]
    process_cpu = time.process_time() - cpu_start
    print(json.dumps({
        "characters": count, "ticks": ticks, "load_average": round(os.getloadavg()[0], 2),
        "tick_ms_per_character": round(1e3 * float(np.median([s["tick"] for s in samples])) / count, 3),
        "solver_stages_ms_per_character": round(1e3 * float(np.median([s["solver"] for s in samples])) / count, 3),
        "process_cpu_ms_per_character": round(1e3 * process_cpu / ticks / count, 3),
        "stage_ms_per_character": {label: round(1e3 * total / ticks / count, 3)
                                   for label, total in sorted(totals.items(), key=lambda item: -item[1])},
        "stage_cpu_ms_per_character": {label: round(1e3 * total / ticks / count, 3)
                                       for label, total in sorted(cpu.items(), key=lambda item: -item[1])},
    }))


if __name__ == "__main__":
    main()
