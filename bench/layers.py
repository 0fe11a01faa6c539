"""What keeping an outfit's layers apart costs a frame (``cloth.layers``, issue 13 item 5).

Dresses a clip's character in an outfit, steps it ``--frames`` frames at 60 fps and prints, as one JSON
line, the median wall time of the whole frame, of the layer passes (``DressedCharacter._separate_layers``)
and of the crossing count (``DressedCharacter.layer_crossings``), in ms.

    .venv/bin/python bench/layers.py [--clip test/data/xia_strutting_01_000.bvh] [--outfit pants,long_skirt]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import preset

CLIP = Path(__file__).resolve().parents[1] / "test" / "data" / "xia_strutting_01_000.bvh"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clip", default=str(CLIP), help="BVH clip")
    parser.add_argument("--outfit", default="pants,long_skirt", help="comma-separated garments, inner first")
    parser.add_argument("--frames", type=int, default=120, help="frames to time after dressing")
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False)
    character = make_character(source.rest_pose, source.joint_map, args.outfit.split(","), preset("si"))
    spent: dict[str, list[float]] = {"separate": [], "count": []}

    def timed(method, name):
        def call(*a, **k):
            tic = time.perf_counter()
            result = method(*a, **k)
            spent[name].append(time.perf_counter() - tic)
            return result
        return call

    steps = simulate_frames(source, character, np.arange(args.frames + 1) / 60.0)
    next(steps)  # the dressing
    character._separate_layers = timed(character._separate_layers, "separate")
    character.layer_crossings = timed(character.layer_crossings, "count")
    frames = []
    for _ in range(args.frames):
        tic = time.perf_counter()
        next(steps)
        frames.append(time.perf_counter() - tic)
    print(json.dumps({"outfit": character.garment_names, "points": [s.model.num_points for s in character.solvers],
                      "frame_ms": 1e3 * float(np.median(frames)),
                      "layers_ms": 1e3 * float(np.median(spent["separate"])),
                      "crossings_ms": 1e3 * float(np.median(spent["count"]))}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
