"""``garment-sim evaluate``: do the garments stay on real motion? Issue 11's figures and targets.

One run per clip x garment x playback speed x frame rate: the clip is played once (no loop)
at that speed, sampled at that frame rate, and drives ``DressedCharacter`` exactly as
``garment-sim simulate`` does (``commands.simulate.simulate_frames``); the figures
(``garment_sim_ros.quality``, filled into every ``FrameReport``) are gathered from the first
frame after dressing to the clip's end (or ``--duration``) and judged against
``quality.TARGETS``. Exit status: 0 when every run passes, 1 when one fails, 2 on bad input.

An outfit is one run: ``--garments pants+long_skirt,one_piece+pants`` is two runs, each of two garments
worn together (``+`` joins the garments of an outfit, ``,`` separates runs). Its row holds the outfit's
figures (a frame counts when any garment fails it), ``layer_crossing_frames`` / ``layer_crossings_max``
(outer garments' edges through an inner garment's triangles, target (f)) and ``layers``, each garment's
own figures.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..cloth.garments import GARMENT_NAMES
from ..params import PARAM_OPTION_HELP, PRESETS, parse_params, preset
from ..quality import TARGETS
from .simulate import DECIMATE_HELP, GARMENTS_HELP

HELP = ("Play BVH clips once through on the dressed character, each garment at each playback speed and frame "
        "rate, and judge how well the garments stay on: limb bones through the cloth, trouser legs off their "
        "leg, free points inside the body, stretch, guard firings; one row per run and a summary.")
TARGET_NAMES = {"b": "bones", "c": "legs", "a": "depth", "d": "stretch", "e": "guard",  # issue 11's letters
                "f": "layers"}  # issue 13's: an outer garment through an inner one


@dataclass(frozen=True)
class Run:
    """One evaluation run."""

    clip: str  # BVH file
    garment: str  # a built-in's name, a spec file or a spec's name in config/garments/; an outfit joins them by +
    speed: float  # playback speed, x
    fps: float  # frame rate of the run, Hz
    duration: float | None = None  # body seconds after dressing at most (None: to the clip's end)
    preset: str = "si"
    resolution: float = 1.0
    decimate: int | None = None  # a mesh file's vertex budget (--decimate)
    forearms: bool = True  # the body's forearm volumes (``make_character``); False: the memo's 10 volumes
    params: tuple[tuple[str, object], ...] = ()  # (name, value) changes to the preset (--param)
    nudge: int = 0  # seed of the start's nudge (``nudge_free_points``); 0: none (--nudges)


# The run's free points are moved this far (m) after dressing, each in a seeded random direction (``--nudges``):
# a thousandth of the depth tolerance, far below anything visible. The cloth on the acrobatic clips is chaotic (a
# pinch decides which side a fold goes): a row that passes or fails with one nudge and not another is decided by its
# trajectory, not by the method (docs/real_motion.md, "Two rules on by default, judged over nudged starts").
NUDGE_M = 1e-6


def nudge_free_points(character, seed: int) -> None:
    """Move every free point of ``character``'s garments by ``NUDGE_M`` in a random direction drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    for solver in character.solvers:
        free = solver.constants.inv_mass > 0
        step = rng.normal(size=solver.state.positions.shape)
        step *= NUDGE_M / np.linalg.norm(step, axis=1, keepdims=True)
        solver.state.positions[free] += step[free]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("clips", nargs="+", metavar="CLIP.bvh", help="BVH clips to play")
    parser.add_argument("--garments", default="all",
                        help=f"{GARMENTS_HELP}, one run each; or all (the built-ins); garments joined by + are "
                             "one run of an outfit worn together (pants+long_skirt)")
    parser.add_argument("--speeds", default="1", help="comma-separated playback speeds (default 1)")
    parser.add_argument("--fps", default="60", help="comma-separated frame rates, Hz (default 60)")
    parser.add_argument("--duration", type=float, default=None,
                        help="play at most this many seconds of each clip after dressing (default: all of it)")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel processes (default 1)")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution factor")
    parser.add_argument("--decimate", type=int, default=None, metavar="VERTICES", help=DECIMATE_HELP)
    parser.add_argument("--preset", default="si", choices=sorted(PRESETS), help="parameter preset")
    parser.add_argument("--no-forearms", action="store_true",
                        help="the memo's 10 volumes for the skirts and trousers (default: plus the forearms)")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help=f"change a solver parameter of the preset for every run ({PARAM_OPTION_HELP})")
    parser.add_argument("--nudges", default="0", metavar="SEEDS",
                        help="comma-separated seeds, one run each: every free point moved 1 um in a random direction "
                             "after dressing (0: not moved; default 0); the summary says which rows pass with every "
                             "seed and which with only some (the cloth is chaotic on acrobatic clips)")
    parser.add_argument("--json", action="store_true", help="one JSON object per run, then a summary object")


