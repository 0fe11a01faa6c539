"""Broad phase and pose interpolation for the collision kernels (``collision.kernels``).

From cheap to exact, each test only rejecting pairs the exact handling would miss: a volume's reach
(``reach_radii``: how far any point of it moves in the substep, plus its bounding radius), its local
box (``local_boxes``) against the point's relative trajectory p0' -> p1 in the volume's frame, and,
for cached pairs, the bounding sphere of that trajectory (``broad_phase_rejects``). Arrays as in
``collision.volume_arrays`` (``vol``): positions (V, 3) m, rotation matrices (V, 3, 3), quaternions (V, 4) xyzw.
"""

from __future__ import annotations

import math

from .. import quat_kernels as quat
from .geometry import kernel
from .volumes import CAPSULE, ELLIPSOID

# ----------------------------------------------------------------------------- broad phase

@kernel
def broad_phase_rejects(vol, v, xs, x, i):
    """True when point i's simplified relative trajectory cannot reach volume v.

    With a = |p0 - c0| (start, start pose), b = |p1 - c1| (end, end pose) and L an upper bound
    of the relative trajectory |p1 - p0'| (point sweep + centre displacement + a times the
    chord 2 sin(theta/2) of the volume's rotation over the substep), every point of the
    segment p0' -> p1 is at least (a + b - L) / 2 from the centre. That covers the static test
    too (b >= (a + b - L) / 2), so rejecting never changes a result.
    """
    pos0, pos1 = vol.pos0, vol.pos1
    a = math.sqrt((xs[i, 0] - pos0[v, 0]) ** 2 + (xs[i, 1] - pos0[v, 1]) ** 2 + (xs[i, 2] - pos0[v, 2]) ** 2)
    b = math.sqrt((x[i, 0] - pos1[v, 0]) ** 2 + (x[i, 1] - pos1[v, 1]) ** 2 + (x[i, 2] - pos1[v, 2]) ** 2)
    sweep = math.sqrt((x[i, 0] - xs[i, 0]) ** 2 + (x[i, 1] - xs[i, 1]) ** 2 + (x[i, 2] - xs[i, 2]) ** 2)
    bound = sweep + vol.displacement[v] + a * vol.chord[v]
    return 0.5 * (a + b - bound) > vol.bounding_radii[v] * (1.0 + 1e-9) + 1e-12


@kernel
def out_of_reach(vol, v, x, i):
    """Beyond ``reach_radii``: point i's substep cannot touch volume v."""
    pos1, reach = vol.pos1, vol.reach
    return (x[i, 0] - pos1[v, 0]) ** 2 + (x[i, 1] - pos1[v, 1]) ** 2 + (x[i, 2] - pos1[v, 2]) ** 2 > reach[v] * reach[v]


@kernel
def outside_bounding_sphere(vol, v, x, i):
    """Point i is outside volume v's bounding sphere at the end pose."""
    pos, bounding_radii = vol.pos1, vol.bounding_radii
    d2 = (x[i, 0] - pos[v, 0]) ** 2 + (x[i, 1] - pos[v, 1]) ** 2 + (x[i, 2] - pos[v, 2]) ** 2
    return d2 > bounding_radii[v] * bounding_radii[v]


# Local boxes are this much larger than the volume: capsule entry stops _TRACE_TOLERANCE short of the
# surface, and a dynamic entry point is computed on the segment up to rounding.
_BOX_MARGIN = 1e-6


@kernel
def local_boxes(kinds, radii, cuts, boxes):
    """Per volume, ``(lo_x, lo_y, lo_z, hi_x, hi_y, hi_z)`` in its local frame: a box holding every point
    that can count as inside it or as a dynamic entry point (ellipsoids: within the cut only)."""
    for v in range(kinds.shape[0]):
        if kinds[v] == CAPSULE:
            r = max(radii[v, 0], radii[v, 1])
            hx, hy, lo_z, hi_z = r, r, -radii[v, 2] - r, radii[v, 2] + r
        elif kinds[v] == ELLIPSOID:
            hx, hy = radii[v, 0], radii[v, 1]
            lo_z, hi_z = max(-radii[v, 2], cuts[v, 0]), min(radii[v, 2], cuts[v, 1])
        else:  # sphere: radii[v, 0] for the static test, all three for the quadric entry
            r = max(radii[v, 0], max(radii[v, 1], radii[v, 2]))
            hx, hy, lo_z, hi_z = r, r, -r, r
        margin = _BOX_MARGIN + 1e-9 * max(hx, max(hy, max(-lo_z, hi_z)))
        boxes[v, 0], boxes[v, 1], boxes[v, 2] = -hx - margin, -hy - margin, lo_z - margin
        boxes[v, 3], boxes[v, 4], boxes[v, 5] = hx + margin, hy + margin, hi_z + margin


