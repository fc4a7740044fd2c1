"""``pedvr bench sim`` runs what it says, ``--load K`` runs K busy processes beside it and stops
them, and bad flags are one line (the figures themselves are not asserted: benchmarks, not tests)."""

from __future__ import annotations

import json
import time

import pytest

from pedvr.bench_sim import plaza_scene, run_sim_bench
from pedvr.benchload import cpu_load
from pedvr.cli import main
from pedvr.errors import UsageError
from pedvr.sim import PHASES


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except FileNotFoundError:
        return False


def test_busy_processes_run_during_the_block_and_are_gone_after() -> None:
    with cpu_load(2) as load:
        assert len(load.pids) == 2 and all(_alive(p) for p in load.pids)
        time.sleep(0.2)
        cpu = []
        for p in load.pids:
            with open(f"/proc/{p}/stat") as fh:
                fields = fh.read().split()
            cpu.append(int(fields[13]) + int(fields[14]))  # utime + stime in clock ticks: they spin
        assert min(cpu) > 0
    assert not any(_alive(p) for p in load.pids)
    with cpu_load(0) as none:
        assert none.pids == []


def test_bench_sim_reports_every_phase_and_the_body_apart_from_the_contacts() -> None:
    r = run_sim_bench(12, steps=6, warmup=2, load=1)
    assert r["agents"] == 12 and r["steps"] == 6 and r["condition"] == "pedvr+g" and r["load_processes"] == 1
    phases = r["phase_ms_mean"]
    assert isinstance(phases, dict) and set(phases) == set(PHASES)
    assert 0 < r["step_ms_p50"] <= r["step_ms_p95"]  # type: ignore[operator]
    assert 0 < r["body_ms_mean"] <= phases["animate"]  # type: ignore[operator]
    assert 0 <= r["contact_ms_mean"] <= phases["animate"]  # type: ignore[operator]
    assert r["overlaps_over_1cm"] == 0


def test_plaza_scales_with_the_crowd() -> None:
    small, big = plaza_scene(10), plaza_scene(1000)
    assert sum(s.count for s in big.spawns) == 1000
    assert big.world.bounds[1][0] > 2.0 * small.world.bounds[1][0]
    with pytest.raises(UsageError, match=r"--agents 0: expected a whole number of agents >= 1"):
        plaza_scene(0)


def test_cli_bench_sim_json_and_bad_flags(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "sim", "--agents", "8", "--steps", "3", "--warmup", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["agents"] == 8 and out["load_processes"] == 0
    assert main(["bench", "sim", "--agents", "8", "--load", "-1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "pedvr: error: --load -1: expected a whole number of busy processes from 0 to 64")
    assert main(["bench", "sim", "--agents", "8", "--warmup", "-3"]) == 2
    assert capsys.readouterr().err.strip() == "pedvr: error: --warmup -3: expected a whole number >= 0"
