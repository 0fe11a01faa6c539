"""``garment-sim fig5``: memo Fig. 5, the error of the simplified dynamic collision detection."""

from __future__ import annotations

import argparse
import json

from ..collision import experiments

HELP = ("memo Fig. 5: distance between the simplified dynamic method's collision point and the "
        "reference (static handling at a 0.00001 s step), per start distance and time step. The set-up: "
        f"an ellipsoid with radii {experiments.RADII} m (a thigh) rising at {experiments.RISE_SPEED} m/s and "
        "turning 90 deg/s, a point moving at 0.5 m/s tilted 45 deg.")


def positive_floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not values or any(not v > 0.0 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive numbers, got {text!r}")
    return values


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per (distance_m, time_step_s) line")
    parser.add_argument("--distances", type=positive_floats, default=experiments.FIG5_DISTANCES,
                        help="start distances, m, comma-separated (default: %(default)s)")
    parser.add_argument("--steps", type=positive_floats, default=experiments.FIG5_STEPS,
                        help="time steps, s, comma-separated (default: %(default)s)")


def run(args: argparse.Namespace) -> int:
    rows = experiments.fig5(args.distances, args.steps)
    if args.json:
        for row in rows:
            print(json.dumps(row))
        return 0
    print("Fig. 5: worst simplification error over 8 step-grid shifts, mm "
          f"(ellipsoid radii {experiments.RADII} m; reference: static at {experiments.REFERENCE_STEP} s)")
    steps = sorted({row["time_step_s"] for row in rows})
    print("distance mm | " + " ".join(f"h={h:<8g}" for h in steps))
    for distance in sorted({row["distance_m"] for row in rows}):
        errors = {row["time_step_s"]: row["error_m"] for row in rows if row["distance_m"] == distance}
        print(f"{distance * 1000:11.1f} | " + " ".join(f"{errors[h] * 1000:10.3f}" for h in steps))
    return 0
