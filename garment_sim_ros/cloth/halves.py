"""A garment cut in two halves for the kernels that spread its springs and edges over two threads (issue 15).

A Gauss-Seidel sweep (the length correction, the edge handling) and the forces' scatter write both ends of a
spring in turn, so two threads may not take springs that share a point. The garment's points are cut in two
halves at the median of the horizontal axis it is widest along (left and right of the body: each half still
runs from the attached top to the hem); a spring with both ends in one half is that half's, the few across
the cut (two seams of a tube: 1.6 % of the 5 000-point one-piece's correction springs) are handled after both
halves, on one thread. Within a half the springs keep the model's order, so a sweep carries the attachments'
pull down the garment as the serial one does; grouped by colour instead (no two springs of a colour sharing a
point, 14 colours) a sweep needs twice the sweeps for the same residual (docs/benchmarks.md, "The 20 000-point
frame on both cores"). Two halves whatever the thread count: the result does not depend on it. The kernels
take the springs reordered (copies in the halves' order): through an index array they cost 30 % more than the
serial sweep on one thread.

A point on an opening's rim (the mesh's border: edges of one triangle) with a pair across the cut takes all
its pairs to the last group, in the model's order (1.8 % of the springs then). Split, its pairs in a half are
swept before the rest of the garment and those across after it, so each iteration ends with the last met and
the first stretched by their move. Where the cut runs through a walking vent, the ring spring at the vent's
top (the slit's end: the opened rings' tension goes round it) came out of the one-piece's real-clip run
(test_halves: CC walk, 40 frames; 6 runs, the start nudged by 1 um) at 1.51-1.91 its rest length against
the serial sweep's 1.29-1.48, always there (the long skirt, 3 runs: 1.31-1.78 against 1.31-1.48); its pairs
together, 1.31-1.43 (long skirt 1.32-1.44, 4 runs), the worst where the serial run's is. The attached rim
counts too: without it the one-piece's p99 median over the run rose to 1.029 (serial 1.022). A closed seam's
points keep their split: taking every point with a pair across (both sides of the cut) gave 1.25-1.47 but
1.46-2.06 on the long skirt, with 7.5 % of the springs on one thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .mesh_check import boundary_loops


def halves(positions: np.ndarray) -> np.ndarray:
    """(N,) bool: which points (N, 3) m are in the second half, beyond the median of the horizontal axis (x or
    y) the points spread widest along."""
    axis = int(np.argmax(np.ptp(positions[:, :2], axis=0)))
    return positions[:, axis] > np.median(positions[:, axis])


def rim(triangles: np.ndarray, count: int) -> np.ndarray:
    """(count,) bool: which of ``count`` points lie on the border of the mesh of ``triangles`` (T, 3)."""
    on_rim = np.zeros(count, dtype=bool)
    loops = boundary_loops(triangles)
    if loops:
        on_rim[np.concatenate(loops)] = True
    return on_rim


def split_pairs(pairs: np.ndarray, second: np.ndarray, on_rim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (P, 2) of points in the halves' order: (order (P,) int64, indices into ``pairs`` -- the first
    half's pairs, the second's, the last group's (those across the cut and every pair of a point ``on_rim``
    with one across) -- each group in the pairs' order; starts (4,) int64 of the three groups and their end)."""
    ends = second[pairs]
    across = ends[:, 0] != ends[:, 1]
    last = np.zeros(len(second), dtype=bool)
    last[pairs[across].ravel()] = True
    last &= on_rim
    group = np.where(across | last[pairs].any(axis=1), 2, ends[:, 0].astype(np.int64))
    order = np.argsort(group, kind="stable").astype(np.int64)
    return order, np.concatenate([[0], np.cumsum(np.bincount(group, minlength=3))]).astype(np.int64)


@dataclass(frozen=True)
class ParallelLayout:
    """A garment's springs and edges in the halves' order (``split_pairs``), as the threaded kernels take them:
    all springs with their rest lengths (m), stiffnesses and dampings (the forces), the correction springs
    (structural and shear) with their rest lengths, the structural edges with theirs; each with its starts."""

    springs: np.ndarray
    rest: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    spring_starts: np.ndarray
    correction_springs: np.ndarray
    correction_rest: np.ndarray
    correction_starts: np.ndarray
    edges: np.ndarray
    edge_rest: np.ndarray
    edge_starts: np.ndarray

    @classmethod
    def build(cls, rest_positions, triangles, springs, rest_lengths, stiffness, damping, correction_count: int,
              edges, edge_rest) -> ParallelLayout:
        """From the rest positions (N, 3) m and the triangles (T, 3), the springs (S, 2) with their rest lengths,
        stiffnesses and dampings (S,), the first ``correction_count`` of them corrected, and the edges (E, 2) with
        their rest lengths."""
        second, on_rim = halves(rest_positions), rim(triangles, len(rest_positions))
        order, starts = split_pairs(springs, second, on_rim)
        correction, correction_starts = split_pairs(springs[:correction_count], second, on_rim)
        edge_order, edge_starts = split_pairs(edges, second, on_rim)
        return cls(*(np.ascontiguousarray(a[order]) for a in (springs, rest_lengths, stiffness, damping)), starts,
                   np.ascontiguousarray(springs[correction]), np.ascontiguousarray(rest_lengths[correction]),
                   correction_starts, np.ascontiguousarray(edges[edge_order]),
                   np.ascontiguousarray(edge_rest[edge_order]), edge_starts)
