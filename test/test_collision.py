"""Collision handling against quadric volumes (memo §6.2): each equation against a hand-computed
case, the dynamic method against exact solutions, the adaptive switch, the cache and the broad
phase."""

import math

import numpy as np
import pytest

from garment_sim_ros.collision.collider import Collider
from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID, SPHERE, Volume, VolumeSet
from garment_sim_ros.params import DEFAULT_PARAMS
from garment_sim_ros.transforms import (
    IDENTITY_QUAT,
    quat_conjugate,
    quat_from_axis_angle,
    quat_rotate,
    quat_slerp,
    quat_to_matrix,
)

H = 0.01


def make_collider(volumes, n_points, pos0, rot0=None, pos1=None, rot1=None, cache_size=1, **params):
    volume_set = VolumeSet(tuple(volumes))
    collider = Collider(volume_set, n_points, cache_size=cache_size)
    collider.set_params(DEFAULT_PARAMS.replace(**params))
    n = len(volume_set)
    pos0 = np.asarray(pos0, dtype=float).reshape(n, 3)
    rot0 = np.tile(IDENTITY_QUAT, (n, 1)) if rot0 is None else np.asarray(rot0, dtype=float).reshape(n, 4)
    pos1 = pos0 if pos1 is None else np.asarray(pos1, dtype=float).reshape(n, 3)
    rot1 = rot0 if rot1 is None else np.asarray(rot1, dtype=float).reshape(n, 4)
    collider.begin_frame(pos0, rot0, pos1, rot1)
    collider.begin_substep(0.0, 1.0)
    return collider


def handle(collider, x_start, x, v=None, h=H, inv_mass=None, contacts=None):
    """``collider.handle_all`` on copies of the points; ``contacts`` (the garment's cache, kept across calls
    by the caller) or a fresh one."""
    x_start = np.array(x_start, dtype=float).reshape(-1, 3)
    x = np.array(x, dtype=float).reshape(-1, 3)
    v = np.zeros_like(x) if v is None else np.array(v, dtype=float).reshape(-1, 3)
    inv_mass = np.ones(len(x)) if inv_mass is None else np.asarray(inv_mass, dtype=float)
    collider.handle_all(x_start, x, v, inv_mass, h, collider.new_contacts() if contacts is None else contacts)
    return x, v


def sphere(r=0.1, name="s"):
    return Volume(name, SPHERE, "f", (r, r, r))


def coulomb(v_rel, n, kf):
    """Memo Eq. 6-2 by hand: normal part removed, tangential scaled by the modified Coulomb factor."""
    vn = np.dot(v_rel, n) * n
    vt = v_rel - vn
    ratio = kf * np.linalg.norm(vn) / np.linalg.norm(vt)
    return (1.0 - ratio) * vt if ratio <= 1.0 else np.zeros(3)


# ----------------------------------------------------------------------------- static handling

def test_sphere_point_is_projected_radially_to_r_plus_eps():
    centre = np.array([1.0, 2.0, 3.0])
    c = make_collider([sphere(0.1)], 1, centre, collision_mode="static", collision_epsilon=0.003)
    p = centre + [0.03, 0.04, 0.0]  # 5 cm from the centre, along (0.6, 0.8, 0)
    x, _ = handle(c, p, p)
    np.testing.assert_allclose(x[0], centre + 0.103 * np.array([0.6, 0.8, 0.0]), atol=1e-12)
    assert c.static_hits == 1 and c.dynamic_hits == 0


def test_outside_point_is_untouched():
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static")
    p = [0.0, 0.0, 0.1001]
    x, v = handle(c, p, p, v=[1.0, 2.0, 3.0])
    np.testing.assert_array_equal(x[0], p)
    np.testing.assert_array_equal(v[0], [1.0, 2.0, 3.0])
    assert c.static_hits == 0


@pytest.mark.parametrize("v_in, kf", [((-1.0, 0.5, 0.0), 0.2),   # sliding: |v_t| >= k_f |v_n|
                                      ((-0.52, -0.86, 0.0), 0.5)])  # sticking: |v_t| = 0.1 < k_f |v_n| = 0.5
def test_coulomb_friction_both_branches(v_in, kf):
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static", friction=kf, collision_epsilon=0.0)
    n = np.array([0.6, 0.8, 0.0])
    x, v = handle(c, 0.05 * n, 0.05 * n, v=v_in)
    expected = coulomb(np.array(v_in), n, kf)
    np.testing.assert_allclose(v[0], expected, atol=1e-12)
    if kf == 0.5:
        np.testing.assert_array_equal(v[0], 0.0)
    else:  # the hand numbers: v_n = -0.2 n, v_t = (-0.88, 0.66, 0), c = 1 - 0.04 / 1.1
        np.testing.assert_allclose(v[0], (1 - 0.04 / 1.1) * np.array([-0.88, 0.66, 0.0]), atol=1e-12)


def test_separating_point_keeps_its_velocity():
    # inside (pushed there by the length correction, say) but already moving outwards: no impulse
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static", collision_epsilon=0.0)
    x, v = handle(c, [0.05, 0, 0], [0.05, 0, 0], v=[1.0, 0.3, 0.0])
    np.testing.assert_allclose(x[0], [0.1, 0, 0])
    np.testing.assert_array_equal(v[0], [1.0, 0.3, 0.0])


def test_ellipsoid_keeps_z_and_scales_xy_onto_the_cross_section():
    radii = (0.08, 0.06, 0.2)
    e = Volume("e", ELLIPSOID, "f", radii, cut=(-0.15, 0.15))
    c = make_collider([e], 1, [0, 0, 0], collision_mode="static", collision_epsilon=0.0, axial_friction=0.0)
    x, _ = handle(c, [0.02, 0.03, 0.1], [0.02, 0.03, 0.1])
    # Eq. 6-4 by hand: s = sqrt(1 - (0.1/0.2)^2) / sqrt((0.02/0.08)^2 + (0.03/0.06)^2)
    s = math.sqrt(0.75) / math.sqrt(0.25 ** 2 + 0.5 ** 2)
    np.testing.assert_allclose(x[0], [0.02 * s, 0.03 * s, 0.1], atol=1e-12)


def test_ellipsoid_eps_is_along_the_surface_normal():
    radii = np.array([0.08, 0.06, 0.2])
    e = Volume("e", ELLIPSOID, "f", tuple(radii))
    c = make_collider([e], 1, [0, 0, 0], collision_mode="static", collision_epsilon=0.004, axial_friction=0.0)
    x, _ = handle(c, [0.02, 0.03, 0.1], [0.02, 0.03, 0.1])
    s = math.sqrt(0.75) / math.sqrt(0.25 ** 2 + 0.5 ** 2)
    surface = np.array([0.02 * s, 0.03 * s, 0.1])
    gradient = surface / radii ** 2
    np.testing.assert_allclose(x[0], surface + 0.004 * gradient / np.linalg.norm(gradient), atol=1e-12)


def test_ellipsoid_cut_ends_are_respected():
    p = [0.01, 0.0, 0.17]  # inside the full ellipsoid, beyond the cut at z = 0.15
    kept = make_collider([Volume("e", ELLIPSOID, "f", (0.08, 0.06, 0.2), cut=(-0.15, 0.15))], 1, [0, 0, 0],
                         collision_mode="static")
    x, _ = handle(kept, p, p)
    np.testing.assert_array_equal(x[0], p)
    assert kept.penetration_depths(np.array([p]))[0] == 0.0
    handled = make_collider([Volume("e", ELLIPSOID, "f", (0.08, 0.06, 0.2), cut=(-0.15, 0.18))], 1, [0, 0, 0],
                            collision_mode="static", collision_epsilon=0.0, axial_friction=0.0)
    x, _ = handle(handled, p, p)
    assert x[0, 2] == pytest.approx(0.17) and x[0, 0] > 0.01


