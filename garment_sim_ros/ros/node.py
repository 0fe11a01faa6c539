"""``garment_sim_node``: the ROS 2 adapter around the character loop.

Wires topics, parameters and timers to the ROS-free modules:

- ``/tf`` and ``/tf_static`` (``tf2_msgs/TFMessage``; static: transient local) into a ``PoseBuffer``;
  only frames starting with ``frame_prefix`` are this character's. With ``frame_prefixes`` one node
  dresses several characters, each its own buffer and loop (``runtime.crowd``): each transform goes to
  its character in one pass, one MarkerArray per frame holds them all, each character in its own
  namespace, and /diagnostics has a status per character. /tf is taken raw and drained at
  the start of every frame, decoded by ``tf_input.TFDecoder`` (numpy), so 100+ joints at 120 Hz and
  more cost a small share of a core and the frame always samples the newest data (issue 17).
- a timer at ``rate_hz``: ``T_next = D_last + now`` (the node's clock, so ``use_sim_time`` works;
  ``D_last`` the last tick's compute time) -> ``CharacterLoop.frame(T_next, now)`` -> the garments (and
  body volumes) on ``~/markers`` as a serialized ``visualization_msgs/MarkerArray`` in ``fixed_frame``
  stamped with the time of the pose they were simulated on (``FrameResult.time_s``), and to Rerun when
  ``rerun_sink`` is not off (with the loop's events, guard recoveries and parameter changes as text
  entries). A tick that simulates nothing (holding, folded, no newer pose) publishes the last frame's
  markers again: with the topic's transient-local QoS, a late RViz sees the garment.
- ``/diagnostics`` (``diagnostic_msgs/DiagnosticArray``) every ``diagnostics_period``: fps, substeps,
  lag, stage times, penetration, the garments' quality (``bones_through``, ``bones_through_frames``,
  ``legs_off``, structural and shear stretch p99 and max: ``runtime.frame_stats``), skeleton age,
  counts of refused input (``rejected_*``, ``input_*``),
  of skipped frames and re-dresses (``loop_*``) and of garment steps the solver's guard restored or
  re-fitted (``solver_restored``, ``solver_refitted``); OK running, WARN waiting, holding or lagging,
  ERROR for a skeleton that cannot be mapped or a frame that failed since the last status.
- parameters: every row of ``params.PARAMETERS`` and ``runtime.settings.NODE_PARAMETERS``, declared
  with descriptors (``node_parameters``). A change (parameter services, ``set_parameters``, the
  watched params file) is validated against the tables first: a bad value is refused with the
  table's reason and the old value stays; a good one takes effect at the next frame.
- a steady timer every ``watch_period``: the params file when watched (``params_watch``) and the worn
  garments' spec and mesh files (a save re-dresses; the frame itself touches no file).
"""

from __future__ import annotations

import sys
import time
import traceback
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from ..params import ParameterError, SolverParams
from ..rerun_log import RerunLogger
from ..runtime.character_loop import FrameResult
from ..runtime.crowd import Member, character_namespace, character_prefixes, crowd_markers, make_members, route_tf
from ..runtime.events import EventLog
from ..runtime.marker_cdr import serialize_marker_array
from ..runtime.settings import SOLVER_PARAMETER_NAMES, garment_folders, solver_params
from ..runtime.tf_input import TFDecoder, ingest
from .diagnostics import crowd_statuses
from .node_parameters import NodeParameters
from .params_watch import ParamsFileWatch
from .ros_parameters import params_file_from_args, plain
from .spinning import spin_until_shutdown

NODE_NAME = "garment_sim_node"
# /tf: reliable and volatile as tf2's listeners, so every publisher that works with tf2 matches. Keep
# last 1000 messages: the node drains the whole queue every frame (``_absorb_tf``), so the depth is
# only the slack for a long frame (dressing takes up to a second): 4 characters at 240 Hz fill 1000 in
# ~1 s; older samples are of no use (``PoseBuffer.max_duration_s``). Memory: 16 kB per 142-joint message.
_TF_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
_TF_STATIC_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
# ~/markers: transient local, keep last 1: a late RViz gets the garment at once (volatile subscribers,
# RViz's default, still match); the node publishes at rate_hz while holding too, the held garment.
_MARKERS_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
_REDRESS_KEYS = ("garments", "resolution", "garment_path")
_CLEAR_KEYS = ("garments", "resolution", "garment_path", "marker_namespace", "publish_volumes")


