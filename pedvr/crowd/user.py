"""The user agent (PedVR §3.5): the person, as a disc the crowd avoids.

Backends feed a :class:`UserInput` (scripted path, keyboard, HMD); the
simulation's ``sense`` phase reads it once per step. The user is never
steered: its velocity is a filtered finite difference of its poses (PedVR
§3.6 synchronises the user's velocity as well as its position).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np


class UserInput(Protocol):
    """Where the user is at simulation time ``t`` (floor position, yaw)."""

    def pose(self, t: float) -> tuple[np.ndarray, float]: ...


class ScriptedUser:
    """Walks a polyline at constant speed, facing along it; then stands.

    ``path`` is the route already threaded through the navigation mesh
    (start, then every waypoint to every red sphere in order).
    """

    def __init__(self, path: np.ndarray, *, speed: float, heading: float) -> None:
        self.path = np.asarray(path, dtype=np.float64).reshape(-1, 2)
        seg = np.diff(self.path, axis=0)
        self._len = np.linalg.norm(seg, axis=1)
        self._cum = np.concatenate([[0.0], np.cumsum(self._len)])
        self._dir = np.divide(seg, self._len[:, None], out=np.zeros_like(seg), where=self._len[:, None] > 0)
        self.speed = speed
        self._heading0 = heading

    @property
    def length(self) -> float:
        return float(self._cum[-1])

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        s = min(max(t, 0.0) * self.speed, self.length)
        if self.path.shape[0] < 2 or self.length == 0.0:
            return self.path[0].copy(), self._heading0
        k = int(np.searchsorted(self._cum, s, side="right") - 1)
        k = min(max(k, 0), self._len.shape[0] - 1)
        while k > 0 and self._len[k] == 0.0:
            k -= 1
        p = self.path[k] + self._dir[k] * (s - self._cum[k])
        d = self._dir[k]
        return p, math.atan2(d[1], d[0])


class StandingUser:
    """A user who stands still (for scenes with the user disabled or in tests)."""

    def __init__(self, pos: tuple[float, float], heading: float = 0.0) -> None:
        self._pos = np.asarray(pos, dtype=np.float64)
        self._heading = heading

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        return self._pos.copy(), self._heading


class UserAgent:
    """Filters the input's poses into the user agent's velocity.

    The velocity is an exponentially smoothed finite difference with time
    constant ``tau`` (s), independent of the step size. It also tracks the
    red-sphere route: ``sphere`` is the index of the next sphere to reach.
    """

    def __init__(self, source: UserInput, *, route: tuple[tuple[float, float], ...],
                 sphere_radius: float, tau: float = 0.1) -> None:
        self.source = source
        self.route = np.asarray(route, dtype=np.float64).reshape(-1, 2)
        self.sphere_radius = sphere_radius
        self.tau = tau
        self.sphere = 0
        self.sphere_times: list[float] = []
        self._last: np.ndarray | None = None
        self.vel = np.zeros(2)

    @property
    def route_done(self) -> bool:
        return self.sphere >= self.route.shape[0]

    def sense(self, t: float, dt: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Position, filtered velocity and heading at time ``t``."""
        pos, heading = self.source.pose(t)
        pos = np.asarray(pos, dtype=np.float64)
        if self._last is not None and dt > 0:
            raw = (pos - self._last) / dt
            alpha = 1.0 - math.exp(-dt / self.tau)
            self.vel = self.vel + alpha * (raw - self.vel)
        self._last = pos.copy()
        if not self.route_done and np.linalg.norm(pos - self.route[self.sphere]) <= self.sphere_radius:
            self.sphere += 1
            self.sphere_times.append(t)
        return pos, self.vel.copy(), heading
