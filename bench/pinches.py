"""Which frames of a garment on a real clip fail issue 11's (b) bones or (d) stretch, and why (issue 11, pinches).

``python bench/pinches.py CLIP.bvh GARMENT [--seconds S] [--fps F] [--speed X]`` plays the clip as ``evaluate``
dresses and plays it and prints, as JSON lines, one line per frame that fails (b) (a limb bone through a
triangle) or (d) (structural or shear p99 past 1.05, or a spring past 1.5), then a summary line of counts by
cause. A frame's cause, from its worst springs (the longest ten past 1.05; for (b) the crossing bone's own
volume) and the volumes within ``NEAR`` of their ends, at the frame's end:

- ``start``: one of the first ``START_FRAMES`` frames after dressing;
- ``pinch``: the ends touch two volumes whose surfaces are within ``NEAR`` of each other (overlapping or
  closer than the cloth needs): the cloth between them is pushed both ways;
- ``caught``: no pinch now, but a volume near the ends pinched cloth within the last ``CAUGHT`` frames (the
  cloth was carried off with it);
- ``fast``: one volume, moving faster than ``FAST`` m/s relative to the root;
- ``cut``: the rest (one slow volume or none: the garment's shape has too little cloth for the pose).

A frame with a bone through the cloth: ``pinch`` when the bone's volume is within ``NEAR`` of a volume it may
be pressed against (``Collider.pressing``), ``start``, ``caught`` as above, else ``other``.
"""

from __future__ import annotations

import argparse
import collections
import json
import math

import numpy as np
from numba import njit

from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.collision.contact_planes import _overlap
from garment_sim_ros.collision.geometry import inside_shape, to_local
from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID
from garment_sim_ros.commands.simulate import simulate_frames
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.quality import TARGETS

NEAR = 0.01  # m: a cloth point this near a volume's surface touches it; two surfaces this near pinch cloth
START_FRAMES = 6  # frames after dressing counted as the clip's start
FAST = 2.0  # m/s: a volume moving faster than this relative to the root
WORST = 10  # springs per frame looked at
CAUGHT = 30  # frames: cloth still stretched round a volume this soon after it pinched it was caught there


