"""Fabric presets: the solver parameters (``params.PARAMETERS``, units and ranges there) one fabric sets.

A garment spec's ``material`` is a preset name, or a mapping with an optional ``preset`` and explicit
values of the parameters in ``MATERIAL_PARAMETERS``; the garment is simulated with the run's parameters
and these values in their place (``material_overrides``).

How the physical values become the mass-spring model's:

- ``areal_density`` is the fabric's weight (kg/m^2), as sold.
- Stretch: the explicit solver cannot carry a woven fabric's tensile stiffness (10^3-10^4 N/m membrane
  stiffness, spring stiffness capped at ``stability_factor * m / h^2``, a few N/m); Provot's length
  limit stands for it. ``limit_ratio`` is the elongation the fabric takes under the light loads of
  wearing: about 1 % for wovens, several % for knits.
- ``bend_stiffness``: a bend spring across two edges is not a bending rigidity; the presets keep the
  ratio between fabrics' Kawabata bending rigidity B (KES-FB2, gf cm^2/cm), cotton shirting (B ~ 0.08)
  at the default 0.2 N/m: ``bend = 0.2 N/m * B / 0.08``. The solver caps what is unstable (reported).
- Damping scales with the areal density, so a spring's damping rate c/m (1/s) stays the default's.
- ``friction`` is the fabric-on-skin Coulomb coefficient.

Sources. Weights: trade units (1 oz/yd^2 = 33.9 g/m^2; 1 momme = 4.34 g/m^2). Bending rigidity:
Kawabata & Niwa, "Fabric performance in clothing and clothing manufacture", J. Text. Inst. 80 (1989),
and KES-FB2 tables of apparel fabrics (orders of magnitude, not one sample). Friction: Derler &
Gerhardt, "Tribology of skin: review and analysis of experimental results for the friction coefficient
of human skin", Tribology Letters 45 (2012): textiles on dry skin 0.2-0.6.
"""

from __future__ import annotations

from typing import Any, Mapping

from ..params import DEFAULT_PARAMS, PARAMETER_TABLE, ParameterError

# The parameters a material may set (all in params.PARAMETERS, with their units and ranges).
MATERIAL_PARAMETERS = ("areal_density", "limit_ratio", "stretch_stiffness", "shear_stiffness", "bend_stiffness",
                       "stretch_damping", "shear_damping", "bend_damping", "friction")

_REFERENCE_DENSITY = 0.15  # kg/m^2, the defaults' cloth (params.DEFAULT_PARAMS.areal_density)
_REFERENCE_BENDING_RIGIDITY = 0.08  # gf cm^2/cm, cotton shirting, at the default bend stiffness


def _fabric(density: float, bending_rigidity: float, limit_ratio: float, friction: float,
            stretch: float = 2.0) -> dict[str, float]:
    """A preset from physical values: density kg/m^2, Kawabata B gf cm^2/cm, elongation ratio, friction."""
    damping = density / _REFERENCE_DENSITY
    return {
        "areal_density": density,
        "limit_ratio": limit_ratio,
        "stretch_stiffness": stretch,
        "shear_stiffness": stretch / 2.0,
        "bend_stiffness": round(DEFAULT_PARAMS.bend_stiffness * bending_rigidity / _REFERENCE_BENDING_RIGIDITY, 4),
        "stretch_damping": round(DEFAULT_PARAMS.stretch_damping * damping, 5),
        "shear_damping": round(DEFAULT_PARAMS.shear_damping * damping, 5),
        "bend_damping": round(DEFAULT_PARAMS.bend_damping * damping, 5),
        "friction": friction,
    }


MATERIALS: dict[str, dict[str, float]] = {
    # poplin/broadcloth shirting 100-130 g/m^2; B 0.05-0.1; woven, ~1 % under wear; cotton on skin ~0.4
    "cotton_shirting": _fabric(0.12, 0.08, 0.01, 0.4),
    # 12-14 oz/yd^2 denim = 0.41-0.47 kg/m^2; B 0.5-1.5 (stiff twill); rigid, ~0.5 %; ~0.45 on skin
    "denim": _fabric(0.44, 1.0, 0.005, 0.45),
    # charmeuse 16-19 momme = 0.07-0.08 kg/m^2; B 0.01-0.03; ~1 %; silk slides on skin, ~0.25
    "silk": _fabric(0.075, 0.02, 0.01, 0.25),
    # single jersey 150-200 g/m^2; B 0.02-0.05; a knit gives several % under wear; ~0.45 on skin
    "jersey_knit": _fabric(0.18, 0.035, 0.06, 0.45, stretch=1.0),
    # garment (nappa) leather 0.8-1.2 mm at ~0.85 g/cm^3 = 0.7-1.0 kg/m^2; B several units; ~2 %; ~0.5
    "leather": _fabric(0.9, 4.0, 0.02, 0.5, stretch=4.0),
}


def material_overrides(material: Any, where: str) -> dict[str, float]:
    """The parameter values ``material`` sets (a preset name, or a mapping: ``preset`` and/or values).
    ``where`` names the file and key in error messages."""
    if material is None:
        return {}
    if isinstance(material, str):
        material = {"preset": material}
    if not isinstance(material, Mapping):
        raise ParameterError(f"{where}: expected a preset name ({', '.join(MATERIALS)}) or a mapping, got {material!r}")
    values: dict[str, float] = {}
    name = material.get("preset")
    if name is not None:
        if name not in MATERIALS:
            raise ParameterError(f"{where}.preset: unknown material {name!r}; known: {', '.join(MATERIALS)}")
        values.update(MATERIALS[name])
    for key, value in material.items():
        if key == "preset":
            continue
        if key not in MATERIAL_PARAMETERS:
            raise ParameterError(f"{where}.{key}: not a material parameter; allowed: preset, "
                                 f"{', '.join(MATERIAL_PARAMETERS)}")
        try:
            values[key] = PARAMETER_TABLE[key].check(value)
        except ParameterError as err:
            raise ParameterError(f"{where}.{err}") from None
    return values
