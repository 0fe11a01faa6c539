"""Numba kernels: mass points against quadric volumes (memo §6.2), over flat arrays.

Volumes arrive as flat arrays: ``kinds (V,)``, ``radii (V, 3)``, ``cuts (V, 2)``, bounding and
switch radii ``(V,)``, and their poses at the substep start and end, positions ``(V, 3)`` and
rotation matrices ``(V, 3, 3)`` (local -> simulation frame). Local geometry is the one of
``volumes.py``. Everything is computed in the volume's local frame at the substep END pose,
which is the frame the memo's simplified relative trajectory ``p0' -> p1`` lives in.

Physical choices where the memo's text is loose (each is marked "physics:" below):
- the velocity response is relative to the velocity of the volume's surface at the contact
  point (a swinging leg drags its surface along), and only an approaching normal velocity is
  removed: a point inside but already separating keeps its velocity (no impulse, no friction);
- the point is put ``eps`` outside along the surface normal (the memo's Eq. 6-4 adds eps to x
  and y separately, which is not a distance);
- the slide after a dynamic hit (Eq. 6-8) uses the velocity relative to the surface: the point
  already moves with the volume by being attached to it at the end pose.

Beyond the memo: body volumes overlap at the joints, so a point pushed out of one volume can land
in its neighbour; a point that was hit gets a few extra static passes (``_SETTLE_PASSES``).
The per-point cache (temporal coherence) lists the volumes hit in the last ``handle_all``
first, then older entries the point is still near; the broad phase evicts the far ones.

The local geometry (frames, signed distances, projections, where a path enters a volume) is in
``collision.geometry``; the broad phase of ``handle_all`` and the pose interpolation in
``collision.broad_phase``; this module holds the response and the drivers over points and edges.
"""

from __future__ import annotations

import math

from numba import njit, prange

from .broad_phase import (
    broad_phase_rejects,
    out_of_reach,
    outside_bounding_sphere,
    segment_misses_box,
)
from .geometry import (
    TINY,
    capsule_entry,
    deepest_on_segment,
    kernel,
    penetration_depth,
    quadric_entry,
    rotate,
    static_projection,
    surface_at,
    to_local,
    to_world,
)
from .volumes import CAPSULE, ELLIPSOID, SPHERE

NO_HIT = 0
STATIC_HIT = 1
DYNAMIC_HIT = 2

MODE_ADAPTIVE = 0
MODE_STATIC = 1
MODE_DYNAMIC = 2

_SETTLE_PASSES = 4  # extra static passes for a point hit by a volume (overlapping volumes)


# ----------------------------------------------------------------------------- response

@kernel
def respond_velocity(vx, vy, vz, sx, sy, sz, nx, ny, nz, friction):
    """Memo Eq. 6-2 / 6-8 relative to the surface velocity s, normal n (unit, outward).

    Returns the new RELATIVE velocity: perfectly inelastic (an approaching normal part is
    removed) and the tangential part scaled by the modified Coulomb factor
    ``c = 1 - k_f |v_n| / |v_t|`` if ``|v_t| >= k_f |v_n|`` else 0. The velocity responded is
    the one the point carries into the next substep (after the length correction, Eq. 5-2).
    """
    rx, ry, rz = vx - sx, vy - sy, vz - sz
    vn = rx * nx + ry * ny + rz * nz
    if vn >= 0.0:  # physics: separating (or resting) relative to the surface: no impulse
        return rx, ry, rz
    tx, ty, tz = rx - vn * nx, ry - vn * ny, rz - vn * nz
    vt = math.sqrt(tx * tx + ty * ty + tz * tz)
    if vt >= friction * -vn and vt > 0.0:
        c = 1.0 - friction * -vn / vt
    else:
        c = 0.0
    return c * tx, c * ty, c * tz


@kernel
def surface_velocity(pos0, rot0, pos1, rot1, v, lx, ly, lz, h):
    """Velocity of the volume's material point with local coordinates l over the substep."""
    if h <= 0.0:
        return 0.0, 0.0, 0.0
    ax, ay, az = to_world(pos0, rot0, v, lx, ly, lz)
    bx, by, bz = to_world(pos1, rot1, v, lx, ly, lz)
    return (bx - ax) / h, (by - ay) / h, (bz - az) / h


