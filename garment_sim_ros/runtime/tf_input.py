"""/tf and /tf_static messages into a ``PoseBuffer`` (ROS-free: reads the message's fields, or its
CDR bytes with ``TFDecoder``; the node takes /tf as bytes, ``ingest`` serves /tf_static and tests).

One character per frame prefix: a transform belongs to the character when its child frame starts
with the prefix (every transform when the prefix is empty); others are another character's and
are skipped without complaint. ``TFDecoder`` routes every transform of a message to its character
among several prefixes in one pass (a crowd in one node: ``runtime.crowd``). Frame names lose a
leading '/' (tf2 does the same). What the buffer refuses (NaN, zero quaternions, cycles, far too
old or future stamps...) is counted there (``PoseBuffer.rejected``) and the first reason is kept
for a throttled log line.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .marker_cdr import ENCAPSULATION_HEADER

_PAYLOAD = len(ENCAPSULATION_HEADER)


@dataclass
class IngestResult:
    stored: int = 0
    other_character: int = 0
    refused: int = 0
    first_refusal: str = ""


def stamp_seconds(stamp) -> float:
    """``builtin_interfaces/Time`` as seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def seconds_to_stamp(seconds: float) -> tuple[int, int]:
    """Seconds as ``(sec, nanosec)`` with ``0 <= nanosec < 1e9`` (rounded to the nanosecond)."""
    total = int(round(seconds * 1e9))
    sec, nanosec = divmod(total, 1_000_000_000)
    return sec, nanosec


def frame_name(name: str) -> str:
    return name[1:] if name.startswith("/") else name


def ingest(buffer, message, prefix: str = "", static: bool = False, now_s: float | None = None) -> IngestResult:
    """Store the transforms of a ``tf2_msgs/TFMessage`` that belong to the character of ``prefix``;
    ``now_s``, the receiver's clock (None before it started), refuses stamps far in its future."""
    result = IngestResult()
    for transform in message.transforms:
        child = frame_name(transform.child_frame_id)
        if not child.startswith(prefix):
            result.other_character += 1
            continue
        t, r = transform.transform.translation, transform.transform.rotation
        refusal = buffer.add_transform(stamp_seconds(transform.header.stamp), frame_name(transform.header.frame_id),
                                       child, (t.x, t.y, t.z), (r.x, r.y, r.z, r.w), static=static, now_s=now_s)
        if refusal is None:
            result.stored += 1
        else:
            result.refused += 1
            result.first_refusal = result.first_refusal or refusal
    return result


# ------------------------------------------------------------------------------ raw CDR /tf
# rclpy builds a TFMessage as one Python object per field (2.3 ms for 142 transforms, rclpy issue
# 836) and the per-transform ``ingest`` above adds 1 ms: at 120 Hz that is ~40 % of a core spent
# before a frame is simulated. A publisher sends the same frame names in the same order every
# tick, so the byte layout (where each stamp and pose lies) is parsed once per layout and every
# later message is a few numpy gathers. The decoding follows the CDR rules in ``marker_cdr``
# (XCDR1 little endian, alignment counted from the payload start after the 4-byte header).


@dataclass
class TransformBatch:
    """The transforms of one or more TFMessages that belong to a character, as arrays (N rows)."""

    stamps: np.ndarray  # (N,) s
    parents: list[str]
    children: list[str]
    translations: np.ndarray  # (N, 3)
    rotations: np.ndarray  # (N, 4) x, y, z, w
    other_character: int = 0  # transforms skipped: another character's

    @staticmethod
    def concatenate(batches: "list[TransformBatch]") -> "TransformBatch":
        if len(batches) == 1:
            return batches[0]
        return TransformBatch(np.concatenate([b.stamps for b in batches]),
                              [p for b in batches for p in b.parents], [c for b in batches for c in b.children],
                              np.concatenate([b.translations for b in batches]),
                              np.concatenate([b.rotations for b in batches]),
                              sum(b.other_character for b in batches))


@dataclass
class _Layout:
    """Where the fields of a TFMessage with given frame names lie, and which rows are whose: the kept
    rows (M) are grouped by character, character k's are rows ``bounds[k]:bounds[k + 1]``."""

    size: int
    name_index: np.ndarray  # byte positions of every count, string length and string byte
    name_bytes: np.ndarray  # their values: a message matches the layout when these agree
    stamp_words: np.ndarray  # (M,) uint32 index of each kept row's stamp.sec (nanosec follows)
    pose_doubles: np.ndarray  # (M,) float64 index of each kept row's translation.x (7 doubles)
    parents: list[str]
    children: list[str]
    bounds: list[int]  # (K + 1,) where each character's rows start, then M
    transforms: int  # every transform of the message, kept or not


