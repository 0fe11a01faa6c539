"""Body volumes and measurements fitted to a skeleton's own bone lengths (memo §6.1).

``fit_body(rest_pose, joint_map)`` encloses the body, in its canonical standing pose
(``body.canonical.canonical_pose``: legs straight down, spine up, arms in an A-pose), in the memo's
10 volumes (pelvis, torso,
chest, head, upper and lower legs, upper arms), 12 with ``forearms=True`` (plus the forearms: a hand swinging
past the hip or resting on it, against a skirt), or 15 with ``detailed=True`` (plus neck,
forearms, feet: the one-piece dress), and derives the ``BodyMeasurements`` garments are cut
from, so a tall and a short skeleton both get garments that fit.

Geometry. A limb volume is attached to the frame of the joint where its segment starts
(``Volume.frame``); its local z runs along the bone towards the next joint, its local x is the
body's forward direction made perpendicular to the bone (the left direction for a bone that
points forward, the foot), and it is centred at mid-bone. It is an ellipsoid elongated along z
with both ends cut a little past the joints: ``a_z`` is chosen so that the cross-section at a
joint is ``JOINT_TAPER`` times the mid-bone one, so neighbouring volumes overlap at the joint
while the outline keeps narrowing (no bulge past it). The trunk is three stacked ellipsoids
(pelvis upright from crotch to waist; torso from the spine to the chest joint; chest from the
chest joint up to the shoulders); the head is a sphere. A trunk segment spanning several bones
(CC's torso: Waist -> Spine01 -> Spine02; CMU's neck: Neck -> Neck1 -> Head) rides on its first
joint's frame aimed at the joint at its top at every pose (``body.aiming``), so it follows the
chain, not its first bone.

Missing optional roles fall back: no spine -> the torso starts at the pelvis; no neck -> the chest
stops at the shoulders and the neck volume rides on the chest; no foot, lower arm or hand -> the
segment before ends at its joint's first child (its own length from Winter's ratios if it has
none), and the detailed body has no foot or forearm volume on that side.

Plausibility. Every measurement taken from the skeleton (limb radii, hip and shoulder joint
spacing, the head) is checked against human ranges relative to the stature
(``PLAUSIBLE_PER_STATURE``); one outside is replaced by the anthropometric estimate and named in
``Body.estimated``, so a rig with odd bones still gets a human body (and says which parts were guessed).

Motion. Given poses the body will be driven with (``fit_body(motion=...)``), a trunk volume an arm
bone comes near in them is narrowed to this subject (``body.narrowing``).

Sizes. Radii are anthropometric ratios of the skeleton's own lengths: limb radii of the bone's
length, trunk widths of the hip-joint and shoulder-joint spacing, levels (waist, crotch,
armpit) and the head of the stature ``H`` estimated from the leg (hip-knee-ankle = 0.491 H,
ankle height 0.039 H; Winter, Biomechanics and Motor Control of Human Movement, table 4.1).

Measurements are read back from the volumes (after overrides), in the root frame of the rest
pose (``body.root.root_frame``): e.g. ``thigh_radius`` is the thigh volume's radius and
``hip_ry`` the half width of the trunk volumes at hip level. Knee and ankle heights are those of
the standing body (legs straight below the hip joints, lengths from the bones): in CMU's rest
pose the legs are splayed about 20 deg, while garments are fitted to a standing body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Mapping, Sequence

import numpy as np

from ..collision.volumes import ELLIPSOID, SPHERE, Volume, VolumeSet
from ..transforms import quat_conjugate, quat_from_matrix, quat_multiply, quat_rotate, yaw_quat
from .aiming import FrameAim, aimed_frame_poses
from .canonical import MIN_BONE_M
from .joint_map import validate_joint_map
from .measurements import BodyMeasurements
from .narrowing import narrow_for_motion
from .overrides import BodyOverrides, apply_overrides, check_overrides
from .root import root_frame
from .skeleton import SkeletonPose

# Stature from the leg (Winter): hip-knee 0.245 H + knee-ankle 0.246 H; ankle above the floor 0.039 H.
LEG_PER_STATURE = 0.491
ANKLE_HEIGHT_PER_STATURE = 0.039
# Bone lengths per stature (Winter), for a limb whose far joint the skeleton lacks.
UPPER_ARM_PER_STATURE = 0.186
FOREARM_PER_STATURE = 0.146
# Levels relative to the hip joints, per stature.
WAIST_ABOVE_HIP_JOINT = 0.10
CROTCH_BELOW_HIP_JOINT = 0.045
ARMPIT_BELOW_SHOULDER = 0.07
# Radii: limbs per bone length (mid-bone), trunk per joint spacing or stature, head per stature.
THIGH_RADIUS_PER_LENGTH = 0.20
SHIN_RADIUS_PER_LENGTH = 0.135
UPPER_ARM_RADIUS_PER_LENGTH = 0.15
FOREARM_RADIUS_PER_LENGTH = 0.14
FOOT_HEIGHT_PER_LENGTH = 0.25  # half height of the foot per ankle-to-toe length
FOOT_WIDTH_PER_LENGTH = 0.33  # half width
NECK_RADIUS_PER_STATURE = 0.034
HEAD_RADIUS_PER_STATURE = 0.058
HEAD_CENTRE_ABOVE_JOINT = 0.8  # head centre this many head radii along the head from the head joint
WAIST_PER_HIP_WIDTH = 0.80  # waist breadth / hip breadth
HIP_DEPTH_PER_WIDTH = 0.72
WAIST_DEPTH_PER_WIDTH = 0.72
CHEST_WIDTH_PER_SHOULDER = 0.85  # chest half width / shoulder-joint half spacing
CHEST_DEPTH_PER_WIDTH = 0.75
# Cross-section at a joint / mid-bone cross-section (limbs), and how far cuts reach past a joint.
JOINT_TAPER = 0.7
TRUNK_TAPER = 0.9
CUT_PAST_JOINT = 0.15  # fraction of the half length
# Thighs and shins stop this far short of the body's mid-plane (per stature; 12 mm at 1.75 m), narrower
# sideways than deep where
# the hip joints are close: real thighs flatten against each other there, and the trousers' inner seams
# must pass between them (CMU's hip joints are 6-7 cm from the mid-plane, their thighs 8 cm in radius).
THIGH_MID_PLANE_GAP_PER_STATURE = 0.007

# Human ranges (low, high) and the estimate used outside them, per stature (the stature is read from the
# legs): radii at mid-bone, half spacings of the hip and shoulder joints, the head. The estimates are
# the ratios above for a 1.75 m adult (Winter, table 4.1; hip and shoulder joint spacing from the
# biacromial and bi-iliac breadths, 0.23 H and 0.17 H, less the joints' depth in the body); the
# ranges span slim to broad adults and the shared clips' bodies (thigh 0.048-0.051 H).
PLAUSIBLE_PER_STATURE: dict[str, tuple[float, float, float]] = {
    "thigh_radius": (0.035, 0.065, 0.050),
    "shin_radius": (0.022, 0.045, 0.033),
    "upper_arm_radius": (0.018, 0.045, 0.030),
    "forearm_radius": (0.015, 0.040, 0.025),
    "leg_y": (0.030, 0.075, 0.050),
    "shoulder_y": (0.075, 0.140, 0.105),
    "head_radius": (0.045, 0.075, HEAD_RADIUS_PER_STATURE),
}

BASIC_VOLUMES: tuple[str, ...] = (
    "pelvis", "torso", "chest", "head",
    "left_upper_leg", "right_upper_leg", "left_lower_leg", "right_lower_leg",
    "left_upper_arm", "right_upper_arm",
)
DETAILED_VOLUMES: tuple[str, ...] = BASIC_VOLUMES + (
    "neck", "left_lower_arm", "right_lower_arm", "left_foot", "right_foot",
)
@dataclass(frozen=True)
class Body:
    volumes: VolumeSet
    measurements: BodyMeasurements
    joint_map: Mapping[str, str]
    rest_pose: SkeletonPose
    estimated: tuple[str, ...] = ()  # measurements out of human range, replaced by estimates (PLAUSIBLE_PER_STATURE)
    # trunk volumes narrowed so the arm bones stay outside them in the motion fitted to: name -> scale on
    # their cross-section (< 1); see ``body.narrowing``
    narrowed: Mapping[str, float] = field(default_factory=dict)


class _Fit:
    """The rest pose seen from its root frame, and the volume builders."""

    def __init__(self, pose: SkeletonPose, joint_map: Mapping[str, str]):
        self.pose = pose
        self.map = joint_map
        self.origin, yaw = root_frame(pose, joint_map)
        self.root_rotation = yaw_quat(yaw)
        self.forward = quat_rotate(self.root_rotation, np.array([1.0, 0.0, 0.0]))
        self.left = quat_rotate(self.root_rotation, np.array([0.0, 1.0, 0.0]))
        self.up = np.array([0.0, 0.0, 1.0])

    def world(self, role: str) -> np.ndarray:
        return self.pose.frame(self.map[role])[0]

    def local(self, point: np.ndarray) -> np.ndarray:
        """World point -> root frame."""
        return quat_rotate(quat_conjugate(self.root_rotation), np.asarray(point) - self.origin)

    def bone_end(self, role: str, next_role: str | None) -> np.ndarray | None:
        """Where the segment starting at ``role`` ends: the next role's joint, else the first child away from it."""
        if next_role is not None and next_role in self.map:
            return self.world(next_role)
        skeleton = self.pose.skeleton
        start = self.world(role)
        frontier = skeleton.children(skeleton.index(self.map[role]))
        while frontier:
            away = [c for c in frontier if np.linalg.norm(self.pose.positions[c] - start) > 1e-6]
            if away:
                return self.pose.positions[away[0]]
            frontier = [g for c in frontier for g in skeleton.children(c)]
        return None

    def axes(self, axis: np.ndarray) -> np.ndarray:
        """Rotation matrix with z = axis and x = forward made perpendicular (left for a forward bone)."""
        z = axis / np.linalg.norm(axis)
        x = self.forward - np.dot(self.forward, z) * z
        if np.linalg.norm(x) > 0.5:
            x /= np.linalg.norm(x)
            y = np.cross(z, x)
        else:
            y = self.left - np.dot(self.left, z) * z
            y /= np.linalg.norm(y)
            x = np.cross(y, z)
        return np.column_stack([x, y, z])

    def attach(self, name: str, kind: int, frame_role: str, centre: np.ndarray, axis: np.ndarray,
               radii: tuple[float, float, float], cut: tuple[float, float] = (-np.inf, np.inf)) -> Volume:
        """A volume centred at ``centre`` with local z along ``axis`` (world, rest pose), on ``frame_role``'s frame."""
        joint_position, joint_rotation = self.pose.frame(self.map[frame_role])
        inverse = quat_conjugate(joint_rotation)
        rotation = quat_from_matrix(self.axes(axis))
        return Volume(
            name=name, kind=kind, frame=self.map[frame_role],
            radii=tuple(float(r) for r in radii), cut=tuple(float(c) for c in cut),
            offset_position=tuple(float(v) for v in quat_rotate(inverse, centre - joint_position)),
            offset_rotation=tuple(float(v) for v in quat_multiply(inverse, rotation)),
        )

    def volume(self, name: str, frame_role: str, start: np.ndarray, axis: np.ndarray, s0: float, s1: float,
               rx: float, ry: float, taper: float, bone: bool = False) -> Volume:
        """Ellipsoid over ``[s0, s1]`` along ``axis`` from ``start`` (world), cut a little past both ends;
        ``bone``: that span is a bone the cloth may not cross (``Volume.bone``)."""
        unit = _unit(axis)
        half = 0.5 * (s1 - s0)
        a_z = half / math.sqrt(1.0 - taper**2)
        past = CUT_PAST_JOINT * half
        volume = self.attach(name, ELLIPSOID, frame_role, start + unit * 0.5 * (s0 + s1), unit, (rx, ry, a_z),
                             (-half - past, half + past))
        return replace(volume, bone=(-half, half)) if bone else volume

    def aim(self, role: str, target: str) -> FrameAim | None:
        """``role``'s frame aimed at the joint ``target`` when a joint of its own lies between them, off the
        line's ends (the segment spans several bones: CC's Waist -> Spine01 -> Spine02); else None, the
        frame's own bone is the segment."""
        skeleton = self.pose.skeleton
        start, end = skeleton.index(self.map[role]), skeleton.index(target)
        path = [end, *skeleton.ancestors(end)]
        if start not in path:
            return None
        between = path[1:path.index(start)]
        ends = self.pose.positions[[start, end]]
        if not any(min(np.linalg.norm(self.pose.positions[j] - ends, axis=1)) > MIN_BONE_M for j in between):
            return None
        _, rotation = self.pose.frame(self.map[role])
        direction = quat_rotate(quat_conjugate(rotation), _unit(self.pose.positions[end] - ends[0]))
        return FrameAim(self.map[role], target, tuple(float(v) for v in direction))

    def bone(self, role: str, next_role: str | None, fallback_length: float) -> tuple[np.ndarray, np.ndarray]:
        """Start and end (world) of the segment starting at ``role``."""
        start = self.world(role)
        end = self.bone_end(role, next_role)
        if end is None:  # a leaf limb joint: the bone runs on along its parent's direction
            parent = self.pose.skeleton.parents[self.pose.skeleton.index(self.map[role])]
            end = start + fallback_length * _unit(start - self.pose.positions[parent])
        return start, end

    def limb(self, name: str, start: np.ndarray, end: np.ndarray, radius: float, width: float | None = None) -> Volume:
        """A limb volume of ``radius`` (m, mid-bone), narrower sideways if ``width`` (its half width) is less."""
        length = float(np.linalg.norm(end - start))
        ry = radius if width is None else min(radius, width)
        return self.volume(name, name, start, end - start, 0.0, length, radius, ry, JOINT_TAPER, bone=True)


