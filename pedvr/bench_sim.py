"""Whole-step benchmark (issue 12): ``Simulation.step()`` with full bodies on a generated plaza.

``pedvr bench sim --agents N [--load K] --json``. The scene (:func:`plaza_scene`) is an open square
sized for about ``DENSITY`` agents per m² with four pillars; ``N`` agents walk between random points
of the square (goal selector ``region``, a new goal on each arrival) and the user crosses it on its
diagonals, scripted. The condition is ``pedvr+g`` (coupled steering, full bodies, gaze on): every
phase runs, sense to record. The first ``warmup`` steps (numba compilation and cache loads, the crowd
mixing from its spawn) are not timed; then ``steps`` steps are, with ``load`` busy processes beside
them (:mod:`pedvr.benchload`).

Reported per step, in ms: ``step_ms_p50`` / ``p95`` / ``mean`` of the whole step; ``phase_ms_mean``
per named phase; and inside ``animate``, the crowd's contact pass (``contact_ms_mean``, the
steering layer's) apart from the body layer (``body_ms_mean``: root motion, gait, choreographers,
blend, IK, forward kinematics, skate meter; ``body_ms_p95``), with ``gaze_rule_ms_mean`` (the body's
PedVR gaze rule, timed inside ``decide``) and the renderer's bone matrices
(``joint_matrices_ms_mean``, not part of the step). ``step_cpu_ms_mean`` and ``body_cpu_ms_mean``
are this process's CPU time (all its threads) per step and in the body layer: on a shared machine
they tell what the work costs when the wall times mostly tell how long it waited for a core.

``--vs rvo2`` (issue 27) also steps RVO2 (pyrvo, :func:`pedvr.crowd.bench.rvo2_simulator`) on the
same crowd in the same loop: after each timed ``Simulation.step()``, RVO2's agents are set to the
crowd's positions, velocities and preferred velocities (untimed), with the scene's ORCA parameters,
each agent's radius and maximum speed, and the plaza's walls and pillars as RVO2 obstacles (the
outline pedvr's ORCA sees); then RVO2's ``do_step`` is timed (:func:`pedvr.crowd.bench.rvo2_step`:
its k-d trees, neighbours, ORCA, position update; steering only, no bodies). RVO2's result is thrown
away, so each step it steers exactly the crowd pedvr steers. Reported: ``rvo2_step_ms_p50`` / ``p95``
/ ``mean``, ``rvo2_cpu_ms_mean`` and the ratios of pedvr's whole step to it (``ratio_p50``,
``ratio_mean``, ``ratio_cpu``), with ``p95_over_p50`` for pedvr's step.
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from pedvr.benchload import check_load, cpu_load
from pedvr.crowd.bench import rvo2_simulator, rvo2_step
from pedvr.errors import UsageError
from pedvr.scene.config import SceneConfig
from pedvr.scene.loader import parse_scene
from pedvr.sim import PHASES, Simulation
from pedvr.world.geometry import rvo_rings, walkable_area

DENSITY = 0.2  # agents per m² of the plaza
MIN_SIDE = 16.0  # m
PEERS = ("rvo2",)
RVO2_WARMUP = 3  # RVO2 steps before the timed ones (its first builds the obstacle tree's caches)


def plaza_scene(agents: int, *, seed: int = 0) -> SceneConfig:
    """The generated plaza for ``agents`` agents (validated like any scene file)."""
    if isinstance(agents, bool) or not isinstance(agents, int) or agents < 1:
        raise UsageError(f"--agents {agents!r}: expected a whole number of agents >= 1")
    half = 0.5 * max(MIN_SIDE, math.sqrt(agents / DENSITY))
    inner = half - 1.0
    p = 0.35 * half
    data: dict[str, Any] = {
        "scene": {"name": f"plaza_{agents}", "seed": seed, "duration": 60.0,
                  "description": f"{agents} agents walk between random points of a {2 * half:.0f} m square"},
        "world": {"bounds": [[-half, -half], [half, half]],
                  "obstacles": [{"kind": "pillar", "circle": [x, y, 0.4], "height": 3.0}
                                for x in (-p, p) for y in (-p, p)]},
        "agents": {"profiles": {"adult": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6}},
                   "spawns": [{"profile": "adult", "state": "walk", "count": agents,
                               "region": {"box": [-inner, -inner, inner, inner]}}]},
        "behavior": {"states": {"walk": {
            "goal": {"selector": "region", "box": [-inner, -inner, inner, inner]},
            "transitions": [{"on": "arrival", "to": "walk"}]}}},
        "user": {"start": [-inner, -inner], "heading_deg": 45.0,
                 "route": [[inner, inner], [inner, -inner], [-inner, inner], [-inner, -inner]]},
    }
    return parse_scene(data, source=f"<plaza {agents}>")


class _Timer:
    """Wraps a callable and accumulates its wall and CPU time (bench instrumentation only)."""

    def __init__(self, fn: Callable[..., Any]) -> None:
        self.fn = fn
        self.total = 0.0
        self.last = 0.0
        self.cpu = 0.0

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.last = time.perf_counter() - t0
            self.total += self.last
            self.cpu += time.process_time() - c0


class _Rvo2Mirror:
    """RVO2 on the simulation's crowd (see the module doc): :meth:`step` sets it to the crowd and
    times one RVO2 step."""

    def __init__(self, sim: Simulation) -> None:
        c = sim.crowd
        self.sim = sim
        self.rvo = rvo2_simulator(sim.scene.steering, sim.dt, c.pos, c.radius, c.max_speed,
                                  rvo_rings(walkable_area(sim.scene.world)))
        self.ms: list[float] = []
        self.cpu = 0.0
        for _ in range(RVO2_WARMUP):
            self.step()
        self.ms.clear()
        self.cpu = 0.0

    def step(self) -> None:
        c, rvo = self.sim.crowd, self.rvo
        if len(c) != rvo.get_num_agents():  # the plaza has no sources or sinks
            raise RuntimeError(f"the crowd has {len(c)} agents, RVO2 {rvo.get_num_agents()}")
        pos, vel = c.pos.tolist(), c.vel.tolist()
        for i in range(len(c)):
            rvo.set_agent_position(i, tuple(pos[i]))
            rvo.set_agent_velocity(i, tuple(vel[i]))
        core, _, cpu = rvo2_step(rvo, c.pref_vel)
        self.ms.append(1e3 * core)
        self.cpu += cpu


def run_sim_bench(agents: int, *, steps: int = 450, warmup: int = 180, load: int = 0,
                  seed: int = 0, vs: str | None = None) -> dict[str, object]:
    """Time ``steps`` whole simulation steps of the plaza; returns a JSON-able dict (ms).
    ``vs="rvo2"``: RVO2 steers the same crowd in the same loop (module doc)."""
    check_load(load)
    if vs is not None and vs not in PEERS:
        raise UsageError(f"--vs {vs!r}: expected one of {', '.join(PEERS)}")
    for name, v, lo in (("--steps", steps, 1), ("--warmup", warmup, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise UsageError(f"{name} {v!r}: expected a whole number >= {lo}")
    scene = plaza_scene(agents, seed=seed)
    t0 = time.perf_counter()
    sim = Simulation(scene, condition="pedvr+g")
    setup_s = time.perf_counter() - t0
    contact = _Timer(sim.steering.resolve_contacts)
    sim.steering.resolve_contacts = contact  # type: ignore[method-assign]
    body_parts = [_Timer(sim.body.animate), _Timer(sim.body.compose)]
    sim.body.animate, sim.body.compose = body_parts  # type: ignore[method-assign]
    gaze = _Timer(sim.body.gaze_rule)
    sim.body.gaze_rule = gaze  # type: ignore[method-assign]
    for _ in range(warmup):
        sim.step()
    peer = _Rvo2Mirror(sim) if vs == "rvo2" else None
    n_before = len(sim.metrics.step_ms)
    phases_before = dict(sim.metrics.phase_ms)
    for tm in (contact, gaze, *body_parts):
        tm.total = tm.cpu = 0.0
    body_steps: list[float] = []
    mats = np.empty((len(sim.crowd), 26, 4, 4), np.float32)
    mat_total = 0.0
    cpu = 0.0
    with cpu_load(load) as running:
        for _ in range(steps):
            c0 = time.process_time()
            sim.step()
            cpu += time.process_time() - c0
            body_steps.append(body_parts[0].last + body_parts[1].last)
            if mats.shape[0] != len(sim.crowd):
                mats = np.empty((len(sim.crowd), 26, 4, 4), np.float32)
            m0 = time.perf_counter()
            sim.body.joint_matrices(mats)
            mat_total += time.perf_counter() - m0
            if peer is not None:
                peer.step()
    ms = np.asarray(sim.metrics.step_ms[n_before:])
    phase = {k: round((sim.metrics.phase_ms.get(k, 0.0) - phases_before.get(k, 0.0)) / steps, 4)
             for k in PHASES}
    summary = sim.summary()
    p50 = float(np.percentile(ms, 50))
    versus: dict[str, object] = {}
    if peer is not None:
        rv = np.asarray(peer.ms)
        rv50 = float(np.percentile(rv, 50))
        versus = {
            "vs": vs, "rvo2_step_ms_p50": round(rv50, 4),
            "rvo2_step_ms_p95": round(float(np.percentile(rv, 95)), 4),
            "rvo2_step_ms_mean": round(float(rv.mean()), 4),
            "rvo2_cpu_ms_mean": round(1e3 * peer.cpu / steps, 4),
            "ratio_p50": round(p50 / rv50, 3), "ratio_mean": round(float(ms.mean() / rv.mean()), 3),
            "ratio_cpu": round(cpu / peer.cpu, 3) if peer.cpu > 0 else None,
        }
    return {
        "bench": "sim", "scene": scene.name, "agents": agents, "condition": "pedvr+g", "steps": steps,
        "warmup": warmup, "dt": sim.dt, "setup_s": round(setup_s, 3),
        "step_ms_p50": round(p50, 4),
        "step_ms_p95": round(float(np.percentile(ms, 95)), 4),
        "step_ms_mean": round(float(ms.mean()), 4),
        "p95_over_p50": round(float(np.percentile(ms, 95)) / p50, 3),
        "step_cpu_ms_mean": round(1e3 * cpu / steps, 4),
        "phase_ms_mean": phase,
        "contact_ms_mean": round(1e3 * contact.total / steps, 4),
        "body_ms_mean": round(1e3 * sum(t.total for t in body_parts) / steps, 4),
        "body_ms_p95": round(1e3 * float(np.percentile(body_steps, 95)), 4),
        "body_cpu_ms_mean": round(1e3 * sum(t.cpu for t in body_parts) / steps, 4),
        "gaze_rule_ms_mean": round(1e3 * gaze.total / steps, 4),
        "joint_matrices_ms_mean": round(1e3 * mat_total / steps, 4),
        "foot_skate_max_m": summary["foot_skate_max_m"], "overlaps_over_1cm": summary["overlaps_over_1cm"],
        **versus,
        **running.describe(),
        "threads": numba.get_num_threads(), "threading_layer": _threading_layer(),
        "machine": platform.machine(), "python": platform.python_version(), "numba": numba.__version__,
    }


def _threading_layer() -> str:
    try:
        return str(numba.threading_layer())
    except ValueError:  # no parallel kernel has run yet
        return "none"
