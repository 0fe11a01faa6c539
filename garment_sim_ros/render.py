"""A small offscreen software rasteriser for PNG pictures of a dressed character (ROS-free, no display).

Pinhole camera, numba z-buffer rasterisation of triangles with per-vertex colours (Gouraud),
depth-tested thick lines for the skeleton, optional alpha blending for see-through body volumes.
Draw opaque meshes first, then translucent ones (they blend over what is there, without writing
depth). Supersampled (``supersample`` x the size, box-filtered down) for smooth edges.

Screen space: pixel ``(row, col)`` covers ``x in [col, col + 1)``, ``y in [row, row + 1)``, sampled
at its centre; ``depth`` is the distance along the view axis (smaller is nearer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .body.aiming import volume_poses
from .collision.contact_planes import press, pressable_pairs
from .collision.volume_arrays import VolumeArrays
from .collision.volumes import CAPSULE, ELLIPSOID, SPHERE, VolumeSet
from .rerun_log import skeleton_segments
from .shading import BODY_RGB, DEFAULT_LIGHT_DIR, SKELETON_RGB, shade
from .transforms import quat_rotate, quat_to_matrix

FLOOR_GRAY = 232
SHADOW_GRAY = 200
SHADOW_LIFT_M = 0.002  # above the floor, so the depth test keeps the shadow
VIEWS = {  # direction from the character towards the camera (REP-103: the character faces +x)
    "front": (1.0, 0.0, 0.12),
    "side": (0.0, 1.0, 0.12),  # from the character's left
    "three-quarter": (1.0, 0.75, 0.3),
}


@dataclass(frozen=True)
class Camera:
    """A pinhole camera at ``eye`` looking at ``target``, ``up`` roughly up, vertical field of view
    ``fov_deg``, image ``width`` x ``height`` pixels."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    width: int
    height: int
    fov_deg: float = 30.0
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self):
        if not (isinstance(self.width, int) and isinstance(self.height, int) and self.width > 0 and self.height > 0):
            raise ValueError(f"Camera: width and height must be positive integers, got {self.width} x {self.height}")
        if not 1.0 <= self.fov_deg <= 150.0:
            raise ValueError(f"Camera: fov_deg must be in [1, 150], got {self.fov_deg}")
        forward = np.subtract(self.target, self.eye)
        if np.linalg.norm(forward) < 1e-9 or np.linalg.norm(np.cross(forward, self.up)) < 1e-9:
            raise ValueError("Camera: eye and target must differ and the view must not be parallel to up")

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit right, up and forward vectors of the image."""
        forward = np.subtract(self.target, self.eye).astype(float)
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, self.up)
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def project(self, points: np.ndarray) -> np.ndarray:
        """Screen coordinates (N, 3): x (columns), y (rows, down), depth along the view axis (m)."""
        right, up, forward = self.basis()
        relative = np.asarray(points, dtype=float) - np.asarray(self.eye, dtype=float)
        depth = relative @ forward
        focal = 0.5 * self.height / math.tan(math.radians(0.5 * self.fov_deg))
        safe = np.where(depth > 1e-6, depth, np.nan)  # behind the camera: not drawn
        x = 0.5 * self.width + focal * (relative @ right) / safe
        y = 0.5 * self.height - focal * (relative @ up) / safe
        return np.column_stack([x, y, safe])

    def scaled(self, factor: int) -> "Camera":
        return Camera(self.eye, self.target, self.width * factor, self.height * factor, self.fov_deg, self.up)


def framing_camera(view: str, low: np.ndarray, high: np.ndarray, width: int, height: int,
                   fov_deg: float = 30.0, margin: float = 1.08) -> Camera:
    """A camera looking from ``view`` (a key of ``VIEWS``) at the box ``low``..``high``, at the distance
    where the box's corners fill the image (with ``margin``)."""
    if view not in VIEWS:
        raise ValueError(f"unknown view {view!r}; allowed: {', '.join(VIEWS)}")
    low, high = np.asarray(low, float), np.asarray(high, float)
    center = 0.5 * (low + high)
    direction = np.asarray(VIEWS[view], float)
    direction /= np.linalg.norm(direction)
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    distance = 2.0 * float(np.linalg.norm(high - low)) / math.tan(math.radians(0.5 * fov_deg))
    for _ in range(3):  # the fill ratio shrinks about as 1 / distance once the camera is well away
        camera = Camera(tuple(center + distance * direction), tuple(center), width, height, fov_deg)
        screen = camera.project(corners)
        fill = max(np.max(np.abs(screen[:, 0] - 0.5 * width)) / (0.5 * width),
                   np.max(np.abs(screen[:, 1] - 0.5 * height)) / (0.5 * height))
        distance *= fill * margin
    return Camera(tuple(center + distance * direction), tuple(center), width, height, fov_deg)


