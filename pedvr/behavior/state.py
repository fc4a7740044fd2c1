"""The behavior layer's shared vocabulary: the per-agent arrays and the constants every part reads.

This module imports nothing of :mod:`pedvr.behavior` (issue 24, "the house"): the BFSM,
the context, the trees, the scheduler and the triggers all build on it, and none of
them has to import another to agree on what a row's state, a tree's outcome or an
event's hold on an agent means.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

NO_STATE = -1  # BehaviorState.state of the user row (no BFSM state)
TREE_SUCCESS, TREE_FAILURE = 1, 2  # BehaviorState.tree_done: the state's personal tree just ended so
FREE = 0  # BehaviorState.event_priority of an agent no event holds (personal trees and the BFSM: 0)

FOV_HALF = math.radians(100.0)  # the gaze rule's field of view (pedvr.body.model.FOV_HALF)
IDLE_SPEED = 0.2  # m/s: below this an agent stands
EYE_HEIGHT = 1.6  # m: where a gaze at a ground point or an agent's place looks


@dataclass
class BehaviorState:
    """Per-row behavior state; rows align with :class:`pedvr.crowd.state.CrowdState`.

    ``state`` is -1 (:data:`NO_STATE`) for the user row. ``goal`` is NaN where there is no goal.
    """

    state: np.ndarray  # (N,) int32 state id, index into BFSM.names
    entered_at: np.ndarray  # (N,) float64 s
    timer_end: np.ndarray  # (N,) float64 s, +inf when the state has no timer
    goal: np.ndarray  # (N, 2) float64 m, NaN for none
    speed_scale: np.ndarray  # (N,) float64
    seq_index: np.ndarray  # (N,) int64 position in the goal sequence
    seq_until: np.ndarray  # (N,) float64 s: an idle/flow sequence entry ends then
    arrivals: np.ndarray  # (N,) int64 goals reached so far
    # the behavior-tree layer (pedvr.behavior.scheduler, leaves):
    face: np.ndarray  # (N,) float64 rad: preferred facing while standing, NaN for none (the Face action)
    tree_state: np.ndarray  # (N,) int32: the state whose personal tree is running, -1 for none
    tree_done: np.ndarray  # (N,) int8: the state's tree just ended: TREE_SUCCESS, TREE_FAILURE, 0 not
    in_event: np.ndarray  # (N,) bool: claimed by a multi-actor event (its BFSM is frozen)
    # (N,) int32: the priority of the event that holds the row (pending or running), FREE for none;
    # a trigger may bind an agent only for an event of a higher priority (ADAPT's Event Priority)
    event_priority: np.ndarray

    @classmethod
    def rows(cls, n: int) -> BehaviorState:
        return cls(
            state=np.full(n, NO_STATE, np.int32),
            entered_at=np.zeros(n),
            timer_end=np.full(n, np.inf),
            goal=np.full((n, 2), np.nan),
            speed_scale=np.ones(n),
            seq_index=np.zeros(n, np.int64),
            seq_until=np.full(n, np.inf),
            arrivals=np.zeros(n, np.int64),
            face=np.full(n, np.nan),
            tree_state=np.full(n, -1, np.int32),
            tree_done=np.zeros(n, np.int8),
            in_event=np.zeros(n, np.bool_),
            event_priority=np.full(n, FREE, np.int32),
        )

    def append(self, other: BehaviorState) -> None:
        for f in fields(self):
            setattr(self, f.name, np.concatenate([getattr(self, f.name), getattr(other, f.name)]))

    def keep(self, mask: np.ndarray) -> None:
        for f in fields(self):
            setattr(self, f.name, np.ascontiguousarray(getattr(self, f.name)[mask]))
