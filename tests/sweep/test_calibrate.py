"""The calibration sweep (issue 26 item 4, pedvr.sweep.calibrate): its spec's errors, the
space-filling design, the objective and the sensitivity table, and one short run on Dask that
gives what the serial run gives."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pedvr.sweep.calibrate import (
    CalibrationError,
    calibrate,
    design,
    load_calibration,
    objective,
    parse_calibration,
    sensitivity,
)

REPO = Path(__file__).resolve().parents[2]


def _spec(**over: Any) -> dict[str, Any]:
    cal: dict[str, Any] = {"name": "t", "cases": ["uo_070"], "duration": 5.0,
                           "design": {"method": "sobol", "points": 8, "seed": 3},
                           "parameters": {"time_gap": [0.1, 0.6], "depth_ratio": [0.6, 0.9]}}
    for k, v in over.items():
        if k.startswith("design."):
            cal["design"][k.removeprefix("design.")] = v
        else:
            cal[k] = v
    return {"calibration": cal}


def test_the_shipped_spec_loads() -> None:
    spec = load_calibration(REPO / "sweeps" / "calibration.toml")
    assert spec.points == len(design(spec)) and set(spec.cases) <= {"uo_070", "uo_100", "uo_145"}


@pytest.mark.parametrize(("over", "message"), [
    ({"cases": ["uo_071"]}, r"s\.toml: calibration\.cases = \['uo_071'\]: must be a non-empty list of uo_070"),
    ({"parameters": {"tau": [0.1, 1.0]}}, r"calibration\.parameters\.tau = \[0\.1, 1\.0\]: unknown; a \[steering\]"),
    ({"parameters": {"time_gap": [0.6, 0.1]}}, r"parameters\.time_gap = \[0\.6, 0\.1\]: must be \[low, high\]"),
    ({"parameters": {"depth_ratio": [0.3, 0.9]}}, r"parameters\.depth_ratio = \[0\.3, 0\.9\]: .*within \[0\.52, 1"),
    ({"design.points": 6}, r"calibration\.design\.points = 6: must be a power of 2 for a Sobol' design"),
    ({"design.method": "grid"}, r"calibration\.design\.method = 'grid': must be one of sobol, halton, lhs"),
    ({"measures": ["flow"]}, r"calibration\.measures = \['flow'\]: must be a non-empty list of flow_per_s"),
    ({"duration": -1}, r"calibration\.duration = -1: must be simulated seconds"),
])
def test_a_bad_spec_names_its_key(over: dict[str, Any], message: str) -> None:
    with pytest.raises(CalibrationError, match=message):
        parse_calibration(_spec(**over), source="s.toml")


def test_a_bad_spec_is_one_line_on_the_command_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[calibration]\ncases = ["uo_070"]\n[calibration.design]\npoints = 5\n'
                   "[calibration.parameters]\ntime_gap = [0.1, 0.5]\n")
    r = subprocess.run([sys.executable, "-m", "pedvr.sweep.calibrate", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip() == (f"pedvr calibrate: {bad}: calibration.design.points = 5: must be a power of 2 "
                                "for a Sobol' design (its balance needs it)")


@pytest.mark.parametrize("method", ["sobol", "halton", "lhs"])
def test_the_design_fills_the_ranges_and_is_the_same_for_the_same_spec(method: str) -> None:
    spec = parse_calibration(_spec(**{"design.method": method}), source="s.toml")
    pts = design(spec)
    assert pts.shape == (8, 2)
    np.testing.assert_array_equal(pts, design(spec))
    lo, hi = np.array([0.1, 0.6]), np.array([0.6, 0.9])
    assert (pts >= lo).all() and (pts <= hi).all()
    # space-filling: each parameter's range cut in 4 has 2 of the 8 points in every quarter (Sobol',
    # Latin hypercube); Halton's second base is 3, so it only promises every quarter some
    quarter = np.floor((pts - lo) / (hi - lo) * 4).astype(int)
    for k in range(2):
        counts = np.bincount(quarter[:, k], minlength=4)
        assert (counts == 2).all() if method != "halton" else (counts >= 1).all(), (method, pts)
    other = parse_calibration(_spec(**{"design.method": method, "design.seed": 4}), source="s.toml")
    assert not np.array_equal(pts, design(other))


def test_the_objective_is_the_mean_absolute_error_and_a_missing_measure_counts_fully() -> None:
    rows: list[dict[str, Any]] = [{"errors": {"flow_per_s": -0.2, "speed_mps": 0.1}},
                                  {"errors": {"flow_per_s": 1.0, "speed_mps": None}}]
    assert objective(rows) == pytest.approx((0.2 + 0.1 + 1.0) / 3)
    assert math.isinf(objective([{"errors": {"flow_per_s": None}}]))


def test_sensitivity_finds_the_parameter_that_matters() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, 1.0, (16, 3))
    y = 2.0 * x[:, 1] + 0.01 * rng.normal(size=16)
    table = {s["parameter"]: s for s in sensitivity(x, y, ["a", "b", "c"], {"e": -x[:, 1]})}
    assert table["b"]["spearman_objective"] > 0.99 and table["b"]["spearman e"] == -1.0
    assert table["b"]["src_objective"] > 0.99 and table["b"]["r2_linear"] > 0.99
    assert abs(table["a"]["src_objective"]) < 0.05 and abs(table["c"]["src_objective"]) < 0.05
    flat = sensitivity(x, np.ones(16), ["a", "b", "c"])
    assert flat[0]["spearman_objective"] is None and flat[0]["r2_linear"] is None  # nothing to explain


def test_a_short_calibration_on_dask_is_the_serial_one(cluster_client: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two points of the 0.5 m bottleneck against its published flow (no real data given): every
    point's error is its run's flow against 1.15 /s, Dask and serial agree to the byte."""
    spec = parse_calibration({"calibration": {
        "name": "short", "cases": ["bottleneck_050"], "measures": ["flow_per_s"], "duration": 20.0,
        "design": {"method": "lhs", "points": 2, "seed": 1}, "parameters": {"time_gap": [0.1, 0.5]}}},
        source="short.toml")
    monkeypatch.delenv("PEDVR_REAL_DATA", raising=False)
    serial = calibrate(spec, workers=0, data=None)
    on_dask = calibrate(spec, client=cluster_client, data=None)
    assert json.dumps(serial["points"]) == json.dumps(on_dask["points"])
    assert serial["references"] == {"bottleneck_050": "published"}
    for p in serial["points"]:
        flow = p["values"]["bottleneck_050 flow_per_s"]
        assert flow is not None and flow > 0.2
        assert p["errors"]["bottleneck_050 flow_per_s"] == pytest.approx((flow - 1.15) / 1.15, abs=1e-4)
        assert p["objective"] == pytest.approx(abs(p["errors"]["bottleneck_050 flow_per_s"]), abs=1e-4)
        assert p["overlaps_over_1cm"] == 0
    assert serial["best"]["objective"] == min(p["objective"] for p in serial["points"])
