"""A simple body: the seam the full body layer (issue 3) will fill.

The simulation asks its body model two things each step: what the body can
do (motion limits, per agent, per step: the coupled steering constraints) and
where the body went given the commanded velocities (root position, heading).
This model is a point that walks: the root follows the commanded velocity,
and the facing turns toward the direction of motion no faster than the turn
rate allowed at the current speed (PedVR §4.1). In the decoupled condition the
facing snaps to the velocity direction, as a skeleton rigidly following a disc.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numba import njit

from pedvr.body.quat import FASTMATH
from pedvr.crowd.state import LIMIT_TURN_STANDING, LIMIT_TURN_WALKING, CrowdState
from pedvr.kernels import wrap_pi

MOVING = 0.05  # m/s: below this the facing follows the preferred facing instead


class BodyModel(Protocol):
    def fill_limits(self, crowd: CrowdState, out: np.ndarray) -> None: ...

    def animate(self, crowd: CrowdState, new_vel: np.ndarray, dt: float, *,
                coupled: bool) -> tuple[np.ndarray, np.ndarray]: ...


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def turn_rate_limit(speed: np.ndarray, pref_speed: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Turn-rate limit falling linearly with speed (rad/s), as steering uses it."""
    frac = np.clip(speed / np.maximum(pref_speed, 1e-6), 0.0, 1.0)
    lo, hi = limits[:, LIMIT_TURN_STANDING], limits[:, LIMIT_TURN_WALKING]
    return lo + frac * (hi - lo)


class SimpleBody:
    """Per-agent limits from the profile (constant); root = integrated disc."""

    def fill_limits(self, crowd: CrowdState, out: np.ndarray) -> None:
        out[:] = crowd.limits

    def animate(self, crowd: CrowdState, new_vel: np.ndarray, dt: float, *,
                coupled: bool) -> tuple[np.ndarray, np.ndarray]:
        n = len(crowd)
        root = np.empty((n, 2))
        heading = np.empty(n)
        root_motion_kernel(crowd.pos, np.ascontiguousarray(new_vel, np.float64), crowd.heading,
                           crowd.pref_heading, crowd.pref_speed, crowd.limits, crowd.is_user,
                           crowd.length > 0.0, dt, coupled, root, heading)
        return root, heading


@njit(cache=True, fastmath=FASTMATH)
def root_motion_kernel(pos, vel, heading, pref_heading, pref_speed, limits, is_user, steered, dt, coupled,
                       root_out, heading_out):  # type: ignore[no-untyped-def]
    """:meth:`SimpleBody.animate` for every agent: the root follows the commanded velocity; the
    facing turns toward the motion (or, below ``MOVING`` or backing away, toward the preferred
    facing) no faster than :func:`turn_rate_limit` allows when coupled, snapping to it when not.
    A ``steered`` row (a pushed pram, which cannot step sideways: its sideways speed is capped,
    ``pedvr.sim.PRAM_SIDEWAYS``) turns toward its preferred facing while it moves, as a pusher
    steers a pram: its motion follows its facing, so turning toward the motion would never turn
    it. The user's root and facing are its input's."""
    for i in range(pos.shape[0]):
        if is_user[i]:
            root_out[i, 0], root_out[i, 1] = pos[i, 0], pos[i, 1]
            heading_out[i] = heading[i]
            continue
        vx, vy = vel[i, 0], vel[i, 1]
        root_out[i, 0] = pos[i, 0] + vx * dt
        root_out[i, 1] = pos[i, 1] + vy * dt
        speed = math.sqrt(vx * vx + vy * vy)
        moving = speed > MOVING
        motion_dir = math.atan2(vy, vx)
        target = motion_dir if moving and not (coupled and steered[i]) else pref_heading[i]
        # Backing away or side-stepping keeps the facing: a person steps back without turning around.
        if moving and math.cos(motion_dir - heading[i]) * speed < 0.0:
            target = pref_heading[i]
        delta = wrap_pi(target - heading[i])
        if coupled:
            frac = min(max(speed / max(pref_speed[i], 1e-6), 0.0), 1.0)
            lo, hi = limits[i, LIMIT_TURN_STANDING], limits[i, LIMIT_TURN_WALKING]
            lim = (lo + frac * (hi - lo)) * dt
            delta = min(max(delta, -lim), lim)
            h = heading[i] + delta
            heading_out[i] = wrap_pi(h)
        elif moving:
            heading_out[i] = motion_dir
        else:
            h = heading[i] + delta
            heading_out[i] = wrap_pi(h)


@njit(cache=True)
def sync_kernel(root, pos, vel, max_speed, is_user, dt, out_pos, out_vel):  # type: ignore[no-untyped-def]
    """The sync phase's commit (:meth:`pedvr.sim.Simulation._sync`): each virtual row takes its
    body's ``root (N,2)`` as its position and the root's motion, ``(root - pos) / dt``, as its
    velocity, scaled down to ``max_speed`` where faster; the user's rows keep theirs. Writes
    ``out_pos``/``out_vel (N,2)``. One pass, the bytes of the numpy expressions it replaced
    (issue 27: they made eight temporaries a step)."""
    for i in range(pos.shape[0]):
        if is_user[i]:
            out_pos[i, 0] = pos[i, 0]
            out_pos[i, 1] = pos[i, 1]
            out_vel[i, 0] = vel[i, 0]
            out_vel[i, 1] = vel[i, 1]
            continue
        mx = (root[i, 0] - pos[i, 0]) / dt
        my = (root[i, 1] - pos[i, 1]) / dt
        speed = math.hypot(mx, my)
        if speed > max_speed[i]:
            k = max_speed[i] / speed
            mx *= k
            my *= k
        out_pos[i, 0] = root[i, 0]
        out_pos[i, 1] = root[i, 1]
        out_vel[i, 0] = mx
        out_vel[i, 1] = my
