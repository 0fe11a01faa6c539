"""The fast paths of the collision kernels against the exact tests they stand in for: the local-box
broad phase never rejects a pair the exact handling would hit (brute force, every volume kind), the
parallel ``handle_all`` gives the serial results bit for bit, and the broad phase as a whole changes
no result over several substeps of moving volumes (cache carried along)."""

from dataclasses import replace

import numpy as np
import pytest

from garment_sim_ros.collision import broad_phase, geometry
from garment_sim_ros.collision.collider import PARALLEL_MIN_POINTS, Collider
from garment_sim_ros.collision.volume_arrays import no_planes
from garment_sim_ros.collision.volumes import CAPSULE, ELLIPSOID, SPHERE, Volume, VolumeSet
from garment_sim_ros.transforms import quat_from_axis_angle

VOLUMES = (
    Volume("sphere", SPHERE, "f", (0.1, 0.1, 0.1)),
    Volume("ellipsoid", ELLIPSOID, "f", (0.07, 0.05, 0.2), cut=(-0.17, 0.15)),
    Volume("capsule", CAPSULE, "f", (0.06, 0.04, 0.12)),
    Volume("round_capsule", CAPSULE, "f", (0.09, 0.02, 0.03)),  # one end sphere holds the other
)


def _local_arrays(volumes):
    vs = VolumeSet(tuple(volumes))
    kinds = np.ascontiguousarray(vs.kinds, dtype=np.int64)
    radii = np.ascontiguousarray(vs.radii, dtype=np.float64)
    cuts = np.ascontiguousarray(vs.cuts, dtype=np.float64)
    boxes = np.zeros((len(vs), 6))
    broad_phase.local_boxes(kinds, radii, cuts, boxes)
    return kinds, radii, cuts, boxes


def _some_planes(n_volumes, rng):
    """Two contact planes per volume (``VolumeArrays.planes``), random normals, a few cm off the centre."""
    planes = no_planes(n_volumes)
    for v in range(n_volumes):
        for k in range(2):
            normal = rng.normal(size=3)
            planes[v, k, :3] = normal / np.linalg.norm(normal)
            planes[v, k, 3] = rng.uniform(0.0, 0.05)
    return planes


@pytest.mark.parametrize("pressed", [False, True])
@pytest.mark.parametrize("index", range(len(VOLUMES)))
def test_local_box_never_rejects_a_hit(index, pressed):
    """Random local segments around the volume (many grazing it): whenever the exact static test of the
    end, the dynamic entry along the segment, or the edge handling's deepest point finds the volume, the
    box test must not reject the segment; and it does reject most segments that miss. ``pressed``: the
    volumes cut by contact planes, which the box ignores (a cut volume lies in the uncut one)."""
    kinds, radii, cuts, boxes = _local_arrays(VOLUMES)
    v, kind = index, int(kinds[index])
    rng = np.random.default_rng(index)
    planes = _some_planes(len(VOLUMES), rng) if pressed else no_planes(len(VOLUMES))
    extent = np.array([boxes[v, 3], boxes[v, 4], boxes[v, 5]]) * 1.6
    hits = rejected_misses = misses = 0
    for _ in range(6000):
        a = rng.uniform(-extent, extent)
        b = a + rng.normal(0.0, 0.06, 3) if rng.random() < 0.7 else rng.uniform(-extent, extent)
        inside = geometry.static_projection(kind, radii, cuts, planes, v, *b)[0]
        alpha = geometry.entry(kind, radii, cuts, planes, v, *a, *b)[0]
        t, deep = geometry.deepest_on_segment(kind, radii, cuts, planes, v, *a, *b)
        hit = inside or alpha >= 0.0 or deep
        rejects = broad_phase.segment_misses_box(boxes, v, *a, *b)
        if hit:
            hits += 1
            assert not rejects, f"{VOLUMES[v].name}: box rejects a hit, a={a}, b={b}"
        else:
            misses += 1
            rejected_misses += rejects
    assert hits > 300 and misses > 300  # both sides are exercised
    assert rejected_misses > 0.3 * misses  # and the box is not vacuous


def test_local_boxes_hold_the_volumes():
    kinds, radii, cuts, boxes = _local_arrays(VOLUMES)
    # sphere: +-r; ellipsoid: +-a_x, +-a_y, z within the cut; capsule: widest radius, both end caps
    np.testing.assert_allclose(boxes[0], [-0.1, -0.1, -0.1, 0.1, 0.1, 0.1], atol=2e-6)
    np.testing.assert_allclose(boxes[1], [-0.07, -0.05, -0.17, 0.07, 0.05, 0.15], atol=2e-6)
    np.testing.assert_allclose(boxes[2], [-0.06, -0.06, -0.18, 0.06, 0.06, 0.18], atol=2e-6)
    assert np.all(boxes[:, :3] < boxes[:, 3:])


