"""A study protocol starts a demonstration to the participant (issue 15: "triggered ... by the study
protocol"): a trial step's ``demonstrate`` cues, through the behavior layer, recorded as any other."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from pedvr.demonstrator.demonstration import PROTOCOL_EVENT, demonstrate_to_user
from pedvr.errors import UsageError
from pedvr.scene.loader import load_any
from pedvr.sim import Simulation
from pedvr.study.errors import ProtocolError
from pedvr.study.protocol import DemoCue, load_protocol
from pedvr.study.store import StudyStore
from tests.study.conftest import run_session

DATA = Path(__file__).resolve().parent / "data"
QDIR = DATA.parents[2] / "user_study" / "questionnaires"


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    db = tmp_path_factory.mktemp("cue") / "cue.sqlite"
    with StudyStore(db) as store:
        res, _ = run_session(DATA / "demo_cue.toml", store, "SIM01")
    assert res.status == "finished"
    return db


def test_the_protocol_cue_starts_the_demonstration_on_time_by_the_guide(study: Path) -> None:
    with sqlite3.connect(study) as c:
        trials = dict(c.execute("SELECT step_key, trial_id FROM trials"))
        demo = c.execute("SELECT trial_id, agent_id, exhibit, event, outcome, sim_t FROM demonstrations "
                         "ORDER BY frame").fetchall()
        start = dict(c.execute("SELECT agent_id, x FROM agent_samples WHERE trial_id = ? AND frame = 0",
                               (trials["shown"],)))
        gaze = c.execute("SELECT source FROM gaze_events WHERE trial_id = ?", (trials["shown"],)).fetchall()
    # the scene has no triggers: the cue's demonstration is the only one, in the cued trial only
    assert [(d[0], d[2], d[3]) for d in demo] == [(trials["shown"], "vase", e) for e in ("start", "stroke", "end")]
    assert demo[-1][4] == "success"
    assert 1.0 - 1e-6 <= demo[0][5] <= 1.0 + 1.0 / 30.0  # at the cue's time (the next decision tick)
    # guide_state = "guide": the agent that started in state guide at x = -3, not the visitor nearer the user
    assert start[demo[0][1]] == -3.0
    assert gaze and all(g == ("demonstration",) for g in gaze)  # eye contact with the participant


def test_without_a_guide_state_the_free_agent_nearest_the_user_demonstrates() -> None:
    sim = Simulation(load_any(DATA / "demo_scene.toml", seed=1))
    assert PROTOCOL_EVENT not in sim.scheduler.events  # the scene declares no demonstration event
    run = demonstrate_to_user(sim.scheduler, "bowl")
    assert run is not None and run.event.name == PROTOCOL_EVENT and run.event.tree == "demonstrate"
    visitor = int(sim.crowd.ids[1 + 1])  # the second spawn, at (2.5, 2.8): nearest the user at (0.3, 2.5)
    assert run.values["guide"] == visitor and run.values["observer"] == sim.scheduler.ctx.user
    # the guide is in an event now: a second cue in its state finds no one free and starts nothing
    for _ in range(3):
        sim.step()
    assert demonstrate_to_user(sim.scheduler, "vase", guide_state="visitor") is None
    with pytest.raises(UsageError, match=r"exhibit 'vaze': not in the scene; its exhibits: bowl, vase"):
        demonstrate_to_user(sim.scheduler, "vaze")


def test_cues_are_parsed_sorted_and_carried_into_the_plan(tmp_path: Path) -> None:
    f = _protocol(tmp_path, 'demonstrate = [{ exhibit = "bowl", at_s = 5.0 }, '
                            '{ exhibit = "vase", at_s = 1.0, guide_state = "guide" }]')
    p = load_protocol(f)
    assert p.steps[0].demonstrations == (DemoCue("vase", 1.0, "guide"), DemoCue("bowl", 5.0, None))
    one = load_protocol(_protocol(tmp_path, 'demonstrate = { exhibit = "bowl", at_s = 0.0 }'))
    assert one.steps[0].demonstrations == (DemoCue("bowl", 0.0, None),)


@pytest.mark.parametrize("cue,message", [
    ('demonstrate = { exhibit = "vaze", at_s = 1.0 }',
     r"p\.toml: steps\[0\]\.demonstrate\.exhibit = 'vaze': no such exhibit in the trial's scene; "
     r"its exhibits: vase, bowl$"),
    ('demonstrate = [{ exhibit = "vase", at_s = -1.0 }]',
     r"p\.toml: steps\[0\]\.demonstrate\[0\]\.at_s = -1\.0: must be >= 0 s$"),
    ('demonstrate = [{ exhibit = "vase", at_s = 1.0 }, { exhibit = "vase", at_s = 14.0 }]',
     r"p\.toml: steps\[0\]\.demonstrate\[1\]\.at_s = 14\.0: must be before the trial's time_limit_s \(14 s\)$"),
    ('demonstrate = { exhibit = "vase", at_s = "soon" }',
     r"p\.toml: steps\[0\]\.demonstrate\.at_s = 'soon': expected a number >= 0 s$"),
    ('demonstrate = { exhibit = "vase", at_s = 1.0, guide_state = "docent" }',
     r"p\.toml: steps\[0\]\.demonstrate\.guide_state = 'docent': no such behavior state in the trial's scene; "
     r"its states: guide, visitor$"),
    ('demonstrate = { exhibit = "vase", at_s = 1.0, at = 1.0 }',
     r"p\.toml: steps\[0\]\.demonstrate\.at = 1\.0: unknown key; expected one of exhibit, at_s, guide_state"),
    ('demonstrate = "vase"',
     r"p\.toml: steps\[0\]\.demonstrate = 'vase': expected a table \{ exhibit = \"\.\.\.\", at_s = \.\.\. \} "
     r"or an array of them$"),
])
def test_a_bad_cue_is_one_line_naming_the_key(tmp_path: Path, cue: str, message: str) -> None:
    with pytest.raises(ProtocolError, match=message) as exc:
        load_protocol(_protocol(tmp_path, cue), display_path="p.toml")
    assert len(exc.value.problems) == 1, exc.value.problems


def _protocol(folder: Path, cue: str) -> Path:
    """The first trial of demo_cue.toml with ``cue`` as its demonstrate key (absolute paths)."""
    text = (DATA / "demo_cue.toml").read_text()
    text = text.replace('demonstrate = [{ exhibit = "vase", at_s = 1.0, guide_state = "guide" }]', cue)
    text = text.replace('"demo_scene.toml"', f'"{DATA / "demo_scene.toml"}"')
    text = text.replace("../../../user_study/questionnaires", str(QDIR))
    f = folder / "p.toml"
    f.write_text(text)
    return f
