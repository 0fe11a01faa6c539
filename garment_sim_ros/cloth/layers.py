"""Layered garments: an inner garment's surface as a collider for an outer one (numba kernels).

After the body volumes (each garment's own frame step; ``dressing.DressedCharacter`` runs this once per
frame, see there), every outer garment is kept on the outside of every inner garment's surface,
``thickness`` off it (``params.layer_thickness``), in four passes over the outer garment, with the
inner garment's triangles (outward normals: counter-clockwise seen from outside) binned into a uniform
grid (the broad phase: each triangle in every cell its box touches; a point or edge meets the triangles of
the cells its box, grown by how near it looks, touches):

1. path: a point whose motion over the frame (``x_prev`` -> ``x``) went through an inner triangle from
   its outer side is put back on that side, at the crossing;
2. point-triangle proximity: a point over an inner triangle (its projection inside the triangle) closer
   than ``reach`` and less than ``thickness`` outside it goes to ``thickness`` outside; first the
   triangle it was over at the last call, however far the inner garment moved into it (the body
   pushes the inner garment out through a resting outer one);
3. edge-edge proximity: an outer edge closer than ``thickness`` to an inner triangle's edge, less than
   ``thickness`` outside that triangle, has its two ends moved out along the triangle's normal, each
   by its share (the ends' barycentric weights), so that the closest point ends ``thickness`` out; this
   is what catches an outer edge over a ridge of the inner garment, where its ends are over no triangle;
4. edge-triangle: an outer edge still through inner triangles goes out of them, by what its first and last
   crossings along it say about its ends (``_edge_through``): an edge that enters the inner surface at its
   first crossing and leaves it at its last straddles a tube or a fold with both ends outside (a long skirt's
   10-18 cm edge across a trouser leg) and moves out whole, along the two triangles' mean normal, until its
   deepest point is ``thickness`` out; otherwise the end behind a crossing goes ``thickness`` out of that
   triangle's plane when it is less than ``reach`` through (deeper, the end is not inside the inner garment
   but behind a fold of it, and pushing it across would tear the cloth); an edge through a whole trouser leg
   or both sides of a fold (the crossed normals face apart: no way out along them) moves out sideways, whole,
   the short way across the inner garment seen along it (``_clear_skewer``), at most ``SKEWER_M``.

The inner garment is not moved (one-way coupling: it is pressed by the body only; the outer one is the
lighter drape over it; letting it give way under an outer point the body holds in it cost the trousers their
own targets: README, "Outfits"). Points pushed lose their velocity into the inner surface. All in the simulation
(root) frame, metres. The grid and the crossing count (the layers' bone-through-cloth check) are
``cloth.triangle_grid``'s; what the outer garment owes the body after these passes (a triangle put across a
limb bone goes back) and the bands carried alike are ``cloth.outfit_rules``'.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..collision.crossing import segment_crosses_triangle, segment_misses_triangle_box
from .triangle_grid import (
    build_grid,
    count_edges_through,
    edge_crossings,
    first_and_last_crossing,
    near_segment,
    triangle_normals,
)

REACH_M = 0.05  # m: an outer point this close over an inner garment's triangle is checked against it
_SETTLED = 1e-6  # m: a point this close to the thickness is where it belongs (no sweep for rounding)
# separate's passes run at most this many times (again while they push a point: a push out of one face of a
# crease can put it through the next; CC walk, pants + long skirt, 3 s, before the bone rule: 3 sweeps left 50
# crossing frames of 156, 8 left 45)
SWEEPS = 8
CELL_PER_TRIANGLE = 1.5  # the grid's cell, in a typical inner triangle's radii (centroid to farthest corner)
_TRACK_DEPTH = 0.05  # m: a point this far behind the triangle it was over has not been pushed through it
_LEVER = 0.25  # an edge moves by its ends while (1 - s)^2 + s^2 of the free ones reaches this: at most twice as far
FOLD = 0.3  # |n1 + n2| of two unit normals below which the triangles are the two sides of a flat fold
# an edge through a whole trouser leg or fold (``_clear_skewer``) moves out sideways at most this far, m (a
# thigh's trouser leg is 14 cm across: out of its middle, 7 cm and the thickness), the way with the least
# of the inner garment of this many directions across it
SKEWER_M = 0.1
SKEWER_DIRECTIONS = 16


@njit(cache=True, inline="always")
def _over(px, py, pz, y, a, b, c, nx, ny, nz):
    """Whether the point's projection on the triangle's plane is inside the triangle (edges included)."""
    for (i, j) in ((a, b), (b, c), (c, a)):
        ex, ey, ez = y[j, 0] - y[i, 0], y[j, 1] - y[i, 1], y[j, 2] - y[i, 2]
        rx, ry, rz = px - y[i, 0], py - y[i, 1], pz - y[i, 2]
        # (e x r) . n >= 0 on the inner side of edge i -> j for a counter-clockwise triangle
        if (ey * rz - ez * ry) * nx + (ez * rx - ex * rz) * ny + (ex * ry - ey * rx) * nz < -1e-12:
            return False
    return True


@njit(cache=True, inline="always")
def _height(x, i, y, a, normals, t):
    """Signed distance of point i of ``x`` above the plane of triangle t (vertex a of ``y``), m."""
    return ((x[i, 0] - y[a, 0]) * normals[t, 0] + (x[i, 1] - y[a, 1]) * normals[t, 1]
            + (x[i, 2] - y[a, 2]) * normals[t, 2])


@njit(cache=True, inline="always")
def _push(x, v, pushed, i, nx, ny, nz, distance):
    """Move point i by ``distance`` along unit (nx, ny, nz) and take away its velocity against it; ``pushed[i]``
    set."""
    pushed[i] = True
    x[i, 0] += distance * nx
    x[i, 1] += distance * ny
    x[i, 2] += distance * nz
    vn = v[i, 0] * nx + v[i, 1] * ny + v[i, 2] * nz
    if vn < 0.0:
        v[i, 0] -= vn * nx
        v[i, 1] -= vn * ny
        v[i, 2] -= vn * nz


@njit(cache=True, inline="always")
def _push_out(x, v, pushed, i, normals, t, distance):
    """``_push`` along triangle t's normal."""
    _push(x, v, pushed, i, normals[t, 0], normals[t, 1], normals[t, 2], distance)