@njit(cache=True)
def rasterize_triangles(screen, triangles, colors, alpha, depth_buffer, image):
    """Draw triangles (T, 3) over screen-space vertices ``screen`` (N, 3: x, y, depth) with per-vertex
    ``colors`` (N, 3) floats 0..255 into ``image`` (H, W, 3) float. ``alpha`` 1: opaque, depth-tested,
    writes depth; below 1: blended over nearer-than-stored pixels, depth not written."""
    height, width = depth_buffer.shape
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        ax, ay, az = screen[a, 0], screen[a, 1], screen[a, 2]
        bx, by, bz = screen[b, 0], screen[b, 1], screen[b, 2]
        cx, cy, cz = screen[c, 0], screen[c, 1], screen[c, 2]
        if not (az > 0.0 and bz > 0.0 and cz > 0.0):  # NaN (behind the camera) fails this too
            continue
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if abs(area) < 1e-12:
            continue
        col0 = max(int(math.floor(min(ax, bx, cx))), 0)
        col1 = min(int(math.ceil(max(ax, bx, cx))), width - 1)
        row0 = max(int(math.floor(min(ay, by, cy))), 0)
        row1 = min(int(math.ceil(max(ay, by, cy))), height - 1)
        for row in range(row0, row1 + 1):
            py = row + 0.5
            for col in range(col0, col1 + 1):
                px = col + 0.5
                wa = ((bx - px) * (cy - py) - (by - py) * (cx - px)) / area
                wb = ((cx - px) * (ay - py) - (cy - py) * (ax - px)) / area
                wc = 1.0 - wa - wb
                if wa < 0.0 or wb < 0.0 or wc < 0.0:
                    continue
                depth = wa * az + wb * bz + wc * cz
                if depth >= depth_buffer[row, col]:
                    continue
                for k in range(3):
                    color = wa * colors[a, k] + wb * colors[b, k] + wc * colors[c, k]
                    image[row, col, k] = alpha * color + (1.0 - alpha) * image[row, col, k]
                if alpha >= 1.0:
                    depth_buffer[row, col] = depth


@njit(cache=True)
def rasterize_segments(screen, color, radius_px, depth_bias, depth_buffer, image):
    """Thick depth-tested lines: ``screen`` (S, 2, 3) segment ends in screen space, one ``color`` (3,).
    ``depth_bias`` (m) pulls the lines towards the camera so they show on the surfaces they lie on."""
    height, width = depth_buffer.shape
    reach = int(math.ceil(radius_px))
    for s in range(screen.shape[0]):
        x0, y0, z0 = screen[s, 0, 0], screen[s, 0, 1], screen[s, 0, 2]
        x1, y1, z1 = screen[s, 1, 0], screen[s, 1, 1], screen[s, 1, 2]
        if not (z0 > 0.0 and z1 > 0.0):
            continue
        steps = int(math.ceil(2.0 * max(abs(x1 - x0), abs(y1 - y0)))) + 1
        for i in range(steps + 1):
            f = i / steps
            x, y, z = x0 + f * (x1 - x0), y0 + f * (y1 - y0), z0 + f * (z1 - z0) - depth_bias
            for row in range(max(int(y) - reach, 0), min(int(y) + reach + 1, height)):
                for col in range(max(int(x) - reach, 0), min(int(x) + reach + 1, width)):
                    if (col + 0.5 - x) ** 2 + (row + 0.5 - y) ** 2 > radius_px * radius_px:
                        continue
                    if z < depth_buffer[row, col]:
                        depth_buffer[row, col] = z
                        for k in range(3):
                            image[row, col, k] = color[k]


