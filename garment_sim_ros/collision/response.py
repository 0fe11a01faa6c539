"""Numba kernels: one mass point against one quadric volume (memo §6.2) -- the test, and the response.

Volumes as one ``VolumeArrays`` bundle (``vol``: shapes, and poses at the substep's start and end);
the local geometry is ``collision.geometry``'s. Everything is computed in the volume's local frame at
the substep END pose, which is the frame the memo's simplified relative trajectory ``p0' -> p1``
lives in. The drivers over all points and edges are in ``collision.kernels``.

Physical choices where the memo's text is loose (each is marked "physics:" below):
- the velocity response is relative to the velocity of the volume's surface at the contact
  point (a swinging leg drags its surface along), and only an approaching normal velocity is
  removed: a point inside but already separating keeps its velocity (no impulse, no friction);
- the point is put ``eps`` outside along the surface normal (the memo's Eq. 6-4 adds eps to x
  and y separately, which is not a distance);
- the slide after a dynamic hit (Eq. 6-8) uses the velocity relative to the surface: the point
  already moves with the volume by being attached to it at the end pose.
"""

from __future__ import annotations

import math

from .geometry import (
    entry,
    inlined_kernel,
    kernel,
    penetration_depth,
    plane_gap,
    rotate,
    static_projection,
    surface_at,
    to_local,
    to_world,
)
from .volumes import ELLIPSOID

NO_HIT = 0
STATIC_HIT = 1
DYNAMIC_HIT = 2

MODE_ADAPTIVE = 0
MODE_STATIC = 1
MODE_DYNAMIC = 2


# ----------------------------------------------------------------------------- response

@kernel
def respond_velocity(vx, vy, vz, sx, sy, sz, nx, ny, nz, friction):
    """Memo Eq. 6-2 / 6-8 relative to the surface velocity s, normal n (unit, outward).

    Returns the new RELATIVE velocity: perfectly inelastic (an approaching normal part is
    removed) and the tangential part scaled by the modified Coulomb factor
    ``c = 1 - k_f |v_n| / |v_t|`` if ``|v_t| >= k_f |v_n|`` else 0. The velocity responded is
    the one the point carries into the next substep (after the length correction, Eq. 5-2).
    """
    rx, ry, rz = vx - sx, vy - sy, vz - sz
    vn = rx * nx + ry * ny + rz * nz
    if vn >= 0.0:  # physics: separating (or resting) relative to the surface: no impulse
        return rx, ry, rz
    tx, ty, tz = rx - vn * nx, ry - vn * ny, rz - vn * nz
    vt = math.sqrt(tx * tx + ty * ty + tz * tz)
    if vt >= friction * -vn and vt > 0.0:
        c = 1.0 - friction * -vn / vt
    else:
        c = 0.0
    return c * tx, c * ty, c * tz


@kernel
def surface_velocity(vol, v, lx, ly, lz, h):
    """Velocity of the volume's material point with local coordinates l over the substep."""
    if h <= 0.0:
        return 0.0, 0.0, 0.0
    ax, ay, az = to_world(vol.pos0, vol.rot0, v, lx, ly, lz)
    bx, by, bz = to_world(vol.pos1, vol.rot1, v, lx, ly, lz)
    return (bx - ax) / h, (by - ay) / h, (bz - az) / h


# A point inside an ellipsoid that came in through one of its cut planes this substep leaves through that
# plane when the static projection (keep z, out across the cross-section) would move it further than this
# share of the volume's smaller radius; nearer the surface it leaves across it, as the memo does. Trousers,
# 9 clips x 1-3x x 60/30 fps, 3 s: guard firings 96 -> 39 (38 on the cartwheel), frames with a leg off
# 246 -> 135. Without the share (any point that came through a cut) hem points at the shins' ankle cut
# went out under the shin and the walks at 30 fps lost a trouser leg (CC walk 1x/2x: 19, 36 frames).
_CUT_EXIT_SHARE = 0.5
# A point inside a trunk volume within ``open_cut_band`` (grip[3]) of an open cut (``_cut_is_open``: the pelvis'
# bottom, between the thighs) leaves through it when the static projection would move it more than this many
# collision epsilons: the taut seat of a crouch lies on that face and each length-correction sweep pulled a point a
# few mm up through it, which the projection put 31-72 mm sideways onto the rim (CC jump: springs at 4-7 rest
# lengths). The full protocol over three nudged starts (648 runs), with ``band_gives_way``: passed 423 -> 431, bone
# frames 316 -> 130; alone 423 -> 429, bone frames 292 (docs/real_motion.md, "Two rules on by default").
_CUT_NEAR_MOVES = 4.0
_ON_PLANE = 1e-9  # m: a static projection this near a contact plane went onto it