@njit(cache=True, inline="always")
def _closest_between_segments(x, p0, p1, y, q0, q1):
    """Parameters (s, r) of the closest points p0 + s (p1 - p0) and q0 + r (q1 - q0), and their distance."""
    d1x, d1y, d1z = x[p1, 0] - x[p0, 0], x[p1, 1] - x[p0, 1], x[p1, 2] - x[p0, 2]
    d2x, d2y, d2z = y[q1, 0] - y[q0, 0], y[q1, 1] - y[q0, 1], y[q1, 2] - y[q0, 2]
    rx, ry, rz = x[p0, 0] - y[q0, 0], x[p0, 1] - y[q0, 1], x[p0, 2] - y[q0, 2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denominator = a * e - b * b
    s = min(max((b * f - c * e) / denominator, 0.0), 1.0) if denominator > 1e-18 else 0.0
    r = (b * s + f) / e if e > 1e-18 else 0.0
    if r < 0.0:
        r, s = 0.0, min(max(-c / a, 0.0), 1.0) if a > 1e-18 else 0.0
    elif r > 1.0:
        r, s = 1.0, min(max((b - c) / a, 0.0), 1.0) if a > 1e-18 else 0.0
    gx = rx + s * d1x - r * d2x
    gy = ry + s * d1y - r * d2y
    gz = rz + s * d1z - r * d2z
    return s, r, math.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True)
