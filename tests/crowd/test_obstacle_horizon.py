"""Issue 26: coupled agents see walls ``[steering] time_horizon_obst_coupled`` (0.5 s) ahead, but
``time_horizon_obst`` (1 s, RVO2's and the paper's) near the user and door leaves, in a door's
etiquette, and in ``decoupled`` (pedvr.crowd.orca.obstacle_horizon)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pedvr.crowd import orca
from pedvr.crowd.steering import Steering, SteeringInputError
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd

DT = 1 / 90
WALL = [(0.9, -1.0), (1.5, -1.0), (1.5, 1.0), (0.9, 1.0)]  # its near face 0.65 m ahead of the agent's disc
LONG = dataclasses.replace(SteeringParams(), time_horizon_obst_coupled=SteeringParams().time_horizon_obst)


def _wall_line(params: SteeringParams, *, user: bool, coupled: bool = True) -> np.ndarray:
    """Agent 0 at the origin walks +x at 1 m/s toward a wall; with ``user``, the user stands 1 m
    behind it, among its neighbours. The first obstacle line of agent 0."""
    pos = [(0.0, 0.0)] + ([(-1.0, 0.0)] if user else [])
    n = len(pos)
    state = crowd(pos, [(1.0, 0.0)] + [(0.0, 0.0)] * (n - 1), [(1.3, 0.0)] + [(0.0, 0.0)] * (n - 1),
                  is_user=[False] + [True] * (n - 1))
    s = Steering(params, ObstacleSet.from_polygons([WALL]), coupled=coupled)
    return s.orca_lines(state, DT, 0)[0]


def test_walls_are_seen_half_a_second_ahead_away_from_the_user() -> None:
    short = SteeringParams()
    assert short.time_horizon_obst_coupled == 0.5 and short.time_horizon_obst == 1.0
    alone, alone_long = _wall_line(short, user=False), _wall_line(LONG, user=False)
    # the wall's line lets the agent walk at it up to its distance over the horizon: twice as fast
    # at 0.5 s as at 1 s (the line's point lies on the agent's way, at distance / horizon)
    assert alone[0] > 1.9 * alone_long[0] > 0.5, (alone, alone_long)
    # with the user among its neighbours, the paper's horizon: the very same line as with 1 s
    np.testing.assert_array_equal(_wall_line(short, user=True), _wall_line(LONG, user=True))
    # decoupled is the paper's plain ORCA: 1 s whatever time_horizon_obst_coupled says
    np.testing.assert_array_equal(_wall_line(short, user=False, coupled=False),
                                  _wall_line(LONG, user=False, coupled=False))


def test_the_long_horizon_near_a_door_leaf_or_the_user() -> None:
    """The rule itself: a door leaf (an obstacle edge of a moving segment, vertex >= n_static) or
    the user among the neighbours gives ``time_horizon_obst``; otherwise the short one, never
    longer than ``time_horizon_obst``."""
    is_user = np.array([False, False, True])
    nbrs = np.array([[1, 2], [0, 2], [0, 1]], np.int64)
    edges = np.array([3, 9], np.int64)  # vertices 0-7 static, 8 on: door leaves
    def h(count: int, n_obst: int, short: float) -> float:
        near = orca.near_user_or_leaf(0, is_user, nbrs, np.array([count, 1, 1]), edges, n_obst, 8)
        return orca.obstacle_horizon(near, 1.0, short)

    assert h(1, 1, 0.5) == 0.5  # a wall, a walker
    assert h(2, 1, 0.5) == 1.0  # the user near
    assert h(1, 2, 0.5) == 1.0  # a door leaf near
    assert h(1, 1, 2.0) == 1.0  # never longer


def test_a_horizon_that_is_not_positive_is_named() -> None:
    """Parameters made in code (not through a scene file, whose loader checks them) are checked
    by the steering itself, with every horizon named."""
    bad = dataclasses.replace(SteeringParams(), time_horizon_obst_coupled=0.0)
    with pytest.raises(SteeringInputError, match=r"time_horizon_obst_coupled = 0\.0: all must be > 0"):
        Steering(bad, ObstacleSet.empty(), coupled=True)
