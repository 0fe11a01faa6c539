"""Garment meshes from files (OBJ, PLY, STL, glTF/GLB), read with trimesh, in the project's frame.

``load_mesh_file`` returns the vertices in metres with z up, x forward and y left (REP-103), the
triangles, and what an attachment can select by: the file's vertex colours and vertex groups (a PLY
vertex property or a glTF custom attribute ``_NAME``, a vertex in the group where the value is
>= 0.5). Vertices at exactly the same position are merged (a UV seam or an STL's per-triangle corners
would otherwise split the cloth); ``file_to_mesh`` maps the file's vertex indices to the merged ones,
for index lists in a spec. ``decimate`` reduces a mesh to a vertex budget with fast-simplification
(what trimesh's simplifier calls), carrying colours, groups and index mappings through the collapses.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .mesh_check import UNITS, GarmentMeshError

# up_axis z: the file is in the project's frame (x forward, y left, z up). up_axis y: the glTF and
# Blender-export convention (+y up, +z forward, +x the model's left); rows are the file's x, y, z in ours.
UP_AXES = {
    "z": np.eye(3),
    "y": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
}
FORMATS = (".obj", ".ply", ".stl", ".glb", ".gltf")
_PLY_STANDARD = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha", "s", "t", "u", "v",
                 "texture_u", "texture_v"}


@dataclass(frozen=True)
class MeshFile:
    path: Path
    vertices: np.ndarray  # (N, 3) metres, project frame
    triangles: np.ndarray  # (T, 3) vertex indices
    colours: np.ndarray | None  # (N, 4) uint8 RGBA vertex colours, None when the file has none
    groups: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (N,) bool membership
    file_to_mesh: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (F,) file vertex -> vertex


def load_mesh_file(path: str | Path, units: str = "m", up_axis: str = "z", where: str | None = None) -> MeshFile:
    """The mesh in ``path`` in metres and the project's axes; ``GarmentMeshError`` naming ``where``
    (default: the file) when it cannot be read."""
    import trimesh

    path = Path(path)
    where = where or str(path)
    if path.suffix.lower() not in FORMATS:
        raise GarmentMeshError(f"{where}: {path.name}: unsupported mesh format; allowed: {', '.join(FORMATS)}")
    if not path.is_file():
        raise GarmentMeshError(f"{where}: mesh file {path} not found")
    try:
        mesh = trimesh.load(path, process=False, force="mesh")
    except Exception as err:  # trimesh raises many types for a broken file; name the file and its words
        raise GarmentMeshError(f"{where}: cannot read {path.name}: {err}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise GarmentMeshError(f"{where}: {path.name} holds no triangles")
    file_vertices = np.asarray(mesh.vertices, dtype=float)
    colours = np.asarray(mesh.visual.vertex_colors, dtype=np.uint8) if mesh.visual.kind == "vertex" else None
    groups = {name.lstrip("_"): np.asarray(value, float).reshape(len(file_vertices), -1)[:, 0] >= 0.5
              for name, value in mesh.vertex_attributes.items() if np.asarray(value).shape[:1] == (len(file_vertices),)}
    ply = mesh.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
    if ply is not None and ply.dtype.names:
        groups.update({name: np.asarray(ply[name], float).reshape(-1) >= 0.5
                       for name in ply.dtype.names if name not in _PLY_STANDARD and ply[name].ndim == 1})

    # Merge vertices at the same position, keeping the first occurrence's order (a clean file keeps its indices).
    _, first, inverse = np.unique(file_vertices, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    file_to_mesh = rank[inverse.ravel()]
    keep = first[order]
    vertices = file_vertices[keep] * UNITS[units] @ UP_AXES[up_axis]  # rows: the file's axes in ours
    return MeshFile(path, vertices, file_to_mesh[np.asarray(mesh.faces, dtype=np.int64)],
                    None if colours is None else colours[keep],
                    {name: _merged_membership(member, file_to_mesh, len(keep)) for name, member in groups.items()},
                    file_to_mesh)


def _merged_membership(member: np.ndarray, mapping: np.ndarray, count: int) -> np.ndarray:
    """A merged vertex is in a group when any file vertex merged into it is."""
    merged = np.zeros(count, dtype=bool)
    merged[mapping[member]] = True
    return merged


def decimate(mesh: MeshFile, max_vertices: int) -> MeshFile:
    """``mesh`` reduced to at most ``max_vertices`` vertices by quadric edge collapse (fast-simplification)."""
    import fast_simplification

    if len(mesh.vertices) <= max_vertices:
        return mesh
    target = 2 * max_vertices  # triangles: about twice the vertices on a garment-like surface
    for _ in range(8):
        _, _, collapses = fast_simplification.simplify(mesh.vertices, mesh.triangles, target_count=target,
                                                       return_collapses=True)
        vertices, triangles, mapping = fast_simplification.replay_simplification(
            mesh.vertices, mesh.triangles, collapses)
        if len(vertices) <= max_vertices:
            break
        target = int(target * max_vertices / len(vertices) * 0.97)
    mapping = np.asarray(mapping, dtype=np.int64)
    colours = None
    if mesh.colours is not None:  # a kept vertex keeps the colour of the first vertex collapsed into it
        colours = np.zeros((len(vertices), 4), np.uint8)
        colours[mapping[::-1]] = mesh.colours[::-1]
    groups = {name: _merged_membership(member, mapping, len(vertices)) for name, member in mesh.groups.items()}
    return replace(mesh, vertices=np.asarray(vertices, float), triangles=np.asarray(triangles, np.int64),
                   colours=colours, groups=groups, file_to_mesh=mapping[mesh.file_to_mesh])
