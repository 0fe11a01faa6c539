"""Triangles binned into a uniform grid, and segments met against them (numba kernels over flat arrays).

The broad phase of the layers (``cloth.layers``): each triangle goes in every cubic cell its box touches (a
counting sort); a segment's box, grown by a pad, finds the triangles of the cells it touches, each once. On it:
which triangles a segment crosses (first and last along it), and how many edges cross any (the layers'
bone-through-cloth check, ``count_edges_through``). Points and lengths in metres.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..collision.crossing import segment_crosses_triangle, segment_misses_triangle_box


@njit(cache=True)
def build_grid(y, triangles, cell):
    """Triangles of points ``y`` (M, 3) binned into cubic cells of ``cell`` m, each in every cell its box
    touches (a counting sort: count, prefix sum, fill). Returns (origin (3,) m, dims (3,) int, starts (C+1,),
    entries) with cell ``(i * dims[1] + j) * dims[2] + k`` holding ``entries[starts[key]:starts[key + 1]]``."""
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(3):
        lo[k] = y[:, k].min() - 1e-6
        hi[k] = y[:, k].max() + 1e-6
    dims = np.empty(3, dtype=np.int64)
    for k in range(3):
        dims[k] = int((hi[k] - lo[k]) / cell) + 1
    counts = np.zeros(dims[0] * dims[1] * dims[2] + 1, dtype=np.int64)
    starts = counts
    entries = np.empty(0, dtype=np.int64)
    fill = counts
    for phase in range(2):
        if phase == 1:
            starts = np.cumsum(counts)
            entries = np.empty(starts[-1], dtype=np.int64)
            fill = starts[:-1].copy()
        for t in range(triangles.shape[0]):
            a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
            i0 = int((min(y[a, 0], y[b, 0], y[c, 0]) - lo[0]) / cell)
            i1 = int((max(y[a, 0], y[b, 0], y[c, 0]) - lo[0]) / cell)
            j0 = int((min(y[a, 1], y[b, 1], y[c, 1]) - lo[1]) / cell)
            j1 = int((max(y[a, 1], y[b, 1], y[c, 1]) - lo[1]) / cell)
            k0 = int((min(y[a, 2], y[b, 2], y[c, 2]) - lo[2]) / cell)
            k1 = int((max(y[a, 2], y[b, 2], y[c, 2]) - lo[2]) / cell)
            for i in range(max(i0, 0), min(i1, dims[0] - 1) + 1):
                for j in range(max(j0, 0), min(j1, dims[1] - 1) + 1):
                    for k in range(max(k0, 0), min(k1, dims[2] - 1) + 1):
                        key = (i * dims[1] + j) * dims[2] + k
                        if phase == 0:
                            counts[key + 1] += 1
                        else:
                            entries[fill[key]] = t
                            fill[key] += 1
    return lo, dims, starts, entries


@njit(cache=True)
def triangle_normals(y, triangles, normals):
    """Unit normals (T, 3) of the triangles of ``y`` (0 for a degenerate one), written to ``normals``."""
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        e1x, e1y, e1z = y[b, 0] - y[a, 0], y[b, 1] - y[a, 1], y[b, 2] - y[a, 2]
        e2x, e2y, e2z = y[c, 0] - y[a, 0], y[c, 1] - y[a, 1], y[c, 2] - y[a, 2]
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        norm = math.sqrt(nx * nx + ny * ny + nz * nz)
        scale = 1.0 / norm if norm > 1e-12 else 0.0
        normals[t, 0], normals[t, 1], normals[t, 2] = nx * scale, ny * scale, nz * scale


@njit(cache=True, inline="always")
def _cell_range(lo_p, hi_p, origin, dims, cell, axis):
    """The grid cells along ``axis`` a coordinate range touches (first, last + 1)."""
    first = max(int(math.floor((lo_p - origin[axis]) / cell)), 0)
    last = min(int(math.floor((hi_p - origin[axis]) / cell)), dims[axis] - 1)
    return first, last + 1


@njit(cache=True, inline="always")
def _near_box(lox, loy, loz, hix, hiy, hiz, origin, dims, cell, starts, entries, stamp, query, found, ordered):
    """The triangles binned in the cells the box ``lo`` .. ``hi`` touches, each once, written to ``found``
    (T,); returns how many. ``stamp`` (T,) holds the last query that found each triangle; ``query`` is new.
    ``ordered``: in increasing order, so that pushes made one after another (the edge passes) do not depend
    on the grid's cells."""
    count = 0
    i0, i1 = _cell_range(lox, hix, origin, dims, cell, 0)
    j0, j1 = _cell_range(loy, hiy, origin, dims, cell, 1)
    k0, k1 = _cell_range(loz, hiz, origin, dims, cell, 2)
    for ci in range(i0, i1):
        for cj in range(j0, j1):
            for ck in range(k0, k1):
                key = (ci * dims[1] + cj) * dims[2] + ck
                for e in range(starts[key], starts[key + 1]):
                    t = entries[e]
                    if stamp[t] != query:
                        stamp[t] = query
                        # insertion: an edge's box finds a few tens of triangles
                        m = count
                        while ordered and m > 0 and found[m - 1] > t:
                            found[m] = found[m - 1]
                            m -= 1
                        found[m] = t
                        count += 1
    return count


