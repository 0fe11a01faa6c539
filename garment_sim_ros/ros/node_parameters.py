"""The node's parameters on rclpy: declared from the tables, every set checked against them.

rclpy's public callbacks: ``_prepare`` (pre-set, runtime sets only) checks against the tables and
types the values as declared; rclpy then checks the descriptors (type, range, read-only), ``_check``
(on-set, also at declaration) refuses with the table's reason, ``_accepted`` (post-set) keeps the
new values and hands them on. rclpy checks descriptors before on-set callbacks, and its messages lack
the table's units and allowed values: a value ``_prepare`` refuses is passed on as the current one
(rclpy finds nothing wrong) and ``_check`` refuses it with the table's reason.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterNotDeclaredException,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..params import ParameterError
from ..runtime.settings import ALL_PARAMETERS, PARAMETER_ROWS, refused_changes
from .ros_parameters import descriptor, parameter_type, plain, ros_value


class UndeclaredParameters(ParameterNotDeclaredException):
    """rclpy's refusal of undeclared parameters (the parameter services answer with it), naming them."""

    def __init__(self, message: str):
        Exception.__init__(self, message)


class NodeParameters:
    """Every table row declared on ``node``; ``values`` holds them checked (name -> value). A set the
    tables accept updates ``values`` and calls ``on_accepted(changes)``.

    Start-up values (--params-file, -p; ``overrides``, the node's ``parameter_overrides``) are checked
    by ``_check`` like runtime ones: a refused one is logged and the default used."""

    def __init__(self, node: Node, overrides: Sequence[Parameter], on_accepted: Callable[[dict[str, Any]], None]):
        self.node = node
        self.on_accepted = on_accepted
        self._refusals: dict[str, str] = {}  # parameter -> the tables' reason, from _prepare for _check
        self.values: dict[str, Any] = {}
        logger = node.get_logger()
        node.add_on_set_parameters_callback(self._check)
        for row in ALL_PARAMETERS:
            try:
                node.declare_parameter(row.name, ros_value(row.node_value), descriptor(row))
            except (InvalidParameterTypeException, InvalidParameterValueException) as err:
                logger.error(f"start-up parameter refused: {err}; using the default {row.node_value!r}")
                node.declare_parameter(row.name, ros_value(row.node_value), descriptor(row), ignore_override=True)
            self.values[row.name] = row.check(plain(node.get_parameter(row.name).value))
        unknown = sorted({p.name for p in overrides} - set(PARAMETER_ROWS) - {"use_sim_time"})
        if unknown:
            logger.warning(f"unknown start-up parameter(s) {', '.join(unknown)} ignored; known: "
                           f"{', '.join(PARAMETER_ROWS)}")
        node.add_pre_set_parameters_callback(self._prepare)
        node.add_post_set_parameters_callback(self._accepted)

    def _prepare(self, parameters: list[Parameter]) -> list[Parameter]:
        """Pre-set: each parameter typed as declared (an integer for a real number is that number), or,
        refused by the tables, its current value with the reason kept for ``_check``."""
        node = self.node
        self._refusals = {}
        undeclared = [p.name for p in parameters if not node.has_parameter(p.name)]
        if undeclared:  # rclpy Jazzy's own refusal names none of them (it lists a consumed generator)
            reason = f"undeclared parameter(s) {', '.join(undeclared)}; known: {', '.join(PARAMETER_ROWS)}"
            node.get_logger().warning(f"parameter set refused: {reason}")
            raise UndeclaredParameters(reason)
        changes = {}
        for parameter in parameters:
            name = parameter.name
            if name not in PARAMETER_ROWS:
                continue  # use_sim_time: rclpy's own rules apply
            try:
                if parameter.type_ == Parameter.Type.NOT_SET:
                    raise ParameterError(f"{name}: cannot be unset; allowed: {PARAMETER_ROWS[name].allowed()}")
                changes[name] = PARAMETER_ROWS[name].check(plain(parameter.value))
            except ParameterError as err:
                self._refusals[name] = str(err)
        self._refusals.update(refused_changes(changes, self.values))
        for reason in dict.fromkeys(self._refusals.values()):  # every refused set said once
            node.get_logger().warning(f"parameter set refused: {reason}")
        return [parameter if parameter.name not in PARAMETER_ROWS
                else node.get_parameter(parameter.name) if parameter.name in self._refusals
                else Parameter(parameter.name, parameter_type(PARAMETER_ROWS[parameter.name]),
                               ros_value(changes[parameter.name]))
                for parameter in parameters]

    def _check(self, parameters: list[Parameter]) -> SetParametersResult:
        """On-set (runtime sets after ``_prepare``, and declarations): the table's refusal, if any."""
        for parameter in parameters:
            reason = self._refusals.get(parameter.name)
            if reason is None and parameter.name in PARAMETER_ROWS:
                try:
                    PARAMETER_ROWS[parameter.name].check(plain(parameter.value))
                except ParameterError as err:
                    reason = str(err)
            if reason is not None:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _accepted(self, parameters: list[Parameter]) -> None:
        """Post-set: keep the new values, hand them on."""
        changes = {p.name: PARAMETER_ROWS[p.name].check(plain(p.value)) for p in parameters if p.name in PARAMETER_ROWS}
        self.values.update(changes)
        self.on_accepted(changes)