def test_a_point_by_an_open_cut_leaves_through_it_but_not_through_a_cut_another_volume_covers():
    # 1 mm under a trunk volume's top cut, no bone going on through it: the cut is the nearest way out
    chest = Volume("chest", ELLIPSOID, "f", (0.1, 0.15, 0.3), cut=(-0.15, 0.15))
    p = [0.02, 0.03, 0.149]
    alone = make_collider([chest], 1, [0, 0, 0], collision_mode="static", open_cut_band=0.003)
    x, _ = handle(alone, p, p)
    np.testing.assert_allclose(x[0], [0.02, 0.03, 0.15 + alone._eps], atol=1e-12)
    # a volume over the middle of the cut's face (a neck on the chest): the cut is not open; the point goes across
    # the cross-section (z kept, x and y scaled onto it, eps along the normal), in neither volume (the cartwheel's
    # one-piece at 3x 30 fps went out through the chest's top into the neck and the head, then 15.8 mm into the chest)
    neck = [0.0, 0.0, 0.23]
    covered = make_collider([chest, sphere(0.088, "neck")], 1, [[0, 0, 0], neck], collision_mode="static",
                            open_cut_band=0.003)
    assert np.linalg.norm(np.subtract(p, neck)) > 0.088 > np.linalg.norm(np.subtract(x[0], neck))  # in the chest only
    x, _ = handle(covered, p, p)
    assert covered.static_hits == 1 and covered.penetration_depths(x)[0] == 0.0
    assert abs(x[0, 2] - 0.149) <= covered._eps and x[0, 1] / x[0, 0] == pytest.approx(1.5, rel=0.05)
    assert np.hypot(x[0, 0], x[0, 1]) > 3.0 * np.hypot(0.02, 0.03)


def test_response_is_relative_to_a_translating_surface():
    # a sphere moving +x at 2 m/s runs into a resting point: the point leaves with the surface
    h = 0.01
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], pos1=[0.02, 0, 0], collision_mode="static",
                      collision_epsilon=0.0, friction=0.3)
    p = [0.11, 0.0, 0.0]  # 1 cm inside at the end pose
    x, v = handle(c, p, p, v=[0.0, 0.5, 0.0], h=h)
    np.testing.assert_allclose(x[0], [0.12, 0, 0], atol=1e-12)
    # relative velocity (-2, 0.5, 0): v_n = (-2, 0, 0) removed, v_t = (0, 0.5, 0) scaled by
    # 1 - 0.3 * 2 / 0.5 < 0 -> sticks: the point moves with the surface
    np.testing.assert_allclose(v[0], [2.0, 0.0, 0.0], atol=1e-12)
    # with less friction it slides: c = 1 - 0.1 * 2 / 0.5 = 0.6
    c.set_params(DEFAULT_PARAMS.replace(collision_mode="static", collision_epsilon=0.0, friction=0.1))
    x, v = handle(c, p, p, v=[0.0, 0.5, 0.0], h=h)
    np.testing.assert_allclose(v[0], [2.0, 0.3, 0.0], atol=1e-12)


def position_friction(start, end, centre, r, grip):
    """Position-level friction (``contact_friction``) by hand for a static hit on a still sphere, eps 0:
    the end point goes radially onto the surface (depth d), then its slide t from the start along the
    tangent plane there is undone up to ``grip * d``."""
    u = (end - centre) / np.linalg.norm(end - centre)
    contact = centre + r * u
    depth = r - np.linalg.norm(end - centre)
    slide = (contact - start) - np.dot(contact - start, u) * u
    return contact - min(1.0, grip * depth / np.linalg.norm(slide)) * slide


@pytest.mark.parametrize("grip, sticks", [(0.6, True),  # |t| ~ 1 mm < 0.6 x 2 mm
                                          (0.2, False)])  # kinetic: 0.4 mm of the slide undone
def test_position_friction_undoes_the_slide_up_to_grip_times_depth(grip, sticks):
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static", collision_epsilon=0.0, friction=0.0,
                      contact_friction=grip, axial_friction=0.0)
    start, end = np.array([0.0, 0.0, 0.1]), np.array([0.001, 0.0, 0.098])
    x, v = handle(c, start, end, v=[0.1, 0.0, -0.2])
    np.testing.assert_allclose(x[0], position_friction(start, end, np.zeros(3), 0.1, grip), atol=1e-12)
    assert np.linalg.norm(x[0]) == pytest.approx(0.1, abs=1e-5)  # on the surface (its tangent plane)
    normal = x[0] / np.linalg.norm(x[0])
    tangential = v[0] - np.dot(v[0], normal) * normal
    if sticks:  # static: back where it started along the surface, no sliding velocity left
        np.testing.assert_allclose(x[0], start, atol=1e-5)
        np.testing.assert_allclose(tangential, 0.0, atol=1e-12)
    else:
        assert 0.0 < np.linalg.norm(tangential) < 0.1


@pytest.mark.parametrize("grip", [0.0, 0.5])
def test_position_friction_holds_a_point_on_a_slope(grip):
    """A point resting 20 deg down a still sphere's side, gravity on, 1 s of 1 ms steps (the solver's order:
    step, handle, velocity from the positions): tan 20 deg = 0.36 < 0.5 holds it; without the position
    friction, and without the velocity-level one (0 here), it slides off."""
    r, angle, h = 0.1, math.radians(20.0), 0.001
    c = make_collider([sphere(r)], 1, [0, 0, 0], collision_epsilon=0.0, friction=0.0, contact_friction=grip,
                      axial_friction=0.0)
    x = r * np.array([[math.sin(angle), 0.0, math.cos(angle)]])
    v, contacts = np.zeros((1, 3)), c.new_contacts()
    for _ in range(1000):
        x_start = x.copy()
        x = x + h * (v + h * np.array([0.0, 0.0, -9.81]))
        c.handle_all(x_start, x, np.zeros((1, 3)), np.ones(1), h, contacts)
        v = (x - x_start) / h
    moved = np.linalg.norm(x[0] - r * np.array([math.sin(angle), 0.0, math.cos(angle)]))
    if grip > 0.0:
        assert moved < 1e-4
    else:
        assert moved > 0.05


@pytest.mark.parametrize("limb_moves, gripped, carried", [
    (0.004, True, True),  # the limb slides down under its tube's point: it takes the point along
    (-0.004, True, False),  # up under it (the point slides down the limb): free, the velocity-level law only
    (0.004, False, False),  # a point of no tube round this limb (a skirt, a waistband): free
])
def test_friction_along_a_limb_holds_its_tube_against_a_slide_toward_the_root(limb_moves, gripped, carried):
    """``axial_friction``: a tube's point pressed 5 mm into its limb (local z runs from the joint down the limb)
    keeps its place along the limb up to the coefficient x that depth (1 x 5 mm here, the slide 4 mm) where it
    would slide toward the limb's root; down the limb, or off a tube, it slides."""
    limb = Volume("limb", CAPSULE, "f", (0.05, 0.05, 0.1))
    c = make_collider([limb], 1, [0, 0, 0], pos1=[0, 0, limb_moves], collision_mode="static", collision_epsilon=0.0,
                      friction=0.0, axial_friction=1.0)
    if gripped:
        c.grip_tubes({"leg": ("limb",)}, {"leg": [np.array([0])]})
    x, v = handle(c, [0.051, 0.0, 0.0], [0.045, 0.0, 0.0])
    assert x[0, 0] == pytest.approx(0.05, abs=1e-9)  # out on the surface either way
    assert x[0, 2] == pytest.approx(limb_moves if carried else 0.0, abs=1e-9)
    assert v[0, 2] == pytest.approx(limb_moves / H if carried else 0.0, abs=1e-9)


