"""Doorway geometry: leaf frames, the Best Open-door Position, the Opposing Goal, the waiting
regions of Table 1, and the key positions of the door interaction (Huang & Terzopoulos §4.2,
Fig. 4, App. B, Fig. 18).

A hinged leaf has a frame: origin at its hinge, ``x`` along the closed leaf toward its free
edge (``w`` long), ``y`` toward its *pull side* (the side the leaf opens into; for a
double-acting leaf, the side away from whoever opens it). A leaf opened by ``a`` points along
``(cos a, sin a)`` in that frame. Everything an agent is sent to is built in this frame and
turned into the world by :meth:`LeafFrame.world`.

Table 1 (m), reproduced exactly in :data:`TABLE_1`:

============== ====== ====== =======
door           PullWR PushWR AgentWR
============== ====== ====== =======
simple door    3.3    2.5    1.5
revolving door 3.0    3.0    1.5
double door    3.5    2.5    1.5
============== ====== ====== =======

The issue that asked for this reads them as radii, and so does pedvr. Centres (§4.2, Fig. 4):
PullWR at the door's hinge, PushWR at the door's centre, AgentWR at the holder; for a double
door both at the centre of the single door in question ("centered at the centers of the two
sprung single hinged doors"); for a revolving door at its axis. For a pedestrian carrying a box
or pushing a perambulator the simple-door values are scaled by :data:`CARRIER_SCALE` (§4.6).

Key positions (pedvr's reading of Fig. 4, Fig. 6 and Fig. 18, which draw but do not measure
them): the pull-side BOP is outside the leaf's swing, just beyond its free edge at
:data:`BOP_PULL_POLAR` from the closed leaf (the holder must stand outside the circle the leaf
sweeps, App. B.2); the push-side BOP faces the leaf a little on its latch side, inside the swing
circle (App. B.2); a holder holding the door for someone to pass first stands just beyond the
open leaf's free edge, on its far side from the passage (Fig. 6, HOF), where a follower taking
the door over stands too (Fig. 19); the lane through the doorway runs at
:data:`LANE_AT` of the leaf from its hinge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

PULL, PUSH, AGENT = 0, 1, 2
TABLE_1: dict[str, tuple[float, float, float]] = {
    "single": (3.3, 2.5, 1.5),
    "revolving": (3.0, 3.0, 1.5),
    "double": (3.5, 2.5, 1.5),
}
CARRIER_SCALE = 1.2  # §4.6: the simple-door regions, for a carrier or a perambulator

BOP_PULL_POLAR = math.radians(22.0)  # where the puller stands, from the closed leaf about the hinge
OUTER_MARGIN = 0.08  # m beyond the leaf's swing circle (and its sweep clearance) a holder keeps
HOLD_BEYOND = math.radians(8.0)  # how far past the open leaf's direction the HOF holder stands
LANE_AT = 0.55  # fraction of the leaf from its hinge where the passing lane crosses the doorway
PULL_HAND_AT = 0.92  # fraction of the leaf where the handle is (the pulling hand, the holding hand)
PUSH_HAND_AT = 0.5  # fraction of the leaf where the pushing hand meets the bar
HAND_HEIGHT = 1.0  # m: handle and push bar
HOLD_ANGLE = math.radians(90.0)  # a held leaf (HOF, HOL)


def waiting_radii(kind: str, *, carrier: bool = False) -> tuple[float, float, float]:
    """(PullWR, PushWR, AgentWR) in metres for a door ``kind`` (Table 1), scaled for carriers
    and perambulators at simple doors (§4.6)."""
    pull, push, agent = TABLE_1[kind]
    if carrier and kind == "single":
        return pull * CARRIER_SCALE, push * CARRIER_SCALE, agent * CARRIER_SCALE
    return pull, push, agent


@dataclass(frozen=True)
class LeafFrame:
    """A hinged leaf's frame for one interaction: ``hinge`` (2,), ``e`` the closed direction,
    ``m`` the pull-side normal (unit), ``w`` the leaf's length, ``sign`` the sign of the leaf's
    angle when it opens into ``m`` (so ``angle = sign * a`` with ``a >= 0`` in this frame)."""

    hinge: np.ndarray
    e: np.ndarray
    m: np.ndarray
    w: float
    sign: int

    @classmethod
    def of(cls, hinge: np.ndarray, base: float, length: float, sign: int) -> LeafFrame:
        e = np.array([math.cos(base), math.sin(base)])
        left = np.array([-e[1], e[0]])
        return cls(hinge=np.asarray(hinge, np.float64), e=e, m=left * sign, w=float(length), sign=int(sign))

    def world(self, x: float, y: float) -> np.ndarray:
        return self.hinge + x * self.e + y * self.m

    def local(self, p: np.ndarray) -> tuple[float, float]:
        d = np.asarray(p, np.float64) - self.hinge
        return float(d @ self.e), float(d @ self.m)

    def polar(self, rho: float, phi: float) -> np.ndarray:
        """The world point ``rho`` m from the hinge, ``phi`` rad from the closed leaf toward the pull side."""
        return self.world(rho * math.cos(phi), rho * math.sin(phi))

    def heading(self, dx: float, dy: float) -> float:
        """World heading of the local direction ``(dx, dy)``."""
        v = dx * self.e + dy * self.m
        return math.atan2(v[1], v[0])

    def side_of(self, p: np.ndarray) -> int:
        """+1 on the pull side, -1 on the push side."""
        return 1 if self.local(p)[1] >= 0.0 else -1

    def outer(self, radius: float) -> float:
        """Distance from the hinge at which a body of ``radius`` is clear of the leaf at any angle."""
        return self.w + radius + OUTER_MARGIN + 0.05  # 0.05: the leaf's sweep clearance

    # -- key positions (world) ------------------------------------------------------------------

    def bop_pull(self, radius: float) -> tuple[np.ndarray, float]:
        """The pull case's Best Open-door Position and facing (toward the handle)."""
        p = self.polar(self.outer(radius), BOP_PULL_POLAR)
        h = self.handle(0.0, PULL_HAND_AT)
        return p, math.atan2(h[1] - p[1], h[0] - p[0])

    def bop_push(self, radius: float) -> tuple[np.ndarray, float]:
        """The push case's Best Open-door Position and facing (toward the leaf)."""
        return self.world(LANE_AT * self.w, -(radius + 0.22)), self.heading(0.0, 1.0)

    def handle(self, a: float, at: float) -> np.ndarray:
        """Ground point of the hand on the leaf opened by ``a``, ``at`` of its length from the hinge."""
        return self.polar(at * self.w, a)

    def hold_beyond_tip(self, a: float, radius: float) -> tuple[np.ndarray, float]:
        """Where a HOF holder (or a PL follower taking over) stands for a leaf opened by ``a``:
        just beyond its free edge, facing the passage."""
        p = self.polar(self.outer(radius), a + HOLD_BEYOND)
        lane = self.world(LANE_AT * self.w, 0.0)
        return p, math.atan2(lane[1] - p[1], lane[0] - p[0])

    def lane(self, y: float) -> np.ndarray:
        """The passing lane's point ``y`` m toward the pull side of the doorway line."""
        return self.world(LANE_AT * self.w, y)


def enter_region(p: np.ndarray, goal: np.ndarray, circles: list[tuple[np.ndarray, float]]) -> float:
    """How far ``p`` may walk straight toward ``goal`` before it enters the union of ``circles``
    (centre, radius): 0 if it is inside one already, the whole distance if the line misses them."""
    d = np.asarray(goal, np.float64) - p
    length = float(math.hypot(d[0], d[1]))
    if length < 1e-9:
        return 0.0
    u = d / length
    best = length
    for c, r in circles:
        q = p - c
        if float(q @ q) <= r * r:
            return 0.0
        b = float(q @ u)
        disc = b * b - (float(q @ q) - r * r)
        if disc < 0.0:
            continue
        t = -b - math.sqrt(disc)
        if 0.0 <= t < best:
            best = t
    return best


def point_segment(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The distance from the point ``x`` to the segment ``a``–``b`` (2D)."""
    ab = b - a
    t = min(max(float((x - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0), 1.0)
    return float(np.hypot(*(x - (a + t * ab))))
