"""Numba kernels: limb bones through cloth triangles (beyond the memo, which handles mass points only).

A limb can pass *between* cloth points: every point stays outside the volumes while a triangle
spans the limb, its plane cut by the bone. Point (``kernels.handle_all``) and edge
(``kernels.handle_edges``) handling do not see it, and once the bone is through, no later contact
pushes the cloth back: the limb is outside the garment. ``handle_axes`` tests the bone of every
volume that has one (``Volume.bone``: limbs and the spine, on the volume's local z axis) against
the garment's triangles at the substep's end. A crossed triangle goes back to the side of the bone
it was on at the substep's start (``_side_direction``: the continuous information the end state
lacks), with the least move that takes the bone out of it seen along the bone: each corner short
of ``eps`` on that side goes there, a corner already there stays; a corner so moved that is inside
the limb goes out across its surface radially, so it stays on its side. A triangle with an attached
corner (the row under a waistband) cannot go back that way: when the bone reaches it, its free corners
go to the side of the bone its attached corners are on (``_attached_side``; a forearm at the hip, CC
jump: the skirt no longer stays caught on it, issue 11). A triangle the bone still crosses at the substep's
start (caught) is part of one sheet whose edge is far: moved across the bone it only passes the crossing to a
neighbour. Where the limb's end is a free wrist, it goes off the bone past that end instead (CC jump: the
band row caught on the forearm after the hand left the hip, 11 frames on each garment before); nearer the bone's
root end (a shoulder) lying outside the other volumes, past that end (cartwheel, long skirt: the upper arm).

Priority in a pinch (a forearm on the hip, an arm against the chest: two volumes overlap and
squeeze the cloth): the cloth goes no further than where the other volume begins (``_room``), and a
triangle that could only clear the bone with a corner deeper than ``pinch_depth`` in another volume
is left crossed: contact wins over crossing, so the depth the pinch costs is bounded by
``pinch_depth``. Into a volume that may be pressed against the bone's (``contact_planes``: flesh that
gives way) a corner may go ``pressed_pinch_depth`` deep (``VolumeArrays.pinch_depths``), and the point
handling after the bones' takes it out again (``Collider.resolve_substep``): on cmu_131 the wrist of a
hand on the hip spears the trousers under the band, and every way off the bone put a corner 1-8 mm into
the thigh. Where the bodies' volumes overlap more than that round a bone (a wrist inside the hip volume),
no cloth position is both outside the volumes and off the bone.

``segment_crosses_triangle`` is the crossing test of the metric as well (``quality``), so both
agree on what "through" means.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry import (
    entry,
    kernel,
    rotate,
    static_projection,
    to_local,
    to_world,
)
from .response import deepest_elsewhere, depth_elsewhere, depth_in, surface_velocity
from .volume_arrays import VolumeArrays

# Barycentric and segment-parameter slack of the crossing test: a bone through a shared edge or
# vertex exactly must not slip between the two triangles, so boundaries count as crossed.
_EDGE_SLACK = 1e-9
# |sine| of the angle between a bone and a triangle's plane below which they count as parallel
# (a bone lying in the cloth's plane does not pass through it).
_PARALLEL_SINE = 1e-9
_TINY = 1e-12
# a crossed triangle leaves along its normal when the normal's part across the bone is at least this (sine)
_ACROSS = 0.3
# handle_axes' broad phase: consecutive triangles per bounding box (a grid garment's run of 32 triangles lies
# along one row, a few cm long; a bone's segment box meets few of them)
AXIS_BLOCK = 32
_BOX_SLACK = 1e-9  # m, the segment box's slack in ``segment_misses_triangle_box``
_OUT_OF_PINCHES = 3  # volumes a point is put out of in turn (``out_of_pinches``: the pelvis, then a thigh)


@kernel
def axis_block_count(triangles):
    """How many boxes ``handle_axes`` needs for ``triangles`` triangles (the rows of its ``boxes``)."""
    return (triangles + AXIS_BLOCK - 1) // AXIS_BLOCK


@kernel
def segment_crosses_triangle(px, py, pz, dx, dy, dz, x, a, b, c):
    """Möller–Trumbore: where the segment ``p + s d`` (0 <= s <= 1) meets triangle (a, b, c) of ``x``.

    Returns ``(crosses, s, u, w)``: the point is ``x[a] + u (x[b] - x[a]) + w (x[c] - x[a])``. A segment
    through an edge or a vertex crosses; one parallel to the triangle's plane (in it or not) does not."""
    e1x, e1y, e1z = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    e2x, e2y, e2z = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    hx, hy, hz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = e1x * hx + e1y * hy + e1z * hz
    # det = d . (e1 x e2): |d| |e1 x e2| times the sine of the angle between d and the plane
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    scale = math.sqrt((dx * dx + dy * dy + dz * dz) * (nx * nx + ny * ny + nz * nz))
    if abs(det) <= _PARALLEL_SINE * scale:
        return False, 0.0, 0.0, 0.0
    inv = 1.0 / det
    sx, sy, sz = px - x[a, 0], py - x[a, 1], pz - x[a, 2]
    u = inv * (sx * hx + sy * hy + sz * hz)
    if u < -_EDGE_SLACK or u > 1.0 + _EDGE_SLACK:
        return False, 0.0, 0.0, 0.0
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
    w = inv * (dx * qx + dy * qy + dz * qz)
    if w < -_EDGE_SLACK or u + w > 1.0 + _EDGE_SLACK:
        return False, 0.0, 0.0, 0.0
    s = inv * (e2x * qx + e2y * qy + e2z * qz)
    return -_EDGE_SLACK <= s <= 1.0 + _EDGE_SLACK, s, u, w


