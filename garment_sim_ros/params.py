"""Every solver parameter in one place: name, default, unit, range, meaning.

``PARAMETERS`` is the single table the solver, the ROS node (its parameter descriptors),
the YAML loader and the README's parameter list are made from. ``SolverParams`` is the
validated, immutable value object the solver reads; ``SolverParams.replace(**changes)``
validates and returns a new one, raising ``ParameterError`` that names the parameter, the
bad value and what is allowed.

Presets: ``PRESETS["si"]`` (defaults, SI units) and ``PRESETS["memo"]``, the parameter set
of the memo's experiments (§7: mass 20, gravity 0.5, spring 10000, damping 100, air 20,
limit 1 %, friction 0.2, 6 iterations, 2 correction iterations, 0.04 s time step; neither
the strain limiting after collision nor the tethers, both beyond the memo). The memo's "0.04 s
time step" is read as the *frame* time, split into 6 substeps (the reading
that is stable with explicit Euler; a 0.04 s substep with 6 per frame would simulate 0.24 s
per frame, slower than the 31 fps it reports).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

COLLISION_MODES = ("adaptive", "static", "dynamic")


class ParameterError(ValueError):
    """A parameter value was refused; the message names it and what is allowed."""


@dataclass(frozen=True)
class Param:
    name: str
    default: Any
    unit: str
    low: float | None
    high: float | None
    description: str
    choices: tuple[str, ...] = ()
    # The ROS node's default where a real-time node needs another than the offline commands, whose figures must not
    # depend on the machine's speed (None: ``default``); ``node_value`` reads it
    node_default: Any = None

    @property
    def node_value(self) -> Any:
        """The default the node declares (``node_default``, else ``default``)."""
        return self.default if self.node_default is None else self.node_default

    def check(self, value: Any) -> Any:
        """Return the value normalised to the parameter's type, or raise ParameterError."""
        expected = type(self.default)
        if expected is str:
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise ParameterError(f"{self.name}: got {value!r}; allowed: one of {', '.join(self.choices)}")
            return value
        if expected is tuple:
            if not isinstance(value, (list, tuple)) or len(value) != len(self.default):
                raise ParameterError(f"{self.name}: got {value!r}; allowed: a list of {len(self.default)} numbers "
                                     f"({self.unit})")
            return tuple(self._check_number(v, float) for v in value)
        return self._check_number(value, expected)

    def parse(self, text: str) -> Any:
        """The value written as ``text`` on a command line (a tuple's numbers comma-separated), checked."""
        if isinstance(self.default, str):
            return self.check(text)
        try:
            numbers = [float(part) for part in text.split(",")]
        except ValueError:
            raise ParameterError(f"{self.name}: got {text!r}; allowed: {self.allowed()}") from None
        return self.check(numbers if isinstance(self.default, tuple) else numbers[0] if len(numbers) == 1 else text)

    def _check_number(self, value: Any, kind: type) -> Any:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(f"{self.name}: got {value!r} ({type(value).__name__}); allowed: {self.allowed()}")
        if kind is int and not float(value).is_integer():
            raise ParameterError(f"{self.name}: got {value!r}; allowed: a whole number, {self.allowed()}")
        if not math.isfinite(value):
            raise ParameterError(f"{self.name}: got {value!r}; allowed: a finite number, {self.allowed()}")
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            raise ParameterError(f"{self.name}: got {value!r}; allowed: {self.allowed()}")
        return kind(value)

    def allowed(self) -> str:
        if self.choices:
            return "one of " + ", ".join(self.choices)
        unit = f" {self.unit}" if self.unit and self.unit != "1" else ""
        return f"[{self.low}, {self.high}]{unit}"


