"""The drape scene (``garment-sim drape``, n = 64) with its parameters overridden: which setting buys what.

Each ``NAME=VALUE`` replaces a solver parameter of ``drape_params`` (``contact_friction=0`` ``contact_margin=0``
``collision_epsilon=0.003`` ``correction_iterations=4`` are main's drape before issue 15's friction); ``frames=K``
times K frames after the 5 warm-up ones (default 90, the whole scene; 10: the cloth lying on the still sphere).
Prints one JSON line: ms per frame (mean, median; and the process's CPU time, steadier on a loaded machine) and its
stages (integration, correction, collision; the fused frame's cycle-counter split), the worst stretch and
penetration over all frames, the final top z, and the stretch every 5 frames.

    PYTHONPATH=$PWD python bench/drape_settings.py [NAME=VALUE ...] [frames=K]
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from garment_sim_ros.commands import drape


def main(argv: list[str]) -> dict:
    frames, changes = drape.DEFAULT_FRAMES, {}
    for item in argv:
        name, value = item.split("=")
        if name == "frames":
            frames = int(value)
        else:
            changes[name] = float(value) if "." in value else int(value)
    n = drape.DEFAULT_N
    scene = drape.DrapeScene(n, drape.drape_params(n).replace(**changes))
    wall, cpu, stages, stretch_every_5 = [], [], np.zeros(3), []
    worst_stretch = worst_depth = 0.0
    for frame in range(drape.WARMUP_FRAMES + frames):
        tic, cpu_tic = time.perf_counter(), time.process_time()
        report = scene.advance()
        if frame >= drape.WARMUP_FRAMES:
            wall.append(time.perf_counter() - tic)
            cpu.append(time.process_time() - cpu_tic)
            stages += (report.integration_s, report.correction_s, report.collision_s)
        worst_stretch, worst_depth = max(worst_stretch, scene.stretch()), max(worst_depth, scene.penetration())
        if frame % 5 == 0:
            stretch_every_5.append(round(scene.stretch(), 3))
    return {"changes": changes, "frames": frames, "ms_per_frame": round(1e3 * float(np.mean(wall)), 2),
            "ms_per_frame_median": round(1e3 * float(np.median(wall)), 2),
            "cpu_ms_per_frame": round(1e3 * float(np.mean(cpu)), 2),
            "stages_ms": dict(zip(("integration", "correction", "collision"), np.round(1e3 * stages / frames, 2))),
            "max_stretch": round(worst_stretch, 4), "max_penetration_mm": round(1e3 * worst_depth, 3),
            "final_top_z_m": round(float(np.max(scene.positions[:, 2])), 4), "stretch_every_5_frames": stretch_every_5}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1:]), default=float))
