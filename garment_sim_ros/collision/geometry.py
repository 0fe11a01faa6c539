"""Local geometry of the quadric volumes for the numba kernels: frames, signed distances, the static
projection out of a volume, penetration depth and where a straight path enters a volume.

Volumes as in ``volumes.py`` (kinds, radii (V, 3) m, cuts (V, 2) m), posed by positions (V, 3) m and
rotation matrices (V, 3, 3) (local -> simulation frame). One point against one volume is
``collision.response``; the drivers over points and edges ``collision.kernels``; the broad phase
``collision.broad_phase``; the bone crossing ``collision.crossing``.
"""

from __future__ import annotations

import math

from numba import njit

from .volumes import CAPSULE, ELLIPSOID, SPHERE

TINY = 1e-12
_TRACE_TOLERANCE = 1e-7  # m: sphere tracing stops this close to a capsule's surface
_TRACE_ITERATIONS = 48
_SEARCH_ITERATIONS = 60

# The kernels work in place on their arguments and allocate nothing, so they are compiled without numba's
# runtime (``_nrt=False``, as numba's own allocation-free helpers are): a call from one kernel to another then
# no longer increments and decrements an atomic reference count per array argument, which was most of
# handle_all's time (docs/benchmarks.md). A kernel that allocated would fail to compile, not misbehave.
kernel = njit(cache=True, _nrt=False)


# ----------------------------------------------------------------------------- frames

@kernel
def to_local(pos, rot, v, px, py, pz):
    """Simulation-frame point -> local coordinates of volume ``v`` (R^T (p - pos))."""
    dx = px - pos[v, 0]
    dy = py - pos[v, 1]
    dz = pz - pos[v, 2]
    # rot[v, r, c], not a view rot[v]: no array is made per call in the hot loops
    return (rot[v, 0, 0] * dx + rot[v, 1, 0] * dy + rot[v, 2, 0] * dz,
            rot[v, 0, 1] * dx + rot[v, 1, 1] * dy + rot[v, 2, 1] * dz,
            rot[v, 0, 2] * dx + rot[v, 1, 2] * dy + rot[v, 2, 2] * dz)


@kernel
def to_world(pos, rot, v, lx, ly, lz):
    return (pos[v, 0] + rot[v, 0, 0] * lx + rot[v, 0, 1] * ly + rot[v, 0, 2] * lz,
            pos[v, 1] + rot[v, 1, 0] * lx + rot[v, 1, 1] * ly + rot[v, 1, 2] * lz,
            pos[v, 2] + rot[v, 2, 0] * lx + rot[v, 2, 1] * ly + rot[v, 2, 2] * lz)


@kernel
def rotate(rot, v, lx, ly, lz):
    return (rot[v, 0, 0] * lx + rot[v, 0, 1] * ly + rot[v, 0, 2] * lz,
            rot[v, 1, 0] * lx + rot[v, 1, 1] * ly + rot[v, 1, 2] * lz,
            rot[v, 2, 0] * lx + rot[v, 2, 1] * ly + rot[v, 2, 2] * lz)


# ----------------------------------------------------------------------------- geometry

@kernel
def capsule_sdf(r_bottom, r_top, half_length, x, y, z):
    """Exact signed distance and unit outward normal of a tapered capsule (round cone).

    The convex hull of the sphere ``r_bottom`` at ``z = -half_length`` and the sphere
    ``r_top`` at ``z = +half_length``; in the (rho, z) half plane the surface is the two
    circles joined by their common tangent line (after Quilez's round-cone distance).
    """
    height = 2.0 * half_length
    w = z + half_length
    rho = math.sqrt(x * x + y * y)
    if rho > TINY:
        ux, uy = x / rho, y / rho
    else:  # on the axis: any radial direction is as good
        ux, uy = 1.0, 0.0
    b = (r_bottom - r_top) / height
    if abs(b) >= 1.0:  # one end sphere contains the other: the capsule is that sphere
        cz = -half_length if r_bottom >= r_top else half_length
        radius = max(r_bottom, r_top)
        return _sphere_sdf(radius, x, y, z - cz)
    a = math.sqrt(1.0 - b * b)
    k = -b * rho + a * w
    if k < 0.0:
        return _sphere_sdf(r_bottom, x, y, z + half_length)
    if k > a * height:
        return _sphere_sdf(r_top, x, y, z - half_length)
    return a * rho + b * w - r_bottom, a * ux, a * uy, b


