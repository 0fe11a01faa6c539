"""Orders of a garment's springs and edges for the kernels that spread them over numba's threads (issue 15).

A Gauss-Seidel sweep (the length correction, the edge handling) writes both ends of a spring in turn, so
two threads may not take springs that share a point: grouped by colour (``colour_order``), a colour's
springs share none and run in parallel, colour after colour. The forces are gathered per point instead
(``spring_incidence``): each point sums its own springs, so no two threads write one point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def colour_order(pairs: np.ndarray, num_points: int) -> tuple[np.ndarray, np.ndarray]:
    """A permutation of ``pairs`` (S, 2) point indices grouping them by colour (greedy, in the pairs' order, the
    lowest colour free at both ends) and where each colour starts in it (C + 1,) int64."""
    used = [0] * num_points  # per point, a bit per colour one of its pairs has
    colours = np.empty(len(pairs), dtype=np.int64)
    for s, (a, b) in enumerate(pairs.tolist()):
        taken = used[a] | used[b]
        colour = (~taken & (taken + 1)).bit_length() - 1  # the lowest bit not taken
        colours[s] = colour
        used[a] |= 1 << colour
        used[b] |= 1 << colour
    order = np.argsort(colours, kind="stable")
    return order, np.concatenate([[0], np.cumsum(np.bincount(colours, minlength=1))]).astype(np.int64)


def spring_incidence(springs: np.ndarray, num_points: int) -> tuple[np.ndarray, np.ndarray]:
    """The springs (S, 2) at each point, as CSR: (starts (N + 1,), ends) int64, point i's springs being
    ``ends[starts[i]:starts[i + 1]]`` in the springs' order, spring s written s where i is its first end and
    ``~s`` (= -s - 1) where i is its second."""
    count = len(springs)
    points = np.concatenate([springs[:, 0], springs[:, 1]])
    ends = np.concatenate([np.arange(count), ~np.arange(count)]).astype(np.int64)
    order = np.argsort(points, kind="stable")
    starts = np.searchsorted(points[order], np.arange(num_points + 1)).astype(np.int64)
    return starts, ends[order]


@dataclass(frozen=True)
class ParallelLayout:
    """A garment's springs and edges as the threaded kernels take them (``GarmentSolver`` builds it for a garment
    whose collider runs parallel): the correction springs (structural and shear) and the structural edges, each
    grouped by colour with where each colour starts, and the springs at each point (``spring_incidence``) with a
    scratch of one force per spring (S, 3) N."""

    correction_springs: np.ndarray
    correction_rest: np.ndarray
    correction_starts: np.ndarray
    incidence: tuple[np.ndarray, np.ndarray]
    spring_forces: np.ndarray
    edges: np.ndarray
    edge_rest: np.ndarray
    edge_starts: np.ndarray

    @classmethod
    def build(cls, springs, rest_lengths, correction_count: int, edges, edge_rest, num_points: int) -> ParallelLayout:
        """From all springs (S, 2) with their rest lengths (S,) m, the first ``correction_count`` of them corrected,
        and the edges (E, 2) with theirs (E,) m."""
        order, starts = colour_order(springs[:correction_count], num_points)
        edge_order, edge_starts = colour_order(edges, num_points)
        return cls(np.ascontiguousarray(springs[order]), np.ascontiguousarray(rest_lengths[order]), starts,
                   spring_incidence(springs, num_points), np.zeros((len(springs), 3)),
                   np.ascontiguousarray(edges[edge_order]), np.ascontiguousarray(edge_rest[edge_order]), edge_starts)
