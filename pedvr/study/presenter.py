"""What the participant sees and does: the seam between the study runner and a backend.

The session runner (:mod:`pedvr.study.session`) never draws anything. It
talks to a :class:`Participant`, which

* shows an instruction page and returns once the participant confirms it;
* asks one question and returns the participant's *confirmed* answer (the
  participant picks, sees the choice highlighted, and confirms; PedVR §6.2.4:
  pairwise items show the two conditions only by their labels A, B, C);
* supplies the user's pose during a trial (:meth:`Participant.trial_input`,
  a :class:`pedvr.crowd.user.UserInput`), presents each frame and says which
  simulation time the next frame shows (:meth:`Participant.present`), and
  reports the head pose to record (:meth:`Participant.head_pose`).

Two implementations live here: :class:`SimulatedParticipant` (follows the red
spheres along the navigation mesh and answers from a seeded distribution, so
whole studies can be dry-run headless and the analysis has signal) and
:class:`TerminalParticipant` (``--backend headless`` with a person at the
keyboard: questionnaires typed as numbers and confirmed; the trial's walk is
scripted, since there is no view to steer in).

The in-app participant for ``--backend desktop|xr`` is
:class:`pedvr.xr.participant.InAppParticipant`: ``show`` and ``ask`` draw a
text panel in front of the user (both eyes in the headset) and return on a
confirmed trigger / click / Enter (the answer logic is
:mod:`pedvr.study.panel_input`); ``trial_input`` returns the backend's HMD- or
keyboard-driven ``UserInput``; ``present`` renders the frame and returns the
display time relative to the trial start; ``head_pose`` the head pose.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, TextIO

import numpy as np

from pedvr.crowd.user import UserInput
from pedvr.errors import UsageError
from pedvr.scene.config import USER_WALKS
from pedvr.study.console import Command
from pedvr.study.counterbalance import stable_seed
from pedvr.study.errors import AnswerError
from pedvr.study.protocol import ShownPair, TrialSpec
from pedvr.study.questionnaire import Item, Questionnaire, Response, check_response

if TYPE_CHECKING:
    from pedvr.scene.config import SceneConfig
    from pedvr.sim import Simulation


@dataclass(frozen=True)
class Page:
    """An instruction page: shown until the participant confirms."""

    title: str
    text: str


@dataclass(frozen=True)
class Question:
    """One question as shown: the item, and for pairwise items the pair (by labels only).

    ``occurrence`` counts administrations of this questionnaire in the
    participant's plan so far (1 for the first SSQ, 2 for the second).
    ``required`` may be weaker than the item's when the protocol step is optional.
    """

    questionnaire: Questionnaire
    item: Item
    position: int
    count: int
    pair: ShownPair | None = None
    scenario: str | None = None
    condition: str | None = None
    label: str | None = None
    occurrence: int = 1
    required: bool = True


@dataclass(frozen=True)
class HeadPose:
    """Head position (m, pedvr world frame: x, y on the floor, z up) and orientation (w, x, y, z)."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]


