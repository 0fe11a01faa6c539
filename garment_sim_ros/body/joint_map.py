"""Joint maps: which skeleton frame carries each body segment.

A joint map is a dict ``role -> frame name``; each role names the joint at the START of a body
segment (the joint whose bone carries the segment). Built-in maps live as YAML in
``config/joint_maps/``; ``auto_joint_map`` recognises common humanoid naming conventions
(CMU MotionBuilder and 3dsMax, Mixamo, Character Creator, Unity, Unreal, SMPL, ``L_Thigh``...)
from tokenised names and the tree structure, so a new humanoid usually needs no map.

How the automatic mapper decides:

- Names give each joint a side (``Left``/``L``/``l``/``_L``... prefix or suffix) and a body
  part from synonyms (``UpLeg``/``UpperLeg``/``Thigh``/sided ``Hip`` = upper leg,
  ``Foot``/``Ankle`` = foot...). Finger, toe and face bones are no role.
- Limbs are read from the tree, upwards from the hand (wrist) or foot (ankle): its parent is the
  lower arm (knee), the next the upper arm (hip). Twist/roll helpers and joints at the same
  position (zero-length bones) are skipped, and a bone split into numbered segments (Rigify's
  ``DEF-thigh.L`` -> ``DEF-thigh.L.001``) starts at its first. So ``LeftShoulder`` is the upper
  arm in the 3dsMax/SMPL conventions and the clavicle in Mixamo's without a rule per convention,
  and CMU's ``LHipJoint`` (at the pelvis) is never taken for the thigh.
- The pelvis is where both legs meet; the trunk is the chain from there to the head (the head
  joint, or for a rig that names none, such as Rigify's ``DEF-spine.006``, the top of the unsided
  chain above the arms). Joints at one position collapse to the deepest (the one whose bone
  leaves that point). The chest is the trunk point the clavicles (or upper arms) hang from
  (Character Creator's ``CC_Base_Spine02``, Unreal's ``spine_05``); when they hang from the neck
  base itself (CMU: ``Spine1`` has only zero-length bones, to ``Neck`` and the collars), the point
  below it. The spine is the lowest trunk point above the pelvis; the neck the first neck-named
  point, else the point above the chest. A static root above the hips is no role.

Positions, when given, serve only to find zero-length bones, so any pose of the skeleton will do
(a clip's frame, what /tf shows, the identity-rotation offsets pose): a bone's length does not
depend on the pose.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping

import numpy as np

from ..config_files import config_file, read_yaml
from .skeleton import Skeleton

ROLES: tuple[str, ...] = (
    "pelvis", "spine", "chest", "neck", "head",
    "left_upper_leg", "left_lower_leg", "left_foot",
    "right_upper_leg", "right_lower_leg", "right_foot",
    "left_upper_arm", "left_lower_arm", "left_hand",
    "right_upper_arm", "right_lower_arm", "right_hand",
)
REQUIRED_ROLES: tuple[str, ...] = (
    "pelvis", "chest", "head",
    "left_upper_leg", "left_lower_leg", "right_upper_leg", "right_lower_leg",
    "left_upper_arm", "right_upper_arm",
)
BUILTIN_MAPS: tuple[str, ...] = ("cmu_motionbuilder", "cmu_3dsmax")


class JointMapError(ValueError):
    """A joint map is invalid or a skeleton cannot be mapped; the message says what is missing."""


def validate_joint_map(joint_map: Mapping[str, str], skeleton: Skeleton | None = None,
                       source: str = "joint map") -> dict[str, str]:
    """Check roles, required roles, distinct frames and (given a skeleton) that the frames exist."""
    if not isinstance(joint_map, Mapping):
        raise JointMapError(f"{source}: expected a mapping role -> frame name, got {type(joint_map).__name__}")
    unknown = [k for k in joint_map if k not in ROLES]
    if unknown:
        raise JointMapError(f"{source}: unknown role(s) {', '.join(map(str, unknown))}; allowed: {', '.join(ROLES)}")
    for role, frame in joint_map.items():
        if not isinstance(frame, str) or not frame:
            raise JointMapError(f"{source}: role {role!r} must name a frame (a non-empty string), got {frame!r}")
    missing = [r for r in REQUIRED_ROLES if r not in joint_map]
    if missing:
        raise JointMapError(f"{source}: missing required role(s) {', '.join(missing)}")
    frames = list(joint_map.values())
    repeated = sorted({f for f in frames if frames.count(f) > 1})
    if repeated:
        raise JointMapError(f"{source}: frame(s) {', '.join(repeated)} given to more than one role")
    if skeleton is not None:
        absent = [f"{role}: {frame}" for role, frame in joint_map.items() if frame not in skeleton.names]
        if absent:
            raise JointMapError(f"{source}: frame(s) not in the skeleton: {'; '.join(absent)}; "
                                f"skeleton frames: {', '.join(skeleton.names)}")
    return {role: joint_map[role] for role in ROLES if role in joint_map}


def load_joint_map(path: str | Path, skeleton: Skeleton | None = None) -> dict[str, str]:
    """Read a joint map from YAML (``role: frame`` lines)."""
    data = read_yaml(path, JointMapError, "joint map")
    return validate_joint_map(data if data is not None else {}, skeleton, source=str(path))


def builtin_joint_map(name: str) -> dict[str, str]:
    if name not in BUILTIN_MAPS:
        raise JointMapError(f"unknown built-in joint map {name!r}; known: {', '.join(BUILTIN_MAPS)}")
    return load_joint_map(config_file("joint_maps", f"{name}.yaml"))


# ---------------------------------------------------------------------------------------------
# Names -> (side, part)

_WORDS: dict[str, str] = {}
for _part, _words in {
    "pelvis": "pelvis hips",
    "spine": "spine back lowerback upperback waist abdomen belly torso chest upperchest thorax",
    "neck": "neck lowerneck upperneck",
    "head": "head",
    "clavicle": "clavicle collar collarbone",
    "shoulder": "shoulder",  # the clavicle (Mixamo) or the shoulder joint (3dsMax, SMPL): the tree decides
    "upper_arm": "arm uparm upperarm humerus",
    "lower_arm": "forearm lowerarm elbow",
    "hand": "hand wrist",
    "upper_leg": "upleg upperleg thigh femur",
    "lower_leg": "leg lowerleg knee shin calf tibia",
    "foot": "foot ankle",
    "toe": "toe toes toebase ball",
    "finger": "finger fingers fingerbase thumb index middle ring pinky little",
}.items():
    _WORDS.update(dict.fromkeys(_words.split(), _part))
_LEFT = {"left", "l"}
_RIGHT = {"right", "r"}
_NOISE = {"mixamorig", "cc", "base", "bip", "def", "org", "jnt", "joint", "bone", "mch", "rig", "char"}
_LEAF = {"end", "top", "tip", "nub", "site", "null", "effector"}  # end markers: no segment starts there
_AUX = {"twist", "roll", "share", "helper", "adjust", "corrective", "ik", "pole", "target", "ctrl", "bend"}
_PRIORITY = ("finger", "toe")  # 'LeftHandIndex1' is a finger, 'LeftFootToe' a toe
_SPLIT = re.compile(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+")


def _split_glued(token: str) -> list[str]:
    """'lhand' -> ['l', 'hand'], 'leftarm' -> ['left', 'arm']; known words stay whole."""
    if token in _WORDS:
        return [token]
    for prefix in ("left", "right", "l", "r"):
        if token.startswith(prefix) and token[len(prefix):] in _WORDS:
            return [prefix, token[len(prefix):]]
    return [token]


def _bare(name: str) -> str:
    return re.sub(r"^.*[:|]", "", name)  # namespaces: 'mixamorig:', 'Armature|'


def _stem(name: str) -> str:
    """The name without numbers and separators: 'DEF-thigh.L.001' and 'DEF-thigh.L' share one."""
    return re.sub(r"[\d\W_]+", "", _bare(name).lower())


def classify_name(name: str) -> tuple[str | None, str | None]:
    """``(side, part)`` of a joint name; side 'left'/'right'/None, part a body part, 'aux' or None."""
    tokens = [t for raw in _SPLIT.findall(_bare(name)) for t in _split_glued(raw.lower())]
    side = None
    words = []
    for token in tokens:
        if token in _LEFT or token in _RIGHT:
            side = "left" if token in _LEFT else "right"
        elif not token.isdigit() and token not in _NOISE:
            words.append(token)
    if any(w in _LEAF for w in words):
        return side, None
    parts = [_WORDS[w] for w in words if w in _WORDS]
    joined = _WORDS.get("".join(words))
    if any(w in _AUX for w in words):
        # Limb twist bones are helpers beside the chain; a trunk 'NeckTwist' (CC) is the chain itself.
        return side, ("neck" if "neck" in parts else "aux")
    if "hip" in words and not joined and not parts:
        return side, ("upper_leg" if side else "pelvis")  # 'left_hip' is the hip joint, 'Hip' the pelvis
    for part in _PRIORITY:
        if part in parts:
            return side, part
    if joined:
        return side, joined
    return side, (parts[-1] if parts else None)


# ---------------------------------------------------------------------------------------------
# Tree structure

_LIMBS = {
    "leg": ("upper_leg", "lower_leg", "foot", {"upper_leg", "lower_leg", "foot"}),
    "arm": ("upper_arm", "lower_arm", "hand", {"shoulder", "upper_arm", "lower_arm", "hand"}),
}


class _Tree:
    def __init__(self, skeleton: Skeleton, rest_positions: np.ndarray | None):
        self.skeleton = skeleton
        self.parents = skeleton.parents
        self.labels = [classify_name(n) for n in skeleton.names]
        self.depth = [0] * len(self.parents)
        for i, p in enumerate(self.parents):
            self.depth[i] = 0 if p < 0 else self.depth[p] + 1
        self.positions = None if rest_positions is None else np.asarray(rest_positions, dtype=float)
        if self.positions is not None:
            # Relative to the long bones, not the pose's extent: a pose's spread (a static root left
            # behind, limbs folded or laid along one axis) says nothing about the rig's scale.
            child = np.asarray(self.parents) >= 0
            lengths = np.linalg.norm(self.positions[child] - self.positions[np.asarray(self.parents)[child]], axis=1)
            scale = float(np.percentile(lengths, 90)) if len(lengths) else 0.0
            self.tolerance = 1e-3 * max(scale, 1e-9)

    def part(self, i: int) -> str | None:
        return self.labels[i][1]

    def side(self, i: int) -> str | None:
        return self.labels[i][0]

    def colocated(self, i: int, j: int) -> bool:
        if self.positions is None:
            return False
        return float(np.linalg.norm(self.positions[i] - self.positions[j])) <= self.tolerance

    def ancestors(self, i: int) -> list[int]:
        return self.skeleton.ancestors(i)

    def walk_up(self, i: int) -> int | None:
        """The nearest ancestor that starts a segment ending at ``i``: skip helpers and co-located joints."""
        for a in self.ancestors(i):
            if self.part(a) != "aux" and not self.colocated(a, i):
                return a
        return None

    def segment_start(self, i: int | None) -> int | None:
        """The first of a bone's numbered segments ('DEF-thigh.L.001' -> its parent 'DEF-thigh.L')."""
        while i is not None and self.parents[i] >= 0:
            parent = self.parents[i]
            if self.labels[parent] != self.labels[i] or _stem(self.skeleton.names[parent]) != _stem(
                    self.skeleton.names[i]):
                break
            i = parent
        return i

    def walk_down(self, i: int, side: str | None, parts: set[str]) -> int | None:
        """The next joint below ``i`` along its limb (a child of the same side and limb if any)."""
        frontier = [c for c in self.skeleton.children(i)]
        while frontier:
            candidates = [c for c in frontier if self.part(c) not in ("aux", None) and not self.colocated(c, i)]
            preferred = [c for c in candidates if self.side(c) == side and self.part(c) in parts]
            if preferred or len(candidates) == 1:
                return (preferred or candidates)[0]
            if candidates:
                return None
            frontier = [g for c in frontier for g in self.skeleton.children(c)]
        return None

    def shallowest(self, side: str | None, part: str) -> int | None:
        found = [i for i, (s, p) in enumerate(self.labels) if s == side and p == part]
        return min(found, key=lambda i: self.depth[i]) if found else None

    def lowest_common_ancestor(self, a: int, b: int) -> int:
        try:
            return self.skeleton.common_ancestor(a, b)
        except ValueError:
            raise JointMapError("the skeleton has more than one root") from None


