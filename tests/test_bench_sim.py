"""``pedvr bench sim`` runs what it says, ``--load K`` runs K busy processes beside it and stops
them, and bad flags are one line (the figures themselves are not asserted: benchmarks, not tests)."""

from __future__ import annotations

import json
import sys
import time

import numpy as np
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
    # --load repeats like bench steering's: one run per value, quiet and loaded side by side
    assert main(["bench", "sim", "--agents", "8", "--steps", "2", "--warmup", "1", "--load", "0", "--load", "1",
                 "--json"]) == 0
    assert [r["load_processes"] for r in json.loads(capsys.readouterr().out)] == [0, 1]
    assert main(["bench", "sim", "--agents", "8", "--load", "-1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "pedvr: error: --load -1: expected a whole number of busy processes from 0 to 64")
    assert main(["bench", "sim", "--agents", "8", "--warmup", "-3"]) == 2
    assert capsys.readouterr().err.strip() == "pedvr: error: --warmup -3: expected a whole number >= 0"


def test_vs_rvo2_steers_the_same_crowd_in_the_same_loop() -> None:
    """RVO2 (pyrvo) gets the plaza's crowd each step and is timed beside the whole step."""
    pytest.importorskip("pyrvo")
    from pedvr.bench_sim import _Rvo2Mirror
    from pedvr.sim import Simulation

    sim = Simulation(plaza_scene(30, seed=3), condition="pedvr+g")
    for _ in range(5):
        sim.step()
    peer = _Rvo2Mirror(sim)
    rvo = peer.rvo
    assert rvo.get_num_agents() == len(sim.crowd)
    # the walls and four pillars pedvr's ORCA sees (RVO2's obstacle tree may split edges: more vertices)
    rv = np.array([rvo.get_obstacle_vertex(k).to_tuple() for k in range(rvo.get_num_obstacle_vertices())])
    gap = np.hypot(*(sim.obstacles.vertices[:, None, :] - rv[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert len(sim.obstacles) > 4 and gap.max() < 1e-5  # RVO2 keeps single-precision floats
    sim.step()
    peer.step()
    c = sim.crowd
    moved = np.array([rvo.get_agent_position(i).to_tuple() for i in range(len(c))]) - c.pos
    # RVO2 stepped from the crowd's positions: no agent is further than one step at its top speed
    assert np.all(np.hypot(moved[:, 0], moved[:, 1]) <= c.max_speed * sim.dt + 1e-9)
    assert [rvo.get_agent_radius(i) for i in range(len(c))] == c.radius.tolist()
    assert len(peer.ms) == 1 and peer.ms[0] > 0.0

    r = run_sim_bench(20, steps=5, warmup=2, vs="rvo2")
    assert r["vs"] == "rvo2" and 0 < r["rvo2_step_ms_p50"] <= r["rvo2_step_ms_p95"]  # type: ignore[operator]
    assert r["ratio_p50"] == pytest.approx(r["step_ms_p50"] / r["rvo2_step_ms_p50"], rel=0.01)  # type: ignore[operator]
    assert "vs" not in run_sim_bench(8, steps=2, warmup=1)


def test_vs_rvo2_bad_peer_or_no_pyrvo_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(UsageError, match=r"--vs 'orca': expected one of rvo2"):
        run_sim_bench(8, steps=2, warmup=1, vs="orca")
    monkeypatch.setitem(sys.modules, "pyrvo", None)  # as if the bench extra were not installed
    assert main(["bench", "sim", "--agents", "8", "--steps", "2", "--warmup", "1", "--vs", "rvo2"]) == 2
    assert capsys.readouterr().err.strip() == (
        "pedvr: error: --vs rvo2: needs pyrvo, RVO2's binding (pip install 'pedvr[bench]')")
