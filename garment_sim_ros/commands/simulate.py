"""``garment-sim simulate``: a headless run of garments on a moving character, per-frame figures."""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ..body.sources import GAITS, bvh_source, procedural_source
from ..cloth.garments import GARMENT_NAMES
from ..cloth.spec import parse_garment_list
from ..dressing import make_character
from ..params import DEFAULT_PARAMS, PARAM_OPTION_HELP, PRESETS, parse_params, preset

HELP = ("Dress the procedural walking character (or a BVH clip) and simulate it without ROS, printing "
        "per-frame figures: substeps, stage times, stretch and penetration; --export writes the run "
        "(skeleton, garments, volumes per frame) to an .npz file.")


GARMENTS_HELP = (f"comma-separated: built-ins ({', '.join(GARMENT_NAMES)}), garment spec files (*.yaml) or the "
                 "names of specs in config/garments/")
DECIMATE_HELP = "reduce a garment mesh file to at most this many vertices first (quadric decimation)"


def add_arguments(parser) -> None:
    parser.add_argument("--garments", default="pants", help=GARMENTS_HELP)
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    parser.add_argument("--fps", type=float, default=60.0, help="frame rate of the run, Hz (default 60)")
    parser.add_argument("--gait", default="walk", choices=GAITS, help="procedural character's gait")
    parser.add_argument("--bvh", default=None, help="play this BVH clip instead of the procedural character")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed of the --bvh clip (default 1)")
    parser.add_argument("--loop", action="store_true",
                        help="restart the --bvh clip after its end (default: the run stops at the clip's end)")
    parser.add_argument("--keep-first-frame", action="store_true",
                        help="play the --bvh clip's frame 0 even when it is a reference pose (dropped by default)")
    parser.add_argument("--export", default=None, metavar="RUN.npz",
                        help="write the run (skeleton, garments, volumes, every frame) to this .npz file")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution factor")
    parser.add_argument("--decimate", type=int, default=None, metavar="VERTICES", help=DECIMATE_HELP)
    parser.add_argument("--preset", default="si", choices=sorted(PRESETS), help="parameter preset")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help=f"change a solver parameter of the preset ({PARAM_OPTION_HELP})")
    parser.add_argument("--every", type=int, default=10, help="print every N-th frame (default 10)")
    parser.add_argument("--json", action="store_true", help="one JSON object per printed frame, then a summary")


def parse_garments(text: str) -> list[str]:
    """The ``--garments`` entries, each checked to name a built-in or a valid spec (``SpecError`` if not)."""
    parse_garment_list(text)
    return [g.strip() for g in text.split(",") if g.strip()]


def parse_outfits(text: str) -> list[list[str]]:
    """``'long_skirt,pants+short_skirt'`` -> ``[['long_skirt'], ['pants', 'short_skirt']]``: ``,`` separates
    outfits, ``+`` joins the garments of one worn together (``SpecError`` names a bad or repeated one)."""
    outfits = [parse_garments(outfit.replace("+", ",")) for outfit in text.split(",") if outfit.strip()]
    if not outfits:
        raise ValueError(f"--garments: no outfit in {text!r}; e.g. pants+long_skirt")
    return outfits


def simulate_frames(source, character, times):
    """Dress ``character`` on ``source`` at ``times[0]``, then step it to each later time. Yields
    ``(t, pose, reports)`` per time, ``reports`` None for a dressing: the one run loop of ``simulate``,
    ``snapshot`` and ``evaluate``. A looping clip's seam is a teleport, as in the node: the garments are
    dressed again on the first pose after it instead of being dragged across the jump."""
    times = iter(times)
    t = next(times)
    pose = source.pose(t)
    character.dress(pose, t, source.motion(t))
    yield t, pose, None
    for t_next in times:
        pose = source.pose(t_next)
        if source.loop_index(t_next) != source.loop_index(t):
            character.dress(pose, t_next, source.motion(t_next))
            yield t_next, pose, None
        else:
            yield t_next, pose, character.step(pose, source.motion(t_next), t_next)
        t = t_next


def run_source(args, params=DEFAULT_PARAMS):
    """The motion source ``--bvh``/``--speed``/``--loop`` (or ``--gait``) ask for (a clip's joint glitches
    replaced by ``params``)."""
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise ValueError(f"--speed must be > 0, got {args.speed}")
    if args.bvh:
        return bvh_source(args.bvh, loop=args.loop, keep_first_frame=args.keep_first_frame, speed=args.speed,
                          params=params)
    if args.speed != 1.0 or args.loop or args.keep_first_frame:
        raise ValueError("--speed, --loop and --keep-first-frame play a --bvh clip; the procedural character "
                         "has --gait walk/run/fast")
    return procedural_source(args.gait)


