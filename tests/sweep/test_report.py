"""``pedvr sweep report DIR``: the measures that matter against each swept parameter, the other parameters
as series and facets (issue 25.10), with CIs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from pedvr.cli import main
from pedvr.sweep.errors import SweepError
from pedvr.sweep.report import MEASURES, confidence_interval, write_sweep_report
from tests.sweep.conftest import write_spec


def test_confidence_interval_is_students_t() -> None:
    from scipy import stats

    v = np.array([1.0, 2.0, 4.0, 7.0, np.nan])
    mean, half, n = confidence_interval(v)
    lo, hi = stats.t.interval(0.95, 3, loc=3.5, scale=stats.sem(v[:4]))
    assert (mean, n) == (3.5, 4) and half == pytest.approx((hi - lo) / 2)
    assert np.isnan(confidence_interval(np.array([2.0]))[1])


def test_report_writes_plots_and_markdown(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = write_spec(
        tmp_path,
        """
[sweep]
name = "rep"
scenes = ["headon_corridor"]
duration = 0.4
seeds = [1, 2, 3]
[sweep.grid]
condition = ["decoupled", "pedvr"]
"steering.time_horizon" = [1.0, 3.0]
""",
    )
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--workers", "0", "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "12 of 12 runs ran now (12 ok, 0 failed, 0 lost)" in printed
    assert main(["sweep", "report", str(out)]) == 0
    md = out / "report" / "report.md"
    assert f"report: {md}" in capsys.readouterr().out
    text = md.read_text()
    assert "Rows: 12 of 12 planned; 12 ok, 0 failed, 0 lost." in text
    assert "## Against `condition`" in text and "## Against `steering.time_horizon`" in text
    assert "Mean over seeds and 95 % CI; one line per `steering.time_horizon`." in text
    assert "| measure | steering.time_horizon | condition = decoupled | condition = pedvr |" in text
    # The coupled condition limits acceleration; decoupled ORCA does not: a measure that must vary.
    assert re.search(r"\| `max_accel_mps2` \| 1\.0 \| [\d.]+ ± [\d.]+ \| 2\.2 ± 0 \|", text), text
    for axis in ("condition", "steering.time_horizon"):
        png = out / "report" / "plots" / f"by_{axis}.png"
        assert f"(plots/{png.name})" in text
        with Image.open(png) as im:
            grey = np.asarray(im.convert("L"))
            assert im.size[0] == 430 and im.size[1] > 300  # one column of panels, a row per measure
            assert len(np.unique(grey)) > 10  # drawn, not blank
    # Measures only: never the machine's timings, never the parameters themselves (issue 25.10).
    cells = pd.read_csv(out / "report" / "summary.csv")
    assert set(cells["measure"]) <= set(MEASURES) and "max_accel_mps2" in set(cells["measure"])
    assert "`wall_s`" in text.split("Varying metrics not plotted")[1]
    # Metrics equal in every run are listed, not plotted.
    assert "`overlaps_over_1cm` = 0" in text and "overlaps_over_1cm" not in set(cells["measure"])
    assert "Code: pedvr 0.2.0" in text


def _synthetic(folder: Path) -> Path:
    """A table of 2 scenes × a × b × c × 3 seeds where the measure is 1 only when a = 1 and b = 1: an
    interaction, which a plot averaging over b shows as 0.5 (the rows are written by the real table)."""
    from pedvr.sweep.runner import MANIFEST
    from pedvr.sweep.table import ResultTable

    folder.mkdir()
    rows = []
    for scene in ("s1", "s2"):
        for a in (0, 1):
            for b in (0, 1):
                for c in ("x", "y"):
                    for seed in (1, 2, 3):
                        rows.append(
                            {
                                "run_key": f"{scene}{a}{b}{c}{seed}",
                                "scene": scene,
                                "seed": seed,
                                "duration": 1.0,
                                "a": a,
                                "b": b,
                                "c": c,
                                "pedvr_version": "0.2.0",
                                "status": "ok",
                                "error": None,
                                "mean_speed_mps": float(a * b) + 0.01 * seed,
                                "arrivals": seed,
                                "wall_s": 1.0 + seed,
                                "other_metric": float(seed),
                            }
                        )
    table = ResultTable(folder)
    for r in rows:
        table.add(r)
    table.flush()
    (folder / MANIFEST).write_text(
        json.dumps(
            {
                "name": "syn",
                "kind": "runs",
                "tasks": len(rows),
                "parameters": ["a", "b", "c", "duration"],
                "swept": ["a", "b", "c"],
            }
        )
    )
    return folder


def test_interactions_show_as_series_and_facets(tmp_path: Path) -> None:
    folder = _synthetic(tmp_path / "syn")
    md = write_sweep_report(folder).read_text()
    cells = pd.read_csv(folder / "report" / "summary.csv")
    on_a = cells[(cells["x"] == "a") & (cells["measure"] == "mean_speed_mps")]
    # x = a, one line per b, one column of panels per c, averaged over scene (the fourth factor).
    assert set(on_a["series"]) == {"b"} and set(on_a["facet"]) == {"c"}
    got = {
        (str(r.series_value), str(r.facet_value), str(r.x_value)): round(r.mean, 6) for r in on_a.itertuples()
    }
    assert got[("1", "x", "1")] == pytest.approx(1.02) and got[("0", "x", "1")] == pytest.approx(0.02)
    assert got[("1", "y", "0")] == pytest.approx(0.02)
    assert set(on_a["n"]) == {6}  # 3 seeds × 2 scenes
    assert (
        "Mean over seeds and 95 % CI; one line per `b`; one column of panels per `c`; averaged over `scene`."
        in md
    )
    assert "| `mean_speed_mps` | 1 | x | 0.02 ± " in md  # series b = 1, facet c = x, at a = 0
    for x in ("a", "b", "c", "scene"):
        with Image.open(folder / "report" / "plots" / f"by_{x}.png") as im:
            assert im.size[1] > 300 and len(np.unique(np.asarray(im.convert("L")))) > 10
    assert set(cells["measure"]) == {"mean_speed_mps", "arrivals"}  # timings and unknown metrics: not plotted
    assert (
        "Varying metrics not plotted (`pedvr sweep report DIR --metric NAME` plots them): `other_metric`, `wall_s`."
        in md
    )
    write_sweep_report(folder, metrics=["other_metric"])
    assert set(pd.read_csv(folder / "report" / "summary.csv")["measure"]) == {"other_metric"}
    with pytest.raises(
        SweepError, match=r"--metric nope: not a numeric column of .*runs\.parquet; numeric columns: a, "
    ):
        write_sweep_report(folder, metrics=["nope"])


def test_metric_flag_applies_to_the_report_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _synthetic(tmp_path / "syn")
    assert main(["sweep", "report", str(folder), "--metric", "other_metric"]) == 0
    capsys.readouterr()
    assert main(["sweep", str(tmp_path / "x.toml"), "--metric", "wall_s"]) == 2
    assert capsys.readouterr().err == (
        "pedvr: error: pedvr sweep: --metric applies to the report: pedvr sweep report DIR --metric NAME\n"
    )


def test_a_broken_table_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "runs.parquet").write_bytes(b"not parquet")
    assert main(["sweep", "report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"pedvr: error: {tmp_path}/runs.parquet: not a readable Parquet table"
    )
