"""The parameter tables' rows as rclpy sees them: types, descriptors, values; the --params-file argument."""

from __future__ import annotations

import array
from typing import Any, Sequence

import numpy as np
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.parameter import Parameter

from ..params import Param


def parameter_type(row: Param) -> Parameter.Type:
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


def ros_value(value: Any) -> Any:
    """A validated value as rclpy stores it (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value


def plain(value: Any) -> Any:
    """A parameter value as Python scalars and lists (rclpy gives arrays as ``array.array``)."""
    if isinstance(value, (array.array, np.ndarray)):
        return value.tolist()
    return value


def descriptor(row: Param) -> ParameterDescriptor:
    """The ``ParameterDescriptor`` of a table row: description with unit and allowed values, range, read-only."""
    unit = f" [{row.unit}]" if row.unit and row.unit != "1" else ""
    result = ParameterDescriptor(
        name=row.name, type=parameter_type(row).value, description=f"{row.description}{unit}",
        additional_constraints=f"allowed: {row.allowed()}", read_only=bool(getattr(row, "read_only", False)))
    kind = parameter_type(row)
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
