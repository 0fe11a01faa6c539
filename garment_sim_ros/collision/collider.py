"""Collision handling of mass points against a ``VolumeSet`` (memo §6.2), for the cloth solver.

Per frame the solver calls ``begin_frame`` with the volumes' poses at the frame's start and
end; per substep ``begin_substep`` (poses interpolated to the substep's ends),
``handle_contacts`` inside the length correction (memo §3 step 4) and ``resolve_substep`` after
it (step 5 and beyond). The arithmetic is in ``kernels``; this class owns the volumes' arrays
(``VolumeArrays``, poses rewritten per substep), scratch buffers and the frame's hit counters.
The garment's own collision state, the per-point cache of recently hit volumes (``contacts``), is
the caller's (``ClothState.contacts``), passed to every call, so that a copy of the garment's
state is all of it. Arguments in one order everywhere: start positions, positions, velocities,
inverse masses, substep length, contacts, then the cloth's topology.
"""

from __future__ import annotations

import numpy as np

from ..params import DEFAULT_PARAMS, SolverParams
from . import contact_planes, crossing, kernels
from .response import MODE_ADAPTIVE, MODE_DYNAMIC, MODE_STATIC
from .volume_arrays import VolumeArrays, no_planes
from .volumes import VolumeSet

# ``parallel=None``: handle_all and handle_contacts spread the points over numba's threads from this many
# points on. Measured (docs/benchmarks.md): 2 threads pay from ~2 000 points (handle_all 0.18 against 0.43 ms
# per call), lose a little at 720; with one thread the parallel kernels cost what the serial ones do.
PARALLEL_MIN_POINTS = 1500
# handle_axes: passes over the triangles at most; moving a crossed triangle off a bone can cross a neighbour
AXIS_PASSES = 16
_MODES = {"adaptive": MODE_ADAPTIVE, "static": MODE_STATIC, "dynamic": MODE_DYNAMIC}
_NO_PAIRS = np.zeros((0, 2), dtype=np.int64)  # contact planes off