@kernel
def segment_misses_triangle_box(x, a, b, c, px, py, pz, qx, qy, qz):
    """True when the bounding boxes of segment p -> q and triangle (a, b, c) of ``x`` are apart (1 nm slack):
    then the segment cannot cross the triangle. Most triangles are nowhere near a bone. (``segment_misses_block``
    tests a stored box the same way; here each bound is taken only when the ones before did not decide: one
    helper taking all six made ``handle_axes`` 5-9 % slower at 20 000 points.)"""
    return (max(x[a, 0], x[b, 0], x[c, 0]) < min(px, qx) - _BOX_SLACK
            or min(x[a, 0], x[b, 0], x[c, 0]) > max(px, qx) + _BOX_SLACK
            or max(x[a, 1], x[b, 1], x[c, 1]) < min(py, qy) - _BOX_SLACK
            or min(x[a, 1], x[b, 1], x[c, 1]) > max(py, qy) + _BOX_SLACK
            or max(x[a, 2], x[b, 2], x[c, 2]) < min(pz, qz) - _BOX_SLACK
            or min(x[a, 2], x[b, 2], x[c, 2]) > max(pz, qz) + _BOX_SLACK)


@kernel
def block_boxes(x, triangles, boxes):
    """Per run of ``AXIS_BLOCK`` consecutive triangles (T, 3) of ``x``, the box of their corners into ``boxes``
    (``axis_block_count(T)``, 6): (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z) m."""
    n_triangles = triangles.shape[0]
    for k in range(boxes.shape[0]):
        for c in range(3):
            boxes[k, c] = math.inf
            boxes[k, 3 + c] = -math.inf
        for run in range(k * AXIS_BLOCK, min((k + 1) * AXIS_BLOCK, n_triangles)):
            t = np.uint64(run)  # unsigned: no test for a negative index (``kernels._handle_edge_run``)
            for j in range(3):
                i = np.uint64(triangles[t, j])
                for c in range(3):
                    boxes[k, c] = min(boxes[k, c], x[i, c])
                    boxes[k, 3 + c] = max(boxes[k, 3 + c], x[i, c])


