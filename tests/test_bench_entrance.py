"""``bench/entrance_observations.py``: its measures on a recording whose answers are known, a pedvr
run's report, and one-line errors for bad flags and a data folder without the recordings."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "bench" / "entrance_observations.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)


def test_a_known_recording_and_a_pedvr_run(tmp_path: Path) -> None:
    # ten people walk down the corridor's centre line at 1 m/s, one a second: a Jülich-style file
    # (id frame x y z, cm, 16 frames/s) whose crossings of y = 7.5 m are 1 s apart at 1 m/s
    folder = tmp_path / "uni-directional"
    folder.mkdir()
    rows = []
    for pid in range(1, 11):
        for f in range(64):  # 4 s from y = 9.5 m
            t = f / 16.0
            rows.append((pid, 16 * (pid - 1) + f, 90.0, 100.0 * (9.5 - t), 170.0))
    np.savetxt(folder / "uo-070-180-180.txt", np.array(rows), fmt="%d %d %.3f %.3f %.3f")
    r = _run("--data", str(tmp_path), "--seeds", "1", "--until", "12")
    assert r.returncode == 0, r.stderr
    real, run = (json.loads(line) for line in r.stdout.splitlines())
    assert real["real"] == "uo-070-180-180.txt" and real["crossed"] == 10
    assert real["gap_median_s"] == pytest.approx(1.0, abs=0.07) and real["gap_mean_s"] == pytest.approx(1.0, abs=0.07)
    assert real["speed_median"] == pytest.approx(1.0, abs=0.02)
    assert real["accel_p99"] < 0.05  # steady walking: no acceleration, the tracks' ends left out
    assert run["pedvr"] == "validation/uo_070" and run["seed"] == 1 and run["crossed"] > 0
    assert 0.0 < run["before_mouth_speed"] < 2.0 and 0.0 <= run["before_mouth_dense"] <= 1.0


@pytest.mark.parametrize(("args", "message"), [
    (["--seeds", "-1"], "argument --seeds: '-1' must be an integer >= 0"),
    (["--until", "0"], "argument --until: '0' must be > 0"),
])
def test_a_bad_flag_is_one_line(args: list[str], message: str) -> None:
    r = _run(*args)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip().splitlines()[-1].endswith(message), r.stderr


def test_a_data_folder_without_the_recordings_is_one_line(tmp_path: Path) -> None:
    r = _run("--data", str(tmp_path))
    assert r.returncode == 2 and r.stdout == ""
    last = r.stderr.strip().splitlines()[-1]
    assert f"--data {tmp_path}: no {tmp_path}/uni-directional/uo-*.txt" in last, r.stderr
    assert "Traceback" not in r.stderr
