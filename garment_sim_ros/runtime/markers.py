"""The node's MarkerArray content, built from numpy arrays (ROS-free).

- a garment: one ``TRIANGLE_LIST`` marker whose points are its triangles' corners, three per
  triangle in the mesh's order, each with its vertex's shaded colour (``shading.shade``);
- the body volumes: one ``SPHERE`` marker per volume, posed and scaled to the ellipsoid's
  diameters (``rerun_log.volume_ellipsoids``, so markers and Rerun show the same shapes).

The meshes and volumes come in the shapes of ``rerun_log.frame_payload``; the result is
``MarkerData`` for ``marker_cdr.serialize_marker_array``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numba import njit

from ..shading import BODY_RGB
from .marker_cdr import ADD, DELETEALL, SPHERE, TRIANGLE_LIST, MarkerData

VOLUME_ALPHA = 0.35  # see-through, so the garment inside a wide volume stays visible


def triangle_corners(values: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Per-vertex ``values`` (N, K) expanded to the corners of ``triangles`` (T, 3): (3 T, K)."""
    return values[np.asarray(triangles).reshape(-1)]


def rgba(colors_uint8: np.ndarray, alpha: float = 1.0) -> np.ndarray:
    """Colours (N, 3) in 0..255 as float32 RGBA in 0..1."""
    colors = np.empty((len(colors_uint8), 4), dtype=np.float32)
    colors[:, :3] = np.asarray(colors_uint8, dtype=np.float32) / 255.0
    colors[:, 3] = alpha
    return colors


def garment_marker(mesh: tuple, namespace: str, frame_id: str, stamp: tuple[int, int]) -> MarkerData:
    """The TRIANGLE_LIST marker of one ``(name, positions, normals, triangles, colors)`` mesh on
    ``<namespace>/<name>``."""
    name, positions, _normals, triangles, colors = mesh
    triangles = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1, 3)
    points = np.empty((3 * len(triangles), 3))
    corner_colors = np.empty((3 * len(triangles), 4), dtype=np.float32)
    _expand_corners(np.ascontiguousarray(positions, dtype=float), np.ascontiguousarray(colors, dtype=np.uint8),
                    triangles, points, corner_colors)
    return MarkerData(ns=f"{namespace}/{name}", id=0, type=TRIANGLE_LIST, action=ADD, frame_id=frame_id,
                      stamp=stamp, points=points, colors=corner_colors)


@njit(cache=True)
def _expand_corners(positions, colors, triangles, points, corner_colors):
    """``triangle_corners`` of the positions and of ``rgba(colors)`` in one pass (the publish hot path)."""
    k = 0
    for t in range(triangles.shape[0]):
        for c in range(3):
            v = triangles[t, c]
            points[k, 0] = positions[v, 0]
            points[k, 1] = positions[v, 1]
            points[k, 2] = positions[v, 2]
            corner_colors[k, 0] = colors[v, 0] / np.float32(255.0)
            corner_colors[k, 1] = colors[v, 1] / np.float32(255.0)
            corner_colors[k, 2] = colors[v, 2] / np.float32(255.0)
            corner_colors[k, 3] = 1.0
            k += 1


def volume_markers(volumes: tuple, namespace: str, frame_id: str, stamp: tuple[int, int],
                   rgb: Sequence[int] = BODY_RGB) -> list[MarkerData]:
    """SPHERE markers on ``<namespace>/volumes`` (ids 0..V-1) from ``(centers, rotations, half_sizes)``."""
    centers, rotations, half_sizes = volumes
    color = np.append(np.asarray(rgb, float) / 255.0, VOLUME_ALPHA)
    return [MarkerData(ns=f"{namespace}/volumes", id=i, type=SPHERE, action=ADD, frame_id=frame_id, stamp=stamp,
                       position=centers[i], orientation=rotations[i], scale=2.0 * np.asarray(half_sizes[i]),
                       color=color)
            for i in range(len(centers))]


def delete_all(frame_id: str, stamp: tuple[int, int]) -> MarkerData:
    """A DELETEALL: RViz drops every marker of this publisher before the ones after it in the array."""
    return MarkerData(ns="", id=0, type=0, action=DELETEALL, frame_id=frame_id, stamp=stamp)


def frame_markers(payload: dict, namespace: str, frame_id: str, stamp: tuple[int, int],
                  with_volumes: bool, clear: bool = False) -> list[MarkerData]:
    """Every marker of one frame: the garments of ``payload["garments"]``, then (optionally) the volumes;
    first a DELETEALL when ``clear`` (the character was dressed again, the garments or namespaces changed:
    the old markers go)."""
    markers = [delete_all(frame_id, stamp)] if clear else []
    markers += [garment_marker(mesh, namespace, frame_id, stamp) for mesh in payload["garments"]]
    if with_volumes:
        markers += volume_markers(payload["volumes"], namespace, frame_id, stamp)
    return markers
