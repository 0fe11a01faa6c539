"""What the contact planes (``collision.contact_planes``) cost per frame on a real clip.

``python bench/contact_planes.py CLIP.bvh GARMENT [--seconds S] [--start T]`` plays the clip at 60 fps from
``--start``, once with ``contact_planes`` on and once off, and prints, as JSON lines, per run: the solver's
time per frame (the reports' integration_s + correction_s + collision_s; median and mean, ms), the deepest
overlap pressed (mm), the number of substeps, the frames with a limb bone through the cloth, the longest
structural spring (rest lengths) and the deepest free point (mm); then the time of one ``Collider.begin_substep`` (pose
interpolation, plus the planes when on; µs, the median of 2000 calls on the clip's last pose).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip")
    parser.add_argument("garment")
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--start", type=float, default=0.0)
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False)
    times = args.start + np.arange(int(round(args.seconds * 60)) + 1) / 60.0
    for on in (1, 0):
        params = DEFAULT_PARAMS.replace(contact_planes=on)
        character = make_character(source.rest_pose, source.joint_map, [args.garment], params,
                                   motion=source.fit_poses())
        costs, pressed, substeps, bone_frames, stretch, depth = [], 0.0, 0, 0, 0.0, 0.0
        for _, _, reports in simulate_frames(source, character, times):
            if reports is not None:
                report = reports[0]
                costs.append(report.integration_s + report.correction_s + report.collision_s)
                pressed = max(pressed, report.pressed_depth_m)
                substeps += report.substeps
                bone_frames += report.bones_through > 0
                stretch = max(stretch, report.structural_stretch_max)
                depth = max(depth, report.max_depth_m)
        collider = character.solvers[0].collider
        calls = []
        for _ in range(2000):
            tic = time.perf_counter()
            collider.begin_substep(0.25, 0.5)
            calls.append(time.perf_counter() - tic)
        print(json.dumps({"contact_planes": on, "frames": len(costs), "substeps": substeps,
                          "solver_ms_median": round(1e3 * float(np.median(costs)), 3),
                          "solver_ms_mean": round(1e3 * float(np.mean(costs)), 3),
                          "pressed_mm": round(1e3 * pressed, 1), "bone_frames": bone_frames,
                          "structural_stretch_max": round(stretch, 2), "max_depth_mm": round(1e3 * depth, 1),
                          "begin_substep_us": round(1e6 * float(np.median(calls)), 2)}), flush=True)


if __name__ == "__main__":
    main()