PARAMETERS: tuple[Param, ...] = (
    # time stepping (memo §3)
    Param("substep", 0.005, "s", 1e-5, 0.1,
          "fixed substep h; a frame of length dt runs ceil(dt/h) substeps of dt/n (<= h)"),
    Param("max_substeps", 8, "1", 1, 200,
          "IC_max: at most this many substeps per frame; past it the garment lags real time (reported)"),
    Param("limb_step_ratio", 0.25, "1", 0.0, 100.0,
          "substeps from the limbs' speed: enough per frame (at most max_limb_substeps) that no point of a body "
          "volume's surface moves more than this x the volume's radius in one substep; 0: only substep decides"),
    Param("max_limb_substeps", 24, "1", 1, 200,
          "at most this many substeps per frame from the limbs' speed (limb_step_ratio): compute, never lag, so "
          "apart from max_substeps, which caps the substeps of a long frame"),
    Param("frame_retries", 5, "1", 0, 8,
          "a frame that starts with the garment whole and ends with a limb bone through a triangle, a structural or "
          "shear spring past 1.5 x its rest length or their p99 past 1.05, one that ends more damaged than it "
          "started (with replay_frames), and any frame with a spring past the guard's 10 x, runs again from its "
          "start with twice the substeps, at most this many times (a frame then "
          "costs up to 2^(n+1) - 1 times one); the least damaged try is kept, one that ran away last; 0: off"),
    Param("replay_frames", 2, "1", 0, 8,
          "with it (> 0), a frame that ends more damaged than it started is retried too (frame_retries), and a frame "
          "its retries leave damaged, having started whole or ended worse, runs again from the start of the "
          "replay_frames frames before it, those and it at 4, 8, then 16 x their planned substeps, and the least "
          "damaged end is kept: a tear whose cause lies a frame or two back (cloth caught under a forearm) that no "
          "retry of its own frame mends; the frames already shown stay as they were; a replay costs up to "
          "28 (n + 1) frames; 0: off"),
    Param("retry_budget", 0.0, "s", 0.0, 10.0,
          "wall-clock bound on a frame's tries (frame_retries): no further try starts once the tries so far and the "
          "next (about twice the last) would pass it, the frame then reported (FrameReport.retries_cut); for a node "
          "that must not stall a second on an acrobatic clip, e.g. 0.1; 0: no bound (the offline commands' default: "
          "evaluate's figures are of that); the node's default is 0.05: unbounded, a frame's tries stalled a node on a "
          "2-core machine, each late frame longer and so retried more (5 marker arrays/s against 25 without retries, "
          "2026-12-03)", node_default=0.05),
    Param("correction_iterations", 4, "1", 0, 200,
          "Provot length-correction iterations per substep (contacts are handled after the first)"),
    Param("limit_ratio", 0.01, "1", 0.0, 1.0,
          "springs longer than (1 + limit_ratio) x rest length are shortened"),
    Param("strain_limit_iterations", 48, "1", 0, 200,
          "length-correction iterations after collision handling (the last projection of a substep), each "
          "followed by the in-contact points' collision handling; points in contact move by contact_mobility of "
          "their share, points it would leave deeper in a volume stay; 0: off"),
    Param("strain_limit_tolerance", 0.02, "1", 0.0, 1.0,
          "the strain limiting stops early once no spring is longer than (1 + limit_ratio + this) x rest length"),
    Param("tear_give_stretch", 1.49, "1", 0.0, 10.0,
          "a structural or shear spring still longer than this x rest length after the strain limiting (a pinch "
          "holding its ends on two volumes) is shortened into its ends' contact room: each end moves up to half "
          "collision_epsilon towards the other, never into a volume; just under issue 11's tearing bound, 1.5 "
          "(docs/real_motion.md: lower values measured worse); 0: off"),
    Param("strain_limit_slide", 0, "1", 0, 1,
          "opt-in (1): the strain limiting's contact handling puts a point the correction pulled into a volume out "
          "across the nearest surface, so that cloth pulled taut across a limb slides off it, in garments without "
          "limb tubes (skirts, the one-piece); 0: back out on the side it came from at the substep's start"),
    Param("band_gives_way", 1, "1", 0, 1,
          "1: a waistband's attached point (a garment carried by the pelvis) whose skinned position lies inside a "
          "forearm's volume goes out of it across its axis towards the trunk, collision_epsilon beyond the surface "
          "(a hand on the hip: the band under the forearm); 0: attached points stay where they are skinned (the "
          "export's skinning exactly; docs/real_motion.md: on by default since 2026-11-28, with open_cut_band)"),
    Param("contact_mobility", 0.5, "1", 0.0, 1.0,
          "share of the strain limiting's correction a point in contact takes (0: contacts hold, 1: as free points)"),
    Param("tethers", 1, "1", 0, 1,
          "long-range attachments (1: on, 0: off): each free point stays within (1 + tether_slack) x its rest "
          "distance along the cloth from the nearest attached point, after every correction iteration"),
    Param("tether_slack", 0.02, "1", 0.0, 1.0,
          "how much farther than its rest distance along the cloth a point may go from its tether anchor"),
    # material
    Param("areal_density", 0.15, "kg/m^2", 1e-4, 10.0,
          "cloth mass per area; a point's mass is a third of its triangles' area times this"),
    Param("point_mass", 0.0, "kg", 0.0, 1e3,
          "if > 0, every point has this mass instead (the memo's uniform mass)"),
    Param("stretch_stiffness", 2.0, "N/m", 0.0, 1e7, "structural (mesh edge) spring stiffness"),
    Param("shear_stiffness", 1.0, "N/m", 0.0, 1e7, "shear spring stiffness (across a quad's diagonal)"),
    Param("bend_stiffness", 0.2, "N/m", 0.0, 1e7, "bend spring stiffness (across two edges)"),
    Param("stretch_damping", 0.01, "N*s/m", 0.0, 1e5, "structural spring damping along the spring"),
    Param("shear_damping", 0.005, "N*s/m", 0.0, 1e5, "shear spring damping"),
    Param("bend_damping", 0.001, "N*s/m", 0.0, 1e5, "bend spring damping"),
    Param("stability_factor", 0.25, "1", 0.01, 1.0,
          "springs are limited to k <= factor * m / h^2 and c <= 2 * factor * m / h (explicit Euler "
          "stability); how many were limited is reported"),
    # external forces
    Param("gravity", (0.0, 0.0, -9.81), "m/s^2", -1e3, 1e3, "gravity, world frame"),
    Param("air_damping", 0.6, "1/s", 0.0, 1e3,
          "air resistance per unit mass: F = -m * air_damping * (v_world - wind) (memo: k_air / m)"),
    Param("wind", (0.0, 0.0, 0.0), "m/s", -1e3, 1e3, "constant wind velocity, world frame"),
    Param("gust_amplitude", 0.0, "m/s", 0.0, 1e3, "gust speed added along the wind direction (or +x)"),
    Param("gust_frequency", 0.5, "Hz", 0.0, 100.0, "gust frequency; gusts follow a sum of two sines"),
    # relative simulation (memo §4, plus rotation)
    Param("linear_inertia_scale", 1.0, "1", 0.0, 1.0,
          "how much of the root's linear acceleration/velocity the garment feels (1 physical, 0 carried rigidly)"),
    Param("angular_inertia_scale", 1.0, "1", 0.0, 1.0,
          "how much of the root's yaw rotation the garment feels (centrifugal, Coriolis, Euler forces)"),
    Param("teleport_distance", 1.0, "m", 0.0, 1e6,
          "a root jump longer than this within one frame carries the garment along rigidly (no inertia); "
          "the node dresses again once the next /tf sample confirms it (else the sample is an outlier)"),
    # skeleton input (body.glitches: clips on load, /tf in the node's pose buffer)
    Param("max_joint_speed", 3000.0, "deg/s", 0.0, 1e6,
          "a joint's local rotation turning faster than this (and by more than 30 deg) between two samples jumped: "
          "held until it comes back (a glitch, replaced) or stays away max_glitch_time (real, kept); 0 turns the "
          "joint glitch filter off"),
    Param("max_glitch_time", 0.1, "s", 0.0, 10.0,
          "a joint's jump that comes back within this is a glitch; one that stays longer is real motion (live, it "
          "is used that much later)"),
    # collision (memo §6)
    Param("friction", 0.2, "1", 0.0, 100.0, "k_f of the modified Coulomb law (memo Eq. 6-2)"),
    Param("contact_friction", 0.0, "1", 0.0, 1.0,
          "position-level friction (Macklin et al. 2014): a point pushed out of a volume has its slide along the "
          "surface over the substep undone up to this x the depth it was pushed out by (all of it below: "
          "static); works where the velocity-level friction above cannot reach (contacts handled during the "
          "length correction); 0: off"),
    Param("axial_friction", 0.0, "1", 0.0, 1.0,
          "opt-in: position-level friction along a limb's bone for its limb tube (a trouser leg on the thigh and "
          "the shin): as contact_friction, for a slide toward the limb's root only, so that a limb moving along "
          "itself carries its trouser leg and a stretched spring does not pull a ring it grips up the limb; a ring "
          "slides down freely; 0: off (docs/real_motion.md: it stops the climb, the first frames stretch more)"),
    Param("open_cut_band", 0.003, "m", 0.0, 0.1,
          "a point inside a trunk volume (an ellipsoid no bone continues through) within this of an open cut plane "
          "(the middle of its face in no other volume: the pelvis' bottom, between the thighs) leaves through the "
          "cut, not across the cross-section, when that would move it more than four collision_epsilon; off while "
          "dressing; 0: off (docs/real_motion.md: with band_gives_way, over three nudged starts of the full "
          "protocol 423 -> 431 of 648 runs pass, bone frames 316 -> 130)"),
    Param("contact_margin", 0.0, "m", 0.0, 0.05,
          "a volume stays in a point's contact cache while the point is within this of the volume's bounding "
          "sphere, so that the contact handling during the length correction keeps a point resting just outside "
          "out of it (a sphere's bounding sphere is its surface); 0: evicted once the broad phase rejects it"),
    Param("collision_epsilon", 0.003, "m", 0.0, 0.1, "points are put this far outside a volume's surface"),
    Param("contact_time_fraction", 0.5, "1", 0.0, 1.0,
          "c_time of memo Eq. 6-8: share of the step left after a hit that the point moves with the volume"),
    Param("dynamic_switch_ratio", 0.125, "1", 0.0, 100.0,
          "dynamic (swept) handling when the relative trajectory is longer than this x volume radius (memo: 1/8)"),
    Param("max_distance", 0.0, "m", 0.0, 10.0,
          "motion constraints (opt-in safety net): a free point stays within this distance of its skinned "
          "position (rigid on its nearest body volume, bound at dressing); 0: off"),
    Param("pinch_depth", 0.001, "m", 0.0, 0.1,
          "a triangle a bone passes through is moved off it unless that puts a point deeper than this into "
          "another volume (a pinch: a hand on the hip); contact wins there"),
    Param("pressed_pinch_depth", 0.01, "m", 0.0, 0.1,
          "the same, into a volume that may be pressed against the bone's (``contact_planes``: a forearm "
          "on the hip or the thigh) or that meets it at a joint (the forearm at the upper arm's elbow); the "
          "point handling after the bones' takes such a point out again"),
    Param("edge_pinch_depth", 0.01, "m", 0.0, 0.1,
          "an edge a limb cuts stays cut when moving it out would put an end deeper than this into another "
          "volume (a thigh against the belly, the trousers' crotch between the pelvis and the thighs): contact "
          "wins; 0: off, edges always move out"),
    Param("contact_planes", 1, "1", 0, 1,
          "1: body volumes disjoint in the canonical pose (or round bones that share no joint) that overlap in "
          "motion, or come closer than the cloth needs (a forearm on the hip), meet on a contact plane, the "
          "cloth between them on it (pressed flesh, ``collision.contact_planes``); 0: off"),
    Param("press_clearance", 0.015, "m", 0.0, 0.1,
          "a contact plane keeps at least this distance from either pressed volume's bone (room for the cloth)"),
    Param("press_gap", 0.015, "m", 0.0, 0.05,
          "the cloth's room between pressed volumes: two volumes closer than this get a contact plane, its two "
          "faces this far apart less the volumes' overlap, never nearer than two collision epsilons "
          "(``collision.contact_planes``)"),
    Param("collision_mode", "adaptive", "", None, None,
          "adaptive (memo §6.2.1), static only or dynamic only", COLLISION_MODES),
    # layers (garments worn over each other)
    Param("layer_thickness", 0.004, "m", 0.0, 0.05,
          "an outer garment's points are kept this far outside an inner garment's surface"),
)

