"""Procedural garment meshes cut to a body's measurements.

Every garment is built in the root frame of the rest pose (origin at the pelvis joint,
x forward, y left, z up, metres) from rings of vertices: a ring is an ellipse at one
height, consecutive rings are joined by quads split into two triangles. Triangles are
wound counter-clockwise seen from outside, so their normals point away from the body.

``resolution`` scales the vertex count along and around the garment linearly (so the mass
point count grows with its square); 1.0 gives about the memo's sizes (§7, Table 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..body.measurements import STANDARD_BODY, BodyMeasurements

GARMENT_NAMES = ("short_skirt", "long_skirt", "pants", "one_piece")
MAX_RESOLUTION = 20.0
_LEG_GAP = 0.004  # m between a trouser leg's inner side and the body's mid-plane
# The trousers' crotch seam hangs one thigh radius plus this share of it below the body's crotch (the
# pelvis volume's bottom cut). A thigh swinging by an angle a about its hip joint lifts the front (in
# flexion) or back (in extension) of its surface at the crotch by r sin(a) <= r, its radius r, whatever
# the angle; the leg tubes carry the seam up with it. A seam nearer than that is pushed into the pelvis
# volume, and the static handling (keep z, out radially) throws it sideways across a thigh (CC walk, a
# fixed 25 mm margin before: 34 of 156 frames with a thigh through the cloth, 12 with a leg out). Deep
# flexion needs more: past 90 deg the pelvis tilts too and the front of the hip tube folds into the crease
# between thigh and belly, and a short rise is dragged along the thigh. Measured on the CC jump (both hips
# to 120 deg), 3 s at 1x/2x/3x, 60 fps: margin 0.3 r (25 mm at r = 85 mm, before) legs off 152/6/70
# frames, guard 16/8/5; 0.65 r legs off 0/0/0, guard 2/1/1; more thigh ease (0.6 r) made it worse.
_CROTCH_EASE_PER_THIGH = 0.65
# Ease of a trouser leg (added to the body's radius there), as shares of the thigh's radius: round the
# thigh and knee (35 mm on the 1.75 m standard body), and below the knee (45 mm): scaled with the body.
_THIGH_EASE_PER_THIGH = 0.41
_SHIN_EASE_PER_THIGH = 0.53
# Seat ease of the trousers' hip tube at the hips' widest (on top of the waist-and-hips ease), as a share of the
# thigh's radius (17 mm on the standard body), tapering to none at the waist and at the crotch: a thigh flexing
# forward swells out of the pelvis volume under the seat, and the hip tube's rings there went round it stretched
# (cmu_01_01's crouches, both hips flexed: worst frame's p99 1.21 -> 1.07 over the clip at 1x, 60 fps; the CC
# walk's ring 3 cm above the hip joint). None at the crotch ring: ease there lengthens the crotch seam and a thigh
# walks through it into the other leg (20 mm there too: cmu_01_01 at 3x, 349 legs-off frames); more than this
# at the seat did the same (0.3: 42 legs-off frames at 3x). docs/real_motion.md, "Seat ease".
_SEAT_EASE_PER_THIGH = 0.2
# Width ease of the trousers' crotch ring (the hip tube's last ring, which the two legs' top rings share), side to
# side only, as a share of the thigh's radius (34 mm on the standard body), from none at the hips' widest: a thigh
# flexed to 90 deg or spread in a straddle swells the body's section there sideways, and the ring's front and back
# halves went round it stretched (the CC jump's crouch, the cartwheel: trouser p99 1.2-1.4 with every start). Front
# to back the ring keeps the hips' ease: that length is the crotch seam's ("Seat ease" above). Over three starts of
# the two clips' trousers at 1x and 2x (24 runs): 0 -> 2 passing, 0.4 -> 9, 0.6 -> 8, 0.8 -> 4; the seven ordinary
# clips' trouser runs pass at 0.4 as at 0 (docs/real_motion.md, "Crotch width ease").
_CROTCH_WIDTH_EASE_PER_THIGH = 0.4
# Room between a one-piece's neckline and the upper arms hanging at the sides, per stature (15 mm at 1.75 m).
_UNDERARM_EASE_PER_STATURE = 0.0086


# The stride a long skirt is cut for: the angle between the thighs, legs straight and swung apart front and
# back. Level walking spans about 40 deg of hip flexion-extension (Perry & Burnfield, Gait Analysis, 2nd ed.,
# 2010); the stylised walks of the shared clips go further: 62 to 76 deg at their widest (CC walk 62, cmu_131
# 65, xia_angry 76), measured between the thigh bones in every 1/60 s frame of their first 3 s. A long
# stride's 80 deg covers them. The cut is conservative (legs straight, the hem as deep down them as at rest):
# xia_angry's closed hem was stretched 11-13 % in its widest strides; this loop is 39 % longer than that hem.
_STRIDE = math.radians(80.0)


def _crotch_drop(body: BodyMeasurements) -> float:
    """How far (m) the trousers' crotch seam hangs below the body's crotch: room for the thighs' swing."""
    return body.thigh_radius * (1.0 + _CROTCH_EASE_PER_THIGH)


