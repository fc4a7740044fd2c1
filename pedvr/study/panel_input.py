"""The in-app participant's answer logic: pages and questions as pure state machines.

No window, no OpenXR: the backends translate their input into
:class:`PanelEvent` values and feed them to a :class:`PagePanel` or a
:class:`QuestionPanel`; the panel says what to draw (:meth:`lines`, with the
highlighted row and the rows a mouse click picks) and, once the participant
has confirmed, :attr:`done` and :attr:`response`. Tests drive them directly.

Events (what each backend maps to them):

========== ============================================= ==================================
event      desktop                                       XR controller
========== ============================================= ==================================
``prev``   ← or ↑                                        thumbstick left
``next``   → or ↓                                        thumbstick right
``select`` Enter, left click                             trigger
``confirm``Y                                             (trigger: ``select`` confirms too)
``back``   Backspace, right click                        menu button
``char``   a typed character (digits pick scale points   —
           and options; text and number items take text)
``pick``   left click on an option row (then ``select``) —
========== ============================================= ==================================

A question is answered in two steps: *choosing* (move the highlight, type)
until ``select`` accepts a valid answer, then *confirming* ("You chose: …"):
``select`` or ``confirm`` commits it, ``back`` returns to choosing. Answers
already committed are stored by the runner as they are given; ``back`` never
goes to an earlier question (the experimenter can correct answers from the
database; the protocol's order stays as planned).

Free text without a keyboard (in the headset, ``keyboard=False``) is spelled
on a letter wheel (:data:`WHEEL`): ``prev``/``next`` move along it, ``select``
types the highlighted letter, or finishes on ``DONE``, or deletes on ``DEL``,
and ``back`` deletes too. Finishing with nothing typed gives no answer when
the item is optional; a *required* item also offers :data:`TOLD_EXPERIMENTER`
on the wheel for answers too long to spell (the participant says it aloud,
the experimenter notes it). Number items take typed digits or step by 1 (or
by the item's ``step``: NASA-TLX ratings move 5 points) with ``prev``/``next``
(so they work with a thumbstick).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from pedvr.study.errors import AnswerError
from pedvr.study.presenter import Page, Question
from pedvr.study.questionnaire import Response, check_response

EVENTS = ("prev", "next", "select", "confirm", "back", "char", "pick")
NO_ANSWER = "(no answer)"
TOLD_EXPERIMENTER = "(told the experimenter)"
MAX_TEXT = 2000
DONE, DELETE, SPACE = "DONE", "DEL", "space"
# The letter wheel for spelling with a thumbstick: finishing and deleting at hand either side of
# "a", where the highlight starts; lower case, since answers are sentences, not shouted.
WHEEL = (DONE, DELETE, *"abcdefghijklmnopqrstuvwxyz", SPACE, *".,?!'-", *"0123456789")
WHEEL_START = WHEEL.index("a")
WHEEL_SHOWN = 4  # wheel entries shown either side of the highlighted one


@dataclass(frozen=True)
class PanelEvent:
    """One abstract input event (see the module docstring); ``value`` is the character or option index."""

    kind: str
    value: str | int | None = None

    def __post_init__(self) -> None:
        if self.kind not in EVENTS:
            raise ValueError(f"panel event {self.kind!r}: expected one of {', '.join(EVENTS)}")


@dataclass(frozen=True)
class PanelView:
    """What to draw: ``lines`` top to bottom, the ``highlight`` row (or None), the row of each option."""

    lines: tuple[str, ...]
    highlight: int | None = None
    option_rows: dict[int, int] = field(default_factory=dict)  # line index -> option index
    title_rows: int = 1


class PagePanel:
    """An instruction page: done when the participant selects or confirms ("continue")."""

    def __init__(self, page: Page, *, keyboard: bool = True) -> None:
        self.page = page
        self.keyboard = keyboard
        self.done = False

    def feed(self, event: PanelEvent) -> None:
        if event.kind in ("select", "confirm"):
            self.done = True

    def view(self) -> PanelView:
        hint = "Press Enter (or click) to continue" if self.keyboard else "Pull the trigger to continue"
        return PanelView(lines=(self.page.title, "", *self.page.text.splitlines(), "", hint), title_rows=1)


class QuestionPanel:
    """One question: choose, select, confirm (module docstring). ``keyboard``: a keyboard is available."""

    def __init__(self, question: Question, *, keyboard: bool = True) -> None:
        self.question = question
        self.keyboard = keyboard
        q, item = question.questionnaire, question.item
        self.mode: str  # "options" | "number" | "text" | "spell" (free text on the letter wheel)
        self.options: list[tuple[str, Response]] = []
        if item.kind == "scale" and q.scale is not None:
            self.mode = "options"
            self.options = [
                (f"{v}  {q.label(item, v)}".rstrip(), Response(value=v))
                for v in range(q.scale.minimum, q.scale.maximum + 1)
            ]
        elif item.kind in ("choice", "consent"):
            self.mode = "options"
            names = list(item.choices) if item.kind == "choice" else ["yes", "no"]
            self.options = [(f"{k}  {o}", Response(text=o)) for k, o in enumerate(names, 1)]
        elif item.kind == "number":
            self.mode = "number"
        elif not keyboard:
            self.mode = "spell"
        else:
            self.mode = "text"
        if self.mode == "options" and not question.required:
            self.options.append((NO_ANSWER, Response()))
        self.wheel = WHEEL + ((TOLD_EXPERIMENTER,) if self.mode == "spell" and question.required else ())
        self.index = 0 if self.mode == "options" else WHEEL_START if self.mode == "spell" else -1
        self.text = ""
        self.state = "choosing"  # choosing | confirming | done
        self.error: str | None = None
        self.pending: Response | None = None
        self.response: Response | None = None

    @property
    def done(self) -> bool:
        return self.state == "done"

    # -- input ----------------------------------------------------------------------------------

    def feed(self, event: PanelEvent) -> None:
        if self.state == "done":
            return
        if self.state == "confirming":
            if event.kind in ("select", "confirm"):
                self.response, self.state = self.pending, "done"
            elif event.kind == "back":
                self.state, self.pending = "choosing", None
            return
        k = event.kind
        if k == "select" and self.mode == "spell":
            self._spell()
        elif k == "select":
            self._select()
        elif k in ("prev", "next"):
            self._move(-1 if k == "prev" else 1)
        elif k == "pick" and self.mode == "options" and isinstance(event.value, int):
            if 0 <= event.value < len(self.options):
                self.index, self.error = event.value, None
        elif k == "char" and isinstance(event.value, str):
            self._char(event.value)
        elif k == "back" and self.mode in ("text", "number", "spell"):
            self.text, self.error = self.text[:-1], None

    def _spell(self) -> None:
        entry = self.wheel[self.index]
        self.error = None
        if entry == DONE:
            self._select()
        elif entry == DELETE:
            self.text = self.text[:-1]
        elif entry == TOLD_EXPERIMENTER:
            self.pending, self.state = Response(text=TOLD_EXPERIMENTER), "confirming"
        elif len(self.text) < MAX_TEXT:
            self.text += " " if entry == SPACE else entry

    def _move(self, step: int) -> None:
        self.error = None
        if self.mode == "spell":
            self.index = (self.index + step) % len(self.wheel)
        elif self.mode == "options" and self.options:
            self.index = (self.index + step) % len(self.options)
        elif self.mode == "number":
            item = self.question.item
            lo = item.minimum if item.minimum is not None else 0.0
            delta = step * (item.step or 1.0)
            try:
                v = float(self.text) + delta
            except ValueError:
                v = lo if delta > 0 or item.maximum is None else item.maximum
            if item.minimum is not None:
                v = max(v, item.minimum)
            if item.maximum is not None:
                v = min(v, item.maximum)
            self.text = f"{v:g}"

    def _char(self, ch: str) -> None:
        self.error = None
        if self.mode == "text":
            if ch.isprintable() and len(self.text) < MAX_TEXT:
                self.text += ch
        elif self.mode == "number":
            if ch.isdigit() or ch in ".-":
                self.text += ch
        elif ch.isdigit():
            q, item = self.question.questionnaire, self.question.item
            d = int(ch)
            if item.kind == "scale" and q.scale is not None:
                if q.scale.minimum <= d <= q.scale.maximum:
                    self.index = d - q.scale.minimum
            elif 1 <= d <= len(self.options) and self.options[d - 1][0] != NO_ANSWER:
                self.index = d - 1

    def _candidate(self) -> Response | None:
        if self.mode == "options":
            return self.options[self.index][1] if self.options else None
        if self.text.strip() == "":
            if self.mode == "spell" and self.question.required:
                self.error = "spell an answer, or choose " + TOLD_EXPERIMENTER
                return None
            return Response()
        if self.mode == "number":
            try:
                return Response(value=float(self.text))
            except ValueError:
                self.error = "please type a number"
                return None
        return Response(text=self.text)

    def _select(self) -> None:
        resp = self._candidate()
        if resp is None:
            if self.error is None:
                self.error = "nothing to choose"
            return
        empty = resp.value is None and resp.text is None
        if empty and not self.question.required:
            self.pending = resp
        else:
            q = self.question.questionnaire
            try:
                self.pending = check_response(
                    q, replace(self.question.item, required=self.question.required), resp
                )
            except AnswerError as exc:
                self.error = "; ".join(exc.problems) if exc.problems else str(exc)
                return
        self.error, self.state = None, "confirming"

    # -- what to draw ---------------------------------------------------------------------------

    def shown_answer(self, r: Response) -> str:
        q, item = self.question.questionnaire, self.question.item
        if r.value is None and r.text is None:
            return NO_ANSWER
        if r.text is not None:
            return r.text
        assert r.value is not None
        out = f"{r.value:g}"
        if item.kind == "scale" and q.scale is not None and q.label(item, int(r.value)):
            out += f" ({q.label(item, int(r.value))})"
        return out

    def _wheel_line(self) -> str:
        """The highlighted wheel entry in brackets, with its neighbours either side."""
        n = len(self.wheel)
        parts = []
        for d in range(-WHEEL_SHOWN, WHEEL_SHOWN + 1):
            e = self.wheel[(self.index + d) % n]
            parts.append(f"[{e}]" if d == 0 else e)
        return "   ".join(parts)

    def view(self) -> PanelView:
        qn, q, item = self.question, self.question.questionnaire, self.question.item
        lines = [f"{q.title}  ({qn.position}/{qn.count})"]
        if qn.pair is not None:
            lines.append(f"LEFT: {qn.pair.left_label}    RIGHT: {qn.pair.right_label}")
        elif qn.label is not None:
            lines.append(f"Simulation {qn.label}")
        lines += ["", *item.text.splitlines(), ""]
        if self.state == "confirming":
            assert self.pending is not None
            lines.append(f"You chose: {self.shown_answer(self.pending)}")
            lines.append("")
            lines.append(
                "Enter or Y (or click) to confirm, Backspace (right click) to change"
                if self.keyboard
                else "Trigger to confirm, menu button to change"
            )
            return PanelView(lines=tuple(lines), highlight=len(lines) - 3, title_rows=1)
        rows: dict[int, int] = {}
        highlight: int | None = None
        if self.mode == "options":
            for k, (text, _) in enumerate(self.options):
                rows[len(lines)] = k
                if k == self.index:
                    highlight = len(lines)
                lines.append(("> " if k == self.index else "   ") + text)
        else:
            item_range = ""
            if self.mode == "number" and (item.minimum is not None or item.maximum is not None):
                lo = "" if item.minimum is None else f"{item.minimum:g}"
                hi = "" if item.maximum is None else f"{item.maximum:g}"
                item_range = f"  ({lo}..{hi})"
            highlight = len(lines)
            lines.append(f"> {self.text}_{item_range}")
            if self.mode == "spell":  # the wheel is what the thumbstick moves: highlight it
                highlight = len(lines)
                lines.append(self._wheel_line())
        lines.append("")
        if self.error:
            lines.append(f"! {self.error}")
        if self.keyboard:
            how = {
                "options": "Arrow keys or number keys to choose, Enter (or click) to select",
                "number": "Type a number (or ←/→), Enter to select, Backspace to delete",
                "text": "Type your answer, Enter to select, Backspace to delete",
            }[self.mode]
        else:
            how = {
                "number": "Thumbstick left/right to change, trigger to select",
                "spell": f"Thumbstick left/right to a letter, trigger to type it ({DONE} when finished); "
                         "menu button deletes",
                "options": "Thumbstick left/right to choose, trigger to select",
            }[self.mode]
        lines.append(how)
        return PanelView(lines=tuple(lines), highlight=highlight, option_rows=rows, title_rows=1)


def drive(panel: PagePanel | QuestionPanel, events: list[PanelEvent]) -> list[PanelEvent]:
    """Feed ``events`` until the panel is done; return the events left over (not for the next panel)."""
    for k, ev in enumerate(events):
        panel.feed(ev)
        if panel.done:
            return events[k + 1 :]
    return []
