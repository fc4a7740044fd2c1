"""The user agent (PedVR §3.5): the person, as a disc the crowd avoids.

Backends feed a :class:`UserInput` (scripted path, keyboard, HMD); the
simulation's ``sense`` phase reads it once per step. The user is never
steered: its velocity is a filtered finite difference of its poses (PedVR
§3.6 synchronises the user's velocity as well as its position).
"""

from __future__ import annotations

import math
from collections.abc import Callable
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


class ReactiveUser:
    """A scripted user who reacts like a person (for headless dry runs of a study).

    It walks ``path`` at ``speed`` like :class:`ScriptedUser`, but looks at the
    crowd (``perceive() -> (pos (N,2), vel (N,2), radius (N,), is_user (N,))``,
    the committed state of the last step) and, when a pedestrian is about to
    pass closer than ``radius + r_j + comfort`` within ``LOOKAHEAD`` seconds,
    steps aside after ``reaction_time`` seconds (a perception-reaction delay),
    away from the pedestrian's side, by what is still missing — so it takes
    whatever share of the avoidance the pedestrian leaves it, as a participant
    does. With nobody about to come too close it drifts back to its route.
    ``inside(point) -> bool`` keeps it on walkable ground.

    The constants are pedvr's choice: reaction 0.5 s (pedestrian reaction times
    in head-on encounters are 0.3-0.7 s), comfort 0.15 m, side steps at most
    0.6 m/s, back to the route at 0.3 m/s.
    """

    LOOKAHEAD = 3.0  # s
    RANGE = 6.0  # m
    MAX_LATERAL = 0.6  # m/s
    RETURN_SPEED = 0.3  # m/s

    def __init__(self, path: np.ndarray, *, speed: float, heading: float, radius: float,
                 perceive: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                 inside: Callable[[np.ndarray], bool], reaction_time: float = 0.5,
                 comfort: float = 0.15) -> None:
        self._route = ScriptedUser(path, speed=speed, heading=heading)
        self.speed = speed
        self.radius = radius
        self.reaction_time = reaction_time
        self.comfort = comfort
        self._perceive = perceive
        self._inside = inside
        self._t: float | None = None
        self._s = 0.0  # arc length walked along the route
        self._offset = np.zeros(2)  # displacement from the route, m
        self._threat_since: float | None = None
        self._heading = heading

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        dt = 0.0 if self._t is None else max(t - self._t, 0.0)
        self._t = t
        before, _ = self._route.pose(self._s / self.speed if self.speed > 0 else 0.0)
        here = before + self._offset
        self._s = min(self._s + self.speed * dt, self._route.length)
        base, heading = self._route.pose(self._s / self.speed if self.speed > 0 else 0.0)
        forward = (base - before) / dt if dt > 0 else np.zeros(2)
        lateral = self._evade(t, here, forward)
        if lateral is None:  # nobody to avoid: drift back onto the route
            back = -self._offset
            dist = float(np.hypot(*back))
            step = min(dist, self.RETURN_SPEED * dt)
            lateral_step = back / dist * step if dist > 1e-9 else np.zeros(2)
        else:
            lateral_step = lateral * dt
        offset = self._offset + lateral_step
        if self._inside(base + offset):
            self._offset = offset
        elif not self._inside(base + self._offset):
            self._offset = self._offset * 0.5  # squeezed by a corner: give up some of the offset
        pos = base + self._offset
        motion = forward + (lateral_step / dt if dt > 0 else 0.0)
        if float(np.hypot(*motion)) > 0.05:
            self._heading = math.atan2(motion[1], motion[0])
        elif self._route.length > 0:
            self._heading = heading
        return pos, self._heading

    def _evade(self, t: float, here: np.ndarray, forward: np.ndarray) -> np.ndarray | None:
        """The lateral velocity that keeps the comfort distance, or None without a threat."""
        pos, vel, radius, is_user = self._perceive()
        others = ~is_user
        if not others.any():
            self._threat_since = None
            return None
        p = pos[others] - here
        w = forward - vel[others]  # my velocity relative to theirs
        ww = np.einsum("ij,ij->i", w, w)
        tca = np.divide(np.einsum("ij,ij->i", p, w), ww, out=np.zeros_like(ww), where=ww > 1e-9)
        m = p - w * tca[:, None]
        miss = np.hypot(m[:, 0], m[:, 1])
        need = self.radius + radius[others] + self.comfort
        dist = np.hypot(p[:, 0], p[:, 1])
        threat = (tca > 0.0) & (tca < self.LOOKAHEAD) & (dist < self.RANGE) & (miss < need)
        if not threat.any():
            self._threat_since = None
            return None
        if self._threat_since is None:
            self._threat_since = t
        if t - self._threat_since < self.reaction_time:
            return np.zeros(2)  # seen, not yet reacted: keep walking
        k = int(np.flatnonzero(threat)[np.argmin(tca[threat])])
        away = -m[k] / miss[k] if miss[k] > 1e-3 else np.array([forward[1], -forward[0]])
        norm = float(np.hypot(*away))
        if norm < 1e-9:
            return np.zeros(2)
        away = away / norm
        amount = float(need[k] - miss[k])
        speed = min(self.MAX_LATERAL, amount / max(float(tca[k]) - 0.3, 0.3))
        return away * speed
