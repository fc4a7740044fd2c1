"""``pedvr measure`` and ``pedvr bench realism``: outputs, plots, and one clear line for bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pedvr.cli import main
from pedvr.measure.cases import CASES, DEFAULT_CASES


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short pedvr run of the 1.2 m bottleneck, recorded."""
    out = tmp_path_factory.mktemp("rec")
    path = out / "b120.npz"
    rc = main(["run", "validation/bottleneck_120", "--backend", "headless", "--duration", "12", "--quiet",
               "--record", str(path), "--metrics-json", str(out / "b120.json")])
    assert rc == 0 and path.is_file()
    return path


def test_measure_a_recording_finds_its_case_and_plots(recording: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    plots = tmp_path / "plots"
    assert main(["measure", str(recording), "--json", "--plot", str(plots)]) == 0
    (r,) = json.loads(capsys.readouterr().out)
    assert r["label"].startswith("bottleneck_120 (pedvr") and r["agents"] == 60
    assert r["crossed"] >= 5  # people pass the bottleneck's mouth within 12 s
    assert r["flow_per_s"] is not None and 0.3 < r["flow_per_s"] < 5.0
    names = sorted(p.name for p in plots.iterdir())
    assert names == ["bottleneck_120_density_speed.png", "bottleneck_120_fd.png", "bottleneck_120_nt.png",
                     "bottleneck_120_setup.png"]
    assert all((plots / n).stat().st_size > 5000 for n in names)  # real figures, not empty files


def test_measure_table_and_explicit_area_and_line(recording: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["measure", str(recording), "--area", "-0.5", "0.5", "0.5", "1.3", "--line", "0.75", "0", "-0.75", "0",
                 "--steady", "2", "12"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("| run | agents | crossed | flow_per_s |") and "bottleneck_120 (pedvr" in out


@pytest.mark.parametrize(("argv", "match"), [
    (["measure"], "give INPUT files, or --case NAME"),
    (["measure", "nowhere.npz"], "nowhere.npz: no such recording"),
    (["measure", "nowhere.txt", "--case", "uo_070"], "nowhere.txt: no such trajectory file"),
    (["measure", "--case", "uo_999"], "case 'uo_999': unknown; known: uo_070"),
    (["measure", "REC", "--area", "1", "1", "0", "0"], r"--area 1.0 1.0 0.0 0.0: expected X0 Y0 X1 Y1 with X1 > X0"),
    (["measure", "REC", "--line", "0", "0", "0", "0"], "--line 0.0 0.0 0.0 0.0: the two points must differ"),
    (["measure", "REC", "--area", "50", "50", "51", "51"], "lies outside the walkable area"),
    (["measure", "--case", "uo_070", "--data", "/no/such/folder"], "--data /no/such/folder: no such folder"),
    (["bench", "realism", "--models", "vadere"], "--models 'vadere': unknown; known: pedvr, decoupled"),
    (["bench", "realism", "--cases", "nope"], "case 'nope': unknown"),
])
def test_bad_input_is_one_line(argv: list[str], match: str, recording: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    argv = [str(recording) if a == "REC" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pedvr: error: "), err
    assert __import__("re").search(match, err[0]), err[0]


def test_a_file_that_is_no_recording(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "x.npz"
    np.savez(bad, a=np.zeros(3))
    assert main(["measure", str(bad)]) == 2
    assert "x.npz: not a pedvr recording (no t, ids, pos, is_user, meta)" in capsys.readouterr().err


def test_bench_realism_runs_a_short_case(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.json"
    assert main(["bench", "realism", "--cases", "bottleneck_100", "--models", "pedvr", "--duration", "8",
                 "--json", "--out", str(out)]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r == json.loads(out.read_text())
    (case,) = r["cases"]
    run = case["runs"]["pedvr"]
    assert run["measures"]["passed_of"] == 60 and run["run"]["overlaps_over_1cm"] == 0
    flow = run["references"]["flow_per_s"]
    assert flow["published"] == pytest.approx(1.9)
    if flow["value"] is not None:
        assert flow["rel_error_published"] == pytest.approx((flow["value"] - 1.9) / 1.9, abs=1e-3)


def test_every_case_has_its_scene_and_a_reference() -> None:
    assert set(DEFAULT_CASES) <= set(CASES)
    for c in CASES.values():
        assert c.scene_path().is_file()
        assert c.real is not None or c.published, c.name  # something to compare with


def test_jupedsim_runs_the_same_case() -> None:
    """JuPedSim (the bench extra) in the same walkable area, start positions and sources."""
    pytest.importorskip("jupedsim", reason="jupedsim comes with the bench extra: pip install -e '.[bench]'")
    from pedvr.measure.cases import get_case
    from pedvr.measure.realism import run_jupedsim

    run, info = run_jupedsim(get_case("bottleneck_120"), model="jupedsim-cfsm", duration=10.0, seed=None)
    assert run.agents == 60 and info["agents_added"] == 60  # the scene's 60 start positions
    first = run.traj.data[run.traj.data.frame == run.traj.data.frame.min()]
    assert first.y.min() >= 2.9  # they start where pedvr's do: 3 m and more in front of the mouth
    run2, info2 = run_jupedsim(get_case("counterflow_400"), model="jupedsim-cfsm", duration=6.0, seed=None,
                               radius=0.2)
    assert info2["agents_added"] >= 4  # both sources have begun (east from 3.76 s, west from 5.92 s)
