"""The fused frame (issue 15): one compiled call runs all of a frame's substeps of ``GarmentSolver.advance``.

The reference path (``GarmentSolver.advance``'s loop) makes 15 (memo preset) to 56 (a real clip, the strain
limiting on) kernel calls a substep from Python, each paying numba's dispatch (typing its arguments, under
1 us) and the solver's own checks and bookkeeping: 16-20 % of the one-piece's step
(docs/benchmarks.md, "The fused frame"). Here the same kernels
(``cloth.kernels``, ``collision.kernels``, ``collision.crossing``,
``motion_constraints.limit_distance``) are called in the same order with the same arguments from one
numba function, so the garment comes out the same, bit for bit (``test/test_fused.py``), with no Python
and no allocation between substeps. What depends on the frame's clock only (the frame forces, the attached
points' targets, the volumes' poses at the frame's ends, the skinned positions) is computed in Python before
the call, by the reference path's own functions, once per substep or frame.

The collision drivers run their ``prange`` twins when the collider does (``Collider.parallel``): the points
spread over numba's threads inside the call, as they do on the reference path.

Falls back to the reference loop (``usable``): a garment without volumes (the kernel takes the collider's
arrays and scratch; without collision a substep is 4-6 calls, little to save) and a collider with its broad
phase switched off (a test-only switch the kernel does not carry).
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import NumbaPerformanceWarning
from numba.extending import intrinsic

from ..collision import crossing
from ..collision import kernels as collision_kernels
from ..collision.collider import AXIS_PASSES
from ..collision.kernels import parallel_twin
from ..collision.response import MODE_STATIC
from . import kernels
from .motion_constraints import limit_distance

_NO_POINTS = np.zeros((0, 3))
INTEGRATION, CORRECTION, COLLISION, CALL = range(4)  # ``run_substeps``' tick counters
# the collision drivers the serial chain below calls; the parallel chain (``_parallel_chain``) their twins
_handle_all, _handle_contacts = collision_kernels.handle_all, collision_kernels.handle_contacts


@intrinsic
def _cycles(typingctx):
    """The CPU's cycle counter (LLVM's ``readcyclecounter``; 0 where the CPU has none): the stage split inside
    the call, which has no clock of its own. Only ratios of it are used (``advance_substeps``)."""
    def codegen(context, builder, signature, args):
        counter = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.IntType(64), []),
                                                 "llvm.readcyclecounter")
        return builder.call(counter, [])

    return types.int64(), codegen


def usable(solver) -> bool:
    """Whether ``solver``'s configuration runs on the fused path (see the module docstring)."""
    return solver.collider is not None and solver.collider.use_broad_phase


