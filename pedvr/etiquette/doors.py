"""Door mechanics: sprung, double-acting hinged doors whose leaves walkers push open.

Huang & Terzopoulos, App. A, build a procedural (not physical) door
controller with two functions, automatic opening and closing procedures and
a bounce on release. This module is that controller for every leaf of a
scene, as arrays, plus the simplest door interaction of the paper: every
walker (virtual agent or user) behaves as the *NH* holder of App. B.3, "not
hold the door for others", and nobody waits or orders themselves at the
doorway. Waiting regions, doorway ordering, holding decisions and the user
holding a door for agents are the etiquette layer's job (DESIGN.md), built on
top of this state; they are not here.

Choices where the paper leaves the controller open (App. A gives its
functions, not their constants):

- **Double-acting leaves.** A leaf swings to either side and always opens
  *away* from the walker who opens it, so an opener never has to stand
  outside the swing circle (the pull case of App. B.2). Which side is fixed
  when a closed leaf is opened and kept until it closes again; a walker
  arriving from the leaf's side passes beside it.
- **Who opens it.** A walker within :data:`REACH` of the doorway line,
  laterally inside the leaf, and moving toward that line faster than
  :data:`APPROACH_SPEED` has a hand on the leaf: it opens at
  :data:`OPEN_SPEED` toward :data:`PASSAGE_ANGLE` ("the minimal angle that
  permits passage", App. B.3) and stays there while such a walker, or one in
  the doorway, remains.
- **Bodies are the p_stop of f_bounce.** A leaf never sweeps through a
  walker's disc: a moving leaf stops :data:`SWEEP_CLEARANCE` short of one,
  and a disc that gets into a leaf pushes it out of the way (the body keeps
  pushing the door open while passing). The user's body, which nothing can
  push, always wins: the leaf gets out of its way even into another walker,
  whom :meth:`DoorLeaves.push_out` then moves aside.
- **Leaves are obstacles.** The simulation gives the leaves, where they
  stand at the start of each step, to ORCA and the contact pass as moving
  two-vertex obstacles (``Steering.set_moving_segments``), so walkers steer
  round open leaves and wait for a leaf that cannot open yet.
- **Release.** When nobody holds it the leaf bounces :data:`BOUNCE_ANGLE`
  further open at opening speed, then the closer brings it back with time
  constant :data:`CLOSE_TIME`; a walker arriving meanwhile catches it
  ("the next holder can interrupt the door closing procedure", App. B.2).
- Revolving doors (§4.5.1) are not modelled.

Angles are radians; a leaf's angle is measured counter-clockwise from its
closed direction (from its hinge toward the opposite jamb or the middle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from pedvr.scene.config import WorldConfig

PASSAGE_ANGLE = math.radians(80.0)
MAX_ANGLE = math.radians(100.0)  # the door stop
BOUNCE_ANGLE = math.radians(10.0)
OPEN_SPEED = 2.5  # rad/s: about 90 degrees in 0.6 s
CLOSE_TIME = 0.8  # s, the closer's time constant
CLOSED_EPS = math.radians(1.0)  # below this a closing leaf latches shut
REACH = 0.8  # m from the doorway line (plus the walker's radius) at which a hand reaches the leaf
APPROACH_SPEED = 0.1  # m/s toward the doorway line: slower walkers are not opening the door
SWEEP_CLEARANCE = 0.05  # m: a swinging leaf stops this far short of a body

CLOSED, HELD, BOUNCE, CLOSING = 0, 1, 2, 3


@dataclass
class DoorLeaves:
    """Every leaf of a scene's doors as arrays (``L`` rows, a double door gives two).

    ``door`` ``(L,) int64`` index into ``world.doors``; ``hinge`` ``(L, 2)``
    m; ``base`` ``(L,)`` rad, the closed direction; ``length`` ``(L,)`` and
    ``height`` ``(L,)`` m; ``angle`` ``(L,)`` rad; ``side`` ``(L,) int64``
    +1 / -1 the side it is open to, 0 when closed; ``phase`` ``(L,) int64``
    one of ``CLOSED, HELD, BOUNCE, CLOSING``; ``target`` ``(L,)`` rad, the
    angle the current procedure moves toward.
    """

    door: np.ndarray
    hinge: np.ndarray
    base: np.ndarray
    length: np.ndarray
    height: np.ndarray
    angle: np.ndarray
    side: np.ndarray
    phase: np.ndarray
    target: np.ndarray

    @classmethod
    def of_world(cls, world: WorldConfig) -> DoorLeaves:
        door, hinge, base, length, height = [], [], [], [], []
        for k, d in enumerate(world.doors):
            a, b = np.asarray(d.span[0], np.float64), np.asarray(d.span[1], np.float64)
            ends = [(a, b)] if d.kind == "single" else [(a, 0.5 * (a + b)), (b, 0.5 * (a + b))]
            for h, tip in ends:
                door.append(k)
                hinge.append(h)
                base.append(math.atan2(tip[1] - h[1], tip[0] - h[0]))
                length.append(float(np.hypot(*(tip - h))))
                height.append(d.height)
        n = len(door)
        return cls(
            door=np.asarray(door, np.int64),
            hinge=np.asarray(hinge, np.float64).reshape(n, 2),
            base=np.asarray(base, np.float64),
            length=np.asarray(length, np.float64),
            height=np.asarray(height, np.float64),
            angle=np.zeros(n),
            side=np.zeros(n, np.int64),
            phase=np.zeros(n, np.int64),
            target=np.zeros(n),
        )

    def __len__(self) -> int:
        return int(self.door.shape[0])

    def step(self, dt: float, pos: np.ndarray, vel: np.ndarray, radius: np.ndarray,
             fixed: np.ndarray | None = None) -> None:
        """Advance every leaf by ``dt`` given the walkers' discs (``pos``, ``vel`` ``(N, 2)``,
        ``radius`` ``(N,)``): the leaves yield to bodies wherever their hinges let them, and
        always to a ``fixed`` body (``(N,)`` bool: the user, whom nothing can push)."""
        if len(self):
            n = np.asarray(pos).shape[0]
            fx = np.zeros(n, np.bool_) if fixed is None else np.ascontiguousarray(fixed, np.bool_)
            _step_leaves(self.hinge, self.base, self.length, self.angle, self.side, self.phase,
                         self.target, np.ascontiguousarray(pos, np.float64),
                         np.ascontiguousarray(vel, np.float64),
                         np.ascontiguousarray(radius, np.float64), fx, float(dt))

    def push_out(self, pos: np.ndarray, radius: np.ndarray, movable: np.ndarray) -> tuple[np.ndarray, float]:
        """Bodies yield to leaves that could not yield to them (at the door stop, or caught
        between two walkers): each ``movable`` disc cutting into a leaf moves out along the
        leaf's normal. Returns the new positions and the deepest overlap left (m), which is
        the user's (never moved: a person's body cannot be pushed) or a disc's between two
        leaves."""
        out = np.array(pos, dtype=np.float64, copy=True)
        if not len(self):
            return out, 0.0
        deepest = _push_out(self.hinge, self.base + self.angle, self.length, out,
                            np.ascontiguousarray(radius, np.float64), np.ascontiguousarray(movable))
        return out, float(deepest)

    def world_angle(self) -> np.ndarray:
        """``(L,)`` direction of each leaf in the ground plane (rad)."""
        return self.base + self.angle

    def tips(self) -> np.ndarray:
        """``(L, 2)`` the free edge of each leaf."""
        w = self.world_angle()
        return self.hinge + self.length[:, None] * np.stack([np.cos(w), np.sin(w)], axis=1)

    def pose(self) -> np.ndarray:
        """``(L, 5)`` hinge x, hinge y, world angle, length, height: what a frame draws."""
        return np.column_stack([self.hinge, self.world_angle(), self.length, self.height])


def hand_angle(hinge: np.ndarray, base: float, p_abs: np.ndarray) -> float:
    """App. A's ``f_a(p_abs, p_rel)``: the leaf angle that puts its hand point at ``p_abs``.

    A hand point on the leaf lies on the ray from the hinge, so the angle is
    that ray's direction relative to the closed one (``p_rel``, the distance
    along the leaf, does not change it).
    """
    d = np.asarray(p_abs, np.float64) - np.asarray(hinge, np.float64)
    return _wrap(math.atan2(d[1], d[0]) - base)


def hand_point(hinge: np.ndarray, base: float, angle: float, p_rel: float) -> np.ndarray:
    """App. A's ``f_pabs(a_curr, p_rel)``: where the hand is, ``p_rel`` metres from the hinge."""
    w = base + angle
    return np.asarray(hinge, np.float64) + p_rel * np.array([math.cos(w), math.sin(w)])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _blocked(qx: float, qy: float, c: float, s: float, length: float, r: float) -> tuple[float, float]:
    """The leaf angles ``[lo, hi]`` at which a leaf of ``length`` touches a disc of radius ``r``
    centred at ``q`` (relative to the hinge, closed direction ``(c, s)``); ``lo > hi`` if none."""
    along = qx * c + qy * s
    across = -qx * s + qy * c
    rho = math.hypot(along, across)
    if rho >= length + r or rho < 1e-9:
        return 1.0, -1.0
    phi = math.atan2(across, along)
    if rho <= r:
        half = 0.5 * math.pi
    elif math.sqrt(rho * rho - r * r) <= length:
        half = math.asin(r / rho)  # the disc meets the leaf's side
    else:
        cosv = (length * length + rho * rho - r * r) / (2.0 * length * rho)
        half = math.acos(min(1.0, max(-1.0, cosv)))  # only the leaf's free edge reaches it
    return phi - half, phi + half


