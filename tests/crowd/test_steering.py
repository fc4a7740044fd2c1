"""Responsibility toward the user, motion limits (coupled mode), façade contracts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.crowd.orca import (
    SIDEWAYS_SLOPE,
    STATUS_DROPPED_HEADING,
    STATUS_DROPPED_MOTION,
    STATUS_SOFT_OBSTACLES,
    STOPPED_SPEED,
)
from pedvr.crowd.state import (
    LIMIT_ACCEL,
    LIMIT_BACKWARD,
    LIMIT_DECEL,
    LIMIT_SIDEWAYS,
)
from pedvr.crowd.steering import Steering, SteeringInputError
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd, spread_points

PARAMS = SteeringParams(neighbor_dist=5.0, max_neighbors=10, time_horizon=2.0,
                        time_horizon_obst=1.0)


def _head_on(rho: float, *, agent_vel=(1.0, 0.0)) -> tuple[Steering, object]:
    # Agent 0 walks +x, the user (row 1) walks -x toward it, slightly offset.
    state = crowd([(0.0, 0.0), (4.0, 0.1)], [agent_vel, (-1.0, 0.0)],
                  [agent_vel, (-1.0, 0.0)], responsibility=rho, is_user=[False, True])
    return Steering(PARAMS, ObstacleSet.empty(), coupled=False), state


def test_user_velocity_is_never_changed() -> None:
    steering, state = _head_on(1.0)
    out = steering.compute_velocities(state, 0.1)
    assert out[1].tolist() == state.vel[1].tolist()


def test_orca_toward_the_user_is_only_the_late_safety_step() -> None:
    """ρ is taken over the encounter, in the preferred velocity (pedvr.crowd.encounter);
    ORCA's own line toward the user is the safety step: share 1 whatever ρ, with the short
    user horizon (1 s), and none at all when the scene switches the safety off."""
    outs = []
    for rho in (0.0, 0.5, 1.0):
        steering, state = _head_on(rho)
        outs.append(steering.compute_velocities(state, 0.1))
    assert all(np.array_equal(o, outs[0]) for o in outs)
    # 4 m apart closing at 2 m/s: contact in 1.75 s, beyond the 1 s horizon: no deflection.
    np.testing.assert_array_equal(outs[0][0], [1.0, 0.0])
    # 2 m apart: contact in 0.75 s: the agent deflects.
    steering, state = _head_on(0.0)
    state.pos[1] = (2.0, 0.1)
    near = steering.compute_velocities(state, 0.1)[0]
    assert abs(near[1]) > 0.05
    off = Steering(SteeringParams(neighbor_dist=5.0, max_neighbors=10, time_horizon=2.0,
                                  time_horizon_obst=1.0, user_safety=False),
                   ObstacleSet.empty(), coupled=False)
    np.testing.assert_array_equal(off.compute_velocities(state, 0.1)[0], [1.0, 0.0])


def test_rho_zero_agent_keeps_its_preferred_velocity() -> None:
    steering, state = _head_on(0.0)
    out = steering.compute_velocities(state, 0.1)
    np.testing.assert_array_equal(out[0], state.pref_vel[0])


def test_between_virtual_agents_responsibility_does_not_apply() -> None:
    a = crowd([(0.0, 0.0), (4.0, 0.1)], [(1.0, 0.0), (-1.0, 0.0)], [(1.0, 0.0), (-1.0, 0.0)],
              responsibility=1.0)
    b = a.copy()
    b.responsibility[:] = 0.0
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=False)
    np.testing.assert_array_equal(s.compute_velocities(a, 0.1), s.compute_velocities(b, 0.1))


def test_rho_one_agent_avoids_a_user_walking_straight() -> None:
    steering, state = _head_on(1.0)
    dt = 0.05
    closest = np.inf
    for _ in range(200):
        v = steering.compute_velocities(state, dt)
        assert v[1].tolist() == [-1.0, 0.0]
        state.vel = v.copy()
        state.pos = state.pos + v * dt
        closest = min(closest, float(np.linalg.norm(state.pos[0] - state.pos[1])))
    assert closest >= 0.5 - 1e-3
    # The user went straight: it never deviated from y = 0.1.
    assert state.pos[1, 1] == pytest.approx(0.1)


def _turn_heading(heading: np.ndarray, vel: np.ndarray, state, dt: float) -> None:
    """A body-like heading update: turn toward the velocity at the speed's turn rate."""
    speed = np.linalg.norm(vel, axis=1)
    for i in range(len(heading)):
        if speed[i] < STOPPED_SPEED:
            continue
        target = math.atan2(vel[i, 1], vel[i, 0])
        diff = (target - heading[i] + math.pi) % (2 * math.pi) - math.pi
        frac = min(speed[i] / state.pref_speed[i], 1.0)
        lim = state.limits[i]
        omega = lim[2] + (lim[3] - lim[2]) * frac
        heading[i] += float(np.clip(diff, -omega * dt, omega * dt))


