"""Sweeps on a 2-worker LocalCluster: results equal the serial in-process runs, a worker killed
mid-sweep changes nothing, an interrupted sweep resumes with only the missing runs, a run that
raises is a row with its error, recordings are kept one file per run."""

from __future__ import annotations

import json
import os
import re
import signal
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from pedvr.sweep.errors import SweepError
from pedvr.sweep.runner import run_sweep
from pedvr.sweep.spec import SweepSpec, load_spec
from pedvr.sweep.table import read_table
from pedvr.sweep.task import is_timing
from tests.sweep.conftest import SMALL, write_spec


def _frame(folder: Path) -> pd.DataFrame:
    df = read_table(folder).to_pandas()
    df = df[[c for c in df.columns if not is_timing(c)]]
    return df.sort_values("run_key").reset_index(drop=True)[sorted(c for c in df.columns if not is_timing(c))]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> tuple[SweepSpec, pd.DataFrame]:
    """The 12-run spec and its table done serially in this process (the reference)."""
    folder = tmp_path_factory.mktemp("small")
    spec = load_spec(write_spec(folder, SMALL.format(duration=0.6)))
    outcome = run_sweep(spec, out=folder / "serial", workers=0, progress=False)
    assert outcome.ok == 12 and outcome.where == "this process, serially"
    return spec, _frame(folder / "serial")


