"""Behavior trees: the node framework (ADAPT §6; the vocabulary of py_trees).

A node is a :class:`Behaviour`. The framework owns :meth:`Behaviour.tick`;
a node overrides three hooks, exactly as in py_trees:

``initialise(ctx)``
    called on the first tick of a run (the node was not RUNNING);
``update(ctx) -> Status``
    called on every tick; returns RUNNING, SUCCESS or FAILURE;
``terminate(ctx, new_status)``
    called once when the run ends: with SUCCESS or FAILURE when ``update``
    returned it, with INVALID when a parent stopped the node while it was
    RUNNING (the termination signal of ADAPT §6.1.1). A leaf that started a
    body capability ends it here; a composite stops its running children.

Sharp edges (py_trees warns of the same ones):

* Never call ``update`` yourself, and never tick a child twice in one tick.
* ``terminate`` must only undo what the node itself started: a parent may
  stop a lower-priority child *after* a higher-priority one has already
  started (a selector cannot know which branch wins before ticking it).
  Leaves check that they still own a capability before ending it (see
  :mod:`pedvr.behavior.leaves`).
* A node whose run ended is re-initialised by its next tick: a repeat
  decorator or a memoryless composite runs a child again simply by ticking it.

Sleeping. A tree does not need a tick while every running leaf is only
waiting for time to pass. A RUNNING leaf states the earliest time it needs
its next tick in ``self.wake`` (default 0: every tick); the framework keeps
the minimum over the tree in ``ctx.wake`` and the scheduler skips the tree
until then (:mod:`pedvr.behavior.scheduler`). This is what makes hundreds of
trees cheap at 30 Hz; reactive (memoryless) composites re-check their
higher-priority children every tick and so keep their tree awake.

Randomness comes only from ``ctx.rng`` (the simulation's one generator),
drawn in tick order, so the same seed gives the same run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence as Seq
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pedvr.behavior.context import Context


class Status(Enum):
    """A node's status (py_trees' names). The body's handles report the same three running states."""

    INVALID = "invalid"
    RUNNING = "running"
    SUCCESS = "success"
    FAILURE = "failure"


INVALID, RUNNING, SUCCESS, FAILURE = Status.INVALID, Status.RUNNING, Status.SUCCESS, Status.FAILURE
NEVER = math.inf


def draw_seconds(rng: np.random.Generator, spec: tuple[float, float]) -> float:
    """A duration from ``(lo, hi)``: ``lo`` when ``hi <= lo``, else uniform in ``[lo, hi]``."""
    lo, hi = spec
    return lo if hi <= lo else lo + (hi - lo) * float(rng.random())


class Behaviour:
    """A node. Subclasses override ``initialise`` / ``update`` / ``terminate``."""

    __slots__ = ("name", "status", "wake")

    def __init__(self, name: str = "") -> None:
        self.name = name or type(self).__name__
        self.status = INVALID
        self.wake = 0.0  # leaves: earliest time of the next tick they need while RUNNING

    def initialise(self, ctx: Context) -> None:
        """A run starts (the node was not RUNNING)."""

    def update(self, ctx: Context) -> Status:
        raise NotImplementedError

    def terminate(self, ctx: Context, new_status: Status) -> None:
        """The run ended with ``new_status`` (INVALID: stopped by a parent)."""

    def tick(self, ctx: Context) -> Status:
        """Owned by the framework: initialise if needed, update, terminate if done."""
        if self.status is not RUNNING:
            self.initialise(ctx)
        s = self.update(ctx)
        if s is RUNNING:
            if self.wake < ctx.wake:
                ctx.wake = self.wake
        else:
            self.terminate(ctx, s)
        self.status = s
        return s

    def stop(self, ctx: Context) -> None:
        """The termination signal: a RUNNING node ends now (``terminate(INVALID)``)."""
        if self.status is RUNNING:
            self.terminate(ctx, INVALID)
        self.status = INVALID

    def iterate(self) -> list[Behaviour]:
        """This node and every node below it, depth first."""
        return [self]