@kernel
def segment_misses_block(boxes, k, px, py, pz, qx, qy, qz):
    """True when the segment p -> q's box (the slack of ``segment_misses_triangle_box``) is apart from block k's
    box: then it is apart from the box of every triangle in the block, which lies within."""
    return (boxes[k, 3] < min(px, qx) - _BOX_SLACK or boxes[k, 0] > max(px, qx) + _BOX_SLACK
            or boxes[k, 4] < min(py, qy) - _BOX_SLACK or boxes[k, 1] > max(py, qy) + _BOX_SLACK
            or boxes[k, 5] < min(pz, qz) - _BOX_SLACK or boxes[k, 2] > max(pz, qz) + _BOX_SLACK)


@njit(cache=True)  # not ``kernel``: it allocates its boxes
def segments_through_triangles(starts, ends, x, triangles, crossed):
    """Which segments (``starts``, ``ends``: (B, 3)) cross any triangle (T, 3) of points ``x`` (N, 3).

    Writes ``crossed`` (B,) bool and returns how many do. A segment touching a triangle's edge or
    vertex crosses; one parallel to a triangle's plane (in it or not) does not cross that triangle.
    """
    n_triangles = triangles.shape[0]
    boxes = np.empty((axis_block_count(n_triangles), 6))
    block_boxes(x, triangles, boxes)  # most runs of triangles are nowhere near a bone (``crossing.handle_axes``)
    count = 0
    for k in range(starts.shape[0]):
        px, py, pz = starts[k, 0], starts[k, 1], starts[k, 2]
        qx, qy, qz = ends[k, 0], ends[k, 1], ends[k, 2]
        dx, dy, dz = qx - px, qy - py, qz - pz
        crossed[k] = False
        for block in range(boxes.shape[0]):
            if crossed[k] or segment_misses_block(boxes, block, px, py, pz, qx, qy, qz):
                continue
            for t in range(block * AXIS_BLOCK, min((block + 1) * AXIS_BLOCK, n_triangles)):
                a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
                if segment_misses_triangle_box(x, a, b, c, px, py, pz, qx, qy, qz):
                    continue
                if segment_crosses_triangle(px, py, pz, dx, dy, dz, x, a, b, c)[0]:
                    crossed[k] = True
                    count += 1
                    break
    return count


@kernel
def _normal(x, a, b, c):
    """Unnormalised normal (b - a) x (c - a) of triangle (a, b, c) of ``x``."""
    e1x, e1y, e1z = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    e2x, e2y, e2z = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    return e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x


@kernel
def _crossed_at_start(vol, v, xs, a, b, c):
    pos0, rot0 = vol.pos0, vol.rot0
    z0, z1 = vol.bones[v, 0], vol.bones[v, 1]
    px, py, pz = to_world(pos0, rot0, v, 0.0, 0.0, z0)
    qx, qy, qz = to_world(pos0, rot0, v, 0.0, 0.0, z1)
    return segment_crosses_triangle(px, py, pz, qx - px, qy - py, qz - pz, xs, a, b, c)[0]


@kernel
def _clearing(corners, ux, uy, clearance):
    """How far, in all, the corners (3, 3 local) move to lie ``clearance`` or more along (ux, uy)."""
    total = 0.0
    for k in range(3):
        total += max(0.0, clearance - (corners[k, 0] * ux + corners[k, 1] * uy))
    return total