# A point inside an ellipsoid that came in through one of its cut planes this substep leaves through that
# plane when the static projection (keep z, out across the cross-section) would move it further than this
# share of the volume's smaller radius; nearer the surface it leaves across it, as the memo does. Trousers,
# 9 clips x 1-3x x 60/30 fps, 3 s: guard firings 96 -> 39 (38 on the cartwheel), frames with a leg off
# 246 -> 135. Without the share (any point that came through a cut) hem points at the shins' ankle cut
# went out under the shin and the walks at 30 fps lost a trouser leg (CC walk 1x/2x: 19, 36 frames).
_CUT_EXIT_SHARE = 0.5


@kernel
def handle_pair(kinds, radii, cuts, switch_radii, pos0, rot0, pos1, rot1, v,
                xs, x, vel, i, h, eps, friction, c_time, switch_ratio, mode):
    """Handle point ``i`` against volume ``v``; ``x``, ``vel`` updated in place.

    ``xs[i]`` is the point at the substep start, ``x[i]`` at its end. Returns
    ``(code, alpha, lx, ly, lz)``: NO_HIT / STATIC_HIT / DYNAMIC_HIT, the collision time
    fraction (dynamic) and the contact point (on the surface, before eps) in the local frame
    of the substep-end pose.
    """
    kind = kinds[v]
    bx, by, bz = to_local(pos1, rot1, v, x[i, 0], x[i, 1], x[i, 2])
    use_dynamic = mode == MODE_DYNAMIC
    if mode == MODE_ADAPTIVE or use_dynamic:
        # p0 in the start pose's local frame = p0' in the end pose's local frame (memo §6.2.1)
        ax, ay, az = to_local(pos0, rot0, v, xs[i, 0], xs[i, 1], xs[i, 2])
        if mode == MODE_ADAPTIVE:
            trajectory = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
            use_dynamic = trajectory > switch_ratio * switch_radii[v]
        if use_dynamic:
            if kind == CAPSULE:
                alpha = capsule_entry(radii, v, ax, ay, az, bx, by, bz)
            else:
                alpha = quadric_entry(kind, radii, cuts, v, ax, ay, az, bx, by, bz)
            if alpha >= 0.0:
                sx, sy, sz, nx, ny, nz = surface_at(
                    kind, radii, v, ax + alpha * (bx - ax), ay + alpha * (by - ay), az + alpha * (bz - az))
                _respond(pos0, rot0, pos1, rot1, v, x, vel, i, sx, sy, sz, nx, ny, nz,
                         eps, friction, h, c_time * (1.0 - alpha) * h)
                return DYNAMIC_HIT, alpha, sx, sy, sz
    inside, sx, sy, sz, nx, ny, nz = static_projection(kind, radii, cuts, v, bx, by, bz)
    if not inside:
        return NO_HIT, -1.0, bx, by, bz
    reach = _CUT_EXIT_SHARE * min(radii[v, 0], radii[v, 1])
    if kind == ELLIPSOID and (sx - bx) ** 2 + (sy - by) ** 2 > reach * reach:
        # A point that came in through a cut plane this substep goes back out through it, not across the
        # cross-section: the pelvis' bottom cut is open between the thighs, and a crotch seam a few mm up
        # into it was thrown 14 cm sideways, across a thigh (see _CUT_EXIT_SHARE).
        ax, ay, az = to_local(pos0, rot0, v, xs[i, 0], xs[i, 1], xs[i, 2])
        if az < cuts[v, 0] and cuts[v, 0] > -radii[v, 2]:
            sx, sy, sz, nx, ny, nz = bx, by, cuts[v, 0], 0.0, 0.0, -1.0
        elif az > cuts[v, 1] and cuts[v, 1] < radii[v, 2]:
            sx, sy, sz, nx, ny, nz = bx, by, cuts[v, 1], 0.0, 0.0, 1.0
    _respond(pos0, rot0, pos1, rot1, v, x, vel, i, sx, sy, sz, nx, ny, nz, eps, friction, h, 0.0)
    return STATIC_HIT, 1.0, sx, sy, sz