def _moving_scene(seed, n_points):
    """The four volumes near each other, turning and translating over several substeps; points around them."""
    rng = np.random.default_rng(seed)
    n = len(VOLUMES)
    pos0 = rng.uniform(-0.15, 0.15, (n, 3))
    pos1 = pos0 + rng.normal(0.0, 0.04, (n, 3))
    rot0 = quat_from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(0, np.pi, n))
    rot1 = quat_from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(0, 0.5, n))
    x = rng.uniform(-0.35, 0.35, (n_points, 3))
    return pos0, rot0, pos1, rot1, x, rng


def _pressable_volumes():
    """``VOLUMES`` on frames of their own, apart at rest: every pair that meets is pressed onto a contact plane."""
    n = len(VOLUMES)
    rest_positions = np.array([[k, 0.0, 0.0] for k in range(n)], dtype=float)
    rest_rotations = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return VolumeSet(tuple(replace(v, frame=v.name) for v in VOLUMES), (rest_positions, rest_rotations))


def _run_substeps(seed, n_points, parallel, use_broad_phase, substeps=4, h=0.01, pressed=False):
    pos0, rot0, pos1, rot1, x, rng = _moving_scene(seed, n_points)
    volumes = _pressable_volumes() if pressed else VolumeSet(VOLUMES)
    collider = Collider(volumes, n_points, cache_size=2, parallel=parallel)
    collider.use_broad_phase = use_broad_phase
    collider.begin_frame(pos0, rot0, pos1, rot1)
    v = np.zeros_like(x)
    inv_mass = np.ones(n_points)
    inv_mass[::17] = 0.0  # attached points are left alone
    contacts = collider.new_contacts()
    steps = rng.normal(0.0, 0.02, (substeps, n_points, 3))
    for k in range(substeps):
        collider.begin_substep(k / substeps, (k + 1) / substeps)
        x_start = x.copy()
        x = x + steps[k] * inv_mass[:, None]
        v = (x - x_start) / h
        collider.handle_contacts(x_start, x, v, inv_mass, h, contacts)
        collider.handle_all(x_start, x, v, inv_mass, h, contacts)
    assert (collider.pressed_depth > 0.0) == pressed  # the volumes overlap in the scene: pressed when asked
    return x, v, contacts, collider.static_hits, collider.dynamic_hits


@pytest.mark.parametrize("seed", [11, 12])
def test_parallel_handle_all_equals_serial(seed):
    serial = _run_substeps(seed, 3000, parallel=False, use_broad_phase=True)
    parallel = _run_substeps(seed, 3000, parallel=True, use_broad_phase=True)
    assert serial[3] + serial[4] > 100  # the scene collides
    for a, b in zip(serial, parallel):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("pressed", [False, True])
@pytest.mark.parametrize("seed", [13, 14])
def test_broad_phase_changes_nothing_over_substeps(seed, pressed):
    """Reach, local box and bounding-sphere tests on against all of them off, cache carried over substeps;
    ``pressed``: the volumes that meet cut by contact planes."""
    with_broad = _run_substeps(seed, 1500, parallel=False, use_broad_phase=True, pressed=pressed)
    without = _run_substeps(seed, 1500, parallel=False, use_broad_phase=False, pressed=pressed)
    assert with_broad[3] + with_broad[4] > 50
    for name, a, b in zip(("x", "v"), with_broad[:2], without[:2]):
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert with_broad[3:] == without[3:]


def test_collider_goes_parallel_from_the_threshold():
    volumes = VolumeSet(VOLUMES)
    assert Collider(volumes, PARALLEL_MIN_POINTS).parallel
    assert not Collider(volumes, PARALLEL_MIN_POINTS - 1).parallel
    assert not Collider(volumes, 10 * PARALLEL_MIN_POINTS, parallel=False).parallel


def test_handle_edges_checks_every_new_edge_array():
    pos0, rot0, pos1, rot1, x, _ = _moving_scene(3, 10)
    collider = Collider(VolumeSet(VOLUMES), 10)
    collider.begin_frame(pos0, rot0, pos1, rot1)
    edges = np.array([[0, 1], [1, 2]])
    rest = np.array([0.1, 0.1])
    collider.handle_edges(x.copy(), x.copy(), np.ones(10), edges, rest)
    with pytest.raises(ValueError, match="point indices below 10"):
        collider.handle_edges(x.copy(), x.copy(), np.ones(10), np.array([[0, 1], [1, 10]]), rest)
    with pytest.raises(ValueError, match="rest lengths"):
        collider.handle_edges(x.copy(), x.copy(), np.ones(10), edges, rest[:1])