@kernel
def _side_direction(vol, v, z, triangles, t, u, w, xs, x, corners, clearance):
    """Unit local direction (ux, uy), across volume v's axis at height z, towards the side of the bone
    triangle t was on at the substep's start. ``corners`` (3, 3): its corners, local, at the end pose.

    A triangle the bone already crossed at the start takes the shortest way out (across its nearest
    edge, seen along the bone). Else the side is the one of the triangle's plane the axis point was on at
    the start (``xs``, start pose): the triangle goes along its normal, away from the axis, which keeps a
    fold round the bone (two triangles meeting at an edge the bone slipped through) together: both go
    out of the fold. A triangle nearly square to the bone (speared by it) cannot leave along its normal:
    it goes towards where its crossed point was at the start, seen from the axis."""
    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    if _crossed_at_start(vol, v, xs, a, b, c):
        best, ux, uy = math.inf, 1.0, 0.0
        for k in range(3):
            ex, ey = corners[(k + 1) % 3, 0] - corners[k, 0], corners[(k + 1) % 3, 1] - corners[k, 1]
            length = math.sqrt(ex * ex + ey * ey)
            if length < _TINY:
                continue
            nx, ny = ey / length, -ex / length
            if nx * corners[k, 0] + ny * corners[k, 1] > 0.0:  # from the edge towards the axis
                nx, ny = -nx, -ny
            cost = _clearing(corners, nx, ny, clearance)
            if cost < best:
                best, ux, uy = cost, nx, ny
        return ux, uy
    pos0, rot0, pos1, rot1 = vol.pos0, vol.rot0, vol.pos1, vol.rot1
    wa = 1.0 - u - w
    sx, sy, sz = (wa * xs[a, 0] + u * xs[b, 0] + w * xs[c, 0], wa * xs[a, 1] + u * xs[b, 1] + w * xs[c, 1],
                  wa * xs[a, 2] + u * xs[b, 2] + w * xs[c, 2])
    ax, ay, az = to_world(pos0, rot0, v, 0.0, 0.0, z)
    n0x, n0y, n0z = _normal(xs, a, b, c)
    side = n0x * (ax - sx) + n0y * (ay - sy) + n0z * (az - sz)  # > 0: the axis was in front of the triangle
    nx, ny, nz = _normal(x, a, b, c)
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm > _TINY and side != 0.0:
        sign = -1.0 if side > 0.0 else 1.0
        lx, ly, _ = to_local(pos1, rot1, v, pos1[v, 0] + sign * nx / norm, pos1[v, 1] + sign * ny / norm,
                             pos1[v, 2] + sign * nz / norm)
        across = math.sqrt(lx * lx + ly * ly)
        if across > _ACROSS:
            return lx / across, ly / across
    ox, oy, _ = to_local(pos0, rot0, v, sx, sy, sz)
    off = math.sqrt(ox * ox + oy * oy)
    if off < _TINY:
        return 1.0, 0.0
    return ox / off, oy / off


@kernel
def _cost_keeping_attached(triangles, t, inv_mass, corners, ux, uy, clearance):
    """``_clearing``'s cost of the side (ux, uy) for triangle t (``corners`` (3, 3): local), or inf when an
    attached corner is short of ``clearance`` along it: it rides on the body and cannot move there."""
    for k in range(3):
        if inv_mass[triangles[t, k]] == 0.0 and corners[k, 0] * ux + corners[k, 1] * uy < clearance:
            return math.inf
    return _clearing(corners, ux, uy, clearance)


@kernel
def _attached_side(triangles, t, inv_mass, corners, clearance):
    """Unit local direction (ux, uy) towards the side of the bone triangle t's attached corners are on
    (``corners`` (3, 3): its corners, local, at the end pose), and whether every attached corner lies
    ``clearance`` or more along it. The attached corners cannot move, so the free ones go to their side:
    the triangle stays on the body's side of the bone it rides on. Tried: each attached corner's own
    direction and, with two, the side of their edge away from the axis; the one costing least."""
    best, best_x, best_y = math.inf, 1.0, 0.0
    previous = -1
    for k in range(3):
        if inv_mass[triangles[t, k]] != 0.0:
            continue
        length = math.sqrt(corners[k, 0] ** 2 + corners[k, 1] ** 2)
        if length > _TINY:
            ux, uy = corners[k, 0] / length, corners[k, 1] / length
            cost = _cost_keeping_attached(triangles, t, inv_mass, corners, ux, uy, clearance)
            if cost < best:
                best, best_x, best_y = cost, ux, uy
        if previous >= 0:
            ex, ey = corners[k, 0] - corners[previous, 0], corners[k, 1] - corners[previous, 1]
            length = math.sqrt(ex * ex + ey * ey)
            if length > _TINY:
                ux, uy = ey / length, -ex / length
                if ux * corners[k, 0] + uy * corners[k, 1] < 0.0:  # away from the axis
                    ux, uy = -ux, -uy
                cost = _cost_keeping_attached(triangles, t, inv_mass, corners, ux, uy, clearance)
                if cost < best:
                    best, best_x, best_y = cost, ux, uy
        previous = k
    return best_x, best_y, best < math.inf


