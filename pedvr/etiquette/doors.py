"""Door hardware: sprung hinged leaves and revolving doors, as arrays (Huang & Terzopoulos App. A, §4.5).

Huang & Terzopoulos build a procedural (not physical) door controller with
two functions for a hand on the door — the leaf angle from the hand's
position, ``f_a(p_abs, p_rel)``, and the hand's position from the angle,
``f_pabs(a_curr, p_rel)`` — automatic opening and closing procedures that can
be triggered, and a bounce on release, ``f_bounce(a_bounce, p_stop)``: the
door opens a little further, then closes, and stops closing where its board
meets ``p_stop`` (App. A). This module is that controller for every leaf and
panel of a scene. Who holds which leaf, and when, is the etiquette's business
(:mod:`pedvr.etiquette.interaction`); it drives a leaf through :meth:`DoorLeaves.grab`
(the automatic opening, the door leading the hand), :meth:`DoorLeaves.hand`
(the hand leading the door) and :meth:`DoorLeaves.release` (the bounce).

Leaf kinds:

- **One-way** (the paper's sprung single hinged door): the leaf opens only
  into its *pull side*. From the pull side it must be pulled by a hand on the
  handle; from the push side a hand on the push bar, or a body walking into
  it, pushes it open (App. B.2). A body pressing on a closed leaf from the
  pull side cannot open it: it is pushed back (nobody walks through a closed
  door).
- **Double-acting** (``swing = "both_ways"``, issue 4's leaves): the leaf
  swings to either side and always opens *away* from the walker who opens it.
  Which side is fixed when a closed leaf is opened and kept until it closes.
- **Revolving panels** (§4.5.1): four panels on one axis, turned by whoever
  pushes them (:class:`Revolvers`).

Choices where App. A gives functions, not constants:

- **Who opens a leaf without a hand.** A walker allowed to (``auto``, the
  user and walkers outside the etiquette) within :data:`REACH` of the doorway
  line, laterally inside the leaf, and moving toward that line faster than
  :data:`APPROACH_SPEED` from a side it may be pushed from, opens it at
  :data:`OPEN_SPEED` toward :data:`PASSAGE_ANGLE` and holds it there while such
  a walker, or one in the doorway, remains. From a one-way leaf's pull side such
  a walker keeps an open leaf held (it walks into the open doorway), but not one
  closed within :data:`PULL_CATCH_ANGLE`: that takes a hand, as a closed one does.
- **Bodies are the p_stop of f_bounce.** A leaf never sweeps through a
  walker's disc: a moving leaf stops :data:`SWEEP_CLEARANCE` short of one, and
  a disc that gets into a leaf pushes it out of the way where the hinge lets
  it. The user's body, which nothing can push, always wins: the leaf gets out
  of its way even into another walker, whom :meth:`DoorLeaves.push_out` then
  moves aside. A release may also name a ``stop`` angle at which the closing
  board halts (App. A's ``p_stop``, for a holder who takes the door after its
  bounce).
- **Leaves are obstacles.** The simulation gives the leaves, where they stand
  at the start of each step, to ORCA and the contact pass as moving two-vertex
  obstacles (``Steering.set_moving_segments``).
- **Release.** A released leaf bounces :data:`BOUNCE_ANGLE` further open at
  opening speed, then the closer brings it back with time constant
  :data:`CLOSE_TIME`, never faster than the door's ``closing_speed``; a hand
  arriving meanwhile catches it ("the next holder can interrupt the door
  closing procedure", App. B.2).

Angles are radians; a leaf's angle is measured counter-clockwise from its
closed direction (from its hinge toward the opposite jamb or the middle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from pedvr.scene.config import WorldConfig

PASSAGE_ANGLE = math.radians(80.0)
MAX_ANGLE = math.radians(100.0)  # the door stop
BOUNCE_ANGLE = math.radians(10.0)
OPEN_SPEED = 2.5  # rad/s: about 90 degrees in 0.6 s
HAND_SPEED = 4.0  # rad/s: the fastest a hand swings a leaf it holds
CLOSE_TIME = 0.8  # s, the closer's time constant
CLOSED_EPS = math.radians(1.0)  # below this a closing leaf latches shut
# A one-way leaf closed nearer than this is shut for one on its pull side without a hand on it: its
# edge stands too near the frame to walk into, so walking at it does not hold it (issue 26: a pram
# on the pull side, 1.4 m out, held a leaf 1.8° from latching, which swung open toward it, round the
# pram's front, and swept the pram into the pocket behind it; test_carriers' seed 17).
PULL_CATCH_ANGLE = math.radians(10.0)
REACH = 0.8  # m from the doorway line (plus the walker's radius) at which a hand reaches the leaf
APPROACH_SPEED = 0.1  # m/s toward the doorway line: slower walkers are not opening the door
USER_SWEEP_MAX = 0.009  # m a step: the user turns a panel tip no faster with others at the drum
SWEEP_CLEARANCE = 0.05  # m: a swinging leaf stops this far short of a body

CLOSED, HELD, BOUNCE, CLOSING = 0, 1, 2, 3  # phase
AUTO, OPEN, HAND = 0, 1, 2  # drive: the procedures and walkers, a hand opening it, a hand holding it
PANELS = 4  # a revolving door's panels (§4.5.1, Fig. 8a)
REVOLVE_ACCEL = 1.5  # rad/s²: how fast pushers bring a revolving door up to speed
REVOLVE_DRAG = 2.0  # rad/s²: how fast an unpushed revolving door stops


@dataclass
class DoorLeaves:
    """Every leaf and revolving panel of a scene as arrays (``L`` rows; a double door gives two
    leaves, a revolving door four panels).

    ``door`` ``(L,) int64`` index into ``world.doors``; ``hinge`` ``(L, 2)`` m (a panel's: the
    axis); ``base`` ``(L,)`` rad, the closed direction; ``length`` ``(L,)`` and ``height`` ``(L,)``
    m; ``angle`` ``(L,)`` rad; ``side`` ``(L,) int64`` +1 / -1 the side it is open to, 0 when
    closed; ``phase`` ``(L,) int64`` one of ``CLOSED, HELD, BOUNCE, CLOSING``; ``target`` ``(L,)``
    rad, the angle the current procedure moves toward; ``swing`` ``(L,) int64`` +1 / -1 the only
    sign a one-way leaf's angle takes (toward its pull side), 0 double-acting; ``panel`` ``(L,)``
    bool, a revolving panel (turned by :class:`Revolvers`, not by the leaf procedures);
    ``drive`` ``(L,) int64`` ``AUTO, OPEN, HAND``; ``close_speed`` ``(L,)`` rad/s;
    ``stop`` ``(L,)`` rad, the angle a closing leaf halts at (NaN: none).
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
    swing: np.ndarray
    panel: np.ndarray
    drive: np.ndarray
    close_speed: np.ndarray
    stop: np.ndarray
    open_speed: np.ndarray
    revolvers: Revolvers = field(default_factory=lambda: Revolvers.empty())

    @classmethod
    def of_world(cls, world: WorldConfig) -> DoorLeaves:
        door: list[int] = []
        hinge: list[np.ndarray] = []
        base: list[float] = []
        length: list[float] = []
        height: list[float] = []
        swing: list[int] = []
        panel: list[bool] = []
        close: list[float] = []
        rev: list[tuple[int, np.ndarray, float, float, int, int]] = []
        for k, d in enumerate(world.doors):
            a, b = np.asarray(d.span[0], np.float64), np.asarray(d.span[1], np.float64)
            if d.kind == "revolving":
                centre = 0.5 * (a + b)
                base0 = math.atan2(b[1] - a[1], b[0] - a[0])
                rev.append((k, centre, base0, 0.5 * d.width, 1 if d.rotation == "ccw" else -1, len(door)))
                for p in range(PANELS):
                    door.append(k)
                    hinge.append(centre)
                    base.append(base0 + p * 0.5 * math.pi)
                    length.append(0.5 * d.width - 0.03)
                    height.append(d.height)
                    swing.append(0)
                    panel.append(True)
                    close.append(d.closing_speed)
                continue
            if d.kind == "single":
                ends = [(b, a)] if d.hinge == 1 else [(a, b)]
            else:
                ends = [(a, 0.5 * (a + b)), (b, 0.5 * (a + b))]
            for h, tip in ends:
                e = tip - h
                door.append(k)
                hinge.append(h)
                base.append(math.atan2(e[1], e[0]))
                length.append(float(np.hypot(*e)))
                height.append(d.height)
                panel.append(False)
                close.append(d.closing_speed)
                if d.swing == "both_ways":
                    swing.append(0)
                else:
                    # The pull side is d.pull (+1: left of span[0] -> span[1]); the leaf's positive
                    # angle turns it toward the left of its own closed direction, which is the
                    # span's left where the leaf points along the span and its right otherwise.
                    along = float(np.dot(e, b - a))
                    swing.append(int(d.pull * (1 if along > 0 else -1)))
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
            swing=np.asarray(swing, np.int64),
            panel=np.asarray(panel, np.bool_),
            drive=np.zeros(n, np.int64),
            close_speed=np.asarray(close, np.float64),
            stop=np.full(n, np.nan),
            open_speed=np.full(n, OPEN_SPEED),
            revolvers=Revolvers.of(rev),
        )

    def __len__(self) -> int:
        return int(self.door.shape[0])

    # -- the hand (App. A) ---------------------------------------------------------------------

    def grab(self, leaf: int, *, open_to: float, speed: float = OPEN_SPEED) -> None:
        """A hand takes the leaf and opens it automatically toward ``open_to`` (rad, signed as the
        leaf opens) at ``speed`` (rad/s), the door leading the hand (``f_pabs``); a closing leaf is
        caught (App. B.2)."""
        self.drive[leaf] = OPEN
        self.phase[leaf] = HELD
        self.target[leaf] = self._clamp(leaf, open_to)
        self.stop[leaf] = math.nan
        self.open_speed[leaf] = speed

    def hand(self, leaf: int, angle: float) -> None:
        """The hand holding the leaf wants it at ``angle`` (rad, from ``f_a`` of where the hand
        is): the hand leads the door, which follows at most :data:`HAND_SPEED`."""
        self.drive[leaf] = HAND
        self.phase[leaf] = HELD
        self.target[leaf] = self._clamp(leaf, angle)

    def release(self, leaf: int, *, bounce: float = BOUNCE_ANGLE, stop: float | None = None) -> None:
        """The hand lets go: ``f_bounce(a_bounce, p_stop)``. The leaf opens ``bounce`` further, then
        closes, halting at ``stop`` (rad) if given."""
        self.drive[leaf] = AUTO
        a = float(self.angle[leaf])
        s = self.side[leaf] if self.side[leaf] != 0 else (1 if a >= 0 else -1)
        if abs(a) < CLOSED_EPS:
            self.phase[leaf] = CLOSING
        else:
            self.phase[leaf] = BOUNCE
            self.target[leaf] = s * min(abs(a) + bounce, MAX_ANGLE)
        self.stop[leaf] = math.nan if stop is None else float(stop)

    def _clamp(self, leaf: int, a: float) -> float:
        s = int(self.swing[leaf])
        if s != 0:
            return s * min(max(s * a, 0.0), MAX_ANGLE)
        return min(max(a, -MAX_ANGLE), MAX_ANGLE)

    def opening_sign(self, leaf: int, from_side: int) -> int:
        """The sign a leaf's angle takes when opened by someone on ``from_side`` of it (+1: the left
        of its closed direction): a one-way leaf's own sign, a double-acting leaf away from them."""
        s = int(self.swing[leaf])
        return s if s != 0 else -int(from_side)

    # -- the step ------------------------------------------------------------------------------

    def step(self, dt: float, pos: np.ndarray, vel: np.ndarray, radius: np.ndarray,
             fixed: np.ndarray | None = None, auto: np.ndarray | None = None,
             carried: np.ndarray | None = None) -> None:
        """Advance every leaf and panel by ``dt`` given the walkers' discs (``pos``, ``vel``
        ``(N, 2)``, ``radius`` ``(N,)``): the leaves yield to bodies wherever their hinges let them,
        and always to a ``fixed`` body (``(N,)`` bool: the user, whom nothing can push). ``auto``
        ``(N,)`` bool: who may push a leaf open just by walking into it (default: everyone);
        ``carried`` ``(N,)`` bool: riders of a revolving door, who move with its compartment."""
        n = np.asarray(pos).shape[0]
        fx = np.zeros(n, np.bool_) if fixed is None else np.ascontiguousarray(fixed, np.bool_)
        au = np.ones(n, np.bool_) if auto is None else np.ascontiguousarray(auto, np.bool_)
        p = np.ascontiguousarray(pos, np.float64)
        v = np.ascontiguousarray(vel, np.float64)
        r = np.ascontiguousarray(radius, np.float64)
        if len(self) and not self.panel.all():
            _step_leaves(self.hinge, self.base, self.length, self.angle, self.side, self.phase,
                         self.target, self.swing, self.panel, self.drive, self.close_speed, self.stop,
                         self.open_speed, p, v, r, fx, au, float(dt))
        rv = self.revolvers
        if len(rv):
            ca = np.zeros(n, np.bool_) if carried is None else np.ascontiguousarray(carried, np.bool_)
            _step_revolvers(rv.centre, rv.radius, rv.sense, rv.first, rv.rotation, rv.omega, rv.push,
                            self.base, self.length, self.angle, p, v, r, fx, ca, float(dt))

    def push_out(self, pos: np.ndarray, radius: np.ndarray, movable: np.ndarray) -> tuple[np.ndarray, float]:
        """Bodies yield to leaves that could not yield to them (at the door stop, closed against a
        body on its pull side, or caught between two walkers): each ``movable`` disc cutting into
        a leaf moves out along the leaf's normal. Returns the new positions and the deepest
        overlap left (m), which is the user's (never moved: a person's body cannot be pushed) or a
        disc's between two leaves."""
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


