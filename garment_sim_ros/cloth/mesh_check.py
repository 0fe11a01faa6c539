"""What a garment mesh must be before it is simulated, and a clear refusal when it is not.

A garment is an open or closed two-manifold surface: every edge belongs to one triangle (a boundary:
a hem, a waistband) or two (interior), no triangle is degenerate or repeated, neighbouring triangles
are wound the same way (each interior edge is walked once each way), every vertex is used, and the
whole is of human-garment size in metres. ``check_mesh`` raises ``GarmentMeshError`` naming the
first fault, how many there are, and the fix; ``boundary_loops`` gives the boundary as closed loops
(the loops an attachment can name: ``top``, ``bottom``, ``waist``, ``neck``).
"""

from __future__ import annotations

import numpy as np

# A garment taller or wider than this, or smaller than the smallest, is in the wrong units (m).
MAX_GARMENT_SIZE_M = 3.0
MIN_GARMENT_SIZE_M = 0.05
# A triangle whose area is below this fraction of the mean edge length squared is degenerate.
DEGENERATE_AREA_RATIO = 1e-6  # above float32 rounding of a file's coordinates
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}  # a spec's units: metres per number in the file
_HINT_ORDER = ("cm", "mm", "in", "m")  # the first that gives a garment's size is suggested


class GarmentMeshError(ValueError):
    """A garment mesh was refused; the message names the garment, the fault and the fix."""


def directed_edges(triangles: np.ndarray) -> np.ndarray:
    """(3T, 2) the triangles' edges in winding order: a->b, b->c, c->a."""
    t = np.asarray(triangles, dtype=np.int64)
    return np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])


def _size_hint(as_read: float) -> str:
    """What units would make a garment whose file says ``as_read`` across a garment's size."""
    for unit in _HINT_ORDER:
        metres = UNITS[unit]
        if MIN_GARMENT_SIZE_M <= as_read * metres <= MAX_GARMENT_SIZE_M:
            return f"The file's numbers read as {unit} give {as_read * metres:.3g} m (set units: {unit})"
    return "No unit makes it a garment's size: check the file"


def check_mesh(vertices: np.ndarray, triangles: np.ndarray, where: str, units: str = "m") -> None:
    """Refuse a mesh that cannot be simulated as a garment (``GarmentMeshError``); ``where`` names it.

    ``vertices`` (N, 3) metres, ``triangles`` (T, 3) indices. ``units`` is what the spec said, for the
    hint when the size is absurd."""
    x = np.asarray(vertices, dtype=float)
    t = np.asarray(triangles, dtype=np.int64)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 3 or not np.all(np.isfinite(x)):
        raise GarmentMeshError(f"{where}: need at least 3 finite vertices (N, 3), got shape {x.shape}")
    if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0:
        raise GarmentMeshError(f"{where}: need at least one triangle (T, 3), got shape {t.shape}")
    if t.min() < 0 or t.max() >= len(x):
        raise GarmentMeshError(f"{where}: triangle indices must be in [0, {len(x) - 1}], got {t.min()}..{t.max()}")

    extent = float(np.max(x.max(axis=0) - x.min(axis=0)))
    if not MIN_GARMENT_SIZE_M <= extent <= MAX_GARMENT_SIZE_M:
        raise GarmentMeshError(
            f"{where}: the garment is {extent:.3g} m across (units: {units}), outside "
            f"[{MIN_GARMENT_SIZE_M}, {MAX_GARMENT_SIZE_M}] m: wrong units? "
            f"{_size_hint(extent / UNITS.get(units, 1.0))}")

    repeated = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    p = x[t]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    edge_length = np.linalg.norm(x[directed_edges(t)[:, 1]] - x[directed_edges(t)[:, 0]], axis=1)
    degenerate = repeated | (area <= DEGENERATE_AREA_RATIO * np.mean(edge_length) ** 2)
    if degenerate.any():
        first = int(np.flatnonzero(degenerate)[0])
        raise GarmentMeshError(
            f"{where}: {int(degenerate.sum())} degenerate triangle(s) (zero area or a repeated vertex), first "
            f"#{first} {t[first].tolist()}: remove them (Blender: Mesh > Clean Up > Degenerate Dissolve)")

    as_sets = np.sort(t, axis=1)
    _, first_of, counts = np.unique(as_sets, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        dup = as_sets[first_of[counts > 1][0]]
        raise GarmentMeshError(
            f"{where}: {int(np.sum(counts[counts > 1] - 1))} duplicate triangle(s) (the same three vertices), first "
            f"{dup.tolist()}: remove doubles (Blender: Mesh > Clean Up > Merge by Distance)")

    directed = directed_edges(t)
    undirected = np.sort(directed, axis=1)
    keys, per_edge = np.unique(undirected, axis=0, return_counts=True)
    if np.any(per_edge > 2):
        bad = keys[per_edge > 2]
        raise GarmentMeshError(
            f"{where}: not manifold: {len(bad)} edge(s) shared by more than two triangles, first between vertices "
            f"{bad[0].tolist()}: a cloth surface has at most two triangles on an edge (split the seam)")
    _, walked = np.unique(directed, axis=0, return_counts=True)
    if np.any(walked > 1):
        bad = np.unique(directed, axis=0)[walked > 1]
        raise GarmentMeshError(
            f"{where}: inconsistent winding: {len(bad)} edge(s) walked the same way by both their triangles, first "
            f"{bad[0].tolist()}: make the normals consistent (Blender: Mesh > Normals > Recalculate Outside)")

    unused = np.setdiff1d(np.arange(len(x)), t.ravel())
    if len(unused):
        raise GarmentMeshError(f"{where}: {len(unused)} vertex/vertices in no triangle, first #{int(unused[0])}: "
                               "remove loose vertices (Blender: Mesh > Clean Up > Delete Loose)")


def boundary_loops(triangles: np.ndarray) -> list[np.ndarray]:
    """The mesh's boundary as closed vertex loops, each in the triangles' winding order.

    A boundary edge is walked by one triangle only; on a consistently wound mesh the boundary edges
    leave every boundary vertex once, so following them closes each loop."""
    directed = directed_edges(triangles)
    undirected = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(undirected, axis=0, return_inverse=True, return_counts=True)
    boundary = directed[counts[inverse.ravel()] == 1]
    following = {int(a): int(b) for a, b in boundary}
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen and v in following:
            seen.add(v)
            loop.append(v)
            v = following[v]
        loops.append(np.array(loop, dtype=np.int64))
    return loops
