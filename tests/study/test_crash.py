"""Killing the process mid-trial loses no answer, and --resume finishes the protocol (for real: SIGKILL)."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PROTOCOL = Path(__file__).resolve().parent / "data" / "crash.toml"


def _rows(db: Path, sql: str) -> list[tuple]:
    with sqlite3.connect(db, timeout=10) as c:
        return c.execute(sql).fetchall()


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "pedvr.study", "run", str(PROTOCOL), "--participant", "P01", "--simulated",
            "--backend", "headless", *args]


def test_kill_mid_trial_then_resume(tmp_path: Path) -> None:
    db = tmp_path / "crash.sqlite"
    # half real time, so the 4 s trial takes 8 s of wall time and is surely running when killed
    proc = subprocess.Popen(_cli("--db", str(db), "--pace", "0.5"), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while True:
            assert proc.poll() is None, "the session ended before it could be killed:\n" + proc.stdout.read().decode()
            assert time.monotonic() < deadline, "the trial never started"
            if db.exists():
                try:
                    got = _rows(db, "SELECT COUNT(*) FROM samples s JOIN trials t USING (trial_id) "
                                    "WHERE t.outcome IS NULL")
                except sqlite3.OperationalError:  # schema not created yet
                    got = [(0,)]
                if got[0][0] >= 90:  # at least one committed chunk of the running trial
                    break
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL

    before = _rows(db, "SELECT answer_id, questionnaire, item, raw_value, text FROM answers ORDER BY answer_id")
    assert len(before) == 1 + 16  # consent and the first SSQ, all committed before the trial
    assert _rows(db, "SELECT outcome FROM trials") == [(None,)]
    assert _rows(db, "SELECT status FROM sessions") == [("running",)]
    samples_at_kill = _rows(db, "SELECT COUNT(*) FROM samples")[0][0]
    assert samples_at_kill >= 90 and samples_at_kill % 90 == 0  # whole chunks only

    # starting again without --resume is refused, and changes nothing
    again = subprocess.run(_cli("--db", str(db)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert again.returncode == 2
    assert "pedvr: error: participant P01 already exists in" in again.stderr and "use --resume" in again.stderr

    done = subprocess.run(_cli("--db", str(db), "--resume"), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "resuming at step 3/4" in done.stdout and "participant P01 finished the protocol" in done.stdout

    after = _rows(db, "SELECT answer_id, questionnaire, item, raw_value, text FROM answers ORDER BY answer_id")
    assert after[: len(before)] == before  # nothing lost or changed
    assert len(after) == 1 + 16 + 16
    assert _rows(db, "SELECT COUNT(*), COUNT(DISTINCT step_index || item) FROM answers") == [(33, 33)]
    assert _rows(db, "SELECT outcome FROM trials ORDER BY trial_id") == [("interrupted",), ("time_limit",)]
    assert _rows(db, "SELECT status FROM sessions ORDER BY session_id") == [("crashed",), ("finished",)]
    # the crashed session ends at its last committed chunk of samples (the trial's start plus their span),
    # after its answers and the trial's start, before the resumed session began
    (crashed_end, resumed_start), = _rows(db, "SELECT a.ended_utc, b.started_utc FROM sessions a, sessions b "
                                              "WHERE a.session_id = 1 AND b.session_id = 2")
    trial_start, span = _rows(db, "SELECT t.started_utc, MAX(s.t_mono) - MIN(s.t_mono) FROM trials t "
                                  "JOIN samples s USING (trial_id) WHERE t.trial_id = 1")[0]
    last_answer = _rows(db, "SELECT MAX(answered_utc) FROM answers WHERE session_id = 1")[0][0]
    assert last_answer <= trial_start < crashed_end <= resumed_start and span > 0.9
    assert _rows(db, "SELECT COUNT(*) FROM steps WHERE status != 'done'") == [(0,)]
    # the interrupted trial keeps its committed samples; the rerun has all of its own
    per_trial = _rows(db, "SELECT t.trial_id, t.frames, COUNT(s.frame) FROM trials t LEFT JOIN samples s "
                          "USING (trial_id) GROUP BY t.trial_id ORDER BY t.trial_id")
    assert per_trial[0][2] == samples_at_kill
    assert per_trial[1][1] == per_trial[1][2] == 361


# Runs `pedvr study run` with StudyStore.end_session replaced by a wait: the process has committed its last
# step (finished, or consent declined) and is killed by the test with SIGKILL exactly there, before it can
# end its session or set the participant's status.
KILLED_BEFORE_END_SESSION = """
import os, signal, sys
from pathlib import Path
from pedvr.study.store import StudyStore
def end_session(self, session_id, status):
    Path(os.environ["PEDVR_TEST_MARK"]).write_text(status)
    signal.pause()
