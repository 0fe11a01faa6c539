"""Numba kernels: mass points and cloth edges against quadric volumes (memo §6.2), the drivers.

Every kernel takes the volumes first, as one ``VolumeArrays`` bundle (``vol``: shapes, and the poses
at the substep's start and end), then the points in one order: start positions ``xs`` (N, 3) m,
positions ``x`` (N, 3) m, velocities ``vel`` (N, 3) m/s, inverse masses (N,) 1/kg, the substep
length ``h`` s; then the parameters, then what is written besides the points (the contact cache).
The kernels called from Python take the bundle as a plain tuple, ``tuple(vol)``, and name it on entry
(``VolumeArrays(*arrays)``): numba types a named tuple argument in Python, about 3 us per call for its
14 arrays (measured; the collision makes 50 to 100 calls a frame), a plain tuple in C.
One point against one volume is ``collision.response``; the local geometry ``collision.geometry``;
the broad phase ``collision.broad_phase``.

Beyond the memo: body volumes overlap at the joints, so a point pushed out of one volume can land
in its neighbour; a point that was hit gets a few extra static passes (``_SETTLE_PASSES``).
The per-point contact cache (temporal coherence; ``ClothState.contacts``) lists the volumes hit in
the last ``handle_all`` first, then older entries the point is still near; the broad phase evicts
the far ones.
"""

from __future__ import annotations

import math
import types

import numpy as np
from numba import njit, prange

from .broad_phase import (
    broad_phase_rejects,
    interpolate_poses,
    out_of_reach,
    outside_bounding_sphere,
    reach_radii,
    segment_misses_box,
    substep_motion,
)
from .contact_planes import press
from .geometry import (
    TINY,
    deepest_on_segment,
    inlined_kernel,
    kernel,
    penetration_depth,
    rotate,
    static_projection,
    to_local,
)
from .response import MODE_STATIC, NO_HIT, STATIC_HIT, depth_elsewhere, handle_local_pair, handle_pair
from .volume_arrays import VolumeArrays
from .volumes import CAPSULE, SPHERE

_SETTLE_PASSES = 4  # extra static passes for a point hit by a volume (overlapping volumes)


def serial_and_parallel(driver):
    """``driver`` (a loop over points with ``prange``) compiled twice: serial, where numba's ``prange``
    is ``range``, and with the points spread over numba's threads. One source for both, so the two
    cannot drift apart."""
    return kernel(driver), parallel_twin(driver)


def parallel_twin(function, namespace=None):
    """``function`` compiled with numba's threads, from a twin of it with its own name: numba's on-disk
    cache (``cache=True``) keys a function by its qualified name and line, and two dispatchers of one
    function would overwrite each other's cache entries. ``namespace``: the globals the twin's calls
    resolve in (default: the function's own)."""
    twin = types.FunctionType(function.__code__, function.__globals__ if namespace is None else namespace,
                              function.__name__ + "_parallel", function.__defaults__, function.__closure__)
    twin.__qualname__ = function.__qualname__ + "_parallel"
    twin.__doc__ = function.__doc__
    return njit(cache=True, parallel=True)(twin)


# ----------------------------------------------------------------------------- per substep
@kernel
def substep_poses(arrays, frame_pos, frame_quat, f0, f1, pressing, clearance, gap, room):
    """The volumes' poses at frame fractions ``f0`` and ``f1`` (the substep's ends), interpolated between the
    frame's (``frame_pos`` (2, V, 3) m, ``frame_quat`` (2, V, 4) xyzw), their motion over the substep, and the
    contact planes of the ``pressing`` pairs (P, 2) at its end (``contact_planes.press``; none: the planes are
    left as they are). ``Collider.begin_substep`` and the fused frame both call this. Returns the deepest
    overlap pressed, m."""
    vol = VolumeArrays(*arrays)
    interpolate_poses(frame_pos[0], frame_quat[0], frame_pos[1], frame_quat[1], f0, vol.pos0, vol.rot0)
    interpolate_poses(frame_pos[0], frame_quat[0], frame_pos[1], frame_quat[1], f1, vol.pos1, vol.rot1)
    substep_motion(vol.pos0, vol.rot0, vol.pos1, vol.rot1, vol.displacement, vol.chord)
    if pressing.shape[0] == 0:
        return 0.0
    return press(arrays, pressing, clearance, gap, room)


