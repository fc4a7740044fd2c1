"""Behavioral finite state machine (PedVR §4.3, as in Menge).

The BFSM maps (time, simulator state) to a state id and a goal per agent:
``B_i : t × S → ID × R²``. States come from the scene; each names a goal
selector (:mod:`pedvr.behavior.goals`) and transitions out of it:

* ``arrival``: the agent is within the state's ``arrive_dist`` of its goal
  (or, in a ``sequence`` state, has walked its whole goal sequence);
* ``timer``: ``after`` seconds (drawn uniformly from ``[lo, hi]`` on entry)
  have passed since entering the state;
* ``probability``: a Poisson event with ``rate`` per second, tested at each
  decision tick;
* ``success`` / ``failure``: the state's behavior tree (``tree``) ended so
  (:mod:`pedvr.behavior.scheduler`; without such a transition the tree runs
  again).

Transitions are tested in the order the scene lists them; the first that
fires wins. With several targets, the next state is drawn by ``weights``.
Entering a ``final`` state marks the agent for removal (it has left the
scene; SteerSuite agents leave at their last goal).

Rows ``frozen`` by the scheduler (agents in a multi-actor event, or getting
up from a seat) are not decided; the scheduler pauses their timers.

Event checks are vectorised over agents; only agents whose transition fires
run Python. All draws use the simulation's one rng, in row order, so a run
is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from pedvr.behavior.goals import GoalContext, Walkable, selectors
from pedvr.behavior.state import BehaviorState
from pedvr.scene.config import BehaviorConfig, SequenceGoal, StateConfig

__all__ = ["BFSM", "BehaviorState", "Decision"]  # BehaviorState lives in pedvr.behavior.state


@njit(cache=True)
def _candidates(state, frozen, goal, pos, arrive, idle_arrival, has_prob, seq_until, timer_end, tree_done,
                t, flags):  # noqa: ANN001, ANN202
    """One pass over the rows for :meth:`BFSM.decide`: per active row (a state, not frozen)
    ``flags[i] = (has_goal, at_goal, timer, candidate)``, where a candidate may transition this
    tick (at its goal or its sequence entry's end, its timer run out, its tree done, an
    arrival with no goal, or a state with probability transitions); clears the active rows'
    ``tree_done`` (the caller keeps a copy). Returns the number of active rows."""
    active = 0
    for i in range(state.shape[0]):
        if state[i] < 0 or frozen[i]:
            continue
        active += 1
        s = state[i]
        has = not math.isnan(goal[i, 0])
        at = False
        if has:
            dx = goal[i, 0] - pos[i, 0]
            dy = goal[i, 1] - pos[i, 1]
            at = math.sqrt(dx * dx + dy * dy) < arrive[s]
        at = at or t >= seq_until[i]
        timer = t >= timer_end[i]
        flags[i, 0] = has
        flags[i, 1] = at
        flags[i, 2] = timer
        flags[i, 3] = at or timer or tree_done[i] != 0 or (not has and idle_arrival[s]) or has_prob[s]
        tree_done[i] = 0
    return active


@dataclass(frozen=True)
class Decision:
    """What a decision tick changed: rows whose goal changed, rows to remove."""

    goal_changed: np.ndarray  # (N,) bool
    leaving: np.ndarray  # (N,) bool
    arrived: int  # goals reached in this tick


class BFSM:
    """The state machine of one scene. Holds no per-agent data itself."""

    def __init__(self, config: BehaviorConfig, walkable: Walkable) -> None:
        self.config = config
        self.walkable = walkable
        self.names: tuple[str, ...] = tuple(config.states)
        self.ids = {n: i for i, n in enumerate(self.names)}
        self._states: tuple[StateConfig, ...] = tuple(config.states[n] for n in self.names)
        self._arrive = np.array([s.arrive_dist for s in self._states], np.float64)
        self._has_prob = np.array([any(tr.on == "probability" for tr in s.transitions)
                                   for s in self._states], np.bool_)
        # A state without a goal "arrives" at once: only worth a look if it listens for arrival.
        self._idle_arrival = np.array([s.goal is None and any(tr.on == "arrival" for tr in s.transitions)
                                       for s in self._states], np.bool_)

    def enter(self, b: BehaviorState, row: int, state_name: str, *, t: float, pos: np.ndarray,
              rng: np.random.Generator, sequence: tuple[SequenceGoal, ...]) -> bool:
        """Put ``row`` into a state: draw its timer and goal. Returns True if final."""
        sid = self.ids[state_name]
        s = self._states[sid]
        b.state[row] = sid
        b.entered_at[row] = t
        b.speed_scale[row] = s.speed_scale
        timers = [tr for tr in s.transitions if tr.on == "timer"]
        if timers:
            lo, hi = timers[0].after
            b.timer_end[row] = t + (lo if hi <= lo else float(rng.uniform(lo, hi)))
        else:
            b.timer_end[row] = np.inf
        if s.goal is not None and s.goal.kind == "sequence":
            b.seq_index[row] = 0
        self._select_goal(b, row, s, t=t, pos=pos, rng=rng, sequence=sequence)
        return s.final

    def _select_goal(self, b: BehaviorState, row: int, s: StateConfig, *, t: float, pos: np.ndarray,
                     rng: np.random.Generator, sequence: tuple[SequenceGoal, ...]) -> None:
        b.seq_until[row] = np.inf
        if s.goal is None:
            b.goal[row] = np.nan
            return
        cur = None if np.isnan(b.goal[row, 0]) else (float(b.goal[row, 0]), float(b.goal[row, 1]))
        ctx = GoalContext(rng=rng, pos=(float(pos[0]), float(pos[1])), walkable=self.walkable,
                          goal_sets=self.config.goal_sets, current_goal=cur, sequence=sequence,
                          sequence_index=int(b.seq_index[row]))
        g = selectors[s.goal.kind](s.goal.params, ctx)
        b.goal[row] = np.nan if g is None else g
        if s.goal.kind == "sequence" and b.seq_index[row] < len(sequence):
            entry = sequence[int(b.seq_index[row])]
            if entry.kind in ("idle", "flow", "flee") and math.isfinite(entry.duration) \
                    and entry.duration > 0:
                b.seq_until[row] = t + entry.duration
            if entry.kind == "seek":
                b.speed_scale[row] = s.speed_scale

    def decide(self, b: BehaviorState, *, t: float, dt: float, pos: np.ndarray,
               rng: np.random.Generator, sequences: list[tuple[SequenceGoal, ...]],
               frozen: np.ndarray | None = None) -> Decision:
        """One decision tick at time ``t`` (``dt`` since the last tick); ``frozen`` rows are skipped."""
        n = b.state.shape[0]
        goal_changed = np.zeros(n, np.bool_)
        leaving = np.zeros(n, np.bool_)
        flags = np.zeros((n, 4), np.bool_)  # has_goal, at_goal, timer, candidate
        tree_done = b.tree_done.copy()
        count = _candidates(b.state, np.zeros(n, np.bool_) if frozen is None else frozen, b.goal, pos,
                            self._arrive, self._idle_arrival, self._has_prob, b.seq_until, b.timer_end,
                            b.tree_done, float(t), flags)
        if count == 0:
            return Decision(goal_changed, leaving, 0)
        has_goal, at_goal, timer = flags[:, 0], flags[:, 1], flags[:, 2]
        candidates = np.flatnonzero(flags[:, 3])
        arrived = 0
        for row in candidates.tolist():
            s = self._states[int(b.state[row])]
            seq = sequences[row]
            if at_goal[row]:
                arrived += int(has_goal[row])
                b.arrivals[row] += int(has_goal[row])
                if s.goal is not None and s.goal.kind == "sequence" and b.seq_index[row] + 1 < len(seq):
                    b.seq_index[row] += 1
                    self._select_goal(b, row, s, t=t, pos=pos[row], rng=rng, sequence=seq)
                    goal_changed[row] = True
                    continue
            for tr in s.transitions:
                fire = (
                    (tr.on == "arrival" and (at_goal[row] or (not has_goal[row] and s.goal is None)))
                    or (tr.on == "timer" and timer[row])
                    or (tr.on == "probability" and rng.random() < 1.0 - math.exp(-tr.rate * dt))
                    or (tr.on == "success" and tree_done[row] == 1)
                    or (tr.on == "failure" and tree_done[row] == 2)
                )
                if not fire:
                    continue
                if len(tr.to) == 1:
                    nxt = tr.to[0]
                else:
                    w = np.asarray(tr.weights or [1.0] * len(tr.to))
                    nxt = tr.to[int(rng.choice(len(tr.to), p=w / w.sum()))]
                leaving[row] = self.enter(b, row, nxt, t=t, pos=pos[row], rng=rng, sequence=seq)
                goal_changed[row] = True
                break
        return Decision(goal_changed, leaving, arrived)