def test_coupled_motion_limits_hold_over_a_random_run() -> None:
    rng = np.random.default_rng(5)
    n = 30
    state = crowd(spread_points(rng, n, 10.0, 0.6), radius=0.25, max_speed=1.6,
                  heading=rng.uniform(-math.pi, math.pi, n))
    goals = rng.uniform(0.0, 10.0, (n, 2))
    steering = Steering(PARAMS, ObstacleSet.empty(), coupled=True)
    dt = 1.0 / 30.0
    lim = state.limits[0]
    k = min(SIDEWAYS_SLOPE, lim[LIMIT_SIDEWAYS] / lim[LIMIT_BACKWARD])
    worst_side = 0.0
    for step in range(300):
        if step % 60 == 0:
            goals = rng.uniform(0.0, 10.0, (n, 2))
        d = goals - state.pos
        dist = np.linalg.norm(d, axis=1, keepdims=True)
        state.pref_vel = d / np.maximum(dist, 1e-9) * np.minimum(1.3, dist)
        v = steering.compute_velocities(state, dt)
        assert not np.any(steering.last_status & (STATUS_DROPPED_HEADING | STATUS_DROPPED_MOTION))
        old = state.vel
        speed = np.linalg.norm(old, axis=1)
        f = np.where(speed[:, None] >= STOPPED_SPEED, old / np.maximum(speed, 1e-12)[:, None],
                     np.stack([np.cos(state.heading), np.sin(state.heading)], axis=1))
        dv = v - old
        along = (dv * f).sum(axis=1)
        assert np.all(along <= lim[LIMIT_ACCEL] * dt + 1e-9)
        assert np.all(-along <= lim[LIMIT_DECEL] * dt + 1e-9)
        assert np.all(np.linalg.norm(dv, axis=1) <= max(lim[LIMIT_ACCEL], lim[LIMIT_DECEL]) * dt
                      + 1e-9)
        h = np.stack([np.cos(state.heading), np.sin(state.heading)], axis=1)
        hp = np.stack([-h[:, 1], h[:, 0]], axis=1)
        fwd = (v * h).sum(axis=1)
        side = np.abs((v * hp).sum(axis=1))
        assert np.all(fwd >= -lim[LIMIT_BACKWARD] - 1e-9)
        assert np.all(side <= lim[LIMIT_SIDEWAYS] + k * fwd + 1e-9)
        worst_side = max(worst_side, float(side.max()))
        state.vel = v.copy()
        state.pos = state.pos + v * dt
        _turn_heading(state.heading, v, state, dt)
    assert np.mean(np.linalg.norm(state.vel, axis=1)) > 0.3  # they did walk