@dataclass
class Revolvers:
    """The revolving doors (§4.5.1): ``R`` doors of :data:`PANELS` panels each, panel rows
    ``first[r] .. first[r] + 3`` of :class:`DoorLeaves`. ``centre`` ``(R, 2)`` m, ``radius``
    ``(R,)`` m (half the span), ``sense`` ``(R,) int64`` +1 counter-clockwise, ``rotation``
    ``(R,)`` rad turned so far (every panel's leaf angle), ``omega`` ``(R,)`` rad/s (signed),
    ``push`` ``(R,)`` rad/s the speed the pushers drive it toward this step (>= 0, in the door's
    sense; set by the etiquette: a rotation driven by pushers)."""

    door: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    base: np.ndarray
    sense: np.ndarray
    first: np.ndarray
    rotation: np.ndarray
    omega: np.ndarray
    push: np.ndarray

    @classmethod
    def empty(cls) -> Revolvers:
        return cls.of([])

    @classmethod
    def of(cls, rows: list[tuple[int, np.ndarray, float, float, int, int]]) -> Revolvers:
        n = len(rows)
        return cls(door=np.asarray([r[0] for r in rows], np.int64),
                   centre=np.asarray([r[1] for r in rows], np.float64).reshape(n, 2),
                   base=np.asarray([r[2] for r in rows], np.float64),
                   radius=np.asarray([r[3] for r in rows], np.float64),
                   sense=np.asarray([r[4] for r in rows], np.int64),
                   first=np.asarray([r[5] for r in rows], np.int64),
                   rotation=np.zeros(n), omega=np.zeros(n), push=np.zeros(n))

    def __len__(self) -> int:
        return int(self.door.shape[0])

    def compartment_angle(self, r: int, k: int) -> float:
        """World direction (rad) of the middle of compartment ``k`` (between panels ``k`` and
        ``k + 1``, counted in the door's sense) of revolving door ``r``, now."""
        s = int(self.sense[r])
        return float(self.base[r] + self.rotation[r] + s * (k + 0.5) * 0.5 * math.pi)


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
def _step_leaves(hinge, base, length, angle, side, phase, target, swing, panel, drive, close_speed, stop,  # noqa: ANN001, ANN202
                 open_speed, pos, vel, radius, fixed, auto, dt):
    n = pos.shape[0]
    for i in range(hinge.shape[0]):
        if panel[i]:
            continue
        c, s = math.cos(base[i]), math.sin(base[i])
        w = length[i]
        sw = swing[i]
        lo_lim = 0.0 if sw > 0 else -MAX_ANGLE
        hi_lim = 0.0 if sw < 0 else MAX_ANGLE
        a = angle[i]
        if drive[i] == AUTO:
            # Who has a hand on this leaf: near its doorway line, inside it laterally, moving toward
            # it, from a side it may be pushed open from.
            held = False
            opener_side = 0
            nearest = 1e18
            for j in range(n):
                if not auto[j]:
                    continue
                qx, qy = pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1]
                along = qx * c + qy * s
                across = -qx * s + qy * c
                r = radius[j]
                if along < -r or along > w + r:
                    continue
                if sw != 0 and across * sw > 0 and abs(a) < PULL_CATCH_ANGLE:
                    continue  # on the pull side of a (nearly) closed one-way leaf: it takes a hand
                in_doorway = abs(across) < r
                closing_in = -(-vel[j, 0] * s + vel[j, 1] * c) * math.copysign(1.0, across)
                if in_doorway or (abs(across) < REACH + r and closing_in > APPROACH_SPEED):
                    held = True
                    if abs(across) < nearest:
                        nearest = abs(across)
                        opener_side = sw if sw != 0 else (-1 if across > 0 else 1)  # away from the walker
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
        # The procedure's (or the hand's) wish for this step.
        if drive[i] == HAND:
            step = HAND_SPEED * dt
            d = target[i] - a
            want = target[i] if abs(d) <= step else a + math.copysign(step, d)
        elif phase[i] == HELD or phase[i] == BOUNCE:
            step = (open_speed[i] if drive[i] == OPEN else OPEN_SPEED) * dt
            d = target[i] - a
            want = target[i] if abs(d) <= step else a + math.copysign(step, d)
            if phase[i] == HELD and target[i] != 0.0 and a * target[i] > target[i] * target[i]:
                want = a  # held further open by a body: the hand does not pull it back
        elif phase[i] == CLOSING:
            want = a * math.exp(-dt / CLOSE_TIME)
            cap = close_speed[i] * dt
            if abs(a - want) > cap:
                want = a - math.copysign(cap, a)
            if abs(want) < CLOSED_EPS:
                want = 0.0
            if not math.isnan(stop[i]) and stop[i] * a > 0.0 and abs(want) < abs(stop[i]) <= abs(a):
                want = stop[i]  # f_bounce's p_stop: the board halts here
        else:
            want = 0.0
        # Bodies: a disc the leaf is inside pushes it out, away from the disc's centre ...
        for _ in range(3):
            moved = False
            for j in range(n):
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w, radius[j])
                if lo < a < hi:
                    b = hi if 0.5 * (lo + hi) < a else lo
                    b = min(max(b, lo_lim), hi_lim)
                    if b != a:
                        a = b
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
        # way even into another walker, who is then pushed aside (DoorLeaves.push_out) -- where the
        # hinge lets it: a one-way leaf does not swing through its frame.
        for j in range(n):
            if fixed[j]:
                lo, hi = _blocked(pos[j, 0] - hinge[i, 0], pos[j, 1] - hinge[i, 1], c, s, w, radius[j])
                if lo < a < hi:
                    b = hi if 0.5 * (lo + hi) < a else lo
                    a = min(max(b, lo_lim), hi_lim)
        a = min(hi_lim, max(lo_lim, a))
        if a != 0.0 and side[i] != 0 and a * side[i] < 0:
            side[i] = 1 if a > 0 else -1  # pushed through to the other side
        if a == 0.0 and phase[i] == CLOSING:
            phase[i] = CLOSED
            side[i] = 0
            stop[i] = math.nan
        if side[i] == 0 and a != 0.0:
            side[i] = 1 if a > 0 else -1  # pushed open by a body without a hand on it
            if phase[i] == CLOSED:
                phase[i] = CLOSING
        angle[i] = a