def head_from_floor(sim: Simulation, *, eye_height_m: float) -> HeadPose:
    """The head pose implied by the user agent's floor pose: eye height, yaw only."""
    x, y = (float(v) for v in sim.crowd.pos[0])
    yaw = float(sim.crowd.heading[0])
    return HeadPose(
        position=(x, y, eye_height_m), orientation=(math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
    )


class ExperimenterCommand(Exception):
    """Raised from :meth:`Participant.show` or :meth:`Participant.ask` when the experimenter skipped
    or aborted at the console while the participant was on a panel (the in-app participant polls
    the console: issue 23 item 3); the session handles ``command`` as one given between steps."""

    def __init__(self, command: Command) -> None:
        super().__init__(command.kind)
        self.command = command


class Participant(Protocol):
    """The participant as the session runner sees it (see the module docstring)."""

    kind: str

    def show(self, page: Page) -> None:
        """Show ``page``; return when the participant confirms."""
        ...

    def ask(self, question: Question) -> Response:
        """Ask ``question``; return the confirmed answer (validated again by the runner)."""
        ...

    def trial_input(self, *, trial: TrialSpec, scene: SceneConfig) -> UserInput | None:
        """The user's pose source for this trial; ``None`` = the simulation's scripted walk of the route."""
        ...

    @property
    def user_walk(self) -> str | None:
        """How the scripted walk goes when :meth:`trial_input` gives ``None``: ``straight``,
        ``reactive`` (:class:`pedvr.crowd.user.ReactiveUser`), or ``None`` for the scene's."""
        ...

    def present(self, sim: Simulation) -> float:
        """Present the current frame; return the simulation time the next frame shows."""
        ...

    def head_pose(self, sim: Simulation) -> HeadPose:
        """The head pose to record for the frame just presented."""
        ...


# -- the simulated participant ----------------------------------------------------------------


# Latent social presence of each condition for the simulated participant,
# ordered as PedVR §6.5 found (PedVR+G > PedVR > Decoupled). Only used to draw
# dry-run answers with signal; not a model of people.
SIMULATED_PRESENCE = {"decoupled": 0.0, "pedvr": 0.5, "pedvr+g": 1.5}

FREE_TEXT = (
    "Fine, no problems.",
    'The people in "B" looked at me,\tand I said "sorry" once.',
    "Trial A felt odd, C felt natural;\nI walked around them, not through.",
    "Some walked, 'robotically', others didn't; hard to say",
)


class SimulatedParticipant:
    """A scripted participant for dry runs and tests.

    Walks the red-sphere route along the navigation mesh, stepping aside for
    pedestrians like a person (``walk = "reactive"``, the default:
    :class:`~pedvr.crowd.user.ReactiveUser`, so trajectories differ by condition
    as a real participant's would) or straight along it (``"straight"``), and
    answers every question
    from a distribution seeded by (``seed``, participant ``number``,
    questionnaire, item, comparison, scenario): the same answers on every
    run and after a resume. Pairwise answers lean towards the condition with
    the higher :data:`SIMULATED_PRESENCE`, with a per-participant sensitivity
    and a per-comparison offset shared by the items, so the analysis finds
    the ordering and Cronbach's α is positive. ``pace`` > 0 paces trials to
    wall-clock time (1.0 = real time) through the injected ``sleep``.
    """

    kind = "simulated"

    def __init__(
        self,
        *,
        seed: int,
        number: int,
        eye_height_m: float = 1.6,
        pace: float = 0.0,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        walk: str = "reactive",
    ) -> None:
        if walk not in USER_WALKS:
            raise ValueError(f"walk {walk!r}: expected one of {', '.join(USER_WALKS)}")
        self._walk = walk
        self.seed = seed
        self.number = number
        self.eye_height_m = eye_height_m
        self.pace = pace
        self._clock = clock
        self._sleep = sleep
        own = np.random.default_rng(stable_seed(seed, number, "participant"))
        self.sensitivity = float(own.uniform(0.6, 1.4))
        self._trial_start: tuple[float, float] | None = None

    def _rng(self, *parts: int | str) -> np.random.Generator:
        return np.random.default_rng(stable_seed(self.seed, self.number, *parts))

    def show(self, page: Page) -> None:
        return None

    def ask(self, question: Question) -> Response:
        q, item = question.questionnaire, question.item
        pair = question.pair
        rng = self._rng(
            q.id,
            item.id,
            question.occurrence,
            question.scenario or "",
            pair.comparison if pair else "",
            question.condition or "",
        )
        if q.kind == "pairwise" and pair is not None and q.scale is not None:
            mid = (q.scale.minimum + q.scale.maximum) / 2
            shared = self._rng(q.id, question.scenario or "", pair.comparison).normal(0.0, 0.5)
            diff = SIMULATED_PRESENCE[pair.left_condition] - SIMULATED_PRESENCE[pair.right_condition]
            v = mid - 1.4 * self.sensitivity * diff + shared + rng.normal(0.0, 0.8)
            return Response(value=int(np.clip(round(v), q.scale.minimum, q.scale.maximum)))
        if q.kind == "ssq":
            p = 0.12 + 0.12 * (question.occurrence - 1)
            return Response(value=int(rng.choice(4, p=[1 - p, p * 0.75, p * 0.2, p * 0.05])))
        if q.kind == "likert" and q.scale is not None:
            base = SIMULATED_PRESENCE.get(question.condition or "", 0.5)
            v = q.scale.minimum + (q.scale.maximum - q.scale.minimum) * (0.3 + 0.3 * base) + rng.normal(0, 1)
            if item.reverse:
                v = q.scale.minimum + q.scale.maximum - v
            return Response(value=int(np.clip(round(v), q.scale.minimum, q.scale.maximum)))
        if item.kind == "consent":
            return Response(text="yes")
        if item.kind == "number":
            lo = item.minimum if item.minimum is not None else 0.0
            hi = item.maximum if item.maximum is not None else 100.0
            v = float(np.clip(round(rng.normal(25.0, 6.0)), lo, hi))
            if item.step is not None and item.minimum is not None:  # on the item's grid (NASA-TLX: 0, 5, ...)
                v = float(np.clip(item.minimum + round((v - item.minimum) / item.step) * item.step, lo, hi))
            return Response(value=v)
        if item.kind == "choice":
            return Response(text=str(rng.choice(list(item.choices))))
        if item.kind == "scale" and q.scale is not None:
            return Response(value=int(rng.integers(q.scale.minimum, q.scale.maximum + 1)))
        return Response(text=FREE_TEXT[int(rng.integers(len(FREE_TEXT)))])

    def trial_input(self, *, trial: TrialSpec, scene: SceneConfig) -> UserInput | None:
        self._trial_start = None
        return None

    @property
    def user_walk(self) -> str:
        return self._walk

    def present(self, sim: Simulation) -> float:
        if self.pace > 0:
            now = self._clock()
            if self._trial_start is None:
                self._trial_start = (now, sim.t)
            due = self._trial_start[0] + (sim.t - self._trial_start[1]) / self.pace
            if due > now:
                self._sleep(due - now)
        return sim.t + sim.dt

    def head_pose(self, sim: Simulation) -> HeadPose:
        return head_from_floor(sim, eye_height_m=self.eye_height_m)


# -- the terminal participant -----------------------------------------------------------------


class TerminalParticipant:
    """A person at the terminal (``--backend headless``): read, type, confirm.

    Pages wait for Enter. Scale items list their points and take the
    number; number items take a number; choice items take the option's
    number; text items take one line. Every answer is echoed and must be
    confirmed with ``y``; optional items accept an empty line as "no answer".
    Trials run the scripted walk (there is no view to steer in headless mode).
    """

    kind = "terminal"
    user_walk = None  # the scene's (a person at the terminal has no view to walk in)

    def __init__(
        self, *, stdin: TextIO = sys.stdin, stdout: TextIO = sys.stdout, eye_height_m: float = 1.6
    ) -> None:
        self.stdin = stdin
        self.stdout = stdout
        self.eye_height_m = eye_height_m

    def _line(self, prompt: str) -> str:
        self.stdout.write(prompt)
        self.stdout.flush()
        line = self.stdin.readline()
        if line == "":
            raise UsageError("the participant's input ended (stdin closed); continue later with --resume")
        return line.rstrip("\n")

    def show(self, page: Page) -> None:
        self.stdout.write(f"\n== {page.title} ==\n{page.text}\n")
        self._line("[press Enter to continue] ")

    def ask(self, question: Question) -> Response:
        q, item = question.questionnaire, question.item
        head = f"\n-- {q.title} ({question.position}/{question.count}) --\n"
        if question.pair is not None:
            head += f"LEFT: {question.pair.left_label}    RIGHT: {question.pair.right_label}\n"
        elif question.label is not None:
            head += f"Simulation {question.label}\n"
        self.stdout.write(head + item.text + "\n")
        options: list[str] = []
        if item.kind == "scale" and q.scale is not None:
            for v in range(q.scale.minimum, q.scale.maximum + 1):
                self.stdout.write(f"  {v} = {q.label(item, v)}\n".replace(" = \n", "\n"))
        elif item.kind in ("choice", "consent"):
            options = list(item.choices) if item.kind == "choice" else ["yes", "no"]
            for k, o in enumerate(options, 1):
                self.stdout.write(f"  {k} = {o}\n")
        while True:
            raw = self._line("> ")
            resp = self._parse(item, raw, options)
            if resp is None:
                continue
            empty = resp.value is None and resp.text is None
            if not (empty and not question.required):
                try:
                    resp = check_response(q, item, resp)
                except AnswerError as exc:
                    self.stdout.write(f"  {exc}\n")
                    continue
            shown = (
                "no answer"
                if resp.value is None and resp.text is None
                else (resp.text if resp.text is not None else f"{resp.value:g}")
            )
            if item.kind == "scale" and q.scale is not None and resp.value is not None:
                if q.label(item, int(resp.value)):
                    shown += f" ({q.label(item, int(resp.value))})"
            if self._line(f"  you chose: {shown}. Confirm? [y/n] ").strip().lower() in ("y", "yes"):
                return resp

    def _parse(self, item: Item, raw: str, options: list[str]) -> Response | None:
        text = raw.strip()
        if text == "":
            return Response()
        if item.kind in ("scale", "number"):
            try:
                return Response(value=float(text))
            except ValueError:
                self.stdout.write("  please type a number\n")
                return None
        if options:
            if text.isdigit() and 1 <= int(text) <= len(options):
                return Response(text=options[int(text) - 1])
            if text in options:
                return Response(text=text)
            self.stdout.write(f"  please type 1..{len(options)}\n")
            return None
        return Response(text=raw)

    def trial_input(self, *, trial: TrialSpec, scene: SceneConfig) -> UserInput | None:
        self.stdout.write(
            f"\n(headless: the scripted walker follows the red spheres in {trial.scene_name})\n"
        )
        return None

    def present(self, sim: Simulation) -> float:
        return sim.t + sim.dt

    def head_pose(self, sim: Simulation) -> HeadPose:
        return head_from_floor(sim, eye_height_m=self.eye_height_m)
