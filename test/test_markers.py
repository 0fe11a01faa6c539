"""The node's markers from numpy arrays (ROS-free): triangle corners, colours, volume spheres."""

from __future__ import annotations

import numpy as np
import pytest

from garment_sim_ros.runtime.marker_cdr import SPHERE, TRIANGLE_LIST
from garment_sim_ros.runtime.markers import frame_markers, garment_marker, rgba, triangle_corners, volume_markers

# Two triangles sharing an edge: a unit square in the z = 1 plane.
POSITIONS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]])
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])
NORMALS = np.tile([0.0, 0.0, 1.0], (4, 1))
COLORS = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [51, 102, 204]], dtype=np.uint8)
MESH = ("pants", POSITIONS, NORMALS, TRIANGLES, COLORS)


def test_triangle_corners_are_the_vertices_in_triangle_order():
    corners = triangle_corners(POSITIONS, TRIANGLES)
    assert corners.shape == (6, 3)
    np.testing.assert_array_equal(corners, POSITIONS[[0, 1, 2, 0, 2, 3]])


def test_rgba_scales_bytes_to_unit_floats_with_the_given_alpha():
    colors = rgba(COLORS, alpha=0.5)
    assert colors.dtype == np.float32
    np.testing.assert_allclose(colors[3], [0.2, 0.4, 0.8, 0.5], rtol=1e-6)
    np.testing.assert_array_equal(colors[0], [1.0, 0.0, 0.0, 0.5])


def test_garment_marker_is_a_triangle_list_with_a_colour_per_corner():
    marker = garment_marker(MESH, "garment", "world", (12, 500))
    assert (marker.ns, marker.id, marker.type, marker.frame_id, marker.stamp) == \
        ("garment/pants", 0, TRIANGLE_LIST, "world", (12, 500))
    assert len(marker.points) == 3 * len(TRIANGLES) and len(marker.colors) == len(marker.points)
    # Corner 4 is vertex 2 of triangle 1: position (1, 1, 1), blue.
    np.testing.assert_array_equal(marker.points[4], [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(marker.colors[4], [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_array_equal(marker.scale, [1.0, 1.0, 1.0])  # RViz draws a triangle list at scale 1


def test_volume_markers_are_spheres_scaled_to_the_diameters_and_posed():
    quarter_turn = np.array([0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)])
    volumes = (np.array([[0.0, 0.0, 1.0], [0.2, 0.0, 0.5]]), np.array([[0.0, 0.0, 0.0, 1.0], quarter_turn]),
               np.array([[0.1, 0.1, 0.1], [0.05, 0.06, 0.2]]))
    markers = volume_markers(volumes, "garment", "world", (3, 0))
    assert [m.id for m in markers] == [0, 1] and {m.ns for m in markers} == {"garment/volumes"}
    assert all(m.type == SPHERE for m in markers)
    np.testing.assert_allclose(markers[1].scale, [0.1, 0.12, 0.4])
    np.testing.assert_allclose(markers[1].position, [0.2, 0.0, 0.5])
    np.testing.assert_allclose(markers[1].orientation, quarter_turn)
    assert 0.0 < markers[0].color[3] < 1.0  # see-through


@pytest.mark.parametrize("with_volumes, expected", [(True, 2), (False, 1)])
def test_frame_markers_put_garments_first_and_volumes_only_when_asked(with_volumes, expected):
    payload = {"garments": [MESH], "volumes": (np.zeros((1, 3)), np.array([[0.0, 0.0, 0.0, 1.0]]), np.ones((1, 3)))}
    markers = frame_markers(payload, "ns", "map", (1, 2), with_volumes)
    assert len(markers) == expected and markers[0].type == TRIANGLE_LIST
    assert all(m.frame_id == "map" and m.stamp == (1, 2) for m in markers)
