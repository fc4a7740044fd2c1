"""A one-crowd harness that drives FullBody with scripted root motion (no steering)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pedvr.body import FullBody
from pedvr.body import skeleton as sk
from pedvr.crowd.state import CrowdState
from pedvr.scene.config import MotionLimits

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


def ramp(vx: float, vy: float, *, accel: float = MotionLimits().max_accel, n: int = 1) -> Callable[[float], np.ndarray]:
    """Velocity ``(n,2)`` speeding up from rest at ``accel`` m/s² (the default profile's) to ``(vx, vy)``."""
    speed = float(np.hypot(vx, vy))

    def v(t: float) -> np.ndarray:
        k = min(1.0, accel * t / speed)
        return np.tile([vx * k, vy * k], (n, 1))

    return v


def knee_flexion(local_q: np.ndarray) -> np.ndarray:
    """Knee flexion angles ``(..., 2)`` in degrees (left, right) from local rotations ``(..., J, 4)``."""
    q = local_q[..., [sk.L_KNEE, sk.R_KNEE], :]
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(q[..., :3], axis=-1), np.abs(q[..., 3])))


class Trace:
    """Per-frame pelvis height, contact flags, knee flexion and feet of every body (a ``drive`` recorder)."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.pelvis: list[np.ndarray] = []
        self.planted: list[np.ndarray] = []
        self.knee: list[np.ndarray] = []
        self.feet: list[np.ndarray] = []

    def __call__(self, body: FullBody, t: float) -> None:
        st = body.state
        self.t.append(t)
        self.pelvis.append(st.world_pos[:, sk.PELVIS, 1].copy())
        self.planted.append(st.planted.copy())
        self.knee.append(knee_flexion(st.local_q))
        self.feet.append(st.foot_ref.copy())

    def arrays(self, after: float = 0.0) -> dict[str, np.ndarray]:
        keep = np.asarray(self.t) > after
        return {"pelvis": np.asarray(self.pelvis)[keep], "planted": np.asarray(self.planted)[keep],
                "knee": np.asarray(self.knee)[keep], "feet": np.asarray(self.feet)[keep]}

    def bob(self, row: int, *, after: float, period: float) -> float:
        """Mean peak-to-peak pelvis height over windows of ``period`` s (one stride) after ``after`` s."""
        y = self.arrays(after)["pelvis"][:, row]
        w = max(1, round(period / DT))
        return float(np.mean([np.ptp(y[k:k + w]) for k in range(0, len(y) - w + 1, w)]))

    def double_support(self, row: int, *, after: float) -> float:
        """Fraction of frames with both feet planted."""
        return float((self.arrays(after)["planted"][:, row].sum(axis=1) == 2).mean())

    def stance_knee_min(self, row: int, *, after: float) -> np.ndarray:
        """The straightest knee (degrees) of each completed stance of either foot."""
        a = self.arrays(after)
        out = []
        for f in range(2):
            on = a["planted"][:, row, f] == 1
            edges = np.flatnonzero(np.diff(on.astype(np.int8)))
            for s0, s1 in zip(edges[:-1], edges[1:], strict=True):
                if on[s0 + 1]:
                    out.append(a["knee"][s0 + 1:s1 + 1, row, f].min())
        return np.asarray(out)

    def landings(self, row: int, direction: np.ndarray) -> np.ndarray:
        """Each landing's step along ``direction``: the landed foot ahead of the other foot (m)."""
        pl = np.asarray(self.planted)[:, row]
        feet = np.asarray(self.feet)[:, row]
        d = np.asarray(direction, np.float64) / np.linalg.norm(direction)
        out = []
        for k in range(1, len(pl)):
            for f in range(2):
                if pl[k, f] and not pl[k - 1, f]:
                    out.append((feet[k, f] - feet[k, 1 - f]) @ d)
        return np.asarray(out)

    def swings(self, row: int) -> np.ndarray:
        """Each completed swing's displacement of the foot, ``(S, 2)`` m (lift-off to landing)."""
        pl = np.asarray(self.planted)[:, row]
        feet = np.asarray(self.feet)[:, row]
        out = []
        for f in range(2):
            up = np.flatnonzero(np.diff(pl[:, f].astype(np.int8)) == -1)  # last planted frame
            down = np.flatnonzero(np.diff(pl[:, f].astype(np.int8)) == 1) + 1  # landing frame
            for k0 in up:
                later = down[down > k0]
                if later.size:
                    out.append(feet[later[0], f] - feet[k0, f])
        return np.asarray(out).reshape(-1, 2)
