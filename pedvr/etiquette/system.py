"""Door and doorway etiquette in the running simulation (Huang & Terzopoulos §3–6, App. B).

:class:`DoorEtiquette` is one simulation's etiquette layer. At the decision rate (30 Hz, in
the ``decide`` phase) it finds who is about to pass which door (a pedestrian whose path crosses
a door within the door's sensing range), orders them (Alg. 1–4, :mod:`.ordering`), and runs the
state-based door interaction model of App. B for holders and followers of hinged doors
(:mod:`.interaction`) and the push-and-pass model of revolving doors (:mod:`.revolving`). Every
simulation step it turns what it decided into motion: it overrides the preferred velocity and
facing of the pedestrians it drives (``steer``, after the plan phase), carries the riders of a
revolving door (``carry``, after ORCA), lets each holder's hand drive its leaf and the leaf lead
the hand (``before_doors`` / ``after_doors``, around the door step) and keeps a holder facing
the door while it steps aside (``face``).

The user takes part (no anchor has this): the user is a pedestrian of the ordering, a possible
follower for whom agents decide HOF / HOL / NH with the same network (Care from the user's
profile: ``[user] sex`` and ``carrying``, or the study protocol), and a possible holder (a
backend calls :meth:`DoorEtiquette.user_hand`). The user is observed, never driven; an agent
holding a door for the user is the holder of a ``door_hold`` event in which the user is an
actor, so the user-encounter model leaves it alone (``Scheduler.engaged_with_user``).

Determinism: walkers are visited in id order; every draw (traits, sampled decisions, how a
follower thanks) comes from the etiquette's own generator, a child spawned from the
simulation's (so scenes without doors draw exactly what they drew before).
"""


from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit

from pedvr.body import skeleton as sk
from pedvr.body.steps import RIGHT
from pedvr.etiquette.core import DoorState, EtiquetteCore, Walker
from pedvr.etiquette.doors import OPEN, hand_angle, hand_point
from pedvr.etiquette.interaction import decide_hinged
from pedvr.etiquette.objects import DoorObject
from pedvr.etiquette.regions import HAND_HEIGHT, HOLD_ANGLE, point_segment
from pedvr.etiquette.revolving import carried, carry_riders, decide_revolving
from pedvr.etiquette.vocab import (
    APPROACH,
    CLEAR,
    DEADLOCK_AFTER,
    DEADLOCK_FREE_S,
    ENTRANT,
    EXITING,
    FOLLOWER,
    HOLD_DOOR,
    HOLDER,
    HOLDER_DEC,
    IDLE_ANGLE,
    IDLE_LIFT,
    NONE,
    PASS_CONFIRM,
    PASSING,
    PURSUIT_LOOK,
    RIDER,
    RUSH_SPEEDUP,
    SENSE_USER,
    USER_AFTER_PASS,
    WAIT_ENDS,
)

if TYPE_CHECKING:
    from pedvr.crowd.state import CrowdState

# A walker held back on its way to a key pose turns toward where it wants to go (DoorEtiquette._held_back)
HELD_BACK_WANT = 0.5  # m/s of preferred speed at least: it wants to walk
HELD_BACK_SPEED = 0.4  # m/s: it moves slower than this
HELD_BACK_ANGLE = math.radians(45.0)  # and this far off the way it wants

__all__ = ["DoorEtiquette", "DoorState", "Walker"]