def advance_substeps(solver, frame, count: int, h: float, v0, a0, yaw_rate: float, yaw_acc: float, yaw_step: float,
                     targets0, targets1, skinned, report) -> None:
    """The substep loop of ``GarmentSolver.advance`` for ``count`` substeps of ``h`` s, in one compiled call.

    Per-substep inputs as the reference loop computes them (``relative_frame_forces``, ``wind_velocity``);
    ``skinned``: the motion constraints' skinned positions (N, 3) at the frame's ends, or None when off.
    The collider's ``begin_frame`` must have run. Adds the hits to the collider's counters, and the call's wall
    time to ``report``'s stages, split as the cycle counter measured them inside it (all of it to integration
    on a CPU without one); Python and numba's dispatch around the kernels, a few us, are spread with it."""
    from .solver import relative_frame_forces, wind_velocity

    params, const, model, state, collider = solver.params, solver.constants, solver.model, solver.state, solver.collider
    dt = float(frame.t1 - frame.t0)
    uniform, frame_velocity = np.empty((count, 3)), np.empty((count, 3))
    omega, fractions = np.empty(count), np.empty((count, 2))
    for k in range(count):  # the reference loop's arithmetic, so that every substep sees the same numbers
        f0, f1 = k / count, (k + 1) / count
        mid = 0.5 * (f0 + f1) * dt
        uniform[k], frame_velocity[k] = relative_frame_forces(
            params, frame.root_yaw0 + yaw_step * 0.5 * (f0 + f1), v0 + a0 * mid, a0,
            wind_velocity(params, frame.t0 + mid))
        omega[k] = yaw_rate + yaw_acc * mid
        fractions[k] = f0, f1
    constrained = skinned is not None
    skinned0, skinned1 = skinned if constrained else (_NO_POINTS, _NO_POINTS)
    layout = solver.parallel_layout()
    if layout is None:  # the serial chain: the model's order, as if all of it were the first half
        springs = (model.springs, model.rest_lengths, const.stiffness, const.damping, _first_half(len(model.springs)))
        correction = (model.springs, model.rest_lengths, _first_half(solver._correct_count))
        edges = (solver._edges, solver._edge_rest, _first_half(len(solver._edges)))
    else:  # the parallel chain: in the halves' order (``GarmentSolver.parallel_layout``)
        springs = (layout.springs, layout.rest, layout.stiffness, layout.damping, layout.spring_starts)
        correction = (layout.correction_springs, layout.correction_rest, layout.correction_starts)
        edges = (layout.edges, layout.edge_rest, layout.edge_starts)
    garment = (const.mass, const.inv_mass, springs, correction, model.attached, model.tether_anchors,
               model.tether_lengths, edges, solver._triangles)
    scratch = (solver._forces, solver._x_start, solver._x_collision, solver._x_kept, solver._v_kept,
               solver._v_scratch, solver._strain_inv_mass, solver._strain_stretches, collider._depths,
               collider._scratch, collider._corners, collider.axis_boxes(solver._triangles), solver._x_given)
    settings = (float(h), float(yaw_acc), float(params.air_damping), float(params.angular_inertia_scale),
                int(params.correction_iterations), float(params.limit_ratio),
                bool(params.tethers), 1.0 + float(params.tether_slack), constrained, float(params.max_distance),
                int(params.strain_limit_iterations), float(params.contact_mobility),
                1.0 + params.limit_ratio + params.strain_limit_tolerance, float(solver.STRAIN_LIMIT_UNDONE),
                solver.limit_slides, float(params.tear_give_stretch))
    contact = (collider._eps, collider._friction, collider._c_time, collider._switch_ratio, collider._mode,
               collider._edge_pinch_depth, collider._grip, collider._margin, collider._pinch_depth)
    pressing = collider.pressing
    press = collider._press_with
    ticks = np.zeros(4, dtype=np.int64)
    tic = time.perf_counter()
    n_static, n_dynamic, pressed = (run_substeps_parallel if collider.parallel else run_substeps)(
        state.positions, state.velocities, state.contacts, garment, scratch, uniform, frame_velocity, omega,
        fractions, targets0, targets1, skinned0, skinned1, collider._packed, collider._frame_pos,
        collider._frame_quat, pressing, press, settings, contact, ticks)
    wall = time.perf_counter() - tic
    collider.pressed_depth = max(collider.pressed_depth, float(pressed))
    collider.static_hits += int(n_static)
    collider.dynamic_hits += int(n_dynamic)
    if ticks[CALL] <= 0:
        report.integration_s += wall
        return
    report.integration_s += wall * (ticks[CALL] - ticks[CORRECTION] - ticks[COLLISION]) / ticks[CALL]
    report.correction_s += wall * ticks[CORRECTION] / ticks[CALL]
    report.collision_s += wall * ticks[COLLISION] / ticks[CALL]


def _first_half(count: int) -> np.ndarray:
    """The starts (4,) of ``cloth.halves``' groups with all ``count`` pairs in the first."""
    return np.array([0, count, count, count], dtype=np.int64)