class _Plausibility:
    """Measurements checked against human ranges relative to the stature; one out of range is
    replaced by the anthropometric estimate and its name recorded (``Body.estimated``)."""

    def __init__(self, stature: float):
        self.stature = stature
        self.estimated: list[str] = []

    def __call__(self, name: str, value: float) -> float:
        low, high, typical = PLAUSIBLE_PER_STATURE[name]
        if low * self.stature <= value <= high * self.stature:
            return value
        if name not in self.estimated:
            self.estimated.append(name)
        return typical * self.stature


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _fit_volumes(fit: _Fit, detailed: bool, forearms: bool
                 ) -> tuple[list[Volume], list[FrameAim], dict[str, float], list[str]]:
    sides = ("left", "right")
    hip_joints = [fit.local(fit.world(f"{s}_upper_leg")) for s in sides]
    knees = [fit.world(f"{s}_lower_leg") for s in sides]
    thigh = [float(np.linalg.norm(k - fit.world(f"{s}_upper_leg"))) for s, k in zip(sides, knees)]
    ankles = [fit.bone_end(f"{s}_lower_leg", f"{s}_foot") for s in sides]
    shin = [float(np.linalg.norm(a - k)) if a is not None else t for a, k, t in zip(ankles, knees, thigh)]
    stature = (np.mean(thigh) + np.mean(shin)) / LEG_PER_STATURE
    plausible = _Plausibility(stature)
    hip_joint_z = float(np.mean([h[2] for h in hip_joints]))
    leg_x = float(np.mean([h[0] for h in hip_joints]))
    leg_y = plausible("leg_y", float(np.mean([abs(h[1]) for h in hip_joints])))
    shoulders = [fit.local(fit.world(f"{s}_upper_arm")) for s in sides]
    shoulder_z = float(np.mean([p[2] for p in shoulders]))
    shoulder_y = plausible("shoulder_y", float(np.mean([abs(p[1]) for p in shoulders])))

    def limb(role: str, next_role: str | None, measurement: str, radius_per_length: float,
             fallback_length: float, width: float | None = None) -> Volume:
        start, end = fit.bone(role, next_role, fallback_length)
        radius = plausible(measurement, radius_per_length * float(np.linalg.norm(end - start)))
        return fit.limb(role, start, end, radius, width)

    volumes: list[Volume] = []
    for s, t, sh in zip(sides, thigh, shin):
        volumes.append(limb(f"{s}_upper_leg", f"{s}_lower_leg", "thigh_radius", THIGH_RADIUS_PER_LENGTH, t,
                            width=leg_y - THIGH_MID_PLANE_GAP_PER_STATURE * stature))
        volumes.append(limb(f"{s}_lower_leg", f"{s}_foot", "shin_radius", SHIN_RADIUS_PER_LENGTH, sh,
                            width=leg_y - THIGH_MID_PLANE_GAP_PER_STATURE * stature))
    for s in sides:
        volumes.append(limb(f"{s}_upper_arm", f"{s}_lower_arm", "upper_arm_radius", UPPER_ARM_RADIUS_PER_LENGTH,
                            UPPER_ARM_PER_STATURE * stature))
    thigh_radius = float(np.mean([v.radii[0] for v in volumes if v.name.endswith("upper_leg")]))

    # Pelvis: upright, widest at the hip joints, from the crotch to the waist, covering the thigh tops.
    hip_ry = leg_y + thigh_radius
    waist_rise = WAIST_ABOVE_HIP_JOINT * stature
    pelvis_a_z = waist_rise / math.sqrt(1.0 - WAIST_PER_HIP_WIDTH**2)
    crotch_drop = CROTCH_BELOW_HIP_JOINT * stature
    # Deep enough to cover the thigh tops in front and the root joint's line (the spine's) behind: rigs
    # put the root joint anywhere from above the hip joints to 6 cm behind them.
    centre = fit.origin + quat_rotate(fit.root_rotation, np.array([0.5 * leg_x, 0.0, hip_joint_z]))
    volumes.append(fit.attach("pelvis", ELLIPSOID, "pelvis", centre, fit.up,
                              (HIP_DEPTH_PER_WIDTH * hip_ry + 0.5 * abs(leg_x), hip_ry, pelvis_a_z),
                              (-crotch_drop, waist_rise)))

    # Torso (lower back to chest joint) and chest (chest joint to the shoulders or the neck).
    waist_ry = WAIST_PER_HIP_WIDTH * hip_ry
    spine_role = "spine" if "spine" in fit.map else "pelvis"
    chest = fit.world("chest")
    spine_start = fit.world(spine_role)
    torso_length = float(np.linalg.norm(chest - spine_start))
    aims = [fit.aim(spine_role, fit.map["chest"])] if spine_role == "spine" else []
    if torso_length > 1e-6:
        volumes.append(fit.volume("torso", spine_role, spine_start, chest - spine_start, 0.0, torso_length,
                                  WAIST_DEPTH_PER_WIDTH * waist_ry, waist_ry, TRUNK_TAPER, bone=True))
    else:  # the chest joint sits at the pelvis: the torso stands upright from there to the waist
        volumes.append(fit.volume("torso", "pelvis", chest, fit.up, 0.0, waist_rise, WAIST_DEPTH_PER_WIDTH * waist_ry,
                                  waist_ry, TRUNK_TAPER))
    head = fit.world("head")
    neck_base = fit.world("neck") if "neck" in fit.map else head
    chest_axis = _unit(neck_base - chest)
    shoulder_mid = fit.origin + quat_rotate(fit.root_rotation, np.array([0.0, 0.0, shoulder_z]))
    shoulder_top = float(np.dot(shoulder_mid - chest, chest_axis))
    if "neck" in fit.map:
        chest_top = max(float(np.dot(neck_base - chest, chest_axis)), shoulder_top)
    else:  # up to the shoulders, leaving the neck below the head
        chest_top = min(shoulder_top, 0.8 * float(np.dot(head - chest, chest_axis)))
    chest_ry = CHEST_WIDTH_PER_SHOULDER * shoulder_y
    aims.append(fit.aim("chest", fit.map["neck" if "neck" in fit.map else "head"]))
    volumes.append(fit.volume("chest", "chest", chest, chest_axis, 0.0, chest_top,
                              CHEST_DEPTH_PER_WIDTH * chest_ry, chest_ry, TRUNK_TAPER))

    # Head: a sphere along the head (towards its child, else up from the neck).
    head_radius = plausible("head_radius", HEAD_RADIUS_PER_STATURE * stature)
    head_end = fit.bone_end("head", None)
    head_axis = _unit(head_end - head) if head_end is not None and np.linalg.norm(head_end - head) > 0.3 * head_radius \
        else _unit(head - (neck_base if "neck" in fit.map else chest))
    volumes.append(fit.attach("head", SPHERE, "head", head + HEAD_CENTRE_ABOVE_JOINT * head_radius * head_axis,
                              head_axis, (head_radius,) * 3))

    if detailed:
        neck_role = "neck" if "neck" in fit.map else "chest"
        neck_start = fit.world(neck_role) if neck_role == "neck" else chest + chest_top * chest_axis
        neck_radius = NECK_RADIUS_PER_STATURE * stature
        if neck_role == "neck":
            aims.append(fit.aim("neck", fit.map["head"]))
        volumes.append(fit.volume("neck", neck_role, neck_start, head - neck_start, 0.0,
                                  float(np.linalg.norm(head - neck_start)), neck_radius, neck_radius, TRUNK_TAPER))
        for s in sides:
            if f"{s}_foot" in fit.map:
                volumes.append(_foot(fit, s))
    if detailed or forearms:
        for s in sides:
            if f"{s}_lower_arm" in fit.map:
                volumes.append(limb(f"{s}_lower_arm", f"{s}_hand", "forearm_radius", FOREARM_RADIUS_PER_LENGTH,
                                    FOREARM_PER_STATURE * stature))
    spine_z = float(fit.local(fit.world("spine"))[2]) if "spine" in fit.map else math.inf
    levels = {"stature": stature, "hip_joint_z": hip_joint_z, "leg_x": leg_x, "leg_y": leg_y, "spine_z": spine_z,
              "thigh": float(np.mean(thigh)), "shin": float(np.mean(shin)), "shoulder_z": shoulder_z,
              "shoulder_y": shoulder_y}
    return volumes, [a for a in aims if a is not None], levels, plausible.estimated


