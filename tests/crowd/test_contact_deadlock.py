"""Contact pass, deadlock remedy, neighbour search and determinism."""

from __future__ import annotations

import contextlib

import numba
import numpy as np
import pytest

from pedvr.crowd.contact import max_obstacle_penetration, overlapping_pairs
from pedvr.crowd.neighbors import agent_neighbors
from pedvr.crowd.steering import Steering
from pedvr.kernels import forcing
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd, spread_points

PARAMS = SteeringParams(neighbor_dist=5.0, max_neighbors=10, time_horizon=2.0,
                        time_horizon_obst=1.0)
BOX = np.array([(4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0)])  # counter-clockwise
BOUNDARY = np.array([(0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0)])  # clockwise


def _jam(seed: int, n: int = 260):
    rng = np.random.default_rng(seed)
    pts = []
    while len(pts) < n:
        q = rng.uniform(0.3, 9.7, 2)
        if not (3.9 < q[0] < 6.1 and 3.9 < q[1] < 6.1):
            pts.append(q)
    pos = np.array(pts)
    radius = rng.uniform(0.22, 0.28, n)
    is_user = np.zeros(n, np.bool_)
    is_user[0] = True
    return pos, radius, is_user


def test_contact_pass_clears_a_dense_jam_and_never_moves_the_user() -> None:
    pos, radius, is_user = _jam(1)
    obstacles = ObstacleSet.from_polygons([BOX, BOUNDARY])
    s = Steering(PARAMS, obstacles, coupled=False)
    assert overlapping_pairs(pos, radius, 0.01).shape[0] > 50  # really jammed
    out = s.resolve_contacts(pos, radius, is_user)
    assert overlapping_pairs(out, radius, 0.01).shape[0] == 0
    assert max_obstacle_penetration(out, radius, s._verts, s._next, s._prev) <= 0.01
    assert out[0].tolist() == pos[0].tolist()
    assert np.all(np.isfinite(out))


def test_contact_pass_leaves_a_clear_crowd_alone() -> None:
    rng = np.random.default_rng(2)
    pos = spread_points(rng, 100, 20.0, 0.6)
    out = Steering(PARAMS, ObstacleSet.empty(), coupled=False).resolve_contacts(
        pos, np.full(100, 0.25), np.zeros(100, np.bool_))
    np.testing.assert_array_equal(out, pos)


def test_agent_takes_the_whole_correction_against_the_user() -> None:
    pos = np.array([(0.0, 0.0), (0.4, 0.0)])
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=False)
    out = s.resolve_contacts(pos, np.full(2, 0.25), np.array([True, False]))
    assert out[0].tolist() == [0.0, 0.0]
    assert out[1, 0] >= 0.5 - 0.005 and out[1, 1] == 0.0


def test_two_agents_head_on_in_a_1m_corridor_both_pass() -> None:
    # Plain ORCA already resolves this one (its right-leg tie break); the test
    # guards that the unstick nudge and the motion limits do not break it.
    walls = ObstacleSet.from_polygons([[(-8.0, 0.5), (8.0, 0.5)], [(8.0, -0.5), (-8.0, -0.5)]])
    for coupled in (False, True):
        state = crowd([(-3.0, 0.0), (3.0, 0.0)], radius=0.2, max_speed=1.6,
                      heading=[0.0, np.pi])
        goals = np.array([(6.0, 0.0), (-6.0, 0.0)])
        s = Steering(PARAMS, walls, coupled=coupled)
        assert _walk(s, state, goals, steps=400, dt=0.05)


def _walk(s: Steering, state, goals, *, steps: int, dt: float, unstick: bool = True) -> bool:
    stuck = np.zeros(len(state))
    for _ in range(steps):
        d = goals - state.pos
        dist = np.linalg.norm(d, axis=1, keepdims=True)
        pref = d / np.maximum(dist, 1e-9) * np.minimum(1.3, dist)
        state.pref_vel = s.unstick(state.vel, pref, state.is_user, stuck, dt) if unstick else pref
        v = s.compute_velocities(state, dt)
        state.vel = v.copy()
        state.pos = s.resolve_contacts(state.pos + v * dt, state.radius, state.is_user)
        moving = np.linalg.norm(v, axis=1) > 0.05
        state.heading[moving] = np.arctan2(v[moving, 1], v[moving, 0])
    return bool(np.all(np.linalg.norm(goals - state.pos, axis=1) < 0.1))


@pytest.mark.parametrize("coupled", [False, True])
def test_unstick_frees_an_agent_stuck_square_on_to_a_box(coupled: bool) -> None:
    # Preferred velocity straight into the middle of a box: ORCA's answer is
    # exactly zero forever. Turning right slides it round the corner.
    box = ObstacleSet.from_polygons([[(0.0, -0.6), (0.4, -0.6), (0.4, 0.6), (0.0, 0.6)]])
    goals = np.array([(3.0, 0.0)])
    s = Steering(PARAMS, box, coupled=coupled)
    assert not _walk(s, crowd([(-3.0, 0.0)], max_speed=1.6), goals, steps=300, dt=0.05,
                     unstick=False)
    assert _walk(s, crowd([(-3.0, 0.0)], max_speed=1.6), goals, steps=300, dt=0.05)


