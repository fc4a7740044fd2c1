"""Issue 26: a coupled walker's footprint is an ellipse along its heading (a shoulder width
across, 2 b front to back), so people in line follow closer than shoulder-width discs; the
decoupled baseline keeps the paper's discs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.crowd.footprint import DEPTH_RATIO, SHOULDER_TWIST_LIMIT, depth_of, shoulder_twist, turn_for
from pedvr.crowd.steering import Steering, SteeringInputError
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd


def _settle(coupled: bool, heading: float, steps: int = 90) -> tuple[float, float, Steering]:
    state = crowd([(0.0, 0.0)], [(math.cos(heading), math.sin(heading))], heading=[heading])
    s = Steering(SteeringParams(), ObstacleSet.empty(), coupled=coupled)
    s.compute_velocities(state, 1 / 90)
    for _ in range(steps):
        state.turn, state.torso = s.turn_shoulders(state, 1 / 90)
    return float(state.turn[0]), float(state.torso[0]), s


def test_a_coupled_walker_is_an_ellipse_along_its_heading() -> None:
    turn, torso, s = _settle(True, 0.7)
    assert turn == pytest.approx(s.walk_turn)
    assert depth_of(0.25, turn) == pytest.approx(0.72 * 0.25)  # the default depth_ratio
    assert abs(math.remainder(torso - 0.7, math.pi)) < 1e-9  # depth along the heading
    turn, _, _ = _settle(False, 0.7)
    assert turn == 0.0  # decoupled: the disc


def test_depth_ratio_is_checked() -> None:
    assert turn_for(1.0) == 0.0 and turn_for(DEPTH_RATIO) == pytest.approx(1.0)
    with pytest.raises(SteeringInputError, match=r"depth_ratio = 0.3: must be in \[0.52, 1\]"):
        Steering(SteeringParams(depth_ratio=0.3), ObstacleSet.empty(), coupled=True)


def _follow(coupled: bool) -> np.ndarray:
    """Two people in line, 0.40 m centre to centre, both walking +x at 1 m/s (their footprints
    settled first): the follower's new velocity."""
    state = crowd([(0.0, 0.0), (0.4, 0.0)], [(1.0, 0.0), (1.0, 0.0)], [(1.0, 0.0), (1.0, 0.0)],
                  heading=[0.0, 0.0])
    s = Steering(SteeringParams(), ObstacleSet.empty(), coupled=coupled)
    s.compute_velocities(state, 1 / 90)
    for _ in range(60):
        state.turn, state.torso = s.turn_shoulders(state, 1 / 90)
    return s.compute_velocities(state, 1 / 90)[0]


def test_people_in_line_follow_closer_than_discs_only_when_coupled() -> None:
    """0.40 m apart is clear of two walking ellipses (2 b = 0.36 m) but inside two discs."""
    np.testing.assert_allclose(_follow(True), (1.0, 0.0), atol=1e-9)  # walks on behind
    assert _follow(False)[0] < 0.5  # discs overlap: the follower is pushed back hard


def _slot_agent(pos: tuple[float, float], pref: tuple[float, float]) -> tuple[float, float]:
    """One coupled agent at ``pos`` wanting ``pref`` by a wall at x 4.5..5.5 with a 0.5 m slot
    at y 4.75..5.25: its turn and torso after a second of turn_shoulders."""
    wall = ObstacleSet.from_polygons([np.array([[4.5, 0.0], [5.5, 0.0], [5.5, 4.75], [4.5, 4.75]]),
                                      np.array([[4.5, 5.25], [5.5, 5.25], [5.5, 10.0], [4.5, 10.0]])])
    state = crowd([pos], [pref], [pref], heading=[math.atan2(pref[1], pref[0])])
    s = Steering(SteeringParams(), wall, coupled=True)
    s.compute_velocities(state, 1 / 90)
    for _ in range(90):
        state.turn, state.torso = s.turn_shoulders(state, 1 / 90)
    return float(state.turn[0]), float(state.torso[0])


def test_a_body_turns_its_shoulders_to_pass_a_gap_narrower_than_them() -> None:
    turn, torso = _slot_agent((4.2, 5.0), (1.0, 0.0))  # 0.3 m before a 0.5 m slot, heading in
    assert turn == pytest.approx(1.0)
    assert abs(math.remainder(torso - math.pi / 2, math.pi)) < 1e-9  # the chest faces the slot's walls
    assert _slot_agent((4.2, 2.0), (1.0, 0.0))[0] < 1.0  # walking at the wall itself: no slot there
    assert _slot_agent((2.0, 5.0), (1.0, 0.0))[0] < 1.0  # far from the slot
    assert _slot_agent((4.2, 7.0), (0.0, 1.0))[0] < 1.0  # along the wall, one wall only


def test_a_body_coming_at_a_slot_askew_lays_its_shoulders_along_the_slot() -> None:
    """The torso faces the slot's wall (its shoulders along the slot), not across the agent's own
    way: coming at the slot diagonally, across its way would leave it askew in the mouth."""
    turn, torso = _slot_agent((4.2, 4.9), (1.0, 0.3))
    assert turn == pytest.approx(1.0)
    assert abs(math.remainder(torso - math.pi / 2, math.pi)) < 1e-6


def test_shoulder_twist_is_the_numpy_expression_bit_for_bit() -> None:
    """The twist the body is drawn with is made in one kernel pass (issue 27); it is the numpy
    expression it replaced, bit for bit, turns beyond [0, 1], whole turns, zeros, NaN and inf
    included."""
    rng = np.random.default_rng(3)
    n = 200_000
    quarter = rng.integers(-6, 6, n // 4) * (math.pi / 2)
    torso = np.concatenate([rng.uniform(-20.0, 20.0, n), quarter + rng.normal(0.0, 1e-15, n // 4),
                            [0.0, -0.0, math.pi, -math.pi, np.nan, np.inf]])
    heading = np.concatenate([rng.uniform(-20.0, 20.0, n), quarter[::-1], [0.0, 0.0, -math.pi, math.pi, 0.0, 0.0]])
    turn = np.concatenate([rng.uniform(-1.0, 3.0, n), rng.uniform(0.0, 1.0, n // 4), [1.0, 1.0, -0.0, 0.0, 1.0, 1.0]])
    with np.errstate(invalid="ignore"):
        delta = (torso - heading + np.pi) % (2.0 * np.pi) - np.pi
    delta = np.where(delta > 0.5 * np.pi, delta - np.pi, np.where(delta < -0.5 * np.pi, delta + np.pi, delta))
    want = np.clip(turn * delta, -SHOULDER_TWIST_LIMIT, SHOULDER_TWIST_LIMIT)
    np.testing.assert_array_equal(shoulder_twist(turn, torso, heading).view(np.int64), want.view(np.int64))
