"""``garment_sim_node``: the ROS 2 adapter around the character loop.

Wires topics, parameters and timers to the ROS-free modules:

- ``/tf`` and ``/tf_static`` (``tf2_msgs/TFMessage``; static: transient local) into a ``PoseBuffer``;
  only frames starting with ``frame_prefix`` are this character's. /tf is taken raw and drained at
  the start of every frame, decoded by ``tf_input.TFDecoder`` (numpy), so 100+ joints at 120 Hz and
  more cost a small share of a core and the frame always samples the newest data (issue 17).
- a timer at ``rate_hz``: ``T_next = D_last + now`` (the node's clock, so ``use_sim_time`` works;
  ``D_last`` the last tick's compute time) -> ``CharacterLoop.frame(T_next)`` -> the garments (and
  body volumes) on ``~/markers`` as a serialized ``visualization_msgs/MarkerArray`` stamped
  ``T_next`` in ``fixed_frame``, and to Rerun when ``rerun_sink`` is not off.
- ``/diagnostics`` (``diagnostic_msgs/DiagnosticArray``) every ``diagnostics_period``: fps, substeps,
  lag, stage times, penetration, the garments' quality (``bones_through``, ``bones_through_frames``,
  ``legs_off``, structural and shear stretch p99 and max: ``ros.frame_stats``), skeleton age,
  counts of refused input (``rejected_*``, ``input_*``),
  of skipped frames and re-dresses (``loop_*``) and of garment steps the solver's guard restored or
  re-fitted (``solver_restored``, ``solver_refitted``); OK running, WARN waiting, holding or lagging,
  ERROR for a skeleton that cannot be mapped or a frame that failed since the last status.
- parameters: every row of ``params.PARAMETERS`` and ``ros.settings.NODE_PARAMETERS``, declared
  with descriptors. A change (parameter services, ``set_parameters``, the watched params file) is
  validated against the tables first: a bad value is refused with the table's reason and the old
  value stays; a good one takes effect at the next frame.
"""

from __future__ import annotations

import array
import sys
import time
import traceback
from collections import Counter
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from ..body.pose_buffer import PoseBuffer
from ..markers import frame_markers
from ..params import Param, ParameterError, SolverParams
from ..quality import report_scalars
from ..rerun_log import RerunLogger, frame_payload
from .character_loop import CharacterLoop, FrameResult, Status, Throttle
from .frame_stats import FrameStats
from .marker_cdr import DELETEALL, MarkerData, serialize_marker_array
from .params_file import FileWatch, ParamsFileError, read_node_parameters
from .settings import (ALL_PARAMETERS, PARAMETER_ROWS, SOLVER_PARAMETER_NAMES, check_garments, garment_folders,
                       is_read_only)
from .tf_input import IngestResult, TFDecoder, TransformBatch, ingest, ingest_batch, seconds_to_stamp

NODE_NAME = "garment_sim_node"
LAG_WARNING_FRACTION = 0.1  # diagnostics turn WARN when the garments fall behind by this share of the time
# /tf: reliable and volatile as tf2's listeners, so every publisher that works with tf2 matches. Keep
# last 1000 messages: the node drains the whole queue every frame (``_absorb_tf``), so the depth is
# only the slack for a long frame (dressing takes up to a second): 4 characters at 240 Hz fill 1000 in
# ~1 s; older samples are of no use (``PoseBuffer.max_duration_s``). Memory: 16 kB per 142-joint message.
_TF_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
_TF_STATIC_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
_REDRESS_KEYS = ("garments", "resolution", "garment_path")
_CLEAR_KEYS = ("garments", "resolution", "garment_path", "marker_namespace", "publish_volumes")


def _parameter_type(row: Param) -> Parameter.Type:
    default = row.default
    if isinstance(default, bool):
        return Parameter.Type.BOOL
    if isinstance(default, list):
        return Parameter.Type.STRING_ARRAY
    if isinstance(default, tuple):
        return Parameter.Type.DOUBLE_ARRAY
    if isinstance(default, int):
        return Parameter.Type.INTEGER
    if isinstance(default, float):
        return Parameter.Type.DOUBLE
    return Parameter.Type.STRING


