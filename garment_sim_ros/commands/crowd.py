"""``garment-sim crowd``: how many characters one process keeps at 60 fps, and how the cost grows
with their number (offline, no ROS).

The characters are the procedural walker, each at its own phase (``PHASE_S`` apart) and its own
place (``SPACING_M`` apart side by side), each run as the node runs one of its ``frame_prefixes``
(``runtime.crowd.Member``: its /tf transforms into its own ``PoseBuffer`` in one batch per frame,
``CharacterLoop.frame``, its markers), with the node's default parameters. A tick is what the node
does at 60 Hz: every character's input, frame and markers, then one MarkerArray of them all
serialized (handing the bytes to DDS is ``garment-sim publish``'s figure). ``step_ms`` is the
characters' ``CharacterLoop.frame`` (pose sampling, root motion, the solver, the quality meters),
``solver_ms`` the part in the solver's stages (integration, correction, collision: its own timers),
``publish_ms`` the markers, ``measured_max_per_tick`` the most characters whose quality meters ran in
one tick (at the node's 10 Hz, spread: ``runtime.crowd.make_members``). Body time advances
1/60 s per tick with no waiting, so ``tick_ms`` is the compute a 60 fps node needs.

The characters' garments go through the solver one after another: the cloth kernels hold the GIL
and run on one thread, the collision kernels on numba's threads (``--threads``; ``runtime.crowd``).
``--processes P`` splits them over P processes running at once (one node per group of characters,
the way past one process): the row is the slowest process's.

``--json``: one line per count, then a summary: ``characters_at_60fps`` is the largest count timed
whose median tick fits 1/60 s; ``characters_at_60fps_linear`` the count a least-squares line
``tick_ms = fixed_ms + ms_per_character * N`` through the timed counts predicts.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import time

import numpy as np

from ..benchmarking import load_average, progress, set_threads
from ..body.procedural import ProceduralCharacter, walk
from ..runtime.character_loop import Status
from ..runtime.crowd import Member, character_namespace, crowd_markers, make_members
from ..runtime.marker_cdr import serialize_marker_array
from ..runtime.settings import default_values, solver_params
from .simulate import parse_garments

HELP = ("How many characters one process dresses at 60 fps: N walkers through the node's per-character "
        "path (pose buffer, character loop, markers), cost per tick against N.")

RATE_HZ = 60.0
PHASE_S = 0.37  # the walkers' phases apart, s (not a divisor of the gait's period: every one differs)
SPACING_M = 1.5  # the walkers' places apart, side by side, m
DRESS_TIMEOUT_S = 10.0  # body time within which every character must be dressed
WORKER_TIMEOUT_S = 1800.0  # wall time a worker process gets for its row


class Crowd:
    """``count`` walkers, each a ``Member`` with the prefix ``c<k>/``, fed and ticked in body time."""

    def __init__(self, count: int, garments: list[str], resolution: float = 1.0):
        self.walker = ProceduralCharacter(walk())
        self.values = {**default_values(), "garments": garments, "resolution": resolution}
        prefixes = [f"c{k}/" for k in range(count)]
        self.members = make_members(prefixes, self.values, solver_params(self.values))
        skeleton = self.walker.skeleton
        self._children = [[prefix + name for name in skeleton.names] for prefix in prefixes]
        self._parents = [[self.values["fixed_frame"] if p < 0 else prefix + skeleton.names[p] for p in skeleton.parents]
                         for prefix in prefixes]
        self.time_s = 0.0

    def offset(self, k: int) -> np.ndarray:
        """Where walker k's path lies: ``SPACING_M`` apart side by side, m."""
        return np.array([0.0, SPACING_M * k, 0.0])

    def phase(self, k: int) -> float:
        return PHASE_S * k

    def root(self, k: int, t: float) -> np.ndarray:
        """Walker k's root (pelvis) in the world at body time ``t``."""
        return self.walker.local_transforms(t + self.phase(k))[0][0] + self.offset(k)

    def feed(self, k: int, t: float) -> None:
        """Walker k's transforms at ``t`` into its buffer in one batch (``ingest_batch``'s call)."""
        translations, rotations = self.walker.local_transforms(t + self.phase(k))
        translations = translations.copy()
        translations[0] += self.offset(k)
        self.members[k].buffer.add_transforms(np.full(len(translations), t), self._parents[k], self._children[k],
                                              translations, rotations, now_s=t)

    def tick(self, count: int) -> dict[str, float]:
        """One 60 Hz frame of the first ``count`` characters: its stages' wall times, s, and how many
        characters' quality meters ran (``measured``)."""
        self.time_s += 1.0 / RATE_HZ
        t = self.time_s
        tic = time.perf_counter()
        for k in range(count):
            self.feed(k, t)
        fed = time.perf_counter()
        shown: list[Member] = []
        publish_s = solver_s = 0.0
        measured = 0
        for member in self.members[:count]:
            result = member.loop.frame(t, t)
            if result is not None:
                measured += result.measured
                solver_s += sum(r.integration_s + r.correction_s + r.collision_s for r in result.reports)
                before = time.perf_counter()
                member.hold(result, character_namespace(self.values["marker_namespace"], member.prefix, True),
                            self.values)
                publish_s += time.perf_counter() - before
            if member.held is not None:
                shown.append(member)
        stepped = time.perf_counter()
        serialize_marker_array(crowd_markers(shown, clear=False))
        end = time.perf_counter()
        return {"input": fed - tic, "step": stepped - fed - publish_s, "solver": solver_s,
                "publish": publish_s + end - stepped, "tick": end - tic, "measured": measured}

    def dress_all(self) -> None:
        """Tick every character until all are running (``RuntimeError`` if one is not within ``DRESS_TIMEOUT_S``)."""
        while not all(m.loop.status == Status.RUNNING for m in self.members):
            if self.time_s > DRESS_TIMEOUT_S:
                undressed = [m for m in self.members if m.loop.status != Status.RUNNING]
                raise RuntimeError("not dressed: " + "; ".join(f"{m.prefix} {m.loop.status}: {m.loop.detail}"
                                                                for m in undressed))
            self.tick(len(self.members))

    def separation(self, count: int) -> tuple[float, float]:
        """How far the first ``count`` garments' centres lie from their own walker's root (the farthest) and
        from the other walkers' roots (the nearest; inf for one character), horizontally, m."""
        own, others = 0.0, float("inf")
        for k, member in enumerate(self.members[:count]):
            centre = np.concatenate(member.loop.character.world_positions()).mean(axis=0)[:2]
            for j in range(count):
                distance = float(np.linalg.norm(centre - self.root(j, member.loop.last_time)[:2]))
                own, others = (max(own, distance), others) if j == k else (own, min(others, distance))
        return own, others