def separate(x, v, movable, x_prev, use_path, edges, y, triangles, normals, radii, thickness, reach, origin, dims,
             cell, starts, entries, tracked, sweeps):
    """Keep the outer garment's points ``x`` (N, 3) (velocities ``v``, both changed in place; ``movable``
    (N,) bool) ``thickness`` outside the inner garment's triangles (T, 3) of ``y`` (M, 3), unit ``normals``
    (T, 3) and ``radii`` (T,) (farthest corner from the centroid, m); see the module docstring. ``x_prev``
    (N, 3) the points at the frame's start (used when ``use_path``), ``edges`` (E, 2) the outer garment's
    structural edges, ``tracked`` (N,) the inner triangle each point was over at the last call (-1: none),
    updated. Passes 2 to 4 run again while they push a point, up to ``sweeps`` times in all (a push out of
    one triangle can put a point into its neighbour in a crease); a sweep after the first looks only at the
    points the one before pushed and their edges: the others are where they were when they were last
    looked at and nothing pushed them then, so they would not be pushed now. Returns how many pushes were
    made."""
    total = 0
    n = x.shape[0]
    stamp = np.full(triangles.shape[0], -1, dtype=np.int64)
    found = np.empty(triangles.shape[0], dtype=np.int64)
    query = 0
    look = np.ones(n, dtype=np.bool_)  # (N,) the points this sweep looks at
    pushed = np.zeros(n, dtype=np.bool_)  # (N,) the points this sweep pushed
    for sweep in range(sweeps):
        moved = 0
        pushed[:] = False
        # 1. paths through a triangle from its outer side (the first sweep only)
        if use_path and sweep == 0:
            for i in range(n):
                if not movable[i]:
                    continue
                px, py, pz = x_prev[i, 0], x_prev[i, 1], x_prev[i, 2]
                dx, dy, dz = x[i, 0] - px, x[i, 1] - py, x[i, 2] - pz
                best_s, best_t = 2.0, -1
                query += 1
                for m in range(near_segment(px, py, pz, x[i, 0], x[i, 1], x[i, 2], 0.0, origin, dims, cell, starts,
                                             entries, stamp, query, found, False)):
                    t = found[m]
                    # from the outer side to the inner side only
                    if dx * normals[t, 0] + dy * normals[t, 1] + dz * normals[t, 2] >= 0.0:
                        continue
                    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
                    if segment_misses_triangle_box(y, a, b, c, px, py, pz, x[i, 0], x[i, 1], x[i, 2]):
                        continue
                    hit, s, _, _ = segment_crosses_triangle(px, py, pz, dx, dy, dz, y, a, b, c)
                    if hit and s < best_s:
                        best_s, best_t = s, t
                if best_t >= 0:
                    d = _height(x, i, y, triangles[best_t, 0], normals, best_t)  # < 0: how far through
                    _push_out(x, v, pushed, i, normals, best_t, thickness - d)
                    moved += 1
        # 2. point-triangle proximity
        for i in range(n):
            if not (movable[i] and look[i]):
                continue
            t = tracked[i]
            if t >= 0:
                a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
                d = _height(x, i, y, a, normals, t)
                # laterally within 1.5 times the triangle's radius of its centroid (it may have slid off its edge)
                gx = x[i, 0] - (y[a, 0] + y[b, 0] + y[c, 0]) / 3.0
                gy = x[i, 1] - (y[a, 1] + y[b, 1] + y[c, 1]) / 3.0
                gz = x[i, 2] - (y[a, 2] + y[b, 2] + y[c, 2]) / 3.0
                lateral2 = gx * gx + gy * gy + gz * gz - d * d
                if -_TRACK_DEPTH < d < thickness - _SETTLED and lateral2 < 2.25 * radii[t] * radii[t]:
                    _push_out(x, v, pushed, i, normals, t, thickness - d)
                    moved += 1
            tracked[i] = -1
            px, py, pz = x[i, 0], x[i, 1], x[i, 2]
            best_d, best_t = reach, -1
            query += 1
            for m in range(near_segment(px, py, pz, px, py, pz, reach, origin, dims, cell, starts, entries, stamp,
                                         query, found, False)):
                t = found[m]
                a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
                d = _height(x, i, y, a, normals, t)
                if abs(d) < abs(best_d) and _over(px, py, pz, y, a, b, c, normals[t, 0], normals[t, 1], normals[t, 2]):
                    best_d, best_t = d, t
            if best_t >= 0 and best_d < thickness - _SETTLED:
                _push_out(x, v, pushed, i, normals, best_t, thickness - best_d)
                moved += 1
            tracked[i] = best_t
        # 3. edge-edge proximity and 4. edges through a triangle
        for k in range(edges.shape[0]):
            p0, p1 = edges[k, 0], edges[k, 1]
            if not (look[p0] or look[p1]):
                continue
            query += 1
            count = near_segment(x[p0, 0], x[p0, 1], x[p0, 2], x[p1, 0], x[p1, 1], x[p1, 2], thickness, origin, dims,
                                  cell, starts, entries, stamp, query, found, True)
            for m in range(count):
                t = found[m]
                if _apart(x, p0, p1, y, triangles, t, thickness):
                    continue  # most triangles of a cell are nowhere near the edge
                moved += _edge_near_triangle(x, v, pushed, movable, p0, p1, y, triangles, normals, t, thickness,
                                             reach)
            through, skewer_s = _edge_through(x, v, pushed, movable, p0, p1, y, triangles, normals, found, count,
                                              thickness, reach)
            moved += through
            if skewer_s >= 0.0:
                query += 1
                count = near_segment(x[p0, 0], x[p0, 1], x[p0, 2], x[p1, 0], x[p1, 1], x[p1, 2], SKEWER_M, origin,
                                     dims, cell, starts, entries, stamp, query, found, False)
                moved += _clear_skewer(x, v, pushed, movable, p0, p1, skewer_s, y, triangles, found, count,
                                       thickness)
        total += moved
        if moved == 0:
            break
        look[:] = pushed
    return total


