"""Steering benchmark: pedvr's ORCA kernels against RVO2 (pyrvo) on one machine.

The scenario is RVO2's "Circle" example scaled to pedestrians: ``agents``
agents evenly on a circle, each walking to its antipode. Centres start 0.6 m
apart along the circle (radius ``max(10, agents * 0.6 / 2π)`` m), so every
agent starts with a full neighbour list and the crowd jams as it converges.
Parameters: time step 0.1 s, neighbour distance 3 m, 10 neighbours, time
horizons 2 s (agents and obstacles), radius 0.25 m, max speed 1.4 m/s,
preferred speed 1.4 m/s (slowing within 1.4 m of the goal), decoupled mode,
no user, no obstacles.

Both simulations run in the same process and the same loop, one step of each
in turn, so they see the same machine state. Like the simulation's decoupled
condition, pedvr's velocity after a step is the disc's actual motion (ORCA's,
plus whatever the contact pass pushed: position-based dynamics), so the next
step's ORCA sees a neighbour blocked in the jam as blocked. Measured per step:

* core: RVO2's ``do_step`` (k-d tree, neighbours, ORCA, position update)
  against ours (grid, neighbours, ORCA, position update);
* end to end: the core plus setting preferred velocities (for RVO2 the Python
  loop of ``set_agent_pref_velocity`` calls, for us one numpy expression) and,
  for us, the contact pass (which RVO2 does not have). RVO2's preferred
  velocities are computed with numpy from positions read back after each
  step, outside the timed region (reading them back is not part of either).

``*_overlaps_over_1cm`` counts distinct agent pairs that overlapped by more
than 1 cm at the end of any step (ours after the contact pass).
"""

from __future__ import annotations

import math
import os
import platform
import time
from collections.abc import Sequence
from typing import Any

import numba
import numpy as np

from pedvr.benchload import cpu_load
from pedvr.crowd.contact import overlapping_pairs
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.crowd.steering import Steering
from pedvr.errors import UsageError
from pedvr.kernels import forcing
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet

DT = 0.1
NEIGHBOR_DIST = 3.0
MAX_NEIGHBORS = 10
TIME_HORIZON = 2.0
RADIUS = 0.25
MAX_SPEED = 1.4
PREF_SPEED = 1.4
SPACING = 0.6
OVERLAP_TOL = 0.01


def circle_radius(agents: int) -> float:
    """Radius of the start circle, m: centres ``SPACING`` apart, at least 10 m."""
    return max(10.0, agents * SPACING / (2.0 * math.pi))


def _pref_velocities(pos: np.ndarray, goals: np.ndarray) -> np.ndarray:
    d = goals - pos
    dist = np.sqrt((d * d).sum(axis=1))
    scale = np.where(dist > 1e-9, np.minimum(PREF_SPEED, dist) / np.maximum(dist, 1e-9), 0.0)
    return d * scale[:, None]


def _crowd(pos: np.ndarray) -> CrowdState:
    n = pos.shape[0]
    return CrowdState(
        ids=np.arange(n, dtype=np.int64), pos=pos.copy(), vel=np.zeros((n, 2)),
        pref_vel=np.zeros((n, 2)), heading=np.zeros(n), pref_heading=np.zeros(n),
        radius=np.full(n, RADIUS), pref_speed=np.full(n, PREF_SPEED),
        max_speed=np.full(n, MAX_SPEED), responsibility=np.full(n, 0.5),
        is_user=np.zeros(n, np.bool_), limits=np.zeros((n, N_LIMITS)))