def time_group(count: int, garments: list[str], resolution: float, warmup: int, frames: int,
               threads: int | None, start=None, results=None) -> dict:
    """Dress ``count`` characters and time ``frames`` ticks after ``warmup`` (one process's share). In a
    worker process: ``start``, a barrier, lines the timed ticks up with the other workers' (dressing
    takes each a different while) and the row goes to the ``results`` queue."""
    threads = set_threads(threads)
    crowd = Crowd(count, garments, resolution)
    crowd.dress_all()
    if start is not None:
        start.wait()
    for _ in range(warmup):
        crowd.tick(count)
    samples = [crowd.tick(count) for _ in range(frames)]
    own, others = crowd.separation(count)
    row = {"series": {key: [sample[key] for sample in samples] for key in samples[0]}, "own": own, "others": others,
           "mass_points": sum(m.loop.mass_points for m in crowd.members),
           "max_penetration_m": max(m.loop.character.max_penetration() for m in crowd.members), "threads": threads}
    if results is not None:
        results.put(row)
    return row


def time_crowd(count: int, processes: int, garments: list[str], resolution: float, warmup: int, frames: int,
               threads: int | None) -> dict:
    """``count`` characters split over ``processes`` processes timed at the same time (``time_group`` each;
    one: in this process): the row of the slowest."""
    sizes = [len(group) for group in np.array_split(np.arange(count), processes) if len(group)]
    job = (garments, resolution, warmup, frames, threads)
    if len(sizes) == 1:
        groups = [time_group(sizes[0], *job)]
    else:
        context = multiprocessing.get_context("spawn")  # fork would copy numba's thread pool
        start, results = context.Barrier(len(sizes)), context.Queue()
        workers = [context.Process(target=time_group, args=(size, *job, start, results)) for size in sizes]
        for worker in workers:
            worker.start()
        groups = [results.get(timeout=WORKER_TIMEOUT_S) for _ in workers]  # a worker that died: queue.Empty
        for worker in workers:
            worker.join()
    slowest = max(groups, key=lambda g: np.median(g["series"]["tick"]))
    series = slowest["series"]
    tick_ms = _ms(series["tick"])
    others = min(g["others"] for g in groups)
    return {"characters": count, "processes": len(groups), "characters_per_process": max(sizes), "garments": garments,
            "mass_points": sum(g["mass_points"] for g in groups), "input_ms": _ms(series["input"]),
            "step_ms": _ms(series["step"]), "solver_ms": _ms(series["solver"]), "publish_ms": _ms(series["publish"]),
            "tick_ms": tick_ms,
            "tick_p95_ms": _ms(series["tick"], 0.95), "measured_max_per_tick": max(series["measured"]),
            "per_character_ms": round(tick_ms / max(sizes), 3),
            "fps": round(1e3 / tick_ms, 1), "max_penetration_m": max(g["max_penetration_m"] for g in groups),
            "garment_to_own_root_max_m": round(max(g["own"] for g in groups), 4),
            "garment_to_other_root_min_m": None if others == float("inf") else round(others, 4),
            "frames": frames, "threads": slowest["threads"], "load_average": load_average()}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--characters", type=int, nargs="+", default=[1, 2, 4, 8, 16], metavar="N",
                        help="character counts to time (default: %(default)s)")
    parser.add_argument("--garments", default="one_piece", help="comma-separated garments each character wears")
    parser.add_argument("--resolution", type=float, default=1.0, help="garment resolution (default: 1)")
    parser.add_argument("--frames", type=int, default=60, help="timed ticks per count (default: 60)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed ticks before them (default: 5)")
    parser.add_argument("--processes", type=int, default=1,
                        help="split the characters over this many processes at once, as nodes on one machine "
                             "(default: 1)")
    parser.add_argument("--threads", type=int, default=None,
                        help="numba threads per process (default: numba's for one process, 1 for several)")
    parser.add_argument("--json", action="store_true", help="one JSON object per count, then a summary")


