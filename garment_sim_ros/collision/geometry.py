"""Local geometry of the quadric volumes for the numba kernels: frames, signed distances, the static
projection out of a volume, penetration depth and where a straight path enters a volume.

Volumes as in ``volumes.py`` (kinds, radii (V, 3) m, cuts (V, 2) m), posed by positions (V, 3) m and
rotation matrices (V, 3, 3) (local -> simulation frame), and cut by their contact planes (``planes``
(V, P, 4), local, ``collision.contact_planes``): a point beyond one of a volume's planes is not inside
it, and a point inside that is nearer a plane than the curved surface leaves through the plane. One
point against one volume is ``collision.response``; the drivers over points and edges
``collision.kernels``; the broad phase ``collision.broad_phase``; the bone crossing ``collision.crossing``.
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
# A kernel called per point, pair or edge from another, inlined in numba's IR into its callers: a call LLVM leaves
# standing passes each array argument field by field (the volumes' bundle ~170 arguments), which cost more than
# the work of a point it left (docs/benchmarks.md, "Calls per point").
inlined_kernel = njit(cache=True, _nrt=False, inline="always")


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


# ----------------------------------------------------------------------------- contact planes

@kernel
def plane_gap(planes, v, x, y, z):
    """``(gap, k)``: how far (m) the local point is on the kept side of volume v's nearest contact plane k;
    negative beyond it (the most negative of the planes it is beyond); ``(inf, -1)`` without planes.
    A plane row is (unit normal out of the kept side, offset): kept where n . p <= offset; the used rows
    come first, an offset of +inf ends them (``contact_planes``)."""
    gap, nearest = math.inf, -1
    for k in range(planes.shape[1]):
        offset = planes[v, k, 3]
        if offset == math.inf:
            break
        g = offset - (planes[v, k, 0] * x + planes[v, k, 1] * y + planes[v, k, 2] * z)
        if g < gap:
            gap, nearest = g, k
    return gap, nearest


@kernel
def clip_to_planes(planes, v, x0, y0, z0, x1, y1, z1):
    """``(t_in, t_out, k)``: the part [t_in, t_out] of the segment p0 -> p1 (t in [0, 1]) on the kept side of
    every contact plane of volume v (Cyrus-Beck), and the plane k it enters through at t_in (-1: it starts on
    the kept side). Empty when t_in > t_out."""
    t_in, t_out, face = 0.0, 1.0, -1
    for k in range(planes.shape[1]):
        offset = planes[v, k, 3]
        if offset == math.inf:
            break
        nx, ny, nz = planes[v, k, 0], planes[v, k, 1], planes[v, k, 2]
        f0 = nx * x0 + ny * y0 + nz * z0 - offset
        f1 = nx * x1 + ny * y1 + nz * z1 - offset
        if f0 > 0.0:
            if f1 > 0.0:
                return 2.0, -1.0, -1
            t = f0 / (f0 - f1)
            if t > t_in:
                t_in, face = t, k
        elif f1 > 0.0:
            t_out = min(t_out, f0 / (f0 - f1))
    return t_in, t_out, face


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


@inlined_kernel
def static_projection(kind, radii, cuts, planes, v, x, y, z):
    """Static handling geometry (memo Eq. 6-1, 6-3, 6-4) in the local frame.

    Returns ``(inside, sx, sy, sz, nx, ny, nz)``: whether the point is inside the volume and,
    if so, the surface point it is moved to (without eps) and the unit outward normal there.
    A point beyond a contact plane is not inside; one inside that is nearer a contact plane than the
    curved surface point below goes onto the plane, along its normal (pressed flesh: the body there is
    the plane). Else: sphere: radially from the centre. Ellipsoid: z kept, (x, y) scaled onto the
    cross-section ellipse at that z, only where ``cut[0] <= z <= cut[1]``. Capsule: along the exact
    distance gradient, i.e. radially from the nearest point of the tapered axis.
    """
    inside, sx, sy, sz, nx, ny, nz = _shape_projection(kind, radii, cuts, v, x, y, z)
    if not inside or planes[v, 0, 3] == math.inf:
        return inside, sx, sy, sz, nx, ny, nz
    gap, k = plane_gap(planes, v, x, y, z)
    if gap < 0.0:
        return False, x, y, z, nx, ny, nz
    if gap * gap < (sx - x) ** 2 + (sy - y) ** 2 + (sz - z) ** 2:
        px, py, pz = planes[v, k, 0], planes[v, k, 1], planes[v, k, 2]
        return True, x + gap * px, y + gap * py, z + gap * pz, px, py, pz
    return True, sx, sy, sz, nx, ny, nz


@inlined_kernel
def _shape_projection(kind, radii, cuts, v, x, y, z):
    """``static_projection`` of the uncut shape (no contact planes)."""
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
def penetration_depth(kind, radii, cuts, planes, v, x, y, z):
    """Depth (m) of a local point inside the volume, 0 outside.

    With contact planes: 0 beyond one, else at most the distance to the nearest (the volume as pressed).
    Sphere and capsule: exact. Ellipsoid (inside and within the cut): an upper bound of the
    exact distance to the ellipsoid's surface, the smallest of the distances to three surface
    points: the static projection (cross-section), the radial one from the centre, and the
    one reached along the gradient direction (tight near the surface, second order). The cut
    planes are joins to neighbouring volumes, not surfaces, so depth is measured to the
    curved surface only. An upper bound makes "deeper than 1 mm" assertions conservative.
    """
    if planes[v, 0, 3] == math.inf:  # not pressed: most volumes, most of the time
        return _shape_depth(kind, radii, cuts, v, x, y, z)
    gap = plane_gap(planes, v, x, y, z)[0]
    if gap <= 0.0:
        return 0.0
    return min(gap, _shape_depth(kind, radii, cuts, v, x, y, z))


@kernel
def _shape_depth(kind, radii, cuts, v, x, y, z):
    """``penetration_depth`` of the uncut shape (no contact planes)."""
    if kind == ELLIPSOID:
        inside, sx, sy, sz, nx, ny, nz = _shape_projection(kind, radii, cuts, v, x, y, z)
        if not inside:
            return 0.0
        ax, ay, az = radii[v, 0], radii[v, 1], radii[v, 2]
        best = math.sqrt((sx - x) ** 2 + (sy - y) ** 2 + (sz - z) ** 2)
        q = math.sqrt((x / ax) ** 2 + (y / ay) ** 2 + (z / az) ** 2)
        if q > TINY:
            best = min(best, math.sqrt(x * x + y * y + z * z) * (1.0 / q - 1.0))
        gx, gy, gz = _unit_gradient(ax, ay, az, x, y, z)
        t = ray_exit(ax, ay, az, x, y, z, gx, gy, gz)
        if t >= 0.0:
            best = min(best, t)
        return best
    if kind == SPHERE:
        d, nx, ny, nz = _sphere_sdf(radii[v, 0], x, y, z)
    else:
        d, nx, ny, nz = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
    return max(0.0, -d)


@kernel
def ray_exit(ax, ay, az, x, y, z, dx, dy, dz):
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
def inside_shape(kind, radii, cuts, v, x, y, z):
    """Whether the local point is inside the uncut shape (within an ellipsoid's cut)."""
    if kind == CAPSULE:
        return capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)[0] < 0.0
    if kind == ELLIPSOID and (z < cuts[v, 0] or z > cuts[v, 1]):
        return False
    return (x / radii[v, 0]) ** 2 + (y / radii[v, 1]) ** 2 + (z / radii[v, 2]) ** 2 < 1.0


