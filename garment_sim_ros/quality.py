"""How well a garment stays on the body: the figures of issue 11 and their targets (ROS-free).

A point-depth figure alone cannot see a limb that passes *between* cloth points, so besides
(a) the deepest free point inside a volume (``Collider.penetration_depths``) a garment is
measured by:

- (b) limb bones through the cloth: the limb bone segments (thighs, shins, upper arms,
  forearms, and the spine from the pelvis to the chest joint) that cross a garment triangle;
- (c) trouser legs off their leg: a limb tube of the garment (``GarmentMesh.limb_tubes``) one of whose
  rings goes round none of its limb's volumes (winding number about the volume's axis);
- (d) structural and shear stretch (length / rest length): 99th percentile and maximum;
- (e) guard firings (``FrameReport.recovery``), counted by the callers;
- the cloth surface's depth: the deepest triangle centre (of the triangles with no attached vertex) inside
  a volume. Not one of the issue's targets; it shows what a picture shows: a body part bulging through a
  triangle whose corners all lie outside (the corner where a contact plane meets a volume's curved surface,
  long or stretched triangles round a small radius);
- (f) in an outfit, layer crossings: a garment's edges through a triangle of one worn under it
  (``cloth.triangle_grid.count_edges_through``; ``DressedCharacter.measure`` fills it).

``GarmentMeter.measure`` fills a ``FrameReport``'s figures; ``DressedCharacter.step`` calls it
after every frame. ``Targets`` is the one table of pass/fail thresholds (``garment-sim evaluate``).
The per-triangle and per-spring work is in numba kernels over flat arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .cloth.kernels import spring_stretches
from .cloth.model import STRETCH_MAX_TARGET, STRETCH_P99_TARGET, stretch_figures, stretch_groups
from .collision.crossing import segments_through_triangles
from .collision.geometry import to_local
from .transforms import quat_to_matrix

# name, joint-map role at the bone's start, role at its end (body.joint_map.ROLES)
LIMB_BONES: tuple[tuple[str, str, str], ...] = (
    ("left_thigh", "left_upper_leg", "left_lower_leg"),
    ("right_thigh", "right_upper_leg", "right_lower_leg"),
    ("left_shin", "left_lower_leg", "left_foot"),
    ("right_shin", "right_lower_leg", "right_foot"),
    ("left_upper_arm", "left_upper_arm", "left_lower_arm"),
    ("right_upper_arm", "right_upper_arm", "right_lower_arm"),
    ("left_forearm", "left_lower_arm", "left_hand"),
    ("right_forearm", "right_lower_arm", "right_hand"),
    ("spine", "pelvis", "chest"),
)


# ----------------------------------------------------------------------------- kernels

@njit(cache=True)
def rings_around(x, ring_vertices, ring_starts, ring_volumes, pos, rot, cuts, around):
    """Which rings go round one of their volumes' axes.

    Ring ``r`` is ``x[ring_vertices[ring_starts[r]:ring_starts[r + 1]]]`` (a closed polygon);
    ``ring_volumes`` (R, K) the volumes it may go round (-1: none); ``pos`` (V, 3), ``rot`` (V, 3, 3)
    the volumes' poses in ``x``'s frame; ``cuts`` (V, 2) their kept local z range, m. A ring goes
    round volume v when its mean local height lies within v's cut and its winding number about
    v's local z axis is not zero (a ring's centroid would not do: a loose hem hanging off a bent
    shin still goes round it with its centroid 1.5 shin radii off the axis). Writes ``around`` (R,).
    """
    for r in range(ring_starts.shape[0] - 1):
        first, last = ring_starts[r], ring_starts[r + 1]
        around[r] = False
        for k in range(ring_volumes.shape[1]):
            v = ring_volumes[r, k]
            if v < 0:
                continue
            i = ring_vertices[last - 1]
            lx, ly, lz = to_local(pos, rot, v, x[i, 0], x[i, 1], x[i, 2])
            previous = math.atan2(ly, lx)
            turned = 0.0
            height = 0.0
            for j in range(first, last):
                i = ring_vertices[j]
                lx, ly, lz = to_local(pos, rot, v, x[i, 0], x[i, 1], x[i, 2])
                angle = math.atan2(ly, lx)
                step = angle - previous
                turned += (step + math.pi) % (2.0 * math.pi) - math.pi  # the short way round
                previous = angle
                height += lz
            height /= last - first
            if cuts[v, 0] <= height <= cuts[v, 1] and round(turned / (2.0 * math.pi)) != 0:
                around[r] = True
                break


# ----------------------------------------------------------------------------- per garment

def surface_depth(solver, triangles: np.ndarray) -> float:
    """Deepest centre of the garment's ``triangles`` (T, 3) inside any volume at the last frame's end, m."""
    if solver.collider is None or not len(triangles):
        return 0.0
    return solver.collider.deepest_triangle_centre(solver.state.positions, triangles)


def free_point_depth(solver) -> float:
    """Deepest free (not attached) point of the garment inside any volume at the last frame's end, m.

    Attached points are left out: they ride on their segment wherever it puts them (a strapless
    dress's neckline runs under the arms' volumes)."""
    if solver.collider is None:
        return 0.0
    free = solver.constants.inv_mass > 0.0
    depths = solver.collider.penetration_depths(solver.state.positions)[free]
    return float(np.max(depths, initial=0.0))


class LimbTubes:
    """A garment's limb tubes (``ClothModel.limb_tubes``) against a ``VolumeSet``, as flat arrays.

    A tube whose limb has no volume of that name is not checked (a body without leg volumes)."""

    def __init__(self, model, volumes):
        names = volumes.names() if volumes is not None else []
        vertices, starts, ring_volumes, ring_tube = [], [0], [], []
        self.names: list[str] = []
        for tube, segments in model.limb_tubes.items():
            wanted = [names.index(s) for s in segments if s in names]
            if not wanted:
                continue
            for ring in model.rings[tube][1:]:  # the first ring joins the body tube (see GarmentMesh)
                vertices.append(np.asarray(ring, dtype=np.int64))
                starts.append(starts[-1] + len(ring))
                ring_volumes.append(wanted)
                ring_tube.append(len(self.names))
            self.names.append(tube)
        width = max((len(v) for v in ring_volumes), default=1)
        self.ring_vertices = np.concatenate(vertices) if vertices else np.zeros(0, np.int64)
        self.ring_starts = np.asarray(starts, dtype=np.int64)
        self.ring_volumes = np.full((len(ring_volumes), width), -1, dtype=np.int64)
        for r, wanted in enumerate(ring_volumes):
            self.ring_volumes[r, :len(wanted)] = wanted
        self.ring_tube = np.asarray(ring_tube, dtype=np.int64)
        self.cuts = np.ascontiguousarray(volumes.cuts, dtype=float) if volumes is not None else np.zeros((0, 2))
        self._around = np.zeros(len(ring_volumes), dtype=np.bool_)

    def rings_off(self, positions: np.ndarray, volume_positions: np.ndarray, volume_rotations: np.ndarray
                  ) -> np.ndarray:
        """Per tube (``self.names``), the rings that go round none of its limb's volumes.

        ``positions`` (N, 3) and the volumes' poses (V, 3) and (V, 3, 3) rotation matrices or
        (V, 4) xyzw quaternions, all in one frame (the world, or the simulation frame)."""
        rotations = np.asarray(volume_rotations, dtype=float)
        if rotations.ndim == 2:
            rotations = quat_to_matrix(rotations)
        if len(self._around):
            rings_around(np.ascontiguousarray(positions, dtype=float), self.ring_vertices, self.ring_starts,
                         self.ring_volumes, np.ascontiguousarray(volume_positions, dtype=float),
                         np.ascontiguousarray(rotations), self.cuts, self._around)
        return np.bincount(self.ring_tube[~self._around], minlength=len(self.names))


def rings_off_the_legs(model, volumes, positions, volume_positions, volume_rotations) -> np.ndarray:
    """Rings off their limb per limb tube of ``model`` (see ``LimbTubes.rings_off``)."""
    return LimbTubes(model, volumes).rings_off(positions, volume_positions, volume_rotations)


class GarmentMeter:
    """Measures one garment on one body after a frame (index arrays prepared once)."""

    def __init__(self, model, volumes, joint_map):
        self.bones = tuple(b for b in LIMB_BONES if b[1] in joint_map and b[2] in joint_map)
        self._bone_frames = [(joint_map[start], joint_map[end]) for _, start, end in self.bones]
        self.tubes = LimbTubes(model, volumes)
        self._triangles = np.ascontiguousarray(model.triangles, dtype=np.int64)
        attached = np.zeros(model.num_points, dtype=bool)
        attached[model.attached] = True
        self._free_triangles = self._triangles[~attached[self._triangles].any(axis=1)]
        self._kinds = stretch_groups(model.spring_kinds)
        self._springs = np.ascontiguousarray(model.springs)
        self._rest = np.ascontiguousarray(model.rest_lengths)
        self._stretch = np.zeros(model.num_correction_springs)  # structural and shear come first
        self._crossed = np.zeros(len(self.bones), dtype=np.bool_)

    def bone_segments(self, pose) -> tuple[np.ndarray, np.ndarray]:
        """Starts and ends (B, 3) of ``self.bones`` in the world at a ``SkeletonPose``, m."""
        index = np.array([[pose.skeleton.index(a), pose.skeleton.index(b)] for a, b in self._bone_frames],
                         dtype=np.int64).reshape(-1, 2)
        return np.ascontiguousarray(pose.positions[index[:, 0]]), np.ascontiguousarray(pose.positions[index[:, 1]])

    def bones_through(self, world_positions: np.ndarray, pose) -> list[str]:
        """Names of the limb bones crossing a garment triangle (garment positions (N, 3), world, m)."""
        starts, ends = self.bone_segments(pose)
        segments_through_triangles(starts, ends, np.ascontiguousarray(world_positions, dtype=float),
                                   self._triangles, self._crossed)
        return [b[0] for b, hit in zip(self.bones, self._crossed) if hit]

    def stretch(self, positions: np.ndarray) -> dict[str, tuple[float, float]]:
        """``{"structural": (p99, max), "shear": (p99, max)}`` of length / rest length at ``positions`` (N, 3)."""
        spring_stretches(np.ascontiguousarray(positions, dtype=float), self._springs, self._rest, self._stretch)
        return self.stretch_figures(self._stretch)

    def stretch_figures(self, stretches: np.ndarray) -> dict[str, tuple[float, float]]:
        """``stretch``'s figures from the structural and shear springs' length / rest length (S_c,)."""
        return stretch_figures(stretches, self._kinds)

    def measure(self, report, solver, world_positions, pose, volume_positions, volume_rotations) -> None:
        """Fill ``report``'s quality figures (see ``FrameReport``) for ``solver``'s garment after a
        frame: its world positions (N, 3), the ``SkeletonPose`` and the volumes' world poses."""
        report.max_depth_m = free_point_depth(solver)
        report.surface_depth_m = surface_depth(solver, self._free_triangles)
        report.bones_through = len(self.bones_through(world_positions, pose))
        off = self.tubes.rings_off(world_positions, volume_positions, volume_rotations)
        report.legs_off = int(np.count_nonzero(off))
        stretch = self.stretch_figures(solver.stretches)  # the solver measured them after the frame
        report.structural_stretch_p99, report.structural_stretch_max = stretch["structural"]
        report.shear_stretch_p99, report.shear_stretch_max = stretch["shear"]


