"""Questionnaires as data: loading, validating, answering and scoring.

A questionnaire is a TOML file in ``user_study/questionnaires/`` (format in
``user_study/EXPERIMENTER.md``). Four kinds:

``ssq``       the Simulator Sickness Questionnaire (Kennedy et al. 1993), 16
              symptoms scored 0–3, administered before and after the study
              (PedVR §6.2.4, §6.4); scored by :func:`score_ssq`.
``pairwise``  items answered once per pair of conditions on a bipolar scale
              whose minimum means "the left one much better" — the social
              presence questionnaire of PedVR Table 2 (Garau et al. 2005).
``likert``    items on one scale, each optionally ``reverse`` scored, for
              questionnaires other studies add (e.g. single-condition ratings).
``form``      free items: ``text``, ``number``, ``choice`` and ``consent``
              (consent, demographics, feedback).

Raw answers are stored as shown; :func:`recode` maps them to the fixed
orientation the analysis uses (see its docstring).

A questionnaire may name its published scoring (``scoring = "ipq"``): a
function registered in :mod:`pedvr.study.scoring` that checks the file has
the items, scale and reversed items the instrument needs (at load, with the
other problems) and turns one administration's answers into its scores.
Likert questionnaires without one are scored as the mean of their recoded
items (``scoring = "mean"``).

Scale points may carry per-item labels (``labels`` on the item, one per point,
overriding the scale's: the IPQ's and the Slater–Usoh–Steed questionnaire's
anchors differ from item to item); an empty label leaves a point unlabelled
(it shows as its number and is stored with no label).
"""

from __future__ import annotations

import hashlib
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pedvr.study.errors import AnswerError, ProtocolError
from pedvr.study.instrument import ITEM_KINDS, KINDS, Item, Questionnaire, Response, Scale
from pedvr.study.scoring import scorers
from pedvr.validation import MISSING, Checker

# Kennedy, Lane, Berbaum & Lilienthal (1993), Table 1 ("SSQ scoring"): item
# numbers 1..16 in the standard order (general discomfort ... burping). Items
# 1, 5, 8, 9 and 11 count on two subscales.
SSQ_NAUSEA = (1, 6, 7, 8, 9, 15, 16)
SSQ_OCULOMOTOR = (1, 2, 3, 4, 5, 9, 11)
SSQ_DISORIENTATION = (5, 8, 10, 11, 12, 13, 14)
SSQ_WEIGHTS = {"nausea": 9.54, "oculomotor": 7.58, "disorientation": 13.92, "total": 3.74}
SSQ_ITEMS = 16
# The 16 symptoms by the ids the shipped file gives them, in Kennedy et al.'s order: the key above is by
# position, so a file must list exactly these ids in exactly this order (checked at load).
SSQ_ITEM_IDS = (
    "general_discomfort",
    "fatigue",
    "headache",
    "eye_strain",
    "difficulty_focusing",
    "increased_salivation",
    "sweating",
    "nausea",
    "difficulty_concentrating",
    "fullness_of_head",
    "blurred_vision",
    "dizzy_eyes_open",
    "dizzy_eyes_closed",
    "vertigo",
    "stomach_awareness",
    "burping",
)
# Cell texts that pandas.read_csv (defaults) or R read as missing: not allowed as scale labels, so
# exported answers keep their labels.
MISSING_SPELLINGS = frozenset(
    {
        "",
        "#N/A",
        "#N/A N/A",
        "#NA",
        "-1.#IND",
        "-1.#QNAN",
        "-NaN",
        "-nan",
        "1.#IND",
        "1.#QNAN",
        "<NA>",
        "N/A",
        "NA",
        "NULL",
        "NaN",
        "None",
        "n/a",
        "nan",
        "null",
    }
)


def load_questionnaire(path: str | Path, *, display_path: str | None = None) -> Questionnaire:
    """Load and validate one questionnaire file; raise one :class:`ProtocolError` with all problems."""
    p = Path(path)
    shown = display_path or str(path)
    if not p.is_file():
        raise ProtocolError([f"{shown}: no such questionnaire file"])
    raw = p.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProtocolError([f"{shown}: not valid TOML: {exc}"]) from None
    q = parse_questionnaire(data, source=shown, content_hash=hashlib.sha256(raw).hexdigest()[:16])
    return replace(q, document=raw.decode("utf-8"))


