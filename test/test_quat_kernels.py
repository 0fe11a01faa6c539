"""The numba quaternion kernels (``quat_kernels``) against their numpy twin (``transforms``)."""

from __future__ import annotations

import numpy as np
import pytest

from garment_sim_ros import quat_kernels as quat
from garment_sim_ros.transforms import quat_multiply, quat_normalize, quat_rotate, quat_slerp, quat_to_matrix

RNG = np.random.default_rng(7)
QUATS = quat_normalize(RNG.normal(size=(50, 4)))
OTHERS = quat_normalize(RNG.normal(size=(50, 4)))
VECTORS = RNG.normal(size=(50, 3))


def test_rotate_matches_transforms_and_keeps_lengths():
    for q, v in zip(QUATS, VECTORS):
        got = np.array(quat.rotate(*q, *v))
        np.testing.assert_allclose(got, quat_rotate(q, v), atol=1e-12)
        assert np.linalg.norm(got) == pytest.approx(np.linalg.norm(v), rel=1e-12)


def test_multiply_matches_transforms_and_composes_rotations():
    for a, b, v in zip(QUATS, OTHERS, VECTORS):
        ab = np.array(quat.multiply(*a, *b))
        np.testing.assert_allclose(ab, quat_multiply(a, b), atol=1e-12)
        np.testing.assert_allclose(quat_rotate(ab, v), quat_rotate(a, quat_rotate(b, v)), atol=1e-12)


@pytest.mark.parametrize("fraction", [0.0, 0.3, 0.5, 1.0])
def test_slerp_matches_transforms_on_the_shorter_arc(fraction):
    for a, b in zip(QUATS, OTHERS):
        got = np.array(quat.slerp(*a, *b, fraction))
        want = quat_slerp(a, b, fraction)
        # the same rotation (q and -q are one rotation)
        assert abs(float(np.dot(got, want))) == pytest.approx(1.0, abs=1e-9)
        assert np.linalg.norm(got) == pytest.approx(1.0, abs=1e-12)
    a = QUATS[0]  # identical ends: no division by sin(0)
    np.testing.assert_allclose(quat.slerp(*a, *a, 0.4), a, atol=1e-12)


def test_matrix_into_matches_transforms():
    out = np.zeros((len(QUATS), 3, 3))
    for v, q in enumerate(QUATS):
        quat.matrix_into(out, v, *q)
        np.testing.assert_allclose(out[v], quat_to_matrix(q), atol=1e-12)
        np.testing.assert_allclose(out[v] @ out[v].T, np.eye(3), atol=1e-12)
