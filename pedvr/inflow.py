"""Sources and sinks: agents that arrive at a rate and leave at exits (issue 26).

A real experiment meters its inflow (people released into a corridor at so many
per second) and people leave the camera's view at the exit. Scenes say so with
``[[agents.sources]]`` and ``[[agents.sinks]]`` (:class:`pedvr.scene.config.Source`,
:class:`pedvr.scene.config.Sink`); the :class:`pedvr.sim.Simulation` asks this
module, between steps, which agents have left and where new ones may enter.

Contracts:

* A source owes ``floor((t - start) * rate) + 1`` agents at time ``t`` (``regular``;
  ``poisson`` draws the gaps, exponential of mean ``1 / rate``, with the run's
  generator), at most ``max_count`` in all, none after ``stop``.
* An owed agent enters only at a spot free of every body's footprint (its
  bounding radius, so a turned or pram footprint counts whole) and of the user,
  with ``CLEARANCE`` to spare, and on the navigation mesh for its radius (never
  inside a wall). When no spot is free it waits and is tried again next step:
  the inflow is delayed, never dropped and never overlapping.
* A sink removes every virtual agent whose position lies inside its region (a
  sink with ``states``: every one in one of those BFSM states); the user is never
  removed.
* Everything random is drawn from the generator passed in, in a fixed order: the
  same seed gives the same arrivals.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pedvr.crowd.footprint import footprints
from pedvr.crowd.state import CrowdState
from pedvr.scene.config import Sink, Source

CLEARANCE = 0.05  # m of free space a new agent keeps from every footprint when it enters
TRIES = 12  # random spots tried per owed agent and step before it waits for the next step


@dataclass
class SourceState:
    """What one source has done so far: agents added, when the next one is due (s), and the due
    times (s) of those still waiting for a free spot, oldest first."""

    added: int = 0
    next_due: float = 0.0
    pending: list[float] = field(default_factory=list)


@dataclass
class Inflow:
    """The scene's sources and sinks over a run (one per :class:`pedvr.sim.Simulation`)."""

    sources: tuple[Source, ...]
    sinks: tuple[Sink, ...]
    state_names: tuple[str, ...] = ()  # the BFSM's state names (a sink with ``states`` needs them)
    state: list[SourceState] = field(default_factory=list)
    removed: int = 0  # agents removed at sinks
    max_wait: float = 0.0  # s: the longest an owed agent waited for a free spot
    _sink_states: list[np.ndarray | None] = field(default_factory=list)  # BFSM state ids, per sink

    def __post_init__(self) -> None:
        self.state = [SourceState(next_due=s.start) for s in self.sources]
        self._sink_states = [None if not sink.states else
                             np.asarray([self.state_names.index(name) for name in sink.states], np.int64)
                             for sink in self.sinks]

    def owed(self, k: int, t: float, rng: np.random.Generator) -> int:
        """How many agents source ``k`` owes at time ``t`` (those due now join the ones still
        waiting; ``poisson`` gaps are drawn here, in due order)."""
        src, st = self.sources[k], self.state[k]
        while (st.next_due <= t + 1e-9 and st.next_due < src.stop
               and (src.max_count == 0 or st.added + len(st.pending) < src.max_count)):
            st.pending.append(st.next_due)
            gap = 1.0 / src.rate if src.timing == "regular" else float(rng.exponential(1.0 / src.rate))
            st.next_due += gap
        return len(st.pending)

    def entered(self, k: int, n: int, t: float) -> None:
        """``n`` of source ``k``'s waiting agents entered at time ``t`` (the oldest first)."""
        st = self.state[k]
        for due in st.pending[:n]:
            self.max_wait = max(self.max_wait, t - due)
        del st.pending[:n]
        st.added += n

    def waiting(self) -> int:
        """Agents due that wait for a free spot."""
        return sum(len(st.pending) for st in self.state)

    def candidates(self, k: int, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` random spots ``(n, 2)`` in source ``k``'s area or along its line."""
        src = self.sources[k]
        u = rng.uniform(size=(n, 2))
        if src.line is not None:
            (x0, y0), (x1, y1) = src.line
            return np.column_stack([x0 + u[:, 0] * (x1 - x0), y0 + u[:, 0] * (y1 - y0)])
        assert src.region is not None
        kind, v = src.region
        if kind == "box":
            return np.column_stack([v[0] + u[:, 0] * (v[2] - v[0]), v[1] + u[:, 1] * (v[3] - v[1])])
        r = v[2] * np.sqrt(u[:, 0])  # uniform over the disc
        a = 2.0 * np.pi * u[:, 1]
        return np.column_stack([v[0] + r * np.cos(a), v[1] + r * np.sin(a)])

    def place(self, k: int, count: int, *, centres: np.ndarray, reach: np.ndarray, radius: float,
              rng: np.random.Generator, on_mesh: Callable[[tuple[float, float]], bool]
              ) -> list[tuple[float, float]]:
        """Up to ``count`` free spots for new agents of ``radius`` from source ``k``: each one
        clear by ``CLEARANCE`` of every body (discs ``centres (N, 2)``, ``reach (N,)``: each
        footprint's centre and bounding radius, :func:`bounding_discs`) and of the spots already
        chosen, and on the mesh (``on_mesh``). Fewer when the area is full."""
        out: list[tuple[float, float]] = []
        for _ in range(count):
            spot = None
            for p in self.candidates(k, TRIES, rng):
                if centres.shape[0]:
                    gap = np.hypot(centres[:, 0] - p[0], centres[:, 1] - p[1]) - reach - radius
                    if gap.min() < CLEARANCE:
                        continue
                if any(math.dist(p, q) < 2.0 * radius + CLEARANCE for q in out):
                    continue
                if not on_mesh((float(p[0]), float(p[1]))):
                    continue
                spot = (float(p[0]), float(p[1]))
                break
            if spot is None:
                break
            out.append(spot)
        return out

    def sunk(self, crowd: CrowdState, state: np.ndarray | None = None) -> np.ndarray:
        """Rows ``(N,)`` of virtual agents inside some sink region (of a sink with ``states``, only
        those whose BFSM state id, ``state[row]``, is one of them)."""
        out = np.zeros(len(crowd), np.bool_)
        x, y = crowd.pos[:, 0], crowd.pos[:, 1]
        for sink, ids in zip(self.sinks, self._sink_states, strict=True):
            kind, v = sink.region
            if kind == "box":
                inside = (x >= v[0]) & (x <= v[2]) & (y >= v[1]) & (y <= v[3])
            else:
                inside = np.hypot(x - v[0], y - v[1]) <= v[2]
            if ids is not None:
                if state is None:
                    raise ValueError("a sink with states needs the agents' BFSM states")
                inside &= np.isin(state, ids)
            out |= inside
        return out & ~crowd.is_user

    def summary(self, t: float) -> dict[str, object]:
        """The JSON keys: agents added and removed, agents still waiting at ``t`` (s) and the
        longest wait for a free spot (s), the ones still waiting included."""
        waits = [self.max_wait] + [t - st.pending[0] for st in self.state if st.pending]
        return {
            "source_agents_added": sum(st.added for st in self.state),
            "sink_agents_removed": self.removed,
            "source_agents_waiting": self.waiting(),
            "source_max_wait_s": round(max(waits), 6),
        }


def bounding_discs(crowd: CrowdState) -> tuple[np.ndarray, np.ndarray]:
    """Every row's footprint (:func:`pedvr.crowd.footprint.footprints`) as its bounding disc:
    centres ``(N, 2)`` m and radii ``(N,)`` m (a turned body's or a pram's footprint counts whole)."""
    fp = footprints(crowd.pos, crowd.radius, crowd.turn, crowd.torso, crowd.heading, crowd.ahead,
                    crowd.length)
    return fp.centre, fp.radius
