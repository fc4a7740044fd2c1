"""``pedvr sweep report DIR``: a plot of each varying metric against each swept parameter, with CIs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pedvr.cli import main
from pedvr.sweep.report import confidence_interval
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
    assert "| metric | condition = decoupled | condition = pedvr |" in text
    # The coupled condition limits acceleration; decoupled ORCA does not: a metric that must vary.
    for axis in ("condition", "steering.time_horizon"):
        png = out / "report" / "plots" / f"max_accel_mps2__{axis}.png"
        assert f"(plots/{png.name})" in text
        with Image.open(png) as im:
            assert im.size == (500, 340)
            assert len(np.unique(np.asarray(im.convert("L")))) > 10  # drawn, not blank
    # Metrics equal in every run are listed, not plotted.
    assert "`overlaps_over_1cm` = 0" in text
    assert not (out / "report" / "plots" / "overlaps_over_1cm__condition.png").exists()


def test_a_broken_table_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "runs.parquet").write_bytes(b"not parquet")
    assert main(["sweep", "report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(
        f"pedvr: error: {tmp_path}/runs.parquet: not a readable Parquet table"
    )
