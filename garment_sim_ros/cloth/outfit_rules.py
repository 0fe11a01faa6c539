"""What an outfit's outer garment owes the body and the garment under it beyond the layers' separation.

- ``carried_like``: an outer garment's attachment lying on an inner one's of the same role (a skirt's waistband on
  the trousers') is skinned as that one is, so the two bands do not part;
- ``undo_bone_crossings``: the body comes first: a triangle the layers' pushes put across a limb bone goes back.

Numba kernels over flat arrays where they run every frame; root frame, metres.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np
from numba import njit

from ..collision.crossing import segment_crosses_triangle, segment_misses_triangle_box
from .garments import GarmentMesh

SAME_BAND_M = 0.02  # m: an outer garment's attachment this close to an inner one's is carried as that one is
BONE_PASSES = 4  # undo_bone_crossings' passes (a corner put back can cross a neighbour)
BACK_STEPS = 4  # undo_bone_crossings puts a triangle back by quarters of the way, the least that clears the bone


@njit(cache=True)
def undo_bone_crossings(x, v, x_kept, v_kept, triangles, starts, ends, passes):
    """The body comes first: a triangle (T, 3) of ``x`` (N, 3) that a limb bone (``starts``, ``ends``: (B, 3))
    crosses and did not cross at ``x_kept`` (the positions the body's handling left) has its corners put back
    towards there, by the least quarter of the way that clears the bone (velocities ``v`` from ``v_kept``).
    Putting a corner back can cross a neighbour that shares it, so up to ``passes`` passes, until one puts
    nothing back (all back: nothing crosses that did not). Returns the corners moved."""
    restored = 0
    saved = np.empty((3, 3))  # a triangle's corners before they go back
    for _ in range(passes):
        moved = 0
        for k in range(starts.shape[0]):
            px, py, pz = starts[k, 0], starts[k, 1], starts[k, 2]
            qx, qy, qz = ends[k, 0], ends[k, 1], ends[k, 2]
            for t in range(triangles.shape[0]):
                a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
                if segment_misses_triangle_box(x, a, b, c, px, py, pz, qx, qy, qz):
                    continue
                if not segment_crosses_triangle(px, py, pz, qx - px, qy - py, qz - pz, x, a, b, c)[0]:
                    continue
                if segment_crosses_triangle(px, py, pz, qx - px, qy - py, qz - pz, x_kept, a, b, c)[0]:
                    continue  # the body's handling left it crossed: not the layers' doing
                # back by the least of BACK_STEPS equal steps that clears the bone (all the way clears it): a
                # corner put all the way back while its neighbours stay pushed stretches their springs
                for j in range(3):
                    for k3 in range(3):
                        saved[j, k3] = x[triangles[t, j], k3]
                for step in range(1, BACK_STEPS + 1):
                    fraction = step / BACK_STEPS
                    for j in range(3):
                        i = triangles[t, j]
                        for k3 in range(3):
                            x[i, k3] = saved[j, k3] + fraction * (x_kept[i, k3] - saved[j, k3])
                    if not segment_crosses_triangle(px, py, pz, qx - px, qy - py, qz - pz, x, a, b, c)[0]:
                        break
                for j in range(3):
                    i = triangles[t, j]
                    if x[i, 0] != saved[j, 0] or x[i, 1] != saved[j, 1] or x[i, 2] != saved[j, 2]:
                        v[i, :] = v_kept[i, :]
                        moved += 1
        restored += moved
        if moved == 0:
            break
    return restored


def carried_like(mesh: GarmentMesh, inner_meshes: Sequence[GarmentMesh]) -> GarmentMesh:
    """``mesh`` with an attachment that lies on an inner garment's attachment of the same role (a skirt's
    waistband on the trousers', every vertex within ``SAME_BAND_M`` of it) skinned as that one is: two bands
    carried differently would part, and the outer one, whose points cannot be pushed, would pass through."""
    shared = dict(mesh.shared_attachments)
    for role, ids in mesh.attachments.items():
        for inner in inner_meshes:
            if role not in inner.attachments:
                continue
            band = inner.vertices[inner.attachments[role]]
            gaps = np.linalg.norm(mesh.vertices[ids][:, None, :] - band[None, :, :], axis=2).min(axis=1)
            if np.all(gaps <= SAME_BAND_M):
                shared.pop(role, None)
                if role in inner.shared_attachments:
                    shared[role] = inner.shared_attachments[role]
                break
    return dataclasses.replace(mesh, shared_attachments=shared)