@kernel
def _room(vol, v, lx, ly, lz, ux, uy, uz, length):
    """How far from volume v's local point l the cloth can go along the local unit (ux, uy, uz), up to
    ``length``, before it enters another volume; a volume l is inside already (the neighbour at a joint)
    does not stop it. In a pinch (a forearm on the hip) the cloth between the two stays between them."""
    kinds, radii, cuts, bounding_radii = vol.kinds, vol.radii, vol.cuts, vol.bounding_radii
    pos, rot = vol.pos1, vol.rot1
    ax, ay, az = to_world(pos, rot, v, lx, ly, lz)
    bx, by, bz = to_world(pos, rot, v, lx + length * ux, ly + length * uy, lz + length * uz)
    room = length
    for o in range(kinds.shape[0]):
        if o == v or (ax - pos[o, 0]) ** 2 + (ay - pos[o, 1]) ** 2 + (az - pos[o, 2]) ** 2 > (
                bounding_radii[o] + length) ** 2:
            continue
        px, py, pz = to_local(pos, rot, o, ax, ay, az)
        qx, qy, qz = to_local(pos, rot, o, bx, by, bz)
        alpha = entry(kinds[o], radii, cuts, vol.planes, o, px, py, pz, qx, qy, qz)[0]
        if alpha >= 0.0:
            room = min(room, alpha * length)
    return room


@kernel
def _entered_end(vol, v, triangles, t, u, w, xs):
    """Whether volume v's bone, which did not cross triangle t at the substep's start (the caller's ``caught``),
    reached it, crossed at barycentric (u, w), past its far end: the crossed
    point lay beyond that end along the bone at the substep's start, and the end is a wrist (``pushes_ahead``)
    inside no other volume. Its near end is always at the trunk or the limb above (``body.fitting``). Not an
    ankle: there the foot goes on at an angle, and a hem the foot came down on was held past the ankle end as
    the foot lifted (CC basketball, long skirt, 1x 60 fps: three hem points 3-4 mm past it for 50 frames, their
    springs 3.3x their rest length)."""
    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    wa = 1.0 - u - w
    lz = to_local(vol.pos0, vol.rot0, v, wa * xs[a, 0] + u * xs[b, 0] + w * xs[c, 0],
                  wa * xs[a, 1] + u * xs[b, 1] + w * xs[c, 1], wa * xs[a, 2] + u * xs[b, 2] + w * xs[c, 2])[2]
    if lz <= vol.bones[v, 1]:
        return False
    return _end_free(vol, v)


@kernel
def _end_free(vol, v):
    """Whether volume v's bone ends at a wrist (``pushes_ahead``) inside no other volume (an elbow is inside the
    forearm's volume): cloth can go off the bone past that end (not an ankle: ``_entered_end``)."""
    return vol.pushes_ahead[v] and _bone_end_clear(vol, v, 1)


@kernel
def _bone_end_clear(vol, v, end):
    """Whether volume v's bone's far end (``end`` 1) or root end (-1) lies inside no other volume (end pose)."""
    ex, ey, ez = to_world(vol.pos1, vol.rot1, v, 0.0, 0.0, vol.bones[v, 1 if end == 1 else 0])
    return depth_elsewhere(vol, v, ex, ey, ez) == 0.0


@kernel
def _load_corners(vol, v, x, triangles, t, corners):
    """Triangle t's corners of ``x`` into ``corners`` (3, 3), in volume v's local frame at the end pose."""
    for k in range(3):
        i = triangles[t, k]
        corners[k, 0], corners[k, 1], corners[k, 2] = to_local(vol.pos1, vol.rot1, v, x[i, 0], x[i, 1], x[i, 2])


