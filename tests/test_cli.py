"""The command line: the headless run's outputs, and one clear line for every bad input."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pedvr.cli import main

METRIC_KEYS = {"steps", "agents", "max_overlap_m", "overlaps_over_1cm", "min_user_distance_m", "arrivals",
               "mean_speed_mps", "max_accel_mps2", "max_turn_rate_radps", "step_ms_p50", "step_ms_p95"}


def test_headless_run_writes_recording_and_metrics(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rec, met = tmp_path / "r.npz", tmp_path / "m.json"
    code = main(["run", "headon_corridor", "--backend", "headless", "--duration", "2", "--seed", "4",
                 "--condition", "decoupled", "--responsibility", "0.25", "--record", str(rec),
                 "--metrics-json", str(met), "--quiet"])
    assert code == 0
    out = capsys.readouterr().out
    assert out.startswith("backend: headless (asked for with --backend headless)")
    m = json.loads(met.read_text())
    assert METRIC_KEYS <= set(m)
    assert m["steps"] == 180 and m["agents"] == 1 and m["seed"] == 4 and m["responsibility"] == 0.25
    with np.load(rec) as z:
        meta = json.loads(str(z["meta"]))
        assert meta["seed"] == 4 and meta["condition"] == "decoupled" and len(meta["scene_hash"]) == 16
        assert z["pos"].shape == (181, 2, 2) and z["heading"].shape == (181, 2)
        assert z["is_user"].sum() == 1


@pytest.mark.parametrize("sig, code, said", [(signal.SIGINT, 130, True), (signal.SIGTERM, 143, "SIGTERM"),
                                             (signal.SIGHUP, 129, "SIGHUP")], ids=["Ctrl-C", "SIGTERM", "SIGHUP"])
def test_an_interrupted_run_keeps_its_outputs_and_exits_as_the_signal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, sig: int, code: int,
    said: object,
) -> None:
    """A run ended early writes what it has and exits 128 + the signal (as ``pedvr study run``
    does), not 0: ``pedvr run ... && next`` must not go on as if the run had finished."""
    from pedvr.sim import Simulation

    step = Simulation.step
    count = [0]

    def stepping(self: Simulation) -> None:
        step(self)
        count[0] += 1
        if count[0] == 40:
            os.kill(os.getpid(), sig)

    monkeypatch.setattr(Simulation, "step", stepping)
    assert main(["run", "headon_corridor", "--backend", "headless", "--duration", "60", "--out", str(tmp_path),
                 "--quiet"]) == code
    m = json.loads(next(tmp_path.glob("*.json")).read_text())
    assert m["interrupted"] == said and 40 <= m["steps"] < 60 * 90
    assert "interrupted by" in capsys.readouterr().out
    with np.load(next(tmp_path.glob("*.npz"))) as z:
        assert z["pos"].shape[0] == m["steps"] + 1


def test_auto_backend_falls_back_to_headless_and_says_why(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["run", "--duration", "0.5", "--out", str(tmp_path), "--quiet"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("backend: headless (no OpenXR: ") and "no desktop: no display (DISPLAY is not set)" in first
    assert len(list(tmp_path.glob("antipodal_circle-seed7-pedvr.*"))) == 2


@pytest.mark.parametrize("argv, code, message", [
    (["run", "--responsibility", "2"], 2, r"argument --responsibility: '2' must be in \[0, 1\]"),
    (["run", "--duration", "-1"], 2, r"argument --duration: '-1' must be > 0"),
    (["run", "--condition", "fast"], 2, r"argument --condition: invalid choice: 'fast'"),
    (["run", "no/such/scene.toml"], 2, r"no/such/scene\.toml: no such scene file"),
    (["run", "--backend", "xr"], 3, r"cannot start the OpenXR backend: .*; use --backend headless"),
    (["run", "--backend", "desktop"], 3, r"cannot open a desktop window: .*; use --backend headless"),
    (["frobnicate"], 2, r"invalid choice: 'frobnicate'"),
    (["run", "--duration", "nan"], 2, r"^pedvr: error: run: argument --duration: 'nan' must be a finite number > 0"),
    (["run", "--duration", "inf", "--frames", "x"], 2, r"argument --duration: 'inf' must be a finite number > 0"),
    (["run", "--frames", "/proc/nope"], 2, r"--frames /proc/nope: cannot create the folder \("),
    (["run", "--video", "/proc/x.mp4"], 2, r"--video folder /proc: the folder is not writable \("),
    (["run", "--record", "/proc/r.npz"], 2, r"--record folder /proc: the folder is not writable \("),
    (["run", "--personal-space", "3"], 2, r"argument --personal-space: '3' must be in \[0, 2\] m"),
    (["run", "--user-walk", "zigzag"], 2, r"argument --user-walk: invalid choice: 'zigzag'"),
    ([], 2, r"^pedvr: error: the following arguments are required: COMMAND; see 'pedvr --help'$"),
    (["run", "--seed", "x"], 2, r"^pedvr: error: run: argument --seed: 'x' is not an integer; see 'pedvr run --help'$"),
    # issue 24.2: numpy's generators take no negative seed; one line, not numpy's ValueError
    (["run", "headon_corridor", "--seed", "-3"], 2,
     r"^pedvr: error: run: argument --seed: '-3' must be an integer >= 0; see 'pedvr run --help'$"),
    # the sub-commands' numbers are parsed as pedvr run's are (pedvr.argtypes): inf is refused too
    (["bench", "sweep", "--duration", "inf"], 2, r"argument --duration: 'inf' must be a finite number > 0"),
    (["bench", "sweep", "--workers", "-1"], 2, r"argument --workers: '-1' must be an integer >= 0"),
    (["bench", "render", "--fovy", "180"], 2, r"argument --fovy: '180' must be between 0 and 180 degrees"),
    (["bench", "render", "--fovy", "wide"], 2, r"argument --fovy: 'wide' is not a number"),
    (["bench", "render", "--warmup", "-1"], 2, r"argument --warmup: '-1' must be an integer >= 0"),
    (["measure", "--cutoff", "inf"], 2, r"argument --cutoff: 'inf' must be a finite number > 0"),
    (["study", "run", "p.toml", "--participant", "P1", "--pace", "nan"], 2,
     r"argument --pace: 'nan' must be a finite number > 0"),
])
def test_bad_input_is_one_clear_line(argv: list[str], code: int, message: str,
                                     capsys: pytest.CaptureFixture) -> None:
    import re

    assert main(argv) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pedvr: error: ")
    assert re.search(message, err[0]), err[0]


def test_out_that_is_a_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    f = tmp_path / "taken"
    f.write_text("not a folder")
    assert main(["run", "--out", str(f), "--duration", "0.1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"pedvr: error: --out {f}: exists and is not a folder"]
    assert main(["run", "--record", str(tmp_path), "--duration", "0.1", "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == f"pedvr: error: --record {tmp_path}: is a folder; give a file name"


def test_version_help_and_names(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from pedvr.cli import _version

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"pedvr {_version()}"
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    helptext = capsys.readouterr().out
    assert "(default: pedvr)" in helptext and "(default: antipodal_circle)" in helptext
    assert "pedvr+g    coupled, and agents look at the user" in helptext
    assert main(["run", "headon_corridor", "--condition", "pedvr+g", "--duration", "0.1", "--quiet",
                 "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["headon_corridor-seed3-pedvr-g.json",
                                                          "headon_corridor-seed3-pedvr-g.npz"]
    capsys.readouterr()
    assert main(["scene", "check", "scenes/headon_corridor.toml"]) == 0
    assert "1 agent, 0 obstacles, 2 states" in capsys.readouterr().out


def test_python_dash_m_and_no_traceback_on_bad_scene(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[scene]\nname = "b"\nseed = 1\nduration = 5\n')
    r = subprocess.run([sys.executable, "-m", "pedvr", "run", str(bad), "--backend", "headless"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert all(line.startswith(f"pedvr: error: {bad}: ") for line in lines)
    assert any("world = <missing>: required table" in line for line in lines)
    assert any("user = <missing>: required table" in line for line in lines)


def test_run_help_says_each_default_once(capsys: pytest.CaptureFixture) -> None:
    """Issue 25.14: an option whose help names its default got argparse's "(default: None)" too."""
    import re

    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines; compare words
    assert "(default: None)" not in text and "(default: False)" not in text
    options = re.split(r" (?=--[a-z-]+ )", text)
    duration = next(o for o in options if o.startswith("--duration DURATION"))
    assert duration.count("(default") == 1 and "(default: the scene's duration)" in duration
    assert "(default: pedvr)" in text and "(default: 30.0)" in text  # plain defaults are still shown
    for o in options:
        assert o.count("(default") <= 1, o


