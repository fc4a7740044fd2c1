"""Triggers: what starts events (ADAPT §7: spatial and temporal triggers, and the user's input).

Checked once per decision tick, before events start, over arrays:

``enter``        an actor (``who = "user"`` or ``"agent"``) enters ``region`` (the edge
                 outside → inside). ``who = "agent"`` binds the entering ``agent`` (and
                 ``user``); ``who = "user"`` binds ``user``, the eligible ``agent`` nearest
                 the user, and the eligible ``other`` nearest that agent.
``near``         ``who = ["user", "agent"]``: the user comes within ``distance`` of an
                 eligible agent (binds ``user``, ``agent``); ``["agent", "agent"]``: two
                 eligible agents come within ``distance`` (binds ``agent``, ``other``; the
                 pair in id order). Fires on the edge: when the pair *becomes* near
                 (and eligible), not while it stays so.
``time``         at ``at`` s, then every ``every`` s (drawn per firing); binds ``agent`` to
                 an eligible agent drawn with the rng and ``other`` to the eligible agent
                 nearest to it.
``user_action``  the backend reports the user's ``action`` (``Simulation.user_action``);
                 binds ``user`` and, as ``agent``, the eligible agent nearest the user
                 within ``distance`` m (any distance if 0).

Binding symbols besides these: ``midpoint`` (halfway between ``agent`` and
``other``, or the user, moved onto the walkable area), ``here`` (where
``agent`` stands). Eligible agents: not the user, not in an event, in one of
``states`` if given, and with ``idle``, standing on their feet with no goal
(not merely stopped on the way somewhere, nor just spawned and about to go),
and not held by an event of the trigger's event's priority or higher.

Pre-emption (ADAPT §6.1.1, Event Priority; issue 24): an agent held by a
lower-priority event (pending or running) is as eligible as a free one, so a
scene's higher-priority trigger can take an agent out of a conversation: the
event it starts claims the agent and the scheduler terminates the lower one
as a whole (:meth:`pedvr.behavior.scheduler.Scheduler.start_event`). An agent
held by an event of the same or a higher priority is never bound. Among
eligible agents, binding does not prefer free ones: the nearest is taken, as
for free agents alone.

Every firing that passes ``cooldown`` and ``max_running`` draws once from
the rng against ``chance``; a firing whose draw fails still starts the
cooldown (the pair met and did not stop to talk).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from pedvr.behavior.context import Context
from pedvr.behavior.spec import EventDef, TriggerDef
from pedvr.behavior.state import IDLE_SPEED
from pedvr.behavior.tree import draw_seconds

BIND_SYMBOLS = ("agent", "other", "user", "midpoint", "here")


class EventHost(Protocol):
    """What triggers need of the scheduler (:class:`pedvr.behavior.scheduler.Scheduler` is one):
    the tick context, the declared events, how many events a trigger has running, and a way to
    start one. A protocol, so this module does not import the scheduler that imports it."""

    ctx: Context
    events: dict[str, EventDef]

    def running_from(self, trigger: int) -> int: ...

    def start_event(self, name: str, values: dict[str, Any], *, trigger: int | None = None) -> object: ...


class _State:
    __slots__ = ("decl", "index", "last", "inside", "next_at", "actions")

    def __init__(self, decl: TriggerDef, index: int) -> None:
        self.decl = decl
        self.index = index
        self.last: dict[tuple[int, ...], float] = {}  # cooldown start per actor set
        self.inside: set[tuple[int, ...]] = set()  # pairs / actors on the near side of the edge
        self.next_at = decl.at if decl.kind == "time" else math.inf
        self.actions = 0


class Triggers:
    """The scene's triggers; ``state_ids`` maps BFSM state names to ids (``BFSM.ids``)."""

    def __init__(self, decls: tuple[TriggerDef, ...], scheduler: EventHost, *,
                 state_ids: dict[str, int]) -> None:
        self.scheduler = scheduler
        self.states = [_State(d, k) for k, d in enumerate(decls)]
        self._state_ids = [np.asarray([state_ids[s] for s in d.states], np.int32) for d in decls]
        self.fired = [0] * len(decls)

    def user_action(self, name: str) -> None:
        for st in self.states:
            if st.decl.kind == "user_action" and st.decl.action == name:
                st.actions += 1

    def _eligible(self, k: int) -> np.ndarray:
        st = self.states[k]
        ctx = self.scheduler.ctx
        crowd, b = ctx.crowd, ctx.behavior
        ev = self.scheduler.events.get(st.decl.event)
        priority = ev.priority if ev is not None else 0
        # free agents, and those a lower-priority event holds: the new event pre-empts it
        ok = ~crowd.is_user & (b.event_priority < priority)
        if st.decl.states:
            ok &= np.isin(b.state, self._state_ids[k])
        if st.decl.idle and ok.any():
            speed = np.hypot(crowd.vel[:, 0], crowd.vel[:, 1])
            body = ctx.body
            co = body.coordinator
            sitting = body.state.sitting | (co.weights[:, co.index["sitting"]] > 0.0)
            ok &= (speed < IDLE_SPEED) & ~sitting & np.isnan(b.goal[:, 0])
        return ok

    def fire(self, t: float) -> None:
        for k, st in enumerate(self.states):
            kind = st.decl.kind
            if kind == "near":
                self._near(k, st, t)
            elif kind == "enter":
                self._enter(k, st, t)
            elif kind == "time":
                if t >= st.next_at - 1e-9:
                    every = st.decl.every
                    st.next_at = t + draw_seconds(self.scheduler.ctx.rng, every) if every else math.inf
                    self._pick_and_fire(k, st, t, around=None)
            elif st.actions:
                st.actions = 0
                self._pick_and_fire(k, st, t, around=self.scheduler.ctx.user)

    # -- kinds ----------------------------------------------------------------------------------

    def _near(self, k: int, st: _State, t: float) -> None:
        ctx = self.scheduler.ctx
        crowd = ctx.crowd
        ok = self._eligible(k)
        d = st.decl.distance
        now: set[tuple[int, ...]] = set()
        if st.decl.who[0] == "user":
            if ctx.user is None:
                return
            u = crowd.pos[ctx.row(ctx.user)]
            dist = np.hypot(crowd.pos[:, 0] - u[0], crowd.pos[:, 1] - u[1])
            for row in np.flatnonzero(ok & (dist < d)).tolist():
                now.add((int(crowd.ids[row]),))
        else:
            rows = np.flatnonzero(ok)
            if rows.size >= 2:
                p = crowd.pos[rows]
                dd = np.hypot(p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1])
                i, j = np.nonzero(np.triu(dd < d, 1))
                for a, b in zip(crowd.ids[rows[i]].tolist(), crowd.ids[rows[j]].tolist(), strict=True):
                    now.add((min(a, b), max(a, b)))
        new = sorted(now - st.inside)
        st.inside = now
        for key in new:
            if len(key) == 1:
                self._fire(k, st, t, key, {"agent": key[0], "user": ctx.user})
            else:
                self._fire(k, st, t, key, {"agent": key[0], "other": key[1]})

    def _enter(self, k: int, st: _State, t: float) -> None:
        ctx = self.scheduler.ctx
        crowd = ctx.crowd
        kind, v = st.decl.region  # type: ignore[misc]
        x, y = crowd.pos[:, 0], crowd.pos[:, 1]
        if kind == "box":
            inside = (x >= v[0]) & (x <= v[2]) & (y >= v[1]) & (y <= v[3])
        else:
            inside = np.hypot(x - v[0], y - v[1]) <= v[2]
        if st.decl.who[0] == "user":
            mask = crowd.is_user & inside
        else:
            mask = self._eligible(k) & inside
        now: set[tuple[int, ...]] = {(int(a),) for a in crowd.ids[mask].tolist()}
        new = sorted(now - st.inside)
        st.inside = now
        for key in new:
            if key[0] == ctx.user:
                self._pick_and_fire(k, st, t, around=ctx.user, key=key)
            else:
                self._fire(k, st, t, key, {"agent": key[0], "user": ctx.user})

    def _pick_and_fire(self, k: int, st: _State, t: float, *, around: int | None,
                       key: tuple[int, ...] = ()) -> None:
        ctx = self.scheduler.ctx
        crowd = ctx.crowd
        ok = self._eligible(k)
        rows = np.flatnonzero(ok)
        if rows.size == 0:
            if key:  # the user entered with nobody to bind: events that need only the user still start
                self._fire(k, st, t, key, {"user": ctx.user})
            return
        if around is None:
            first = int(rows[int(ctx.rng.integers(rows.size))])
        else:
            u = crowd.pos[ctx.row(around)]
            dist = np.hypot(crowd.pos[rows, 0] - u[0], crowd.pos[rows, 1] - u[1])
            if st.decl.distance > 0:
                keep = dist < st.decl.distance
                rows, dist = rows[keep], dist[keep]
                if rows.size == 0:
                    return
            first = int(rows[int(np.argmin(dist))])
        found: dict[str, Any] = {"agent": int(crowd.ids[first]), "user": ctx.user}
        others = rows[rows != first]
        if others.size:
            p = crowd.pos[first]
            dist = np.hypot(crowd.pos[others, 0] - p[0], crowd.pos[others, 1] - p[1])
            found["other"] = int(crowd.ids[int(others[int(np.argmin(dist))])])
        self._fire(k, st, t, key, found)

    # -- firing ---------------------------------------------------------------------------------

    def _fire(self, k: int, st: _State, t: float, key: tuple[int, ...], found: dict[str, Any]) -> None:
        sch = self.scheduler
        decl = st.decl
        if t - st.last.get(key, -math.inf) < decl.cooldown:
            return
        if sch.running_from(k) >= decl.max_running:
            return
        values = self._values(decl, found)
        if values is None:
            return
        st.last[key] = t
        if decl.chance < 1.0 and sch.ctx.rng.random() >= decl.chance:
            return
        self.fired[k] += 1
        sch.start_event(decl.event, values, trigger=k)

    def _values(self, decl: TriggerDef, found: dict[str, Any]) -> dict[str, Any] | None:
        """The event's parameter values from the bind table; None if a symbol has no actor here."""
        ctx = self.scheduler.ctx
        out: dict[str, Any] = {}
        for p, sym in decl.bind.items():
            if isinstance(sym, tuple):
                out[p] = sym
            elif sym in ("agent", "other", "user"):
                if found.get(sym) is None:
                    return None
                out[p] = found[sym]
            elif sym == "here":
                if found.get("agent") is None:
                    return None
                out[p] = ctx.pos(found["agent"])
            elif sym == "midpoint":
                a = found.get("agent")
                b = found.get("other", found.get("user"))
                if a is None or b is None:
                    return None
                pa, pb = ctx.pos(a), ctx.pos(b)
                out[p] = ctx.walkable.nearest_walkable(((pa[0] + pb[0]) / 2, (pa[1] + pb[1]) / 2))
            else:
                out[p] = sym  # an object name
        return out