@njit(cache=True)
def _accumulate_in_order(x, v, mass, springs, rest, stiffness, damping, uniform, omega, yaw_acc, air_damping,
                         frame_velocity, rotation_scale, forces, starts):
    """The serial chain's forces: ``kernels.accumulate_forces`` (the springs in the model's order: ``starts``
    unused); the parallel chain's is ``kernels.accumulate_forces_halves``, with the same arguments."""
    kernels.accumulate_forces(x, v, mass, springs, rest, stiffness, damping, uniform, omega, yaw_acc, air_damping,
                              frame_velocity, rotation_scale, forces)


@njit(cache=True)
def _correct_in_order(x, inv_mass, springs, rest, starts, limit_ratio):
    """The serial chain's correction iteration: ``kernels.length_correction`` over the first ``starts[3]`` springs
    in the model's order; the parallel chain's is ``kernels.length_correction_halves``, with the same arguments."""
    return kernels.length_correction(x, inv_mass, springs, rest, starts[3], limit_ratio)


@njit(cache=True)
def _edges_in_order(arrays, xs, x, inv_mass, edges, edge_rest, starts, edge_pinch_depth):
    """The serial chain's edge handling: ``handle_edges`` in the edges' order (``starts`` unused); the parallel
    chain's is ``handle_edges_halves``, with the same arguments."""
    return collision_kernels.handle_edges(arrays, xs, x, inv_mass, edges, edge_rest, edge_pinch_depth)


_accumulate, _correct, _handle_edges = _accumulate_in_order, _correct_in_order, _edges_in_order


@njit(cache=True)
def run_substeps(x, v, contacts, garment, scratch, uniform, frame_velocity, omega, fractions, targets0, targets1,
                 skinned0, skinned1, arrays, frame_pos, frame_quat, pressing, press, settings, contact, ticks):
    """All substeps of a frame, as ``GarmentSolver.advance``'s loop (with a collider) runs them; ``x``, ``v``
    (N, 3) and ``contacts`` in place. Per substep k: ``uniform`` (K, 3) m/s^2, ``frame_velocity`` (K, 3) m/s,
    ``omega`` (K,) rad/s, ``fractions`` (K, 2) of the frame at its ends; the tuples as ``advance_substeps``
    packs them; ``pressing`` the volume pairs that may be pressed together (``Collider``), ``press`` their
    (clearance, gap) m. Returns (static hits, dynamic hits, deepest overlap pressed m); a non-finite force
    sets ``x`` to NaN and stops, as the reference loop does. Adds cycle counts to ``ticks`` (4,): the
    correction's, the collision's (with the volumes' poses per substep), the whole call's; the rest of the
    call is the integration's."""
    start = _cycles()
    mass, inv_mass, springs, correction, attached, tether_anchors, tether_lengths, edges, triangles = garment
    forces, x_start = scratch[0], scratch[1]
    (h, yaw_acc, air_damping, rotation_scale, iterations, limit_ratio, tethers, tether_scale, constrained,
     max_distance, strain_iterations) = settings[:11]
    eps, friction, switch_ratio, mode, grip = contact[0], contact[1], contact[3], contact[4], contact[6]
    n_static = 0
    n_dynamic = 0
    pressed = 0.0
    for k in range(uniform.shape[0]):
        f0, f1 = fractions[k, 0], fractions[k, 1]
        _accumulate(x, v, mass, springs[0], springs[1], springs[2], springs[3], uniform[k], omega[k], yaw_acc,
                    air_damping, frame_velocity[k], rotation_scale, forces, springs[4])
        if not math.isfinite(_sum(forces)):
            x[:] = math.nan  # the guard restores; collision handling would turn NaN into garbage
            break
        kernels.integrate(x, v, forces, inv_mass, h, x_start)
        kernels.set_attached(x, attached, targets0, targets1, f1)
        tic = _cycles()
        # the collider's begin_substep: the volumes' poses at the substep's ends, the planes of ``pressing``
        pressed = max(pressed, collision_kernels.substep_poses(arrays, frame_pos, frame_quat, f0, f1, pressing,
                                                               press[0], press[1], press[2]))
        tac = _cycles()
        ticks[COLLISION] += tac - tic
        for iteration in range(max(1, iterations)):
            if iteration < iterations:
                _correct(x, inv_mass, correction[0], correction[1], correction[2], limit_ratio)
                if tethers:
                    kernels.tether_constraints(x, inv_mass, tether_anchors, tether_lengths, tether_scale)
            if iteration == 0:
                tic = _cycles()
                n_static += _handle_contacts(arrays, x_start, x, v, inv_mass, h, eps, friction, grip, switch_ratio,
                                              mode, contacts)
                ticks[COLLISION] += _cycles() - tic
                tac += _cycles() - tic
        ticks[CORRECTION] += _cycles() - tac
        if constrained:
            limit_distance(x, skinned0, skinned1, f1, max_distance, inv_mass)
        kernels.velocities_from_positions(x, x_start, h, v)
        tic = _cycles()
        scratch[2][:] = x
        s, d = _resolve(arrays, x_start, x, v, inv_mass, h, contacts, edges, triangles, scratch, contact)
        n_static += s
        n_dynamic += d
        ticks[COLLISION] += _cycles() - tic
        if strain_iterations > 0:
            s, d = _limit_strain(arrays, x_start, x, v, inv_mass, h, contacts, correction, edges, triangles, scratch,
                                 settings, contact, skinned0, skinned1, f1, ticks)
            n_static += s
            n_dynamic += d
    ticks[CALL] += _cycles() - start
    return n_static, n_dynamic, pressed


