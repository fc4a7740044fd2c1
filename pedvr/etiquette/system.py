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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit

from pedvr.body import skeleton as sk
from pedvr.body.steps import LEFT, RIGHT, generate_steps
from pedvr.etiquette import decision as bn
from pedvr.etiquette.doors import OPEN, DoorLeaves, hand_angle, hand_point
from pedvr.etiquette.ordering import NONE
from pedvr.etiquette.regions import HAND_HEIGHT, HOLD_ANGLE, LeafFrame
from pedvr.scene.config import Door, EtiquetteConfig, SceneConfig

if TYPE_CHECKING:
    from pedvr.behavior.scheduler import Scheduler
    from pedvr.body.model import FullBody
    from pedvr.crowd.state import CrowdState

# Roles of a pedestrian at a door.
APPROACH, FOLLOWER, HOLDER, PASSING, ENTRANT, RIDER, EXITING = range(7)
ROLE_NAMES = ("approach", "follower", "holder", "passing", "entrant", "rider", "exiting")
# App. B's states.
(OPENER_INIT, REACH_DOOR, OPEN_DOOR, HOLDER_DEC, HOLD_DOOR, FOLLOWER_INIT, FOLLOWER_DEC, REACH_EDGE,
 RELEASE_DOOR, FINISH_DOOR) = range(10)
STATE_NAMES = ("OpenerInit", "ReachDoor", "OpenDoor", "HolderDec", "HoldDoor", "FollowerInit",
               "FollowerDec", "ReachEdge", "ReleaseDoor", "FinishDoor")

OPENER_RANGE = 1.6  # m from the BOP within which a leaderless pedestrian takes the door (Alg. 2)
ARRIVE = 0.12  # m: a key pose is reached
REACH_TIME = 0.35  # s: the hand reaches the handle (ReachDoor)
DECIDE_WAIT = 0.6  # s: a holder in HolderDec waits this long for a follower to commit
CLEAR = 0.45  # m past the doorway line (plus the radius) at which a walker has passed
RUSH_SPEEDUP = 0.4  # a pedestrian walks (1 + RUSH_SPEEDUP * Rush) times its speed near a doorway
CATCH_UP = 1.3  # a committed follower farther than CATCH_UP_AT from its holder walks this much faster
CATCH_UP_AT = 2.5  # m
STATE_TIMEOUT = 10.0  # s: a door state that has not moved on gives up (never a deadlock)
HOLD_TIMEOUT = 12.0  # s: a holder waits this long for an agent follower
CARRIER_PATIENCE = 8.0  # s: a carrier alone at a pull side frees a hand after this long
HELP_RANGE = 6.0  # m: a pedestrian behind a carrier this close overtakes to open the door (§4.6)
DEADLOCK_AFTER = 20.0  # s of waiting with the doorway free: a deadlock (the metric)
DEADLOCK_FREE_S = 3.0  # s the doorway must have stayed free for a long wait to count as a deadlock
SENSE_USER = 0.2  # m/s: the user walking toward a door faster than this takes part in its ordering
THANK_RANGE = 2.5  # m: a follower thanks its holder when passing this close
LEAF_REACH = 0.9  # m: a hand farther than this from its leaf lets go
IDLE_ANGLE = math.radians(1.2)  # rad: a holding hand's idle sway along the door's swing
IDLE_LIFT = 0.012  # m: and up and down
GRAB_REACH_S = 1.5  # s: a press of E or the trigger takes a handle that comes within reach this soon


