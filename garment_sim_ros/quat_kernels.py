"""Quaternion math for numba kernels (xyzw, scalars in and tuples out: nothing is allocated).

The numpy twin is ``transforms`` (``quat_rotate``, ``quat_multiply``, ``quat_slerp``,
``quat_to_matrix``); ``test/test_quat_kernels.py`` checks the two against each other. Every kernel
that rotates, composes or interpolates quaternions uses these (forward kinematics, the volumes'
poses in the root frame, the collision handling's pose interpolation).
"""

from __future__ import annotations

import math

from numba import njit

kernel = njit(cache=True, _nrt=False)


@kernel
def rotate(qx, qy, qz, qw, vx, vy, vz):
    """``q v q*`` for a unit quaternion: v + 2 w (u x v) + 2 u x (u x v), u = (qx, qy, qz)."""
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + (qy * tz - qz * ty), vy + qw * ty + (qz * tx - qx * tz),
            vz + qw * tz + (qx * ty - qy * tx))


@kernel
def multiply(ax, ay, az, aw, bx, by, bz, bw):
    """The Hamilton product ``a b`` (b applied first)."""
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@kernel
def slerp(ax, ay, az, aw, bx, by, bz, bw, fraction):
    """Unit quaternion at ``fraction`` from a to b along the shorter arc (linear when they are
    within 1e-12 of each other, where the sine ratio loses its digits), normalised."""
    dot = ax * bx + ay * by + az * bz + aw * bw
    sign = 1.0
    if dot < 0.0:
        sign, dot = -1.0, -dot
    if dot > 1.0 - 1e-12:
        wa, wb = 1.0 - fraction, fraction
    else:
        theta = math.acos(min(1.0, dot))
        wa = math.sin((1.0 - fraction) * theta) / math.sin(theta)
        wb = math.sin(fraction * theta) / math.sin(theta)
    wb *= sign
    qx, qy, qz, qw = wa * ax + wb * bx, wa * ay + wb * by, wa * az + wb * bz, wa * aw + wb * bw
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    return qx / n, qy / n, qz / n, qw / n


@kernel
def matrix_into(out, v, qx, qy, qz, qw):
    """The rotation matrix of unit quaternion q into ``out[v]`` (3, 3)."""
    out[v, 0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    out[v, 0, 1] = 2.0 * (qx * qy - qz * qw)
    out[v, 0, 2] = 2.0 * (qx * qz + qy * qw)
    out[v, 1, 0] = 2.0 * (qx * qy + qz * qw)
    out[v, 1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    out[v, 1, 2] = 2.0 * (qy * qz - qx * qw)
    out[v, 2, 0] = 2.0 * (qx * qz - qy * qw)
    out[v, 2, 1] = 2.0 * (qy * qz + qx * qw)
    out[v, 2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)