@njit(cache=True)
def _sum(a):
    """The sum of a (N, 3) array's entries (the reference path's finiteness test of the forces)."""
    total = 0.0
    for i in range(a.shape[0]):
        total += a[i, 0] + a[i, 1] + a[i, 2]
    return total


@njit(cache=True)
def _points(arrays, xs, x, v, inv_mass, h, contacts, scratch, contact):
    """``Collider._points``: every point against every volume; (static hits, dynamic hits)."""
    return _handle_all(arrays, xs, x, v, inv_mass, h, contact[0], contact[1], contact[6], contact[2], contact[3],
                       contact[4], contact[7], contacts, scratch[9])


@njit(cache=True)
def _resolve(arrays, xs, x, v, inv_mass, h, contacts, edges, triangles, scratch, contact):
    """``Collider.resolve_substep`` (same calls, same retry); ``edges``: (edges, rest lengths, starts of the
    halves); (static hits, dynamic hits)."""
    eps, friction, switch_ratio, mode, edge_pinch_depth, grip = (
        contact[0], contact[1], contact[3], contact[4], contact[5], contact[6])
    n_static, n_dynamic = _points(arrays, xs, x, v, inv_mass, h, contacts, scratch, contact)
    crossed = crossing.handle_axes(arrays, xs, x, v, inv_mass, h, triangles, eps, AXIS_PASSES, scratch[10],
                                   scratch[11])
    if _handle_edges(arrays, xs, x, inv_mass, edges[0], edges[1], edges[2], edge_pinch_depth) or crossed:
        n_static += _handle_contacts(arrays, xs, x, v, inv_mass, h, eps, friction, grip, switch_ratio, mode,
                                     contacts)
        _handle_edges(arrays, xs, x, inv_mass, edges[0], edges[1], edges[2], edge_pinch_depth)
        s, d = _points(arrays, xs, x, v, inv_mass, h, contacts, scratch, contact)
        n_static += s
        n_dynamic += d
        if crossing.handle_axes(arrays, xs, x, v, inv_mass, h, triangles, eps, AXIS_PASSES, scratch[10], scratch[11]):
            crossing.out_of_pinches(arrays, x, inv_mass, eps, contact[8])
    return n_static, n_dynamic


