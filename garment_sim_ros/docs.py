"""The README's parameter tables, generated from the parameter tables themselves.

``python -m garment_sim_ros.docs`` prints them; a test checks the README carries every row.
"""

from __future__ import annotations

from .params import DEFAULT_PARAMS, PARAMETERS, PRESETS


def _value(value) -> str:
    if isinstance(value, tuple):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def solver_parameter_rows() -> list[str]:
    rows = ["| name | default | memo preset | unit | range | meaning |", "|---|---|---|---|---|---|"]
    memo = PRESETS["memo"]
    for p in PARAMETERS:
        allowed = ", ".join(p.choices) if p.choices else f"{_value(p.low)} .. {_value(p.high)}"
        rows.append(f"| `{p.name}` | {_value(getattr(DEFAULT_PARAMS, p.name))} | {_value(getattr(memo, p.name))} "
                    f"| {p.unit} | {allowed} | {p.description} |")
    return rows


def main() -> None:
    print("\n".join(solver_parameter_rows()))


if __name__ == "__main__":
    main()
