"""A procedural walking/running humanoid: the demo's default input and the tests' fast-motion source.

No file needed. The skeleton is a 1.75 m adult (scaled by ``height``), z up, facing +x, left = +y,
standing with its soles on z = 0. Joint local frames have identity rotations at rest: each bone
offset is expressed in its parent's axes, so in the rest pose every joint's world rotation is the
identity and the arms hang 10 deg out from the body (the pose garments are fitted to).

The gait is a sum of sinusoids of the gait phase ``phi = 2 pi f t`` (``f`` the stride frequency:
one stride = a left and a right step, each leg swings once per stride):

- hip flexion ``A sin(phi)`` (right leg half a cycle later), so its peak angular speed is
  ``2 pi f A``; the knee bends ``K max(0, cos phi)^2`` during the swing (while the hip flexes);
  the ankle keeps the foot level;
- each arm swings against the leg of its side, ``-B sin(phi)``, peak speed ``2 pi f B``;
  the elbows bend by a constant angle;
- the pelvis twists ``-T sin(phi)`` about z, the chest counter-twists, the neck keeps the head
  on the heading; the pelvis drops ``bob sin(phi)^2`` (lowest at double support);
- the root travels at ``speed`` along a circle of radius ``speed / turn_rate`` (a line when the
  turn rate is 0).

Feet roughly plant: by default the hip amplitude is the one whose step length matches the
stride, ``stride / 4 = L sin A cos T + w sin T`` (``L`` the hip-to-ankle length, ``w`` the hip's
lateral offset, ``T`` the twist: the pelvis rotation lengthens the step), so the stance foot's
net slip over a stance is zero (a sinusoidal swing still slides it back and forth a little within
the stance).
A straight stance leg at ``+-A`` lifts the ankle by ``L (1 - cos A)``; a bob up to that keeps the
stance foot on or above the floor (a smaller one lifts it a little at the ends of the stance, like
heel strike and toe-off).

A start-up ramp scales every amplitude, the travel speed and the turn rate by a smooth step
``s(t)`` (0 at t <= 0, 1 from ``ramp_s`` on, C2; the bob by ``s^2``, as the stance leg's lift),
so ``pose(0)`` is exactly the rest pose and the root's acceleration stays finite. Everything is a
pure function of ``t``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from ..params import ParameterError
from ..transforms import quat_from_axis_angle, quat_multiply
from .skeleton import Skeleton, SkeletonPose, forward_kinematics

REFERENCE_HEIGHT = 1.75  # m: the proportions below are for this standing height
ARM_ABDUCTION_DEG = 10.0  # rest-pose angle between each arm and the body

# Bone offsets of the reference adult in the parent's axes (m), and the side they belong to.
_UPPER_ARM_M = 0.31
_FOREARM_M = 0.25
_ARM_DIR = np.array([0.0, math.sin(math.radians(ARM_ABDUCTION_DEG)), -math.cos(math.radians(ARM_ABDUCTION_DEG))])
_CENTRE_BONES: tuple[tuple[str, str | None, tuple[float, float, float]], ...] = (
    ("pelvis", None, (0.0, 0.0, 0.95)),  # root: offset from the world origin, on the floor
    ("spine", "pelvis", (0.0, 0.0, 0.10)),
    ("chest", "spine", (0.0, 0.0, 0.22)),
    ("neck", "chest", (0.0, 0.0, 0.21)),
    ("head", "neck", (0.0, 0.0, 0.14)),
)
_SIDE_BONES: tuple[tuple[str, str, tuple[float, float, float]], ...] = (
    ("hip", "pelvis", (0.0, 0.09, -0.05)),
    ("knee", "hip", (0.0, 0.0, -0.42)),
    ("ankle", "knee", (0.0, 0.0, -0.40)),
    ("toe", "ankle", (0.14, 0.0, -0.06)),
    ("shoulder", "chest", (0.0, 0.19, 0.17)),
    ("elbow", "shoulder", tuple(_UPPER_ARM_M * _ARM_DIR)),
    ("wrist", "elbow", tuple(_FOREARM_M * _ARM_DIR)),
)
_HEAD_TOP_M = (0.0, 0.0, 0.13)  # crown of the head in the head frame, reference adult


def _build_skeleton() -> tuple[Skeleton, np.ndarray]:
    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, float, float]] = []
    for name, parent, offset in _CENTRE_BONES:
        names.append(name)
        parents.append(-1 if parent is None else names.index(parent))
        offsets.append(offset)
    centre = set(names)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        for name, parent, (x, y, z) in _SIDE_BONES:
            parent_name = parent if parent in centre else f"{side}_{parent}"
            names.append(f"{side}_{name}")
            parents.append(names.index(parent_name))
            offsets.append((x, sign * y, z))
    return Skeleton(tuple(names), tuple(parents)), np.array(offsets)


_SKELETON, _REFERENCE_OFFSETS = _build_skeleton()

WALKER_JOINT_MAP: dict[str, str] = {
    "pelvis": "pelvis", "spine": "spine", "chest": "chest", "neck": "neck", "head": "head",
    **{
        f"{side}_{role}": f"{side}_{frame}"
        for side in ("left", "right")
        for role, frame in (
            ("upper_leg", "hip"), ("lower_leg", "knee"), ("foot", "ankle"),
            ("upper_arm", "shoulder"), ("lower_arm", "elbow"), ("hand", "wrist"),
        )
    },
}


def _joint(name: str) -> int:
    return _SKELETON.index(name)


def _sides(frame: str) -> list[int]:
    return [_joint(f"left_{frame}"), _joint(f"right_{frame}")]


@dataclass(frozen=True)
class Gait:
    """Gait parameters, SI units with the unit in the name. Give ``stride_frequency_hz`` or
    ``stride_length_m`` (the other follows from ``speed_mps``); ``hip_swing_deg=None`` derives the
    amplitude whose step matches the stride from the character's leg length (feet plant)."""

    speed_mps: float = 1.3  # root travel speed, 0 = in place
    stride_frequency_hz: float | None = None  # strides (gait cycles) per second; cadence = 2x steps/s
    stride_length_m: float | None = None  # distance travelled per stride
    hip_swing_deg: float | None = None  # hip flexion amplitude (+-)
    knee_bend_deg: float = 60.0  # peak knee flexion in the swing
    arm_swing_deg: float = 15.0  # shoulder flexion amplitude (+-)
    elbow_bend_deg: float = 15.0  # constant elbow flexion
    pelvis_bob_m: float = 0.04  # pelvis drop at double support
    torso_twist_deg: float = 5.0  # pelvis yaw amplitude (+-), the chest counter-twists
    turn_rate_deg_s: float = 0.0  # heading rate; > 0 turns left (walks a circle)
    ramp_s: float = 1.0  # standing still -> full gait; 0 = full gait at every t
    frequency: float = field(init=False)  # resolved stride frequency, Hz
    stride: float = field(init=False)  # resolved stride length, m

    _RANGES = {
        "speed_mps": (0.0, 12.0, "m/s"), "stride_frequency_hz": (1e-3, 5.0, "Hz"),
        "stride_length_m": (1e-3, 5.0, "m"), "hip_swing_deg": (0.0, 80.0, "deg"),
        "knee_bend_deg": (0.0, 150.0, "deg"), "arm_swing_deg": (0.0, 120.0, "deg"),
        "elbow_bend_deg": (0.0, 150.0, "deg"), "pelvis_bob_m": (0.0, 0.3, "m"),
        "torso_twist_deg": (0.0, 45.0, "deg"), "turn_rate_deg_s": (-720.0, 720.0, "deg/s"),
        "ramp_s": (0.0, 60.0, "s"),
    }

    def __post_init__(self):
        for f in fields(self):
            if not f.init:
                continue
            value = getattr(self, f.name)
            if value is None and f.name in ("stride_frequency_hz", "stride_length_m", "hip_swing_deg"):
                continue
            low, high, unit = self._RANGES[f.name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
                raise ParameterError(f"Gait.{f.name}: got {value!r}; allowed: a number in [{low}, {high}] {unit}")
        given = [n for n in ("stride_frequency_hz", "stride_length_m") if getattr(self, n) is not None]
        if len(given) != 1:
            raise ParameterError(f"Gait: give exactly one of stride_frequency_hz, stride_length_m "
                                 f"(the other follows from speed_mps); got {given or 'neither'}")
        if self.stride_frequency_hz is not None:
            frequency = float(self.stride_frequency_hz)
        elif self.speed_mps == 0.0:
            raise ParameterError("Gait.stride_length_m: walking in place (speed_mps=0) has no stride length; "
                                 "give stride_frequency_hz instead")
        else:
            frequency = self.speed_mps / self.stride_length_m
            low, high, _ = self._RANGES["stride_frequency_hz"]
            if not low <= frequency <= high:
                raise ParameterError(f"Gait.stride_length_m: {self.stride_length_m} m at {self.speed_mps} m/s gives "
                                     f"{frequency:.3g} strides/s; allowed: [{low}, {high}] Hz")
        object.__setattr__(self, "frequency", frequency)
        object.__setattr__(self, "stride", self.speed_mps / frequency)

    def replace(self, **changes: Any) -> "Gait":
        """A validated copy with some inputs changed."""
        return replace(self, **changes)


def walk(**changes: Any) -> Gait:
    """An ordinary walk: 1.3 m/s, 0.9 strides/s (1.8 steps/s, 1.44 m stride)."""
    return Gait(speed_mps=1.3, stride_frequency_hz=0.9).replace(**changes)


def run(**changes: Any) -> Gait:
    """A jog: 3.0 m/s, 1.4 strides/s, bent elbows, high knee."""
    return Gait(speed_mps=3.0, stride_frequency_hz=1.4, knee_bend_deg=100.0, arm_swing_deg=35.0,
                elbow_bend_deg=80.0, pelvis_bob_m=0.06, torso_twist_deg=8.0).replace(**changes)


def fast_motion(**changes: Any) -> Gait:
    """The no-penetration suite's motion (issue 3): root 3 m/s; at 1.5 strides/s the planted hip
    amplitude of a 1.75 m adult (37.6 deg) swings the legs at 2 pi f A = 354 deg/s peak and the
    45 deg arm swing at 424 deg/s (targets: legs >= 180, arms >= 360 deg/s)."""
    return Gait(speed_mps=3.0, stride_frequency_hz=1.5, knee_bend_deg=100.0, arm_swing_deg=45.0,
                elbow_bend_deg=60.0, pelvis_bob_m=0.06, torso_twist_deg=10.0).replace(**changes)


def _ramp(t: float, ramp_s: float) -> tuple[float, float]:
    """Amplitude scale s(t) (C2 smooth step 0 -> 1) and its integral S(t) = int_0^t s."""
    if ramp_s == 0.0:
        return 1.0, t
    if t <= 0.0:
        return 0.0, 0.0
    if t >= ramp_s:
        return 1.0, t - 0.5 * ramp_s
    u = t / ramp_s
    return u ** 3 * (10.0 - 15.0 * u + 6.0 * u * u), ramp_s * u ** 4 * (2.5 - 3.0 * u + u * u)


class ProceduralCharacter:
    """The procedural humanoid driven by a ``Gait``; every method is a pure function of time."""

    # Joints whose local rotation is a yaw (about local z) or a pitch (about local y).
    _HIPS, _KNEES, _ANKLES = _sides("hip"), _sides("knee"), _sides("ankle")
    _SHOULDERS, _ELBOWS = _sides("shoulder"), _sides("elbow")
    _PELVIS, _SPINE, _CHEST, _NECK = _joint("pelvis"), _joint("spine"), _joint("chest"), _joint("neck")

    def __init__(self, gait: Gait | None = None, height: float = REFERENCE_HEIGHT):
        if isinstance(height, bool) or not isinstance(height, (int, float)) or not 0.5 <= height <= 3.0:
            raise ParameterError(f"ProceduralCharacter.height: got {height!r}; allowed: a number in [0.5, 3.0] m")
        self.gait = walk() if gait is None else gait
        self.height = float(height)
        self.skeleton = _SKELETON
        self.joint_map = dict(WALKER_JOINT_MAP)
        scale = self.height / REFERENCE_HEIGHT
        self._offsets = _REFERENCE_OFFSETS * scale
        self.head_top = np.array(_HEAD_TOP_M) * scale  # crown of the head in the head frame
        self.leg_length = float(-(self._offsets[self._KNEES[0], 2] + self._offsets[self._ANKLES[0], 2]))
        if self.gait.hip_swing_deg is None:
            twist = math.radians(self.gait.torso_twist_deg)
            hip_width = float(self._offsets[self._HIPS[0], 1])
            reach = max(0.0, self.gait.stride / 4.0 - hip_width * math.sin(twist)) / (self.leg_length * math.cos(twist))
            if reach > math.sin(math.radians(60.0)):
                raise ParameterError(
                    f"Gait: a {self.gait.stride:.2f} m stride needs a hip swing beyond 60 deg for a {self.height} m "
                    f"character (leg {self.leg_length:.2f} m); raise stride_frequency_hz or give hip_swing_deg")
            self.hip_swing_deg = math.degrees(math.asin(reach))
        else:
            self.hip_swing_deg = float(self.gait.hip_swing_deg)

    @property
    def peak_swing_speeds_deg_s(self) -> tuple[float, float]:
        """Analytic peak angular speeds (legs, arms) of the hip and shoulder swing at full gait."""
        omega = 2.0 * math.pi * self.gait.frequency
        return omega * self.hip_swing_deg, omega * self.gait.arm_swing_deg

    def rest_pose(self) -> SkeletonPose:
        return self._pose_from_local(*self._local(0.0, amplitude=0.0, travelled=0.0))

    def local_transforms(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Parent-relative translations (J, 3) and rotations (J, 4) at time ``t`` (s); the root's
        relative to the fixed world frame — what a /tf publisher sends."""
        amplitude, travelled = _ramp(float(t), self.gait.ramp_s)
        return self._local(float(t), amplitude, travelled)

    def pose(self, t: float) -> SkeletonPose:
        return self._pose_from_local(*self.local_transforms(t))

    def _pose_from_local(self, translations: np.ndarray, rotations: np.ndarray) -> SkeletonPose:
        return forward_kinematics(self.skeleton, translations, rotations)

    def _local(self, t: float, amplitude: float, travelled: float) -> tuple[np.ndarray, np.ndarray]:
        gait = self.gait
        phase = 2.0 * math.pi * gait.frequency * t
        side_phase = np.array([phase, phase + math.pi])  # left, right
        sin_side = np.sin(side_phase)
        hip = math.radians(self.hip_swing_deg) * amplitude * sin_side
        knee = math.radians(gait.knee_bend_deg) * amplitude * np.maximum(0.0, np.cos(side_phase)) ** 2
        shoulder = -math.radians(gait.arm_swing_deg) * amplitude * sin_side
        twist = math.radians(gait.torso_twist_deg) * amplitude * math.sin(phase)

        # Flexion (limb forward) is a negative rotation about +y; the knee bends the other way.
        pitch = np.zeros(len(self.skeleton.names))
        pitch[self._HIPS] = -hip
        pitch[self._KNEES] = knee
        pitch[self._ANKLES] = hip - knee  # keeps the foot level
        pitch[self._SHOULDERS] = -shoulder
        pitch[self._ELBOWS] = -math.radians(gait.elbow_bend_deg) * amplitude
        heading = math.radians(gait.turn_rate_deg_s) * travelled
        yaw = np.zeros(len(self.skeleton.names))
        yaw[self._PELVIS] = heading - twist
        yaw[self._SPINE] = twist
        yaw[self._CHEST] = twist
        yaw[self._NECK] = -twist
        rotations = quat_multiply(quat_from_axis_angle([0.0, 0.0, 1.0], yaw),
                                  quat_from_axis_angle([0.0, 1.0, 0.0], pitch))

        # The path: a circle of radius speed / turn rate, arc length speed * travelled.
        distance = gait.speed_mps * travelled
        translations = self._offsets.copy()
        translations[self._PELVIS] += (
            distance * np.sinc(heading / math.pi),
            distance * math.sin(0.5 * heading) * np.sinc(heading / (2.0 * math.pi)),
            # the straight stance leg lifts the ankle by ~ (amplitude sin(phase))^2: keep the foot down
            -gait.pelvis_bob_m * (amplitude * math.sin(phase)) ** 2,
        )
        return translations, rotations
