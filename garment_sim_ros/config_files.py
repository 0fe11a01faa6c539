"""Finding and reading the package's YAML files (ROS-free)."""

from __future__ import annotations

import sys
from pathlib import Path

import yaml


def config_file(*parts: str) -> Path:
    """A file under the package's ``config/``: the source tree's, else the installed share/ copy."""
    candidates = (
        Path(__file__).resolve().parents[1] / "config",
        Path(sys.prefix) / "share" / "garment_sim_ros" / "config",
    )
    for directory in candidates:
        path = directory.joinpath(*parts)
        if path.exists():
            return path
    raise FileNotFoundError(f"config file {'/'.join(parts)} not found in {' or '.join(map(str, candidates))}")


def read_yaml(path: str | Path, error: type[Exception], what: str):
    """The YAML document in ``path``; a missing file or a syntax error raises ``error`` naming the file."""
    path = Path(path)
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror or err}") from None
    except yaml.YAMLError as err:
        raise error(f"{path}: not valid YAML: {err}") from None