def _numbers(option: str, text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"{option}: expected comma-separated numbers, got {text!r}") from None
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"{option}: every value must be a number > 0, got {text!r}")
    return values


def _seeds(text: str) -> list[int]:
    try:
        seeds = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"--nudges: expected comma-separated whole numbers, got {text!r}") from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) < len(seeds):
        raise ValueError(f"--nudges: expected distinct seeds >= 0, got {text!r}")
    return seeds


def plan(args) -> list[Run]:
    """The runs the arguments ask for, clip by clip, then garment (or outfit), speed, frame rate, nudge."""
    from .simulate import parse_outfits

    garments = (list(GARMENT_NAMES) if args.garments.strip() == "all"
                else ["+".join(outfit) for outfit in parse_outfits(args.garments)])
    speeds, rates = _numbers("--speeds", args.speeds), _numbers("--fps", args.fps)
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise ValueError(f"--duration must be > 0, got {args.duration}")
    if args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    for clip in args.clips:
        if not Path(clip).is_file():
            raise ValueError(f"no such clip: {clip}")
    changes = parse_params(args.param, args.preset)
    seeds = _seeds(args.nudges)
    return [Run(clip, garment, speed, fps, args.duration, args.preset, args.resolution, args.decimate,
                not args.no_forearms, changes, seed)
            for clip in args.clips for garment in garments for speed in speeds for fps in rates for seed in seeds]


