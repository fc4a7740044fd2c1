"""The in-app participant's page/answer state machine (no window): choose, select, confirm, back."""

from __future__ import annotations

from pathlib import Path

import pytest

from pedvr.study.panel_input import NO_ANSWER, TOLD_EXPERIMENTER, PagePanel, PanelEvent, QuestionPanel, drive
from pedvr.study.presenter import Page, Question
from pedvr.study.protocol import ShownPair
from pedvr.study.questionnaire import Questionnaire, Response, load_questionnaire, parse_questionnaire

QDIR = Path(__file__).resolve().parents[2] / "user_study" / "questionnaires"


def ev(*spec: str) -> list[PanelEvent]:
    """``"next"``, ``"select"``, ``"c:7"`` (a typed character), ``"p:2"`` (click on option 2)."""
    out = []
    for s in spec:
        if s.startswith("c:"):
            out.append(PanelEvent("char", s[2:]))
        elif s.startswith("p:"):
            out.append(PanelEvent("pick", int(s[2:])))
        else:
            out.append(PanelEvent(s))
    return out


def q(name: str) -> Questionnaire:
    return load_questionnaire(QDIR / f"{name}.toml")


def question(qn: Questionnaire, item: int = 0, *, required: bool | None = None, pair: ShownPair | None = None,
             label: str | None = None) -> Question:
    it = qn.items[item]
    return Question(questionnaire=qn, item=it, position=item + 1, count=len(qn.items), pair=pair, label=label,
                    required=it.required if required is None else required)


def run(panel: QuestionPanel, *spec: str) -> Response | None:
    drive(panel, ev(*spec))
    return panel.response


def test_page_waits_for_select_or_confirm() -> None:
    p = PagePanel(Page(title="Welcome", text="Hello.\nSecond line."))
    drive(p, ev("next", "prev", "back", "c:x"))
    assert not p.done
    assert p.view().lines[:4] == ("Welcome", "", "Hello.", "Second line.")
    assert "Enter" in p.view().lines[-1]
    drive(p, ev("select"))
    assert p.done
    p2 = PagePanel(Page(title="T", text="x"), keyboard=False)
    assert "trigger" in p2.view().lines[-1]
    drive(p2, ev("confirm"))
    assert p2.done


def test_scale_choose_select_confirm() -> None:
    ssq = q("ssq")
    p = QuestionPanel(question(ssq))
    v = p.view()
    assert v.highlight is not None and v.lines[v.highlight].startswith("> 0")
    assert sorted(v.option_rows.values()) == [0, 1, 2, 3]
    assert run(p, "next", "next", "prev") is None  # moving is not answering
    assert p.index == 1
    run(p, "select")
    assert p.state == "confirming" and not p.done
    assert any(line.startswith("You chose: 1 (") for line in p.view().lines)
    assert run(p, "select") == Response(value=1)
    assert p.done
    run(p, "back", "next", "select")  # a finished panel ignores input
    assert p.response == Response(value=1)


def test_number_keys_pick_scale_points_and_y_confirms() -> None:
    sp = q("social_presence")
    pair = ShownPair(comparison="pedvr+g/decoupled", left_condition="pedvr+g", right_condition="decoupled",
                     left_label="A", right_label="C", flipped=False)
    p = QuestionPanel(question(sp, pair=pair))
    assert "LEFT: A    RIGHT: C" in p.view().lines
    lo, hi = sp.scale.minimum, sp.scale.maximum  # type: ignore[union-attr]
    assert run(p, f"c:{hi + 1}") is None and p.index == 0  # out of the scale: ignored
    assert run(p, "c:5", "select", "c:y", "confirm") == Response(value=5)
    assert lo <= 5 <= hi


def test_back_returns_from_confirming_to_choosing() -> None:
    p = QuestionPanel(question(q("ssq")))
    run(p, "c:3", "select", "back")
    assert p.state == "choosing" and p.pending is None
    assert run(p, "prev", "select", "confirm") == Response(value=2)


def test_wrap_around_and_mouse_pick() -> None:
    p = QuestionPanel(question(q("ssq")))
    run(p, "prev")
    assert p.index == 3
    assert run(p, "p:2", "select", "select") == Response(value=2)
    p = QuestionPanel(question(q("ssq")))
    run(p, "p:9")  # off the list: ignored
    assert p.index == 0


def test_consent_and_choice_by_number() -> None:
    c = QuestionPanel(question(q("consent")))
    assert [o for o, _ in c.options] == ["1  yes", "2  no"]
    assert run(c, "c:2", "select", "select") == Response(text="no")
    demo = q("demographics")
    g = QuestionPanel(question(demo, 1))
    assert g.options[-1][0] == NO_ANSWER  # optional: "(no answer)" is an option
    assert run(g, "c:3", "select", "confirm") == Response(text="non-binary")
    g = QuestionPanel(question(demo, 1))
    assert run(g, "prev", "select", "select") == Response()  # the "(no answer)" option


def test_number_item_typed_stepped_and_validated() -> None:
    demo = q("demographics")
    p = QuestionPanel(question(demo, 0))
    run(p, "c:1", "c:2", "select")  # 12 < min 16: refused with a message, still choosing
    assert p.state == "choosing" and p.error and any(line.startswith("! ") for line in p.view().lines)
    run(p, "back", "back", "c:3", "c:x", "c:0")  # x is not a number character
    assert p.text == "30"
    assert run(p, "select", "confirm") == Response(value=30.0)
    # the thumbstick: steps from the minimum, clamped to the range
    p = QuestionPanel(question(demo, 0), keyboard=False)
    run(p, "next", "next", "next")
    assert p.text == "18"
    run(p, "prev")
    assert run(p, "select", "select") == Response(value=17.0)
    # an optional number left empty is "no answer"
    p = QuestionPanel(question(demo, 0))
    assert run(p, "select", "select") == Response()


