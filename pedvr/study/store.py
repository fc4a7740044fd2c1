"""The study database: one SQLite file per study, written as things happen.

Tables (columns in :data:`SCHEMA`): ``participants``, ``sessions`` (software
version, protocol hash, seed, backend, start time UTC), ``steps`` (each
participant's plan and how far it got), ``trials`` (scene, condition, label,
order, seed, outcome), ``samples`` (one row per frame: monotonic time, frame
index, head position and orientation quaternion, distance to the nearest
agent), ``agent_samples`` (every agent's position and heading per frame),
``gaze_events`` (the PedVR gaze rule's and demonstrators' gazes at the participant, by
``source``), ``contacts``, ``answers`` (raw as shown and recoded to the
fixed orientation, with the response time from the item shown to the answer
confirmed), ``events`` (the experimenter's pauses, skips, aborts, signals) and
``demonstrations`` (a demonstrator's start, stroke points and end, for demonstrations to the
participant: pedvr.demonstrator).

Durability: the database runs in WAL mode with ``synchronous = FULL``. Every
answer, every step status and every trial start and end is its own
committed transaction; samples are committed in chunks of about a second.
A process killed mid-trial therefore loses at most that trial's last
uncommitted chunk of samples, never an answer; on ``--resume`` the
unfinished trial is marked ``interrupted`` (its committed samples are kept)
and run again as a new trial row.

Analysis and export open the database read-only (``read_only=True``): a
database on a read-only medium or without write permission can be read, and
nothing is written, not even a migration; an older schema is read through
temporary views that add the newer columns as missing values.
"""

from __future__ import annotations

import json
import sqlite3
import urllib.parse
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from pedvr.study.errors import DamagedStoreError, ParticipantExistsError, StudyStoreError, is_corruption

# 2: gaze_events.target (1 is migrated on open: its gaze table was always empty);
# 3: answers.response_time_s, samples.spheres (the red spheres reached so far);
# 4: gaze_events.source ('rule': the PedVR gaze rule; 'demonstration': a demonstrator looking the
#    participant in the eyes) and the demonstrations table (pedvr.demonstrator)
# 5: door_events (door etiquette: who held a door for whom, HOF/HOL/NH, waits, thank-yous)
SCHEMA_VERSION = "5"

SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS participants (
    participant TEXT PRIMARY KEY, number INTEGER NOT NULL, simulated INTEGER NOT NULL,
    created_utc TEXT NOT NULL, protocol_hash TEXT NOT NULL, status TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS sessions (
    session_id INTEGER PRIMARY KEY, participant TEXT NOT NULL REFERENCES participants(participant),
    software_version TEXT NOT NULL, protocol_source TEXT NOT NULL, protocol_hash TEXT NOT NULL,
    seed INTEGER NOT NULL, backend TEXT NOT NULL, participant_kind TEXT NOT NULL,
    started_utc TEXT NOT NULL, ended_utc TEXT, status TEXT NOT NULL, resumed INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS steps (
    participant TEXT NOT NULL REFERENCES participants(participant), step_index INTEGER NOT NULL,
    step_key TEXT NOT NULL, kind TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
    reason TEXT, session_id INTEGER, finished_utc TEXT, PRIMARY KEY (participant, step_index));
CREATE TABLE IF NOT EXISTS trials (
    trial_id INTEGER PRIMARY KEY, participant TEXT NOT NULL, session_id INTEGER NOT NULL,
    step_index INTEGER NOT NULL, step_key TEXT NOT NULL, design TEXT NOT NULL, block TEXT,
    scenario TEXT NOT NULL,
    scene_source TEXT NOT NULL, scene_hash TEXT NOT NULL, condition TEXT NOT NULL, label TEXT,
    trial_order INTEGER, responsibility REAL, seed INTEGER NOT NULL, time_limit_s REAL NOT NULL,
    started_utc TEXT NOT NULL, ended_utc TEXT, outcome TEXT, sim_time_s REAL, frames INTEGER,
    spheres_reached INTEGER, spheres_total INTEGER, min_user_distance_m REAL, contacts INTEGER);
CREATE TABLE IF NOT EXISTS samples (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, t_mono REAL NOT NULL, sim_t REAL NOT NULL,
    head_x REAL NOT NULL, head_y REAL NOT NULL, head_z REAL NOT NULL,
    head_qw REAL NOT NULL, head_qx REAL NOT NULL, head_qy REAL NOT NULL, head_qz REAL NOT NULL,
    nearest_agent_m REAL, spheres INTEGER, PRIMARY KEY (trial_id, frame)) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS agent_samples (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, agent_id INTEGER NOT NULL, is_user INTEGER NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, heading REAL NOT NULL,
    PRIMARY KEY (trial_id, frame, agent_id)) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS gaze_events (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, sim_t REAL NOT NULL, agent_id INTEGER NOT NULL,
    event TEXT NOT NULL, target TEXT NOT NULL DEFAULT 'user', source TEXT NOT NULL DEFAULT 'rule');
CREATE TABLE IF NOT EXISTS contacts (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, sim_t REAL NOT NULL, agent_a INTEGER NOT NULL,
    agent_b INTEGER NOT NULL, with_user INTEGER NOT NULL, overlap_m REAL NOT NULL);
CREATE TABLE IF NOT EXISTS answers (
    answer_id INTEGER PRIMARY KEY, participant TEXT NOT NULL, session_id INTEGER NOT NULL,
    step_index INTEGER NOT NULL, step_key TEXT NOT NULL, questionnaire TEXT NOT NULL,
    questionnaire_kind TEXT NOT NULL, item TEXT NOT NULL,
    item_number INTEGER NOT NULL, block TEXT, scenario TEXT, condition TEXT, label TEXT, comparison TEXT,
    left_condition TEXT, right_condition TEXT, left_label TEXT, right_label TEXT, flipped INTEGER,
    raw_value REAL, raw_label TEXT, recoded_value REAL, text TEXT, answered_utc TEXT NOT NULL,
    response_time_s REAL);
CREATE UNIQUE INDEX IF NOT EXISTS answers_once
    ON answers (participant, step_index, item, IFNULL(comparison, ''));
CREATE TABLE IF NOT EXISTS events (
    event_id INTEGER PRIMARY KEY, session_id INTEGER NOT NULL, participant TEXT NOT NULL,
    step_index INTEGER, utc TEXT NOT NULL, kind TEXT NOT NULL, detail TEXT);
""" + """
CREATE TABLE IF NOT EXISTS demonstrations (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, sim_t REAL NOT NULL, demo_id INTEGER NOT NULL,
    agent_id INTEGER NOT NULL, exhibit TEXT NOT NULL, event TEXT NOT NULL, x REAL NOT NULL, y REAL NOT NULL,
    outcome TEXT);
CREATE TABLE IF NOT EXISTS door_events (
    trial_id INTEGER NOT NULL, frame INTEGER NOT NULL, sim_t REAL NOT NULL, door TEXT NOT NULL,
    event TEXT NOT NULL, agent_id INTEGER NOT NULL, other_id INTEGER, action TEXT,
    with_user INTEGER NOT NULL, detail TEXT);
"""
# Tables added by each schema version (created by the migration; an older file read read-only gets an
# empty temporary one).
ADDED_TABLES = {"4": ("demonstrations",), "5": ("door_events",)}

# Columns added by each schema version: (table, column, SQL type and default, value read from older files).
ADDED_COLUMNS = {
    "2": (("gaze_events", "target", "TEXT NOT NULL DEFAULT 'user'", "'user'"),),
    "3": (
        ("answers", "response_time_s", "REAL", "NULL"),
        ("samples", "spheres", "INTEGER", "NULL"),
    ),
    "4": (("gaze_events", "source", "TEXT NOT NULL DEFAULT 'rule'", "'rule'"),),
    "5": (),  # a new table only (ADDED_TABLES)
}

TABLES = (
    "participants",
    "sessions",
    "steps",
    "trials",
    "samples",
    "agent_samples",
    "gaze_events",
    "contacts",
    "answers",
    "events",
    "demonstrations",
    "door_events",
)


def _create_statement(table: str) -> str:
    """The ``CREATE TABLE IF NOT EXISTS`` statement of ``table`` in :data:`SCHEMA`."""
    start = SCHEMA.index(f"CREATE TABLE IF NOT EXISTS {table} (")
    return SCHEMA[start:SCHEMA.index(";", start)]


def utc_now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


@dataclass(frozen=True)
class StepRow:
    index: int
    key: str
    kind: str
    spec: str
    status: str
    reason: str | None


class StudyStore:
    """An open study database. Use as a context manager or call :meth:`close`.

    ``path`` is created with the schema when missing; an existing file must
    be a pedvr study database of this schema version or an older one (older
    ones are migrated on open). With ``read_only`` the file must exist, is
    opened read-only (``mode=ro``; where SQLite cannot even create the WAL
    index next to a read-only file, ``immutable=1``: the file is then assumed
    not to change while it is open) and is never written; an older schema is
    read through temporary views (module docstring).
    """

    def __init__(self, path: str | Path, *, read_only: bool = False) -> None:
        self.path = Path(path)
        self.read_only = read_only
        if self.path.exists() and not self.path.is_file():
            raise StudyStoreError(f"{self.path}: not a file")
        if read_only:
            self.db = self._connect_read_only()
        else:
            if self.path.parent and not self.path.parent.exists():
                try:
                    self.path.parent.mkdir(parents=True, exist_ok=True)
                except OSError as exc:
                    raise StudyStoreError(
                        f"{self.path}: cannot create its folder: {exc.strerror or exc}"
                    ) from None
            try:
                self.db = sqlite3.connect(self.path, isolation_level=None, timeout=10.0)
                self.db.execute("PRAGMA journal_mode = WAL")
                self.db.execute("PRAGMA synchronous = FULL")
                self.db.execute("PRAGMA foreign_keys = ON")
            except sqlite3.OperationalError as exc:
                raise StudyStoreError(
                    f"{self.path}: cannot open the study database for writing ({exc})"
                ) from None
            except sqlite3.DatabaseError as exc:
                if is_corruption(exc):
                    raise DamagedStoreError(self.path, str(exc)) from None
                raise StudyStoreError(f"{self.path}: not a SQLite database ({exc})") from None
        try:
            have = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as exc:
            self.db.close()
            if is_corruption(exc):
                raise DamagedStoreError(self.path, str(exc)) from None
            raise StudyStoreError(f"{self.path}: not a SQLite database ({exc})") from None
        if (have or read_only) and "meta" not in have:
            self.db.close()
            raise StudyStoreError(
                f"{self.path}: a SQLite database, but not a pedvr study database "
                f"(tables: {', '.join(sorted(have)) or 'none'})"
            )
        if have:
            row = self.db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            version = None if row is None else str(row[0])
            if version not in ("1", *ADDED_COLUMNS):
                self.db.close()
                raise StudyStoreError(
                    f"{self.path}: study database schema version {version!r}; this pedvr reads "
                    f"{', '.join(repr(v) for v in ('1', *ADDED_COLUMNS))}"
                )
            assert version is not None
            if version != SCHEMA_VERSION:
                if read_only:
                    self._view_as_current(version)
                else:
                    self._migrate(version)
        else:
            self.db.executescript(
                "BEGIN IMMEDIATE;"
                + SCHEMA
                + f"INSERT INTO meta VALUES ('schema_version', '{SCHEMA_VERSION}'); COMMIT;"
            )

    def _connect_read_only(self) -> sqlite3.Connection:
        if not self.path.is_file():
            raise StudyStoreError(f"{self.path}: no such study database")
        uri = "file:" + urllib.parse.quote(str(self.path.resolve()))
        last: sqlite3.DatabaseError | None = None
        for mode in ("mode=ro", "immutable=1"):
            try:
                db = sqlite3.connect(f"{uri}?{mode}", uri=True, isolation_level=None, timeout=10.0)
            except sqlite3.DatabaseError as exc:
                last = exc
                continue
            try:
                db.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
                return db
            except sqlite3.DatabaseError as exc:
                db.close()
                last = exc
                # Only a file SQLite cannot open read-only in place (no WAL index can be made beside it)
                # is read as immutable; anything else (not a database, locked) is reported as it is.
                if not any(w in str(exc) for w in ("readonly", "read-only", "unable to open")):
                    break
        if isinstance(last, sqlite3.OperationalError):
            raise StudyStoreError(f"{self.path}: cannot open the study database to read it ({last})")
        if last is not None and is_corruption(last):
            raise DamagedStoreError(self.path, str(last))
        raise StudyStoreError(f"{self.path}: not a SQLite database ({last})")

    def _added_since(self, version: str) -> list[tuple[str, str, str, str]]:
        later = [v for v in ADDED_COLUMNS if int(v) > int(version)]
        return [c for v in later for c in ADDED_COLUMNS[v]]

    def _migrate(self, version: str) -> None:
        """Add the columns of every later schema version, in one transaction."""
        with self.transaction():
            for table, column, decl, _ in self._added_since(version):
                self.db.execute(f"ALTER TABLE {table} ADD COLUMN {column} {decl}")
            for table in self._tables_since(version):
                self.db.execute(_create_statement(table))
            self.db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (SCHEMA_VERSION,))

    def _view_as_current(self, version: str) -> None:
        """Read-only: temporary views named like the tables add the newer columns (temp is searched first)."""
        by_table: dict[str, list[str]] = {}
        for table, column, _, value in self._added_since(version):
            by_table.setdefault(table, []).append(f"{value} AS {column}")
        for table, extra in by_table.items():
            self.db.execute(f"CREATE TEMP VIEW {table} AS SELECT *, {', '.join(extra)} FROM main.{table}")
        for table in self._tables_since(version):
            temp = _create_statement(table).replace("CREATE TABLE IF NOT EXISTS", "CREATE TEMP TABLE")
            self.db.execute(temp)

    def _tables_since(self, version: str) -> list[str]:
        return [t for v, ts in ADDED_TABLES.items() if int(v) > int(version) for t in ts]

    # -- plumbing --------------------------------------------------------------------------

    def transaction(self) -> _Tx:
        return _Tx(self.db)

    def close(self) -> None:
        self.db.close()

    def rollback_open(self) -> None:
        """Roll back a transaction left open by an interrupted write (a signal between BEGIN and COMMIT)."""
        if self.db.in_transaction:
            self.db.execute("ROLLBACK")

    def check_intact(self) -> None:
        """Raise :class:`DamagedStoreError` when SQLite's ``quick_check`` finds a damaged page.

        It reads every page (seconds for hundreds of MB), so it runs once where a command starts
        (``study run`` before anything is written, ``analyze`` and ``export`` before anything is read),
        not on every open.
        """
        try:
            rows = self.db.execute("PRAGMA quick_check(1)").fetchall()
        except sqlite3.DatabaseError as exc:
            if not is_corruption(exc):
                raise
            raise DamagedStoreError(self.path, str(exc)) from None
        if rows != [("ok",)]:
            raise DamagedStoreError(self.path, "; ".join(str(r[0]) for r in rows))

    def __enter__(self) -> StudyStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def query(self, sql: str, params: Sequence[Any] = ()) -> list[dict[str, Any]]:
        cur = self.db.execute(sql, params)
        cols = [d[0] for d in cur.description] if cur.description else []
        return [dict(zip(cols, r, strict=True)) for r in cur.fetchall()]

    # -- participants, sessions, plan ------------------------------------------------------

    def participant(self, participant: str) -> dict[str, Any] | None:
        rows = self.query("SELECT * FROM participants WHERE participant = ?", (participant,))
        return rows[0] if rows else None

    def register(
        self,
        *,
        participant: str,
        number: int,
        simulated: bool,
        protocol_hash: str,
        plan: Iterable[tuple[int, str, str, str]],
    ) -> None:
        """Add a participant and their plan (``(index, key, kind, spec_json)`` rows) in one transaction."""
        if self.participant(participant) is not None:
            raise ParticipantExistsError(
                f"participant {participant} already exists in {self.path}; use --resume to continue their "
                "session, or choose another participant id"
            )
        clash = self.query("SELECT participant FROM participants WHERE number = ?", (number,))
        if clash:
            raise ParticipantExistsError(
                f"participant {participant}: number {number} is already used by {clash[0]['participant']} in "
                f"{self.path}; the number picks the counterbalancing, so each must be unique"
            )
        with self.transaction():
            self.db.execute(
                "INSERT INTO participants VALUES (?, ?, ?, ?, ?, 'in_progress')",
                (participant, number, int(simulated), utc_now(), protocol_hash),
            )
            self.db.executemany(
                "INSERT INTO steps (participant, step_index, step_key, kind, spec, status) "
                "VALUES (?, ?, ?, ?, ?, 'pending')",
                [(participant, i, k, kind, spec) for i, k, kind, spec in plan],
            )

    def next_number(self) -> int:
        """One more than the largest participant number used so far."""
        rows = self.query("SELECT MAX(number) AS n FROM participants")
        return int(rows[0]["n"] or 0) + 1

    def set_participant_status(self, participant: str, status: str) -> None:
        with self.transaction():
            self.db.execute("UPDATE participants SET status = ? WHERE participant = ?", (status, participant))

    def start_session(
        self,
        *,
        participant: str,
        software_version: str,
        protocol_source: str,
        protocol_hash: str,
        seed: int,
        backend: str,
        participant_kind: str,
        resumed: bool,
    ) -> int:
        with self.transaction():
            cur = self.db.execute(
                "INSERT INTO sessions (participant, software_version, protocol_source, protocol_hash, seed, "
                "backend, participant_kind, started_utc, status, resumed) VALUES (?, ?, ?, ?, ?, ?, ?, ?, "
                "'running', ?)",
                (
                    participant,
                    software_version,
                    protocol_source,
                    protocol_hash,
                    seed,
                    backend,
                    participant_kind,
                    utc_now(),
                    int(resumed),
                ),
            )
            return int(cur.lastrowid or 0)

    def end_session(self, session_id: int, status: str) -> None:
        with self.transaction():
            self.db.execute(
                "UPDATE sessions SET status = ?, ended_utc = ? WHERE session_id = ?",
                (status, utc_now(), session_id),
            )

    def close_dead_sessions(self, participant: str) -> int:
        """Sessions of ``participant`` still ``running`` belong to a dead process: mark them ``crashed``.

        Their ``ended_utc`` becomes the time of the last thing they committed (:meth:`last_record_utc`):
        the process died after it, within about a second of samples or before the next answer.
        """
        with self.transaction():
            dead = [
                int(r["session_id"])
                for r in self.query(
                    "SELECT session_id FROM sessions WHERE participant = ? AND status = 'running'",
                    (participant,),
                )
            ]
            for sid in dead:
                self.db.execute(
                    "UPDATE sessions SET status = 'crashed', ended_utc = ? WHERE session_id = ?",
                    (self.last_record_utc(sid), sid),
                )
            return len(dead)

    def last_record_utc(self, session_id: int) -> str:
        """When session ``session_id`` last committed something: a step, an answer, an event, a trial's
        start or end, or a trial's last chunk of samples (its start plus the samples' monotonic span)."""
        times = [
            r["t"]
            for r in self.query(
                "SELECT started_utc AS t FROM sessions WHERE session_id = ? "
                "UNION ALL SELECT MAX(finished_utc) FROM steps WHERE session_id = ? "
                "UNION ALL SELECT MAX(answered_utc) FROM answers WHERE session_id = ? "
                "UNION ALL SELECT MAX(utc) FROM events WHERE session_id = ? "
                "UNION ALL SELECT MAX(COALESCE(ended_utc, started_utc)) FROM trials WHERE session_id = ?",
                (session_id,) * 5,
            )
            if r["t"] is not None
        ]
        for r in self.query(
            "SELECT t.started_utc, MAX(s.t_mono) - MIN(s.t_mono) AS span FROM trials t "
            "JOIN samples s USING (trial_id) WHERE t.session_id = ? AND t.ended_utc IS NULL "
            "GROUP BY t.trial_id",
            (session_id,),
        ):
            start = datetime.fromisoformat(r["started_utc"].replace("Z", "+00:00"))
            end = start + timedelta(seconds=float(r["span"] or 0.0))
            times.append(end.isoformat(timespec="milliseconds").replace("+00:00", "Z"))
        return max(times)  # ISO 8601 UTC strings of one format sort as times

    def settle_last_session(self, participant: str, status: str) -> bool:
        """Close the session that recorded ``participant``'s last step as ``status`` (``finished``, or
        ``withdrawn`` after a declined consent) when its process died before saying so itself.

        A process killed after committing the last step but before ending its session leaves that
        session ``running`` (``crashed`` once :meth:`close_dead_sessions` has run): it did end as
        ``status``, at the time the step was recorded. The participant takes ``status`` too, and an
        event (kind ``closed_on_resume``) says what was repaired. True when something was.
        """
        rows = self.query(
            "SELECT session_id, finished_utc FROM steps WHERE participant = ? AND status != 'pending' "
            "AND session_id IS NOT NULL ORDER BY finished_utc DESC, step_index DESC LIMIT 1",
            (participant,),
        )
        with self.transaction():
            repaired = False
            if rows:
                sid, at = int(rows[0]["session_id"]), rows[0]["finished_utc"]
                cur = self.db.execute(
                    "UPDATE sessions SET status = ?, ended_utc = ? WHERE session_id = ? "
                    "AND status IN ('running', 'crashed')",
                    (status, at, sid),
                )
                repaired = cur.rowcount > 0
                if repaired:
                    self.db.execute(
                        "INSERT INTO events (session_id, participant, step_index, utc, kind, detail) "
                        "VALUES (?, ?, NULL, ?, 'closed_on_resume', ?)",
                        (sid, participant, utc_now(), f"the process ended after the last step was "
                         f"recorded; the session is {status} as of that step"),
                    )
            self.db.execute("UPDATE participants SET status = ? WHERE participant = ?", (status, participant))
        return repaired

    def steps(self, participant: str) -> list[StepRow]:
        return [
            StepRow(
                index=r["step_index"],
                key=r["step_key"],
                kind=r["kind"],
                spec=r["spec"],
                status=r["status"],
                reason=r["reason"],
            )
            for r in self.query(
                "SELECT * FROM steps WHERE participant = ? ORDER BY step_index", (participant,)
            )
        ]

    def mark_step(
        self, *, participant: str, index: int, status: str, session_id: int, reason: str | None = None
    ) -> None:
        with self.transaction():
            self.db.execute(
                "UPDATE steps SET status = ?, reason = ?, session_id = ?, finished_utc = ? "
                "WHERE participant = ? AND step_index = ?",
                (status, reason, session_id, utc_now(), participant, index),
            )

    def log_event(
        self,
        *,
        session_id: int,
        participant: str,
        step_index: int | None,
        kind: str,
        detail: str | None = None,
    ) -> None:
        with self.transaction():
            self.db.execute(
                "INSERT INTO events (session_id, participant, step_index, utc, kind, detail) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (session_id, participant, step_index, utc_now(), kind, detail),
            )

    # -- answers ---------------------------------------------------------------------------

    def answered(self, participant: str, step_index: int) -> set[tuple[str, str | None]]:
        """``(item, comparison)`` already answered in this step (resume skips them)."""
        return {
            (r["item"], r["comparison"])
            for r in self.query(
                "SELECT item, comparison FROM answers WHERE participant = ? AND step_index = ?",
                (participant, step_index),
            )
        }

    def record_answer(self, **row: Any) -> None:
        """Insert one answer and commit it before returning."""
        row = dict(row)
        row.setdefault("answered_utc", utc_now())
        cols = ", ".join(row)
        marks = ", ".join("?" for _ in row)
        with self.transaction():
            self.db.execute(f"INSERT INTO answers ({cols}) VALUES ({marks})", tuple(row.values()))

    # -- trials ----------------------------------------------------------------------------

    def begin_trial(self, **row: Any) -> int:
        row = dict(row)
        row.setdefault("started_utc", utc_now())
        cols = ", ".join(row)
        marks = ", ".join("?" for _ in row)
        with self.transaction():
            cur = self.db.execute(f"INSERT INTO trials ({cols}) VALUES ({marks})", tuple(row.values()))
            return int(cur.lastrowid or 0)

    def write_samples(
        self,
        *,
        samples: list[tuple[Any, ...]],
        agents: list[tuple[Any, ...]],
        contacts: list[tuple[Any, ...]],
        gaze: list[tuple[Any, ...]],
        demonstrations: Sequence[tuple[Any, ...]] = (),
        doors: Sequence[tuple[Any, ...]] = (),
    ) -> None:
        """Commit one chunk of per-frame rows. A gaze row without a source (six values) is the gaze rule's."""
        gaze = [g if len(g) == 7 else (*g, "rule") for g in gaze]
        with self.transaction():
            self.db.executemany("INSERT INTO samples VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", samples)
            self.db.executemany("INSERT INTO agent_samples VALUES (?, ?, ?, ?, ?, ?, ?)", agents)
            self.db.executemany("INSERT INTO contacts VALUES (?, ?, ?, ?, ?, ?, ?)", contacts)
            self.db.executemany("INSERT INTO gaze_events (trial_id, frame, sim_t, agent_id, event, target, "
                                "source) VALUES (?, ?, ?, ?, ?, ?, ?)", gaze)
            self.db.executemany("INSERT INTO demonstrations VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                                demonstrations)
            self.db.executemany("INSERT INTO door_events VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", doors)

    def finish_trial(self, trial_id: int, **row: Any) -> None:
        row = dict(row)
        row.setdefault("ended_utc", utc_now())
        sets = ", ".join(f"{k} = ?" for k in row)
        with self.transaction():
            self.db.execute(f"UPDATE trials SET {sets} WHERE trial_id = ?", (*row.values(), trial_id))

    def mark_interrupted_trials(self, participant: str) -> int:
        """Trials with no outcome were cut off by a crash; say so (their committed samples stay)."""
        with self.transaction():
            cur = self.db.execute(
                "UPDATE trials SET outcome = 'interrupted' WHERE participant = ? AND outcome IS NULL",
                (participant,),
            )
            return cur.rowcount

    def meta(self, key: str) -> Any:
        """A JSON value stored with :meth:`set_meta`, or ``None``."""
        rows = self.query("SELECT value FROM meta WHERE key = ?", (key,))
        return json.loads(rows[0]["value"]) if rows else None

    def set_meta(self, key: str, value: object) -> None:
        with self.transaction():
            self.db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, json.dumps(value)))


class _Tx:
    """``BEGIN IMMEDIATE`` … ``COMMIT`` (``ROLLBACK`` on error) on an autocommit connection."""

    def __init__(self, db: sqlite3.Connection) -> None:
        self.db = db

    def __enter__(self) -> sqlite3.Connection:
        if not self.db.in_transaction:
            self.db.execute("BEGIN IMMEDIATE")
            self._own = True
        else:
            self._own = False
        return self.db

    def __exit__(self, exc_type: object, *rest: object) -> None:
        if not self._own:
            return
        if exc_type is None:
            self.db.execute("COMMIT")
        else:
            self.db.execute("ROLLBACK")


def open_store(path: str | Path, *, must_exist: bool = False, read_only: bool = False) -> StudyStore:
    """Open a study database; with ``must_exist`` (implied by ``read_only``) a missing file is an error."""
    p = Path(path)
    if (must_exist or read_only) and not p.is_file():
        raise StudyStoreError(f"{p}: no such study database")
    return StudyStore(p, read_only=read_only)
