"""Contact planes: body volumes pressed together meet on a plane instead of overlapping (issue 11, pinches).

The volumes are rigid, but flesh gives way where two body parts press together: a forearm on the hip, the
shins as the legs pass, a thigh raised against the belly. Two volumes that overlap then leave the cloth
between them no position outside both, and the point handling throws it through one of them (a bone
through the cloth) or fights the length correction (stretch, the guard). Here each such pair gets a
**contact plane** that cuts both volumes, each keeping its own side: the two cut volumes meet at the plane,
and a cloth point squeezed between them rests on it, outside both (``geometry.static_projection``,
``entry``, ``penetration_depth``, ``deepest_on_segment`` read the planes). The two faces are ``room - o``
apart about the plane (o the overlap; ``room`` is ``press_gap``, 15 mm), but never nearer than ``gap``, twice
the collision epsilon: a point put epsilon outside one face (as the point handling does) is then at worst
on the plane, not epsilon deep into the other volume.

**The cloth's room** (issue 11, pinches: a forearm beside the hip, 6.5 mm off it on cmu_131, 6.7 mm on the
CC walk). Two volumes closer than ``room`` but not touching leave a wedge between their curved surfaces;
a cloth point in it is put out of one volume along its normal and into the other, and back along the
other's: the normals are not opposite in a wedge, so the points are squeezed out of it along it, a
spring's two ends in opposite directions (1.56–1.58 rest lengths for a frame). Such a pair gets a plane
too, each volume cut back to leave ``room`` between flat, parallel faces, where the cloth lies with
nothing squeezing it. The compromise, bounded: a volume within ``room`` of another loses at most
``room / 2`` (7.5 mm) of its surface there beyond its share of any overlap, and as they press into each
other the faces close to ``gap`` once they overlap by ``room - gap`` (9 mm); a point may so end up to
``room / 2 - epsilon`` (4.5 mm) inside a volume as it would be uncut (not counted as depth (a), which is
measured against the volumes as pressed, nor as ``pressed``, which is the overlap).

Which pairs: those on different skeleton frames and, in the pose the body was fitted on
(``VolumeSet.rest_poses``, the canonical standing pose), disjoint, or overlapping round bones that share no
joint (their segments more than ``JOINT_GAP`` apart). Pairs overlapping at rest round one joint (a thigh and
its shin, the pelvis and a thigh) overlap by design and are left as they are; pairs disjoint at rest only
overlap when pressed together. The torso and a thigh overlap at rest too (51 mm on the CC rig, at the hip
crease, inside the pelvis' volume) but share no joint: a thigh raised ~160 deg against the belly (the CC
cartwheel) lies deep in the torso with the skirt's front between them, and only a plane gives that cloth a
place; at rest their plane cuts the two where the pelvis covers them.

Where (``press``), per pair (a, b) overlapping now, or closer than ``room`` (see above; and a point put
epsilon out of one would be inside the other, the handling passing it back and forth: a forearm 3.3 mm off
the hip, a skirt point between them 1.8 mm deep), at the substep's end poses: along a line joining points
c_a, c_b of the two volumes' axes (their local z segments), the volumes reach e_a from c_a and e_b from c_b
(their surfaces), and overlap by o = e_a + e_b - |c_b - c_a| > -room. The line joins the axes' nearest points,
unless the axes lie side by side (a forearm along the hip, an upper arm along the chest): their nearest
points are then at one end, where the volumes taper, and they overlap most elsewhere, so lines from
heights sampled along each axis, square to both (within 15 deg), are measured too, and the deepest is
used when it finds 10 mm more overlap (``_overlap``). The plane is square to that line and divides the
axes' distance in proportion to the reaches (the thicker part gives way more, each by its share of o),
then is moved, if need be, to keep ``clearance`` from either volume's bone
segment (the whole segment; a volume without a bone: its axis point c_a): a limb's bone stays on its own
side with room for the cloth, so the cloth between a forearm and the hip ends between the forearm's bone
and the pelvis' centre. Bones closer together than twice the clearance: the plane goes halfway between
the two clearance bounds. (The faces, either side of it, keep the clearance from their own bone.)

The planes are stored in each volume's local frame (``VolumeArrays.planes``, (V, MAX_PLANES, 4): unit
normal out of the kept side, offset m; the used rows first, an offset of +inf ends them), so they move
with the volume over the substep as the z cuts do. A volume pressed by more than MAX_PLANES others keeps
the first MAX_PLANES (pairs in index order). Planes are infinite: a volume loses the whole cap beyond its
plane, at most its share of the overlap deep (``press`` returns the deepest overlap, which evaluate reports
as the flesh pressed).
"""