def _ros_value(value: Any) -> Any:
    """A validated value as rclpy stores it (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value


def _plain(value: Any) -> Any:
    """A parameter value as Python scalars and lists (rclpy gives arrays as ``array.array``)."""
    if isinstance(value, (array.array, np.ndarray)):
        return value.tolist()
    return value


def descriptor(row: Param) -> ParameterDescriptor:
    """The ``ParameterDescriptor`` of a table row: description with unit and allowed values, range, read-only."""
    unit = f" [{row.unit}]" if row.unit and row.unit != "1" else ""
    result = ParameterDescriptor(
        name=row.name, type=_parameter_type(row).value, description=f"{row.description}{unit}",
        additional_constraints=f"allowed: {row.allowed()}", read_only=bool(getattr(row, "read_only", False)))
    kind = _parameter_type(row)
    if row.low is not None and row.high is not None:
        if kind == Parameter.Type.DOUBLE:
            result.floating_point_range = [FloatingPointRange(from_value=float(row.low), to_value=float(row.high),
                                                              step=0.0)]
        elif kind == Parameter.Type.INTEGER:
            result.integer_range = [IntegerRange(from_value=int(row.low), to_value=int(row.high), step=1)]
    return result


def params_file_from_args(args: Sequence[str]) -> str:
    """The last ``--params-file PATH`` among ROS arguments, or ''."""
    args = list(args)
    paths = [args[i + 1] for i, arg in enumerate(args[:-1]) if arg == "--params-file"]
    return paths[-1] if paths else ""


class GarmentSimNode(Node):
    """Dresses the character of ``frame_prefix`` on /tf; see the module docstring."""

    def __init__(self, node_name: str = NODE_NAME, *, params_file_hint: str = "", **kwargs):
        super().__init__(node_name, **kwargs)
        self._throttle = Throttle()
        self._params_file_hint = params_file_hint
        self.values: dict[str, Any] = self._declare_parameters()
        self.solver_params = SolverParams(**{name: self.values[name] for name in SOLVER_PARAMETER_NAMES})
        v = self.values
        self.buffer = PoseBuffer(v["fixed_frame"], max_age_s=v["max_skeleton_age"],
                                 max_extrapolation_s=v["max_extrapolation"])
        self.loop = CharacterLoop(self.buffer, self.solver_params, v["garments"], v["resolution"],
                                  frame_prefix=v["frame_prefix"], root_frame=v["root_frame"],
                                  joint_map_file=v["joint_map_file"], body_file=v["body_file"],
                                  logger=self.get_logger(), garment_path=garment_folders(v["garment_path"]))
        self.stats = FrameStats()
        self.input_counts: Counter[str] = Counter()  # transforms stored / of other characters / refused
        self.frame_errors = 0
        self._frame_errors_reported = 0
        self.last_diagnostics: dict[str, str] = {}
        self.params_file_errors = 0
        self.params_file_message = ""
        self._pending: dict[str, Any] = {}
        self._clear_markers = False
        self._last_compute_s = 0.0
        self._watch: FileWatch | None = None

        # raw: the bytes are decoded by ``TFDecoder`` (numpy), never into Python message objects
        self._tf_decoder = TFDecoder(v["frame_prefix"])
        self._tf_pending: list[bytes] = []
        # the /tf input at the newest frame, for the Rerun recording: messages absorbed, newest lag (ms)
        self._frame_input: dict[str, float] = {"backlog": 0.0}
        self._warned_tf_full = False
        self._tf_subscription = self.create_subscription(TFMessage, "/tf", self._on_tf, _TF_QOS, raw=True)
        self.create_subscription(TFMessage, "/tf_static", self._on_tf_static, _TF_STATIC_QOS)
        self.marker_publisher = self.create_publisher(MarkerArray, "~/markers", 2)
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.frame_timer = self.create_timer(1.0 / v["rate_hz"], self._on_frame_timer)  # the node's clock
        # Steady: diagnostics and the file watch go on when sim time stalls or has not started.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.diagnostics_timer = self.create_timer(v["diagnostics_period"], self.publish_diagnostics, clock=steady)
        self.watch_timer = self.create_timer(v["watch_period"], self.poll_params_file, clock=steady)
        self.rerun = self._create_rerun_logger()

    # ------------------------------------------------------------------------------ parameters
    def _declare_parameters(self) -> dict[str, Any]:
        """Declare every table row; start-up values (--params-file, -p) are validated like runtime ones."""
        overrides = getattr(self, "_parameter_overrides", {})
        values = {}
        for row in ALL_PARAMETERS:
            value = row.default
            if row.name in overrides:
                given = _plain(overrides[row.name].value)
                try:
                    value = row.check(given)
                except ParameterError as err:
                    self.get_logger().error(f"start-up parameter refused: {err}; using the default {row.default!r}")
            self.declare_parameter(row.name, _ros_value(value), descriptor(row), ignore_override=True)
            values[row.name] = value
        unknown = sorted(set(overrides) - set(PARAMETER_ROWS) - {"use_sim_time"})
        if unknown:
            self.get_logger().warning(f"unknown start-up parameter(s) {', '.join(unknown)} ignored; known: "
                                      f"{', '.join(PARAMETER_ROWS)}")
        return values

    def _validate(self, parameters: Sequence[Parameter]) -> tuple[list[Parameter], dict[str, Any]]:
        """Parameters typed as declared, and the table values they set; ``ParameterError`` for a bad one."""
        checked, changes = [], {}
        for parameter in parameters:
            name = parameter.name
            if name not in PARAMETER_ROWS:
                checked.append(parameter)  # use_sim_time, or undeclared: rclpy's own rules apply
                continue
            if parameter.type_ == Parameter.Type.NOT_SET:
                raise ParameterError(f"{name}: cannot be unset; allowed: {PARAMETER_ROWS[name].allowed()}")
            value = PARAMETER_ROWS[name].check(_plain(parameter.value))
            if is_read_only(name):
                raise ParameterError(f"{name}: read-only, set at start (--params-file or -p); running with "
                                     f"{self.values[name]!r}, got {value!r}")
            checked.append(Parameter(name, _parameter_type(PARAMETER_ROWS[name]), _ros_value(value)))
            changes[name] = value
        if {"garments", "garment_path"} & changes.keys():
            check_garments(changes.get("garments", self.values["garments"]),
                           changes.get("garment_path", self.values["garment_path"]))
        solver_changes = {k: v for k, v in changes.items() if k in SOLVER_PARAMETER_NAMES}
        if solver_changes:
            self.solver_params.replace(**solver_changes)
        return checked, changes

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        """rclpy's, after validating against the parameter tables (the parameter services call this)."""
        try:
            checked, changes = self._validate(parameter_list)
        except ParameterError as err:
            return SetParametersResult(successful=False, reason=str(err))
        result = super().set_parameters_atomically(checked)
        if result.successful:
            self._accept(changes)
        return result

    def set_parameters(self, parameter_list: list[Parameter]) -> list[SetParametersResult]:
        return [self.set_parameters_atomically([parameter]) for parameter in parameter_list]

    def _accept(self, changes: dict[str, Any]) -> None:
        self.values.update(changes)
        self._pending.update(changes)
        if "rate_hz" in changes:
            self.frame_timer.timer_period_ns = int(1e9 / changes["rate_hz"])
        if "diagnostics_period" in changes:
            self.diagnostics_timer.timer_period_ns = int(1e9 * changes["diagnostics_period"])
        if "watch_period" in changes:
            self.watch_timer.timer_period_ns = int(1e9 * changes["watch_period"])

    def _apply_pending(self) -> None:
        """Parameter changes take effect here, at the start of a frame."""
        changes, self._pending = self._pending, {}
        if not changes:
            return
        if SOLVER_PARAMETER_NAMES & changes.keys():
            self.solver_params = SolverParams(**{name: self.values[name] for name in SOLVER_PARAMETER_NAMES})
            self.loop.set_params(self.solver_params)
        if any(key in changes for key in _REDRESS_KEYS):
            self.loop.set_garments(self.values["garments"], self.values["resolution"],
                                   garment_folders(self.values["garment_path"]))
        if any(key in changes for key in _CLEAR_KEYS):
            self._clear_markers = True
        self.buffer.max_age_s = self.values["max_skeleton_age"]
        self.buffer.max_extrapolation_s = self.values["max_extrapolation"]

    # ------------------------------------------------------------------------------ params file
    def params_file_path(self) -> str:
        return self.values["params_file"] or self._params_file_hint

    def poll_params_file(self) -> None:
        """Timer: re-apply the params file when its modification time or size changed."""
        path = self.params_file_path()
        if not self.values["watch_params_file"] or not path:
            if self.values["watch_params_file"]:
                self._log("warning", "params_file", "watch_params_file is on but params_file is empty and no "
                                                    "--params-file was given: nothing to watch")
            self._watch = None
            return
        if self._watch is None or self._watch.path != Path(path):
            self._watch = FileWatch(path)
            if path == self._params_file_hint:
                self._watch.changed()  # loaded at start by --params-file (under any -p): apply later edits only
        if self._watch.changed():
            self.apply_params_file(path)

    def apply_params_file(self, path: str) -> bool:
        """Apply the node's section of ``path``: all of it, or (any bad key or value) none of it."""
        try:
            given = read_node_parameters(path, self.get_fully_qualified_name())
        except ParamsFileError as err:
            return self._refuse_params_file([str(err)])
        if not given:
            self._log("warning", "params_file_section", f"{path}: no ros__parameters section matches this node "
                      f"({self.get_fully_qualified_name()}); name it so, or /**/{self.get_name()} for every namespace")
        problems, changes = [], []
        for name, raw in given.items():
            raw = _plain(raw)
            if name not in PARAMETER_ROWS:
                if self.has_parameter(name):
                    if self.get_parameter(name).value != raw:
                        changes.append(Parameter(name, value=raw))
                else:
                    problems.append(f"{path}: {name}: unknown parameter; known: {', '.join(PARAMETER_ROWS)}")
                continue
            try:
                value = PARAMETER_ROWS[name].check(raw)
            except ParameterError as err:
                problems.append(f"{path}: {err}")
                continue
            if value == self.values[name]:
                continue
            if is_read_only(name):
                problems.append(f"{path}: {name}: read-only, set at start; running with {self.values[name]!r}, "
                                f"the file says {value!r} (restart the node to change it)")
            else:
                changes.append(Parameter(name, value=_ros_value(value)))
        if problems:
            return self._refuse_params_file(problems)
        if changes:
            result = self.set_parameters_atomically(changes)
            if not result.successful:
                return self._refuse_params_file([f"{path}: {result.reason}"])
        self.params_file_message = f"{path}: applied " + (
            ", ".join(f"{p.name}={_plain(p.value)!r}" for p in changes) if changes else "(no change)")
        self.get_logger().info(self.params_file_message)
        return True

    def _refuse_params_file(self, problems: list[str]) -> bool:
        self.params_file_errors += 1
        self.params_file_message = "; ".join(problems) + "; keeping the last good configuration"
        self.get_logger().error(self.params_file_message)
        return False

    # ------------------------------------------------------------------------------ input
    def _on_tf(self, message: bytes | TFMessage) -> None:
        """/tf, serialized (a ``TFMessage`` is serialized first: tests feed objects). Kept until the
        next frame absorbs it: one batch per frame costs about what one message costs; a full
        backlog (no frames: sim time not started) is absorbed here."""
        self._tf_pending.append(message if isinstance(message, bytes) else serialize_message(message))
        if len(self._tf_pending) >= _TF_QOS.depth:
            self._absorb_tf()

    def _absorb_tf(self) -> None:
        """Everything waiting on /tf (kept by ``_on_tf`` and still in the subscription's queue) into
        the pose buffer at once, at the start of every frame.

        rclpy's executor takes one message per subscription per wait, so behind a frame timer that is
        always ready the queue only grew and the node read its oldest message, 0.84 s old at 120 Hz
        (issue 17). Draining the queue here keeps the node on the newest data whatever the executor
        does."""
        messages, self._tf_pending = self._tf_pending, []
        kept = len(messages)
        handle = self._tf_subscription.handle
        with handle:
            while True:
                taken = handle.take_message(TFMessage, True)
                if taken is None:
                    break
                messages.append(taken[0])
        if not messages:
            return
        self.stats.record_drain(len(messages))
        self._frame_input["backlog"] = float(len(messages))
        if len(messages) - kept >= _TF_QOS.depth and not self._warned_tf_full:
            self._warned_tf_full = True  # once: the diagnostics go on counting (input_backlog, input_hz)
            self.get_logger().warning(
                f"/tf arrives faster than this node absorbs it: its queue was full at a frame (it keeps "
                f"{_TF_QOS.depth} messages, older ones were dropped); it sustains about "
                f"{self.stats.input_rate():.0f} messages/s. Poses stay the newest; see input_lag_* in diagnostics")
        now_ns = self.get_clock().now().nanoseconds  # 0: use_sim_time before the first /clock
        now_s = now_ns * 1e-9 if now_ns else None
        batches = []
        for data in messages:
            try:
                batch = self._tf_decoder.decode(data)
            except ValueError as err:
                self.input_counts["undecodable"] += 1
                self._log("warning", "tf_undecodable", f"a /tf message could not be decoded (counted): {err}")
                continue
            if len(batch.stamps) and now_s is not None:
                lag_s = now_s - float(batch.stamps.max())  # receive time - stamp
                self.stats.record_input(lag_s)
                self._frame_input["lag_ms"] = 1e3 * lag_s
            if not (len(batch.stamps) or batch.other_character):
                self.input_counts["empty_messages"] += 1  # nothing to do; counted so a silent publisher shows
            batches.append(batch)
        if batches:
            self._count_input(ingest_batch(self.buffer, TransformBatch.concatenate(batches), now_s=now_s),
                              count_empty=False)

    def _on_tf_static(self, message: TFMessage) -> None:
        self._count_input(ingest(self.buffer, message, self.values["frame_prefix"], static=True))

    def _count_input(self, result: IngestResult, count_empty: bool = True) -> None:
        self.input_counts["stored"] += result.stored
        self.input_counts["other_character"] += result.other_character
        self.input_counts["refused"] += result.refused
        if count_empty and not (result.stored or result.other_character or result.refused):
            self.input_counts["empty_messages"] += 1  # nothing to do; counted so a silent publisher shows
        if result.refused:
            self._log("warning", "tf_refused",
                      f"refused /tf input (counted in diagnostics), e.g. {result.first_refusal}")

    # ------------------------------------------------------------------------------ the frame
    def _on_frame_timer(self) -> None:
        tic = time.perf_counter()
        dressed = False
        try:
            self._absorb_tf()  # the newest /tf first, however the executor scheduled the callbacks
            self._apply_pending()
            frame_time = self._last_compute_s + self.get_clock().now().nanoseconds * 1e-9  # T_next
            result = self.loop.frame(frame_time)
            if result is not None:
                self._publish_frame(result)
                dressed = result.dressed
        except Exception:  # a frame must never take the node down: report it and go on
            self.frame_errors += 1
            self._log("error", "frame_error", f"frame failed (counted in diagnostics):\n{traceback.format_exc()}")
        compute_s = time.perf_counter() - tic
        self.stats.record_tick(compute_s)
        # D_last: dressing is no frame's compute time, T_next of the next frame must not jump by it
        self._last_compute_s = 0.0 if dressed else compute_s

    def _publish_frame(self, result: FrameResult) -> None:
        tic = time.perf_counter()
        payload = frame_payload(self.loop.character, result.pose)
        v = self.values
        stamp = seconds_to_stamp(result.pose_time_s)  # the pose's time, never newer (issue 17)
        markers = frame_markers(payload, v["marker_namespace"], v["fixed_frame"], stamp, v["publish_volumes"])
        if self._clear_markers or result.dressed:  # garments or namespaces changed: drop the old markers
            markers.insert(0, MarkerData(ns="", id=0, type=0, action=DELETEALL, frame_id=v["fixed_frame"],
                                         stamp=stamp))
            self._clear_markers = False
        self.marker_publisher.publish(serialize_marker_array(markers))
        publish_s = time.perf_counter() - tic
        self.stats.record_frame(result.reports, result.frame_s, result.penetration_m)
        recovered = [(solver.model.name, report.recovery)
                     for solver, report in zip(self.loop.character.solvers, result.reports) if report.recovery]
        if recovered:
            self._log("warning", "solver_recovery", "a garment step went bad (counted in diagnostics as solver_*): "
                      + ", ".join(f"{name} {what}" for name, what in recovered))
        self.stats.record_publish(publish_s)
        if self.rerun is not None:
            self._log_rerun(result, payload, publish_s)

    def _log_rerun(self, result: FrameResult, payload: dict, publish_s: float) -> None:
        reports = result.reports
        timings_ms = {"integration": sum(r.integration_s for r in reports),
                      "correction": sum(r.correction_s for r in reports),
                      "collision": sum(r.collision_s for r in reports), "publish": publish_s}
        quality = {solver.model.name: report_scalars(report)
                   for solver, report in zip(self.loop.character.solvers, reports)}
        try:
            self.rerun.log_frame(result.time_s, timings_ms={k: 1e3 * s for k, s in timings_ms.items()},
                                 quality=quality, inputs=self._frame_input, **payload)
        except Exception as err:  # the viewer went away, the disk is full...: markers go on
            self.get_logger().error(f"Rerun logging failed, switched off: {err}")
            self.rerun = None

    def _create_rerun_logger(self) -> RerunLogger | None:
        v = self.values
        if v["rerun_sink"] == "off":
            return None
        try:
            return RerunLogger(sink=v["rerun_sink"], path=v["rerun_path"], url=v["rerun_url"] or None,
                               recording_name=self.get_fully_qualified_name())
        except Exception as err:
            self.get_logger().error(f"rerun_sink {v['rerun_sink']!r} failed, Rerun logging is off: {err}")
            return None

    # ------------------------------------------------------------------------------ diagnostics
    def publish_diagnostics(self) -> None:
        figures = self.stats.window()
        now = self.get_clock().now()
        if now.nanoseconds == 0 and self.get_clock().ros_time_is_active:
            self.loop.clock_not_started()  # use_sim_time and no /clock yet: the frame timer does not fire
        loop = self.loop
        lagging = figures["lag_fraction"] > LAG_WARNING_FRACTION
        level, message = DiagnosticStatus.OK, loop.status
        failed = self.frame_errors > self._frame_errors_reported  # a frame failed since the last status
        self._frame_errors_reported = self.frame_errors
        if loop.status == Status.UNMAPPABLE or failed:
            level = DiagnosticStatus.ERROR
        elif loop.status != Status.RUNNING or lagging:
            level = DiagnosticStatus.WARN
        if loop.detail:
            message = f"{loop.status}: {loop.detail}"
        elif lagging:
            message = (f"{loop.status}; too slow: the garments simulated only {1 - figures['lag_fraction']:.0%} of "
                       f"the body's time (max_substeps), {figures['lag_s']:.3f} s behind in total")
        values = {key: f"{value:.6g}" for key, value in figures.items()}
        values.update({
            "status": loop.status,
            "garments": " ".join(loop.garments),
            "mass_points": str(loop.mass_points),
            "skeleton_age_s": f"{loop.skeleton_age(now.nanoseconds * 1e-9):.6g}",
            "total_frames": str(self.stats.total_frames),
            "frame_errors": str(self.frame_errors),
            "params_file_errors": str(self.params_file_errors),
        })
        values.update({f"input_{key}": str(count) for key, count in sorted(self.input_counts.items())})
        values.update({f"rejected_{key}": str(count) for key, count in sorted(self.buffer.rejected.items())})
        values.update({f"adjusted_{key}": str(count) for key, count in sorted(self.buffer.adjusted.items())})
        values.update({f"loop_{key}": str(count) for key, count in sorted(loop.counts.items())})
        values.update({f"solver_{key}": str(count) for key, count in sorted(self.stats.recoveries.items())})
        self.last_diagnostics = values
        status = DiagnosticStatus(level=level, name=f"garment_sim: {self.get_fully_qualified_name()}",
                                  message=message,
                                  hardware_id=self.values["frame_prefix"] or self.values["fixed_frame"],
                                  values=[KeyValue(key=k, value=v) for k, v in values.items()])
        self.diagnostics_publisher.publish(DiagnosticArray(header=Header(stamp=now.to_msg()), status=[status]))

    def _log(self, level: str, key: str, message: str) -> None:
        if not self._throttle.ready(key):
            return
        # one call per severity: rclpy's logger refuses two severities from one line of code
        if level == "error":
            self.get_logger().error(message)
        else:
            self.get_logger().warning(message)

    def destroy_node(self) -> None:
        if self.rerun is not None:
            self.rerun.close()
            self.rerun = None
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console entry point ``garment_sim_node``, e.g.
    ``garment_sim_node --ros-args --params-file config/garment_sim.yaml -r __ns:=/alice -p frame_prefix:=alice/``."""
    rclpy.init(args=args)
    node = GarmentSimNode(params_file_hint=params_file_from_args(sys.argv if args is None else args))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
