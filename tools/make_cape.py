#!/usr/bin/env python3
"""Generate the example garment config/garments/cape.obj and its spec cape.yaml.

A short cape: a closed collar ring round the neck base, then a panel from the shoulders down the back to
the hips, covering the back 75 degrees of the way round (open over 280 degrees at the front: the arms swing
outside it, and its top corners lie on the shoulder blades, not over the upper arms). It is cut on the
procedural character (1.75 m) in the canonical pose, in its root frame (x forward, y left, z up, m): a
smooth flared outline, each vertex then moved out along its horizontal ray from the neck axis until it
clears the body's fitted volumes (the 15-volume body) by ``CLEARANCE_M``, so the cape starts off the
shoulders and arms. The spec fits the collar's top loop to the wearer's neck (scaled across to the neck,
heights by the stature ratio) and hangs it on the chest. Run from the repository root:

    PYTHONPATH=$PWD python tools/make_cape.py        # writes config/garments/cape.obj and cape.yaml
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

AROUND = 48  # vertices round the collar
# the front opening, centred on +x. At 240 (the back third) the panel's top corners lay over the upper arms,
# which pinched its sides against the chest (nine clips 3 s: stretch (d) 6 of 9, every target 5; at 280: 7, 7)
OPEN_DEG = 280.0
CLEARANCE_M = 0.02  # each vertex this far off the volumes (the collision epsilon is 3 mm)
HEM_BELOW_NECK = 0.55  # hem this many metres below the collar on the 1.75 m body (the hips)
PANEL_LEVELS = 16  # levels of the panel below the collar, 2 cm then every 3.5 cm down to the hem
# the panel's outline before clearing the body: (depth below the collar m, half depth x, half width y)
OUTLINE = [(0.0, 0.09, 0.09), (0.03, 0.15, 0.22), (0.10, 0.19, 0.29), (0.30, 0.21, 0.32), (HEM_BELOW_NECK, 0.27, 0.40)]
SPEC = """\
# A short cape down the back: the example garment. Generated with its mesh by tools/make_cape.py.
# Keys: README, "Your own garments".
name: cape
mesh: cape.obj
units: m
up_axis: z
placement: {{mode: fit, anchor: neck, reference_height: {height:.3f}}}  # the collar on the wearer's neck
attach:
  - role: chest
    vertices: {{loop: top}}              # the collar rides on the chest,
    falloff: 0.04                      # and the collar's lower ring within 4 cm of it
material: cotton_shirting
layer: 1
detailed_body: true                    # neck and forearm volumes under the cape
"""


def _cleared(points: np.ndarray, centre: np.ndarray, depth_at) -> np.ndarray:
    """Each point moved out along its horizontal ray from ``centre`` until ``depth_at`` (metres inside the
    volumes, of points grown by the clearance in every direction) is zero."""
    out = points.copy()
    for _ in range(200):  # 5 mm steps: at most a metre
        inside = depth_at(out) > 0.0
        if not inside.any():
            break
        ray = out[inside, :2] - centre[:2]
        out[inside, :2] += 0.005 * ray / np.linalg.norm(ray, axis=1, keepdims=True)
    return out


def cape_mesh():
    """(vertices (N, 3) m, triangles (T, 3), the body's stature m), wound counter-clockwise from outside."""
    from garment_sim_ros.body.fitting import fit_body
    from garment_sim_ros.body.root import root_frame
    from garment_sim_ros.body.sources import procedural_source
    from garment_sim_ros.cloth.spec import FIT_EASE_M  # the collar's top loop: this far above the neck base
    from garment_sim_ros.collision.collider import Collider
    from garment_sim_ros.transforms import compose, inverse, yaw_quat

    source = procedural_source("walk")
    body = fit_body(source.rest_pose, source.joint_map, detailed=True)
    m = body.measurements
    to_root = inverse(*(lambda p, yaw: (p, yaw_quat(yaw)))(*root_frame(source.rest_pose, source.joint_map)))
    frames = [compose(*to_root, *source.rest_pose.frame(f)) for f in body.volumes.frames]
    poses = body.volumes.world_poses(np.array([p for p, _ in frames]), np.array([q for _, q in frames]))

    def depth_at(points):
        collider = Collider(body.volumes, len(points))
        collider.begin_frame(*poses, *poses)
        # grown by the clearance: a point is "inside" when any point CLEARANCE_M around it is
        offsets = CLEARANCE_M * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
        return np.max([collider.penetration_depths(np.ascontiguousarray(points + o)) for o in offsets], axis=0)

    centre = np.array([m.chest_x, 0.0, m.neck_z])
    top_z = m.neck_z + 0.004  # the collar's foot, just above the trunk's top
    angles = 2.0 * np.pi * np.arange(AROUND) / AROUND
    half_open = np.radians(OPEN_DEG) / 2.0
    columns = np.flatnonzero((angles >= half_open) & (angles <= 2.0 * np.pi - half_open))

    def ring(z, rx, ry, which):
        a = angles[which]
        return np.stack([m.chest_x + rx * np.cos(a), ry * np.sin(a), np.full(len(a), z)], axis=1)

    neck = m.neck_radius + FIT_EASE_M
    collar = [ring(m.neck_z + FIT_EASE_M, neck, neck, np.arange(AROUND)),
              ring(top_z, neck + 0.012, neck + 0.012, np.arange(AROUND))]
    # rows evenly spaced: stretch is a spring's length over its rest length, so rows cut finer under the collar
    # (geometric steps, 5 mm there, 11 cm at the hem) took the panel's whole sag in their short springs
    # (structural p99 1.09 on the Xia strut, 1.02 with even rows: README, "Your own garments")
    drops = np.concatenate([[0.0], np.linspace(0.02, HEM_BELOW_NECK, PANEL_LEVELS)])
    panel = [ring(top_z - d, *(np.interp(d, [o[0] for o in OUTLINE], [o[k] for o in OUTLINE]) for k in (1, 2)),
                  columns) for d in drops[1:]]
    vertices = np.concatenate(collar + panel)
    vertices[2 * AROUND:] = _cleared(vertices[2 * AROUND:], centre, depth_at)

    triangles = []
    top, bottom = np.arange(AROUND), AROUND + np.arange(AROUND)
    for j in range(AROUND):  # the closed collar band
        a, b, c, d = top[j], top[(j + 1) % AROUND], bottom[j], bottom[(j + 1) % AROUND]
        triangles += [(a, c, d), (a, d, b)]
    rows = [bottom[columns]] + [2 * AROUND + k * len(columns) + np.arange(len(columns)) for k in range(len(panel))]
    for upper, lower in zip(rows[:-1], rows[1:]):  # the open panel, strips between columns
        for j in range(len(columns) - 1):
            a, b, c, d = upper[j], upper[j + 1], lower[j], lower[j + 1]
            triangles += [(a, c, d), (a, d, b)] if j % 2 == 0 else [(a, c, b), (b, c, d)]
    return vertices, np.array(triangles, dtype=np.int64), m.height


def main(folder: Path) -> int:
    import trimesh

    vertices, triangles, height = cape_mesh()
    mesh = trimesh.Trimesh(vertices, triangles, process=False)
    obj = trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False,
                                          header="cape: generated by tools/make_cape.py")
    (folder / "cape.obj").write_text(obj)
    (folder / "cape.yaml").write_text(SPEC.format(height=height))
    print(f"wrote {folder}/cape.obj ({len(vertices)} vertices, {len(triangles)} triangles) and cape.yaml")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else
                  Path(__file__).resolve().parents[1] / "config" / "garments"))
