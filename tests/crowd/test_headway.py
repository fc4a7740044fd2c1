"""Issue 26: the coupled preferred speed keeps a time gap to whoever walks ahead in the agent's
lane going its way (pedvr.crowd.headway, after Tordeux et al.'s collision-free speed model)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pedvr.crowd.footprint import depth_of
from pedvr.crowd.steering import Steering, SteeringInputError
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd

PARAMS = dataclasses.replace(SteeringParams(), time_gap=1.0)


def _pref(others: list[tuple[tuple[float, float], tuple[float, float]]], *, coupled: bool = True,
          params: SteeringParams = PARAMS) -> np.ndarray:
    """Agent 0 at the origin wants +x at 1.3 m/s; ``others``: (position, preferred velocity).
    Footprints settled (walking ellipses when coupled). Agent 0's preferred velocity after the
    headway."""
    pos = [(0.0, 0.0)] + [p for p, _ in others]
    pref = [(1.3, 0.0)] + [v for _, v in others]
    state = crowd(pos, pref, pref, heading=[0.0] * len(pos))
    s = Steering(params, ObstacleSet.empty(), coupled=coupled)
    s.compute_velocities(state, 1 / 90)
    for _ in range(60):
        state.turn, state.torso = s.turn_shoulders(state, 1 / 90)
    return s.headway(state, state.pref_vel)[0]


def test_the_preferred_speed_is_the_free_distance_over_the_time_gap() -> None:
    b = depth_of(0.25, Steering(PARAMS, ObstacleSet.empty(), coupled=True).walk_turn)
    out = _pref([((1.0, 0.0), (1.3, 0.0))])  # a leader 1 m ahead going the same way
    np.testing.assert_allclose(out, ((1.0 - 2 * b) / 1.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(_pref([((3.0, 0.0), (1.3, 0.0))]), (1.3, 0.0))  # far: free speed
    np.testing.assert_allclose(_pref([((0.4, 0.1), (1.3, 0.0))]), (0.0, 0.0), atol=0.05)  # at contact: stop


def test_only_those_ahead_in_the_lane_going_the_same_way_count() -> None:
    free = np.array([1.3, 0.0])
    np.testing.assert_allclose(_pref([((1.0, 0.0), (-1.3, 0.0))]), free)  # oncoming: ORCA passes it
    np.testing.assert_allclose(_pref([((1.0, 0.0), (0.0, 0.0))]), free)  # standing aside (a holder)
    np.testing.assert_allclose(_pref([((1.0, 0.0), (0.0, 1.3))]), free)  # crossing
    np.testing.assert_allclose(_pref([((1.0, 0.8), (1.3, 0.0))]), free)  # beside, not in the lane
    np.testing.assert_allclose(_pref([((-1.0, 0.0), (1.3, 0.0))]), free)  # behind


def test_decoupled_and_a_zero_gap_leave_the_preferred_velocity_alone() -> None:
    leader = [((1.0, 0.0), (1.3, 0.0))]
    np.testing.assert_allclose(_pref(leader, coupled=False), (1.3, 0.0))
    np.testing.assert_allclose(_pref(leader, params=dataclasses.replace(PARAMS, time_gap=0.0)), (1.3, 0.0))
    with pytest.raises(SteeringInputError, match=r"time_gap = -1.0: must be >= 0 s"):
        Steering(dataclasses.replace(PARAMS, time_gap=-1.0), ObstacleSet.empty(), coupled=True)


def test_of_two_each_ahead_of_the_other_only_the_one_further_behind_follows() -> None:
    """Ways that converge (two merging into an opening, or stepping off a doorway): each stands
    ahead of the other, in its lane, going its way. Both following, both stood still for good
    (door_single_flow seed 18: two people just through the door for 12 s, the held door and its
    follower waiting behind them). The one further behind the other follows; the other walks on."""
    e1 = np.array([np.cos(np.radians(-75.0)), np.sin(np.radians(-75.0))])
    pos = [(0.0, 0.0), (0.35, 0.42)]
    pref = [(1.3, 0.0), tuple(1.3 * e1)]
    heading = [0.0, float(np.arctan2(e1[1], e1[0]))]
    state = crowd(pos, pref, pref, heading=heading)
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=True)
    s.compute_velocities(state, 1 / 90)
    out = s.headway(state, state.pref_vel)
    d = np.subtract(pos[1], pos[0])
    assert d @ (1.0, 0.0) > -d @ e1 > 0.0  # 1 is further ahead of 0 than 0 is of 1: 0 is behind
    assert np.hypot(*out[0]) < 0.3  # 0 keeps its time gap to 1 (near contact: it all but stops)
    np.testing.assert_allclose(out[1], pref[1])  # 1 is not held back by 0
    swapped = crowd(pos[::-1], pref[::-1], pref[::-1], heading=heading[::-1])  # row order: the same
    s.compute_velocities(swapped, 1 / 90)
    np.testing.assert_allclose(s.headway(swapped, swapped.pref_vel)[::-1], out)