@njit(cache=True, inline="always")
def _apart(x, p0, p1, y, triangles, t, pad):
    """True when the boxes of edge (p0, p1) of ``x`` and triangle t of ``y``, grown by ``pad`` m, are apart."""
    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    for k in range(3):
        if (max(y[a, k], y[b, k], y[c, k]) < min(x[p0, k], x[p1, k]) - pad
                or min(y[a, k], y[b, k], y[c, k]) > max(x[p0, k], x[p1, k]) + pad):
            return True
    return False


@njit(cache=True, inline="always")
def _edge_near_triangle(x, v, pushed, movable, p0, p1, y, triangles, normals, t, thickness, reach):
    """Pass 3 of ``separate`` for outer edge (p0, p1) and inner triangle t; returns the pushes made."""
    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    moved = 0
    for (q0, q1) in ((a, b), (b, c), (c, a)):
        s, r, distance = _closest_between_segments(x, p0, p1, y, q0, q1)
        if distance >= thickness or not (0.0 < s < 1.0 and 0.0 < r < 1.0):
            continue  # an end or a corner is the points' pass's
        d = ((1.0 - s) * _height(x, p0, y, a, normals, t) + s * _height(x, p1, y, a, normals, t))
        if not -reach < d < thickness - _SETTLED:
            continue
        moved += _push_edge(x, v, pushed, movable, p0, p1, s, normals[t, 0], normals[t, 1], normals[t, 2],
                            thickness - d)
    return moved


@njit(cache=True, inline="always")
def _push_edge(x, v, pushed, movable, p0, p1, s, nx, ny, nz, distance):
    """Move edge (p0, p1)'s point at parameter ``s`` by ``distance`` along unit (nx, ny, nz), its ends each by
    their share (weights 1 - s and s; a pinned end takes none); returns 1 if it moved, else 0."""
    w0 = (1.0 - s) if movable[p0] else 0.0
    w1 = s if movable[p1] else 0.0
    moving = w0 * (1.0 - s) + w1 * s
    if moving < _LEVER:
        return 0  # the point is by a pinned end: its free end would have to go far (distance / moving)
    share = distance / moving
    if w0 > 0.0:
        _push(x, v, pushed, p0, nx, ny, nz, w0 * share)
    if w1 > 0.0:
        _push(x, v, pushed, p1, nx, ny, nz, w1 * share)
    return 1