@kernel
def _sphere_sdf(radius, x, y, z):
    d = math.sqrt(x * x + y * y + z * z)
    if d > TINY:
        return d - radius, x / d, y / d, z / d
    return -radius, 0.0, 0.0, 1.0


@kernel
def _unit_gradient(ax, ay, az, x, y, z):
    """Unit outward normal of the quadric (x/ax)^2 + (y/ay)^2 + (z/az)^2 = 1 at (x, y, z)."""
    gx = x / (ax * ax)
    gy = y / (ay * ay)
    gz = z / (az * az)
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if g > TINY:
        return gx / g, gy / g, gz / g
    return 0.0, 0.0, 1.0


@kernel
def static_projection(kind, radii, cuts, v, x, y, z):
    """Static handling geometry (memo Eq. 6-1, 6-3, 6-4) in the local frame.

    Returns ``(inside, sx, sy, sz, nx, ny, nz)``: whether the point is inside the volume and,
    if so, the surface point it is moved to (without eps) and the unit outward normal there.
    Sphere: radially from the centre. Ellipsoid: z kept, (x, y) scaled onto the cross-section
    ellipse at that z, only where ``cut[0] <= z <= cut[1]``. Capsule: along the exact distance
    gradient, i.e. radially from the nearest point of the tapered axis.
    """
    if kind == SPHERE:
        r = radii[v, 0]
        d, nx, ny, nz = _sphere_sdf(r, x, y, z)
        if d >= 0.0:
            return False, x, y, z, nx, ny, nz
        return True, r * nx, r * ny, r * nz, nx, ny, nz
    if kind == ELLIPSOID:
        ax, ay, az = radii[v, 0], radii[v, 1], radii[v, 2]
        if z < cuts[v, 0] or z > cuts[v, 1]:
            return False, x, y, z, 0.0, 0.0, 1.0
        xy = (x / ax) ** 2 + (y / ay) ** 2
        zz = (z / az) ** 2
        if xy + zz >= 1.0:
            return False, x, y, z, 0.0, 0.0, 1.0
        section = math.sqrt(max(0.0, 1.0 - zz))  # cross-section scale at this z
        if xy > TINY * TINY:
            s = section / math.sqrt(xy)
            sx, sy = s * x, s * y
        else:  # on the axis: out along local x
            sx, sy = section * ax, 0.0
        nx, ny, nz = _unit_gradient(ax, ay, az, sx, sy, z)
        return True, sx, sy, z, nx, ny, nz
    d, nx, ny, nz = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
    if d >= 0.0:
        return False, x, y, z, nx, ny, nz
    return True, x - d * nx, y - d * ny, z - d * nz, nx, ny, nz


@kernel
def penetration_depth(kind, radii, cuts, v, x, y, z):
    """Depth (m) of a local point inside the volume, 0 outside.

    Sphere and capsule: exact. Ellipsoid (inside and within the cut): an upper bound of the
    exact distance to the ellipsoid's surface, the smallest of the distances to three surface
    points: the static projection (cross-section), the radial one from the centre, and the
    one reached along the gradient direction (tight near the surface, second order). The cut
    planes are joins to neighbouring volumes, not surfaces, so depth is measured to the
    curved surface only. An upper bound makes "deeper than 1 mm" assertions conservative.
    """
    if kind == ELLIPSOID:
        inside, sx, sy, sz, nx, ny, nz = static_projection(kind, radii, cuts, v, x, y, z)
        if not inside:
            return 0.0
        ax, ay, az = radii[v, 0], radii[v, 1], radii[v, 2]
        best = math.sqrt((sx - x) ** 2 + (sy - y) ** 2 + (sz - z) ** 2)
        q = math.sqrt((x / ax) ** 2 + (y / ay) ** 2 + (z / az) ** 2)
        if q > TINY:
            best = min(best, math.sqrt(x * x + y * y + z * z) * (1.0 / q - 1.0))
        gx, gy, gz = _unit_gradient(ax, ay, az, x, y, z)
        t = _ray_exit(ax, ay, az, x, y, z, gx, gy, gz)
        if t >= 0.0:
            best = min(best, t)
        return best
    if kind == SPHERE:
        d, nx, ny, nz = _sphere_sdf(radii[v, 0], x, y, z)
    else:
        d, nx, ny, nz = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
    return max(0.0, -d)


