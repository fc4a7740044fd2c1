"""SteerBench scores of one run, as SteerSuite computes them (Singh, Kapadia, Faloutsos, Reinman 2009).

The definition implemented is SteerSuite's own code (``steerlib/src/
AgentMetricsCollector.cpp``, ``CompositeTechnique01.cpp``, ``CompositeTechnique02.cpp``),
per agent, per frame, at SteerSuite's default fixed frame rate of 20 frames per
second (``fixedFPS`` 20 in its configuration):

* **collisions**: unique collisions, i.e. episodes: an agent starts a collision
  with another object (agent or obstacle) on the first frame its disc
  penetrates that object by more than ``COLLISION_EPSILON`` = 0.001 m, and a new
  one after it has come apart. An agent–agent episode counts once for each of
  the two agents (each has its own collector), an agent–obstacle episode once.
* **time**: ``totalTimeEnabled``, the seconds the agent was active: until it
  reached its last goal (pedvr removes it there, as SteerSuite disables it) or
  the run ended.
* **path length**: ``totalDistanceTraveled``, the sum of the frame-to-frame
  displacements.
* **kinetic energy**: ``sumTotalOfInstantaneousKineticEnergies``, the *sum over
  frames* of ½|v|² (unit mass) with v the frame-to-frame displacement over the
  frame time. SteerSuite notes this is frame-rate dependent; computing it at
  SteerSuite's 20 fps keeps it comparable with published scores.
* **acceleration**: ``sumTotalOfInstantaneousAcceleration``, the sum over frames
  of |Δv| / frame time (the first frame contributes 0).

``composite01 = 50·C̄ + T̄ + Ē`` and ``composite02 = composite01 + Ā``, where
each bar is the total over all agents divided by the number of agents
(SteerSuite's ``getTotalBenchmarkScore``; weights α = 50, β = γ = δ = 1). Lower
is better.

Choices where SteerSuite and pedvr differ (interpretation of SteerBench's
frame-based collector on pedvr's fixed 90 Hz step): pedvr's trajectory is
sampled at 20 fps by linear interpolation between its steps, so every metric,
collisions included, sees the frames SteerSuite would have; a collision shorter
than a frame can be missed, as in SteerSuite (the run's own
``overlaps_over_1cm`` checks every step). The user, in scenes that have one, is
an object agents can collide with but is not scored. Obstacles are the scene's
polygons; the world bounds are not obstacles in SteerSuite and are not counted.
"""

from __future__ import annotations

import numpy as np
import shapely
from scipy.spatial import cKDTree

from pedvr.scene.config import SceneConfig

STEERSUITE_FPS = 20.0
COLLISION_EPSILON = 0.001  # m, SteerSuite's AgentMetricsCollector.h
ALPHA, BETA, GAMMA, DELTA = 50.0, 1.0, 1.0, 1.0  # composite weights (CompositeTechnique01/02 init())


def radii_by_id(scene: SceneConfig, n_ids: int) -> np.ndarray:
    """Each stable id's disc radius, from the scene: the user first (when enabled), then every
    spawned agent in file order, which is the order :class:`pedvr.sim.Simulation` numbers them.

    Raises ValueError when the run has more ids than the scene spawns (agents added during the
    run have no radius here).
    """
    radii: list[float] = [scene.user.radius] if scene.user.enabled else []
    for sp in scene.spawns:
        radii += [scene.profiles[sp.profile].radius] * (sp.count or len(sp.positions))
    if n_ids > len(radii):
        raise ValueError(
            f"steerbench: the run has {n_ids} agents but the scene spawns {len(radii)}; "
            "agents added during a run cannot be scored"
        )
    return np.asarray(radii[:n_ids], np.float64)


def resample(t: np.ndarray, pos: np.ndarray, fps: float = STEERSUITE_FPS) -> np.ndarray:
    """Positions ``(S, A, 2)`` at times ``t (S,)`` → ``(F, A, 2)`` at ``k / fps``; NaN where absent."""
    frames = np.arange(int(np.floor(t[-1] * fps + 1e-9)) + 1) / fps
    i = np.clip(np.searchsorted(t, frames, side="right") - 1, 0, len(t) - 1)
    j = np.minimum(i + 1, len(t) - 1)
    span = t[j] - t[i]
    frac = np.divide(frames - t[i], span, out=np.zeros_like(frames), where=span > 0)
    f = frac[:, None, None]
    return np.where(f > 0, pos[i] + f * (pos[j] - pos[i]), pos[i])  # on a step: that step, absent or not