def test_version_is_0_2_0_from_one_place(capsys: pytest.CaptureFixture) -> None:
    """Issue 25.8: README says pedvr 0.2, pyproject said 0.1.0; now pyproject reads pedvr.__version__."""
    import tomllib

    import pedvr

    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == "pedvr 0.2.0" == f"pedvr {pedvr.__version__}"
    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "pedvr.__version__"}


STEERSUITE_NO_USER = """<SteerBenchTestCase xmlns="http://www.magix.ucla.edu/steerbench">
  <header><version>1.0</version><name>lone</name>
    <worldBounds><xmin>-10</xmin><xmax>10</xmax><ymin>0</ymin><ymax>0</ymax><zmin>-10</zmin><zmax>10</zmax></worldBounds>
  </header>
  <agent><name>A</name>
    <initialConditions><radius>0.5</radius><position><x>-3</x><y>0</y><z>0</z></position>
      <direction><x>1</x><y>0</y><z>0</z></direction><speed>0</speed></initialConditions>
    <goalSequence><seekStaticTarget><targetLocation><x>3</x><y>0</y><z>0</z></targetLocation>
      <desiredSpeed>1.3</desiredSpeed><timeDuration>1000.0</timeDuration></seekStaticTarget></goalSequence>
  </agent>
</SteerBenchTestCase>
"""


def test_a_case_without_a_user_says_so(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Issue 25.15: a SteerSuite case has no user; the summary printed "min distance to user None m"."""
    case = tmp_path / "lone.xml"
    case.write_text(STEERSUITE_NO_USER)
    assert main(["run", str(case), "--backend", "headless", "--duration", "0.2", "--quiet",
                 "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "None" not in out and "into the user" not in out
    assert "agents 1, arrivals 0, mean speed" in out and ", no user in the scene\n" in out
    assert main(["run", "headon_corridor", "--duration", "0.2", "--quiet", "--out", str(tmp_path / "o2")]) == 0
    assert re.search(r"min distance to user \d+\.\d+ m\n", capsys.readouterr().out)