class Collider:
    """Collision handling of mass points against a VolumeSet, in the simulation frame."""

    def __init__(self, volumes: VolumeSet, n_points: int, cache_size: int = 2, parallel: bool | None = None):
        if not isinstance(volumes, VolumeSet) or len(volumes) == 0:
            raise ValueError(f"Collider: volumes must be a non-empty VolumeSet, got {volumes!r}")
        if int(n_points) != n_points or n_points < 0:
            raise ValueError(f"Collider: n_points must be a whole number >= 0, got {n_points!r}")
        if int(cache_size) != cache_size or not 1 <= cache_size <= len(volumes):
            raise ValueError(f"Collider: cache_size must be in [1, {len(volumes)}] (the number of volumes), "
                             f"got {cache_size!r}")
        self.volumes = volumes
        self.n_points = int(n_points)
        self.cache_size = int(cache_size)
        n_volumes = len(volumes)
        self.arrays = VolumeArrays.at_rest(volumes)  # the kernels' view; poses at the substep's ends
        self._pressable = contact_planes.pressable_pairs(volumes)  # (K, 2) pairs that may be pressed together
        self._jointed = contact_planes.jointed_pairs(volumes)  # (J, 2) pairs whose bones meet at a joint
        self.pressed_depth = 0.0  # m, the deepest overlap of two volumes pressed onto a contact plane this frame
        # as the kernels take them from Python (a plain tuple: see ``collision.kernels``); and with every
        # broad-phase test passing, the same poses
        self._packed, self._packed_unbounded = tuple(self.arrays), tuple(self.arrays.unbounded())
        # frame poses (quaternions), interpolated per substep into the arrays' matrices
        self._frame_pos = np.zeros((2, n_volumes, 3))
        self._frame_quat = np.zeros((2, n_volumes, 4))
        self._frame_quat[:, :, 3] = 1.0
        self._scratch = np.zeros((self.n_points, 2 * self.cache_size), dtype=np.int64)  # handle_all's
        self._depths = np.zeros(self.n_points)
        # per point, a bit per volume: the volumes that grip it along their axes (``axial_friction``,
        # ``grip_tubes``); none by default
        self._grips = np.zeros(self.n_points, dtype=np.int64)
        if parallel is None:
            parallel = self.n_points >= PARALLEL_MIN_POINTS
        self.parallel = bool(parallel)
        self._checked_edges = None  # the last edge array handle_edges validated
        self._checked_triangles = None  # the last triangle array handle_axes validated
        self._checked_springs = None  # the last spring array give_room_to_tears validated
        self._checked_contacts = None  # the last contact cache validated
        self._corners = np.zeros((3, 3))  # handle_axes' scratch
        self._triangle_boxes = np.zeros((0, 6))  # handle_axes' scratch, sized for the triangles it checked last
        self.use_broad_phase = True  # off only to check that it changes nothing
        self.static_hits = 0
        self.dynamic_hits = 0
        self.set_params(DEFAULT_PARAMS)
        self._frame_started = False

    def grip_tubes(self, limb_tubes: dict, rings: dict) -> None:
        """Let the limbs grip their tubes along their bones (``axial_friction``): ``limb_tubes`` maps a tube
        (a trouser leg) to the names of the volumes it goes round (``ClothModel.limb_tubes``), ``rings`` a tube to
        its rings' point indices (``ClothModel.rings``). Other cloth a limb touches (a skirt, a waistband a
        forearm leaves along itself) slides along it as before."""
        names = self.volumes.names()
        if len(names) > 63:
            raise ValueError(f"grip_tubes: at most 63 volumes (a bit each), got {len(names)}")
        self._grips[:] = 0
        for tube, segments in limb_tubes.items():
            bits = sum(1 << names.index(s) for s in segments if s in names)
            for ring in rings[tube]:
                self._grips[np.asarray(ring, dtype=np.int64)] |= bits

    def new_contacts(self) -> np.ndarray:
        """An empty contact cache: (n_points, cache_size) int64 volume indices, most recent first, -1 empty."""
        return np.full((self.n_points, self.cache_size), -1, dtype=np.int64)

    # ------------------------------------------------------------------ set-up per run/frame/substep
    def set_params(self, params: SolverParams) -> None:
        self._friction = float(params.friction)
        self._grip = (float(params.contact_friction), float(params.axial_friction), self._grips,
                      float(params.open_cut_band))
        self._margin = float(params.contact_margin)
        self._eps = float(params.collision_epsilon)
        self._pinch_depth = float(params.pinch_depth)
        self._edge_pinch_depth = float(params.edge_pinch_depth)
        self._c_time = float(params.contact_time_fraction)
        self._switch_ratio = float(params.dynamic_switch_ratio)
        self._mode = _MODES[params.collision_mode]
        self._press = bool(params.contact_planes) and len(self._pressable) > 0
        self._clearance = float(params.press_clearance)
        self._room = max(float(params.press_gap), 2.0 * self._eps)
        if not self._press:
            self.arrays.planes[...] = no_planes(len(self.volumes))
        self.arrays.pinch_depths[...] = float(params.pinch_depth)
        # flesh that gives way: pressed against the bone's volume, or the next limb's at the bone's joint (the
        # upper arm's bone near the elbow: cmu_131's one-piece at 3x, every way off it 1-11 mm into the forearm)
        for a, b in np.concatenate([self.pressing, self._jointed]):
            self.arrays.pinch_depths[a, b] = self.arrays.pinch_depths[b, a] = float(params.pressed_pinch_depth)

    def begin_frame(self, pos0, rot0, pos1, rot1) -> None:
        """Volume poses at the frame's start and end: (V, 3) positions, (V, 4) xyzw quaternions."""
        n_volumes = len(self.volumes)
        for name, value, width in (("pos0", pos0, 3), ("rot0", rot0, 4), ("pos1", pos1, 3), ("rot1", rot1, 4)):
            array = np.asarray(value, dtype=float)
            if array.shape != (n_volumes, width) or not np.all(np.isfinite(array)):
                raise ValueError(f"Collider.begin_frame: {name} must be finite with shape ({n_volumes}, {width}), "
                                 f"got shape {array.shape}")
        for k, (p, q) in enumerate(((pos0, rot0), (pos1, rot1))):
            q = np.asarray(q, dtype=float)
            norms = np.linalg.norm(q, axis=1)
            if np.any(norms < 1e-9):
                raise ValueError(f"Collider.begin_frame: rot{k} has a zero quaternion (volume "
                                 f"{self.volumes.names()[int(np.argmin(norms))]!r})")
            self._frame_pos[k] = p
            self._frame_quat[k] = q / norms[:, None]
        self.static_hits = 0
        self.dynamic_hits = 0
        self.pressed_depth = 0.0
        self._frame_started = True
        self.begin_substep(0.0, 1.0)

    def begin_substep(self, f0: float, f1: float) -> None:
        """Interpolate the poses at frame fractions f0 (substep start) and f1 (end)."""
        if not self._frame_started:
            raise RuntimeError("Collider.begin_substep: call begin_frame first")
        if not 0.0 <= f0 < f1 <= 1.0:
            raise ValueError(f"Collider.begin_substep: need 0 <= f0 < f1 <= 1, got f0={f0}, f1={f1}")
        # the pressed volumes' planes at the substep's end, carried over it in their local frames
        deepest = kernels.substep_poses(self._packed, self._frame_pos, self._frame_quat, float(f0), float(f1),
                                        self.pressing, *self._press_with)
        self.pressed_depth = max(self.pressed_depth, deepest)

    @property
    def pressing(self) -> np.ndarray:
        """(P, 2) the volume pairs pressed together where they meet (``contact_planes``); none when off."""
        return self._pressable if self._press else _NO_PAIRS

    @property
    def press_with(self) -> tuple[float, float, float] | None:
        """(clearance, gap, room) m the pressed volumes' planes keep (``contact_planes.press``); None when off."""
        return self._press_with if self._press else None

    @property
    def _press_with(self) -> tuple[float, float, float]:
        return self._clearance, 2.0 * self._eps, self._room

    # ------------------------------------------------------------------ handling
    # Each public call checks its arguments, then runs its kernel (``_points``, ``_contacts``, ``_edges``,
    # ``_axes``); ``resolve_substep`` checks once for its up to nine kernel calls.
    def resolve_substep(self, x_start, x, v, inv_mass, h: float, contacts, edges, edge_rest, triangles,
                        edge_halves=None) -> None:
        """Full collision handling of a substep's end (memo §3 step 5, and beyond it edges and bones),
        with its retry policy: every point against every volume; then triangles a limb bone passes
        through go back to their side of it and edges a limb cuts into go back out; if either moved
        anything, the points that put into a volume are handled again -- the cached contacts, then,
        as an edge moved off one volume can meet its neighbour, the edges and every point against
        every volume once more, then the bones, so that a pinch ends with the cloth on its side of
        the bone (``collision.crossing``), and, if those moved any, every point against every volume
        last: a corner the bones' handling put up to ``pressed_pinch_depth`` into a volume pressed
        against the bone's (a hand on the hip, its wrist against the thigh: cmu_131) goes out of it.
        Points (N, 3) m, velocities m/s, ``h`` s; ``contacts`` as ``new_contacts`` makes it; ``edges``
        (E, 2) with ``edge_rest`` (E,) m; ``triangles`` (T, 3); ``edge_halves``: where the halves start (4,)
        when the edges are in ``cloth.halves``' order, each half then handled on its own thread; None: in their
        order on one."""
        self._check_points(x_start, x, v, inv_mass, h, contacts)
        edges, edge_rest = self._check_edges(edges, edge_rest)
        self._check_triangles(triangles)
        h = float(h)
        self._points(x_start, x, v, inv_mass, h, contacts)
        crossed = self._axes(x_start, x, v, inv_mass, h, triangles)
        if self._edges(x_start, x, inv_mass, edges, edge_rest, edge_halves) or crossed:
            self._contacts(x_start, x, v, inv_mass, h, contacts, self._mode)
            self._edges(x_start, x, inv_mass, edges, edge_rest, edge_halves)
            self._points(x_start, x, v, inv_mass, h, contacts)
            if self._axes(x_start, x, v, inv_mass, h, triangles):
                crossing.out_of_pinches(self._packed, x, inv_mass, self._eps, self._pinch_depth)

    def handle_contacts(self, x_start, x, v, inv_mass, h: float, contacts) -> None:
        """Handling of the cached (in-contact) pairs, ``contacts``, at the substep-end poses (memo §3 step 4).

        Static (``x_start`` None), or -- given the points' substep-start positions ``x_start`` -- the same adaptive
        static/dynamic handling as ``handle_all`` (without the slide), so that a point the length
        correction pulled deep into a thin limb goes back out on the side it came from. ``h`` (s), the
        substep's length, gives the surface's velocity.
        """
        static = x_start is None
        self._check_points(x if static else x_start, x, v, inv_mass, h, contacts)
        self._contacts(x if static else x_start, x, v, inv_mass, float(h), contacts,
                       MODE_STATIC if static else self._mode)

    def handle_all(self, x_start, x, v, inv_mass, h: float, contacts) -> None:
        """Every point against every volume, adaptive static/dynamic (memo §3 step 5, §6.2); ``contacts``
        (``new_contacts``) is read first and rewritten with what the points now touch."""
        self._check_points(x_start, x, v, inv_mass, h, contacts)
        self._points(x_start, x, v, inv_mass, float(h), contacts)

    def handle_edges(self, x_start, x, inv_mass, edges, rest_lengths) -> int:
        """Move cloth edges (E, 2) that cut into a volume deeper than their rest length allows back out,
        on the side they came from (``x_start``: substep start; see ``kernels.handle_edges``); x in
        place. Returns the number of edges moved."""
        for name, array in (("x_start", x_start), ("x", x)):
            if not isinstance(array, np.ndarray) or array.shape != (self.n_points, 3) or array.dtype != np.float64:
                raise ValueError(f"Collider.handle_edges: {name} must be a float64 array of shape ({self.n_points}, 3)")
        edges, rest_lengths = self._check_edges(edges, rest_lengths)
        return self._edges(x_start, x, np.asarray(inv_mass, dtype=np.float64), edges, rest_lengths)

    def handle_axes(self, x_start, x, v, inv_mass, h: float, triangles) -> int:
        """Move cloth triangles (T, 3) that a volume's axis (its bone) passes through off it, to the
        volume's surface on the side they came from (``x_start``: substep start; see
        ``crossing.handle_axes``); x and v in place. Returns the number of triangles moved."""
        self._check_points(x_start, x, v, inv_mass, h)
        self._check_triangles(triangles)
        return self._axes(x_start, x, v, inv_mass, float(h), triangles)

    def _points(self, x_start, x, v, inv_mass, h: float, contacts) -> None:
        kernel = kernels.handle_all_parallel if self.parallel else kernels.handle_all
        arrays = self._packed if self.use_broad_phase else self._packed_unbounded
        n_static, n_dynamic = kernel(arrays, x_start, x, v, inv_mass, h, self._eps, self._friction, self._grip,
                                     self._c_time, self._switch_ratio, self._mode, self._margin, contacts,
                                     self._scratch)
        self.static_hits += int(n_static)
        self.dynamic_hits += int(n_dynamic)

    def _contacts(self, x_start, x, v, inv_mass, h: float, contacts, mode: int) -> None:
        kernel = kernels.handle_contacts_parallel if self.parallel else kernels.handle_contacts
        self.static_hits += int(kernel(self._packed, x_start, x, v, inv_mass, h, self._eps, self._friction,
                                       self._grip, self._switch_ratio, mode, contacts))

    def _edges(self, x_start, x, inv_mass, edges, rest_lengths, halves=None) -> int:
        if halves is None:
            return int(kernels.handle_edges(self._packed, x_start, x, inv_mass, edges, rest_lengths,
                                            self._edge_pinch_depth))
        return int(kernels.handle_edges_halves(self._packed, x_start, x, inv_mass, edges, rest_lengths, halves,
                                               self._edge_pinch_depth))

    def _axes(self, x_start, x, v, inv_mass, h: float, triangles) -> int:
        return int(crossing.handle_axes(self._packed, x_start, x, v, inv_mass, h, triangles, self._eps, AXIS_PASSES,
                                        self._corners, self._triangle_boxes))

    def bones_through(self, x, triangles) -> int:
        """How many of the volumes' bones (``Volume.bone``) cross a triangle (T, 3) of ``x`` (N, 3) m at the
        substep-end poses: issue 11's (b) on the body's volumes (``quality`` measures it on the skeleton's joints,
        which the bones were fitted round)."""
        self._check_triangles(triangles)
        arrays = self.arrays
        boned = ~np.isnan(arrays.bones[:, 0])
        if not boned.any():
            return 0
        axes = arrays.rot1[boned, :, 2]  # the local z axes, simulation frame
        starts = arrays.pos1[boned] + axes * arrays.bones[boned, :1]
        ends = arrays.pos1[boned] + axes * arrays.bones[boned, 1:]
        return int(crossing.segments_through_triangles(starts, ends, np.ascontiguousarray(x, dtype=np.float64),
                                                       triangles, np.zeros(len(starts), dtype=np.bool_)))

    def give_room_to_tears(self, x, inv_mass, springs, rest, count: int, stretch: float, x_from) -> int:
        """Springs (S, 2) of ``x`` (N, 3) m, the first ``count``, longer than ``stretch`` x their ``rest`` (S,) m
        shortened into their ends' contact room, half ``collision_epsilon``, no point into a volume at the
        substep-end poses (``kernels.give_room_to_tears``; ``x_from`` (N, 3) scratch); x in place. Returns how
        many ends moved."""
        n, count = self.n_points, int(count)
        for name, array in (("x", x), ("x_from", x_from)):
            if not isinstance(array, np.ndarray) or array.shape != (n, 3) or array.dtype != np.float64 \
                    or not array.flags.c_contiguous:
                raise ValueError(f"Collider.give_room_to_tears: {name} must be a C-contiguous float64 array of "
                                 f"shape ({n}, 3) (modified in place)")
        springs, rest = np.asarray(springs), np.asarray(rest, dtype=np.float64)
        if (springs.ndim != 2 or springs.shape[1] != 2 or rest.ndim != 1
                or not 0 <= count <= min(len(springs), len(rest)) or np.shape(inv_mass) != (n,)):
            raise ValueError(f"Collider.give_room_to_tears: need springs (S, 2), rest (S,) and inv_mass ({n},), "
                             f"count <= S; got {springs.shape}, {rest.shape}, {np.shape(inv_mass)}, {count}")
        if springs is not self._checked_springs:  # the solver passes the same array every substep: check it once
            if springs.size and not 0 <= springs.min() <= springs.max() < n:
                raise ValueError(f"Collider.give_room_to_tears: springs must be point indices below {n}")
            self._checked_springs = springs
        return int(kernels.give_room_to_tears(self._packed, x, np.asarray(inv_mass, dtype=np.float64), springs, rest,
                                              count, float(stretch), self._eps, x_from))

    def penetration_depths(self, x) -> np.ndarray:
        """(N,) metres inside the deepest volume at the substep-end poses, 0 outside.

        Exact for spheres and capsules; for ellipsoids an upper bound of the distance to the
        curved surface (see ``geometry.penetration_depth``), so "< 1 mm" checks are conservative.
        """
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"Collider.penetration_depths: x must have shape (N, 3), got {x.shape}")
        out = self._depths if x.shape[0] == self.n_points else np.zeros(x.shape[0])
        kernels.penetration_depths(self._packed, x, out)
        return out.copy()

    def deepest_triangle_centre(self, x, triangles) -> float:
        """Metres inside a volume (``penetration_depths``) of the deepest centre of ``triangles`` (T, 3) of the
        points ``x`` (N, 3) at the substep-end poses, 0 when none is inside."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        triangles = np.ascontiguousarray(triangles, dtype=np.int64)
        if (x.shape != (self.n_points, 3) or triangles.ndim != 2 or triangles.shape[1] != 3
                or (triangles.size and not 0 <= triangles.min() <= triangles.max() < self.n_points)):
            raise ValueError(f"Collider.deepest_triangle_centre: need points ({self.n_points}, 3) and triangles (T, 3) "
                             f"of indices below {self.n_points}, got {x.shape} and {triangles.shape}")
        return float(kernels.deepest_triangle_centre(self._packed, x, triangles))

    def _check_points(self, x_start, x, v, inv_mass, h, contacts=None) -> None:
        """Refuse what the kernels would misread: they index the arrays unchecked and write x, v, contacts."""
        n = self.n_points
        for name, array, shape in (("x", x, (n, 3)), ("v", v, (n, 3)), ("inv_mass", inv_mass, (n,))):
            if not isinstance(array, np.ndarray) or array.shape != shape or array.dtype != np.float64:
                got = f"{array.dtype} {array.shape}" if isinstance(array, np.ndarray) else type(array).__name__
                raise ValueError(f"Collider: {name} must be a float64 array of shape {shape} "
                                 f"(modified in place), got {got}")
            if name != "inv_mass" and not array.flags.c_contiguous:
                raise ValueError(f"Collider: {name} must be C-contiguous (it is modified in place)")
        if not isinstance(x_start, np.ndarray) or x_start.shape != x.shape or x_start.dtype != np.float64:
            raise ValueError(f"Collider: x_start must be a float64 array of shape {x.shape}")
        if not h > 0.0:
            raise ValueError(f"Collider: the substep length h must be > 0 s, got {h!r}")
        if contacts is not None and contacts is not self._checked_contacts:  # the same array every substep
            if (not isinstance(contacts, np.ndarray) or contacts.dtype != np.int64
                    or contacts.shape != (n, self.cache_size) or not contacts.flags.c_contiguous):
                raise ValueError(f"Collider: contacts must be a C-contiguous int64 array of shape "
                                 f"{(n, self.cache_size)} (Collider.new_contacts; modified in place)")
            self._checked_contacts = contacts

    def _check_edges(self, edges, rest_lengths):
        """``edges`` (E, 2) point indices and their ``rest_lengths`` (E,) m as arrays, or a clear error."""
        edges = np.asarray(edges)
        rest_lengths = np.asarray(rest_lengths, dtype=np.float64)
        if edges is not self._checked_edges:  # the solver passes the same array every substep: check it once
            if (edges.ndim != 2 or edges.shape[1] != 2 or rest_lengths.shape != (len(edges),)
                    or (edges.size and not 0 <= edges.min() <= edges.max() < self.n_points)):
                raise ValueError(f"Collider.handle_edges: edges must be (E, 2) point indices below {self.n_points} "
                                 "with E rest lengths")
            self._checked_edges = edges
        elif rest_lengths.shape != (len(edges),):
            raise ValueError(f"Collider.handle_edges: need {len(edges)} rest lengths, got shape {rest_lengths.shape}")
        return edges, rest_lengths

    def _check_triangles(self, triangles) -> None:
        if triangles is not self._checked_triangles:  # the solver passes the same array every substep
            if (not isinstance(triangles, np.ndarray) or triangles.ndim != 2 or triangles.shape[1] != 3
                    or triangles.dtype != np.int64
                    or (triangles.size and not 0 <= triangles.min() <= triangles.max() < self.n_points)):
                raise ValueError(f"Collider.handle_axes: triangles must be an int64 (T, 3) array of point indices "
                                 f"below {self.n_points}")
            self._checked_triangles = triangles
            self._triangle_boxes = np.zeros((crossing.axis_block_count(len(triangles)), 6))

    def axis_boxes(self, triangles) -> np.ndarray:
        """``crossing.handle_axes``' box scratch for ``triangles`` (T, 3) (checked as ``handle_axes`` does)."""
        self._check_triangles(triangles)
        return self._triangle_boxes
