"""A time-stamped transform tree (what /tf and /tf_static carry), sampled as a skeleton at any time.

ROS-free: the node feeds it ``add_transform`` calls from its /tf and /tf_static callbacks; tests
feed it directly. A transform maps the child's coordinates into the parent's (the tf convention,
the same as ``transforms.py``'s poses).

- Static transforms hold for all time. Dynamic ones are kept per child frame as a time series
  sorted by stamp (out-of-order arrivals inserted in place, an exact duplicate stamp replaces),
  bounded by ``max_duration_s`` behind the child's newest stamp and ``max_count`` samples (at least
  the two newest are kept), so memory stays bounded under any flood.
- ``sample(T, frames)`` composes each frame's pose in the fixed frame at time ``T``: translations
  interpolate linearly and rotations by slerp between the two bracketing stamps (exact at stamps;
  exact at the midpoint of a constant-velocity translation); past the newest stamp it extrapolates
  at the constant velocity of the last pair at least 10 ms apart (a /tf flood's stamp jitter stays
  harmless) for at most ``max_extrapolation_s``, then holds; before the
  oldest it holds the oldest. The fixed frame can sit anywhere in the tree (as in tf2: poses are
  composed to the tree's root and re-expressed in the fixed frame).
- ``root_motion(T, dt, joint_map)``: the root (pelvis) kinematics the relative simulation needs
  (memo §4): position, heading, velocity ``v0``, acceleration ``a0``, yaw rate and yaw acceleration,
  from a least-squares quadratic over a ``kinematics_window_s`` window of samples (centred on T
  where the data allows, else the newest) — so +-2 mm of mocap noise at 120 Hz give an ``a0`` error
  of at most 4 m/s^2 instead of the 115 m/s^2 of a second difference of one noisy pair.
- Bad input is refused with a message and counted, never raised: ``rejected[reason]`` counts
  refusals (``non_finite``, ``malformed``, ``bad_frame_name``, ``zero_quaternion``,
  ``non_unit_quaternion``, ``cycle``, ``too_old``, ``from_future`` (given the receiver's clock),
  ``too_many_frames``; ``root_outlier``, a lone jump, see below; and ``degenerate_root``, a
  ``root_motion`` whose hips coincide horizontally); ``adjusted[what]`` counts
  accepted input that was changed or replaced something (``normalised_quaternion``,
  ``reparented``: a child with a new parent, latest wins and the old history is dropped;
  ``static_dynamic_switch``; ``out_of_order``; ``duplicate_replaced``; ``jump_confirmed``).
- A root sample that jumped (``body.jumps``) is held back until the next sample confirms the jump
  (the history before it dropped) or shows it a lone outlier (dropped).
- A joint whose rotation jumped (``body.glitches``: faster than ``max_joint_speed`` deg/s) is held
  back, its frame keeping its last good data, until its data comes back (a glitch: the held samples
  are dropped, counted in ``adjusted["joint_glitch"]`` and per frame in ``glitches``, described in
  ``last_glitch``) or stays away ``max_glitch_time`` (real motion: stored as it came,
  ``adjusted["fast_joint_move"]``).
"""

from __future__ import annotations

import math
from collections import Counter
from numbers import Real
from typing import Mapping, Sequence

import numpy as np

from ..params import DEFAULT_PARAMS
from ..transforms import IDENTITY_QUAT, compose, inverse, quat_slerp
from .compose_plan import ComposePlan, tree_chain
from .glitches import GlitchHold, rotation_angle, rotation_jumped, turned
from .jumps import JumpHold, is_jump
from .root import fit_root_kinematics, headings, root_frame
from .sample_series import SampleSeries
from .samples import PoseSample, RootMotion, SampleStatus
from .skeleton import Skeleton, SkeletonPose, compose_tree

_UNIT_SILENT = 1e-3  # |q| within this of 1 is rounding: normalised without being counted
_MAX_PLANS = 64  # sets of frames whose composition plan is kept (the skeleton, its root frames, ...)


