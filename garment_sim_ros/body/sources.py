"""Motion sources that can be sampled at any time: the procedural character and BVH clips.

A ``MotionSource`` bundles what a dressed character needs from its input: the skeleton, the
joint map, the rest pose the garments are fitted to (the canonical standing pose,
``body.canonical``), ``pose(t)`` in the world frame and ``motion(t)``, the root's kinematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .pose_buffer import RootMotion, SampleStatus
from .root import root_frame
from .skeleton import Skeleton, SkeletonPose

GAITS = ("walk", "run", "fast")
MOTION_WINDOW_S = 1.0 / 60.0  # finite-difference step of ``motion``


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

    def motion(self, t: float, window: float = MOTION_WINDOW_S) -> RootMotion:
        """Root motion at ``t`` by finite differences that never reach before the motion's start,
        past its end or across a loop's seam (one-sided there): a loop's seam is a jump, not motion."""
        start, end = 0.0, math.inf if self.duration is None else self.duration
        if self.period is not None:
            start = math.floor(t / self.period) * self.period
            end = start + self.period
        return motion_from_poses(self.pose, self.joint_map, t, window, (start, end))


def motion_from_poses(pose_at: Callable[[float], SkeletonPose], joint_map, t: float,
                      window: float = MOTION_WINDOW_S, span: tuple[float, float] = (-math.inf, math.inf)) -> RootMotion:
    """Root motion at ``t`` from poses ``window`` apart: central differences inside ``span``, one-sided
    (second order) where a central sample would fall outside it."""
    if t - window < span[0] - 1e-12:
        offsets = (0, 1, 2)  # forward
    elif t + window > span[1] + 1e-12:
        offsets = (-2, -1, 0)  # backward
    else:
        offsets = (-1, 0, 1)
    samples = [root_frame(pose_at(t + k * window), joint_map) for k in offsets]
    p = np.array([s[0] for s in samples])
    yaw = np.unwrap([s[1] for s in samples])
    here = offsets.index(0)
    # derivative weights at the sample ``here`` of three equally spaced ones (exact for quadratics)
    slope = {0: (-1.5, 2.0, -0.5), 1: (-0.5, 0.0, 0.5), 2: (0.5, -2.0, 1.5)}[here]

    def rate(values):
        return sum(w * v for w, v in zip(slope, values)) / window

    def curvature(values):
        return (values[0] - 2 * values[1] + values[2]) / window**2

    return RootMotion(
        status=SampleStatus.OK, dt=window, samples=3, position=p[here], yaw=float(samples[here][1]),
        velocity=rate(p), acceleration=curvature(p),
        yaw_rate=float(rate(yaw)), yaw_acceleration=float(curvature(yaw)),
    )


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
               joint_map: dict | None = None) -> MotionSource:
    """A BVH clip played at ``speed``; frame 0 is dropped when it is a reference pose (see
    ``body.bvh.load_bvh``) unless ``keep_first_frame``. The joint map is found from the first
    played frame (any pose serves), the rest pose is that frame stood up (``canonical_pose``)."""
    from .bvh import load_bvh
    from .canonical import canonical_pose
    from .joint_map import auto_joint_map

    if not (speed > 0.0 and math.isfinite(speed)):
        raise ValueError(f"playback speed must be a finite number > 0, got {speed!r}")
    clip = load_bvh(path, keep_first_frame=keep_first_frame)
    first = clip.pose(0)
    mapping = dict(joint_map) if joint_map else auto_joint_map(clip.skeleton, first.positions)

    def pose(t: float) -> SkeletonPose:
        return clip.sample(t * speed, loop=loop)

    def local_transforms(t: float) -> tuple[np.ndarray, np.ndarray]:
        return clip.sample_local(t * speed, loop=loop)

    played = clip.duration / speed
    return MotionSource(path, clip.skeleton, mapping, canonical_pose(first, mapping), pose,
                        None if loop else played, local_transforms, period=played if loop and played > 0 else None,
                        dropped_reference_frame=clip.dropped_reference_frame)
