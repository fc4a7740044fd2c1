"""Questionnaires as data: SSQ scoring by hand, validation errors, recoding (PedVR §6.2.4)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pedvr.study.errors import AnswerError, ProtocolError
from pedvr.study.questionnaire import Response, check_response, load_questionnaire, recode, score_ssq

QDIR = Path(__file__).resolve().parents[2] / "user_study" / "questionnaires"


def _ssq(**set_items: int) -> dict[int, int]:
    r = {k: 0 for k in range(1, 17)}
    r.update({int(k[1:]): v for k, v in set_items.items()})
    return r


def test_ssq_item_on_two_subscales_counts_in_both_and_twice_in_total() -> None:
    # Item 1 (general discomfort) is on Nausea and Oculomotor; item 5 (difficulty focusing) on
    # Oculomotor and Disorientation. Raw sums: N = 2, O = 2 + 3 = 5, D = 3.
    s = score_ssq(_ssq(i1=2, i5=3))
    assert (s.raw_nausea, s.raw_oculomotor, s.raw_disorientation) == (2, 5, 3)
    assert s.nausea == pytest.approx(2 * 9.54)
    assert s.oculomotor == pytest.approx(5 * 7.58)
    assert s.disorientation == pytest.approx(3 * 13.92)
    assert s.total == pytest.approx((2 + 5 + 3) * 3.74)


def test_ssq_hand_computed_full_case() -> None:
    # Items 1..16 answered 0,1,2,3,0,1,2,3,... : N items 1,6,7,8,9,15,16 -> 0+1+2+3+0+2+3 = 11;
    # O items 1,2,3,4,5,9,11 -> 0+1+2+3+0+0+2 = 8; D items 5,8,10,11,12,13,14 -> 0+3+1+2+3+0+1 = 10.
    r = {k: (k - 1) % 4 for k in range(1, 17)}
    s = score_ssq(r)
    assert (s.raw_nausea, s.raw_oculomotor, s.raw_disorientation) == (11, 8, 10)
    assert s.nausea == pytest.approx(104.94)
    assert s.oculomotor == pytest.approx(60.64)
    assert s.disorientation == pytest.approx(139.2)
    assert s.total == pytest.approx(108.46)


def test_ssq_all_severe_maximum() -> None:
    s = score_ssq({k: 3 for k in range(1, 17)})
    assert s.total == pytest.approx(3.74 * 3 * 21)
    assert s.nausea == pytest.approx(9.54 * 21)


@pytest.mark.parametrize("answers, message", [
    ({k: 0 for k in range(1, 16)}, r"ssq item 16: missing"),
    ({**{k: 0 for k in range(1, 17)}, 3: 4}, r"ssq item 3 = 4: expected an integer 0\.\.3"),
    ({**{k: 0 for k in range(1, 17)}, 17: 1}, r"ssq item 17: expected an item number 1\.\.16"),
])
def test_ssq_bad_answers(answers: dict[int, int], message: str) -> None:
    with pytest.raises(AnswerError, match=message):
        score_ssq(answers)


def test_shipped_questionnaires_load() -> None:
    ssq = load_questionnaire(QDIR / "ssq.toml")
    assert ssq.kind == "ssq" and len(ssq.items) == 16 and ssq.items[0].id == "general_discomfort"
    sp = load_questionnaire(QDIR / "social_presence.toml")
    assert sp.kind == "pairwise" and len(sp.items) == 8
    assert sp.scale is not None and sp.scale.label(1) == "Left much better" and sp.scale.label(7) == "Right much better"
    for f in QDIR.glob("*.toml"):
        load_questionnaire(f)


def test_bad_questionnaire_lists_every_problem(tmp_path: Path) -> None:
    f = tmp_path / "bad.toml"
    f.write_text("""
[questionnaire]
id = "bad"
title = "Bad"
kind = "pairwise"
colour = "red"

[scale]
min = 1
max = 6
labels = ["a", "b", "NA"]

[[items]]
id = "q1"
text = "One"

