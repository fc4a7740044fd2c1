"""BFSM (PedVR §4.3): goals, waits, transitions on arrival, timer and probability."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.behavior.bfsm import BFSM, BehaviorState
from pedvr.behavior.goals import GoalContext, selectors
from pedvr.scene.config import BehaviorConfig, GoalSelector, GoalSet, SequenceGoal, StateConfig, Transition


class OpenPlane:
    """A walkable plane: every point is walkable."""

    def random_point(self, rng: np.random.Generator, region: object = None) -> tuple[float, float]:
        x0, y0, x1, y1 = region.bounds  # type: ignore[attr-defined]
        return float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1))

    def nearest_walkable(self, p: tuple[float, float]) -> tuple[float, float]:
        return p


def machine(states: dict[str, StateConfig], goal_sets: dict[str, GoalSet] | None = None) -> BFSM:
    return BFSM(BehaviorConfig(states=states, goal_sets=goal_sets or {}), OpenPlane())


def test_arrival_then_timer_cycle() -> None:
    fsm = machine({
        "walk": StateConfig("walk", GoalSelector("point", {"at": [5.0, 0.0]}),
                            (Transition(on="arrival", to=("wait",)),), arrive_dist=0.3),
        "wait": StateConfig("wait", None, (Transition(on="timer", to=("walk",), after=(2.0, 2.0)),)),
    })
    b = BehaviorState.rows(1)
    rng = np.random.default_rng(0)
    pos = np.array([[0.0, 0.0]])
    fsm.enter(b, 0, "walk", t=0.0, pos=pos[0], rng=rng, sequence=())
    assert tuple(b.goal[0]) == (5.0, 0.0)
    d = fsm.decide(b, t=0.1, dt=0.1, pos=pos, rng=rng, sequences=[()])
    assert not d.goal_changed[0] and fsm.names[b.state[0]] == "walk"
    pos[0] = (4.8, 0.0)  # inside arrive_dist
    d = fsm.decide(b, t=1.0, dt=0.1, pos=pos, rng=rng, sequences=[()])
    assert d.arrived == 1 and fsm.names[b.state[0]] == "wait" and np.isnan(b.goal[0, 0])
    d = fsm.decide(b, t=2.9, dt=0.1, pos=pos, rng=rng, sequences=[()])
    assert fsm.names[b.state[0]] == "wait"
    d = fsm.decide(b, t=3.0, dt=0.1, pos=pos, rng=rng, sequences=[()])
    assert fsm.names[b.state[0]] == "walk" and d.goal_changed[0]


def test_timer_range_is_drawn_within_bounds() -> None:
    fsm = machine({"wait": StateConfig("wait", None, (Transition(on="timer", to=("wait",), after=(10.0, 20.0)),))})
    b = BehaviorState.rows(200)
    rng = np.random.default_rng(1)
    for row in range(200):
        fsm.enter(b, row, "wait", t=0.0, pos=np.zeros(2), rng=rng, sequence=())
    assert 10.0 <= b.timer_end.min() and b.timer_end.max() <= 20.0
    assert b.timer_end.std() > 2.0  # really drawn, not a constant


def test_probability_transition_rate() -> None:
    """A Poisson rate of 0.5/s over 1 s fires for about 1 - e^-0.5 = 39% of agents."""
    fsm = machine({"a": StateConfig("a", None, (Transition(on="probability", to=("b",), rate=0.5),)),
                   "b": StateConfig("b", None)})
    n = 4000
    b = BehaviorState.rows(n)
    rng = np.random.default_rng(2)
    for row in range(n):
        fsm.enter(b, row, "a", t=0.0, pos=np.zeros(2), rng=rng, sequence=())
    pos = np.zeros((n, 2))
    for k in range(10):
        fsm.decide(b, t=0.1 * (k + 1), dt=0.1, pos=pos, rng=rng, sequences=[()] * n)
    frac = float(np.mean(b.state == fsm.ids["b"]))
    assert abs(frac - (1 - math.exp(-0.5))) < 0.03


def test_weighted_targets() -> None:
    fsm = machine({"a": StateConfig("a", None, (Transition(on="arrival", to=("b", "c"), weights=(3.0, 1.0)),)),
                   "b": StateConfig("b", None), "c": StateConfig("c", None)})
    n = 4000
    b = BehaviorState.rows(n)
    rng = np.random.default_rng(3)
    for row in range(n):
        fsm.enter(b, row, "a", t=0.0, pos=np.zeros(2), rng=rng, sequence=())
    fsm.decide(b, t=0.1, dt=0.1, pos=np.zeros((n, 2)), rng=rng, sequences=[()] * n)
    assert abs(float(np.mean(b.state == fsm.ids["b"])) - 0.75) < 0.03


def test_final_state_marks_leaving() -> None:
    fsm = machine({"go": StateConfig("go", GoalSelector("point", {"at": [1.0, 0.0]}),
                                     (Transition(on="arrival", to=("exit",)),)),
                   "exit": StateConfig("exit", None, final=True)})
    b = BehaviorState.rows(1)
    rng = np.random.default_rng(0)
    fsm.enter(b, 0, "go", t=0.0, pos=np.zeros(2), rng=rng, sequence=())
    d = fsm.decide(b, t=0.1, dt=0.1, pos=np.array([[1.0, 0.0]]), rng=rng, sequences=[()])
    assert d.leaving[0]


def test_sequence_walks_every_goal_before_arrival_fires() -> None:
    seq = (SequenceGoal("seek", (1.0, 0.0)), SequenceGoal("idle", duration=2.0), SequenceGoal("seek", (2.0, 0.0)))
    fsm = machine({"seek": StateConfig("seek", GoalSelector("sequence", {}),
                                       (Transition(on="arrival", to=("exit",)),), arrive_dist=0.2),
                   "exit": StateConfig("exit", None, final=True)})
    b = BehaviorState.rows(1)
    rng = np.random.default_rng(0)
    fsm.enter(b, 0, "seek", t=0.0, pos=np.zeros(2), rng=rng, sequence=seq)
    assert tuple(b.goal[0]) == (1.0, 0.0)
    at1 = np.array([[1.0, 0.0]])
    d = fsm.decide(b, t=1.0, dt=0.1, pos=at1, rng=rng, sequences=[seq])
    assert not d.leaving[0] and np.isnan(b.goal[0, 0])  # idling
    d = fsm.decide(b, t=2.5, dt=0.1, pos=at1, rng=rng, sequences=[seq])
    assert not d.leaving[0]
    d = fsm.decide(b, t=3.1, dt=0.1, pos=at1, rng=rng, sequences=[seq])
    assert tuple(b.goal[0]) == (2.0, 0.0) and not d.leaving[0]
    d = fsm.decide(b, t=5.0, dt=0.1, pos=np.array([[2.0, 0.0]]), rng=rng, sequences=[seq])
    assert d.leaving[0]


def test_circle_selector_biases_goals_to_the_antipode() -> None:
    """Goals land on the far side, so straight paths cross near the centre."""
    rng = np.random.default_rng(4)
    sel = selectors["circle"]
    params = {"center": [0.0, 0.0], "radius": 6.0, "spread": 0.35}
    miss = []
    for _ in range(2000):
        a = rng.uniform(-math.pi, math.pi)
        p = (6 * math.cos(a), 6 * math.sin(a))
        g = sel(params, GoalContext(rng=rng, pos=p, walkable=OpenPlane(), goal_sets={}))
        assert g is not None
        assert math.isclose(math.hypot(*g), 6.0, rel_tol=1e-9)
        # distance of the straight path p->g from the centre
        d = np.subtract(g, p)
        miss.append(abs(p[0] * d[1] - p[1] * d[0]) / np.linalg.norm(d))
    assert np.median(miss) < 1.2  # uniform goals would give a median near 4.2 m


def test_set_selector_honours_weights_and_avoids_current() -> None:
    gs = GoalSet("g", ((0.0, 0.0), (10.0, 0.0), (0.0, 10.0)), (1.0, 1.0, 2.0))
    rng = np.random.default_rng(5)
    counts = np.zeros(3)
    for _ in range(3000):
        g = selectors["set"]({"set": "g"}, GoalContext(rng=rng, pos=(0.0, 0.0), walkable=OpenPlane(),
                                                       goal_sets={"g": gs}))
        counts[[(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)].index(g)] += 1
    assert counts[0] == 0  # the agent is there already
    assert abs(counts[2] / counts[1] - 2.0) < 0.25


@pytest.mark.parametrize("kind", list(selectors))
def test_every_registered_selector_validates_unknown_params(kind: str) -> None:
    from pedvr.behavior.goals import validate_params

    problems = validate_params(kind, {"bogus": 1})
    assert any(key == "bogus" and "unknown parameter" in why for key, _, why in problems)