def parse_questionnaire(data: dict[str, Any], *, source: str, content_hash: str = "") -> Questionnaire:
    """Validate a parsed questionnaire document."""
    c = Checker(source)
    c.known(data, "", ("questionnaire", "scale", "items"))
    q = c.table(data, "questionnaire", "questionnaire", required=True) or {}
    c.known(q, "questionnaire", ("id", "title", "kind", "instructions", "citation", "scoring"))
    qid = c.string(q, "id", "questionnaire.id")
    title = c.string(q, "title", "questionnaire.title")
    kind = c.string(q, "kind", "questionnaire.kind", choices=KINDS)
    instructions = c.string(q, "instructions", "questionnaire.instructions", required=False, default="")
    citation = c.string(q, "citation", "questionnaire.citation", required=False, default="")
    scoring = c.string(q, "scoring", "questionnaire.scoring", required=False, default="")
    if scoring and scoring not in scorers:
        c.bad("questionnaire.scoring", scoring, scorers.unknown(scoring))
        scoring = None

    scale = _scale(c, data.get("scale", MISSING), kind)
    items = _items(c, data, kind, scale)

    if kind == "ssq" and scale is not None and (scale.minimum, scale.maximum) != (0, 3):
        c.bad("scale", f"{scale.minimum}..{scale.maximum}", "the SSQ is scored 0..3 (Kennedy et al. 1993)")
    if kind == "ssq" and items is not None and len(items) != SSQ_ITEMS:
        c.bad("items", f"{len(items)} items", f"the SSQ has exactly {SSQ_ITEMS} items, in the standard order")
    elif kind == "ssq" and items is not None:
        _check_ssq_order(c, items)
    if kind == "pairwise" and scale is not None and (scale.maximum - scale.minimum) % 2 != 0:
        c.bad(
            "scale",
            f"{scale.minimum}..{scale.maximum}",
            "a pairwise scale needs a middle point (an odd number of points) meaning no difference",
        )
    if kind == "likert" and not scoring and scoring is not None:
        scoring = "mean"
    if c.problems:
        raise ProtocolError(c.problems)
    assert qid is not None and title is not None and kind is not None and items is not None
    out = Questionnaire(
        id=qid,
        title=title,
        kind=kind,
        instructions=instructions or "",
        scale=scale,
        items=items,
        source=source,
        content_hash=content_hash,
        citation=citation or "",
        scoring=scoring or "",
    )
    if out.scoring:
        for key, value, why in scorers[out.scoring].check(out):
            c.bad(key, value, f"{why} ({out.scoring} scoring)")
        if c.problems:
            raise ProtocolError(c.problems)
    return out


def _check_ssq_order(c: Checker, items: tuple[Item, ...]) -> None:
    """The SSQ is scored by item position (Kennedy et al. 1993, Table 1): item k must be symptom k.

    Ids are the only thing a file carries that says which symptom an item is (texts may be
    translated), so each position must hold the standard id: two swapped items name both positions.
    """
    for k, (it, want) in enumerate(zip(items, SSQ_ITEM_IDS, strict=True)):
        if it.id != want:
            then = (
                f"; {it.id} is item {SSQ_ITEM_IDS.index(it.id) + 1}"
                if it.id in SSQ_ITEM_IDS
                else f"; the ids are {', '.join(SSQ_ITEM_IDS)}"
            )
            c.bad(
                f"items[{k}].id",
                it.id,
                f"expected {want!r}, item {k + 1} of Kennedy et al. (1993): the SSQ is scored by position, "
                f"so its items keep the standard order{then}",
            )


def _labels(c: Checker, d: dict[str, Any], key: str, path: str) -> tuple[str, ...] | None:
    """Point labels: strings, "" allowed (an unlabelled point), no spelling that reads back as missing.

    Labels with a bad spelling are returned anyway (so their count is checked too); the problem is recorded.
    """
    v = d.get(key, MISSING)
    if not isinstance(v, list) or len(v) < 2 or not all(isinstance(x, str) for x in v):
        c.bad(path, v, "expected an array of at least 2 strings, one per scale point (\"\" for no label)")
        return None
    for k, lab in enumerate(v):
        if lab.strip() in MISSING_SPELLINGS and lab != "":
            why = "reads back as a missing value in pandas or R; reword it (e.g. lower case)"
            c.bad(f"{path}[{k}]", lab, why)
    return tuple(v)


def _scale(c: Checker, s: Any, kind: str | None) -> Scale | None:
    needs = kind in ("ssq", "pairwise", "likert")
    if s is MISSING:
        if needs:
            c.bad("scale", s, f"required table for a {kind} questionnaire")
        return None
    if not isinstance(s, dict):
        c.bad("scale", s, "expected a table")
        return None
    c.known(s, "scale", ("min", "max", "labels"))
    lo = c.integer(s, "min", "scale.min")
    hi = c.integer(s, "max", "scale.max")
    labels = _labels(c, s, "labels", "scale.labels")
    if lo is None or hi is None or labels is None:
        return None
    if hi <= lo:
        c.bad("scale.max", hi, f"must be > scale.min ({lo})")
        return None
    if len(labels) != hi - lo + 1:
        c.bad(
            "scale.labels",
            list(labels),
            f"{len(labels)} labels; expected {hi - lo + 1}, one per point {lo}..{hi}",
        )
        return None
    return Scale(minimum=lo, maximum=hi, labels=labels)


