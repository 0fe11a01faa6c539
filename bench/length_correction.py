"""The length correction's sweep: which way of running it is fastest to a given residual (issue 15 item 1).

The one-piece at 720, 5 000 and 20 000 points (``garment-sim scale``'s resolutions), hanging from its
attached points and stretched 15 % downwards with 1 mm of noise (the correction has to carry the
attachments' pull down the whole garment, its slowest case). Per way of sweeping: the sweeps until no
structural or shear spring is longer than ``1 + limit_ratio + strain_limit_tolerance`` (the strain
limiting's stop) and the median time per sweep over those sweeps, on 1 and 2 of numba's threads.

- ``gauss_seidel``: ``cloth.kernels.length_correction`` in the model's order (the solver's);
- ``coloured``: the springs reordered by colour (no two of a colour share a point), the same kernel;
- ``coloured_prange``: the same order, each colour's springs over numba's threads (bit-equal to ``coloured``);
- ``jacobi``: every point moved by the mean of its springs' corrections times a relaxation, a ``prange``
  over the points gathering from their springs (CSR), then one over the points applying.

    PYTHONPATH=$PWD python bench/length_correction.py [--points 720 5000 20000] [--max-sweeps 400]

One JSON line per size, way and thread count.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numba
import numpy as np
from numba import njit, prange

from garment_sim_ros.cloth import kernels
from garment_sim_ros.cloth.garments import build_garment
from garment_sim_ros.cloth.model import build_cloth_model
from garment_sim_ros.commands.scale import GARMENT, resolution_for
from garment_sim_ros.params import DEFAULT_PARAMS

STRETCH, NOISE = 1.15, 1e-3  # the starting state: 15 % longer downwards, 1 mm of noise (m)
RELAXATION = 1.5  # the Jacobi sweep's over-relaxation of the averaged corrections (1.0-1.8 tried; 1.5 best)


def colour_order(springs: np.ndarray, num_points: int) -> tuple[np.ndarray, np.ndarray]:
    """A permutation of ``springs`` (S, 2) grouping them by colour (greedy, lowest colour free at both ends)
    and where each colour starts (C + 1,)."""
    used = [0] * num_points
    colours = np.empty(len(springs), dtype=np.int64)
    for s, (a, b) in enumerate(springs.tolist()):
        taken = used[a] | used[b]
        colour = (~taken & (taken + 1)).bit_length() - 1
        colours[s] = colour
        used[a] |= 1 << colour
        used[b] |= 1 << colour
    order = np.argsort(colours, kind="stable")
    return order, np.concatenate([[0], np.cumsum(np.bincount(colours))]).astype(np.int64)


@njit(parallel=True)  # a prange reduction (max) needs numba's runtime
def coloured_sweep(x, inv_mass, springs, rest, starts, limit_ratio):
    """``length_correction`` colour after colour, a colour's springs over the threads."""
    worst = 0.0
    for c in range(starts.shape[0] - 1):
        for s in prange(starts[c], starts[c + 1]):
            a, b = springs[s, 0], springs[s, 1]
            dx, dy, dz, ratio, scale = _excess(x, inv_mass, springs, rest, s, limit_ratio)
            worst = max(worst, ratio)
            for k, d in ((0, dx), (1, dy), (2, dz)):
                x[a, k] += inv_mass[a] * scale * d
                x[b, k] -= inv_mass[b] * scale * d
    return worst


@njit(inline="always")
def _excess(x, inv_mass, springs, rest, s, limit_ratio):
    """Spring s: (b - a, its length / rest length, the share of b - a to move by per unit inverse mass: 0
    within its limit), as ``cloth.kernels.length_correction`` computes them."""
    a, b = springs[s, 0], springs[s, 1]
    dx, dy, dz = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    limit = (1.0 + limit_ratio) * rest[s]
    total = inv_mass[a] + inv_mass[b]
    scale = (length - limit) / (length * total) if length > limit and total > 0.0 else 0.0
    return dx, dy, dz, length / rest[s], scale


