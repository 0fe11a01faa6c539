"""``garment-sim table1``: the memo's Table 1 protocol, per-stage time per frame for the four garments.

Protocol (memo §7): each garment at its default resolution on the procedural walking
character, 6 substeps per frame, 2 length-correction iterations, the memo's parameter set
(``PRESETS["memo"]``, run as-is: its mass 20, gravity 0.5, spring 10000, ... are in the memo's
own units, and changing any of them would no longer be the memo's experiment). The memo's
"h = 0.04 s" is read as the *frame* time, split into 6 substeps of 0.04/6 s: the stable reading
(0.04 s substeps would simulate 0.24 s per frame, 7x faster than real time at the memo's 31 fps,
and spring 10000 on mass 20 gives k h^2 / m = 0.8 at h = 0.04 s, past the solver's stability
limit of 0.25, so every spring would be capped; at h = 0.04/6 s none is).
The body advances 0.04 s per frame (25 frames per body second), whatever the wall time.
The body is the memo's 10 volumes (no forearms, neck or feet) for the skirts and trousers (every other
command adds the forearms); the one-piece keeps the detailed body its neckline needs.

What each figure is: see ``garment_sim_ros.benchmarking``. The memo's R (rendering in Java3D)
is compared with our publish + Rerun logging, its I with ``integration_ms``, its CH with
``collision_ms``; ``ratio`` = memo total / our total.
"""

from __future__ import annotations

import argparse
import json

from ..benchmarking import character_benchmark, load_average, progress, set_threads
from ..cloth.garments import GARMENT_NAMES
from ..params import PRESETS

HELP = ("memo Table 1: each garment at its default resolution on the walking character, the memo's "
        "parameters (6 substeps in a 0.04 s frame, 2 correction iterations); medians per frame of "
        "integration, collision, MarkerArray building, Rerun logging and the total, against the memo's row.")

FRAME_S = 0.04  # the memo's h, read as the frame time
DEFAULT_FRAMES = 200
DEFAULT_WARMUP = 20

# Memo Table 1 (Pentium III 866 MHz, Java3D): seconds per frame; R render, I integration, CH collision.
MEMO_TABLE1 = {
    "short_skirt": {"mass_points": 343, "springs": 1275, "R": 0.0125, "I": 0.0057, "CH": 0.0141,
                    "total": 0.0323, "fps": 31.0},
    "long_skirt": {"mass_points": 564, "springs": 2147, "R": 0.0128, "I": 0.0122, "CH": 0.0226,
                   "total": 0.0476, "fps": 21.0},
    "pants": {"mass_points": 548, "springs": 2126, "R": 0.0128, "I": 0.0119, "CH": 0.0241,
              "total": 0.0488, "fps": 20.5},
    "one_piece": {"mass_points": 672, "springs": 2571, "R": 0.0133, "I": 0.0161, "CH": 0.0238,
                  "total": 0.0532, "fps": 18.8},
}
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per garment instead of a table")
    parser.add_argument("--frames", type=int, default=DEFAULT_FRAMES,
                        help="timed frames per garment (default: %(default)s)")
    parser.add_argument("--warmup", type=int, default=DEFAULT_WARMUP,
                        help="untimed frames before them (default: %(default)s)")
    parser.add_argument("--garments", default=",".join(GARMENT_NAMES),
                        help="comma-separated subset of the garments (default: all four)")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")
    parser.add_argument("--no-rerun", action="store_true", help="skip Rerun logging (rerun_ms is null)")


def table1_row(garment: str, frames: int, warmup: int, rerun: bool = True) -> dict:
    """One garment's row: our medians, the memo's row (seconds) and memo total / our total."""
    row = character_benchmark(garment, PRESETS["memo"], FRAME_S, frames, warmup, rerun=rerun,
                              forearms=False)
    memo = MEMO_TABLE1[garment]
    row["memo"] = memo
    row["ratio"] = round(memo["total"] * 1e3 / row["total_ms"], 2)
    return row


def run(args: argparse.Namespace) -> int:
    from .simulate import parse_garments

    garments = parse_garments(args.garments)
    threads = set_threads(args.threads)
    if not args.json:
        print(f"memo Table 1 protocol: 6 substeps per {FRAME_S} s frame, 2 correction iterations, memo preset; "
              f"medians of {args.frames} frames after {args.warmup}; {threads} numba thread(s), "
              f"load {load_average()}")
        print(f"{'garment':<12} {'points':>6} {'springs':>7} {'integr.':>8} {'collis.':>8} {'step':>8} "
              f"{'publish':>8} {'rerun':>8} {'total':>8} {'fps':>7} {'penetr.':>8} | {'memo I':>7} {'CH':>6} {'R':>6} "
              f"{'total':>6} {'fps':>5} {'ratio':>6}")
        print(f"{'':<12} {'':>6} {'':>7}" + f" {'ms':>8}" * 6 + f" {'':>7} {'mm':>8} | "
              f"{'ms':>7} {'ms':>6} {'ms':>6} {'ms':>6}")
    for garment in garments:
        progress(f"table1: {garment} ...")
        row = table1_row(garment, args.frames, args.warmup, rerun=not args.no_rerun)
        if args.json:
            print(json.dumps(row), flush=True)
            continue
        memo = row["memo"]
        rerun_ms = "off" if row["rerun_ms"] is None else f"{row['rerun_ms']:.3f}"
        print(f"{garment:<12} {row['mass_points']:>6} {row['springs']:>7} {row['integration_ms']:>8.3f} "
              f"{row['collision_ms']:>8.3f} {row['step_ms']:>8.3f} {row['publish_ms']:>8.3f} {rerun_ms:>8} "
              f"{row['total_ms']:>8.3f} {row['fps']:>7.1f} {row['max_penetration_m'] * 1e3:>8.3f} | "
              f"{memo['I'] * 1e3:>7.1f} {memo['CH'] * 1e3:>6.1f} {memo['R'] * 1e3:>6.1f} {memo['total'] * 1e3:>6.1f} "
              f"{memo['fps']:>5.1f} {row['ratio']:>5.1f}x", flush=True)
    return 0