# ----------------------------------------------------------------------------- scalars and targets

# FrameReport quality fields as scalars (name -> field, scale): Rerun, diagnostics, command lines
REPORT_SCALARS: tuple[tuple[str, str, float], ...] = (
    ("depth_mm", "max_depth_m", 1e3),
    ("surface_depth_mm", "surface_depth_m", 1e3),
    ("bones_through", "bones_through", 1.0),
    ("legs_off", "legs_off", 1.0),
    ("structural_stretch_p99", "structural_stretch_p99", 1.0),
    ("structural_stretch_max", "structural_stretch_max", 1.0),
    ("shear_stretch_p99", "shear_stretch_p99", 1.0),
    ("shear_stretch_max", "shear_stretch_max", 1.0),
    ("layer_crossings", "layer_crossings", 1.0),
)


def report_scalars(report) -> dict[str, float]:
    """A ``FrameReport``'s quality figures by name (``REPORT_SCALARS``), plus ``guard`` (1 if it fired)."""
    values = {name: float(getattr(report, field)) * scale for name, field, scale in REPORT_SCALARS}
    values["guard"] = float(bool(report.recovery))
    return values


@dataclass(frozen=True)
class Targets:
    """Issue 11's pass/fail thresholds for one run (a clip, a garment, a playback speed, a frame rate),
    measured from the first frame after dressing. Keys are the issue's letters:

    - (b) no limb bone through the cloth in any frame;
    - (c) no trouser leg off its leg in any frame;
    - (a) free points deeper than ``depth_tolerance_m`` in at most ``depth_frame_share`` of the
      frames, and never deeper than ``depth_never_m``;
    - (d) stretch (structural and shear) 99th percentile at most ``stretch_p99`` in every frame and
      no spring beyond ``stretch_max`` times its rest length;
    - (e) the guard never fires;
    - (f) an outfit's outer garments: no edge through a triangle of a garment worn under it in any frame
      (issue 13; not asked of one garment).

    From ``fast_speed`` times playback on only (b), (c), (e) and ``depth_never_m`` are asked.
    """

    depth_tolerance_m: float = 0.001
    depth_frame_share: float = 0.001
    depth_never_m: float = 0.005
    stretch_p99: float = STRETCH_P99_TARGET
    stretch_max: float = STRETCH_MAX_TARGET
    fast_speed: float = 3.0

    def judge(self, row: dict) -> dict[str, bool | None]:
        """Pass (True), fail (False) or not asked (None) per target for an evaluation row (the keys of
        ``commands.evaluate.evaluate_run``'s result)."""
        fast = row["speed"] >= self.fast_speed
        depth_m = row["max_depth_mm"] * 1e-3
        if fast:
            depth_ok = depth_m < self.depth_never_m
        else:
            depth_ok = depth_m <= self.depth_never_m and row["deep_frames"] <= self.depth_frame_share * row["frames"]
        stretch_ok = all(row[f"{kind}_stretch_p99"] <= self.stretch_p99
                         and row[f"{kind}_stretch_max"] <= self.stretch_max for kind in ("structural", "shear"))
        return {
            "b": row["bones_frames"] == 0,
            "c": row["legs_off_frames"] == 0 if row["limb_tubes"] else None,
            "a": depth_ok,
            "d": None if fast else stretch_ok,
            "e": row["guard_firings"] == 0,
            "f": row["layer_crossing_frames"] == 0 if "layer_crossing_frames" in row else None,
        }


TARGETS = Targets()
