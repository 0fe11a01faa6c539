"""``garment-sim scale``: how the cost per frame grows with the number of mass points.

The one-piece dress (15 volumes) under the Table 1 protocol (``garment-sim table1``: memo preset,
6 substeps in a 0.04 s frame, 2 correction iterations) at resolutions chosen for target mass-point
counts from ~500 to 50 000 (the count grows with the resolution squared; the row gives the actual
count). Per size the same per-stage medians as ``table1`` plus ``particle_substeps_per_s`` =
mass points x substeps per frame / the step's wall time (collision included, publish and Rerun not).
Big sizes run fewer frames (``--frames-large``) so the default run stays within a few minutes.
``--threads`` sets numba's thread count, for the 1 against 2 threads comparison.
"""

from __future__ import annotations

import argparse
import json
import math

from ..benchmarking import character_benchmark, load_average, progress, set_threads
from ..cloth.garments import MAX_RESOLUTION, build_garment
from ..params import PRESETS
from .table1 import FRAME_S

HELP = ("Cost per frame against resolution: the one-piece dress under the Table 1 protocol at ~500 to "
        "50 000 mass points; per-stage medians and particle-substeps per second.")

GARMENT = "one_piece"
DEFAULT_POINTS = (500, 2_000, 5_000, 10_000, 20_000, 50_000)
LARGE_POINTS = 10_000  # from this size on, --frames-large frames are timed


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per size instead of a table")
    parser.add_argument("--points", type=int, nargs="+", default=list(DEFAULT_POINTS), metavar="N",
                        help="target mass-point counts (default: %(default)s)")
    parser.add_argument("--frames", type=int, default=100, help="timed frames per small size (default: 100)")
    parser.add_argument("--frames-large", type=int, default=30,
                        help=f"timed frames from {LARGE_POINTS} mass points on (default: 30)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed frames before them (default: 5)")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")
    parser.add_argument("--no-rerun", action="store_true", help="skip Rerun logging (rerun_ms is null)")


def resolution_for(points: int) -> float:
    """The garment resolution whose dress has about ``points`` mass points (count ~ resolution^2)."""
    base = len(build_garment(GARMENT).vertices)
    resolution = round(math.sqrt(points / base), 3)
    if not 0.25 <= resolution <= MAX_RESOLUTION:
        low, high = math.ceil(0.25**2 * base), int(MAX_RESOLUTION**2 * base)
        raise ValueError(f"--points {points}: allowed {low}..{high} mass points for the {GARMENT} template")
    return resolution


def run(args: argparse.Namespace) -> int:
    resolutions = [resolution_for(points) for points in args.points]
    threads = set_threads(args.threads)
    if not args.json:
        print(f"{GARMENT} under the Table 1 protocol (memo preset, 6 substeps per {FRAME_S} s frame); "
              f"{threads} numba thread(s), load {load_average()}")
        print(f"{'points':>7} {'res.':>6} {'frames':>6} {'integr.':>8} {'collis.':>8} {'step':>8} {'publish':>8} "
              f"{'rerun':>8} {'total':>8} {'fps':>7} {'Mpart-sub/s':>11} {'penetr.':>8}")
        print(f"{'':>7} {'':>6} {'':>6} {'ms':>8} {'ms':>8} {'ms':>8} {'ms':>8} {'ms':>8} {'ms':>8} {'':>7} "
              f"{'':>11} {'mm':>8}")
    for points, resolution in zip(args.points, resolutions):
        frames = args.frames if points < LARGE_POINTS else args.frames_large
        progress(f"scale: ~{points} mass points (resolution {resolution}) ...")
        row = character_benchmark(GARMENT, PRESETS["memo"], FRAME_S, frames, args.warmup,
                                  resolution=resolution, rerun=not args.no_rerun)
        if args.json:
            print(json.dumps(row), flush=True)
            continue
        rerun_ms = "off" if row["rerun_ms"] is None else f"{row['rerun_ms']:.2f}"
        print(f"{row['mass_points']:>7} {resolution:>6.3f} {frames:>6} {row['integration_ms']:>8.2f} "
              f"{row['collision_ms']:>8.2f} {row['step_ms']:>8.2f} {row['publish_ms']:>8.2f} {rerun_ms:>8} "
              f"{row['total_ms']:>8.2f} {row['fps']:>7.1f} {row['particle_substeps_per_s'] / 1e6:>11.2f} "
              f"{row['max_penetration_m'] * 1e3:>8.3f}", flush=True)
    return 0