# ----------------------------------------------------------------------------- dynamic handling

def exact_translation_hit(p0, u, c0, V, R, radii, h):
    """Collision time and point (in the end pose) of a point moving at u against an ellipsoid
    translating at V with fixed orientation R: solved by hand in the volume frame."""
    rel0 = R.T @ (np.asarray(p0) - c0)
    w = R.T @ (np.asarray(u) - V)
    a = np.sum((w / radii) ** 2)
    b = 2 * np.sum(rel0 * w / radii ** 2)
    cc = np.sum((rel0 / radii) ** 2) - 1
    t = (-b - math.sqrt(b * b - 4 * a * cc)) / (2 * a)
    assert 0 <= t <= h
    local = rel0 + t * w
    return t, c0 + V * h + R @ local


def test_dynamic_detection_is_exact_for_pure_translation():
    radii = np.array([0.08, 0.06, 0.2])
    q = quat_from_axis_angle([1.0, 2.0, 0.5], 0.7)
    R = quat_to_matrix(q)
    c0, V, h = np.array([0.3, -0.2, 0.1]), np.array([1.5, -0.5, 2.0]), 0.05
    p0 = c0 + R @ np.array([0.0, 0.2, 0.05])
    u = np.array([1.0, -4.0, 1.0])
    col = make_collider([Volume("e", ELLIPSOID, "f", tuple(radii))], 1, c0, [q], c0 + V * h, [q],
                        collision_mode="dynamic", collision_epsilon=0.0, contact_time_fraction=0.0, axial_friction=0.0)
    x, _ = handle(col, p0, p0 + u * h, h=h)
    t, expected = exact_translation_hit(p0, u, c0, V, R, radii, h)
    np.testing.assert_allclose(x[0], expected, atol=1e-12)
    assert col.dynamic_hits == 1


def test_fast_point_tunnels_through_static_handling_but_not_dynamic():
    p0, p1 = [-0.3, 0.0, 0.0], [0.3, 0.0, 0.0]  # 0.6 m in one 0.01 s step through a 0.1 m sphere
    static = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static")
    x, _ = handle(static, p0, p1, v=[60.0, 0, 0])
    np.testing.assert_array_equal(x[0], p1)  # missed: it went through
    dynamic = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="dynamic", collision_epsilon=0.002)
    x, v = handle(dynamic, p0, p1, v=[60.0, 0, 0])
    # caught at alpha = 1/3 on the near side; all normal velocity removed -> no slide
    np.testing.assert_allclose(x[0], [-0.102, 0, 0], atol=1e-12)
    np.testing.assert_allclose(v[0], 0.0, atol=1e-12)


def test_dynamic_slide_after_the_hit_uses_c_time_and_the_remaining_step():
    h, kf, c_time = 0.01, 0.2, 0.5
    dynamic = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="dynamic", collision_epsilon=0.0,
                            friction=kf, contact_time_fraction=c_time)
    u = np.array([30.0, 0.0, -30.0])  # 45 deg onto the top of the sphere
    p0 = np.array([-0.25, 0.0, 0.35])  # ends at (0.05, 0, 0.05), inside
    x, v = handle(dynamic, p0, p0 + u * h, v=u, h=h)
    # hand solution: |p0 + s u_hat| = r along the line, alpha = s / |u h|
    d = u / np.linalg.norm(u)
    bq = np.dot(p0, d)
    s = -bq - math.sqrt(bq * bq - (np.dot(p0, p0) - 0.01))
    alpha = s / np.linalg.norm(u * h)
    contact = p0 + s * d
    n = contact / np.linalg.norm(contact)
    v_new = coulomb(u, n, kf)
    np.testing.assert_allclose(v[0], v_new, atol=1e-9)
    np.testing.assert_allclose(x[0], contact + c_time * (h - h * alpha) * v_new, atol=1e-9)
    assert np.linalg.norm(x[0]) >= 0.1 - 1e-12  # a tangent slide on a convex surface stays outside


def test_swinging_volume_that_sweeps_over_a_resting_point_is_caught():
    # a thigh-like ellipsoid hanging from the hip swings 90 deg forward (to +x) in one step,
    # through a resting point that is outside it at both poses
    e = Volume("thigh", ELLIPSOID, "f", (0.07, 0.07, 0.2), offset_position=(0.0, 0.0, -0.2))
    vs = VolumeSet((e,))
    pos0, rot0 = vs.world_poses(np.zeros((1, 3)), IDENTITY_QUAT[None])
    pos1, rot1 = vs.world_poses(np.zeros((1, 3)), quat_from_axis_angle([0.0, 1.0, 0.0], -math.pi / 2)[None])
    p = np.array([0.12, 0.0, -0.12])
    static = make_collider([e], 1, pos0, rot0, pos1, rot1, collision_mode="static")
    assert static.penetration_depths(p[None])[0] == 0.0
    x, _ = handle(static, p, p)
    np.testing.assert_array_equal(x[0], p)  # static handling never sees it
    adaptive = make_collider([e], 1, pos0, rot0, pos1, rot1, collision_mode="adaptive")
    x, _ = handle(adaptive, p, p)
    assert adaptive.dynamic_hits == 1
    # in the leg's frame the point ran from local x = +0.12 to -0.12 at z = 0.08: it is caught
    # on the +x side, outside the surface (carried along by the swing)
    local = quat_rotate(quat_conjugate(rot1[0]), x[0] - pos1[0])
    assert local[0] > 0.06
    assert np.sum((local / np.array([0.07, 0.07, 0.2])) ** 2) >= 1.0


# ----------------------------------------------------------------------------- adaptive switch

@pytest.mark.parametrize("end_radius, expected", [(0.0762, "static"), (0.0738, "dynamic")])
def test_adaptive_switch_follows_the_one_eighth_rule(end_radius, expected):
    # radius 0.08 -> threshold 0.01 m; the point moves 0.0088 or 0.0112 m radially inwards
    c = make_collider([sphere(0.08)], 1, [0, 0, 0], collision_mode="adaptive")
    handle(c, [0.085, 0, 0], [end_radius, 0, 0])
    assert (c.static_hits, c.dynamic_hits) == ((1, 0) if expected == "static" else (0, 1))


def test_adaptive_switch_measures_the_relative_trajectory_and_reads_the_ratio():
    # the point rests; the sphere moves 0.011 m into it: relative trajectory 0.011 > 0.08 / 8
    c = make_collider([sphere(0.08)], 1, [0, 0, 0], pos1=[0.011, 0, 0], collision_mode="adaptive")
    handle(c, [0.085, 0, 0], [0.085, 0, 0])
    assert (c.static_hits, c.dynamic_hits) == (0, 1)
    c.set_params(DEFAULT_PARAMS.replace(dynamic_switch_ratio=0.25))  # threshold 0.02 m
    c.begin_frame(np.zeros((1, 3)), IDENTITY_QUAT[None], np.array([[0.011, 0, 0]]), IDENTITY_QUAT[None])
    handle(c, [0.085, 0, 0], [0.085, 0, 0])
    assert (c.static_hits, c.dynamic_hits) == (1, 0)


