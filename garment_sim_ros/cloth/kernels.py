"""Numba kernels of the mass-spring solver (memo §5), over flat float64 arrays.

Positions and velocities are in the simulation frame: the root frame, translating with the
pelvis and turning with its heading (memo §4, extended to rotation about z).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .. import quat_kernels as quat


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
    for s in range(springs.shape[0]):
        a = springs[s, 0]
        b = springs[s, 1]
        fx, fy, fz = _spring_force(x, v, a, b, rest[s], stiffness[s], damping[s])
        forces[a, 0] += fx
        forces[a, 1] += fy
        forces[a, 2] += fz
        forces[b, 0] -= fx
        forces[b, 1] -= fy
        forces[b, 2] -= fz


@njit(cache=True, parallel=True)
def accumulate_forces_gathered(x, v, mass, springs, rest, stiffness, damping, uniform_accel, omega_z, alpha_z,
                               drag_rate, frame_velocity, rotation_scale, forces, incidence, spring_forces):
    """``accumulate_forces`` over numba's threads: each spring's force into ``spring_forces`` (S, 3), then each
    point gathers its springs' (``incidence``: ``spring_incidence``'s CSR) instead of the springs scattering
    into the points, so no two threads write one point. The same forces up to the order of the sum per point;
    the same on any number of threads."""
    starts, ends = incidence
    for s in prange(springs.shape[0]):
        spring_forces[s, 0], spring_forces[s, 1], spring_forces[s, 2] = _spring_force(
            x, v, springs[s, 0], springs[s, 1], rest[s], stiffness[s], damping[s])
    for i in prange(x.shape[0]):
        fx, fy, fz = _frame_force(x, v, mass, i, uniform_accel, omega_z, alpha_z, drag_rate, frame_velocity,
                                  rotation_scale)
        for k in range(starts[i], starts[i + 1]):
            e = ends[k]
            if e >= 0:  # point i is the spring's first end: pulled towards the second
                fx, fy, fz = fx + spring_forces[e, 0], fy + spring_forces[e, 1], fz + spring_forces[e, 2]
            else:
                e = ~e
                fx, fy, fz = fx - spring_forces[e, 0], fy - spring_forces[e, 1], fz - spring_forces[e, 2]
        forces[i, 0], forces[i, 1], forces[i, 2] = fx, fy, fz


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


@njit(cache=True, inline="always")
def _spring_force(x, v, a, b, rest, stiffness, damping):
    """The force on point a of the spring from a to b, with damping along it (b gets its opposite)."""
    dx = x[b, 0] - x[a, 0]
    dy = x[b, 1] - x[a, 1]
    dz = x[b, 2] - x[a, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length < 1e-12:
        return 0.0, 0.0, 0.0
    ux, uy, uz = dx / length, dy / length, dz / length
    closing = (v[b, 0] - v[a, 0]) * ux + (v[b, 1] - v[a, 1]) * uy + (v[b, 2] - v[a, 2]) * uz
    magnitude = stiffness * (length - rest) + damping * closing
    return magnitude * ux, magnitude * uy, magnitude * uz


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
    worst = 0.0
    for s in range(count):
        worst = max(worst, _correct_spring(x, inv_mass, springs[s, 0], springs[s, 1], rest[s], limit_ratio))
    return worst


@njit(cache=True, parallel=True)  # a prange reduction (max) needs numba's runtime
def coloured_length_correction(x, inv_mass, springs, rest, colour_starts, limit_ratio, sweeps):
    """``sweeps`` iterations of ``length_correction`` over ``springs`` grouped by colour (``colour_order``: no two
    springs of a colour share a point), each colour's springs over numba's threads. The same result on any number
    of threads. Returns the largest length / rest length the first sweep met (0 for no springs)."""
    worst = 0.0
    for sweep in range(sweeps):
        for c in range(colour_starts.shape[0] - 1):
            met = 0.0
            for s in prange(colour_starts[c], colour_starts[c + 1]):
                met = max(met, _correct_spring(x, inv_mass, springs[s, 0], springs[s, 1], rest[s], limit_ratio))
            if sweep == 0:
                worst = max(worst, met)
    return worst


@njit(cache=True, inline="always")
def _correct_spring(x, inv_mass, a, b, rest, limit_ratio):
    """Shorten the spring from a to b to ``(1 + limit_ratio) * rest`` if it is longer (``length_correction``);
    returns its length / rest length before."""
    dx, dy, dz, length = _spring_vector(x, a, b)
    limit = (1.0 + limit_ratio) * rest
    if length <= limit:
        return length / rest
    wa = inv_mass[a]
    wb = inv_mass[b]
    total = wa + wb
    if total == 0.0:
        return length / rest
    scale = (length - limit) / (length * total)
    x[a, 0] += wa * scale * dx
    x[a, 1] += wa * scale * dy
    x[a, 2] += wa * scale * dz
    x[b, 0] -= wb * scale * dx
    x[b, 1] -= wb * scale * dy
    x[b, 2] -= wb * scale * dz
    return length / rest


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