StudyStore.end_session = end_session
if os.environ.get("PEDVR_TEST_DECLINE"):
    from pedvr.study.presenter import SimulatedParticipant
    from pedvr.study.questionnaire import Response
    ask = SimulatedParticipant.ask
    SimulatedParticipant.ask = lambda self, q: Response(text="no") if q.item.kind == "consent" else ask(self, q)
from pedvr.study.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _kill_before_end_session(tmp_path: Path, protocol: Path, db: Path, *, decline: bool) -> str:
    mark = tmp_path / "last-step-committed"
    env = {**os.environ, "PEDVR_TEST_MARK": str(mark), **({"PEDVR_TEST_DECLINE": "1"} if decline else {})}
    proc = subprocess.Popen([sys.executable, "-c", KILLED_BEFORE_END_SESSION, "run", str(protocol), "--participant",
                             "P01", "--simulated", "--backend", "headless", "--db", str(db)],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while not mark.exists():
            assert proc.poll() is None, "the session ended before it could be killed:\n" + proc.stdout.read().decode()
            assert time.monotonic() < deadline, "the session never reached its end"
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL
    return mark.read_text()


def _questionnaires_only(folder: Path) -> Path:
    p = folder / "short.toml"
    p.write_text(f'[study]\nname = "short"\nseed = 9\nconditions = ["pedvr"]\n'
                 f'questionnaire_dir = "{ROOT / "user_study" / "questionnaires"}"\n'
                 '[[steps]]\nid = "consent"\nkind = "questionnaire"\nquestionnaire = "consent"\n'
                 '[[steps]]\nid = "ssq_pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n'
                 '[[steps]]\nid = "ssq_post"\nkind = "questionnaire"\nquestionnaire = "ssq"\n')
    return p


def test_killed_after_its_last_step_the_participant_and_its_session_are_finished(tmp_path: Path) -> None:
    """Issue 25.4: the kill leaves every step done but the session running; resuming closes that session as
    finished at the time its last step was recorded (not crashed, not without an end), and the report
    counts one finished session for one finished participant."""
    from pedvr.study.analysis import analyze

    db = tmp_path / "short.sqlite"
    assert _kill_before_end_session(tmp_path, _questionnaires_only(tmp_path), db, decline=False) == "finished"
    assert _rows(db, "SELECT COUNT(*) FROM steps WHERE status != 'done'") == [(0,)]
    assert _rows(db, "SELECT status, ended_utc FROM sessions") == [("running", None)]
    assert _rows(db, "SELECT status FROM participants") == [("in_progress",)]
    answers = _rows(db, "SELECT * FROM answers ORDER BY answer_id")

    cmd = [sys.executable, "-m", "pedvr.study", "run", str(tmp_path / "short.toml"), "--participant", "P01",
           "--simulated", "--backend", "headless", "--db", str(db), "--resume"]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "participant P01 has finished the protocol; nothing to resume" in done.stdout
    last_step = _rows(db, "SELECT MAX(finished_utc) FROM steps")[0][0]
    assert _rows(db, "SELECT status, ended_utc FROM sessions") == [("finished", last_step)]
    assert _rows(db, "SELECT status FROM participants") == [("finished",)]
    assert _rows(db, "SELECT kind FROM events") == [("closed_on_resume",)]
    assert _rows(db, "SELECT * FROM answers ORDER BY answer_id") == answers  # nothing lost or added
    sample = analyze(db=db)["sample"]
    assert sample["sessions"] == {"finished": 1} and sample["by_status"] == {"finished": 1}
    # resuming again changes nothing more
    again = subprocess.run(done.args, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and _rows(db, "SELECT COUNT(*) FROM events") == [(1,)]


def test_killed_after_consent_was_declined_the_participant_is_withdrawn(tmp_path: Path) -> None:
    """The same moment after a declined consent: resuming must not carry on with the protocol."""
    db = tmp_path / "short.sqlite"
    proto = _questionnaires_only(tmp_path)
    assert _kill_before_end_session(tmp_path, proto, db, decline=True) == "withdrawn"
    assert _rows(db, "SELECT status FROM sessions") == [("running",)]
    cmd = [sys.executable, "-m", "pedvr.study", "run", str(proto), "--participant", "P01", "--simulated",
           "--backend", "headless", "--db", str(db), "--resume"]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and r.stderr.strip() == (
        "pedvr: error: participant P01 declined consent; there is nothing to resume")
    consent = _rows(db, "SELECT finished_utc FROM steps WHERE step_key = 'consent'")[0][0]
    assert _rows(db, "SELECT status, ended_utc FROM sessions") == [("withdrawn", consent)]
    assert _rows(db, "SELECT status FROM participants") == [("withdrawn",)]
    assert _rows(db, "SELECT questionnaire, text FROM answers") == [("consent", "no")]  # no SSQ was given