def _map_limb(tree: _Tree, side: str, limb: str) -> dict[str, int]:
    upper_part, lower_part, end_part, members = _LIMBS[limb]
    end = tree.shallowest(side, end_part)
    if end is not None:
        lower = tree.segment_start(tree.walk_up(end))
    else:
        lower = tree.shallowest(side, lower_part)
        end = None if lower is None else tree.walk_down(lower, side, members)
    upper = None if lower is None else tree.segment_start(tree.walk_up(lower))
    found = {upper_part: upper, lower_part: lower, end_part: end}
    # A joint of another side or body part is no limb joint: the chain left the limb.
    roles = {}
    for part, joint in found.items():
        if joint is not None and tree.side(joint) == side and tree.part(joint) in members:
            roles[f"{side}_{part}"] = joint
    if f"{side}_{lower_part}" not in roles:
        roles.pop(f"{side}_{upper_part}", None)
    return roles


def _map_trunk(tree: _Tree, pelvis: int, head: int, arms: int | None) -> dict[str, int]:
    """Spine, chest and neck on the chain from the pelvis to the head; ``arms``: where the upper arms hang."""
    top = tree.lowest_common_ancestor(pelvis, head)
    path = []
    for a in tree.ancestors(head):
        if a == top:
            break
        path.append(a)
    path = [j for j in reversed(path) if tree.part(j) != "aux"]
    # Joints at one position form one point; the deepest carries the bone to the next point.
    points: list[list[int]] = []
    for j in path:
        if points and tree.colocated(points[-1][-1], j):
            points[-1].append(j)
        else:
            points.append([j])
    if points and tree.colocated(points[-1][-1], head):
        points.pop()  # joints at the head's own position start no trunk segment
    neck_at = next((k for k, group in enumerate(points) if any(tree.part(j) == "neck" for j in group)), None)
    # The point the clavicles (or upper arms) hang from; if that is the neck base (CMU's zero-length
    # Spine1 at Neck), the chest is the point below it.
    hang = None if arms is None else tree.lowest_common_ancestor(arms, head)
    chest_at = next((k for k, group in enumerate(points) if hang in group), None)
    if chest_at is not None and neck_at is not None and chest_at >= neck_at:
        chest_at = neck_at - 1 if neck_at > 0 else None
    trunk_end = neck_at if neck_at is not None else len(points)
    if chest_at is None and trunk_end:
        chest_at = trunk_end // 2 if trunk_end >= 2 else 0  # the arms tell nothing: the middle point
    roles = {}
    if neck_at is not None:
        roles["neck"] = points[neck_at][-1]
    elif chest_at is not None and chest_at + 1 < len(points):
        roles["neck"] = points[chest_at + 1][-1]  # unnamed (Rigify's DEF-spine.004): above the chest
    if chest_at is not None:
        roles["chest"] = points[chest_at][-1]
        if chest_at >= 1:
            roles["spine"] = points[0][-1]
    return roles