@dataclass
class Walker:
    """One pedestrian (an agent or the user) taking part in a door's etiquette."""

    id: int
    door: int
    side: int  # the side it comes from: +1 the left of span[0] -> span[1]
    is_user: bool = False
    leaf: int = -1  # the leaf it passes (a double door's chosen side), -1 revolving / undecided
    role: int = APPROACH
    state: int = -1
    leader: int = NONE
    since: float = 0.0
    waited: float = 0.0
    waiting: bool = False
    wait_from: float = math.nan
    action: str = ""  # a holder's decision for its follower
    follower: int = NONE
    holder: int = NONE
    plan: np.ndarray | None = None
    plan_i: int = 0
    face: float = math.nan
    lock: bool = False
    speed: float = 1.3
    arm: int = -1  # the arm on the leaf (0 left, 1 right)
    p_rel: float = 0.0
    want: float = 0.0  # the angle (>= 0, in the leaf frame) the holder's hand wants
    frame: LeafFrame | None = None
    compartment: int = -1
    catching: bool = False  # walking into a revolving compartment in its window
    thanked: bool = False
    helping: int = NONE  # the carrier this pedestrian overtakes to help
    event: Any = None
    stop_hold: bool = False
    user_hold_for: float = 0.0  # the user's progress toward the door when held for (give-up rule)
    user_best: float = math.inf
    user_best_at: float = 0.0
    alone_since: float = math.nan


@dataclass
class DoorState:
    """Per door: who holds each leaf, who is initiating (the mutex), who uses which leaf."""

    kind: str
    centre: np.ndarray
    u: np.ndarray  # along the span
    n: np.ndarray  # the door's +1 side
    leaves: list[int]
    mutex: dict[int, int] = field(default_factory=dict)  # leaf -> initiating walker
    holder: dict[int, int] = field(default_factory=dict)  # leaf -> holding walker