class DoorEtiquette(EtiquetteCore):
    """The etiquette layer of one simulation (module docstring). Keyword-only set-up, as
    :class:`~pedvr.etiquette.core.EtiquetteCore`."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # passages from positions (track_passages): per crowd row, its position at the last tick
        # and, per door, the side it crossed the doorway from (0: none pending)
        self._trk_ids = np.zeros(0, np.int64)
        self._trk_prev = np.zeros((0, 2))
        self._trk_pend = np.zeros((0, len(self.doors)), np.int8)
        self.last_passage = [0.0] * len(self.doors)  # s: when each door last passed someone
        self._user_through: dict[int, float] = {}  # door -> when the user last went through it

    def smart_objects(self) -> dict[str, Any]:
        """Every door as a smart object (``pass``, ``hold``), named as in the scene."""
        return {d.name: DoorObject.of(self, k) for k, d in enumerate(self.doors)}

    # -- the decision tick -------------------------------------------------------------------

    def decide(self, t: float, crowd: CrowdState, paths: list[np.ndarray], cursor: np.ndarray) -> None:
        """At the decision rate, in the ``decide`` phase (before the scheduler ticks)."""
        self.t = t
        self._run_later(t)
        self.track_passages(crowd)
        self._engage(crowd, paths, cursor)
        for k, ds in enumerate(self.dstate):
            ws = [w for w in self._walkers_at(k)]
            if not ws:
                continue
            if ds.kind == "revolving":
                decide_revolving(self, k, ws, crowd)
            else:
                decide_hinged(self, k, ws, crowd)
        self._watch_deadlocks(crowd)

    def _walkers_at(self, k: int) -> list[Walker]:
        return sorted((w for w in self.walkers.values() if w.door == k), key=lambda w: w.id)


    def _path_doors(self, agent: int, path: np.ndarray) -> list[tuple[int, int]]:
        """(door, waypoint index) for every door the path crosses, cached per path object."""
        cached = self._path_cache.get(agent)
        if cached is not None and cached[0] == id(path):
            return cached[1]
        out: list[tuple[int, int]] = []
        if path.shape[0] >= 2:
            a, b = path[:-1], path[1:]
            for k, d in enumerate(self.doors):
                p, q = np.asarray(d.span[0]), np.asarray(d.span[1])
                hit = _segments_cross(a, b, p, q)
                for i in np.flatnonzero(hit):
                    out.append((k, int(i) + 1))
        self._path_cache[agent] = (id(path), out)
        return out

    def _before(self, k: int, p: np.ndarray, start: np.ndarray) -> bool:
        """Whether ``p`` is on the same side of door ``k``'s line as ``start`` (a leg's start)."""
        ds = self.dstate[k]
        return float((p - ds.centre) @ ds.n) * float((start - ds.centre) @ ds.n) > 0.0

    def _engage(self, crowd: CrowdState, paths: list[np.ndarray], cursor: np.ndarray) -> None:
        """Who takes part in which door's etiquette now (and who is done)."""
        pos = crowd.pos
        n = len(crowd)
        # the leg each walks now, from where it is to its current waypoint, against every door: (N, D)
        ahead = pos.copy()
        for r in range(n):
            path = paths[r]
            if path.shape[0] >= 2:
                ahead[r] = path[min(int(cursor[r]), path.shape[0] - 1)]
        leg_cross = np.zeros((n, len(self.doors)), np.bool_)
        for k, d in enumerate(self.doors):
            leg_cross[:, k] = _segments_cross(pos, ahead, np.asarray(d.span[0]), np.asarray(d.span[1]))
        for r in range(n):
            agent = int(crowd.ids[r])
            if bool(crowd.is_user[r]):
                self._engage_user(r, agent, crowd)
                continue
            w = self.walkers.get(agent)
            path = paths[r]
            c = int(cursor[r])
            # the doors its path crosses from here on; on the leg it walks now, only while it is
            # still on the side that leg starts from: someone who walked through as an approacher
            # (a door its holder let go, NH) has passed, and is not an approacher from the far side
            # (door_single_flow seed 1: one walked through, was taken for one coming from the
            # other side, and was sent back through the door to queue)
            crossing = [(k, i) for k, i in self._path_doors(agent, path)
                        if i > c or (i == c and self._before(k, pos[r], path[c - 1]))]
            if path.shape[0] >= 2:
                crossing.extend((int(k), c) for k in np.flatnonzero(leg_cross[r]))
            if w is None:
                for k, _ in crossing:
                    ds = self.dstate[k]
                    if float(np.hypot(*(pos[r] - ds.centre))) <= self.doors[k].sensing_range:
                        side = 1 if float((pos[r] - ds.centre) @ ds.n) >= 0.0 else -1
                        self.walkers[agent] = Walker(id=agent, door=k, side=side, since=self.t,
                                                     speed=float(crowd.pref_speed[r]),
                                                     waited=self.waited_at.pop((agent, k), 0.0),
                                                     first_wait=self.wait_since_at.pop((agent, k), math.nan),
                                                     last_wait=self.t)
                        break
                continue
            if w.role == APPROACH and not any(k == w.door for k, _ in crossing):
                self._drop(w, why="no longer passing")

    def _engage_user(self, r: int, agent: int, crowd: CrowdState) -> None:
        pos, vel = crowd.pos[r], crowd.vel[r]
        w = self.walkers.get(agent)
        if w is not None:
            if float(np.hypot(*vel)) >= SENSE_USER:
                w.still_since = math.nan
            elif math.isnan(w.still_since):
                w.still_since = self.t
            ds = self.dstate[w.door]
            rel = pos - ds.centre
            through = float(rel @ ds.n) * w.side < -(CLEAR + 0.25)
            far = float(np.hypot(*rel)) > self.doors[w.door].sensing_range
            if w.role != HOLDER and (through or far):
                h = self.walkers.get(w.holder) if through and w.holder != NONE else None
                if h is not None and h.state == HOLD_DOOR and h.follower == w.id:
                    self.log("held_for_user", h, action=h.action)  # the user walked through the held door
                if through:
                    self._user_through[w.door] = self.t
                self._drop(w, why="passed" if through else "walked away")
            return
        for k, ds in enumerate(self.dstate):
            rel = pos - ds.centre
            dist = float(np.hypot(*rel))
            if dist > self.doors[k].sensing_range or dist < 1e-9:
                continue
            if self.t - self._user_through.get(k, -math.inf) < USER_AFTER_PASS and self.user_leaf < 0:
                continue  # just through it: stepping back onto its way is not coming to the door
            lateral = abs(float(rel @ ds.u))
            if lateral > 0.5 * self.doors[k].width + 1.5:
                continue
            toward = -float(vel @ rel) / dist
            if toward > SENSE_USER or (dist < 2.0 and self.user_leaf >= 0):
                side = 1 if float(rel @ ds.n) >= 0.0 else -1
                self.walkers[agent] = Walker(id=agent, door=k, side=side, is_user=True, since=self.t)
                return

    # -- per step: motion ----------------------------------------------------------------------

    def steer(self, crowd: CrowdState) -> None:
        """After the plan phase: the preferred velocity and facing of every pedestrian the
        etiquette drives, and the speed of those it only hurries (Rush, catching up)."""
        if not self.walkers:
            return
        pv, ph = crowd.pref_vel, crowd.pref_heading
        for w in self.walkers.values():
            if w.is_user:
                continue
            r = self._row.get(w.id)
            if r is None:
                continue
            if w.role == RIDER:
                continue  # carried (``carry``)
            scale = 1.0 + RUSH_SPEEDUP * (1.0 if w.helping != NONE else float(self.rush[r]))
            if w.plan is None:
                if w.waiting or not math.isnan(w.face):
                    pv[r] = 0.0
                    if not math.isnan(w.face):
                        ph[r] = w.face
                else:
                    v = pv[r] * scale
                    sp = float(np.hypot(*v))
                    if sp > crowd.max_speed[r]:
                        v *= crowd.max_speed[r] / sp
                    pv[r] = v
                continue
            p = crowd.pos[r]
            last = w.plan.shape[0] - 1
            # on from the nearest key ahead (a body pushed past its keys does not walk back to them)
            k = w.plan_i + int(np.argmin(np.hypot(*(w.plan[w.plan_i:] - p).T)))
            while k < last and float(np.hypot(*(w.plan[k] - p))) < 0.2:
                k += 1
            # a body pushed abreast of its key (within half a metre, level with it or past it along
            # the way to the next) walks on to the next rather than sideways back to it
            while k < last and float(np.hypot(*(w.plan[k] - p))) < 0.5 \
                    and float((p - w.plan[k]) @ (w.plan[k + 1] - w.plan[k])) >= 0.0:
                k += 1
            # A rigid footprint (a pram) cannot step sideways: it pursues the point PURSUIT_LOOK
            # ahead along its keys (pure pursuit), not the keys one by one.
            target = None
            if crowd.length[r] > 0.0:
                k, target = pursuit_point(w.plan, w.plan_i, p, PURSUIT_LOOK)
            w.plan_i = k
            d = (w.plan[k] if target is None else target) - p
            dist = float(np.hypot(*d))
            speed = min(w.speed * (scale if w.role in (APPROACH, FOLLOWER, ENTRANT, PASSING) else 1.0),
                        float(crowd.max_speed[r]))
            if k == last:
                speed = min(speed, dist / 0.45)
            if dist < 1e-6:
                pv[r] = 0.0
            else:
                pv[r] = d / dist * speed
            if (k == last and dist < 0.35) or w.lock:
                if not math.isnan(w.face):
                    ph[r] = w.face
            else:
                ph[r] = math.atan2(d[1], d[0])

    def face(self, heading: np.ndarray, prev: np.ndarray, crowd: CrowdState, dt: float, *,
             coupled: bool = True) -> np.ndarray:
        """After the body's animate: walkers stepping sideways or back around a door keep facing
        the door (App. C's constrained steps), turning no faster than the body's turn rate; and,
        coupled, a walker held back on its way to a key pose (:meth:`_held_back`) turns toward
        where it wants to go at its standing turn rate, not toward where it drifts."""
        out = heading
        for w in self.walkers.values():
            if w.is_user:
                continue
            r = self._row.get(w.id)
            if r is None:
                continue
            if w.lock and not math.isnan(w.face):
                want = w.face
            elif coupled and w.plan is not None and self._held_back(r, crowd):
                want = float(crowd.pref_heading[r])
            else:
                continue
            delta = (want - prev[r] + math.pi) % (2 * math.pi) - math.pi
            lim = float(crowd.limits[r, 2]) * dt  # the standing turn rate: these are slow steps
            out[r] = prev[r] + max(-lim, min(lim, delta))
        return out

    @staticmethod
    def _held_back(r: int, crowd: CrowdState) -> bool:
        """Whether row ``r``, walking to a key pose, is held back: it wants to walk
        (:data:`HELD_BACK_WANT`) but moves slower than :data:`HELD_BACK_SPEED`, in a direction more
        than :data:`HELD_BACK_ANGLE` off the one it wants (issue 26).

        The body turns toward its motion (``pedvr.body.simple.root_motion_kernel``), and coupled ORCA
        keeps the motion inside the body's limits, which are narrow sideways: a body that a leaf or
        a neighbour deflects turns toward the deflection, and then cannot walk where it wanted. A
        puller who had held the door at its edge, facing the handle, and was to walk on into the
        doorway (HOL) drifted at 0.2 m/s toward the leaf, turning with the drift, and stood at the
        leaf's tip for 40 s (door_single_flow seed 12 from 38 s, the last passage at 79 s). A
        person held back turns toward where they want to go and steps that way; so does a walker
        here, at its standing turn rate. A pushed pram (it steers) is left to its own rules, and so
        is ``decoupled`` (``face(..., coupled=False)``): its discs face their motion, its ORCA knows
        no body limits, and it stays the paper's plain baseline (with the rule, door_double_flow
        under ``decoupled`` passed 22 of 30 in 90 s, against 30;
        ``tests/etiquette/test_double_door_pocket.py``)."""
        if float(crowd.length[r]) > 0.0:
            return False
        want = float(np.hypot(*crowd.pref_vel[r]))
        vx, vy = float(crowd.vel[r, 0]), float(crowd.vel[r, 1])
        speed = math.hypot(vx, vy)
        if want < HELD_BACK_WANT or speed >= HELD_BACK_SPEED:
            return False
        if speed < 1e-6:
            return True
        off = (math.atan2(vy, vx) - float(crowd.pref_heading[r]) + math.pi) % (2 * math.pi) - math.pi
        return abs(off) > HELD_BACK_ANGLE

    def engaged_with_user(self, crowd: CrowdState) -> np.ndarray:
        """``(N,)`` agents in a door interaction at a door the user takes part in (holding it,
        following, passing, riding): the user-encounter model leaves them alone, as it does agents
        an event drives for the user (``Scheduler.engaged_with_user``); ORCA still keeps them off
        the user."""
        out = np.zeros(len(crowd), np.bool_)
        if self.user_id is None or self.user_id not in self.walkers:
            return out
        k = self.walkers[self.user_id].door
        for w in self.walkers.values():
            if w.door == k and not w.is_user and w.role != APPROACH and w.id in self._row:
                out[self._row[w.id]] = True
        return out

    def at_doors(self, crowd: CrowdState) -> np.ndarray:
        """``(N,)`` agents taking part in any door's etiquette now, approaching included: coupled
        ORCA gives them no dense slack (``[steering] dense_slack``), since the etiquette orders
        who goes, and they see obstacles ``time_horizon_obst`` ahead, not the shorter
        ``time_horizon_obst_coupled`` (door leaves swing). (With the slack a queue pressed on
        toward a busy single door: door_single_flow seeds 1-3 passed 27/29/28 of 40 against
        33/33/29, and a pram was left behind at a double door in three seeds of ten; with the
        shorter horizon in four.)"""
        out = np.zeros(len(crowd), np.bool_)
        for w in self.walkers.values():
            r = self._row.get(w.id)
            if r is not None and not w.is_user:
                out[r] = True
        return out

    def carry(self, new_vel: np.ndarray, crowd: CrowdState) -> None:
        """After ORCA: revolving-door riders move with their compartment."""
        carry_riders(self, new_vel, crowd)

    def auto_open(self, crowd: CrowdState) -> np.ndarray:
        """``(N,)`` who may push a leaf open just by walking into it: the user, carriers (no free
        hand: they push with the body, §4.6) and anyone the etiquette does not drive."""
        out = np.ones(len(crowd), np.bool_)
        for w in self.walkers.values():
            r = self._row.get(w.id)
            if r is not None and not w.is_user and not bool(self.carrying[r]):
                out[r] = w.role in (PASSING,) and w.state == -1
        return out

    def carried(self, crowd: CrowdState) -> np.ndarray:
        """``(N,)`` who moves with a revolving door's compartment now (its panels do not stop for them)."""
        out = np.zeros(len(crowd), np.bool_)
        for w in self.walkers.values():
            if w.role in (RIDER, ENTRANT, EXITING) and carried(self, w, crowd):
                out[self._row[w.id]] = True
        return out

    # -- per step: the hand on the door (App. A) -------------------------------------------------

    def before_doors(self, crowd: CrowdState) -> None:
        """The hand leads the door: each holder's leaf wants ``f_a`` of where the hand is."""
        lv = self.leaves
        for leaf, holder_id in self._hands():
            w = self.walkers[holder_id]
            if w.is_user:
                self._user_drive(w, crowd)
                continue
            if int(lv.drive[leaf]) == OPEN or w.frame is None:
                continue
            r = self._row[holder_id]
            fr = w.frame
            hand = self._hand_point(r, w)
            target = fr.handle(w.want, w.p_rel)
            # the hand actually reached the leaf's target: the door follows the hand (f_a); else the
            # door follows where the hand is going (IK lag), never more than HAND_SPEED a second.
            at = hand if float(np.hypot(*(hand - target))) < 0.12 else target
            lv.hand(leaf, hand_angle(lv.hinge[leaf], float(lv.base[leaf]), at))

    def after_doors(self, crowd: CrowdState) -> None:
        """The door leads the hand: each holder's hand target is ``f_pabs`` on its leaf."""
        lv = self.leaves
        b = self.body.state
        for leaf, holder_id in self._hands():
            w = self.walkers[holder_id]
            if w.is_user or w.frame is None or w.arm < 0:
                continue
            r = self._row[holder_id]
            if int(lv.drive[leaf]) == OPEN:
                a = self.leaf_open(leaf, w.frame)
            else:
                cur = self.leaf_open(leaf, w.frame)
                a = cur + max(-0.07, min(0.07, w.want - cur))
            lift = 0.0
            if w.state == HOLD_DOOR:  # App. B: subtle idle noise while holding (deterministic: by id)
                a += IDLE_ANGLE * math.sin(2.0 * math.pi * 0.31 * self.t + 1.7 * w.id)
                lift = IDLE_LIFT * math.sin(2.0 * math.pi * 0.47 * self.t + 0.9 * w.id)
            p = hand_point(lv.hinge[leaf], float(lv.base[leaf]), w.frame.sign * a, w.p_rel)
            b.reach_pt[r, w.arm] = (p[0], HAND_HEIGHT + lift, p[1])
            b.reach_on[r, w.arm] = True

    def _hands(self) -> list[tuple[int, int]]:
        out = []
        for ds in self.dstate:
            for leaf, holder in ds.holder.items():
                if holder in self.walkers and self.walkers[holder].arm >= 0 or (
                        holder in self.walkers and self.walkers[holder].is_user):
                    out.append((leaf, holder))
        return out

    def _hand_point(self, r: int, w: Walker) -> np.ndarray:
        joint = sk.R_HAND if w.arm == RIGHT else sk.L_HAND
        p = self.body.state.world_pos[r, joint]
        return np.array([p[0], p[2]])


    def user_reach(self, crowd: CrowdState) -> None:
        """Once per step before the doors: a pending press takes the nearest handle within reach."""
        if not self._user_grab_pending or self.user_id is None:
            return
        if self.t > self._user_grab_until:  # the press found no handle in time: it lapses
            self._user_grab_pending = False
            return
        r = self._row[self.user_id]
        p = crowd.pos[r]
        h = crowd.heading[r]
        reach = self.user_hand_point if self.user_hand_point is not None else \
            p + 0.45 * np.array([math.cos(h), math.sin(h)])
        best, best_d = -1, 1.0
        lv = self.leaves
        for leaf in range(len(lv)):
            if lv.panel[leaf]:
                continue
            tip = lv.tips()[leaf]
            d = point_segment(reach, lv.hinge[leaf], tip)
            k = int(lv.door[leaf])
            holder = self.dstate[k].holder.get(leaf, self.dstate[k].mutex.get(leaf))
            if d < best_d and (holder is None or holder == self.user_id):
                best, best_d = leaf, d
        if best < 0:
            return  # nothing within reach yet: the press keeps reaching until GRAB_REACH_S
        self._user_grab_pending = False
        k = int(lv.door[best])
        ds = self.dstate[k]
        side = 1 if float((p - ds.centre) @ ds.n) >= 0.0 else -1
        w = self.walkers.get(self.user_id)
        if w is None or w.door != k:
            if w is not None:
                self._drop(w, why="took another door")
            w = Walker(id=self.user_id, door=k, side=side, is_user=True, since=self.t)
            self.walkers[self.user_id] = w
        w.frame = self.frame(best, side)
        w.role = HOLDER
        w.leaf = best
        self.set_state(w, HOLDER_DEC)
        ds.holder[best] = self.user_id
        self.user_leaf = best
        if self.leaf_open(best, w.frame) < math.radians(60):
            self.leaves.grab(best, open_to=w.frame.sign * HOLD_ANGLE)
        else:
            self.leaves.hand(best, float(self.leaves.angle[best]))
        self.log("open", w, leaf=best, by="user")

    def _user_drive(self, w: Walker, crowd: CrowdState) -> None:
        """The user's hand drives the leaf (VR: the controller's position, f_a); on the desktop the
        leaf stays where the automatic opening put it while the user holds it."""
        leaf = self.user_leaf
        if leaf < 0 or w.frame is None:
            return
        lv = self.leaves
        p = crowd.pos[self._row[w.id]]
        if float(np.hypot(*(p - lv.hinge[leaf]))) > float(lv.length[leaf]) + 1.6:
            self._user_release()  # walked away from it
            return
        if self.user_hand_point is not None and int(lv.drive[leaf]) != OPEN:
            lv.hand(leaf, hand_angle(lv.hinge[leaf], float(lv.base[leaf]), self.user_hand_point))

    def track_passages(self, crowd: CrowdState) -> None:
        """Passages, measured from positions at the decision rate (issue 24 item 3): a body passes
        a door when the way it moved since the last tick crosses the doorway (jamb to jamb) and it
        then stands :data:`PASS_CONFIRM` m beyond the doorway line; one that steps back across
        first has not passed. Each passage is a ``pass`` event (who, the side it came from, the
        leaf it went through at a double door, how long it waited at the door) and counts in
        ``door_passages``; what the door states believe (a FinishDoor that timed out, a walker
        dropped on the near side) counts for nothing."""
        ids = crowd.ids
        n = len(crowd)
        pos = crowd.pos
        if self._trk_ids.shape[0] != n or not np.array_equal(self._trk_ids, ids):
            old = {int(a): r for r, a in enumerate(self._trk_ids)}
            prev = pos.copy()
            pend = np.zeros((n, len(self.doors)), np.int8)
            for r in range(n):
                o = old.get(int(ids[r]))
                if o is not None:
                    prev[r] = self._trk_prev[o]
                    pend[r] = self._trk_pend[o]
            self._trk_ids, self._trk_prev, self._trk_pend = ids.copy(), prev, pend
        prev, pend = self._trk_prev, self._trk_pend
        for k, ds in enumerate(self.dstate):
            d = self.doors[k]
            cross = _segments_cross(prev, pos, np.asarray(d.span[0]), np.asarray(d.span[1]))
            if cross.any():
                came = np.where((prev - ds.centre) @ ds.n >= 0.0, 1, -1).astype(np.int8)
                back = cross & (pend[:, k] != 0) & (pend[:, k] != came)
                pend[back, k] = 0  # stepped back across before passing
                fresh = cross & ~back
                pend[fresh, k] = came[fresh]
            todo = np.flatnonzero(pend[:, k])
            if not todo.size:
                continue
            beyond = ((pos[todo] - ds.centre) @ ds.n) * pend[todo, k] < -PASS_CONFIRM
            for r in todo[beyond]:
                self._passage(int(r), k, int(pend[r, k]), crowd)
                pend[r, k] = 0
        self._trk_prev = pos.copy()

    def _passage(self, r: int, k: int, side: int, crowd: CrowdState) -> None:
        agent = int(crowd.ids[r])
        user = bool(crowd.is_user[r])
        w = self.walkers.get(agent)
        waited = w.waited if w is not None and w.door == k else self.waited_at.pop((agent, k), 0.0)
        ds = self.dstate[k]
        leaf = -1
        if ds.kind != "revolving":  # the leaf whose closed span the body crossed nearest
            lv = self.leaves
            base = lv.base[ds.leaves]
            closed = np.stack([np.cos(base), np.sin(base)], 1)
            mids = lv.hinge[ds.leaves] + 0.5 * lv.length[ds.leaves, None] * closed
            along = (mids - ds.centre) @ ds.u
            at = float((crowd.pos[r] - ds.centre) @ ds.u)
            leaf = ds.leaves[int(np.argmin(np.abs(along - at)))]
        self.passages += 1
        self.last_passage[k] = self.t
        if not user:
            ds.run_len = ds.run_len + 1 if side == ds.run_side else 1
            ds.run_side = side
        self.wait_since_at.pop((agent, k), None)
        if w is not None and w.door == k:
            w.first_wait = math.nan  # its wait at this door is over
        if not user:
            self.waits.append(waited)
        self.events.append({"t": round(self.t, 4), "event": "pass", "door": self.doors[k].name,
                             "agent": agent, "waited_s": round(waited, 3), "user": user, "side": side,
                             "leaf": leaf})

    def _watch_deadlocks(self, crowd: CrowdState) -> None:
        """The metric ``door_deadlocks``: long waits at a door that do not end (issue 26). A
        pedestrian's wait at a door runs from the first time it stands waiting there until its
        body passes the door, or it has walked on without waiting for :data:`WAIT_ENDS` (a
        shuffle forward in a queue does not end it). It is a deadlock,
        counted once per pedestrian and logged, when it has lasted :data:`DEADLOCK_AFTER` and

        * the door has passed nobody for as long (the doorway is stuck), or
        * the doorway has been free all that while: nobody holds or is taking the door and nobody
          is within 1 m of it, for :data:`DEADLOCK_FREE_S` at least;

        and, at the end of the run (:meth:`summary`), every wait still going on that has lasted
        :data:`DEADLOCK_AFTER` counts too: it never ended. A queue that moves on (a passage every
        few seconds) is no deadlock while the run goes on; one still standing at the end is."""
        for k, ds in enumerate(self.dstate):
            free = not ds.holder and not ds.mutex and not bool(
                (np.hypot(*(crowd.pos - ds.centre).T) < 1.0).any())
            if not free:
                self._free_since[k] = math.nan
            elif math.isnan(self._free_since[k]):
                self._free_since[k] = self.t
        for w in self.walkers.values():
            r = self._row.get(w.id)
            if w.is_user or r is None:
                continue
            if w.waiting and float(np.hypot(*crowd.vel[r])) < 0.2:
                w.last_wait = self.t
                if math.isnan(w.first_wait):
                    w.first_wait = self.t
            elif not math.isnan(w.first_wait) and self.t - w.last_wait > WAIT_ENDS:
                w.first_wait = math.nan  # walking on, not waiting, for a while: that wait is over
            if math.isnan(w.first_wait) or self.t - w.first_wait < DEADLOCK_AFTER or w.id in self._deadlocked:
                continue
            stalled = self.t - self.last_passage[w.door] >= DEADLOCK_AFTER
            since = self._free_since[w.door]
            free_long = not math.isnan(since) and self.t - since >= DEADLOCK_FREE_S and w.waiting
            if not (stalled or free_long):
                continue
            self.deadlocks += 1
            self._deadlocked.add(w.id)
            self.log("deadlock", w, waited_s=round(self.t - w.first_wait, 2),
                     why="stalled door" if stalled else "free doorway")

    def unended_waits(self) -> list[int]:
        """Pedestrians whose wait at a door has lasted :data:`DEADLOCK_AFTER` and goes on now
        (not counted as a deadlock already)."""
        out = []
        for w in self.walkers.values():
            if not w.is_user and not math.isnan(w.first_wait) and w.id not in self._deadlocked \
                    and self.t - w.first_wait >= DEADLOCK_AFTER:
                out.append(w.id)
        return out

    @staticmethod
    def empty_summary() -> dict[str, object]:
        """The door metrics of a run without door etiquette."""
        return {"door_holds": {"HOF": 0, "HOL": 0, "NH": 0}, "door_passages": 0, "door_wait_s_p95": 0.0,
                "door_deadlocks": 0, "door_stalls": 0, "door_thanks": 0, "door_holds_for_user": 0,
                "door_events": []}

    def summary(self) -> dict[str, object]:
        """The run's door metrics (the metrics JSON): holds by HOF / HOL / NH, passages (bodies
        through a doorway), the 95th percentile of the time agents waited at doors, deadlocks (long
        waits that did not end, :meth:`_watch_deadlocks`) and of them the stalls (seen while the
        run went on: a door that passed nobody, or a free doorway, for 20 s while someone waited),
        thank-yous, doors held for the user, and every door event (who held for whom, waits,
        thank-yous)."""
        return {
            "door_holds": dict(self.holds),
            "door_passages": self.passages,
            "door_wait_s_p95": round(float(np.percentile(self.waits, 95)), 4) if self.waits else 0.0,
            "door_deadlocks": self.deadlocks + len(self.unended_waits()),
            "door_stalls": self.deadlocks,
            "door_thanks": self.thanks,
            "door_holds_for_user": sum(1 for e in self.events if e["event"] == "hold" and e.get("for_user")),
            "door_events": list(self.events),
        }


