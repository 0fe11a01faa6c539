#!/usr/bin/env python3
"""Why an outfit's outer garment is left through an inner one: the crossings left after each frame, sorted.

Plays a clip (3 s at 1x, 60 fps, as ``garment-sim evaluate``) in an outfit and, after every frame, takes each
outer edge still through an inner garment's triangles and sorts it by what ``cloth.layers._edge_through`` makes
of it, from its first and last crossing along it:

- ``straddle``: enters the inner surface at its first crossing and leaves it at its last, both ends outside
  (a long skirt's edge across a trouser leg or a fold);
- ``skewer``: a straddle whose two crossed triangles face apart (``FOLD``): through a whole trouser leg or both
  sides of a fold, which ``_clear_skewer`` moves out sideways when the way out is near;
- ``inside-shallow`` / ``inside-deep``: an end behind a crossing, less / more than ``REACH_M`` (5 cm) behind
  that triangle's plane (deeper: behind a fold, such as the crotch, not inside the trousers);
- ``inside-pinned``: that end is attached (not moved by the layers).

Prints, per kind, the frames with such an edge and how many edges in all. Run from the repository root:

    PYTHONPATH=$PWD python tools/layer_crossings.py test/data/cc_cmu_07_01_walk.bvh --outfit pants+long_skirt
"""

from __future__ import annotations

import argparse
import collections

import numpy as np

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth.layers import FOLD, REACH_M, InnerSurface
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import preset


def kinds(surface: InnerSurface, x: np.ndarray, edges: np.ndarray, movable: np.ndarray) -> list[str]:
    """The kind of each outer edge (points ``x`` (N, 3), ``edges`` (E, 2)) through ``surface``."""
    crossed = surface.crossings(x, edges)
    found = []
    for (p0, p1), (first, last) in zip(edges, crossed):
        if first < 0:
            continue
        d = x[p1] - x[p0]
        enters, leaves = d @ surface.normals[first] < 0.0, d @ surface.normals[last] > 0.0
        if enters and leaves:
            found.append("skewer" if np.linalg.norm(surface.normals[first] + surface.normals[last]) < FOLD else
                         "straddle")
            continue
        for inside, end, t in ((not enters, p0, first), (not leaves, p1, last)):
            if inside:
                behind = (x[end] - surface.positions[surface.triangles[t, 0]]) @ surface.normals[t]
                found.append("inside-pinned" if not movable[end] else
                             "inside-deep" if behind <= -REACH_M else "inside-shallow")
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip", help="BVH clip")
    parser.add_argument("--outfit", default="pants+long_skirt", help="garments joined by +, inner first")
    parser.add_argument("--duration", type=float, default=3.0, help="seconds of the clip, s")
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False)
    character = make_character(source.rest_pose, source.joint_map, args.outfit.split("+"), preset("si"),
                               motion=source.fit_poses())
    frames = int(np.floor(min(source.duration, args.duration) * 60.0 + 1e-9))
    frames_with, edges_of = collections.Counter(), collections.Counter()
    for _, _, reports in simulate_frames(source, character, np.arange(frames + 1) / 60.0):
        if reports is None:
            continue
        seen = []
        for row, solver in enumerate(character.solvers):
            for inner in character._inner[row]:
                surface = InnerSurface(character.solvers[inner].state.positions,
                                       character.solvers[inner].model.triangles, REACH_M)
                seen += kinds(surface, solver.state.positions, solver.model.edges, solver.constants.inv_mass > 0.0)
        edges_of.update(seen)
        edges_of["any"] += len(seen)
        frames_with.update(set(seen) | ({"any"} if seen else set()))
    print(f"{args.clip} {args.outfit}: {frames} frames")
    for kind in ("any", "straddle", "skewer", "inside-shallow", "inside-deep", "inside-pinned"):
        print(f"  {kind:15s} frames {frames_with[kind]:4d}  edges {edges_of[kind]:5d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