def rvo2_simulator(params: SteeringParams, dt: float, pos: np.ndarray, radius: np.ndarray,
                   max_speed: np.ndarray, rings: Sequence[np.ndarray] = ()) -> Any:
    """RVO2 (pyrvo) set up as pedvr's steering is: the same ORCA parameters (``params``), time
    step, agents (``pos (N, 2)``, ``radius (N,)``, ``max_speed (N,)``) and obstacles (``rings``,
    RVO2-oriented as :func:`pedvr.world.geometry.rvo_rings` gives them). Also used by
    ``pedvr bench sim --vs rvo2`` (:mod:`pedvr.bench_sim`)."""
    try:
        import pyrvo
    except ImportError:
        raise UsageError("--vs rvo2: needs pyrvo, RVO2's binding (pip install 'pedvr[bench]')") from None

    sim = pyrvo.RVOSimulator()
    sim.set_time_step(dt)
    sim.set_agent_defaults(params.neighbor_dist, params.max_neighbors, params.time_horizon,
                           params.time_horizon_obst, float(radius[0]) if len(radius) else 0.25,
                           float(max_speed[0]) if len(max_speed) else 1.0)
    for ring in rings:
        sim.add_obstacle([(float(x), float(y)) for x, y in ring])
    for i in range(pos.shape[0]):
        sim.add_agent((float(pos[i, 0]), float(pos[i, 1])))
        if radius[i] != radius[0]:
            sim.set_agent_radius(i, float(radius[i]))
        if max_speed[i] != max_speed[0]:
            sim.set_agent_max_speed(i, float(max_speed[i]))
    sim.process_obstacles()
    return sim


def rvo2_step(sim: Any, pref_vel: np.ndarray) -> tuple[float, float, float]:
    """RVO2's step: its preferred velocities set (``pref_vel (N, 2)``, a Python loop of calls, as
    RVO2's examples do), then ``do_step``. Returns the seconds of ``do_step`` alone (the core), of
    both (end to end) and the CPU seconds of ``do_step``."""
    r0 = time.perf_counter()
    for i in range(pref_vel.shape[0]):
        sim.set_agent_pref_velocity(i, (float(pref_vel[i, 0]), float(pref_vel[i, 1])))
    r1 = time.perf_counter()
    c1 = time.process_time()
    sim.do_step()
    c2 = time.process_time()
    r2 = time.perf_counter()
    return r2 - r1, r2 - r0, c2 - c1


def _pair_keys(pos: np.ndarray, radius: np.ndarray) -> np.ndarray:
    pairs = overlapping_pairs(pos, radius, OVERLAP_TOL)
    return pairs[:, 0] * pos.shape[0] + pairs[:, 1]


def _one_step(state: CrowdState, goals: np.ndarray, steering: Steering, radius: np.ndarray,
              is_user: np.ndarray, vel_out: np.ndarray, sim: Any, rvo_pos: np.ndarray, agents: int,
              ours_pairs: set[int], rvo_pairs: set[int],
              ) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """One step of each; returns pedvr's (core, contact, end to end) and RVO2's (core, end to end), s."""
    t0 = time.perf_counter()
    state.pref_vel = _pref_velocities(state.pos, goals)
    t1 = time.perf_counter()
    v = steering.compute_velocities(state, DT, out=vel_out)
    before = state.pos
    state.pos = state.pos + v * DT
    t2 = time.perf_counter()
    state.pos = steering.resolve_contacts(state.pos, radius, is_user)
    state.vel = (state.pos - before) / DT  # what the simulation's decoupled condition does
    t3 = time.perf_counter()
    ours_pairs.update(_pair_keys(state.pos, radius).tolist())
    rvo = (0.0, 0.0)
    if sim is not None:
        core, e2e, _ = rvo2_step(sim, _pref_velocities(rvo_pos, goals))
        rvo = (core, e2e)
        for i in range(agents):
            rvo_pos[i] = sim.get_agent_position(i).to_tuple()
        rvo_pairs.update(_pair_keys(rvo_pos, radius).tolist())
    return (t2 - t1, t3 - t2, t3 - t0), rvo


def crossing_steps(agents: int) -> int:
    """Steps for the front of the crowd to reach the centre, plus 200 steps of jam."""
    return int(math.ceil(circle_radius(agents) / (PREF_SPEED * DT))) + 200


