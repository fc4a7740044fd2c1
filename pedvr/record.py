"""The ``record`` phase: trajectories and the run's metrics.

The recording keeps, per step, every agent's and the user's position,
velocity and heading by stable id; it is saved as one ``.npz`` with the seed
and the scene's content hash. Metrics are accumulated as the run goes, so a
run can report them without keeping the trajectory.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit

from pedvr.crowd.footprint import Footprints, footprints
from pedvr.crowd.overlap import (
    body_user_clearance,
    motion_extremes,
    nearest_edges,
    pair_overlaps,
    user_clearance,
    wall_overlaps,
)
from pedvr.crowd.state import CrowdState
from pedvr.world.visibility_kernels import EdgeGrid

OVERLAP_TOLERANCE = 0.01  # m: the quality bar (DESIGN.md)
INSIDE_EVERY = 30  # steps between point-in-obstacle tests of rows far from every edge
CLEARANCE_RANGE = 2.0  # m: the user's clearance is sampled while the nearest agent is this close
STALL_DISTANCE = 0.5  # m: an agent with a goal that moved less than this ...
STALL_SECONDS = 20.0  # s: ... in this long is stalled (a deadlock, or a jam that does not clear)


def _user_row(crowd: CrowdState) -> int:
    """The user's row (the simulation keeps it at row 0), -1 when there is none."""
    if len(crowd) and crowd.is_user[0]:
        return 0
    rows = np.flatnonzero(crowd.is_user)
    return int(rows[0]) if rows.size else -1


@njit(cache=True)
def progress_kernel(ids, pos, wants, t, distance, seconds, anchor_pos, anchor_t, stalled):  # noqa: ANN001, ANN201
    """:meth:`Metrics.observe_progress`'s pass over the rows: an id's anchor moves to its row's
    position (time ``t``) when the row has no goal to walk to (``wants`` False) or is ``distance``
    or more from it (a NaN anchor, never set, counts as that far); rows that want to walk and whose
    anchor is ``seconds`` old or older are stalled. Writes their ids to ``stalled[:m]``, returns m."""
    m = 0
    for k in range(ids.shape[0]):
        i = ids[k]
        dx = pos[k, 0] - anchor_pos[i, 0]
        dy = pos[k, 1] - anchor_pos[i, 1]
        d = math.sqrt(dx * dx + dy * dy)
        if not wants[k] or not d < distance:
            anchor_pos[i, 0] = pos[k, 0]
            anchor_pos[i, 1] = pos[k, 1]
            anchor_t[i] = t
        if wants[k] and t - anchor_t[i] >= seconds:
            stalled[m] = i
            m += 1
    return m


@njit(cache=True)
def _root_sync(pelvis, pos, is_user, seated):  # noqa: ANN001, ANN202
    """The largest horizontal distance (m) between a virtual, unseated row's pelvis ``(N, 3)``
    (Y up) and its 2D position; 0 when there is none."""
    worst = 0.0  # squared: one square root at the end (it keeps the order)
    for i in range(pos.shape[0]):
        if not (is_user[i] or seated[i]):
            dx = pelvis[i, 0] - pos[i, 0]
            dz = pelvis[i, 2] - pos[i, 1]
            worst = max(worst, dx * dx + dz * dz)
    return math.sqrt(worst)


