"""The standard instruments: shipped files load with their published scoring, each scorer against hand
computations, and files that do not match their scoring are refused naming what is wrong."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pedvr.study.errors import AnswerError, ProtocolError
from pedvr.study.questionnaire import Response, check_response, load_questionnaire
from pedvr.study.scoring import TLX_PAIRS, score_answers, scorers, tlx_pair_id

QDIR = Path(__file__).resolve().parents[2] / "user_study" / "questionnaires"
INSTRUMENTS = {
    "ipq": ("ipq", 14),
    "slater_usoh_steed": ("slater_usoh_steed", 6),
    "nasa_tlx": ("nasa_tlx", 21),
    "nasa_tlx_raw": ("nasa_tlx", 6),
    "copresence": ("copresence", 5),
    "sus": ("sus", 10),
}


@pytest.mark.parametrize("qid", sorted(INSTRUMENTS))
def test_shipped_instruments_load_with_their_scoring_and_cite_a_source(qid: str) -> None:
    q = load_questionnaire(QDIR / f"{qid}.toml")
    scoring, n_items = INSTRUMENTS[qid]
    assert (q.id, q.scoring, len(q.items)) == (qid, scoring, n_items)
    assert re.search(r"\((19|20)\d\d\)", q.citation)  # an author-year source
    text = (QDIR / f"{qid}.toml").read_text()
    assert "# Source:" in text  # the file says where the items come from and why they may be reproduced


def test_ipq_by_hand() -> None:
    q = load_questionnaire(QDIR / "ipq.toml")
    raw = {"g1": 5, "sp1": 6, "sp2": 1, "sp3": 4, "sp4": 3, "sp5": 5, "inv1": 2, "inv2": 3, "inv3": 6, "inv4": 1,
           "real1": 0, "real2": 2, "real3": 3, "real4": 1}
    s = score_answers(q, raw)
    # SP2, INV3, REAL1 reversed on 0..6: 6 - answer
    assert s["general_presence"] == 5
    assert s["spatial_presence"] == pytest.approx((6 + (6 - 1) + 4 + 3 + 5) / 5)
    assert s["involvement"] == pytest.approx((2 + 3 + (6 - 6) + 1) / 4)
    assert s["experienced_realism"] == pytest.approx(((6 - 0) + 2 + 3 + 1) / 4)
    # the stored recoded values agree with the scoring (the file marks exactly the published reversed items)
    assert {it.id for it in q.items if it.reverse} == {"sp2", "inv3", "real1"}
    # a missing item leaves its subscale undefined, the others stand
    s = score_answers(q, {**raw, "inv2": None})
    assert s["involvement"] is None and s["spatial_presence"] is not None
    # anchors are the item's own: the IPQ's differ from item to item
    assert q.label(q.item("real1"), 0) == "completely real" and q.label(q.item("real1"), 6) == "not real at all"
    assert q.label(q.item("sp1"), 3) == ""


def test_slater_usoh_steed_by_hand() -> None:
    q = load_questionnaire(QDIR / "slater_usoh_steed.toml")
    s = score_answers(q, {"sus1": 7, "sus2": 6, "sus3": 5, "sus4": 6, "sus5": 2, "sus6": 1})
    assert s == {"sus_count": 3.0, "sus_mean": pytest.approx(27 / 6)}
    assert score_answers(q, {"sus1": 7})["sus_count"] is None


def test_nasa_tlx_raw_and_weighted_by_hand() -> None:
    q = load_questionnaire(QDIR / "nasa_tlx.toml")
    ratings = {"mental": 70, "physical": 20, "temporal": 50, "performance": 30, "effort": 60, "frustration": 10}
    names = {"mental": "Mental Demand", "physical": "Physical Demand", "temporal": "Temporal Demand",
             "performance": "Performance", "effort": "Effort", "frustration": "Frustration"}
    # choose the first of each pair, except that effort beats everything after it
    chosen = {}
    for a, b in TLX_PAIRS:
        chosen[tlx_pair_id(a, b)] = names[b] if b == "effort" else names[a]
    # tallies: effort wins its 5 pairs, every other scale the pairs where it comes first (except vs effort)
    tally = dict.fromkeys(names, 0)
    for a, b in TLX_PAIRS:
        tally[b if b == "effort" else a] += 1
    assert sum(tally.values()) == 15
    s = score_answers(q, {**ratings, **chosen})
    assert s["raw_tlx"] == pytest.approx(sum(ratings.values()) / 6)
    assert s["weighted_tlx"] == pytest.approx(sum(ratings[d] * tally[d] for d in names) / 15)
    assert s["mental"] == 70
    # without the comparisons only the raw TLX
    raw_only = score_answers(load_questionnaire(QDIR / "nasa_tlx_raw.toml"), ratings)
    assert raw_only["raw_tlx"] == pytest.approx(40.0) and raw_only["weighted_tlx"] is None


def test_nasa_tlx_ratings_are_on_the_forms_21_marks() -> None:
    q = load_questionnaire(QDIR / "nasa_tlx_raw.toml")
    item = q.item("mental")
    assert check_response(q, item, Response(value=35)).value == 35
    with pytest.raises(AnswerError, match=r"nasa_tlx_raw\.mental = 37: expected a multiple of 5 from 0"):
        check_response(q, item, Response(value=37))
    with pytest.raises(AnswerError, match=r"nasa_tlx_raw\.mental = 105: expected a number in 0\.\.100"):
        check_response(q, item, Response(value=105))


def test_copresence_by_hand() -> None:
    q = load_questionnaire(QDIR / "copresence.toml")
    s = score_answers(q, {"cp1": 2, "cp2": 3, "cp3": -1, "cp4": 0, "cp5": 2})
    assert s["copresence"] == pytest.approx((2 + 3 + 1 + 0 - 2) / 5)  # items 3 and 5 reversed: -answer


def test_system_usability_scale_by_hand() -> None:
    q = load_questionnaire(QDIR / "sus.toml")
    answers = {f"q{k}": v for k, v in enumerate([4, 2, 5, 1, 4, 2, 5, 1, 4, 3], start=1)}
    # odd: answer - 1 -> 3, 4, 3, 4, 3 = 17; even: 5 - answer -> 3, 4, 3, 4, 2 = 16; (17 + 16) * 2.5
    assert score_answers(q, answers)["sus_score"] == pytest.approx(82.5)
    assert score_answers(q, {f"q{k}": 1 if k % 2 else 5 for k in range(1, 11)})["sus_score"] == 0.0
    assert score_answers(q, {f"q{k}": 5 if k % 2 else 1 for k in range(1, 11)})["sus_score"] == 100.0


def test_plain_likert_is_scored_as_the_mean_of_recoded_items() -> None:
    q = load_questionnaire(QDIR / "realism_rating.toml")
    assert q.scoring == "mean"
    # robotic is reversed on 1..7: 8 - 2 = 6
    assert score_answers(q, {"natural_motion": 6, "noticed_me": 4, "robotic": 2})["mean"] == pytest.approx(16 / 3)


def _write(tmp_path: Path, name: str, body: str) -> Path:
    f = tmp_path / f"{name}.toml"
    f.write_text(body)
    return f


def test_a_file_that_does_not_match_its_scoring_is_refused(tmp_path: Path) -> None:
    text = (QDIR / "ipq.toml").read_text()
    # SP2 not reversed, INV1 missing
    text = text.replace('labels = ["fully disagree", "", "", "", "", "", "fully agree"]\nreverse = true\n\n[[items]]\nid = "sp3"',
                        'labels = ["fully disagree", "", "", "", "", "", "fully agree"]\n\n[[items]]\nid = "sp3"', 1)
    text = text.replace('id = "inv1"', 'id = "inv1x"')
    f = _write(tmp_path, "ipq", text)
    with pytest.raises(ProtocolError) as exc:
        load_questionnaire(f)
    lines = exc.value.problems
    assert any(line.startswith(f"{f}: items = [") and "needs items inv1 (ipq scoring)" in line for line in lines)
    assert f"{f}: items[2].reverse = false: must be true (a reversed item) (ipq scoring)" in lines


def test_unknown_scoring_lists_the_known_ones(tmp_path: Path) -> None:
    f = _write(tmp_path, "x", '[questionnaire]\nid = "x"\ntitle = "X"\nkind = "likert"\nscoring = "ipq2"\n'
                              '[scale]\nmin = 1\nmax = 3\nlabels = ["a", "", "c"]\n[[items]]\nid = "a"\ntext = "A"\n')
    with pytest.raises(ProtocolError, match=r"questionnaire\.scoring = 'ipq2': unknown questionnaire scoring 'ipq2'; "
                                            r"known: copresence, ipq, mean, nasa_tlx, slater_usoh_steed, sus"):
        load_questionnaire(f)
    assert sorted(scorers) == ["copresence", "ipq", "mean", "nasa_tlx", "slater_usoh_steed", "sus"]


def test_item_labels_and_steps_are_checked(tmp_path: Path) -> None:
    f = _write(tmp_path, "y", '[questionnaire]\nid = "y"\ntitle = "Y"\nkind = "form"\n'
                              '[scale]\nmin = 1\nmax = 3\nlabels = ["a", "", "c"]\n'
                              '[[items]]\nid = "a"\nkind = "scale"\ntext = "A"\nlabels = ["x", "NA"]\n'
                              '[[items]]\nid = "b"\nkind = "number"\ntext = "B"\nstep = 5\n'
                              '[[items]]\nid = "c"\nkind = "text"\ntext = "C"\nstep = 1\n')
    with pytest.raises(ProtocolError) as exc:
        load_questionnaire(f)
    lines = exc.value.problems
    assert f"{f}: items[0].labels[1] = 'NA': reads back as a missing value in pandas or R; reword it (e.g. lower case)" in lines
    assert f'{f}: items[0].labels = ["x", "NA"]: 2 labels; expected 3, one per point 1..3' in lines
    assert f"{f}: items[1].step = 5.0: a step needs the item's min (answers are min + k * step)" in lines
    assert f"{f}: items[2].step = 1: only number items have a step" in lines


def _swapped(tmp_path: Path, name: str, a: int, b: int, *, ids_only: bool) -> Path:
    import tomllib

    import tomli_w

    data = tomllib.loads((QDIR / name).read_text())
    items = data["items"]
    if ids_only:
        items[a]["id"], items[b]["id"] = items[b]["id"], items[a]["id"]
    else:
        items[a], items[b] = items[b], items[a]
    f = tmp_path / f"{a}_{name}"
    f.write_bytes(tomli_w.dumps(data).encode())
    return f


def _scores(q: object, answers: dict[str, object]) -> dict[str, float | None]:
    """``q``'s scores as the analysis computes them: the SSQ by position (the stored item number), the
    others by their registered scoring, by item id."""
    from pedvr.study.questionnaire import score_ssq

    if q.kind == "ssq":  # type: ignore[attr-defined]
        return score_ssq({it.number: answers[it.id] for it in q.items}).as_dict()  # type: ignore[attr-defined]
    return score_answers(q, answers)  # type: ignore[arg-type]


def _answers(q: object, rng: object) -> dict[str, object]:
    out: dict[str, object] = {}
    for it in q.items:  # type: ignore[attr-defined]
        if it.kind == "scale":
            out[it.id] = int(rng.integers(q.scale.minimum, q.scale.maximum + 1))  # type: ignore[attr-defined]
        elif it.kind == "number":
            out[it.id] = float(rng.integers(0, 21) * 5)  # type: ignore[attr-defined]
        else:
            out[it.id] = str(rng.choice(list(it.choices)))  # type: ignore[attr-defined]
    return out


SCORED = sorted([*(f"{q}.toml" for q in INSTRUMENTS), "ssq.toml"])


@pytest.mark.parametrize("name", SCORED)
def test_reordered_items_are_refused_or_score_the_same(name: str, tmp_path: Path) -> None:
    """Issue 25.1: moving an item (id, text and flags together) to another place in a scored instrument
    never scores silently wrong: the SSQ, keyed by position, refuses the file naming the item; the
    instruments keyed by id score the same answers the same."""
    import numpy as np

    q = load_questionnaire(QDIR / name)
    rng = np.random.default_rng(7)
    answers = _answers(q, rng)
    want = _scores(q, answers)
    refused = 0
    for k in range(len(q.items) - 1):
        f = _swapped(tmp_path, name, k, k + 1, ids_only=False)
        try:
            moved = load_questionnaire(f)
        except ProtocolError as exc:
            assert f"{f}: items[{k}].id = " in str(exc)
            refused += 1
            continue
        assert _scores(moved, answers) == want, f"items {k} and {k + 1} swapped score differently"
    assert refused == (len(q.items) - 1 if q.kind == "ssq" else 0)


@pytest.mark.parametrize("name", ["ssq.toml", "sus.toml", "copresence.toml", "nasa_tlx.toml", "nasa_tlx_raw.toml",
                                  "slater_usoh_steed.toml"])
def test_an_id_moved_onto_another_items_text_is_refused_or_harmless(name: str, tmp_path: Path) -> None:
    """Swapping two ids while the texts stay is refused where it would change a score: by position (SSQ),
    by the published reversed items (SUS, co-presence), by the scale each TLX rating names. (The IPQ
    cannot tell: an id moved between two unreversed items of different subscales is not detectable
    without binding ids to texts, which would refuse translations.)"""
    import numpy as np

    q = load_questionnaire(QDIR / name)
    answers_by_text = {it.text: v for it, v in zip(q.items, _answers(q, np.random.default_rng(3)).values(),
                                                      strict=True)}
    want = _scores(q, {it.id: answers_by_text[it.text] for it in q.items})
    for k in range(len(q.items) - 1):
        f = _swapped(tmp_path, name, k, k + 1, ids_only=True)
        try:
            moved = load_questionnaire(f)
        except ProtocolError:
            continue
        # the participant answers the texts they see; the scores must not change
        got = _scores(moved, {it.id: answers_by_text[it.text] for it in moved.items})
        assert got == want, f"ids of items {k} and {k + 1} swapped: scored {got}, expected {want}"


def test_tlx_rating_must_name_its_scale(tmp_path: Path) -> None:
    f = _swapped(tmp_path, "nasa_tlx_raw.toml", 0, 1, ids_only=True)
    with pytest.raises(ProtocolError, match=r"items\[0\]\.text = 'Mental Demand: How mentally demanding was the "
                                            r"task\? .*': the rating with id 'physical' must begin with its scale's "
                                            r"name, 'Physical Demand' \(the name the paired comparisons use\) "
                                            r"\(nasa_tlx scoring\)"):
        load_questionnaire(f)