def test_unstick_turns_right_only_after_patience_and_never_the_user() -> None:
    s = Steering(PARAMS, ObstacleSet.empty(), coupled=False)
    vel = np.zeros((3, 2))
    pref = np.array([(1.0, 0.0), (1.0, 0.0), (0.0, 0.0)])
    is_user = np.array([False, True, False])
    stuck = np.zeros(3)
    out = s.unstick(vel, pref, is_user, stuck, 1.0)
    np.testing.assert_array_equal(out, pref)  # 1 s < patience
    out = s.unstick(vel, pref, is_user, stuck, 1.0)
    assert out[0, 1] < 0.0 and abs(np.linalg.norm(out[0]) - 1.0) < 1e-12  # turned right
    np.testing.assert_array_equal(out[1:], pref[1:])
    assert stuck[1] == 0.0 and stuck[2] == 0.0
    # Moving again: the wait decays.
    s.unstick(pref.copy(), pref, is_user, stuck, 1.0)
    assert 0.0 < stuck[0] < 2.0


def test_grid_neighbours_equal_brute_force() -> None:
    rng = np.random.default_rng(9)
    pos = rng.uniform(0.0, 30.0, (400, 2))
    pos[:50] = rng.uniform(10.0, 12.0, (50, 2))  # a dense knot
    idx, cnt = agent_neighbors(pos, neighbor_dist=3.0, max_neighbors=7)
    d2 = ((pos[:, None, :] - pos[None, :, :]) ** 2).sum(axis=2)
    np.fill_diagonal(d2, np.inf)
    for i in range(pos.shape[0]):
        order = np.argsort(d2[i], kind="stable")
        want = [j for j in order[:7] if d2[i, j] < 9.0]
        assert idx[i, :cnt[i]].tolist() == want


def test_last_lists_bound_the_search_and_change_nothing() -> None:
    """Steering starts each row's neighbour search no wider than its last neighbours now are: the
    lists come out exactly as from a full-range search, after the crowd moved, after rows were
    shuffled (the last lists then name other agents: still a bound), and with exact ties."""
    from pedvr.crowd import neighbors as nb

    rng = np.random.default_rng(11)
    pos = rng.uniform(0.0, 20.0, (500, 2))
    pos[:120] = rng.uniform(8.0, 10.0, (120, 2))  # a dense knot
    pos[120:136] = np.stack(np.meshgrid(np.arange(4.0), np.arange(4.0)), -1).reshape(-1, 2) * 0.5 + 25.0  # ties
    k = 10

    def search(p: np.ndarray, prev: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        g = nb.build_agent_grid(p, nb.default_cell_size(3.0))
        idx = np.empty((len(p), k), np.int64)
        dsq = np.empty((len(p), k))
        cnt = np.empty(len(p), np.int64)
        pi, pc = prev if prev is not None else (nb.NO_LISTS, nb.NO_COUNTS)
        nb.agent_neighbors_kernel(p, 3.0, k, g.origin, g.cell, g.shape[0], g.shape[1], g.cell_start, g.order,
                                  g.sorted_pos, idx, dsq, cnt, pi, pc)
        return idx, cnt

    last = search(pos, None)
    for moved in (pos + rng.uniform(-0.3, 0.3, pos.shape), pos[rng.permutation(len(pos))], pos.copy()):
        want_idx, want_cnt = search(moved, None)
        got_idx, got_cnt = search(moved, last)
        np.testing.assert_array_equal(got_cnt, want_cnt)
        for i in range(len(moved)):
            assert got_idx[i, :got_cnt[i]].tolist() == want_idx[i, :want_cnt[i]].tolist()
    assert (last[1] == k).sum() > 300  # most lists were full: the bound was used


def _run(threads: int, coupled: bool) -> bytes:
    """With more than one thread every kernel is pinned to its parallel twin (200 agents fit the
    serial budget, pedvr.kernels.SERIAL_BUDGET_S, and left alone would run on one thread)."""
    prev = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        with forcing(True) if threads > 1 else contextlib.nullcontext():
            return _steps(coupled)
    finally:
        numba.set_num_threads(prev)


def _steps(coupled: bool) -> bytes:
    rng = np.random.default_rng(4)
    n = 200
    state = crowd(spread_points(rng, n, 12.0, 0.5), heading=rng.uniform(-3, 3, n))
    state.is_user[0] = True
    state.responsibility[:] = 0.8
    goals = rng.uniform(0.0, 12.0, (n, 2))
    s = Steering(PARAMS, ObstacleSet.from_polygons([BOX]), coupled=coupled)
    stuck = np.zeros(n)
    for _ in range(30):
        d = goals - state.pos
        pref = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9) * 1.3
        state.pref_vel = s.unstick(state.vel, pref, state.is_user, stuck, 0.1)
        v = s.compute_velocities(state, 0.1)
        state.vel = v.copy()
        state.pos = s.resolve_contacts(state.pos + v * 0.1, state.radius, state.is_user)
    return state.pos.tobytes() + state.vel.tobytes() + stuck.tobytes()


@pytest.mark.parametrize("coupled", [False, True])
def test_same_inputs_same_bytes_with_any_thread_count(coupled: bool) -> None:
    one = _run(1, coupled)
    assert one == _run(1, coupled)
    assert one == _run(numba.config.NUMBA_NUM_THREADS, coupled)
