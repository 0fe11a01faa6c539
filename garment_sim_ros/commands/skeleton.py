"""``garment-sim skeleton FILE.bvh``: the joint map, fitted volumes and clip info of a BVH clip."""

from __future__ import annotations

import json
import sys

import numpy as np

from ..body.bvh import UNIT_SCALES, BvhError, Clip, load_bvh
from ..body.canonical import canonical_pose
from ..body.fitting import Body, fit_body
from ..body.joint_map import JointMapError, auto_joint_map, load_joint_map
from ..body.overrides import BodyConfigError, load_body_overrides
from ..collision.volumes import KIND_NAMES
from ..params import DEFAULT_PARAMS, PARAMETER_TABLE, ParameterError

HELP = ("Read a BVH clip (converted to REP-103 z-up metres) and print the detected joint map, the body "
        "volumes fitted to its skeleton in the canonical standing pose and to its first pose (trunk volumes an arm "
        "bone comes near are narrowed; a trunk volume spanning several spine bones is aimed at the joint at its top), "
        "the measurements estimated and clip info "
        "(frames, fps, duration, mean horizontal pelvis speed) with the joint glitches replaced on reading.")

_KIND_LABELS = {code: label for label, code in KIND_NAMES.items()}


def add_arguments(parser) -> None:
    parser.add_argument("bvh", metavar="FILE.bvh", help="BVH clip to read")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--units", default="auto",
                        help=f"file length unit: auto (from the skeleton's height), {', '.join(UNIT_SCALES)}, "
                             "or metres per unit")
    parser.add_argument("--keep-first-frame", action="store_true",
                        help="keep frame 0 even when it is a reference pose (dropped by default)")
    parser.add_argument("--max-joint-speed", type=float, default=DEFAULT_PARAMS.max_joint_speed, metavar="DEG_S",
                        help="joint glitch filter: a joint turning faster than this jumped (deg/s; 0: off; "
                             f"default {DEFAULT_PARAMS.max_joint_speed:g})")
    parser.add_argument("--max-glitch-time", type=float, default=DEFAULT_PARAMS.max_glitch_time, metavar="S",
                        help="a jump back within this is a glitch, replaced; longer is motion, kept "
                             f"(s; default {DEFAULT_PARAMS.max_glitch_time:g})")
    parser.add_argument("--joint-map", metavar="YAML", help="joint map file instead of the automatic mapper")
    parser.add_argument("--detailed", action="store_true", help="fit the 15-volume body (neck, forearms, feet)")
    parser.add_argument("--body-config", metavar="YAML", help="volume overrides (default: config/body.yaml)")


def _units(text: str) -> str | float:
    try:
        return float(text)
    except ValueError:
        return text


def root_speed(clip: Clip, pelvis: str) -> float:
    """Mean horizontal speed of the pelvis over the clip, m/s (path length / duration)."""
    if clip.frames < 2:
        return 0.0
    path = clip.joint_trajectory(pelvis)[:, :2]
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum() / clip.duration)


def summary(clip: Clip, body: Body) -> dict:
    aimed_at = {aim.frame: aim.target for aim in body.volumes.aims}
    return {
        "file": clip.path,
        "joint_map": dict(body.joint_map),
        "volumes": [
            {"name": v.name, "kind": _KIND_LABELS[v.kind], "frame": v.frame,
             "radii": [round(r, 4) for r in v.radii],
             "cut": [round(c, 4) if np.isfinite(c) else None for c in v.cut],
             "offset_position": [round(c, 4) for c in v.offset_position],
             "aimed_at": aimed_at.get(v.frame)}
            for v in body.volumes.volumes
        ],
        "frames": clip.frames,
        "fps": round(clip.fps, 4),
        "duration_s": round(clip.duration, 4),
        "root_speed_mps": round(root_speed(clip, body.joint_map["pelvis"]), 4),
        "units_scale": clip.units_scale,
        "dropped_reference_frame": clip.dropped_reference_frame,
        "joint_glitches": clip.glitches.as_dict(),
        "joint_glitches_text": clip.glitches.summary(limit=len(clip.glitches.counts)),
        "estimated": list(body.estimated),
        "narrowed": {name: round(scale, 4) for name, scale in body.narrowed.items()},
        "measurements": {k: round(float(v), 4) for k, v in vars(body.measurements).items()},
    }


def _print_text(info: dict) -> None:
    print(f"{info['file']}: {info['frames']} frames at {info['fps']:g} fps, {info['duration_s']:.2f} s, "
          f"pelvis {info['root_speed_mps']:.2f} m/s, {info['units_scale']:g} m per file unit")
    if info["dropped_reference_frame"]:
        print("frame 0 is a reference pose the motion jumps away from: not used (--keep-first-frame keeps it)")
    print(f"joint glitches (a joint's rotation leaving faster than --max-joint-speed and back within "
          f"--max-glitch-time; file frames): {info['joint_glitches_text']}")
    print("estimated (out of human range, replaced by an estimate from the height): "
          + (", ".join(info["estimated"]) or "nothing"))
    print("narrowed (an arm bone is near or in it in the first pose; cross-section scaled): "
          + (", ".join(f"{name} x{scale:.3f}" for name, scale in info["narrowed"].items()) or "nothing"))
    print("joint map:")
    for role, frame in info["joint_map"].items():
        print(f"  {role:<16} {frame}")
    print("volumes (radii in cm):")
    for v in info["volumes"]:
        radii = " ".join(f"{100 * r:5.1f}" for r in v["radii"])
        aim = f"  aimed at {v['aimed_at']}" if v["aimed_at"] else ""
        print(f"  {v['name']:<16} {v['kind']:<9} on {v['frame']:<16} {radii}{aim}")
    print("measurements (m, root frame):")
    for key, value in info["measurements"].items():
        print(f"  {key:<13} {value:7.3f}")


def run(args) -> int:
    try:
        clip = load_bvh(args.bvh, units=_units(args.units), keep_first_frame=args.keep_first_frame,
                        max_joint_speed=PARAMETER_TABLE["max_joint_speed"].check(args.max_joint_speed),
                        max_glitch_time=PARAMETER_TABLE["max_glitch_time"].check(args.max_glitch_time))
        first = clip.pose(0)
        if args.joint_map:
            joint_map = load_joint_map(args.joint_map, clip.skeleton)
        else:
            joint_map = auto_joint_map(clip.skeleton, first.positions)
        body = fit_body(canonical_pose(first, joint_map), joint_map, detailed=args.detailed,
                        overrides=load_body_overrides(args.body_config),
                        motion=[first])
        info = summary(clip, body)
    except (BvhError, JointMapError, BodyConfigError, ParameterError, FileNotFoundError, ValueError) as err:
        print(f"garment-sim skeleton: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(info))
    else:
        _print_text(info)
    return 0