class Canvas:
    """An image and its depth buffer seen through a ``Camera`` (rendered at ``supersample`` x)."""

    def __init__(self, camera: Camera, background=(255, 255, 255), supersample: int = 2):
        if not (isinstance(supersample, int) and 1 <= supersample <= 4):
            raise ValueError(f"Canvas: supersample must be an integer in [1, 4], got {supersample!r}")
        self.camera = camera
        self.supersample = supersample
        self._camera = camera.scaled(supersample)
        size = (self._camera.height, self._camera.width)
        self.depth = np.full(size, np.inf)
        self.pixels = np.empty(size + (3,))
        self.pixels[:] = np.asarray(background, float)

    def mesh(self, positions: np.ndarray, triangles: np.ndarray, colors: np.ndarray, alpha: float = 1.0) -> None:
        """Triangles with per-vertex colours (N, 3) 0..255 (uint8 or float)."""
        if not 0.0 < alpha <= 1.0:
            raise ValueError(f"Canvas.mesh: alpha must be in (0, 1], got {alpha}")
        rasterize_triangles(self._camera.project(positions), np.ascontiguousarray(triangles, dtype=np.int64),
                            np.ascontiguousarray(colors, dtype=float), float(alpha), self.depth, self.pixels)

    def segments(self, segments: np.ndarray, color, width_px: float = 3.0, depth_bias: float = 0.0) -> None:
        """Line segments (S, 2, 3) in the world, ``width_px`` wide in the output image."""
        ends = np.asarray(segments, float).reshape(-1, 3)
        screen = self._camera.project(ends).reshape(-1, 2, 3)
        rasterize_segments(screen, np.asarray(color, float), 0.5 * width_px * self.supersample, float(depth_bias),
                           self.depth, self.pixels)

    def image(self) -> np.ndarray:
        """The picture (H, W, 3) uint8, box-filtered down from the supersampled buffer."""
        s = self.supersample
        h, w = self.camera.height, self.camera.width
        small = self.pixels.reshape(h, s, w, s, 3).mean(axis=(1, 3))
        return np.clip(np.rint(small), 0, 255).astype(np.uint8)


# ---------------------------------------------------------------------------------- volumes as meshes
def _grid_triangles(rows: int, columns: int) -> np.ndarray:
    """Triangles of a (rows x columns) vertex grid that wraps around in columns."""
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(columns), indexing="ij")
    a = r * columns + c
    b = r * columns + (c + 1) % columns
    return np.concatenate([np.stack([a, b, a + columns], -1).reshape(-1, 3),
                           np.stack([b, b + columns, a + columns], -1).reshape(-1, 3)])


def _cap(ring: np.ndarray, center: np.ndarray, normal: np.ndarray, offset: int):
    """A flat disc closing ``ring`` (M, 3): vertices, normals and fan triangles (indices from ``offset``)."""
    m = len(ring)
    positions = np.vstack([ring, center[None]])
    triangles = np.column_stack([np.arange(m), (np.arange(m) + 1) % m, np.full(m, m)]) + offset
    return positions, np.tile(normal, (m + 1, 1)), triangles


