"""Smart objects: things in the scene with named affordances (ADAPT §6.2, Fig. 8).

A tree invokes an affordance with the ``use`` leaf (:class:`Use`): the
object returns a node that takes control of the agent (walk up, turn, sit)
and the leaf hands it every tick until it reports SUCCESS or FAILURE, as
ADAPT's chair "diverts any ticks it receives from the scheduler clock to
the smart object". An object owns its per-object state (who sits, who
holds the door) and is ticked once per decision tick (``tick``), before the
trees.

A new kind is a subclass registered by name; a scene declares instances
under ``[[behavior.objects]]`` with ``name``, ``kind``, ``at``,
``facing_deg`` and the kind's own keys (``PARAMS``)::

    @object_kinds.register("kiosk")
    class Kiosk(SmartObject):
        AFFORDANCES = ("browse",)

        def affordance(self, name, agent, ctx):
            return Sequence([GoTo(agent, PointTarget(self.at)), Face(agent, heading=self.facing),
                             Gesture(agent, ("point",), seconds=(3.0, 6.0))])
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from pedvr.behavior.context import Context
from pedvr.behavior.goals import Param, non_negative, positive
from pedvr.behavior.leaves import Face, GoTo, PointTarget, SitDown, StandUp, Target, stand_up_undo
from pedvr.behavior.spec import ObjectDef
from pedvr.behavior.tree import FAILURE, INVALID, RUNNING, SUCCESS, Behaviour, Status
from pedvr.registry import Registry


class SmartObject:
    """A smart object. Subclasses set ``AFFORDANCES`` (and ``PARAMS`` for their own scene keys),
    and implement :meth:`affordance`; :meth:`available` and :meth:`tick` are optional."""

    AFFORDANCES: ClassVar[tuple[str, ...]] = ()
    PARAMS: ClassVar[dict[str, Param]] = {}
    ON_OBSTACLES: ClassVar[bool] = False  # ``at`` may lie on an obstacle (an exhibit on a table)

    def __init__(self, decl: ObjectDef) -> None:
        self.name = decl.name
        self.kind = decl.kind
        self.at = decl.at
        self.facing = decl.facing
        self.params = dict(decl.params)
        # what happened here, for the run's metrics: uses that succeeded and failures by reason
        self.uses: dict[str, int] = {}
        self.failures: dict[str, int] = {}
        self.log: list[dict[str, Any]] = []  # one entry per use worth reporting (the run's metrics)

    def count(self, affordance: str) -> None:
        """Count a successful use of ``affordance``."""
        self.uses[affordance] = self.uses.get(affordance, 0) + 1

    def fail(self, why: str) -> Status:
        """Count a failure of an affordance by reason; returns FAILURE for the affordance's node."""
        self.failures[why] = self.failures.get(why, 0) + 1
        return FAILURE

    def available(self, affordance: str, agent: int, ctx: Context) -> bool:
        """Whether ``agent`` could use ``affordance`` now (``use`` with ``nearest`` skips objects
        that cannot)."""
        return affordance in self.AFFORDANCES

    def affordance(self, name: str, agent: int, ctx: Context) -> Behaviour | None:
        """The node that drives ``agent`` through affordance ``name``; None refuses (FAILURE)."""
        raise NotImplementedError

    def tick(self, ctx: Context) -> None:
        """Per-object state, once per decision tick before the trees."""

    def figures(self) -> dict[str, float]:
        """The object's own figures for the run's metrics (summed by name over the scene's objects
        by :meth:`pedvr.behavior.scheduler.Scheduler.summary`); none by default."""
        return {}


object_kinds: Registry[type[SmartObject]] = Registry("smart object kind")


class ObjectTarget(Target):
    """A smart object as a target: its place ``at``."""

    def __init__(self, obj: SmartObject) -> None:
        self.obj = obj

    def point(self, ctx: Context) -> tuple[float, float] | None:
        return self.obj.at

    def gaze(self, ctx: Context) -> object:
        return (self.obj.at[0], 1.0, self.obj.at[1])


