"""Where the drape's time goes (``garment-sim drape``, n = 64): per kernel, per frame.

Runs the scene twice from the start: on the fused frame (``cloth.fused``, what ``garment-sim drape`` runs: its
wall and CPU time per frame) and on the reference loop with every kernel it calls wrapped in a CPU timer (the same
kernels in the same order, ``cloth.fused``'s docstring): each kernel's CPU ms per frame and calls per substep
(the strain limiting's sweeps and contact handling apart), and what the reference loop spends outside the
kernels (Python, numba's dispatch). CPU time (``time.process_time``, all threads), as the wall time on a loaded
machine also counts the time other processes held the cores. Prints one JSON line.

    PYTHONPATH=$PWD python bench/drape_profile.py [frames=K] [threads=T] [NAME=VALUE ...]

``frames`` (default 60) timed frames after the 5 warm-up ones; ``NAME=VALUE`` replaces a ``drape_params`` value.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from garment_sim_ros.benchmarking import call_timers, load_average, set_threads
from garment_sim_ros.cloth import kernels as cloth_kernels
from garment_sim_ros.collision import crossing
from garment_sim_ros.collision import kernels as collision_kernels
from garment_sim_ros.commands import drape

TIMED = {cloth_kernels: ("accumulate_forces", "integrate", "set_attached", "length_correction", "tether_constraints",
                         "velocities_from_positions", "contact_weights", "spring_stretches", "keep_where_inside"),
         collision_kernels: ("handle_all", "handle_all_parallel", "handle_contacts", "handle_contacts_parallel",
                             "handle_edges", "penetration_depths", "substep_poses"),
         crossing: ("handle_axes",)}


def profile(frames: int, changes: dict) -> dict:
    n = drape.DEFAULT_N
    params = drape.drape_params(n).replace(**changes)
    fused_scene = drape.DrapeScene(n, params)
    fused_wall, fused_cpu = [], []
    for frame in range(drape.WARMUP_FRAMES + frames):
        tic, cpu_tic = time.perf_counter(), time.process_time()
        fused_scene.advance()
        if frame >= drape.WARMUP_FRAMES:
            fused_wall.append(time.perf_counter() - tic)
            fused_cpu.append(time.process_time() - cpu_tic)

    scene = drape.DrapeScene(n, params)
    scene.solver.use_fused = False
    strain_inv_mass, strain_velocities = scene.solver._strain_inv_mass, scene.solver._v_scratch

    def label(name, args):  # the strain limiting's sweeps and contact handling apart from the correction's
        if name == "length_correction" and args[1] is strain_inv_mass:
            return "strain_limit.length_correction"
        if name.startswith("handle_contacts") and args[3] is strain_velocities:
            return "strain_limit." + name
        return name

    targets = [(module, name) for module, names in TIMED.items() for name in names]
    cpu = []
    for frame in range(drape.WARMUP_FRAMES):
        scene.advance()
    # CPU time of the whole process: the parallel collision kernels run on numba's worker threads
    with call_timers(targets, clock=time.process_time, key=label) as totals:
        for frame in range(frames):
            tic = time.process_time()
            scene.advance()
            cpu.append(time.process_time() - tic)
    seconds = {key: entry[1] for key, entry in totals.items()}
    calls = {key: entry[2] for key, entry in totals.items()}
    in_kernels = sum(seconds.values())
    substeps = frames * drape.SUBSTEPS
    per_frame = {key: round(1e3 * value / frames, 3) for key, value in sorted(seconds.items(), key=lambda kv: -kv[1])}
    return {"changes": changes, "frames": frames, "threads": set_threads(None),
            "parallel_collision": scene.solver.collider.parallel, "load_1min": load_average(),
            "fused_ms_per_frame": round(1e3 * float(np.mean(fused_wall)), 2),
            "fused_ms_per_frame_median": round(1e3 * float(np.median(fused_wall)), 2),
            "fused_cpu_ms_per_frame": round(1e3 * float(np.mean(fused_cpu)), 2),
            "reference_cpu_ms_per_frame": round(1e3 * float(np.mean(cpu)), 2),
            "reference_cpu_outside_kernels_ms_per_frame": round(1e3 * (sum(cpu) - in_kernels) / frames, 2),
            "kernel_cpu_ms_per_frame": per_frame,
            "calls_per_substep": {key: round(calls[key] / substeps, 2) for key in per_frame},
            "final_top_z_m": round(float(np.max(scene.positions[:, 2])), 4)}


def main(argv: list[str]) -> dict:
    frames, threads, changes = 60, None, {}
    for item in argv:
        name, value = item.split("=")
        if name == "frames":
            frames = int(value)
        elif name == "threads":
            threads = int(value)
        else:
            changes[name] = float(value) if "." in value else int(value)
    set_threads(threads)
    return profile(frames, changes)


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1:])))
