"""float32 against float64 in the solver's hot kernels: speed and accuracy, measured (issue 15 item 1).

``kernels``: the one-piece at 720, 5 000 and 20 000 points in ``bench/length_correction.py``'s starting state
(hanging, stretched 15 %), ``cloth.kernels.accumulate_forces``, ``integrate`` and one ``length_correction``
sweep on float64 arrays and on float32 copies of them (positions, velocities, masses, rest lengths,
stiffness, damping; the scalars as ``np.float32``), so that numba compiles a float32 specialisation; and
``length_correction_float32``, the sweep with no float64 literal. Per kernel and dtype the median CPU time
per call (``time.process_time``: the machine is shared; the dtypes alternate call by call), and the share of
the specialisation's LLVM float arithmetic still in double (a float64 literal promotes). Then the residual:
the worst stretch after ``--sweeps`` sweeps in each dtype, and the largest position difference to float64.

``collision``: ``collision.kernels.handle_all`` and ``handle_contacts`` (serial) on their first call's
arguments in frame ``--collision-frame`` of the CC walk, float64 against float32 copies (positions,
velocities, inverse masses, the volumes' float arrays, the scalars); CPU time per call, double share,
position difference.

``frames``: the one-piece on the CC walk (default parameters, 60 fps, the fused frame), stepped ``--frames``
frames by several characters in turn: float64 (the solver as it is); float32, whose fused call gets float32
copies of the positions, velocities, cloth arrays and the solver's scratch, written back after it (the
state is float32 from frame to frame; the collider's arrays stay float64); and float64 controls from a start
rounded once to float32 or with 0.1 um of noise (``--controls``): how far the motion itself carries a
float32-sized difference. Per run: median CPU ms per frame, the largest position difference to float64
after frame 1 and the last, the worst spring stretch and the deepest free point over the frames.

    PYTHONPATH=$PWD python bench/float32.py [--parts kernels collision frames] [--points 720 5000 20000]
        [--sweeps 20] [--frames 100] [--controls 2]

One JSON line per size and kernel, per size for the collision and the frames.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import time
from pathlib import Path

import numpy as np
from length_correction import starting_state
from numba import njit

from garment_sim_ros import benchmarking, quality
from garment_sim_ros.body.sources import bvh_source
from garment_sim_ros.cloth import fused, kernels
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.model import build_cloth_model
from garment_sim_ros.cloth.solver import derive_constants
from garment_sim_ros.collision import kernels as collision_kernels
from garment_sim_ros.commands.scale import GARMENT, resolution_for
from garment_sim_ros.dressing import make_character
from garment_sim_ros.params import DEFAULT_PARAMS

CLIP = Path(__file__).resolve().parent.parent / "test" / "data" / "cc_cmu_07_01_walk.bvh"
PARTS = ("kernels", "collision", "frames")
CALLS = 40  # timed calls per kernel and dtype


def single(*arrays):
    return tuple(np.ascontiguousarray(a, dtype=np.float32) for a in arrays)


def double_share(dispatcher, dtype, position_arg: int = 0) -> float:
    """The share of the specialisation's floating-point instructions (fadd/fsub/fmul/fdiv/fcmp) done in double,
    on a fresh compilation (numba does not inspect code loaded from its cache)."""
    for signature in dispatcher.signatures:
        if str(signature[position_arg].dtype) == dtype:
            fresh = njit(dispatcher.py_func)
            fresh.compile(signature)
            ops = re.findall(r"= f(?:add|sub|mul|div|cmp) (?:[a-z]+ )*(float|double)", fresh.inspect_llvm(signature))
            return round(sum(op == "double" for op in ops) / max(1, len(ops)), 3)
    return float("nan")


@njit(cache=True)
def length_correction_float32(x, inv_mass, springs, rest, count, limit_factor):
    """``cloth.kernels.length_correction`` with no float64 literal (its ``1.0 + limit_ratio`` is
    ``limit_factor``): on float32 arrays all its arithmetic is float32, what a float32 solver would run."""
    zero = np.float32(0.0)
    worst = zero
    for s in range(count):
        a = springs[s, 0]
        b = springs[s, 1]
        dx, dy, dz, length = kernels._spring_vector(x, a, b)
        limit = limit_factor * rest[s]
        worst = max(worst, length / rest[s])
        if length <= limit:
            continue
        wa = inv_mass[a]
        wb = inv_mass[b]
        total = wa + wb
        if total == zero:
            continue
        scale = (length - limit) / (length * total)
        x[a, 0] += wa * scale * dx
        x[a, 1] += wa * scale * dy
        x[a, 2] += wa * scale * dz
        x[b, 0] -= wb * scale * dx
        x[b, 1] -= wb * scale * dy
        x[b, 2] -= wb * scale * dz
    return worst


def kernel_part(points: int, sweeps: int) -> list[dict]:
    params = DEFAULT_PARAMS
    model = build_cloth_model(build_garment(GARMENT, resolution=resolution_for(points)))
    const = derive_constants(model, params)
    count, springs, limit = model.num_correction_springs, model.springs, params.limit_ratio
    x64 = starting_state(model, np.random.default_rng(0))[0]
    v64 = np.random.default_rng(1).normal(0.0, 0.1, x64.shape)
    doubles = (x64, v64, const.mass, const.inv_mass, model.rest_lengths, const.stiffness, const.damping,
               np.array([0.0, 0.0, -9.81]), np.array([0.3, 0.0, 0.0]))
    by_dtype = {"float64": (doubles, float), "float32": (single(*doubles), np.float32)}

    def calls(dtype):
        """name: (dispatcher, set-up before the clock, the timed call)."""
        (x, v, mass, inv_mass, rest, stiffness, damping, accel, frame_v), scalar = by_dtype[dtype]
        forces, x_start, moved = np.zeros_like(x), np.zeros_like(x), x.copy()
        reset = lambda: moved.__setitem__(slice(None), x)  # noqa: E731 -- every call from the same state
        return {
            "accumulate_forces": (kernels.accumulate_forces, None, lambda: kernels.accumulate_forces(
                x, v, mass, springs, rest, stiffness, damping, accel, scalar(0.5), scalar(0.1), scalar(0.2),
                frame_v, scalar(1.0), forces)),
            "integrate": (kernels.integrate, reset, lambda: kernels.integrate(moved, v, forces, inv_mass,
                                                                               scalar(1.0 / 600.0), x_start)),
            "length_correction": (kernels.length_correction, reset, lambda: kernels.length_correction(
                moved, inv_mass, springs, rest, count, scalar(limit))),
            "length_correction_float32": (length_correction_float32, reset, lambda: length_correction_float32(
                moved, inv_mass, springs, rest, count, scalar(1.0 + limit))),
        }

    table = {dtype: calls(dtype) for dtype in by_dtype}
    rows, reference_ms = [], {}
    for name in table["float64"]:
        cpu = {dtype: [] for dtype in table}
        for repeat in range(CALLS + 1):
            for dtype in table:  # alternating, call by call
                _, reset, call = table[dtype][name]
                if reset:
                    reset()
                tic = time.process_time()
                call()
                if repeat:  # the first compiles
                    cpu[dtype].append(time.process_time() - tic)
        ms = {dtype: statistics.median(series) * 1e3 for dtype, series in cpu.items()}
        reference_ms.setdefault(name.removesuffix("_float32"), ms["float64"])
        rows.append({"part": "kernels", "points": model.num_points, "kernel": name,
                     "ms_float64": round(ms["float64"], 4), "ms_float32": round(ms["float32"], 4),
                     # against the solver's kernel on float64 (the twin's own float64 run is a check only)
                     "speedup": round(reference_ms[name.removesuffix("_float32")] / max(ms["float32"], 1e-9), 2),
                     "double_share_float32": double_share(table["float32"][name][0], "float32"),
                     "load_1min": benchmarking.load_average()})
    # the residual: the same sweeps in both dtypes from the same starting state
    (x32, inv_mass32, rest32), rest64 = (by_dtype["float32"][0][k] for k in (0, 3, 4)), model.rest_lengths
    swept = {"float64": x64.copy(), "float32": x32.copy(), "float32_pure": x32.copy()}
    for _ in range(sweeps):
        kernels.length_correction(swept["float64"], const.inv_mass, springs, rest64, count, limit)
        kernels.length_correction(swept["float32"], inv_mass32, springs, rest32, count, np.float32(limit))
        length_correction_float32(swept["float32_pure"], inv_mass32, springs, rest32, count, np.float32(1.0 + limit))
    row = {"part": "residual", "points": model.num_points, "sweeps": sweeps}
    for way, x in swept.items():
        x = x.astype(np.float64)
        row[f"stretch_after_{way}"] = round(kernels.spring_stretches(x, springs, rest64, np.empty(count)), 6)
        row[f"max_position_difference_m_{way}"] = float(np.abs(x - swept["float64"]).max())
    rows.append(row)
    return rows


class Float32Frame:
    """``fused.run_substeps`` on float32 copies of the cloth's state and arrays, written back after the call."""

    def __init__(self, original):
        self.original = original

    def __call__(self, x, v, contacts, garment, scratch, *rest):
        x32, v32 = single(x, v)
        garment32 = tuple(single(a)[0] if a.dtype == np.float64 else a for a in garment)
        # the solver's own scratch (the first 9); the collider's stays as it is
        scratch32 = tuple(single(a)[0] if k < 9 and a.dtype == np.float64 else a for k, a in enumerate(scratch))
        result = self.original(x32, v32, contacts, garment32, scratch32, *rest)
        x[:] = x32
        v[:] = v32
        return result