def _foot(fit: _Fit, side: str) -> Volume:
    """Ankle to toe; the heel reaches behind the ankle, the toes past the toe joint."""
    role = f"{side}_foot"
    ankle = fit.world(role)
    toe = fit.bone_end(role, None)
    if toe is None:
        toe = ankle + 0.13 * fit.forward
    length = float(np.linalg.norm(toe - ankle))
    return fit.volume(role, role, ankle, toe - ankle, -0.35 * length, 1.3 * length,
                      FOOT_HEIGHT_PER_LENGTH * length, FOOT_WIDTH_PER_LENGTH * length, JOINT_TAPER)


def _measure(fit: _Fit, volumes: VolumeSet, levels: dict[str, float]) -> BodyMeasurements:
    """Measurements read from the fitted volumes in the rest pose's root frame."""
    by_name = {v.name: v for v in volumes.volumes}
    # the rest pose: an aimed frame is as the skeleton has it there
    positions, rotations = volumes.world_poses(*aimed_frame_poses(fit.pose, volumes.frames))

    def placed(name: str):
        k = volumes.names().index(name)
        centre = fit.local(positions[k])
        axis = quat_rotate(quat_conjugate(fit.root_rotation), quat_rotate(rotations[k], np.array([0.0, 0.0, 1.0])))
        return by_name[name], centre, axis

    def section(z: float) -> tuple[float, float, float]:
        """Centre (x), half depth and half width of what the trunk volumes' cross-sections at height z span."""
        front, back, ry = -math.inf, math.inf, 0.0
        for name in ("pelvis", "torso", "chest"):
            volume, centre, axis = placed(name)
            zl = (z - centre[2]) / max(axis[2], 1e-6)
            if volume.cut[0] <= zl <= volume.cut[1]:
                f = math.sqrt(max(0.0, 1.0 - (zl / volume.radii[2]) ** 2))
                x = centre[0] + zl * axis[0]
                front, back = max(front, x + f * volume.radii[0]), min(back, x - f * volume.radii[0])
                ry = max(ry, f * volume.radii[1])
        if ry == 0.0:
            return 0.0, 0.0, 0.0
        return 0.5 * (front + back), 0.5 * (front - back), ry

    def limb_section(name: str, zl: float) -> float:
        volume = by_name[name]
        return max(volume.radii[:2]) * math.sqrt(max(0.0, 1.0 - (zl / volume.radii[2]) ** 2))

    stature = levels["stature"]
    pelvis, pelvis_centre, pelvis_axis = placed("pelvis")
    hip_z = float(pelvis_centre[2])
    waist_z = float(pelvis_centre[2] + pelvis.cut[1] * pelvis_axis[2])
    crotch_z = float(pelvis_centre[2] + pelvis.cut[0] * pelvis_axis[2])
    chest_z = levels["shoulder_z"] - ARMPIT_BELOW_SHOULDER * stature
    knee_z = levels["hip_joint_z"] - levels["thigh"]
    ankle_z = knee_z - levels["shin"]
    thighs = [by_name[f"{s}_upper_leg"] for s in ("left", "right")]
    shins = [by_name[f"{s}_lower_leg"] for s in ("left", "right")]
    # Bone volumes are centred at mid-bone: the knee is at +thigh/2 of the thigh's, the ankle at +shin/2.
    knee_radius = max(max(max(v.radii[:2]) for v in shins),
                      max(limb_section(v.name, 0.5 * levels["thigh"]) for v in thighs))
    ankle_radius = max(limb_section(v.name, 0.5 * levels["shin"]) for v in shins)
    # the nearer hanging arm's inner side; at least the neck's radius (an override's fat arm)
    underarm_y = max(min(abs(float(fit.local(fit.world(f"{s}_upper_arm"))[1]))
                         - max(by_name[f"{s}_upper_arm"].radii[:2]) for s in ("left", "right")),
                     NECK_RADIUS_PER_STATURE * stature)
    head, head_centre, _ = placed("head")
    chest, chest_centre, chest_axis = placed("chest")
    height = float(head_centre[2] + head.radii[0]) - (ankle_z - ANKLE_HEIGHT_PER_STATURE * stature)
    waist_x, waist_rx, waist_ry = section(waist_z)
    hip_x, hip_rx, hip_ry = section(hip_z)
    chest_x, chest_rx, chest_ry = section(chest_z)
    return BodyMeasurements(**{k: float(v) for k, v in dict(
        height=height,
        waist_z=waist_z, waist_rx=waist_rx, waist_ry=waist_ry,
        hip_z=hip_z, hip_rx=hip_rx, hip_ry=hip_ry,
        crotch_z=crotch_z, leg_y=levels["leg_y"],
        thigh_radius=float(np.mean([max(v.radii[:2]) for v in thighs])),
        knee_z=knee_z, knee_radius=float(knee_radius), ankle_z=ankle_z, ankle_radius=float(ankle_radius),
        chest_z=chest_z, chest_rx=chest_rx, chest_ry=chest_ry,
        shoulder_z=levels["shoulder_z"], shoulder_y=levels["shoulder_y"],
        neck_z=chest_centre[2] + chest.cut[1] * chest_axis[2], neck_radius=NECK_RADIUS_PER_STATURE * stature,
        waist_x=waist_x, hip_x=hip_x, chest_x=chest_x, leg_x=levels["leg_x"], spine_z=levels["spine_z"],
        underarm_y=underarm_y,
    ).items()})