@kernel
def entry(kind, radii, cuts, planes, v, x0, y0, z0, x1, y1, z1):
    """``(alpha, face)``: the first alpha in [0, 1] where the local segment p0 -> p1 enters the volume as
    its contact planes cut it, and through which face: -1 the curved surface (``quadric_entry``,
    ``capsule_entry``), k its contact plane k. ``(-1, -1)`` when it does not (or starts inside).

    The kept part of the segment is [t_in, t_out] (``clip_to_planes``): a curved entry beyond a plane is
    none; a segment that starts beyond a plane and is inside the shape where it crosses onto the kept side
    enters through the plane (a point that was beyond the pressed face and is now inside)."""
    if planes[v, 0, 3] == math.inf:  # not pressed
        return _shape_entry(kind, radii, cuts, v, x0, y0, z0, x1, y1, z1), -1
    t_in, t_out, face = clip_to_planes(planes, v, x0, y0, z0, x1, y1, z1)
    if t_in > t_out:
        return -1.0, -1
    alpha = _shape_entry(kind, radii, cuts, v, x0, y0, z0, x1, y1, z1)
    if alpha >= t_in:
        return (alpha, -1) if alpha <= t_out else (-1.0, -1)
    if face >= 0 and inside_shape(kind, radii, cuts, v, x0 + t_in * (x1 - x0), y0 + t_in * (y1 - y0),
                                  z0 + t_in * (z1 - z0)):
        return t_in, face
    return -1.0, -1


@kernel
def _shape_entry(kind, radii, cuts, v, x0, y0, z0, x1, y1, z1):
    if kind == CAPSULE:
        return capsule_entry(radii, v, x0, y0, z0, x1, y1, z1)
    return quadric_entry(kind, radii, cuts, v, x0, y0, z0, x1, y1, z1)


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
def surface_at(kind, radii, planes, v, face, x, y, z):
    """Closest-surface point and unit normal for a point on (or within tolerance of) the surface, on its
    curved part (``face`` -1) or on contact plane ``face`` (``entry``)."""
    if face >= 0:
        return x, y, z, planes[v, face, 0], planes[v, face, 1], planes[v, face, 2]
    if kind == CAPSULE:
        d, nx, ny, nz = capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
        return x - d * nx, y - d * ny, z - d * nz, nx, ny, nz
    nx, ny, nz = _unit_gradient(radii[v, 0], radii[v, 1], radii[v, 2], x, y, z)
    return x, y, z, nx, ny, nz


@kernel
def deepest_on_segment(kind, radii, cuts, planes, v, ax, ay, az, bx, by, bz):
    """Where the segment a -> b (local frame) goes deepest into volume v: ``(t, inside)``.

    Ellipsoid and sphere: the point nearest the centre in coordinates scaled by the radii (exact);
    capsule: the minimum of the signed distance along the segment (convex) by golden-section search.
    Outside the cut (a join to the neighbouring volume) is not inside, nor beyond a contact plane (that
    deepest point of the uncut shape is then pressed away).
    """
    t, inside = _deepest_in_shape(kind, radii, cuts, v, ax, ay, az, bx, by, bz)
    if inside and planes[v, 0, 3] != math.inf:
        inside = plane_gap(planes, v, ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az))[0] > 0.0
    return t, inside


@kernel
def _deepest_in_shape(kind, radii, cuts, v, ax, ay, az, bx, by, bz):
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
