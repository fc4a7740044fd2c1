"""Deadlock remedy: nudge the preferred velocity of agents that stay stuck.

ORCA is free of oscillation but not of deadlock: two agents meeting head-on
in a corridor, a crossing that jams, a doorway, can settle into a symmetric
state where every agent's best permitted velocity is (near) zero. A cheap,
well-known remedy is to break the symmetry in the *preferred* velocity: when
an agent's speed stays below ``slow_fraction`` of its preferred speed for
longer than ``patience`` seconds while it wants to move, its preferred
velocity is turned to its right by an angle that grows with how long it has
been stuck (``turn_rate`` rad per second beyond ``patience``, at most
``max_turn``). Everyone keeping right is a right-of-way convention: two
agents head-on both step to their own right and pass left shoulder to left
shoulder.

``stuck_time (N,)`` (seconds) is the only state; the simulation owns it and
passes it each step. It grows by ``dt`` while the agent is slow and decays at
``recovery`` times ``dt`` once it moves again, so the detour is held for a
little while after the agent gets going instead of snapping back into the
same deadlock. Deterministic: no randomness, no agent-order dependence.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

SLOW_FRACTION = 0.2  # "stuck" means speed below this share of the preferred speed
PATIENCE = 1.5  # s of being stuck before the preferred velocity is turned
TURN_RATE = 0.6  # rad/s: how fast the detour angle grows after PATIENCE
MAX_TURN = 1.2  # rad (about 70°)
RECOVERY = 0.5  # stuck_time decays at this many seconds per second once moving


@njit(cache=True)  # O(N) and cheap: a parallel region would cost more than it saves (pedvr.kernels)
def unstick_kernel(vel, pref_vel, is_user, stuck_time, dt, slow_fraction, patience, turn_rate,
                   max_turn, recovery, out_pref_vel):
    """Update ``stuck_time`` in place and write perturbed preferred velocities.

    User rows and agents with zero preferred velocity are never perturbed and
    their ``stuck_time`` is reset to 0.
    """
    for i in range(vel.shape[0]):
        px = pref_vel[i, 0]
        py = pref_vel[i, 1]
        out_pref_vel[i, 0] = px
        out_pref_vel[i, 1] = py
        pref_speed = math.sqrt(px * px + py * py)
        if is_user[i] or pref_speed < 1e-6:
            stuck_time[i] = 0.0
            continue
        speed = math.sqrt(vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
        if speed < slow_fraction * pref_speed:
            stuck_time[i] += dt
        else:
            stuck_time[i] = max(0.0, stuck_time[i] - recovery * dt)
        over = stuck_time[i] - patience
        if over > 0.0:
            # Turn to the right (clockwise) by an angle growing with the wait.
            a = -min(max_turn, turn_rate * over + 0.2)
            c = math.cos(a)
            s = math.sin(a)
            out_pref_vel[i, 0] = c * px - s * py
            out_pref_vel[i, 1] = s * px + c * py


def unstick(vel: np.ndarray, pref_vel: np.ndarray, is_user: np.ndarray, stuck_time: np.ndarray,
            dt: float, *, out: np.ndarray | None = None, slow_fraction: float = SLOW_FRACTION,
            patience: float = PATIENCE, turn_rate: float = TURN_RATE,
            max_turn: float = MAX_TURN, recovery: float = RECOVERY) -> np.ndarray:
    """Preferred velocities ``(N,2)`` with stuck agents turned right; see the module doc.

    ``stuck_time`` is updated in place (caller-owned state); ``pref_vel`` is
    not modified unless it is passed as ``out``.
    """
    if out is None:
        out = np.empty_like(pref_vel)
    unstick_kernel(vel, pref_vel, is_user, stuck_time, float(dt), float(slow_fraction),
                   float(patience), float(turn_rate), float(max_turn), float(recovery), out)
    return out
