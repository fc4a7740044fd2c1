"""Issue 14: door etiquette's events reach the study store (``door_events``) and the objective
measure ``doors_held_for_participant`` counts the doors agents held open for the participant."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from pedvr.study.errors import ProtocolError
from pedvr.study.measures import load_trials, measures
from pedvr.study.protocol import load_protocol
from pedvr.study.store import SCHEMA_VERSION, StudyStore
from tests.study.conftest import run_session

DATA = Path(__file__).resolve().parent / "data"


def test_a_door_held_for_the_participant_is_recorded_and_measured(tmp_path: Path) -> None:
    db = tmp_path / "door.sqlite"
    with StudyStore(db) as store:
        res, _ = run_session(DATA / "door.toml", store, "SIM01")
        assert res.status == "finished"
        (record,) = list(load_trials(store))
        held = measures["doors_held_for_participant"].compute(record)
    with sqlite3.connect(db) as c:
        rows = c.execute("SELECT event, agent_id, other_id, action, with_user, door, sim_t, frame "
                         "FROM door_events ORDER BY sim_t").fetchall()
        user_id = 0
    holds = [r for r in rows if r[0] == "hold"]
    assert holds and holds[0][1] == 1 and holds[0][2] == user_id, rows  # the agent held for the participant
    # the protocol's participant_sex = "female" (the scene says male): Care = 1, and the kind,
    # unhurried holder a step away holds the door and lets her pass first (Table 2: TTT, Rush F)
    assert holds[0][3] == "HOF" and holds[0][4] == 1 and holds[0][5] == "main"
    assert held == sum(1 for r in holds if r[3] in ("HOF", "HOL") and r[4] == 1) >= 1
    assert all(r[7] >= 0 and r[6] <= 9.0 + 1e-6 for r in rows)


def test_schema_4_database_gets_the_door_events_table(tmp_path: Path) -> None:
    db = tmp_path / "v4.sqlite"
    StudyStore(db).close()
    with sqlite3.connect(db) as c:  # make it look like a version-4 database (demonstrations, no doors)
        c.execute("DROP TABLE door_events")
        c.execute("UPDATE meta SET value = '4' WHERE key = 'schema_version'")
    with StudyStore(db) as store:
        store.write_samples(samples=[], agents=[], contacts=[], gaze=[],
                            doors=[(1, 4, 0.5, "main", "hold", 2, 0, "HOF", 1, None)])
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0] == SCHEMA_VERSION
        assert c.execute("SELECT action, with_user FROM door_events").fetchall() == [("HOF", 1)]


def test_a_bad_participant_profile_is_one_line(tmp_path: Path) -> None:
    f = tmp_path / "p.toml"
    f.write_text((DATA / "door.toml").read_text().replace('participant_sex = "female"', 'participant_sex = "f"')
                 .replace("door_scene.toml", str(DATA / "door_scene.toml"))
                 .replace("../../../user_study/questionnaires", str(DATA.parents[2] / "user_study" / "questionnaires")))
    with pytest.raises(ProtocolError, match=r"p\.toml: study\.participant_sex = 'f': expected one of 'female', 'male'"):
        load_protocol(f)
