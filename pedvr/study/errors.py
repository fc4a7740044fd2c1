"""The errors the study toolkit raises at its public boundaries.

Each message is one line (or one line per problem) naming what is wrong and
where: the file and dotted key, the participant, the database, the row.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from pedvr.errors import PedvrError


class ProtocolError(PedvrError):
    """A protocol or questionnaire file is invalid.

    ``problems`` holds one line per problem, each of the form
    ``user_study/x.toml: steps[3].time_limit_s = -5: must be > 0``; the message
    is those lines joined, so every problem is reported at once (like
    :class:`pedvr.errors.SceneError`).
    """

    exit_code = 2

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class StudyStoreError(PedvrError):
    """The study database cannot be used as asked (wrong schema, unknown id, bad state)."""

    exit_code = 2


class ParticipantExistsError(StudyStoreError):
    """A participant is started again without ``--resume``."""


class DamagedStoreError(StudyStoreError):
    """SQLite finds the study database damaged (a corrupt page, not merely a file of another kind).

    pedvr never writes to such a file (it is refused before anything is added), so what it still holds
    can be salvaged; the message says how.
    """

    def __init__(self, path: str | Path, detail: str) -> None:
        self.path = Path(path)
        detail = "; ".join(line for line in detail.splitlines() if line and not line.startswith("***"))
        super().__init__(
            f"{path}: the study database is damaged ({detail}); pedvr left the file as it is: restore it "
            "from a backup, or salvage what SQLite can still read into a new file with its .recover "
            "command (https://sqlite.org/recovery.html) and use that one"
        )


# SQLite's primary result codes for a damaged file (extended codes keep them in the low byte).
SQLITE_CORRUPT = 11


def is_corruption(exc: BaseException) -> bool:
    """Whether ``exc`` (or an exception it was raised from: pandas wraps sqlite3's) is SQLite reporting a
    damaged database."""
    seen: BaseException | None = exc
    while seen is not None:
        code = getattr(seen, "sqlite_errorcode", 0) if isinstance(seen, sqlite3.Error) else 0
        if code & 0xFF == SQLITE_CORRUPT:
            return True
        seen = seen.__cause__ or seen.__context__
    return False


@contextmanager
def damage_reported(path: str | Path) -> Iterator[None]:
    """Turn SQLite's "database disk image is malformed" (raw, or wrapped by pandas) met while working on
    the study database ``path`` into one :class:`DamagedStoreError` line; anything else passes."""
    try:
        yield
    except PedvrError:
        raise
    except Exception as exc:
        if not is_corruption(exc):
            raise
        raise DamagedStoreError(path, _first_cause(exc)) from None


def _first_cause(exc: BaseException) -> str:
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, sqlite3.Error):
            return str(seen)
        seen = seen.__cause__ or seen.__context__
    return str(exc)


class AnswerError(PedvrError):
    """An answer (from a participant or in a responses file) is not valid for its question.

    ``problems`` holds one line per problem (``answers.csv:12: response = 9:
    expected an integer 1..7``); the message is those lines joined.
    """

    exit_code = 2

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class OutputError(PedvrError):
    """An output folder or file (export, report) cannot be written, or would overwrite files."""

    exit_code = 2
