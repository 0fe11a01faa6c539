"""The node's own parameters, one table beside the solver's (ROS-free).

``NODE_PARAMETERS`` lists what ``garment_sim_node`` declares besides ``params.PARAMETERS``:
name, default, unit, range or choices, meaning, and whether it is read-only (fixed at start:
``--ros-args --params-file`` or ``-p``). ``ALL_PARAMETERS`` is both tables, in declaration order;
``check_value(name, value)`` validates one value against its row and returns it normalised (ints
to floats for real-valued parameters), raising ``ParameterError`` naming the value and what is
allowed. The README's parameter section and the node's descriptors are made from these tables.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from ..cloth.garments import GARMENT_NAMES, MAX_RESOLUTION
from ..cloth.spec import SpecError, resolve_garment
from ..params import PARAMETERS, Param, ParameterError, SolverParams

RERUN_SINKS = ("off", "save", "connect", "serve")


def check_garments(entries: Sequence[str], garment_path: str) -> None:
    """Refuse a ``garments`` entry that is neither a built-in, a valid spec file nor a spec's name in
    ``garment_path`` (folders separated by ':') or config/garments/: ``ParameterError`` with the reason."""
    for entry in entries:
        try:
            resolve_garment(entry, garment_folders(garment_path))
        except SpecError as err:
            raise ParameterError(f"garments: {err}") from None


def garment_folders(garment_path: str) -> list[str]:
    """The ``garment_path`` parameter's folders."""
    return [p for p in garment_path.split(":") if p]


@dataclass(frozen=True)
class NodeParam(Param):
    """A node parameter. Besides ``Param``'s types: bool, and string lists (``default`` a list;
    every entry one of ``choices``, at least one, no repeats)."""

    read_only: bool = False

    def check(self, value: Any) -> Any:
        if isinstance(self.default, bool):
            if not isinstance(value, bool):
                raise ParameterError(f"{self.name}: got {value!r} ({type(value).__name__}); allowed: true or false")
            return value
        if isinstance(self.default, list):
            if (not isinstance(value, (list, tuple)) or not value or not all(isinstance(v, str) for v in value)
                    or (self.choices and not set(value) <= set(self.choices)) or len(set(value)) != len(value)):
                raise ParameterError(f"{self.name}: got {value!r}; allowed: {self.allowed()}")
            return list(value)
        if isinstance(self.default, str) and not self.choices:
            if not isinstance(value, str):
                raise ParameterError(f"{self.name}: got {value!r} ({type(value).__name__}); allowed: a string")
            return value
        return super().check(value)

    def allowed(self) -> str:
        if isinstance(self.default, bool):
            return "true or false"
        if isinstance(self.default, list):
            return ("a non-empty list of distinct names, each one of " + ", ".join(self.choices) if self.choices
                    else "a non-empty list of distinct names")
        if isinstance(self.default, str) and not self.choices:
            return "a string"
        return super().allowed()