@njit(cache=True)
def surface_distances(kinds, radii, cuts, pos, rot, x, out):
    """Upper bound (m) of each point's distance (N, V) to each volume's uncut surface, 0 inside: bisection
    along the line to the volume's local origin (a star-shaped volume)."""
    for i in range(x.shape[0]):
        for v in range(kinds.shape[0]):
            lx, ly, lz = to_local(pos, rot, v, x[i, 0], x[i, 1], x[i, 2])
            if inside_shape(kinds[v], radii, cuts, v, lx, ly, lz):
                out[i, v] = 0.0
                continue
            cz = 0.0  # the axis point nearest the point's height (a sphere's centre)
            if kinds[v] == ELLIPSOID:
                cz = min(max(lz, cuts[v, 0]), cuts[v, 1])
            elif kinds[v] == CAPSULE:
                cz = min(max(lz, -radii[v, 2]), radii[v, 2])
            if not inside_shape(kinds[v], radii, cuts, v, 0.0, 0.0, cz):
                out[i, v] = math.inf
                continue
            lo, hi = 0.0, 1.0  # share of the way from the axis point to the point: inside at lo, outside at hi
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                if inside_shape(kinds[v], radii, cuts, v, mid * lx, mid * ly, cz + mid * (lz - cz)):
                    lo = mid
                else:
                    hi = mid
            out[i, v] = (1.0 - lo) * math.sqrt(lx * lx + ly * ly + (lz - cz) ** 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip")
    parser.add_argument("garment")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--fps", type=float, default=60.0)
    parser.add_argument("--speed", type=float, default=1.0)
    args = parser.parse_args()
    source = bvh_source(args.clip, loop=False, speed=args.speed, params=DEFAULT_PARAMS)
    character = make_character(source.rest_pose, source.joint_map, [args.garment], DEFAULT_PARAMS, 1.0,
                               motion=source.fit_poses())  # as evaluate dresses it
    solver = character.solvers[0]
    model, arrays = solver.model, solver.collider.arrays
    names = np.array(solver.volumes.names())
    springs = model.springs[:model.num_correction_springs]
    rest = model.rest_positions
    pressable = {(int(a), int(b)) for a, b in solver.collider.pressing}
    causes: collections.Counter = collections.Counter()
    last_pinched = {}  # volume -> the last frame it pinched cloth
    previous = None
    meter = character._meters[0]
    frames = int(math.floor(args.seconds * args.fps + 1e-9))
    for frame, (t, pose, reports) in enumerate(simulate_frames(source, character, np.arange(frames + 1) / args.fps)):
        pos = arrays.pos1.copy()
        if reports is None:
            previous = pos
            continue
        report = reports[0]
        speeds = np.linalg.norm(pos - previous, axis=1) * args.fps
        previous = pos
        stretch_fail = (max(report.structural_stretch_p99, report.shear_stretch_p99) > TARGETS.stretch_p99
                        or max(report.structural_stretch_max, report.shear_stretch_max) > TARGETS.stretch_max)
        if not stretch_fail and not report.bones_through:
            continue
        x = solver.state.positions
        overlaps = {}

        def pair_overlap(a, b):
            key = (min(a, b), max(a, b))
            if key not in overlaps:
                overlaps[key] = _overlap(arrays.kinds, arrays.radii, arrays.cuts, arrays.pos1, arrays.rot1, *key)[0]
            return overlaps[key]

        def classify(points):
            d = np.zeros((len(points), len(names)))
            surface_distances(arrays.kinds, arrays.radii, arrays.cuts, arrays.pos1, arrays.rot1,
                              np.ascontiguousarray(x[points]), d)
            near = sorted(set(np.flatnonzero((d <= NEAR).any(axis=0)).tolist()))
            pinches = [(a, b, pair_overlap(a, b)) for i, a in enumerate(near) for b in near[i + 1:]
                       if (a, b) in pressable and pair_overlap(a, b) > -NEAR]
            for a, b, _ in pinches:
                last_pinched[a] = last_pinched[b] = frame
            if frame <= START_FRAMES:
                cause = "start"
            elif pinches:
                cause = "pinch"
            elif any(frame - last_pinched.get(v, -CAUGHT) < CAUGHT for v in near):
                cause = "caught"
            elif any(speeds[v] > FAST for v in near):
                cause = "fast"
            else:
                cause = "cut"
            return cause, [names[v] for v in near], [[names[a], names[b], round(1e3 * o, 1)] for a, b, o in pinches]

        row = {"frame": frame, "t": round(float(t), 3)}
        if stretch_fail:
            order = np.argsort(-solver.stretches)[:WORST]
            order = order[solver.stretches[order] > TARGETS.stretch_p99]
            cause, near, pinches = classify(np.unique(springs[order].ravel()))
            middle = 0.5 * (rest[springs[order[0], 0]] + rest[springs[order[0], 1]])
            row.update(stretch=[round(report.structural_stretch_p99, 3), round(report.structural_stretch_max, 2),
                                round(report.shear_stretch_p99, 3), round(report.shear_stretch_max, 2)],
                       stretch_cause=cause, worst_at_rest_cm=[round(100 * c) for c in middle], near=near,
                       pinches=pinches, max_volume_speed=round(float(max((speeds[names == n][0] for n in near),
                                                                         default=0.0)), 2))
            causes["stretch " + cause] += 1
        if report.bones_through:
            crossing = meter.bones_through(character.world_positions()[0], pose)
            # the crossing bones' own volumes, and the volumes that may be pressed against them within NEAR
            own = [v for v, n in enumerate(names) if any(n.replace("lower_arm", "forearm").replace(
                "upper_leg", "thigh").replace("lower_leg", "shin") == b or (b == "spine" and n == "torso")
                for b in crossing)]
            pinched = [[names[v], names[o], round(1e3 * pair_overlap(v, o), 1)] for v in own
                       for o in range(len(names)) if (min(v, o), max(v, o)) in pressable
                       and pair_overlap(v, o) > -NEAR]
            row.update(bones=crossing, bone_pinches=pinched)
            causes["bones " + ("pinch" if pinched else "start" if frame <= START_FRAMES else "caught" if any(
                frame - last_pinched.get(v, -CAUGHT) < CAUGHT for v in own) else "other")] += 1
        print(json.dumps(row))
    print(json.dumps({"clip": args.clip, "garment": args.garment, "speed": args.speed, "fps": args.fps,
                      "causes": dict(causes)}))


if __name__ == "__main__":
    main()
