"""``python -m benchmarks.bounds_energy --quick``: every case optimised, replayed in the env, and
above its bounds; a bound above an achieved value is reported."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks import bounds_energy as bench


@pytest.mark.slow  # four optimisations, about a minute
def test_quick_every_case_is_replayed_above_its_bounds(tmp_path):
    data = bench.main(["--quick", "--out", str(tmp_path)])
    saved = json.loads((tmp_path / "bounds_energy.json").read_text())
    assert saved["violation_count"] == 0
    assert {r["case"] for r in saved["rows"]} == set(bench.cases())
    for r in data["rows"]:
        t = r["time_optimal"]
        assert t["success"], r["case"]
        assert t["settle_time_s"] >= max(r["settle_bound_s"], r["settle_bound_used_s"])
        if "fuel_optimal" in r:
            f = r["fuel_optimal"]
            assert f["success"]
            assert f["fuel_g"] >= f["fuel_bound_own_time_g"] >= r["fuel_bound_g"] > 0
    table = (tmp_path / "bounds_energy.md").read_text()
    assert "reorient-wheels cubesat-6u-rw" in table and "0 found" in table


def test_a_bound_above_an_achieved_value_is_reported():
    row = {"settle_bound_s": 10.0, "settle_bound_used_s": 12.0, "fuel_bound_g": 0.1,
           "time_optimal": {"success": True, "settle_time_s": 11.0, "fuel_g": 0.2},
           "fuel_optimal": {"success": True, "settle_time_s": 20.0, "fuel_g": 0.15,
                            "fuel_bound_own_time_g": 0.16},
           "pd": {"success": True, "settle_time_s": 11.0, "fuel_g": 0.05}}
    found = bench.violations(row)
    assert len(found) == 3
    assert any("time_optimal settles at 11.0 s < settle_bound_used_s" in v for v in found)
    assert any("fuel_optimal spends 0.15 g < its own-time bound" in v for v in found)
    # The PD may use every actuator: held to the reported bound, not the restricted one.
    assert any("pd spends 0.05 g < fuel_bound_g" in v for v in found)
    row["time_optimal"]["settle_time_s"] = 12.0
    row["fuel_optimal"]["fuel_g"] = 0.16
    row["pd"]["fuel_g"] = 0.1
    assert bench.violations(row) == []


def test_episodes_are_picked_at_the_quartiles():
    key = np.arange(101.0)[::-1]
    assert sorted(key[bench.picks(key, 3, quick=False)]) == [25.0, 50.0, 75.0]
    assert key[bench.picks(key, 1, quick=True)][0] == 0.0


def test_an_unknown_case_exits_with_a_message(capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main(["--case", "nope"])
    assert exc.value.code == 2 and "the cases are" in capsys.readouterr().err