@inlined_kernel
def handle_pair(vol, v, xs, x, vel, i, h, eps, friction, grip, c_time, switch_ratio, mode):
    """Handle point ``i`` against volume ``v``; ``x``, ``vel`` updated in place; ``grip`` the position-level
    friction coefficients (``contact_friction``, ``axial_friction``; see ``_respond``), the tube bits and
    ``open_cut_band``.

    ``xs[i]`` is the point at the substep start, ``x[i]`` at its end. Returns
    ``(code, alpha, lx, ly, lz)``: NO_HIT / STATIC_HIT / DYNAMIC_HIT, the collision time
    fraction (dynamic) and the contact point (on the surface, before eps) in the local frame
    of the substep-end pose.
    """
    # p0 in the start pose's local frame = p0' in the end pose's local frame (memo §6.2.1)
    ax, ay, az = to_local(vol.pos0, vol.rot0, v, xs[i, 0], xs[i, 1], xs[i, 2])
    bx, by, bz = to_local(vol.pos1, vol.rot1, v, x[i, 0], x[i, 1], x[i, 2])
    return handle_local_pair(vol, v, x, vel, i, ax, ay, az, bx, by, bz, h, eps, friction, grip, c_time,
                             switch_ratio, mode)


# Inlined in numba's IR into every caller: left to LLVM, which did not inline it once ``handle_pair`` wrapped it,
# handle_contacts ran 13 % slower (20 000 points, one thread, /tmp/w15h-micro.py).
@inlined_kernel
def handle_local_pair(vol, v, x, vel, i, ax, ay, az, bx, by, bz, h, eps, friction, grip, c_time, switch_ratio,
                      mode):
    """``handle_pair`` given point i's local coordinates in volume v's frame: p0' = ``a`` (``xs[i]``, start
    pose) and p1 = ``b`` (``x[i]``, end pose), as a caller that has them already (the broad phase's box test)
    passes them rather than rotating the point again."""
    kinds, radii, cuts, planes = vol.kinds, vol.radii, vol.cuts, vol.planes
    kind = kinds[v]
    use_dynamic = mode == MODE_DYNAMIC
    if mode == MODE_ADAPTIVE or use_dynamic:
        if mode == MODE_ADAPTIVE:
            trajectory = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
            use_dynamic = trajectory > switch_ratio * vol.switch_radii[v]
        if use_dynamic:
            alpha, face = entry(kind, radii, cuts, planes, v, ax, ay, az, bx, by, bz)
            if alpha >= 0.0:
                sx, sy, sz, nx, ny, nz = surface_at(kind, radii, planes, v, face, ax + alpha * (bx - ax),
                                                    ay + alpha * (by - ay), az + alpha * (bz - az))
                _respond(vol, v, x, vel, i, ax, ay, az, bx, by, bz, sx, sy, sz, nx, ny, nz, eps, friction, grip,
                         h, c_time * (1.0 - alpha) * h)
                return DYNAMIC_HIT, alpha, sx, sy, sz
    inside, sx, sy, sz, nx, ny, nz = static_projection(kind, radii, cuts, planes, v, bx, by, bz)
    if not inside:
        return NO_HIT, -1.0, bx, by, bz
    reach = _CUT_EXIT_SHARE * min(radii[v, 0], radii[v, 1])
    move = (sx - bx) ** 2 + (sy - by) ** 2
    far = move > reach * reach
    # a trunk volume's cut, no bone continuing through it, with the rule on (off: the block below as without it)
    trunk_cut = (grip[3] > 0.0 and move > _CUT_NEAR_MOVES * _CUT_NEAR_MOVES * eps * eps
                 and math.isnan(vol.bones[v, 0]))
    if (kind == ELLIPSOID and (far or trunk_cut)
            and abs(plane_gap(planes, v, sx, sy, sz)[0]) > _ON_PLANE):  # not onto a contact plane
        # A point that came in through a cut plane this substep and would go far goes back out through it, not
        # across the cross-section: a crotch seam a few mm up into the pelvis was thrown 14 cm across a thigh.
        # Within ``open_cut_band`` (grip[3]) of an open cut, it leaves through the cut: no bone continues through it
        # and the middle of its face lies in no other volume (the pelvis' bottom, between the thighs; not its top,
        # in the torso, nor the chest's top under a neck: the cartwheel's one-piece went into the neck and the head
        # that way, and from them 15.8 mm into the chest).
        came_through, side = True, 0.0
        if far and az < cuts[v, 0] and cuts[v, 0] > -radii[v, 2]:
            side = -1.0
        elif far and az > cuts[v, 1] and cuts[v, 1] < radii[v, 2]:
            side = 1.0
        elif trunk_cut and bz - grip[3] < cuts[v, 0] and cuts[v, 0] > -radii[v, 2]:
            came_through, side = False, -1.0
        elif trunk_cut and bz + grip[3] > cuts[v, 1] and cuts[v, 1] < radii[v, 2]:
            came_through, side = False, 1.0
        exit_z = cuts[v, 0] if side < 0.0 else cuts[v, 1]
        if side != 0.0 and (came_through or _cut_is_open(vol, v, exit_z, side, eps)):
            sx, sy, sz, nx, ny, nz = bx, by, exit_z, 0.0, 0.0, side
    _respond(vol, v, x, vel, i, ax, ay, az, bx, by, bz, sx, sy, sz, nx, ny, nz, eps, friction, grip, h, 0.0)
    return STATIC_HIT, 1.0, sx, sy, sz