# ----------------------------------------------------------------------------- drivers over points

# The drivers hand their points to a per-point function in runs of this many, one call a run. A call from one
# compiled function to another passes every array field by field (the volumes' bundle alone is ~170 arguments),
# and LLVM did not inline the per-point functions: one such call per point was half of handle_all's time and
# three quarters of handle_contacts' (docs/benchmarks.md, "Calls per point"). Inside a run the per-point
# functions are inlined in numba's IR (``inline="always"``), which numba's parallel loop cannot take in its own
# body: its reductions' analysis fails on the inlined loops.
_RUN = 64


@kernel
def _runs(n_points):
    """How many runs of ``_RUN`` points ``n_points`` make."""
    return (n_points + _RUN - 1) // _RUN


@kernel
def _next_candidate(vol, xs, x, i, cache, any_cached, start):
    """The first uncached volume ``v >= start`` that point i may hit (within its reach, then its local box
    meets the segment p0' -> p1), with p0' and p1 in its frame (``handle_local_pair``'s ``a``, ``b``): ``(v,
    ax, ay, az, bx, by, bz)``; v is the volume count if none. Most pairs end here, in a few dozen flops.
    ``any_cached``: whether point i's cache row holds a volume (``_has_cached``; if not, it is not searched)."""
    n_volumes = vol.kinds.shape[0]
    for v in range(start, n_volumes):
        cached = False
        for c in range(cache.shape[1] if any_cached else 0):
            cached = cached or cache[i, c] == v
        u = np.uint64(v)  # unsigned: no test for a negative index in the loads below (start is not known >= 0)
        if cached or out_of_reach(vol, u, x, i):  # the cache first: a point resting on a volume skips its rotations
            continue
        bx, by, bz = to_local(vol.pos1, vol.rot1, u, x[i, 0], x[i, 1], x[i, 2])
        ax, ay, az = to_local(vol.pos0, vol.rot0, u, xs[i, 0], xs[i, 1], xs[i, 2])
        if not segment_misses_box(vol.boxes, u, ax, ay, az, bx, by, bz):
            return v, ax, ay, az, bx, by, bz
    return n_volumes, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