@dataclass(frozen=True)
class GarmentMesh:
    name: str
    vertices: np.ndarray  # (N, 3) rest positions, root frame, metres
    triangles: np.ndarray  # (T, 3) vertex indices, counter-clockwise seen from outside
    attachments: dict[str, np.ndarray]  # joint-map role -> vertex indices carried by that segment
    rings: dict[str, list[np.ndarray]] = field(default_factory=dict)  # named vertex rings, top to bottom
    # Tubes that must stay round a limb: a ``rings`` name -> the body segments (joint-map roles, which
    # are also the fitted volumes' names) each of its rings goes round, one or another. The first ring
    # is where the tube leaves the garment's body tube (the trousers' crotch), no loop round the limb.
    limb_tubes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    # Attachments skinned to two segments: a role of ``attachments`` -> (a second role, its weight in
    # [0, 1]); the points ride on the weighted mean of where each segment puts them (see ``_waistband``).
    shared_attachments: dict[str, tuple[str, float]] = field(default_factory=dict)

    def edges(self) -> np.ndarray:
        """Unique undirected mesh edges (E, 2), smaller index first, sorted."""
        t = self.triangles
        pairs = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        pairs.sort(axis=1)
        return np.unique(pairs, axis=0)


def _ring(center_x: float, center_y: float, z: float, rx: float, ry: float, count: int, phase: float = 0.0):
    angle = phase + 2.0 * np.pi * np.arange(count) / count
    return np.stack([center_x + rx * np.cos(angle), center_y + ry * np.sin(angle), np.full(count, z)], axis=1)


