"""/tf and /tf_static messages into a ``PoseBuffer`` (ROS-free: reads the message's fields only).

One character per frame prefix: a transform belongs to the character when its child frame starts
with the prefix (every transform when the prefix is empty); others are another character's and
are skipped without complaint. Frame names lose a leading '/' (tf2 does the same). What the
buffer refuses (NaN, zero quaternions, cycles, far too old or future stamps...) is counted there
(``PoseBuffer.rejected``) and the first reason is kept for a throttled log line.
"""

from __future__ import annotations

from dataclasses import dataclass


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
