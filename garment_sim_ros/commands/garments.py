"""``garment-sim garments``: the built-in garments and the garment specs in the search path, and their sizes."""

from __future__ import annotations

import json

from ..body.measurements import STANDARD_BODY
from ..cloth.garments import MAX_RESOLUTION
from ..cloth.model import build_cloth_model
from ..cloth.spec import BUILTIN_SPECS, GarmentSpec, build_mesh, find_specs, load_spec, search_path

HELP = ("List the built-in garments and the garment specs found in the search path (--garment-path, then "
        "config/garments/) at a resolution: mass points, mesh edges (what the memo counts as springs), all "
        "springs (structural + shear + bend) and triangles, on the standard body.")


def add_arguments(parser) -> None:
    parser.add_argument("--resolution", type=float, default=1.0,
                        help=f"vertex density factor of the built-ins, 0.25..{MAX_RESOLUTION:g} "
                             "(1 = about the memo's sizes)")
    parser.add_argument("--garment-path", default="", metavar="DIR[:DIR...]",
                        help="folders searched for garment specs before config/garments/")
    parser.add_argument("--json", action="store_true", help="one JSON object per garment")


def garment_summary(spec: GarmentSpec | str, resolution: float = 1.0) -> dict:
    spec = BUILTIN_SPECS[spec] if isinstance(spec, str) else spec
    model = build_cloth_model(build_mesh(spec, STANDARD_BODY, resolution))
    counts = model.spring_counts()
    return {
        "name": spec.name,
        "source": "built-in" if spec.path is None else str(spec.path),
        "layer": spec.layer,
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
    folders = [p for p in args.garment_path.split(":") if p]
    specs = list(BUILTIN_SPECS.values()) + [load_spec(path) for path in find_specs(folders)]
    rows = [garment_summary(spec, args.resolution) for spec in specs]
    if args.json:
        for row in rows:
            print(json.dumps(row))
        return 0
    print(f"{'garment':<12} {'mass points':>11} {'edges':>6} {'springs':>8} {'triangles':>9} {'layer':>5}  "
          "carried by; source")
    for r in rows:
        print(f"{r['name']:<12} {r['mass_points']:>11} {r['edges']:>6} {r['springs']:>8} {r['triangles']:>9} "
              f"{r['layer']:>5}  {', '.join(r['carried_by'])}; {r['source']}")
    print(f"search path: {', '.join(map(str, search_path(folders)))}")
    return 0