def run(args) -> int:
    garments = parse_garments(args.garments)
    if not (args.fps > 0 and args.duration > 0):
        raise ValueError("--fps and --duration must be > 0")
    if args.export and not args.export.endswith(".npz"):
        raise ValueError(f"--export: {args.export!r} must end in .npz")
    params = preset(args.preset).replace(**dict(parse_params(args.param, args.preset)))
    source = run_source(args, params)
    character = make_character(source.rest_pose, source.joint_map, garments, params, args.resolution,
                               decimate_to=args.decimate, motion=source.fit_poses())
    frames = int(round(args.duration * args.fps))
    if source.duration is not None:  # a clip that does not loop: the run ends with it
        frames = min(frames, int(math.floor(source.duration * args.fps + 1e-9)))
    recorder = None
    if args.export:
        from ..export import RunRecorder

        recorder = RunRecorder(character, source, args.fps, args.speed)
    worst_penetration = 0.0
    quality_frames = {"bones_through_frames": 0, "legs_off_frames": 0, "guard_firings": 0}
    totals = []
    if not args.json:
        worn = ", ".join(f"{s.model.name} ({s.model.num_points} points)" for s in character.solvers)
        print(f"{source.name}: {worn}, {len(character.body.volumes)} volumes, {args.fps:g} fps, {frames} frames, "
              f"preset {args.preset}")
        for note in character.notes:
            print(f"dressing: {note}")
        if source.dropped_reference_frame:
            print("the clip's frame 0 is a reference pose: dropped (--keep-first-frame plays it)")
        if source.glitches.total:
            print(f"the clip's input: {source.glitches.summary()}")
        print(f"{'frame':>6} {'t [s]':>7} {'substeps':>8} {'integr. ms':>10} {'correct. ms':>11} {'collision ms':>12} "
              f"{'stretch':>8} {'p99':>6} {'penetr. mm':>10} {'bones':>5} {'legs off':>8} {'lag s':>6}")
    steps = simulate_frames(source, character, np.arange(frames + 1) / args.fps)
    tic = time.perf_counter()
    for frame, (t, pose, reports) in enumerate(steps):
        elapsed = time.perf_counter() - tic
        if recorder is not None:
            recorder.add(t, pose)
        if reports is None:  # the dressing
            tic = time.perf_counter()
            continue
        totals.append(elapsed)
        penetration = character.max_penetration()
        worst_penetration = max(worst_penetration, penetration)
        positions = character.world_positions()
        if not all(np.all(np.isfinite(p)) for p in positions):
            raise ValueError(f"frame {frame}: non-finite garment positions")
        # issue 11's figures (garment_sim_ros.quality), over every frame, not only the printed ones
        bones, legs_off = sum(r.bones_through for r in reports), sum(r.legs_off for r in reports)
        quality_frames["bones_through_frames"] += bones > 0
        quality_frames["legs_off_frames"] += legs_off > 0
        quality_frames["guard_firings"] += sum(bool(r.recovery) for r in reports)
        if frame % max(1, args.every) == 0 or frame == frames:
            row = {
                "frame": frame, "t": round(t, 4), "substeps": reports[0].substeps,
                "retries": max(r.retries for r in reports),
                "integration_ms": sum(r.integration_s for r in reports) * 1e3,
                "correction_ms": sum(r.correction_s for r in reports) * 1e3,
                "collision_ms": sum(r.collision_s for r in reports) * 1e3,
                "max_stretch": max(r.max_stretch for r in reports),
                "max_penetration_m": penetration, "lag_s": reports[0].lag_s,
                "stretch_p99": max(max(r.structural_stretch_p99, r.shear_stretch_p99) for r in reports),
                "bones_through": bones, "legs_off": legs_off, "guard": sum(bool(r.recovery) for r in reports),
            }
            if args.json:
                print(json.dumps(row))
            else:
                print(f"{frame:>6} {t:>7.3f} {row['substeps']:>8} {row['integration_ms']:>10.3f} "
                      f"{row['correction_ms']:>11.3f} {row['collision_ms']:>12.3f} {row['max_stretch']:>8.4f} "
                      f"{row['stretch_p99']:>6.3f} {penetration * 1e3:>10.3f} {bones:>5} {legs_off:>8} "
                      f"{row['lag_s']:>6.3f}")
        tic = time.perf_counter()
    summary = {"garments": character.garment_names, "notes": character.notes, "frames": frames,
               "median_frame_ms": float(np.median(totals) * 1e3) if totals else 0.0,
               "max_penetration_m": worst_penetration, **quality_frames,
               "joint_glitches": source.glitches.as_dict()}
    if recorder is not None:
        summary["export"] = str(recorder.save(args.export))
    if args.json:
        print(json.dumps({"summary": summary}))
    else:
        print(f"median frame {summary['median_frame_ms']:.3f} ms, max penetration {worst_penetration * 1e3:.3f} mm, "
              f"limb bones through the cloth in {quality_frames['bones_through_frames']} frames, trouser legs off in "
              f"{quality_frames['legs_off_frames']}, guard fired {quality_frames['guard_firings']} times")
        if recorder is not None:
            print(f"wrote {summary['export']} ({recorder.frames} frames)")
    return 0