def test_decoupled_mode_ignores_the_limits() -> None:
    # Same start: a standing agent told to walk sideways at 1.3 m/s.
    state = crowd([(0.0, 0.0)], [(0.0, 0.0)], [(0.0, 1.3)], heading=[0.0])
    loose = Steering(PARAMS, ObstacleSet.empty(), coupled=False).compute_velocities(state, 0.1)
    tight = Steering(PARAMS, ObstacleSet.empty(), coupled=True).compute_velocities(state, 0.1)
    np.testing.assert_allclose(loose[0], (0.0, 1.3))
    assert np.linalg.norm(tight[0]) <= state.limits[0, LIMIT_ACCEL] * 0.1 + 1e-9


def test_infeasible_hard_prefix_drops_heading_limits_first() -> None:
    # Walking at 1.3 m/s straight "backwards" relative to a heading that jumped:
    # (c) excludes the current velocity's whole accel polygon.
    state = crowd([(0.0, 0.0)], [(1.3, 0.0)], [(1.3, 0.0)], heading=[math.pi])
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=True)
    out = s.compute_velocities(state, 0.1)
    assert s.last_status[0] & STATUS_DROPPED_HEADING
    assert not s.last_status[0] & STATUS_DROPPED_MOTION
    assert np.linalg.norm(out[0] - state.vel[0]) <= state.limits[0, LIMIT_DECEL] * 0.1 + 1e-9


def test_a_body_pushed_at_a_wall_brakes_within_its_limits() -> None:
    """A body moving at a wall faster than it can brake before ORCA's obstacle horizon (a
    contact push can do that since its velocity is its actual motion): the obstacle lines go
    soft and it brakes as hard as its limits allow, instead of dropping every limit and
    jumping to a velocity plain ORCA likes (which RVO2 would)."""
    wall = ObstacleSet.from_polygons([np.array([[-5.0, 0.6], [5.0, 0.6], [5.0, 1.0], [-5.0, 1.0]])])
    state = crowd([(0.0, 0.0)], [(0.0, 1.0)], [(0.0, 1.3)], heading=[math.pi / 2])
    s = Steering(PARAMS, wall, coupled=True)
    dt = 1.0 / 90.0
    out = s.compute_velocities(state, dt)
    assert s.last_status[0] & STATUS_SOFT_OBSTACLES
    assert not s.last_status[0] & STATUS_DROPPED_MOTION
    assert np.linalg.norm(out[0] - state.vel[0]) <= state.limits[0, LIMIT_DECEL] * dt + 1e-9
    assert out[0, 1] < state.vel[0, 1] - 0.9 * state.limits[0, LIMIT_DECEL] * dt  # it brakes, hard
    plain = Steering(PARAMS, wall, coupled=False).compute_velocities(state, dt)
    assert plain[0, 1] < 0.4  # what the limits keep it from doing at once


def test_wrong_shapes_are_named() -> None:
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=False)
    state = crowd([(0.0, 0.0), (1.0, 0.0)])
    state.vel = np.zeros((3, 2))
    with pytest.raises(SteeringInputError, match=r"CrowdState\.vel has shape \(3, 2\)"):
        s.compute_velocities(state, 0.1)
    state = crowd([(0.0, 0.0)])
    state.radius = np.zeros(1)
    with pytest.raises(SteeringInputError, match="radius min = 0.0: every radius must be > 0"):
        s.compute_velocities(state, 0.1)
    with pytest.raises(SteeringInputError, match="dt = 0: must be > 0"):
        s.compute_velocities(crowd([(0.0, 0.0)]), 0)
    with pytest.raises(SteeringInputError, match="neighbor_dist = -1.0"):
        Steering(SteeringParams(neighbor_dist=-1.0), ObstacleSet.empty(), coupled=False)
    state = crowd([(0.0, 0.0), (1.0, 0.0)])
    state.heading = np.array([0.0, np.nan])
    with pytest.raises(SteeringInputError, match=r"CrowdState\.heading\[1\] = nan: must be finite"):
        s.compute_velocities(state, 0.1)