def _unnamed_head(tree: _Tree, arms: int) -> int | None:
    """The top of the unsided spine/neck chain above where the arms hang (Rigify: DEF-spine.006)."""
    joint, top = arms, None
    while True:
        above = [c for c in tree.skeleton.children(joint)
                 if tree.side(c) is None and tree.part(c) in ("spine", "neck", "head")]
        if len(above) != 1:
            return top
        joint = top = above[0]


def auto_joint_map(skeleton: Skeleton, rest_positions: np.ndarray | None = None) -> dict[str, str]:
    """Map a humanoid skeleton's frames to ``ROLES`` from its names and tree.

    ``rest_positions (J, 3)`` (any units, any pose of the skeleton), if given, lets the mapper skip
    zero-length joints.
    Raises ``JointMapError`` listing every missing required role and the joints it saw.
    """
    tree = _Tree(skeleton, rest_positions)
    roles: dict[str, int] = {}
    for side in ("left", "right"):
        for limb in ("leg", "arm"):
            roles.update(_map_limb(tree, side, limb))
    if "left_upper_leg" in roles and "right_upper_leg" in roles:
        roles["pelvis"] = tree.lowest_common_ancestor(roles["left_upper_leg"], roles["right_upper_leg"])
    upper_arms = [roles[r] for r in ("left_upper_arm", "right_upper_arm") if r in roles]
    arms = None
    if upper_arms:
        arms = upper_arms[0] if len(upper_arms) == 1 else tree.lowest_common_ancestor(*upper_arms)
    head = tree.shallowest(None, "head")
    if head is None and arms is not None:
        head = _unnamed_head(tree, arms)
    if head is not None:
        roles["head"] = head
        if "pelvis" in roles:
            roles.update(_map_trunk(tree, roles["pelvis"], head, arms))
    missing = [r for r in REQUIRED_ROLES if r not in roles]
    if missing:
        seen = ", ".join(
            f"{name} ({' '.join(x for x in label if x) or '?'})" for name, label in zip(skeleton.names, tree.labels)
        )
        raise JointMapError(f"cannot map the skeleton automatically: missing required role(s) {', '.join(missing)}; "
                            f"joints seen (side part): {seen}; give a joint map YAML (see config/joint_maps/)")
    named = {role: skeleton.names[roles[role]] for role in ROLES if role in roles}
    return validate_joint_map(named, skeleton, source="automatic joint map")
