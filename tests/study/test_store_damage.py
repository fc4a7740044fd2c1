"""A damaged study database and a refused participant id (issue 25.2, 25.5): one line each, and the file on
disk is left exactly as it was (or never created)."""

from __future__ import annotations

import hashlib
import sqlite3
from pathlib import Path

import pandas as pd
import pytest

from pedvr.study.analysis import analyze
from pedvr.study.cli import main
from pedvr.study.errors import DamagedStoreError, damage_reported
from pedvr.study.export import export_study
from pedvr.study.store import StudyStore

from .conftest import QDIR_SHIPPED, run_session

PAGE_DAMAGE = bytes(range(7, 7 + 160))  # a fixed pattern: the same damage on every run


def _ssq_protocol(folder: Path, name: str = "s") -> Path:
    """A protocol with only questionnaires: a real study database in a second, no simulation."""
    proto = folder / f"{name}.toml"
    proto.write_text(f'[study]\nname = "{name}"\nseed = 3\nconditions = ["pedvr"]\n'
                     f'questionnaire_dir = "{QDIR_SHIPPED}"\n'
                     '[[steps]]\nid = "pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n'
                     '[[steps]]\nid = "post"\nkind = "questionnaire"\nquestionnaire = "ssq"\n')
    return proto


def _damaged_study(folder: Path) -> tuple[Path, Path, str]:
    """Three participants' answers, then the root page of the answers table overwritten in the middle (the
    file's header and schema stay readable: SQLite opens it and fails only when it reads that page).
    Returns the protocol, the database and its SHA-256."""
    proto = _ssq_protocol(folder)
    db = folder / "s.sqlite"
    with StudyStore(db) as store:
        for k in range(1, 4):
            assert run_session(proto, store, f"P{k:02d}")[0].status == "finished"
    with sqlite3.connect(db) as c:
        c.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        page_size = c.execute("PRAGMA page_size").fetchone()[0]
        root = c.execute("SELECT rootpage FROM sqlite_master WHERE name = 'answers'").fetchone()[0]
    c.close()
    with db.open("r+b") as f:
        f.seek((root - 1) * page_size + 8)
        f.write(PAGE_DAMAGE)
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as c, pytest.raises(sqlite3.DatabaseError, match="malformed"):
        c.execute("SELECT * FROM answers").fetchall()  # really damaged, and only in a page
    c.close()
    return proto, db, hashlib.sha256(db.read_bytes()).hexdigest()


def _one_error_line(err: str, db: Path) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pedvr: error: {db}: the study database is damaged (")
    assert lines[0].endswith("pedvr left the file as it is: restore it from a backup, or salvage what SQLite can "
                             "still read into a new file with its .recover command "
                             "(https://sqlite.org/recovery.html) and use that one")


def test_run_analyze_and_export_of_a_damaged_database_are_one_line_and_change_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    proto, db, sha = _damaged_study(tmp_path)
    out = tmp_path / "export"
    for argv in (["analyze", str(db)], ["analyze", str(db), "--report", str(tmp_path / "rep")],
                 ["export", str(db), "--out", str(out)],
                 ["run", str(proto), "--participant", "P04", "--simulated", "--db", str(db)],
                 ["run", str(proto), "--participant", "simulated", "--db", str(db)],
                 ["run", str(proto), "--participant", "P02", "--simulated", "--resume", "--db", str(db)]):
        assert main(argv) == 2, argv
        _one_error_line(capsys.readouterr().err, db)
        assert hashlib.sha256(db.read_bytes()).hexdigest() == sha, argv  # the file is left untouched
    assert not out.exists() and not (tmp_path / "rep").exists()  # refused before anything was written
    with pytest.raises(DamagedStoreError, match=r"s\.sqlite: the study database is damaged \(On tree page \d+"):
        analyze(db=db)
    with pytest.raises(DamagedStoreError, match=r"s\.sqlite: the study database is damaged"):
        export_study(db, out=out)
    assert hashlib.sha256(db.read_bytes()).hexdigest() == sha


def test_damage_met_while_reading_is_one_error_too(tmp_path: Path) -> None:
    """The net under the check at the start: SQLite's error met mid-read, raw or wrapped by pandas."""
    _, db, _ = _damaged_study(tmp_path)
    with StudyStore(db, read_only=True) as store:
        with pytest.raises(DamagedStoreError, match=r"s\.sqlite: the study database is damaged \(database disk "
                                                    r"image is malformed\)"), damage_reported(db):
            pd.read_sql_query("SELECT * FROM answers", store.db)
        with pytest.raises(DamagedStoreError), damage_reported(db):
            store.query("SELECT * FROM answers")
        with pytest.raises(sqlite3.OperationalError, match="no such table"), damage_reported(db):
            store.query("SELECT * FROM no_such_table")  # not damage: passes as it is


def test_a_damaged_first_page_is_damage_and_a_foreign_file_is_not_a_database(tmp_path: Path) -> None:
    _, db, _ = _damaged_study(tmp_path)
    with db.open("r+b") as f:  # page 1 below the 100-byte file header: the schema's own b-tree
        f.seek(100)
        f.write(PAGE_DAMAGE)
    with pytest.raises(DamagedStoreError, match=r"s\.sqlite: the study database is damaged"):
        StudyStore(db, read_only=True)
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"not a database at all" * 300)
    with pytest.raises(Exception, match=r"junk\.sqlite: not a SQLite database") as exc:
        StudyStore(junk, read_only=True)
    assert not isinstance(exc.value, DamagedStoreError)


@pytest.mark.parametrize("with_db", [True, False])
def test_an_invalid_participant_id_creates_no_database(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                       monkeypatch: pytest.MonkeyPatch, with_db: bool) -> None:
    proto = _ssq_protocol(tmp_path, "alice_study")
    monkeypatch.chdir(tmp_path)
    db = tmp_path / "given.sqlite"
    argv = ["run", str(proto), "--participant", "Alice", *(["--db", str(db)] if with_db else [])]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "pedvr: error: participant 'Alice': expected an id ending in a number >= 1, like P07 (the number selects "
        "the counterbalanced orders)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alice_study.toml"]  # no .sqlite, -wal or -shm