def _band(upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Triangles joining two closed rings of equal length (indices, both counter-clockwise from above).

    ``upper`` lies above ``lower``. Diagonals alternate so the mesh has no preferred shear direction.
    """
    n = len(upper)
    j = np.arange(n)
    a, b = upper[j], upper[(j + 1) % n]
    c, d = lower[j], lower[(j + 1) % n]
    even = (j % 2) == 0
    # Quad a-b (top, CCW) over c-d (bottom). Outward normal = (d - c) x (a - c) direction for CCW rings.
    first = np.where(even[:, None], np.stack([a, c, d], 1), np.stack([a, c, b], 1))
    second = np.where(even[:, None], np.stack([a, d, b], 1), np.stack([b, c, d], 1))
    return np.concatenate([first, second])


def _step_band(upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Triangles joining two closed rings of unequal lengths (as ``_band``), each evenly spaced round the tube
    from the same starting angle: both rings are walked round together, each triangle advancing along the
    ring whose next vertex comes first."""
    upper_next = np.arange(1, len(upper) + 1) / len(upper)  # share of the way round
    lower_next = np.arange(1, len(lower) + 1) / len(lower)
    triangles = []
    i = j = 0
    while i < len(upper) or j < len(lower):
        if j == len(lower) or (i < len(upper) and upper_next[i] < lower_next[j]):
            triangles.append((upper[i], lower[j % len(lower)], upper[(i + 1) % len(upper)]))
            i += 1
        else:
            triangles.append((upper[i % len(upper)], lower[j], lower[(j + 1) % len(lower)]))
            j += 1
    return np.array(triangles, dtype=np.int64)


def _tube(levels: list[tuple[float, float, float, float, float]], around: int):
    """Vertices and triangles of a tube from (center_x, center_y, z, rx, ry) levels, top first."""
    vertices = np.concatenate([_ring(cx, cy, z, rx, ry, around) for cx, cy, z, rx, ry in levels])
    rings = [np.arange(i * around, (i + 1) * around) for i in range(len(levels))]
    triangles = np.concatenate([_band(rings[i], rings[i + 1]) for i in range(len(rings) - 1)])
    return vertices, triangles, rings


def _profile(z_top: float, z_bottom: float, count: int, section) -> list[tuple[float, float, float, float, float]]:
    """``count`` levels from z_top to z_bottom; ``section(z) -> (centre_x, rx, ry)``."""
    zs = np.linspace(z_top, z_bottom, count)
    return [(float(cx), 0.0, float(z), float(rx), float(ry)) for z in zs for cx, rx, ry in [section(z)]]


def _interp_section(points: list[tuple[float, float, float, float]]):
    """Piecewise-linear (centre_x, rx, ry) against z from (z, centre_x, rx, ry) knots."""
    knots = sorted(points)
    zs = [p[0] for p in knots]
    return lambda z: tuple(np.interp(z, zs, [p[k] for p in knots]) for k in (1, 2, 3))


def _waistband(body: BodyMeasurements) -> dict[str, tuple[str, float]]:
    """A waistband (the skirts', the trousers'), carried by the pelvis, is skinned to the spine segment too,
    weighted by its height above the spine's joint (the lumbar pivot): half at the pivot, all the spine's a
    waist depth above it (linear blend skinning across the bend). Carried by the pelvis alone, a band above
    the pivot ends inside the torso when the trunk bends forward: on the CC basketball clip (band 9.6 cm above
    the pivot) the short skirt's guard fired 78 times in 3 s with free points 116 mm deep; on the CC cartwheel
    (the pelvis turned up to 89 deg against the waist) the trousers' band went 7-21 mm from the spine's bone,
    the bone through the row under it in 41 of 442 frames (1x, 60 fps). On the spine alone the procedural
    walker's band (1.7 cm above its pivot) twisted with the chest."""
    if not math.isfinite(body.spine_z):
        return {}
    weight = float(np.clip(0.5 + 0.5 * (body.waist_z - body.spine_z) / body.waist_rx, 0.0, 1.0))
    return {"pelvis": ("spine", weight)} if weight > 0.0 else {}


def _counts(resolution: float, around: int, levels: int) -> tuple[int, int]:
    if not (isinstance(resolution, (int, float)) and 0.25 <= resolution <= MAX_RESOLUTION):
        raise ValueError(f"garment resolution must be a number in [0.25, {MAX_RESOLUTION}], got {resolution!r}")
    return max(8, 2 * round(around * resolution / 2)), max(3, round(levels * resolution))


def _ellipse_perimeter(rx: np.ndarray, ry: np.ndarray) -> np.ndarray:
    """Ramanujan's approximation (relative error under 1e-4 for rx/ry up to 3)."""
    h = ((rx - ry) / (rx + ry)) ** 2
    return np.pi * (rx + ry) * (1.0 + 3.0 * h / (10.0 + np.sqrt(4.0 - 3.0 * h)))


def _stride_girth(body: BodyMeasurements, z: np.ndarray) -> np.ndarray:
    """The shortest loop (m) round both legs at height ``z`` (root frame) in a ``_STRIDE`` stride: the loop
    round two circles of the legs' radius there whose centres are the two leg axes' points at that depth below
    the hip joints (2 d + 2 pi r, d their distance). The legs are straight and the points' depth along each
    leg is the rest pose's, as a hem hanging at a fixed length of cloth from the waist meets the legs."""
    hip_joint_z = 2.0 * body.knee_z - body.ankle_z  # thigh and shin equally long (Winter: 0.245 and 0.246 H)
    depth = np.maximum(hip_joint_z - z, 0.0)
    apart = np.hypot(2.0 * depth * math.sin(0.5 * _STRIDE), 2.0 * body.leg_y)
    radius = np.where(z < body.knee_z, np.interp(z, [body.ankle_z, body.knee_z], [body.ankle_radius, body.knee_radius]),
                      np.interp(z, [body.knee_z, body.crotch_z], [body.knee_radius, body.thigh_radius]))
    return 2.0 * apart + 2.0 * np.pi * radius


def _vent(levels: list[tuple[float, float, float, float, float]], body: BodyMeasurements) -> int:
    """The first ring (from the top) of a walking vent: the rings from there to the hem are shorter than the
    loop round both legs in a ``_STRIDE`` stride (``_stride_girth``), so the skirt opens at the back from the
    ring above them down; ``len(levels)`` (no vent) when every ring goes round the stride. Real straight long
    skirts have a vent or slit for the same reason: a hem that does not go round the stride stretches (the
    long skirt's hem ring 11-13 % longer than at rest in xia_angry's widest strides)."""
    z, rx, ry = (np.array([level[k] for level in levels]) for k in (2, 3, 4))
    goes_round = (_ellipse_perimeter(rx, ry) >= _stride_girth(body, z)) | (z >= body.crotch_z)
    return int(np.flatnonzero(goes_round)[-1]) + 1


def _open_at_back(vertices: np.ndarray, triangles: np.ndarray, rings: list[np.ndarray], first: int):
    """The tube ``_tube`` built, cut open along its back centre line from ring ``first`` down: those rings'
    back-centre vertices are doubled and the quads on their right (seen from outside: towards the ring's
    end) take the copies. Each opened ring becomes the open chain from the back centre round to its copy."""
    around = len(rings[0])
    back = around // 2  # ring index 0 is the front centre (+x)
    opened = np.array([ring[back] for ring in rings[first:]], dtype=np.int64)
    copies = len(vertices) + np.arange(len(opened))
    column, level = triangles % around, triangles // around
    seam_quads = np.all((column == back - 1) | (column == back), axis=1)
    retarget = seam_quads[:, None] & (column == back) & (level >= first)
    triangles = triangles.copy()
    triangles[retarget] = copies[level[retarget] - first]
    rings = [*rings[:first], *[np.concatenate([ring[back:], ring[:back], [copy]]) for ring, copy in
                               zip(rings[first:], copies)]]
    return np.concatenate([vertices, vertices[opened]]), triangles, rings


def _vented_tube(levels: list[tuple[float, float, float, float, float]], around: int, body: BodyMeasurements):
    """``_tube`` with a walking vent at the back where its rings are too short for the stride (``_vent``)."""
    vertices, triangles, rings = _tube(levels, around)
    if (first := _vent(levels, body)) < len(rings):
        vertices, triangles, rings = _open_at_back(vertices, triangles, rings, first)
    return vertices, triangles, rings


def _skirt(name: str, body: BodyMeasurements, resolution: float, hem_z: float, flare: float,
           around: int, levels: int, vented: bool = False) -> GarmentMesh:
    ease = 0.012  # cloth stands this far off the body at the waist and hips
    radii = _interp_section([
        (body.waist_z, body.waist_x, body.waist_rx + ease, body.waist_ry + ease),
        (body.hip_z, body.hip_x, body.hip_rx + ease, body.hip_ry + ease),
        (hem_z, body.leg_x, (body.hip_rx + ease) * flare, (body.hip_ry + ease) * flare),
    ])
    n_around, n_levels = _counts(resolution, around, levels)
    profile = _profile(body.waist_z, hem_z, n_levels, radii)
    vertices, triangles, rings = _vented_tube(profile, n_around, body) if vented else _tube(profile, n_around)
    return GarmentMesh(name, vertices, triangles, {"pelvis": rings[0]}, {"waistband": [rings[0]], "hem": [rings[-1]]},
                       shared_attachments=_waistband(body))


def short_skirt(body: BodyMeasurements = STANDARD_BODY, resolution: float = 1.0) -> GarmentMesh:
    hem_z = body.crotch_z - 0.45 * (body.crotch_z - body.knee_z)  # mid-thigh
    return _skirt("short_skirt", body, resolution, hem_z, flare=1.35, around=48, levels=8)


def long_skirt(body: BodyMeasurements = STANDARD_BODY, resolution: float = 1.0) -> GarmentMesh:
    hem_z = body.knee_z - 0.7 * (body.knee_z - body.ankle_z)  # lower calf
    return _skirt("long_skirt", body, resolution, hem_z, flare=1.8, around=48, levels=13, vented=True)


def _neckline_half_width(body: BodyMeasurements, ease: float) -> float:
    """Half width (m) of the one-piece's neckline: the chest's plus ease, but inside the upper arms hanging
    straight down from their shoulder joints (``underarm_y``) by ``_UNDERARM_EASE_PER_STATURE``. Cut to the
    chest's width, the neckline's sides (attached, so never pushed out of a volume) lay 10-35 mm inside a
    hanging arm on the Character Creator clips, and the bodice under them was pushed out round the arm's far
    side: the upper arm's bone through the top band in 74 of 180 frames on the CC jump, 39 on the basketball
    clip (1x, 60 fps)."""
    return min(body.chest_ry + ease, body.underarm_y - _UNDERARM_EASE_PER_STATURE * body.height)


def one_piece(body: BodyMeasurements = STANDARD_BODY, resolution: float = 1.0) -> GarmentMesh:
    """A strapless one-piece dress from under the arms to below the knee; its top edge is carried by the chest."""
    ease = 0.015  # a little more than the skirts: the chest volume swells between the knots below
    hem_z = body.knee_z - 0.15 * (body.knee_z - body.ankle_z)
    radii = _interp_section([
        (body.chest_z, body.chest_x, body.chest_rx + ease, body.chest_ry + ease),
        (body.waist_z, body.waist_x, body.waist_rx + ease, body.waist_ry + ease),
        (body.hip_z, body.hip_x, body.hip_rx + ease, body.hip_ry + ease),
        (hem_z, body.leg_x, (body.hip_rx + ease) * 1.45, (body.hip_ry + ease) * 1.45),
    ])
    n_around, n_levels = _counts(resolution, 48, 15)
    # vented as the long skirt: closed, its hem (a sheath's, 9-21 % shorter than the loop round both legs in
    # the long skirt's stride on the shared clips' bodies) went round both legs in xia_angry's 73 deg strides
    # (its springs' p99 1.13-1.19) and cmu_131's wide stances (thighs 62-69 deg apart, a knee bent 55 deg;
    # 14-16 cm up the legs, 6-7 % longer than at rest for a second)
    vertices, triangles, rings = _vented_tube(_profile(body.chest_z, hem_z, n_levels, radii), n_around, body)
    neckline = vertices[rings[0]]
    neckline[:, 1] *= _neckline_half_width(body, ease) / (body.chest_ry + ease)
    vertices[rings[0]] = neckline
    waist_level = int(np.argmin([abs(v[2] - body.waist_z) for v in vertices[[r[0] for r in rings]]]))
    return GarmentMesh("one_piece", vertices, triangles, {"chest": rings[0]},
                       {"neckline": [rings[0]], "waist": [rings[waist_level]], "hem": [rings[-1]]})


def pants(body: BodyMeasurements = STANDARD_BODY, resolution: float = 1.0) -> GarmentMesh:
    """Trousers: a hip tube from the waist to below the crotch (``_crotch_drop``) that splits into two leg tubes.

    The hip ring's front and back centre vertices, joined by a crotch seam of interior
    vertices, start both legs: each leg's first ring is half of the hip ring plus the seam;
    a few rings down, the leg's rings step down to fewer vertices.
    """
    ease = 0.012
    n_around, n_hip_levels = _counts(resolution, 32, 3)  # hip ring size, levels from the waist to the crotch
    seam_z = body.crotch_z - _crotch_drop(body)
    # The tube goes on below the crotch to the seam: more rings at about the spacing of the waist-to-crotch
    # tube, not longer springs (a coarser tube bends less where the thighs swing).
    rise = body.waist_z - body.crotch_z
    n_hip_levels = 1 + round((n_hip_levels - 1) * (body.waist_z - seam_z) / rise)
    half = n_around // 2
    # Interior crotch-seam vertices: 4 make its segments 57 mm (2 made them 95 mm, the hip ring's are 28-38 mm),
    # short enough that the pelvis volume does not bulge through the crotch between them onto a thigh's bone,
    # which then walked through the seam into the other trouser leg at 2-3x (docs/real_motion.md, "Trouser legs
    # off at 2-3x": legs-off frames 209 -> 0 on seven such runs).
    seam = max(1, round(4 * resolution))
    # The leg's first rings below the crotch have as many vertices as its top ring (half the hip ring and the
    # seam: 21); the rest step down to 19 (33-38 mm apart, as fine as the hip ring), which keeps the trousers
    # at the memo's size (Table 1: 548 points; 672 here, 720 with every ring at 21). Stepping down at ring 1 or
    # ring 4 instead let a thigh out of its leg again (the CC jump at 3x: 50 and 12 legs-off frames).
    top_around = half + 1 + seam
    leg_around = half + 1 + max(1, round(2 * resolution))
    n_top_rings = max(1, round(2 * resolution))  # leg rings below the top ring with ``top_around`` vertices
    n_leg_levels = max(3, round(14 * resolution))
    hem_z = body.ankle_z + 0.05

    seat_ease = ease + _SEAT_EASE_PER_THIGH * body.thigh_radius
    crotch_width_ease = _CROTCH_WIDTH_EASE_PER_THIGH * body.thigh_radius
    hip_radii = _interp_section([
        (body.waist_z, body.waist_x, body.waist_rx + ease, body.waist_ry + ease),
        (body.hip_z, body.hip_x, body.hip_rx + seat_ease, body.hip_ry + seat_ease),
        (body.crotch_z, body.hip_x, body.hip_rx + ease, body.hip_ry + ease + crotch_width_ease),
    ])
    # Ring phase: index 0 at the front centre (+x), index `half` at the back centre.
    hip_levels = _profile(body.waist_z, seam_z, n_hip_levels, hip_radii)
    vertices = [_ring(cx, cy, z, rx, ry, n_around) for cx, cy, z, rx, ry in hip_levels]
    hip_rings = [np.arange(i * n_around, (i + 1) * n_around) for i in range(n_hip_levels)]
    triangles = [_band(hip_rings[i], hip_rings[i + 1]) for i in range(n_hip_levels - 1)]
    count = n_hip_levels * n_around

    crotch = hip_rings[-1]
    crotch_z = hip_levels[-1][2]
    cx_crotch, rx_crotch = hip_levels[-1][0], hip_levels[-1][3]
    # Seam from back to front along x at the crotch height.
    seam_x = cx_crotch + np.linspace(-rx_crotch, rx_crotch, seam + 2)[1:-1]
    vertices.append(np.stack([seam_x, np.zeros(seam), np.full(seam, crotch_z)], axis=1))
    seam_ids = np.arange(count, count + seam)
    count += seam

    # Counter-clockwise (from above) leg rings: left leg = front -> left side -> back -> seam -> front.
    left_top = np.concatenate([crotch[0:half + 1], seam_ids])
    right_top = np.concatenate([crotch[half:], crotch[:1], seam_ids[::-1]])
    leg_rings: dict[str, list[np.ndarray]] = {}
    for side, sign, top in (("left", 1.0, left_top), ("right", -1.0, right_top)):
        # Lower rings: circles about the leg axis, starting at the angle of the top ring's first vertex.
        top_xy = np.concatenate(vertices)[top][:, :2]
        start = np.arctan2(top_xy[0, 1] - sign * body.leg_y, top_xy[0, 0] - body.leg_x)
        rings = [top]
        for k in range(1, n_leg_levels + 1):
            z = crotch_z + (hem_z - crotch_z) * k / n_leg_levels
            if z < body.knee_z:
                radius = float(np.interp(z, [body.ankle_z, body.knee_z], [body.ankle_radius, body.knee_radius]))
                radius += _SHIN_EASE_PER_THIGH * body.thigh_radius
            else:
                radius = float(np.interp(z, [body.knee_z, crotch_z], [body.knee_radius, body.thigh_radius]))
                radius += _THIGH_EASE_PER_THIGH * body.thigh_radius
            # The legs' inner sides must not cross the body's mid-plane into the other leg.
            ry = min(radius, 0.5 * (body.leg_y + radius - _LEG_GAP))
            centre_y = max(body.leg_y, _LEG_GAP + ry)
            around = top_around if k <= n_top_rings else leg_around
            vertices.append(_ring(body.leg_x, sign * centre_y, z, radius, ry, around, phase=start))
            rings.append(np.arange(count, count + around))
            count += around
        triangles.extend(_band(upper, lower) if len(upper) == len(lower) else _step_band(upper, lower)
                         for upper, lower in zip(rings[:-1], rings[1:]))
        leg_rings[f"{side}_leg"] = rings
    return GarmentMesh(
        "pants", np.concatenate(vertices), np.concatenate(triangles), {"pelvis": hip_rings[0]},
        {"waistband": [hip_rings[0]], **leg_rings},
        {f"{side}_leg": (f"{side}_upper_leg", f"{side}_lower_leg") for side in ("left", "right")},
        shared_attachments=_waistband(body),
    )


TEMPLATES = {"short_skirt": short_skirt, "long_skirt": long_skirt, "pants": pants, "one_piece": one_piece}


def build_garment(name: str, body: BodyMeasurements = STANDARD_BODY, resolution: float = 1.0) -> GarmentMesh:
    try:
        template = TEMPLATES[name]
    except KeyError:
        raise ValueError(f"unknown garment {name!r}; known: {', '.join(GARMENT_NAMES)}") from None
    return template(body, resolution)
