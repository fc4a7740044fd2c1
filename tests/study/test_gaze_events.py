"""Gap 2: the simulation's PedVR gaze-rule events reach the study store's ``gaze_events`` table."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from pedvr.study.store import SCHEMA_VERSION, StudyStore
from tests.study.conftest import run_session

DATA = Path(__file__).resolve().parent / "data"


def test_pedvr_g_trial_records_gaze_events_and_decoupled_none(tmp_path: Path) -> None:
    db = tmp_path / "gaze.sqlite"
    with StudyStore(db) as store:
        res, _ = run_session(DATA / "gaze.toml", store, "SIM01")
    assert res.status == "finished"
    with sqlite3.connect(db) as c:
        rows = c.execute(
            "SELECT t.condition, g.frame, g.sim_t, g.agent_id, g.event, g.target FROM gaze_events g "
            "JOIN trials t USING (trial_id) ORDER BY g.trial_id, g.sim_t").fetchall()
        conds = {r[0] for r in c.execute("SELECT condition FROM trials")}
    assert conds == {"decoupled", "pedvr+g"}
    assert not [r for r in rows if r[0] == "decoupled"]
    g = [r for r in rows if r[0] == "pedvr+g"]
    assert g and g[0][4] == "start"
    assert all(r[4] in ("start", "end") and r[5] == "user" and r[3] > 0 and 0 <= r[2] <= 5.0 for r in g)
    # every event is filed at the first recorded frame at or after it
    with sqlite3.connect(db) as c:
        for _, frame, t, *_ in g:
            ft = c.execute("SELECT s.sim_t FROM samples s JOIN trials t USING (trial_id) "
                           "WHERE t.condition = 'pedvr+g' AND s.frame = ?", (frame,)).fetchone()[0]
            assert ft >= t - 1e-6


def test_schema_1_database_is_migrated(tmp_path: Path) -> None:
    db = tmp_path / "old.sqlite"
    StudyStore(db).close()
    with sqlite3.connect(db) as c:  # make it look like a version-1 database
        c.execute("ALTER TABLE gaze_events DROP COLUMN target")
        c.execute("ALTER TABLE gaze_events DROP COLUMN source")
        c.execute("DROP TABLE demonstrations")
        c.execute("ALTER TABLE answers DROP COLUMN response_time_s")
        c.execute("ALTER TABLE samples DROP COLUMN spheres")
        c.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
    with StudyStore(db) as store:
        store.write_samples(samples=[], agents=[], contacts=[], gaze=[(1, 0, 0.0, 3, "start", "user")])
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0] == SCHEMA_VERSION
        assert c.execute("SELECT target FROM gaze_events").fetchall() == [("user",)]
