"""BVH motion-capture clips, converted once at the edge to REP-103 (z up, metres).

A small parser of our own: the maintained candidate, ``bvhio`` 1.5.4, pins a compiled
``pyglm==2.8.2``, builds one Python transform object per joint per frame (slow for 2752 x 31),
loops forever on a truncated MOTION section (``readline`` at end of file never raises) and
reports wrong line numbers past the first joint. This one reads the MOTION block in one numpy
call and names the file and line of every error.

Axes: BVH is y up; a character facing +z in the file has its left on +x. The proper rotation
``M: (x, y, z)_bvh -> (z, x, y)_rep`` maps BVH forward (+z) to REP-103 forward (+x), BVH left
(+x) to +y and BVH up (+y) to +z. Local translations are rotated by ``M`` (and scaled to metres),
local rotations are conjugated by ``M``, so world positions come out as ``M`` times the file's.

Euler channels are applied in the order written, intrinsic, as BVH defines it:
``CHANNELS 3 Zrotation Xrotation Yrotation`` means ``R = Rz(a) Rx(b) Ry(c)``.
A joint's local translation is its OFFSET, with each axis that has a position channel replaced
by the channel's value (the root's position channels give its position).

End Sites are kept as leaf joints named ``<parent>_end`` (no channels, identity rotation): they
give the head and the feet their length.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from ..params import DEFAULT_PARAMS
from ..transforms import IDENTITY_QUAT, quat_from_axis_angle, quat_multiply, quat_rotate, quat_slerp
from .glitches import GlitchReport, filter_glitches
from .skeleton import Skeleton, SkeletonPose, forward_kinematics

# File length units -> metres. CMU: the cgspeed conversions keep the ASF's unit of 1/0.45 inch.
UNIT_SCALES: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "cmu": 0.05644,
}
# Auto-detection picks the unit that makes the skeleton's longest bone path (a foot to the other
# hand, ``_tree_span``) closest to this, within the plausible range: measured 2.09-2.22 m on the
# shared CMU, Xia and Character Creator clips (1.6-1.9 m people).
_TYPICAL_EXTENT_M = 2.1
_PLAUSIBLE_EXTENT_M = (0.7, 4.5)

# BVH axis letter -> the REP-103 axis it becomes under M.
_REP_AXIS = {"X": np.array([0.0, 1.0, 0.0]), "Y": np.array([0.0, 0.0, 1.0]), "Z": np.array([1.0, 0.0, 0.0])}
_CHANNEL = re.compile(r"^([XYZ])(position|rotation)$")


class BvhError(ValueError):
    """A BVH file could not be read; the message names the file and the line."""


def bvh_to_rep(v: np.ndarray) -> np.ndarray:
    """Vectors (..., 3) from BVH axes to REP-103 axes: ``(x, y, z) -> (z, x, y)``."""
    v = np.asarray(v, dtype=float)
    return v[..., [2, 0, 1]]


@dataclass(frozen=True)
class Clip:
    """A motion clip in REP-103 metres.

    ``translations (F, J, 3)`` and ``rotations (F, J, 4)`` (xyzw) are local to each joint's
    parent (the root's to the world); ``offsets (J, 3)`` are the rest-pose local translations.
    """

    path: str
    skeleton: Skeleton
    offsets: np.ndarray
    translations: np.ndarray
    rotations: np.ndarray
    frame_time: float
    units_scale: float  # metres per file unit
    dropped_reference_frame: bool = False  # frame 0 of the file was a reference pose and is not here
    glitches: GlitchReport = field(default_factory=GlitchReport)  # joint glitches replaced on load (file frames)

    @property
    def frames(self) -> int:
        return int(self.translations.shape[0])

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Time from the first to the last frame, s."""
        return (self.frames - 1) * self.frame_time

    def pose(self, i: int) -> SkeletonPose:
        if not -self.frames <= i < self.frames:
            raise IndexError(f"{self.path}: frame {i} out of range; the clip has {self.frames} frames")
        return forward_kinematics(self.skeleton, self.translations[i], self.rotations[i])

    def without_first_frame(self) -> "Clip":
        if self.frames < 2:
            raise BvhError(f"{self.path}: cannot drop the first frame of a clip with {self.frames} frame")
        return replace(self, translations=self.translations[1:], rotations=self.rotations[1:],
                       dropped_reference_frame=True)

    def frame_positions(self, frames: slice) -> np.ndarray:
        """World joint positions (F, J, 3) of a range of frames."""
        return np.array([self.pose(i).positions for i in range(*frames.indices(self.frames))])

    def sample_local(self, t: float, loop: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Local translations (J, 3) and rotations (J, 4) at time ``t`` (s from the first frame).

        Translations are interpolated linearly, rotations by slerp, joint by joint. ``loop``: the
        clip restarts after its last frame (period ``duration``, no blend across the seam: mocap
        clips do not end where they start); otherwise ``t`` is clamped to the clip.
        """
        if not math.isfinite(t):
            raise ValueError(f"{self.path}: sample time must be finite, got {t!r}")
        if self.frames == 1:
            return self.translations[0], self.rotations[0]
        t = t % self.duration if loop else min(max(t, 0.0), self.duration)
        position = t / self.frame_time
        i = min(int(position), self.frames - 2)
        a = position - i
        translations = (1.0 - a) * self.translations[i] + a * self.translations[i + 1]
        return translations, quat_slerp(self.rotations[i], self.rotations[i + 1], a)

    def sample(self, t: float, loop: bool = False) -> SkeletonPose:
        """World pose at time ``t``: ``sample_local`` composed down the tree."""
        return forward_kinematics(self.skeleton, *self.sample_local(t, loop))

    def joint_trajectory(self, name: str) -> np.ndarray:
        """World positions (F, 3) of one joint over every frame (composes only its ancestors)."""
        chain = [self.skeleton.index(name)]
        while self.skeleton.parents[chain[-1]] >= 0:
            chain.append(self.skeleton.parents[chain[-1]])
        position = self.translations[:, chain[-1]]
        rotation = self.rotations[:, chain[-1]]
        for j in reversed(chain[:-1]):
            position = position + quat_rotate(rotation, self.translations[:, j])
            rotation = quat_multiply(rotation, self.rotations[:, j])
        return position


@dataclass
class _Joint:
    name: str
    parent: int
    offset: np.ndarray
    channels: list[str]
    line: int  # line of the JOINT/ROOT/End Site keyword


class _Lines:
    """Non-empty lines with their 1-based numbers, for error messages."""

    def __init__(self, path: str, text: str):
        self.path = path
        self.items = [(n, line.split()) for n, line in enumerate(text.splitlines(), 1) if line.strip()]
        self.pos = 0
        self.last_line = text.count("\n") + 1

    def error(self, line: int, message: str) -> BvhError:
        return BvhError(f"{self.path}:{line}: {message}")

    def next(self, expected: str) -> tuple[int, list[str]]:
        if self.pos >= len(self.items):
            raise self.error(self.last_line, f"unexpected end of file, expected {expected}")
        item = self.items[self.pos]
        self.pos += 1
        return item

    def expect(self, what: str, ok: Callable[[list[str]], bool], message: str) -> tuple[int, list[str]]:
        """The next line (``what`` names it at the end of the file); unless ``ok(tokens)``, refused with
        ``message`` and what the line says."""
        line, tokens = self.next(what)
        if not ok(tokens):
            raise self.error(line, f"{message}, got {' '.join(tokens)!r}")
        return line, tokens


def _parse_floats(lines: _Lines, line: int, tokens: list[str], what: str) -> np.ndarray:
    values = []
    for token in tokens:
        try:
            values.append(float(token))
        except ValueError:
            raise lines.error(line, f"{what}: {token!r} is not a number") from None
    return np.array(values)


def _parse_hierarchy(lines: _Lines) -> list[_Joint]:
    lines.expect("HIERARCHY", lambda tokens: tokens == ["HIERARCHY"], "expected 'HIERARCHY'")
    line, tokens = lines.expect("ROOT", lambda tokens: tokens[0] == "ROOT" and len(tokens) == 2,
                                "expected 'ROOT <name>'")
    joints: list[_Joint] = []
    _parse_joint(lines, joints, tokens[1], -1, line, end_site=False)
    return joints


def _parse_joint(lines: _Lines, joints: list[_Joint], name: str, parent: int, line: int, end_site: bool) -> None:
    lines.expect("'{'", lambda tokens: tokens == ["{"], f"expected '{{' after joint {name!r}")
    offset_line, tokens = lines.expect("OFFSET", lambda tokens: tokens[0] == "OFFSET" and len(tokens) == 4,
                                       f"joint {name!r}: expected 'OFFSET x y z'")
    offset = _parse_floats(lines, offset_line, tokens[1:], f"joint {name!r} OFFSET")
    channels: list[str] = []
    if not end_site:
        channel_line, tokens = lines.expect(
            "CHANNELS", lambda tokens: tokens[0] == "CHANNELS" and len(tokens) >= 2 and tokens[1].isdigit(),
            f"joint {name!r}: expected 'CHANNELS <count> <names...>'")
        channels = tokens[2:]
        if int(tokens[1]) != len(channels):
            raise lines.error(channel_line, f"joint {name!r}: CHANNELS says {tokens[1]} but lists {len(channels)}")
        for channel in channels:
            if not _CHANNEL.match(channel):
                raise lines.error(channel_line, f"joint {name!r}: unknown channel {channel!r}; allowed: "
                                                "Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation")
        if len(set(channels)) != len(channels):
            raise lines.error(channel_line, f"joint {name!r}: a channel is listed twice: {' '.join(channels)}")
    joints.append(_Joint(name, parent, offset, channels, line))
    index = len(joints) - 1
    while True:
        child_line, tokens = lines.next("JOINT, End Site or '}'")
        if tokens == ["}"]:
            return
        if end_site:
            raise lines.error(child_line, f"an End Site has no children; expected '}}', got {' '.join(tokens)!r}")
        if tokens[0] == "JOINT" and len(tokens) == 2:
            _parse_joint(lines, joints, tokens[1], index, child_line, end_site=False)
        elif tokens == ["End", "Site"]:
            _parse_joint(lines, joints, f"{name}_end", index, child_line, end_site=True)
        else:
            raise lines.error(child_line, f"joint {name!r}: expected 'JOINT <name>', 'End Site' or '}}', "
                                          f"got {' '.join(tokens)!r}")


def _parse_motion(lines: _Lines, channel_count: int) -> tuple[np.ndarray, float]:
    lines.expect("MOTION", lambda tokens: tokens == ["MOTION"], "expected 'MOTION' after the hierarchy")
    line, tokens = lines.expect("'Frames: <count>'", lambda tokens: len(tokens) == 2 and tokens[0] == "Frames:"
                                and tokens[1].isdigit() and int(tokens[1]) >= 1, "expected 'Frames: <count >= 1>'")
    frame_count = int(tokens[1])
    line, tokens = lines.expect("'Frame Time: <seconds>'", lambda tokens: len(tokens) == 3
                                and tokens[:2] == ["Frame", "Time:"], "expected 'Frame Time: <seconds>'")
    frame_time = float(_parse_floats(lines, line, tokens[2:], "Frame Time")[0])
    if not (math.isfinite(frame_time) and frame_time > 0.0):
        raise lines.error(line, f"Frame Time must be a positive number of seconds, got {tokens[2]!r}")
    rows = lines.items[lines.pos:]
    if len(rows) < frame_count:
        raise lines.error(lines.last_line, f"truncated MOTION: 'Frames: {frame_count}' but only {len(rows)} "
                                           "frame lines follow")
    if len(rows) > frame_count:
        raise lines.error(rows[frame_count][0], f"{len(rows) - frame_count} line(s) after the {frame_count} "
                                                "frames that 'Frames:' announces")
    for n, values in rows:
        if len(values) != channel_count:
            raise lines.error(n, f"frame line has {len(values)} values, the hierarchy declares "
                                 f"{channel_count} channels")
    try:
        data = np.array([values for _, values in rows], dtype=float)
    except ValueError:
        for n, values in rows:
            _parse_floats(lines, n, values, "frame values")
        raise
    if not np.all(np.isfinite(data)):
        n = rows[int(np.argwhere(~np.isfinite(data))[0, 0])][0]
        raise lines.error(n, "frame values must be finite numbers")
    return data, frame_time


def _tree_span(joints: list[_Joint]) -> float:
    """The longest path between two joints along the bones (sum of OFFSET lengths), file units.

    Pose-independent, unlike the OFFSETS pose's height: rigs that keep their bind in the rotation
    channels lay their bones along one axis (all flat, or all stacked) when rotations are identity.
    For a human this is the span from a foot to a hand (about 1.3 statures, fingers included)."""
    neighbours: list[list[tuple[int, float]]] = [[] for _ in joints]
    for i, joint in enumerate(joints):
        if joint.parent >= 0:
            length = float(np.linalg.norm(joint.offset))
            neighbours[i].append((joint.parent, length))
            neighbours[joint.parent].append((i, length))

    def farthest(start: int) -> tuple[int, float]:
        distance = {start: 0.0}
        stack = [start]
        while stack:
            i = stack.pop()
            for j, length in neighbours[i]:
                if j not in distance:
                    distance[j] = distance[i] + length
                    stack.append(j)
        end = max(distance, key=distance.get)
        return end, distance[end]

    return farthest(farthest(0)[0])[1]  # two sweeps find a tree's longest path


def resolve_units(units: str | float, extent: float, path: str) -> float:
    """Metres per file unit: a name of ``UNIT_SCALES``, a positive number, or ``"auto"``."""
    if isinstance(units, (int, float)) and not isinstance(units, bool):
        if not (math.isfinite(units) and units > 0.0):
            raise BvhError(f"{path}: units scale must be a positive number of metres per unit, got {units!r}")
        return float(units)
    if units == "auto":
        if extent <= 0.0:
            raise BvhError(f"{path}: the skeleton's bones have no length; cannot detect units, pass units=")
        plausible = {name: scale for name, scale in UNIT_SCALES.items()
                     if _PLAUSIBLE_EXTENT_M[0] <= extent * scale <= _PLAUSIBLE_EXTENT_M[1]}
        if not plausible:
            raise BvhError(f"{path}: the skeleton spans {extent:g} file units foot to hand, which is no human in "
                           f"any of {', '.join(UNIT_SCALES)}; pass units= explicitly")
        return min(plausible.values(), key=lambda s: abs(math.log(extent * s / _TYPICAL_EXTENT_M)))
    if units in UNIT_SCALES:
        return UNIT_SCALES[units]
    raise BvhError(f"{path}: unknown units {units!r}; allowed: auto, {', '.join(UNIT_SCALES)} or metres per unit")


def _euler_quaternions(channels: list[str], values: np.ndarray) -> np.ndarray:
    """Local rotations (F, 4) in REP-103 axes from one joint's Euler channels (degrees)."""
    rotation = np.tile(IDENTITY_QUAT, (values.shape[0], 1))
    for k, channel in enumerate(channels):
        axis, kind = _CHANNEL.match(channel).groups()
        if kind == "rotation":
            rotation = quat_multiply(rotation, quat_from_axis_angle(_REP_AXIS[axis], np.radians(values[:, k])))
    return rotation


def load_bvh(path: str | Path, units: str | float = "auto", keep_first_frame: bool = False,
             max_joint_speed: float = DEFAULT_PARAMS.max_joint_speed,
             max_glitch_time: float = DEFAULT_PARAMS.max_glitch_time) -> Clip:
    """Read a BVH file into a ``Clip`` in REP-103 metres.

    ``units``: ``"auto"`` (from the rest pose's height), a name of ``UNIT_SCALES`` or metres per
    file unit. Frame 0 is dropped when it is a reference pose (``starts_with_reference_frame``: a
    T-pose the motion jumps away from, as in CMU 01_01 and the Character Creator exports;
    ``Clip.dropped_reference_frame`` says so), unless ``keep_first_frame``. Then each joint's glitches
    (``body.glitches``: ``max_joint_speed`` deg/s, 0 for none; ``max_glitch_time`` s) are replaced,
    reported in ``Clip.glitches`` by file frame.
    """
    path = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise BvhError(f"{path}: cannot read BVH file: {err.strerror or err}") from None
    lines = _Lines(path, text)
    joints = _parse_hierarchy(lines)
    channel_count = sum(len(j.channels) for j in joints)
    data, frame_time = _parse_motion(lines, channel_count)
    scale = resolve_units(units, _tree_span(joints), path)

    names = [j.name for j in joints]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        first = next(j for j in joints if j.name == duplicates[0])
        raise lines.error(first.line, f"joint names must be unique; repeated: {', '.join(duplicates)}")
    skeleton = Skeleton(tuple(names), tuple(j.parent for j in joints))

    frames = data.shape[0]
    offsets_file = np.array([j.offset for j in joints])
    translations_file = np.broadcast_to(offsets_file, (frames, len(joints), 3)).copy()
    rotations = np.empty((frames, len(joints), 4))
    column = 0
    for i, joint in enumerate(joints):
        values = data[:, column:column + len(joint.channels)]
        for k, channel in enumerate(joint.channels):
            axis, kind = _CHANNEL.match(channel).groups()
            if kind == "position":
                translations_file[:, i, "XYZ".index(axis)] = values[:, k]
        rotations[:, i] = _euler_quaternions(joint.channels, values)
        column += len(joint.channels)
    clip = Clip(
        path=path,
        skeleton=skeleton,
        offsets=bvh_to_rep(offsets_file) * scale,
        translations=bvh_to_rep(translations_file) * scale,
        rotations=rotations,
        frame_time=frame_time,
        units_scale=scale,
    )
    if not keep_first_frame and starts_with_reference_frame(clip):
        clip = clip.without_first_frame()
    rotations, glitches = filter_glitches(names, clip.rotations, frame_time, max_joint_speed, max_glitch_time,
                                          first_frame=int(clip.dropped_reference_frame))
    return replace(clip, rotations=rotations, glitches=glitches)


# A first frame counts as a reference pose when the joints move, on average, this much more from it
# to frame 1 than between the frames after it, and at least REFERENCE_JUMP_M (m): measured on the shared
# clips, real first steps move 0.2-2 cm per frame, the reference frames 11-180 cm.
REFERENCE_JUMP_RATIO = 5.0
REFERENCE_JUMP_M = 0.05
_REFERENCE_WINDOW = 12  # frames after the first that set the clip's usual step


def starts_with_reference_frame(clip: Clip) -> bool:
    """Whether frame 0 is a reference pose (T/A-pose) rather than motion: the mean joint moves much
    farther from it to frame 1 than it usually moves in a frame."""
    if clip.frames < 3:
        return False
    positions = clip.frame_positions(slice(0, _REFERENCE_WINDOW + 2))
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=2).mean(axis=1)
    return bool(steps[0] > REFERENCE_JUMP_M and steps[0] > REFERENCE_JUMP_RATIO * np.median(steps[1:]))
