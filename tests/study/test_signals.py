"""SIGTERM and SIGHUP end a session as ``aborted`` with a logged event, like Ctrl-C (real signals, sent by
the process to itself at a chosen moment), and ``--resume`` continues."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from pedvr.signals import TerminatedBySignal, signals_abort
from pedvr.study.cli import main
from pedvr.study.presenter import SimulatedParticipant
from pedvr.study.store import StudyStore

from .conftest import DATA, run_session

MINI = DATA / "mini.toml"


class SignalsItself(SimulatedParticipant):
    """Sends ``signum`` to its own process at the ``at_question``-th question or ``at_frame``-th trial frame."""

    def __init__(self, signum: int, *, at_question: int | None = None, at_frame: int | None = None, **kw: object):
        super().__init__(**kw)  # type: ignore[arg-type]
        self.signum, self.at_question, self.at_frame = signum, at_question, at_frame
        self.questions = self.frames = 0

    def ask(self, question):  # type: ignore[no-untyped-def]
        self.questions += 1
        if self.questions == self.at_question:
            os.kill(os.getpid(), self.signum)
        return super().ask(question)

    def present(self, sim):  # type: ignore[no-untyped-def]
        self.frames += 1
        if self.frames == self.at_frame:
            os.kill(os.getpid(), self.signum)
        return super().present(sim)


def test_sigterm_during_a_questionnaire_aborts_and_resume_continues(tmp_path: Path) -> None:
    before = signal.getsignal(signal.SIGTERM)
    with StudyStore(tmp_path / "s.sqlite") as store:
        who = SignalsItself(signal.SIGTERM, at_question=4, seed=5, number=1)
        with pytest.raises(TerminatedBySignal) as exc, signals_abort():
            run_session(MINI, store, "P01", participant=who)
        assert exc.value.exit_code == 128 + signal.SIGTERM
        assert store.query("SELECT status FROM sessions") == [{"status": "aborted"}]
        assert store.query("SELECT kind, detail FROM events") == [{"kind": "abort", "detail": "interrupted (SIGTERM received)"}]
        assert store.query("SELECT COUNT(*) AS n FROM answers")[0]["n"] == 3  # the 4th was being asked
        result, out = run_session(MINI, store, "P01", resume=True)
        assert result.status == "finished" and "resuming at step 2/" in out
        assert store.query("SELECT COUNT(*) AS n FROM answers WHERE questionnaire = 'ssq'")[0]["n"] == 16
    assert signal.getsignal(signal.SIGTERM) is before  # the handlers are put back


def test_sighup_during_a_trial_marks_it_interrupted(tmp_path: Path) -> None:
    with StudyStore(tmp_path / "h.sqlite") as store:
        who = SignalsItself(signal.SIGHUP, at_frame=12, seed=5, number=1)
        with pytest.raises(TerminatedBySignal), signals_abort():
            run_session(MINI, store, "P01", participant=who)
        assert store.query("SELECT status FROM sessions") == [{"status": "aborted"}]
        assert store.query("SELECT detail FROM events WHERE kind = 'abort'") == [{"detail": "interrupted (SIGHUP received)"}]
        trial = store.query("SELECT trial_id, outcome, frames FROM trials")
        assert [(t["outcome"], t["frames"]) for t in trial] == [("interrupted", 12)]
        n = store.query("SELECT COUNT(*) AS n FROM samples WHERE trial_id = ?", (trial[0]["trial_id"],))[0]["n"]
        assert n == 12  # every recorded frame kept, none twice
        assert not store.db.in_transaction


def test_the_cli_exits_with_128_plus_the_signal_and_one_line(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    real_present = SimulatedParticipant.present
    calls = {"n": 0}

    def present(self, sim):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        if calls["n"] == 5:
            os.kill(os.getpid(), signal.SIGTERM)
        return real_present(self, sim)

    monkeypatch.setattr(SimulatedParticipant, "present", present)
    db = tmp_path / "c.sqlite"
    code = main(["run", str(MINI), "--participant", "P01", "--simulated", "--backend", "headless", "--db", str(db)])
    assert code == 128 + signal.SIGTERM
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"pedvr: SIGTERM: session of P01 aborted and saved in {db}; continue with --resume"]
    with StudyStore(db, read_only=True) as store:
        assert store.query("SELECT status FROM sessions") == [{"status": "aborted"}]
        assert store.query("SELECT outcome FROM trials") == [{"outcome": "interrupted"}]