@njit(cache=True, inline="always")
def _edge_through(x, v, pushed, movable, p0, p1, y, triangles, normals, found, count, thickness, reach):
    """Pass 4 of ``separate``: outer edge (p0, p1) through inner triangles (``found[:count]``, the candidates)
    goes out of them. The crossings along the edge, first and last, say which ends are inside the inner
    surface: one entered at the first crossing and left at the last is a straddle (both ends outside, the
    edge through a trouser leg or a fold), moved out whole along the two triangles' mean normal until its
    deepest point is ``thickness`` out (the two planes bound a convex tube); otherwise the end behind the
    first crossing (left there) or the last (entered there) goes ``thickness`` out of that triangle's plane.
    Returns the pushes made."""
    first, first_s, last, last_s = first_and_last_crossing(x, p0, p1, y, triangles, found, count)
    if first < 0:
        return 0, -1.0
    dx, dy, dz = x[p1, 0] - x[p0, 0], x[p1, 1] - x[p0, 1], x[p1, 2] - x[p0, 2]
    enters = dx * normals[first, 0] + dy * normals[first, 1] + dz * normals[first, 2] < 0.0
    leaves = dx * normals[last, 0] + dy * normals[last, 1] + dz * normals[last, 2] > 0.0
    if enters and leaves:
        ux, uy, uz = normals[first, 0] + normals[last, 0], normals[first, 1] + normals[last, 1], normals[first, 2] + \
            normals[last, 2]
        norm = math.sqrt(ux * ux + uy * uy + uz * uz)
        if norm < FOLD:
            return 0, 0.5 * (first_s + last_s)  # through a tube or both sides of a fold: no way out along them
        ux, uy, uz = ux / norm, uy / norm, uz / norm
        # heights over the two planes along the edge: h_first(s) falls, h_last(s) rises; the deepest point of
        # their wedge is where they meet, and a move along u raises both alike
        f0, f1 = _height(x, p0, y, triangles[first, 0], normals, first), _height(x, p1, y, triangles[first, 0],
                                                                                  normals, first)
        l0, l1 = _height(x, p0, y, triangles[last, 0], normals, last), _height(x, p1, y, triangles[last, 0],
                                                                              normals, last)
        slope = (f1 - f0) - (l1 - l0)
        s = min(max((l0 - f0) / slope, 0.0), 1.0) if slope < -1e-12 else 0.5 * (first_s + last_s)
        deepest = f0 + s * (f1 - f0)
        rise = ux * normals[first, 0] + uy * normals[first, 1] + uz * normals[first, 2]
        distance = (thickness - deepest) / rise
        if not 0.0 < distance < math.sqrt(dx * dx + dy * dy + dz * dz):
            return 0, 0.5 * (first_s + last_s)  # a wedge deeper than the edge is long: no tube's top it spans
        return _push_edge(x, v, pushed, movable, p0, p1, s, ux, uy, uz, distance), -1.0
    moved = 0
    for (inside, end, t) in ((not enters, p0, first), (not leaves, p1, last)):
        if inside and movable[end]:
            d = _height(x, end, y, triangles[t, 0], normals, t)
            if -reach < d < thickness:
                _push_out(x, v, pushed, end, normals, t, thickness - d)
                moved += 1
    return moved, -1.0


@njit(cache=True, inline="always")
def _clear_skewer(x, v, pushed, movable, p0, p1, s_mid, y, triangles, found, count, thickness):
    """An outer edge (p0, p1) with both ends outside that runs through the inner surface where no normal shows
    a way out (through a whole trouser leg, in at one side and out at the other, or through both sides of a
    fold; its chord's middle at parameter ``s_mid``) moves out sideways, whole: the inner garment seen along the
    edge (the corners of the candidate triangles ``found[:count]`` that reach across the edge's span, as offsets
    from the edge's line) is a band, and the edge goes, of ``SKEWER_DIRECTIONS`` directions across it, the way
    with the least of it, ``thickness`` beyond it, when that is nearer than ``SKEWER_M`` and the edge's length
    (farther, the band has no near side: the pinch between two legs). Both ends must be free (one end moved
    alone would turn the edge about the other). Returns the pushes made."""
    if not (movable[p0] and movable[p1]):
        return 0
    dx, dy, dz = x[p1, 0] - x[p0, 0], x[p1, 1] - x[p0, 1], x[p1, 2] - x[p0, 2]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length < 1e-9:
        return 0
    dx, dy, dz = dx / length, dy / length, dz / length
    # two unit directions across the edge: e1 from the axis the edge is least along, e2 = d x e1
    if abs(dx) <= abs(dy) and abs(dx) <= abs(dz):
        ax, ay, az = 1.0, 0.0, 0.0
    elif abs(dy) <= abs(dz):
        ax, ay, az = 0.0, 1.0, 0.0
    else:
        ax, ay, az = 0.0, 0.0, 1.0
    along = ax * dx + ay * dy + az * dz
    e1x, e1y, e1z = ax - along * dx, ay - along * dy, az - along * dz
    norm = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x, e1y, e1z = e1x / norm, e1y / norm, e1z / norm
    e2x, e2y, e2z = dy * e1z - dz * e1y, dz * e1x - dx * e1z, dx * e1y - dy * e1x
    mx = x[p0, 0] + s_mid * length * dx
    my = x[p0, 1] + s_mid * length * dy
    mz = x[p0, 2] + s_mid * length * dz
    reach = min(SKEWER_M, length)
    support = np.zeros(SKEWER_DIRECTIONS)  # (K,) m: how far the band reaches each way from the edge's line
    for m in range(count):
        t = found[m]
        lo_s, hi_s = np.inf, -np.inf
        for j in range(3):
            q = triangles[t, j]
            sq = (y[q, 0] - x[p0, 0]) * dx + (y[q, 1] - x[p0, 1]) * dy + (y[q, 2] - x[p0, 2]) * dz
            lo_s, hi_s = min(lo_s, sq), max(hi_s, sq)
        if hi_s < 0.0 or lo_s > length:
            continue  # beside the edge's span: not in its way
        for j in range(3):
            q = triangles[t, j]
            wx, wy, wz = y[q, 0] - mx, y[q, 1] - my, y[q, 2] - mz
            c1, c2 = wx * e1x + wy * e1y + wz * e1z, wx * e2x + wy * e2y + wz * e2z
            for k in range(SKEWER_DIRECTIONS):
                angle = 2.0 * math.pi * k / SKEWER_DIRECTIONS
                support[k] = max(support[k], c1 * math.cos(angle) + c2 * math.sin(angle))
    best = int(np.argmin(support))
    distance = support[best] + thickness
    if distance >= reach:
        return 0
    angle = 2.0 * math.pi * best / SKEWER_DIRECTIONS
    ux = math.cos(angle) * e1x + math.sin(angle) * e2x
    uy = math.cos(angle) * e1y + math.sin(angle) * e2y
    uz = math.cos(angle) * e1z + math.sin(angle) * e2z
    _push(x, v, pushed, p0, ux, uy, uz, distance)
    _push(x, v, pushed, p1, ux, uy, uz, distance)
    return 1