# ``_handle_point_all``'s ``first`` for a point with cached volumes: its scan comes after them, from where they put it
_AFTER_CACHE = (-1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@kernel
def _has_cached(cache, i):
    """Whether point i's contact cache holds a volume."""
    for c in range(cache.shape[1]):
        if cache[i, c] >= 0:
            return True
    return False


@kernel
def _near_bounding_sphere(vol, v, x, i, margin):
    """Point i is within ``margin`` of volume v's bounding sphere (end pose), or inside it."""
    pos = vol.pos1
    d2 = (x[i, 0] - pos[v, 0]) ** 2 + (x[i, 1] - pos[v, 1]) ** 2 + (x[i, 2] - pos[v, 2]) ** 2
    return d2 <= (vol.bounding_radii[v] + margin) ** 2


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


@inlined_kernel
def _handle_point_all(vol, xs, x, vel, i, h, eps, friction, grip, c_time, switch_ratio, mode, margin, cache,
                      scratch, first):
    """Point i against every volume, cached volumes first (temporal coherence), then rebuilds
    its cache row: this call's hits first, then the older entries the point is still near
    (the broad phase evicts the others). ``scratch[i]`` (length 2 C) holds the hits in its
    first half and the kept entries in its second. ``first``: for a point with an empty cache,
    the caller's ``_next_candidate(..., 0)`` (its scan is not repeated); else ``_AFTER_CACHE``. Returns (static
    hits, dynamic hits)."""
    n_volumes = vol.kinds.shape[0]
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
        # handle_contacts sees next; within ``margin`` of that sphere it stays (see ``_handle_all``).
        if not (margin > 0.0 and _near_bounding_sphere(vol, v, x, i, margin)) and (
                out_of_reach(vol, v, x, i) or broad_phase_rejects(vol, v, xs, x, i)):
            continue  # the margin first: a point resting by the volume skips the broad phase's square roots
        code = handle_pair(vol, v, xs, x, vel, i, h, eps, friction, grip, c_time, switch_ratio, mode)[0]
        if code == NO_HIT:
            n_kept = _record(scratch, i, cache_size, n_kept, cache_size, v)
            continue
        if code == STATIC_HIT:
            n_static += 1
        else:
            n_dynamic += 1
        n_hits = _record(scratch, i, 0, n_hits, cache_size, v)
    any_cached = first[0] < 0
    v, ax, ay, az, bx, by, bz = _next_candidate(vol, xs, x, i, cache, True, 0) if any_cached else first
    while v < n_volumes:
        code = handle_local_pair(vol, v, x, vel, i, ax, ay, az, bx, by, bz, h, eps, friction, grip, c_time,
                                 switch_ratio, mode)[0]
        if code != NO_HIT:
            if code == STATIC_HIT:
                n_static += 1
            else:
                n_dynamic += 1
            n_hits = _record(scratch, i, 0, n_hits, cache_size, v)
        # from the point's current position: a hit has moved it
        v, ax, ay, az, bx, by, bz = _next_candidate(vol, xs, x, i, cache, any_cached, v + 1)
    # Volumes overlap at the joints: being pushed out of one can push a point into its
    # neighbour (the crotch between pelvis and thigh). A few static passes settle it, without the friction
    # along the bones: the way out of a squeeze is often along them, and the grip would hold the point inside.
    settle_grip = (grip[0], 0.0, grip[2], grip[3])
    for _ in range(_SETTLE_PASSES if n_static + n_dynamic > 0 else 0):
        moved = False
        for v in range(n_volumes):
            if outside_bounding_sphere(vol, v, x, i):
                continue
            code = handle_pair(vol, v, xs, x, vel, i, h, eps, friction, settle_grip, c_time, switch_ratio,
                               MODE_STATIC)[0]
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


def _handle_all(arrays, xs, x, vel, inv_mass, h, eps, friction, grip, c_time, switch_ratio, mode, margin, cache,
                scratch):
    """Memo §3 step 5 over all points (the broad phase's reach first; with infinite bounding radii it is
    infinite). ``margin`` > 0 (``contact_margin``, m): a cached volume stays cached while the point is within
    that of its bounding sphere, so that the contact handling during the length correction
    (``handle_contacts``) keeps a point resting just outside out of it. Returns (static hits, dynamic hits)."""
    vol = VolumeArrays(*arrays)
    reach_radii(vol, xs, x, inv_mass)
    n_static = 0
    n_dynamic = 0
    for run in prange(_runs(x.shape[0])):  # the points are independent here: each touches its own rows only
        s, d = _handle_run(vol, xs, x, vel, inv_mass, h, eps, friction, grip, c_time, switch_ratio, mode, margin,
                           cache, scratch, run * _RUN, min(x.shape[0], (run + 1) * _RUN))
        n_static += s
        n_dynamic += d
    return n_static, n_dynamic


@kernel
def _handle_run(vol, xs, x, vel, inv_mass, h, eps, friction, grip, c_time, switch_ratio, mode, margin, cache, scratch,
                start, end):
    """``handle_all`` of the points ``start:end``; (static hits, dynamic hits)."""
    n_static = 0
    n_dynamic = 0
    n_volumes = vol.kinds.shape[0]
    for i in range(start, end):
        if inv_mass[i] == 0.0:
            continue
        # Most points have no cached volume and none within reach: one scan, in a loop without the handling's
        # code, finds that, and its first candidate is where the handling goes on.
        first = _AFTER_CACHE if _has_cached(cache, i) else _next_candidate(vol, xs, x, i, cache, False, 0)
        if first[0] == n_volumes:
            continue
        s, d = _handle_point_all(vol, xs, x, vel, i, h, eps, friction, grip, c_time, switch_ratio, mode, margin, cache,
                                 scratch, first)
        n_static += s
        n_dynamic += d
    return n_static, n_dynamic


handle_all, handle_all_parallel = serial_and_parallel(_handle_all)


@inlined_kernel
def _contacts_point(vol, xs, x, vel, i, h, eps, friction, grip, switch_ratio, mode, cache):
    """Point i against its cached volumes (``handle_contacts``); the number of hits."""
    pos1, bounding_radii = vol.pos1, vol.bounding_radii
    n_moved = 0
    for c in range(cache.shape[1]):
        v = cache[i, c]
        if v < 0:
            continue
        b = math.sqrt((x[i, 0] - pos1[v, 0]) ** 2 + (x[i, 1] - pos1[v, 1]) ** 2 + (x[i, 2] - pos1[v, 2]) ** 2)
        if b > bounding_radii[v]:
            continue
        code = handle_pair(vol, v, xs, x, vel, i, h, eps, friction, grip, 0.0, switch_ratio, mode)[0]
        if code != NO_HIT:
            n_moved += 1
    return n_moved


def _handle_contacts(arrays, xs, x, vel, inv_mass, h, eps, friction, grip, switch_ratio, mode, cache):
    """Memo §3 step 4: the cached (point, volume) pairs at the end poses, during the length correction.

    ``mode`` as in ``handle_pair``, from the substep's start positions ``xs``. physics: the correction
    can pull a point deep into a thin limb (towards a neighbour on the limb's far side); pushed out
    radially from there it lands wherever it happens to be relative to the axis, and edges end up
    straddling the limb. Tested along its relative trajectory, a deep point goes back out where it
    came in. No slide here (c_time 0): the velocities are recomputed after the correction and the
    full handling responds them. Returns the number of points moved out."""
    vol = VolumeArrays(*arrays)
    n_moved = 0
    for run in prange(_runs(x.shape[0])):  # each point only touches its own row
        n_moved += _contacts_run(vol, xs, x, vel, inv_mass, h, eps, friction, grip, switch_ratio, mode, cache,
                                 run * _RUN, min(x.shape[0], (run + 1) * _RUN))
    return n_moved


@kernel
def _contacts_run(vol, xs, x, vel, inv_mass, h, eps, friction, grip, switch_ratio, mode, cache, start, end):
    """``handle_contacts`` of the points ``start:end``; the number of hits."""
    n_moved = 0
    for i in range(start, end):
        if inv_mass[i] != 0.0:
            n_moved += _contacts_point(vol, xs, x, vel, i, h, eps, friction, grip, switch_ratio, mode, cache)
    return n_moved


handle_contacts, handle_contacts_parallel = serial_and_parallel(_handle_contacts)


# Edges up to this many times their rest length are not tested: between two points outside a convex
# volume such a chord dips at most its sagitta, which exceeds the rest length's by (L/2)^2 (slack - 1) / r
# -- under 0.1 mm for 3 cm edges on a 5 cm limb -- and the length correction keeps most edges within 1 %.
_EDGE_SLACK = 1.02


@kernel
def handle_edges(arrays, xs, x, inv_mass, edges, rest_lengths, edge_pinch_depth):
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
    else the nearer one. In a pinch (``edge_pinch_depth`` m > 0; 0: off) -- the move would put an end
    deeper than that into another volume -- the edge stays (contact over crossing, as
    ``crossing.handle_axes``): a thigh raised against the belly (CC cartwheel, issue 11) overlaps the
    torso's volume by 3-7 cm, and edges moved out of one into the other threw the skirt between them
    10-19 cm a substep, past the guard's stretch; the trousers' crotch between the pelvis and the thighs
    (CC jump at 2x) was thrown 14-21 cm a substep, across the thigh's bone. Returns the number of edges moved.
    """
    return _handle_edge_run(arrays, xs, x, inv_mass, edges, rest_lengths, 0, edges.shape[0], edge_pinch_depth)


@njit(cache=True, parallel=True)
def handle_edges_halves(arrays, xs, x, inv_mass, edges, rest_lengths, starts, edge_pinch_depth):
    """``handle_edges`` on two threads: each half of the garment's edges on its own thread, in their order, then
    those across the cut (the edges and their rest lengths in ``cloth.halves``' order, ``starts`` (4,) its
    groups'); the same on any number of threads."""
    moved = np.zeros(3, dtype=np.int64)  # per group (numba's reductions do not reach into the runs)
    for half in prange(2):
        moved[half] = _handle_edge_run(arrays, xs, x, inv_mass, edges, rest_lengths, starts[half], starts[half + 1],
                                       edge_pinch_depth)
    moved[2] = _handle_edge_run(arrays, xs, x, inv_mass, edges, rest_lengths, starts[2], starts[3], edge_pinch_depth)
    return moved.sum()


@kernel
def _handle_edge_run(arrays, xs, x, inv_mass, edges, rest_lengths, start, end, edge_pinch_depth):
    """``handle_edges`` of the edges ``start:end``; how many moves."""
    vol = VolumeArrays(*arrays)
    kinds, radii, cuts, planes = vol.kinds, vol.radii, vol.cuts, vol.planes
    bounding_radii, boxes = vol.bounding_radii, vol.boxes
    pos0, rot0, pos, rot = vol.pos0, vol.rot0, vol.pos1, vol.rot1
    n_moved = 0
    for k in range(start, end):
        e = np.uint64(k)  # unsigned: no test for a negative index (a run from a start not known >= 0: dearer)
        a = np.uint64(edges[e, 0])
        b = np.uint64(edges[e, 1])
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
            t, inside = deepest_on_segment(kinds[v], radii, cuts, planes, v, ax, ay, az, bx, by, bz)
            if not inside or t <= 0.0 or t >= 1.0:
                continue
            px, py, pz = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
            inside, sx, sy, sz, nx, ny, nz = static_projection(kinds[v], radii, cuts, planes, v, px, py, pz)
            if not inside:
                continue
            # the same point of the edge at the substep's start, in the volume's frame (p0', memo §6.2.1)
            ox, oy, oz = to_local(pos0, rot0, v, xs[a, 0] + t * (xs[b, 0] - xs[a, 0]),
                                  xs[a, 1] + t * (xs[b, 1] - xs[a, 1]), xs[a, 2] + t * (xs[b, 2] - xs[a, 2]))
            if (kinds[v] != CAPSULE and ox * nx + oy * ny < 0.0
                    and not static_projection(kinds[v], radii, cuts, planes, v, ox, oy, oz)[0]):
                # it was clear of the volume, beyond the axis: out there, where the axis' perpendicular
                # towards the start point meets the surface (static projection of a point just off it)
                ux, uy = ox, oy
                norm = math.sqrt(ux * ux + uy * uy)
                if norm > TINY:
                    lift = 1e-6 * max(radii[v, 0], radii[v, 1])
                    inside, sx, sy, sz, nx, ny, nz = static_projection(
                        kinds[v], radii, cuts, planes, v, lift * ux / norm, lift * uy / norm, pz)
                    if not inside:
                        continue
            dip = math.sqrt((sx - px) ** 2 + (sy - py) ** 2 + (sz - pz) ** 2)
            r = radii[v, 0] if kinds[v] == SPHERE else math.sqrt(sx * sx + sy * sy)
            half_chord = min(r, 0.5 * rest_lengths[e])
            excess = dip - (r - math.sqrt(r * r - half_chord * half_chord))
            if excess <= 0.0:
                continue
            wx, wy, wz = rotate(rot, v, excess * nx, excess * ny, excess * nz)
            if edge_pinch_depth > 0.0 and (
                    depth_elsewhere(vol, v, x[a, 0] + wx, x[a, 1] + wy, x[a, 2] + wz) > edge_pinch_depth
                    or depth_elsewhere(vol, v, x[b, 0] + wx, x[b, 1] + wy, x[b, 2] + wz) > edge_pinch_depth):
                continue  # out of v is into another volume: a pinch, where contact wins (see the docstring)
            for i in (a, b):
                if inv_mass[i] > 0.0:
                    x[i, 0] += wx
                    x[i, 1] += wy
                    x[i, 2] += wz
            n_moved += 1
    return n_moved


@kernel
def _deepest(vol, px, py, pz):
    """Depth of point p inside its deepest volume at the end poses (see ``penetration_depth``), 0 outside, m."""
    kinds, radii, cuts, planes, pos, rot = vol.kinds, vol.radii, vol.cuts, vol.planes, vol.pos1, vol.rot1
    bounding_radii = vol.bounding_radii
    deepest = 0.0
    for v in range(kinds.shape[0]):
        if (px - pos[v, 0]) ** 2 + (py - pos[v, 1]) ** 2 + (pz - pos[v, 2]) ** 2 > bounding_radii[v] ** 2:
            continue  # outside the sphere holding the volume: depth 0 (most pairs, without a rotation)
        lx, ly, lz = to_local(pos, rot, v, px, py, pz)
        deepest = max(deepest, penetration_depth(kinds[v], radii, cuts, planes, v, lx, ly, lz))
    return deepest


@kernel
def penetration_depths(arrays, x, out):
    """Depth of every point inside its deepest volume at the end poses (``_deepest``) into ``out`` (N,) m.
    Returns nothing: compiled without numba's runtime, a returned array would carry no reference of its own,
    and a compiled caller dropping it would free the caller's array (``cloth.fused``)."""
    vol = VolumeArrays(*arrays)
    for i in range(x.shape[0]):
        out[i] = _deepest(vol, x[i, 0], x[i, 1], x[i, 2])


@kernel
def deepest_triangle_centre(arrays, x, triangles):
    """The depth of the deepest centre of the triangles (T, 3) of ``x`` inside a volume (``_deepest``), m;
    0 when none is inside. The centre is the corners' sum over 3, as numpy's mean of them."""
    vol = VolumeArrays(*arrays)
    deepest = 0.0
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        deepest = max(deepest, _deepest(vol, (x[a, 0] + x[b, 0] + x[c, 0]) / 3.0, (x[a, 1] + x[b, 1] + x[c, 1]) / 3.0,
                                        (x[a, 2] + x[b, 2] + x[c, 2]) / 3.0))
    return deepest


# Tries per end of a tear's give (``give_room_to_tears``): the move halved until the end stays outside every volume
_GIVE_TRIES = 5
_GIVE_PASSES = 3  # passes over the springs at most: a point shared by two torn springs gives to both


@kernel
def give_room_to_tears(arrays, x, inv_mass, springs, rest, count, stretch, eps, x_from):
    """The contacts' room given to springs still torn after the strain limiting: each of the first ``count``
    springs (S, 2) of points ``x`` (N, 3) m longer than ``stretch`` x its ``rest`` (S,) m is shortened to that,
    its ends moving by their inverse masses along it, each end at most half the collision epsilon ``eps`` m from
    where it was on entry (``x_from`` (N, 3), scratch) and never deeper into a volume than it was (``_deepest`` at
    the end poses: a point outside stays outside); a move that would be is halved, up to ``_GIVE_TRIES`` times.
    Positions only: the room is the contact's, not motion. Returns how many ends moved.

    Why: where two volumes squeeze cloth (the cartwheel's raised thigh 55-68 mm into the torso, issue 11), the
    contact handling holds both ends of a spring on the two surfaces and nothing shortens it; the limiting's own
    contact handling puts its points ``eps`` out of their volumes, room that a tearing spring can have without a
    point going in. Half of it: the other half stays for the next substep's handling (given whole, points put on
    the surface ended 1.6-1.8 mm deep on the cartwheel; docs/real_motion.md)."""
    vol = VolumeArrays(*arrays)
    room = 0.5 * eps
    for i in range(x.shape[0]):
        for c in range(3):
            x_from[i, c] = x[i, c]
    moved = 0
    for _ in range(_GIVE_PASSES):
        before = moved
        for s in range(count):
            a, b = springs[s, 0], springs[s, 1]
            dx, dy, dz = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            wa, wb = inv_mass[a], inv_mass[b]
            if length <= stretch * rest[s] or wa + wb <= 0.0:
                continue
            share = (length - stretch * rest[s]) / (length * (wa + wb))
            for end, step in ((a, share * wa), (b, -share * wb)):
                if step == 0.0:
                    continue
                depth = _deepest(vol, x[end, 0], x[end, 1], x[end, 2])
                for _try in range(_GIVE_TRIES):
                    px, py, pz = x[end, 0] + step * dx, x[end, 1] + step * dy, x[end, 2] + step * dz
                    far = math.sqrt((px - x_from[end, 0]) ** 2 + (py - x_from[end, 1]) ** 2
                                    + (pz - x_from[end, 2]) ** 2)
                    if far <= room and _deepest(vol, px, py, pz) <= depth:
                        x[end, 0], x[end, 1], x[end, 2] = px, py, pz
                        moved += 1
                        break
                    step *= 0.5
        if moved == before:  # nothing moved: another pass would find the same (most substeps: no spring torn)
            break
    return moved