def dressed(resolution: float):
    source = bvh_source(str(CLIP), loop=True)
    character = make_character(source.rest_pose, source.joint_map, ["one_piece"], DEFAULT_PARAMS, resolution,
                               motion=source.fit_poses())
    character.dress(source.pose(0.0), 0.0, source.motion(0.0))
    return source, character


def figures(solver) -> tuple[float, float]:
    """(worst spring stretch, deepest free point inside a volume m) of ``solver``'s garment now."""
    model = solver.model
    stretches = np.empty(model.num_correction_springs)
    return (float(kernels.spring_stretches(solver.state.positions, model.springs, model.rest_lengths, stretches)),
            quality.free_point_depth(solver))


def frame_part(points: int, frames: int, controls: int) -> dict:
    """float64, float32, and float64 from a start rounded once to float32 and from ``controls`` starts with
    0.1 um of noise: how far the motion's own sensitivity carries a float32-sized difference, the yardstick
    of the float32 run's difference and figures."""
    resolution = resolution_for(points)
    ways = ["float64", "float32", "float64_rounded_start"] + [f"float64_noise_seed{k}" for k in range(controls)]
    runs = {way: dressed(resolution) for way in ways}
    for way, (_, character) in runs.items():
        start = character.solvers[0].state.positions
        if way == "float64_rounded_start":
            start[:] = start.astype(np.float32)
        elif way.startswith("float64_noise"):
            free = character.solvers[0].constants.inv_mass > 0.0
            start[free] += np.random.default_rng(int(way[-1])).normal(0.0, 1e-7, start[free].shape)
    cpu = {way: [] for way in runs}
    worst = {way: (0.0, 0.0) for way in runs}
    row = {"part": "frames", "clip": CLIP.name, "frames": frames}
    originals = {name: getattr(fused, name) for name in ("run_substeps", "run_substeps_parallel")}
    for frame in range(1, frames + 1):
        t = frame / 60.0
        for way, (source, character) in runs.items():
            for name, original in originals.items():  # the serial or the parallel chain, as the collider runs
                setattr(fused, name, Float32Frame(original) if way == "float32" else original)
            try:
                tic = time.process_time()
                character.step(source.pose(t), source.motion(t), t, measure=False)
                cpu[way].append(time.process_time() - tic)
            finally:
                for name, original in originals.items():
                    setattr(fused, name, original)
            worst[way] = tuple(map(max, worst[way], figures(character.solvers[0])))
        if frame in (1, frames):
            positions = {way: character.solvers[0].state.positions for way, (_, character) in runs.items()}
            for way in ways[1:]:
                row[f"difference_mm_{way}_frame{frame}"] = round(
                    float(np.abs(positions[way] - positions["float64"]).max()) * 1e3, 5)
    row["points"] = runs["float64"][1].solvers[0].model.num_points
    for way in runs:
        row[f"max_stretch_{way}"] = round(worst[way][0], 5)
        row[f"max_depth_mm_{way}"] = round(worst[way][1] * 1e3, 3)
    for way in ("float64", "float32"):  # frame 1 compiles
        row[f"cpu_ms_{way}"] = round(statistics.median(cpu[way][1:]) * 1e3, 3)
    row["speedup"] = round(row["cpu_ms_float64"] / row["cpu_ms_float32"], 2)
    row["load_1min"] = benchmarking.load_average()
    return row


