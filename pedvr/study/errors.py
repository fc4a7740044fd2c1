"""The errors the study toolkit raises at its public boundaries.

Each message is one line (or one line per problem) naming what is wrong and
where: the file and dotted key, the participant, the database, the row.
"""

from __future__ import annotations

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