PARAMETER_TABLE = {p.name: p for p in PARAMETERS}


@dataclass(frozen=True)
class SolverParams:
    substep: float
    max_substeps: int
    limb_step_ratio: float
    max_limb_substeps: int
    frame_retries: int
    replay_frames: int
    retry_budget: float
    correction_iterations: int
    limit_ratio: float
    strain_limit_iterations: int
    strain_limit_tolerance: float
    tear_give_stretch: float
    strain_limit_slide: int
    band_gives_way: int
    contact_mobility: float
    tethers: int
    tether_slack: float
    areal_density: float
    point_mass: float
    stretch_stiffness: float
    shear_stiffness: float
    bend_stiffness: float
    stretch_damping: float
    shear_damping: float
    bend_damping: float
    stability_factor: float
    gravity: tuple[float, float, float]
    air_damping: float
    wind: tuple[float, float, float]
    gust_amplitude: float
    gust_frequency: float
    linear_inertia_scale: float
    angular_inertia_scale: float
    teleport_distance: float
    max_joint_speed: float
    max_glitch_time: float
    friction: float
    contact_friction: float
    axial_friction: float
    open_cut_band: float
    contact_margin: float
    collision_epsilon: float
    contact_time_fraction: float
    dynamic_switch_ratio: float
    max_distance: float
    pinch_depth: float
    pressed_pinch_depth: float
    edge_pinch_depth: float
    contact_planes: int
    press_clearance: float
    press_gap: float
    collision_mode: str
    layer_thickness: float

    def __post_init__(self):
        for f in fields(self):
            object.__setattr__(self, f.name, PARAMETER_TABLE[f.name].check(getattr(self, f.name)))

    def replace(self, **changes: Any) -> "SolverParams":
        unknown = sorted(set(changes) - set(PARAMETER_TABLE))
        if unknown:
            raise ParameterError(f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(PARAMETER_TABLE)}")
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return SolverParams(**values)