def test_compute_never_mutates_the_state() -> None:
    rng = np.random.default_rng(3)
    state = crowd(spread_points(rng, 40, 8.0, 0.6), rng.uniform(-1, 1, (40, 2)),
                  rng.uniform(-1, 1, (40, 2)))
    before = state.copy()
    Steering(PARAMS, ObstacleSet.empty(), coupled=True).compute_velocities(state, 0.1)
    for name in ("pos", "vel", "pref_vel", "heading", "radius", "limits"):
        np.testing.assert_array_equal(getattr(state, name), getattr(before, name))


def test_moving_segments_are_obstacles_for_orca_and_contacts() -> None:
    """A segment set between steps (a door leaf) stops an agent walking at it, like a wall."""
    import numpy as np

    from pedvr.crowd.state import CrowdState
    from pedvr.crowd.steering import Steering
    from pedvr.scene.config import SteeringParams
    from pedvr.world.obstacles import ObstacleSet

    def agent_at(x: float) -> CrowdState:
        return CrowdState(ids=np.array([0]), pos=np.array([[x, 0.0]]), vel=np.array([[1.3, 0.0]]),
                          pref_vel=np.array([[1.3, 0.0]]), heading=np.zeros(1), pref_heading=np.zeros(1),
                          radius=np.array([0.25]), pref_speed=np.array([1.3]), max_speed=np.array([1.6]),
                          responsibility=np.array([0.5]), is_user=np.zeros(1, bool), limits=np.zeros((1, 6)))

    s = Steering(SteeringParams(), ObstacleSet.empty(), coupled=False)
    state = agent_at(0.0)
    free = s.compute_velocities(state, 0.05)
    np.testing.assert_allclose(free, [[1.3, 0.0]])  # nothing in the way yet
    s.set_moving_segments(np.array([[0.6, -1.0]]), np.array([[0.6, 1.0]]))  # a leaf across its path
    for _ in range(60):  # walk 3 s at it
        v = s.compute_velocities(state, 0.05)
        state.pos = state.pos + v * 0.05
        state.vel = v
    assert state.pos[0, 0] <= 0.6 - 0.25 + 1e-3  # stopped at the leaf, not through it
    pushed = s.resolve_contacts(np.array([[0.5, 0.0]]), np.array([0.25]), np.zeros(1, bool))
    assert pushed[0, 0] <= 0.35 + 1e-3  # the contact pass keeps discs off it too
    s.set_moving_segments(np.zeros((0, 2)), np.zeros((0, 2)))  # the leaf swung away
    np.testing.assert_allclose(s.compute_velocities(agent_at(0.0), 0.05), [[1.3, 0.0]])


def test_every_checked_value_is_named_when_bad() -> None:
    """The per-step check's fast path (one kernel) lets nothing through that the messages name."""
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=False)
    for name, bad, message in (
        ("pos", np.array([[0.0, 0.0], [np.inf, 0.0]]), r"CrowdState\.pos\[1\] = \[inf  0\.\]: must be finite"),
        ("vel", np.array([[0.0, np.nan], [0.0, 0.0]]), r"CrowdState\.vel\[0\] = \[ 0\. nan\]: must be finite"),
        ("pref_vel", np.array([[0.0, 0.0], [0.0, -np.inf]]), r"CrowdState\.pref_vel\[1\].*must be finite"),
        ("radius", np.array([0.25, -0.1]), "radius min = -0.1: every radius must be > 0"),
        ("responsibility", np.array([0.5, 1.5]), r"responsibility outside \[0, 1\]: min 0\.5, max 1\.5"),
        ("responsibility", np.array([np.nan, 1.0]), r"responsibility outside \[0, 1\]"),
        ("pos", [[0.0, 0.0], [1.0, 0.0]], "CrowdState.pos: expected a numpy array, got list"),
        ("is_user", np.zeros(2, np.int64), r"CrowdState\.is_user has shape \(2,\) dtype int64: must be 2 bool"),
    ):
        state = crowd([(0.0, 0.0), (1.0, 0.0)])
        setattr(state, name, bad)
        with pytest.raises(SteeringInputError, match=message):
            s.compute_velocities(state, 0.1)