@kernel
def _respond(pos0, rot0, pos1, rot1, v, x, vel, i, sx, sy, sz, nx, ny, nz, eps, friction, h, slide_time):
    """Put point i at the local surface point s + eps n (end pose), respond its velocity, and
    slide it for ``slide_time`` with the new velocity relative to the surface (Eq. 6-8).

    physics: eps is a distance along the normal (not the memo's eps per coordinate); the slide
    is relative to the surface, since sitting at the end pose already carries the point along;
    the surface velocity is the one of the volume's material point at the contact.
    """
    cx, cy, cz = sx + eps * nx, sy + eps * ny, sz + eps * nz
    svx, svy, svz = surface_velocity(pos0, rot0, pos1, rot1, v, cx, cy, cz, h)
    wnx, wny, wnz = rotate(rot1, v, nx, ny, nz)
    rx, ry, rz = respond_velocity(vel[i, 0], vel[i, 1], vel[i, 2], svx, svy, svz, wnx, wny, wnz, friction)
    px, py, pz = to_world(pos1, rot1, v, cx, cy, cz)
    x[i, 0] = px + slide_time * rx
    x[i, 1] = py + slide_time * ry
    x[i, 2] = pz + slide_time * rz
    vel[i, 0] = svx + rx
    vel[i, 1] = svy + ry
    vel[i, 2] = svz + rz


# ----------------------------------------------------------------------------- drivers over points

@kernel
def _next_candidate(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache, start):
    """The first uncached volume ``v >= start`` that point i may hit (within its reach, then its local box
    meets the segment p0' -> p1); the volume count if none. Most pairs end here, in a few dozen flops."""
    n_volumes = reach.shape[0]
    for v in range(start, n_volumes):
        if out_of_reach(reach, pos1, v, x, i):
            continue
        bx, by, bz = to_local(pos1, rot1, v, x[i, 0], x[i, 1], x[i, 2])
        ax, ay, az = to_local(pos0, rot0, v, xs[i, 0], xs[i, 1], xs[i, 2])
        if segment_misses_box(boxes, v, ax, ay, az, bx, by, bz):
            continue
        cached = False
        for c in range(cache.shape[1]):
            cached = cached or cache[i, c] == v
        if not cached:
            return v
    return n_volumes


@kernel
def _needs_handling(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache):
    """Whether point i has a cached volume or may hit another one; if not, ``_handle_point_all`` would
    change nothing. Checked first, in a loop without the handling's code, as most points are clear."""
    for c in range(cache.shape[1]):
        if cache[i, c] >= 0:
            return True
    return _next_candidate(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache, 0) < reach.shape[0]


@kernel
def _record(scratch, i, start, count, capacity, v):
    """Append v to the list scratch[i, start:start + count] unless it is there or full; new count."""
    for k in range(count):
        if scratch[i, start + k] == v:
            return count
    if count < capacity:
        scratch[i, start + count] = v
        return count + 1
    return count