def as_float32(argument):
    """A kernel argument with its float64 arrays and floats in float32 (tuples element by element)."""
    if isinstance(argument, tuple):
        return tuple(as_float32(a) for a in argument)
    if isinstance(argument, np.ndarray) and argument.dtype == np.float64:
        return single(argument)[0]
    return np.float32(argument) if isinstance(argument, float) else argument


def copied(argument):
    """A kernel argument with its arrays copied (tuples element by element)."""
    if isinstance(argument, tuple):
        return tuple(copied(a) for a in argument)
    return argument.copy() if isinstance(argument, np.ndarray) else argument


def collision_part(points: int, frames: int) -> list[dict]:
    """``collision.kernels.handle_all`` and ``handle_contacts`` (serial) on their first call's arguments in
    the CC walk's frame ``frames`` on the reference path, float64 against float32 copies of them; each call
    from the same state (its positions, velocities and cache copied before the clock)."""
    source, character = dressed(resolution_for(points))
    solver = character.solvers[0]
    solver.use_fused = False
    solver.collider.parallel = False
    names = ("handle_all", "handle_contacts")
    originals = {name: getattr(collision_kernels, name) for name in names}
    captured = {}

    def capturing(name):
        def capture(*args):  # the frame's first call: after the integration, the most points to move
            if name not in captured:  # copied: the volumes' poses change in place substep by substep
                captured[name] = tuple(copied(a) for a in args)
            return originals[name](*args)
        return capture

    for name in names:
        setattr(collision_kernels, name, capturing(name))
    try:
        for frame in range(1, frames + 1):
            captured.clear()
            character.step(source.pose(frame / 60.0), source.motion(frame / 60.0), frame / 60.0, measure=False)
    finally:
        for name, original in originals.items():
            setattr(collision_kernels, name, original)
    rows = []
    for name, kernel in originals.items():
        args = {"float64": captured[name], "float32": as_float32(captured[name])}
        in_place = [k for k, a in enumerate(captured[name]) if isinstance(a, np.ndarray) and a.ndim == 2]
        out, cpu = {}, {dtype: [] for dtype in args}
        for repeat in range(CALLS + 1):
            for dtype, call_args in args.items():
                call_args = tuple(a.copy() if k in in_place else a for k, a in enumerate(call_args))
                tic = time.process_time()
                kernel(*call_args)
                if repeat:  # the first compiles
                    cpu[dtype].append(time.process_time() - tic)
                out[dtype] = call_args[2]  # the positions
        ms = {dtype: statistics.median(series) * 1e3 for dtype, series in cpu.items()}
        rows.append({"part": "collision", "points": solver.model.num_points, "frame": frames, "kernel": name,
                     "ms_float64": round(ms["float64"], 4), "ms_float32": round(ms["float32"], 4),
                     "speedup": round(ms["float64"] / ms["float32"], 2),
                     "double_share_float32": double_share(kernel, "float32", position_arg=2),
                     "moved_points": int((np.abs(out["float64"] - captured[name][2]).max(axis=1) > 0).sum()),
                     "max_position_difference_m": float(np.abs(out["float64"] - out["float32"]).max()),
                     "load_1min": benchmarking.load_average()})
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS))
    parser.add_argument("--points", type=int, nargs="+", default=[720, 5000, 20000])
    parser.add_argument("--sweeps", type=int, default=20, help="correction sweeps of the residual comparison")
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--controls", type=int, default=2, help="float64 runs from a start with 0.1 um of noise")
    parser.add_argument("--collision-frame", type=int, default=30, help="the frame whose handle_all call is timed")
    parser.add_argument("--threads", type=int, default=1, help="numba threads (the comparison is per core)")
    args = parser.parse_args()
    benchmarking.set_threads(args.threads)
    for points in args.points:
        if "kernels" in args.parts:
            for row in kernel_part(points, args.sweeps):
                print(json.dumps(row), flush=True)
        if "collision" in args.parts:
            for row in collision_part(points, args.collision_frame):
                print(json.dumps(row), flush=True)
        if "frames" in args.parts:
            print(json.dumps(frame_part(points, args.frames, args.controls)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
