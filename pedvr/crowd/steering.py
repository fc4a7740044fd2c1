"""The typed façade over the steering kernels: ORCA, contacts, unsticking.

:class:`Steering` validates arrays, owns reusable scratch and the static
obstacle grid, and calls the numba kernels in :mod:`pedvr.crowd.orca`,
:mod:`pedvr.crowd.neighbors`, :mod:`pedvr.crowd.contact` and
:mod:`pedvr.crowd.deadlock`. It computes; it never mutates the
:class:`~pedvr.crowd.state.CrowdState` it is given (compute, then apply: the
simulation commits the returned arrays).

Units: metres, seconds, radians. Every array is float64 (``is_user`` bool)
and C-contiguous; shapes are checked and a wrong one raises
:class:`SteeringInputError` naming the field, its shape/dtype and what was
expected.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit

from pedvr.crowd import contact as _contact
from pedvr.crowd import deadlock as _deadlock
from pedvr.crowd import footprint as _fp
from pedvr.crowd import headway as _hw
from pedvr.crowd import neighbors as _nb
from pedvr.crowd import orca as _orca
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.errors import PedvrError
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet

# Obstacle-grid cell side, m: about RVO2's obstacle range (time_horizon_obst *
# max_speed + radius) for walking agents, so a query touches ~4 cells.
OBSTACLE_CELL = 2.0
_CHUNKS_PER_THREAD = 4


_FIELDS = tuple((name, tail, np.dtype(dtype)) for name, tail, dtype in (
    ("pos", (2,), np.float64), ("vel", (2,), np.float64), ("pref_vel", (2,), np.float64),
    ("heading", (), np.float64), ("radius", (), np.float64), ("pref_speed", (), np.float64),
    ("max_speed", (), np.float64), ("responsibility", (), np.float64), ("is_user", (), np.bool_),
    ("limits", (N_LIMITS,), np.float64), ("turn", (), np.float64), ("torso", (), np.float64),
))  # CrowdState's fields that steering reads: (name, shape after the row axis, dtype)


@njit(cache=True)
def _values_ok(pos, vel, pref_vel, heading, radius, responsibility):  # noqa: ANN001, ANN202
    """True when positions, velocities and headings are finite, radii positive and
    responsibilities inside [0, 1] (NaN fails every test)."""
    for i in range(pos.shape[0]):
        if not (math.isfinite(pos[i, 0]) and math.isfinite(pos[i, 1]) and math.isfinite(vel[i, 0])
                and math.isfinite(vel[i, 1]) and math.isfinite(pref_vel[i, 0])
                and math.isfinite(pref_vel[i, 1]) and math.isfinite(heading[i])):
            return False
        if not (radius[i] > 0.0 and 0.0 <= responsibility[i] <= 1.0):
            return False
    return True


class SteeringInputError(PedvrError, ValueError):
    """An array handed to :class:`Steering` has the wrong shape, dtype or value."""


def _check(name: str, a: np.ndarray, shape: tuple[int, ...], dtype: type | np.dtype) -> np.ndarray:
    if not isinstance(a, np.ndarray):
        raise SteeringInputError(f"{name}: expected a numpy array, got {type(a).__name__}")
    if a.dtype != np.dtype(dtype) or a.shape != shape:
        want = "x".join(str(s) for s in shape) or "scalar"
        raise SteeringInputError(
            f"{name} has shape {a.shape} dtype {a.dtype}: must be {want} {np.dtype(dtype)}")
    return np.ascontiguousarray(a)


class Steering:
    """ORCA steering for one crowd (van den Berg et al. 2011; PedVR §4.1).

    ``coupled`` selects the condition: False is plain ORCA (the Decoupled
    baseline), True adds the body's motion limits as hard lines of the same
    linear program (see :mod:`pedvr.crowd.orca` for the geometry and what is
    relaxed first when infeasible). The time horizons, neighbour distance and
    count come from ``params``; per-agent radius, max speed, responsibility
    toward the user and limits come from the state.

    The instance keeps scratch buffers between calls; it is not safe to call
    one instance from two threads at once.
    """

    def __init__(self, params: SteeringParams, obstacles: ObstacleSet, *, coupled: bool) -> None:
        if params.neighbor_dist <= 0.0:
            raise SteeringInputError(
                f"neighbor_dist = {params.neighbor_dist}: must be > 0")
        if params.max_neighbors < 0:
            raise SteeringInputError(f"max_neighbors = {params.max_neighbors}: must be >= 0")
        if params.time_gap < 0.0:
            raise SteeringInputError(f"time_gap = {params.time_gap}: must be >= 0 s")
        if not _fp.DEPTH_RATIO <= params.depth_ratio <= 1.0:
            raise SteeringInputError(f"depth_ratio = {params.depth_ratio}: must be in [{_fp.DEPTH_RATIO}, 1]")
        if not params.dense_slack >= 0.0:
            raise SteeringInputError(f"dense_slack = {params.dense_slack}: must be >= 0 m/s")
        if min(params.time_horizon, params.time_horizon_obst, params.time_horizon_obst_coupled) <= 0.0:
            raise SteeringInputError(
                f"time_horizon = {params.time_horizon}, time_horizon_obst = {params.time_horizon_obst}, "
                f"time_horizon_obst_coupled = {params.time_horizon_obst_coupled}: all must be > 0")
        self.params = params
        self.obstacles = obstacles
        self.coupled = bool(coupled)
        self._verts = np.ascontiguousarray(obstacles.vertices, dtype=np.float64).reshape(-1, 2)
        self._next = np.ascontiguousarray(obstacles.next, dtype=np.int64)
        self._prev = np.ascontiguousarray(obstacles.prev, dtype=np.int64)
        self._dir = np.ascontiguousarray(obstacles.direction, dtype=np.float64).reshape(-1, 2)
        self._convex = np.ascontiguousarray(obstacles.convex, dtype=np.bool_)
        self._n_static = len(obstacles)  # vertices from here on are moving segments (door leaves)
        self.obstacle_grid = _nb.build_obstacle_grid(self._verts, self._next, OBSTACLE_CELL)
        self._obst_cap = max(1, min(32, len(obstacles)))
        self._scratch_key: tuple[int, int, int] | None = None
        self._bounds = np.zeros(0, np.int64)  # chunk bounds of the last row count
        self._neighbors: tuple[np.ndarray, np.ndarray] | None = None
        # Verlet lists (pedvr.crowd.neighbors.verlet_candidates_kernel): where the footprint centres
        # were when they were made, each row's candidates and their count
        self._candidates: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._cand_cap = 4 * max(int(params.max_neighbors), 1)
        # Coupled: the walking body's turn (its ellipse along the heading, pedvr.crowd.footprint);
        # decoupled: the paper's discs.
        self.walk_turn = _fp.turn_for(params.depth_ratio) if self.coupled else 0.0
        # The late safety step toward the user (pedvr.crowd.encounter): ORCA's line toward
        # the user has this horizon; 0 switches it off.
        self.user_horizon = float(params.user_safety_horizon) if params.user_safety else 0.0
        # Coupled: in ORCA's dense case an agent keeps toward its goal within this slack
        # (pedvr.crowd.orca.toward_preferred); decoupled: the paper's least violation.
        self.dense_slack = float(params.dense_slack) if self.coupled else 0.0
        # Coupled: the obstacle horizon of agents outside a door's etiquette, away from the user and
        # door leaves (orca.obstacle_horizon); decoupled, and those in it: time_horizon_obst.
        self.short_obst = float(params.time_horizon_obst_coupled if self.coupled
                                else params.time_horizon_obst)
        self.last_status = np.zeros(0, np.int8)
        """Per row, after :meth:`compute_velocities`: ``orca.STATUS_*`` bit flags
        (dense case; heading limits dropped; all motion limits dropped)."""

    def set_moving_segments(self, a: np.ndarray, b: np.ndarray) -> None:
        """Line segments ``a[k] -> b[k]`` (``(M, 2)``, m) that are obstacles for the next calls
        besides the static ones, replacing the previous set: door leaves, which move between
        steps. They enter ORCA and the contact pass as RVO2's two-vertex obstacles."""
        a = np.asarray(a, np.float64).reshape(-1, 2)
        b = np.asarray(b, np.float64).reshape(-1, 2)
        if a.shape != b.shape:
            raise SteeringInputError(f"moving segments: a {a.shape} and b {b.shape} must match")
        st = self.obstacles
        extra = ObstacleSet.from_polygons([np.stack([p, q]) for p, q in zip(a, b, strict=True)])
        m = len(st)
        self._verts = np.ascontiguousarray(np.concatenate([st.vertices.reshape(-1, 2), extra.vertices]))
        self._next = np.ascontiguousarray(np.concatenate([st.next, extra.next + m]), dtype=np.int64)
        self._prev = np.ascontiguousarray(np.concatenate([st.prev, extra.prev + m]), dtype=np.int64)
        self._dir = np.ascontiguousarray(np.concatenate([st.direction.reshape(-1, 2), extra.direction]))
        self._convex = np.ascontiguousarray(np.concatenate([st.convex, extra.convex]), dtype=np.bool_)
        self.obstacle_grid = _nb.build_obstacle_grid(self._verts, self._next, OBSTACLE_CELL)

    # ------------------------------------------------------------------ ORCA

    def _scratch(self, n: int, k: int) -> tuple[np.ndarray, ...]:
        threads = numba.get_num_threads()
        chunks = max(1, min(n, threads * _CHUNKS_PER_THREAD))
        key = (chunks, k, self._obst_cap)
        if self._bounds.shape[0] != chunks + 1 or self._bounds[-1] != n:
            self._bounds = np.linspace(0, n, chunks + 1).astype(np.int64)
        if self._scratch_key != key:
            cap = _fp.COVER_DISCS * self._obst_cap + k + _orca.MAX_MOTION_LINES  # a pram: lines a disc
            self._lines = np.zeros((chunks, cap, 4))
            self._proj = np.zeros((chunks, cap, 4))
            self._oidx = np.zeros((chunks, self._obst_cap), np.int64)
            self._odsq = np.zeros((chunks, self._obst_cap))
            self._scratch_key = key
        return self._bounds, self._lines, self._proj, self._oidx, self._odsq

    def validate(self, state: CrowdState) -> None:
        """Check every field's shape and dtype; raise :class:`SteeringInputError`.

        Every step calls it, so the common case (all well) is one pass over the fields'
        shapes and one kernel over their values; the messages are made only on failure."""
        n = len(state)
        for name, tail, dtype in _FIELDS:
            a = getattr(state, name)
            if type(a) is not np.ndarray or a.dtype != dtype or a.shape != (n, *tail):
                _check(f"CrowdState.{name}", a, (n, *tail), dtype)
        if n and _values_ok(state.pos, state.vel, state.pref_vel, state.heading, state.radius,
                            state.responsibility):
            return
        for name in ("pos", "vel", "pref_vel", "heading"):
            a = getattr(state, name)
            if n and not np.isfinite(a).all():
                bad = int(np.flatnonzero(~np.isfinite(a.reshape(n, -1)).all(axis=1))[0])
                raise SteeringInputError(
                    f"CrowdState.{name}[{bad}] = {a[bad]}: must be finite (agent id {int(state.ids[bad])})")
        if n and not np.all(state.radius > 0.0):
            raise SteeringInputError(
                f"CrowdState.radius min = {state.radius.min()}: every radius must be > 0")
        if n and not (np.all(state.responsibility >= 0.0) and np.all(state.responsibility <= 1.0)):
            raise SteeringInputError(
                "CrowdState.responsibility outside [0, 1]: "
                f"min {state.responsibility.min()}, max {state.responsibility.max()}")

    def neighbors(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Agent neighbours ``(idx (N,K) int64, count (N,) int64)``, nearest first."""
        return _nb.agent_neighbors(pos, neighbor_dist=self.params.neighbor_dist,
                                   max_neighbors=self.params.max_neighbors)

    def compute_velocities(self, state: CrowdState, dt: float,
                           out: np.ndarray | None = None, *,
                           intent: np.ndarray | None = None,
                           at_doors: np.ndarray | None = None,
                           footprints: _fp.Footprints | None = None) -> np.ndarray:
        """New velocities ``(N,2) float64`` m/s for every row of ``state``.

        User rows get their input velocity back. ``dt`` (s) matters for the
        collision case of ORCA (cut-off at ``dt``) and for motion limits.
        ``out``, if given, must be ``(N,2) float64`` and is filled and returned.
        ``intent`` ``(N,2)``: the velocities the agents mean to walk before the time gap and
        the encounters (default ``state.pref_vel``); the dense slack presses only on neighbours
        going an agent's way (:func:`pedvr.crowd.orca.toward_preferred`). ``at_doors`` ``(N,)``
        bool: agents in a door's etiquette, which orders who goes: they take the paper's least
        violation whatever ``dense_slack`` says, and see obstacles ``time_horizon_obst`` ahead
        (door leaves swing) where other coupled agents see them ``time_horizon_obst_coupled``
        ahead, away from the user and door leaves (:func:`pedvr.crowd.orca.obstacle_horizon`).
        ``footprints``: :meth:`footprints` of this ``state``, where the caller has them already
        (the simulation makes them once for :meth:`headway` and this); made afresh when
        ``None``. Footprints of another state are not detected: the velocities would be wrong.
        """
        if not dt > 0.0:
            raise SteeringInputError(f"dt = {dt}: must be > 0")
        self.validate(state)
        n = len(state)
        if out is None:
            out = np.empty((n, 2))
        else:
            _check("out", out, (n, 2), np.float64)
            if not out.flags.c_contiguous:
                raise SteeringInputError("out: must be C-contiguous")
        self.last_status = np.zeros(n, np.int8)
        if n == 0:
            return out
        p = self.params
        k = int(p.max_neighbors)
        fp = self.footprints(state) if footprints is None else footprints
        pos = fp.centre  # footprints are steered about their centres (a pram's lies ahead of its pusher)
        kk = max(k, 1)
        idx = np.empty((n, kk), np.int64)
        dsq = np.empty((n, kk))
        cnt = np.empty(n, np.int64)
        cand = self._candidates
        if cand is None or not _nb.candidates_hold(pos, cand[0], _nb.VERLET_SKIN):
            # Verlet lists made afresh, as far beyond each row's last neighbours as the skin
            cand = (pos.copy(), *self._verlet_candidates(pos, k))
            self._candidates = cand
        # the lists a whole search would give, found among each row's candidates (pedvr.crowd.neighbors)
        _nb.verlet_neighbors_kernel(pos, float(p.neighbor_dist), k, cand[1], cand[2], idx, dsq, cnt)
        self._neighbors = (idx, cnt)
        og = self.obstacle_grid
        obst_count = np.empty(n, np.int64)
        wants = np.ascontiguousarray(state.pref_vel if intent is None
                                     else _check("intent", intent, (n, 2), np.float64))
        slack = np.full(n, self.dense_slack)
        short_obst = np.full(n, self.short_obst)
        if at_doors is not None:
            doors = _check("at_doors", at_doors, (n,), np.bool_)
            slack[doors] = 0.0
            short_obst[doors] = float(p.time_horizon_obst)
        while True:
            bounds, lines, proj, oidx, odsq = self._scratch(n, kk)
            _orca.orca_kernel(
                pos, np.ascontiguousarray(state.vel), np.ascontiguousarray(state.pref_vel),
                fp.radius, fp.depth, fp.facing, fp.rigid, np.ascontiguousarray(state.max_speed),
                np.ascontiguousarray(state.is_user),
                np.ascontiguousarray(state.heading), np.ascontiguousarray(state.pref_speed),
                np.ascontiguousarray(state.limits), idx, cnt, self._verts, self._next, self._prev,
                self._dir, self._convex, self._n_static, og.origin, og.cell, og.shape[0], og.shape[1],
                og.cell_start, og.cell_edges, og.edge_cells, float(p.time_horizon),
                float(p.time_horizon_obst), short_obst, self.user_horizon, float(dt), self.coupled, bounds,
                lines, proj, oidx, odsq, out, self.last_status, obst_count, wants, slack)
            need = int(obst_count.max())
            if need <= self._obst_cap:
                return out
            self._obst_cap = need  # rare: more obstacle neighbours than room; redo

    def _verlet_candidates(self, pos: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Each row's candidates ``(idx (N, C), count (N,))`` (:func:`pedvr.crowd.neighbors.
        verlet_candidates_kernel`; the last lists, where they are of these rows, bound how far
        they reach), with room made where a row's did not fit."""
        n = pos.shape[0]
        g = _nb.build_agent_grid(pos, _nb.default_cell_size(self.params.neighbor_dist),
                                 per_item=_nb.NEIGHBOR_CELLS_PER_AGENT)
        nd = float(self.params.neighbor_dist)
        if self._neighbors is not None and self._neighbors[0].shape[0] == n:
            prev_idx, prev_cnt = self._neighbors
        else:  # no last lists of these rows: a whole search bounds the candidates (a dense crowd's
            # would otherwise reach the skin beyond the neighbour distance, hundreds of rows each)
            kk = max(k, 1)
            prev_idx, dsq, prev_cnt = np.empty((n, kk), np.int64), np.empty((n, kk)), np.empty(n, np.int64)
            _nb.agent_neighbors_kernel(pos, nd, k, g.origin, g.cell, g.shape[0], g.shape[1], g.cell_start,
                                       g.order, g.sorted_pos, prev_idx, dsq, prev_cnt, _nb.NO_LISTS,
                                       _nb.NO_COUNTS)
        while True:
            cidx = np.empty((n, self._cand_cap), np.int64)
            ccnt = np.empty(n, np.int64)
            _nb.verlet_candidates_kernel(pos, nd, k, _nb.VERLET_SKIN, prev_idx, prev_cnt, g.origin, g.cell,
                                         g.shape[0], g.shape[1], g.cell_start, g.order, g.sorted_pos, cidx,
                                         ccnt)
            need = int(ccnt.max()) if n else 0
            fits = need <= self._cand_cap
            # room for the next ones to grow a little, and no more than that (a crowd thins out)
            self._cand_cap = max(4 * max(k, 1), need + need // 4)
            if fits:
                return cidx, ccnt

    def orca_lines(self, state: CrowdState, dt: float, row: int) -> np.ndarray:
        """The ORCA lines of one row, as :meth:`compute_velocities` builds them from ``state``:
        ``(L, 4) float64`` rows ``(point_x, point_y, dir_x, dir_y)``, permitted side on the left
        of the direction (RVO2's ``getAgentORCALine``, with the point first). Obstacle lines
        come first, then (coupled) the motion-limit lines, then one line per neighbour,
        nearest first. For inspection and tests; not on the step path. A coupled row sees
        obstacles as one outside a door's etiquette does (:func:`pedvr.crowd.orca.obstacle_horizon`).
        """
        if not dt > 0.0:
            raise SteeringInputError(f"dt = {dt}: must be > 0")
        self.validate(state)
        n = len(state)
        if not 0 <= row < n:
            raise SteeringInputError(f"row {row}: expected 0 <= row < {n}")
        p = self.params
        fp = self.footprints(state)
        pos = fp.centre
        idx, cnt = self.neighbors(pos)
        og = self.obstacle_grid
        rng = p.time_horizon_obst * float(state.max_speed[row]) + float(fp.radius[row])
        oidx, ocnt = _nb.obstacle_neighbors(pos[row:row + 1], np.array([rng * rng]), self._verts,
                                            self._next, og)
        is_user = np.ascontiguousarray(state.is_user)
        near = _orca.near_user_or_leaf(row, is_user, idx, cnt, np.ascontiguousarray(oidx[0]), int(ocnt[0]),
                                       self._n_static)
        tho = _orca.obstacle_horizon(near, float(p.time_horizon_obst), self.short_obst)
        lines = np.zeros((_fp.COVER_DISCS * int(ocnt[0]) + idx.shape[1] + _orca.MAX_MOTION_LINES, 4))
        count, _, _, _ = _orca.agent_lines(
            row, pos, np.ascontiguousarray(state.vel), fp.radius, fp.depth, fp.facing, fp.rigid,
            np.ascontiguousarray(state.is_user),
            np.ascontiguousarray(state.heading), np.ascontiguousarray(state.pref_speed),
            np.ascontiguousarray(state.limits), idx, cnt, np.ascontiguousarray(oidx[0]), int(ocnt[0]),
            self._verts, self._next, self._prev, self._dir, self._convex, self._n_static,
            float(p.time_horizon), tho, self.user_horizon, float(dt), self.coupled,
            lines)
        return lines[:count].copy()

    def headway(self, state: CrowdState, pref_vel: np.ndarray, *,
                footprints: _fp.Footprints | None = None) -> np.ndarray:
        """Preferred velocities ``(N, 2)`` whose speeds keep the time gap ``params.time_gap`` to
        whoever walks ahead in each agent's lane and goes its way (:mod:`pedvr.crowd.headway`):
        coupled mode only; decoupled (plain ORCA), or a time gap of 0, returns them unchanged.
        Uses the neighbour lists of the last :meth:`compute_velocities` when they are of the
        same rows (the simulation forgets them when rows come or go), else searches afresh.
        ``footprints`` as for :meth:`compute_velocities`."""
        n = len(state)
        pref_vel = _check("pref_vel", pref_vel, (n, 2), np.float64)
        if n == 0 or not self.coupled or self.params.time_gap <= 0.0:
            return pref_vel.copy()
        fp = self.footprints(state) if footprints is None else footprints
        if self._neighbors is None or self._neighbors[0].shape[0] != n:
            self._neighbors = self.neighbors(np.ascontiguousarray(fp.centre))
        idx, cnt = self._neighbors
        out = np.empty((n, 2))
        _hw.headway_kernel(fp.centre, pref_vel, fp.radius, fp.depth, fp.facing,
                           np.ascontiguousarray(state.is_user), idx, cnt, float(self.params.time_gap), out)
        return out

    def forget_neighbors(self) -> None:
        """Rows came or went: the last neighbour lists and candidates no longer name the same agents."""
        self._neighbors = None
        self._candidates = None

    # ------------------------------------------------------------------ footprints

    @staticmethod
    def footprints(state: CrowdState) -> _fp.Footprints:
        """The rows' footprints as steering sees them (:func:`pedvr.crowd.footprint.footprints`)."""
        return _fp.footprints(state.pos, state.radius, state.turn, state.torso, state.heading, state.ahead,
                              state.length)

    def turn_shoulders(self, state: CrowdState, dt: float, *, short_of_room: np.ndarray | None = None,
                       to_user: np.ndarray | None = None,
                       pinned: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """New ``(turn (N,), torso (N,))`` after this step (see :mod:`pedvr.crowd.footprint`):
        agents squeezing past someone turn their shoulders, the others untwist. Uses the
        neighbour lists of the last :meth:`compute_velocities` on the same state.
        ``short_of_room``/``to_user`` come from the user encounter (default: none). ``pinned``
        rows (seated bodies, as :meth:`resolve_contacts` takes them) keep their footprint: the
        contact pass cannot move them, so a seated body that turned as someone squeezed past could
        overlap a seated neighbour for good (shopping_mall: 12.5 cm with a shorter obstacle horizon).

        Decoupled (the paper's plain ORCA) keeps its discs: nobody turns (issue 26: pedvr's turned
        shoulders packed it to 3.4 m⁻² behind the 1.45 m corridor entrance, denser than the
        discs it steers with allow)."""
        n = len(state)
        if not self.coupled:
            return np.zeros(n), np.ascontiguousarray(state.heading, np.float64).copy()
        if self._neighbors is None or self._neighbors[0].shape[0] != n:
            self._neighbors = self.neighbors(np.ascontiguousarray(state.pos))
        idx, cnt = self._neighbors
        short = np.zeros(n, np.bool_) if short_of_room is None else np.ascontiguousarray(short_of_room)
        room = np.zeros((n, 2)) if to_user is None else np.ascontiguousarray(to_user, np.float64)
        turn = np.empty(n)
        torso = np.empty(n)
        if n:
            pos = np.ascontiguousarray(state.pos)
            wall = np.full(n, np.inf)
            turned = np.flatnonzero(state.turn > self.walk_turn)
            if turned.size and len(self._next):
                og = self.obstacle_grid
                _fp.wall_distance_kernel(pos, turned, np.ascontiguousarray(state.radius), self._verts,
                                         self._next, og.origin, og.cell, og.shape[0], og.shape[1],
                                         og.cell_start, og.cell_edges, og.edge_cells, wall)
            radius = np.ascontiguousarray(state.radius)
            is_user = np.ascontiguousarray(state.is_user)
            narrow = np.zeros((n, 2))
            if self._n_static:  # passages narrower than the shoulders (coupled: decoupled returned above)
                og = self.obstacle_grid
                _fp.narrow_kernel(pos, np.ascontiguousarray(state.pref_vel), radius, is_user, self._verts,
                                  self._next, self._n_static, og.origin, og.cell, og.shape[0], og.shape[1],
                                  og.cell_start, og.cell_edges, og.edge_cells, narrow)
            _fp.turn_kernel(pos, np.ascontiguousarray(state.vel), radius, is_user,
                            np.ascontiguousarray(state.turn), np.ascontiguousarray(state.torso),
                            np.ascontiguousarray(state.heading), self.walk_turn, idx, cnt, short, room,
                            narrow, wall, float(dt), turn, torso)
            turn[state.length > 0.0] = 0.0  # a pram and its pusher: one rigid footprint, no shoulder turn
            if pinned is not None:
                keep = _check("pinned", pinned, (n,), np.bool_)
                turn[keep] = state.turn[keep]
                torso[keep] = state.torso[keep]
        return turn, torso

    # ------------------------------------------------------------------ contacts

    def resolve_contacts(self, pos: np.ndarray, radius: np.ndarray, is_user: np.ndarray, *,
                         turn: np.ndarray | None = None, torso: np.ndarray | None = None,
                         heading: np.ndarray | None = None, ahead: np.ndarray | None = None,
                         length: np.ndarray | None = None, pinned: np.ndarray | None = None,
                         tolerance: float = _contact.DEFAULT_TOLERANCE,
                         max_iterations: int = _contact.DEFAULT_ITERATIONS) -> np.ndarray:
        """New positions ``(N,2)`` with overlaps pushed apart (see :mod:`pedvr.crowd.contact`).

        The user row never moves; agents take the whole correction against the
        user and against obstacle edges, and are never left inside the user.
        ``turn``/``torso`` give the footprints (default: discs), and ``heading``/``ahead``/
        ``length`` the rigid ones that reach ahead of a body (a pushed pram; default: none;
        :func:`pedvr.crowd.footprint.footprints`): they are pushed apart about their centres,
        and the bodies move with them. ``pinned`` rows (seated bodies) do not move, except out
        of the user's way.
        """
        n = pos.shape[0] if isinstance(pos, np.ndarray) else -1
        pos = _check("pos", pos, (n, 2), np.float64)
        radius = _check("radius", radius, (n,), np.float64)
        is_user = _check("is_user", is_user, (n,), np.bool_)
        if pinned is not None:
            pinned = _check("pinned", pinned, (n,), np.bool_)
        depth = facing = rigid = None
        if length is not None and heading is not None and ahead is not None and np.any(length > 0.0):
            fp = _fp.footprints(pos, radius, np.zeros(n) if turn is None else turn,
                                np.zeros(n) if torso is None else torso,
                                _check("heading", heading, (n,), np.float64),
                                _check("ahead", ahead, (n,), np.float64),
                                _check("length", length, (n,), np.float64))
            out = _contact.resolve_contacts(fp.centre, fp.radius, is_user, self._verts, self._next,
                                            self._prev, self.obstacle_grid, depth=fp.depth, facing=fp.facing,
                                            rigid=fp.rigid, n_static=self._n_static, pinned=pinned,
                                            tolerance=tolerance, max_iterations=max_iterations)
            return _fp.positions_of(out, heading, ahead)
        if turn is not None and torso is not None:
            depth, facing = _fp.footprint_arrays(radius, _check("turn", turn, (n,), np.float64),
                                                 _check("torso", torso, (n,), np.float64))
        return _contact.resolve_contacts(pos, radius, is_user, self._verts, self._next,
                                         self._prev, self.obstacle_grid, depth=depth, facing=facing,
                                         rigid=rigid, n_static=self._n_static, pinned=pinned,
                                         tolerance=tolerance, max_iterations=max_iterations)

    # ------------------------------------------------------------------ deadlocks

    def unstick(self, vel: np.ndarray, pref_vel: np.ndarray, is_user: np.ndarray,
                stuck_time: np.ndarray, dt: float, *, out: np.ndarray | None = None,
                slow_fraction: float = _deadlock.SLOW_FRACTION,
                patience: float = _deadlock.PATIENCE, turn_rate: float = _deadlock.TURN_RATE,
                max_turn: float = _deadlock.MAX_TURN,
                recovery: float = _deadlock.RECOVERY) -> np.ndarray:
        """Preferred velocities with stuck agents nudged (see :mod:`pedvr.crowd.deadlock`).

        ``stuck_time (N,) float64`` is owned by the caller and updated in
        place; everything else is read only. Call before :meth:`compute_velocities`.
        """
        n = vel.shape[0] if isinstance(vel, np.ndarray) else -1
        _check("vel", vel, (n, 2), np.float64)
        _check("pref_vel", pref_vel, (n, 2), np.float64)
        _check("is_user", is_user, (n,), np.bool_)
        _check("stuck_time", stuck_time, (n,), np.float64)
        if not stuck_time.flags.c_contiguous:
            raise SteeringInputError("stuck_time: must be C-contiguous (it is updated in place)")
        if out is not None:
            _check("out", out, (n, 2), np.float64)
        return _deadlock.unstick(vel, pref_vel, is_user, stuck_time, dt, out=out,
                                 slow_fraction=slow_fraction, patience=patience,
                                 turn_rate=turn_rate, max_turn=max_turn, recovery=recovery)