def fit_body(rest_pose: SkeletonPose, joint_map: Mapping[str, str], detailed: bool = False,
             overrides: BodyOverrides | Mapping | None = None, motion: Sequence[SkeletonPose] = (),
             forearms: bool = False) -> Body:
    """Fit the bounding volumes and measurements of the body the skeleton's rest pose defines.

    ``rest_pose``: the canonical standing pose (``body.canonical.canonical_pose``); volumes are
    attached to joint frames in it, so it must be a pose of the skeleton that moves.
    ``overrides``: a ``BodyOverrides`` (``load_body_overrides``) or a mapping
    ``{volume: {radii: [x, y, z], cut: [lo, hi], offset_position: [x, y, z]}}`` (metres, the
    volume's local frame / its joint frame), applied after fitting.
    ``forearms``: the 10 volumes plus the forearms (12; the detailed body has them anyway).
    ``motion``: poses of the same skeleton the body will be driven with (``MotionSource.fit_poses``: the
    pose it is dressed on, as in the node); trunk volumes an arm bone comes near in them are narrowed
    (``body.narrowing``).
    """
    joint_map = validate_joint_map(joint_map, rest_pose.skeleton)
    if any(pose.skeleton != rest_pose.skeleton for pose in motion):
        raise ValueError("fit_body: the motion's poses must be of the rest pose's skeleton")
    if not isinstance(overrides, BodyOverrides):
        overrides = check_overrides({"volumes": overrides} if overrides else None, "overrides")
    fit = _Fit(rest_pose, joint_map)
    volumes, aims, levels, estimated = _fit_volumes(fit, detailed, forearms)
    volumes, narrowed = narrow_for_motion(volumes, joint_map, motion, levels["stature"], aims)
    volumes.sort(key=lambda v: DETAILED_VOLUMES.index(v.name))  # the basic ones first, in BASIC_VOLUMES' order
    volume_set = VolumeSet(tuple(apply_overrides(volumes, overrides)), aims=tuple(aims))
    rest_frames = [rest_pose.frame(f) for f in volume_set.frames]
    volume_set = volume_set.at_rest_in(np.array([p for p, _ in rest_frames]), np.array([q for _, q in rest_frames]))
    return Body(volume_set, _measure(fit, volume_set, levels), joint_map, rest_pose, tuple(estimated), narrowed)

