"""`bench`: figure discovery, the JSON contract of DESIGN.md 5.6, bad names."""

from __future__ import annotations

import json

from grasp_ctrl.bench.runner import all_figures
from grasp_ctrl.cli import main

STABLE = {"estimate_4tips_ms", "control_tick_ms", "dxl_cycle_16_ms", "mock_realtime_factor"}


def test_stable_figure_names_are_registered():
    assert STABLE <= set(all_figures())


def test_bench_json_contract(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--only", "estimate_4tips_ms,mock_realtime_factor", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert set(doc) == {"machine", "figures"} and isinstance(doc["machine"], str)
    assert set(doc["figures"]) == {"estimate_4tips_ms", "mock_realtime_factor"}
    for fig in doc["figures"].values():
        assert set(fig) == {"median", "p99", "unit"}
        assert fig["median"] > 0 and fig["p99"] >= fig["median"] * 0.999
    rt = doc["figures"]["mock_realtime_factor"]
    assert rt["median"] == rt["p99"] and rt["unit"] == "x"
    assert "estimate_4tips_ms" in capsys.readouterr().out


def test_unknown_figure_is_a_one_line_error(capsys):
    assert main(["bench", "--only", "warp_speed"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warp_speed" in err[0]