class InnerSurface:
    """An inner garment's triangles at its current positions, binned for ``separate`` and
    ``count_edges_through``. ``positions`` (M, 3) m, ``triangles`` (T, 3); ``reach`` m (how near a point
    looks for a triangle to be over, ``separate``'s pass 2)."""

    def __init__(self, positions: np.ndarray, triangles: np.ndarray, reach: float):
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)
        self.triangles = np.ascontiguousarray(triangles, dtype=np.int64)
        self.normals = np.empty((len(self.triangles), 3))
        triangle_normals(self.positions, self.triangles, self.normals)
        p = self.positions[self.triangles]
        # (T,) m: each triangle's farthest corner from its centroid
        self.radii = np.ascontiguousarray(np.linalg.norm(p - p.mean(axis=1, keepdims=True), axis=2).max(axis=1))
        # a typical triangle's size: a triangle sits in a few cells and an edge's box, grown by the thickness,
        # meets a few tens of triangles (bins grown by the reach made each edge meet a hundred)
        self.cell = CELL_PER_TRIANGLE * float(np.median(self.radii))
        self.reach = reach
        self.origin, self.dims, self.starts, self.entries = build_grid(self.positions, self.triangles, self.cell)

    def separate(self, x: np.ndarray, v: np.ndarray, movable: np.ndarray, edges: np.ndarray, thickness: float,
                 tracked: np.ndarray, x_prev: np.ndarray | None = None) -> int:
        """``x``, ``v`` (N, 3) float64 changed in place; ``movable`` (N,) bool; ``edges`` (E, 2) the outer
        garment's; ``tracked`` (N,) int64, updated; ``x_prev`` (N, 3) the frame's start (None: no path
        pass). Returns how many pushes were made."""
        return int(separate(x, v, movable, x if x_prev is None else x_prev, x_prev is not None,
                            np.ascontiguousarray(edges, dtype=np.int64), self.positions, self.triangles, self.normals,
                            self.radii, float(thickness), self.reach, self.origin, self.dims, self.cell, self.starts,
                            self.entries, tracked, SWEEPS))

    def crossings(self, x: np.ndarray, edges: np.ndarray) -> np.ndarray:
        """(E, 2) int64: per edge (E, 2) of points ``x`` (N, 3), the first and last of these triangles it crosses
        along it (-1: none)."""
        crossed = np.empty((len(edges), 2), dtype=np.int64)
        edge_crossings(np.ascontiguousarray(x, dtype=np.float64), np.ascontiguousarray(edges, dtype=np.int64),
                       self.positions, self.triangles, self.origin, self.dims, self.cell, self.starts, self.entries,
                       crossed)
        return crossed

    def edges_through(self, x: np.ndarray, edges: np.ndarray) -> int:
        """How many edges (E, 2) of points ``x`` (N, 3) cross one of these triangles."""
        return int(count_edges_through(np.ascontiguousarray(x, dtype=np.float64),
                                       np.ascontiguousarray(edges, dtype=np.int64), self.positions, self.triangles,
                                       self.origin, self.dims, self.cell, self.starts, self.entries))