def evaluate_run(run: Run, after_dressing: Callable | None = None) -> dict:
    """Play ``run`` and return its row, over the frames after dressing:

    ``clip`` (file stem), ``garment`` (an outfit's names joined by +), ``speed`` (x), ``fps`` (Hz), ``nudge``
    (the seed of the start's nudge, 0: none), ``frames``;
    ``bones_frames`` (frames with a limb bone through the cloth) and ``bones_max`` (most bones at once);
    ``limb_tubes`` (the garment's trouser legs) and ``legs_off_frames``; ``deep_frames`` / ``deep_share``
    (frames with a free point deeper than ``Targets.depth_tolerance_m``) and ``max_depth_mm``, depth measured
    against the volumes as contact planes press them where two meet, and ``pressed_mm``, the deepest overlap
    of two volumes so pressed away (``collision.contact_planes``; not a target: how much flesh gave way);
    ``surface_depth_mm``, the deepest triangle centre inside a volume (``quality.surface_depth``; not a target:
    the body bulging through the cloth between points that are outside);
    ``structural_stretch_p99`` / ``shear_stretch_p99`` (the worst frame's 99th percentile of length /
    rest length) and ``..._max`` (the longest spring); ``guard_firings`` (frames) and ``carried_frames`` (frames
    a garment was carried rigidly after a runaway, ``DressedCharacter._recover``), ``retried_frames`` (frames run
    again with more substeps, ``frame_retries``) and ``replayed_frames`` (frames whose retries left them damaged
    run again with the frames before them, ``replay_frames``); not targets: what the figures cost;
    ``joint_glitches`` and ``joint_glitches_text``, the clip's joint glitches replaced on load (``body.glitches``);
    ``targets`` (``quality.Targets.judge``), ``passed`` and ``wall_s``. An outfit's frame counts when any
    of its garments fails it; it adds ``layer_crossing_frames`` (frames with an outer garment's edge through
    an inner garment's triangle), ``layer_crossings_max`` (most such edges at once) and ``layers``: per
    garment, inner first, its own figures (the keys above from ``bones_frames`` to ``replayed_frames``).
    ``after_dressing(character)`` is called once the garments are on, after the nudge (a test moves the cloth
    there)."""
    from ..body.sources import bvh_source
    from ..dressing import make_character
    from .simulate import simulate_frames

    tic = time.perf_counter()
    params = preset(run.preset).replace(**dict(run.params))
    source = bvh_source(run.clip, loop=False, speed=run.speed, params=params)
    character = make_character(source.rest_pose, source.joint_map, run.garment.split("+"), params,
                               run.resolution, decimate_to=run.decimate, motion=source.fit_poses(),
                               forearms=run.forearms)
    seconds = source.duration if run.duration is None else min(source.duration, run.duration)
    frames = int(math.floor(seconds * run.fps + 1e-9))
    if frames < 1:
        raise ValueError(f"{run.clip}: {seconds:.4f} s at {run.speed:g}x is shorter than one frame at {run.fps:g} fps")
    worn = len(character.solvers)
    depth, bones = np.zeros((frames, worn)), np.zeros((frames, worn), dtype=np.int64)
    legs_off, guard = np.zeros((frames, worn), dtype=np.int64), np.zeros((frames, worn), dtype=bool)
    carried = np.zeros((frames, worn), dtype=bool)
    retried = np.zeros((frames, worn), dtype=bool)  # frames run again with more substeps (``frame_retries``)
    replayed = np.zeros((frames, worn), dtype=bool)  # frames run again with those before them (``replay_frames``)
    crossings = np.zeros((frames, worn), dtype=np.int64)
    stretch = np.zeros((frames, worn, 4))  # structural p99, max, shear p99, max
    pressed = np.zeros((frames, worn))  # m, the deepest overlap of two volumes pressed onto a contact plane
    surface = np.zeros((frames, worn))  # m, the deepest triangle centre inside a volume
    steps = simulate_frames(source, character, np.arange(frames + 1) / run.fps)
    for k, (_, _, reports) in enumerate(steps):
        if reports is None:  # the dressing
            if run.nudge:
                nudge_free_points(character, run.nudge)
            if after_dressing is not None:
                after_dressing(character)
            continue
        for g, report in enumerate(reports):
            depth[k - 1, g], bones[k - 1, g], legs_off[k - 1, g] = (report.max_depth_m, report.bones_through,
                                                                    report.legs_off)
            guard[k - 1, g], crossings[k - 1, g] = bool(report.recovery), report.layer_crossings
            carried[k - 1, g] = report.carried
            retried[k - 1, g], replayed[k - 1, g] = report.retries > 0, report.replays > 0
            pressed[k - 1, g] = report.pressed_depth_m
            surface[k - 1, g] = report.surface_depth_m
            stretch[k - 1, g] = (report.structural_stretch_p99, report.structural_stretch_max,
                                 report.shear_stretch_p99, report.shear_stretch_max)

    def figures(garments) -> dict:
        """The figures of the garments (columns) ``garments``: a frame counts when any of them fails it."""
        deep = np.count_nonzero(np.any(depth[:, garments] > TARGETS.depth_tolerance_m, axis=1))
        worst = stretch[:, garments].max(axis=(0, 1))
        return {
            "bones_frames": int(np.count_nonzero(bones[:, garments].sum(axis=1))),
            "bones_max": int(bones[:, garments].sum(axis=1).max()),
            "limb_tubes": sum(len(character.solvers[g].model.limb_tubes) for g in garments),  # trouser legs
            "legs_off_frames": int(np.count_nonzero(legs_off[:, garments].sum(axis=1))),
            "deep_frames": int(deep), "deep_share": float(deep / frames),
            "max_depth_mm": float(depth[:, garments].max() * 1e3),
            "pressed_mm": float(pressed[:, garments].max() * 1e3),
            "surface_depth_mm": float(surface[:, garments].max() * 1e3),
            "structural_stretch_p99": float(worst[0]), "structural_stretch_max": float(worst[1]),
            "shear_stretch_p99": float(worst[2]), "shear_stretch_max": float(worst[3]),
            "guard_firings": int(np.count_nonzero(np.any(guard[:, garments], axis=1))),
            "carried_frames": int(np.count_nonzero(np.any(carried[:, garments], axis=1))),
            "retried_frames": int(np.count_nonzero(np.any(retried[:, garments], axis=1))),
            "replayed_frames": int(np.count_nonzero(np.any(replayed[:, garments], axis=1))),
        }

    row = {"clip": Path(run.clip).stem, "garment": "+".join(character.garment_names), "speed": run.speed,
           "fps": run.fps, "nudge": run.nudge, "frames": frames, **figures(list(range(worn))),
           "joint_glitches": source.glitches.total, "joint_glitches_text": source.glitches.summary()}
    if worn > 1:
        row["layer_crossing_frames"] = int(np.count_nonzero(crossings.sum(axis=1)))
        row["layer_crossings_max"] = int(crossings.sum(axis=1).max())
        row["layers"] = [{"garment": character.garment_names[g], **figures([g])} for g in character.layer_order]
    row["targets"] = TARGETS.judge(row)
    row["passed"] = all(v is not False for v in row["targets"].values())
    row["wall_s"] = round(time.perf_counter() - tic, 2)  # for the reader only; nothing is judged on it
    return row


