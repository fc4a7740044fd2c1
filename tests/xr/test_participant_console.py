"""The in-app participant and the experimenter: console keys while a panel waits (issue 23 item 3), and
the XR runtime's facts stored with the session (issue 23, ``pedvr xr check``'s facts in the records).

A real session (:class:`~pedvr.study.session.Session`, SQLite store, the ``mini`` test protocol); the
participant's view is a scripted frontend, the runtime a fake port (``test_session.FakePort``)."""

from __future__ import annotations

import io
import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest

from pedvr.study.console import ExperimenterConsole, ScriptedKeys
from pedvr.study.protocol import load_protocol
from pedvr.study.session import Session
from pedvr.study.store import StudyStore
from pedvr.xr.locomotion import Controls
from pedvr.xr.participant import InAppParticipant, SessionClosed, XrFrontend
from pedvr.xr.session import SessionState, StateChanged
from tests.study.test_in_app import FakeFrontend
from tests.xr.test_session import FOCUS, READY, FakePort

ROOT = Path(__file__).resolve().parents[2]


class Unanswered(FakeFrontend):
    """A controller that cannot press: panels never get an event (closes after ``close_after`` frames,
    so a panel nobody can leave fails the test instead of hanging it)."""

    def frame(self, sim: Any, panel: Any) -> tuple[float | None, list[Any]]:
        self.frames += 1
        self.t += 1 / 60
        return self.t, []

    def runtime_facts(self) -> dict[str, Any] | None:
        return None


class WithFacts(FakeFrontend):
    """Answers everything; knows the runtime's facts from its 5th frame on."""

    def runtime_facts(self) -> dict[str, Any] | None:
        return {"runtime": "Fake XR 1.0", "frames_seen": self.frames} if self.frames >= 5 else None


def _session(store: StudyStore, participant: InAppParticipant, console: ExperimenterConsole) -> Session:
    p = load_protocol(ROOT / "tests" / "study" / "data" / "mini.toml")
    return Session(protocol=p, store=store, participant_id="P04", participant=participant, console=console,
                   backend="xr")


def _console(keys: list[str | None]) -> tuple[ExperimenterConsole, io.StringIO]:
    out = io.StringIO()
    return ExperimenterConsole(out=out, keys=ScriptedKeys(keys), live=False), out


def test_console_keys_work_while_a_panel_waits(tmp_path: Path) -> None:
    # frames 1-3 nothing, then h (help), then s with a reason (skip the welcome page), then the SSQ's
    # first panel waits too: a (abort), yes.
    console, out = _console([None, None, None, "h", None, "s", "cannot press", None, None, "a", "yes"])
    who = InAppParticipant(Unanswered(close_after=400), console=console)
    db = tmp_path / "s.sqlite"
    with StudyStore(db) as store:
        res = _session(store, who, console).run()
    assert res.status == "aborted"
    text = out.getvalue()
    assert "keys: p pause/resume" in text and "skipping: cannot press" in text
    with sqlite3.connect(db) as c:
        steps = c.execute("SELECT step_index, status, reason FROM steps ORDER BY step_index LIMIT 2").fetchall()
        assert steps == [(0, "skipped", "cannot press"), (1, "pending", None)]
        kinds = [k for (k,) in c.execute("SELECT kind FROM events ORDER BY event_id")]
        assert kinds == ["skip", "abort"]
        assert c.execute("SELECT status FROM sessions").fetchone() == ("aborted",)


def test_without_the_console_a_panel_nobody_can_answer_only_ends_with_the_view() -> None:
    who = InAppParticipant(Unanswered(close_after=30))
    from pedvr.study.presenter import Page

    with pytest.raises(SessionClosed):
        who.show(Page(title="Welcome", text="Hello."))


def test_the_runtime_facts_are_stored_once_with_the_session(tmp_path: Path) -> None:
    console, _ = _console([])
    db = tmp_path / "s.sqlite"
    with StudyStore(db) as store:
        assert _session(store, InAppParticipant(WithFacts(), console=console), console).run().status == "finished"
    with sqlite3.connect(db) as c:
        rows = c.execute("SELECT session_id, detail FROM events WHERE kind = 'xr_runtime'").fetchall()
    assert len(rows) == 1 and rows[0][0] == 1
    assert json.loads(rows[0][1]) == {"runtime": "Fake XR 1.0", "frames_seen": 5}


def test_the_xr_frontend_gives_the_facts_only_once_focused_for_a_while() -> None:
    port = FakePort(events=[READY, [StateChanged(SessionState.SYNCHRONIZED)], [], [], [],
                            [StateChanged(SessionState.VISIBLE)], FOCUS],
                    controls=[Controls()] * 40)
    fe = XrFrontend(port=port)
    seen = []
    for _ in range(25):
        fe.frame(None, None)
        seen.append(fe.runtime_facts())
    assert seen[5] is None  # not focused yet
    k = next(i for i, f in enumerate(seen) if f is not None)
    assert k >= 9 and seen[k] == port.runtime_facts()


def test_the_protocols_trials_are_prepared_before_the_view_opens() -> None:
    from pedvr.xr.participant import prepare_protocol

    protocol = load_protocol(ROOT / "tests" / "study" / "data" / "mini.toml")
    prepare_protocol(protocol, say=lambda line: None)  # compiled (or loaded from the cache) now
    lines: list[str] = []
    assert prepare_protocol(protocol, say=lines.append) == 1
    assert lines[0].startswith("preparing trial scene 1 of 3: headon_corridor (")
    assert lines[-1] == "prepared: numba's cache is warm" and len(lines) == 2
