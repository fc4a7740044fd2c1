"""A scripted user who handles doors as a person would (headless runs of door scenes).

The scripted users of :mod:`pedvr.crowd.user` walk their route straight through a doorway;
at a one-way door pulled from the user's side that walk would press the user against a closed
leaf (nothing moves the user, and a pulled leaf cannot open into someone standing in its swing).
:class:`DoorUser` walks the same route and at each door it meets does what the desktop or
headset user does with ``E`` or the trigger (:meth:`EtiquetteCore.user_hand`):

* **pull side**: it steps to the handle, outside the leaf's swing, presses, waits until the leaf
  is open and ``hold`` seconds more (agents behind it pass first, PF), then walks round the leaf's
  edge and through, letting go once past;
* **push side** (and double-acting doors): it presses as it reaches the leaf, walks through,
  stops just past the doorway holding the door behind it for ``hold`` seconds (agents behind
  take it over, PL), and lets go;
* **revolving door**: it walks round through a compartment on the keep-right half, pushing the
  panels (they give way to the user's body).

Like a person, it does not walk into a doorway through which someone is coming its way: it
steps aside, off the passing lane beside the doorway, and goes on once the doorway is clear
(:meth:`DoorUser._step_aside`).

With ``hold = 0`` it only opens the doors it must open. Poses are a function of the time
it is asked about (``pose(t)`` is called once per step with increasing ``t``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from pedvr.etiquette.regions import BOP_PULL_POLAR, HOLD_ANGLE, LANE_AT, PULL_HAND_AT, LeafFrame

if TYPE_CHECKING:
    from pedvr.crowd.state import CrowdState
    from pedvr.etiquette.core import EtiquetteCore

DRUM_SPEED = 0.4  # m/s: in a revolving door's drum the user walks slowly (the panels turn with the user)
CLEARANCE = 0.06  # m beyond touching discs that the scripted user keeps from anyone it walks toward
COMING_SPEED = 0.15  # m/s toward the user's side: someone in or at the doorway coming through
GIVE_WAY_S = 15.0  # s the user waits aside at most, then goes on whoever is in the doorway
SEES_THROUGH = math.radians(20.0)  # a leaf open this far shows the user the door's far side (_coming)
WALK, TO_HANDLE, OPENING, HOLDING, THROUGH, PAST_HOLD, REJOIN, GIVE_WAY = range(8)


class DoorUser:
    """A scripted user that opens and holds doors (module docstring)."""

    def __init__(self, path: np.ndarray, *, speed: float, heading: float, radius: float, hold: float,
                 etiquette: EtiquetteCore,
                 perceive: Callable[[], CrowdState] | None = None,
                 inside: Callable[[np.ndarray], bool] | None = None) -> None:
        self.et = etiquette
        self.perceive = perceive  # () -> the crowd now: who is where, how fast, with what ahead of them
        self.inside = inside  # whether a point is walkable (where to step aside); None: anywhere
        self.speed = float(speed)
        self.radius = float(radius)
        self.hold = float(hold)
        self.path = self._thread_revolving(np.asarray(path, np.float64).reshape(-1, 2))
        seg = np.diff(self.path, axis=0)
        self._len = np.linalg.norm(seg, axis=1)
        self._cum = np.concatenate([[0.0], np.cumsum(self._len)])
        self._heading = heading
        self._s = 0.0
        self._t: float | None = None
        self._pos = self.path[0].copy()
        self.mode = WALK
        self._door = -1
        self._leaf = -1
        self._frame: LeafFrame | None = None
        self._since = 0.0
        self._may_give_way = True
        self._own = 1
        self._world_side = 1
        self._goal: list[np.ndarray] = []
        self._done: set[tuple[float, int]] = set()
        self.crossings = self._crossings()

    # -- the route -------------------------------------------------------------------------

    def _thread_revolving(self, path: np.ndarray) -> np.ndarray:
        """Replace a straight crossing of a revolving door by an arc through its keep-right half."""
        rv = self.et.leaves.revolvers
        out = [path[0]]
        for a, b in zip(path[:-1], path[1:], strict=True):
            for r in range(len(rv)):
                c = rv.centre[r]
                rad = float(rv.radius[r])
                d = b - a
                n = float(np.hypot(*d))
                if n < 1e-9:
                    continue
                t = float(np.clip((c - a) @ d / (n * n), 0.0, 1.0))
                if float(np.hypot(*(a + t * d - c))) > 0.9 * rad:
                    continue
                u = d / n
                right = np.array([u[1], -u[0]]) * float(rv.sense[r])
                ride = 0.55 * rad
                for ang in np.linspace(-1.0, 1.0, 7):
                    phi = math.pi * 0.5 * ang
                    out.append(c + ride * (math.sin(phi) * u + math.cos(phi) * right))
            out.append(b)
        return np.asarray(out)

    def _crossings(self) -> list[tuple[float, int]]:
        """(arc length, door) where the route crosses each hinged door."""
        out = []
        for k, d in enumerate(self.et.doors):
            if d.kind == "revolving":
                continue
            p, q = np.asarray(d.span[0]), np.asarray(d.span[1])
            for i in range(self.path.shape[0] - 1):
                a, b = self.path[i], self.path[i + 1]
                den = (b[0] - a[0]) * (q[1] - p[1]) - (b[1] - a[1]) * (q[0] - p[0])
                if abs(den) < 1e-12:
                    continue
                s = ((p[0] - a[0]) * (q[1] - p[1]) - (p[1] - a[1]) * (q[0] - p[0])) / den
                u = ((p[0] - a[0]) * (b[1] - a[1]) - (p[1] - a[1]) * (b[0] - a[0])) / den
                if 0.0 <= s <= 1.0 and 0.0 <= u <= 1.0:
                    out.append((float(self._cum[i] + s * self._len[i]), k))
        return sorted(out)

    def _at(self, s: float) -> tuple[np.ndarray, float]:
        s = min(max(s, 0.0), float(self._cum[-1]))
        k = int(np.searchsorted(self._cum, s, side="right") - 1)
        k = min(max(k, 0), self._len.shape[0] - 1)
        while k > 0 and self._len[k] == 0.0:
            k -= 1
        d = (self.path[k + 1] - self.path[k]) / max(float(self._len[k]), 1e-12)
        return self.path[k] + d * (s - self._cum[k]), math.atan2(d[1], d[0])

    # -- UserInput ----------------------------------------------------------------------------

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        """The user's pose at ``t``; like a person, it does not step into someone: a step that
        would bring it within :data:`CLEARANCE` of a pedestrian's disc, closer than it is now,
        is not taken (the user waits a moment; the door procedures go on)."""
        before, s_before, h_before = self._pos.copy(), self._s, self._heading
        pos, heading = self._pose(t)
        if self.perceive is not None and self._blocked(before, pos):
            self._pos, self._s = before, s_before
            return before.copy(), h_before
        return pos, heading

    def _blocked(self, a: np.ndarray, b: np.ndarray) -> bool:
        assert self.perceive is not None
        c = self.perceive()
        if not len(c):
            return False
        others = ~c.is_user
        need = c.radius[others] + self.radius + CLEARANCE
        d_a = np.hypot(*(c.pos[others] - a).T)
        d_b = np.hypot(*(c.pos[others] - b).T)
        return bool(np.any((d_b < need) & (d_b < d_a - 1e-9)))

    def _pose(self, t: float) -> tuple[np.ndarray, float]:
        dt = 0.0 if self._t is None else max(0.0, t - self._t)
        self._t = t
        if self.path.shape[0] < 2 or float(self._cum[-1]) == 0.0:
            return self.path[0].copy(), self._heading
        if self.mode == WALK:
            nxt = next(((s, k) for s, k in self.crossings if s > self._s - 0.2 and (s, k) not in self._done),
                       None)
            if nxt is not None and nxt[0] - self._s < self._approach(nxt[1]):
                self._start_door(nxt, t)
            else:
                speed = min(self.speed, DRUM_SPEED) if self._in_drum(self._pos) else self.speed
                self._s = min(self._s + speed * dt, float(self._cum[-1]))
                self._pos, self._heading = self._at(self._s)
                return self._pos.copy(), self._heading
        return self._door_step(t, dt)

    def _in_drum(self, p: np.ndarray) -> bool:
        rv = self.et.leaves.revolvers
        for r in range(len(rv)):
            if float(np.hypot(*(p - rv.centre[r]))) < float(rv.radius[r]) + self.radius + 0.3:
                return True
        return False

    def _approach(self, k: int) -> float:
        return 1.6

    def _start_door(self, crossing: tuple[float, int], t: float) -> None:
        s, k = crossing
        self._done.add(crossing)
        et = self.et
        ds = et.dstate[k]
        side = 1 if float((self._pos - ds.centre) @ ds.n) >= 0.0 else -1
        leaves = ds.leaves
        cross_pt, _ = self._at(s)
        mids = et.leaves.hinge + 0.5 * (et.leaves.tips() - et.leaves.hinge)
        leaf = min(leaves, key=lambda i: float(np.hypot(*(mids[i] - cross_pt))))
        self._door, self._leaf = k, leaf
        self._frame = et.frame(leaf, side)
        self._own = self._frame.side_of(self._pos)  # the side it comes from: +1 the leaf's pull side
        self._world_side = side  # the same, as the etiquette's walkers count sides
        self._cross_s = s
        self._begin(t)

    def _begin(self, t: float, *, give_way: bool = True) -> None:
        """At the door: step aside for someone coming through (``give_way``), follow a holder
        through, or open the door itself."""
        aside = self.mode == GIVE_WAY
        self._open_or_follow(t, give_way=give_way)
        if aside and self.mode != GIVE_WAY and self._goal:
            # from beside the doorway back onto the passing lane in front of it first: straight from
            # there to the doorway, its disc cut the jamb by the hinge, and the open leaf with it
            fr = self._frame
            assert fr is not None
            out = fr.outer(self.radius) + 0.1 if self._own > 0 else self.radius + 0.5
            self._goal.insert(0, fr.lane(self._own * out))

    def _open_or_follow(self, t: float, *, give_way: bool) -> None:
        et = self.et
        fr = self._frame
        assert fr is not None
        k, leaf = self._door, self._leaf
        self._since = t
        if give_way and self._coming():
            self._step_aside(t)
            return
        pull = fr.side_of(self._pos) > 0
        # until it holds a door it opened itself; not again after waiting aside for GIVE_WAY_S
        self._may_give_way = give_way
        held = et.dstate[k].holder.get(leaf, et.dstate[k].mutex.get(leaf))
        if held is not None and held != et.user_id:
            # someone else has the door (and may be holding it for the user): walk through it
            side_local = 1 if pull else -1
            self.mode = THROUGH
            self._hold_past = False
            wait = fr.w + self.radius + 0.3 if pull else self.radius + 0.5  # outside the leaf's swing
            self._goal = [fr.lane(side_local * wait), fr.lane(0.0),
                          fr.lane(-side_local * (self.radius + 0.8))]
            self._waiting_open = True
            return
        self._waiting_open = False
        if pull:
            self.mode = TO_HANDLE
            bop = fr.polar(fr.outer(self.radius), BOP_PULL_POLAR)
            self._goal = [bop]
        else:
            self.mode = THROUGH
            et.user_hand(True)
            self._goal = [fr.lane(self.radius + 0.45)]  # just past the doorway, beside the lane
            self._hold_past = self.hold > 0.0

    # -- giving way ---------------------------------------------------------------------------

    def _coming(self) -> bool:
        """Someone coming through the door toward the user's side, as a person there would see it:
        in the doorway, walking toward the user's side faster than :data:`COMING_SPEED`; and, once
        a leaf of the door is open (:data:`SEES_THROUGH`: a closed door hides its far side), one
        doing so up to 1.5 m beyond the doorway, or a pram pusher of this door from the far side
        backing through (it backs its pram through, then turns round where it comes out: its
        steering, giving way to a user walking at it, backs it away again, so it never looks as if
        it were coming)."""
        if self.perceive is None:
            return False
        fr = self._frame
        assert fr is not None
        leaves = list(self.et.dstate[self._door].leaves)
        seen = float(np.abs(self.et.leaves.angle[leaves]).max()) >= SEES_THROUGH
        if seen:
            for o in self.et.walkers.values():
                if o.door == self._door and o.backing and o.side != self._world_side and not o.is_user:
                    return True
        c = self.perceive()
        own = self._own
        rel = c.pos - fr.hinge
        lx = rel @ fr.e
        ly = own * (rel @ fr.m)  # depth toward the user's side
        vy = own * (c.vel @ fr.m)
        return bool(np.any(~c.is_user & (lx > -0.3) & (lx < fr.w + 0.3) & (ly > (-1.5 if seen else -0.3))
                           & (ly < 0.6) & (vy > COMING_SPEED)))

    def _doorway_busy(self) -> bool:
        """Someone coming (:meth:`_coming`), or anyone's body or pushed pram still in the doorway
        (within 0.6 m of its line, between its jambs)."""
        if self._coming():
            return True
        assert self.perceive is not None
        c = self.perceive()
        fr = self._frame
        assert fr is not None
        others = ~c.is_user
        reach = c.ahead[others] + c.length[others] if len(c.length) else np.zeros(int(others.sum()))
        head = np.stack([np.cos(c.heading[others]), np.sin(c.heading[others])], axis=1)
        for f in (0.0, 0.25, 0.5, 0.75, 1.0):  # the body, and points along what it pushes
            rel = c.pos[others] + head * (f * reach)[:, None] - fr.hinge
            lx, ly = rel @ fr.e, rel @ fr.m
            pad = c.radius[others] if f == 0.0 else 0.3
            if np.any((lx > -0.2 - pad) & (lx < fr.w + 0.2 + pad) & (np.abs(ly) < 0.6 + pad)):
                return True
        return False

    def _step_aside(self, t: float) -> None:
        """Off the passing lane beside the doorway, on the user's side: beyond the hinge on the push
        side (the leaf swings away from there); beyond the free edge on the pull side, clear of
        the leaf's swing (its pocket is at the hinge) and of a neighbouring leaf's."""
        fr = self._frame
        assert fr is not None
        if self.et.user_leaf >= 0:
            self.et.user_hand(False)  # a hand pressed on the leaf lets go: the user is not going through yet
        own = self._own
        r = self.radius
        hinge_side = fr.world(-(r + 0.35), own * (r + 0.5))
        edge_side = fr.world(fr.w + r + 0.35, own * (fr.w + r + 0.3 if own > 0 else r + 0.5))
        spots = [hinge_side, edge_side] if own < 0 else [edge_side]
        spot = next((p for p in spots if self.inside is None or self.inside(p)), self._pos.copy())
        self.mode = GIVE_WAY
        self._goal = [spot]
        self._since = t

    def _walk_to(self, goal: np.ndarray, dt: float) -> bool:
        d = goal - self._pos
        n = float(np.hypot(*d))
        if n < 1e-6:
            return True
        step = min(n, self.speed * 0.7 * dt)
        self._pos = self._pos + d / n * step
        self._heading = math.atan2(d[1], d[0])
        return n - step < 0.05

    def _door_step(self, t: float, dt: float) -> tuple[np.ndarray, float]:
        et = self.et
        fr = self._frame
        assert fr is not None
        if self.mode == TO_HANDLE:
            if len(self._goal) > 1:  # back onto the lane first (after stepping aside), then to the handle
                if self._walk_to(self._goal[0], dt):
                    self._goal.pop(0)
            elif self._walk_to(self._goal[0], dt):
                # its hand goes to the handle it means, as the headset user's controller does: a
                # press takes the handle nearest the hand, and a reach straight ahead at a double
                # door's middle could find the other leaf's handle as near (the user then opened
                # one leaf and walked into the other, closed one, 25 cm deep)
                handle = fr.handle(et.leaf_open(self._leaf, fr), PULL_HAND_AT)
                self._heading = math.atan2(*(handle - self._pos)[::-1])
                et.user_hand(True, hand=(float(handle[0]), float(handle[1])))
                self.mode = OPENING
                self._since = t
        elif self.mode == OPENING:
            if et.user_hand_point is not None:  # the press has taken the handle (the step before)
                et.user_hand_moved(None)  # the hand no longer leads the leaf: it opens by itself
            open_now = et.leaf_open(self._leaf, fr)
            if open_now >= HOLD_ANGLE - math.radians(12.0) or t - self._since > 3.0:
                self.mode = HOLDING
                self._since = t
        elif self.mode == HOLDING:
            if t - self._since >= self.hold:
                # round the leaf's edge into the doorway and through
                a = et.leaf_open(self._leaf, fr)
                round_edge = max(a - math.radians(30.0), math.radians(15.0))
                self._goal = [fr.polar(fr.outer(self.radius), round_edge),
                              fr.world(LANE_AT * fr.w, self.radius + 0.2), fr.lane(-(self.radius + 0.8))]
                self._hold_past = False
                self._may_give_way = False  # it holds the door it opened: whoever comes, comes through
                self.mode = THROUGH
        elif self.mode == GIVE_WAY:
            if self._goal and self._walk_to(self._goal[0], dt):
                self._goal.pop(0)
            waited = t - self._since > GIVE_WAY_S
            if waited or not self._doorway_busy():
                self._begin(t, give_way=not waited)
        elif self.mode == THROUGH:
            if (self._may_give_way and self._own * fr.local(self._pos)[1] > self.radius + 0.3
                    and self._coming()):
                self._step_aside(t)  # someone is coming through: the user has not stepped in yet
                return self._pos.copy(), self._heading
            shut = et.leaf_open(self._leaf, fr) < math.radians(60.0)
            if self._waiting_open and len(self._goal) == 2 and shut:
                # at the doorway while the door is not (yet) open for the user: wait for it
                if t - self._since > 12.0:
                    self._waiting_open = False
                    self.mode = TO_HANDLE  # nobody opens it: open it itself
                    self._goal = [fr.polar(fr.outer(self.radius), BOP_PULL_POLAR)] if fr.side_of(
                        self._pos) > 0 else [self._pos.copy()]
                return self._pos.copy(), self._heading
            if self._goal and self._walk_to(self._goal[0], dt):
                self._goal.pop(0)
            if not self._goal:
                if self._hold_past:
                    self.mode = PAST_HOLD
                    self._since = t
                else:
                    et.user_hand(False)
                    self._rejoin()
        elif self.mode == PAST_HOLD:
            if t - self._since >= self.hold:
                et.user_hand(False)
                self._rejoin()
        elif self.mode == REJOIN:
            if self._walk_to(self._goal[0], dt):
                self._s = self._rejoin_s
                self.mode = WALK
        return self._pos.copy(), self._heading

    def _rejoin(self) -> None:
        """Walk back onto the route a little past the door, then on along it."""
        s = self._cross_s + 0.8
        self._rejoin_s = s
        p, _ = self._at(s)
        self._goal = [p]
        self.mode = REJOIN
