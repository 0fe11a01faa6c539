"""Joint glitches: a joint's rotation that leaves faster than a body moves and soon comes back.

Mocap solvers flip a joint now and then. Measured on the shared clips: the Character Creator
cartwheel's right thigh turns 106-179 deg between two 60 Hz frames (6000-10700 deg/s; its knee jumps
33-49 cm while the foot stays) and back 4-5 frames later; Xia's old-man toe turns 180 deg for 5 frames
at 120 Hz; the basketball clip's left thumb flips back and forth. The fastest real joint motion on
the shared clips is ~2900 deg/s (a CMU toe at 120 Hz, 24 deg in a frame); human gaits stay under
1200 deg/s, a jump's tuck is ~900 deg/s (test_fast_swings.py).

One rule for clips (``filter_glitches``, from ``body.bvh.load_bvh``) and /tf (``PoseBuffer``), per joint, on its
local rotation:

- a sample jumped (``rotation_jumped``) when it is more than ``MIN_GLITCH_ANGLE_DEG`` and faster than
  ``max_joint_speed`` (deg/s) from the joint's last good sample. It is held (not used);
- a later sample that is back (not a jump from the last good one, and nearer it than the newest held
  sample) ends a glitch: the held samples are dropped, the joint goes from its last good rotation
  to the returning one (a clip: the glitched frames are interpolated; /tf: the buffer interpolates
  across the gap and holds or extrapolates its last good data until then);
- data that stays away longer than ``max_glitch_time`` (s, counted from the first held sample) is a
  real fast move: the held samples are accepted as they came (live, that much later).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ..transforms import quat_slerp

# A rotation step smaller than this is never a glitch, however short the time between samples: at
# 1 kHz mocap noise of a few degrees is thousands of deg/s. The glitches measured turn >= 50 deg.
MIN_GLITCH_ANGLE_DEG = 30.0


def rotation_angle(a, b):
    """The angle (rad) of the rotation between unit quaternions ``a`` and ``b`` (..., 4)."""
    dot = np.abs(np.sum(np.asarray(a, float) * np.asarray(b, float), axis=-1))
    return 2.0 * np.arccos(np.minimum(dot, 1.0))


def turned(a, b) -> float:
    """``rotation_angle`` of two quaternions in plain Python (a /tf sample at a time: no numpy call)."""
    return 2.0 * math.acos(min(abs(sum(x * y for x, y in zip(a, b))), 1.0))


def rotation_jumped(angle_rad, elapsed_s, max_joint_speed: float):
    """Whether turning ``angle_rad`` in ``elapsed_s`` (s) is a jump at ``max_joint_speed`` (deg/s; 0: never);
    scalars or arrays of one shape."""
    if max_joint_speed <= 0.0:
        return np.zeros(np.shape(angle_rad), dtype=bool) if np.ndim(angle_rad) else False
    return (angle_rad > math.radians(MIN_GLITCH_ANGLE_DEG)) & (angle_rad > math.radians(max_joint_speed) * elapsed_s)


@dataclass
class Held:
    """A joint's samples held since its last good one (stamp s, rotation xyzw)."""

    good_stamp: float
    good_rotation: object  # xyzw, a sequence of 4
    samples: list[tuple] = field(default_factory=list)  # the caller's samples: (stamp, ..., rotation)


class GlitchHold:
    """Each joint's held samples, settled by its next samples (module docstring). ``offer`` says what
    to do with a sample; the caller stores what it is told to."""

    ACCEPT = "accept"  # store the sample
    HOLD = "hold"  # do not store it (yet)
    GLITCH = "glitch"  # the held samples were a glitch: drop them, store this one
    FAST_MOVE = "fast_move"  # the held samples were real: store them, then this one

    def __init__(self, max_joint_speed: float, max_glitch_time: float):
        self.max_joint_speed = max_joint_speed
        self.max_glitch_time = max_glitch_time
        self.held: dict[str, Held] = {}

    def forget(self, joint: str) -> None:
        self.held.pop(joint, None)

    def offer(self, joint: str, stamp: float, rotation, good_stamp: float, good_rotation, sample: tuple):
        """The verdict on ``joint``'s new sample after its last good one (``good_stamp``, ``good_rotation``),
        and the held samples it settles (each ``sample`` as given: its stamp first, its rotation last)."""
        held = self.held.get(joint)
        if held is None:
            if rotation_jumped(turned(good_rotation, rotation), stamp - good_stamp, self.max_joint_speed):
                self.held[joint] = Held(good_stamp, good_rotation, [sample])
                return self.HOLD, []
            return self.ACCEPT, []
        from_good = turned(held.good_rotation, rotation)
        from_spike = turned(held.samples[-1][-1], rotation)
        if not rotation_jumped(from_good, stamp - held.good_stamp, self.max_joint_speed) and from_good < from_spike:
            del self.held[joint]
            return self.GLITCH, held.samples
        if stamp - held.samples[0][0] > self.max_glitch_time:
            del self.held[joint]
            return self.FAST_MOVE, held.samples
        held.samples.append(sample)
        return self.HOLD, []


