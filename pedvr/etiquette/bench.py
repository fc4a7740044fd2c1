"""Door etiquette benchmark (issue 14): ``pedvr bench doors [--agents N ...] --json``.

The scene is the shipped ``door_building`` (Huang & Terzopoulos §6, Fig. 2(f): four rooms joined
by four sprung one-way doors, pedestrians going from room to room indefinitely) with its sixteen
pedestrians, or ``N`` of them (each of its four spawns gets ``N / 4``, the rest to the first ones).
The condition is ``pedvr+g``: full bodies, gaze, the etiquette layer (ordering, App. B states,
App. C steps, hands on leaves), the doors' mechanics and every other phase. The first ``warmup``
steps (numba compilation, cache loads) are not timed; then ``steps`` are.

Reported per step, in ms: ``step_ms_p50`` / ``p95`` / ``mean`` of the whole step, ``phase_ms_mean``
per named phase, and ``etiquette_ms_mean`` (the etiquette layer's own calls: its 30 Hz decision
tick, steering, faces, hands and the door step it wraps are in the phases). The paper ran 16
pedestrians at about 50 fps including rendering on a 3.33 GHz Xeon; the goal here is
16 pedestrians <= 1 ms per step and 64 <= 3 ms (without rendering).
"""

from __future__ import annotations

import dataclasses
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from pedvr.errors import UsageError
from pedvr.scene.config import SceneConfig
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import PHASES, Simulation

SCENE = "door_building"


def building_scene(agents: int) -> SceneConfig:
    """``door_building`` with ``agents`` pedestrians spread over its four spawns."""
    if isinstance(agents, bool) or not isinstance(agents, int) or agents < 1:
        raise UsageError(f"--agents {agents!r}: expected a whole number of pedestrians >= 1")
    scene = load_scene(resolve_scene(SCENE))
    n = len(scene.spawns)
    counts = [agents // n + (1 if i < agents % n else 0) for i in range(n)]
    spawns = tuple(dataclasses.replace(s, count=c)
                   for s, c in zip(scene.spawns, counts, strict=True) if c > 0)
    return dataclasses.replace(scene, spawns=spawns)


class _Timer:
    def __init__(self, fn: Callable[..., Any]) -> None:
        self.fn = fn
        self.total = 0.0

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.total += time.perf_counter() - t0


def run_doors_bench(agents: int, *, steps: int = 900, warmup: int = 300) -> dict[str, object]:
    """Time ``steps`` whole steps of the building with ``agents`` pedestrians (module docstring)."""
    for name, v, lo in (("--steps", steps, 1), ("--warmup", warmup, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise UsageError(f"{name} {v!r}: expected a whole number >= {lo}")
    scene = building_scene(agents)
    t0 = time.perf_counter()
    sim = Simulation(scene, condition="pedvr+g")
    setup_s = time.perf_counter() - t0
    et = sim.etiquette
    assert et is not None  # the building has doors and etiquette on
    timers = []
    for name in ("decide", "steer", "face", "carry", "before_doors", "after_doors", "auto_open", "carried",
                 "engaged_with_user", "user_reach"):
        tm = _Timer(getattr(et, name))
        setattr(et, name, tm)
        timers.append(tm)
    for _ in range(warmup):
        sim.step()
    n_before = len(sim.metrics.step_ms)
    phases_before = dict(sim.metrics.phase_ms)
    for tm in timers:
        tm.total = 0.0
    for _ in range(steps):
        sim.step()
    ms = np.asarray(sim.metrics.step_ms[n_before:])
    phase = {k: round((sim.metrics.phase_ms.get(k, 0.0) - phases_before.get(k, 0.0)) / steps, 4)
             for k in PHASES}
    s = sim.summary()
    return {
        "bench": "doors", "scene": SCENE, "agents": agents, "condition": "pedvr+g", "steps": steps,
        "warmup": warmup, "dt": sim.dt, "setup_s": round(setup_s, 3),
        "step_ms_p50": round(float(np.percentile(ms, 50)), 4),
        "step_ms_p95": round(float(np.percentile(ms, 95)), 4),
        "step_ms_mean": round(float(ms.mean()), 4),
        "phase_ms_mean": phase,
        "etiquette_ms_mean": round(1e3 * sum(t.total for t in timers) / steps, 4),
        "door_passages": s["door_passages"], "door_holds": s["door_holds"],
        "door_deadlocks": s["door_deadlocks"],
        "overlaps_over_1cm": s["overlaps_over_1cm"], "door_leaf_overlap_max_m": s["door_leaf_overlap_max_m"],
        "machine": platform.machine(), "python": platform.python_version(),
    }
