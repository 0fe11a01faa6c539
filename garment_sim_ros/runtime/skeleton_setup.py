"""Before dressing (ROS-free): which tree on /tf is the character's skeleton, whether its bones hold
still, and which of its frames plays which body role."""

from __future__ import annotations

import numpy as np

from ..body.canonical import local_transforms
from ..body.joint_map import auto_joint_map, load_joint_map
from ..body.pose_buffer import PoseBuffer, SampleStatus
from ..body.skeleton import Skeleton, SkeletonPose

# Bones seen on /tf must match those BONE_CHECK_S earlier within this tolerance (m + fraction) before the
# body is fitted: a rigid skeleton's bones do not change, a retargeting or scaling one does.
BONE_CHECK_S = 0.1
BONE_TOLERANCE_M = 0.005
BONE_TOLERANCE = 0.02


def skeleton_roots(buffer: PoseBuffer, frame_prefix: str) -> tuple[str | None, dict[str, int]]:
    """The root of the largest tree among the fixed frame's children named ``frame_prefix...`` (None
    when there is none), and every such root whose tree is a skeleton too, not a stray frame (a camera):
    at least half as many frames as the largest, by root, with their frame counts."""
    roots = [f for f in buffer.frames if f.startswith(frame_prefix) and buffer.parent(f) == buffer.fixed_frame]
    if not roots:
        return None, {}
    sizes = {f: len(buffer.skeleton_from_tree(f).names) for f in sorted(roots)}
    picked = max(sizes, key=sizes.get)
    return picked, {f: size for f, size in sizes.items() if size >= sizes[picked] / 2}


def bones_unsettled(buffer: PoseBuffer, skeleton: Skeleton, time_s: float, pose: SkeletonPose) -> tuple[str, str]:
    """``("", "")`` if the bones seen at ``time_s`` are those of ``BONE_CHECK_S`` earlier, else a reason
    (a counts key, or "" for a plain wait) and what is wrong: the canonical pose is built from them, so
    a skeleton that has not been seen for that long, or is still being scaled or re-rigged, is not
    fitted yet."""
    earlier = buffer.sample(time_s - BONE_CHECK_S, skeleton)
    if earlier.status != SampleStatus.OK:  # not seen that long ago: wait for the history
        return "", f"its bones are checked over {BONE_CHECK_S:g} s of data first"
    now_t, before_t = local_transforms(pose)[0][1:], local_transforms(earlier.pose)[0][1:]
    lengths, before = np.linalg.norm(now_t, axis=1), np.linalg.norm(before_t, axis=1)
    change = np.abs(lengths - before)
    worst = int(np.argmax(change)) if len(change) else 0
    if len(change) and change[worst] > BONE_TOLERANCE_M + BONE_TOLERANCE * before[worst]:
        return "bones_changing", (f"to hold still in shape: bone {skeleton.names[worst + 1]!r} is "
                                  f"{lengths[worst]:.4f} m long now and {before[worst]:.4f} m "
                                  f"{BONE_CHECK_S:g} s earlier")
    return "", ""


def map_joints(skeleton: Skeleton, pose: SkeletonPose, frame_prefix: str, joint_map_file: str = "") -> dict[str, str]:
    """Role -> frame name (with the prefix): from ``joint_map_file`` (names without the prefix), else
    recognised from the names without the prefix and the pose (``JointMapError`` when it cannot be)."""
    bare = Skeleton(tuple(n[len(frame_prefix):] if n.startswith(frame_prefix) else n for n in skeleton.names),
                    skeleton.parents)
    bare_map = load_joint_map(joint_map_file, bare) if joint_map_file else auto_joint_map(bare, pose.positions)
    return {role: skeleton.names[bare.index(name)] for role, name in bare_map.items()}
