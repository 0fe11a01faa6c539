"""The numpy CDR writer produces the MarkerArray bytes that rclpy produces, and they read back."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from garment_sim_ros.ros.marker_objects import marker_array_message
from garment_sim_ros.runtime.marker_cdr import (
    DELETE,
    SPHERE,
    TRIANGLE_LIST,
    MarkerData,
    serialize_marker_array,
    serialize_marker_array_with_padding,
)


def triangle_list(n_points: int, seed: int = 0, **fields) -> MarkerData:
    rng = np.random.default_rng(seed)
    defaults = dict(ns="garment/dress", id=7, type=TRIANGLE_LIST, frame_id="world",
                    stamp=(1_700_000_000, 123_456_789), scale=np.ones(3), color=(1.0, 1.0, 1.0, 1.0),
                    points=rng.normal(size=(n_points, 3)), colors=rng.uniform(size=(n_points, 4)))
    return MarkerData(**{**defaults, **fields})


def sphere(name: str, marker_id: int) -> MarkerData:
    return MarkerData(ns="body_volumes", id=marker_id, type=SPHERE, frame_id="world", stamp=(5, 999_999_999),
                      position=(0.1, -0.2, 0.9), orientation=(0.0, 0.0, 0.38268343236, 0.92387953251),
                      scale=(0.3, 0.25, 0.6), color=(0.9, 0.6, 0.5, 0.4), lifetime=(0, 200_000_000),
                      frame_locked=True)


def assert_bytes_match_rclpy(markers: list[MarkerData]) -> bytes:
    """Every byte equals rclpy's except alignment padding, which Fast-CDR leaves uninitialised
    and we write as zeros."""
    ours, padding = serialize_marker_array_with_padding(markers)
    reference = serialize_message(marker_array_message(markers))
    assert len(ours) == len(reference)
    assert ours == serialize_marker_array(markers)
    ours_u8, reference_u8 = np.frombuffer(ours, np.uint8), np.frombuffer(reference, np.uint8)
    is_padding = np.zeros(len(ours), bool)
    for start, stop in padding:
        assert 0 < stop - start < 8
        is_padding[start:stop] = True
    assert not ours_u8[is_padding].any()
    differing = np.flatnonzero((ours_u8 != reference_u8) & ~is_padding)
    assert differing.size == 0, f"bytes differ from rclpy's at offsets {differing[:8].tolist()}"
    return ours


def as_rows(items, names) -> np.ndarray:
    return np.array([[getattr(item, n) for n in names] for item in items], dtype=float).reshape(-1, len(names))


def assert_reads_back(data: bytes, markers: list[MarkerData]) -> None:
    received = deserialize_message(data, MarkerArray).markers
    assert len(received) == len(markers)
    for got, sent in zip(received, markers):
        assert (got.header.stamp.sec, got.header.stamp.nanosec) == sent.stamp
        assert (got.header.frame_id, got.ns) == (sent.frame_id, sent.ns)
        assert (got.id, got.type, got.action) == (sent.id, sent.type, sent.action)
        p, q = got.pose.position, got.pose.orientation
        np.testing.assert_array_equal([p.x, p.y, p.z, q.x, q.y, q.z, q.w], np.r_[sent.position, sent.orientation])
        np.testing.assert_array_equal([got.scale.x, got.scale.y, got.scale.z], sent.scale)
        c = got.color
        np.testing.assert_array_equal(np.float32([c.r, c.g, c.b, c.a]), np.float32(sent.color))
        assert (got.lifetime.sec, got.lifetime.nanosec) == sent.lifetime
        assert got.frame_locked == sent.frame_locked
        expected_points = np.zeros((0, 3)) if sent.points is None else sent.points
        np.testing.assert_array_equal(as_rows(got.points, "xyz"), expected_points)
        expected_colors = np.zeros((0, 4), np.float32) if sent.colors is None else sent.colors.astype(np.float32)
        np.testing.assert_array_equal(as_rows(got.colors, "rgba").astype(np.float32), expected_colors)
        assert (got.texture_resource, got.texture.header.frame_id, got.texture.format, len(got.texture.data)) \
            == ("", "", "", 0)
        assert (len(got.uv_coordinates), got.text, got.mesh_resource) == (0, "", "")
        assert (got.mesh_file.filename, len(got.mesh_file.data), got.mesh_use_embedded_materials) == ("", 0, False)


def check(markers: list[MarkerData]) -> None:
    assert_reads_back(assert_bytes_match_rclpy(markers), markers)


def test_triangle_list_with_points_and_colours():
    check([triangle_list(3 * 41)])


def test_float32_inputs_are_written_as_float64_points_and_float32_colours():
    marker = triangle_list(30)
    marker.points = marker.points.astype(np.float32)
    marker.colors = marker.colors.astype(np.float32)
    check([marker])


def test_sphere_without_points():
    check([sphere("pelvis", 0)])


def test_empty_point_and_colour_arrays():
    check([triangle_list(0)])
    check([triangle_list(0, colors=None)])


def test_empty_marker_array():
    data = assert_bytes_match_rclpy([])
    assert data == b"\x00\x01\x00\x00\x00\x00\x00\x00"


def test_several_markers_of_both_kinds_in_one_array():
    check([triangle_list(9, seed=1, id=0), sphere("torso", 1), triangle_list(5, seed=2, id=2, colors=None),
           sphere("head", 2), MarkerData(ns="garment/dress", id=3, type=TRIANGLE_LIST, action=DELETE)])


names = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\0"), max_size=9)


@settings(max_examples=40, deadline=None)
@given(frame_id=names, ns=names, n_points=st.integers(0, 7), with_colors=st.booleans(),
       frame_locked=st.booleans(), seed=st.integers(0, 2**16))
def test_alignment_for_any_string_lengths_and_point_counts(frame_id, ns, n_points, with_colors, frame_locked, seed):
    """Strings of every length mod 8 (UTF-8 multi-byte too) shift where the float64 pose and
    points start; each marker of the array starts at a different alignment as well."""
    first = triangle_list(n_points, seed, frame_id=frame_id, ns=ns, frame_locked=frame_locked)
    if not with_colors:
        first.colors = None
    second = triangle_list(n_points + 1, seed + 1, frame_id=ns, ns=frame_id + "x")
    check([first, second])


@pytest.mark.parametrize("fields, message", [
    (dict(points=np.zeros((4, 2))), "points must be a numeric (N, 3) array"),
    (dict(points=np.zeros((4, 3)), colors=np.zeros((3, 4))), "colors has 3 rows but points has 4"),
    (dict(colors=np.zeros((3, 4))), "colors has 3 rows but points has 0"),
    (dict(scale=(1.0, 1.0)), "scale must have shape (3,)"),
    (dict(stamp=(0, 1_000_000_000)), "stamp must be (sec int32, nanosec in [0, 1e9))"),
    (dict(id=2**31), "id must fit in int32"),
    (dict(frame_id="wor\0ld"), "frame_id must not contain a NUL"),
])
def test_bad_fields_are_refused_with_the_field_named(fields, message):
    with pytest.raises(ValueError) as error:
        MarkerData(ns="n", id=fields.pop("id", 0), type=TRIANGLE_LIST, **fields)
    assert message in str(error.value)


def test_serializer_module_imports_no_rclpy():
    code = ("import sys, garment_sim_ros.runtime.marker_cdr; "
            "loaded = [m for m in sys.modules if m.split('.')[0] in ('rclpy', 'visualization_msgs', 'rpyutils')]; "
            "assert not loaded, loaded")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_marker_type_constants_are_visualization_msgs():
    assert (SPHERE, TRIANGLE_LIST, DELETE) == (Marker.SPHERE, Marker.TRIANGLE_LIST, Marker.DELETE)