@kernel
def _handle_point_all(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                      displacement, chord, reach, boxes, xs, x, vel, i, h, eps, friction, c_time, switch_ratio,
                      mode, cache, scratch):
    """Point i against every volume, cached volumes first (temporal coherence), then rebuilds
    its cache row: this call's hits first, then the older entries the point is still near
    (the broad phase evicts the others). ``scratch[i]`` (length 2 C) holds the hits in its
    first half and the kept entries in its second. Returns (static hits, dynamic hits)."""
    n_volumes = kinds.shape[0]
    cache_size = cache.shape[1]
    n_static = 0
    n_dynamic = 0
    n_hits = 0
    n_kept = 0
    for s in range(cache_size):
        v = cache[i, s]
        if v < 0:
            continue
        # A cached volume the point left is evicted by the bounding-sphere test, which decides what
        # handle_contacts sees next.
        if (out_of_reach(reach, pos1, v, x, i)
                or broad_phase_rejects(bounding_radii, pos0, pos1, displacement, chord, v, xs, x, i)):
            continue
        code = handle_pair(kinds, radii, cuts, switch_radii, pos0, rot0, pos1, rot1, v,
                           xs, x, vel, i, h, eps, friction, c_time, switch_ratio, mode)[0]
        if code == NO_HIT:
            n_kept = _record(scratch, i, cache_size, n_kept, cache_size, v)
            continue
        if code == STATIC_HIT:
            n_static += 1
        else:
            n_dynamic += 1
        n_hits = _record(scratch, i, 0, n_hits, cache_size, v)
    v = _next_candidate(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache, 0)
    while v < n_volumes:
        code = handle_pair(kinds, radii, cuts, switch_radii, pos0, rot0, pos1, rot1, v,
                           xs, x, vel, i, h, eps, friction, c_time, switch_ratio, mode)[0]
        if code != NO_HIT:
            if code == STATIC_HIT:
                n_static += 1
            else:
                n_dynamic += 1
            n_hits = _record(scratch, i, 0, n_hits, cache_size, v)
        # from the point's current position: a hit has moved it
        v = _next_candidate(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache, v + 1)
    # Volumes overlap at the joints: being pushed out of one can push a point into its
    # neighbour (the crotch between pelvis and thigh). A few static passes settle it.
    for _ in range(_SETTLE_PASSES if n_static + n_dynamic > 0 else 0):
        moved = False
        for v in range(n_volumes):
            if outside_bounding_sphere(bounding_radii, pos1, v, x, i):
                continue
            code = handle_pair(kinds, radii, cuts, switch_radii, pos0, rot0, pos1, rot1, v,
                               xs, x, vel, i, h, eps, friction, c_time, switch_ratio, MODE_STATIC)[0]
            if code != NO_HIT:
                moved = True
                n_static += 1
                n_hits = _record(scratch, i, 0, n_hits, cache_size, v)
        if not moved:
            break
    slot = 0
    for k in range(n_hits):
        cache[i, slot] = scratch[i, k]
        slot += 1
    for k in range(n_kept):
        v = scratch[i, cache_size + k]
        hit = False
        for j in range(n_hits):
            hit = hit or scratch[i, j] == v
        if not hit and slot < cache_size:
            cache[i, slot] = v
            slot += 1
    for c in range(slot, cache_size):
        cache[i, c] = -1
    return n_static, n_dynamic


@kernel
def handle_all(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
               displacement, chord, reach, boxes, xs, x, vel, inv_mass, h, eps, friction, c_time, switch_ratio,
               mode, cache, scratch):
    """Memo §3 step 5 over all points (serial). Returns (static hits, dynamic hits)."""
    n_static = 0
    n_dynamic = 0
    for i in range(x.shape[0]):
        if inv_mass[i] == 0.0 or not _needs_handling(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache):
            continue
        s, d = _handle_point_all(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                                 displacement, chord, reach, boxes, xs, x, vel, i, h, eps, friction, c_time,
                                 switch_ratio, mode, cache, scratch)
        n_static += s
        n_dynamic += d
    return n_static, n_dynamic


@njit(cache=True, parallel=True)
def handle_all_parallel(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                        displacement, chord, reach, boxes, xs, x, vel, inv_mass, h, eps, friction, c_time,
                        switch_ratio, mode, cache, scratch):
    """``handle_all`` with the points spread over threads (points are independent here)."""
    n_static = 0
    n_dynamic = 0
    for i in prange(x.shape[0]):
        if inv_mass[i] != 0.0 and _needs_handling(pos0, rot0, pos1, rot1, reach, boxes, xs, x, i, cache):
            s, d = _handle_point_all(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                                     displacement, chord, reach, boxes, xs, x, vel, i, h, eps, friction, c_time,
                                     switch_ratio, mode, cache, scratch)
            n_static += s
            n_dynamic += d
    return n_static, n_dynamic