@kernel
def _past_end(vol, v, x, triangles, t, end, eps, corners):
    """``_destinations`` of triangle t of ``x`` off volume v's bone past its far end (``end`` 1) or its root end
    (-1), into ``corners``."""
    _load_corners(vol, v, x, triangles, t, corners)
    return _destinations(vol, v, 0.0, 0.0, end, eps, corners)


@kernel
def _destinations(vol, v, ux, uy, past_end, eps, corners):
    """Where the corners (``corners`` (3, 3), local, replaced by their destinations in the simulation frame) go
    off volume v's bone: across it (``past_end`` 0), along the local unit (ux, uy, 0), each corner short of ``eps``
    along it goes there; ``past_end`` 1 (-1): along the bone, each corner short of ``eps`` beyond its far (root)
    end goes there. A corner so moved that is inside v goes out across v's surface (radially, or across that
    end's cut), but not into another
    volume (``_room``). False when a corner would end deeper in another volume o than ``vol.pinch_depths[v, o]``
    (``_too_deep``)."""
    for k in range(3):
        lx, ly, lz = corners[k, 0], corners[k, 1], corners[k, 2]
        if past_end != 0:  # along the bone, its sign's way: the end's and its cut's column (1 far, 0 root)
            side = 1 if past_end == 1 else 0
            if past_end * lz < past_end * vol.bones[v, side] + eps:
                lz = vol.bones[v, side] + past_end * eps
                if static_projection(vol.kinds[v], vol.radii, vol.cuts, vol.planes, v, lx, ly, lz)[0]:
                    lz += past_end * _room(vol, v, lx, ly, lz, 0.0, 0.0, float(past_end),
                                           past_end * (vol.cuts[v, side] - lz) + eps)
        else:
            short = eps - (lx * ux + ly * uy)
            if short > 0.0:
                lx, ly = lx + short * ux, ly + short * uy
                inside, sx, sy, sz, nx, ny, nz = static_projection(vol.kinds[v], vol.radii, vol.cuts, vol.planes,
                                                                     v, lx, ly, lz)
                if inside:
                    out = math.sqrt((sx - lx) ** 2 + (sy - ly) ** 2) + eps
                    radial = math.sqrt(lx * lx + ly * ly)  # >= eps: it is on the side now
                    rx, ry = lx / radial, ly / radial
                    out = _room(vol, v, lx, ly, lz, rx, ry, 0.0, out)
                    lx, ly = lx + out * rx, ly + out * ry
        corners[k, 0], corners[k, 1], corners[k, 2] = to_world(vol.pos1, vol.rot1, v, lx, ly, lz)
        if _too_deep(vol, v, corners[k, 0], corners[k, 1], corners[k, 2]):
            return False  # no room for the cloth between this bone and another volume: contact wins
    return True


@kernel
def _too_deep(vol, v, px, py, pz):
    """Whether the simulation-frame point p is deeper in a volume o other than v than a corner moved off v's bone
    may be (``vol.pinch_depths[v, o]``), at the end poses."""
    for o in range(vol.kinds.shape[0]):
        if o != v and depth_in(vol, o, px, py, pz) > vol.pinch_depths[v, o]:
            return True
    return False