class GarmentSimNode(Node):
    """Dresses the character of ``frame_prefix`` (or those of ``frame_prefixes``) on /tf; see the module docstring."""

    def __init__(self, node_name: str = NODE_NAME, *, params_file_hint: str = "", **kwargs):
        super().__init__(node_name, **kwargs)
        self._events = EventLog(self.get_logger())
        self.parameter_checks = NodeParameters(self, kwargs.get("parameter_overrides") or (),
                                               self._on_parameters_accepted)
        self.values: dict[str, Any] = self.parameter_checks.values
        self.solver_params: SolverParams = solver_params(self.values)
        v = self.values
        try:
            prefixes = character_prefixes(v["frame_prefix"], v["frame_prefixes"])
        except ParameterError as err:
            self.get_logger().error(f"{err}; dressing one character of frame_prefix {v['frame_prefix']!r}")
            prefixes = [v["frame_prefix"]]
        self.members: list[Member] = make_members(prefixes, v, self.solver_params, self.get_logger(),
                                                  self._on_loop_event)
        self.frame_errors = 0
        self._frame_errors_reported = 0
        self.last_diagnostics: dict[str, str] = {}  # the first character's last status values
        self._pending: dict[str, Any] = {}
        self._clear_markers = False
        self._last_compute_s = 0.0
        self._frame_time = 0.0  # the frame being computed (T_next), s: the time of the loop's events
        self._shown: list[Member] = []  # the characters in the last MarkerArray...
        self._held_message = b""  # ...serialized, published again while nothing new is simulated

        # raw: the bytes are decoded by ``TFDecoder`` (numpy), never into Python message objects
        self._tf_decoder = TFDecoder(prefixes)
        self._tf_pending: list[bytes] = []
        # the /tf input at the newest frame, for the Rerun recording: messages absorbed, newest lag (ms)
        self._frame_input: dict[str, float] = {"backlog": 0.0}
        self._warned_tf_full = False
        self._tf_subscription = self.create_subscription(TFMessage, "/tf", self._on_tf, _TF_QOS, raw=True)
        self.create_subscription(TFMessage, "/tf_static", self._on_tf_static, _TF_STATIC_QOS)
        self.marker_publisher = self.create_publisher(MarkerArray, "~/markers", _MARKERS_QOS)
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.frame_timer = self.create_timer(1.0 / v["rate_hz"], self._on_frame_timer)  # the node's clock
        # Steady: diagnostics and the file watch go on when sim time stalls or has not started.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.diagnostics_timer = self.create_timer(v["diagnostics_period"], self.publish_diagnostics, clock=steady)
        self.params_watch = ParamsFileWatch(self, params_file_hint)
        self.watch_timer = self.create_timer(v["watch_period"], self._on_watch_timer, clock=steady)
        self.rerun = self._create_rerun_logger()
        if self.rerun is not None:
            self.rerun.log_event(0.0, "info", "quality_rate", f"quality meters at {v['quality_rate_hz']:g} Hz of body "
                                 "time (penetration, bones through, legs off, stretch on the measured frames only)")

    # the first (with frame_prefix alone, the only) character's
    loop = property(lambda self: self.members[0].loop)
    buffer = property(lambda self: self.members[0].buffer)
    stats = property(lambda self: self.members[0].stats)
    input_counts = property(lambda self: self.members[0].input_counts)

    # ------------------------------------------------------------------------------ parameters
    def _on_parameters_accepted(self, changes: dict[str, Any]) -> None:
        """The new values take effect at the next frame (timers at once)."""
        self._pending.update(changes)
        if "rate_hz" in changes:
            self.frame_timer.timer_period_ns = int(1e9 / changes["rate_hz"])
        if "diagnostics_period" in changes:
            self.diagnostics_timer.timer_period_ns = int(1e9 * changes["diagnostics_period"])
        if "watch_period" in changes:
            self.watch_timer.timer_period_ns = int(1e9 * changes["watch_period"])

    def _on_watch_timer(self) -> None:
        """The files: the params file (when watched) and the worn garments' specs (a save re-dresses)."""
        self.params_watch.poll()
        for member in self.members:
            member.loop.check_specs()

    def _apply_pending(self) -> None:
        """Parameter changes take effect here, at the start of a frame."""
        changes, self._pending = self._pending, {}
        if not changes:
            return
        if SOLVER_PARAMETER_NAMES & changes.keys():
            self.solver_params = solver_params(self.values)
        for member in self.members:
            if SOLVER_PARAMETER_NAMES & changes.keys():
                member.loop.set_params(self.solver_params)
            if any(key in changes for key in _REDRESS_KEYS):
                member.loop.set_garments(self.values["garments"], self.values["resolution"],
                                         garment_folders(self.values["garment_path"]))
            if any(key in changes for key in _CLEAR_KEYS):
                self._clear_markers = True
                member.restyle(self._namespace(member), self.values)
            member.loop.quality_rate_hz = self.values["quality_rate_hz"]
            member.buffer.max_age_s = self.values["max_skeleton_age"]
            member.buffer.max_extrapolation_s = self.values["max_extrapolation"]
        if self.rerun is not None:
            self.rerun.every_n = self.values["rerun_every_n"]
            self.rerun.log_event(self._frame_time, "info", "parameters",
                                 ", ".join(f"{name}={plain(value)!r}" for name, value in sorted(changes.items())))

    def _namespace(self, member: Member) -> str:
        return character_namespace(self.values["marker_namespace"], member.prefix, len(self.members) > 1)

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
        for member in self.members:
            member.stats.record_drain(len(messages))
        self._frame_input["backlog"] = float(len(messages))
        if len(messages) - kept >= _TF_QOS.depth and not self._warned_tf_full:
            self._warned_tf_full = True  # once: the diagnostics go on counting (input_backlog, input_hz)
            self.get_logger().warning(
                f"/tf arrives faster than this node absorbs it: its queue was full at a frame (it keeps "
                f"{_TF_QOS.depth} messages, older ones were dropped); it sustains about "
                f"{self.stats.input_rate():.0f} messages/s. Poses stay the newest; see input_lag_* in diagnostics")
        now_ns = self.get_clock().now().nanoseconds  # 0: use_sim_time before the first /clock
        now_s = now_ns * 1e-9 if now_ns else None
        errors, refusals, lags = route_tf(self._tf_decoder, self.members, messages, now_s)
        self.input_counts["undecodable"] += len(errors)
        if errors:
            self.log_throttled("warning", "tf_undecodable",
                               f"a /tf message could not be decoded (counted): {errors[0]}")
        for lag_s in lags:  # receive time - stamp, per message
            for member in self.members:
                member.stats.record_input(lag_s)
        if lags:
            self._frame_input["lag_ms"] = 1e3 * lags[-1]
        self._log_refusals(refusals)

    def _on_tf_static(self, message: TFMessage) -> None:
        self._log_refusals([refusal for member in self.members
                            if (refusal := member.count_input(ingest(member.buffer, message, member.prefix,
                                                                     static=True)))])

    def _log_refusals(self, refusals: list[str]) -> None:
        if refusals:
            self.log_throttled("warning", "tf_refused",
                               f"refused /tf input (counted in diagnostics), e.g. {refusals[0]}")

    # ------------------------------------------------------------------------------ the frame
    def _on_frame_timer(self) -> None:
        tic = time.perf_counter()
        dressed = fresh = False
        members = self.members
        try:
            self._absorb_tf()  # the newest /tf first, however the executor scheduled the callbacks
            self._apply_pending()
            now_s = self.get_clock().now().nanoseconds * 1e-9
            self._frame_time = self._last_compute_s + now_s  # T_next = D_last + now
        except Exception:  # a frame must never take the node down: report it and go on
            self._frame_failed()
            members = []
        for member in members:  # one after another: see runtime.crowd
            try:
                result = member.loop.frame(self._frame_time, now_s)
                if result is not None:
                    self._record_frame(member, result)
                    fresh, dressed = True, dressed or result.dressed
            except Exception:
                self._frame_failed()
        try:
            self._publish_markers(fresh, clear=dressed)
        except Exception:
            self._frame_failed()
        compute_s = time.perf_counter() - tic
        for member in self.members:
            member.stats.record_tick(compute_s)
        # D_last: dressing is no frame's compute time, T_next of the next frame must not jump by it
        self._last_compute_s = 0.0 if dressed else compute_s

    def _frame_failed(self) -> None:
        if not self.context.ok():
            return  # shut down (a signal) mid-frame: the publish failed, nothing to report
        self.frame_errors += 1
        self.log_throttled("error", "frame_error", f"frame failed (counted in diagnostics):\n{traceback.format_exc()}")

    def _record_frame(self, member: Member, result: FrameResult) -> None:
        tic = time.perf_counter()
        member.hold(result, self._namespace(member), self.values)  # stamped with the pose's time
        publish_s = time.perf_counter() - tic
        member.stats.record_frame(result.reports, result.frame_s, result.penetration_m, result.measured,
                                  result.catch_up_recoveries)
        recovered = [f"{member.prefix}{solver.model.name} {report.recovery}"
                     for solver, report in zip(member.loop.character.solvers, result.reports) if report.recovery]
        recovered += [f"{member.prefix}{what} while catching up" for what in result.catch_up_recoveries]
        if recovered:
            self.log_throttled("warning", "solver_recovery",
                               "a garment step went bad (counted in diagnostics as solver_*): " + ", ".join(recovered))
        member.stats.record_publish(publish_s)
        if self.rerun is not None and member is self.members[0]:  # Rerun records the first character
            self._log_rerun(result, member.held[0], publish_s)

    def _publish_markers(self, fresh: bool, clear: bool = False) -> None:
        """Every character's held frame in one MarkerArray (none while (re-)dressing: its first frame
        replaces it). Nothing new simulated (holding, folded, no newer pose): the last message again, at
        rate_hz, so a late subscriber sees the garments. After a change of garments or namespaces (or
        volumes switched off), or a re-dress, a DELETEALL first that drops the old ones (published once,
        the held message is without it)."""
        shown = [m for m in self.members if m.held is not None and m.loop.character is not None]
        if not shown:
            return
        clear = clear or self._clear_markers
        if fresh or clear or shown != self._shown:
            self._shown, self._clear_markers = shown, False
            self._held_message = serialize_marker_array(crowd_markers(shown, clear=False))
            if clear:
                self.marker_publisher.publish(serialize_marker_array(crowd_markers(shown, clear=True)))
                return
        self.marker_publisher.publish(self._held_message)

    def _log_rerun(self, result: FrameResult, payload: dict, publish_s: float) -> None:
        try:
            self.rerun.log_result(result, self.loop.character, payload, publish_s, self._frame_input)
        except Exception as err:  # the viewer went away, the disk is full...: markers go on
            self.get_logger().error(f"Rerun logging failed, switched off: {err}")
            self.rerun = None

    def _on_loop_event(self, level: str, kind: str, message: str) -> None:
        """The character loop's events (dressed, teleported, holding...) on the Rerun timeline."""
        if self.rerun is not None:
            self.rerun.log_event(self._frame_time, level, kind, message)

    def _create_rerun_logger(self) -> RerunLogger | None:
        v = self.values
        if v["rerun_sink"] == "off":
            return None
        try:
            return RerunLogger(sink=v["rerun_sink"], path=v["rerun_path"], url=v["rerun_url"] or None,
                               recording_name=self.get_fully_qualified_name(), every_n=v["rerun_every_n"])
        except Exception as err:
            self.get_logger().error(f"rerun_sink {v['rerun_sink']!r} failed, Rerun logging is off: {err}")
            return None

    # ------------------------------------------------------------------------------ diagnostics
    def publish_diagnostics(self) -> None:
        now = self.get_clock().now()
        if now.nanoseconds == 0 and self.get_clock().ros_time_is_active:
            for member in self.members:  # use_sim_time and no /clock yet: the frame timer does not fire
                member.loop.clock_not_started()
        failed = self.frame_errors > self._frame_errors_reported  # a frame failed since the last status
        self._frame_errors_reported = self.frame_errors
        totals = {"frame_errors": self.frame_errors, "params_file_errors": self.params_watch.errors}
        statuses = crowd_statuses(self.get_fully_qualified_name(), self.members, self.values, now.nanoseconds * 1e-9,
                                  totals, failed)
        self.last_diagnostics = {kv.key: kv.value for kv in statuses[0].values}  # the first character's
        self.diagnostics_publisher.publish(DiagnosticArray(header=Header(stamp=now.to_msg()), status=statuses))

    def log_throttled(self, level: str, key: str, message: str) -> None:
        self._events.log(level, key, message)

    def destroy_node(self) -> None:
        if self.rerun is not None:
            self.rerun.close()
            self.rerun = None
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console entry point ``garment_sim_node``, e.g.
    ``garment_sim_node --ros-args --params-file config/garment_sim.yaml -r __ns:=/alice -p frame_prefix:=alice/``."""
    rclpy.init(args=args)
    spin_until_shutdown(GarmentSimNode(params_file_hint=params_file_from_args(sys.argv if args is None else args)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
