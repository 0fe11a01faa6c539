"""The command line's JSON contracts."""

import json
import subprocess
import sys


def garment_sim(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "garment_sim_ros.cli", *args], capture_output=True, text=True,
                          timeout=600)


def test_garments_json_lists_the_four_templates_and_the_shipped_specs():
    result = garment_sim("garments", "--json")
    assert result.returncode == 0, result.stderr
    rows = [json.loads(line) for line in result.stdout.splitlines()]
    assert [r["name"] for r in rows] == ["short_skirt", "long_skirt", "pants", "one_piece", "cape"]
    assert [r["source"] for r in rows][:4] == ["built-in"] * 4 and rows[4]["source"].endswith("cape.yaml")
    for r in rows:
        assert {"name", "mass_points", "edges", "springs", "triangles"} <= set(r)
        assert r["springs"] > r["edges"] > r["mass_points"] > 0
        assert r["triangles"] > r["mass_points"]


def test_unknown_command_is_refused_with_the_list():
    result = garment_sim("dance")
    assert result.returncode == 2
    assert "unknown command 'dance'" in result.stderr and "garments" in result.stderr


def test_bad_resolution_is_an_error_not_a_traceback():
    result = garment_sim("garments", "--resolution", "-3")
    assert result.returncode == 2
    assert "resolution" in result.stderr
    assert "Traceback" not in result.stderr


def test_demo_json_summary_reads_back_from_a_real_run(tmp_path):
    rrd = tmp_path / "demo.rrd"
    result = garment_sim("demo", "--duration", "2", "--garments", "pants", "--rrd", str(rrd), "--json")
    assert result.returncode == 0, result.stderr[-2000:]
    assert "[WARN]" not in result.stderr and "[ERROR]" not in result.stderr, result.stderr  # issue 18: a clean start
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert {"garments", "fps", "frames", "max_penetration_m", "rrd"} <= set(summary)
    assert summary["garments"] == [{"name": "pants", "mass_points": summary["garments"][0]["mass_points"]}]
    assert summary["frames"] > 10 and summary["fps"] > 1.0
    assert 0.0 <= summary["max_penetration_m"] < 0.001
    assert rrd.stat().st_size > 10_000 and summary["rrd"] == str(rrd)


def test_simulate_takes_param_changes_and_refuses_a_bad_one_naming_its_range():
    result = garment_sim("simulate", "--duration", "0.1", "--json", "--param", "band_gives_way=0",
                         "--param", "open_cut_band=0")
    assert result.returncode == 0, result.stderr[-2000:]
    result = garment_sim("simulate", "--duration", "0.1", "--param", "open_cut_band=0.5")
    assert result.returncode == 2
    assert "open_cut_band: got 0.5; allowed: [0.0, 0.1] m" in result.stderr and "Traceback" not in result.stderr
