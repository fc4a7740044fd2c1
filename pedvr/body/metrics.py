"""Foot-skate measurement, the same for every condition.

A planted foot touches the ground at its heel (flat or heel rocker: pitch
≤ 0) and/or its ball (flat or heel off: pitch ≥ 0). When a contact point
touches down its horizontal world position is remembered; its slide is
the horizontal distance from there while the contact lasts. A *stance* is
one uninterrupted planted interval of a foot; its slide is the largest of
its heel and ball slides. Positions come from the final forward kinematics
(heel end site, toe joint), so an IK that cannot reach shows as slide.

The user's body is not measured: its root is the user's tracked or typed
motion (which may start and stop instantly), not something the body made.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pedvr.body import skeleton as sk


@njit(cache=True)
def skate_kernel(world_pos, planted, pitch, lift, measured, anchor, in_contact, stance_max, out, n_out):  # type: ignore[no-untyped-def]
    """Update contact anchors; emit finished stances' slides into ``out``; return the new count."""
    n = world_pos.shape[0]
    m = n_out
    for i in range(n):
        if not measured[i]:
            continue
        for f in range(2):
            heel_node = sk.L_HEEL if f == 0 else sk.R_HEEL
            ball_node = sk.L_TOE if f == 0 else sk.R_TOE
            on = planted[i, f] != 0 and lift[i, f] == 0.0
            if not on:
                if in_contact[i, f, 0] or in_contact[i, f, 1]:
                    if m < out.shape[0]:
                        out[m] = stance_max[i, f]
                        m += 1
                in_contact[i, f, 0] = False
                in_contact[i, f, 1] = False
                stance_max[i, f] = 0.0
                continue
            for c in range(2):
                node = heel_node if c == 0 else ball_node
                touching = pitch[i, f] <= 0.0 if c == 0 else pitch[i, f] >= 0.0
                x = world_pos[i, node, 0]
                z = world_pos[i, node, 2]
                if touching:
                    if not in_contact[i, f, c]:
                        in_contact[i, f, c] = True
                        anchor[i, f, c, 0] = x
                        anchor[i, f, c, 1] = z
                    else:
                        d = math.hypot(x - anchor[i, f, c, 0], z - anchor[i, f, c, 1])
                        if d > stance_max[i, f]:
                            stance_max[i, f] = d
                else:
                    in_contact[i, f, c] = False
    return m


class SkateMeter:
    """Per-stance slides of planted feet, accumulated over a run."""

    def __init__(self) -> None:
        self.anchor = np.zeros((0, 2, 2, 2))
        self.in_contact = np.zeros((0, 2, 2), np.bool_)
        self.stance_max = np.zeros((0, 2))
        self._buf = np.zeros(4096)
        self.stances: list[np.ndarray] = []

    def append(self, n: int) -> None:
        self.anchor = np.concatenate([self.anchor, np.zeros((n, 2, 2, 2))])
        self.in_contact = np.concatenate([self.in_contact, np.zeros((n, 2, 2), np.bool_)])
        self.stance_max = np.concatenate([self.stance_max, np.zeros((n, 2))])

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
                         self.stance_max,
                         self._buf, 0)
        if m:
            self.stances.append(self._buf[:m].copy())

    def slides(self, *, include_open: bool = True) -> np.ndarray:
        """Slides (m) of every finished stance (and, by default, those still open)."""
        parts = list(self.stances)
        if include_open:
            parts.append(self.stance_max[self.in_contact.any(axis=2)])
        return np.concatenate(parts) if parts else np.zeros(0)
