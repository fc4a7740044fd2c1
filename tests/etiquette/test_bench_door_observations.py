"""``bench/door_observations.py`` names an observation it does not have, rather than running nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_an_unknown_observation_is_one_clear_error() -> None:
    # "deadlock" is two observations, deadlock6 and deadlock12; asked for, it used to be skipped in silence
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "door_observations.py"), "--only", "deadlock", "rush"],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines()[-1] == (
        "door_observations.py: error: --only deadlock: no such observation; expected some of interleave, "
        "late_group, hurried, double, revolving, deadlock6, deadlock12, rush, single_flow, double_flow, "
        "double_queue, pram, lone_pram, user_pram")