def steerbench_scores(
    arrays: dict[str, np.ndarray],
    *,
    scene: SceneConfig,
    radius: np.ndarray | None = None,
    fps: float = STEERSUITE_FPS,
) -> dict[str, float | int]:
    """SteerBench per-agent averages and composite scores of a recorded run (see the module docstring).

    ``arrays`` is :meth:`pedvr.record.Recording.arrays`; ``radius`` each id's
    radius (default :func:`radii_by_id`).
    """
    ids, is_user = arrays["ids"], arrays["is_user"]
    rad = radii_by_id(scene, int(ids.max()) + 1)[ids] if radius is None else np.asarray(radius, np.float64)
    p = resample(np.asarray(arrays["t"]), np.asarray(arrays["pos"]), fps)
    scored = np.flatnonzero(~is_user)
    n = scored.size
    if n == 0:
        return {"agents": 0}
    frame = 1.0 / fps
    present = ~np.isnan(p[..., 0])  # (F, A)
    step = present[1:] & present[:-1]  # frame-to-frame updates while enabled
    d = np.where(step[..., None], p[1:] - p[:-1], 0.0)
    v = d / frame
    dist = np.linalg.norm(d, axis=2)
    ke = 0.5 * np.einsum("fai,fai->fa", v, v)
    dv = np.where((step[1:] & step[:-1])[..., None], v[1:] - v[:-1], 0.0)
    acc = np.linalg.norm(dv, axis=2) / frame
    collisions = _unique_collisions(p, present, rad, scene)

    total_c = float(collisions[scored].sum())
    total_t = float(step[:, scored].sum() * frame)
    total_e = float(ke[:, scored].sum())
    total_a = float(acc[:, scored].sum())
    total_l = float(dist[:, scored].sum())
    finished = int(np.count_nonzero(present[0, scored] & ~present[-1, scored]))
    c01 = ALPHA * total_c / n + BETA * total_t / n + GAMMA * total_e / n
    return {
        "agents": int(n),
        "agents_finished": finished,
        "collisions_per_agent": round(total_c / n, 6),
        "time_per_agent_s": round(total_t / n, 6),
        "path_length_per_agent_m": round(total_l / n, 6),
        "kinetic_energy_per_agent": round(total_e / n, 6),
        "acceleration_per_agent": round(total_a / n, 6),
        "composite01": round(c01, 6),
        "composite02": round(c01 + DELTA * total_a / n, 6),
    }


def _unique_collisions(p: np.ndarray, present: np.ndarray, rad: np.ndarray, scene: SceneConfig) -> np.ndarray:
    """Per id, the number of collision episodes (SteerSuite's ``numUniqueCollisions``)."""
    f_count, a_count = present.shape
    polys = [shapely.Polygon(o.vertices) for o in scene.world.obstacles]
    tree = shapely.STRtree(polys) if polys else None
    n_other = a_count + len(polys)
    counts = np.zeros(a_count, np.int64)
    prev = np.zeros(0, np.int64)
    reach = 2.0 * float(rad.max()) if rad.size else 0.0
    for f in range(f_count):
        rows = np.flatnonzero(present[f])
        if rows.size == 0:
            prev = np.zeros(0, np.int64)
            continue
        pts = p[f, rows]
        codes: list[np.ndarray] = []
        if rows.size > 1:
            pairs = cKDTree(pts).query_pairs(r=reach, output_type="ndarray")
            if pairs.size:
                a, b = rows[pairs[:, 0]], rows[pairs[:, 1]]
                pen = rad[a] + rad[b] - np.linalg.norm(p[f, a] - p[f, b], axis=1)
                hit = pen > COLLISION_EPSILON
                a, b = a[hit], b[hit]
                codes += [a * n_other + b, b * n_other + a]
        if tree is not None:
            geoms = shapely.points(pts)
            pi, oi = tree.query(geoms, predicate="dwithin", distance=float(rad.max()))
            if pi.size:
                obs = np.asarray(polys, dtype=object)[oi]
                gap = shapely.distance(geoms[pi], obs)
                inside = gap <= 0.0
                if inside.any():
                    gap[inside] = -shapely.distance(geoms[pi[inside]], shapely.boundary(obs[inside]))
                hit = rad[rows[pi]] - gap > COLLISION_EPSILON
                codes.append(rows[pi[hit]] * n_other + a_count + oi[hit])
        cur = np.unique(np.concatenate(codes)) if codes else np.zeros(0, np.int64)
        new = np.setdiff1d(cur, prev, assume_unique=True)
        np.add.at(counts, new // n_other, 1)
        prev = cur
    return counts