@njit(cache=True)
def _limit_strain(arrays, xs, x, v, inv_mass, h, contacts, correction, edges, triangles, scratch, settings, contact,
                  skinned0, skinned1, f1, ticks):
    """``GarmentSolver._limit_strain`` (same calls, same order, its stage split); ``correction``: (springs, rest
    lengths, starts of the halves); (static hits, dynamic hits)."""
    tic = _cycles()
    x_collision, x_kept, v_kept, v_scratch, strain_inv_mass, stretches, depths = scratch[2:9]
    limit_ratio, constrained, max_distance, strain_iterations = settings[5], settings[8], settings[9], settings[10]
    springs, rest, starts = correction
    mobility, converged, undone = settings[11], settings[12], settings[13]
    eps, friction, switch_ratio, mode, grip = contact[0], contact[1], contact[3], contact[4], contact[6]
    slides = settings[14]
    start = x if slides else xs  # sliding: static, out across the nearest surface (``GarmentSolver.limit_slides``)
    limit_mode = MODE_STATIC if slides else mode
    kernels.contact_weights(x, x_collision, inv_mass, mobility, strain_inv_mass)
    x_kept[:] = x
    v_kept[:] = v
    worst_kept = kernels.spring_stretches(x, springs, rest, stretches)
    tac = _cycles()
    n_static = 0
    for _ in range(strain_iterations):
        if _correct(x, strain_inv_mass, springs, rest, starts, limit_ratio) <= converged:
            break
        n_static += _handle_contacts(arrays, start, x, v_scratch, inv_mass, h, eps, friction, grip, switch_ratio,
                                      limit_mode, contacts)
    if constrained:
        limit_distance(x, skinned0, skinned1, f1, max_distance, inv_mass)
    for i in range(x.shape[0]):
        for c in range(3):
            v[i, c] += (x[i, c] - x_kept[i, c]) / h
    toc = _cycles()
    s, n_dynamic = _resolve(arrays, xs, x, v, inv_mass, h, contacts, edges, triangles, scratch, contact)
    collision_kernels.penetration_depths(arrays, x, depths)
    kernels.keep_where_inside(x, v, x_kept, v_kept, depths)
    bound = max(worst_kept, undone)
    if kernels.spring_stretches(x, springs, rest, stretches) > bound:
        # the handling threw a point off (see GarmentSolver.STRAIN_LIMIT_UNDONE): not this substep
        collision_kernels.penetration_depths(arrays, x_kept, depths)
        kernels.undo_limiting(x, v, x_kept, v_kept, depths, springs, rest, stretches, bound)
    if settings[15] > 0.0:  # the contacts' room given to torn springs (``Collider.give_room_to_tears``)
        collision_kernels.give_room_to_tears(arrays, x, inv_mass, springs, rest, starts[3], settings[15], eps,
                                             scratch[12])
    ticks[CORRECTION] += toc - tac
    ticks[COLLISION] += (tac - tic) + (_cycles() - toc)
    return n_static + s, n_dynamic


def _parallel_chain():
    """``run_substeps`` with the collision drivers' ``prange`` twins, and every function between them compiled
    with numba's threads too: a cached function without them that calls a parallel one crashes when loaded
    from numba's cache (numba 0.68: a segfault on the first call; compiled fresh it runs)."""
    namespace = dict(globals())
    namespace["_handle_all"] = collision_kernels.handle_all_parallel
    namespace["_handle_contacts"] = collision_kernels.handle_contacts_parallel
    namespace["_accumulate"] = kernels.accumulate_forces_halves
    namespace["_handle_edges"] = collision_kernels.handle_edges_halves
    namespace["_correct"] = kernels.length_correction_halves
    for name in ("_points", "_resolve", "_limit_strain", "run_substeps"):
        namespace[name] = parallel_twin(globals()[name].py_func, namespace)
    return namespace["run_substeps"]


run_substeps_parallel = _parallel_chain()
# The twins have no loop of their own to spread (their threads are the drivers'): numba's note saying so at
# their compilation is expected, not a lost optimisation.
warnings.filterwarnings("ignore", r"(?s)\s*The keyword argument 'parallel=True' was specified.*cloth[/\\]fused\.py",
                        NumbaPerformanceWarning)
