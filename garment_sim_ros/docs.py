"""The README's parameter and material tables, generated from the tables themselves.

``python -m garment_sim_ros.docs README.md`` rewrites the tables between their markers
(``<!-- solver-parameters -->`` ... ``<!-- /solver-parameters -->`` and the same for
``node-parameters`` and ``materials``); a test checks the README is current.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from .params import DEFAULT_PARAMS, PARAMETERS, PRESETS


def _value(value) -> str:
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    return str(value)


def _allowed(p) -> str:
    return p.allowed() if hasattr(p, "allowed") else ""


def solver_parameter_rows() -> list[str]:
    rows = ["| name | default | memo preset | unit | allowed | meaning |", "|---|---|---|---|---|---|"]
    memo = PRESETS["memo"]
    for p in PARAMETERS:
        rows.append(f"| `{p.name}` | {_value(getattr(DEFAULT_PARAMS, p.name))} | {_value(getattr(memo, p.name))} "
                    f"| {p.unit} | {_allowed(p)} | {p.description} |")
    return rows


def node_parameter_rows() -> list[str]:
    from .runtime.settings import NODE_PARAMETERS

    rows = ["| name | default | unit | allowed | meaning |", "|---|---|---|---|---|"]
    for p in NODE_PARAMETERS:
        note = " (read-only)" if p.read_only else ""
        rows.append(f"| `{p.name}`{note} | {_value(p.default)} | {p.unit} | {_allowed(p)} | {p.description} |")
    return rows


def material_rows() -> list[str]:
    from .cloth.materials import MATERIAL_PARAMETERS, MATERIALS

    units = {p.name: p.unit for p in PARAMETERS}
    rows = ["| material | " + " | ".join(f"`{k}` ({units[k]})" for k in MATERIAL_PARAMETERS) + " |",
            "|---|" + "---|" * len(MATERIAL_PARAMETERS)]
    for name, values in MATERIALS.items():
        rows.append(f"| `{name}` | " + " | ".join(_value(values[k]) for k in MATERIAL_PARAMETERS) + " |")
    return rows


SECTIONS = {"solver-parameters": solver_parameter_rows, "node-parameters": node_parameter_rows,
            "materials": material_rows}


def render(text: str) -> str:
    for name, rows in SECTIONS.items():
        pattern = re.compile(rf"(<!-- {name} -->\n).*?(<!-- /{name} -->)", re.S)
        if not pattern.search(text):
            raise ValueError(f"README has no <!-- {name} --> ... <!-- /{name} --> markers")
        text = pattern.sub(lambda m: m.group(1) + "\n".join(rows()) + "\n" + m.group(2), text)
    return text


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        for rows in SECTIONS.values():
            print("\n".join(rows()) + "\n")
        return 0
    path = Path(argv[0])
    path.write_text(render(path.read_text()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
