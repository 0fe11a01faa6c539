"""``garment-sim demo``: the node and a walking character in one process, recorded to Rerun."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from ..body.sources import GAITS
from ..cloth.garments import GARMENT_NAMES

HELP = ("Run garment_sim_node and skeleton_player (the procedural walking character, or a BVH clip) in one "
        "process for a while, save the Rerun recording and print a summary: garments, mass points, fps, stage "
        "times, maximum penetration.")

DEFAULT_OUTFIT = "one_piece"


def add_arguments(parser) -> None:
    parser.add_argument("--duration", type=float, default=20.0, help="seconds of dressed walking (default 20)")
    parser.add_argument("--garments", default=DEFAULT_OUTFIT, help=f"comma-separated, of: {', '.join(GARMENT_NAMES)}")
    parser.add_argument("--bvh", default="", help="play this BVH clip instead of the procedural character")
    parser.add_argument("--gait", default="walk", choices=GAITS, help="procedural character's gait")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed factor (2, 3 to stress the solver)")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution factor")
    parser.add_argument("--rrd", default="out/demo.rrd", help="where to save the Rerun recording")
    parser.add_argument("--rate", type=float, default=60.0, help="the node's frame rate, Hz")
    parser.add_argument("--rerun-every-n", type=int, default=1,
                        help="log the 3D data of every n-th frame to the recording (default 1: every frame)")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run(args) -> int:
    from ..commands.simulate import parse_garments
    from ..runtime.settings import check_value

    garments = parse_garments(args.garments)
    if not args.duration > 0:
        raise ValueError(f"--duration must be > 0, got {args.duration}")
    check_value("rerun_every_n", args.rerun_every_n)  # a bad value: a message naming the range
    if args.bvh and not Path(args.bvh).is_file():
        raise ValueError(f"--bvh: no such file {args.bvh!r}")
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")  # a demo talks to itself only
    Path(args.rrd).parent.mkdir(parents=True, exist_ok=True)

    from ..ros.in_process import node_and_player
    from ..runtime.character_loop import Status

    player_parameters = {"bvh": args.bvh, "gait": args.gait, "speed": float(args.speed), "loop": True}
    node_parameters = {"garments": garments, "resolution": float(args.resolution), "rate_hz": float(args.rate),
                       "rerun_sink": "save", "rerun_path": str(args.rrd), "rerun_every_n": args.rerun_every_n}
    windows: list[dict[str, float]] = []
    with node_and_player(node_parameters, player_parameters) as (executor, node):
        wearer = "the clip " + args.bvh if args.bvh else "a procedural " + args.gait
        _progress(f"demo: {', '.join(garments)} on {wearer}; dressing...")
        start = time.monotonic()
        running_since = None
        seen = None
        while True:
            executor.spin_once(timeout_sec=0.05)
            now = time.monotonic()
            if running_since is None:
                if node.loop.status in (Status.RUNNING, Status.BEHIND):  # dressed
                    running_since = now
                    _progress(f"demo: dressed in {now - start:.1f} s, walking for {args.duration:g} s")
                elif now - start > 60.0:
                    raise RuntimeError("the character was not dressed within 60 s: "
                                       f"{node.loop.status} {node.loop.detail}")
                continue
            if node.last_diagnostics is not seen and node.last_diagnostics:
                seen = node.last_diagnostics
                figures = {k: float(v) for k, v in seen.items() if _is_number(v)}
                windows.append(figures)
                _progress(f"demo: t={now - running_since:5.1f} s  fps {figures.get('fps', 0):5.1f}  "
                          f"frame {figures.get('tick_ms', 0):6.2f} ms  "
                          f"penetration {figures.get('max_penetration_mm', 0):.3f} mm")
            if now - running_since >= args.duration:
                break
        summary = _summary(node, windows, args.rrd)
    if args.json:
        print(json.dumps(summary))
    else:
        _print_table(summary)
    return 0


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _summary(node, windows: list[dict], rrd: str) -> dict:
    steady = windows[1:] or windows  # the first window holds the dressing
    mean = lambda key: sum(w.get(key, 0.0) for w in steady) / max(len(steady), 1)  # noqa: E731
    return {
        "garments": [{"name": s.model.name, "mass_points": s.model.num_points} for s in node.loop.character.solvers],
        "volumes": len(node.loop.character.body.volumes),
        "fps": mean("fps"),
        "frames": node.stats.total_frames,
        "tick_ms": mean("tick_ms"),
        "integration_ms": mean("integration_ms"),
        "correction_ms": mean("correction_ms"),
        "collision_ms": mean("collision_ms"),
        "publish_ms": mean("publish_ms"),
        "substeps": mean("substeps"),
        "lag_s": max((w.get("lag_s", 0.0) for w in windows), default=0.0),
        "max_penetration_m": max((w.get("max_penetration_mm", 0.0) for w in windows), default=0.0) * 1e-3,
        "max_stretch": max((w.get("max_stretch", 0.0) for w in steady), default=0.0),
        "rrd": str(rrd),
    }


def _print_table(summary: dict) -> None:
    print()
    print(f"{'garment':<12} {'mass points':>11}")
    for g in summary["garments"]:
        print(f"{g['name']:<12} {g['mass_points']:>11}")
    print(f"\n{summary['volumes']} body volumes, {summary['frames']} frames at {summary['fps']:.1f} fps "
          f"({summary['substeps']:.1f} substeps per frame), garment lag {summary['lag_s']:.3f} s")
    print(f"per frame: integration {summary['integration_ms']:.2f} ms, length correction "
          f"{summary['correction_ms']:.2f} ms, collision {summary['collision_ms']:.2f} ms, publish "
          f"{summary['publish_ms']:.2f} ms; whole tick {summary['tick_ms']:.2f} ms")
    print(f"max penetration {summary['max_penetration_m'] * 1e3:.3f} mm, max spring stretch "
          f"{summary['max_stretch']:.3f} x rest")
    print(f"\nRerun recording: {summary['rrd']}  (open it with: .venv/bin/rerun {summary['rrd']})")
