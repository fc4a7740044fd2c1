"""The behavior scheduler (ADAPT §6.1.1): personal trees, events, smart objects, triggers.

Ticked once per decision tick (30 Hz by default) inside the simulation's
``decide`` phase, after the BFSM. ADAPT's four principles, as pedvr reads them:

**PBT clock.** Every active tree is ticked at the decision rate; a tree
that is only waiting for time to pass sleeps until its wake time
(:mod:`pedvr.behavior.tree`), which is why hundreds of trees cost little.

**Suspension.** An agent claimed by an event is suspended from its
autonomy: its personal tree is terminated and its BFSM is frozen (not
decided, its timers paused). When the event ends the agent gets back the
goal and speed it had, its BFSM timers shifted by the time it was away, and
its personal tree starts again (ADAPT: "control is yielded to the
characters' own individual decision processes").

**Termination.** A terminated tree stops its running nodes (each ends the
capability it started) and undoes what it left in place
(:class:`pedvr.behavior.context.Run`). Ending can take several ticks: a
seated agent stands up first. An agent is *ready* for a new event, and its
BFSM resumes, only once it stands.

**Priority.** Personal trees and the BFSM have priority 0; events have a
priority >= 1. An event that needs an agent held by a lower-priority event
terminates that event as a whole (its other agents return to autonomy at
once). An event waits, claiming the agents it can, until all its agents are
ready; after its ``patience`` it is dropped and they are released. The user
may fill any observed role of any number of events: the user is never
claimed. This holds however the event is started: from code
(:meth:`Scheduler.start_event`) or by a scene's trigger, which may bind an
agent a lower-priority event holds (:mod:`pedvr.behavior.triggers`). Each
agent's hold is in ``BehaviorState.event_priority`` (0 when free).

Personal trees belong to BFSM states (``tree = "name"`` in a state): the
tree starts when an agent enters the state, stops when it leaves, and when
it ends by itself its outcome is the state's ``success`` / ``failure``
transition event (without one the tree starts again). Each agent keeps one
instance of each of its states' trees, so per-node state (a cooldown) lasts
across runs; an event builds its tree afresh each time it starts.

Order and determinism: events tick in the order they started, then the
personal trees that are due (a heap of wake times) in the order they started; every random draw comes from the
simulation's rng in that order. Trees read positions committed by the last
step and write only goals, facings, speed scales and body capability
commands, which nothing reads before the next phase.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pedvr.behavior.bfsm import BFSM
from pedvr.behavior.context import Context, Run
from pedvr.behavior.library import library_trees
from pedvr.behavior.nodes import Bindings, build
from pedvr.behavior.objects import SmartObject
from pedvr.behavior.spec import EventDef, TreeDef
from pedvr.behavior.state import FREE, TREE_FAILURE, TREE_SUCCESS
from pedvr.behavior.tree import FAILURE, RUNNING, SUCCESS, Behaviour, Status
from pedvr.behavior.triggers import Triggers
from pedvr.errors import UsageError
from pedvr.scene.config import BehaviorConfig

PENDING, ACTIVE, ENDED = "pending", "running", "ended"


class TreeRun(Run):
    """A tree being run: its root, its wake time, and what it leaves in place (``undo``)."""

    __slots__ = ("root", "wake", "seq")

    def __init__(self, root: Behaviour | None, seq: int) -> None:
        super().__init__()
        self.root = root
        self.wake = 0.0
        self.seq = seq


class PersonalRun(TreeRun):
    __slots__ = ("agent", "state")

    def __init__(self, root: Behaviour, seq: int, *, agent: int, state: int) -> None:
        super().__init__(root, seq)
        self.agent = agent
        self.state = state


class EventRun(TreeRun):
    """A multi-actor event: ``agents`` it drives (claimed), ``actors`` it only observes (the user)."""

    __slots__ = ("event", "tree", "values", "agents", "actors", "phase", "requested", "started", "outcome",
                 "trigger")

    def __init__(self, event: EventDef, tree: TreeDef, values: dict[str, Any], seq: int, *, agents: list[int],
                 actors: list[int], t: float, trigger: int | None) -> None:
        super().__init__(None, seq)
        self.event = event
        self.tree = tree
        self.values = values
        self.agents = agents
        self.actors = actors
        self.phase = PENDING
        self.requested = t
        self.started = math.nan
        self.outcome = ""
        self.trigger = trigger

    @property
    def priority(self) -> int:
        return self.event.priority


@dataclass
class Suspension:
    """What an agent had when an event claimed it (restored when released)."""

    since: float
    goal: tuple[float, float]
    speed_scale: float


class Scheduler:
    """Runs the scene's interactions. ``tick(t)`` returns the rows whose goal it restored."""

    def __init__(self, config: BehaviorConfig, ctx: Context, *, bfsm: BFSM) -> None:
        self.ctx = ctx
        self.trees: dict[str, TreeDef] = {**library_trees(), **config.trees}
        self.events: dict[str, EventDef] = dict(config.events)
        self.bfsm = bfsm
        self.state_tree: list[TreeDef | None] = []
        for n in bfsm.names:
            tree = config.states[n].tree
            self.state_tree.append(None if tree is None else self.trees[tree])
        self._has_tree = np.array([t is not None for t in self.state_tree] + [False], np.bool_)
        self.personal: dict[int, PersonalRun] = {}
        self._roots: dict[tuple[int, int], Behaviour] = {}  # (agent, state) -> its personal tree
        self._due: list[tuple[float, int, PersonalRun]] = []  # heap (wake, seq, run); stale entries skipped
        self._ids_seen: np.ndarray | None = None
        self.live: list[EventRun] = []  # pending and running events, in start order
        self.control: dict[int, EventRun] = {}
        self.suspended: dict[int, Suspension] = {}
        self.triggers = Triggers(config.triggers, self, state_ids=bfsm.ids)
        self.log: list[dict[str, Any]] = []
        self.counts = {"events_started": 0, "events_succeeded": 0, "events_failed": 0,
                       "events_interrupted": 0, "events_dropped": 0}
        self._seq = 0
        self._replan: list[int] = []
        self.ticked = 0  # trees ticked at the last tick (the others slept)

    @property
    def objects(self) -> dict[str, SmartObject]:
        return self.ctx.objects

    # -- public API -----------------------------------------------------------------------------

    def start_event(self, name: str, values: dict[str, Any], *, trigger: int | None = None) -> EventRun:
        """Request event ``name`` for the given parameter values (agent ids, points, object names).

        The event claims its agents (terminating lower-priority events that
        hold them) and starts once all are ready. Raises UsageError for an
        unknown event or values that do not fit its parameters.
        """
        ev = self.events.get(name)
        if ev is None:
            raise UsageError(f"event {name!r}: unknown; known: {', '.join(sorted(self.events)) or 'none'}")
        tree = self.trees[ev.tree]
        bound, agents, actors = self._bind(name, tree, values)
        self._seq += 1
        run = EventRun(ev, tree, bound, self._seq, agents=agents, actors=actors, t=self.ctx.t,
                       trigger=trigger)
        self.live.append(run)
        self.counts["events_started"] += 1
        self._claim(run)
        return run

    def running_from(self, trigger: int) -> int:
        """Events started by trigger ``trigger`` (its index) that are pending or running."""
        return sum(1 for r in self.live if r.trigger == trigger)

    def cancel(self, run: EventRun) -> None:
        """End an event from code (a pending or running one): counted as interrupted."""
        self._end_event(run, None, "cancelled")

    def user_action(self, name: str) -> None:
        """The backend reports an action of the user (a button, a key) for ``user_action`` triggers."""
        self.triggers.user_action(name)

    def frozen(self) -> np.ndarray:
        """``(N,)`` rows whose BFSM must not decide now: in an event, or still getting up from a seat."""
        b = self.ctx.behavior
        out = b.in_event.copy()
        body = self.ctx.body
        if len(body.state) == out.shape[0] and out.shape[0]:
            co = body.coordinator
            getting_up = (co.weights[:, co.index["sitting"]] > 0.0) | body.state.sitting
            out |= getting_up & (b.tree_state < 0)
        return out

    def pinned(self) -> np.ndarray:
        """``(N,)`` seated bodies (sitting down, seated, getting up), which steering must not slide.

        The simulation zeroes their steering velocity and the contact pass
        moves others, not them, as it does for the user. A seated agent the
        user touches is not pinned: nothing may overlap the user, and the user
        cannot be moved (DESIGN.md), so the seated body is pushed instead.
        """
        body, crowd = self.ctx.body, self.ctx.crowd
        n = len(crowd)
        if len(body.state) != n or n == 0:
            return np.zeros(n, np.bool_)
        co = body.coordinator
        out = (body.state.sitting | (co.weights[:, co.index["sitting"]] > 0.0)) & ~crowd.is_user
        if out.any() and crowd.is_user.any():
            u = int(np.flatnonzero(crowd.is_user)[0])
            gap = np.hypot(*(crowd.pos - crowd.pos[u]).T) - crowd.radius - crowd.radius[u]
            out &= gap > 0.05
        return out

    def engaged_with_user(self) -> np.ndarray:
        """``(N,)`` rows driven by a running event in which the user has a role (holding a
        gate for the user, demonstrating to the user), or by a running node that drives them for
        the user (``ctx.engaged``: a demonstration from a BFSM state's tree): the user encounter
        model (:mod:`pedvr.crowd.encounter`) leaves them alone, since they move *for* the user,
        not out of the user's way; ORCA's late safety step still applies."""
        crowd = self.ctx.crowd
        out = np.zeros(len(crowd), np.bool_)
        user = self.ctx.user
        if user is None:
            return out
        for run in self.live:
            if run.phase == ACTIVE and user in run.actors:
                out |= np.isin(crowd.ids, run.agents)
        if self.ctx.engaged:
            out |= np.isin(crowd.ids, sorted(self.ctx.engaged))
        return out

    def summary(self) -> dict[str, object]:
        out: dict[str, object] = dict(self.counts)
        out["chair_sits"] = sum(o.uses.get("sit", 0) for o in self.objects.values() if o.kind == "chair")
        uses: dict[str, int] = {}
        fails: dict[str, int] = {}
        for o in self.objects.values():
            for name, n in o.uses.items():
                uses[f"{o.kind}.{name}"] = uses.get(f"{o.kind}.{name}", 0) + n
            for why, n in o.failures.items():
                fails[f"{o.kind}.{why}"] = fails.get(f"{o.kind}.{why}", 0) + n
        out["affordance_uses"] = uses
        out["affordance_failures"] = fails
        figures: dict[str, float] = {}
        for o in self.objects.values():
            for name, x in o.figures().items():
                figures[name] = figures.get(name, 0) + x
        out.update(figures)  # each kind's own (an exhibit's: demonstrations_unseen, ...)
        out["event_log"] = list(self.log)  # every ended event: name, agents, times, outcome, why
        out["object_log"] = [e for o in self.objects.values() for e in o.log]  # demonstrations, ...
        return out

    # -- the tick -------------------------------------------------------------------------------

    def tick(self, t: float) -> list[int]:
        ctx = self.ctx
        ctx.t = t
        self.ticked = 0
        for o in self.objects.values():
            o.tick(ctx)
        self._sync_personal()
        self.triggers.fire(t)
        for run in list(self.live):
            if run.phase == PENDING:
                self._try_start(run)
        left = ctx.crowd.ids is not self._ids_seen  # rows changed: some actor may have left
        self._ids_seen = ctx.crowd.ids
        for run in list(self.live):
            if run.phase != ACTIVE:
                continue
            if left and any(ctx.find(a) is None for a in run.actors):
                self._end_event(run, FAILURE, "an actor left")
            elif run.wake <= t + 1e-9:
                s = self._tick_run(run)
                if s is not RUNNING:
                    self._end_event(run, s, s.value)
        # Personal trees that are due, in the order they started; the others sleep in the heap.
        due: list[PersonalRun] = []
        heap = self._due
        while heap and heap[0][0] <= t + 1e-9:
            wake, _, prun = heapq.heappop(heap)
            if self.personal.get(prun.agent) is prun and prun.wake == wake:
                due.append(prun)
        due.sort(key=lambda r: r.seq)
        for prun in due:
            row = ctx.find(prun.agent)
            if row is None:
                continue
            s = self._tick_run(prun)
            if s is not RUNNING:
                self._end_personal(prun, row, s)
            else:
                heapq.heappush(heap, (prun.wake, prun.seq, prun))
        back, self._replan = self._replan, []
        return [r for r in (ctx.find(a) for a in back) if r is not None]

    def _tick_run(self, run: TreeRun) -> Status:
        ctx = self.ctx
        self.ticked += 1
        ctx.run = run
        ctx.wake = math.inf
        assert run.root is not None
        s = run.root.tick(ctx)
        run.wake = ctx.wake
        return s

    # -- personal trees -------------------------------------------------------------------------

    def _sync_personal(self) -> None:
        """Start, stop and restart personal trees to follow the agents' BFSM states."""
        ctx = self.ctx
        b = ctx.behavior
        n = b.state.shape[0]
        if len(self.personal) > int(np.count_nonzero(b.tree_state >= 0)):  # agents left the scene
            for agent in [a for a in self.personal if ctx.find(a) is None]:
                self._stop(self.personal.pop(agent))
            for key in [k for k in ctx.owners if ctx.find(k[0]) is None]:
                del ctx.owners[key]
            for gone in [k for k in self._roots if ctx.find(k[0]) is None]:
                del self._roots[gone]
        if n == 0 or not self._has_tree.any():
            return
        want = self._has_tree[b.state] & ~b.in_event & ~ctx.crowd.is_user
        stale = (b.tree_state >= 0) & (~want | (b.tree_state != b.state))
        for row in np.flatnonzero(stale).tolist():
            agent = int(ctx.crowd.ids[row])
            prun = self.personal.pop(agent, None)
            if prun is not None:
                self._stop(prun)
            b.tree_state[row] = -1
        # An agent getting up from a seat starts its next tree once standing.
        fresh = want & (b.tree_state < 0)
        for row in np.flatnonzero(fresh).tolist():
            agent = int(ctx.crowd.ids[row])
            if ctx.sitting(agent):
                continue
            sid = int(b.state[row])
            root = self._roots.get((agent, sid))
            if root is None:  # built once per agent and state: its nodes (a cooldown) outlive a run
                tree = self.state_tree[sid]
                assert tree is not None
                param = next(iter(tree.params))
                root = build(tree.root, Bindings({param: agent}, objects=self.objects, user=ctx.user))
                self._roots[(agent, sid)] = root
            self._seq += 1
            prun = PersonalRun(root, self._seq, agent=agent, state=int(b.state[row]))
            self.personal[agent] = prun
            heapq.heappush(self._due, (prun.wake, prun.seq, prun))
            b.tree_state[row] = b.state[row]

    def _stop(self, run: TreeRun) -> None:
        """The termination signal: stop the running nodes, undo what the tree left in place."""
        self.ctx.run = run
        if run.root is not None and run.root.status is RUNNING:
            run.root.stop(self.ctx)
        run.end()

    def _end_personal(self, prun: PersonalRun, row: int, s: Status) -> None:
        self.personal.pop(prun.agent, None)
        prun.end()
        b = self.ctx.behavior
        b.tree_state[row] = -1
        b.tree_done[row] = TREE_SUCCESS if s is SUCCESS else TREE_FAILURE

    # -- events ---------------------------------------------------------------------------------

    def _bind(self, name: str, tree: TreeDef, values: dict[str, Any]) -> tuple[dict[str, Any], list[int],
                                                                                list[int]]:
        ctx = self.ctx
        missing = [p for p in tree.params if p not in values]
        extra = [p for p in values if p not in tree.params]
        if missing or extra:
            raise UsageError(f"event {name!r}: parameters {', '.join(tree.params)}; "
                             f"missing {missing or 'none'}, unknown {extra or 'none'}")
        bound: dict[str, Any] = {}
        agents: list[int] = []
        actors: list[int] = []
        for p, kind in tree.params.items():
            v = values[p]
            if kind in ("agent", "user", "actor"):
                if isinstance(v, bool) or not isinstance(v, int | np.integer) or ctx.find(int(v)) is None:
                    raise UsageError(f"event {name!r}: {p} = {v!r}: expected the id of an agent in the scene")
                is_user = int(v) == ctx.user
                if kind == "agent" and is_user:
                    raise UsageError(f"event {name!r}: {p} is an agent role; the user is never driven")
                if kind == "user" and not is_user:
                    raise UsageError(f"event {name!r}: {p} is the user's role; {v} is not the user")
                if kind == "agent":
                    if int(v) in agents:
                        raise UsageError(f"event {name!r}: agent {v} fills two roles")
                    agents.append(int(v))
                actors.append(int(v))
                bound[p] = int(v)
            elif kind == "point":
                if not (isinstance(v, tuple | list) and len(v) == 2):
                    raise UsageError(f"event {name!r}: {p} = {v!r}: expected a point (x, y)")
                bound[p] = (float(v[0]), float(v[1]))
            else:
                obj = self.objects.get(v) if isinstance(v, str) else v
                if not isinstance(obj, SmartObject):
                    raise UsageError(f"event {name!r}: {p} = {v!r}: expected a smart object name; "
                                     f"the scene's: {', '.join(self.objects) or 'none'}")
                bound[p] = obj
        return bound, agents, actors

    def _claim(self, run: EventRun) -> None:
        """Take every agent of ``run`` that is free or held by a lower priority (ADAPT's Event Priority)."""
        for agent in run.agents:
            cur = self.control.get(agent)
            if cur is run:
                continue
            if cur is not None:
                if cur.priority >= run.priority:
                    continue
                self._end_event(cur, None, f"interrupted by {run.event.name}")
            self._suspend(agent, run)

    def _suspend(self, agent: int, run: EventRun) -> None:
        ctx = self.ctx
        row = ctx.row(agent)
        b = ctx.behavior
        prun = self.personal.pop(agent, None)
        if prun is not None:
            self._stop(prun)
            b.tree_state[row] = -1
        if agent not in self.suspended:
            g = b.goal[row]
            self.suspended[agent] = Suspension(since=ctx.t, goal=(float(g[0]), float(g[1])),
                                               speed_scale=float(b.speed_scale[row]))
        self.control[agent] = run
        b.in_event[row] = True
        b.event_priority[row] = run.priority
        ctx.body.go_to(agent, None)  # stand while the event gathers its actors

    def _try_start(self, run: EventRun) -> None:
        ctx = self.ctx
        if any(ctx.find(a) is None for a in run.actors):
            self._end_event(run, FAILURE, "an actor left")
            return
        self._claim(run)
        ready = all(self.control.get(a) is run and not ctx.sitting(a) for a in run.agents)
        if ready:
            run.root = build(run.tree.root, Bindings(run.values, objects=self.objects, user=ctx.user))
            run.phase = ACTIVE
            run.started = ctx.t
            run.wake = 0.0
        elif ctx.t - run.requested > run.event.patience:
            self._end_event(run, None, "dropped: actors not ready")

    def _end_event(self, run: EventRun, s: Status | None, why: str) -> None:
        """End ``run`` (``s`` None: interrupted or dropped) and return its agents to autonomy."""
        if run.phase == ENDED:
            return
        ctx = self.ctx
        if run.phase == ACTIVE:
            self._stop(run)
        else:
            run.end()
        if s is SUCCESS:
            key = "events_succeeded"
        elif s is FAILURE:
            key = "events_failed"
        else:
            key = "events_dropped" if run.phase == PENDING else "events_interrupted"
        self.counts[key] += 1
        run.phase = ENDED
        run.outcome = why
        self.live.remove(run)
        self.log.append({"event": run.event.name, "t_requested": round(run.requested, 6),
                         "t_started": None if math.isnan(run.started) else round(run.started, 6),
                         "t_ended": round(ctx.t, 6), "outcome": key.removeprefix("events_"), "why": why,
                         "agents": list(run.agents)})
        for agent in run.agents:
            if self.control.get(agent) is run:
                self._resume(agent)

    def _resume(self, agent: int) -> None:
        """Give the agent back to its BFSM: the goal and speed it had, its timers shifted."""
        ctx = self.ctx
        self.control.pop(agent, None)
        sus = self.suspended.pop(agent, None)
        for key in [k for k in ctx.owners if k[0] == agent]:
            del ctx.owners[key]
        row = ctx.find(agent)
        if row is None or sus is None:
            return
        b = ctx.behavior
        away = ctx.t - sus.since
        b.timer_end[row] += away
        b.seq_until[row] += away
        b.goal[row] = sus.goal
        b.speed_scale[row] = sus.speed_scale
        b.face[row] = np.nan
        b.in_event[row] = False
        b.event_priority[row] = FREE
        self._replan.append(agent)