@njit(cache=True)
def _step_revolvers(centre, radius, sense, first, rotation, omega, push, base, length, angle,  # noqa: ANN001, ANN202
                    pos, vel, rad, fixed, carried, dt):
    """Turn each revolving door: toward the pushers' speed (or to a stop without them), never
    sweeping a panel into a body that does not ride in it; the user pushes it out of the way."""
    n = pos.shape[0]
    for d in range(centre.shape[0]):
        sg = sense[d]
        w = omega[d] * sg  # in the door's sense
        goal = push[d]
        if goal > w:
            w = min(goal, w + REVOLVE_ACCEL * dt)
        else:
            w = max(goal, w - REVOLVE_DRAG * dt)
        w = max(w, 0.0)
        delta = w * dt  # wished rotation this step, in the door's sense
        # The user's body pushes the door round (either way) out of its way, whatever else.
        forced = 0.0
        for j in range(n):
            if not fixed[j]:
                continue
            for k in range(PANELS):
                i = first[d] + k
                b0 = base[i] + angle[i]
                lo, hi = _blocked(pos[j, 0] - centre[d, 0], pos[j, 1] - centre[d, 1], math.cos(b0),
                                  math.sin(b0), length[i], rad[j])
                if lo < 0.0 < hi:
                    # in the door's sense: rotating by +x moves the panel toward hi when sg > 0
                    fwd = hi if sg > 0 else -lo
                    back = -lo if sg > 0 else hi
                    if fwd <= back:
                        forced = max(forced, fwd)
                    else:
                        forced = min(forced, -back)
        if forced != 0.0:
            delta = forced
            # ...but with others at the drum a panel's tip moves no more than USER_SWEEP_MAX a
            # step (the contact pass moves them that little); the user may lean into a panel
            # meanwhile (nothing ever moves the user).
            for j in range(n):
                if carried[j] or fixed[j]:
                    continue
                qx, qy = pos[j, 0] - centre[d, 0], pos[j, 1] - centre[d, 1]
                if qx * qx + qy * qy <= (radius[d] + rad[j] + SWEEP_CLEARANCE) ** 2:
                    cap = USER_SWEEP_MAX / radius[d]
                    delta = max(-cap, min(cap, delta))
                    break
        else:
            # p_stop: a panel stops SWEEP_CLEARANCE short of anyone it would sweep into.
            for j in range(n):
                if carried[j] or fixed[j]:
                    continue
                qx, qy = pos[j, 0] - centre[d, 0], pos[j, 1] - centre[d, 1]
                if qx * qx + qy * qy > (radius[d] + rad[j] + SWEEP_CLEARANCE) ** 2:
                    continue
                for k in range(PANELS):
                    i = first[d] + k
                    b0 = base[i] + angle[i]
                    lo, hi = _blocked(qx, qy, math.cos(b0), math.sin(b0), length[i], rad[j] + SWEEP_CLEARANCE)
                    if lo > hi:
                        continue
                    ahead = lo if sg > 0 else -hi  # how far it turns, in the door's sense, before it touches
                    if ahead >= 0.0:
                        delta = min(delta, ahead)
                    elif (hi if sg > 0 else -lo) > 0.0:
                        delta = min(delta, 0.0)  # already touching: it does not turn further into them
            delta = max(delta, 0.0)
        rotation[d] += sg * delta
        omega[d] = sg * delta / dt
        for k in range(PANELS):
            angle[first[d] + k] = rotation[d]


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
