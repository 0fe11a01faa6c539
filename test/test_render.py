"""The offscreen rasteriser: triangles land where projected, the z-buffer keeps the nearer surface,
and a snapshot shows the character where its joints project, centred on its pelvis wherever it is."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID, SPHERE
from garment_sim_ros.render import Camera, framing_camera, local_volume_mesh, rasterize_triangles

WHITE = 255.0
CC_CLIP = Path(__file__).parent / "data" / "cc_cmu_07_01_walk.bvh"  # Character Creator rig


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
    assert path.name == "volumes_walk.png"
    picture = np.asarray(Image.open(path).convert("RGB")).astype(int)
    assert picture.shape == (180, 120, 3)
    source = procedural_source("walk")
    pose = source.pose(1.0)
    camera = character_camera(pose, source.joint_map, "front", 120, 180)  # the snapshot's camera
    floor = picture[175, 3]
    for joint in ("chest", "pelvis", "left_knee", "head"):
        x, y, _ = camera.project(pose.frame(joint)[0][None])[0]
        pixel = picture[int(y), int(x)]
        assert np.abs(pixel - 255).max() > 20 and np.abs(pixel - floor).max() > 10, f"{joint} not drawn at {x}, {y}"
    assert np.all(picture[30, :8] == 255) and np.all(picture[30, -8:] == 255)  # sky beside the head


def body_pixels(picture: np.ndarray) -> np.ndarray:
    """Where the body volumes are drawn: the only coloured pixels (sky, floor, shadow and bones are grey)."""
    return np.ptp(picture, axis=2) > 15


def test_the_picture_follows_the_character_wherever_it_stands():
    # the camera is on the pelvis and the floor at the lowest foot: moved 40 m away and 3 m up,
    # the character is drawn as it is at the origin
    from garment_sim_ros.body.fitting import fit_body
    from garment_sim_ros.body.skeleton import SkeletonPose
    from garment_sim_ros.body.sources import procedural_source
    from garment_sim_ros.render import render_character

    source = procedural_source("walk")
    body = fit_body(source.rest_pose, source.joint_map)
    pose = source.pose(0.7)
    moved = SkeletonPose(pose.skeleton, pose.positions + [30.0, -25.0, 3.0], pose.rotations)
    here, there = (render_character(p, body.volumes, source.joint_map, width=90, height=135, skeleton=True)
                   for p in (pose, moved))
    assert body_pixels(here).sum() > 1000
    assert np.mean(np.abs(here.astype(int) - there) > 8) < 0.002


def test_snapshot_of_a_character_creator_clip_centres_the_pelvis(tmp_path):
    # joint 0 of this rig is a static root on the floor; the character walks 3 m from the origin
    from PIL import Image

    from garment_sim_ros.body.sources import bvh_source
    from garment_sim_ros.commands.snapshot import snapshot
    from garment_sim_ros.render import character_camera

    width, height = 150, 225
    path = snapshot(tmp_path, None, time_s=2.0, view="three-quarter", size=(width, height), bvh=str(CC_CLIP))
    assert path.name == "volumes_cc_cmu_07_01_walk.png"
    body = body_pixels(np.asarray(Image.open(path).convert("RGB")).astype(int))
    rows, cols = np.nonzero(body)
    assert len(rows) > 0.03 * width * height
    # inside the picture: clear of the sides and the top (the label's band included)
    assert cols.min() > 4 and cols.max() < width - 5 and rows.min() > 0.05 * height and rows.max() < height - 5
    # the pelvis on the centre line: the hips' row of body pixels is centred, the figure spans most of the height
    pelvis_row = rows.min() + int(0.45 * (rows.max() - rows.min()))
    hips = np.nonzero(body[pelvis_row])[0]
    assert abs(0.5 * (hips.min() + hips.max()) - 0.5 * width) < 0.08 * width
    assert rows.max() - rows.min() > 0.6 * height
    source = bvh_source(str(CC_CLIP), loop=False)
    pose = source.pose(2.0)
    pelvis = pose.frame(source.joint_map["pelvis"])[0]
    assert pelvis[0] > 2.5  # far from the origin
    x, y, _ = character_camera(pose, source.joint_map, "three-quarter", width, height).project(pelvis[None])[0]
    assert abs(x - 0.5 * width) < 0.5 and abs(y - 0.5 * height) < 0.15 * height and body[int(y), int(x)]


def test_canonical_view_shows_body_and_skeleton(tmp_path):
    from PIL import Image

    from garment_sim_ros.commands.snapshot import snapshot

    path = snapshot(tmp_path, None, time_s=0.0, view="front", size=(120, 180), bvh=str(CC_CLIP), canonical=True)
    assert path.name == "canonical_cc_cmu_07_01_walk.png"
    picture = np.asarray(Image.open(path).convert("RGB")).astype(int)
    body = body_pixels(picture)
    rows, cols = np.nonzero(body)
    assert len(rows) > 0.03 * body.size
    assert cols.min() > 2 and cols.max() < 117 and rows.min() > 9 and rows.max() < 177
    dark = picture.max(axis=2) < 90  # the bones (the label is above the figure)
    assert dark[rows.min():].sum() > 20


def test_pressed_volumes_are_drawn_flat_where_they_meet_and_no_longer_overlap():
    # the CC walk at 1.9 s: a forearm on the hip and the thighs pass; the solver keeps the cloth out of the
    # volumes cut by their contact planes, and the picture draws that body: each volume of a pressed pair lies
    # outside the other as pressed, where uncut they overlap by centimetres
    from garment_sim_ros.body.aiming import volume_poses
    from garment_sim_ros.body.fitting import fit_body
    from garment_sim_ros.body.sources import bvh_source
    from garment_sim_ros.collision.contact_planes import pressable_pairs
    from garment_sim_ros.collision.geometry import penetration_depth, to_local
    from garment_sim_ros.render import contact_planes_at, volume_meshes
    from garment_sim_ros.transforms import quat_to_matrix

    source = bvh_source(str(Path(__file__).parent / "data" / "cc_cmu_07_01_walk.bvh"), loop=False)
    volumes = fit_body(source.rest_pose, source.joint_map, motion=source.fit_poses()).volumes
    pose = source.pose(1.9)
    press_with = (0.015, 0.006, 0.02)
    centers, rotations = volume_poses(volumes, pose)
    planes = contact_planes_at(volumes, centers, rotations, *press_with)
    matrices = quat_to_matrix(rotations)
    kinds, radii, cuts = volumes.kinds.astype(np.int64), volumes.radii.astype(float), volumes.cuts.astype(float)

    def deepest(meshes, a, b, cut_planes):
        local = [to_local(centers, matrices, b, *p) for p in meshes[a][0]]
        return max(penetration_depth(kinds[b], radii, cuts, cut_planes, b, *p) for p in local)

    pressed, whole = volume_meshes(volumes, pose, press_with), volume_meshes(volumes, pose)
    uncut = np.zeros_like(planes)
    uncut[:, :, 3] = np.inf
    meeting = [(a, b) for a, b in pressable_pairs(volumes) if np.isfinite(planes[a, 0, 3]) and any(
        np.isfinite(planes[b, :, 3]))]
    overlaps = {(a, b): deepest(whole, a, b, uncut) for a, b in meeting}
    assert max(overlaps.values()) > 0.01, overlaps  # the pose presses volumes together
    for (a, b), overlap in overlaps.items():
        assert deepest(pressed, a, b, planes) <= 1e-9 and deepest(pressed, b, a, planes) <= 1e-9, (a, b, overlap)