@njit(cache=True, inline="always")
def near_segment(px, py, pz, qx, qy, qz, pad, origin, dims, cell, starts, entries, stamp, query, found, ordered):
    """``_near_box`` for the box of segment p -> q grown by ``pad`` m."""
    return _near_box(min(px, qx) - pad, min(py, qy) - pad, min(pz, qz) - pad, max(px, qx) + pad, max(py, qy) + pad,
                     max(pz, qz) + pad, origin, dims, cell, starts, entries, stamp, query, found, ordered)


@njit(cache=True, inline="always")
def first_and_last_crossing(x, p0, p1, y, triangles, found, count):
    """The first and last of the triangles ``found[:count]`` that edge (p0, p1) of ``x`` crosses, along it from p0:
    (first, its segment parameter, last, its parameter); first = -1 when it crosses none."""
    px, py, pz = x[p0, 0], x[p0, 1], x[p0, 2]
    dx, dy, dz = x[p1, 0] - px, x[p1, 1] - py, x[p1, 2] - pz
    first_s, last_s, first, last = 2.0, -1.0, -1, -1
    for m in range(count):
        t = found[m]
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        if segment_misses_triangle_box(y, a, b, c, px, py, pz, x[p1, 0], x[p1, 1], x[p1, 2]):
            continue
        hit, s, _, _ = segment_crosses_triangle(px, py, pz, dx, dy, dz, y, a, b, c)
        if not hit:
            continue
        if s < first_s:
            first_s, first = s, t
        if s > last_s:
            last_s, last = s, t
    return first, first_s, last, last_s


@njit(cache=True)
def edge_crossings(x, edges, y, triangles, origin, dims, cell, starts, entries, crossed):
    """Per edge (E, 2) of points ``x`` (N, 3), the first and last triangle (T, 3) of points ``y`` it crosses,
    along it from its first point, through the grid of ``build_grid``: ``crossed`` (E, 2) int64, -1 for none
    (``tools/layer_crossings.py`` sorts the crossings left with it)."""
    stamp = np.full(triangles.shape[0], -1, dtype=np.int64)
    found = np.empty(triangles.shape[0], dtype=np.int64)
    for k in range(edges.shape[0]):
        p0, p1 = edges[k, 0], edges[k, 1]
        count = near_segment(x[p0, 0], x[p0, 1], x[p0, 2], x[p1, 0], x[p1, 1], x[p1, 2], 0.0, origin, dims, cell,
                              starts, entries, stamp, k, found, False)
        first, _, last, _ = first_and_last_crossing(x, p0, p1, y, triangles, found, count)
        crossed[k, 0], crossed[k, 1] = first, last


@njit(cache=True)
def count_edges_through(x, edges, y, triangles, origin, dims, cell, starts, entries):
    """How many edges (E, 2) of points ``x`` (N, 3) cross a triangle (T, 3) of points ``y`` (M, 3), through
    the grid of ``build_grid`` (a segment through a triangle's edge or vertex crosses, as for the bones)."""
    count = 0
    stamp = np.full(triangles.shape[0], -1, dtype=np.int64)
    found = np.empty(triangles.shape[0], dtype=np.int64)
    for k in range(edges.shape[0]):
        p0, p1 = edges[k, 0], edges[k, 1]
        px, py, pz = x[p0, 0], x[p0, 1], x[p0, 2]
        qx, qy, qz = x[p1, 0], x[p1, 1], x[p1, 2]
        for m in range(near_segment(px, py, pz, qx, qy, qz, 0.0, origin, dims, cell, starts, entries, stamp, k, found,
                                     False)):
            a, b, c = triangles[found[m], 0], triangles[found[m], 1], triangles[found[m], 2]
            if segment_misses_triangle_box(y, a, b, c, px, py, pz, qx, qy, qz):
                continue
            if segment_crosses_triangle(px, py, pz, qx - px, qy - py, qz - pz, y, a, b, c)[0]:
                count += 1
                break
    return count
