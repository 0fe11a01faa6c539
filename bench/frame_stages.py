"""Where a whole frame of ``garment-sim scale`` goes (issue 15: the 20 000-point dress at 60 fps, a share per stage).

The one-piece under the Table 1 protocol (memo preset, procedural walk, 0.04 s frames) at about ``--points``
mass points, frame by frame as ``benchmarking.character_benchmark`` runs it, each stage timed apart: the
solver's step (``DressedCharacter.step`` without the quality figures), the quality meters
(``DressedCharacter.measure``, and each meter inside it), the publish payload (normals and shaded colours,
``rerun_log.frame_payload``), the markers (``markers.frame_markers``) and their CDR bytes
(``serialize_marker_array``). Rerun logging is left out (``garment-sim scale``'s ``rerun_ms``). Per stage the
median wall time, the median CPU time of this thread (``time.thread_time``: with ``--threads 1`` all of the
stage's work, which other processes on the machine do not inflate as they do the wall time) and of the process
(``time.process_time``: all of numba's threads, with their waits for each other).

    PYTHONPATH=$PWD python bench/frame_stages.py [--points 20000] [--frames 10] [--threads 1]

One JSON line: ms per stage (``wall_ms``, ``cpu_ms``, ``process_cpu_ms``), the shares of the CPU total, the
load average.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from garment_sim_ros import benchmarking, quality
from garment_sim_ros.body.sources import procedural_source
from garment_sim_ros.commands.scale import resolution_for
from garment_sim_ros.commands.table1 import FRAME_S
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import PRESETS
from garment_sim_ros.rerun_log import frame_payload
from garment_sim_ros.runtime.marker_cdr import serialize_marker_array
from garment_sim_ros.runtime.markers import frame_markers
from garment_sim_ros.runtime.tf_input import seconds_to_stamp

STAGES = ("step", "measure", "payload", "markers", "cdr")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20_000, help="target mass points (garment-sim scale's)")
    parser.add_argument("--frames", type=int, default=10, help="timed frames")
    parser.add_argument("--warmup", type=int, default=5, help="untimed frames before them")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")
    args = parser.parse_args()
    threads = benchmarking.set_threads(args.threads)
    source = procedural_source("walk")
    character = make_character(source.rest_pose, source.joint_map, ["one_piece"], PRESETS["memo"],
                               resolution_for(args.points), motion=source.fit_poses())
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    meter = character._meters[0]
    samples = {stage: ([], [], []) for stage in STAGES}
    with benchmarking.call_timers(((quality, "free_point_depth"), (quality, "surface_depth"), (meter, "bones_through"),
                                   (meter.tubes, "rings_off"), (meter, "stretch_figures"))) as meters:
        for frame in range(1, args.warmup + args.frames + 1):
            t = frame * FRAME_S
            pose, motion = source.pose(t), source.motion(t)
            if frame == args.warmup + 1:
                meters.clear()
            clocks = [(time.perf_counter(), time.thread_time(), time.process_time())]
            reports = character.step(pose, motion, t, measure=False)
            clocks.append((time.perf_counter(), time.thread_time(), time.process_time()))
            character.measure(reports, pose)
            clocks.append((time.perf_counter(), time.thread_time(), time.process_time()))
            payload = frame_payload(character, pose)
            clocks.append((time.perf_counter(), time.thread_time(), time.process_time()))
            markers = frame_markers(payload, "garment", "world", seconds_to_stamp(t), with_volumes=True)
            clocks.append((time.perf_counter(), time.thread_time(), time.process_time()))
            serialize_marker_array(markers)
            clocks.append((time.perf_counter(), time.thread_time(), time.process_time()))
            if frame > args.warmup:
                for k, stage in enumerate(STAGES):
                    samples[stage][0].append(clocks[k + 1][0] - clocks[k][0])
                    samples[stage][1].append(clocks[k + 1][1] - clocks[k][1])
                    samples[stage][2].append(clocks[k + 1][2] - clocks[k][2])
    wall, cpu, process = ({stage: round(statistics.median(series[k]) * 1e3, 3) for stage, series in samples.items()}
                          for k in range(3))
    total = sum(cpu.values())
    print(json.dumps({
        "bench": "frame_stages", "mass_points": character.solvers[0].model.num_points, "frames": args.frames,
        "threads": threads, "wall_ms": wall, "cpu_ms": cpu, "process_cpu_ms": process, "cpu_total_ms": round(total, 3),
        "cpu_share": {stage: round(value / total, 3) for stage, value in cpu.items()},
        "meters_cpu_ms": {name: round(c / args.frames * 1e3, 3) for name, (_, c, _) in meters.items()},
        "load_1min": benchmarking.load_average()}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