from __future__ import annotations

import math

import numpy as np

from ..transforms import quat_to_matrix
from .geometry import capsule_sdf, kernel, ray_exit, to_world
from .volume_arrays import VolumeArrays
from .volumes import CAPSULE, ELLIPSOID, SPHERE, VolumeSet

_BISECTIONS = 40  # a capsule's reach along a ray, by bisection: 2^-40 of its length
_TINY = 1e-9  # m: axes closer than this have no direction between them
JOINT_GAP = 0.01  # m: two bones closer than this at rest share a joint (a rig's bones meet at it exactly)
_SAMPLES = 9  # heights along each axis whose lines square to the other axis are measured too (``_overlap``)
# A sampled line is used within 15 deg of square to both axes: oblique lines measure an ellipsoid's reach
# towards its long axis, and the plane cut square to them takes a cap off it.
_MAX_TILT = math.sin(math.radians(15.0))
# m: and only when it finds this much more overlap than the nearest points' line: a line a few mm deeper
# turns the plane from one substep to the next (cmu_131 at 1.98 s: 1.5 mm deeper, the forearm-thigh plane
# turned 15 deg and the forearm went through the short skirt).
_SAMPLED_MARGIN = 0.01


@kernel
def _axis(kinds, radii, cuts, v):
    """Local z range of volume v's axis: a sphere's centre, a capsule's segment, an ellipsoid's z extent
    within its cut."""
    if kinds[v] == SPHERE:
        return 0.0, 0.0
    if kinds[v] == CAPSULE:
        return -radii[v, 2], radii[v, 2]
    return max(-radii[v, 2], cuts[v, 0]), min(radii[v, 2], cuts[v, 1])


@kernel
def _nearest_on_segments(px, py, pz, dx, dy, dz, qx, qy, qz, ex, ey, ez):
    """Parameters (s, t) in [0, 1] of the nearest points p + s d and q + t e of two segments (Ericson 5.1.9)."""
    rx, ry, rz = px - qx, py - qy, pz - qz
    a = dx * dx + dy * dy + dz * dz
    e = ex * ex + ey * ey + ez * ez
    f = ex * rx + ey * ry + ez * rz
    if a <= _TINY * _TINY and e <= _TINY * _TINY:
        return 0.0, 0.0
    if a <= _TINY * _TINY:
        return 0.0, min(1.0, max(0.0, f / e))
    c = dx * rx + dy * ry + dz * rz
    if e <= _TINY * _TINY:
        return min(1.0, max(0.0, -c / a)), 0.0
    b = dx * ex + dy * ey + dz * ez
    denom = a * e - b * b
    s = min(1.0, max(0.0, (b * f - c * e) / denom)) if denom > 0.0 else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, min(1.0, max(0.0, -c / a))
    elif t > 1.0:
        t, s = 1.0, min(1.0, max(0.0, (b - c) / a))
    return s, t


@kernel
def _reach(kinds, radii, rot, v, z, ux, uy, uz):
    """How far (m) volume v's surface is from its local axis point (0, 0, z) along the world direction u."""
    dx = rot[v, 0, 0] * ux + rot[v, 1, 0] * uy + rot[v, 2, 0] * uz
    dy = rot[v, 0, 1] * ux + rot[v, 1, 1] * uy + rot[v, 2, 1] * uz
    dz = rot[v, 0, 2] * ux + rot[v, 1, 2] * uy + rot[v, 2, 2] * uz
    if kinds[v] == SPHERE:
        return radii[v, 0]
    if kinds[v] == ELLIPSOID:
        return max(0.0, ray_exit(radii[v, 0], radii[v, 1], radii[v, 2], 0.0, 0.0, z, dx, dy, dz))
    # capsule: convex, so the ray from an axis point (inside) leaves it once: bisect the sign of its distance
    lo, hi = 0.0, 2.0 * radii[v, 2] + max(radii[v, 0], radii[v, 1])
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if capsule_sdf(radii[v, 0], radii[v, 1], radii[v, 2], mid * dx, mid * dy, z + mid * dz)[0] < 0.0:
            lo = mid
        else:
            hi = mid
    return lo


