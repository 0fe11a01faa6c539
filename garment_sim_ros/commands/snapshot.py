"""``garment-sim snapshot``: PNG pictures of a dressed character, rendered offscreen (no ROS, no display)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..body.sources import GAITS, bvh_source, procedural_source
from ..render import VIEWS, render_character
from .simulate import DECIMATE_HELP, parse_outfits

HELP = ("Render PNG pictures offscreen: the procedural walking character (or a --bvh clip) dressed and "
        "simulated (no ROS) for --time seconds, one panel per outfit side by side (dressed_<clip>.png); with "
        "--volumes-only its collision volumes over the skeleton at --time (volumes_<clip>.png); with "
        "--canonical the volumes and skeleton on the canonical pose the body is fitted and the garments "
        "cut on (canonical_<clip>.png). <clip> is the BVH file's stem, or the gait.")
DEFAULT_OUTFITS = "long_skirt,pants,one_piece"
BODY_INSET_M = 0.004  # dressed pictures: the body drawn this far inside the volumes (see render_character)


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="docs/images", help="folder for the PNG files (default docs/images)")
    parser.add_argument("--garments", default=DEFAULT_OUTFITS,
                        help="comma-separated outfits, one panel each; '+' joins garments worn together, "
                             f"e.g. 'pants+short_skirt' (default {DEFAULT_OUTFITS}); a garment is a built-in, "
                             "a spec file (*.yaml) or a spec's name in config/garments/")
    parser.add_argument("--time", type=float, default=2.0, help="time in the motion the picture shows, s (default 2)")
    parser.add_argument("--view", default="three-quarter", choices=sorted(VIEWS), help="camera direction")
    parser.add_argument("--volumes-only", action="store_true",
                        help="draw the body's collision volumes (see-through) and skeleton, no garments")
    parser.add_argument("--canonical", action="store_true",
                        help="draw the body's volumes and skeleton on the canonical (rest) pose; ignores --time")
    parser.add_argument("--bvh", default=None, help="a BVH clip instead of the procedural character")
    parser.add_argument("--keep-first-frame", action="store_true",
                        help="keep the --bvh clip's frame 0 even when it is a reference pose (dropped by default)")
    parser.add_argument("--gait", default="walk", choices=GAITS, help="procedural character's gait")
    parser.add_argument("--size", default="360x540", help="pixels per panel, WIDTHxHEIGHT (default 360x540)")
    parser.add_argument("--fps", type=float, default=60.0, help="simulation frame rate, Hz (default 60)")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution factor")
    parser.add_argument("--decimate", type=int, default=None, metavar="VERTICES", help=DECIMATE_HELP)


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--size: expected WIDTHxHEIGHT in pixels, e.g. 360x540, got {text!r}") from None
    if not (64 <= width <= 4096 and 64 <= height <= 4096):
        raise ValueError(f"--size: each side must be in [64, 4096] pixels, got {text!r}")
    return width, height


def dressed_at(source, garments: list[str], time_s: float, fps: float, resolution: float,
               decimate_to: int | None = None):
    """Simulate ``garments`` on ``source`` from t = 0 to ``time_s``; returns (character, pose at time_s)."""
    from ..dressing import make_character
    from ..params import preset
    from .simulate import simulate_frames

    character = make_character(source.rest_pose, source.joint_map, garments, preset("si"), resolution,
                               decimate_to=decimate_to, motion=source.fit_poses())
    frames = max(1, math.ceil(time_s * fps))
    for _, pose, _ in simulate_frames(source, character, np.linspace(0.0, time_s, frames + 1)):
        pass
    return character, pose


def snapshot(out: Path, outfits: list[list[str]] | None, time_s: float, view: str, size: tuple[int, int],
             gait: str = "walk", fps: float = 60.0, resolution: float = 1.0, bvh: str | None = None,
             canonical: bool = False, keep_first_frame: bool = False, decimate_to: int | None = None) -> Path:
    """Render and save one PNG of the procedural ``gait`` or the ``bvh`` clip: the outfits side by side
    (``dressed_<clip>.png``), or with ``outfits=None`` the body volumes over the skeleton at ``time_s``
    (``volumes_<clip>.png``), or with ``canonical`` on the rest pose (``canonical_<clip>.png``).
    Returns the file."""
    from PIL import Image, ImageDraw

    from ..body.fitting import fit_body
    from ..rerun_log import garment_meshes

    source = bvh_source(bvh, loop=False, keep_first_frame=keep_first_frame) if bvh else procedural_source(gait)
    clip = Path(bvh).stem if bvh else gait
    if source.duration is not None and time_s > source.duration + 1e-9 and not canonical:
        raise ValueError(f"--time {time_s:g} s is past the end of {bvh} ({source.duration:.3f} s)")
    width, height = size
    panels, labels = [], []
    if canonical or outfits is None:
        pose = source.rest_pose if canonical else source.pose(time_s)
        body = fit_body(source.rest_pose, source.joint_map, detailed=True, motion=source.fit_poses())
        panels.append(render_character(pose, body.volumes, source.joint_map, view=view, width=width, height=height,
                                       volume_alpha=0.55, skeleton=True))
        labels.append(f"{clip}: {len(body.volumes)} body volumes, "
                      + ("canonical pose" if canonical else f"t = {time_s:g} s"))
        path = out / f"{'canonical' if canonical else 'volumes'}_{clip}.png"
    else:
        for garments in outfits:
            character, pose = dressed_at(source, garments, time_s, fps, resolution, decimate_to)
            panels.append(render_character(pose, character.body.volumes, source.joint_map, garment_meshes(character),
                                           view=view, width=width, height=height, body_inset_m=BODY_INSET_M,
                                           press_with=character.solvers[0].collider.press_with))
            points = sum(s.model.num_points for s in character.solvers)
            labels.append(f"{' + '.join(character.garment_names)} ({points} points)")
        labels[0] = f"{clip}, t = {time_s:g} s: {labels[0]}"
        path = out / f"dressed_{clip}.png"
    picture = Image.fromarray(np.concatenate(panels, axis=1))
    draw = ImageDraw.Draw(picture)
    for i, label in enumerate(labels):
        draw.text((i * width + 8, 8), label, fill=(40, 40, 40))
    out.mkdir(parents=True, exist_ok=True)
    picture.save(path, optimize=True)
    return path


def run(args) -> int:
    if not (math.isfinite(args.time) and 0.0 <= args.time <= 60.0):
        raise ValueError(f"--time must be in [0, 60] s, got {args.time}")
    if not (math.isfinite(args.fps) and 10.0 <= args.fps <= 1000.0):
        raise ValueError(f"--fps must be in [10, 1000] Hz, got {args.fps}")
    outfits = None if args.volumes_only or args.canonical else parse_outfits(args.garments)
    path = snapshot(Path(args.out), outfits, args.time, args.view, parse_size(args.size), args.gait, args.fps,
                    args.resolution, args.bvh, args.canonical, args.keep_first_frame, args.decimate)
    print(f"wrote {path} ({path.stat().st_size // 1024} KiB)")
    return 0