@kernel
def _cut_is_open(vol, v, z, side, eps):
    """Whether the middle of volume v's cut face at local ``z`` (m; ``side`` +1: its top, -1: its bottom), ``eps``
    (m) beyond the face, lies in no other volume (end pose): nothing on the body continues through it."""
    px, py, pz = to_world(vol.pos1, vol.rot1, v, 0.0, 0.0, z + side * eps)
    return depth_elsewhere(vol, v, px, py, pz) == 0.0


@kernel
def depth_elsewhere(vol, v, px, py, pz):
    """Depth (m) of the simulation-frame point p in the deepest volume other than v (end poses): what a move
    out of v costs in a pinch (``crossing``, ``kernels.handle_edges``)."""
    return deepest_elsewhere(vol, v, px, py, pz)[0]


@kernel
def deepest_elsewhere(vol, v, px, py, pz):
    """``(depth, o)``: ``depth_elsewhere`` and the volume o it is in (-1: none; v = -1: any volume)."""
    deepest, which = 0.0, -1
    for o in range(vol.kinds.shape[0]):
        if o == v:
            continue
        depth = depth_in(vol, o, px, py, pz)
        if depth > deepest:
            deepest, which = depth, o
    return deepest, which


@kernel
def depth_in(vol, o, px, py, pz):
    """Depth (m) of the simulation-frame point p in volume o (end pose); 0 outside its bounding sphere."""
    pos = vol.pos1
    if (px - pos[o, 0]) ** 2 + (py - pos[o, 1]) ** 2 + (pz - pos[o, 2]) ** 2 > vol.bounding_radii[o] ** 2:
        return 0.0
    lx, ly, lz = to_local(pos, vol.rot1, o, px, py, pz)
    return penetration_depth(vol.kinds[o], vol.radii, vol.cuts, vol.planes, o, lx, ly, lz)


