"""One study database holds one protocol's participants (issue 25.3): a participant of another protocol is
refused, naming the protocol the database belongs to, before anything is written."""

from __future__ import annotations

import hashlib
import sqlite3
from pathlib import Path

import pytest

from pedvr.study.analysis import analyze
from pedvr.study.cli import main
from pedvr.study.errors import StudyStoreError
from pedvr.study.store import StudyStore

from .conftest import QDIR_SHIPPED, run_session


def _protocol(folder: Path, name: str, *, comment: str = "") -> Path:
    """A questionnaire-only protocol named ``name`` (a real database in a second, no simulation)."""
    p = folder / f"{name}.toml"
    p.write_text(f'{comment}[study]\nname = "{name}"\nseed = 3\nconditions = ["pedvr"]\n'
                 f'questionnaire_dir = "{QDIR_SHIPPED}"\n'
                 '[[steps]]\nid = "pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n')
    return p


def test_a_participant_of_another_protocol_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    replication = _protocol(tmp_path, "pedvr_replication")
    mini = _protocol(tmp_path, "mini")
    db = tmp_path / "pedvr_replication.sqlite"
    with StudyStore(db) as store:
        for k in (1, 2, 3):
            assert run_session(replication, store, f"P{k:02d}")[0].status == "finished"
        assert store.meta("protocol") == {"name": "pedvr_replication", "source": str(replication)}
        with pytest.raises(StudyStoreError) as exc:
            run_session(mini, store, "P04")
    assert str(exc.value) == (
        f"{db}: this study database belongs to protocol 'pedvr_replication' ({replication}), not to 'mini' "
        f"({mini}): give protocol 'mini' a database of its own (--db; default ./mini.sqlite)")
    with sqlite3.connect(db) as c:
        c.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    c.close()
    sha = hashlib.sha256(db.read_bytes()).hexdigest()
    # the command line says the same in one line, and adds nothing
    assert main(["run", str(mini), "--participant", "P05", "--simulated", "--db", str(db)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pedvr: error: {db}: this study database belongs to protocol "
                                               "'pedvr_replication'")
    assert hashlib.sha256(db.read_bytes()).hexdigest() == sha
    res = analyze(db=db)
    assert res["n_participants"] == 3 and res["sample"]["protocols"] == [
        {"source": str(replication), "participants": 3}]


def test_an_edited_file_of_the_same_protocol_is_the_same_study(tmp_path: Path) -> None:
    proto = _protocol(tmp_path, "s")
    db = tmp_path / "s.sqlite"
    with StudyStore(db) as store:
        run_session(proto, store, "P01")
        _protocol(tmp_path, "s", comment="# a comment added mid-study\n")
        assert run_session(proto, store, "P02")[0].status == "finished"
        hashes = [r["protocol_hash"] for r in store.query("SELECT protocol_hash FROM participants ORDER BY number")]
    assert len(set(hashes)) == 2  # each participant keeps the file they ran with


def test_a_database_from_before_the_record_belongs_to_what_its_participants_ran(tmp_path: Path) -> None:
    one = _protocol(tmp_path, "one")
    other = _protocol(tmp_path, "other")
    db = tmp_path / "old.sqlite"
    with StudyStore(db) as store:
        run_session(one, store, "P01")
        store.db.execute("DELETE FROM meta WHERE key = 'protocol'")  # as written by pedvr 0.2
        with pytest.raises(StudyStoreError, match=rf"old\.sqlite: this study database holds the participants of "
                                                  rf"{one}, not of {other}: give protocol 'other' a database of "
                                                  r"its own \(--db; default \./other\.sqlite\)"):
            run_session(other, store, "P02")
        assert store.meta("protocol") is None and len(store.query("SELECT * FROM participants")) == 1
        _protocol(tmp_path, "one", comment="# edited\n")  # the same file, edited: still this study
        assert run_session(one, store, "P02")[0].status == "finished"
        assert store.meta("protocol") == {"name": "one", "source": str(one)}


def test_the_sample_lists_the_protocol_files_of_a_mixed_database(tmp_path: Path) -> None:
    """A database mixed before the refusal existed: the analysis says which files its participants ran."""
    one, other = _protocol(tmp_path, "one"), _protocol(tmp_path, "other")
    db = tmp_path / "mixed.sqlite"
    with StudyStore(db) as store:
        run_session(one, store, "P01")
        run_session(one, store, "P02")
        store.set_meta("protocol", {"name": "other", "source": str(other)})
        run_session(other, store, "P03")
    s = analyze(db=db)["sample"]
    assert s["protocols"] == [{"source": str(one), "participants": 2}, {"source": str(other), "participants": 1}]
    from pedvr.study.report import write_report

    md = (write_report(analyze(db=db), out=tmp_path / "rep").with_suffix(".md")).read_text()
    assert (f"Participants ran under 2 protocol files ({one}: 2; {other}: 1): one database should hold one "
            "study") in md
