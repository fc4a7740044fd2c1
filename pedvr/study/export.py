"""Export a study database as tidy tab-separated files that R and pandas read without fixes.

``pedvr study export DB --out DIR [--force]`` writes one ``<table>.tsv`` per
table (``participants``, ``sessions``, ``steps``, ``trials``, ``samples``,
``answers``, ``events``, ``gaze_events``, ``contacts``), one
``trajectories/trial-<id>.tsv`` per trial (every agent and the user, one row
per agent per frame: the ``agent_samples`` table split by trial),
``trial_measures.tsv`` (the objective measures of every trial,
:mod:`pedvr.study.measures`), and ``responses.csv``: the pairwise answers
recoded to the fixed orientation in the long format
``participant,scenario,comparison,question,response`` that ``pedvr study
analyze --responses`` reads.

``samples.tsv`` and the trajectory files carry an ``interrupted`` column: 1
for the frames of a trial that was cut off and run again (outcome
``interrupted`` or ``aborted``, or no outcome yet after a crash not resumed),
so an analysis of the samples alone does not count such a trial twice; 0
otherwise (a ``skipped`` trial is not run again: 0, and its outcome is in
``trials.tsv``). ``answers.tsv`` has each answer's ``response_time_s``.

The database is opened read-only. Existing files are not overwritten unless
``force``; the refusal names the first one. Format: UTF-8, header row, ``\\t``
(or ``,`` for ``responses.csv``) separated, ``\\n`` line ends, missing values
as ``NA``; a field containing the separator, a quote or a line break is
quoted with ``"`` and its quotes are doubled (RFC 4180), which
``pandas.read_csv(f, sep="\\t")`` and R's ``read.delim(f)`` both read back
unchanged. Floats are written with full precision. Caveat: a free-text answer
that is exactly one of pandas' NA spellings (``NA``, ``null``, ...) reads back
as missing.
"""

from __future__ import annotations

import csv
from pathlib import Path

import pandas as pd

from pedvr.study.output import make_folder, prepare_folder, refuse_overwrite, write_file
from pedvr.study.store import StudyStore, open_store

TABLE_FILES = (
    "participants",
    "sessions",
    "steps",
    "trials",
    "samples",
    "answers",
    "events",
    "gaze_events",
    "contacts",
    "demonstrations",
    "door_events",
)
# Trials whose samples are superseded by a rerun (see the module docstring).
RERUN_OUTCOMES = ("interrupted", "aborted")
INTERRUPTED_SQL = (
    "CASE WHEN t.outcome IS NULL OR t.outcome IN ('interrupted', 'aborted') THEN 1 ELSE 0 END AS interrupted"
)


def _write(df: pd.DataFrame, path: Path, *, sep: str = "\t") -> None:
    write_file(
        path,
        lambda p: df.to_csv(
            p,
            sep=sep,
            index=False,
            na_rep="NA",
            quoting=csv.QUOTE_MINIMAL,
            lineterminator="\n",
            encoding="utf-8",
        ),
    )


def read_table(store: StudyStore, table: str) -> pd.DataFrame:
    """A whole table, ordered by its key columns (the order the export writes).

    ``samples`` gains the ``interrupted`` column (module docstring).
    """
    order = {
        "participants": "participant",
        "sessions": "session_id",
        "steps": "participant, step_index",
        "trials": "trial_id",
        "samples": "trial_id, frame",
        "answers": "answer_id",
        "events": "event_id",
        "gaze_events": "trial_id, frame, agent_id",
        "demonstrations": "trial_id, frame, demo_id",
        "contacts": "trial_id, frame, agent_a, agent_b",
        "door_events": "trial_id, frame, agent_id",
        "agent_samples": "trial_id, frame, agent_id",
    }[table]
    if table == "samples":
        return pd.read_sql_query(
            f"SELECT s.*, {INTERRUPTED_SQL} FROM samples s JOIN trials t USING (trial_id) "
            "ORDER BY s.trial_id, s.frame",
            store.db,
        )
    return pd.read_sql_query(f"SELECT * FROM {table} ORDER BY {order}", store.db)


def responses_frame(store: StudyStore) -> pd.DataFrame:
    """Pairwise answers, recoded, as ``participant,scenario,comparison,question,response``."""
    df = pd.read_sql_query(
        "SELECT participant, COALESCE(block, scenario) AS scenario, comparison, item AS question, "
        "CAST(recoded_value AS INTEGER) AS response FROM answers "
        "WHERE questionnaire_kind = 'pairwise' AND recoded_value IS NOT NULL ORDER BY answer_id",
        store.db,
    )
    return df


def export_study(db: str | Path, *, out: str | Path, force: bool = False) -> list[Path]:
    """Write the export files into ``out`` (created); return the paths written.

    Raises :class:`~pedvr.study.errors.OutputError` (one line) when ``out`` is
    not a folder, cannot be created or written, or holds a file the export
    would write (without ``force``), and
    :class:`~pedvr.study.errors.DamagedStoreError` when SQLite finds the
    database damaged (before any file is written).
    """
    from pedvr.study.measures import trial_measures

    out = Path(out)
    written: list[Path] = []
    with open_store(db, read_only=True) as store:
        store.check_intact()  # a damaged database is refused before anything is read or written
        trial_ids = [
            int(r[0])
            for r in store.db.execute("SELECT DISTINCT trial_id FROM agent_samples ORDER BY trial_id")
        ]
        traj = out / "trajectories"
        planned = [
            *(out / f"{t}.tsv" for t in TABLE_FILES),
            out / "trial_measures.tsv",
            out / "responses.csv",
            *(traj / f"trial-{t:05d}.tsv" for t in trial_ids),
        ]
        prepare_folder(out, what="export")
        refuse_overwrite(planned, force=force)
        for table in TABLE_FILES:
            p = out / f"{table}.tsv"
            _write(read_table(store, table), p)
            written.append(p)
        p = out / "trial_measures.tsv"
        _write(trial_measures(store), p)
        written.append(p)
        make_folder(traj)
        for tid in trial_ids:
            df = pd.read_sql_query(
                "SELECT a.trial_id, a.frame, s.sim_t, a.agent_id, a.is_user, a.x, a.y, a.heading, "
                f"{INTERRUPTED_SQL} "
                "FROM agent_samples a JOIN samples s ON s.trial_id = a.trial_id AND s.frame = a.frame "
                "JOIN trials t ON t.trial_id = a.trial_id "
                "WHERE a.trial_id = ? ORDER BY a.frame, a.agent_id",
                store.db,
                params=(tid,),
            )
            p = traj / f"trial-{tid:05d}.tsv"
            _write(df, p)
            written.append(p)
        p = out / "responses.csv"
        _write(responses_frame(store), p, sep=",")
        written.append(p)
    return written