def _items(
    c: Checker, data: dict[str, Any], kind: str | None, scale: Scale | None
) -> tuple[Item, ...] | None:
    raw = c.tables(data, "items", "items", required=True)
    out: list[Item] = []
    seen: set[str] = set()
    ok = bool(raw)
    for k, it in enumerate(raw):
        path = f"items[{k}]"
        c.known(
            it, path, ("id", "text", "kind", "reverse", "required", "choices", "min", "max", "labels", "step")
        )
        iid = c.string(it, "id", f"{path}.id")
        text = c.string(it, "text", f"{path}.text")
        default_kind = "scale" if kind in ("ssq", "pairwise", "likert") else None
        ikind = c.string(
            it,
            "kind",
            f"{path}.kind",
            required=default_kind is None,
            default=default_kind,
            choices=ITEM_KINDS,
        )
        if kind in ("ssq", "pairwise", "likert") and ikind is not None and ikind != "scale":
            c.bad(f"{path}.kind", ikind, f"a {kind} questionnaire has only scale items")
            ikind = None
        if kind == "form" and ikind == "scale" and scale is None:
            c.bad(f"{path}.kind", ikind, "a scale item needs a [scale] table")
            ikind = None
        reverse = c.boolean(it, "reverse", f"{path}.reverse", default=False)
        if reverse and kind != "likert":
            c.bad(f"{path}.reverse", reverse, "only likert items can be reverse scored")
        required = c.boolean(it, "required", f"{path}.required", default=True)
        choices: tuple[str, ...] | None = ()
        if ikind == "choice":
            choices = c.strings(it, "choices", f"{path}.choices", minimum=2)
        elif "choices" in it:
            c.bad(f"{path}.choices", it["choices"], "only choice items have choices")
        lo = c.number(it, "min", f"{path}.min", required=False) if ikind == "number" else None
        hi = c.number(it, "max", f"{path}.max", required=False) if ikind == "number" else None
        step = None
        if "step" in it:
            if ikind != "number":
                c.bad(f"{path}.step", it["step"], "only number items have a step")
            else:
                step = c.number(it, "step", f"{path}.step", check=lambda x: x > 0, expect="> 0")
                if step is not None and lo is None:
                    c.bad(f"{path}.step", step, "a step needs the item's min (answers are min + k * step)")
        if lo is not None and hi is not None and hi <= lo:
            c.bad(f"{path}.max", hi, f"must be > {path}.min ({lo:g})")
        item_labels: tuple[str, ...] | None = ()
        if "labels" in it:
            if ikind != "scale" or scale is None:
                c.bad(f"{path}.labels", it["labels"], "only scale items have point labels")
            else:
                item_labels = _labels(c, it, "labels", f"{path}.labels")
                if item_labels is not None and len(item_labels) != scale.maximum - scale.minimum + 1:
                    c.bad(
                        f"{path}.labels",
                        list(item_labels),
                        f"{len(item_labels)} labels; expected {scale.maximum - scale.minimum + 1}, one per "
                        "point "
                        f"{scale.minimum}..{scale.maximum}",
                    )
                    item_labels = None
        if iid is not None and iid in seen:
            c.bad(f"{path}.id", iid, "duplicate item id")
        if iid is not None:
            seen.add(iid)
        if iid is None or text is None or ikind is None or choices is None or item_labels is None:
            ok = False
            continue
        out.append(
            Item(
                id=iid,
                number=k + 1,
                text=text,
                kind=ikind,
                reverse=reverse,
                required=required,
                choices=choices,
                minimum=lo,
                maximum=hi,
                labels=item_labels,
                step=step,
            )
        )
    return tuple(out) if ok else None


