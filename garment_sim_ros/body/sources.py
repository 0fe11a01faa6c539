"""Motion sources that can be sampled at any time: the procedural character and BVH clips.

A ``MotionSource`` bundles what a dressed character needs from its input: the skeleton, the
joint map, the rest pose the garments are fitted to (the canonical standing pose,
``body.canonical``), ``pose(t)`` in the world frame and ``motion(t)``, the root's kinematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..params import DEFAULT_PARAMS
from .glitches import GlitchReport
from .root import fit_root_kinematics, root_frame
from .samples import RootMotion, SampleStatus
from .skeleton import Skeleton, SkeletonPose

GAITS = ("walk", "run", "fast")
# ``motion``'s window and sampling step, s: the node's pose buffer fits the same quadratic over the same
# window (``PoseBuffer(kinematics_window_s=0.1)``), so a clip and its /tf stream give one root motion.
MOTION_WINDOW_S = 0.1
MOTION_SAMPLE_S = 1.0 / 120.0


@dataclass(frozen=True)
class MotionSource:
    name: str
    skeleton: Skeleton
    joint_map: dict
    rest_pose: SkeletonPose  # the canonical standing pose (body.canonical), world frame
    pose: Callable[[float], SkeletonPose]
    duration: float | None  # s; None = endless
    local_transforms: Callable[[float], tuple] | None = None  # parent-relative (J,3), (J,4), for /tf
    period: float | None = None  # s: the motion starts again every period (a looping clip), else None
    dropped_reference_frame: bool = False  # the clip's frame 0 was a reference pose, not played
    glitches: GlitchReport = field(default_factory=GlitchReport)  # the clip's joint glitches, replaced

    def loop_index(self, t: float) -> int:
        """Which pass through a looping clip time ``t`` falls in (0 for a source that does not loop)."""
        return 0 if self.period is None else math.floor(t / self.period)

    def fit_poses(self) -> list[SkeletonPose]:
        """The poses the body is fitted to (``body.fitting.fit_body(motion=...)``): the one it is dressed on,
        at t = 0, as in the node, which has seen no more. (Fitted to every frame of a clip instead, the
        acrobatic clips' trunks go to their slimmest bound for an arm that crosses them later, and the real
        clips fared worse: README, "Real motion".)"""
        return [self.pose(0.0)]

    def motion(self, t: float, window: float = MOTION_WINDOW_S) -> RootMotion:
        """Root motion at ``t`` from samples that never reach before the motion's start, past its end or
        across a loop's seam (one-sided there): a loop's seam is a jump, not motion."""
        start, end = 0.0, math.inf if self.duration is None else self.duration
        if self.period is not None:
            # inside the loop by a hair at both ends: the period's own end is the next loop's start, and a
            # loop's start computed in floating point may land on the previous loop's end
            loop_start = self.loop_index(t) * self.period
            start, end = loop_start + 1e-9 * self.period, loop_start + (1.0 - 1e-9) * self.period
        return motion_from_poses(self.pose, self.joint_map, t, window, (start, end))


def motion_from_poses(pose_at: Callable[[float], SkeletonPose], joint_map, t: float,
                      window: float = MOTION_WINDOW_S, span: tuple[float, float] = (-math.inf, math.inf)) -> RootMotion:
    """Root motion at ``t``: the node's estimator (``body.root.fit_root_kinematics``, a least-squares
    quadratic) over poses sampled every ``MOTION_SAMPLE_S`` in a ``window`` centred on ``t``, cut to
    ``span`` (so one-sided at a clip's ends and a loop's seam, never across them)."""
    half = 0.5 * window
    start, end = max(t - half, span[0]), min(t + half, span[1])
    count = max(3, int(round((end - start) / MOTION_SAMPLE_S)) + 1)
    times = np.linspace(start, end, count) if end > start else np.array([t])
    samples = [root_frame(pose_at(float(s)), joint_map) for s in times]
    position, yaw = root_frame(pose_at(t), joint_map)
    if len(times) < 2:
        still = np.zeros(3)
        return RootMotion(SampleStatus.OK, window, 1, position, yaw, still, still, 0.0, 0.0)
    velocity, acceleration, yaw_rate, yaw_acceleration = fit_root_kinematics(
        times - t, np.array([s[0] for s in samples]), [s[1] for s in samples])
    return RootMotion(SampleStatus.OK, window, len(times), position, yaw, velocity, acceleration,
                      yaw_rate, yaw_acceleration)


def procedural_source(gait: str = "walk", height: float = 1.75) -> MotionSource:
    from . import procedural
    from .canonical import canonical_pose

    makers = {"walk": procedural.walk, "run": procedural.run, "fast": procedural.fast_motion}
    if gait not in makers:
        raise ValueError(f"unknown gait {gait!r}; known: {', '.join(GAITS)}")
    character = procedural.ProceduralCharacter(makers[gait](), height=height)
    joint_map = dict(character.joint_map)
    return MotionSource(f"procedural {gait}", character.skeleton, joint_map,
                        canonical_pose(character.rest_pose(), joint_map), character.pose, None,
                        character.local_transforms)


def bvh_source(path: str, loop: bool = True, keep_first_frame: bool = False, speed: float = 1.0,
               joint_map: dict | None = None, params=DEFAULT_PARAMS) -> MotionSource:
    """A BVH clip played at ``speed``; frame 0 is dropped when it is a reference pose (see
    ``body.bvh.load_bvh``) unless ``keep_first_frame``, joint glitches are replaced by ``params``'
    ``max_joint_speed`` and ``max_glitch_time``. The joint map is found from the first played frame
    (any pose serves), the rest pose is that frame stood up (``canonical_pose``)."""
    from .bvh import load_bvh
    from .canonical import canonical_pose
    from .joint_map import auto_joint_map

    if not (speed > 0.0 and math.isfinite(speed)):
        raise ValueError(f"playback speed must be a finite number > 0, got {speed!r}")
    clip = load_bvh(path, keep_first_frame=keep_first_frame, max_joint_speed=params.max_joint_speed,
                    max_glitch_time=params.max_glitch_time)
    first = clip.pose(0)
    mapping = dict(joint_map) if joint_map else auto_joint_map(clip.skeleton, first.positions)

    def pose(t: float) -> SkeletonPose:
        return clip.sample(t * speed, loop=loop)

    def local_transforms(t: float) -> tuple[np.ndarray, np.ndarray]:
        return clip.sample_local(t * speed, loop=loop)

    played = clip.duration / speed
    return MotionSource(path, clip.skeleton, mapping, canonical_pose(first, mapping), pose,
                        None if loop else played, local_transforms, period=played if loop and played > 0 else None,
                        dropped_reference_frame=clip.dropped_reference_frame, glitches=clip.glitches)