def _worker_init(threads: int) -> None:
    from ..benchmarking import set_threads

    set_threads(threads)  # the processes share the cores: numba's parallel kernels would oversubscribe


def evaluate_all(runs: list[Run], jobs: int = 1, on_row: Callable[[int, dict], None] | None = None) -> list[dict]:
    """Rows of ``runs`` in order; ``jobs`` > 1 spreads them over that many processes."""
    rows = []
    if jobs == 1 or len(runs) == 1:
        iterator = map(evaluate_run, runs)
        pool = None
    else:
        import multiprocessing

        # spawn: numba's threading layer is not safe across fork
        pool = multiprocessing.get_context("spawn").Pool(min(jobs, len(runs)), _worker_init, (1,))
        iterator = pool.imap(evaluate_run, runs)
    try:
        for k, row in enumerate(iterator):
            rows.append(row)
            if on_row is not None:
                on_row(k, row)
    finally:
        if pool is not None:
            pool.terminate()
    return rows


def _counts(rows: list[dict]) -> dict:
    """Per target (the issue's letter): how many of ``rows`` it was asked of and passed."""
    targets = {}
    for key, name in TARGET_NAMES.items():
        asked = [r["targets"][key] for r in rows if r["targets"][key] is not None]
        targets[key] = {"name": name, "passed": sum(asked), "asked": len(asked)}
    return targets


def summarize(rows: list[dict]) -> dict:
    """Runs passed, and per target (the issue's letter) how many runs it was asked of and passed. With more than
    one nudge seed, ``nudges``: the seeds, runs passed per seed, and over the rows (clip x garment x speed x frame
    rate) how many pass with every seed and with some, in all and per target."""
    summary = {"runs": len(rows), "passed": sum(r["passed"] for r in rows), "targets": _counts(rows)}
    seeds = sorted({r["nudge"] for r in rows})
    if len(seeds) > 1:
        groups: dict[tuple, list[dict]] = {}
        for r in rows:
            groups.setdefault((r["clip"], r["garment"], r["speed"], r["fps"]), []).append(r)

        def spread(ok, asked=lambda r: True) -> dict:
            judged = [g for g in groups.values() if asked(g[0])]
            return {"every": sum(all(ok(r) for r in g) for g in judged),
                    "some": sum(any(ok(r) for r in g) for g in judged), "asked": len(judged)}

        summary["nudges"] = {
            "seeds": seeds, "rows": len(groups),
            "passed_by_seed": [sum(r["passed"] for r in rows if r["nudge"] == s) for s in seeds],
            "passed": spread(lambda r: r["passed"]),
            "targets": {k: spread(lambda r, k=k: r["targets"][k], lambda r, k=k: r["targets"][k] is not None)
                        for k in TARGET_NAMES},
        }
    return summary