def test_free_text_keyboard() -> None:
    fb = q("feedback")
    p = QuestionPanel(question(fb))
    run(p, *[f"c:{ch}" for ch in "Hi thre"], "back", "back", "c:r", "c:e", "c:y", "confirm")
    assert p.text == "Hi threy" and p.state == "choosing"  # "y" and Y are text while typing
    run(p, "back", "back", "back", "c:e", "c:r", "c:e", "select")
    assert p.state == "confirming" and "You chose: Hi there" in p.view().lines
    run(p, "c:z")  # typing while confirming does nothing
    assert run(p, "confirm") == Response(text="Hi there")


def test_required_free_text_must_not_be_empty() -> None:
    fb = q("feedback")
    p = QuestionPanel(question(fb, required=True))
    run(p, "select")
    assert p.state == "choosing" and p.error
    assert run(p, "c:a", "select", "select") == Response(text="a")


def _to(panel: QuestionPanel, entry: str) -> list[str]:
    """The thumbstick pushes that bring the wheel's highlight to ``entry`` (the short way round)."""
    n = len(panel.wheel)
    d = (panel.wheel.index(entry) - panel.index) % n
    return ["next"] * d if d <= n - d else ["prev"] * (n - d)


def spell(panel: QuestionPanel, word: str) -> None:
    for ch in word:
        run(panel, *_to(panel, "space" if ch == " " else ch), "select")


def test_free_text_in_the_headset_is_spelled_on_a_letter_wheel() -> None:
    fb = q("feedback")
    p = QuestionPanel(question(fb), keyboard=False)
    assert p.mode == "spell" and p.wheel[p.index] == "a"  # starts on "a", DONE and DEL just before it
    assert "[a]" in p.view().lines[-3] and "DEL" in p.view().lines[-3]
    spell(p, "too fasT".lower())
    run(p, "back")  # the menu button deletes
    spell(p, "t!")
    assert p.text == "too fast!"
    assert "> too fast!_" in p.view().lines
    run(p, *_to(p, "DEL"), "select")  # DEL on the wheel deletes too
    run(p, *_to(p, "DONE"), "select")
    assert p.state == "confirming" and "You chose: too fast" in p.view().lines
    assert run(p, "select") == Response(text="too fast")
    assert "Thumbstick" in QuestionPanel(question(fb), keyboard=False).view().lines[-1]


def test_headset_text_with_nothing_spelled() -> None:
    fb = q("feedback")
    opt = QuestionPanel(question(fb), keyboard=False)
    assert TOLD_EXPERIMENTER not in opt.wheel
    assert run(opt, *_to(opt, "DONE"), "select", "select") == Response()  # optional: no answer
    req = QuestionPanel(question(fb, required=True), keyboard=False)
    run(req, *_to(req, "DONE"), "select")
    assert req.state == "choosing" and req.error and TOLD_EXPERIMENTER in req.error
    # A required answer too long to spell: the participant says it, the experimenter notes it.
    assert run(req, *_to(req, TOLD_EXPERIMENTER), "select", "select") == Response(text=TOLD_EXPERIMENTER)


def test_likert_label_and_drive_leaves_events_for_nobody() -> None:
    rr = q("realism_rating")
    p = QuestionPanel(question(rr, label="B"))
    assert "Simulation B" in p.view().lines
    left = drive(p, ev("c:4", "select", "confirm", "next", "select"))
    assert p.response == Response(value=4) and left == ev("next", "select")


def test_form_without_scale_text() -> None:
    form = parse_questionnaire(
        {"questionnaire": {"id": "f", "title": "F", "kind": "form"},
         "items": [{"id": "c", "kind": "choice", "text": "Pick", "choices": ["a", "b"]}]},
        source="inline",
    )
    p = QuestionPanel(question(form))
    assert NO_ANSWER not in [o for o, _ in p.options]  # required: no "(no answer)"
    assert run(p, "c:9", "c:0", "next", "select", "select") == Response(text="b")


def test_unknown_event_kind() -> None:
    with pytest.raises(ValueError, match="panel event 'jump'"):
        PanelEvent("jump")


def test_items_with_their_own_anchors_and_ratings_on_a_step() -> None:
    ipq = q("ipq")
    p = QuestionPanel(question(ipq, 10))  # REAL1: "completely real" .. "not real at all"
    lines = p.view().lines
    assert "0  completely real" in [line.strip("> ").strip() for line in lines]
    assert "6  not real at all" in [line.strip("> ").strip() for line in lines]
    assert "3" in [line.strip("> ").strip() for line in lines]  # an unlabelled point shows its number
    assert run(p, "c:6", "select") is None and "You chose: 6 (not real at all)" in p.view().lines
    drive(p, ev("confirm"))
    assert p.response == Response(value=6)
    tlx = q("nasa_tlx_raw")
    p = QuestionPanel(question(tlx, 0), keyboard=False)  # a thumbstick moves the rating 5 points at a time
    assert run(p, "next", "next", "next", "prev", "select", "select") == Response(value=5.0)
    p = QuestionPanel(question(tlx, 0))
    assert run(p, "c:4", "c:2", "select") is None and "multiple of 5" in " ".join(p.view().lines)
