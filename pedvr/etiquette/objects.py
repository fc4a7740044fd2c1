"""Doors as smart objects, and the holder–follower pair as an event (ADAPT §6 on Huang & Terzopoulos).

Every door of a scene is a smart object named as the door (``world.doors[k].name``,
``door_<k>`` by default) with two affordances:

``pass``  walk up to the door and through it; the door etiquette takes the agent over near the
          door (waiting, ordering, opening, holding as its decisions say). SUCCESS on the far
          side, FAILURE if the walk fails.
``hold``  for the agent holding this door (the etiquette made it the holder and it decided HOF or
          HOL for someone): RUNNING while it holds, SUCCESS when the follower has passed or taken
          the door over, FAILURE when it gave up (a user who did not come) or is not holding this
          door. Stopped (a higher-priority event took the agent), the holder lets go and goes on.

When a holder decides to hold for a follower, the etiquette starts the event
``door_hold`` (:data:`DOOR_HOLD_EVENT`: tree ``door_hold``, parameters ``holder`` (agent),
``follower`` (actor: an agent or the user, observed) and ``door`` (object)). The event claims
the holder, so its BFSM is suspended while it holds and resumes after, and it appears in the
scheduler's counts and ``event_log``; when the follower is the user the holder is exempt from
the user-encounter model (``Scheduler.engaged_with_user``), since it moves *for* the user.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pedvr.behavior.leaves import GoTo, PointTarget
from pedvr.behavior.nodes import define_tree
from pedvr.behavior.objects import SmartObject
from pedvr.behavior.spec import EventDef, ObjectDef
from pedvr.behavior.tree import INVALID, RUNNING, SUCCESS, Behaviour, Sequence, Status

if TYPE_CHECKING:
    from pedvr.behavior.context import Context
    from pedvr.etiquette.core import EtiquetteCore

DOOR_HOLD_EVENT = EventDef(name="door_hold", tree="door_hold", priority=1, patience=5.0)

# The event's tree. Not a library tree (pedvr.behavior.library): it needs a door's etiquette, so
# the simulation adds it to its scheduler's trees beside the event (and the trees a scene may
# name stay the same whatever was imported first).
DOOR_HOLD_TREE = define_tree(
    "door_hold", {"holder": "agent", "follower": "actor", "door": "object"},
    {"use": "holder", "object": "door", "affordance": "hold"})


class DoorObject(SmartObject):
    """A door of the scene as a smart object (module docstring)."""

    AFFORDANCES = ("pass", "hold")

    def __init__(self, decl: ObjectDef, etiquette: EtiquetteCore, door: int) -> None:
        super().__init__(decl)
        self.etiquette = etiquette
        self.door = door

    @classmethod
    def of(cls, et: EtiquetteCore, k: int) -> DoorObject:
        ds = et.dstate[k]
        decl = ObjectDef(name=et.doors[k].name, kind="door", at=(float(ds.centre[0]), float(ds.centre[1])),
                         facing=math.atan2(float(ds.n[1]), float(ds.n[0])))
        return cls(decl, et, k)

    def affordance(self, name: str, agent: int, ctx: Context) -> Behaviour | None:
        ds = self.etiquette.dstate[self.door]
        if name == "pass":
            x, y = ctx.pos(agent)
            side = 1 if (x - ds.centre[0]) * ds.n[0] + (y - ds.centre[1]) * ds.n[1] >= 0.0 else -1
            near = ds.centre + ds.n * side * 1.5
            far = ds.centre - ds.n * side * 1.5
            return Sequence([GoTo(agent, PointTarget((float(near[0]), float(near[1]))), arrive=0.6),
                             GoTo(agent, PointTarget((float(far[0]), float(far[1]))), arrive=0.4)])
        if name == "hold":
            return _Hold(self, agent)
        return None


class _Hold(Behaviour):
    __slots__ = ("obj", "agent")

    def __init__(self, obj: DoorObject, agent: int) -> None:
        super().__init__(f"{obj.name}.hold")
        self.obj = obj
        self.agent = agent

    def update(self, ctx: Context) -> Status:
        et = self.obj.etiquette
        outcome = et.hold_outcomes.pop(self.agent, None)
        if outcome is not None:
            if outcome in ("passed", "took over"):
                self.obj.count("hold")
                return SUCCESS
            return self.obj.fail(outcome)
        w = et.walkers.get(self.agent)
        if w is None or w.door != self.obj.door or w.event is None:
            return self.obj.fail("not holding")
        return RUNNING

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if new_status is INVALID:
            self.obj.etiquette.interrupted(self.agent)