def local_volume_mesh(kind: int, radii, cut=(-np.inf, np.inf), rings: int = 14, around: int = 24):
    """A volume's surface in its local frame: ``(positions, normals, triangles)``.
    Ellipsoids are cut flat at ``cut`` (the shape that collides); capsules are tapered (sphere-swept)."""
    rx, ry, rz = (float(v) for v in radii)
    phi = np.linspace(0.0, 2.0 * np.pi, around, endpoint=False)
    circle = np.column_stack([np.cos(phi), np.sin(phi)])
    if kind == CAPSULE:
        # sphere r0 at z = -rz, sphere r1 at z = +rz; rings of both hemispheres, bottom to top
        theta = np.linspace(0.0, 0.5 * np.pi, rings // 2 + 1)
        profile = [(-rz - rx * np.cos(t), rx * np.sin(t), -np.cos(t), np.sin(t)) for t in theta]
        profile += [(rz + ry * np.sin(t), ry * np.cos(t), np.sin(t), np.cos(t)) for t in theta]
        z, radius, nz, nr = (np.array(v) for v in zip(*profile))
        positions = np.column_stack([np.outer(radius, circle[:, 0]).ravel(), np.outer(radius, circle[:, 1]).ravel(),
                                     np.repeat(z, around)])
        normals = np.column_stack([np.outer(nr, circle[:, 0]).ravel(), np.outer(nr, circle[:, 1]).ravel(),
                                   np.repeat(nz, around)])
        return positions, normals, _grid_triangles(len(z), around)
    if kind not in (SPHERE, ELLIPSOID):
        raise ValueError(f"unknown volume kind {kind!r}")
    low, high = (max(cut[0], -rz), min(cut[1], rz)) if kind == ELLIPSOID else (-rz, rz)
    theta = np.linspace(math.acos(min(1.0, high / rz)), math.acos(max(-1.0, low / rz)), rings + 1)
    unit = np.column_stack([np.outer(np.sin(theta), circle[:, 0]).ravel(),
                            np.outer(np.sin(theta), circle[:, 1]).ravel(), np.repeat(np.cos(theta), around)])
    positions = unit * [rx, ry, rz]
    normals = unit / [rx, ry, rz]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    parts = [(positions, normals, _grid_triangles(rings + 1, around))]
    count = len(positions)
    for ring, z, sign in ((positions[:around], high, 1.0), (positions[-around:], low, -1.0)):
        if abs(abs(z) - rz) > 1e-9:  # cut flat: close it
            part = _cap(ring, np.array([0.0, 0.0, z]), np.array([0.0, 0.0, sign]), count)
            parts.append(part)
            count += len(part[0])
    return tuple(np.concatenate(p) for p in zip(*parts))


def contact_planes_at(volumes: VolumeSet, centers: np.ndarray, rotations: np.ndarray, clearance: float,
                      gap: float, room: float) -> np.ndarray:
    """The contact planes (V, MAX_PLANES, 4) the solver presses ``volumes`` with at the world poses ``centers``
    (V, 3) m, ``rotations`` (V, 4) xyzw (``collision.contact_planes.press``; ``clearance``, ``gap``, ``room`` m)."""
    arrays = VolumeArrays.at_rest(volumes)
    arrays.pos1[...] = centers
    arrays.rot1[...] = quat_to_matrix(np.asarray(rotations, dtype=np.float64))
    press(tuple(arrays), pressable_pairs(volumes), float(clearance), float(gap), float(room))
    return arrays.planes


def flatten_beyond_planes(positions: np.ndarray, normals: np.ndarray, planes: np.ndarray) -> None:
    """Move the local mesh vertices (N, 3) beyond any of one volume's contact planes ``planes`` (MAX_PLANES, 4)
    onto it, their normals to its normal (in place): the volume as it collides, pressed flat where it meets
    another."""
    for normal_offset in planes:
        if not np.isfinite(normal_offset[3]):
            break
        normal, offset = normal_offset[:3], normal_offset[3]
        excess = positions @ normal - offset
        beyond = excess > 0.0
        positions[beyond] -= excess[beyond, None] * normal
        normals[beyond] = normal


def volume_meshes(volumes: VolumeSet, pose, press_with: tuple[float, float, float] | None = None
                  ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Every volume's surface in the world at ``pose``: ``(positions, normals, triangles)`` each; with
    ``press_with`` (clearance, gap, room) m, flattened on the contact planes the solver presses them with there."""
    centers, rotations = volume_poses(volumes, pose)
    planes = None if press_with is None else contact_planes_at(volumes, centers, rotations, *press_with)
    meshes = []
    for i in range(len(volumes)):
        positions, normals, triangles = local_volume_mesh(int(volumes.kinds[i]), volumes.radii[i], volumes.cuts[i])
        if planes is not None:
            flatten_beyond_planes(positions, normals, planes[i])
        rotation = rotations[i]
        meshes.append((centers[i] + quat_rotate(rotation, positions), quat_rotate(rotation, normals), triangles))
    return meshes


def floor_height(pose, joint_map) -> float:
    """The lowest joint of either leg (upper leg, its descendants: foot, toes, end sites), m. Not the
    lowest joint overall: some rigs keep a static root on the ground however high the character jumps."""
    parents = pose.skeleton.parents
    legs = {pose.skeleton.index(joint_map[role]) for role in ("left_upper_leg", "right_upper_leg")}
    for j, parent in enumerate(parents):  # parents come before children
        if parent in legs:
            legs.add(j)
    return float(pose.positions[sorted(legs), 2].min())


def character_camera(pose, joint_map, view: str, width: int, height: int) -> Camera:
    """The camera of ``render_character``: a box around the character, centred on its pelvis (the
    joint map's ``pelvis``, not joint 0: some rigs' joint 0 is a static root) horizontally, at least
    0.9 m wide and wide enough for every joint, from ``floor_height`` to 0.15 m above the highest
    joint, framed from ``view``. The pelvis lies on the picture's vertical centre line."""
    pelvis = pose.positions[pose.skeleton.index(joint_map["pelvis"])]
    reach = float(np.max(np.hypot(*(pose.positions[:, :2] - pelvis[:2]).T)))
    half = max(0.45, reach + 0.05)
    top = float(pose.positions[:, 2].max()) + 0.15
    low = np.array([pelvis[0] - half, pelvis[1] - half, floor_height(pose, joint_map)])
    high = np.array([pelvis[0] + half, pelvis[1] + half, top])
    return framing_camera(view, low, high, width, height)


def render_character(pose, volumes: VolumeSet, joint_map, garments=(), view: str = "three-quarter", width: int = 360,
                     height: int = 540, volume_alpha: float = 1.0, skeleton: bool = False,
                     body_inset_m: float = 0.0, light_dir=DEFAULT_LIGHT_DIR, supersample: int = 2,
                     press_with: tuple[float, float, float] | None = None) -> np.ndarray:
    """A picture (H, W, 3) uint8 of a posed character: a floor with the body's shadow, the body
    volumes (``volume_alpha`` < 1: see-through, over the skeleton), the ``garments``
    (``(name, positions, normals, triangles, colors)``, as ``rerun_log.garment_meshes`` gives them)
    and, with ``skeleton``, the bones, seen through ``character_camera`` (``joint_map`` names the
    pelvis and the legs), the floor at ``floor_height``.

    ``body_inset_m`` draws the volumes that much inside their collision surface: the solver keeps
    garment *vertices* out of the volumes (memo §6), so a flat triangle between two vertices resting
    on a curved volume dips into it by its chord's sagitta (~2 mm for 4 cm edges on a 12 cm radius),
    and an exact-surface body would show through there. ``press_with`` (clearance, gap, room) m draws the volumes
    pressed flat where they meet, as the solver's contact planes cut them (``volume_meshes``): the body the
    cloth was kept out of."""
    canvas = Canvas(character_camera(pose, joint_map, view, width, height), supersample=supersample)
    pelvis = pose.positions[pose.skeleton.index(joint_map["pelvis"])]
    ground = floor_height(pose, joint_map)
    floor = np.array([[-1.5, -1.5, 0.0], [1.5, -1.5, 0.0], [1.5, 1.5, 0.0], [-1.5, 1.5, 0.0]]) + [*pelvis[:2], ground]
    canvas.mesh(floor, np.array([[0, 1, 2], [0, 2, 3]]), np.full((4, 3), FLOOR_GRAY))
    meshes = volume_meshes(volumes, pose, press_with)
    light = np.asarray(light_dir, float) / np.linalg.norm(light_dir)
    for positions, _, triangles in meshes:  # shadows: volumes projected along the light onto the floor
        flat = positions - np.maximum(positions[:, 2:3] - ground, 0.0) / light[2] * light
        flat[:, 2] = ground + SHADOW_LIFT_M
        canvas.mesh(flat, triangles, np.full((len(flat), 3), SHADOW_GRAY))
    if skeleton:
        canvas.segments(skeleton_segments(pose), SKELETON_RGB, width_px=2.5)
    for name, positions, normals, triangles, colors in garments:
        canvas.mesh(positions, triangles, colors)
    for positions, normals, triangles in meshes:
        canvas.mesh(positions - body_inset_m * normals, triangles, shade(normals, BODY_RGB, light), alpha=volume_alpha)
    return canvas.image()