@dataclass
class Metrics:
    """Running metrics of one run; :meth:`summary` gives the JSON keys."""

    seg_a: np.ndarray
    seg_b: np.ndarray
    inside: object  # callable: (N,2) -> (N,) bool, True where a point is inside an obstacle
    _grid: Any = None  # EdgeGrid over the edges, built on first use
    steps: int = 0
    _seen: np.ndarray = field(default_factory=lambda: np.zeros(0, np.bool_))  # by id: a virtual agent
    max_overlap: float = 0.0
    overlap_pairs: set[tuple[int, int]] = field(default_factory=set)
    min_user_distance: float = float("inf")
    speed_sum: float = 0.0
    speed_count: int = 0
    max_accel: float = 0.0
    max_turn_rate: float = 0.0
    arrivals: int = 0
    step_ms: list[float] = field(default_factory=list)
    phase_ms: dict[str, float] = field(default_factory=dict)
    gaze_events: list[dict[str, object]] = field(default_factory=list)
    root_sync_error: float = 0.0
    door_overlap: float = 0.0  # m: deepest a door leaf cut into a walker's disc
    door_openings: int = 0  # times a closed leaf was opened
    door_push: float = 0.0  # m: the largest step a leaf forced on a body (walkers steer round leaves)
    personal_space: float = 0.3  # m: the margin agents keep from the user where there is room
    user_overlap: float = 0.0  # m: the deepest any agent's footprint cut into the user's disc
    wall_overlap: float = 0.0  # m: the deepest any agent's footprint cut into a wall
    user_clearance: list[float] = field(default_factory=list)  # m, nearest agent per step, within range
    steps_in_user_margin: int = 0
    user_contact_steps: int = 0  # steps where steering alone would have left an agent inside the user
    stalled_ever: set[int] = field(default_factory=set)
    _anchor_pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # by id
    _anchor_t: np.ndarray = field(default_factory=lambda: np.zeros(0))  # by id, s
    _stalled_now: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # ids

    def observe_body(self, crowd: CrowdState, *, pelvis: np.ndarray,
                     seated: np.ndarray | None = None) -> None:
        """Pelvis ``(N,3)`` (3D, Y up) against the committed 2D agents: the largest
        horizontal distance (virtual agents; it includes the pelvis's deliberate sway). Seated
        bodies (``seated (N,)``) are left out: a chair's sitting pose puts the pelvis 0.3 m behind
        the agent by design (pedvr.behavior.objects.Chair)."""
        n = len(crowd)
        if pelvis.shape[0] == n:
            sitting = seated if seated is not None and seated.shape[0] == n else np.zeros(n, np.bool_)
            worst = _root_sync(pelvis, crowd.pos, crowd.is_user, sitting)
            self.root_sync_error = max(self.root_sync_error, worst)

    def body_summary(self, *, slides: np.ndarray, steps: list[np.ndarray]) -> dict[str, object]:
        """Body metrics: foot skate per stance (m), root sync, gaze events, cadence at 1.3–1.4 m/s.

        ``steps`` are the body's completed steps ``(row id, duration s, distance m,
        speed m/s)``; the cadence is 1 / mean duration of steps taken at 1.3–1.4 m/s
        (None when there were none).
        """
        st = np.concatenate(steps) if steps else np.zeros((0, 4))
        band = st[(st[:, 3] >= 1.3) & (st[:, 3] <= 1.4) & (st[:, 1] < 1.5)]  # not first steps from rest
        return {
            "foot_skate_p95_m": round(float(np.percentile(slides, 95)), 6) if slides.size else 0.0,
            "foot_skate_max_m": round(float(slides.max()), 6) if slides.size else 0.0,
            "foot_stances": int(slides.size),
            "root_sync_error_m": round(self.root_sync_error, 6),
            "gaze_events": list(self.gaze_events),
            "cadence_hz_at_1_35": round(float(1.0 / band[:, 1].mean()), 4) if band.size else None,
            "step_length_m_at_1_35": round(float(band[:, 2].mean()), 4) if band.size else None,
        }

    def observe(self, crowd: CrowdState, *, prev_vel: np.ndarray, prev_heading: np.ndarray,
                dt: float) -> None:
        """Account one committed step (``prev_*`` are the rows' values before it)."""
        self.steps += 1
        virt = ~crowd.is_user
        ids = crowd.ids[virt]
        if ids.size:
            top = int(ids.max()) + 1
            if top > self._seen.shape[0]:
                self._seen = np.concatenate([self._seen, np.zeros(max(top, 2 * self._seen.shape[0])
                                                                  - self._seen.shape[0], np.bool_)])
            self._seen[ids] = True
        if virt.any():
            total, rows, acc, turn = motion_extremes(crowd.vel, prev_vel, crowd.heading, prev_heading,
                                                     crowd.is_user, dt)
            self.speed_sum += total
            self.speed_count += rows
            self.max_accel = max(self.max_accel, acc)
            self.max_turn_rate = max(self.max_turn_rate, turn)
        self._overlaps(crowd)

    def _user(self, crowd: CrowdState, fp: Footprints) -> None:
        """The user's distances, every step (not only when some pair of discs is close):
        the closest centre distance, the deepest any footprint cuts into the user's disc,
        and the clearance (surface to surface) to the nearest agent within
        ``CLEARANCE_RANGE``, sampled once per step for the distribution (one kernel pass,
        :func:`pedvr.crowd.overlap.user_clearance`)."""
        u = _user_row(crowd)
        if u < 0 or len(crowd) < 2:
            return
        nearest, clear, dist = user_clearance(crowd.pos, fp.centre, fp.radius, fp.depth, fp.facing, u,
                                              crowd.pos[u], float(crowd.radius[u]))
        self.min_user_distance = min(self.min_user_distance, nearest)
        self.user_overlap = max(self.user_overlap, -clear)
        if dist <= CLEARANCE_RANGE:
            self.user_clearance.append(clear)
            if clear < self.personal_space:
                self.steps_in_user_margin += 1

    def observe_user_contact(self, crowd: CrowdState, proposed: np.ndarray) -> None:
        """Count a step in which steering left some agent's proposed position ``proposed``
        (before the contact pass) more than 1 cm inside the user's disc: a contact the
        contact pass then undid (with the safety step on, there are none)."""
        u = _user_row(crowd)
        if u < 0 or len(crowd) < 2:
            return
        _, clear, _ = body_user_clearance(proposed, crowd.radius, crowd.turn, crowd.torso, crowd.heading,
                                          crowd.ahead, crowd.length, u, crowd.pos[u], float(crowd.radius[u]))
        if -clear > OVERLAP_TOLERANCE:
            self.user_contact_steps += 1

    def observe_progress(self, ids: np.ndarray, pos: np.ndarray, wants: np.ndarray, t: float) -> None:
        """Track who is stalled: rows with ``wants`` (a goal they have not reached) that stayed
        within ``STALL_DISTANCE`` of where they were ``STALL_SECONDS`` ago, or longer.

        Kept by stable id (ids are small integers), one kernel pass: each id has an anchor (a
        position and a time) that moves to the agent whenever it is ``STALL_DISTANCE`` away
        or has no goal to walk to.
        """
        top = int(ids.max()) + 1 if ids.size else 0
        if top > self._anchor_t.shape[0]:
            more = max(top, 2 * self._anchor_t.shape[0]) - self._anchor_t.shape[0]
            self._anchor_pos = np.concatenate([self._anchor_pos, np.full((more, 2), np.nan)])
            self._anchor_t = np.concatenate([self._anchor_t, np.full(more, np.nan)])
        stalled = np.empty(ids.shape[0], np.int64)
        m = progress_kernel(ids, pos, wants, float(t), STALL_DISTANCE, STALL_SECONDS, self._anchor_pos,
                            self._anchor_t, stalled)
        self._stalled_now = stalled[:m]
        if m:
            self.stalled_ever.update(int(i) for i in self._stalled_now)

    def _overlaps(self, crowd: CrowdState) -> None:
        """Overlaps between footprints (discs, or turned ellipses: :mod:`pedvr.crowd.footprint`)
        and of footprints with obstacle edges, the same model that is steered (numba kernels,
        :mod:`pedvr.crowd.overlap`)."""
        n = len(crowd)
        if n == 0:
            return
        fp = footprints(crowd.pos, crowd.radius, crowd.turn, crowd.torso, crowd.heading, crowd.ahead,
                        crowd.length)
        self._user(crowd, fp)
        pos, rad, depth, facing = fp.centre, fp.radius, fp.depth, fp.facing
        worst, pairs = pair_overlaps(pos, rad, depth, facing, OVERLAP_TOLERANCE)
        self.max_overlap = max(self.max_overlap, worst)
        for a, b in crowd.ids[pairs].tolist():
            self.overlap_pairs.add((min(a, b), max(a, b)))
        if self.seg_a.shape[0]:
            d, away = self._edge_distance(pos, float(rad.max()))
            near = np.isfinite(d)
            # A centre that enters an obstacle is near its edges first (nobody crosses a
            # wall's thickness in one step), so rows near an edge are tested every step and
            # the others every INSIDE_EVERY steps.
            check = near if self.steps % INSIDE_EVERY else np.ones(n, np.bool_)
            inside = np.zeros(n, np.bool_)
            if check.any():
                inside[check] = self.inside(pos[check])  # type: ignore[operator]
            worst, cut = wall_overlaps(rad, depth, facing, d, away, inside, crowd.is_user, OVERLAP_TOLERANCE)
            self.max_overlap = max(self.max_overlap, worst)
            self.wall_overlap = max(self.wall_overlap, worst)
            for k in cut.tolist():
                self.overlap_pairs.add((int(crowd.ids[k]), -1))

    def _edge_distance(self, pos: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """Distance from each point to the nearest obstacle edge within ``reach`` (else inf),
        and the unit direction from that nearest point to the point (zero where none); the
        edges are filed in a grid once (forest: 500 agents, 2800 edges)."""
        if self._grid is None:
            self._grid = EdgeGrid.build(self.seg_a, self.seg_b, cell=max(2.0, 4.0 * reach))
        g = self._grid
        d = np.empty(pos.shape[0])
        away = np.empty_like(pos)
        nearest_edges(pos, float(reach), np.ascontiguousarray(self.seg_a, np.float64),
                      np.ascontiguousarray(self.seg_b, np.float64), g.origin, g.cell, g.shape, g.start,
                      g.items, d, away)
        return d, away

    def summary(self) -> dict[str, object]:
        ms = np.asarray(self.step_ms) if self.step_ms else np.zeros(1)
        return {
            "steps": self.steps,
            "agents": int(np.count_nonzero(self._seen)),
            "max_overlap_m": round(max(self.max_overlap, 0.0), 6),
            "overlaps_over_1cm": len(self.overlap_pairs),
            "min_user_distance_m": None if not np.isfinite(self.min_user_distance)
            else round(self.min_user_distance, 6),
            "user_overlap_max_m": round(max(self.user_overlap, 0.0), 6),
            "wall_overlap_max_m": round(max(self.wall_overlap, 0.0), 6),
            "user_clearance_p5_m": _pct(self.user_clearance, 5),
            "user_clearance_p50_m": _pct(self.user_clearance, 50),
            "steps_in_user_margin": self.steps_in_user_margin,
            "user_contact_steps": self.user_contact_steps,
            "arrivals": self.arrivals,
            "stalled_agents": int(self._stalled_now.size),
            "stalled_agents_ever": len(self.stalled_ever),
            "mean_speed_mps": round(self.speed_sum / max(self.speed_count, 1), 6),
            "max_accel_mps2": round(self.max_accel, 6),
            "max_turn_rate_radps": round(self.max_turn_rate, 6),
            "step_ms_p50": round(float(np.percentile(ms, 50)), 4),
            "step_ms_p95": round(float(np.percentile(ms, 95)), 4),
            "phase_ms_mean": {k: round(v / max(self.steps, 1), 5) for k, v in self.phase_ms.items()},
            "door_leaf_overlap_max_m": round(self.door_overlap, 6),
            "door_openings": self.door_openings,
            "door_push_max_m": round(self.door_push, 6),
        }


def _pct(samples: list[float], q: float) -> float | None:
    return round(float(np.percentile(samples, q)), 6) if samples else None


@dataclass
class Recording:
    """Per-step rows by id, assembled into dense arrays when saved."""

    times: list[float] = field(default_factory=list)
    frames: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=list)
    door_angles: list[np.ndarray] = field(default_factory=list)

    def add(self, t: float, crowd: CrowdState, door_angle: np.ndarray | None = None) -> None:
        self.times.append(t)
        self.frames.append((crowd.ids.copy(), crowd.pos.copy(), crowd.vel.copy(),
                            crowd.heading.copy(), crowd.is_user.copy()))
        self.door_angles.append(np.zeros(0) if door_angle is None else np.array(door_angle, np.float64))

    def arrays(self) -> dict[str, np.ndarray]:
        """``t (S,)``, ``ids (A,)``, ``is_user (A,)``, ``pos/vel (S,A,2)``, ``heading (S,A)``,
        ``door_angle (S,L)`` (each door leaf's angle from closed, rad; ``L`` = 0 without doors).

        Agents absent at a step (not yet spawned, or gone) are NaN there.
        """
        ids = np.unique(np.concatenate([f[0] for f in self.frames])) if self.frames else np.zeros(0, np.int64)
        col = {int(i): k for k, i in enumerate(ids)}
        s, a = len(self.frames), ids.shape[0]
        pos = np.full((s, a, 2), np.nan)
        vel = np.full((s, a, 2), np.nan)
        heading = np.full((s, a), np.nan)
        is_user = np.zeros(a, np.bool_)
        for k, (fid, p, v, h, u) in enumerate(self.frames):
            cols = np.fromiter((col[int(i)] for i in fid), np.int64, fid.shape[0])
            pos[k, cols] = p
            vel[k, cols] = v
            heading[k, cols] = h
            is_user[cols] |= u
        leaves = self.door_angles[0].shape[0] if self.door_angles else 0
        door = np.asarray(self.door_angles, np.float64).reshape(s, leaves)
        return {"t": np.asarray(self.times), "ids": ids, "is_user": is_user, "pos": pos, "vel": vel,
                "heading": heading, "door_angle": door}

    def save(self, path: str | Path, meta: dict[str, object]) -> None:
        arrays = self.arrays()
        with open(path, "wb") as fh:
            np.savez_compressed(fh, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays)  # type: ignore[arg-type]