@kernel
def _overlap_along(kinds, radii, rot, a, b, za, zb, ax, ay, az, bx, by, bz):
    """``(overlap, za, zb, ux, uy, uz, distance, reach_a, reach_b)``: how deep (m) volumes a and b overlap
    along the line from a's axis point at local height za (world a) to b's at zb (world b): unit direction u
    from a's to b's, ``distance`` apart, and the volumes' reaches along it; overlap +inf when the two points
    meet (no direction)."""
    ux, uy, uz = bx - ax, by - ay, bz - az
    distance = math.sqrt(ux * ux + uy * uy + uz * uz)
    if distance < _TINY:
        return math.inf, za, zb, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0
    ux, uy, uz = ux / distance, uy / distance, uz / distance
    reach_a = _reach(kinds, radii, rot, a, za, ux, uy, uz)
    reach_b = _reach(kinds, radii, rot, b, zb, -ux, -uy, -uz)
    return reach_a + reach_b - distance, za, zb, ux, uy, uz, distance, reach_a, reach_b


@kernel
def _overlap(kinds, radii, cuts, pos, rot, a, b):
    """``(overlap, za, zb, ux, uy, uz, distance, reach_a, reach_b)`` of volumes a and b (``_overlap_along``):
    along the line joining their axes' nearest points, unless one of the ``_SAMPLES`` lines from evenly
    spaced heights on either axis square to the other (its nearest point there inside the other axis) and
    within ``_MAX_TILT`` of square to the first finds more than ``_SAMPLED_MARGIN`` more overlap: then along
    the deepest of those. Axes side by side (a forearm along the hip, an upper arm along the chest) have
    their nearest points at one end, where the volumes taper, while they overlap most elsewhere."""
    a0, a1 = _axis(kinds, radii, cuts, a)
    b0, b1 = _axis(kinds, radii, cuts, b)
    pax, pay, paz = to_world(pos, rot, a, 0.0, 0.0, a0)
    qax, qay, qaz = to_world(pos, rot, a, 0.0, 0.0, a1)
    pbx, pby, pbz = to_world(pos, rot, b, 0.0, 0.0, b0)
    qbx, qby, qbz = to_world(pos, rot, b, 0.0, 0.0, b1)
    dax, day, daz = qax - pax, qay - pay, qaz - paz
    dbx, dby, dbz = qbx - pbx, qby - pby, qbz - pbz
    s, t = _nearest_on_segments(pax, pay, paz, dax, day, daz, pbx, pby, pbz, dbx, dby, dbz)
    nearest = _overlap_along(kinds, radii, rot, a, b, a0 + s * (a1 - a0), b0 + t * (b1 - b0), pax + s * dax,
                             pay + s * day, paz + s * daz, pbx + t * dbx, pby + t * dby, pbz + t * dbz)
    if nearest[0] == math.inf:
        return nearest
    best = nearest
    length_a = max(_TINY, math.sqrt(dax * dax + day * day + daz * daz))
    length_b = max(_TINY, math.sqrt(dbx * dbx + dby * dby + dbz * dbz))
    for i in range(2 * _SAMPLES):
        h = (i // 2) / (_SAMPLES - 1.0)
        if i % 2 == 0:  # from height h on a's axis, square to b's
            sa = h
            sb = _nearest_on_segments(pax + h * dax, pay + h * day, paz + h * daz, 0.0, 0.0, 0.0,
                                      pbx, pby, pbz, dbx, dby, dbz)[1]
            inside, ex, ey, ez = 0.0 < sb < 1.0, dax / length_a, day / length_a, daz / length_a
        else:  # from height h on b's axis, square to a's
            sb = h
            sa = _nearest_on_segments(pbx + h * dbx, pby + h * dby, pbz + h * dbz, 0.0, 0.0, 0.0,
                                      pax, pay, paz, dax, day, daz)[1]
            inside, ex, ey, ez = 0.0 < sa < 1.0, dbx / length_b, dby / length_b, dbz / length_b
        if not inside:
            continue
        line = _overlap_along(kinds, radii, rot, a, b, a0 + sa * (a1 - a0), b0 + sb * (b1 - b0), pax + sa * dax,
                              pay + sa * day, paz + sa * daz, pbx + sb * dbx, pby + sb * dby, pbz + sb * dbz)
        if line[0] > best[0] and abs(line[3] * ex + line[4] * ey + line[5] * ez) <= _MAX_TILT:
            best = line
    return best if best[0] > nearest[0] + _SAMPLED_MARGIN else nearest


@kernel
def _bone_extent(bones, pos, rot, v, z, cx, cy, cz, ux, uy, uz, sign):
    """The most (sign +1) or least (-1) of u . (p - c) over volume v's bone segment p (its axis point at
    height z without a bone)."""
    lo, hi = bones[v, 0], bones[v, 1]
    if math.isnan(lo):
        lo, hi = z, z
    best = -math.inf
    for h in (lo, hi):
        px, py, pz = to_world(pos, rot, v, 0.0, 0.0, h)
        best = max(best, sign * (ux * (px - cx) + uy * (py - cy) + uz * (pz - cz)))
    return sign * best


@kernel
def _add_plane(planes, pos, rot, v, nx, ny, nz, cx, cy, cz):
    """Append to volume v's planes the one through world point c with world normal n (out of v's kept side)."""
    for k in range(planes.shape[1]):
        if planes[v, k, 3] == math.inf:
            lx = rot[v, 0, 0] * nx + rot[v, 1, 0] * ny + rot[v, 2, 0] * nz
            ly = rot[v, 0, 1] * nx + rot[v, 1, 1] * ny + rot[v, 2, 1] * nz
            lz = rot[v, 0, 2] * nx + rot[v, 1, 2] * ny + rot[v, 2, 2] * nz
            planes[v, k, 0], planes[v, k, 1], planes[v, k, 2] = lx, ly, lz
            planes[v, k, 3] = nx * (cx - pos[v, 0]) + ny * (cy - pos[v, 1]) + nz * (cz - pos[v, 2])
            return


@kernel
def press(arrays, pairs, clearance, gap, room):
    """Contact planes of the ``pairs`` (K, 2) that overlap, or are closer than ``room``, at the substep's end
    poses (``pos1``, ``rot1``), written into ``planes`` (see the module docstring); ``clearance`` m from the
    bones, the two faces ``room`` less the overlap m apart, at least ``gap``. Returns the deepest overlap
    pressed away, m (0: none)."""
    vol = VolumeArrays(*arrays)  # a plain tuple from Python (see ``collision.kernels``)
    kinds, radii, cuts, bones, bounding_radii = vol.kinds, vol.radii, vol.cuts, vol.bones, vol.bounding_radii
    planes, pos, rot = vol.planes, vol.pos1, vol.rot1
    for v in range(planes.shape[0]):
        for k in range(planes.shape[1]):
            planes[v, k, 0], planes[v, k, 1], planes[v, k, 2], planes[v, k, 3] = 0.0, 0.0, 0.0, math.inf
    deepest = 0.0
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        reach = bounding_radii[a] + bounding_radii[b] + room
        if (pos[a, 0] - pos[b, 0]) ** 2 + (pos[a, 1] - pos[b, 1]) ** 2 + (pos[a, 2] - pos[b, 2]) ** 2 > reach * reach:
            continue
        overlap, za, zb, ux, uy, uz, distance, reach_a, reach_b = _overlap(kinds, radii, cuts, pos, rot, a, b)
        if not -room < overlap < math.inf:  # apart by more than the cloth needs, or axes that meet: no side
            continue
        half = 0.5 * min(room, max(gap, room - overlap))  # m, each face from the plane
        deepest = max(deepest, overlap)
        cx, cy, cz = to_world(pos, rot, a, 0.0, 0.0, za)
        # the plane at c + s u: the axes' distance divided in proportion to the reaches, then the clearance
        s = distance * reach_a / (reach_a + reach_b)
        lo = _bone_extent(bones, pos, rot, a, za, cx, cy, cz, ux, uy, uz, 1.0) + clearance + half
        hi = _bone_extent(bones, pos, rot, b, zb, cx, cy, cz, ux, uy, uz, -1.0) - clearance - half
        s = min(hi, max(lo, s)) if lo <= hi else 0.5 * (lo + hi)
        _add_plane(planes, pos, rot, a, ux, uy, uz, cx + (s - half) * ux, cy + (s - half) * uy, cz + (s - half) * uz)
        _add_plane(planes, pos, rot, b, -ux, -uy, -uz, cx + (s + half) * ux, cy + (s + half) * uy, cz + (s + half) * uz)
    return deepest


def pressable_pairs(volumes: VolumeSet) -> np.ndarray:
    """(K, 2) int64 volume index pairs (a < b) that may be pressed together: on different skeleton frames
    and, in ``volumes.rest_poses``, disjoint or overlapping round bones that share no joint (module docstring);
    none without rest poses."""
    if volumes.rest_poses is None:
        return np.zeros((0, 2), dtype=np.int64)
    positions = np.ascontiguousarray(volumes.rest_poses[0], dtype=np.float64)
    rotations = np.ascontiguousarray(quat_to_matrix(np.asarray(volumes.rest_poses[1], dtype=np.float64)))
    kinds = np.ascontiguousarray(volumes.kinds, dtype=np.int64)
    radii = np.ascontiguousarray(volumes.radii, dtype=np.float64)
    cuts = np.ascontiguousarray(volumes.cuts, dtype=np.float64)
    pairs = []
    for a in range(len(volumes)):
        for b in range(a + 1, len(volumes)):
            if volumes.frame_index[a] == volumes.frame_index[b]:
                continue
            overlap = _overlap(kinds, radii, cuts, positions, rotations, a, b)[0]
            if not overlap > 0.0 or (overlap < math.inf and _bones_apart(volumes.bones, positions, rotations, a, b)):
                pairs.append((a, b))
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def jointed_pairs(volumes: VolumeSet) -> np.ndarray:
    """(K, 2) int64 volume index pairs (a < b) whose bones meet at a joint in ``volumes.rest_poses`` (an upper
    arm and its forearm at the elbow, a thigh and its shin at the knee); none without rest poses."""
    if volumes.rest_poses is None:
        return np.zeros((0, 2), dtype=np.int64)
    positions = np.ascontiguousarray(volumes.rest_poses[0], dtype=np.float64)
    rotations = np.ascontiguousarray(quat_to_matrix(np.asarray(volumes.rest_poses[1], dtype=np.float64)))
    bones = volumes.bones
    pairs = [(a, b) for a in range(len(volumes)) for b in range(a + 1, len(volumes))
             if not (np.isnan(bones[a, 0]) or np.isnan(bones[b, 0]) or _bones_apart(bones, positions, rotations, a, b))]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def _bones_apart(bones: np.ndarray, positions: np.ndarray, rotations: np.ndarray, a: int, b: int) -> bool:
    """Whether volumes a and b both have a bone (``VolumeSet.bones``) and the two share no joint: their
    segments more than ``JOINT_GAP`` apart in the given poses ((V, 3) m, (V, 3, 3))."""
    if np.isnan(bones[a, 0]) or np.isnan(bones[b, 0]):
        return False
    pa, qa = (np.array(to_world(positions, rotations, a, 0.0, 0.0, h)) for h in bones[a])
    pb, qb = (np.array(to_world(positions, rotations, b, 0.0, 0.0, h)) for h in bones[b])
    s, t = _nearest_on_segments(*pa, *(qa - pa), *pb, *(qb - pb))
    return float(np.linalg.norm(pa + s * (qa - pa) - pb - t * (qb - pb))) > JOINT_GAP