def run_steering_bench(agents: int, *, vs_rvo2: bool, steps: int | None = None, seed: int = 0,
                       threads: int | None = None, warmup_steps: int = 5, load: int = 0) -> dict[str, object]:
    """Run the antipodal-circle benchmark and return the figures (see module doc).

    ``steps`` defaults to :func:`crossing_steps` (the approach and the central
    jam, where ORCA's dense case dominates). ``threads`` sets
    ``numba.set_num_threads`` (default: numba's current setting). ``seed``
    jitters start positions by up to 1 mm (the circle is otherwise perfectly
    symmetric). ``vs_rvo2=False`` skips pyrvo (its keys
    are then None). ``load`` busy processes (:mod:`pedvr.benchload`) run beside
    the timed steps (not the warm-up), as a renderer and a compositor would.
    """
    if agents < 2:
        raise ValueError(f"agents = {agents}: must be >= 2")
    if steps is None:
        steps = crossing_steps(agents)
    if threads is not None:
        numba.set_num_threads(int(threads))
    rng = np.random.default_rng(seed)
    big_r = circle_radius(agents)
    ang = 2.0 * math.pi * np.arange(agents) / agents
    start = big_r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    start += rng.uniform(-1e-3, 1e-3, start.shape)
    start = start.astype(np.float32).astype(np.float64)  # same start for both
    goals = -start

    params = SteeringParams(neighbor_dist=NEIGHBOR_DIST, max_neighbors=MAX_NEIGHBORS,
                            time_horizon=TIME_HORIZON, time_horizon_obst=TIME_HORIZON,
                            user_responsibility=0.5)
    steering = Steering(params, ObstacleSet.empty(), coupled=False)
    radius = np.full(agents, RADIUS)
    is_user = np.zeros(agents, np.bool_)

    # Warm numba up (compilation / cache load of both twins) on a throwaway copy.
    warm = _crowd(start)
    for k in range(max(warmup_steps, 2)):
        with forcing(k % 2 == 0):
            warm.pref_vel = _pref_velocities(warm.pos, goals)
            v = steering.compute_velocities(warm, DT)
            warm.vel = v
            warm.pos = steering.resolve_contacts(warm.pos + v * DT, radius, is_user)
    _pair_keys(warm.pos, radius)

    sim = None
    if vs_rvo2:
        sim = rvo2_simulator(params, DT, start, radius, np.full(agents, MAX_SPEED))

    state = _crowd(start)
    vel_out = np.empty((agents, 2))
    ours_core = ours_e2e = ours_contact = 0.0
    rvo_core = rvo_e2e = 0.0
    ours_steps: list[float] = []
    rvo_steps: list[float] = []
    ours_pairs: set[int] = set()
    rvo_pairs: set[int] = set()
    rvo_pos = start.copy()
    with cpu_load(load) as busy:
        for _ in range(steps):
            o, r = _one_step(state, goals, steering, radius, is_user, vel_out, sim, rvo_pos, agents,
                             ours_pairs, rvo_pairs)
            ours_core += o[0]
            ours_contact += o[1]
            ours_e2e += o[2]
            ours_steps.append(o[0])
            rvo_core += r[0]
            rvo_e2e += r[1]
            rvo_steps.append(r[0])
    ms = 1000.0 / steps
    result: dict[str, object] = {
        "agents": agents,
        "steps": steps,
        **busy.describe(),
        "circle_radius_m": big_r,
        "threads": numba.get_num_threads(),
        "machine": f"{platform.processor() or platform.machine()} / {os.cpu_count()} cpus",
        "pedvr_ms_per_step": ours_core * ms,
        "pedvr_p95_ms": float(np.percentile(ours_steps, 95)) * 1e3,
        "pedvr_contact_ms_per_step": ours_contact * ms,
        "pedvr_end_to_end_ms_per_step": ours_e2e * ms,
        "pedvr_overlaps_over_1cm": len(ours_pairs),
        "rvo2_ms_per_step": rvo_core * ms if sim is not None else None,
        "rvo2_p95_ms": float(np.percentile(rvo_steps, 95)) * 1e3 if sim is not None else None,
        "rvo2_end_to_end_ms_per_step": rvo_e2e * ms if sim is not None else None,
        "rvo2_overlaps_over_1cm": len(rvo_pairs) if sim is not None else None,
        "ratio": (ours_core / rvo_core) if sim is not None and rvo_core > 0 else None,
        "mean_speed_end": float(np.sqrt((state.vel ** 2).sum(axis=1)).mean()),
    }
    return result