def _ms(samples: list[float], quantile: float = 0.5) -> float:
    return round(float(np.quantile(samples, quantile)) * 1e3, 3)


def run(args: argparse.Namespace) -> int:
    garments = parse_garments(args.garments)
    counts = sorted(set(args.characters))
    if counts[0] < 1 or args.frames < 1 or args.warmup < 0 or args.processes < 1:
        raise ValueError(f"--characters and --processes must be >= 1, --frames >= 1 and --warmup >= 0; got "
                         f"{args.characters}, {args.processes}, {args.frames}, {args.warmup}")
    threads = args.threads if args.threads is not None or args.processes == 1 else 1
    if not args.json:
        print(f"{', '.join(garments)} per character, node defaults at {RATE_HZ:g} Hz; {args.processes} process(es), "
              f"{os.cpu_count()} cores, load {load_average()}")
        print(f"{'chars':>5} {'points':>7} {'input':>7} {'step':>7} {'solver':>7} {'publish':>7} {'tick':>7} "
              f"{'p95':>7} {'per ch.':>7} {'fps':>6} {'own m':>6} {'other m':>7}")
    rows = []
    for count in counts:
        progress(f"crowd: {count} character(s) in {', '.join(garments)}, {args.processes} process(es) ...")
        row = time_crowd(count, args.processes, garments, args.resolution, args.warmup, args.frames, threads)
        rows.append(row)
        if args.json:
            print(json.dumps(row), flush=True)
        else:
            others = row["garment_to_other_root_min_m"]
            print(f"{count:>5} {row['mass_points']:>7} {row['input_ms']:>7.2f} {row['step_ms']:>7.2f} "
                  f"{row['solver_ms']:>7.2f} {row['publish_ms']:>7.2f} {row['tick_ms']:>7.2f} "
                  f"{row['tick_p95_ms']:>7.2f} "
                  f"{row['per_character_ms']:>7.2f} {row['fps']:>6.1f} {row['garment_to_own_root_max_m']:>6.3f} "
                  f"{'-' if others is None else f'{others:.2f}':>7}", flush=True)
    result = summary(rows)
    print(json.dumps(result) if args.json else
          "summary: " + ", ".join(f"{k} {v}" for k, v in result.items() if k != "summary"))
    return 0


def summary(rows: list[dict]) -> dict:
    """Characters at 60 fps (the largest count timed that holds it, and the linear fit's), the fit itself."""
    budget_ms = 1e3 / RATE_HZ
    held = [row["characters"] for row in rows if row["tick_ms"] <= budget_ms]
    counts = np.array([row["characters"] for row in rows], float)
    ticks = np.array([row["tick_ms"] for row in rows], float)
    if len(rows) > 1:
        ms_per_character, fixed_ms = np.polyfit(counts, ticks, 1)
    else:
        ms_per_character, fixed_ms = ticks[0] / counts[0], 0.0
    linear = int((budget_ms - fixed_ms) // ms_per_character) if ms_per_character > 0 else None
    return {"summary": True, "characters_at_60fps": max(held, default=0),
            "characters_at_60fps_linear": max(linear, 0) if linear is not None else None,
            "ms_per_character": round(float(ms_per_character), 3), "fixed_ms": round(float(fixed_ms), 3),
            "budget_ms": round(budget_ms, 3), "processes": rows[0]["processes"], "threads": rows[0]["threads"],
            "cores": os.cpu_count(),
            "load_average": load_average(),
            "tick_ms_by_characters": {str(row["characters"]): row["tick_ms"]
                                      for row in sorted(rows, key=lambda r: r["characters"])}}
