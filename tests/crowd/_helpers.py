"""Shared builders for the crowd tests (not a test module)."""

from __future__ import annotations

import numpy as np

from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.scene.config import MotionLimits

LIMITS = MotionLimits()


def limits_row(m: MotionLimits = LIMITS) -> np.ndarray:
    return np.array([m.max_accel, m.max_decel, m.turn_rate_standing, m.turn_rate_walking,
                     m.max_backward_speed, m.max_sideways_speed])


def crowd(pos, vel=None, pref_vel=None, *, radius=0.25, max_speed=1.5, responsibility=0.5,
          is_user=None, heading=None, pref_speed=1.3) -> CrowdState:
    pos = np.asarray(pos, np.float64).reshape(-1, 2)
    n = pos.shape[0]
    vel = np.zeros((n, 2)) if vel is None else np.asarray(vel, np.float64).reshape(n, 2)
    pref = np.zeros((n, 2)) if pref_vel is None else np.asarray(pref_vel, np.float64).reshape(n, 2)
    return CrowdState(
        ids=np.arange(n, dtype=np.int64), pos=pos.copy(), vel=vel.copy(), pref_vel=pref.copy(),
        heading=np.zeros(n) if heading is None else np.asarray(heading, np.float64).copy(),
        pref_heading=np.zeros(n), radius=np.full(n, float(radius)),
        pref_speed=np.full(n, float(pref_speed)), max_speed=np.full(n, float(max_speed)),
        responsibility=np.full(n, float(responsibility)),
        is_user=np.zeros(n, np.bool_) if is_user is None else np.asarray(is_user, np.bool_).copy(),
        limits=np.tile(limits_row(), (n, 1)) if N_LIMITS == 6 else np.zeros((n, N_LIMITS)))


def f32(a: np.ndarray) -> np.ndarray:
    """Round to float32 and back: RVO2 stores everything in float32."""
    return np.asarray(a, np.float64).astype(np.float32).astype(np.float64)


def spread_points(rng: np.random.Generator, n: int, size: float, min_dist: float) -> np.ndarray:
    """``n`` random points in ``[0, size]^2`` at least ``min_dist`` apart (rejection)."""
    pts = np.empty((n, 2))
    k = 0
    while k < n:
        q = rng.uniform(0.0, size, 2)
        if k == 0 or np.min(np.sum((pts[:k] - q) ** 2, axis=1)) > min_dist * min_dist:
            pts[k] = q
            k += 1
    return pts


def disjoint_boxes(rng: np.random.Generator, k: int, size: float) -> list[np.ndarray]:
    """``k`` axis-aligned boxes (counter-clockwise) whose x and y ranges are all disjoint.

    No box edge's supporting line then cuts another box, so RVO2's obstacle
    tree splits no edge and its obstacle vertices are exactly ours.
    """
    cols = rng.permutation(k)
    rows = rng.permutation(k)
    w = size / k
    boxes = []
    for a, b in zip(cols, rows, strict=True):
        x0 = a * w + rng.uniform(0.1, 0.3) * w
        x1 = x0 + rng.uniform(0.3, 0.6) * w
        y0 = b * w + rng.uniform(0.1, 0.3) * w
        y1 = y0 + rng.uniform(0.3, 0.6) * w
        boxes.append(f32(np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])))
    return boxes


def pair_support(radius: np.ndarray, depth: np.ndarray, facing: np.ndarray, rows: np.ndarray,
                 d: np.ndarray) -> np.ndarray:
    """Vectorised :func:`pedvr.crowd.footprint.support` of ``rows`` along unit directions
    ``d (P, 2)``: an array oracle for the kernels that measure footprints row by row."""
    a, b, f = radius[rows], depth[rows], facing[rows]
    along_f = d[:, 0] * f[:, 0] + d[:, 1] * f[:, 1]
    along_s = -d[:, 0] * f[:, 1] + d[:, 1] * f[:, 0]
    return np.sqrt(a * a * along_s * along_s + b * b * along_f * along_f)
