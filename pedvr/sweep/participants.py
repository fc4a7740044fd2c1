"""Simulated participants: one private store per participant, merged into one store per sweep.

Each task runs ``pedvr study run PROTOCOL --participant SIMnn --simulated
--backend headless`` (the study's own command-line entry point, so the study
package stays the only code that writes study data) into a temporary SQLite
file on its worker, and returns the file's bytes. The client alone writes the
sweep's store, ``DIR/<study>.sqlite``: SQLite allows one writer, and no two
processes ever write one file. The store is created by the study's
:class:`~pedvr.study.store.StudyStore` (its schema, its migrations), then each
participant is copied in one transaction by :func:`merge_participant`.

The copy follows the schema found in the files rather than a list written
here (the study schema grows): every table of the participant's file is
copied column by column (the columns both files have); each table's integer
row id (``session_id``, ``trial_id``, ``answer_id``, ...) is shifted past the
ids already in the sweep's store, and every column of that name in any table
is shifted with it, which keeps samples, answers and events pointing at their
trial and session. A participant merged again (a resumed sweep whose last
merge was not yet recorded in the table) first has its earlier rows removed.
"""

from __future__ import annotations

import sqlite3
from contextlib import closing
from pathlib import Path
from typing import Any


def participant_summary(db: Path, participant: str) -> dict[str, Any]:
    """The table row's metrics for one simulated participant's private store.

    ``status`` (finished, aborted, withdrawn), steps done of total, trials,
    answers, and ``order``: the trials' ``scenario:condition`` (and ``ρ=`` where the
    trial set one) in the order run: what counterbalancing decided for this
    participant's number.
    """
    with closing(sqlite3.connect(db)) as con:
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)")  # the bytes returned must hold every commit
        status = con.execute(
            "SELECT status FROM participants WHERE participant = ?", (participant,)
        ).fetchone()
        steps = con.execute(
            "SELECT COUNT(*), SUM(status != 'pending') FROM steps WHERE participant = ?", (participant,)
        ).fetchone()
        trials = con.execute(
            "SELECT scenario, condition, responsibility FROM trials WHERE participant = ? ORDER BY trial_id",
            (participant,),
        ).fetchall()
        answers = con.execute("SELECT COUNT(*) FROM answers WHERE participant = ?", (participant,)).fetchone()
    return {
        "participant_status": None if status is None else status[0],
        "steps_total": int(steps[0] or 0),
        "steps_done": int(steps[1] or 0),
        "trials": len(trials),
        "answers": int(answers[0] or 0),
        "order": ">".join(f"{s}:{c}" + ("" if r is None else f" ρ={r:g}") for s, c, r in trials),
    }


def _columns(con: sqlite3.Connection, schema: str, table: str) -> list[tuple[str, str, int]]:
    """(name, declared type, pk position) of each column."""
    return [
        (r[1], str(r[2]).upper(), int(r[5])) for r in con.execute(f'PRAGMA {schema}.table_info("{table}")')
    ]


def _row_id(cols: list[tuple[str, str, int]]) -> str | None:
    """The column that is the table's integer row id (a lone ``INTEGER PRIMARY KEY``), if any."""
    pks = [c for c in cols if c[2] > 0]
    return pks[0][0] if len(pks) == 1 and pks[0][1] == "INTEGER" else None


def merge_participant(store: Path, blob: bytes, participant: str) -> None:
    """Copy one participant's private store (``blob``, SQLite bytes) into the sweep's ``store``."""
    from pedvr.study.store import StudyStore

    with StudyStore(store):  # creates or migrates the schema, with the study's own code
        pass
    src = store.with_name(f".{store.stem}.{participant}.merge.sqlite")
    src.write_bytes(blob)
    try:
        with closing(sqlite3.connect(store)) as con:
            con.execute("ATTACH DATABASE ? AS src", (str(src),))
            tables = [
                r[0]
                for r in con.execute(
                    "SELECT name FROM src.sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'"
                )
            ]
            main_tables = {
                r[0] for r in con.execute("SELECT name FROM main.sqlite_master WHERE type = 'table'")
            }
            cols = {t: _columns(con, "main", t) for t in tables if t in main_tables}
            owners = {rid: t for t, c in cols.items() if (rid := _row_id(c)) is not None}
            with con:  # one transaction: the participant is merged whole or not at all
                _remove(con, participant, cols, owners)
                shift = {
                    rid: int(con.execute(f'SELECT COALESCE(MAX("{rid}"), 0) FROM main."{t}"').fetchone()[0])
                    for rid, t in owners.items()
                }
                for t, tcols in cols.items():
                    src_names = {c[0] for c in _columns(con, "src", t)}
                    names = [c[0] for c in tcols if c[0] in src_names]
                    exprs = [f'"{n}" + {shift[n]}' if n in shift else f'"{n}"' for n in names]
                    verb = "INSERT OR IGNORE" if t == "meta" else "INSERT"
                    quoted = ", ".join(f'"{n}"' for n in names)
                    con.execute(f'{verb} INTO main."{t}" ({quoted}) SELECT {", ".join(exprs)} FROM src."{t}"')
            con.execute("DETACH DATABASE src")
    finally:
        src.unlink(missing_ok=True)


def _remove(
    con: sqlite3.Connection,
    participant: str,
    cols: dict[str, list[tuple[str, str, int]]],
    owners: dict[str, str],
) -> None:
    """Delete an earlier copy of ``participant``: rows naming it, and rows pointing at its ids."""
    by_participant = [t for t, c in cols.items() if any(n == "participant" for n, _, _ in c)]
    for t, tcols in cols.items():
        if t in by_participant:
            continue
        for n, _, _ in tcols:
            owner = owners.get(n)
            if owner is not None and owner != t and owner in by_participant:
                con.execute(
                    f'DELETE FROM main."{t}" WHERE "{n}" IN '
                    f'(SELECT "{n}" FROM main."{owner}" WHERE participant = ?)',
                    (participant,),
                )
                break
    for t in by_participant:
        con.execute(f'DELETE FROM main."{t}" WHERE participant = ?', (participant,))


def merged_participants(store: Path) -> set[str]:
    """Participants already in the sweep's store."""
    if not store.is_file():
        return set()
    with closing(sqlite3.connect(store)) as con:
        return {r[0] for r in con.execute("SELECT participant FROM participants")}
