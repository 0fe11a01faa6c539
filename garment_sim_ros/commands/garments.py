"""``garment-sim garments``: the garment templates and their sizes."""

from __future__ import annotations

import json

from ..cloth.garments import GARMENT_NAMES, MAX_RESOLUTION, build_garment
from ..cloth.model import build_cloth_model

HELP = ("List the garment templates at a resolution: mass points, mesh edges (what the memo counts as "
        "springs), all springs (structural + shear + bend) and triangles, on the standard body.")


def add_arguments(parser) -> None:
    parser.add_argument("--resolution", type=float, default=1.0,
                        help=f"vertex density factor, 0.25..{MAX_RESOLUTION:g} (1 = about the memo's sizes)")
    parser.add_argument("--json", action="store_true", help="one JSON object per garment")


def garment_summary(name: str, resolution: float = 1.0) -> dict:
    model = build_cloth_model(build_garment(name, resolution=resolution))
    counts = model.spring_counts()
    return {
        "name": name,
        "mass_points": model.num_points,
        "edges": int(len(model.edges)),
        "springs": int(len(model.springs)),
        "triangles": int(len(model.triangles)),
        "shear_springs": counts["shear"],
        "bend_springs": counts["bend"],
        "carried_by": list(model.attachment_frames),
        "area_m2": round(float(model.vertex_areas.sum()), 4),
    }


def run(args) -> int:
    rows = [garment_summary(name, args.resolution) for name in GARMENT_NAMES]
    if args.json:
        for row in rows:
            print(json.dumps(row))
        return 0
    print(f"{'garment':<12} {'mass points':>11} {'edges':>6} {'springs':>8} {'triangles':>9}  carried by")
    for r in rows:
        print(f"{r['name']:<12} {r['mass_points']:>11} {r['edges']:>6} {r['springs']:>8} {r['triangles']:>9}  "
              f"{', '.join(r['carried_by'])}")
    return 0
