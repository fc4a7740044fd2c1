"""The behavior benchmark runs and reports its keys (speed goals live in the benchmark, not here)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from pedvr.behavior.bench import WANDER, _count, run_behavior_bench
from pedvr.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_bench_behavior_runs_trees_and_events() -> None:
    r = run_behavior_bench(12, events=2, seconds=1.0, warmup=0.5)
    assert r["personal_tree_nodes"] == _count(WANDER) == 18
    assert r["ticks"] == 30 and r["trees_total"] == 14
    assert r["events_running_mean"] == 2.0
    assert 0 < float(r["tick_cpu_ms_mean"]) and float(r["tick_ms_p50"]) <= float(r["tick_ms_p95"])  # type: ignore[arg-type]


def test_bench_behavior_cli_rejects_bad_events(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "behavior", "--events", "99"]) == 2
    assert "--events 99: expected 0 to 70" in capsys.readouterr().err


def test_pytrees_comparison_script_runs() -> None:
    pytest.importorskip("py_trees", reason="py_trees comes with the bench extra: pip install -e '.[bench]'")
    p = subprocess.run([sys.executable, str(ROOT / "bench" / "behavior_pytrees.py"), "--agents", "10", "--ticks", "20"],
                       capture_output=True, text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["py_trees_ms_per_tick"] > 0 and out["pedvr_ms_per_tick"] > 0