NODE_PARAMETERS: tuple[NodeParam, ...] = (
    # input
    NodeParam("fixed_frame", "world", "", None, None,
              "frame the skeleton is sampled in and the markers are published in", read_only=True),
    NodeParam("frame_prefix", "", "", None, None,
              "only /tf frames whose name starts with this belong to this character (e.g. alice/); "
              "empty: every frame", read_only=True),
    NodeParam("frame_prefixes", [""], "", None, None,
              "several characters in one node (a crowd): one frame prefix each (e.g. [alice/, bob/]; none the "
              "start of another), each dressed on its own, its markers under <marker_namespace>/<prefix>, its own "
              "/diagnostics status; root_frame and frame_prefix do not apply, Rerun records the first; [''] "
              "(default): the one character of frame_prefix", read_only=True),
    NodeParam("root_frame", "", "", None, None,
              "the skeleton's root frame (full name, with the prefix); empty: the child of fixed_frame "
              "within the prefix", read_only=True),
    NodeParam("joint_map_file", "", "", None, None,
              "YAML role -> frame name (names without frame_prefix); empty: recognised from the names",
              read_only=True),
    NodeParam("body_file", "", "", None, None,
              "YAML of per-volume overrides of the fitted body (radii, cut, offset_position; see "
              "config/body.yaml); empty: the body as fitted", read_only=True),
    NodeParam("max_skeleton_age", 0.5, "s", 0.01, 60.0,
              "the skeleton is stale when its newest transform is older than this at the frame time; "
              "stale frames are not simulated (the last good state stays) and are counted"),
    NodeParam("max_extrapolation", 0.1, "s", 0.0, 1.0,
              "past the newest transform the skeleton moves on at its last velocity for at most this long"),
    # loop
    NodeParam("rate_hz", 60.0, "Hz", 1.0, 1000.0,
              "frame timer rate; each frame samples the skeleton at T_next = D_last + now"),
    NodeParam("garments", ["pants"], "", None, None,
              "garments worn, each simulated and published on its own: built-ins ("
              + ", ".join(GARMENT_NAMES) + "), garment spec files (*.yaml) or spec names in garment_path; "
              "changing it, or saving a worn spec or its mesh, re-dresses the character"),
    NodeParam("garment_path", "", "", None, None,
              "folders (separated by ':') searched for NAME.yaml garment specs before config/garments/; "
              "changing it re-dresses the character"),
    NodeParam("resolution", 1.0, "1", 0.25, MAX_RESOLUTION,
              "garment vertex density (1 = about the memo's sizes); changing it re-dresses the character"),
    # outputs
    NodeParam("marker_namespace", "garment", "", None, None,
              "marker namespace: garments on <ns>/<garment>, body volumes on <ns>/volumes"),
    NodeParam("publish_volumes", True, "", None, None, "also publish the body volumes as SPHERE markers"),
    NodeParam("diagnostics_period", 1.0, "s", 0.1, 60.0, "period of the /diagnostics status"),
    NodeParam("quality_rate_hz", 10.0, "Hz", 1.0, 1000.0,
              "how often the garments' quality meters run (penetration depth, limb bones through the cloth, "
              "trouser legs off, stretch p99; the largest cost of a character's frame outside the solver): on "
              "the first frame at least 1/rate of body time after the last measured one, on the frame after "
              "dressing and on a frame the solver's guard fired in; rate_hz or more: every frame. The "
              "diagnostics and Rerun say the rate and count the measured frames; garment-sim evaluate and "
              "replay measure every frame"),
    NodeParam("rerun_sink", "off", "", None, None,
              "Rerun logging: off, save (to rerun_path), connect (to the viewer at rerun_url) or serve "
              "(gRPC on every interface)", RERUN_SINKS, read_only=True),
    NodeParam("rerun_path", "out/garment_sim.rrd", "", None, None,
              "the .rrd file written when rerun_sink is save", read_only=True),
    NodeParam("rerun_url", "", "", None, None,
              "viewer address when rerun_sink is connect; empty: rerun+http://127.0.0.1:9876/proxy", read_only=True),
    NodeParam("rerun_every_n", 1, "frames", 1, 1000,
              "log the garments, volumes and skeleton to Rerun every n-th frame only (scalars and events every "
              "frame): the recording shrinks about n times"),
    # configuration file
    NodeParam("watch_params_file", False, "", None, None,
              "re-apply params_file whenever it changes (the node's section, validated; a bad file is "
              "refused whole and logged)"),
    NodeParam("params_file", "", "", None, None,
              "the parameter YAML to watch; empty: the last --params-file given at start"),
    NodeParam("watch_period", 1.0, "s", 0.05, 60.0,
              "how often params_file (when watched) and the worn garments' spec and mesh files are checked for "
              "changes"),
)

ALL_PARAMETERS: tuple[Param, ...] = PARAMETERS + NODE_PARAMETERS
PARAMETER_ROWS: dict[str, Param] = {p.name: p for p in ALL_PARAMETERS}
SOLVER_PARAMETER_NAMES = frozenset(p.name for p in PARAMETERS)


def solver_params(values: Mapping[str, Any]) -> SolverParams:
    """The solver's parameters among ``values`` (parameter name -> checked value, every solver row)."""
    return SolverParams(**{name: values[name] for name in SOLVER_PARAMETER_NAMES})


def refused_changes(changes: Mapping[str, Any], values: Mapping[str, Any]) -> dict[str, str]:
    """Why each refused one of ``changes`` (name -> value checked against its row) cannot apply to a node
    running with ``values``: read-only, a garment that does not resolve, a solver combination refused."""
    refused = {name: f"{name}: read-only, set at start (--params-file or -p); running with {values[name]!r}, got "
                     f"{value!r}" for name, value in changes.items() if is_read_only(name)}
    changes = {name: value for name, value in changes.items() if name not in refused}
    garment_keys = {"garments", "garment_path"} & changes.keys()
    if garment_keys:
        try:  # every garment named must resolve to a built-in or a valid spec
            check_garments(changes.get("garments", values["garments"]),
                           changes.get("garment_path", values["garment_path"]))
        except ParameterError as err:
            refused.update({name: str(err) for name in garment_keys})
    solver_changes = SOLVER_PARAMETER_NAMES & changes.keys()
    if solver_changes:
        try:
            solver_params({**values, **changes})  # the combination must be valid too
        except ParameterError as err:
            refused.update({name: str(err) for name in solver_changes})
    return refused


def is_read_only(name: str) -> bool:
    return bool(getattr(PARAMETER_ROWS[name], "read_only", False))


def check_value(name: str, value: Any) -> Any:
    """``value`` normalised for parameter ``name``, or ``ParameterError`` naming what is allowed."""
    row = PARAMETER_ROWS.get(name)
    if row is None:
        raise ParameterError(f"unknown parameter {name!r}; known: {', '.join(PARAMETER_ROWS)}")
    return row.check(value)


def default_values() -> dict[str, Any]:
    return {p.name: (list(p.default) if isinstance(p.default, list) else p.default) for p in ALL_PARAMETERS}