# ----------------------------------------------------------------------------- cache and broad phase

def test_cached_contacts_are_handled_by_handle_contacts_only():
    vols = [sphere(0.1, "a"), sphere(0.1, "b")]
    c = make_collider(vols, 2, [[0, 0, 0], [1, 0, 0]], collision_mode="static", collision_epsilon=0.0)
    contacts = c.new_contacts()
    x, v = handle(c, [[0.05, 0, 0], [1.5, 0, 0]], [[0.05, 0, 0], [1.5, 0, 0]], contacts=contacts)
    np.testing.assert_array_equal(contacts[:, 0], [0, -1])  # point 0 hit volume a; point 1 hit nothing
    # both points are pushed inside a volume; only point 0 has a cached contact
    x = np.array([[0.0, 0.05, 0.0], [1.0, 0.05, 0.0]])
    c.handle_contacts(None, x, v, np.ones(2), H, contacts)
    np.testing.assert_allclose(x[0], [0, 0.1, 0], atol=1e-12)
    np.testing.assert_array_equal(x[1], [1.0, 0.05, 0.0])
    assert c.static_hits == 2


def test_cache_keeps_recent_hits_first_and_evicts_far_volumes():
    vols = [Volume("a", ELLIPSOID, "f", (0.05, 0.05, 0.2)), sphere(0.1, "b"), sphere(0.1, "c")]
    c = make_collider(vols, 1, [[0, 0, 0], [0.25, 0, 0], [3, 0, 0]], cache_size=2, collision_mode="static")
    contacts = c.new_contacts()
    handle(c, [0.01, 0, 0], [0.01, 0, 0], contacts=contacts)  # inside a only
    np.testing.assert_array_equal(contacts[0], [0, -1])
    handle(c, [0.16, 0, 0.0], [0.16, 0, 0.0], contacts=contacts)  # inside a's bounding sphere (kept), inside b (first)
    np.testing.assert_array_equal(contacts[0], [1, 0])
    handle(c, [2.0, 0, 0], [2.0, 0, 0], contacts=contacts)  # far from both: evicted
    np.testing.assert_array_equal(contacts[0], [-1, -1])


@pytest.mark.parametrize("margin, kept", [(0.0, False), (0.005, True)])
def test_contact_margin_keeps_a_resting_point_s_volume_cached(margin, kept):
    """A point put on a sphere, then resting 3 mm outside it: the broad phase evicts the sphere from its cache
    (so the correction's contact handling would not see it), unless within ``contact_margin``."""
    c = make_collider([sphere(0.1)], 1, [0, 0, 0], collision_mode="static", collision_epsilon=0.003,
                      contact_margin=margin)
    contacts = c.new_contacts()
    handle(c, [0.0, 0, 0.099], [0.0, 0, 0.099], contacts=contacts)
    np.testing.assert_array_equal(contacts[0], [0])
    x, _ = handle(c, [0.0, 0, 0.103], [0.0, 0, 0.103], contacts=contacts)
    np.testing.assert_array_equal(x[0], [0.0, 0, 0.103])  # outside: untouched either way
    np.testing.assert_array_equal(contacts[0], [0] if kept else [-1])
    handle(c, [0.0, 0, 0.2], [0.0, 0, 0.2], contacts=contacts)  # far beyond the margin: evicted
    np.testing.assert_array_equal(contacts[0], [-1])


def random_scene(seed, n_points=400):
    rng = np.random.default_rng(seed)
    vols = [Volume("s", SPHERE, "f", (0.1, 0.1, 0.1)),
            Volume("e", ELLIPSOID, "f", (0.07, 0.05, 0.2), cut=(-0.17, 0.15)),
            Volume("c", CAPSULE, "f", (0.06, 0.04, 0.12))]
    pos0 = rng.uniform(-0.2, 0.2, (3, 3))
    pos1 = pos0 + rng.normal(0.0, 0.05, (3, 3))
    rot0 = quat_from_axis_angle(rng.normal(size=(3, 3)), rng.uniform(0, np.pi, 3))
    rot1 = quat_from_axis_angle(rng.normal(size=(3, 3)), rng.uniform(0, np.pi, 3))
    xs = rng.uniform(-0.45, 0.45, (n_points, 3))
    x = xs + rng.normal(0.0, 0.06, (n_points, 3))
    v = (x - xs) / H
    return vols, pos0, rot0, pos1, rot1, xs, x, v


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_broad_phase_does_not_change_results(seed):
    vols, pos0, rot0, pos1, rot1, xs, x, v = random_scene(seed)
    results = []
    for use_broad_phase in (True, False):
        c = make_collider(vols, len(x), pos0, rot0, pos1, rot1, cache_size=2)
        c.use_broad_phase = use_broad_phase
        xb, vb = handle(c, xs, x, v)
        results.append((xb, vb, c.static_hits, c.dynamic_hits))
    (xa, va, sa, da), (xb, vb, sb, db) = results
    assert sa + da > 20  # the scene does collide
    np.testing.assert_array_equal(xa, xb)
    np.testing.assert_array_equal(va, vb)
    assert (sa, da) == (sb, db)


def reference_handle_all(collider, xs, x, v):
    """``handle_all`` spelled out for points with an empty cache: each point against every volume in turn with
    ``response.handle_pair`` (which rotates the point into the volume itself), from where the previous hit put
    it, then up to four static passes while one moves it; no broad phase, no cache."""
    from garment_sim_ros.collision import response

    c, vol = collider, collider.arrays
    x, v = x.copy(), v.copy()
    for i in range(len(x)):
        hits = 0
        for k in range(len(vol.kinds)):
            hits += response.handle_pair(vol, k, xs, x, v, i, H, c._eps, c._friction, c._grip, c._c_time,
                                         c._switch_ratio, c._mode)[0] != response.NO_HIT
        for _ in range(4 if hits else 0):  # no friction along the bones there: the way out may be along one
            settle_grip = (c._grip[0], 0.0, c._grip[2], c._grip[3])
            moved = [response.handle_pair(vol, k, xs, x, v, i, H, c._eps, c._friction, settle_grip, c._c_time,
                                          c._switch_ratio, response.MODE_STATIC)[0] != response.NO_HIT
                     for k in range(len(vol.kinds))]
            if not any(moved):
                break
    return x, v


@pytest.mark.parametrize("seed", [1, 2])
def test_handle_all_equals_every_pair_handled_in_turn(seed):
    """The kernel scans a point's volumes once (its broad phase's box test hands the point's local coordinates to
    the handling) and goes on from where each hit put the point: bit for bit the pair-by-pair handling."""
    vols, pos0, rot0, pos1, rot1, xs, x, v = random_scene(seed)
    c = make_collider(vols, len(x), pos0, rot0, pos1, rot1, cache_size=3)
    xb, vb = handle(c, xs, x, v)
    xr, vr = reference_handle_all(c, xs, x, v)
    assert c.static_hits + c.dynamic_hits > 20 and c.dynamic_hits > 0  # the scene collides, both ways
    np.testing.assert_array_equal(xb, xr)
    np.testing.assert_array_equal(vb, vr)


