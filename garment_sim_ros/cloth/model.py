"""The garment's constants (Warp's ``Model`` / MuJoCo's ``mjModel``): mesh, springs, areas, attachments.

Built once from a ``GarmentMesh``; never changes while simulating. Parameter-dependent
arrays (masses, stiffnesses) are derived from it by ``cloth.solver`` whenever parameters change.

Springs after Provot: *structural* springs are the mesh edges (what the memo counts as
springs); *shear* springs join the two vertices opposite an interior edge (the other
diagonal of a quad split into triangles, or across a grid line); *bend* springs join a
vertex to the vertex two edges away along the straightest continuation. Provot's length
correction acts on structural and shear springs.

Tethers (long-range attachments, as NvCloth and Chaos Cloth use them): every free point is tied to
the attached point nearest to it *along the cloth* (the shortest path over the mesh edges at rest),
and may be no farther from it than that rest distance times ``1 + tether_slack`` (``cloth.solver``).
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field

import numpy as np

from ..transforms import inverse, transform_points
from .garments import GarmentMesh

STRUCTURAL, SHEAR, BEND = 0, 1, 2
SPRING_KIND_NAMES = ("structural", "shear", "bend")
_STRAIGHT_COS = 0.8  # a bend spring continues an edge within ~37 degrees
STRETCH_PERCENTILE = 99.0  # the "p99" of the stretch figures (``stretch_figures``)
# Issue 11's target (d) on those figures: the p99 and the longest spring (length / rest length). Here so that the
# solver (its frame retries, its strain limiting's undo) and the metric (``quality.Targets``) read one number.
STRETCH_P99_TARGET = 1.05
STRETCH_MAX_TARGET = 1.5


@dataclass(frozen=True)
class ClothModel:
    name: str
    rest_positions: np.ndarray  # (N, 3) root frame of the rest pose, m
    triangles: np.ndarray  # (T, 3) int64
    edges: np.ndarray  # (E, 2) mesh edges
    springs: np.ndarray  # (S, 2) int64, structural first, then shear, then bend
    spring_kinds: np.ndarray  # (S,) int64
    rest_lengths: np.ndarray  # (S,) m
    vertex_areas: np.ndarray  # (N,) a third of the adjacent triangles' areas, m^2
    attached: np.ndarray  # (A,) vertex indices carried kinematically
    attachment_frames: tuple[str, ...]  # joint-map roles the attached vertices follow
    attachment_frame_index: np.ndarray  # (A,) index into attachment_frames
    attachment_local: np.ndarray  # (A, 3) coordinates in the attachment frame, m
    # A second carrier per attached point (skinned to two segments): index into attachment_frames (the
    # first carrier's where none), coordinates in it (A, 3) m, and its weight (A,) in [0, 1] (0: none).
    attachment_frame_index2: np.ndarray
    attachment_local2: np.ndarray
    attachment_weight2: np.ndarray
    # Tethers: per point, the attached point nearest along the mesh edges at rest (-1: the point is attached
    # itself, or no attached point is connected to it) (N,) int64, and that path's length (N,) m (0 where -1).
    tether_anchors: np.ndarray
    tether_lengths: np.ndarray
    rings: dict
    limb_tubes: dict = field(default_factory=dict)  # see ``GarmentMesh.limb_tubes``

    @property
    def num_points(self) -> int:
        return len(self.rest_positions)

    @property
    def num_correction_springs(self) -> int:
        """Springs subject to length correction: they come first (structural, then shear)."""
        return int(np.count_nonzero(self.spring_kinds != BEND))

    def spring_counts(self) -> dict[str, int]:
        return {name: int(np.count_nonzero(self.spring_kinds == k)) for k, name in enumerate(SPRING_KIND_NAMES)}


def _shear_pairs(triangles: np.ndarray) -> np.ndarray:
    """For every edge shared by two triangles, the pair of vertices opposite it."""
    tri_edges = np.concatenate([triangles[:, [0, 1, 2]], triangles[:, [1, 2, 0]], triangles[:, [2, 0, 1]]])
    keys = np.sort(tri_edges[:, :2], axis=1)
    order = np.lexsort((keys[:, 1], keys[:, 0]))
    keys, opposite = keys[order], tri_edges[order, 2]
    same = np.all(keys[1:] == keys[:-1], axis=1)
    first = np.nonzero(same)[0]
    pairs = np.stack([opposite[first], opposite[first + 1]], axis=1)
    return pairs[pairs[:, 0] != pairs[:, 1]]


def _bend_pairs(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Vertex pairs two edges apart along the straightest continuation through the middle vertex."""
    n = len(positions)
    directed = np.concatenate([edges, edges[:, ::-1]])  # a -> b
    directed = directed[np.argsort(directed[:, 0], kind="stable")]
    start = np.searchsorted(directed[:, 0], np.arange(n + 1))
    degree = np.diff(start)
    # Every path a -> b -> c: for directed edge e = (a, b), the edges leaving b.
    per_edge = degree[directed[:, 1]]
    edge_id = np.repeat(np.arange(len(directed)), per_edge)
    offset = np.arange(len(edge_id)) - np.repeat(np.cumsum(per_edge) - per_edge, per_edge)
    a = directed[edge_id, 0]
    b = directed[edge_id, 1]
    c = directed[start[b] + offset, 1]
    keep = c != a
    edge_id, a, b, c = edge_id[keep], a[keep], b[keep], c[keep]
    incoming = positions[b] - positions[a]
    outgoing = positions[c] - positions[b]
    cos = np.sum(incoming * outgoing, axis=1) / (
        np.linalg.norm(incoming, axis=1) * np.linalg.norm(outgoing, axis=1))
    order = np.lexsort((-cos, edge_id))  # best continuation first within each edge
    first = order[np.r_[True, edge_id[order][1:] != edge_id[order][:-1]]]
    best = first[cos[first] >= _STRAIGHT_COS]
    return np.stack([a[best], c[best]], axis=1).astype(np.int64)


