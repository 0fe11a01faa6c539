"""``visualization_msgs/MarkerArray`` serialized to CDR straight from numpy arrays.

Building a Marker from tens of thousands of ``geometry_msgs/Point`` objects costs about
160 ms for 60 000 points; writing the CDR bytes ourselves costs one buffer copy of the
point and colour arrays. The bytes are what ``rclpy.serialization.serialize_message``
produces for the same message (XCDR1, little endian, 4-byte encapsulation header), so
``Publisher.publish(serialize_marker_array(markers))`` sends an ordinary MarkerArray.

CDR rules used here: every primitive is aligned to its own size (float64 to 8), counted
from the start of the payload, i.e. after the encapsulation header; a string is a uint32
length that counts its terminating NUL, then the bytes and the NUL; a sequence is a
uint32 count, then its elements. The field order is ROS 2 Jazzy's Marker.msg.

Imports no rclpy: the node imports this module, the reference builder with ``Point``
objects lives in ``marker_objects``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

# Marker.type and Marker.action constants (visualization_msgs/msg/Marker).
SPHERE = 2
TRIANGLE_LIST = 11
ADD = 0
DELETE = 2
DELETEALL = 3

ENCAPSULATION_HEADER = b"\x00\x01\x00\x00"  # CDR_LE, no options
_HEADER_SIZE = len(ENCAPSULATION_HEADER)
_MAX_PADDING = bytes(7)
_INT32 = np.iinfo(np.int32)
_UINT32 = np.iinfo(np.uint32)


def _fixed_vector(name: str, value, size: int) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64)
    if array.shape != (size,):
        raise ValueError(f"MarkerData.{name} must have shape ({size},), got {array.shape}")
    return array


def _per_point(name: str, value, width: int) -> np.ndarray | None:
    if value is None:
        return None
    array = np.asarray(value)
    if array.ndim != 2 or array.shape[1] != width or not np.issubdtype(array.dtype, np.number):
        raise ValueError(f"MarkerData.{name} must be a numeric (N, {width}) array, got shape {array.shape} "
                         f"dtype {array.dtype}")
    return array


def _time(name: str, value) -> tuple[int, int]:
    sec, nanosec = (int(v) for v in value)
    if not (_INT32.min <= sec <= _INT32.max and 0 <= nanosec < 1_000_000_000):
        raise ValueError(f"MarkerData.{name} must be (sec int32, nanosec in [0, 1e9)), got {tuple(value)}")
    return sec, nanosec


@dataclass
class MarkerData:
    """One ``visualization_msgs/Marker``; the fields not listed here are written empty.

    ``points`` (N, 3) and ``colors`` (N, 4, rgba in [0, 1]) are any float arrays; they are
    written as float64 and float32. ``colors`` needs ``points`` of the same length.
    ``stamp`` and ``lifetime`` are ``(sec, nanosec)``; ``orientation`` is (x, y, z, w).
    """

    ns: str
    id: int
    type: int
    action: int = ADD
    frame_id: str = ""
    stamp: tuple[int, int] = (0, 0)
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    orientation: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    color: np.ndarray = field(default_factory=lambda: np.ones(4))
    points: np.ndarray | None = None
    colors: np.ndarray | None = None
    frame_locked: bool = False
    lifetime: tuple[int, int] = (0, 0)

    def __post_init__(self) -> None:
        for name in ("id", "type", "action"):
            value = getattr(self, name)
            if not _INT32.min <= int(value) <= _INT32.max:
                raise ValueError(f"MarkerData.{name} must fit in int32, got {value}")
        for name in ("ns", "frame_id"):
            if "\0" in getattr(self, name):
                raise ValueError(f"MarkerData.{name} must not contain a NUL character: {getattr(self, name)!r}")
        self.stamp = _time("stamp", self.stamp)
        self.lifetime = _time("lifetime", self.lifetime)
        self.position = _fixed_vector("position", self.position, 3)
        self.orientation = _fixed_vector("orientation", self.orientation, 4)
        self.scale = _fixed_vector("scale", self.scale, 3)
        self.color = _fixed_vector("color", self.color, 4)
        self.points = _per_point("points", self.points, 3)
        self.colors = _per_point("colors", self.colors, 4)
        if self.colors is not None and (self.points is None or len(self.colors) != len(self.points)):
            n_points = 0 if self.points is None else len(self.points)
            raise ValueError(f"MarkerData.colors has {len(self.colors)} rows but points has {n_points}: "
                             "give one colour per point, or colors=None")


class _CdrWriter:
    """Collects the CDR chunks of one message; ``b"".join(chunks)`` is the message.

    Large arrays are kept as numpy buffers, so the join is their only copy.
    """

    def __init__(self) -> None:
        self.chunks: list = [ENCAPSULATION_HEADER]
        self.offset = 0  # payload bytes so far: alignment counts from the payload start
        self.padding: list[tuple[int, int]] = []  # [start, stop) in the whole message

    def _append(self, data, alignment: int) -> None:
        pad = -self.offset % alignment
        if pad:
            start = _HEADER_SIZE + self.offset
            self.padding.append((start, start + pad))
            self.chunks.append(_MAX_PADDING[:pad])
            self.offset += pad
        self.chunks.append(data)
        self.offset += memoryview(data).nbytes

    def uint32(self, value: int) -> None:
        self._append(struct.pack("<I", value), 4)

    def int32(self, *values: int) -> None:
        self._append(struct.pack(f"<{len(values)}i", *values), 4)

    def float64(self, values: np.ndarray) -> None:
        self._append(np.ascontiguousarray(values, dtype="<f8").tobytes(), 8)

    def float32(self, values: np.ndarray) -> None:
        self._append(np.ascontiguousarray(values, dtype="<f4").tobytes(), 4)

    def boolean(self, value: bool) -> None:
        self._append(b"\x01" if value else b"\x00", 1)

    def constant(self, block: "_Block") -> None:
        """A block written once ahead (``_Block``), at a 4-aligned offset: its bytes and padding as they were."""
        if self.offset % 4:
            raise ValueError("a constant CDR block starts 4-aligned")
        start = _HEADER_SIZE + self.offset
        self.padding.extend((start + a, start + b) for a, b in block.padding)
        self.chunks.append(block.data)
        self.offset += len(block.data)

    def time(self, sec_nanosec: tuple[int, int]) -> None:
        """builtin_interfaces/Time or Duration: int32 sec, uint32 nanosec."""
        self._append(struct.pack("<iI", *sec_nanosec), 4)

    def string(self, text: str) -> None:
        encoded = text.encode("utf-8") + b"\0"
        self.uint32(len(encoded))
        self._append(encoded, 1)

    def struct_sequence(self, rows: np.ndarray | None, dtype: str) -> None:
        """A sequence of flat structs of one primitive type (Point, ColorRGBA): count, rows."""
        count = 0 if rows is None else len(rows)
        if count > _UINT32.max:
            raise ValueError(f"a sequence of {count} elements does not fit a CDR uint32 count")
        self.uint32(count)
        if count:  # an empty sequence has no element to align
            flat = np.ascontiguousarray(rows, dtype=dtype).reshape(-1)
            self._append(flat.view(np.uint8), flat.dtype.itemsize)


@dataclass(frozen=True)
class _Block:
    """CDR bytes written once, for a 4-aligned start: ``data`` and its padding ranges relative to it."""

    data: bytes
    padding: tuple[tuple[int, int], ...]


def _empty_tail() -> _Block:
    """The fields after ``colors``, always empty here: written once (a marker's CDR is ~25 fields, this is 11)."""
    writer = _CdrWriter()
    writer.string("")  # texture_resource
    writer.time((0, 0))  # texture (sensor_msgs/CompressedImage): header, format, data
    writer.string("")
    writer.string("")
    writer.uint32(0)
    writer.uint32(0)  # uv_coordinates
    writer.string("")  # text
    writer.string("")  # mesh_resource
    writer.string("")  # mesh_file (visualization_msgs/MeshFile): filename, data
    writer.uint32(0)
    writer.boolean(False)  # mesh_use_embedded_materials
    return _Block(b"".join(writer.chunks[1:]), tuple((a - _HEADER_SIZE, b - _HEADER_SIZE) for a, b in writer.padding))


_EMPTY_TAIL = _empty_tail()
_POSE_SCALE = struct.Struct("<10d")  # pose (position, orientation), scale: float64 from an 8-aligned offset
_LIFETIME_LOCKED = struct.Struct("<iI?")  # lifetime (builtin_interfaces/Duration), frame_locked


def _write_marker(writer: _CdrWriter, marker: MarkerData) -> None:
    writer.time(marker.stamp)  # std_msgs/Header header
    writer.string(marker.frame_id)
    writer.string(marker.ns)
    writer.int32(marker.id, marker.type, marker.action)
    # pose and scale (float64), color (float32), lifetime and frame_locked follow one another with no
    # padding once the float64 are aligned: one chunk
    writer._append(_POSE_SCALE.pack(*marker.position, *marker.orientation, *marker.scale)
                   + marker.color.astype("<f4").tobytes()
                   + _LIFETIME_LOCKED.pack(*marker.lifetime, marker.frame_locked), 8)
    writer.struct_sequence(marker.points, "<f8")  # geometry_msgs/Point[]
    writer.struct_sequence(marker.colors, "<f4")  # std_msgs/ColorRGBA[]
    writer.constant(_EMPTY_TAIL)  # texture, uv_coordinates, text, mesh_resource, mesh_file, ...


def _write_marker_array(markers: list[MarkerData]) -> _CdrWriter:
    writer = _CdrWriter()
    writer.uint32(len(markers))
    for marker in markers:
        _write_marker(writer, marker)
    return writer


def serialize_marker_array(markers: list[MarkerData]) -> bytes:
    """The serialized ``visualization_msgs/MarkerArray`` holding ``markers``, ready for
    ``Publisher.publish``. Padding bytes are zero."""
    return b"".join(_write_marker_array(markers).chunks)


def serialize_marker_array_with_padding(markers: list[MarkerData]) -> tuple[bytes, list[tuple[int, int]]]:
    """Like ``serialize_marker_array``, plus the ``[start, stop)`` ranges of alignment padding.

    Fast-CDR leaves padding bytes uninitialised, so a byte-for-byte comparison with
    ``rclpy.serialization.serialize_message`` must skip these ranges.
    """
    writer = _write_marker_array(markers)
    return b"".join(writer.chunks), writer.padding