def check_response(q: Questionnaire, item: Item, r: Response) -> Response:
    """Validate ``r`` for ``item``; return it normalised (scale points as int).

    Raises :class:`AnswerError` naming the questionnaire, item and value.
    """
    where = f"{q.id}.{item.id}"
    if r.value is None and (r.text is None or r.text == ""):
        if item.required:
            raise AnswerError([f"{where}: no answer: this item is required"])
        return Response(value=None, text=None)
    if item.kind == "scale":
        assert q.scale is not None
        v = r.value
        if v is None or float(v) != int(v) or not q.scale.minimum <= int(v) <= q.scale.maximum:
            raise AnswerError([f"{where} = {v!r}: expected an integer {q.scale.minimum}..{q.scale.maximum}"])
        return Response(value=int(v), text=None)
    if item.kind == "number":
        v = r.value
        if (
            v is None
            or (item.minimum is not None and v < item.minimum)
            or (item.maximum is not None and v > item.maximum)
        ):
            lo = "-inf" if item.minimum is None else f"{item.minimum:g}"
            hi = "inf" if item.maximum is None else f"{item.maximum:g}"
            rng = f"{lo}..{hi}"
            raise AnswerError([f"{where} = {v!r}: expected a number in {rng}"])
        if item.step is not None and item.minimum is not None:
            k = (float(v) - item.minimum) / item.step
            if abs(k - round(k)) > 1e-9:
                raise AnswerError(
                    [f"{where} = {v!r}: expected a multiple of {item.step:g} from {item.minimum:g}"]
                )
        return Response(value=float(v), text=None)
    if item.kind in ("choice", "consent"):
        options = item.choices if item.kind == "choice" else ("yes", "no")
        if r.text not in options:
            raise AnswerError([f"{where} = {r.text!r}: expected one of {', '.join(options)}"])
        return Response(value=None, text=r.text)
    if r.text is None:
        raise AnswerError([f"{where}: expected text"])
    return Response(value=None, text=r.text)


def recode(q: Questionnaire, item: Item, value: int | float | None, *, flipped: bool = False) -> float | None:
    """The answer in the fixed orientation the analysis uses.

    Pairwise items: the protocol names each comparison ``left/right`` in a
    fixed order (PedVR Table 3: PedVR+G/Decoupled, PedVR/Decoupled,
    PedVR+G/PedVR). When the participant saw the pair the other way round
    (``flipped``), a raw ``v`` becomes ``min + max - v``, so the recoded value
    always means "1 = the fixed left condition much better". Likert items
    marked ``reverse`` are mirrored the same way. Everything else is unchanged.
    """
    if value is None or q.scale is None or item.kind != "scale":
        return None if value is None else float(value)
    mirror = (q.kind == "pairwise" and flipped) or (q.kind == "likert" and item.reverse)
    return float(q.scale.minimum + q.scale.maximum - value) if mirror else float(value)


@dataclass(frozen=True)
class SSQScore:
    """SSQ subscale scores (weighted) and the raw subscale sums (Kennedy et al. 1993)."""

    nausea: float
    oculomotor: float
    disorientation: float
    total: float
    raw_nausea: int
    raw_oculomotor: int
    raw_disorientation: int

    def as_dict(self) -> dict[str, float]:
        return {
            "nausea": self.nausea,
            "oculomotor": self.oculomotor,
            "disorientation": self.disorientation,
            "total": self.total,
        }


def score_ssq(responses: Mapping[int, int]) -> SSQScore:
    """Score one SSQ administration from ``{item number 1..16: 0..3}``.

    Nausea = 9.54 × Σ items (1, 6, 7, 8, 9, 15, 16); Oculomotor = 7.58 ×
    Σ (1, 2, 3, 4, 5, 9, 11); Disorientation = 13.92 × Σ (5, 8, 10, 11, 12,
    13, 14); Total = 3.74 × (sum of the three raw sums), so items on two
    subscales count twice in the total. Every item must be answered.
    """
    problems = [f"ssq item {k}: missing" for k in range(1, SSQ_ITEMS + 1) if k not in responses]
    for k, v in responses.items():
        if not isinstance(k, int) or not 1 <= k <= SSQ_ITEMS:
            problems.append(f"ssq item {k!r}: expected an item number 1..{SSQ_ITEMS}")
        elif v is None or float(v) != int(v) or not 0 <= int(v) <= 3:
            problems.append(f"ssq item {k} = {v!r}: expected an integer 0..3")
    if problems:
        raise AnswerError(problems)
    n = sum(int(responses[k]) for k in SSQ_NAUSEA)
    o = sum(int(responses[k]) for k in SSQ_OCULOMOTOR)
    d = sum(int(responses[k]) for k in SSQ_DISORIENTATION)
    w = SSQ_WEIGHTS
    return SSQScore(
        nausea=n * w["nausea"],
        oculomotor=o * w["oculomotor"],
        disorientation=d * w["disorientation"],
        total=(n + o + d) * w["total"],
        raw_nausea=n,
        raw_oculomotor=o,
        raw_disorientation=d,
    )
