"""``garment-sim drape``: the classic drape scene, a square cloth falling onto a sphere that then moves.

The scene (issue 6), z up, SI units: an ``N x N`` particle square cloth, 1 m x 1 m, 0.2 kg
(every particle ``0.2 / N^2`` kg), flat, horizontal and at rest, all edges free, centred
0.05 m above the top of a sphere of radius 0.25 m whose centre starts at the origin; gravity
-9.81 m/s^2. The sphere is still for t < 0.5 s, then moves along x at +1 m/s for 0.5 s, -1 m/s
for 0.5 s, again +1 and -1 until t = 2.5 s, and is still after. Frames of 1/30 s, 6 substeps
each (``substep = 1/180`` s); friction 0.5. Five untimed warm-up frames, then the timed ones.

The cloth is a ``GarmentMesh`` without attachments simulated by the same ``GarmentSolver`` as the
garments, in the world frame: the root stays at the origin with yaw 0 and no motion, so the
relative-frame forces reduce to gravity and air drag; the sphere is a one-volume ``VolumeSet``
attached to the frame ``"sphere"`` whose pose each ``FrameInput`` supplies.

Material (``drape_params``): the solver caps spring stiffness at ``stability_factor * m / h^2``
(about 0.4 N/m for N = 64) for explicit Euler; a woven cloth's stretch stiffness is far above
that, so stretch and shear ask for a cloth-like 100 N/m, get the cap (reported as
``capped_springs``) and inextensibility comes from Provot's length correction, as in the memo.
Bending is asked for far below the cap so the cloth folds freely; light air drag.

Contact (issue 15): position-level friction (``contact_friction``, Macklin et al. 2014) holds the cloth on
the moving sphere; the velocity-level ``friction`` alone never reached the points the length correction's
contact handling put back out, and the cloth slid off (final top z -24 m). Points are put 0.5 mm (not the
garments' 3 mm) outside the sphere: a resting point drifts back towards the surface between hits, and pushed
out to the full offset while its neighbour sat a fraction of a mm out it stretched their 16 mm edge by up to
3/16. Points within 5 mm of the sphere keep it in their contact cache (``contact_margin``), so that the
contact handling inside the length correction and the strain limiting keeps them out, not the full handling
after them; and 6 correction iterations, not 4. N = 64, max stretch: 1.20 with the 3 mm offset, 1.114 with
0.5 mm and 4 iterations, 1.097 with 6 (docs/benchmarks.md, "Drape with friction").

Damping and iterations (issue 15, the drape's speed; docs/benchmarks.md, "Where the drape's time goes"). The
springs' damping is explicit too, and a point with ``DAMPED_SPRINGS`` damped springs (about 6 structural and 4
shear on this grid) is surely stable for ``c < m / (DAMPED_SPRINGS h)`` (Gershgorin on the damping matrix): at
N = 64 the asked 0.01 N s/m, capped by the solver to 0.0044, is 5x that, and the cloth fluttered -- every point's
velocity flipped sign each substep (mean speed 1.22 m/s with the sphere still at the end, corners held up at
z = -0.12 m; 0.21 m/s and -0.33 m below the limit). So the damping asked is at most that limit. The strain
limiting runs up to 24 sweeps but stops once no spring is longer than 1.11 x its rest length (tolerance 0.1),
after 8 correction iterations: most substeps stop early, the reversals use more. N = 64: max stretch 1.0973
(1.0966 before), CPU time per frame 22.5-23.1 ms against 30.9-31.1 with 6 / 12 sweeps and the capped damping.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from ..cloth import kernels
from ..cloth.garments import GarmentMesh
from ..cloth.model import STRUCTURAL, build_cloth_model
from ..cloth.solver import FrameInput, GarmentSolver
from ..collision.volumes import SPHERE, Volume, VolumeSet
from ..params import DEFAULT_PARAMS, SolverParams

HELP = ("The classic drape scene: an N x N particle, 1 m square cloth (0.2 kg) falls onto a 0.25 m sphere "
        "that then moves back and forth along x; frame 1/30 s, 6 substeps. Prints time per frame, "
        "particle-substeps per second, penetration, stretch and whether the cloth is still draped.")

CLOTH_SIZE_M = 1.0
CLOTH_MASS_KG = 0.2
SPHERE_RADIUS_M = 0.25
START_GAP_M = 0.05  # cloth above the sphere's top at the start
SPHERE_FRAME = "sphere"
FRAME_S = 1.0 / 30.0
SUBSTEPS = 6
WARMUP_FRAMES = 5
FRICTION = 0.5
CONTACT_FRICTION = 0.5  # position-level friction (see the module docstring)
CONTACT_OFFSET_M = 0.0005  # how far outside the sphere points are put (``collision_epsilon``)
CONTACT_MARGIN_M = 0.005  # points this near the sphere keep it in their contact cache (``contact_margin``)
STILL_UNTIL_S = 0.5
LEG_S = 0.5  # each out or back leg of the sphere's motion
SPHERE_SPEED = 1.0  # m/s
MOVING_UNTIL_S = 2.5
DEFAULT_N = 64
DEFAULT_FRAMES = 90  # with the warm-up frames, 3.17 s: the whole motion and 0.67 s of rest after
DEFAULT_CORRECTION_ITERATIONS = 8
STRAIN_LIMIT_ITERATIONS = 24  # at most; they stop at STRAIN_LIMIT_TOLERANCE
STRAIN_LIMIT_TOLERANCE = 0.1
SPRING_DAMPING = 0.01  # N s/m asked of the stretch and shear springs, at most the stable DAMPED_SPRINGS limit
DAMPED_SPRINGS = 10  # stretch and shear springs per point of the grid, rounded up (5.9 + 3.9 at N = 64)


def square_cloth(n: int, size: float = CLOTH_SIZE_M, height: float = 0.0) -> GarmentMesh:
    """An ``n x n`` vertex grid, ``size`` metres square, horizontal at ``height``, centred on the z axis.

    Vertex ``i * n + j`` sits at ``x = -size/2 + j * size/(n-1)``, ``y = -size/2 + i * size/(n-1)``. Every
    grid cell is split along a diagonal that alternates like a checkerboard (no preferred shear
    direction); triangles are counter-clockwise seen from above (normals +z). No attachments.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"cloth resolution n must be a whole number >= 2 particles per side, got {n!r}")
    coords = np.linspace(-0.5 * size, 0.5 * size, n)
    x, y = np.meshgrid(coords, coords)  # y varies along rows i, x along columns j
    vertices = np.stack([x.ravel(), y.ravel(), np.full(n * n, float(height))], axis=1)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    a, b = i * n + j, i * n + j + 1  # a: (x_j, y_i), b: x_{j+1}
    c, d = a + n, b + n  # c: (x_j, y_{i+1}), d: x_{j+1}
    even = ((i + j) % 2 == 0)[:, None]
    first = np.where(even, np.stack([a, b, d], 1), np.stack([a, b, c], 1))
    second = np.where(even, np.stack([a, d, c], 1), np.stack([b, d, c], 1))
    return GarmentMesh(f"cloth_{n}x{n}", vertices, np.concatenate([first, second]).astype(np.int64), {})


