"""A one-crowd harness that drives FullBody with scripted root motion (no steering)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pedvr.body import FullBody
from pedvr.body import skeleton as sk
from pedvr.crowd.state import CrowdState

DT = 1.0 / 90.0


def crowd_of(n: int, *, pos: np.ndarray | None = None, heading: np.ndarray | None = None,
             user: int | None = None) -> CrowdState:
    pos = np.zeros((n, 2)) if pos is None else np.asarray(pos, np.float64).reshape(n, 2)
    heading = np.zeros(n) if heading is None else np.asarray(heading, np.float64).reshape(n)
    is_user = np.zeros(n, np.bool_)
    if user is not None:
        is_user[user] = True
    return CrowdState(ids=np.arange(n, dtype=np.int64), pos=pos.copy(), vel=np.zeros((n, 2)),
                      pref_vel=np.zeros((n, 2)), heading=heading.copy(), pref_heading=heading.copy(),
                      radius=np.full(n, 0.25), pref_speed=np.full(n, 1.3), max_speed=np.full(n, 1.6),
                      responsibility=np.full(n, 0.5), is_user=is_user, limits=np.zeros((n, 6)))


def bodies(n: int, *, heights: np.ndarray | None = None, emotion: np.ndarray | None = None,
           seed: int = 0) -> FullBody:
    b = FullBody(rng=np.random.default_rng(seed))
    dims = sk.user_dims(n)
    if heights is not None:
        dims[:, sk.DIM_HEIGHT] = heights
        dims[:, sk.DIM_SCALE] = np.asarray(heights) / sk.REFERENCE_HEIGHT
    em = np.zeros((n, 6))
    em[:, 0] = 1.0
    b.append(n, ids=np.arange(n), pos=np.zeros((n, 2)), heading=np.zeros(n), is_user=False, dims=dims,
             emotion=em if emotion is None else emotion)
    return b


def drive(body: FullBody, velocity: Callable[[float], np.ndarray], heading: Callable[[float], np.ndarray],
          seconds: float, *, coupled: bool = True, record: Callable[[FullBody, float], None] | None = None,
          dt: float = DT, t0: float = 0.0) -> CrowdState:
    """Move the roots with ``velocity(t) (N,2)`` and ``heading(t) (N,)`` for ``seconds`` from time ``t0``."""
    n = len(body.state)
    crowd = crowd_of(n, pos=body.state.root, heading=body.state.heading)
    t = t0
    for _ in range(round(seconds / dt)):
        v = np.asarray(velocity(t), np.float64).reshape(n, 2)
        root = crowd.pos + v * dt
        h = np.asarray(heading(t), np.float64).reshape(n)
        body.compose(crowd, root, h, dt=dt, t=t + dt, coupled=coupled)
        crowd.pos, crowd.vel, crowd.heading = root, v, h
        t += dt
        if record is not None:
            record(body, t)
    return crowd