@kernel
def _contacts_point(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1, xs, x, vel,
                    i, h, eps, friction, switch_ratio, mode, cache):
    """Point i against its cached volumes (``handle_contacts``); the number of hits."""
    n_moved = 0
    for c in range(cache.shape[1]):
        v = cache[i, c]
        if v < 0:
            continue
        b = math.sqrt((x[i, 0] - pos1[v, 0]) ** 2 + (x[i, 1] - pos1[v, 1]) ** 2 + (x[i, 2] - pos1[v, 2]) ** 2)
        if b > bounding_radii[v]:
            continue
        code = handle_pair(kinds, radii, cuts, switch_radii, pos0, rot0, pos1, rot1, v,
                           xs, x, vel, i, h, eps, friction, 0.0, switch_ratio, mode)[0]
        if code != NO_HIT:
            n_moved += 1
    return n_moved


@kernel
def handle_contacts(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1, xs, x, vel,
                    inv_mass, h, eps, friction, switch_ratio, mode, cache):
    """Memo §3 step 4: the cached (point, volume) pairs at the end poses, during the length correction.

    ``mode`` as in ``handle_pair``, from the substep's start positions ``xs``. physics: the correction
    can pull a point deep into a thin limb (towards a neighbour on the limb's far side); pushed out
    radially from there it lands wherever it happens to be relative to the axis, and edges end up
    straddling the limb. Tested along its relative trajectory, a deep point goes back out where it
    came in. No slide here (c_time 0): the velocities are recomputed after the correction and the
    full handling responds them. Returns the number of points moved out."""
    n_moved = 0
    for i in range(x.shape[0]):
        if inv_mass[i] != 0.0:
            n_moved += _contacts_point(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                                       xs, x, vel, i, h, eps, friction, switch_ratio, mode, cache)
    return n_moved


@njit(cache=True, parallel=True)
def handle_contacts_parallel(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1, xs, x, vel,
                             inv_mass, h, eps, friction, switch_ratio, mode, cache):
    """``handle_contacts`` with the points spread over threads (each point only touches its own row)."""
    n_moved = 0
    for i in prange(x.shape[0]):
        if inv_mass[i] != 0.0:
            n_moved += _contacts_point(kinds, radii, cuts, bounding_radii, switch_radii, pos0, rot0, pos1, rot1,
                                       xs, x, vel, i, h, eps, friction, switch_ratio, mode, cache)
    return n_moved


# Edges up to this many times their rest length are not tested: between two points outside a convex
# volume such a chord dips at most its sagitta, which exceeds the rest length's by (L/2)^2 (slack - 1) / r
# -- under 0.1 mm for 3 cm edges on a 5 cm limb -- and the length correction keeps most edges within 1 %.
_EDGE_SLACK = 1.02