@njit(parallel=True)  # a prange reduction (max) needs numba's runtime
def jacobi_sweep(x, inv_mass, springs, rest, point_start, point_springs, limit_ratio, relaxation, delta):
    """Every point by ``relaxation`` times the mean of its stretched springs' corrections (both ends' moves
    computed from the positions before the sweep); ``point_springs`` the springs at each point (CSR)."""
    worst = 0.0
    for i in prange(x.shape[0]):
        sx, sy, sz, active = 0.0, 0.0, 0.0, 0
        for k in range(point_start[i], point_start[i + 1]):
            s = point_springs[k]
            dx, dy, dz, ratio, scale = _excess(x, inv_mass, springs, rest, s, limit_ratio)
            worst = max(worst, ratio)
            if scale == 0.0:
                continue
            scale *= inv_mass[i] * (1.0 if i == springs[s, 0] else -1.0)
            sx, sy, sz, active = sx + scale * dx, sy + scale * dy, sz + scale * dz, active + 1
        w = relaxation / max(active, 1)
        delta[i, 0], delta[i, 1], delta[i, 2] = w * sx, w * sy, w * sz
    for i in prange(x.shape[0]):
        for c in range(3):
            x[i, c] += delta[i, c]
    return worst


def starting_state(model, rng) -> tuple[np.ndarray, np.ndarray]:
    x = model.rest_positions.copy()
    top = x[model.attached, 2].mean()
    x[:, 2] = top + STRETCH * (x[:, 2] - top)
    x += rng.normal(0.0, NOISE, x.shape)
    x[model.attached] = model.rest_positions[model.attached]
    inv_mass = 1.0 / (DEFAULT_PARAMS.areal_density * model.vertex_areas)
    inv_mass[model.attached] = 0.0
    return x, inv_mass


def measure(sweep, x0, max_sweeps: int, converged: float) -> tuple[int, float, float]:
    """(sweeps to ``converged``, median ms per sweep, the last residual) of ``sweep(x)`` from ``x0``."""
    x = x0.copy()
    sweep(x)  # compiled before the clock
    x = x0.copy()
    times, worst = [], np.inf
    for count in range(1, max_sweeps + 1):
        tic = time.perf_counter()
        worst = sweep(x)
        times.append(time.perf_counter() - tic)
        if worst <= converged:  # the residual the sweep met on entry: the previous sweep reached it
            return count - 1, 1e3 * statistics.median(times), worst
    return max_sweeps, 1e3 * statistics.median(times), worst


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[720, 5000, 20000])
    parser.add_argument("--max-sweeps", type=int, default=400)
    args = parser.parse_args()
    params = DEFAULT_PARAMS
    limit = params.limit_ratio
    converged = 1.0 + params.limit_ratio + params.strain_limit_tolerance
    for points in args.points:
        model = build_cloth_model(build_garment(GARMENT, resolution=resolution_for(points)))
        count = model.num_correction_springs
        springs, rest = model.springs[:count], model.rest_lengths[:count]
        order, starts = colour_order(springs, model.num_points)
        coloured, coloured_rest = np.ascontiguousarray(springs[order]), np.ascontiguousarray(rest[order])
        incident = np.concatenate([springs[:, 0], springs[:, 1]])
        point_springs = np.argsort(incident, kind="stable") % count
        point_start = np.searchsorted(np.sort(incident), np.arange(model.num_points + 1)).astype(np.int64)
        delta = np.zeros((model.num_points, 3))
        x0, inv_mass = starting_state(model, np.random.default_rng(0))
        ways = {
            "gauss_seidel": lambda x: kernels.length_correction(x, inv_mass, springs, rest, count, limit),
            "coloured": lambda x: kernels.length_correction(x, inv_mass, coloured, coloured_rest, count, limit),
            "coloured_prange": lambda x: coloured_sweep(x, inv_mass, coloured, coloured_rest, starts, limit),
            "jacobi": lambda x: jacobi_sweep(x, inv_mass, springs, rest, point_start, point_springs, limit,
                                             RELAXATION, delta),
        }
        for name, sweep in ways.items():
            for threads in (1, 2) if name in ("coloured_prange", "jacobi") else (1,):
                numba.set_num_threads(threads)
                sweeps, ms, worst = measure(sweep, x0, args.max_sweeps, converged)
                print(json.dumps({"points": model.num_points, "way": name, "threads": threads, "colours":
                                  len(starts) - 1, "sweeps_to_residual": sweeps, "residual": round(worst, 4),
                                  "ms_per_sweep": round(ms, 4), "ms_to_residual": round(sweeps * ms, 3)}),
                      flush=True)
    print(json.dumps({"converged_below": converged}), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
