"""What a behavior tree sees and drives at a tick: the :class:`Context`.

One context per simulation, owned by the scheduler and refreshed at every
decision tick (``t``). Leaves read the world through it (positions,
velocities, headings, visibility, the walkable area, the scene's smart
objects) and act on it only through the body's capabilities and the
behavior arrays (goal, facing, speed scale). Actors are agent ids; the user
is the agent id ``ctx.user`` (observed, never driven).

Ownership. Several nodes may drive one channel of one agent in turn (its
walking, gaze, facing, posture, speed, gesture, each arm). The node that
started a channel last owns it (``claim``); a node ends only what it still
owns (``owns``), so a parent that stops a lower-priority branch after a
higher one started cannot undo the new branch's command.

Lingering effects. Some effects outlive their leaf by design (a gaze that
reached its target, a body sitting down, a speed change); the leaf files an
``undo`` with the running tree (``linger``), and the tree's end (success,
failure or termination) runs them, so a terminated tree leaves nothing of
itself behind (ADAPT §6.1.1, Behavior Termination).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from pedvr.behavior.state import EYE_HEIGHT, FOV_HALF, IDLE_SPEED, BehaviorState
from pedvr.body.model import FullBody
from pedvr.crowd.state import CrowdState
from pedvr.scene.config import WorldConfig

__all__ = ["EYE_HEIGHT", "FOV_HALF", "IDLE_SPEED", "Context", "Run"]  # the constants: pedvr.behavior.state


class Run:
    """A running tree's bookkeeping: lingering effects to undo at its end."""

    __slots__ = ("undo",)

    def __init__(self) -> None:
        self.undo: dict[tuple[int, str], Callable[[], None]] = {}

    def end(self) -> None:
        """Undo every lingering effect, in the order they were filed."""
        undo, self.undo = self.undo, {}
        for fn in undo.values():
            fn()


class Context:
    """The tick context. ``t`` simulation time (s), ``wake`` the earliest time the tree being
    ticked needs its next tick (kept by the framework, see :mod:`pedvr.behavior.tree`)."""

    def __init__(self, *, crowd: CrowdState, behavior: BehaviorState, body: FullBody, visibility: Any,
                 walkable: Any, rng: np.random.Generator, goal_sets: dict[str, Any] | None = None,
                 objects: dict[str, Any] | None = None, user: int | None = None,
                 world: WorldConfig | None = None) -> None:
        self.t = 0.0
        self.wake = math.inf
        self.rng = rng
        self.crowd = crowd
        self.behavior = behavior
        self.body = body
        self.visibility = visibility
        self.walkable = walkable
        self.goal_sets = goal_sets or {}
        # the scene's smart objects by name (pedvr.behavior.objects.SmartObject; typed loosely so that
        # the context, the layer's vocabulary, imports nothing built on it: narrow with isinstance)
        self.objects: dict[str, Any] = objects if objects is not None else {}
        self.user = user
        self.world = world  # the static world (obstacle heights, occluders): for planners that need 3D
        # Gaze events behaviors record, in the PedVR gaze rule's form ({"agent", "t", "event": "start" |
        # "end", "target"}); the simulation shares its metrics' list here, so studies record them too.
        self.gaze_events: list[dict[str, object]] = []
        # Events behaviors record as they happen, each a dict with "kind" and "t" (a demonstration's
        # start, stroke and end: pedvr.demonstrator); the study records them with its samples.
        self.events: list[dict[str, object]] = []
        # Agents a running node drives *for* the user (a demonstration to the user): the user-encounter
        # model leaves them alone, as it does the agents of events in which the user has a role.
        self.engaged: set[int] = set()
        self.run: Run = Run()  # the tree being ticked (the scheduler sets it)
        self.owners: dict[tuple[int, str], object] = {}
        self._ids: np.ndarray | None = None
        self._rows: dict[int, int] = {}

    # -- rows ----------------------------------------------------------------------------------

    def _refresh(self) -> None:
        ids = self.crowd.ids
        if ids is not self._ids:
            self._ids = ids
            self._rows = {int(a): r for r, a in enumerate(ids.tolist())}

    def row(self, agent: int) -> int:
        """The agent's row now; KeyError if it has left (actors of a running tree never have)."""
        if self.crowd.ids is not self._ids:
            self._refresh()
        return self._rows[agent]

    def find(self, agent: int) -> int | None:
        """The agent's row, or None if it has left."""
        if self.crowd.ids is not self._ids:
            self._refresh()
        return self._rows.get(agent)

    # -- the world -----------------------------------------------------------------------------

    def pos(self, agent: int) -> tuple[float, float]:
        p = self.crowd.pos[self.row(agent)]
        return (float(p[0]), float(p[1]))

    def heading(self, agent: int) -> float:
        return float(self.crowd.heading[self.row(agent)])

    def speed(self, agent: int) -> float:
        v = self.crowd.vel[self.row(agent)]
        return math.hypot(float(v[0]), float(v[1]))

    def sitting(self, agent: int) -> bool:
        """Seated or on the way down or up (the sitting blend weight is not 0)."""
        r = self.row(agent)
        co = self.body.coordinator
        return bool(self.body.state.sitting[r]) or float(co.weights[r, co.index["sitting"]]) > 0.0

    def seated(self, agent: int) -> bool:
        """Fully seated (the sitting blend weight is 1)."""
        r = self.row(agent)
        co = self.body.coordinator
        return bool(self.body.state.sitting[r]) and float(co.weights[r, co.index["sitting"]]) >= 1.0

    def idle(self, agent: int) -> bool:
        """Standing still on its feet."""
        return self.speed(agent) < IDLE_SPEED and not self.sitting(agent)

    def in_view(self, agent: int, p: tuple[float, float]) -> bool:
        """``p`` inside the agent's field of view (±100° of its heading) and not occluded in 2D."""
        a = self.pos(agent)
        d = (p[0] - a[0], p[1] - a[1])
        n = math.hypot(*d)
        if n < 1e-9:
            return True
        h = self.heading(agent)
        if (d[0] * math.cos(h) + d[1] * math.sin(h)) / n < math.cos(FOV_HALF):
            return False
        return bool(self.visibility.visible(np.asarray([a]), np.asarray([p]))[0])

    # -- ownership -----------------------------------------------------------------------------

    def claim(self, agent: int, channel: str, node: object) -> None:
        self.owners[(agent, channel)] = node

    def owns(self, agent: int, channel: str, node: object) -> bool:
        return self.owners.get((agent, channel)) is node

    def release(self, agent: int, channel: str, node: object) -> bool:
        """Drop ``node``'s ownership; True if it was the owner (then the caller ends the effect)."""
        key = (agent, channel)
        if self.owners.get(key) is node:
            del self.owners[key]
            return True
        return False

    def linger(self, agent: int, channel: str, undo: Callable[[], None]) -> None:
        """File an effect of the running tree to undo when the tree ends (replaces an older one)."""
        self.run.undo[(agent, channel)] = undo