@pytest.mark.parametrize("parallel", [False, True])
def test_handle_contacts_equals_every_cached_pair_handled_in_turn(parallel):
    """``handle_contacts`` goes through the points in runs (``kernels._RUN``; 400 points: six full runs and a
    part): each point's cached volumes, within their bounding spheres, handled in turn with
    ``response.handle_pair`` without the slide, bit for bit, on one thread and over numba's threads."""
    from garment_sim_ros.collision import response
    from garment_sim_ros.collision.kernels import _RUN

    vols, pos0, rot0, pos1, rot1, _, _, _ = random_scene(7)
    rng = np.random.default_rng(7)
    xs = pos1[np.arange(400) % 3] + rng.uniform(-0.08, 0.08, (400, 3))  # in and about the volumes
    x = xs + rng.normal(0.0, 0.03, xs.shape)
    v = (x - xs) / H
    assert len(x) % _RUN and len(x) > 2 * _RUN  # runs and a part run
    c = Collider(VolumeSet(tuple(vols)), len(x), cache_size=3, parallel=parallel)
    c.set_params(DEFAULT_PARAMS)
    c.begin_frame(pos0, rot0, pos1, rot1)
    c.begin_substep(0.0, 1.0)
    contacts = c.new_contacts()
    handle(c, xs, x, v, contacts=contacts)  # fills the cache
    assert np.count_nonzero(contacts[:, 0] >= 0) > 200
    moved = x + rng.normal(0.0, 0.02, x.shape)  # the length correction's pull
    xb, vb = moved.copy(), v.copy()
    c.static_hits = 0
    c.handle_contacts(xs, xb, vb, np.ones(len(x)), H, contacts)
    vol, xr, vr, hits = c.arrays, moved.copy(), v.copy(), 0
    for i in range(len(x)):
        for k in contacts[i]:
            if k < 0 or np.linalg.norm(xr[i] - vol.pos1[k]) > vol.bounding_radii[k]:
                continue
            hits += response.handle_pair(vol, k, xs, xr, vr, i, H, c._eps, c._friction, c._grip, 0.0,
                                         c._switch_ratio, c._mode)[0] != response.NO_HIT
    ends = np.arange(_RUN - 1, len(x), _RUN)  # each run's last point
    assert hits > 100 and c.static_hits == hits and np.any(xr[ends] != moved[ends])
    np.testing.assert_array_equal(xb, xr)
    np.testing.assert_array_equal(vb, vr)


def test_broad_phase_rejects_far_pairs():
    from garment_sim_ros.collision import broad_phase
    vols, pos0, rot0, pos1, rot1, xs, x, v = random_scene(4)
    c = make_collider(vols, len(x), pos0, rot0, pos1, rot0)  # translating volumes
    far = xs + 5.0
    rejected = [broad_phase.broad_phase_rejects(c.arrays, k, far, far + 0.01, 0) for k in range(3)]
    assert all(rejected)


def test_parallel_kernel_matches_serial():
    vols, pos0, rot0, pos1, rot1, xs, x, v = random_scene(5)
    out = []
    for parallel in (False, True):
        c = Collider(VolumeSet(tuple(vols)), len(x), cache_size=2, parallel=parallel)
        c.begin_frame(pos0, rot0, pos1, rot1)
        c.begin_substep(0.0, 1.0)
        contacts = c.new_contacts()
        xb, vb = handle(c, xs, x, v, contacts=contacts)
        out.append((xb, vb, contacts, c.static_hits, c.dynamic_hits))
    for a, b in zip(*out):
        np.testing.assert_array_equal(a, b)


def test_after_handle_all_no_point_is_inside_any_volume():
    vols, pos0, rot0, pos1, rot1, _, _, _ = random_scene(6)
    # well-separated copies of the volumes, so handling one cannot push a point into another
    offsets = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    pos0, pos1 = pos0 + offsets, pos1 + offsets
    rng = np.random.default_rng(6)
    xs = np.repeat(pos1, 200, axis=0) + rng.uniform(-0.15, 0.15, (600, 3))
    x = xs + rng.normal(0.0, 0.05, (600, 3))
    c = make_collider(vols, len(x), pos0, rot0, pos1, rot1, cache_size=2)
    before = c.penetration_depths(x)
    xb, _ = handle(c, xs, x, (x - xs) / H)
    assert before.max() > 0.02 and np.count_nonzero(before) > 50
    assert c.penetration_depths(xb).max() == 0.0


@pytest.mark.parametrize("p", [[0.07, 0.0, 0.02], [0.075, 0.0, 0.001]])
def test_a_point_squeezed_between_overlapping_volumes_ends_outside_both(p):
    # pushed out of one sphere it lands in the other (a crotch); the settling passes resolve it
    c = make_collider([sphere(0.1, "a"), sphere(0.1, "b")], 1, [[0, 0, 0], [0.15, 0, 0]], collision_mode="static")
    x, _ = handle(c, p, p)
    assert c.static_hits > 2
    assert c.penetration_depths(x)[0] == 0.0


def test_pinned_points_are_skipped():
    c = make_collider([sphere(0.1)], 2, [0, 0, 0], collision_mode="static")
    x, _ = handle(c, [[0.05, 0, 0]] * 2, [[0.05, 0, 0]] * 2, inv_mass=[0.0, 1.0])
    np.testing.assert_array_equal(x[0], [0.05, 0, 0])
    assert x[1, 0] > 0.1


# ----------------------------------------------------------------------------- capsules

def test_capsule_static_cylinder_part_and_tapered_end():
    # equal radii: a cylinder with round ends; point 1 cm off the axis -> radially to r + eps
    cyl = make_collider([Volume("c", CAPSULE, "f", (0.05, 0.05, 0.1))], 1, [0, 0, 0],
                        collision_mode="static", collision_epsilon=0.002)
    x, _ = handle(cyl, [0.01, 0, 0.03], [0.01, 0, 0.03])
    np.testing.assert_allclose(x[0], [0.052, 0, 0.03], atol=1e-12)
    # tapered (0.06 at z=-0.1, 0.03 at z=+0.1): a point above the top sphere's centre is pushed
    # radially from that centre; a point on the cone part along the cone's normal
    tap = make_collider([Volume("c", CAPSULE, "f", (0.06, 0.03, 0.1))], 2, [0, 0, 0],
                        collision_mode="static", collision_epsilon=0.0)
    x, _ = handle(tap, [[0.0, 0.0, 0.12], [0.03, 0.0, 0.0]], [[0.0, 0.0, 0.12], [0.03, 0.0, 0.0]])
    np.testing.assert_allclose(x[0], [0, 0, 0.13], atol=1e-12)
    b = (0.06 - 0.03) / 0.2
    a = math.sqrt(1 - b * b)
    n = np.array([a, 0.0, b])
    depth = 0.06 - (a * 0.03 + b * 0.1)  # distance to the tangent line in the (rho, z) plane
    np.testing.assert_allclose(x[1], [0.03, 0, 0] + depth * n, atol=1e-12)


def test_capsule_dynamic_hits_and_grazes():
    cap = Volume("c", CAPSULE, "f", (0.05, 0.05, 0.1))
    c = make_collider([cap], 3, [0, 0, 0], collision_mode="dynamic", collision_epsilon=0.0,
                      contact_time_fraction=0.0)
    xs = np.array([[-0.3, 0.0, 0.0], [-0.3, 0.0499, 0.0], [-0.3, 0.0501, 0.0]])
    x, _ = handle(c, xs, xs + [0.6, 0, 0], v=np.tile([60.0, 0, 0], (3, 1)))
    np.testing.assert_allclose(x[0], [-0.05, 0, 0], atol=1e-6)
    # the grazing segment enters 0.1 mm deep: caught on the surface at y = 0.0499
    np.testing.assert_allclose(x[1], [-math.sqrt(0.05 ** 2 - 0.0499 ** 2), 0.0499, 0.0], atol=1e-6)
    np.testing.assert_allclose(x[2], [0.3, 0.0501, 0.0])  # passes 0.1 mm outside
    assert c.dynamic_hits == 2


