"""The README documents every parameter, as the parameter tables say."""

from pathlib import Path

from garment_sim_ros import docs
from garment_sim_ros.params import PARAMETERS

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_parameter_tables_are_current():
    text = README.read_text()
    assert docs.render(text) == text, "run: .venv/bin/python -m garment_sim_ros.docs README.md"


def test_every_solver_parameter_has_unit_range_and_meaning():
    text = README.read_text()
    for p in PARAMETERS:
        assert f"| `{p.name}` |" in text
        assert p.description and (p.choices or (p.low is not None and p.high is not None))
        assert p.low is None or p.low <= (min(p.default) if isinstance(p.default, tuple) else p.default)