class DoorEtiquette:
    """The etiquette layer of one simulation (module docstring). Keyword-only set-up."""

    def __init__(self, scene: SceneConfig, *, leaves: DoorLeaves, body: FullBody, rng: np.random.Generator,
                 replan: Callable[[int], None]) -> None:
        self.scene = scene
        self.cfg: EtiquetteConfig = scene.etiquette
        self.doors: list[Door] = list(scene.world.doors)
        self.leaves = leaves
        self.body = body
        self.rng = rng.spawn(1)[0]
        self.replan = replan
        self.scheduler: Scheduler | None = None
        self.user_id: int | None = None
        self.t = 0.0
        self.dstate: list[DoorState] = []
        for k, d in enumerate(self.doors):
            a, b = np.asarray(d.span[0], np.float64), np.asarray(d.span[1], np.float64)
            u = (b - a) / np.linalg.norm(b - a)
            self.dstate.append(DoorState(kind=d.kind, centre=0.5 * (a + b), u=u, n=np.array([-u[1], u[0]]),
                                         leaves=[int(i) for i in np.flatnonzero(leaves.door == k)]))
        self.walkers: dict[int, Walker] = {}
        # per row (follows the crowd): traits
        self.kindness = np.zeros(0)
        self.rush = np.zeros(0)
        self.female = np.zeros(0, np.bool_)
        self.carrying = np.zeros(0, np.bool_)
        self.friend = np.zeros(0, np.int64)
        self._ids = np.zeros(0, np.int64)
        self._row: dict[int, int] = {}
        self._path_cache: dict[int, tuple[int, list[tuple[int, int]]]] = {}
        self._later: list[tuple[float, int, Callable[[], object]]] = []
        self._seq = 0
        # the user's hand on a leaf (a backend's E key or trigger, or the scripted user)
        self.user_leaf = -1
        self.user_hand_point: np.ndarray | None = None
        self._user_grab_pending = False
        self._user_grab_until = 0.0
        # what happened, for metrics and the recording
        self.events: list[dict[str, Any]] = []
        self.holds = {"HOF": 0, "HOL": 0, "NH": 0}
        self.passages = 0
        self.waits: list[float] = []
        self.deadlocks = 0
        self._free_since = [math.nan] * len(self.doors)
        self._deadlocked: set[int] = set()
        self.thanks = 0
        self.carrier_forced = 0
        self.hold_outcomes: dict[int, str] = {}

    # -- rows ------------------------------------------------------------------------------------

    def append(self, ids: np.ndarray, *, profile: Any | None, is_user: bool, female: np.ndarray) -> None:
        """New rows (after the body's): traits drawn from the etiquette's generator."""
        n = len(ids)
        if is_user or profile is None:
            u = self.scene.user
            kind = np.zeros(n)
            rush = np.zeros(n)
            fem = np.full(n, u.sex == "female")
            car = np.full(n, u.carrying != "none")
        else:
            lo, hi = profile.kindness
            kind = lo + (hi - lo) * self.rng.random(n)
            lo, hi = profile.rush
            rush = lo + (hi - lo) * self.rng.random(n)
            fem = np.asarray(female, np.bool_).reshape(n)
            car = np.full(n, profile.carrying != "none")
        self.kindness = np.concatenate([self.kindness, kind])
        self.rush = np.concatenate([self.rush, rush])
        self.female = np.concatenate([self.female, fem])
        self.carrying = np.concatenate([self.carrying, car])
        self.friend = np.concatenate([self.friend, np.full(n, NONE, np.int64)])
        self._ids = np.concatenate([self._ids, np.asarray(ids, np.int64)])
        self._row = {int(a): r for r, a in enumerate(self._ids)}
        if is_user:
            self.user_id = int(ids[0])

    def pair_friends(self, a: int, b: int) -> None:
        self.friend[self._row[a]] = b
        self.friend[self._row[b]] = a

    def keep(self, mask: np.ndarray) -> None:
        gone = [int(i) for i in self._ids[~mask]]
        for i in gone:  # their bodies are gone already: nothing is asked of them
            self._row.pop(i, None)
        for i in gone:
            w = self.walkers.get(i)
            if w is not None:
                self._drop(w, why="left the scene")
        self.kindness = self.kindness[mask]
        self.rush = self.rush[mask]
        self.female = self.female[mask]
        self.carrying = self.carrying[mask]
        self.friend = self.friend[mask]
        self._ids = self._ids[mask]
        self._row = {int(a): r for r, a in enumerate(self._ids)}
        for i in gone:
            self._path_cache.pop(i, None)

    def smart_objects(self) -> dict[str, Any]:
        """Every door as a smart object (``pass``, ``hold``), named as in the scene."""
        from pedvr.etiquette.objects import DoorObject

        return {d.name: DoorObject.of(self, k) for k, d in enumerate(self.doors)}

    # -- the decision tick -------------------------------------------------------------------

    def decide(self, t: float, crowd: CrowdState, paths: list[np.ndarray], cursor: np.ndarray) -> None:
        """At the decision rate, in the ``decide`` phase (before the scheduler ticks)."""
        self.t = t
        self._run_later(t)
        self._engage(crowd, paths, cursor)
        for k, ds in enumerate(self.dstate):
            ws = [w for w in self._walkers_at(k)]
            if not ws:
                continue
            if ds.kind == "revolving":
                from pedvr.etiquette.revolving import decide_revolving

                decide_revolving(self, k, ws, crowd)
            else:
                from pedvr.etiquette.interaction import decide_hinged

                decide_hinged(self, k, ws, crowd)
        self._watch_deadlocks(crowd)

    def _walkers_at(self, k: int) -> list[Walker]:
        return sorted((w for w in self.walkers.values() if w.door == k), key=lambda w: w.id)

    def _run_later(self, t: float) -> None:
        while self._later and self._later[0][0] <= t + 1e-9:
            _, _, fn = self._later.pop(0)
            fn()

    def later(self, dt: float, fn: Callable[[], object]) -> None:
        """Run ``fn`` at the first decision tick ``dt`` seconds from now (a nod's second half)."""
        self._seq += 1
        self._later.append((self.t + dt, self._seq, fn))
        self._later.sort(key=lambda x: (x[0], x[1]))

    def row(self, agent: int) -> int | None:
        return self._row.get(agent)

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
            crossing = [(k, i) for k, i in self._path_doors(agent, path) if i >= c]
            if path.shape[0] >= 2:
                crossing.extend((int(k), c) for k in np.flatnonzero(leg_cross[r]))
            if w is None:
                for k, _ in crossing:
                    ds = self.dstate[k]
                    if float(np.hypot(*(pos[r] - ds.centre))) <= self.doors[k].sensing_range:
                        side = 1 if float((pos[r] - ds.centre) @ ds.n) >= 0.0 else -1
                        self.walkers[agent] = Walker(id=agent, door=k, side=side, since=self.t,
                                                     speed=float(crowd.pref_speed[r]))
                        break
                continue
            if w.role == APPROACH and not any(k == w.door for k, _ in crossing):
                self._drop(w, why="no longer passing")

    def _engage_user(self, r: int, agent: int, crowd: CrowdState) -> None:
        pos, vel = crowd.pos[r], crowd.vel[r]
        w = self.walkers.get(agent)
        if w is not None:
            ds = self.dstate[w.door]
            rel = pos - ds.centre
            through = float(rel @ ds.n) * w.side < -(CLEAR + 0.25)
            far = float(np.hypot(*rel)) > self.doors[w.door].sensing_range
            if w.role != HOLDER and (through or far):
                if through:
                    self._passed(w)
                self._drop(w, why="passed" if through else "walked away")
            return
        for k, ds in enumerate(self.dstate):
            rel = pos - ds.centre
            dist = float(np.hypot(*rel))
            if dist > self.doors[k].sensing_range or dist < 1e-9:
                continue
            lateral = abs(float(rel @ ds.u))
            if lateral > 0.5 * self.doors[k].width + 1.5:
                continue
            toward = -float(vel @ rel) / dist
            if toward > SENSE_USER or (dist < 2.0 and self.user_leaf >= 0):
                side = 1 if float(rel @ ds.n) >= 0.0 else -1
                self.walkers[agent] = Walker(id=agent, door=k, side=side, is_user=True, since=self.t)
                return

    # -- helpers the door models use ------------------------------------------------------------

    def pos(self, crowd: CrowdState, agent: int) -> np.ndarray:
        r = self._row[agent]
        return crowd.pos[r]

    def radius(self, crowd: CrowdState, agent: int) -> float:
        return float(crowd.radius[self._row[agent]])

    def frame(self, leaf: int, opener_side_world: int) -> LeafFrame:
        """The leaf's frame for an interaction begun from ``opener_side_world`` (the door's side)."""
        lv = self.leaves
        k = int(lv.door[leaf])
        ds = self.dstate[k]
        e = np.array([math.cos(lv.base[leaf]), math.sin(lv.base[leaf])])
        left = np.array([-e[1], e[0]])
        from_left = 1 if float(left @ (ds.n * opener_side_world)) > 0 else -1
        sign = lv.opening_sign(leaf, from_left)
        return LeafFrame.of(lv.hinge[leaf], float(lv.base[leaf]), float(lv.length[leaf]), sign)

    def leaf_open(self, leaf: int, frame: LeafFrame) -> float:
        """How far the leaf is open in ``frame`` (>= 0 into its pull side)."""
        return max(0.0, frame.sign * float(self.leaves.angle[leaf]))

    def set_plan(self, w: Walker, crowd: CrowdState, target: np.ndarray, *, facing: float | None,
                 speed: float | None = None, backward: bool = False, lock: bool = False,
                 end_standing: bool = True) -> None:
        """Walk ``w`` to ``target`` along App. C's generated steps (their root keys)."""
        r = self._row[w.id]
        b = self.body.state
        fl, fr = b.foot_ref[r, 0], b.foot_ref[r, 1]
        swing = int(b.swing[r]) if bool(b.stepping[r]) else (RIGHT if float(np.hypot(*(fr - target)))
                                                              > float(np.hypot(*(fl - target))) else LEFT)
        plan = generate_steps(root=crowd.pos[r], left=fl, right=fr, swing=swing,
                              standing=not bool(b.stepping[r]), target=np.asarray(target, np.float64),
                              target_facing=facing, end_standing=end_standing, backward=backward)
        keys = plan.root[1:] if plan.root.shape[0] > 1 else plan.root
        w.waiting = False
        w.plan = np.ascontiguousarray(keys)
        w.plan_i = 0
        w.face = float(plan.facing[-1]) if facing is None else facing
        w.lock = lock
        w.speed = float(crowd.pref_speed[r]) if speed is None else speed

    def go_direct(self, w: Walker, target: np.ndarray, *, facing: float, speed: float,
                  lock: bool = False) -> None:
        """Walk straight at ``target`` (re-aimed every tick: a moving target)."""
        w.waiting = False
        w.plan = np.asarray(target, np.float64).reshape(1, 2).copy()
        w.plan_i = 0
        w.face = facing
        w.lock = lock
        w.speed = speed

    def stand(self, w: Walker, facing: float) -> None:
        """``w`` stands where it is, facing ``facing`` (waiting, or holding still)."""
        w.plan = None
        w.face = facing
        w.lock = False
        w.waiting = w.role in (APPROACH, FOLLOWER)

    def approach(self, w: Walker) -> None:
        """``w`` walks on along its own path (the etiquette only hurries it)."""
        w.plan = None
        w.face = math.nan
        w.lock = False
        w.waiting = False

    def arrived(self, w: Walker, crowd: CrowdState, tol: float = ARRIVE) -> bool:
        if w.plan is None:
            return True
        last = w.plan_i >= w.plan.shape[0] - 1
        return last and float(np.hypot(*(self.pos(crowd, w.id) - w.plan[-1]))) <= tol

    def set_state(self, w: Walker, state: int) -> None:
        w.state = state
        w.since = self.t

    # -- decisions (§5) --------------------------------------------------------------------------

    def decide_hold(self, holder: Walker, follower: Walker, crowd: CrowdState) -> str:
        """HOF / HOL / NH for ``follower`` by the network of §5: Effort from the distance, Care
        from Table 3, the holder's Kindness and Rush."""
        r = self._row[holder.id]
        f = self._row[follower.id]
        d = float(np.hypot(*(crowd.pos[r] - crowd.pos[f])))
        p = bn.holding_probabilities(effort=bn.effort_factor(d),
                                     care=bn.care_factor(follower_female=bool(self.female[f]),
                                                         follower_carrying=bool(self.carrying[f])),
                                     kindness=float(self.kindness[r]), rush=float(self.rush[r]))
        return bn.decide(p, rng=self.rng if self.cfg.decisions == "sampled" else None)

    # -- events (who held for whom) --------------------------------------------------------------

    def log(self, kind: str, w: Walker, **data: Any) -> None:
        ev = {"t": round(self.t, 4), "event": kind, "door": self.doors[w.door].name, "agent": w.id}
        ev.update(data)
        self.events.append(ev)

    def start_hold_event(self, holder: Walker, follower: Walker) -> None:
        """The holder–follower pair as an event of the behavior layer (ADAPT §6): the holder is
        claimed (its BFSM suspended while it holds), the follower is an actor (the user: observed)."""
        sch = self.scheduler
        if sch is None or holder.is_user or "door_hold" not in sch.events:
            return
        try:
            holder.event = sch.start_event("door_hold", {"holder": holder.id, "follower": follower.id,
                                                         "door": self.doors[holder.door].name})
        except Exception:  # noqa: BLE001 - a scene may define door_hold differently: the hold goes on
            holder.event = None

    def end_hold(self, holder: Walker, outcome: str) -> None:
        """The hold is over: ``passed`` / ``took over`` (its event succeeds) or anything else (it
        fails with that reason), as the ``hold`` affordance reports at the scheduler's tick."""
        if holder.event is not None:
            self.hold_outcomes[holder.id] = outcome
        holder.event = None

    def interrupted(self, agent: int) -> None:
        """A higher-priority event took a holder out of its ``door_hold``: it lets go and goes on."""
        w = self.walkers.get(agent)
        if w is not None and w.event is not None:
            w.event = None
            w.stop_hold = True

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
            k = w.plan_i
            last = w.plan.shape[0] - 1
            while k < last and float(np.hypot(*(w.plan[k] - p))) < 0.2:
                k += 1
            w.plan_i = k
            d = w.plan[k] - p
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

    def face(self, heading: np.ndarray, prev: np.ndarray, crowd: CrowdState, dt: float) -> np.ndarray:
        """After the body's animate: walkers stepping sideways or back around a door keep facing
        the door (App. C's constrained steps), turning no faster than the body's turn rate."""
        out = heading
        for w in self.walkers.values():
            if not w.lock or w.is_user or math.isnan(w.face):
                continue
            r = self._row.get(w.id)
            if r is None:
                continue
            delta = (w.face - prev[r] + math.pi) % (2 * math.pi) - math.pi
            lim = float(crowd.limits[r, 2]) * dt  # the standing turn rate: these are slow steps
            out[r] = prev[r] + max(-lim, min(lim, delta))
        return out

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

    def carry(self, new_vel: np.ndarray, crowd: CrowdState) -> None:
        """After ORCA: revolving-door riders move with their compartment."""
        from pedvr.etiquette.revolving import carry_riders

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
        from pedvr.etiquette.revolving import carried

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

    def take_leaf(self, w: Walker, leaf: int, *, arm: int, p_rel: float, open_to: float | None,
                  speed: float = 2.5) -> None:
        """``w``'s hand takes ``leaf``: opening it toward ``open_to`` (the door leads the hand) or
        holding it where it is (the hand leads the door)."""
        ds = self.dstate[w.door]
        ds.holder[leaf] = w.id
        w.leaf = leaf
        w.arm = arm
        w.p_rel = p_rel * float(self.leaves.length[leaf])
        assert w.frame is not None
        if open_to is not None:
            self.leaves.grab(leaf, open_to=w.frame.sign * open_to, speed=speed)
            w.want = open_to
        else:
            w.want = self.leaf_open(leaf, w.frame)
            self.leaves.hand(leaf, float(self.leaves.angle[leaf]))
        r = self._row[w.id]
        h = w.frame.handle(self.leaf_open(leaf, w.frame), p_rel)
        self.body.reach_for(w.id, (float(h[0]), HAND_HEIGHT, float(h[1])),
                            side="right" if arm == RIGHT else "left")
        self.body.gaze_at(w.id, (float(h[0]), HAND_HEIGHT, float(h[1])))
        del r

    def let_go(self, w: Walker, *, bounce: bool = True) -> None:
        """``w`` releases its leaf: ``f_bounce`` (App. A), the closer takes over."""
        ds = self.dstate[w.door]
        for leaf, h in list(ds.holder.items()):
            if h == w.id:
                del ds.holder[leaf]
                self.leaves.release(leaf, bounce=math.radians(10.0) if bounce else 0.0)
        if w.arm >= 0 and not w.is_user and w.id in self._row:
            self.body.reach_for(w.id, None, side="right" if w.arm == RIGHT else "left")
        w.arm = -1
        for leaf, m in list(ds.mutex.items()):
            if m == w.id:
                del ds.mutex[leaf]

    # -- the user's hand -------------------------------------------------------------------------

    def user_hand(self, pressed: bool, hand: tuple[float, float] | None = None) -> bool:
        """A backend reports the user's hand: ``pressed`` (E held or toggled, the trigger) and,
        in VR, the controller's floor position (``hand``; desktop: None, a reach ahead of the
        user is assumed). Pressing near a leaf's handle takes it (the door opens toward the pull
        side, or away from the user on a double-acting leaf); releasing lets go. Returns whether
        the user holds a leaf now."""
        self.user_hand_point = None if hand is None else np.asarray(hand, np.float64)
        if not pressed:
            if self.user_leaf >= 0:
                self._user_release()
            return False
        if self.user_leaf >= 0:
            return True
        self._user_grab_pending = True
        self._user_grab_until = self.t + GRAB_REACH_S
        return True

    def user_hand_moved(self, hand: tuple[float, float] | None) -> bool:
        """VR, every frame between presses: the controller's floor position (None: not tracked; a
        reach ahead of the user is assumed). A held leaf follows it. Returns whether the user holds a
        leaf or is reaching for one (a press still pending), as :meth:`user_hand` does."""
        self.user_hand_point = None if hand is None else np.asarray(hand, np.float64)
        return self.user_leaf >= 0 or self._user_grab_pending

    def _user_release(self) -> None:
        leaf = self.user_leaf
        self.user_leaf = -1
        if leaf < 0:
            return
        k = int(self.leaves.door[leaf])
        ds = self.dstate[k]
        if ds.holder.get(leaf) == self.user_id:
            del ds.holder[leaf]
        self.leaves.release(leaf)
        if self.user_id is not None:
            w = self.walkers.get(self.user_id)
            if w is not None and w.role == HOLDER:
                w.role = APPROACH
                w.state = -1
                self.log("release", w, leaf=leaf)

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
            d = _point_segment(reach, lv.hinge[leaf], tip)
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

    # -- bookkeeping ---------------------------------------------------------------------------

    def _passed(self, w: Walker) -> None:
        h = self.walkers.get(w.holder) if w.is_user and w.holder != NONE else None
        if h is not None and h.state == HOLD_DOOR and h.follower == w.id:
            self.log("held_for_user", h, action=h.action)  # the user walked through the held door
        self.passages += 1
        if not w.is_user:
            self.waits.append(w.waited)
        self.log("pass", w, waited_s=round(w.waited, 3), user=w.is_user, side=w.side, leaf=w.leaf)

    def finish(self, w: Walker, crowd: CrowdState, *, passed: bool = True) -> None:
        """``w`` is through (or gives up the door): its navigation takes over again."""
        if passed:
            self._passed(w)
        self._drop(w, why="done")
        r = self._row.get(w.id)
        if r is not None and not w.is_user:
            self.replan(r)

    def _drop(self, w: Walker, *, why: str) -> None:
        ds = self.dstate[w.door]
        if any(h == w.id for h in ds.holder.values()):
            if w.is_user:
                self._user_release()
            else:
                self.let_go(w)
        for leaf, m in list(ds.mutex.items()):
            if m == w.id:
                del ds.mutex[leaf]
        if w.event is not None:
            self.end_hold(w, why)
        self.walkers.pop(w.id, None)
        if not w.is_user and w.id in self._row:
            if w.arm >= 0:
                self.body.reach_for(w.id, None, side="right" if w.arm == RIGHT else "left")
        for other in self.walkers.values():
            if other.follower == w.id:
                other.follower = NONE
            if other.holder == w.id:
                other.holder = NONE
            if other.leader == w.id:
                other.leader = NONE

    def _watch_deadlocks(self, crowd: CrowdState) -> None:
        """The metric: a pedestrian waiting more than 20 s while its doorway is free. pedvr's reading
        of "free": nobody holds or is taking the door and nobody is within 1 m of it, for the last
        :data:`DEADLOCK_FREE_S` at least (a queue that has waited long while the door is merely
        between two passers, a hand-over of under a second, is not deadlocked)."""
        for k, ds in enumerate(self.dstate):
            free = not ds.holder and not ds.mutex and not bool(
                (np.hypot(*(crowd.pos - ds.centre).T) < 1.0).any())
            if not free:
                self._free_since[k] = math.nan
            elif math.isnan(self._free_since[k]):
                self._free_since[k] = self.t
        for w in self.walkers.values():
            if w.is_user or not w.waiting or math.isnan(w.wait_from):
                continue
            if self.t - w.wait_from < DEADLOCK_AFTER or w.id in self._deadlocked:
                continue
            since = self._free_since[w.door]
            if math.isnan(since) or self.t - since < DEADLOCK_FREE_S:
                continue
            self.deadlocks += 1
            self._deadlocked.add(w.id)
            self.log("deadlock", w, waited_s=round(self.t - w.wait_from, 2))

    @staticmethod
    def empty_summary() -> dict[str, object]:
        """The door metrics of a run without door etiquette."""
        return {"door_holds": {"HOF": 0, "HOL": 0, "NH": 0}, "door_passages": 0, "door_wait_s_p95": 0.0,
                "door_deadlocks": 0, "door_thanks": 0, "door_holds_for_user": 0, "door_events": []}

    def summary(self) -> dict[str, object]:
        """The run's door metrics (the metrics JSON): holds by HOF / HOL / NH, passages, the 95th
        percentile of the time agents waited at doors, deadlocks, thank-yous, doors held for the
        user, and every door event (who held for whom, waits, thank-yous)."""
        return {
            "door_holds": dict(self.holds),
            "door_passages": self.passages,
            "door_wait_s_p95": round(float(np.percentile(self.waits, 95)), 4) if self.waits else 0.0,
            "door_deadlocks": self.deadlocks,
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


def _point_segment(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = min(max(float((x - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0), 1.0)
    return float(np.hypot(*(x - (a + t * ab))))
