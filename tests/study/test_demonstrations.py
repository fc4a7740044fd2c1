"""Demonstrations to the participant (pedvr.demonstrator) reach the study store and its measures."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import pandas as pd
import pytest

from pedvr.study.export import export_study
from pedvr.study.measures import trial_measures
from pedvr.study.store import StudyStore
from tests.study.conftest import run_session

DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    db = tmp_path_factory.mktemp("demo") / "demo.sqlite"
    with StudyStore(db) as store:
        res, _ = run_session(DATA / "demonstration.toml", store, "SIM01")
    assert res.status == "finished"
    return db


def test_a_demonstration_is_recorded_with_its_gazes(study: Path) -> None:
    with sqlite3.connect(study) as c:
        demo = c.execute("SELECT demo_id, agent_id, exhibit, event, x, y, outcome, frame, sim_t FROM demonstrations "
                         "ORDER BY frame").fetchall()
        gaze = c.execute("SELECT event, target, source, sim_t FROM gaze_events ORDER BY frame").fetchall()
        frame_t = dict(c.execute("SELECT frame, sim_t FROM samples"))
    assert [(d[0], d[2], d[3]) for d in demo] == [(0, "bust", "start"), (0, "bust", "stroke"), (0, "bust", "end")]
    assert demo[0][4:6] == (-8.0, 5.0) and demo[-1][6] == "success"
    for *_, frame, t in demo:
        assert frame_t[frame] >= t - 1e-6  # filed at the first frame at or after it
    assert gaze and all(g[1:3] == ("user", "demonstration") for g in gaze)
    assert [g[0] for g in gaze][:2] == ["start", "end"]
    assert gaze[0][3] < demo[1][8] < gaze[1][3]  # eye contact through the stroke point


def test_measures_count_demonstration_gazes_and_watched_demonstrations(study: Path, tmp_path: Path) -> None:
    with StudyStore(study) as store:
        m = trial_measures(store).iloc[0]
        assert m["gaze_events_received"] == 0  # the PedVR gaze rule is off in this condition
        assert m["demonstration_gazes"] == 2
        # the simulated participant walks its loop looking where it goes: the bust, due north, is out of view
        assert m["demonstrations_watched"] == 0
    db = tmp_path / "turned.sqlite"
    db.write_bytes(study.read_bytes())
    with sqlite3.connect(db) as c:  # the participant turns its head to the bust at the stroke
        frame, = c.execute("SELECT frame FROM demonstrations WHERE event = 'stroke'").fetchone()
        x, y = c.execute("SELECT head_x, head_y FROM samples WHERE frame = ?", (frame,)).fetchone()
        yaw = math.atan2(5.0 - y, -8.0 - x)
        c.execute("UPDATE samples SET head_qw = ?, head_qx = 0, head_qy = 0, head_qz = ? WHERE frame = ?",
                  (math.cos(yaw / 2), math.sin(yaw / 2), frame))
    with StudyStore(db) as store:
        assert trial_measures(store).iloc[0]["demonstrations_watched"] == 1
    written = export_study(db, out=tmp_path / "x")
    assert tmp_path / "x" / "demonstrations.tsv" in written
    assert list(pd.read_csv(tmp_path / "x" / "demonstrations.tsv", sep="\t")["event"]) == ["start", "stroke", "end"]