def sphere_x(t: float) -> float:
    """The sphere centre's x at time ``t``: still, then out and back twice at 1 m/s, then still."""
    if t <= STILL_UNTIL_S:
        return 0.0
    t = min(t, MOVING_UNTIL_S) - STILL_UNTIL_S
    leg, into = divmod(t, LEG_S)
    if int(leg) % 2 == 0:
        return SPHERE_SPEED * into
    return SPHERE_SPEED * (LEG_S - into)


def drape_params(n: int, correction_iterations: int = DEFAULT_CORRECTION_ITERATIONS) -> SolverParams:
    """The scene's solver parameters for an ``n x n`` cloth (see the module's notes on the material)."""
    point_mass, substep = CLOTH_MASS_KG / n**2, FRAME_S / SUBSTEPS
    damping = min(SPRING_DAMPING, point_mass / (DAMPED_SPRINGS * substep))  # stable (see the module's notes)
    return DEFAULT_PARAMS.replace(
        point_mass=point_mass, gravity=(0.0, 0.0, -9.81),
        substep=substep, max_substeps=SUBSTEPS, friction=FRICTION,
        stretch_stiffness=100.0, shear_stiffness=100.0, bend_stiffness=0.002,
        stretch_damping=damping, shear_damping=damping, bend_damping=1e-5,
        air_damping=0.2, correction_iterations=correction_iterations, limit_ratio=0.01,
        strain_limit_iterations=STRAIN_LIMIT_ITERATIONS, strain_limit_tolerance=STRAIN_LIMIT_TOLERANCE,
        contact_friction=CONTACT_FRICTION, collision_epsilon=CONTACT_OFFSET_M, contact_margin=CONTACT_MARGIN_M,
    )


