"""``garment-sim simulate``: a headless run of garments on a moving character, per-frame figures."""

from __future__ import annotations

import json
import time

import numpy as np

from ..body.sources import GAITS, bvh_source, procedural_source
from ..cloth.garments import GARMENT_NAMES
from ..params import PRESETS, preset

HELP = ("Dress the procedural walking character (or a BVH clip) and simulate it without ROS, printing "
        "per-frame figures: substeps, stage times, stretch and penetration.")


def add_arguments(parser) -> None:
    parser.add_argument("--garments", default="pants", help=f"comma-separated, of: {', '.join(GARMENT_NAMES)}")
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate of the run, Hz (default 60)")
    parser.add_argument("--gait", default="walk", choices=GAITS, help="procedural character's gait")
    parser.add_argument("--bvh", default=None, help="play this BVH clip instead of the procedural character")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution factor")
    parser.add_argument("--preset", default="si", choices=sorted(PRESETS), help="parameter preset")
    parser.add_argument("--every", type=int, default=10, help="print every N-th frame (default 10)")
    parser.add_argument("--json", action="store_true", help="one JSON object per printed frame, then a summary")


def make_character(source, garments, params, resolution):
    """Fit a body to ``source``'s rest pose and dress it (the one-piece needs the 15-volume body)."""
    from ..body.fitting import fit_body
    from ..dressing import DressedCharacter

    body = fit_body(source.rest_pose, source.joint_map, detailed="one_piece" in garments)
    return DressedCharacter(body, garments, params, resolution)


def parse_garments(text: str) -> list[str]:
    names = [g.strip() for g in text.split(",") if g.strip()]
    unknown = [g for g in names if g not in GARMENT_NAMES]
    if unknown or not names:
        raise ValueError(f"--garments: unknown {unknown or 'empty list'}; choose from {', '.join(GARMENT_NAMES)}")
    return names


def run(args) -> int:
    from ..dressing import motion_from_poses

    garments = parse_garments(args.garments)
    if not (args.fps > 0 and args.duration > 0):
        raise ValueError("--fps and --duration must be > 0")
    params = preset(args.preset)
    source = bvh_source(args.bvh) if args.bvh else procedural_source(args.gait)
    character = make_character(source, garments, params, args.resolution)
    dt = 1.0 / args.fps
    t = 0.0
    character.dress(source.pose(t), t, motion_from_poses(source.pose, source.joint_map, t))
    frames = int(round(args.duration * args.fps))
    worst_penetration = 0.0
    totals = []
    if not args.json:
        print(f"{source.name}: {', '.join(f'{s.model.name} ({s.model.num_points} points)' for s in character.solvers)}, "
              f"{len(character.body.volumes)} volumes, {args.fps:g} fps, preset {args.preset}")
        print(f"{'frame':>6} {'t [s]':>7} {'substeps':>8} {'integr. ms':>10} {'correct. ms':>11} {'collision ms':>12} "
              f"{'stretch':>8} {'penetr. mm':>10} {'lag s':>6}")
    for frame in range(1, frames + 1):
        t = frame * dt
        pose = source.pose(t)
        motion = motion_from_poses(source.pose, source.joint_map, t)
        tic = time.perf_counter()
        reports = character.step(pose, motion, t)
        totals.append(time.perf_counter() - tic)
        penetration = character.max_penetration()
        worst_penetration = max(worst_penetration, penetration)
        positions = character.world_positions()
        if not all(np.all(np.isfinite(p)) for p in positions):
            raise ValueError(f"frame {frame}: non-finite garment positions")
        if frame % max(1, args.every) == 0 or frame == frames:
            row = {
                "frame": frame, "t": round(t, 4), "substeps": reports[0].substeps,
                "integration_ms": sum(r.integration_s for r in reports) * 1e3,
                "correction_ms": sum(r.correction_s for r in reports) * 1e3,
                "collision_ms": sum(r.collision_s for r in reports) * 1e3,
                "max_stretch": max(r.max_stretch for r in reports),
                "max_penetration_m": penetration, "lag_s": reports[0].lag_s,
            }
            if args.json:
                print(json.dumps(row))
            else:
                print(f"{frame:>6} {t:>7.3f} {row['substeps']:>8} {row['integration_ms']:>10.3f} "
                      f"{row['correction_ms']:>11.3f} {row['collision_ms']:>12.3f} {row['max_stretch']:>8.4f} "
                      f"{penetration * 1e3:>10.3f} {row['lag_s']:>6.3f}")
    summary = {"garments": garments, "frames": frames, "median_frame_ms": float(np.median(totals) * 1e3),
               "max_penetration_m": worst_penetration}
    if args.json:
        print(json.dumps({"summary": summary}))
    else:
        print(f"median frame {summary['median_frame_ms']:.3f} ms, max penetration {worst_penetration * 1e3:.3f} mm")
    return 0
