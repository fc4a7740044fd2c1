"""Simulated participants through a protocol on Dask: one study store per sweep, written by the client."""

from __future__ import annotations

import sqlite3
from contextlib import closing
from pathlib import Path
from typing import Any

from pedvr.sweep.participants import merge_participant
from pedvr.sweep.report import write_sweep_report
from pedvr.sweep.runner import run_sweep
from pedvr.sweep.spec import load_spec
from pedvr.sweep.table import read_table
from tests.sweep.conftest import DATA, write_spec


def _count(db: Path, sql: str) -> int:
    with closing(sqlite3.connect(db)) as con:
        return int(con.execute(sql).fetchone()[0])


def test_participants_sweep_merges_one_store(cluster_client: Any, tmp_path: Path) -> None:
    spec = load_spec(
        write_spec(
            tmp_path,
            f"""
[sweep]
name = "dryrun"
[sweep.participants]
protocol = "{DATA / "protocol.toml"}"
count = 6
""",
        )
    )
    assert [t.participant for t in spec.tasks] == [f"SIM0{k}" for k in range(1, 7)]  # type: ignore[union-attr]
    out = tmp_path / "out"
    outcome = run_sweep(spec, out=out, client=cluster_client, progress=False)
    assert (outcome.ok, outcome.failed) == (6, 0), outcome.errors
    store = out / "sweep_dryrun.sqlite"
    assert _count(store, "SELECT COUNT(*) FROM participants WHERE status = 'finished'") == 6
    assert _count(store, "SELECT COUNT(DISTINCT session_id) FROM sessions") == 6
    assert _count(store, "SELECT COUNT(*) FROM trials") == 18
    # Every row points at its own participant's trial and session after the ids were shifted.
    assert (
        _count(
            store,
            "SELECT COUNT(*) FROM samples s LEFT JOIN trials t USING (trial_id) WHERE t.trial_id IS NULL",
        )
        == 0
    )
    assert (
        _count(
            store,
            "SELECT COUNT(*) FROM answers a JOIN sessions s USING (session_id) "
            "WHERE a.participant != s.participant",
        )
        == 0
    )
    assert _count(store, "SELECT COUNT(*) FROM answers") == 6 * 24  # 8 items x 3 comparisons each
    df = read_table(out).to_pandas().sort_values("number")
    assert df["trials"].tolist() == [3] * 6 and (df["participant_status"] == "finished").all()
    # A balanced Latin square of 3 conditions has 6 rows: six participants, six different orders.
    assert df["order"].nunique() == 6
    # Merging a participant again replaces it (a resumed sweep whose row was not yet written).
    with closing(sqlite3.connect(store)) as con:
        before = con.execute("SELECT COUNT(*) FROM samples").fetchone()[0]
    private = tmp_path / "again.sqlite"
    from pedvr.study.cli import main as study_main

    assert (
        study_main(
            [
                "run",
                str(DATA / "protocol.toml"),
                "--participant",
                "SIM02",
                "--simulated",
                "--backend",
                "headless",
                "--db",
                str(private),
            ]
        )
        == 0
    )
    merge_participant(store, private.read_bytes(), "SIM02")
    assert _count(store, "SELECT COUNT(*) FROM participants") == 6
    assert _count(store, "SELECT COUNT(*) FROM trials") == 18
    assert _count(store, "SELECT COUNT(*) FROM samples") == before
    # The report counts orders and runs the study's own analysis on the merged store.
    text = write_sweep_report(out).read_text()
    assert "6 distinct orders over 6 participants." in text
    assert (out / "report" / "study" / "report.md").is_file()