class Use(Behaviour):
    """Invoke ``affordance`` of an object for ``agent``; the object drives the agent until it reports.

    ``obj`` is a :class:`SmartObject`, or a kind name: then the nearest
    object of that kind that is :meth:`~SmartObject.available` is chosen when
    the leaf starts (FAILURE if none is). Stopped, it stops the object's node.
    """

    __slots__ = ("agent", "obj", "affordance_name", "node", "chosen")

    def __init__(self, agent: int, obj: SmartObject | str, *, affordance: str, name: str = "") -> None:
        super().__init__(name)
        self.agent = agent
        self.obj = obj
        self.affordance_name = affordance
        self.node: Behaviour | None = None
        self.chosen: SmartObject | None = None

    def _choose(self, ctx: Context) -> SmartObject | None:
        if isinstance(self.obj, SmartObject):
            return self.obj
        a = ctx.pos(self.agent)
        best, best_d = None, math.inf
        for o in ctx.objects.values():  # scene order: ties go to the first declared
            if o.kind != self.obj or not o.available(self.affordance_name, self.agent, ctx):
                continue
            d = math.hypot(o.at[0] - a[0], o.at[1] - a[1])
            if d < best_d:
                best, best_d = o, d
        return best

    def initialise(self, ctx: Context) -> None:
        self.chosen = self._choose(ctx)
        self.node = None
        if self.chosen is not None:
            self.node = self.chosen.affordance(self.affordance_name, self.agent, ctx)

    def update(self, ctx: Context) -> Status:
        return FAILURE if self.node is None else self.node.tick(ctx)

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if new_status is INVALID and self.node is not None:
            self.node.stop(ctx)


@object_kinds.register("chair")
class Chair(SmartObject):
    """A seat (ADAPT Fig. 8): ``at`` is where the sitter stands before sitting down, ``facing``
    the way it faces when seated; the body's sitting pose puts the pelvis 0.3 m behind ``at``
    (so the seat's front edge is about ``at`` minus 0.25 m along ``facing``).

    Affordances:

    ``sit``  reserve the seat, walk to ``at`` (approach), turn to ``facing``
             (orient), come to rest, sit down. SUCCESS when seated; the agent
             stays seated, and the seat taken, until it uses ``stand`` or its
             tree ends (then it stands up and the seat is freed). FAILURE if the
             seat is taken or reserved by another agent, the approach point is
             not reachable ("blocked": off the walkable area, or the walk
             fails), or someone else stands on the seat for ``blocked_after``
             seconds while the agent is within 1.5 m of it.
    ``stand``  stand up and free the seat; SUCCESS at once if the agent is not
               seated here.
    """

    AFFORDANCES = ("sit", "stand")
    PARAMS = {"blocked_after": Param(non_negative, required=False),
              "approach_time": Param(positive, required=False)}

    def __init__(self, decl: ObjectDef) -> None:
        super().__init__(decl)
        self.occupant: int | None = None
        self.reserved: int | None = None
        self.blocked_after = float(self.params.get("blocked_after", 2.0))
        self.approach_time = float(self.params.get("approach_time", 30.0))

    def available(self, affordance: str, agent: int, ctx: Context) -> bool:
        if affordance == "sit":
            return self.occupant in (None, agent) and self.reserved in (None, agent)
        return affordance == "stand"

    def affordance(self, name: str, agent: int, ctx: Context) -> Behaviour | None:
        if name == "sit":
            return _ChairSit(self, agent)
        if name == "stand":
            return _ChairStand(self, agent)
        return None

    def tick(self, ctx: Context) -> None:
        if self.occupant is not None and ctx.find(self.occupant) is None:
            self.occupant = None
        if self.reserved is not None and ctx.find(self.reserved) is None:
            self.reserved = None

    def vacate(self, ctx: Context, agent: int, owner: object) -> None:
        """The sitter leaves: it stands up (if ``owner`` still holds its posture) and the seat is free."""
        stand_up_undo(ctx, agent, owner)
        if self.occupant == agent:
            self.occupant = None


APPROACH, ORIENT, SETTLE, SIT = 0, 1, 2, 3