class TFDecoder:
    """Decodes serialized ``tf2_msgs/TFMessage`` bytes into ``TransformBatch``es: one per prefix in
    ``prefixes`` (a string: one character), of the transforms whose child frame starts with it
    (another character's, or no one's, are counted, never built). A child is routed to the first
    prefix it starts with; ``runtime.crowd.check_prefixes`` keeps a node's prefixes from overlapping.

    Layouts are cached (at most ``max_layouts``; a publisher whose frame names change every
    message costs a parse each time, still without Python message objects)."""

    def __init__(self, prefixes: str | Sequence[str] = "", max_layouts: int = 64):
        self.prefixes = [prefixes] if isinstance(prefixes, str) else list(prefixes)
        self.max_layouts = max_layouts
        self._layouts: dict[int, list[_Layout]] = {}
        self._count = 0

    def decode(self, data: bytes) -> TransformBatch:
        """The first (or only) character's transforms of ``decode_characters``."""
        return self.decode_characters(data)[0]

    def decode_characters(self, data: bytes) -> list[TransformBatch]:
        """One batch per prefix, in one gather over the message (each batch a slice of it); ``ValueError``
        for bytes that are no little-endian CDR TFMessage."""
        buf = np.frombuffer(data, dtype=np.uint8)
        layout = self._find(buf)
        if layout is None:
            layout = self._parse(data)
            if self._count >= self.max_layouts:
                self._layouts.clear()
                self._count = 0
            self._layouts.setdefault(len(data), []).append(layout)
            self._count += 1
        words = np.frombuffer(data, dtype="<u4", count=len(data) // 4)
        # doubles are 8-aligned from the payload start, which is byte 4 of the message
        doubles = np.frombuffer(data, dtype="<f8", offset=_PAYLOAD, count=(len(data) - _PAYLOAD) // 8)
        sec = words[layout.stamp_words].view(np.int32).astype(np.float64)
        nanosec = words[layout.stamp_words + 1].astype(np.float64)
        poses = doubles[layout.pose_doubles[:, None] + np.arange(7)]
        stamps, bounds = sec + 1e-9 * nanosec, layout.bounds
        return [TransformBatch(stamps[a:b], layout.parents[a:b], layout.children[a:b], poses[a:b, :3],
                               poses[a:b, 3:], layout.transforms - (b - a))
                for a, b in zip(bounds[:-1], bounds[1:])]

    def _find(self, buf: np.ndarray) -> _Layout | None:
        for layout in self._layouts.get(len(buf), ()):
            if np.array_equal(buf[layout.name_index], layout.name_bytes):
                return layout
        return None

    def _parse(self, data: bytes) -> _Layout:
        if len(data) < _PAYLOAD + 4 or data[:2] != ENCAPSULATION_HEADER[:2]:
            raise ValueError(f"not a little-endian CDR message ({len(data)} bytes, header {data[:4].hex()})")
        names: list[int] = []
        offset = 0  # in the payload

        def align(to: int) -> None:
            nonlocal offset
            offset += -offset % to

        def uint32() -> int:
            nonlocal offset
            align(4)
            if _PAYLOAD + offset + 4 > len(data):
                raise ValueError(f"TFMessage truncated at byte {_PAYLOAD + offset} of {len(data)}")
            names.extend(range(_PAYLOAD + offset, _PAYLOAD + offset + 4))
            value = struct.unpack_from("<I", data, _PAYLOAD + offset)[0]
            offset += 4
            return value

        def string() -> str:
            nonlocal offset
            length = uint32()
            start = _PAYLOAD + offset
            if length < 1 or start + length > len(data):
                raise ValueError(f"TFMessage: bad string of {length} bytes at byte {start}")
            names.extend(range(start, start + length))
            offset += length
            return data[start:start + length - 1].decode("utf-8", errors="replace")

        count = uint32()
        rows: list[tuple[int, int, int, str, str]] = []  # character, stamp word, pose double, parent, child
        for _ in range(count):
            align(4)
            stamp_at = offset
            offset += 8  # builtin_interfaces/Time: int32 sec, uint32 nanosec
            parent = frame_name(string())
            child = frame_name(string())
            align(8)
            pose_at = offset
            offset += 56  # geometry_msgs/Transform: Vector3, Quaternion
            if _PAYLOAD + offset > len(data):
                raise ValueError(f"TFMessage truncated: {count} transforms need more than {len(data)} bytes")
            character = next((k for k, prefix in enumerate(self.prefixes) if child.startswith(prefix)), None)
            if character is not None:
                rows.append((character, (_PAYLOAD + stamp_at) // 4, pose_at // 8, parent, child))
        rows.sort(key=lambda row: row[0])  # stable: each character's rows in the message's order
        owners = np.array([row[0] for row in rows], dtype=np.int64)
        bounds = np.searchsorted(owners, np.arange(len(self.prefixes) + 1)).tolist()
        index = np.array(names, dtype=np.int64)
        buf = np.frombuffer(data, dtype=np.uint8)
        return _Layout(len(data), index, buf[index].copy(), np.array([row[1] for row in rows], dtype=np.int64),
                       np.array([row[2] for row in rows], dtype=np.int64), [row[3] for row in rows],
                       [row[4] for row in rows], bounds, count)


def ingest_batch(buffer, batch: TransformBatch, now_s: float | None = None) -> IngestResult:
    """``ingest`` for a decoded batch (dynamic transforms): the same checks, counted the same way."""
    stored, refusals = buffer.add_transforms(batch.stamps, batch.parents, batch.children, batch.translations,
                                             batch.rotations, now_s=now_s)
    return IngestResult(stored=stored, other_character=batch.other_character, refused=len(refusals),
                        first_refusal=refusals[0] if refusals else "")


def stamp_words(data: bytes) -> np.ndarray:
    """The uint32 index of every transform's ``stamp.sec`` in a serialized TFMessage (``nanosec`` is the
    next word): a publisher of pre-serialized messages restamps them there (bench/tf_throughput.py)."""
    return TFDecoder()._parse(data).stamp_words
