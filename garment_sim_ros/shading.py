"""Per-vertex colours shaded from normals (ROS-free): one shading for Rerun, markers and PNGs.

Two-sided Lambert with an ambient floor: a garment is an open surface whose outward side
depends on how its triangles were wound, so ``|n . l|`` lights both sides alike.
"""

from __future__ import annotations

import numpy as np

DEFAULT_LIGHT_DIR = (0.6, 0.35, 0.75)  # from the front-left, above (REP-103: x forward, y left, z up)
DEFAULT_AMBIENT = 0.35


def shade(normals: np.ndarray, base_rgb, light_dir=DEFAULT_LIGHT_DIR, ambient: float = DEFAULT_AMBIENT) -> np.ndarray:
    """Colours (N, 3) uint8 of vertices with unit ``normals`` (N, 3) in a base colour ``base_rgb``
    (three numbers 0..255) lit from ``light_dir`` (towards the light; normalised here)."""
    normals = np.asarray(normals, dtype=float)
    if normals.ndim != 2 or normals.shape[1] != 3:
        raise ValueError(f"shade: normals must be an (N, 3) array, got shape {normals.shape}")
    base = np.asarray(base_rgb, dtype=float)
    if base.shape != (3,) or not np.all((base >= 0.0) & (base <= 255.0)):
        raise ValueError(f"shade: base_rgb must be three numbers in [0, 255], got {base_rgb!r}")
    light = np.asarray(light_dir, dtype=float)
    length = float(np.linalg.norm(light)) if light.shape == (3,) else 0.0
    if not (np.isfinite(length) and length > 0.0):
        raise ValueError(f"shade: light_dir must be a non-zero 3-vector, got {light_dir!r}")
    if not 0.0 <= ambient <= 1.0:
        raise ValueError(f"shade: ambient must be in [0, 1], got {ambient!r}")
    lambert = np.abs(normals @ (light / length))
    intensity = ambient + (1.0 - ambient) * np.clip(np.nan_to_num(lambert), 0.0, 1.0)
    return np.clip(np.rint(intensity[:, None] * base), 0, 255).astype(np.uint8)


# Base colours of the garment templates (RGB 0..255); any other name gets FALLBACK_RGB.
GARMENT_COLORS: dict[str, tuple[int, int, int]] = {
    "short_skirt": (200, 60, 70),
    "long_skirt": (70, 110, 190),
    "pants": (60, 80, 140),
    "one_piece": (190, 120, 40),
}
FALLBACK_RGB = (150, 150, 150)
BODY_RGB = (225, 190, 160)  # body volumes
SKELETON_RGB = (30, 30, 30)


def garment_color(name: str) -> tuple[int, int, int]:
    return GARMENT_COLORS.get(name, FALLBACK_RGB)
