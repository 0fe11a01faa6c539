"""The memo's collision experiments (§7, Fig. 5 and Fig. 6) as pure functions.

Set-up (memo Fig. 3, 5): an uncut ellipsoid with thigh-like radii ``a_x = a_y = 0.08 m``,
``a_z = 0.2 m`` lies with its long axis along world x; it rises at 0.1 m/s and turns
counter-clockwise at 90 deg/s in the x-z plane seen with x to the right and z up (its +x end
goes up). A mass point moves at a constant 0.5 m/s, downwards and 45 deg to the left (-x).
It starts ``distance_m`` before the ellipsoid's top point (0, 0, a_x) along its path, at t = 0.

A run steps the point and the ellipsoid with a time step h and handles the pair with the same
kernel as the cloth solver (``response.handle_pair``), forced static or dynamic, eps = 0. The
collision point is taken in the ellipsoid's local frame (where on the body the point hits):
for the dynamic method the memo's ``l(alpha_c)``, for the static method the surface point the
first penetrating position is projected to. The reference is the static method at a 0.00001 s
step (penetration at most 6 micrometres).

Where the collision falls inside a step matters: with a step h the last step before the hit
starts anywhere between 0 and h of relative travel from the surface. So every (distance, step)
is run with the step grid shifted by k/8 of a step (a first step of (1 - k/8) h, k = 0..7)
and the error reported is the worst of the eight (``error_m``), with their mean beside it.
That makes the result a property of the method, not of the phase of one grid.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from . import response
from .volume_arrays import MAX_PLANES, VolumeArrays
from .volumes import ELLIPSOID

# the memo's friction alone (``response._respond``'s grip), no open-cut exit
_NO_GRIP = (0.0, 0.0, np.zeros(1, dtype=np.int64), 0.0)

RADII = (0.08, 0.08, 0.2)  # m: a thigh
RISE_SPEED = 0.1  # m/s, up
SPIN_RATE = math.radians(90.0)  # rad/s, counter-clockwise in the x-z plane
POINT_SPEED = 0.5  # m/s
POINT_TILT = math.radians(45.0)  # from straight down, towards -x
REFERENCE_STEP = 1e-5  # s
RUN_DURATION = 1.0  # s: long enough for the point to have passed the ellipsoid from 0.5 m
FIG5_DISTANCES = (0.005, 0.02, 0.05, 0.1, 0.145, 0.2, 0.3)  # m
FIG5_STEPS = (0.001, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4)  # s
FIG6_DISTANCE = 0.145  # m
FIG6_TARGETS = (0.0005, 0.001, 0.002, 0.005)  # m
FIG6_STEPS = tuple(float(h) for h in np.geomspace(1e-4, 0.4, 49))  # s, 1e-4 .. 0.4 s
FIG6_INTERVAL = 0.5  # s of simulated time each method covers for the timing
PHASES = 8  # step-grid shifts per (distance, step)


@dataclass(frozen=True)
class Run:
    hit: bool
    point: np.ndarray  # (3,) collision point, ellipsoid-local frame, m (nan if no hit)
    time_s: float  # collision time (nan if no hit)
    steps: int  # time steps simulated


@njit(cache=True)
def _ellipsoid_pose(t, pos, rot):
    """Pose at time t: rotation about world y by (90 deg - spin t), so local z starts along +x."""
    angle = 0.5 * math.pi - SPIN_RATE * t
    c, s = math.cos(angle), math.sin(angle)
    pos[0, 0], pos[0, 1], pos[0, 2] = 0.0, 0.0, RISE_SPEED * t
    rot[0, 0, 0], rot[0, 0, 1], rot[0, 0, 2] = c, 0.0, s
    rot[0, 1, 0], rot[0, 1, 1], rot[0, 1, 2] = 0.0, 1.0, 0.0
    rot[0, 2, 0], rot[0, 2, 1], rot[0, 2, 2] = -s, 0.0, c


@njit(cache=True)
def _fall(start, velocity, h, first_step, duration, mode, stop_at_first_hit, friction, c_time):
    nowhere = np.zeros(1)  # the broad phase's fields: handle_pair reads none of them
    vol = VolumeArrays(np.array([ELLIPSOID]), np.array([[RADII[0], RADII[1], RADII[2]]]), np.array([[-np.inf, np.inf]]),
                       nowhere, np.array([min(RADII[0], RADII[1])]), np.full((1, 2), np.nan), np.zeros((1, 6)),
                       np.zeros((1, 3)), np.zeros((1, 3, 3)), np.zeros((1, 3)), np.zeros((1, 3, 3)), nowhere, nowhere,
                       nowhere, np.full((1, MAX_PLANES, 4), np.inf), np.zeros((1, 1)), np.zeros(1, dtype=np.bool_))
    xs = np.zeros((1, 3))
    x = start.reshape(1, 3).copy()
    vel = velocity.reshape(1, 3).copy()
    hit_point = np.full(3, np.nan)
    hit_time = np.nan
    steps = 0
    t0 = 0.0
    step = first_step
    while t0 < duration - 1e-12:
        _ellipsoid_pose(t0, vol.pos0, vol.rot0)
        _ellipsoid_pose(t0 + step, vol.pos1, vol.rot1)
        xs[0] = x[0]
        x[0] += step * vel[0]
        code, alpha, lx, ly, lz = response.handle_pair(vol, 0, xs, x, vel, 0, step, 0.0, friction, _NO_GRIP, c_time,
                                                       0.0, mode)
        steps += 1
        if code != response.NO_HIT and np.isnan(hit_time):
            hit_point[0], hit_point[1], hit_point[2] = lx, ly, lz
            hit_time = t0 + alpha * step
            if stop_at_first_hit:
                break
        t0 += step
        step = h
    return hit_point, hit_time, steps


@njit(cache=True)
def _fall_repeated(start, velocity, h, duration, mode, friction, c_time, repeats):
    """``repeats`` full runs over ``duration`` (for timing without Python overhead); total steps."""
    total = 0
    for _ in range(repeats):
        total += _fall(start, velocity, h, h, duration, mode, False, friction, c_time)[2]
    return total


def point_start(distance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Start position and velocity of the point for a start distance (m)."""
    direction = np.array([-math.sin(POINT_TILT), 0.0, -math.cos(POINT_TILT)])
    top = np.array([0.0, 0.0, RADII[0]])
    return top - distance_m * direction, POINT_SPEED * direction


