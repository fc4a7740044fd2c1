"""``pedvr bench behavior``: the scheduler's tick for a crowd with personal trees and running events.

Scenario (a generated 50 × 50 m plaza with eight pillars, coupled condition,
bodies on, the user standing in the middle): ``agents`` agents each run the
personal tree :data:`WANDER` (18 nodes: walk to a random point or a spot, wait
or gesture, look at the user when near, pause) from a BFSM state, and
``events`` ADAPT conversations (Fig. 7, two more agents each, walking to a
meeting point, facing, gazing, taking turns gesturing) are kept running: one
that ends is replaced by a new one between steps. Every decision tick (30 Hz)
the time of :meth:`Scheduler.tick` is taken: objects, personal-tree sync,
triggers, event starts and the ticks of every awake tree, including the body
capability calls the leaves make (a ``go_to`` plans its path there). The
first ``warmup`` seconds are not timed. Wall time and the thread's CPU time
are both reported: on a shared machine the wall-time tail is other
processes' turns, not the tick's work.
"""

from __future__ import annotations

import os
import platform
import time
from typing import Any

import numpy as np

from pedvr.behavior.nodes import node_types
from pedvr.scene.loader import parse_scene
from pedvr.sim import Simulation

HALF = 25.0  # m: the plaza is [-HALF, HALF]²
WANDER: dict[str, Any] = {"repeat": {"sequence": [
    {"random": [
        {"sequence": [{"go_to": "me", "to": {"region": [-22.0, -22.0, 22.0, 22.0]}, "max_time": 40.0},
                      {"wait": [1.0, 3.0]}]},
        {"sequence": [{"go_to": "me", "to": {"goal_set": "spots"}, "arrive": 1.0, "max_time": 40.0},
                      {"gesture": "me", "clip": ["check_phone", "point"], "seconds": [1.5, 3.0]}]},
    ], "weights": [3.0, 1.0]},
    {"selector": [
        {"sequence": [{"near": "me", "of": "user", "within": 4.0},
                      {"gaze_at": "me", "at": "user", "seconds": 1.5}]},
        {"invert": {"moving": "me", "above": 2.5}},
    ], "memory": True},
    {"succeed": {"timeout": {"wait": [0.5, 4.0]}, "seconds": 3.0}},
]}}


def _count(node: Any) -> int:
    """Nodes in a tree written in the scene format."""
    if isinstance(node, dict):
        return (1 if any(k in node_types for k in node) else 0) + sum(_count(v) for v in node.values())
    if isinstance(node, list):
        return sum(_count(v) for v in node)
    return 0


def _stats(prefix: str, ms: list[float]) -> dict[str, float]:
    a = np.asarray(ms)
    return {f"{prefix}_p50": round(float(np.percentile(a, 50)), 4),
            f"{prefix}_p95": round(float(np.percentile(a, 95)), 4),
            f"{prefix}_mean": round(float(a.mean()), 4)}