@kernel
def _ray_exit(ax, ay, az, x, y, z, dx, dy, dz):
    """Positive parameter where the ray (x, y, z) + t d leaves the quadric, from inside; -1 if none."""
    qa = (dx / ax) ** 2 + (dy / ay) ** 2 + (dz / az) ** 2
    qb = 2.0 * (x * dx / (ax * ax) + y * dy / (ay * ay) + z * dz / (az * az))
    qc = (x / ax) ** 2 + (y / ay) ** 2 + (z / az) ** 2 - 1.0
    disc = qb * qb - 4.0 * qa * qc
    if qa < TINY or disc < 0.0:
        return -1.0
    return (-qb + math.sqrt(disc)) / (2.0 * qa)


# ----------------------------------------------------------------------------- dynamic detection

@kernel
def quadric_entry(kind, radii, cuts, v, x0, y0, z0, x1, y1, z1):
    """Memo Eq. 6-5, 6-6: first alpha in [0, 1] where l(alpha) = p0' + alpha (p1 - p0') enters
    the sphere/ellipsoid through its curved surface within the cut; -1 if it does not.

    -1 as well when p0' is already inside (nothing to enter; the caller falls back to static
    handling of p1) and for a grazing ray (discriminant < 0). A segment whose entry point lies
    beyond a cut enters through a cut plane: cut planes are joins to the neighbouring volumes,
    not surfaces, so that is no hit either; if p1 ends inside, static handling pushes it out
    across the curved surface, as the memo does for slow points (or, far from it, back through
    the cut: ``_CUT_EXIT_SHARE``).
    """
    ax, ay, az = radii[v, 0], radii[v, 1], radii[v, 2]
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    qa = (dx / ax) ** 2 + (dy / ay) ** 2 + (dz / az) ** 2
    qb = 2.0 * (x0 * dx / (ax * ax) + y0 * dy / (ay * ay) + z0 * dz / (az * az))
    qc = (x0 / ax) ** 2 + (y0 / ay) ** 2 + (z0 / az) ** 2 - 1.0
    if qc <= 0.0 or qb >= 0.0 or qa < TINY:
        return -1.0  # starts inside/on it, or moves away from it (both roots < 0), or does not move
    disc = qb * qb - 4.0 * qa * qc
    if disc < 0.0:
        return -1.0
    alpha = 2.0 * qc / (-qb + math.sqrt(disc))  # the smaller root, in the cancellation-free form
    if alpha > 1.0:
        return -1.0
    if kind == ELLIPSOID:
        z = z0 + alpha * dz
        if z < cuts[v, 0] or z > cuts[v, 1]:
            return -1.0
    return alpha


@kernel
def capsule_minimum(r_bottom, r_top, half_length, ox, oy, oz, dx, dy, dz, lo, hi, iterations):
    """Golden-section search for the t in [lo, hi] where the capsule's signed distance at o + t d is
    least (one minimum: the capsule is convex); the middle of the last bracket."""
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(iterations):
        m1 = hi - g * (hi - lo)
        m2 = lo + g * (hi - lo)
        f1 = capsule_sdf(r_bottom, r_top, half_length, ox + m1 * dx, oy + m1 * dy, oz + m1 * dz)[0]
        f2 = capsule_sdf(r_bottom, r_top, half_length, ox + m2 * dx, oy + m2 * dy, oz + m2 * dz)[0]
        if f1 < f2:
            hi = m2
        else:
            lo = m1
    return 0.5 * (lo + hi)


