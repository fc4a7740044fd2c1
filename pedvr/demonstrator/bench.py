"""``pedvr bench place``: PLACE's planning time per demonstration, and what a running simulation feels of it.

For each scene (``place_table``, the paper's table; ``gallery``) a fixed set
of queries is drawn with a seeded generator: an exhibit of the scene, an
observer on a walkable point 1.5–5 m from it, a demonstrator start 2–10 m
away. Each query is planned the way a demonstration plans it and timed
part by part:

``search``  candidate search and ranking (§4): 72 frame orientations around the target,
            perturbations, validity (collision, reachability by the mesh's connected parts,
            the arm, the 3D sight line through partial occluders, eye contact), sorting;
``path``    the path with clearance to the chosen placement (§5's locomotion plan:
            ``NavMesh.find_path``);
``hand``    the action's hand trajectory with §6's obstacle avoidance;
``plan``    all three: the whole plan of one demonstration (the paper: 100–400 ms; goal 20 ms).

``placed`` counts the queries with a placement, ``placed_widened`` those of them the model
pass could not serve (the wide pass found one), ``placed_fallback`` those placed off the
model (:class:`~pedvr.demonstrator.placement.PlacementSearch`).

In a simulation the search is spread over behavior ticks
(:data:`pedvr.demonstrator.demonstration.PLAN_BUDGET` orientations a tick):
``slice`` is the time of one such tick's share, the most a decision tick
ever spends planning. Then ``sim``: the scene runs headless for
``seconds`` with its demonstrations, and the step times are reported beside
those of the same scene with its demonstrations removed (``sim_base``), so
the cost the frame loop sees is measured, not inferred. Wall-clock times
with ``time.perf_counter``; the machine is what it is (the load average is
printed with the results).
"""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import time
from typing import Any

import numpy as np

from pedvr.behavior.spec import NodeSpec
from pedvr.body.skeleton import user_dims
from pedvr.demonstrator.arm import Action, hand_path, preferred_distance
from pedvr.demonstrator.demonstration import PLAN_BUDGET, Exhibit
from pedvr.demonstrator.placement import Observer, PlacementSearch
from pedvr.demonstrator.stage import Figure, Stage
from pedvr.scene.config import BehaviorConfig, SceneConfig
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

SCENES = ("place_table", "gallery")


def _stats(prefix: str, ms: list[float]) -> dict[str, float]:
    a = np.asarray(ms)
    return {f"{prefix}_ms_p50": round(float(np.percentile(a, 50)), 4),
            f"{prefix}_ms_p95": round(float(np.percentile(a, 95)), 4),
            f"{prefix}_ms_max": round(float(a.max()), 4),
            f"{prefix}_ms_mean": round(float(a.mean()), 4)}


def _queries(scene: SceneConfig, stage: Stage, n: int, rng: np.random.Generator) -> list[tuple[Any, ...]]:
    exhibits = [o for o in scene.behavior.objects if o.kind == "exhibit"]
    mesh = stage.mesh
    out: list[tuple[Any, ...]] = []
    tries = 0
    while len(out) < n and tries < 200 * n:
        tries += 1
        ex = exhibits[int(rng.integers(len(exhibits)))]
        a, r = rng.uniform(-math.pi, math.pi), rng.uniform(1.5, 5.0)
        obs = (ex.at[0] + r * math.cos(a), ex.at[1] + r * math.sin(a))
        a, r = rng.uniform(-math.pi, math.pi), rng.uniform(2.0, 10.0)
        start = (ex.at[0] + r * math.cos(a), ex.at[1] + r * math.sin(a))
        if mesh.contains(obs) and mesh.contains(start) and mesh.same_component(obs, start):
            out.append((ex, obs, start))
    return out