[[items]]
id = "q1"
text = "Two"
reverse = true
""")
    with pytest.raises(ProtocolError) as exc:
        load_questionnaire(f)
    lines = exc.value.problems
    assert any(line.startswith(f"{f}: questionnaire.colour = 'red': unknown key") for line in lines)
    assert any('scale.labels = ["a", "b", "NA"]: 3 labels; expected 6, one per point 1..6' in line for line in lines)
    assert any("items[1].id = 'q1': duplicate item id" in line for line in lines)
    assert any("scale.labels[2] = 'NA': reads back as a missing value in pandas or R" in line for line in lines)
    assert any("items[1].reverse = true: only likert items can be reverse scored" in line for line in lines)


def test_ssq_file_must_have_16_items(tmp_path: Path) -> None:
    text = (QDIR / "ssq.toml").read_text()
    cut = text[: text.rindex("[[items]]")]
    f = tmp_path / "ssq.toml"
    f.write_text(cut)
    with pytest.raises(ProtocolError, match=r"ssq\.toml: items = '15 items': the SSQ has exactly 16 items"):
        load_questionnaire(f)


def test_recode_pairwise_and_reverse_likert() -> None:
    sp = load_questionnaire(QDIR / "social_presence.toml")
    item = sp.items[0]
    assert recode(sp, item, 2, flipped=False) == 2.0
    assert recode(sp, item, 2, flipped=True) == 6.0
    assert recode(sp, item, 4, flipped=True) == 4.0
    lk = load_questionnaire(QDIR / "realism_rating.toml")
    assert recode(lk, lk.item("robotic"), 7) == 1.0
    assert recode(lk, lk.item("natural_motion"), 7) == 7.0


def test_check_response_messages() -> None:
    sp = load_questionnaire(QDIR / "social_presence.toml")
    with pytest.raises(AnswerError, match=r"social_presence\.same_space = 8: expected an integer 1\.\.7"):
        check_response(sp, sp.items[0], Response(value=8))
    with pytest.raises(AnswerError, match=r"social_presence\.same_space: no answer: this item is required"):
        check_response(sp, sp.items[0], Response())
    demo = load_questionnaire(QDIR / "demographics.toml")
    with pytest.raises(AnswerError, match=r"demographics\.age = 5\.0: expected a number in 16\.\.110"):
        check_response(demo, demo.item("age"), Response(value=5.0))
    with pytest.raises(AnswerError, match=r"demographics\.gender = 'cat': expected one of female"):
        check_response(demo, demo.item("gender"), Response(text="cat"))
    assert check_response(demo, demo.item("age"), Response()) == Response()


def _swap_items(tmp_path: Path, name: str, a: int, b: int, *, ids_only: bool = False) -> Path:
    """A copy of a shipped questionnaire with items ``a`` and ``b`` (0-based) swapped: whole items (id,
    text and flags move together, as when blocks are reordered) or only their ids (texts stay)."""
    import tomllib

    import tomli_w

    data = tomllib.loads((QDIR / name).read_text())
    items = data["items"]
    if ids_only:
        items[a]["id"], items[b]["id"] = items[b]["id"], items[a]["id"]
    else:
        items[a], items[b] = items[b], items[a]
    f = tmp_path / name
    f.write_bytes(tomli_w.dumps(data).encode())
    return f


def test_ssq_with_items_1_and_2_swapped_is_refused_at_load(tmp_path: Path) -> None:
    # The SSQ is scored by position: with general discomfort (item 1, on Nausea and Oculomotor) answered
    # "severe" and everything else "none", Kennedy's key gives Nausea 28.62 and Total 22.44; stored at
    # position 2 (fatigue, Oculomotor only) the same answer would score Nausea 0 and Total 11.22.
    right = score_ssq(_ssq(i1=3))
    assert (right.nausea, right.total) == (pytest.approx(28.62), pytest.approx(22.44))
    wrong = score_ssq(_ssq(i2=3))
    assert (wrong.nausea, wrong.total) == (0, pytest.approx(11.22))
    f = _swap_items(tmp_path, "ssq.toml", 0, 1)
    with pytest.raises(ProtocolError) as exc:
        load_questionnaire(f)
    assert exc.value.problems == [
        f"{f}: items[0].id = 'fatigue': expected 'general_discomfort', item 1 of Kennedy et al. (1993): the SSQ "
        "is scored by position, so its items keep the standard order; fatigue is item 2",
        f"{f}: items[1].id = 'general_discomfort': expected 'fatigue', item 2 of Kennedy et al. (1993): the SSQ "
        "is scored by position, so its items keep the standard order; general_discomfort is item 1",
    ]


def test_ssq_with_an_unknown_symptom_id_lists_the_ids(tmp_path: Path) -> None:
    f = tmp_path / "ssq.toml"
    f.write_text((QDIR / "ssq.toml").read_text().replace('id = "burping"', 'id = "belching"'))
    with pytest.raises(ProtocolError, match=r"ssq\.toml: items\[15\]\.id = 'belching': expected 'burping', item 16 "
                                            r"of Kennedy et al\. \(1993\).*; the ids are general_discomfort, fatigue"):
        load_questionnaire(f)
