"""Per-volume overrides of a fitted body, from YAML (``config/body.yaml``, the node's ``body_file``).

``{volumes: {<volume>: {radii: [x, y, z], cut: [lo, hi], offset_position: [x, y, z]}}}`` in metres:
the volume's local frame (radii, cut along local z) and its joint's frame (offset). Checked for
structure when read and against the fitted body when applied, with errors naming the source and key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..collision.volumes import ELLIPSOID, SPHERE, Volume
from ..config_files import config_file, read_yaml

OVERRIDE_KEYS = {"radii": 3, "cut": 2, "offset_position": 3}


class BodyConfigError(ValueError):
    """A body override is refused; the message names the source, the key and what is allowed."""


@dataclass(frozen=True)
class BodyOverrides:
    """Per-volume replacements ``{volume: {radii|cut|offset_position: [...]}}`` and where they came from."""

    volumes: Mapping[str, Mapping[str, tuple[float, ...]]]
    source: str = "overrides"


def check_overrides(data: Any, source: str) -> BodyOverrides:
    """Validate the structure of overrides (names, keys, list lengths, numbers)."""
    from .fitting import DETAILED_VOLUMES  # the fitted body's volume names (fitting applies overrides)

    if data is None:
        return BodyOverrides({}, source)
    if not isinstance(data, Mapping):
        raise BodyConfigError(f"{source}: expected a mapping with the key 'volumes', got {type(data).__name__}")
    unknown = [k for k in data if k != "volumes"]
    if unknown:
        raise BodyConfigError(f"{source}: unknown key(s) {', '.join(map(str, unknown))}; allowed: volumes")
    volumes = data.get("volumes") or {}
    if not isinstance(volumes, Mapping):
        raise BodyConfigError(f"{source}: volumes must map volume names to overrides, got {type(volumes).__name__}")
    checked: dict[str, dict[str, tuple[float, ...]]] = {}
    for name, fields in volumes.items():
        if name not in DETAILED_VOLUMES:
            raise BodyConfigError(f"{source}: volumes.{name}: unknown volume; allowed: {', '.join(DETAILED_VOLUMES)}")
        if not isinstance(fields, Mapping):
            raise BodyConfigError(f"{source}: volumes.{name}: expected a mapping of {', '.join(OVERRIDE_KEYS)}")
        checked[name] = {}
        for key, value in fields.items():
            if key not in OVERRIDE_KEYS:
                raise BodyConfigError(f"{source}: volumes.{name}.{key}: unknown key; "
                                      f"allowed: {', '.join(OVERRIDE_KEYS)}")
            size = OVERRIDE_KEYS[key]
            numbers = isinstance(value, (list, tuple)) and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
            if not numbers or len(value) != size:
                raise BodyConfigError(f"{source}: volumes.{name}.{key}: got {value!r}; allowed: a list of {size} "
                                      "finite numbers (m)")
            checked[name][key] = tuple(float(v) for v in value)
    return BodyOverrides(checked, source)


def load_body_overrides(path: str | Path | None = None) -> BodyOverrides:
    """Read ``config/body.yaml`` (or ``path``)."""
    path = Path(path) if path is not None else config_file("body.yaml")
    return check_overrides(read_yaml(path, BodyConfigError, "body config"), str(path))


def apply_overrides(volumes: list[Volume], overrides: BodyOverrides) -> list[Volume]:
    fitted = {v.name: v for v in volumes}
    for name, fields in overrides.volumes.items():
        where = f"{overrides.source}: volumes.{name}"
        if name not in fitted:
            raise BodyConfigError(f"{where}: this body has no such volume (the 15-volume set needs detailed=True); "
                                  f"fitted: {', '.join(fitted)}")
        volume = fitted[name]
        radii = fields.get("radii", volume.radii)
        cut = fields.get("cut", volume.cut)
        if any(r <= 0.0 for r in radii):
            raise BodyConfigError(f"{where}.radii: got {list(radii)}; allowed: three positive lengths (m)")
        if volume.kind == SPHERE and "radii" in fields and not np.allclose(radii, radii[0]):
            raise BodyConfigError(f"{where}.radii: got {list(radii)}; allowed: a sphere's three radii are equal")
        if "cut" in fields and volume.kind != ELLIPSOID:
            raise BodyConfigError(f"{where}.cut: only ellipsoids are cut; {name} is a sphere")
        if volume.kind == ELLIPSOID and not -radii[2] <= cut[0] < cut[1] <= radii[2]:
            raise BodyConfigError(f"{where}.cut: got {list(cut)} with a_z = {radii[2]:.4g} m; allowed: "
                                  "-a_z <= cut[0] < cut[1] <= a_z (local z, m), inside the ellipsoid")
        fitted[name] = replace(volume, radii=tuple(radii), cut=tuple(cut),
                               offset_position=fields.get("offset_position", volume.offset_position))
    return [fitted[v.name] for v in volumes]


