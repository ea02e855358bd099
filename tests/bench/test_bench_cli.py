"""`bench`: figure discovery, the JSON contract of docs/design.md 5.6, bad names."""

from __future__ import annotations

import json

from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.bench.runner import all_figures
from grasp_ctrl.cli import main

STABLE = {"estimate_4tips_ms", "control_tick_ms", "dxl_cycle_16_ms", "mock_realtime_factor", "trial_realtime_factor"}


def test_stable_figure_names_are_registered():
    assert STABLE <= set(all_figures())


def test_bench_json_contract(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert (
        main(
            [
                "bench",
                "--quick",
                "--only",
                "estimate_4tips_ms,mock_realtime_factor,trial_realtime_factor",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    doc = json.loads(out.read_text())
    assert set(doc) == {"machine", "figures"} and isinstance(doc["machine"], str)
    assert set(doc["figures"]) == {"estimate_4tips_ms", "mock_realtime_factor", "trial_realtime_factor"}
    for fig in doc["figures"].values():
        assert set(fig) == {"median", "p99", "unit"} and fig["median"] > 0
    # A time's p99 is its slow tail above the median; a rate's slow tail is below it.
    assert doc["figures"]["estimate_4tips_ms"]["p99"] >= doc["figures"]["estimate_4tips_ms"]["median"]
    for rate in ("mock_realtime_factor", "trial_realtime_factor"):
        rt = doc["figures"][rate]
        assert 0 < rt["p99"] <= rt["median"] and rt["unit"] == "x"
    assert "estimate_4tips_ms" in capsys.readouterr().out


def test_rate_percentiles_are_the_slow_tail():
    fig = Figure.rate([100.0, 200.0, 300.0, 400.0, 500.0], "x")
    assert fig.median == 300.0 and 100.0 <= fig.p99 < 120.0


def test_unknown_figure_is_a_one_line_error(capsys):
    assert main(["bench", "--only", "warp_speed"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warp_speed" in err[0]