# ----------------------------------------------------------------------------- depths, poses, input

def test_penetration_depths_for_known_points():
    vols = [sphere(0.1, "s"), Volume("e", ELLIPSOID, "f", (0.08, 0.06, 0.2), cut=(-0.15, 0.15)),
            Volume("c", CAPSULE, "f", (0.05, 0.05, 0.1))]
    c = make_collider(vols, 4, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    points = np.array([[0.03, 0.04, 0.0],       # sphere: 0.1 - 0.05
                       [1.0, 0.059, 0.0],       # ellipsoid, 1 mm under the end of its smallest axis
                       [2.0, 0.02, -0.05],      # capsule cylinder part: 0.05 - 0.02
                       [0.5, 0.0, 0.0]])        # outside everything
    np.testing.assert_allclose(c.penetration_depths(points), [0.05, 0.001, 0.03, 0.0], atol=1e-12)


def exact_ellipsoid_depth(radii, y):
    """Distance from an interior point (no zero coordinate) to the ellipsoid's surface: the
    closest point is x_i = a_i^2 y_i / (a_i^2 + t) with t the root in (-min a^2, 0) of
    sum (a_i y_i / (a_i^2 + t))^2 = 1, found by bisection (the sum decreases in t)."""
    lo, hi = -np.min(radii) ** 2, 0.0
    for _ in range(200):
        t = 0.5 * (lo + hi)
        if np.sum((radii * y / (radii ** 2 + t)) ** 2) > 1.0:
            lo = t
        else:
            hi = t
    return np.linalg.norm(radii ** 2 * y / (radii ** 2 + hi) - y)


def test_ellipsoid_depth_is_an_upper_bound_tight_near_the_surface():
    radii = np.array([0.08, 0.06, 0.2])
    c = make_collider([Volume("e", ELLIPSOID, "f", tuple(radii))], 400, [0, 0, 0])
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(400, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = directions * radii * rng.uniform(0.3, 0.999, 400)[:, None]
    estimate = c.penetration_depths(points)
    exact = np.array([exact_ellipsoid_depth(radii, p) for p in points])
    assert np.all(estimate >= exact - 1e-12)
    near = exact < 0.005
    assert near.sum() > 20
    np.testing.assert_allclose(estimate[near], exact[near], rtol=0.02, atol=1e-7)


def test_substep_poses_are_interpolated_linear_and_slerp():
    q0 = quat_from_axis_angle([0, 0, 1.0], 0.2)
    q1 = quat_from_axis_angle([1.0, 1.0, 0], 1.4)
    c = make_collider([sphere()], 1, [0, 0, 0], [q0], [1.0, 2.0, 3.0], [q1])
    c.begin_substep(0.25, 0.75)
    np.testing.assert_allclose(c.arrays.pos0[0], [0.25, 0.5, 0.75])
    np.testing.assert_allclose(c.arrays.pos1[0], [0.75, 1.5, 2.25])
    np.testing.assert_allclose(c.arrays.rot0[0], quat_to_matrix(quat_slerp(q0, q1, 0.25)), atol=1e-12)
    np.testing.assert_allclose(c.arrays.rot1[0], quat_to_matrix(quat_slerp(q0, q1, 0.75)), atol=1e-12)


def test_bad_input_is_refused_with_a_clear_message():
    c = make_collider([sphere()], 2, [0, 0, 0])
    with pytest.raises(ValueError, match=r"x must be a float64 array of shape \(2, 3\)"):
        c.handle_all(np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((2, 3)), np.ones(2), H, c.new_contacts())
    with pytest.raises(ValueError, match="pos1 must be finite with shape"):
        c.begin_frame(np.zeros((1, 3)), IDENTITY_QUAT[None], np.zeros((2, 3)), IDENTITY_QUAT[None])
    with pytest.raises(ValueError, match="0 <= f0 < f1 <= 1"):
        c.begin_substep(0.5, 0.5)
    with pytest.raises(ValueError, match="cache_size"):
        Collider(VolumeSet((sphere(),)), 2, cache_size=3)


# ----------------------------------------------------------------------------- bones through triangles

def forearm(bone=(-0.12, 0.12), name="forearm"):
    """An upright limb: 3 cm radius, its bone along local z."""
    return Volume(name, ELLIPSOID, "f", (0.03, 0.03, 0.15), (-0.14, 0.14), bone=bone)


# a level 10 x 16 cm strip centred at (x0, 0, 0): two triangles, its points 8 cm either side of the x axis
STRIP_TRIANGLES = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)


def strip(x0):
    return np.array([[x0 - 0.05, -0.08, 0.0], [x0 - 0.05, 0.08, 0.0], [x0 + 0.05, -0.08, 0.0], [x0 + 0.05, 0.08, 0.0]])


def bone_through_strip(x, centre):
    from garment_sim_ros.quality import segments_through_triangles

    starts, ends = np.array([centre + [0.0, 0.0, -0.12]]), np.array([centre + [0.0, 0.0, 0.12]])
    return segments_through_triangles(starts, ends, np.ascontiguousarray(x), STRIP_TRIANGLES, np.zeros(1, bool)) == 1


def sweep(collider, x_start, x):
    """Point and edge handling, then the bones against the triangles, as the solver does after a substep.
    Returns the points before the bone test, the triangles it moved and the velocities."""
    v, inv_mass = np.zeros_like(x), np.ones(len(x))
    edges = np.array([[0, 1], [1, 3], [3, 2], [2, 0], [1, 2]])
    rest = np.linalg.norm(x_start[edges[:, 0]] - x_start[edges[:, 1]], axis=1)
    collider.handle_all(x_start, x, v, inv_mass, H, collider.new_contacts())
    collider.handle_edges(x_start, x, inv_mass, edges, rest)
    before = x.copy()
    moved = collider.handle_axes(x_start, x, v, inv_mass, H, STRIP_TRIANGLES)
    return before, moved, v


def test_the_collider_counts_the_volumes_bones_through_the_cloth():
    """``Collider.bones_through`` (the frame retries' damage, issue 11 (b)): the metric's crossing test on the bones
    the volumes carry, at their end poses, turned and moved with them; a volume without a bone does not count."""
    centres = np.array([[0.0, 0, 0], [0.5, 0, 0], [0.0, 0, 0]])
    c = make_collider([forearm(), forearm(name="other"), sphere()], 4, centres)
    assert c.bones_through(strip(0.0), STRIP_TRIANGLES) == 1
    assert c.bones_through(strip(0.5), STRIP_TRIANGLES) == 1  # the other's
    assert c.bones_through(strip(0.25), STRIP_TRIANGLES) == 0  # between them, and through the sphere
    turned = np.array([np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])  # 90 deg about x: its bone along y
    rotations = np.array([turned, IDENTITY_QUAT, IDENTITY_QUAT])
    c.begin_frame(centres, rotations, centres, rotations)
    assert c.bones_through(strip(0.0), STRIP_TRIANGLES) == 0  # in the level strip's plane: not through it
    upright = strip(0.0)[:, [0, 2, 1]]  # the strip stood up in the x-z plane, across the turned bone
    assert c.bones_through(upright, STRIP_TRIANGLES) == 1
    assert c.bones_through(upright + [0.0, 0.2, 0.0], STRIP_TRIANGLES) == 0  # past the bone's end (12 cm)


def test_a_limb_swept_between_two_cloth_points_pushes_the_cloth_instead_of_passing_through():
    """An upright limb moves 10 cm into a level strip through its leading edge, whose points lie 8 cm
    either side of its path: no point is ever within its 3 cm radius, so point (and edge) handling leave
    the cloth where it was, with the bone through it. The bone test moves the strip off the bone, ahead
    of the limb (the side it was on), outside the volume, and it moves with the limb."""
    start, end = np.array([-0.1, 0.0, 0.0]), np.zeros(3)
    c = make_collider([forearm()], 4, start, pos1=end, collision_epsilon=0.003)
    x_start = strip(0.0)
    x = x_start.copy()
    before, moved, v = sweep(c, x_start, x)
    assert np.array_equal(before, x_start) and bone_through_strip(before, end)  # point handling misses it
    assert moved >= 1 and not bone_through_strip(x, end)
    assert np.all(x[:, 0] >= 0.003 - 1e-12)  # ahead of the bone by eps at least
    assert np.allclose(x[:, 1:], x_start[:, 1:])  # pushed along the sweep, not sideways
    assert np.all(c.penetration_depths(x) == 0.0)
    pushed = x[:, 0] < 0.01
    assert np.allclose(v[pushed, 0], 0.1 / H)  # the pushed edge moves on with the limb, no faster


def test_a_strip_that_slides_over_a_still_limb_goes_back_to_the_side_it_came_from():
    c = make_collider([forearm()], 4, [0.0, 0.0, 0.0], collision_epsilon=0.003)
    x_start, x = strip(0.1), strip(0.0)  # its leading edge from in front of the limb to behind it
    before, _, _ = sweep(c, x_start, x)
    assert bone_through_strip(before, np.zeros(3))
    assert not bone_through_strip(x, np.zeros(3)) and np.all(x[:, 0] >= 0.003 - 1e-12)


def poke_strip(limb):
    """An upright ``limb`` rising 3 cm into a level strip held 1 cm beyond its bone's far end, swept once: the
    bone's end, the collider, the strip before and after. Checks the strip was crossed before and is not after."""
    end = np.array([0.0, 0.0, -0.10])
    c = make_collider([forearm(name=limb)], 4, [0.0, 0.0, -0.13], pos1=end, collision_epsilon=0.003)
    x_start = strip(0.01)
    x = x_start.copy()
    before, moved, _ = sweep(c, x_start, x)
    assert np.array_equal(before, x_start) and bone_through_strip(before, end)
    assert moved >= 1 and not bone_through_strip(x, end)
    return end, c, x_start, x


def test_a_limb_end_poking_into_a_strip_pushes_it_along_the_bone_past_the_end():
    """An upright limb rises 3 cm into a level strip held 1 cm beyond its bone's far end (a hand poking into a
    skirt): at the substep's end the bone passes through the strip 2 cm short of its end. Moved across the bone,
    a triangle only passes it on to its neighbour (cmu_01_01, issue 11); the crossed triangle goes back past
    the end, along the bone, and no corner moves sideways."""
    end, c, x_start, x = poke_strip("left_lower_arm")
    assert np.allclose(x[:, :2], x_start[:, :2])  # along the bone only
    assert np.all(x[:3, 2] >= end[2] + 0.12 + 0.003 - 1e-12)  # the crossed triangle, past the bone's end by eps
    assert np.array_equal(x[3], x_start[3])  # the other triangle's own corner stays
    assert np.all(c.penetration_depths(x) == 0.0)


def test_a_shin_end_in_a_strip_sends_it_across_the_bone_not_past_the_ankle():
    """The same poke with a shin (``left_lower_leg``): past an ankle the foot goes on at an angle, and a hem held
    past the ankle end rode up with the lifting foot (CC basketball, long skirt, 1x 60 fps: springs 3.3x their
    rest length for 50 frames). The crossed triangle goes across the bone, as at any other crossing."""
    end, c, x_start, x = poke_strip("left_lower_leg")
    assert not np.allclose(x[:, :2], x_start[:, :2])  # moved sideways, across the bone
    assert np.all(x[:, 2] < end[2] + 0.12)  # nothing pushed past the ankle end


def grid_cloth(cells, spacing):
    """A level square grid of ``cells`` x ``cells`` cells from the origin, two triangles a cell, row by row."""
    side = np.arange(cells + 1) * spacing
    x = np.array([[px, py, 0.0] for py in side for px in side])
    corner = np.arange(cells + 1)
    triangles = []
    for row in range(cells):
        for column in range(cells):
            a, b = row * (cells + 1) + corner[column], row * (cells + 1) + corner[column] + 1
            c, d = a + cells + 1, b + cells + 1
            triangles += [[a, b, d], [a, d, c]]
    return x, np.array(triangles, dtype=np.int64)


def test_the_bone_test_finds_crossed_triangles_in_every_run_of_triangles():
    """Three upright limbs enter a level 10 x 10 grid (200 triangles, boxes of ``AXIS_BLOCK`` = 32 consecutive
    ones) through its edge in rows 0, 5 and 9, that is in the first, a middle and the last box. The boxes
    skip most triangles, never a crossed one: the metric (``segments_through_triangles``, the same boxes)
    finds the three bones through, and every bone leaves the cloth."""
    from garment_sim_ros.collision.crossing import AXIS_BLOCK
    from garment_sim_ros.quality import segments_through_triangles

    x_start, triangles = grid_cloth(10, 0.16)
    assert len(triangles) > 5 * AXIS_BLOCK
    rows = np.array([0, 5, 9])
    end = np.stack([np.full(3, 0.06), 0.16 * rows + 0.06, np.zeros(3)], axis=1)  # inside row r's first cell
    start = end - [0.16, 0.0, 0.0]  # outside the cloth
    limbs = [forearm(name=f"forearm{row}") for row in rows]
    c = make_collider(limbs, len(x_start), start, pos1=end, collision_epsilon=0.003)
    x = x_start.copy()
    bones = np.array([0.0, 0.0, 0.12])
    crossed = np.zeros(3, bool)
    assert segments_through_triangles(end - bones, end + bones, x, triangles, crossed) == 3
    moved = c.handle_axes(x_start, x, np.zeros_like(x), np.ones(len(x)), H, triangles)
    assert moved >= 3
    assert segments_through_triangles(end - bones, end + bones, x, triangles, crossed) == 0


def test_a_volume_without_a_bone_is_not_tested():
    c = make_collider([forearm(bone=None)], 4, [-0.1, 0.0, 0.0], pos1=[0.0, 0.0, 0.0])
    x_start = strip(0.0)
    x = x_start.copy()
    _, moved, _ = sweep(c, x_start, x)
    assert moved == 0 and np.array_equal(x, x_start)


def test_a_limb_reaching_a_row_under_the_band_takes_its_free_corners_to_the_band_side():
    """The strip's edge at y = -8 cm is attached (a waistband riding on the body), and an upright limb moves
    10 cm into the strip through its leading edge, as a forearm at the hip reaches the row under the band
    (CC jump, issue 11). The attached corners cannot move, so the crossed triangles' free corners go to the
    side of the bone the attached ones are on: the bone leaves the strip, the band stays where it is and
    no point is left inside the limb."""
    start, end = np.array([-0.1, 0.0, 0.0]), np.zeros(3)
    c = make_collider([forearm()], 4, start, pos1=end, collision_epsilon=0.003)
    x_start = strip(0.0)
    x = x_start.copy()
    inv_mass = np.array([0.0, 1.0, 0.0, 1.0])  # points 0 and 2: the band
    moved = c.handle_axes(x_start, x, np.zeros_like(x), inv_mass, H, STRIP_TRIANGLES)
    assert moved >= 1 and not bone_through_strip(x, end)
    assert np.array_equal(x[[0, 2]], x_start[[0, 2]])
    assert np.all(c.penetration_depths(x) == 0.0)


def test_a_triangle_with_an_attached_corner_already_caught_on_the_bone_is_left_as_it_is():
    """The same strip on a still limb whose end is inside another volume (a hand), the bone through it at the
    substep's start already: its free neighbours keep it on their side (continuity), so taking its free corners
    to the band side would only pass them back and forth; it stays (measured on the CC jump's short skirt at 2x
    60 fps: 11 frames with a bone through it, 88 when such triangles move too)."""
    hand = forearm(bone=None, name="hand")
    c = make_collider([forearm(name="right_lower_arm"), hand], 4, [[0.0, 0.0, 0.0], [0.0, 0.0, 0.12]],
                      collision_epsilon=0.003)
    x_start = strip(0.0)
    x = x_start.copy()
    inv_mass = np.array([0.0, 1.0, 0.0, 1.0])
    assert c.handle_axes(x_start, x, np.zeros_like(x), inv_mass, H, STRIP_TRIANGLES) == 0
    assert np.array_equal(x, x_start)


def test_a_triangle_with_an_attached_corner_caught_on_a_free_limb_end_goes_past_it():
    """The same, the limb ending in no other volume (a wrist, CC's and CMU's rigs have no hand volume): moved
    across the bone, the caught triangle would only pass the crossing to its neighbour; its free corners go
    beyond the bone's end along it, ``collision_epsilon`` past it, and the attached ones stay (the CC jump: the
    band row caught on the forearm after the hand left the hip, 11 frames on each garment on main). Not at an
    ankle (``pushes_ahead``: a forearm's volume)."""
    c = make_collider([forearm(name="right_lower_arm")], 4, np.zeros(3), collision_epsilon=0.003)
    x_start = strip(0.0)
    x = x_start.copy()
    inv_mass = np.array([0.0, 1.0, 0.0, 1.0])
    assert c.handle_axes(x_start, x, np.zeros_like(x), inv_mass, H, STRIP_TRIANGLES) >= 1
    assert np.array_equal(x[[0, 2]], x_start[[0, 2]])
    assert np.allclose(x[[1, 3], 2], 0.123) and np.array_equal(x[[1, 3], :2], x_start[[1, 3], :2])


@pytest.mark.parametrize("pinch_depth", [0.001, 0.05])
def test_in_a_pinch_contact_wins_beyond_pinch_depth(pinch_depth):
    """A thin hip round the limb's end position: the only place off the bone on the strip's side is inside
    the hip, about 1 cm deep. Past ``pinch_depth`` the strip is left where it is (contact over crossing):
    no point goes deeper than that into the hip; with room enough the bone leaves the strip."""
    hip = Volume("hip", ELLIPSOID, "f", (0.015, 0.3, 0.3))
    end = np.zeros(3)
    c = make_collider([forearm(), hip], 4, [[-0.1, 0.0, 0.0], [0.0, 0.0, 0.0]], pos1=[end, end],
                      collision_epsilon=0.003, pinch_depth=pinch_depth)
    x_start = strip(0.0)
    x = x_start.copy()
    before, _, _ = sweep(c, x_start, x)
    assert np.array_equal(before, x_start) and bone_through_strip(before, end)
    depth = c.penetration_depths(x)
    assert np.all(depth <= pinch_depth)
    if pinch_depth < 0.005:
        assert np.array_equal(x, before) and bone_through_strip(x, end)
    else:
        assert not bone_through_strip(x, end) and depth.max() > 0.005  # the cloth is in the pinch


def _give(collider, x, springs, rest, inv_mass=None, stretch=1.5):
    """``Collider.give_room_to_tears`` on a copy of ``x``; (the points after it, how many ends moved)."""
    x = np.array(x, dtype=float)
    inv_mass = np.ones(len(x)) if inv_mass is None else np.asarray(inv_mass, dtype=float)
    moved = collider.give_room_to_tears(x, inv_mass, np.asarray(springs), np.asarray(rest, dtype=float), len(rest),
                                        stretch, np.zeros_like(x))
    return x, moved


def test_a_torn_spring_takes_its_ends_contact_room_hand_computed():
    """Springs 0-1 (rest 20 mm, 32 mm long: 1.6) and 2-3 (rest 20 mm, 40 mm: 2.0), far from the sphere; 4-5
    within the bound. Half collision_epsilon (1.5 mm) is each end's room: 0-1 needs 1 mm an end and ends at 1.5
    rest lengths; 2-3 needs 5 mm an end, halved to 1.25 mm (within the room), then on the second pass 3.75 mm
    halved four times, 0.234375 mm (1.484375 mm from where it was); the third pass's smallest try would take it
    past the room. 4-5 untouched."""
    collider = make_collider([sphere()], 6, [0.0, 0.0, 0.0])
    x = [[1.0, 0, 0], [1.032, 0, 0], [1.0, 0.5, 0], [1.04, 0.5, 0], [1.0, 1.0, 0], [1.025, 1.0, 0]]
    out, _ = _give(collider, x, [[0, 1], [2, 3], [4, 5]], [0.02, 0.02, 0.02])
    assert out[1, 0] - out[0, 0] == pytest.approx(0.030, abs=1e-12)
    assert out[0, 0] - 1.0 == pytest.approx(0.001, abs=1e-12)
    moves = np.linalg.norm(out - np.array(x), axis=1)
    assert moves[2] == pytest.approx(0.001484375, abs=1e-12) and moves[3] == pytest.approx(0.001484375, abs=1e-12)
    assert np.array_equal(out[4:], np.array(x)[4:])
    assert moves.max() <= 0.5 * DEFAULT_PARAMS.collision_epsilon + 1e-12


def test_a_torn_spring_gives_no_point_into_a_volume():
    """Point 0 on the sphere's surface, its spring to point 1 (3 mm outside, 51 mm away, 1.6 rest lengths) dipping
    into the sphere: point 0 would go in and stays where it is; point 1 moves its share, within the room, and
    stays outside. An attached end (inverse mass 0) never moves: its free end takes the whole shortening."""
    r = 0.1
    collider = make_collider([sphere(r)], 2, [0.0, 0.0, 0.0])
    x = np.array([[r, 0.0, 0.0], [0.09, 0.0, 0.05]])
    length = float(np.linalg.norm(x[1] - x[0]))
    out, moved = _give(collider, x, [[0, 1]], [length / 1.6])
    assert np.array_equal(out[0], x[0]) and moved >= 1
    assert 0.0 < np.linalg.norm(out[1] - x[1]) <= 0.5 * DEFAULT_PARAMS.collision_epsilon + 1e-12
    assert np.all(collider.penetration_depths(out) == 0.0)
    assert length / 1.6 * 1.5 < np.linalg.norm(out[1] - out[0]) < length

    free = np.array([[1.0, 0, 0], [1.022, 0, 0]])  # 1.1 rest lengths: the free end alone moves 1 mm
    out, _ = _give(collider, free, [[0, 1]], [0.02], inv_mass=[0.0, 1.0], stretch=1.05)
    assert np.array_equal(out[0], free[0]) and out[1, 0] == pytest.approx(1.021, abs=1e-12)