@kernel
def capsule_entry(radii, v, x0, y0, z0, x1, y1, z1):
    """First alpha in [0, 1] where the segment enters the tapered capsule; -1 if it does not.

    Sphere tracing on the exact signed distance (never steps past the surface); a grazing
    segment that has not converged after a few dozen steps is finished by a golden-section
    search for the minimum of the distance along the segment (convex: the capsule is convex)
    and a bisection between the last outside point and that minimum.
    """
    rb, rt, hl = radii[v, 0], radii[v, 1], radii[v, 2]
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    d0 = capsule_sdf(rb, rt, hl, x0, y0, z0)[0]
    if d0 <= 0.0 or length < TINY:
        return -1.0
    ux, uy, uz = dx / length, dy / length, dz / length
    t = 0.0
    for _ in range(_TRACE_ITERATIONS):
        d = capsule_sdf(rb, rt, hl, x0 + t * ux, y0 + t * uy, z0 + t * uz)[0]
        if d < _TRACE_TOLERANCE:
            return t / length
        t += d
        if t > length:
            return -1.0
    # grazing: minimise the distance over [t, length]
    t_min = capsule_minimum(rb, rt, hl, x0, y0, z0, ux, uy, uz, t, length, _SEARCH_ITERATIONS)
    if capsule_sdf(rb, rt, hl, x0 + t_min * ux, y0 + t_min * uy, z0 + t_min * uz)[0] > 0.0:
        return -1.0
    lo, hi = t, t_min
    for _ in range(_SEARCH_ITERATIONS):
        mid = 0.5 * (lo + hi)
        if capsule_sdf(rb, rt, hl, x0 + mid * ux, y0 + mid * uy, z0 + mid * uz)[0] > 0.0:
            lo = mid
        else:
            hi = mid
    return hi / length


@kernel
def surface_at(kind, radii, v, x, y, z):
    """Closest-surface point and unit normal for a point on (or within tolerance of) the surface."""
    if kind == CAPSULE:
        d, nx, ny, nz = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
        return x - d * nx, y - d * ny, z - d * nz, nx, ny, nz
    nx, ny, nz = _unit_gradient(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
    return x, y, z, nx, ny, nz


@kernel
def deepest_on_segment(kind, radii, cuts, v, ax, ay, az, bx, by, bz):
    """Where the segment a -> b (local frame) goes deepest into volume v: ``(t, inside)``.

    Ellipsoid and sphere: the point nearest the centre in coordinates scaled by the radii (exact);
    capsule: the minimum of the signed distance along the segment (convex) by golden-section search.
    Outside the cut (a join to the neighbouring volume) is not inside.
    """
    dx, dy, dz = bx - ax, by - ay, bz - az
    if kind == CAPSULE:
        t = capsule_minimum(radii[v, 0], radii[v, 1], radii[v, 2], ax, ay, az, dx, dy, dz, 0.0, 1.0,
                             _SEARCH_ITERATIONS // 2)
        depth = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], ax + t * dx, ay + t * dy, az + t * dz)[0]
        return t, depth < 0.0
    rx, ry, rz = radii[v, 0], radii[v, 1], radii[v, 2]
    sx, sy, sz = ax / rx, ay / ry, az / rz
    ex, ey, ez = dx / rx, dy / ry, dz / rz
    ee = ex * ex + ey * ey + ez * ez
    t = 0.0 if ee < TINY * TINY else min(1.0, max(0.0, -(sx * ex + sy * ey + sz * ez) / ee))
    qx, qy, qz = sx + t * ex, sy + t * ey, sz + t * ez
    if qx * qx + qy * qy + qz * qz >= 1.0:
        return t, False
    z = az + t * dz
    return t, kind == SPHERE or cuts[v, 0] <= z <= cuts[v, 1]