def _unique_new(pairs: np.ndarray, existing: set) -> np.ndarray:
    pairs = np.sort(pairs, axis=1)
    pairs = np.unique(pairs, axis=0) if len(pairs) else pairs
    keep = [tuple(p) not in existing for p in pairs]
    return pairs[np.array(keep, dtype=bool)] if len(pairs) else pairs


def nearest_along_edges(positions: np.ndarray, edges: np.ndarray, sources: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """For every point, the source point nearest to it along the edges (E, 2) and that path's length, m.

    Multi-source Dijkstra over the edge graph weighted by the edges' lengths: (N,) int64 source indices
    (-1 where no source is connected, and for the sources themselves) and (N,) lengths (inf where none).
    Plain Python with heapq: it runs once per model build on ~10^3 points, far below a millisecond's
    worth of anything a graph library would save, and spares the package a SciPy dependency."""
    n = len(positions)
    lengths = np.linalg.norm(positions[edges[:, 1]] - positions[edges[:, 0]], axis=1)
    neighbours: list[list[tuple[int, float]]] = [[] for _ in range(n)]
    for (a, b), length in zip(edges.tolist(), lengths.tolist()):
        neighbours[a].append((b, length))
        neighbours[b].append((a, length))
    distance = np.full(n, np.inf)
    nearest = np.full(n, -1, dtype=np.int64)
    queue = [(0.0, int(s), int(s)) for s in sources]
    heapq.heapify(queue)
    while queue:
        d, i, source = heapq.heappop(queue)
        if d >= distance[i]:
            continue
        distance[i], nearest[i] = d, source
        for j, length in neighbours[i]:
            if d + length < distance[j]:
                heapq.heappush(queue, (d + length, j, source))
    nearest[np.asarray(sources, dtype=np.int64)] = -1
    return nearest, distance


def triangle_areas(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = positions[triangles]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def build_cloth_model(mesh: GarmentMesh, attachment_rest_poses: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
                      ) -> ClothModel:
    """Model of ``mesh``. ``attachment_rest_poses`` maps each role in ``mesh.attachments`` (and the second
    carriers of ``mesh.shared_attachments``) to that segment's rest pose (position, xyzw) in the root
    frame; identity (the root itself) when absent."""
    positions = np.asarray(mesh.vertices, dtype=float)
    triangles = np.asarray(mesh.triangles, dtype=np.int64)
    edges = mesh.edges().astype(np.int64)
    existing = {tuple(e) for e in edges}
    shear = _unique_new(_shear_pairs(triangles), existing)
    existing |= {tuple(p) for p in shear}
    bend = _unique_new(_bend_pairs(positions, edges), existing)
    springs = np.concatenate([edges, shear, bend]).astype(np.int64)
    kinds = np.concatenate([np.full(len(edges), STRUCTURAL), np.full(len(shear), SHEAR), np.full(len(bend), BEND)])
    rest = np.linalg.norm(positions[springs[:, 1]] - positions[springs[:, 0]], axis=1)
    if np.any(rest <= 1e-9):
        raise ValueError(f"garment {mesh.name!r}: a spring has zero rest length (duplicate vertices)")

    areas = triangle_areas(positions, triangles)
    if np.any(areas <= 1e-12):
        raise ValueError(f"garment {mesh.name!r}: {int(np.sum(areas <= 1e-12))} degenerate triangle(s)")
    vertex_areas = np.zeros(len(positions))
    for corner in range(3):
        np.add.at(vertex_areas, triangles[:, corner], areas / 3.0)

    poses = attachment_rest_poses or {}
    shared = dict(mesh.shared_attachments)
    roles = tuple(dict.fromkeys([*mesh.attachments, *(second for second, _ in shared.values())]))

    def local_in(role: str, ids: np.ndarray) -> np.ndarray:
        p, q = poses.get(role, (np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0])))
        return transform_points(*inverse(np.asarray(p, float), np.asarray(q, float)), positions[ids])

    attached, frame_index, local, frame_index2, local2, weight2 = [], [], [], [], [], []
    for role, ids in mesh.attachments.items():
        ids = np.asarray(ids, dtype=np.int64)
        second, weight = shared.get(role, (role, 0.0))
        attached.append(ids)
        frame_index.append(np.full(len(ids), roles.index(role), dtype=np.int64))
        local.append(local_in(role, ids))
        frame_index2.append(np.full(len(ids), roles.index(second), dtype=np.int64))
        local2.append(local_in(second, ids))
        weight2.append(np.full(len(ids), float(weight)))

    def joined(parts, shape, dtype=float):
        return np.concatenate(parts) if parts else np.zeros(shape, dtype)

    attached_ids = joined(attached, 0, np.int64)
    tether_anchors, tether_lengths = nearest_along_edges(positions, edges, attached_ids)
    tether_lengths[tether_anchors < 0] = 0.0

    return ClothModel(
        name=mesh.name,
        rest_positions=positions,
        triangles=triangles,
        edges=edges,
        springs=springs,
        spring_kinds=kinds.astype(np.int64),
        rest_lengths=rest,
        vertex_areas=vertex_areas,
        attached=attached_ids,
        attachment_frames=roles,
        attachment_frame_index=joined(frame_index, 0, np.int64),
        attachment_local=joined(local, (0, 3)),
        attachment_frame_index2=joined(frame_index2, 0, np.int64),
        attachment_local2=joined(local2, (0, 3)),
        attachment_weight2=joined(weight2, 0),
        rings=dict(mesh.rings),
        limb_tubes=dict(mesh.limb_tubes),
        tether_anchors=tether_anchors,
        tether_lengths=tether_lengths,
    )


def stretch_groups(spring_kinds: np.ndarray) -> dict[str, np.ndarray]:
    """``{"structural": indices, "shear": indices}`` of a model's springs (``ClothModel.spring_kinds``), which come
    first, so the indices are into its correction springs too."""
    return {name: np.flatnonzero(spring_kinds == kind) for name, kind in (("structural", STRUCTURAL), ("shear", SHEAR))}


def stretch_figures(stretches: np.ndarray, groups: dict[str, np.ndarray]) -> dict[str, tuple[float, float]]:
    """Issue 11's target (d) figures, ``{name: (p99, max)}`` of length / rest length per group of
    ``stretch_groups`` (0, 0 for an empty group), from the springs' length / rest length ``stretches``: the
    metric's (``quality``) and the frame retries' (``GarmentSolver._damage``)."""
    figures = {}
    for name, index in groups.items():
        values = stretches[index]
        figures[name] = ((float(np.percentile(values, STRETCH_PERCENTILE)), float(values.max())) if len(values)
                         else (0.0, 0.0))
    return figures
