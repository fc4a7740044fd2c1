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
    assert _rows(db, "SELECT COUNT(*) FROM steps WHERE status != 'done'") == [(0,)]
    # the interrupted trial keeps its committed samples; the rerun has all of its own
    per_trial = _rows(db, "SELECT t.trial_id, t.frames, COUNT(s.frame) FROM trials t LEFT JOIN samples s "
                          "USING (trial_id) GROUP BY t.trial_id ORDER BY t.trial_id")
    assert per_trial[0][2] == samples_at_kill
    assert per_trial[1][1] == per_trial[1][2] == 361