class Composite(Behaviour):
    """A node with children; stopping it stops its running children."""

    __slots__ = ("children", "index")

    def __init__(self, children: Seq[Behaviour], name: str = "") -> None:
        super().__init__(name)
        if not children:
            raise ValueError(f"{self.name}: a composite needs at least one child")
        self.children = list(children)
        self.index = 0
        self.wake = NEVER

    def terminate(self, ctx: Context, new_status: Status) -> None:
        for c in self.children:
            if c.status is RUNNING:
                c.stop(ctx)

    def iterate(self) -> list[Behaviour]:
        out: list[Behaviour] = [self]
        for c in self.children:
            out.extend(c.iterate())
        return out


class Sequence(Composite):
    """Children in order: FAILURE at the first failure, SUCCESS when all succeeded.

    ``memory=True`` (default, py_trees' ``Sequence(memory=True)``): a RUNNING
    child is resumed at the next tick and the children before it are not
    ticked again. ``memory=False``: every tick starts from the first child
    (conditions before an action are re-checked); a child that now returns
    RUNNING or FAILURE stops the later child that was running.
    """

    __slots__ = ("memory",)

    def __init__(self, children: Seq[Behaviour], *, memory: bool = True, name: str = "") -> None:
        super().__init__(children, name)
        self.memory = memory

    def initialise(self, ctx: Context) -> None:
        self.index = 0

    def update(self, ctx: Context) -> Status:
        ch = self.children
        i = self.index if self.memory else 0
        n = len(ch)
        while i < n:
            s = ch[i].tick(ctx)
            if s is SUCCESS:
                i += 1
                continue
            if not self.memory:
                j = self.index
                if j > i and ch[j].status is RUNNING:
                    ch[j].stop(ctx)
                if s is RUNNING:
                    ctx.wake = ctx.t  # re-check the earlier children at every tick
            self.index = i
            return s
        self.index = i
        return SUCCESS


class Selector(Composite):
    """Children in priority order: the first that does not fail decides (a fallback).

    ``memory=False`` (default, as py_trees' ``Selector``): every tick tries
    the children from the first; when a higher-priority child returns
    RUNNING or SUCCESS, the lower one that was running is stopped. The tree
    is then ticked at every decision tick. ``memory=True``: a RUNNING child is
    resumed and the children before it are not tried again in this run.
    """

    __slots__ = ("memory",)

    def __init__(self, children: Seq[Behaviour], *, memory: bool = False, name: str = "") -> None:
        super().__init__(children, name)
        self.memory = memory

    def initialise(self, ctx: Context) -> None:
        self.index = 0

    def update(self, ctx: Context) -> Status:
        ch = self.children
        i = self.index if self.memory else 0
        n = len(ch)
        while i < n:
            s = ch[i].tick(ctx)
            if s is FAILURE:
                i += 1
                continue
            j = self.index
            if j != i and j < n and ch[j].status is RUNNING:
                ch[j].stop(ctx)
            self.index = i
            if s is RUNNING and i > 0 and not self.memory:
                ctx.wake = ctx.t
            return s
        self.index = n
        return FAILURE


class RandomSelector(Composite):
    """A selector whose order is drawn at each run: weighted, without replacement.

    The order is drawn in ``initialise`` from ``ctx.rng`` (Efraimidis–Spirakis
    keys ``u^(1/w)``, largest first), then the children are tried in that
    order with memory: the first that does not fail decides. A weight of 0
    puts a child last.
    """

    __slots__ = ("weights", "order")

    def __init__(self, children: Seq[Behaviour], *, weights: Seq[float] | None = None,
                 name: str = "") -> None:
        super().__init__(children, name)
        w = np.ones(len(self.children)) if weights is None else np.asarray(weights, np.float64)
        if w.shape != (len(self.children),) or (w < 0).any() or w.sum() <= 0:
            raise ValueError(f"{self.name}: weights {list(w)} must be one number >= 0 per child, sum > 0")
        self.weights = w
        self.order: list[int] = []

    def initialise(self, ctx: Context) -> None:
        u = ctx.rng.random(len(self.children))
        w = self.weights
        keys = np.where(w > 0, np.log(np.maximum(u, 1e-300)) / np.where(w > 0, w, 1.0), -np.inf)
        self.order = [int(k) for k in np.argsort(-keys, kind="stable")]
        self.index = 0

    def update(self, ctx: Context) -> Status:
        ch = self.children
        order = self.order
        i = self.index
        while i < len(order):
            s = ch[order[i]].tick(ctx)
            if s is FAILURE:
                i += 1
                continue
            self.index = i
            return s
        self.index = i
        return FAILURE


