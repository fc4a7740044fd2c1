"""The user-study toolkit (PedVR §6): protocols, counterbalancing, sessions, storage, analysis.

* :mod:`~pedvr.study.protocol` — protocols as validated TOML data, each participant's plan
* :mod:`~pedvr.study.questionnaire` — questionnaires as data, recoding, SSQ scoring
* :mod:`~pedvr.study.instrument` — the questionnaire vocabulary (scale, item, response), shared by
  questionnaire and :mod:`~pedvr.study.scoring` (the published keys); it imports nothing of the room
* :mod:`~pedvr.study.counterbalance` — balanced Latin squares, left/right assignment
* :mod:`~pedvr.study.session` — the resumable session state machine
* :mod:`~pedvr.study.presenter` — the participant interface (simulated, terminal; the in-app seam)
* :mod:`~pedvr.study.console` — the experimenter console (progress; pause, skip, abort keys)
* :mod:`~pedvr.study.store` — the SQLite study database
* :mod:`~pedvr.study.export` — tidy TSV/CSV export
* :mod:`~pedvr.study.analysis`, :mod:`~pedvr.study.report` — §6.5 statistics and the report
"""

from __future__ import annotations

from pedvr.study.errors import (
    AnswerError,
    OutputError,
    ParticipantExistsError,
    ProtocolError,
    StudyStoreError,
)

__all__ = ["AnswerError", "OutputError", "ParticipantExistsError", "ProtocolError", "StudyStoreError"]
