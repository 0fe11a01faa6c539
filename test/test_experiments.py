"""The memo's Fig. 5 / Fig. 6 experiments: the reference against an independent solution, the
shape of the error, and dynamic handling's larger step at equal error (counted steps, no clocks)."""

import json
import math

import numpy as np
import pytest

from garment_sim_ros.cli import main
from garment_sim_ros.collision import experiments as ex


def exact_first_contact(distance_m):
    """First time the point touches the moving, turning ellipsoid, and where (local frame),
    by scanning the continuous motion and bisecting, independently of the kernels."""
    radii = np.array(ex.RADII)
    start, velocity = ex.point_start(distance_m)

    def local(t):
        angle = 0.5 * math.pi - ex.SPIN_RATE * t
        c, s = math.cos(angle), math.sin(angle)
        rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
        return rot.T @ (start + velocity * t - np.array([0, 0, ex.RISE_SPEED * t]))

    def inside(t):
        return np.sum((local(t) / radii) ** 2) < 1.0

    t = 0.0
    while not inside(t + 1e-4):
        t += 1e-4
    lo, hi = t, t + 1e-4
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inside(mid) else (mid, hi)
    return hi, local(hi)


@pytest.mark.parametrize("distance", [0.02, 0.145])
def test_reference_is_the_exact_first_contact(distance):
    t, point = exact_first_contact(distance)
    ref = ex.reference(distance)
    assert ref.hit
    assert ref.time_s == pytest.approx(t, abs=2 * ex.REFERENCE_STEP)
    np.testing.assert_allclose(ref.point, point, atol=1e-5)


def test_fig5_error_is_tiny_near_the_surface_and_grows_with_distance_and_step():
    distances = (0.005, 0.05, 0.145, 0.3)
    steps = (0.001, 0.01, 0.05, 0.1, 0.2, 0.4)
    rows = ex.fig5(distances, steps)
    assert len(rows) == len(distances) * len(steps)
    err = {(r["distance_m"], r["time_step_s"]): r["error_m"] for r in rows}
    assert all(r["error_mean_m"] <= r["error_m"] for r in rows)
    # tiny near the surface for steps up to 0.1 s, and for small steps at every distance
    assert all(err[0.005, h] < 1e-3 for h in steps if h <= 0.1)
    assert all(err[d, h] < 1e-4 for d in distances for h in steps if h <= 0.01)
    # grows with the step (within the reference's own precision, a few micrometres)
    for d in distances:
        errors = [err[d, h] for h in steps]
        assert all(b >= a - 1e-5 for a, b in zip(errors, errors[1:])), (d, errors)
        assert errors[-1] > 100 * max(errors[0], 1e-6)
    # grows with the distance to the surface (it saturates once the distance exceeds a step's travel)
    for h in (0.1, 0.2, 0.4):
        assert err[0.005, h] < err[0.05, h] <= err[0.145, h] + 1e-5
        assert err[0.3, h] > 3 * err[0.005, h]


def test_largest_step_requires_every_smaller_step_to_meet_the_target():
    errors = {0.001: 1e-4, 0.01: 5e-4, 0.02: 2e-3, 0.05: 8e-4, 0.1: math.inf}
    assert ex.largest_step(errors, 1e-3) == 0.01
    assert ex.largest_step(errors, 1e-5) is None
    assert ex.largest_step(errors, 1.0) == 0.05


def test_fig6_dynamic_takes_far_larger_steps_at_equal_error():
    rows = ex.fig6(targets=(0.001, 0.002), timed=False)
    for row in rows:
        assert row["static_error_m"] <= row["target_error_m"] and row["dynamic_error_m"] <= row["target_error_m"]
        assert row["dynamic_step_s"] > 5 * row["static_step_s"]
        # the work to cover the same interval, in kernel calls (one pair per step)
        assert row["static_steps"] > 5 * row["dynamic_steps"]
        assert row["static_time_s"] is None and row["speedup"] is None


def test_a_run_counts_its_steps_and_shortens_the_first_step_by_the_phase():
    assert ex.run(0.3, 0.01, "static", duration_s=0.1).steps == 10
    shifted = ex.run(0.3, 0.01, "static", phase=0.5, duration_s=0.1)
    assert shifted.steps == 11 and not shifted.hit
    with pytest.raises(ValueError, match="method must be 'static' or 'dynamic'"):
        ex.run(0.1, 0.01, "implicit")


def test_fig5_command_prints_one_json_object_per_distance_and_step(capsys):
    assert main(["fig5", "--json", "--distances", "0.005,0.1", "--steps", "0.01,0.1"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [(r["distance_m"], r["time_step_s"]) for r in rows] == [(0.005, 0.01), (0.005, 0.1), (0.1, 0.01), (0.1, 0.1)]
    assert all(r["error_m"] >= 0.0 for r in rows)


def test_fig6_command_prints_speedup(capsys):
    assert main(["fig6", "--json", "--targets", "0.002"]) == 0
    (row,) = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {"static_step_s", "dynamic_step_s", "static_time_s", "dynamic_time_s", "speedup"} <= set(row)
    assert row["speedup"] > 0.0


def test_commands_refuse_bad_lists(capsys):
    with pytest.raises(SystemExit):
        main(["fig5", "--steps", "0.01,fast"])
    assert "expected comma-separated numbers" in capsys.readouterr().err
