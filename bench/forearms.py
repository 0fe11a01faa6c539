"""What the forearms (12 volumes) cost a garment per frame on a real clip, against the memo's 10 volumes
(issue 11, target b).

``python bench/forearms.py CLIP.bvh [CLIP ...] [--garment G] [--seconds S] [--rounds R]`` plays each clip at
60 fps from its start on each body in turn, ``--rounds`` times (alternating, so a loaded machine slows both alike),
and prints one JSON line per body: the solver's time per frame (integration_s + correction_s + collision_s of
the reports; the median over every round's frames, ms; and collision_s alone), the substeps per frame (mean),
the frames with a limb bone through the cloth and the longest structural spring (rest lengths), from the last
round.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs="+")
    parser.add_argument("--garment", default="short_skirt")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    for clip in args.clips:
        compare(clip, args.garment, args.seconds, args.rounds)


def compare(clip: str, garment: str, seconds: float, rounds: int) -> None:
    """The two bodies' JSON lines for ``garment`` on ``clip`` (see the module docstring)."""
    source = bvh_source(clip, loop=False)
    times = np.arange(int(round(seconds * 60)) + 1) / 60.0
    costs: dict[bool, list[float]] = {False: [], True: []}
    collision: dict[bool, list[float]] = {False: [], True: []}
    last: dict[bool, dict] = {}
    for _ in range(rounds):
        for forearms in (False, True):
            character = make_character(source.rest_pose, source.joint_map, [garment], DEFAULT_PARAMS,
                                       motion=source.fit_poses(), forearms=forearms)
            frames = [r[0] for _, _, r in simulate_frames(source, character, times) if r is not None]
            costs[forearms] += [r.integration_s + r.correction_s + r.collision_s for r in frames]
            collision[forearms] += [r.collision_s for r in frames]
            last[forearms] = {"volumes": len(character.body.volumes),
                              "substeps_per_frame": round(float(np.mean([r.substeps for r in frames])), 2),
                              "bone_frames": sum(r.bones_through > 0 for r in frames),
                              "structural_stretch_max": round(max(r.structural_stretch_max for r in frames), 2)}
    for forearms in (False, True):
        print(json.dumps({"clip": clip, "garment": garment, **last[forearms], "frames": len(times) - 1,
                          "solver_ms_median": round(1e3 * float(np.median(costs[forearms])), 3),
                          "collision_ms_median": round(1e3 * float(np.median(collision[forearms])), 3)}), flush=True)


if __name__ == "__main__":
    main()