def _verdict(row: dict) -> str:
    failed = [TARGET_NAMES[k] for k, ok in row["targets"].items() if ok is False]
    return "PASS" if not failed else "FAIL " + ",".join(failed)


HEADER = (f"{'clip':<40} {'garment':<16} {'speed':>5} {'fps':>4} {'frames':>6}  {'bones frm/max':>13}  "
          f"{'legs off':>8}  {'>1mm %':>6} {'max mm':>7} {'surf mm':>7} {'pressed':>7}  {'struct p99/max':>14}  "
          f"{'shear p99/max':>13}  {'guard':>5}  {'layers frm/max':>14}  result")


def _figures_text(row: dict) -> str:
    legs = f"{row['legs_off_frames']}" if row["limb_tubes"] else "-"
    return (f"{row['bones_frames']:>9}/{row['bones_max']:<3}  {legs:>8}  {100 * row['deep_share']:>6.1f} "
            f"{row['max_depth_mm']:>7.1f} {row['surface_depth_mm']:>7.1f} {row['pressed_mm']:>7.1f}  "
            f"{row['structural_stretch_p99']:>6.2f}/{row['structural_stretch_max']:<7.2f}"
            f"  {row['shear_stretch_p99']:>5.2f}/{row['shear_stretch_max']:<7.2f}  {row['guard_firings']:>5}")


def format_row(row: dict) -> str:
    """A run's line; an outfit's is followed by one line per garment, inner first (its own figures)."""
    layers = (f"{row['layer_crossing_frames']:>10}/{row['layer_crossings_max']:<3}" if "layers" in row
              else f"{'-':>14}")
    lines = [f"{row['clip'][:40]:<40} {row['garment'][:16]:<16} {row['speed']:>4g}x {row['fps']:>4g} "
             f"{row['frames']:>6}  {_figures_text(row)}  {layers}  {_verdict(row)}"]
    for layer in row.get("layers", ()):
        lines.append(f"{'':<40}   {layer['garment'][:14]:<14} {'':>5} {'':>4} {'':>6}  {_figures_text(layer)}")
    return "\n".join(lines)


def format_summary(summary: dict) -> str:
    parts = [f"({k}) {t['name']} {t['passed']}/{t['asked']}" for k, t in summary["targets"].items()]
    text = f"passed {summary['passed']}/{summary['runs']} runs; " + ", ".join(parts)
    if "nudges" in summary:
        nudges = summary["nudges"]
        seeds = ",".join(str(s) for s in nudges["seeds"])
        per_seed = ", ".join(str(n) for n in nudges["passed_by_seed"])
        targets = ", ".join(f"({k}) {s['every']}-{s['some']}/{s['asked']}" for k, s in nudges["targets"].items()
                            if s["asked"])
        text += (f"\nnudges {seeds}: passed {per_seed} of {nudges['rows']} runs each; rows passing with every seed - "
                 f"with some: {nudges['passed']['every']}-{nudges['passed']['some']}/{nudges['rows']}; {targets}")
    return text


def run(args) -> int:
    from ..benchmarking import progress

    runs = plan(args)
    progress(f"evaluate: {len(runs)} runs ({len(args.clips)} clips) on {min(args.jobs, len(runs))} process(es)")
    if not args.json:
        print(HEADER, flush=True)
    start = time.perf_counter()

    def on_row(k: int, row: dict) -> None:
        progress(f"evaluate: [{k + 1}/{len(runs)}] {row['clip']} {row['garment']} {row['speed']:g}x "
                 f"{row['fps']:g} fps: {_verdict(row)} "
                 f"({row['wall_s']:.1f} s; {time.perf_counter() - start:.0f} s so far)")
        print(json.dumps(row) if args.json else format_row(row), flush=True)

    rows = evaluate_all(runs, args.jobs, on_row)
    summary = summarize(rows)
    if not args.json:  # the clips' input repairs, once per clip
        for clip, text in dict((row["clip"], row["joint_glitches_text"]) for row in rows).items():
            print(f"{clip}: {text}")
    print(json.dumps({"summary": summary}) if args.json else format_summary(summary))
    return 0 if summary["passed"] == summary["runs"] else 1