@njit(cache=True)
def _step_leaves(hinge, base, length, angle, side, phase, target, pos, vel, radius, fixed, dt):  # noqa: ANN001, ANN202
    n = pos.shape[0]
    for i in range(hinge.shape[0]):
        c, s = math.cos(base[i]), math.sin(base[i])
        w = length[i]
        # Who has a hand on this leaf: near its doorway line, inside it laterally, moving toward it.
        held = False
        opener_side = 0
        nearest = 1e18
        for j in range(n):
            qx, qy = pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1]
            along = qx * c + qy * s
            across = -qx * s + qy * c
            r = radius[j]
            if along < -r or along > w + r:
                continue
            in_doorway = abs(across) < r
            closing_in = -(-vel[j, 0] * s + vel[j, 1] * c) * math.copysign(1.0, across)
            if in_doorway or (abs(across) < REACH + r and closing_in > APPROACH_SPEED):
                held = True
                if abs(across) < nearest:
                    nearest = abs(across)
                    opener_side = -1 if across > 0 else 1  # open away from the walker
        a = angle[i]
        if held:
            if side[i] == 0 or (phase[i] != HELD and abs(a) < CLOSED_EPS):
                side[i] = opener_side
            phase[i] = HELD
            target[i] = side[i] * PASSAGE_ANGLE
        elif phase[i] == HELD:
            phase[i] = BOUNCE
            open_now = max(abs(a), PASSAGE_ANGLE)
            target[i] = side[i] * min(open_now + BOUNCE_ANGLE, MAX_ANGLE)
        if phase[i] == BOUNCE and abs(a - target[i]) < 1e-6:
            phase[i] = CLOSING
        # The procedure's wish for this step.
        if phase[i] == HELD or phase[i] == BOUNCE:
            step = OPEN_SPEED * dt
            d = target[i] - a
            want = target[i] if abs(d) <= step else a + math.copysign(step, d)
            if phase[i] == HELD and side[i] * a > side[i] * target[i]:
                want = a  # held further open by a body: the hand does not pull it back
        elif phase[i] == CLOSING:
            want = a * math.exp(-dt / CLOSE_TIME)
            if abs(want) < CLOSED_EPS:
                want = 0.0
        else:
            want = 0.0
        # Bodies: a disc the leaf is inside pushes it out, away from the disc's centre ...
        for _ in range(3):
            moved = False
            for j in range(n):
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w, radius[j])
                if lo < a < hi:
                    a = hi if 0.5 * (lo + hi) < a else lo
                    moved = True
            if not moved:
                break
        # ... and a swinging leaf stops SWEEP_CLEARANCE short of any body ahead of it (f_bounce's
        # p_stop), so a walker never has a leaf arrive on it (steering sees leaves as obstacles).
        if want > a:
            ub = want
            for j in range(n):
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w,
                                  radius[j] + SWEEP_CLEARANCE)
                if lo <= hi and 0.5 * (lo + hi) > a:
                    ub = min(ub, max(lo, a))
            a = ub
        elif want < a:
            lb = want
            for j in range(n):
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w,
                                  radius[j] + SWEEP_CLEARANCE)
                if lo <= hi and 0.5 * (lo + hi) < a:
                    lb = max(lb, min(hi, a))
            a = lb
        # A body that cannot be moved (the user's) wins over the others: the leaf gets out of its
        # way even into another walker, who is then pushed aside (DoorLeaves.push_out).
        for j in range(n):
            if fixed[j]:
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w, radius[j])
                if lo < a < hi:
                    a = hi if 0.5 * (lo + hi) < a else lo
        a = min(MAX_ANGLE, max(-MAX_ANGLE, a))
        if a != 0.0 and side[i] != 0 and a * side[i] < 0:
            side[i] = 1 if a > 0 else -1  # pushed through to the other side
        if a == 0.0 and phase[i] == CLOSING:
            phase[i] = CLOSED
            side[i] = 0
        if side[i] == 0 and a != 0.0:
            side[i] = 1 if a > 0 else -1  # pushed open by a body without a hand on it
            if phase[i] == CLOSED:
                phase[i] = CLOSING
        angle[i] = a