class Parallel(Composite):
    """All children ticked together (ADAPT: gaze or gesture while approaching).

    Success policy ``success``: ``"all"`` (py_trees' ``SuccessOnAll``): SUCCESS
    when every child succeeded; ``"one"`` (``SuccessOnOne``): as soon as one
    succeeds. Failure policy ``failure``: ``"one"``: FAILURE as soon as one
    child fails; ``"all"``: go on while any child runs. By default the failure
    policy is the complement of the success policy (all/one, one/all). When
    every child has finished without meeting the success policy, FAILURE.
    Within a tick the success policy is checked first. A child that finished
    is not ticked again in the same run (py_trees' ``synchronise``). When the
    parallel ends, the children still running are stopped.
    """

    __slots__ = ("success_one", "failure_one", "done")

    def __init__(self, children: Seq[Behaviour], *, success: str = "all", failure: str | None = None,
                 name: str = "") -> None:
        super().__init__(children, name)
        if success not in ("all", "one"):
            raise ValueError(f"{self.name}: success policy {success!r}: expected 'all' or 'one'")
        if failure is None:
            failure = "all" if success == "one" else "one"
        if failure not in ("all", "one"):
            raise ValueError(f"{self.name}: failure policy {failure!r}: expected 'all' or 'one'")
        self.success_one = success == "one"
        self.failure_one = failure == "one"
        self.done: list[Status | None] = [None] * len(self.children)

    def initialise(self, ctx: Context) -> None:
        self.done = [None] * len(self.children)

    def update(self, ctx: Context) -> Status:
        ok = bad = 0
        done = self.done
        for k, c in enumerate(self.children):
            s = done[k]
            if s is None:
                s = c.tick(ctx)
                if s is not RUNNING:
                    done[k] = s
            if s is SUCCESS:
                ok += 1
            elif s is FAILURE:
                bad += 1
        n = len(done)
        if ok == n or (ok and self.success_one):
            return SUCCESS
        if (bad and self.failure_one) or ok + bad == n:
            return FAILURE
        return RUNNING


class Decorator(Behaviour):
    """A node with one child; stopping it stops the child."""

    __slots__ = ("child",)

    def __init__(self, child: Behaviour, name: str = "") -> None:
        super().__init__(name)
        self.child = child
        self.wake = NEVER

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if self.child.status is RUNNING:
            self.child.stop(ctx)

    def iterate(self) -> list[Behaviour]:
        return [self, *self.child.iterate()]


class Repeat(Decorator):
    """Run the child again each time it succeeds (ADAPT Fig. 7's loop node).

    Ends with SUCCESS after ``count`` successes, or when ``seconds`` (drawn
    from ``(lo, hi)`` at the start of the run) have passed, stopping the
    child; without either it repeats until stopped. A child failure ends it
    with FAILURE. A child that succeeds at once is run at most once per tick.
    """

    __slots__ = ("count", "seconds", "done", "end")

    def __init__(self, child: Behaviour, *, count: int | None = None,
                 seconds: tuple[float, float] | None = None, name: str = "") -> None:
        super().__init__(child, name)
        if count is not None and count < 1:
            raise ValueError(f"{self.name}: count {count} must be >= 1")
        self.count = count
        self.seconds = seconds
        self.done = 0
        self.end = NEVER

    def initialise(self, ctx: Context) -> None:
        self.done = 0
        self.end = ctx.t + draw_seconds(ctx.rng, self.seconds) if self.seconds is not None else NEVER

    def update(self, ctx: Context) -> Status:
        if ctx.t >= self.end:
            return SUCCESS  # terminate() stops a running child
        s = self.child.tick(ctx)
        if s is FAILURE:
            return FAILURE
        if s is SUCCESS:
            self.done += 1
            if self.count is not None and self.done >= self.count:
                return SUCCESS
            ctx.wake = ctx.t  # the next run of the child starts at the next tick
        if self.end < ctx.wake:
            ctx.wake = self.end
        return RUNNING


