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

from typing import Protocol

import numpy as np

from pedvr.crowd.state import LIMIT_TURN_STANDING, LIMIT_TURN_WALKING, CrowdState

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
        root = crowd.pos + new_vel * dt
        speed = np.linalg.norm(new_vel, axis=1)
        moving = speed > MOVING
        motion_dir = np.arctan2(new_vel[:, 1], new_vel[:, 0])
        # Backing away or side-stepping keeps the facing: a person steps back
        # without turning around.
        facing_target = np.where(moving, motion_dir, crowd.pref_heading)
        fwd = np.cos(motion_dir - crowd.heading) * speed
        facing_target = np.where(moving & (fwd < 0.0), crowd.pref_heading, facing_target)
        delta = wrap(facing_target - crowd.heading)
        if coupled:
            limit = turn_rate_limit(speed, crowd.pref_speed, crowd.limits) * dt
            delta = np.clip(delta, -limit, limit)
            heading = wrap(crowd.heading + delta)
        else:
            heading = np.where(moving, motion_dir, wrap(crowd.heading + delta))
        heading = np.where(crowd.is_user, crowd.heading, heading)
        root = np.where(crowd.is_user[:, None], crowd.pos, root)
        return root, heading
