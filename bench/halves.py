"""The halves' kernels against the serial ones, kernel by kernel, on 1 and 2 threads (issue 15: the 20 000-point frame).

The one-piece under ``garment-sim scale``'s protocol (memo preset, procedural walk) at about ``--points`` mass
points, stepped a few frames; then, from that state, each kernel the solver runs serial below
``PARALLEL_MIN_POINTS`` and in halves from it (``cloth.halves``): the forces, one length-correction sweep, the
edge handling. Per kernel and thread count the fastest of ``--repeats`` calls (each from the same positions)
in wall time and in the process's CPU time (all threads): another process taking a core only ever adds, so the
fastest call is the one with both cores; a second core is only seen when the machine has one free.

    PYTHONPATH=$PWD python bench/halves.py [--points 20000] [--repeats 25]

One JSON line per thread count.
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from garment_sim_ros import benchmarking
from garment_sim_ros.body.sources import procedural_source
from garment_sim_ros.cloth import kernels
from garment_sim_ros.collision import kernels as collision_kernels
from garment_sim_ros.commands.scale import resolution_for
from garment_sim_ros.commands.table1 import FRAME_S
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import PRESETS


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=25)
    args = parser.parse_args()
    source = procedural_source("walk")
    character = make_character(source.rest_pose, source.joint_map, ["one_piece"], PRESETS["memo"],
                               resolution_for(args.points), motion=source.fit_poses())
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    for frame in range(1, 4):
        t = frame * FRAME_S
        character.step(source.pose(t), source.motion(t), t, measure=False)
    solver = character.solvers[0]
    model, const, collider, layout = solver.model, solver.constants, solver.collider, solver.parallel_layout()
    x0, v, x_start = solver.state.positions.copy(), solver.state.velocities, solver._x_start
    x, forces = x0.copy(), np.zeros_like(x0)
    frame = (np.array([0.0, 0.0, -0.5]), 0.1, 0.0, 1.0, np.zeros(3), 1.0, forces)
    limit, pinch = solver.params.limit_ratio, collider._edge_pinch_depth
    calls = {
        "forces_serial": lambda: kernels.accumulate_forces(x, v, const.mass, model.springs, model.rest_lengths,
                                                           const.stiffness, const.damping, *frame),
        "forces_halves": lambda: kernels.accumulate_forces_halves(x, v, const.mass, layout.springs, layout.rest,
                                                                  layout.stiffness, layout.damping, *frame,
                                                                  layout.spring_starts),
        "correction_serial": lambda: kernels.length_correction(x, const.inv_mass, model.springs, model.rest_lengths,
                                                               solver._correct_count, limit),
        "correction_halves": lambda: kernels.length_correction_halves(x, const.inv_mass, layout.correction_springs,
                                                                      layout.correction_rest,
                                                                      layout.correction_starts, limit),
        "edges_serial": lambda: collision_kernels.handle_edges(collider._packed, x_start, x, const.inv_mass,
                                                               solver._edges, solver._edge_rest, pinch),
        "edges_halves": lambda: collision_kernels.handle_edges_halves(collider._packed, x_start, x, const.inv_mass,
                                                                      layout.edges, layout.edge_rest,
                                                                      layout.edge_starts, pinch),
    }
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        row = {"bench": "halves", "mass_points": model.num_points, "threads": threads}
        for name, call in calls.items():
            wall = cpu = np.inf
            for _ in range(args.repeats):
                x[...] = x0
                tic, cpu_tic = time.perf_counter(), time.process_time()
                call()
                wall = min(wall, time.perf_counter() - tic)
                cpu = min(cpu, time.process_time() - cpu_tic)
            row[f"{name}_ms"] = round(wall * 1e3, 3)
            row[f"{name}_process_cpu_ms"] = round(cpu * 1e3, 3)
        row["load_1min"] = benchmarking.load_average()
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
