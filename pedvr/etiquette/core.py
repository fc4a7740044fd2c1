"""The etiquette's state and the helpers its door models use (Huang & Terzopoulos §4–5, App. B–C).

:class:`EtiquetteCore` holds one simulation's door etiquette state: who takes part at which door
(:class:`Walker`), who holds or is taking each leaf (:class:`DoorState`), the pedestrians' traits
(Kindness, Rush, sex, what they carry), the events and metrics; and the moves the door models of
:mod:`.interaction` and :mod:`.revolving` make: walk a pedestrian along App. C's steps or straight
at a target, stand it, put its hand on a leaf or take it off, decide HOF / HOL / NH (§5), log,
finish. :class:`pedvr.etiquette.system.DoorEtiquette` adds the per-tick and per-step work on top.

The door models import this module, never :mod:`.system` (which imports them): no circle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from pedvr.body.steps import LEFT, RIGHT, generate_steps
from pedvr.etiquette import decision as bn
from pedvr.etiquette.doors import DoorLeaves
from pedvr.etiquette.regions import HAND_HEIGHT, LeafFrame
from pedvr.etiquette.vocab import APPROACH, ARRIVE, FOLLOWER, GRAB_REACH_S, HOLDER, NONE, REPLAN_AT
from pedvr.scene.config import Door, EtiquetteConfig, SceneConfig

if TYPE_CHECKING:
    from pedvr.behavior.scheduler import Scheduler
    from pedvr.body.model import FullBody
    from pedvr.crowd.state import CrowdState


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
    freed_hand: bool = False  # a carrier who waited alone long enough and frees a hand
    backing: bool = False  # a pram pusher with a freed hand at a pull door: pram trailing, backs through
    still_since: float = math.nan  # the user: since when it has stood still (slower than SENSE_USER)
    first_wait: float = math.nan  # when it first stood waiting at this door (door_deadlocks)
    blocked_since: float = math.nan  # passing first, blocked since (interaction._pass_on)
    last_wait: float = math.nan  # when it last stood waiting there
    gait: str = ""  # how its plan was made: "steps" (App. C, set_plan / walk_to) or "direct"
    gait_goal: np.ndarray | None = None  # the key pose the steps lead to
    gait_legs: int = 0


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
    run_side: int = 0  # the side the latest passages came from (issue 26: batches)
    run_len: int = 0  # how many passages in a row came from it
    busy: bool = False  # the door passes in batches (queues on both sides; issue 26)


class EtiquetteCore:
    """The etiquette's state and moves (module docstring). Keyword-only set-up."""

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
        self.waited_at: dict[tuple[int, int], float] = {}  # (agent, door) -> s waited, for a dropped walker
        self.wait_since_at: dict[tuple[int, int], float] = {}  # (agent, door) -> when it began to wait
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
                 speed: float | None = None, backward: bool = False, lock: bool = False) -> None:
        """Walk ``w`` to ``target`` along App. C's generated steps (their root keys), to stand
        there facing ``facing`` (None: the way it walked). ``target`` is a key pose's root (2,)
        or ``(K, 2)`` waypoints to it (round a leaf's edge): one step sequence per leg, the feet
        carried from one leg to the next, standing only at the end (App. C.2: ``sd``)."""
        r = self._row[w.id]
        b = self.body.state
        pts = np.asarray(target, np.float64).reshape(-1, 2)
        fl, fr = b.foot_ref[r, 0].copy(), b.foot_ref[r, 1].copy()
        stepping = bool(b.stepping[r])
        swing = int(b.swing[r]) if stepping else (RIGHT if float(np.hypot(*(fr - pts[0])))
                                                  > float(np.hypot(*(fl - pts[0]))) else LEFT)
        cur = crowd.pos[r].copy()
        keys: list[np.ndarray] = []
        face = facing
        for i, q in enumerate(pts):
            last = i == pts.shape[0] - 1
            plan = generate_steps(root=cur, left=fl, right=fr, swing=swing, standing=not stepping and i == 0,
                                  target=q, target_facing=facing if last else None, end_standing=last,
                                  backward=backward)
            keys.append(plan.root[1:] if plan.root.shape[0] > 1 else plan.root)
            if not last:
                keys.append(q.reshape(1, 2))
            for st in plan.steps:
                if st.side == LEFT:
                    fl = st.pos
                else:
                    fr = st.pos
            if plan.steps:
                swing = 1 - plan.steps[-1].side
            if last and facing is None:
                face = float(plan.facing[-1])
            cur = q
        w.waiting = False
        w.plan = np.ascontiguousarray(np.concatenate(keys))
        w.plan_i = 0
        w.face = math.nan if face is None else face
        w.lock = lock
        w.speed = float(crowd.pref_speed[r]) if speed is None else speed
        w.gait = "steps"
        w.gait_goal = pts[-1].copy()
        w.gait_legs = pts.shape[0]

    def walk_to(self, w: Walker, crowd: CrowdState, target: np.ndarray, *, facing: float, speed: float,
                lock: bool = False, backward: bool = False) -> None:
        """A key-pose move of the door interaction (App. B) along App. C's steps (:meth:`set_plan`),
        for a door state that names its key pose every tick: the steps are generated when the key
        pose (or the number of legs to it) changes, by more than :data:`REPLAN_AT`; otherwise only
        the facing, speed and lock are updated."""
        pts = np.asarray(target, np.float64).reshape(-1, 2)
        if w.gait == "steps" and w.plan is not None and w.gait_goal is not None \
                and w.gait_legs == pts.shape[0] and float(np.hypot(*(w.gait_goal - pts[-1]))) < REPLAN_AT:
            w.waiting = False
            w.face = facing
            w.lock = lock
            w.speed = speed
            return
        self.set_plan(w, crowd, pts, facing=facing, speed=speed, lock=lock, backward=backward)

    def go_direct(self, w: Walker, target: np.ndarray, *, facing: float, speed: float,
                  lock: bool = False) -> None:
        """Walk straight at ``target`` (re-aimed every tick: a moving target); ``target`` may be
        ``(K, 2)`` waypoints, the last one the target."""
        w.waiting = False
        w.plan = np.asarray(target, np.float64).reshape(-1, 2).copy()
        w.plan_i = 0
        w.face = facing
        w.lock = lock
        w.speed = speed
        w.gait = "direct"
        w.gait_goal = None

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

    def effort_distance(self, holder: Walker, follower: Walker, crowd: CrowdState) -> float:
        """Effort's distance (§5.1.1): from the holder to ``follower``, body to body, when the
        follower has closed up (App. B.3: the decision comes once the committed follower is at
        its place behind the holder, or at the Opposing Goal across the door)."""
        r = self._row[holder.id]
        f = self._row[follower.id]
        return float(np.hypot(*(crowd.pos[r] - crowd.pos[f])))

    def decide_hold(self, holder: Walker, follower: Walker, crowd: CrowdState) -> str:
        """HOF / HOL / NH for ``follower`` by the network of §5: Effort from the follower's distance
        (:meth:`effort_distance`), Care from Table 3, the holder's Kindness and Rush."""
        r = self._row[holder.id]
        f = self._row[follower.id]
        d = self.effort_distance(holder, follower, crowd)
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


    # -- bookkeeping ---------------------------------------------------------------------------

    def finish(self, w: Walker, crowd: CrowdState) -> None:
        """``w`` is done with the door (through it, or giving it up): its navigation takes over
        again. Whether it passed is not decided here: a passage is counted when its body crosses
        the doorway (:meth:`pedvr.etiquette.system.DoorEtiquette.track_passages`)."""
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
        self.waited_at[(w.id, w.door)] = w.waited  # until its body passes (or it comes back)
        self.wait_since_at[(w.id, w.door)] = w.first_wait
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

