"""The offscreen rasteriser: triangles land where projected, the z-buffer keeps the nearer surface,
and a snapshot of the standard scene shows the character where its joints project."""

from __future__ import annotations

import numpy as np
import pytest

from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID, SPHERE
from garment_sim_ros.render import Camera, framing_camera, local_volume_mesh, rasterize_triangles

WHITE = 255.0


def blank(height=64, width=64):
    return np.full((height, width), np.inf), np.full((height, width, 3), WHITE)


def test_triangle_fills_exactly_its_inside():
    depth, image = blank()
    screen = np.array([[10.0, 10.0, 1.0], [50.0, 10.0, 1.0], [10.0, 50.0, 1.0]])  # x, y, depth
    colors = np.tile([255.0, 0.0, 0.0], (3, 1))
    rasterize_triangles(screen, np.array([[0, 1, 2]]), colors, 1.0, depth, image)
    rows, cols = np.mgrid[0:64, 0:64] + 0.5
    inside = (cols >= 10) & (rows >= 10) & (cols + rows <= 60)
    drawn = np.all(np.abs(image - [255.0, 0.0, 0.0]) < 1e-9, axis=2)
    # every pixel centre strictly inside is drawn, none outside; the boundary may go either way
    strictly_inside = (cols > 10.01) & (rows > 10.01) & (cols + rows < 59.99)
    assert drawn[strictly_inside].all() and not drawn[~inside].any()
    assert np.all(image[~drawn] == WHITE) and np.allclose(depth[drawn], 1.0)


def test_gouraud_interpolates_vertex_colours():
    depth, image = blank()
    screen = np.array([[0.0, 0.0, 1.0], [64.0, 0.0, 1.0], [0.0, 64.0, 1.0]])
    colors = np.array([[0.0, 0.0, 0.0], [200.0, 0.0, 0.0], [0.0, 0.0, 100.0]])
    rasterize_triangles(screen, np.array([[0, 1, 2]]), colors, 1.0, depth, image)
    # pixel centre (x=16.5, y=8.5): barycentric weights of b = x / 64, of c = y / 64
    assert image[8, 16] == pytest.approx([200.0 * 16.5 / 64, 0.0, 100.0 * 8.5 / 64])


@pytest.mark.parametrize("near_first", [True, False])
def test_z_buffer_keeps_the_nearer_triangle_whatever_the_order(near_first):
    depth, image = blank()
    square = np.array([[8.0, 8.0], [56.0, 8.0], [56.0, 56.0], [8.0, 56.0]])
    near = (np.column_stack([square, np.full(4, 2.0)]), np.tile([0.0, 255.0, 0.0], (4, 1)))
    far = (np.column_stack([square + 4.0, np.full(4, 3.0)]), np.tile([0.0, 0.0, 255.0], (4, 1)))
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    for screen, colors in ([near, far] if near_first else [far, near]):
        rasterize_triangles(screen, quad, colors, 1.0, depth, image)
    assert list(image[30, 30]) == [0.0, 255.0, 0.0]  # both cover it: the near one shows
    assert list(image[58, 58]) == [0.0, 0.0, 255.0]  # only the far one covers it
    assert depth[30, 30] == 2.0


def test_translucent_triangle_blends_and_leaves_depth():
    depth, image = blank()
    screen = np.array([[0.0, 0.0, 1.0], [64.0, 0.0, 1.0], [0.0, 64.0, 1.0]])
    rasterize_triangles(screen, np.array([[0, 1, 2]]), np.zeros((3, 3)), 0.25, depth, image)
    assert image[5, 5] == pytest.approx([0.75 * WHITE] * 3)
    assert np.isinf(depth[5, 5])


def test_camera_projects_like_a_pinhole():
    # looking from the front (+x) at the origin: the character's left (+y) is on the image's right
    camera = Camera(eye=(4.0, 0.0, 0.0), target=(0.0, 0.0, 0.0), width=200, height=100, fov_deg=90.0)
    screen = camera.project(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [5.0, 0.0, 0.0]]))
    focal = 50.0  # half the height / tan(45 deg)
    assert screen[0] == pytest.approx([100.0, 50.0, 4.0])
    assert screen[1] == pytest.approx([100.0 + focal / 4.0, 50.0, 4.0])
    assert screen[2] == pytest.approx([100.0, 50.0 - focal / 4.0, 4.0])
    assert np.isnan(screen[3, 2])  # behind the camera
    with pytest.raises(ValueError, match="unknown view 'top'"):
        framing_camera("top", np.zeros(3), np.ones(3), 100, 100)


@pytest.mark.parametrize("kind, radii, cut, z_range", [
    (SPHERE, (0.1, 0.1, 0.1), (-np.inf, np.inf), (-0.1, 0.1)),
    (ELLIPSOID, (0.05, 0.08, 0.3), (-0.2, 0.25), (-0.2, 0.25)),
    (CAPSULE, (0.04, 0.02, 0.2), (-np.inf, np.inf), (-0.24, 0.22)),
])
def test_volume_meshes_lie_on_the_volume_surface(kind, radii, cut, z_range):
    positions, normals, triangles = local_volume_mesh(kind, radii, cut)
    assert positions[:, 2].min() == pytest.approx(z_range[0]) and positions[:, 2].max() == pytest.approx(z_range[1])
    assert triangles.min() >= 0 and triangles.max() < len(positions)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    if kind != CAPSULE:
        side = np.abs(np.abs(normals[:, 2]) - 1.0) > 1e-9  # not on a flat cap
        value = np.sum((positions[side] / radii) ** 2, axis=1)
        assert np.allclose(value, 1.0)


def test_snapshot_of_the_standard_scene_shows_the_character(tmp_path):
    from PIL import Image

    from garment_sim_ros.body.sources import procedural_source
    from garment_sim_ros.commands.snapshot import snapshot
    from garment_sim_ros.render import character_camera

    path = snapshot(tmp_path, None, time_s=1.0, view="front", size=(120, 180))
    picture = np.asarray(Image.open(path).convert("RGB")).astype(int)
    assert picture.shape == (180, 120, 3)
    pose = procedural_source("walk").pose(1.0)
    camera = character_camera(pose, "front", 120, 180)  # the snapshot's camera
    floor = picture[175, 3]
    for joint in ("chest", "pelvis", "left_knee", "head"):
        x, y, _ = camera.project(pose.frame(joint)[0][None])[0]
        pixel = picture[int(y), int(x)]
        assert np.abs(pixel - 255).max() > 20 and np.abs(pixel - floor).max() > 10, f"{joint} not drawn at {x}, {y}"
    assert np.all(picture[30, :8] == 255) and np.all(picture[30, -8:] == 255)  # sky beside the head