@njit(cache=True)
def _push_out(hinge, world_angle, length, pos, radius, movable):  # noqa: ANN001, ANN202
    """Move movable discs out of leaf segments (in place); the deepest overlap left."""
    deepest = 0.0
    for j in range(pos.shape[0]):
        r = radius[j]
        for i in range(hinge.shape[0]):
            ex, ey = math.cos(world_angle[i]), math.sin(world_angle[i])
            qx, qy = pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1]
            t = min(max(qx * ex + qy * ey, 0.0), length[i])
            dx, dy = qx - t * ex, qy - t * ey
            d = math.hypot(dx, dy)
            if d >= r:
                continue
            if movable[j]:
                if d < 1e-9:  # centred on the leaf: out along its left normal
                    dx, dy, d = -ey, ex, 1.0
                pos[j, 0] += dx / d * (r - d)
                pos[j, 1] += dy / d * (r - d)
    for j in range(pos.shape[0]):
        for i in range(hinge.shape[0]):
            ex, ey = math.cos(world_angle[i]), math.sin(world_angle[i])
            qx, qy = pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1]
            t = min(max(qx * ex + qy * ey, 0.0), length[i])
            d = math.hypot(qx - t * ex, qy - t * ey)
            if radius[j] - d > deepest:
                deepest = radius[j] - d
    return deepest