class DrapeScene:
    """The drape scene at one resolution; ``advance()`` runs one frame of ``FRAME_S``."""

    def __init__(self, n: int, params: SolverParams | None = None, sphere_motion=sphere_x):
        self.n = n
        self.sphere_motion = sphere_motion
        height = SPHERE_RADIUS_M + START_GAP_M
        self.model = build_cloth_model(square_cloth(n, height=height))
        volumes = VolumeSet((Volume("sphere", SPHERE, SPHERE_FRAME, (SPHERE_RADIUS_M,) * 3),))
        self.solver = GarmentSolver(self.model, volumes, params or drape_params(n))
        self._structural = int(np.count_nonzero(self.model.spring_kinds == STRUCTURAL))
        self.frame = 0
        self.time = 0.0
        self.solver.reset(np.zeros(3), 0.0, *self._sphere_pose(0.0), 0.0)

    def _sphere_pose(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array([[self.sphere_motion(t), 0.0, 0.0]]), np.array([[0.0, 0.0, 0.0, 1.0]])

    def sphere_center(self, t: float | None = None) -> np.ndarray:
        return self._sphere_pose(self.time if t is None else t)[0][0]

    @property
    def positions(self) -> np.ndarray:
        return self.solver.state.positions  # world frame: the root stays at the origin

    def advance(self):
        """One frame; returns the solver's ``FrameReport``."""
        t0 = self.frame * FRAME_S
        t1 = (self.frame + 1) * FRAME_S
        (p0, q0), (p1, q1) = self._sphere_pose(t0), self._sphere_pose(t1)
        still = np.zeros(3)
        report = self.solver.advance(FrameInput(
            t0=t0, t1=t1, root_position0=still, root_yaw0=0.0, root_position1=still, root_yaw1=0.0,
            root_velocity=still, root_acceleration=still, yaw_rate=0.0, yaw_acceleration=0.0,
            frame_positions0=p0, frame_rotations0=q0, frame_positions1=p1, frame_rotations1=q1))
        self.frame += 1
        self.time = t1
        return report

    def penetration(self) -> float:
        """How deep the cloth is inside the sphere now: ``max(0, R - min_i |x_i - c|)``, m."""
        distance = np.sqrt(np.min(np.sum((self.positions - self.sphere_center()) ** 2, axis=1)))
        return max(0.0, SPHERE_RADIUS_M - float(distance))

    def stretch(self) -> float:
        """Largest structural (mesh edge) length / rest length now."""
        return float(kernels.spring_stretches(self.positions, self.model.springs, self.model.rest_lengths,
                                              np.empty(self._structural)))


def run_drape(n: int = DEFAULT_N, frames: int = DEFAULT_FRAMES, warmup: int = WARMUP_FRAMES,
              correction_iterations: int = DEFAULT_CORRECTION_ITERATIONS) -> dict:
    """Run the scene: ``warmup`` untimed frames, then ``frames`` timed ones; the issue's JSON row."""
    if frames < 1 or warmup < 0:
        raise ValueError(f"--frames must be >= 1 and warm-up >= 0, got {frames} and {warmup}")
    scene = DrapeScene(n, drape_params(n, correction_iterations))
    worst_penetration = worst_stretch = 0.0
    finite = True
    wall, cpu = [], []
    for frame in range(warmup + frames):
        tic, cpu_tic = time.perf_counter(), time.process_time()
        scene.advance()
        elapsed, cpu_elapsed = time.perf_counter() - tic, time.process_time() - cpu_tic
        if frame >= warmup:
            wall.append(elapsed)
            cpu.append(cpu_elapsed)
        if not np.all(np.isfinite(scene.positions)):
            finite = False
            break
        worst_penetration = max(worst_penetration, scene.penetration())
        worst_stretch = max(worst_stretch, scene.stretch())
    particles = scene.model.num_points
    seconds = sum(wall)
    return {
        "n": n,
        "particles": particles,
        "frames": len(wall),
        "substeps_per_frame": SUBSTEPS,
        "ms_per_frame": round(seconds / max(1, len(wall)) * 1e3, 4),
        "ms_per_frame_median": round(float(np.median(wall)) * 1e3, 4) if wall else math.nan,
        # the process's CPU time (all threads): steadier than the wall time on a loaded machine, where the wall
        # time also counts the time other processes held the cores
        "cpu_ms_per_frame": round(sum(cpu) / max(1, len(cpu)) * 1e3, 4),
        "particle_substeps_per_s": round(particles * SUBSTEPS * len(wall) / seconds) if seconds > 0 else None,
        "max_penetration_m": worst_penetration,
        "max_stretch": round(worst_stretch, 5),
        "final_top_z_m": round(float(np.max(scene.positions[:, 2])), 5) if finite else None,
        "nan": not finite,
        "springs": int(len(scene.model.springs)),
        "capped_springs": scene.solver.constants.limited_springs,
        "correction_iterations": scene.solver.params.correction_iterations,
        "simulated_s": round(scene.time, 4),
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON line instead of a table")
    parser.add_argument("--n", type=int, nargs="+", default=[DEFAULT_N], metavar="N",
                        help="particles per side; several values give one row each (default: %(default)s)")
    parser.add_argument("--frames", type=int, default=DEFAULT_FRAMES,
                        help=f"timed frames after {WARMUP_FRAMES} warm-up frames (default: %(default)s)")
    parser.add_argument("--iterations", type=int, default=DEFAULT_CORRECTION_ITERATIONS,
                        help="Provot length-correction iterations per substep (default: %(default)s, the "
                             "project's default is 4; more iterations: less stretch, more time)")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (default: numba's)")


def run(args: argparse.Namespace) -> int:
    from ..benchmarking import load_average, progress, set_threads

    threads = set_threads(args.threads)
    if not args.json:
        print(f"drape: 1 m cloth, 0.2 kg, sphere r = {SPHERE_RADIUS_M} m moving along x; {SUBSTEPS} substeps per "
              f"1/30 s frame, {args.iterations} correction iterations; {args.frames} timed frames after "
              f"{WARMUP_FRAMES}; {threads} numba thread(s), "
              f"load {load_average()}")
        print(f"{'n':>4} {'particles':>9} {'ms/frame':>9} {'Mpart-sub/s':>11} {'penetr. mm':>10} {'stretch':>8} "
              f"{'top z m':>8} {'capped':>7} {'nan':>5}")
    for n in args.n:
        progress(f"drape: n = {n} ...")
        row = run_drape(n, args.frames, correction_iterations=args.iterations)
        row["threads"] = threads
        row["load_1min"] = load_average()
        if args.json:
            print(json.dumps(row), flush=True)
            continue
        rate = "-" if row["particle_substeps_per_s"] is None else f"{row['particle_substeps_per_s'] / 1e6:.2f}"
        top = "-" if row["final_top_z_m"] is None else f"{row['final_top_z_m']:.4f}"
        print(f"{n:>4} {row['particles']:>9} {row['ms_per_frame']:>9.3f} {rate:>11} "
              f"{row['max_penetration_m'] * 1e3:>10.3f} {row['max_stretch']:>8.4f} {top:>8} "
              f"{row['capped_springs']:>7} {str(row['nan']):>5}", flush=True)
    return 0
