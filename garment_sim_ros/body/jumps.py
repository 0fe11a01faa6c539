"""The one rule for a jump in a frame's motion, and the hold that tells a real jump from an outlier.

A dynamic sample whose translation is more than ``jump_distance_m`` from the newest, faster than
``MAX_FRAME_SPEED``, jumped (``is_jump``: the ``PoseBuffer`` applies it to /tf, the character loop to
the root between frames). A gap in the stamps (a stalled publisher) is no jump: the speed stays a
body's.

A jump counts only when the next sample confirms it (``JumpHold``): the jumping sample is held back
(not sampled) until the child's next sample. Near it, the jump is real (a clip looping back, a
teleport): the history before it is dropped, its place is another, and the kinematics must not see
thousands of m/s^2 across it (counted as ``jump_confirmed``). Not near it, it was a lone outlier
(one bad root sample 25 m away): dropped (``root_outlier``; in practice only roots move that far, a
joint's offset does not).
"""

from __future__ import annotations

import math
from collections import Counter

from .sample_series import SampleSeries

MAX_FRAME_SPEED = 12.0  # m/s, faster than any sprinter: a translation faster than this between samples jumped


def is_jump(distance_m, elapsed_s, jump_distance_m: float):
    """Whether moving ``distance_m`` (m) in ``elapsed_s`` (s) is a jump; scalars or arrays of one shape."""
    return (distance_m > jump_distance_m) & (distance_m > MAX_FRAME_SPEED * elapsed_s)  # bools or bool arrays


class JumpHold:
    """Each child's unconfirmed jump, held until its next sample settles it; counts into the buffer's
    ``adjusted`` (``jump_confirmed``) and ``rejected`` (``root_outlier``) counters."""

    def __init__(self, adjusted: Counter[str], rejected: Counter[str]):
        self._adjusted = adjusted
        self._rejected = rejected
        self.held: dict[str, tuple[float, list[float], list[float]]] = {}  # a jump's first sample, by child

    def forget(self, child: str) -> None:
        self.held.pop(child, None)

    def holds(self, child: str, series: SampleSeries, stamp_s: float, position: list[float],
              rotation: list[float], jump_distance_m: float) -> bool:
        """Settle the child's unconfirmed jump with this sample (confirmed, or dropped as an outlier);
        True when this sample is itself a jump, held until the next one."""
        held = self.held.get(child)
        if held is not None and stamp_s > held[0]:
            del self.held[child]
            if math.dist(position, held[1]) <= jump_distance_m:
                series.clear()  # the place before the jump is another: no interpolation or kinematics across it
                series.insert(*held)
                self._adjusted["jump_confirmed"] += 1
                return False
            self._rejected["root_outlier"] += 1
        if len(series) == 0 or stamp_s <= series.newest:
            return False
        if is_jump(math.dist(position, series.translations[-1]), stamp_s - series.newest, jump_distance_m):
            self.held[child] = (stamp_s, position, rotation)
            return True
        return False
