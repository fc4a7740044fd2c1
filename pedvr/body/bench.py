"""Body-layer benchmark: ms per step for the whole body layer beside the steering step.

Scenario: ``agents`` agents evenly on a circle walking to their antipodes
(the steering benchmark's circle), time step 1/90 s, coupled mode. Per step
we time (a) steering: neighbours + ORCA (``Steering.compute_velocities``)
and the contact pass, (b) the body layer: ``fill_limits`` + ``animate`` +
``compose`` (footsteps, six choreographers, the coordinator's blend, leg IK,
forward kinematics, skate metrics) + the gaze rule, and (c) the renderer's
``joint_matrices`` (float32 bone matrices). The first ``warmup`` steps
(numba compilation, cache loads) are not timed.
"""

from __future__ import annotations

import math
import platform
import time

import numba
import numpy as np

from pedvr.body.model import FullBody
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.crowd.steering import Steering
from pedvr.scene.config import MotionLimits, SteeringParams
from pedvr.world.obstacles import ObstacleSet


class _Open:
    """Visibility of an empty world: every segment is clear."""

    def visible(self, a: np.ndarray, b: np.ndarray, radius: object = 0.0) -> np.ndarray:
        return np.ones(np.asarray(a).shape[0], np.bool_)


def run_body_bench(agents: int, *, steps: int = 300, warmup: int = 30, seed: int = 0) -> dict[str, object]:
    """Time the body layer for ``agents`` bodies; returns a JSON-able dict (ms per step)."""
    dt = 1.0 / 90.0
    rng = np.random.default_rng(seed)
    n = int(agents)
    radius_c = max(10.0, n * 0.6 / (2.0 * math.pi))
    ang = np.arange(n) * 2.0 * math.pi / n
    pos = np.stack([np.cos(ang), np.sin(ang)], 1) * radius_c
    goals = -pos
    m = MotionLimits()
    lim = np.tile([m.max_accel, m.max_decel, m.turn_rate_standing, m.turn_rate_walking,
                   m.max_backward_speed, m.max_sideways_speed], (n, 1)).astype(np.float64)
    heading = np.arctan2(goals[:, 1] - pos[:, 1], goals[:, 0] - pos[:, 0])
    crowd = CrowdState(ids=np.arange(n, dtype=np.int64), pos=pos.copy(), vel=np.zeros((n, 2)),
                       pref_vel=np.zeros((n, 2)), heading=heading, pref_heading=heading.copy(),
                       radius=np.full(n, 0.25), pref_speed=np.full(n, 1.35), max_speed=np.full(n, 1.6),
                       responsibility=np.full(n, 0.5), is_user=np.zeros(n, np.bool_), limits=lim.copy())
    assert lim.shape[1] == N_LIMITS
    steering = Steering(SteeringParams(neighbor_dist=3.0), ObstacleSet.empty(), coupled=True)
    body = FullBody(rng=rng)
    crowd.pref_speed *= body.append(n, ids=crowd.ids, pos=crowd.pos, heading=crowd.heading, is_user=False,
                                    limits=lim)
    vis = _Open()
    t_steer: list[float] = []
    t_body: list[float] = []
    t_mat: list[float] = []
    out = np.empty((n, 26, 4, 4), np.float32)
    t = 0.0
    for k in range(warmup + steps):
        d = goals - crowd.pos
        dist = np.linalg.norm(d, axis=1)
        crowd.pref_vel = d / np.maximum(dist, 1e-9)[:, None] * np.minimum(crowd.pref_speed, dist)[:, None]
        crowd.pref_heading = np.arctan2(d[:, 1], d[:, 0])
        a = time.perf_counter()
        body.gaze_rule(crowd, t=t, visibility=vis, d1=4.0, d2=2.0, enabled=True)
        body.fill_limits(crowd, crowd.limits)
        b0 = time.perf_counter()
        new_vel = steering.compute_velocities(crowd, dt)
        b1 = time.perf_counter()
        root, head = body.animate(crowd, new_vel, dt, coupled=True)
        c0 = time.perf_counter()
        root = steering.resolve_contacts(root, crowd.radius, crowd.is_user)
        c1 = time.perf_counter()
        body.compose(crowd, root, head, dt=dt, t=t + dt, coupled=True)
        e = time.perf_counter()
        body.joint_matrices(out)
        f = time.perf_counter()
        crowd.pos, crowd.vel, crowd.heading = root, new_vel, head
        t += dt
        if k >= warmup:
            t_steer.append((b1 - b0) + (c1 - c0))
            t_body.append((b0 - a) + (c0 - b1) + (e - c1))
            t_mat.append(f - e)
    sk = body.skate.slides()
    return {
        "bench": "body", "agents": n, "steps": steps, "dt": dt,
        "body_ms_mean": round(1e3 * float(np.mean(t_body)), 4),
        "body_ms_p95": round(1e3 * float(np.percentile(t_body, 95)), 4),
        "steering_ms_mean": round(1e3 * float(np.mean(t_steer)), 4),
        "joint_matrices_ms_mean": round(1e3 * float(np.mean(t_mat)), 4),
        "foot_skate_max_m": round(float(sk.max()), 6) if sk.size else 0.0,
        "threads": numba.get_num_threads(), "machine": platform.machine(),
        "python": platform.python_version(), "numba": numba.__version__,
    }