def _as_vector(value, size: int) -> list[float] | None:
    """``size`` floats, or None. Plain Python: a /tf flood calls this ~1e4 times a second."""
    try:
        values = [float(v) for v in value]
    except (TypeError, ValueError):
        return None
    return values if len(values) == size else None


class PoseBuffer:
    """The transform tree of /tf and /tf_static, sampled in ``fixed_frame`` at any time."""

    def __init__(
        self,
        fixed_frame: str = "world",
        max_duration_s: float = 2.0,
        max_count: int = 2048,
        max_extrapolation_s: float = 0.1,
        max_age_s: float = 0.5,
        quaternion_tolerance: float = 0.1,
        kinematics_window_s: float = 0.1,
        max_frames: int = 1000,
        max_lead_s: float = 1.0,
        jump_distance_m: float = 1.0,
        max_joint_speed: float = DEFAULT_PARAMS.max_joint_speed,
        max_glitch_time: float = DEFAULT_PARAMS.max_glitch_time,
    ):
        checks = {
            "max_duration_s": (max_duration_s, 0.0), "max_count": (max_count, 2),
            "max_extrapolation_s": (max_extrapolation_s, 0.0), "max_age_s": (max_age_s, 0.0),
            "quaternion_tolerance": (quaternion_tolerance, _UNIT_SILENT),
            "kinematics_window_s": (kinematics_window_s, 0.0), "max_frames": (max_frames, 1),
            "max_lead_s": (max_lead_s, 0.0), "jump_distance_m": (jump_distance_m, 0.0),
            "max_joint_speed": (max_joint_speed, 0.0), "max_glitch_time": (max_glitch_time, 0.0),
        }
        for name, (value, low) in checks.items():
            whole = name in ("max_count", "max_frames")
            if (isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value < math.inf
                    or (whole and not float(value).is_integer())):
                kind = "a whole number" if whole else "a finite number"
                raise ValueError(f"PoseBuffer.{name}: got {value!r}; allowed: {kind} >= {low}")
        if not isinstance(fixed_frame, str) or not fixed_frame:
            raise ValueError(f"PoseBuffer.fixed_frame: got {fixed_frame!r}; allowed: a non-empty frame name")
        self.fixed_frame = fixed_frame
        self.max_duration_s = float(max_duration_s)
        self.max_count = int(max_count)
        self.max_extrapolation_s = float(max_extrapolation_s)
        self.max_age_s = float(max_age_s)
        self.quaternion_tolerance = float(quaternion_tolerance)
        self.kinematics_window_s = float(kinematics_window_s)
        self.max_frames = int(max_frames)
        self.max_lead_s = float(max_lead_s)
        self.jump_distance_m = float(jump_distance_m)  # a root sample farther than this, and too fast, jumped
        self.rejected: Counter[str] = Counter()
        self.adjusted: Counter[str] = Counter()
        self._jumps = JumpHold(self.adjusted, self.rejected)
        self._glitches = GlitchHold(float(max_joint_speed), float(max_glitch_time))
        self.glitches: Counter[str] = Counter()  # joint glitches dropped, by child frame
        self.last_glitch = ""  # the newest glitch, described
        self._parent: dict[str, str] = {}
        self._static: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._dynamic: dict[str, SampleSeries] = {}
        self._tree_version = 0  # bumped whenever a frame, a parent link or a frame's kind (static, dynamic) changes
        self._plans: dict[tuple, ComposePlan] = {}  # _compose's plan per (frames, fixed frame) of this version

    # ------------------------------------------------------------------ input

    def add_transform(self, stamp_s: float, parent: str, child: str, translation, rotation_xyzw,
                      static: bool = False, now_s: float | None = None) -> str | None:
        """Store one transform. Returns None when stored, else why it was refused (also counted).

        ``now_s``, the receiver's clock: a dynamic stamp more than ``max_lead_s`` ahead of it is refused
        (``from_future``): stored, it would be the frame's newest and every true sample after it would
        be refused as ``too_old``."""
        if not (isinstance(parent, str) and isinstance(child, str) and parent and child) or parent == child:
            return self._reject("bad_frame_name", parent, child, "frame names must be two different non-empty strings")
        position = _as_vector(translation, 3)
        rotation = _as_vector(rotation_xyzw, 4)
        if position is None or rotation is None or isinstance(stamp_s, bool) or not isinstance(stamp_s, Real):
            return self._reject("malformed", parent, child, f"need a numeric stamp, a translation of 3 and a rotation "
                                f"of 4 numbers (x, y, z, w); got {stamp_s!r}, {translation!r}, {rotation_xyzw!r}")
        stamp_s = float(stamp_s)
        if not all(math.isfinite(v) for v in (stamp_s, *position, *rotation)):
            return self._reject("non_finite", parent, child, f"non-finite stamp, translation or rotation at {stamp_s}")
        if now_s is not None and not static and stamp_s > now_s + self.max_lead_s:
            return self._reject("from_future", parent, child, f"stamp {stamp_s:.3f} is {stamp_s - now_s:.3f} s ahead "
                                f"of the clock ({now_s:.3f}; max_lead_s {self.max_lead_s}): do the publisher and "
                                "this node agree on use_sim_time?")
        norm = math.sqrt(sum(v * v for v in rotation))
        if norm < 1e-9:
            return self._reject("zero_quaternion", parent, child, f"zero quaternion at {stamp_s}")
        if abs(norm - 1.0) > self.quaternion_tolerance:
            return self._reject("non_unit_quaternion", parent, child, f"quaternion norm {norm:.6g} at {stamp_s} is "
                                f"not within quaternion_tolerance {self.quaternion_tolerance} of 1")
        if abs(norm - 1.0) > _UNIT_SILENT:
            self.adjusted["normalised_quaternion"] += 1
        known = child in self._parent
        if not known and len(self._parent) >= self.max_frames:
            return self._reject("too_many_frames", parent, child,
                                f"already {self.max_frames} child frames (max_frames)")
        if self._parent.get(child) != parent:
            cycle = self._cycle_through(parent, child)
            if cycle:
                return self._reject("cycle", parent, child, f"refused, it would close the cycle {' -> '.join(cycle)}")
            if known:
                self.adjusted["reparented"] += 1
                self._forget(child)
        elif known and static != (child in self._static):
            self.adjusted["static_dynamic_switch"] += 1
            self._forget(child)
        if self._parent.get(child) != parent or static != (child in self._static):
            self._tree_changed()
        self._parent[child] = parent
        if static:
            self._static[child] = (np.array(position), np.array(rotation) / norm)
            return None
        series = self._dynamic.get(child)
        if series is None:
            self._tree_changed()
            series = self._dynamic[child] = SampleSeries(self.max_count)
        elif stamp_s < series.stamps[-1] - self.max_duration_s:
            return self._reject("too_old", parent, child, f"stamp {stamp_s} is more than max_duration_s "
                                f"({self.max_duration_s} s) behind the newest, {series.stamps[-1]}")
        rotation = [v / norm for v in rotation]
        if self._jumps.holds(child, series, stamp_s, position, rotation, self.jump_distance_m):
            return None
        if len(series) and stamp_s > series.newest and self._held_as_glitch(child, series, stamp_s, position, rotation):
            return None
        outcome = series.insert(stamp_s, position, rotation)
        if outcome == "inserted":
            self.adjusted["out_of_order"] += 1
        elif outcome == "replaced":
            self.adjusted["duplicate_replaced"] += 1
        series.trim(self.max_duration_s)
        return None

    def add_transforms(self, stamps, parents: Sequence[str], children: Sequence[str], translations,
                       rotations_xyzw, now_s: float | None = None) -> tuple[int, list[str]]:
        """Many dynamic transforms at once (rows of arrays): the stored count and the refusals.

        The same result as ``add_transform`` row by row, at a /tf flood's rates: the checks run
        vectorised, and a known child with its known parent whose new stamps are in order after its
        newest is appended without the per-row checks. Any other child (new, reparented, refused rows,
        out of order, non-unit quaternions...) goes through ``add_transform`` row by row, in order."""
        stamps = np.asarray(stamps, dtype=float)
        translations = np.asarray(translations, dtype=float).reshape(-1, 3)
        rotations = np.asarray(rotations_xyzw, dtype=float).reshape(-1, 4)
        norms = np.sqrt(np.einsum("ij,ij->i", rotations, rotations))
        good = (np.isfinite(stamps) & np.isfinite(translations).all(axis=1) & np.isfinite(rotations).all(axis=1)
                & (np.abs(norms - 1.0) <= _UNIT_SILENT))
        if now_s is not None:
            good &= stamps <= now_s + self.max_lead_s
        with np.errstate(divide="ignore", invalid="ignore"):  # zero or NaN quaternions: not good, not used
            units = rotations / norms[:, None]
        stamp_list, good_list = stamps.tolist(), good.tolist()
        rows: dict[str, list[int]] = {}
        previous = []  # each row's child's previous row (itself for the first)
        for i, child in enumerate(children):
            index = rows.setdefault(child, [])
            previous.append(index[-1] if index else i)
            index.append(i)
        distance = np.linalg.norm(translations - translations[previous], axis=1)
        elapsed = stamps - stamps[previous]
        jumped = (is_jump(distance, elapsed, self.jump_distance_m)
                  | rotation_jumped(rotation_angle(units, units[previous]), elapsed, self.max_joint_speed)).tolist()
        # each known child's first row against its newest sample, in one call
        known = [(self._dynamic[child], index[0]) for child, index in rows.items() if child in self._dynamic]
        first = [i for _, i in known]
        newest = np.array([series.rotations[-1] for series, _ in known]).reshape(-1, 4)
        turned_away = rotation_jumped(rotation_angle(units[first], newest),
                                      stamps[first] - np.array([series.newest for series, _ in known]),
                                      self.max_joint_speed)
        first_turned = dict(zip((children[i] for i in first), np.atleast_1d(turned_away).tolist()))
        stored, refusals, slow = 0, [], []
        held = self._jumps.held.keys() | self._glitches.held.keys()  # children with an unsettled jump
        for child, index in rows.items():
            series = self._dynamic.get(child)
            parent = parents[index[0]]
            if (series is None or self._parent.get(child) != parent or child in self._static
                    or child in held):
                slow.extend(index)
                continue
            block = [stamp_list[i] for i in index]  # Python scalars: cheaper than numpy for a few rows
            if (not all(good_list[i] and parents[i] == parent and not jumped[i] for i in index)
                    or block[0] <= series.newest or any(b <= a for a, b in zip(block, block[1:]))
                    or math.dist(translations[index[0]], series.translations[-1]) > self.jump_distance_m
                    or first_turned[child]):
                slow.extend(index)  # refused, out of order, duplicated or jumping: one by one, counted there
                continue
            for i, stamp in zip(index, block):
                series.append(stamp, translations[i], units[i])
            series.trim(self.max_duration_s)
            stored += len(index)
        for i in sorted(slow):
            refusal = self.add_transform(stamp_list[i], parents[i], children[i], translations[i], rotations[i],
                                         now_s=now_s)
            if refusal is None:
                stored += 1
            else:
                refusals.append(refusal)
        return stored, refusals

    @property
    def max_joint_speed(self) -> float:
        return self._glitches.max_joint_speed

    @max_joint_speed.setter
    def max_joint_speed(self, value: float) -> None:
        self._glitches.max_joint_speed = float(value)

    @property
    def max_glitch_time(self) -> float:
        return self._glitches.max_glitch_time

    @max_glitch_time.setter
    def max_glitch_time(self, value: float) -> None:
        self._glitches.max_glitch_time = float(value)

    def _held_as_glitch(self, child: str, series: SampleSeries, stamp_s: float, position, rotation) -> bool:
        """Offer a sample after the child's newest to the glitch filter: True when it is held; the samples
        it settles are dropped (a glitch) or stored before it (a real fast move)."""
        verdict, settled = self._glitches.offer(child, stamp_s, rotation, series.newest, series.rotations[-1],
                                                (stamp_s, position, rotation))
        if verdict == GlitchHold.GLITCH:
            self.adjusted["joint_glitch"] += 1
            self.glitches[child] += 1
            first_stamp, _, first_rotation = settled[0]
            angle = math.degrees(turned(series.rotations[-1], first_rotation))
            self.last_glitch = (f"{child!r} turned {angle:.0f} deg "
                                f"in {first_stamp - series.newest:.3f} s at {first_stamp:.3f} and came back "
                                f"{stamp_s - first_stamp:.3f} s later: {len(settled)} sample(s) dropped")
        elif verdict == GlitchHold.FAST_MOVE:
            self.adjusted["fast_joint_move"] += 1
            for sample in settled:
                series.insert(*sample)
        return verdict == GlitchHold.HOLD

    def _reject(self, reason: str, parent, child, why: str) -> str:
        self.rejected[reason] += 1
        return f"transform {parent!r} -> {child!r}: {why}"

    def _cycle_through(self, parent: str, child: str) -> list[str]:
        """The cycle ``child -> parent -> ... -> child`` the new edge would close, or []."""
        chain = [child, parent]
        while chain[-1] in self._parent:
            chain.append(self._parent[chain[-1]])
            if chain[-1] == child:
                return chain
        return []

    def _tree_changed(self) -> None:
        self._tree_version += 1
        self._plans.clear()

    def _forget(self, child: str) -> None:
        self._tree_changed()
        self._jumps.forget(child)
        self._glitches.forget(child)
        self._static.pop(child, None)
        self._dynamic.pop(child, None)
        self._parent.pop(child, None)

    def forget_frames(self, children) -> None:
        """Drop these child frames (their transforms and parent links), e.g. a skeleton that was replaced."""
        for child in children:
            self._forget(child)

    def forget_dynamic(self) -> int:
        """Drop every dynamic frame (static ones stay); returns how many. For a clock that jumped back
        (a looped bag, a sim time reset): the held stamps are in the new clock's future and would
        refuse the new, older ones as ``too_old``."""
        dynamic = list(self._dynamic)
        self.forget_frames(dynamic)
        return len(dynamic)

    def fresh_frames(self, since_s: float) -> set[str]:
        """The dynamic frames whose newest stamp is at or after ``since_s``."""
        return {child for child, series in self._dynamic.items() if series.stamps[-1] >= since_s}

    # ------------------------------------------------------------------ the tree

    @property
    def frames(self) -> tuple[str, ...]:
        """Every frame named so far, as a child or a parent, sorted."""
        return tuple(sorted(set(self._parent) | set(self._parent.values())))

    def parent(self, child: str) -> str | None:
        return self._parent.get(child)

    def sample_count(self, child: str) -> int:
        """Dynamic samples held for ``child`` (1 for a static transform, 0 if unknown)."""
        if child in self._static:
            return 1
        return len(self._dynamic[child]) if child in self._dynamic else 0

    def skeleton_from_tree(self, root_frame_name: str) -> Skeleton:
        """The subtree under ``root_frame_name`` as a ``Skeleton`` (children sorted by name)."""
        if root_frame_name not in self.frames:
            known = ", ".join(self.frames) or "none yet"
            raise KeyError(f"skeleton_from_tree: no frame {root_frame_name!r} in the tree; known: {known}")
        children: dict[str, list[str]] = {}
        for child, parent in self._parent.items():
            children.setdefault(parent, []).append(child)
        names, parents = [root_frame_name], [-1]
        for i, name in enumerate(names):  # breadth first: parents precede children
            for child in sorted(children.get(name, ())):
                names.append(child)
                parents.append(i)
        return Skeleton(tuple(names), tuple(parents))

    # ------------------------------------------------------------------ sampling

    def _compose(self, frames: Sequence[str], times: np.ndarray):
        """Poses of ``frames`` in the fixed frame at ``times`` (K,): positions (F, K, 3), rotations
        (F, K, 4), the frames not connected to the fixed frame, and the dynamic frames used.

        Vectorised: one interpolation over every dynamic frame needed, then one composition per
        tree depth (each frame's pose relative to its tree's root), then into the fixed frame. The
        tree walk (which frames, in which order) is planned once per set of frames until the tree changes."""
        key = (tuple(frames), self.fixed_frame)
        plan = self._plans.get(key)
        if plan is None:
            if len(self._plans) >= _MAX_PLANS:  # callers asking for ever new sets of frames: start again
                self._plans.clear()
            plan = ComposePlan.of(frames, self.fixed_frame, self._parent, self._dynamic, self._static)
            self._plans[key] = plan
        count = len(times)
        size = len(plan.parent_row)
        local_p = np.zeros((size, count, 3))
        local_q = np.tile(IDENTITY_QUAT, (size, count, 1))
        for name, i in plan.static_rows:
            local_p[i], local_q[i] = self._static[name]
        if plan.used:
            pairs = [self._dynamic[name].bracket(times, self.max_extrapolation_s) for name in plan.used]
            p0, p1, q0, q1, weight = (np.stack(parts) for parts in zip(*pairs))
            local_p[plan.used_rows] = p0 + weight[..., None] * (p1 - p0)
            local_q[plan.used_rows] = quat_slerp(q0, q1, weight)
        local_p[plan.roots], local_q[plan.roots] = 0.0, IDENTITY_QUAT  # a tree root is its own origin
        # time-major copies: each time's rows contiguous for compose_tree (rows are parents first)
        local_p, local_q = np.ascontiguousarray(local_p.swapaxes(0, 1)), np.ascontiguousarray(local_q.swapaxes(0, 1))
        world_p, world_q = np.empty_like(local_p), np.empty_like(local_q)
        for k in range(count):
            compose_tree(plan.parent_row, local_p[k], local_q[k], world_p[k], world_q[k])
        world_p, world_q = world_p.swapaxes(0, 1), world_q.swapaxes(0, 1)
        positions, rotations = world_p[plan.found], world_q[plan.found]
        if plan.fixed_row >= 0:
            positions, rotations = compose(*inverse(world_p[plan.fixed_row], world_q[plan.fixed_row]),
                                           positions, rotations)
        return positions, rotations, list(plan.missing), set(plan.used)

    def sample(self, stamp_s: float, frames: Skeleton | Sequence[str]) -> PoseSample:
        """The pose of ``frames`` (a Skeleton, or frame names: a flat skeleton) in the fixed frame at ``stamp_s``."""
        return self._sample(stamp_s, frames)[0]

    def _sample(self, stamp_s: float, frames: Skeleton | Sequence[str]) -> tuple[PoseSample, set[str]]:
        """The sample and the dynamic frames it was composed from."""
        skeleton = frames if isinstance(frames, Skeleton) else Skeleton(tuple(frames), (-1,) * len(frames))
        if not self._parent:
            return PoseSample(None, SampleStatus.NO_DATA, skeleton.names, math.inf, "no transform received yet"), set()
        positions, rotations, missing, used = self._compose(skeleton.names, np.array([float(stamp_s)]))
        if missing:
            detail = "; ".join(self._why_missing(frame) for frame in missing)
            return PoseSample(None, SampleStatus.MISSING_FRAMES, tuple(missing), math.nan, detail), used
        status, age, detail = SampleStatus.OK, 0.0, ""
        if used:
            newest = {frame: self._dynamic[frame].stamps[-1] for frame in used}
            oldest = {frame: self._dynamic[frame].stamps[0] for frame in used}
            stalest = min(newest, key=newest.get)
            age = float(stamp_s - newest[stalest])
            if age > self.max_age_s:
                status = SampleStatus.STALE
                detail = f"newest data of {stalest!r} is {age:.3f} s old (max_age_s {self.max_age_s})"
            elif age > 0.0 or any(stamp_s < oldest[f] for f in used):
                status = SampleStatus.EXTRAPOLATED
                detail = f"{stamp_s} is outside the stamps of " + ", ".join(
                    repr(f) for f in sorted(used) if not oldest[f] <= stamp_s <= newest[f])
        pose = SkeletonPose(skeleton, positions[:, 0], rotations[:, 0])
        return PoseSample(pose, status, (), age, detail), used

    def _why_missing(self, frame: str) -> str:
        if self.fixed_frame not in self.frames:
            return f"{frame!r}: the fixed frame {self.fixed_frame!r} is not in the tree"
        if frame not in self.frames:
            return f"{frame!r}: no transform names it"
        chain = tree_chain(frame, self._parent)
        return f"{frame!r}: {' -> '.join(chain)} does not reach {self.fixed_frame!r}"

    # ------------------------------------------------------------------ root kinematics

    def root_motion(self, stamp_s: float, dt: float, joint_map: Mapping[str, str]) -> RootMotion:
        """Root (pelvis) position, heading and their first two derivatives at ``stamp_s``.

        Position and heading are the sample at ``stamp_s``. The derivatives come from a least-squares
        quadratic in time over the samples of a ``kinematics_window_s`` window ending at
        ``min(stamp_s + window / 2, newest stamp)`` (at least three samples), evaluated at
        ``stamp_s``: centred on T when the data reaches past it, otherwise the newest window, whose
        acceleration is about the mean over it (lags ~ window / 2). The heading is
        ``body.root.root_frame``'s, unwrapped before the fit."""
        names = (joint_map["pelvis"], joint_map["left_upper_leg"], joint_map["right_upper_leg"])
        roles = {"pelvis": names[0], "left_upper_leg": names[1], "right_upper_leg": names[2]}
        now, used = self._sample(stamp_s, list(dict.fromkeys(names)))
        if now.pose is None:
            return RootMotion(now.status, dt, 0, None, None, None, None, None, None, now.detail)
        try:
            return self._root_motion(stamp_s, dt, now, used, roles)
        except ValueError as err:  # body.root.root_frame: the hips coincide horizontally (bad data)
            self.rejected["degenerate_root"] += 1
            return RootMotion(SampleStatus.DEGENERATE, dt, 0, None, None, None, None, None, None,
                              f"at {stamp_s}: {err} ({roles['left_upper_leg']!r}, {roles['right_upper_leg']!r})")

    def _root_motion(self, stamp_s: float, dt: float, now: PoseSample, used: set[str],
                     roles: Mapping[str, str]) -> RootMotion:
        position, yaw = root_frame(now.pose, roles)
        stamps = np.unique(np.concatenate([self._dynamic[f].stamps for f in used] + [np.empty(0)]))
        # centred on T where the data reaches past it (no lag), else the newest window (lag ~ window / 2)
        stamps = stamps[stamps <= stamp_s + 0.5 * self.kinematics_window_s]
        window = stamps[stamps >= stamps[-1] - self.kinematics_window_s] if len(stamps) else stamps
        if len(window) < 3:
            window = stamps[-3:]
        if len(window) < 2:
            zero = np.zeros(3)
            return RootMotion(now.status, dt, len(window), position, yaw, zero, zero, 0.0, 0.0, now.detail)
        names = now.pose.skeleton.names
        positions, _, _, _ = self._compose(names, window)
        yaws = headings(*(positions[names.index(roles[hip])] for hip in ("left_upper_leg", "right_upper_leg")))
        velocity, acceleration, yaw_rate, yaw_acceleration = fit_root_kinematics(
            window - float(stamp_s), positions[0], yaws)
        return RootMotion(now.status, dt, len(window), position, yaw, velocity, acceleration,
                          yaw_rate, yaw_acceleration, now.detail)