@kernel
def segment_misses_box(boxes, v, ax, ay, az, bx, by, bz):
    """True when the local segment a -> b lies wholly outside volume v's local box (then neither the
    static test of b nor the dynamic one of the segment can hit: both points lie on the segment)."""
    return (min(ax, bx) > boxes[v, 3] or max(ax, bx) < boxes[v, 0]
            or min(ay, by) > boxes[v, 4] or max(ay, by) < boxes[v, 1]
            or min(az, bz) > boxes[v, 5] or max(az, bz) < boxes[v, 2])


@kernel
def substep_motion(pos0, rot0, pos1, rot1, displacement, chord):
    """Per volume: centre displacement and rotation chord 2 sin(theta/2) = sqrt(3 - tr(R1 R0^T))."""
    for v in range(pos0.shape[0]):
        displacement[v] = math.sqrt((pos1[v, 0] - pos0[v, 0]) ** 2 + (pos1[v, 1] - pos0[v, 1]) ** 2
                                    + (pos1[v, 2] - pos0[v, 2]) ** 2)
        trace = 0.0
        for r in range(3):
            for c in range(3):
                trace += rot1[v, r, c] * rot0[v, r, c]
        chord[v] = math.sqrt(max(0.0, 3.0 - trace)) * (1.0 + 1e-9) + 1e-12


@kernel
def reach_radii(vol, xs, x, inv_mass):
    """Per volume, the distance from its end-pose centre beyond which no point's substep can touch it.

    The relative trajectory ends at p1 and is at most L = s + d + a c long (``broad_phase_rejects``),
    with a <= b + s + d (triangle inequality), so it keeps at least b - L from the centre; it cannot
    reach the bounding sphere R when b (1 - c) > R + (s + d)(1 + c), with s the largest sweep of any
    free point this substep. One squared distance per pair then rejects the far ones. Writes ``vol.reach``."""
    sweep2 = 0.0
    for i in range(x.shape[0]):
        if inv_mass[i] == 0.0:
            continue
        d2 = (x[i, 0] - xs[i, 0]) ** 2 + (x[i, 1] - xs[i, 1]) ** 2 + (x[i, 2] - xs[i, 2]) ** 2
        if d2 > sweep2:
            sweep2 = d2
    sweep = math.sqrt(sweep2)
    bounding_radii, displacement, chord, reach = vol.bounding_radii, vol.displacement, vol.chord, vol.reach
    for v in range(bounding_radii.shape[0]):
        c = chord[v]
        if c >= 0.5:
            reach[v] = math.inf
        else:
            reach[v] = (bounding_radii[v] + (sweep + displacement[v]) * (1.0 + c)) / (1.0 - c) * (1.0 + 1e-9) + 1e-12


# ----------------------------------------------------------------------------- pose interpolation

@kernel
def interpolate_poses(pos_a, quat_a, pos_b, quat_b, fraction, out_pos, out_rot):
    """Poses at ``fraction`` between a and b: translation linear, rotation slerp (shorter arc),
    written as positions and rotation matrices into the preallocated outputs."""
    for v in range(pos_a.shape[0]):
        for k in range(3):
            out_pos[v, k] = pos_a[v, k] + fraction * (pos_b[v, k] - pos_a[v, k])
        qx, qy, qz, qw = quat.slerp(quat_a[v, 0], quat_a[v, 1], quat_a[v, 2], quat_a[v, 3],
                                    quat_b[v, 0], quat_b[v, 1], quat_b[v, 2], quat_b[v, 3], fraction)
        quat.matrix_into(out_rot, v, qx, qy, qz, qw)
