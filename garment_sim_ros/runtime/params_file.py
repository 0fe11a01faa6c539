"""A ROS 2 parameter YAML read the way ``--params-file`` reads it (ROS-free; ``file_watch`` tells when it changed).

The file maps node names to ``ros__parameters``; names are fully qualified (a leading '/' is
implied), may be nested (``alice: {garment_sim_node: {ros__parameters: ...}}`` is
``/alice/garment_sim_node``) and may use rcl's wildcards: ``*`` one name token, ``/**`` any
namespace (``/**`` alone: every node). Every section that matches the node applies, later
ones overriding earlier ones; nested parameter mappings become dotted names.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

SECTION_KEY = "ros__parameters"


class ParamsFileError(ValueError):
    """The file cannot be read or is not a parameter YAML; the message names the file."""


def _pattern(node_key: str) -> re.Pattern:
    key = node_key if node_key.startswith("/") else "/" + node_key
    parts = []
    for token in key.split("/")[1:]:
        if token == "**":
            parts.append("(/[^/]+)*")
        else:
            parts.append("/" + re.escape(token).replace(r"\*", "[^/]*"))
    return re.compile("".join(parts) + "$")


def _flatten(values: dict, prefix: str = "") -> dict[str, Any]:
    flat = {}
    for name, value in values.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{name}."))
        else:
            flat[f"{prefix}{name}"] = value
    return flat


def _sections(data: dict, path: str, source: str) -> list[tuple[str, dict]]:
    found = []
    for key, value in data.items():
        if key == SECTION_KEY:
            if not isinstance(value, dict):
                raise ParamsFileError(f"{source}: {path or '/'}: {SECTION_KEY} must be a mapping of parameter names "
                                      f"to values, got {type(value).__name__}")
            found.append((path, value))
        elif isinstance(value, dict):
            found += _sections(value, f"{path}/{str(key).strip('/')}", source)
        else:
            raise ParamsFileError(f"{source}: {path}/{key}: expected a node name holding {SECTION_KEY}, "
                                  f"got the value {value!r}")
    return found


def node_parameters(data: Any, node_fqn: str, source: str) -> dict[str, Any]:
    """The parameters the YAML document ``data`` gives the node ``node_fqn`` (e.g. ``/alice/garment_sim_node``)."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ParamsFileError(f"{source}: expected a mapping of node names to {SECTION_KEY}, got {type(data).__name__}")
    values: dict[str, Any] = {}
    for node_key, section in _sections(data, "", source):
        if _pattern(node_key or "/").match(node_fqn):
            values.update(_flatten(section))
    return values


def read_node_parameters(path: str | Path, node_fqn: str) -> dict[str, Any]:
    """Read ``path`` and return the node's parameters; ``ParamsFileError`` naming the file (and the
    line, for YAML syntax errors) when it cannot be read or parsed."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ParamsFileError(f"{path}: cannot read the parameter file: {getattr(err, 'strerror', None) or err}") \
            from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ParamsFileError(f"{path}: not valid YAML: {err}") from None
    return node_parameters(data, node_fqn, str(path))
