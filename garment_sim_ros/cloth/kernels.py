"""Numba kernels of the mass-spring solver (memo §5), over flat float64 arrays.

Positions and velocities are in the simulation frame: the root frame, translating with the
pelvis and turning with its heading (memo §4, extended to rotation about z).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .. import quat_kernels as quat
from ..collision.geometry import _shape_projection, ray_exit
from ..collision.volumes import ELLIPSOID as ELLIPSOID_KIND


@njit(cache=True)
def accumulate_forces(x, v, mass, springs, rest, stiffness, damping, uniform_accel, omega_z, alpha_z,
                      drag_rate, frame_velocity, rotation_scale, forces):
    """Total force on every point (memo Eq. 4-2 with the root's rotation, plus Provot springs).

    Per point of mass m at x with frame-relative velocity v:
      m * uniform_accel                                   gravity and the linear inertial force -m a0
      - m * rotation_scale * (alpha x r + omega x (omega x r) + 2 omega x v)   Euler, centrifugal, Coriolis
      - m * drag_rate * (v + frame_velocity + rotation_scale * omega x r)      air resistance, relative to air
      + springs with damping along the spring.
    ``frame_velocity`` is the root's scaled velocity minus the wind, both in the root frame.
    """
    for i in range(x.shape[0]):
        forces[i, 0], forces[i, 1], forces[i, 2] = _frame_force(x, v, mass, i, uniform_accel, omega_z, alpha_z,
                                                                drag_rate, frame_velocity, rotation_scale)
    _add_spring_forces(x, v, springs, rest, stiffness, damping, 0, springs.shape[0], forces)


@njit(cache=True, parallel=True)
def accumulate_forces_halves(x, v, mass, springs, rest, stiffness, damping, uniform_accel, omega_z, alpha_z,
                             drag_rate, frame_velocity, rotation_scale, forces, starts):
    """``accumulate_forces`` on two threads: the points' own forces over the threads, then the springs of each
    half of the garment on its own thread and those across the cut after them (the springs, their rest lengths,
    stiffnesses and dampings in ``cloth.halves``' order, ``starts`` (4,) its groups'). The same forces up to the
    order of the sums at the points near the cut; the same on any number of threads."""
    for i in prange(x.shape[0]):
        forces[i, 0], forces[i, 1], forces[i, 2] = _frame_force(x, v, mass, i, uniform_accel, omega_z, alpha_z,
                                                                drag_rate, frame_velocity, rotation_scale)
    for half in prange(2):
        _add_spring_forces(x, v, springs, rest, stiffness, damping, starts[half], starts[half + 1], forces)
    _add_spring_forces(x, v, springs, rest, stiffness, damping, starts[2], starts[3], forces)


@njit(cache=True, inline="always")
def _frame_force(x, v, mass, i, uniform_accel, omega_z, alpha_z, drag_rate, frame_velocity, rotation_scale):
    """Point i's force from the moving frame and the air (``accumulate_forces``' first three terms)."""
    m = mass[i]
    rx, ry = x[i, 0], x[i, 1]  # the rotation is about z: r_z plays no part
    vx, vy, vz = v[i, 0], v[i, 1], v[i, 2]
    # omega = (0, 0, w): omega x r = (-w ry, w rx, 0); omega x (omega x r) = (-w^2 rx, -w^2 ry, 0)
    w = omega_z
    fict_x = alpha_z * -ry - w * w * rx + 2.0 * (-w * vy)
    fict_y = alpha_z * rx - w * w * ry + 2.0 * (w * vx)
    spin_x = -w * ry
    spin_y = w * rx
    return (m * (uniform_accel[0] - rotation_scale * fict_x
                 - drag_rate * (vx + frame_velocity[0] + rotation_scale * spin_x)),
            m * (uniform_accel[1] - rotation_scale * fict_y
                 - drag_rate * (vy + frame_velocity[1] + rotation_scale * spin_y)),
            m * (uniform_accel[2] - drag_rate * (vz + frame_velocity[2])))


@njit(cache=True)
def _add_spring_forces(x, v, springs, rest, stiffness, damping, start, end, forces):
    """The forces of the springs ``start:end``, with damping along each, added to their first ends and taken
    from their second."""
    for k in range(start, end):
        s = np.uint64(k)  # unsigned: no test for a negative index (a run from a start not known >= 0: 10 % dearer)
        a = springs[s, 0]
        b = springs[s, 1]
        dx = x[b, 0] - x[a, 0]
        dy = x[b, 1] - x[a, 1]
        dz = x[b, 2] - x[a, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        if length < 1e-12:
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        closing = (v[b, 0] - v[a, 0]) * ux + (v[b, 1] - v[a, 1]) * uy + (v[b, 2] - v[a, 2]) * uz
        magnitude = stiffness[s] * (length - rest[s]) + damping[s] * closing
        forces[a, 0] += magnitude * ux
        forces[a, 1] += magnitude * uy
        forces[a, 2] += magnitude * uz
        forces[b, 0] -= magnitude * ux
        forces[b, 1] -= magnitude * uy
        forces[b, 2] -= magnitude * uz


@njit(cache=True)
def integrate(x, v, forces, inv_mass, h, x_start):
    """Explicit step: ``x_start = x``; ``x += (v + F/m h) h`` for free points (see ``cloth.solver`` on Eq. 5-1)."""
    for i in range(x.shape[0]):
        x_start[i, 0] = x[i, 0]
        x_start[i, 1] = x[i, 1]
        x_start[i, 2] = x[i, 2]
        w = inv_mass[i]
        if w == 0.0:
            continue
        x[i, 0] += (v[i, 0] + forces[i, 0] * w * h) * h
        x[i, 1] += (v[i, 1] + forces[i, 1] * w * h) * h
        x[i, 2] += (v[i, 2] + forces[i, 2] * w * h) * h


@njit(cache=True)
def length_correction(x, inv_mass, springs, rest, count, limit_ratio):
    """One Provot iteration over the first ``count`` springs: shorten every spring longer than
    ``(1 + limit_ratio) * rest`` back to that length, moving both ends by their inverse masses.
    Returns the largest length / rest length it met, before shortening (0 for no springs)."""
    return _correct_run(x, inv_mass, springs, rest, 0, count, limit_ratio)


@njit(cache=True, parallel=True)
def length_correction_halves(x, inv_mass, springs, rest, starts, limit_ratio):
    """``length_correction`` on two threads: each half of the garment's springs on its own thread, in the model's
    order, then those across the cut (the springs and their rest lengths in ``cloth.halves``' order, ``starts``
    (4,) its groups'). The same on any number of threads. Returns the largest length / rest length it met,
    before shortening (0 for no springs)."""
    worst = np.zeros(3)  # per group (numba's reductions do not reach into the runs)
    for half in prange(2):
        worst[half] = _correct_run(x, inv_mass, springs, rest, starts[half], starts[half + 1], limit_ratio)
    worst[2] = _correct_run(x, inv_mass, springs, rest, starts[2], starts[3], limit_ratio)
    return worst.max()


@njit(cache=True)
def _correct_run(x, inv_mass, springs, rest, start, end, limit_ratio):
    """``length_correction`` of the springs ``start:end``; the largest length / rest length it met."""
    worst = 0.0
    for k in range(start, end):
        s = np.uint64(k)  # unsigned: no test for a negative index (a run from a start not known >= 0: 10 % dearer)
        a = springs[s, 0]
        b = springs[s, 1]
        dx, dy, dz, length = _spring_vector(x, a, b)
        limit = (1.0 + limit_ratio) * rest[s]
        worst = max(worst, length / rest[s])
        if length <= limit:
            continue
        wa = inv_mass[a]
        wb = inv_mass[b]
        total = wa + wb
        if total == 0.0:
            continue
        scale = (length - limit) / (length * total)
        x[a, 0] += wa * scale * dx
        x[a, 1] += wa * scale * dy
        x[a, 2] += wa * scale * dz
        x[b, 0] -= wb * scale * dx
        x[b, 1] -= wb * scale * dy
        x[b, 2] -= wb * scale * dz
    return worst


@njit(cache=True)
def tether_constraints(x, inv_mass, anchors, lengths, scale):
    """Long-range attachments: a free point i farther than ``scale * lengths[i]`` from its anchor
    ``anchors[i]`` (an attached point; -1: none) goes straight back towards it to that distance.
    Unilateral (a point nearer than that is left alone) and only the free point moves: the anchor is
    carried by its segment. Returns how many points were moved."""
    moved = 0
    for i in range(x.shape[0]):
        a = anchors[i]
        if a < 0 or inv_mass[i] == 0.0:
            continue
        dx, dy, dz, distance = _spring_vector(x, a, i)
        limit = scale * lengths[i]
        if distance <= limit:
            continue
        pull = 1.0 - limit / distance
        x[i, 0] -= pull * dx
        x[i, 1] -= pull * dy
        x[i, 2] -= pull * dz
        moved += 1
    return moved


@njit(cache=True)
def contact_weights(x, x_before, inv_mass, mobility, out):
    """Inverse masses for the strain limiting after collision handling: a point the handling moved
    (``x`` differs from ``x_before``) is in contact and takes ``mobility`` of its share; ``out`` (N,)."""
    for i in range(x.shape[0]):
        touched = x[i, 0] != x_before[i, 0] or x[i, 1] != x_before[i, 1] or x[i, 2] != x_before[i, 2]
        out[i] = inv_mass[i] * mobility if touched else inv_mass[i]


@njit(cache=True)
def keep_where_inside(x, v, x_kept, v_kept, depth):
    """Points inside a volume (``depth`` > 0) go back to ``x_kept`` with ``v_kept``; returns how many did."""
    restored = 0
    for i in range(x.shape[0]):
        if depth[i] > 0.0:
            for c in range(3):
                x[i, c] = x_kept[i, c]
                v[i, c] = v_kept[i, c]
            restored += 1
    return restored


@njit(cache=True)
def undo_limiting(x, v, x_kept, v_kept, depth_kept, springs, rest, stretches, bound):
    """The strain limiting undone (``GarmentSolver.STRAIN_LIMIT_UNDONE``): points back to ``x_kept`` with ``v_kept``,
    but those inside a volume there (``depth_kept`` > 0) that the limiting's collision handling took out keep where
    it put them (``x``: every point is outside or at ``x_kept``, ``keep_where_inside``), unless a spring (``springs``,
    ``rest``; ``stretches`` scratch) then ends longer than ``bound``: then all go back. Returns whether some kept."""
    kept = False
    for i in range(x.shape[0]):
        if depth_kept[i] > 0.0:
            kept = True
            continue
        for c in range(3):
            x[i, c] = x_kept[i, c]
            v[i, c] = v_kept[i, c]
    if kept and spring_stretches(x, springs, rest, stretches) > bound:
        x[:] = x_kept
        v[:] = v_kept
        kept = False
    return kept


@njit(cache=True)
def velocities_from_positions(x, x_start, h, v):
    """Memo Eq. 5-2: ``v = (x_corrected - x_start) / h``."""
    inv_h = 1.0 / h
    for i in range(x.shape[0]):
        v[i, 0] = (x[i, 0] - x_start[i, 0]) * inv_h
        v[i, 1] = (x[i, 1] - x_start[i, 1]) * inv_h
        v[i, 2] = (x[i, 2] - x_start[i, 2]) * inv_h


@njit(cache=True)
def set_attached(x, attached, targets0, targets1, fraction):
    """Attached points to their targets, ``fraction`` of the way from ``targets0`` to ``targets1``."""
    for k in range(attached.shape[0]):
        i = attached[k]
        for c in range(3):
            x[i, c] = targets0[k, c] + fraction * (targets1[k, c] - targets0[k, c])


@njit(cache=True)
def push_out_of_volumes(targets, positions, rotations, kinds, radii, cuts, chosen, clearance):
    """Each target (A, 3) inside one of the ``chosen`` volumes (indices; poses ``positions`` (V, 3),
    ``rotations`` (V, 4) xyzw, in the root frame) moved out of it ``clearance`` m beyond its surface:
    across the volume's axis towards the root's vertical axis (an ellipsoid), so that every target leaves
    a limb on the side facing the trunk; along the outward normal otherwise."""
    for k in range(targets.shape[0]):
        for j in range(chosen.shape[0]):
            v = chosen[j]
            qx, qy, qz, qw = rotations[v, 0], rotations[v, 1], rotations[v, 2], rotations[v, 3]
            lx, ly, lz = quat.rotate(-qx, -qy, -qz, qw, targets[k, 0] - positions[v, 0],
                                     targets[k, 1] - positions[v, 1], targets[k, 2] - positions[v, 2])
            inside, sx, sy, sz, nx, ny, nz = _shape_projection(kinds[v], radii, cuts, v, lx, ly, lz)
            if not inside:
                continue
            # towards the trunk: the root's vertical axis, seen across the volume's axis
            dx, dy, _ = quat.rotate(-qx, -qy, -qz, qw, -targets[k, 0], -targets[k, 1], 0.0)
            across = math.sqrt(dx * dx + dy * dy)
            if kinds[v] == ELLIPSOID_KIND and across > 1e-9:
                dx, dy = dx / across, dy / across
                exit_at = ray_exit(radii[v, 0], radii[v, 1], radii[v, 2], lx, ly, lz, dx, dy, 0.0)
                if exit_at >= 0.0:
                    sx, sy, sz = lx + exit_at * dx, ly + exit_at * dy, lz
                    nx, ny, nz = dx, dy, 0.0
            wx, wy, wz = quat.rotate(qx, qy, qz, qw, sx + clearance * nx, sy + clearance * ny, sz + clearance * nz)
            targets[k, 0] = positions[v, 0] + wx
            targets[k, 1] = positions[v, 1] + wy
            targets[k, 2] = positions[v, 2] + wz


@njit(cache=True)
def spread_along_band(targets, skinned, springs, rest, limit_ratio):
    """A band's springs between attached targets (A, 3) m kept within ``(1 + limit_ratio) x rest`` after some
    targets were moved off their ``skinned`` places (A, 3) m (``push_out_of_volumes``): of a spring (``springs``
    (B, 2) indices into the targets, ``rest`` (B,) m) with a moved end that is longer than that, the end moved
    less is pulled along the spring to that length, so that a moved stretch of band drags its neighbours with
    it, a ramp rather than a tear. Sweeps in the springs' order and against it, repeated while such a spring
    is over, at most ``targets.shape[0]`` times (a ramp as long as the band); a spring with neither end moved
    is left as skinned. Returns the longest length / rest length of a spring with a moved end met in the last
    round, before its pulls (at most ``1 + limit_ratio`` once converged), as ``length_correction`` reports."""
    worst = 0.0
    for _ in range(targets.shape[0]):
        worst = 0.0
        for sweep in range(2):
            for m in range(springs.shape[0]):
                s = m if sweep == 0 else springs.shape[0] - 1 - m
                a, b = springs[s, 0], springs[s, 1]
                moved_a = _squared_distance(targets, skinned, a)
                moved_b = _squared_distance(targets, skinned, b)
                if moved_a == 0.0 and moved_b == 0.0:
                    continue
                dx, dy, dz, length = _spring_vector(targets, a, b)
                worst = max(worst, length / rest[s])
                limit = (1.0 + limit_ratio) * rest[s]
                if length <= limit:
                    continue
                pull = (length - limit) / length
                if moved_a < moved_b:  # a follows b
                    targets[a, 0] += pull * dx
                    targets[a, 1] += pull * dy
                    targets[a, 2] += pull * dz
                else:
                    targets[b, 0] -= pull * dx
                    targets[b, 1] -= pull * dy
                    targets[b, 2] -= pull * dz
        if worst <= 1.0 + limit_ratio + 1e-9:
            break
    return worst


@njit(cache=True, inline="always")
def _squared_distance(x, y, i):
    """|x[i] - y[i]|^2."""
    return (x[i, 0] - y[i, 0]) ** 2 + (x[i, 1] - y[i, 1]) ** 2 + (x[i, 2] - y[i, 2]) ** 2


@njit(cache=True)
def spring_stretches(x, springs, rest, out):
    """Length / rest length of the first ``len(out)`` springs (S, 2) of points ``x`` (N, 3) into ``out``;
    returns the largest (0 for none). The one stretch figure of the solver, its guard and ``quality``."""
    worst = 0.0
    for s in range(out.shape[0]):
        out[s] = _spring_vector(x, springs[s, 0], springs[s, 1])[3] / rest[s]
        worst = max(worst, out[s])
    return worst


@njit(cache=True, inline="always")
def _spring_vector(x, a, b):
    """(dx, dy, dz, length) from point a to point b."""
    dx = x[b, 0] - x[a, 0]
    dy = x[b, 1] - x[a, 1]
    dz = x[b, 2] - x[a, 2]
    return dx, dy, dz, np.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def vertex_normals(x, triangles, normals):
    """Area-weighted unit vertex normals."""
    normals[:] = 0.0
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        e1x, e1y, e1z = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
        e2x, e2y, e2z = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        for k in (a, b, c):
            normals[k, 0] += nx
            normals[k, 1] += ny
            normals[k, 2] += nz
    for i in range(normals.shape[0]):
        length = np.sqrt(normals[i, 0] ** 2 + normals[i, 1] ** 2 + normals[i, 2] ** 2)
        if length > 0.0:
            normals[i, 0] /= length
            normals[i, 1] /= length
            normals[i, 2] /= length


@njit(cache=True)
def poses_in_root_frame(root_position, root_yaw, frame_positions, frame_rotations, index, offset_positions,
                        offset_rotations, out_positions, out_rotations):
    """For each k: the pose ``frame[index[k]] * offset[k]`` (world) expressed in the root frame
    (pelvis position, heading ``root_yaw``); the volumes' poses the collision handling works in.
    ``offset_rotations`` may be empty: then only positions are written (attached points)."""
    c, s = math.cos(0.5 * root_yaw), math.sin(0.5 * root_yaw)  # inverse heading: (0, 0, -s, c)
    for k in range(index.shape[0]):
        f = index[k]
        qx, qy, qz, qw = frame_rotations[f, 0], frame_rotations[f, 1], frame_rotations[f, 2], frame_rotations[f, 3]
        ox, oy, oz = quat.rotate(qx, qy, qz, qw, offset_positions[k, 0], offset_positions[k, 1], offset_positions[k, 2])
        wx = frame_positions[f, 0] + ox - root_position[0]
        wy = frame_positions[f, 1] + oy - root_position[1]
        wz = frame_positions[f, 2] + oz - root_position[2]
        out_positions[k, 0], out_positions[k, 1], out_positions[k, 2] = quat.rotate(0.0, 0.0, -s, c, wx, wy, wz)
        if offset_rotations.shape[0] == 0:
            continue
        bx, by, bz, bw = offset_rotations[k, 0], offset_rotations[k, 1], offset_rotations[k, 2], offset_rotations[k, 3]
        # world = q * offset, then (0, 0, -s, c) * world
        rx, ry, rz, rw = quat.multiply(qx, qy, qz, qw, bx, by, bz, bw)
        (out_rotations[k, 0], out_rotations[k, 1], out_rotations[k, 2],
         out_rotations[k, 3]) = quat.multiply(0.0, 0.0, -s, c, rx, ry, rz, rw)
