"""What sampling a skeleton source returns: a pose or the root's kinematics, with how it was obtained.

One contract for the /tf buffer (``pose_buffer.PoseBuffer``) and the clips (``sources``): the
character loop and ``dressing.DressedCharacter`` read these whatever the source.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from .skeleton import SkeletonPose


class SampleStatus(Enum):
    """How a sample was obtained, in increasing severity."""

    OK = "ok"  # interpolated between stamps (or only static transforms)
    EXTRAPOLATED = "extrapolated"  # past the newest stamp (bounded) or before the oldest (held)
    STALE = "stale"  # the newest data is older than max_age_s; the pose is the held extrapolation
    MISSING_FRAMES = "missing_frames"  # some frames are unknown or not connected to the fixed frame
    DEGENERATE = "degenerate"  # root_motion only: the hips coincide horizontally, no heading (counted)
    NO_DATA = "no_data"  # nothing received yet


@dataclass(frozen=True)
class PoseSample:
    pose: SkeletonPose | None  # None for MISSING_FRAMES and NO_DATA
    status: SampleStatus
    missing: tuple[str, ...]  # requested frames that could not be composed
    age_s: float  # T minus the newest stamp of the stalest dynamic frame used (< 0: T inside the data)
    detail: str = ""  # human-readable reason for a status other than OK


@dataclass(frozen=True)
class RootMotion:
    """Root kinematics at time ``T`` (fixed frame, SI units). When ``status`` is MISSING_FRAMES,
    NO_DATA or DEGENERATE the kinematic fields are None."""

    status: SampleStatus
    dt: float  # the frame time the increments are for, s
    samples: int  # samples in the least-squares fit (0: no dynamic data, velocities are zero)
    position: np.ndarray | None  # (3,) pelvis position at T, m
    yaw: float | None  # heading at T, rad, in (-pi, pi]
    velocity: np.ndarray | None  # (3,) v0, m/s
    acceleration: np.ndarray | None  # (3,) a0, m/s^2
    yaw_rate: float | None  # rad/s
    yaw_acceleration: float | None  # rad/s^2
    detail: str = ""

    @property
    def dx(self) -> np.ndarray:
        """Root translation over the frame, ``v0 dt + a0 dt^2 / 2`` (memo §4)."""
        return self.velocity * self.dt + 0.5 * self.acceleration * self.dt ** 2

    @property
    def dyaw(self) -> float:
        return self.yaw_rate * self.dt + 0.5 * self.yaw_acceleration * self.dt ** 2