@kernel
def _push_off_axis(vol, v, z, triangles, t, u, w, xs, x, vel, inv_mass, h, eps, corners):
    """Move triangle t, crossed by volume v's axis at local height z (barycentric u, w), off the bone
    (``_destinations``). A triangle the limb's end reached from beyond it (``_entered_end``: a hand poking into a
    skirt) goes back past the end along the bone; moved across the bone there, it only passed the bone on to a
    neighbour, and the limb went through (cmu_01_01, long skirt, 2x 60 fps: the wrist, then the arm to the elbow
    for 150 frames). Where that has no room, and for every other crossing, it goes across the bone to its side
    (unit local direction (ux, uy), ``_side_direction``): the least move that takes the bone out of the triangle,
    seen along the bone; a corner already on that side stays. An approaching velocity relative to v's surface is
    removed. A triangle crossed at the substep's start already (caught) goes past the end when the limb's end is
    free (``_end_free``), its attached corners staying; else, crossed nearer the root end, past that end when it
    is clear of the other volumes (``_bone_end_clear``). A triangle with an attached corner (it rides on the body)
    goes to the side its attached corners are on (``_attached_side``) when the bone reached it in this substep;
    one caught already (its limb's end inside another volume), or whose attached corners straddle the bone, is left
    as it is, and so is one that would end with a corner deeper than ``vol.pinch_depths`` allows in another
    volume: where two volumes overlap more than that round a bone there is no room for cloth, and contact wins.
    Returns whether a corner moved (a triangle still crossed with its free corners past the end does not)."""
    ux, uy, uz = 0.0, 0.0, 0.0
    caught = _crossed_at_start(vol, v, xs, triangles[t, 0], triangles[t, 1], triangles[t, 2])
    if caught and _end_free(vol, v) and _past_end(vol, v, x, triangles, t, 1, eps, corners):
        # moved across the bone, a caught triangle only passes the crossing on to a neighbour (the cloth is one
        # sheet, its edge far away); past the limb's free end the bone leaves it (CC jump: the band row)
        uz = 1.0
    elif (caught and z - vol.bones[v, 0] < vol.bones[v, 1] - z and _bone_end_clear(vol, v, -1)
          and _past_end(vol, v, x, triangles, t, -1, eps, corners)):
        # caught nearer the root end, which is clear of the trunk: off past it (cartwheel, long skirt, the upper
        # arm at the shoulder: moved across the bone the crossing passed back and forth between two triangles)
        uz = -1.0
    elif inv_mass[triangles[t, 0]] == 0.0 or inv_mass[triangles[t, 1]] == 0.0 or inv_mass[triangles[t, 2]] == 0.0:
        if caught:
            # caught before this substep: its free neighbours hold it (their side, by continuity); moved, it
            # would pass back and forth with them (CC jump, short skirt, 2x 60 fps: 11 -> 88 frames)
            return False
        _load_corners(vol, v, x, triangles, t, corners)
        ux, uy, clear = _attached_side(triangles, t, inv_mass, corners, eps)
        if not clear:
            return False  # its attached corners straddle the bone: no move of the free ones clears it
        if not _destinations(vol, v, ux, uy, 0, eps, corners):
            return False
    elif (not caught and _entered_end(vol, v, triangles, t, u, w, xs)
          and _past_end(vol, v, x, triangles, t, 1, eps, corners)):
        uz = 1.0
    else:
        _load_corners(vol, v, x, triangles, t, corners)
        ux, uy = _side_direction(vol, v, z, triangles, t, u, w, xs, x, corners, eps)
        if not _destinations(vol, v, ux, uy, 0, eps, corners):
            return False
    pos1, rot1 = vol.pos1, vol.rot1
    wnx, wny, wnz = rotate(rot1, v, ux, uy, uz)
    moved = False
    for k in range(3):
        i = triangles[t, k]
        if inv_mass[i] == 0.0 or (corners[k, 0] == x[i, 0] and corners[k, 1] == x[i, 1] and corners[k, 2] == x[i, 2]):
            continue  # an attached corner rides on the body
        moved = True
        x[i, 0], x[i, 1], x[i, 2] = corners[k, 0], corners[k, 1], corners[k, 2]
        lx, ly, lz = to_local(pos1, rot1, v, x[i, 0], x[i, 1], x[i, 2])
        svx, svy, svz = surface_velocity(vol, v, lx, ly, lz, h)
        approach = (vel[i, 0] - svx) * wnx + (vel[i, 1] - svy) * wny + (vel[i, 2] - svz) * wnz
        if approach < 0.0:  # physics: inelastic, as the point handling (memo Eq. 6-2), no friction
            vel[i, 0] -= approach * wnx
            vel[i, 1] -= approach * wny
            vel[i, 2] -= approach * wnz
    return moved


