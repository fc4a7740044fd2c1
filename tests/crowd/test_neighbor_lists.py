"""ORCA's neighbour lists stay exact when found faster (issue 27): a sparse crowd's grid grows its
cells, equal distances go by row whatever the search met first, and Verlet candidate lists give
the whole search's lists for as long as nobody moved a quarter of the skin."""

from __future__ import annotations

import numpy as np

from pedvr.crowd import neighbors as nb
from pedvr.crowd.steering import Steering
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd, spread_points

K = 10


def _brute(pos: np.ndarray, neighbor_dist: float, k: int) -> list[list[int]]:
    """The lists by definition: the k nearest others strictly in range, equal distances by row."""
    d2 = ((pos[:, None, :] - pos[None, :, :]) ** 2).sum(axis=2)
    np.fill_diagonal(d2, np.inf)
    out = []
    for i in range(pos.shape[0]):
        order = np.argsort(d2[i], kind="stable")
        out.append([int(j) for j in order[:k] if d2[i, j] < neighbor_dist ** 2])
    return out


def _grid_lists(pos: np.ndarray, neighbor_dist: float, cell: float, per_item: float,
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, nb.AgentGrid]:
    g = nb.build_agent_grid(pos, cell, per_item=per_item)
    n = pos.shape[0]
    idx, dsq, cnt = np.empty((n, K), np.int64), np.empty((n, K)), np.empty(n, np.int64)
    nb.agent_neighbors_kernel(pos, neighbor_dist, K, g.origin, g.cell, g.shape[0], g.shape[1], g.cell_start,
                              g.order, g.sorted_pos, idx, dsq, cnt, nb.NO_LISTS, nb.NO_COUNTS)
    return idx, dsq, cnt, g


def _as_lists(idx: np.ndarray, cnt: np.ndarray) -> list[list[int]]:
    return [idx[i, :cnt[i]].tolist() for i in range(cnt.shape[0])]


def _crowd_with_ties(rng: np.random.Generator) -> np.ndarray:
    pos = rng.uniform(0.0, 20.0, (500, 2))
    pos[:120] = rng.uniform(8.0, 10.0, (120, 2))  # a dense knot
    lattice = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2) * 0.5 + 25.0
    pos[200:236] = lattice[::-1]  # exact ties, rows in the reverse of the lattice's order
    return pos


def test_sparse_crowd_grid_grows_cells_and_lists_stay_exact() -> None:
    """At 0.2 agents per m² (the bench plaza) the grid has about two agents a cell, not a third of
    the neighbour distance; the lists are still the brute-force ones."""
    rng = np.random.default_rng(27)
    n = 1000
    pos = rng.uniform(0.0, np.sqrt(n / 0.2), (n, 2))
    g = nb.build_agent_grid(pos, nb.default_cell_size(5.0), per_item=nb.NEIGHBOR_CELLS_PER_AGENT)
    assert g.cell > 2.0 * nb.default_cell_size(5.0)
    assert g.shape[0] * g.shape[1] <= nb.NEIGHBOR_CELLS_PER_AGENT * n + 16
    idx, cnt = nb.agent_neighbors(pos, neighbor_dist=5.0, max_neighbors=K)
    assert _as_lists(idx, cnt) == _brute(pos, 5.0, K)


def test_equal_distances_go_by_row_whatever_the_grid() -> None:
    """A lattice's neighbours are at equal distances: every cell size gives the same lists, in row
    order among equals, the definition's."""
    pos = _crowd_with_ties(np.random.default_rng(3))
    want = _brute(pos, 3.0, K)
    for cell, per_item in ((1.0, 4.0), (0.37, 4.0), (1.0, 0.5), (3.0, 0.2)):
        idx, _, cnt, _ = _grid_lists(pos, 3.0, cell, per_item)
        assert _as_lists(idx, cnt) == want, (cell, per_item)


def test_candidate_lists_give_the_whole_search_lists_until_a_quarter_skin() -> None:
    """Verlet lists: after every row moves up to just under a quarter of the skin (dense knot,
    ties, sparse rows), the lists found among the candidates are the whole search's; a move of a
    quarter of the skin makes the candidates stale (the caller searches afresh)."""
    rng = np.random.default_rng(5)
    pos = _crowd_with_ties(rng)
    n = pos.shape[0]
    skin = nb.VERLET_SKIN
    idx, _, cnt, g = _grid_lists(pos, 3.0, 1.0, 4.0)
    cidx, ccnt = np.empty((n, 200), np.int64), np.empty(n, np.int64)
    # the last lists (here: of these positions) bound how far the candidates reach
    nb.verlet_candidates_kernel(pos, 3.0, K, skin, idx, cnt, g.origin, g.cell, g.shape[0], g.shape[1],
                                g.cell_start, g.order, g.sorted_pos, cidx, ccnt)
    assert ccnt.max() <= 200
    for trial in range(4):
        ang = rng.uniform(-np.pi, np.pi, n)
        step = 0.2499 * skin * (rng.uniform(0.0, 1.0, n) if trial else np.ones(n))
        moved = pos + step[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        if trial == 3:  # the lattice keeps its ties: it moves as one
            moved[200:236] = pos[200:236] + 0.2499 * skin / np.sqrt(2.0)
        assert nb.candidates_hold(moved, pos, skin)
        got_idx, got_dsq, got_cnt = np.empty((n, K), np.int64), np.empty((n, K)), np.empty(n, np.int64)
        nb.verlet_neighbors_kernel(moved, 3.0, K, cidx, ccnt, got_idx, got_dsq, got_cnt)
        assert _as_lists(got_idx, got_cnt) == _brute(moved, 3.0, K)
    far = pos.copy()
    far[7, 0] += 0.25 * skin
    assert not nb.candidates_hold(far, pos, skin)
    assert not nb.candidates_hold(pos[:-1], pos, skin)  # rows came or went


def _walk(*, fresh: bool) -> bytes:
    """A crowd walking to goals for 60 steps; ``fresh``: the neighbour lists searched afresh every
    step (no candidates, no last lists)."""
    rng = np.random.default_rng(8)
    n = 300
    state = crowd(spread_points(rng, n, 14.0, 0.5), heading=rng.uniform(-3, 3, n))
    state.is_user[0] = True
    goals = rng.uniform(0.0, 14.0, (n, 2))
    params = SteeringParams(neighbor_dist=5.0, max_neighbors=K, time_horizon=2.0, time_horizon_obst=1.0)
    s = Steering(params, ObstacleSet.from_polygons([]), coupled=True)
    reused = 0
    for _ in range(60):
        if fresh:
            s.forget_neighbors()
        reused += s._candidates is not None and nb.candidates_hold(s.footprints(state).centre,
                                                                   s._candidates[0], nb.VERLET_SKIN)
        d = goals - state.pos
        state.pref_vel = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9) * 1.3
        v = s.compute_velocities(state, 1.0 / 90.0)
        state.vel = v.copy()
        state.pos = s.resolve_contacts(state.pos + v / 90.0, state.radius, state.is_user)
        state.heading = np.arctan2(v[:, 1], v[:, 0])
    assert reused > 40 if not fresh else reused == 0  # the candidates served most steps
    return state.pos.tobytes() + state.vel.tobytes()


def test_steering_with_candidate_lists_is_byte_identical_to_searching_every_step() -> None:
    assert _walk(fresh=False) == _walk(fresh=True)
