"""Motion sources that can be sampled at any time: the procedural character and BVH clips.

A ``MotionSource`` bundles what a dressed character needs from its input: the skeleton, the
joint map, the rest pose the garments are fitted to, and ``pose(t)`` in the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .skeleton import Skeleton, SkeletonPose

GAITS = ("walk", "run", "fast")


@dataclass(frozen=True)
class MotionSource:
    name: str
    skeleton: Skeleton
    joint_map: dict
    rest_pose: SkeletonPose
    pose: Callable[[float], SkeletonPose]
    duration: float | None  # s; None = endless
    local_transforms: Callable[[float], tuple] | None = None  # parent-relative (J,3), (J,4), for /tf


def procedural_source(gait: str = "walk", height: float = 1.75) -> MotionSource:
    from . import procedural

    makers = {"walk": procedural.walk, "run": procedural.run, "fast": procedural.fast_motion}
    if gait not in makers:
        raise ValueError(f"unknown gait {gait!r}; known: {', '.join(GAITS)}")
    character = procedural.ProceduralCharacter(makers[gait](), height=height)
    return MotionSource(f"procedural {gait}", character.skeleton, dict(character.joint_map),
                        character.rest_pose(), character.pose, None, character.local_transforms)


def bvh_source(path: str, loop: bool = True, skip_first_frame: bool = False, speed: float = 1.0,
               joint_map: dict | None = None) -> MotionSource:
    from .bvh import load_bvh
    from .joint_map import auto_joint_map

    if not speed > 0.0:
        raise ValueError(f"playback speed must be > 0, got {speed!r}")
    clip = load_bvh(path, skip_first_frame=skip_first_frame)
    rest = clip.rest_pose()
    mapping = dict(joint_map) if joint_map else auto_joint_map(clip.skeleton, rest.positions)

    def pose(t: float) -> SkeletonPose:
        return clip.sample(t * speed, loop=loop)

    def local_transforms(t: float) -> tuple[np.ndarray, np.ndarray]:
        return clip.sample_local(t * speed, loop=loop)

    return MotionSource(path, clip.skeleton, mapping, rest, pose, None if loop else clip.duration / speed,
                        local_transforms)