DEFAULT_PARAMS = SolverParams(**{p.name: p.default for p in PARAMETERS})

PRESETS: dict[str, SolverParams] = {
    "si": DEFAULT_PARAMS,
    "memo": DEFAULT_PARAMS.replace(
        point_mass=20.0,
        gravity=(0.0, 0.0, -0.5),
        stretch_stiffness=10000.0,
        shear_stiffness=10000.0,
        bend_stiffness=10000.0,
        stretch_damping=100.0,
        shear_damping=100.0,
        bend_damping=100.0,
        air_damping=20.0 / 20.0,  # air resistance 20 on a mass of 20
        limit_ratio=0.01,
        friction=0.2,
        max_substeps=6,
        limb_step_ratio=0.0,  # the memo's fixed substeps
        correction_iterations=2,
        substep=0.04 / 6,
        strain_limit_iterations=0,  # beyond the memo: its experiments had neither
        tear_give_stretch=0.0,  # beyond the memo, part of the strain limiting
        frame_retries=0,
        replay_frames=0,  # beyond the memo, like the retries
        tethers=0,
        contact_planes=0,  # beyond the memo: its volumes are rigid
        band_gives_way=0,  # beyond the memo: its waistband is where it is skinned
        open_cut_band=0.0,  # beyond the memo: its volumes are closed
    ),
}


def preset(name: str) -> SolverParams:
    try:
        return PRESETS[name]
    except KeyError:
        raise ParameterError(f"unknown preset {name!r}; known: {', '.join(PRESETS)}") from None


PARAM_OPTION_HELP = ("repeatable; a vector's numbers comma-separated, gravity=0,0,-9.81; checked against the parameter "
                     "table's range")


def parse_params(texts: list[str], preset_name: str = "si") -> tuple[tuple[str, object], ...]:
    """``--param NAME=VALUE`` options as (name, value) pairs, each checked against ``params.PARAMETER_TABLE``
    (``ParameterError`` names the parameter and its range; a later option for the same name wins)."""
    changes = {}
    for text in texts:
        name, equals, value = text.partition("=")
        name = name.strip()
        if not equals or not name:
            raise ValueError(f"--param: expected NAME=VALUE, got {text!r}")
        if name not in PARAMETER_TABLE:
            raise ParameterError(f"--param: unknown parameter {name!r}; known: {', '.join(PARAMETER_TABLE)}")
        changes[name] = PARAMETER_TABLE[name].parse(value.strip())
    preset(preset_name).replace(**changes)  # the whole set checked as the runs will build it
    return tuple(changes.items())
