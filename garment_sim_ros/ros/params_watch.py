"""The node's params file, watched: re-applied whenever it changes (``watch_params_file``).

A change applies all of the node's section or, when any key or value is bad, none of it: the
message names the file, the key and what is allowed, and the last good configuration stays. The
watch's own switches (``watch_params_file``, ``params_file``) are taken from the file only when an
edit changes them: a watch turned on through the parameter service stays on while the file goes on
saying ``false`` (issue 18). A file without a section for the node's fully qualified name is said,
with the key to use, at start and when watched, and so are unknown keys in the start-up file: rclpy
ignores both without a word.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from rclpy.parameter import Parameter

from ..params import ParameterError
from ..runtime.file_watch import FileWatch
from ..runtime.params_file import ParamsFileError, read_node_parameters
from ..runtime.settings import PARAMETER_ROWS, is_read_only
from .ros_parameters import plain, ros_value

if TYPE_CHECKING:
    from .node import GarmentSimNode

WATCH_KEYS = ("watch_params_file", "params_file")


class ParamsFileWatch:
    """The params file of ``node`` (its ``params_file`` parameter, else the ``--params-file`` it was
    started with, ``start_file``); ``errors`` counts refused files, ``message`` says the last outcome."""

    def __init__(self, node: GarmentSimNode, start_file: str = ""):
        self.node = node
        self.start_file = start_file
        self.errors = 0
        self.message = ""
        self._watch: FileWatch | None = None
        self._switches: dict[str, Any] = {}  # WATCH_KEYS as the watched file said at the last read
        section = self._read_section(start_file) if start_file else None
        if section == {}:
            self.warn_no_section(start_file)
        unknown = sorted(set(section or ()) - set(PARAMETER_ROWS) - {"use_sim_time"})
        if unknown:  # rclpy keeps them as overrides nobody declares, silently
            node.get_logger().warning(f"{start_file}: unknown parameter(s) {', '.join(unknown)} ignored; known: "
                                      f"{', '.join(PARAMETER_ROWS)}")

    def path(self) -> str:
        return self.node.values["params_file"] or self.start_file

    def poll(self) -> None:
        """Timer: re-apply the file when its modification time or size changed."""
        path, watching = self.path(), self.node.values["watch_params_file"]
        if not watching or not path:
            if watching:
                self.node.log_throttled("warning", "params_file", "watch_params_file is on but params_file is empty "
                                        "and no --params-file was given: nothing to watch")
            self._watch = None
            return
        if self._watch is None or self._watch.path != Path(path):
            self._watch = FileWatch(path)
            self._switches = {}
            if path == self.start_file:
                self._watch.changed()  # loaded at start by --params-file (under any -p): apply later edits only
                self._switches = {k: v for k, v in (self._read_section(path) or {}).items() if k in WATCH_KEYS}
        if self._watch.changed():
            self.apply(path)

    def _read_section(self, path: str) -> dict[str, Any] | None:
        """The node's parameters in ``path``; None when it cannot be read (said when the watch reads it)."""
        try:
            return read_node_parameters(path, self.node.get_fully_qualified_name())
        except ParamsFileError:
            return None

    def apply(self, path: str) -> bool:
        """Apply the node's section of ``path``: all of it, or (any bad key or value) none of it."""
        node = self.node
        try:
            given = read_node_parameters(path, node.get_fully_qualified_name())
        except ParamsFileError as err:
            return self._refuse([str(err)])
        if not given:
            self.warn_no_section(path)
        said_before, self._switches = self._switches, {k: given[k] for k in WATCH_KEYS if k in given}
        problems, changes = [], []
        for name, raw in given.items():
            raw = plain(raw)
            if name in WATCH_KEYS and said_before.get(name, raw) == raw:
                continue  # the watch's switches: only an edit of them applies
            if name not in PARAMETER_ROWS:
                if node.has_parameter(name):
                    if node.get_parameter(name).value != raw:
                        changes.append(Parameter(name, value=raw))
                else:
                    problems.append(f"{path}: {name}: unknown parameter; known: {', '.join(PARAMETER_ROWS)}")
                continue
            try:
                value = PARAMETER_ROWS[name].check(raw)
            except ParameterError as err:
                problems.append(f"{path}: {err}")
                continue
            if value == node.values[name]:
                continue
            if is_read_only(name):
                problems.append(f"{path}: {name}: read-only, set at start; running with {node.values[name]!r}, "
                                f"the file says {value!r} (restart the node to change it)")
            else:
                changes.append(Parameter(name, value=ros_value(value)))
        if problems:
            return self._refuse(problems)
        if changes:
            result = node.set_parameters_atomically(changes)
            if not result.successful:
                return self._refuse([f"{path}: {result.reason}"])
        self.message = f"{path}: applied " + (
            ", ".join(f"{p.name}={plain(p.value)!r}" for p in changes) if changes else "(no change)")
        node.get_logger().info(self.message)
        return True

    def warn_no_section(self, path: str) -> None:
        name = self.node.get_fully_qualified_name()
        self.node.log_throttled("warning", "params_file_section", f"{path}: no ros__parameters section matches this "
                                f"node's fully qualified name {name!r}: nothing in it applies. Key it "
                                f"'{name.lstrip('/')}', or '/**/{self.node.get_name()}' for any namespace")

    def _refuse(self, problems: list[str]) -> bool:
        self.errors += 1
        self.message = "; ".join(problems) + "; keeping the last good configuration"
        self.node.get_logger().error(self.message)
        return False