class _ChairSit(Behaviour):
    """The chair's ``sit`` state machine (ADAPT Fig. 8): approach → orient → settle → sit."""

    __slots__ = ("chair", "agent", "phase", "step", "blocked_since", "why")

    def __init__(self, chair: Chair, agent: int) -> None:
        super().__init__(f"{chair.name}.sit")
        self.chair = chair
        self.agent = agent
        self.phase = APPROACH
        self.step: Behaviour = GoTo(agent, PointTarget(chair.at), arrive=0.12, max_time=chair.approach_time)
        self.blocked_since = math.inf
        self.why = ""

    def initialise(self, ctx: Context) -> None:
        ch = self.chair
        self.why = ""
        self.blocked_since = math.inf
        self.phase = APPROACH
        self.step = GoTo(self.agent, PointTarget(ch.at), arrive=0.12, max_time=ch.approach_time)
        if ch.occupant not in (None, self.agent) or ch.reserved not in (None, self.agent):
            self.why = "occupied"
            return
        snapped = ctx.walkable.nearest_walkable(ch.at)
        if math.dist(snapped, ch.at) > 0.05:
            self.why = "blocked"
            return
        ch.reserved = self.agent

    def _someone_on_seat(self, ctx: Context) -> bool:
        crowd = ctx.crowd
        me = ctx.row(self.agent)
        at = self.chair.at
        d = ((crowd.pos[:, 0] - at[0]) ** 2 + (crowd.pos[:, 1] - at[1]) ** 2) ** 0.5
        d[me] = math.inf
        return bool((d < crowd.radius + crowd.radius[me]).any())

    def update(self, ctx: Context) -> Status:
        ch = self.chair
        if self.why:
            return ch.fail(self.why)
        if self.phase == APPROACH:
            a = ctx.pos(self.agent)
            if math.dist(a, ch.at) < 1.5 and self._someone_on_seat(ctx):
                self.blocked_since = min(self.blocked_since, ctx.t)
                if ctx.t - self.blocked_since >= ch.blocked_after:
                    return ch.fail("blocked")
            else:
                self.blocked_since = math.inf
            s = self.step.tick(ctx)
            if s is FAILURE:
                return ch.fail("blocked")
            if s is RUNNING:
                if math.dist(a, ch.at) < 1.5:
                    ctx.wake = ctx.t  # watch the seat
                return RUNNING
            self.phase = ORIENT
            self.step = Face(self.agent, heading=ch.facing)
        if self.phase == ORIENT:
            s = self.step.tick(ctx)
            if s is not SUCCESS:
                return s
            self.phase = SETTLE
        if self.phase == SETTLE:
            if ctx.speed(self.agent) > 0.05:
                return RUNNING
            self.phase = SIT
            self.step = SitDown(self.agent)
        s = self.step.tick(ctx)
        if s is SUCCESS:
            ch.occupant = self.agent
            ch.count("sit")
        return s

    def terminate(self, ctx: Context, new_status: Status) -> None:
        ch = self.chair
        if self.step.status is RUNNING:
            self.step.stop(ctx)
        if ch.reserved == self.agent:
            ch.reserved = None
        if new_status is SUCCESS:
            agent, sitter = self.agent, self.step
            ctx.run.undo.pop((agent, "posture"), None)  # vacate() stands the agent up
            ctx.linger(agent, f"seat:{ch.name}", lambda: ch.vacate(ctx, agent, sitter))


class _ChairStand(Behaviour):
    __slots__ = ("chair", "agent", "step")

    def __init__(self, chair: Chair, agent: int) -> None:
        super().__init__(f"{chair.name}.stand")
        self.chair = chair
        self.agent = agent
        self.step: Behaviour | None = None

    def initialise(self, ctx: Context) -> None:
        self.step = None
        if self.chair.occupant == self.agent:
            ctx.run.undo.pop((self.agent, f"seat:{self.chair.name}"), None)
            self.step = StandUp(self.agent)

    def update(self, ctx: Context) -> Status:
        if self.step is None:
            return SUCCESS
        s = self.step.tick(ctx)
        if s is not RUNNING and self.chair.occupant == self.agent:
            self.chair.occupant = None
        return s

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if self.step is not None and self.step.status is RUNNING:
            self.step.stop(ctx)


def make_objects(decls: tuple[ObjectDef, ...] | list[ObjectDef]) -> dict[str, SmartObject]:
    """The scene's smart objects, by name, in declaration order."""
    return {d.name: object_kinds[d.kind](d) for d in decls}


def object_params(kind: str) -> dict[str, Any]:
    return dict(object_kinds[kind].PARAMS)