@dataclass
class GlitchReport:
    """The glitches a filter replaced: per joint, how many and the frames (or stamps) replaced."""

    counts: Counter[str] = field(default_factory=Counter)
    frames: dict[str, list[int]] = field(default_factory=dict)
    fast_moves: Counter[str] = field(default_factory=Counter)  # jumps that stayed: real motion, kept

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def summary(self, limit: int = 6) -> str:
        """One line: the glitch count and the joints with the most, with their frames."""
        if not self.total:
            return "no joint glitches"
        joints = sorted(self.counts, key=lambda j: (-self.counts[j], j))
        parts = [f"{joint} x{self.counts[joint]} (frames {frame_runs(self.frames[joint])})" for joint in joints[:limit]]
        more = f"; {len(joints) - limit} more joints" if len(joints) > limit else ""
        kept = sum(self.fast_moves.values())
        stayed = f" ({kept} jumps that stayed longer than max_glitch_time kept)" if kept else ""
        return f"{self.total} joint glitches replaced{stayed}: " + "; ".join(parts) + more

    def as_dict(self) -> dict:
        return {"total": self.total, "counts": dict(sorted(self.counts.items())),
                "frames": {joint: frames for joint, frames in sorted(self.frames.items())},
                "fast_moves_kept": dict(sorted(self.fast_moves.items()))}


def frame_runs(frames: list[int]) -> str:
    """Sorted frame numbers as runs: ``[5, 6, 7, 9]`` -> ``"5-7, 9"``."""
    runs: list[list[int]] = []
    for frame in frames:
        if runs and frame == runs[-1][1] + 1:
            runs[-1][1] = frame
        else:
            runs.append([frame, frame])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def filter_glitches(names, rotations: np.ndarray, frame_time: float, max_joint_speed: float,
                    max_glitch_time: float, first_frame: int = 0) -> tuple[np.ndarray, GlitchReport]:
    """A clip's local rotations (F, J, 4) with each joint's glitches replaced (slerp from its last good
    frame to the returning one), and the report (frames numbered from ``first_frame``, the file's
    number of row 0). Only joints with a jump between two frames are walked."""
    report = GlitchReport()
    if max_joint_speed <= 0.0 or len(rotations) < 3:
        return rotations, report
    steps = rotation_angle(rotations[:-1], rotations[1:])
    suspects = np.nonzero(rotation_jumped(steps, frame_time, max_joint_speed).any(axis=0))[0]
    if not len(suspects):
        return rotations, report
    rotations = rotations.copy()
    hold = GlitchHold(max_joint_speed, max_glitch_time)
    for j in suspects.tolist():
        name, good = names[j], 0
        for f in range(1, len(rotations)):
            verdict, settled = hold.offer(name, f * frame_time, rotations[f, j], good * frame_time,
                                          rotations[good, j], (f * frame_time, f, rotations[f, j]))
            if verdict == GlitchHold.GLITCH:
                held = [frame for _, frame, _ in settled]
                weights = (np.array(held) - good) / (f - good)
                rotations[held, j] = quat_slerp(rotations[good, j], rotations[f, j], weights)
                report.counts[name] += 1
                report.frames.setdefault(name, []).extend(first_frame + frame for frame in held)
            elif verdict == GlitchHold.FAST_MOVE:
                report.fast_moves[name] += 1
            if verdict != GlitchHold.HOLD:
                good = f
        hold.forget(name)  # held at the clip's end: nothing came back, the frames stay as they are
    return rotations, report