def plaza(agents: int, talkers: int, *, seed: int = 0) -> dict[str, Any]:
    """The bench scene as a parsed-TOML document."""
    pillars = [{"kind": "pillar", "circle": [x, y, 0.4]}
               for x in (-12.0, 12.0) for y in (-12.0, -4.0, 4.0, 12.0)]
    # talkers in pairs 2 m apart, pair centres 4 m apart in rows clear of the pillars
    centres = [(x, y) for y in (0.0, -8.0, 8.0, -16.0, 16.0, -20.0, 20.0) for x in range(-18, 19, 4)]
    if talkers > len(centres):
        raise ValueError(f"at most {len(centres)} conversations fit the plaza")
    pairs = [([float(x) - 1.0, y], [float(x) + 1.0, y]) for x, y in centres[:talkers]]
    spawns: list[dict[str, Any]] = [{"profile": "walker", "state": "wander", "count": agents,
                                     "region": {"box": [-22.0, -22.0, 22.0, 22.0]}}]
    if pairs:
        spawns.append({"profile": "walker", "state": "stand", "positions": [q for pr in pairs for q in pr]})
    return {
        "scene": {"name": "behavior_bench", "seed": seed, "duration": 60.0},
        "world": {"bounds": [[-HALF, -HALF], [HALF, HALF]], "obstacles": pillars},
        "agents": {"profiles": {"walker": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6}},
                   "spawns": spawns},
        "behavior": {
            "goal_sets": {"spots": {"points": [[-18.0, -18.0], [18.0, -18.0], [-18.0, 18.0], [18.0, 18.0],
                                               [0.0, 18.0], [0.0, -18.0]]}},
            "states": {"wander": {"goal": {"selector": "stay"}, "tree": "wander"},
                       "stand": {"goal": {"selector": "stay"}}},
            "trees": {"wander": {"params": {"me": "agent"}, "root": WANDER}},
            "events": {"chat": {"tree": "conversation", "priority": 1}},
        },
        "user": {"start": [0.0, 0.0]},
    }


def run_behavior_bench(agents: int = 200, *, events: int = 20, seconds: float = 20.0, warmup: float = 5.0,
                       seed: int = 0) -> dict[str, object]:
    """Time the scheduler's tick; returns a JSON-able dict (ms per decision tick)."""
    doc = plaza(agents, events, seed=seed)
    sim = Simulation(parse_scene(doc, source="<behavior bench>"), seed=seed, condition="pedvr")
    sch = sim.scheduler
    talkers = [int(i) for i in sim.crowd.ids[~sim.crowd.is_user][agents:]]
    pairs = [(talkers[2 * k], talkers[2 * k + 1]) for k in range(events)]
    times: list[float] = []
    cpu: list[float] = []
    awake: list[int] = []
    running: list[int] = []
    tick = sch.tick

    def timed(t: float) -> list[int]:
        t0, c0 = time.perf_counter(), time.thread_time()
        out = tick(t)
        if sim.t >= warmup:
            times.append((time.perf_counter() - t0) * 1e3)
            cpu.append((time.thread_time() - c0) * 1e3)
            awake.append(sch.ticked)
            running.append(sum(1 for r in sch.live if r.phase == "running"))
        return out

    sch.tick = timed  # type: ignore[method-assign]
    live: dict[int, Any] = {}
    step_ms: list[float] = []
    while sim.t < warmup + seconds:
        for k, (a, b) in enumerate(pairs):  # keep every conversation going
            run = live.get(k)
            if run is None or run.phase == "ended":
                pa, pb = sim.crowd.pos[sim.crowd.index_of(a)], sim.crowd.pos[sim.crowd.index_of(b)]
                spot = sim.goal_mesh.nearest_walkable(tuple((pa + pb) / 2.0))
                live[k] = sch.start_event("chat", {"a": a, "b": b, "spot": spot})
        t0 = time.perf_counter()
        sim.step()
        if sim.t >= warmup:
            step_ms.append((time.perf_counter() - t0) * 1e3)
    return {
        "agents": agents, "personal_tree_nodes": _count(WANDER), "events": events,
        "events_running_mean": round(float(np.mean(running)), 2) if running else 0.0,
        "ticks": len(times), "seconds": seconds,
        **_stats("tick_ms", times), "tick_ms_max": round(max(times), 4),
        # CPU time of the tick's thread: what the tick costs, without the waits of a shared machine
        **_stats("tick_cpu_ms", cpu),
        "trees_ticked_mean": round(float(np.mean(awake)), 1),
        "trees_total": agents + events,
        "sim_step_ms_p50": round(float(np.percentile(step_ms, 50)), 3),
        "events_succeeded": sch.counts["events_succeeded"],
        "loadavg_1min": round(os.getloadavg()[0], 2), "python": platform.python_version(),
        "machine": platform.machine(), "cpus": os.cpu_count(),
    }
