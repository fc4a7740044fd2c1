"""The questionnaire vocabulary: scales, items, questionnaires and responses as plain data.

These types are shared by :mod:`pedvr.study.questionnaire` (loading, validating,
answering) and :mod:`pedvr.study.scoring` (the published keys that check a
loaded file and score its answers). They live here, importing nothing of
``pedvr.study``, so neither of those two modules has to import the other's
types back: the dependency runs one way, ``questionnaire -> scoring -> instrument``.
"""

from __future__ import annotations

from dataclasses import dataclass

KINDS = ("ssq", "pairwise", "likert", "form")
ITEM_KINDS = ("scale", "text", "number", "choice", "consent")


@dataclass(frozen=True)
class Scale:
    """Integer response scale ``minimum..maximum`` with one label per point."""

    minimum: int
    maximum: int
    labels: tuple[str, ...]  # "" = the point has no label of its own

    def label(self, value: int) -> str:
        return self.labels[value - self.minimum]


@dataclass(frozen=True)
class Item:
    """One question. ``number`` is its 1-based position in the file."""

    id: str
    number: int
    text: str
    kind: str = "scale"
    reverse: bool = False
    required: bool = True
    choices: tuple[str, ...] = ()
    minimum: float | None = None
    maximum: float | None = None
    labels: tuple[str, ...] = ()  # scale items: one label per point, overriding the scale's
    step: float | None = None  # number items: answers are minimum + k * step


@dataclass(frozen=True)
class Questionnaire:
    """A validated questionnaire file."""

    id: str
    title: str
    kind: str
    instructions: str
    scale: Scale | None
    items: tuple[Item, ...]
    source: str
    content_hash: str
    citation: str = ""
    scoring: str = ""  # a scorer registered in pedvr.study.scoring; "" = none
    document: str = ""  # the file's TOML text (stored in the study database, so analysis can re-score)

    def label(self, item: Item, value: int) -> str:
        """The label of scale point ``value`` for ``item`` (its own labels, else the scale's); may be ""."""
        assert self.scale is not None
        labels = item.labels or self.scale.labels
        return labels[value - self.scale.minimum]

    def item(self, item_id: str) -> Item:
        for it in self.items:
            if it.id == item_id:
                return it
        raise KeyError(item_id)


@dataclass(frozen=True)
class Response:
    """A confirmed answer as the participant gave it.

    ``value`` is the scale point (or the number) as shown; ``text`` is the
    free text or the chosen option. Both ``None`` means the participant chose
    not to answer an optional item.
    """

    value: float | None = None
    text: str | None = None
