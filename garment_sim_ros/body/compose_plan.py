"""Which frames a pose of the /tf tree is composed from, in which order: planned once per set of frames.

``PoseBuffer`` samples a set of frames many times a second from a tree that rarely changes, so the walk
(every frame needed, parents first, and which are dynamic, static, missing) is worked out once and kept
until the tree changes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Collection, Mapping, Sequence

import numpy as np


def tree_chain(frame: str, parent: Mapping[str, str]) -> list[str]:
    """``frame`` and its ancestors up to the tree's root (the last entry)."""
    chain = [frame]
    while chain[-1] in parent:
        chain.append(parent[chain[-1]])
    return chain


@dataclass(frozen=True)
class ComposePlan:
    """Which rows ``PoseBuffer._compose`` fills for a set of frames (valid while the tree is unchanged)."""

    used: list[str]  # the dynamic frames needed
    used_rows: list[int]  # ...their rows
    static_rows: list[tuple[str, int]]  # the static frames needed and their rows
    parent_row: np.ndarray  # (R,) int64: each row's parent row, -1 for a tree root
    roots: np.ndarray  # (R,) bool: the tree roots (their own origin)
    found: list[int]  # the rows of the frames asked for that reach the fixed frame, in their order
    missing: list[str]  # the frames asked for that do not
    fixed_row: int  # the fixed frame's row when it is not the tree's root, else -1

    @classmethod
    def of(cls, frames: Sequence[str], fixed_frame: str, parent: Mapping[str, str], dynamic: Collection[str],
           static: Collection[str]) -> "ComposePlan":
        """The walk for ``frames`` in ``fixed_frame`` over the tree ``parent`` (child -> parent) whose
        ``dynamic`` and ``static`` frames have transforms: every frame needed, parents first."""
        known = set(parent) | set(parent.values())
        fixed_chain = tree_chain(fixed_frame, parent)
        row: dict[str, int] = {}  # every frame needed, parents before children
        missing = []
        for frame in frames:
            chain = tree_chain(frame, parent)
            if frame != fixed_frame and (frame not in known or chain[-1] != fixed_chain[-1]):
                missing.append(frame)
                continue
            for name in reversed(chain):
                row.setdefault(name, len(row))
        if len(row) > 0:
            for name in reversed(fixed_chain):
                row.setdefault(name, len(row))
        names = list(row)
        used = [name for name in names if name in dynamic]
        parent_row = np.full(len(names), -1, dtype=np.int64)  # compose down the tree: rows are parents first
        for name, i in row.items():
            if name in parent:
                parent_row[i] = row[parent[name]]
        return cls(used=used, used_rows=[row[name] for name in used],
                   static_rows=[(name, row[name]) for name in names if name in static],
                   parent_row=parent_row, roots=parent_row < 0,
                   found=[row[frame] for frame in frames if frame not in missing], missing=missing,
                   fixed_row=row[fixed_frame] if len(fixed_chain) > 1 else -1)