@kernel
def handle_axes(arrays, xs, x, vel, inv_mass, h, triangles, eps, passes, corners, boxes):
    """Every volume axis (the bones; not spheres) against every triangle (T, 3) of ``x`` at the end poses;
    a crossed triangle goes off the axis (``_push_off_axis``). Moving one can cross a neighbour, so up to
    ``passes`` passes, until one moves nothing. ``corners`` (3, 3) and ``boxes`` (``axis_block_count(T)``, 6):
    scratch. Returns the number of triangles moved.

    Broad phase: the boxes of runs of triangles (``block_boxes``), made at each pass's start, skip the runs
    a bone's segment box is apart from; once a triangle moved, its corners may have left their boxes, and the
    rest of the pass tests every triangle. So the triangles tested exactly are the same as without it."""
    vol = VolumeArrays(*arrays)  # a plain tuple from Python (see ``collision.kernels``)
    bones, pos1, rot1 = vol.bones, vol.pos1, vol.rot1
    n_triangles = triangles.shape[0]
    n_moved = 0
    for _ in range(passes):
        moved = 0
        block_boxes(x, triangles, boxes)
        for v in range(bones.shape[0]):
            z0, z1 = bones[v, 0], bones[v, 1]
            if math.isnan(z0):
                continue
            px, py, pz = to_world(pos1, rot1, v, 0.0, 0.0, z0)
            qx, qy, qz = to_world(pos1, rot1, v, 0.0, 0.0, z1)
            dx, dy, dz = qx - px, qy - py, qz - pz
            for k in range(boxes.shape[0]):
                if moved == 0 and segment_misses_block(boxes, k, px, py, pz, qx, qy, qz):
                    continue
                for run in range(k * AXIS_BLOCK, min((k + 1) * AXIS_BLOCK, n_triangles)):
                    # unsigned: no test for a negative index on each of the many loads below
                    t = np.uint64(run)
                    a, b, c = np.uint64(triangles[t, 0]), np.uint64(triangles[t, 1]), np.uint64(triangles[t, 2])
                    if segment_misses_triangle_box(x, a, b, c, px, py, pz, qx, qy, qz):
                        continue
                    crosses, s, u, w = segment_crosses_triangle(px, py, pz, dx, dy, dz, x, a, b, c)
                    if crosses and _push_off_axis(vol, v, z0 + s * (z1 - z0), triangles, t, u, w, xs, x, vel,
                                                  inv_mass, h, eps, corners):
                        moved += 1
        n_moved += moved
        if moved == 0:
            break
    return n_moved


@kernel
def out_of_pinches(arrays, x, inv_mass, eps, depth):
    """Free points (``x`` (N, 3), in place) deeper than ``depth`` in a volume go out of it, ``eps`` beyond its surface
    as pressed (``geometry.static_projection``), the deepest first, up to ``_OUT_OF_PINCHES`` volumes in turn; after
    ``handle_axes``, which may leave a corner up to ``pressed_pinch_depth`` in a volume pressed against a bone's.
    Returns how many moves it made."""
    vol = VolumeArrays(*arrays)
    moves = 0
    for i in range(x.shape[0]):
        if inv_mass[i] == 0.0:
            continue
        for _ in range(_OUT_OF_PINCHES):
            deepest, o = deepest_elsewhere(vol, -1, x[i, 0], x[i, 1], x[i, 2])
            if deepest <= depth:
                break
            lx, ly, lz = to_local(vol.pos1, vol.rot1, o, x[i, 0], x[i, 1], x[i, 2])
            _, sx, sy, sz, nx, ny, nz = static_projection(vol.kinds[o], vol.radii, vol.cuts, vol.planes, o, lx, ly, lz)
            x[i, 0], x[i, 1], x[i, 2] = to_world(vol.pos1, vol.rot1, o, sx + eps * nx, sy + eps * ny, sz + eps * nz)
            moves += 1
    return moves
