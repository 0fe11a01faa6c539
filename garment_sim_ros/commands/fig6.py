"""``garment-sim fig6``: memo Fig. 6, dynamic against static collision handling at equal error."""

from __future__ import annotations

import argparse
import json

from ..collision import experiments
from .fig5 import positive_floats

HELP = ("memo Fig. 6: for each target error at the 145 mm start distance of Fig. 5, the largest time step "
        "each method meets it with (at every smaller step too), the compute time to simulate the same "
        "interval, and speedup = static time / dynamic time (the memo reports about 10x).")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per target error line")
    parser.add_argument("--targets", type=positive_floats, default=experiments.FIG6_TARGETS,
                        help="target errors, m, comma-separated (default: %(default)s)")
    parser.add_argument("--distance", type=float, default=experiments.FIG6_DISTANCE,
                        help="start distance, m (default: %(default)s)")
    parser.add_argument("--interval", type=float, default=experiments.FIG6_INTERVAL,
                        help="simulated time each method covers for the timing, s (default: %(default)s)")


def _cells(row: dict, method: str) -> str:
    if row[f"{method}_step_s"] is None:
        return f"{'none':>14} {'':>6} {'':>8}"
    return f"{row[f'{method}_step_s']:14.5f} {row[f'{method}_steps']:6d} {row[f'{method}_time_s'] * 1e6:8.2f}"


def run(args: argparse.Namespace) -> int:
    if not args.distance > 0.0 or not args.interval > 0.0:
        raise SystemExit("garment-sim fig6: --distance and --interval must be > 0 (m, s), "
                         f"got {args.distance}, {args.interval}")
    rows = experiments.fig6(args.distance, args.targets, interval_s=args.interval)
    if args.json:
        for row in rows:
            print(json.dumps(row))
        return 0
    print(f"Fig. 6: start distance {args.distance * 1000:.0f} mm, {args.interval} s simulated per method")
    print("target mm | static step s  steps  time us | dynamic step s  steps  time us | step ratio  speedup")
    for row in rows:
        ratio = "-" if row["step_ratio"] is None else f"{row['step_ratio']:.1f}"
        speedup = "-" if row["speedup"] is None else f"{row['speedup']:.1f}x"
        print(f"{row['target_error_m'] * 1000:9.2f} | {_cells(row, 'static')} | {_cells(row, 'dynamic')} | "
              f"{ratio:>10} {speedup:>8}")
    return 0
