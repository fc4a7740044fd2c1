"""Published scoring of the standard questionnaires, as a typed registry.

A questionnaire file names its scoring (``[questionnaire] scoring = "ipq"``).
Each :class:`Scorer` does two things:

* ``check(q)`` — at load, the file must have what the published scoring
  needs: the item ids, the scale, and ``reverse = true`` on exactly the
  published reversed items (so the ``recoded_value`` column the export
  writes agrees with the scores). Problems come back as
  ``(dotted key, value, expectation)`` and join the file's other problems.
* ``score(q, answers)`` — one administration's answers (``{item id: raw
  value as shown, or the chosen option's text, or None}``) to its scores
  (``{score name: value, or None where an item it needs is missing}``).
  Reversed items are reversed here from the raw values (``min + max - v``),
  by the published list, not by the file's flags.

Registered scorings (sources are cited in each shipped file too):

``ipq``        igroup Presence Questionnaire (Schubert, Friedmann & Regenbrecht 2001):
               general presence (G1), spatial presence (mean SP1–5), involvement
               (mean INV1–4), experienced realism (mean REAL1–4); SP2, INV3 and REAL1
               reversed. Scores are on the file's 7-point scale (the shipped file: 0–6,
               igroup's data coding; subtract 3 for the −3..+3 presentation).
``slater_usoh_steed``
               the SUS presence questionnaire (Slater, Usoh & Steed 1994; Usoh et al.
               2000): the count of answers of 6 or 7 over the 6 items (0–6, the
               published score) and the mean of the 6 items.
``nasa_tlx``   NASA Task Load Index (Hart & Staveland 1988): the six ratings
               (0–100 in steps of 5), raw TLX (their mean) and, when the 15 paired
               comparisons were answered, the weighted TLX
               (Σ rating × times chosen / 15).
``copresence`` co-presence with virtual humans (Bailenson, Blascovich, Beall & Loomis
               2003): mean of 5 items on −3..+3, items 3 and 5 reversed.
``sus``        System Usability Scale (Brooke 1996): 2.5 × (Σ odd items − 1 +
               Σ 5 − even items), 0–100.
``mean``       any Likert questionnaire: the mean of its recoded items (the default).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from itertools import combinations

from pedvr.registry import Registry
from pedvr.study.instrument import Questionnaire

Answers = Mapping[str, "float | str | None"]
Problem = tuple[str, object, str]


@dataclass(frozen=True)
class Scorer:
    """One published scoring (module docstring)."""

    name: str
    title: str
    scores: tuple[str, ...]  # the score names ``score`` returns, in report order
    check: Callable[[Questionnaire], list[Problem]]
    score: Callable[[Questionnaire, Answers], dict[str, float | None]]


scorers: Registry[Scorer] = Registry("questionnaire scoring")


def _register(s: Scorer) -> Scorer:
    return scorers.register(s.name)(s)


# -- shared checks ---------------------------------------------------------------------------------


def _needs_items(q: Questionnaire, ids: tuple[str, ...], *, kind: str = "scale") -> list[Problem]:
    have = {it.id: it for it in q.items}
    out: list[Problem] = []
    missing = [i for i in ids if i not in have]
    if missing:
        out.append(("items", [it.id for it in q.items], f"needs items {', '.join(missing)}"))
    for i in ids:
        if i in have and have[i].kind != kind:
            k = [it.id for it in q.items].index(i)
            out.append((f"items[{k}].kind", have[i].kind, f"item {i} must be a {kind} item"))
    return out


def _needs_scale(q: Questionnaire, lo: int | None, hi: int | None, *, points: int) -> list[Problem]:
    if q.scale is None:
        return [("scale", None, f"needs a {points}-point scale")]
    span = (q.scale.minimum, q.scale.maximum)
    if span[1] - span[0] + 1 != points or (lo is not None and span != (lo, hi)):
        want = f"{lo}..{hi}" if lo is not None else f"{points} points"
        return [("scale", f"{span[0]}..{span[1]}", f"expected {want}")]
    return []


def _needs_reversed(q: Questionnaire, ids: tuple[str, ...], reversed_ids: frozenset[str]) -> list[Problem]:
    out: list[Problem] = []
    for k, it in enumerate(q.items):
        if it.id in ids and it.reverse != (it.id in reversed_ids):
            want = "true (a reversed item)" if it.id in reversed_ids else "false"
            out.append((f"items[{k}].reverse", it.reverse, f"must be {want}"))
    return out


def _num(a: Answers, item: str) -> float | None:
    v = a.get(item)
    if v is None or isinstance(v, str):
        return None
    f = float(v)
    return f if math.isfinite(f) else None


def _reversed(q: Questionnaire, v: float) -> float:
    assert q.scale is not None
    return q.scale.minimum + q.scale.maximum - v


def _mean(values: list[float | None]) -> float | None:
    """Mean of all of them, or None if any is missing (a subscale needs every item)."""
    if not values or any(v is None for v in values):
        return None
    return sum(v for v in values if v is not None) / len(values)


# -- igroup Presence Questionnaire ----------------------------------------------------------------

IPQ_SUBSCALES: dict[str, tuple[str, ...]] = {
    "general_presence": ("g1",),
    "spatial_presence": ("sp1", "sp2", "sp3", "sp4", "sp5"),
    "involvement": ("inv1", "inv2", "inv3", "inv4"),
    "experienced_realism": ("real1", "real2", "real3", "real4"),
}
IPQ_ITEMS = tuple(i for items in IPQ_SUBSCALES.values() for i in items)
# igroup.org's scoring notes: SP2, INV3 and REAL1 are reversed (e.g. 6 - sp2 on the 0..6 coding).
IPQ_REVERSED = frozenset({"sp2", "inv3", "real1"})


def _ipq_check(q: Questionnaire) -> list[Problem]:
    return (
        _needs_items(q, IPQ_ITEMS)
        + _needs_scale(q, None, None, points=7)
        + _needs_reversed(q, IPQ_ITEMS, IPQ_REVERSED)
    )


def _ipq_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    def value(item: str) -> float | None:
        v = _num(a, item)
        return None if v is None else _reversed(q, v) if item in IPQ_REVERSED else v

    return {name: _mean([value(i) for i in items]) for name, items in IPQ_SUBSCALES.items()}


_register(
    Scorer(
        name="ipq",
        title="igroup Presence Questionnaire",
        scores=tuple(IPQ_SUBSCALES),
        check=_ipq_check,
        score=_ipq_score,
    )
)


# -- Slater-Usoh-Steed presence questionnaire ------------------------------------------------------

SUS_PRESENCE_ITEMS = ("sus1", "sus2", "sus3", "sus4", "sus5", "sus6")
SUS_PRESENCE_HIGH = 6  # Usoh et al. 2000: the score counts answers of 6 or 7 on the 1..7 scale


def _sus_presence_check(q: Questionnaire) -> list[Problem]:
    return (
        _needs_items(q, SUS_PRESENCE_ITEMS)
        + _needs_scale(q, 1, 7, points=7)
        + _needs_reversed(q, SUS_PRESENCE_ITEMS, frozenset())
    )


def _sus_presence_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    values = [_num(a, i) for i in SUS_PRESENCE_ITEMS]
    if any(v is None for v in values):
        return {"sus_count": None, "sus_mean": None}
    return {
        "sus_count": float(sum(1 for v in values if v is not None and v >= SUS_PRESENCE_HIGH)),
        "sus_mean": _mean(values),
    }


_register(
    Scorer(
        name="slater_usoh_steed",
        title="Slater–Usoh–Steed presence questionnaire",
        scores=("sus_count", "sus_mean"),
        check=_sus_presence_check,
        score=_sus_presence_score,
    )
)


# -- NASA Task Load Index ---------------------------------------------------------------------------

TLX_DIMENSIONS = {
    "mental": "Mental Demand",
    "physical": "Physical Demand",
    "temporal": "Temporal Demand",
    "performance": "Performance",
    "effort": "Effort",
    "frustration": "Frustration",
}
TLX_PAIRS = tuple(combinations(TLX_DIMENSIONS, 2))  # the 15 paired comparisons of the weighting


def tlx_pair_id(a: str, b: str) -> str:
    """The item id of the paired comparison of dimensions ``a`` and ``b`` (``w_mental_physical``)."""
    return f"w_{a}_{b}"


def _tlx_check(q: Questionnaire) -> list[Problem]:
    out = _needs_items(q, tuple(TLX_DIMENSIONS), kind="number")
    index = {it.id: k for k, it in enumerate(q.items)}
    for dim in TLX_DIMENSIONS:
        if dim in index:
            it = q.items[index[dim]]
            if it.kind == "number" and (it.minimum, it.maximum) != (0, 100):
                out.append((f"items[{index[dim]}]", f"{it.minimum}..{it.maximum}", "a TLX rating is 0..100"))
            # The id is the key (the ratings and the weighting's choices meet by it), and the text is what
            # the participant rates: an id moved onto another scale's text would score silently wrong.
            if not it.text.strip().lower().startswith(TLX_DIMENSIONS[dim].lower()):
                out.append(
                    (
                        f"items[{index[dim]}].text",
                        it.text,
                        f"the rating with id {dim!r} must begin with its scale's name, "
                        f"{TLX_DIMENSIONS[dim]!r} (the name the paired comparisons use)",
                    )
                )
    pairs = [tlx_pair_id(a, b) for a, b in TLX_PAIRS]
    present = [p for p in pairs if p in index]
    if present and len(present) != len(pairs):
        missing = [p for p in pairs if p not in index]
        out.append(
            (
                "items",
                f"{len(present)} paired comparisons",
                f"the weighting needs all 15; missing {', '.join(missing)}",
            )
        )
    for (a, b), pid in zip(TLX_PAIRS, pairs, strict=True):
        if pid in index:
            it = q.items[index[pid]]
            want = {TLX_DIMENSIONS[a], TLX_DIMENSIONS[b]}
            if it.kind != "choice" or set(it.choices) != want or len(it.choices) != 2:
                out.append(
                    (
                        f"items[{index[pid]}].choices",
                        list(it.choices),
                        f"expected a choice of {' or '.join(sorted(want))}",
                    )
                )
    return out


def _tlx_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    ratings = {d: _num(a, d) for d in TLX_DIMENSIONS}
    out: dict[str, float | None] = dict(ratings)
    out["raw_tlx"] = _mean(list(ratings.values()))
    by_title = {t: d for d, t in TLX_DIMENSIONS.items()}
    weights = dict.fromkeys(TLX_DIMENSIONS, 0)
    answered = 0
    for x, y in TLX_PAIRS:
        chosen = a.get(tlx_pair_id(x, y))
        if isinstance(chosen, str) and by_title.get(chosen) in (x, y):
            weights[by_title[chosen]] += 1
            answered += 1
    if answered == len(TLX_PAIRS) and all(v is not None for v in ratings.values()):
        out["weighted_tlx"] = sum(weights[d] * (ratings[d] or 0.0) for d in TLX_DIMENSIONS) / len(TLX_PAIRS)
    else:
        out["weighted_tlx"] = None
    return out


_register(
    Scorer(
        name="nasa_tlx",
        title="NASA Task Load Index",
        scores=("raw_tlx", "weighted_tlx", *TLX_DIMENSIONS),
        check=_tlx_check,
        score=_tlx_score,
    )
)


# -- co-presence with virtual humans ---------------------------------------------------------------

COPRESENCE_ITEMS = ("cp1", "cp2", "cp3", "cp4", "cp5")
COPRESENCE_REVERSED = frozenset({"cp3", "cp5"})  # Bailenson et al. 2003: items 3 and 5 reverse coded


def _copresence_check(q: Questionnaire) -> list[Problem]:
    return (
        _needs_items(q, COPRESENCE_ITEMS)
        + _needs_scale(q, -3, 3, points=7)
        + _needs_reversed(q, COPRESENCE_ITEMS, COPRESENCE_REVERSED)
    )


def _copresence_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    values: list[float | None] = []
    for i in COPRESENCE_ITEMS:
        v = _num(a, i)
        values.append(None if v is None else _reversed(q, v) if i in COPRESENCE_REVERSED else v)
    return {"copresence": _mean(values)}


_register(
    Scorer(
        name="copresence",
        title="Co-presence with virtual humans",
        scores=("copresence",),
        check=_copresence_check,
        score=_copresence_score,
    )
)


# -- System Usability Scale -------------------------------------------------------------------------

SUS_ITEMS = tuple(f"q{k}" for k in range(1, 11))
SUS_REVERSED = frozenset(f"q{k}" for k in range(2, 11, 2))  # the even, negatively worded items


def _sus_check(q: Questionnaire) -> list[Problem]:
    return (
        _needs_items(q, SUS_ITEMS)
        + _needs_scale(q, 1, 5, points=5)
        + _needs_reversed(q, SUS_ITEMS, SUS_REVERSED)
    )


def _sus_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    values = [_num(a, i) for i in SUS_ITEMS]
    if any(v is None for v in values):
        return {"sus_score": None}
    total = 0.0
    for i, v in zip(SUS_ITEMS, values, strict=True):
        assert v is not None
        total += (5.0 - v) if i in SUS_REVERSED else (v - 1.0)
    return {"sus_score": 2.5 * total}


_register(
    Scorer(
        name="sus",
        title="System Usability Scale",
        scores=("sus_score",),
        check=_sus_check,
        score=_sus_score,
    )
)


# -- the default for Likert questionnaires ---------------------------------------------------------


def _mean_check(q: Questionnaire) -> list[Problem]:
    if q.kind != "likert":
        return [("questionnaire.kind", q.kind, "mean scoring is for likert questionnaires")]
    return []


def _mean_score(q: Questionnaire, a: Answers) -> dict[str, float | None]:
    values = []
    for it in q.items:
        v = _num(a, it.id)
        if v is not None:
            values.append(_reversed(q, v) if it.reverse else v)
    return {"mean": sum(values) / len(values) if values else None}


_register(
    Scorer(name="mean", title="Mean of the items", scores=("mean",), check=_mean_check, score=_mean_score)
)


def score_answers(q: Questionnaire, answers: Answers) -> dict[str, float | None]:
    """``q``'s scores for one administration (``{}`` for a questionnaire without scoring)."""
    if not q.scoring:
        return {}
    return scorers[q.scoring].score(q, answers)
