"""Foot-skate measurement, the same for every condition.

Each foot touches the floor at two points: its heel and its toe tip (the
``LHeel``/``RHeel`` and ``LToeTip``/``RToeTip`` end sites of the final
forward kinematics, both on the floor when the foot stands flat). A point is
*down* from the first frame it is within ``CONTACT_HEIGHT`` (2 mm) of the
floor, or while the gait says it bears weight (the foot planted, and the
heel for a flat foot or a heel rocker, the toe tip for a flat foot or a
raised heel) — the second clause keeps an IK that cannot reach the floor
visible as slide instead of as a hovering foot. When a point goes down its
horizontal position is its anchor; its slide is the largest horizontal
distance from the anchor while it stays down. A *stance* is one
uninterrupted interval in which either point of a foot is down; its slide is
the largest of its two points' slides.

Measuring from the first frame within 2 mm (issue 11) is what catches a
touchdown skid: a heel that comes down 1 mm above the floor and then lands a
centimetre further on was invisible to a meter that anchored at the frame the
gait declared the foot planted.

The user's body is not measured: its root is the user's tracked or typed
motion (which may start and stop instantly), not something the body made.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pedvr.body import skeleton as sk

CONTACT_HEIGHT = 0.002  # m: a heel or toe tip this close to the floor touches it


@njit(cache=True)
def skate_kernel(world_pos, planted, pitch, lift, measured, anchor, in_contact, stance_max, out, n_out):  # type: ignore[no-untyped-def]
    """Update contact anchors; emit finished stances' slides into ``out``; return the new count.

    ``world_pos (N,K,3)`` the final FK; ``planted (N,2)``, ``pitch (N,2)``,
    ``lift (N,2)`` the gait's contact state; ``measured (N,)`` rows to
    account. State: ``anchor (N,2,2,2)`` (foot, point, x/z), ``in_contact
    (N,2,2)``, ``stance_max (N,2)``.
    """
    n = world_pos.shape[0]
    m = n_out
    for i in range(n):
        if not measured[i]:
            continue
        for f in range(2):
            heel_node = sk.L_HEEL if f == 0 else sk.R_HEEL
            tip_node = sk.L_TOE_TIP if f == 0 else sk.R_TOE_TIP
            bearing = planted[i, f] != 0 and lift[i, f] == 0.0
            any_down = False
            for c in range(2):
                node = heel_node if c == 0 else tip_node
                flagged = bearing and (pitch[i, f] <= 0.0 if c == 0 else pitch[i, f] >= 0.0)
                down = flagged or world_pos[i, node, 1] <= CONTACT_HEIGHT
                x = world_pos[i, node, 0]
                z = world_pos[i, node, 2]
                if down:
                    any_down = True
                    if not in_contact[i, f, c]:
                        in_contact[i, f, c] = True
                        anchor[i, f, c, 0] = x
                        anchor[i, f, c, 1] = z
                    else:
                        dx = x - anchor[i, f, c, 0]
                        dz = z - anchor[i, f, c, 1]
                        d = math.sqrt(dx * dx + dz * dz)
                        if d > stance_max[i, f]:
                            stance_max[i, f] = d
                else:
                    in_contact[i, f, c] = False
            if not any_down and stance_max[i, f] >= 0.0:
                # the stance ended this frame (stance_max < 0 marks a foot in the air)
                if m < out.shape[0]:
                    out[m] = stance_max[i, f]
                    m += 1
                stance_max[i, f] = -1.0
            elif any_down and stance_max[i, f] < 0.0:
                stance_max[i, f] = 0.0
    return m


class SkateMeter:
    """Per-stance slides of feet on the floor, accumulated over a run."""

    def __init__(self) -> None:
        self.anchor = np.zeros((0, 2, 2, 2))
        self.in_contact = np.zeros((0, 2, 2), np.bool_)
        self.stance_max = np.zeros((0, 2))
        self._buf = np.zeros(4096)
        self.stances: list[np.ndarray] = []

    def append(self, n: int) -> None:
        self.anchor = np.concatenate([self.anchor, np.zeros((n, 2, 2, 2))])
        self.in_contact = np.concatenate([self.in_contact, np.zeros((n, 2, 2), np.bool_)])
        self.stance_max = np.concatenate([self.stance_max, np.full((n, 2), -1.0)])

    def keep(self, mask: np.ndarray) -> None:
        self.anchor = np.ascontiguousarray(self.anchor[mask])
        self.in_contact = np.ascontiguousarray(self.in_contact[mask])
        self.stance_max = np.ascontiguousarray(self.stance_max[mask])

    def observe(self, world_pos: np.ndarray, planted: np.ndarray, pitch: np.ndarray, lift: np.ndarray,
                measured: np.ndarray) -> None:
        """Account one step; only rows with ``measured`` (the virtual agents) count."""
        if self._buf.shape[0] < 2 * world_pos.shape[0]:
            self._buf = np.zeros(2 * world_pos.shape[0])
        m = skate_kernel(world_pos, planted, pitch, lift, measured, self.anchor, self.in_contact,
                         self.stance_max, self._buf, 0)
        if m:
            self.stances.append(self._buf[:m].copy())

    def slides(self, *, include_open: bool = True) -> np.ndarray:
        """Slides (m) of every finished stance (and, by default, those still open)."""
        parts = list(self.stances)
        if include_open:
            parts.append(self.stance_max[self.stance_max >= 0.0])
        return np.concatenate(parts) if parts else np.zeros(0)
