"""Export a study database as tidy tab-separated files that R and pandas read without fixes.

``pedvr study export DB --out DIR`` writes one ``<table>.tsv`` per table
(``participants``, ``sessions``, ``steps``, ``trials``, ``samples``,
``answers``, ``events``, ``gaze_events``, ``contacts``), one
``trajectories/trial-<id>.tsv`` per trial (every agent and the user, one row
per agent per frame: the ``agent_samples`` table split by trial), and
``responses.csv``: the pairwise answers recoded to the fixed orientation in
the long format ``participant,scenario,comparison,question,response`` that
``pedvr study analyze --responses`` reads.

Format: UTF-8, header row, ``\\t`` (or ``,`` for ``responses.csv``)
separated, ``\\n`` line ends, missing values as ``NA``; a field containing the
separator, a quote or a line break is quoted with ``"`` and its quotes are
doubled (RFC 4180), which ``pandas.read_csv(f, sep="\\t")`` and R's
``read.delim(f)`` both read back unchanged. Floats are written with full
precision. Caveat: a free-text answer that is exactly one of pandas' NA
spellings (``NA``, ``null``, ...) reads back as missing.
"""

from __future__ import annotations

import csv
from pathlib import Path

import pandas as pd

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
)


def _write(df: pd.DataFrame, path: Path, *, sep: str = "\t") -> None:
    df.to_csv(
        path,
        sep=sep,
        index=False,
        na_rep="NA",
        quoting=csv.QUOTE_MINIMAL,
        lineterminator="\n",
        encoding="utf-8",
    )


def read_table(store: StudyStore, table: str) -> pd.DataFrame:
    """A whole table, ordered by its key columns (the order the export writes)."""
    order = {
        "participants": "participant",
        "sessions": "session_id",
        "steps": "participant, step_index",
        "trials": "trial_id",
        "samples": "trial_id, frame",
        "answers": "answer_id",
        "events": "event_id",
        "gaze_events": "trial_id, frame, agent_id",
        "contacts": "trial_id, frame, agent_a, agent_b",
        "agent_samples": "trial_id, frame, agent_id",
    }[table]
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


def export_study(db: str | Path, *, out: str | Path) -> list[Path]:
    """Write the export files into ``out`` (created); return the paths written."""
    out = Path(out)
    written: list[Path] = []
    with open_store(db, must_exist=True) as store:
        out.mkdir(parents=True, exist_ok=True)
        for table in TABLE_FILES:
            p = out / f"{table}.tsv"
            _write(read_table(store, table), p)
            written.append(p)
        traj = out / "trajectories"
        traj.mkdir(exist_ok=True)
        for (tid,) in store.db.execute("SELECT DISTINCT trial_id FROM agent_samples ORDER BY trial_id"):
            df = pd.read_sql_query(
                "SELECT a.trial_id, a.frame, s.sim_t, a.agent_id, a.is_user, a.x, a.y, a.heading "
                "FROM agent_samples a JOIN samples s ON s.trial_id = a.trial_id AND s.frame = a.frame "
                "WHERE a.trial_id = ? ORDER BY a.frame, a.agent_id",
                store.db,
                params=(int(tid),),
            )
            p = traj / f"trial-{int(tid):05d}.tsv"
            _write(df, p)
            written.append(p)
        p = out / "responses.csv"
        _write(responses_frame(store), p, sep=",")
        written.append(p)
    return written