@kernel
def _respond(vol, v, x, vel, i, ax, ay, az, bx, by, bz, sx, sy, sz, nx, ny, nz, eps, friction, grip, h, slide_time):
    """Put point i (local p0' = ``a``, p1 = ``b``, as in ``handle_local_pair``) at the local surface point
    s + eps n (end pose), respond its velocity, and slide it for ``slide_time`` with the new velocity relative
    to the surface (Eq. 6-8).

    physics: eps is a distance along the normal (not the memo's eps per coordinate); the slide
    is relative to the surface, since sitting at the end pose already carries the point along;
    the surface velocity is the one of the volume's material point at the contact.

    ``grip`` (isotropic, along the axis): position-level friction (Macklin et al. 2014, "Unified particle
    physics", §6.1), as the velocity-level law above cannot be: a point the length correction's contact handling
    put back out is outside when the full handling responds velocities, and its velocity is then the corrected
    positions' (Eq. 5-2), so the Coulomb response never reaches it (the drape's sheet slid off the sphere). The
    point's slide relative to the surface over the substep -- from where it started (``xs[i]``, start pose) to
    the contact point (end pose), both in the volume's frame -- is undone up to ``grip[0]`` times the depth it
    was pushed out by along the normal: all of it below that (static), that much of it above (kinetic); the
    tangential velocity relative to the surface keeps the same share. Then, for the points of a limb tube on the
    limbs it goes round (bit v of ``grip[2][i]``, ``Collider.grip_tubes``), what is left of that slide along the
    volume's axis (local z, the bone's, from the joint down the limb; in the tangent plane) is undone up to
    ``grip[1]`` times the depth where it runs toward the limb's root, and the relative velocity along the axis
    keeps that share: a limb moving along itself carries its trouser leg, and the length correction does not
    slide a ring it grips up the limb; down it the ring slides freely (issue 11 (d), docs/real_motion.md). The
    slide runs to the contact point, as the isotropic one's: measured from ``b`` instead (the point's own move),
    a swept hit's slide past the entry was undone too.
    """
    cx, cy, cz = sx + eps * nx, sy + eps * ny, sz + eps * nz
    kept = 1.0  # share of the tangential slide (and relative tangential velocity) the position friction leaves
    kept_axial = 1.0  # and then of what is left of it along the axis
    ex, ey, ez = -nz * nx, -nz * ny, 1.0 - nz * nz  # the axis in the tangent plane, unnormalised
    if grip[0] > 0.0 or grip[1] > 0.0:
        depth = (cx - bx) * nx + (cy - by) * ny + (cz - bz) * nz
        dx, dy, dz = cx - ax, cy - ay, cz - az
        along = dx * nx + dy * ny + dz * nz
        tx, ty, tz = dx - along * nx, dy - along * ny, dz - along * nz
        slide = math.sqrt(tx * tx + ty * ty + tz * tz)
        if depth > 0.0 and slide > 0.0 and grip[0] > 0.0:
            kept = max(0.0, 1.0 - grip[0] * depth / slide)
            cx, cy, cz = cx - (1.0 - kept) * tx, cy - (1.0 - kept) * ty, cz - (1.0 - kept) * tz
        axis = math.sqrt(ex * ex + ey * ey + ez * ez)  # 0 on a cap's pole, where the normal is the axis
        if depth > 0.0 and grip[1] > 0.0 and axis > 1e-9 and (grip[2][i] >> v) & 1:
            ex, ey, ez = ex / axis, ey / axis, ez / axis
            slide = kept * (tx * ex + ty * ey + tz * ez)
            if slide < 0.0:  # toward the limb's root (local z runs from the joint down the limb)
                kept_axial = max(0.0, 1.0 - grip[1] * depth / abs(slide))
                cx, cy, cz = (cx - (1.0 - kept_axial) * slide * ex, cy - (1.0 - kept_axial) * slide * ey,
                              cz - (1.0 - kept_axial) * slide * ez)
    svx, svy, svz = surface_velocity(vol, v, cx, cy, cz, h)
    wnx, wny, wnz = rotate(vol.rot1, v, nx, ny, nz)
    rx, ry, rz = respond_velocity(vel[i, 0], vel[i, 1], vel[i, 2], svx, svy, svz, wnx, wny, wnz, friction)
    if kept < 1.0:
        rn = rx * wnx + ry * wny + rz * wnz
        rx, ry, rz = (rn * wnx + kept * (rx - rn * wnx), rn * wny + kept * (ry - rn * wny),
                      rn * wnz + kept * (rz - rn * wnz))
    if kept_axial < 1.0:
        wex, wey, wez = rotate(vol.rot1, v, ex, ey, ez)
        re = (1.0 - kept_axial) * (rx * wex + ry * wey + rz * wez)
        rx, ry, rz = rx - re * wex, ry - re * wey, rz - re * wez
    px, py, pz = to_world(vol.pos1, vol.rot1, v, cx, cy, cz)
    x[i, 0] = px + slide_time * rx
    x[i, 1] = py + slide_time * ry
    x[i, 2] = pz + slide_time * rz
    vel[i, 0] = svx + rx
    vel[i, 1] = svy + ry
    vel[i, 2] = svz + rz