def _mode(method: str) -> int:
    if method not in ("static", "dynamic"):
        raise ValueError(f"method must be 'static' or 'dynamic', got {method!r}")
    return response.MODE_STATIC if method == "static" else response.MODE_DYNAMIC


def run(distance_m: float, step_s: float, method: str, phase: float = 0.0,
        duration_s: float = RUN_DURATION) -> Run:
    """Step the set-up with one method ("static" or "dynamic") until the first collision.

    ``phase`` in [0, 1) shortens the first step to (1 - phase) step_s (shifts the step grid).
    """
    mode = _mode(method)
    if not step_s > 0.0:
        raise ValueError(f"step_s must be > 0 s, got {step_s!r}")
    if not 0.0 <= phase < 1.0:
        raise ValueError(f"phase must be in [0, 1), got {phase!r}")
    start, velocity = point_start(distance_m)
    point, hit_time, steps = _fall(start, velocity, float(step_s), float(step_s) * (1.0 - phase),
                                   float(duration_s), mode, True, 0.2, 0.5)
    return Run(hit=bool(np.isfinite(hit_time)), point=point, time_s=float(hit_time), steps=int(steps))


def reference(distance_m: float) -> Run:
    return run(distance_m, REFERENCE_STEP, "static")


def errors_over_phases(distance_m: float, step_s: float, method: str, reference_run: Run) -> np.ndarray:
    """(PHASES,) distances (m) between the method's collision point and the reference's, one per
    step-grid shift; inf where the method misses the ellipsoid."""
    out = np.full(PHASES, math.inf)
    for k in range(PHASES):
        result = run(distance_m, step_s, method, k / PHASES)
        if result.hit and reference_run.hit:
            out[k] = float(np.linalg.norm(result.point - reference_run.point))
    return out


def fig5(distances=FIG5_DISTANCES, steps=FIG5_STEPS) -> list[dict]:
    """One row per (distance, step): the simplified dynamic detection's error against the reference."""
    rows = []
    for distance in distances:
        ref = reference(distance)
        for step in steps:
            errors = errors_over_phases(distance, step, "dynamic", ref)
            rows.append({
                "distance_m": float(distance),
                "time_step_s": float(step),
                "error_m": float(errors.max()),
                "error_mean_m": float(errors.mean()),
                "reference_time_s": ref.time_s,
            })
    return rows


def largest_step(errors_by_step: dict[float, float], target_m: float) -> float | None:
    """The largest step such that it and every smaller step meet the target error."""
    best = None
    for step in sorted(errors_by_step):
        if not errors_by_step[step] <= target_m:
            break
        best = step
    return best


def seconds_per_interval(distance_m: float, step_s: float, method: str, interval_s: float) -> float:
    """Compute time (s) to simulate ``interval_s`` with the method at ``step_s``, collision
    handling included after the hit: best of 5 batches, each repeated inside one kernel call
    to ~20 ms so no Python overhead is counted."""
    mode = _mode(method)
    start, velocity = point_start(distance_m)
    repeats = 1
    while True:
        begin = time.perf_counter()
        _fall_repeated(start, velocity, float(step_s), float(interval_s), mode, 0.2, 0.5, repeats)
        elapsed = time.perf_counter() - begin
        if elapsed > 0.02 or repeats >= 1 << 20:
            break
        repeats *= 4
    best = elapsed
    for _ in range(4):
        begin = time.perf_counter()
        _fall_repeated(start, velocity, float(step_s), float(interval_s), mode, 0.2, 0.5, repeats)
        best = min(best, time.perf_counter() - begin)
    return best / repeats


def fig6(distance_m: float = FIG6_DISTANCE, targets=FIG6_TARGETS, steps=FIG6_STEPS,
         interval_s: float = FIG6_INTERVAL, timed: bool = True) -> list[dict]:
    """Per target error: the largest step each method meets it with, the steps and compute
    time to cover ``interval_s`` of simulated time, and ``speedup`` = static / dynamic time."""
    ref = reference(distance_m)
    errors = {method: {step: float(errors_over_phases(distance_m, step, method, ref).max()) for step in steps}
              for method in ("static", "dynamic")}
    rows = []
    for target in targets:
        row: dict = {"distance_m": float(distance_m), "target_error_m": float(target),
                     "interval_s": float(interval_s)}
        for method in ("static", "dynamic"):
            step = largest_step(errors[method], target)
            row[f"{method}_step_s"] = step
            row[f"{method}_error_m"] = None if step is None else errors[method][step]
            row[f"{method}_steps"] = None if step is None else int(math.ceil(interval_s / step - 1e-9))
            row[f"{method}_time_s"] = (seconds_per_interval(distance_m, step, method, interval_s)
                                       if timed and step is not None else None)
        both = row["static_steps"] is not None and row["dynamic_steps"] is not None
        row["step_ratio"] = row["static_steps"] / row["dynamic_steps"] if both else None
        row["speedup"] = (row["static_time_s"] / row["dynamic_time_s"]
                          if both and timed and row["dynamic_time_s"] > 0 else None)
        rows.append(row)
    return rows