def test_two_workers_equal_serial(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    spec, serial = small
    outcome = run_sweep(spec, out=tmp_path / "dask", client=cluster_client, progress=False)
    assert (outcome.ran, outcome.ok, outcome.failed, outcome.lost) == (12, 12, 0, 0)
    assert outcome.where == "2 local Dask workers"
    got = _frame(tmp_path / "dask")
    assert len(got) == 12 and set(got["status"]) == {"ok"}
    for col in (
        "responsibility",
        "scene",
        "seed",
        "min_user_distance_m",
        "overlaps_over_1cm",
        "mean_speed_mps",
    ):
        assert col in got.columns
    assert sorted(got["responsibility"].unique()) == [0.0, 0.5, 1.0]
    assert (got["sim_time_s"] == 0.6).all() and (got["overlaps_over_1cm"] == 0).all()
    pd.testing.assert_frame_equal(got, serial)  # determinism across processes, bit for bit
    meta = json.loads(read_table(tmp_path / "dask").schema.metadata[b"pedvr.sweep"])
    assert meta["swept"] == ["responsibility"] and meta["tasks"] == 12


def test_killed_worker_still_completes(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    spec, serial = small
    killed: list[int] = []

    def kill_a_busy_worker(row: dict[str, Any]) -> None:
        if killed:
            return
        pids = cluster_client.run(os.getpid)
        busy = [w for w, keys in cluster_client.processing().items() if keys]
        victim = pids[busy[0] if busy else next(iter(pids))]
        os.kill(victim, signal.SIGKILL)
        killed.append(victim)

    outcome = run_sweep(
        spec, out=tmp_path / "kill", client=cluster_client, progress=False, on_result=kill_a_busy_worker
    )
    assert killed and outcome.ok == 12 and outcome.lost == 0
    pd.testing.assert_frame_equal(_frame(tmp_path / "kill"), serial)
    cluster_client.wait_for_workers(2, timeout=180)  # the nanny restarts it for the next tests
    assert killed[0] not in cluster_client.run(os.getpid).values()


def test_interrupted_sweep_resumes_only_the_missing_runs(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    spec, serial = small
    seen: list[str] = []

    def interrupt(row: dict[str, Any]) -> None:
        seen.append(row["run_key"])
        if len(seen) == 5:
            raise KeyboardInterrupt

    out = tmp_path / "resume"
    first = run_sweep(spec, out=out, client=cluster_client, progress=False, on_result=interrupt)
    assert first.interrupted and first.ran == 5
    kept = set(read_table(out).column("run_key").to_pylist())
    assert kept == set(seen)  # every finished run was written, none more
    with pytest.raises(SweepError, match="already holds a sweep; continue it with --resume"):
        run_sweep(spec, out=out, client=cluster_client, progress=False)
    ran: list[str] = []
    second = run_sweep(
        spec,
        out=out,
        resume=True,
        client=cluster_client,
        progress=False,
        on_result=lambda row: ran.append(row["run_key"]),
    )
    assert (second.skipped, second.ran, second.ok) == (5, 7, 7) and not second.interrupted
    assert not set(ran) & kept and len(set(ran)) == 7
    pd.testing.assert_frame_equal(_frame(out), serial)
    third = run_sweep(spec, out=out, resume=True, client=cluster_client, progress=False)
    assert (third.skipped, third.ran) == (12, 0)
    other = load_spec(write_spec(tmp_path, SMALL.format(duration=0.7)))
    with pytest.raises(SweepError, match="12 of its rows are runs this spec does not plan"):
        run_sweep(other, out=out, resume=True, workers=0, progress=False)


def _corridor_with_region(folder: Path) -> Path:
    """headon_corridor with its walker drawn from a region (``count`` agents) instead of one position."""
    import tomllib

    import tomli_w

    from pedvr.scenes import resolve_scene

    scene = tomllib.loads(resolve_scene("headon_corridor").read_text())
    spawn = scene["agents"]["spawns"][0]
    del spawn["positions"]
    spawn.update(count=1, region={"box": [4.5, -0.5, 6.0, 0.5]})
    path = folder / "corridor_region.toml"
    path.write_bytes(tomli_w.dumps(scene).encode())
    return path


def test_a_run_that_raises_is_a_row_and_the_sweep_goes_on(cluster_client: Any, tmp_path: Path) -> None:
    # 400 agents do not fit in the spawn region: the scene validates, the run raises in Simulation.
    _corridor_with_region(tmp_path)
    spec = load_spec(
        write_spec(
            tmp_path,
            """
[sweep]
name = "crowded"
scenes = ["corridor_region.toml"]
duration = 0.2
seeds = [1, 2]
keep = "recordings"
[sweep.grid]
"agents.spawns[0].count" = [1, 400]
""",
        )
    )
    outcome = run_sweep(spec, out=tmp_path / "out", client=cluster_client, progress=False)
    assert (outcome.ok, outcome.failed) == (2, 2)
    df = read_table(tmp_path / "out").to_pandas()
    bad = df[df["status"] == "error"]
    assert (bad["agents.spawns[0].count"] == 400).all()
    assert bad["error"].str.contains(r"agents\.spawns\[0\]\.count = 400: only \d+ agents of radius").all()
    assert bad["min_user_distance_m"].isna().all()
    good = df[df["status"] == "ok"]
    for _, row in good.iterrows():  # recordings: one file per run, beside the table
        with np.load(tmp_path / "out" / row["recording"]) as rec:
            meta = json.loads(str(rec["meta"]))
            assert meta["seed"] == row["seed"] and rec["pos"].shape[1] == 2  # the user and one agent
    assert len(outcome.errors) == 2 and "only" in outcome.errors[0]


def test_bench_sweep_reports_both_rates(capsys: pytest.CaptureFixture[str]) -> None:
    from pedvr.cli import main

    assert main(["bench", "sweep", "--runs", "4", "--workers", "2", "--duration", "0.2", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert (r["runs"], r["workers"], r["scene"]) == (4, 2, "headon_corridor")
    assert r["serial_runs_per_min"] > 0 and r["dask_runs_per_min"] > 0
    assert r["serial_runs_per_min"] == pytest.approx(60 * 4 / r["serial_wall_s"], rel=0.01)
    assert r["overhead_per_task_s"] == pytest.approx(
        (r["dask_wall_s"] * 2 - r["serial_wall_s"]) / 4, abs=1e-3
    )
    assert r["worker_s_per_run"] > 0
    assert r["slot_idle_per_task_s"] == pytest.approx(
        r["dask_wall_s"] * 2 / 4 - r["worker_s_per_run"], abs=2e-3
    )


def test_cli_on_an_existing_scheduler(
    cluster_client: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import dask

    from pedvr.cli import main

    spec = write_spec(tmp_path, SMALL.format(duration=0.3).replace("[1, 2, 3, 4]", "[1]"))
    address = cluster_client.scheduler.address
    assert main(["sweep", str(spec), "--scheduler", address, "--out", str(tmp_path / "o"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert re.search(rf"on \d Dask workers at {re.escape(address)}: 3 of 3 runs ran now \(3 ok", out), out
    assert read_table(tmp_path / "o").num_rows == 3
    assert (
        main(["sweep", str(spec), "--scheduler", address, "--workers", "2", "--out", str(tmp_path / "p")])
        == 2
    )
    assert "--workers starts a local cluster" in capsys.readouterr().err
    with dask.config.set({"distributed.comm.timeouts.connect": "0.5s"}):
        assert (
            main(["sweep", str(spec), "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "q")]) == 2
        )
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(
        "pedvr: error: --scheduler tcp://127.0.0.1:9: cannot reach a Dask scheduler there"
    )


def test_a_task_whose_workers_keep_dying_is_lost_then_resumed(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    spec, serial = small
    scheduler = cluster_client.cluster.scheduler
    allowed, scheduler.allowed_failures = scheduler.allowed_failures, 0  # one death and the task is given up
    killed: list[int] = []

    def kill_a_busy_worker(row: dict[str, Any]) -> None:
        busy = [w for w, keys in cluster_client.processing().items() if keys]
        if not killed and busy:
            pid = cluster_client.run(os.getpid)[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    try:
        first = run_sweep(
            spec, out=tmp_path / "lost", client=cluster_client, progress=False, on_result=kill_a_busy_worker
        )
    finally:
        scheduler.allowed_failures = allowed
        cluster_client.wait_for_workers(2, timeout=180)
    assert killed and first.lost >= 1 and first.ok + first.lost == 12
    df = read_table(tmp_path / "lost").to_pandas()
    lost = df[df["status"] == "lost"]
    assert len(lost) == first.lost and lost["error"].str.contains("its worker died").all()
    second = run_sweep(spec, out=tmp_path / "lost", resume=True, client=cluster_client, progress=False)
    assert (second.skipped, second.ran, second.ok) == (first.ok, first.lost, first.lost)
    pd.testing.assert_frame_equal(_frame(tmp_path / "lost"), serial)


def test_a_task_the_scheduler_cancels_is_lost_not_a_crash(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    from distributed import Future

    spec, serial = small
    victim = spec.tasks[-1].key

    def cancel_the_last(row: dict[str, Any]) -> None:
        if row["run_key"] != victim:
            cluster_client.cancel([Future(f"pedvr-{victim}", cluster_client)], force=True)

    first = run_sweep(
        spec, out=tmp_path / "c", client=cluster_client, progress=False, on_result=cancel_the_last
    )
    assert (first.ok, first.lost) == (11, 1) and "cancelled" in first.errors[0]
    second = run_sweep(spec, out=tmp_path / "c", resume=True, client=cluster_client, progress=False)
    assert (second.ran, second.ok) == (1, 1)
    pd.testing.assert_frame_equal(_frame(tmp_path / "c"), serial)


def test_a_worker_killed_holding_a_finished_result_is_waited_for(
    small: tuple[SweepSpec, pd.DataFrame], cluster_client: Any, tmp_path: Path
) -> None:
    """Issue 25.7: a worker that dies holding a result the client has not fetched yet loses it;
    Dask computes it again, and the sweep must wait for it, not write an error row ("NoneType: None")."""
    import time

    spec, serial = small
    scheduler = cluster_client.cluster.scheduler
    ours = {f"pedvr-{t.key}" for t in spec.tasks}
    killed: list[str] = []

    def kill_the_holder_of_an_unfetched_result(row: dict[str, Any]) -> None:
        if killed:
            return
        # While this callback runs, the sweep fetches nothing: results finished now wait in memory.
        deadline = time.monotonic() + 120
        held, address = None, None
        while address is None and time.monotonic() < deadline:
            for k, ts in list(scheduler.tasks.items()):
                holders = list(ts.who_has or ()) if k in ours and ts.state == "memory" else []
                if holders:
                    held, address = ts, holders[0].address
                    break
            time.sleep(0.05)
        assert held is not None and address is not None, "no finished result waited to be fetched"
        os.kill(cluster_client.run(os.getpid)[address], signal.SIGKILL)
        killed.append(held.key)
        while time.monotonic() < deadline and held.state == "memory":  # the scheduler noticed
            time.sleep(0.05)
        time.sleep(0.3)  # and told this client that the result is lost

    try:
        outcome = run_sweep(
            spec,
            out=tmp_path / "held",
            client=cluster_client,
            progress=False,
            on_result=kill_the_holder_of_an_unfetched_result,
        )
    finally:
        cluster_client.wait_for_workers(2, timeout=180)
    assert killed
    assert (outcome.ok, outcome.failed, outcome.lost) == (12, 0, 0), outcome.errors
    pd.testing.assert_frame_equal(_frame(tmp_path / "held"), serial)


def test_resume_runs_error_rows_again(small: tuple[SweepSpec, pd.DataFrame], tmp_path: Path) -> None:
    """Issue 25.7: --resume counted error rows as done, so a table left with the error row of a lost
    result (``NoneType: None``) could never be completed."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    spec, serial = small
    out = tmp_path / "err"
    assert run_sweep(spec, out=out, workers=0, progress=False).ok == 12
    table = read_table(out)
    victim = spec.tasks[3].key
    status = [
        "error" if k == victim else s
        for k, s in zip(table.column("run_key").to_pylist(), table.column("status").to_pylist(), strict=True)
    ]
    error = [
        "NoneType: None" if k == victim else e
        for k, e in zip(table.column("run_key").to_pylist(), table.column("error").to_pylist(), strict=True)
    ]
    table = table.set_column(table.column_names.index("status"), "status", pa.array(status))
    table = table.set_column(table.column_names.index("error"), "error", pa.array(error, pa.string()))
    pq.write_table(table, out / "runs.parquet")
    ran: list[str] = []
    again = run_sweep(
        spec,
        out=out,
        resume=True,
        workers=0,
        progress=False,
        on_result=lambda row: ran.append(row["run_key"]),
    )
    assert ran == [victim] and (again.skipped, again.ran, again.ok, again.retried) == (11, 1, 1, 1)
    assert "1 failed or lost before and ran again" in again.summary()
    pd.testing.assert_frame_equal(_frame(out), serial)