def _segments_cross(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``(S,)`` whether each segment ``a[i] -> b[i]`` crosses the segment ``p -> q`` (touching
    ``p -> q``'s line counts, an endpoint on the segment's own line does not)."""
    out = np.empty(a.shape[0], np.bool_)
    _segments_cross_kernel(np.ascontiguousarray(a, np.float64), np.ascontiguousarray(b, np.float64),
                           float(p[0]), float(p[1]), float(q[0]), float(q[1]), out)
    return out


@njit(cache=True)
def _segments_cross_kernel(a, b, px, py, qx, qy, out):  # noqa: ANN001, ANN202
    """:func:`_segments_cross` over the rows: the signs of the four orientations (one pass at the
    decision rate for every walker and door; the array expressions cost 40 µs a door)."""
    for i in range(a.shape[0]):
        ax, ay, bx, by = a[i, 0], a[i, 1], b[i, 0], b[i, 1]
        o1 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        o2 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
        o3 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
        o4 = (qx - px) * (by - py) - (qy - py) * (bx - px)
        out[i] = o1 * o2 <= 0.0 and o3 * o4 < 0.0


def pursuit_point(plan: np.ndarray, start: int, p: np.ndarray, look: float) -> tuple[int, np.ndarray]:
    """Pure pursuit along the keys ``plan[start:]`` (a polyline) for a body at ``p`` that cannot
    step sideways (a pram's pusher): the point ``look`` m on along the polyline from the point
    of it nearest ``p``, and the index of the key that starts its segment (the last key's index
    where the point is the last key). A pram steered at its keys one by one turned across the
    doorway at a key beside it, or reached the lane a few centimetres off its middle with its
    front already in the doorway, against the other leaf's edge (issue 26, "no carrier left
    behind"; before, keys close beside the pusher and far off its heading were passed over,
    which did not help where they were not beside it). Pursuing a point ahead turns it onto the
    line of its keys gradually, and it reaches the line a look-ahead before the doorway."""
    last = plan.shape[0] - 1
    if start >= last:
        return last, plan[last]
    best_j, best_q, best_d = start, plan[start], math.inf
    for j in range(start, last):
        a, b = plan[j], plan[j + 1]
        ab = b - a
        l2 = float(ab @ ab)
        t = 0.0 if l2 < 1e-12 else min(max(float((p - a) @ ab) / l2, 0.0), 1.0)
        q = a + t * ab
        dq = float(np.hypot(*(q - p)))
        if dq < best_d:
            best_j, best_q, best_d = j, q, dq
    rem = look
    q, j = best_q, best_j
    while j < last:
        e = plan[j + 1]
        left = float(np.hypot(*(e - q)))
        if left >= rem:
            return j, q + (e - q) * (rem / left)
        rem -= left
        q, j = e, j + 1
    return last, plan[last]