class Invert(Decorator):
    """SUCCESS ↔ FAILURE (py_trees' ``Inverter``)."""

    __slots__ = ()

    def update(self, ctx: Context) -> Status:
        s = self.child.tick(ctx)
        return FAILURE if s is SUCCESS else SUCCESS if s is FAILURE else s


class Succeed(Decorator):
    """The child's run always ends in SUCCESS (py_trees' ``FailureIsSuccess``)."""

    __slots__ = ()

    def update(self, ctx: Context) -> Status:
        s = self.child.tick(ctx)
        return RUNNING if s is RUNNING else SUCCESS


class Fail(Decorator):
    """The child's run always ends in FAILURE (py_trees' ``SuccessIsFailure``)."""

    __slots__ = ()

    def update(self, ctx: Context) -> Status:
        s = self.child.tick(ctx)
        return RUNNING if s is RUNNING else FAILURE


class Until(Decorator):
    """Wait for the child to succeed: its FAILURE reads as RUNNING (py_trees' ``FailureIsRunning``).

    A condition below it is checked at every tick ("until the user is near").
    """

    __slots__ = ()

    def update(self, ctx: Context) -> Status:
        s = self.child.tick(ctx)
        if s is FAILURE:
            ctx.wake = ctx.t
            return RUNNING
        return s


class Timeout(Decorator):
    """FAILURE, and the child stopped, if it is still running after ``seconds`` (drawn per run)."""

    __slots__ = ("seconds", "end")

    def __init__(self, child: Behaviour, *, seconds: tuple[float, float], name: str = "") -> None:
        super().__init__(child, name)
        self.seconds = seconds
        self.end = NEVER

    def initialise(self, ctx: Context) -> None:
        self.end = ctx.t + draw_seconds(ctx.rng, self.seconds)

    def update(self, ctx: Context) -> Status:
        if ctx.t >= self.end:
            return FAILURE
        s = self.child.tick(ctx)
        if s is RUNNING and self.end < ctx.wake:
            ctx.wake = self.end
        return s


class Cooldown(Decorator):
    """After a run of the child ends, it is not run again for ``seconds``: FAILURE meanwhile.

    The cooldown belongs to the node instance, so it holds across runs of the
    tree: an agent's personal tree keeps its nodes when its BFSM state starts
    it again; an event's tree is new at each event (see the scheduler).
    """

    __slots__ = ("seconds", "ready_at")

    def __init__(self, child: Behaviour, *, seconds: float, name: str = "") -> None:
        super().__init__(child, name)
        self.seconds = seconds
        self.ready_at = -NEVER

    def update(self, ctx: Context) -> Status:
        if self.child.status is not RUNNING and ctx.t < self.ready_at:
            return FAILURE
        s = self.child.tick(ctx)
        if s is not RUNNING:
            self.ready_at = ctx.t + self.seconds
        return s


class Condition(Behaviour):
    """A leaf that answers at once: SUCCESS or FAILURE, never RUNNING."""

    __slots__ = ()

    def check(self, ctx: Context) -> bool:
        raise NotImplementedError

    def update(self, ctx: Context) -> Status:
        return SUCCESS if self.check(ctx) else FAILURE


class Wait(Behaviour):
    """RUNNING for ``seconds`` (drawn per run), then SUCCESS; the tree sleeps meanwhile."""

    __slots__ = ("seconds", "end")

    def __init__(self, seconds: tuple[float, float], name: str = "") -> None:
        super().__init__(name)
        self.seconds = seconds
        self.end = 0.0

    def initialise(self, ctx: Context) -> None:
        self.end = ctx.t + draw_seconds(ctx.rng, self.seconds)
        self.wake = self.end

    def update(self, ctx: Context) -> Status:
        return SUCCESS if ctx.t >= self.end - 1e-9 else RUNNING