@kernel
def handle_edges(kinds, radii, cuts, bounding_radii, boxes, pos0, rot0, pos, rot, edges, rest_lengths, xs, x,
                 inv_mass):
    """Cloth edges against the volumes at the end poses (beyond the memo, which handles mass points only).

    physics: a limb pressed into an edge pushes its two mass points apart round its sides; once the
    edge is stretched past the limb's width the limb slips between them and slices the cloth, both
    points outside it. An edge of rest length L lying across a limb of local radius r may dip into it
    by the sagitta ``r - sqrt(r^2 - (L/2)^2)`` (a polygon wrapping a round limb); an edge dipping
    deeper is being cut: it is moved out along the volume's normal at its deepest point to that dip,
    translating both free ends (an attached end stays). Ends inside are the point handling's.
    The side is the one the edge came from when that point of the edge was clear of the volume at the
    substep's start (``xs``, start poses ``pos0``/``rot0``), as the dynamic point handling does -- a
    limb moving further than its radius in one substep can pass an edge's middle past its axis;
    else the nearer one. Returns the number of edges moved.
    """
    n_moved = 0
    for e in range(edges.shape[0]):
        a = edges[e, 0]
        b = edges[e, 1]
        if inv_mass[a] == 0.0 and inv_mass[b] == 0.0:
            continue
        length2 = (x[b, 0] - x[a, 0]) ** 2 + (x[b, 1] - x[a, 1]) ** 2 + (x[b, 2] - x[a, 2]) ** 2
        if length2 < (1.0 - 1e-9) * (_EDGE_SLACK * rest_lengths[e]) ** 2:
            continue  # most edges, without a square root; the exact test below decides the borderline ones
        half = 0.5 * math.sqrt(length2)
        if 2.0 * half <= _EDGE_SLACK * rest_lengths[e]:
            continue  # a chord barely longer than its rest length between two outside points dips no deeper
        mx, my, mz = 0.5 * (x[a, 0] + x[b, 0]), 0.5 * (x[a, 1] + x[b, 1]), 0.5 * (x[a, 2] + x[b, 2])
        for v in range(kinds.shape[0]):
            reach = bounding_radii[v] + half
            if (mx - pos[v, 0]) ** 2 + (my - pos[v, 1]) ** 2 + (mz - pos[v, 2]) ** 2 > reach * reach:
                continue
            ax, ay, az = to_local(pos, rot, v, x[a, 0], x[a, 1], x[a, 2])
            bx, by, bz = to_local(pos, rot, v, x[b, 0], x[b, 1], x[b, 2])
            if segment_misses_box(boxes, v, ax, ay, az, bx, by, bz):
                continue  # no point of the edge is inside the volume
            t, inside = deepest_on_segment(kinds[v], radii, cuts, v, ax, ay, az, bx, by, bz)
            if not inside or t <= 0.0 or t >= 1.0:
                continue
            px, py, pz = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
            inside, sx, sy, sz, nx, ny, nz = static_projection(kinds[v], radii, cuts, v, px, py, pz)
            if not inside:
                continue
            # the same point of the edge at the substep's start, in the volume's frame (p0', memo §6.2.1)
            ox, oy, oz = to_local(pos0, rot0, v, xs[a, 0] + t * (xs[b, 0] - xs[a, 0]),
                                  xs[a, 1] + t * (xs[b, 1] - xs[a, 1]), xs[a, 2] + t * (xs[b, 2] - xs[a, 2]))
            if (kinds[v] != CAPSULE and ox * nx + oy * ny < 0.0
                    and not static_projection(kinds[v], radii, cuts, v, ox, oy, oz)[0]):
                # it was clear of the volume, beyond the axis: out there, where the axis' perpendicular
                # towards the start point meets the surface (static projection of a point just off it)
                ux, uy = ox, oy
                norm = math.sqrt(ux * ux + uy * uy)
                if norm > TINY:
                    lift = 1e-6 * max(radii[v, 0], radii[v, 1])
                    inside, sx, sy, sz, nx, ny, nz = static_projection(
                        kinds[v], radii, cuts, v, lift * ux / norm, lift * uy / norm, pz)
                    if not inside:
                        continue
            dip = math.sqrt((sx - px) ** 2 + (sy - py) ** 2 + (sz - pz) ** 2)
            r = radii[v, 0] if kinds[v] == SPHERE else math.sqrt(sx * sx + sy * sy)
            half_chord = min(r, 0.5 * rest_lengths[e])
            excess = dip - (r - math.sqrt(r * r - half_chord * half_chord))
            if excess <= 0.0:
                continue
            wx, wy, wz = rotate(rot, v, excess * nx, excess * ny, excess * nz)
            for i in (a, b):
                if inv_mass[i] > 0.0:
                    x[i, 0] += wx
                    x[i, 1] += wy
                    x[i, 2] += wz
            n_moved += 1
    return n_moved


@kernel
def penetration_depths(kinds, radii, cuts, pos, rot, x, out):
    """Depth of every point inside its deepest volume (see ``penetration_depth``), 0 outside."""
    for i in range(x.shape[0]):
        deepest = 0.0
        for v in range(kinds.shape[0]):
            lx, ly, lz = to_local(pos, rot, v, x[i, 0], x[i, 1], x[i, 2])
            deepest = max(deepest, penetration_depth(kinds[v], radii, cuts, v, lx, ly, lz))
        out[i] = deepest
    return out