def run_place_bench(scene_name: str, *, queries: int = 200, seconds: float = 30.0,
                    seed: int = 7) -> dict[str, Any]:
    """Time ``queries`` plans on a shipped scene, then a headless run with and without its demonstrations."""
    scene = load_scene(resolve_scene(scene_name))
    sim = Simulation(scene)
    stage = Stage(scene.world, sim.goal_mesh)
    figure = Figure.of_dims(user_dims(1)[0], max(p.radius for p in scene.profiles.values()))
    rng = np.random.default_rng(seed)
    qs = _queries(scene, stage, queries, rng)
    parts: dict[str, list[float]] = {"search": [], "path": [], "hand": [], "plan": [], "slice": []}
    found = widened = fallback = 0
    candidates = valid = 0
    for k, (ex, obs, start) in enumerate([qs[0], *qs]):  # the first query again untimed: warm-up
        height = float(ex.params.get("height", 0.0)) or None
        sup = stage.support(ex.at)
        h = height if height is not None else (float(stage.height[sup]) + 0.1 if sup is not None else 1.0)
        kind = str(ex.params.get("action", "point"))
        size = float(ex.params.get("size", 0.1))
        act = Action(kind, ex.at, h, preferred_distance(kind, figure, height=h, size=size,
                                                        d_pref=ex.params.get("d_pref")))
        t0 = time.perf_counter()
        search = PlacementSearch(stage, figure, act, Observer(obs), start=start, default_zeta=ex.facing)
        slices = []
        while True:
            s0 = time.perf_counter()
            done = search.advance(PLAN_BUDGET)
            slices.append(time.perf_counter() - s0)
            if done:
                break
        t1 = time.perf_counter()
        best = search.plan.best
        if best is not None:
            stage.mesh.find_path(start, best.pos)
        t2 = time.perf_counter()
        if best is not None:
            hand_path(stage, figure, pos=best.pos, heading=best.heading, stroke=best.stroke)
        t3 = time.perf_counter()
        if k == 0:
            continue
        found += best is not None
        widened += best is not None and search.plan.widened and not search.plan.fallback
        fallback += best is not None and search.plan.fallback
        candidates += search.plan.candidates
        valid += len(search.plan.ranked)
        parts["search"].append((t1 - t0) * 1e3)
        parts["path"].append((t2 - t1) * 1e3)
        parts["hand"].append((t3 - t2) * 1e3)
        parts["plan"].append((t3 - t0) * 1e3)
        parts["slice"] += [x * 1e3 for x in slices]
    out: dict[str, Any] = {"bench": "place", "scene": scene_name, "queries": len(qs), "placed": found,
                           "placed_widened": widened, "placed_fallback": fallback,
                           "valid_per_query": round(valid / max(len(qs), 1), 2),
                           "candidates_per_query": round(candidates / max(len(qs), 1), 2)}
    for name, ms in parts.items():
        out.update(_stats(name, ms))
    # the frame loop's view: step times with and without the scene's demonstrations
    for key, cfg in (("sim", scene), ("sim_base", _without_demonstrations(scene))):
        run = Simulation(cfg)
        run.advance_to(1.0)  # warm-up (numba caches, first plans)
        run.metrics.step_ms.clear()
        run.advance_to(1.0 + seconds)
        out.update(_stats(f"{key}_step", run.metrics.step_ms))
        if key == "sim":  # demonstrations that ran (finished, or still running at the end)
            ex = [o for o in run.scheduler.objects.values() if isinstance(o, Exhibit)]
            out["sim_demonstrations"] = sum(len(o.log) + len(o.active) for o in ex)
            out["sim_strokes"] = sum(len(e["t_stroke"]) for o in ex for e in o.log)
    out["sim_seconds"] = seconds
    out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    out["machine"] = f"{platform.machine()} {os.cpu_count()} cpus"
    return out


def _without_demonstrations(scene: SceneConfig) -> SceneConfig:
    """The scene with the same agents and walks but no demonstrations: its guide's state tree,
    the triggers and the exhibits removed (the baseline of the step-time comparison)."""
    b = scene.behavior
    states = {n: dataclasses.replace(s, tree=None) if s.tree is not None and s.tree in b.trees and
              _demonstrates(b, s.tree) else s for n, s in b.states.items()}
    objects = tuple(o for o in b.objects if o.kind != "exhibit")
    behavior = BehaviorConfig(states=states, goal_sets=b.goal_sets, decision_hz=b.decision_hz, trees=b.trees,
                              events=b.events, objects=objects, triggers=())
    return dataclasses.replace(scene, behavior=behavior)


def _demonstrates(b: BehaviorConfig, tree: str) -> bool:
    def walk(spec: NodeSpec) -> bool:
        if spec.kind == "demonstrate":
            return True
        kids = spec.main if isinstance(spec.main, tuple) else (spec.main,)
        return any(walk(k) for k in kids if isinstance(k, NodeSpec))

    return walk(b.trees[tree].root)
