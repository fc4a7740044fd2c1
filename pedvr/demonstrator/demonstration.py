"""A demonstration as a behavior: "demonstrate object X to observer Y" (PLACE §3–8 on ADAPT §6).

An **exhibit** is a smart object (``kind = "exhibit"``, on a table or a
pedestal: its ``at`` may lie on an obstacle) with one affordance,
``demonstrate``. The **demonstrate** node (also the ``demonstrate`` library
tree, and ``use`` with the affordance, whose observer is the user) drives the
demonstrator through PLACE:

1. **Plan** (§4): the placement search runs inside the behavior tick, a
   slice of candidates per tick (:data:`PLAN_BUDGET` frame orientations), so
   no frame waits for a whole plan.
2. **Walk** (§5) along the navigation mesh to the placement, looking at the
   floor ahead (§8). When the placement's orientation θ points roughly the
   way the demonstrator comes (within :data:`APPROACH_CONE`), the last leg
   runs along θ from a point :data:`APPROACH` m behind the placement, so the
   body arrives facing θ after a sharp turn a couple of steps out, as the
   paper's subjects did; otherwise (θ back toward where it came from) it walks
   straight in and turns on the spot, never past the placement and back. It
   then turns on the spot for the rest (within 10°).
3. **Act** (§6–7): the pointing (or touching) arm starts :data:`TRANSITION`
   s before the feet stop, matched to the arm swing
   (:mod:`pedvr.demonstrator.coordination`), and follows the planned hand
   path (:mod:`pedvr.demonstrator.arm`) to the stroke point; holds there for
   the exhibit's ``talk`` seconds; returns.
4. **Engage** (§8): gaze at the floor while walking, at the target when the
   action starts, at the observer from ``Δt`` before the stroke (eye contact
   at the stroke), then alternating (:mod:`pedvr.demonstrator.engagement`);
   the head turns at most the placement's allowance (φ), the eyes do the
   rest. Gazes at the observer are recorded like the PedVR gaze rule's
   (``ctx.gaze_events``, ``source = "demonstration"``).
5. **Re-plan** (the paper's future work: the observer moves). While holding,
   every :data:`REPLAN_EVERY` s the node checks the observer; once it has
   moved :data:`REPLAN_MOVE` m or more from where the placement was planned
   for and has settled (walks slower than :data:`SETTLED`, unless the
   current placement no longer works for it), or :data:`REPLAN_STILL` m
   while the current placement no longer works for it (hidden, too close,
   beyond eye contact: a small step behind a pillar is enough; then not within
   :data:`DWELL` s of arriving, but as soon as that is over), a new search runs
   (across ticks; it widens and falls back as
   :class:`~pedvr.demonstrator.placement.PlacementSearch` says when the model
   gives no valid placement). The demonstrator moves only if the new best
   placement is clearly better (:data:`HYSTERESIS` cost units below the current
   placement re-scored for the observer's new place, and :data:`MIN_MOVE` m
   away) and it has stood :data:`DWELL` s, or if the current one became
   invalid: the demonstrator never dances. A placement off the model (a fallback) never
   replaces one that still works, and a valid one always replaces a
   fallback. A search that finds nothing is not repeated until the observer
   moves again. A reposition
   is a short walk at reduced speed (within :data:`SIDESTEP` m side or back steps
   that keep facing the new θ: 2–4 steps up to about 0.6 m, §5's short range, as
   tests/body/test_short_reposition.py checks; longer ones take more), with the
   arm retracted on the way and pointing again on arrival; the talk goes on
   for the time that was left.

The node succeeds when the talk is done, the arm is back and the observer
could see the demonstrator when the talk ended, or early when
the observer walks away (farther than :data:`LEAVE_DIST` from the exhibit for
:data:`LEAVE_AFTER` s: a guide does not go on talking to nobody; logged with
outcome ``left``; the node succeeds, so an event ends normally, but the
exhibit does not count a use); it fails (and
the exhibit counts the reason) with ``no observer``, ``no placement`` (no
placement from which the observer can be seen, even widened and off the
model), ``observer hidden`` (the talk ended with obstacles between the
demonstrator's eyes and the observer's: nowhere better was found; never
logged a success, issue 24), ``blocked`` (every ranked placement
unreachable when walked to) or ``timeout``. Stopped, it ends everything it
started. While it runs for the user, the user-encounter model leaves the
demonstrator alone (``ctx.engaged``), as it does for events in which the
user has a role.

Every demonstration is logged on its exhibit (``object_log`` in the run's
metrics): placement, times of the action start, feet stop, strokes and end,
the planned window and how the swing was matched, the eye-contact error at
each stroke, re-plans and repositions; and whether the observer could see:
``placement_origins`` (the search pass of each placement: ``model``,
``wide``, ``fallback``), ``widened`` (searches that found no valid placement
from the model), ``fallbacks`` (placements taken off the model), ``hidden_s``
(seconds the observer was hidden while the demonstrator talked, sampled at each
re-plan check) and ``seen`` (True or False when the talk ended or no placement
was found, else None). The run's metrics sum them over exhibits
(:data:`FIGURES`: ``demonstrations_unseen`` and the others).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from pedvr.behavior.context import Context
from pedvr.behavior.goals import Param, positive
from pedvr.behavior.library import trees
from pedvr.behavior.nodes import Attr, NodeType, define_tree, node_types
from pedvr.behavior.objects import SmartObject, object_kinds
from pedvr.behavior.spec import EventDef, ObjectDef
from pedvr.behavior.tree import FAILURE, INVALID, RUNNING, SUCCESS, Behaviour, Status
from pedvr.body import skeleton as sk
from pedvr.body.locomotion import V_WALK
from pedvr.body.model import Handle
from pedvr.body.model import Status as BodyStatus
from pedvr.crowd.state import LIMIT_TURN_STANDING
from pedvr.demonstrator import coordination as co
from pedvr.demonstrator import engagement as en
from pedvr.demonstrator.arm import ACTIONS, Action, hand_path, min_jerk_times, preferred_distance
from pedvr.demonstrator.placement import VIS_DISCARD, Observer, Placement, PlacementSearch, score
from pedvr.demonstrator.stage import Figure, Stage
from pedvr.errors import UsageError

if TYPE_CHECKING:
    from pedvr.behavior.scheduler import EventRun, Scheduler

PLAN_BUDGET = 24  # frame orientations evaluated per behavior tick (72 in all: three ticks)
ARRIVE = 0.1  # m: the placement is reached within this
APPROACH = 0.6  # m: the last leg runs along the placement's orientation from this far behind it
SWITCH = 0.5  # m from the approach point where the walk turns onto the last leg
APPROACH_CONE = math.radians(75.0)  # the last leg is straightened only for placements roughly ahead
FACE_TOL = math.radians(10.0)
QUIET = 0.3  # s without a step after which the feet have stopped (a last squaring step may follow a stop)
T_PREP = 1.0  # s from the action's start to its stroke point
T_RETRACT = 0.8  # s to bring the hand back
T_RETRACT_FAST = 0.5  # s, before a reposition
REPLAN_EVERY = 0.5  # s between checks of the observer while holding
REPLAN_MOVE = 0.5  # m the observer must move from where the plan was made before a re-plan
REPLAN_STILL = 0.25  # m: ... or this much while the placement no longer works for the observer
WALK_REPLAN_MOVE = 1.5  # m, while walking to the placement
HYSTERESIS = 20.0  # cost units (20° of neck rotation) a new placement must gain to be worth a move
MIN_MOVE = 0.3  # m: closer placements are not worth a step
DWELL = 2.0  # s at a placement before the demonstrator may move again
SETTLED = 0.5  # m/s: an observer walking faster is waited for (unless it can no longer be shown to)
REPOSITION_SPEED = 0.6  # scale of the preferred speed for a short reposition
SHORT = 2.0  # m: a reposition this short is a few steps at reduced speed
SIDESTEP = 1.2  # m: a reposition this short is stepped facing the new orientation (side / back steps)
TIMEOUT = 90.0  # s: a demonstration that has not finished by then fails
LEAVE_DIST = 7.0  # m from the exhibit: an observer this far away has left ...
LEAVE_AFTER = 1.5  # s: ... when it stays away this long; the demonstration ends early
TRANSITION = co.TRANSITION

PLAN, WALK, SETTLE, STAND, RETREAT = "plan", "walk", "settle", "stand", "retreat"
# The run's metrics (Exhibit.figures, summed over the scene's exhibits), from the demonstrations that ended:
FIGURES = {
    "demonstrations": "demonstrations that ended (any outcome)",
    "demonstrations_unseen": "ended without a placement the observer could see: no placement at all, or "
                             "the observer hidden from the demonstrator when the talk ended",
    "demonstrations_widened": "a search found no valid placement from the model and widened",
    "demonstrations_fallback": "the demonstrator took a placement off the model (none valid even widened)",
    "demonstration_hidden_s": "seconds the observer was hidden from the demonstrator while it talked",
}


def _action_kind(v: object) -> str | None:
    return None if v in ACTIONS else f"expected one of {', '.join(ACTIONS)}"


@object_kinds.register("exhibit")
class Exhibit(SmartObject):
    """Something a demonstrator shows to an observer (PLACE's target ``p_t``), ``at`` its ground point.

    Scene keys: ``height`` (m, the point shown: the object's top; default the
    supporting obstacle's height + 0.1, or 1.0 off obstacles), ``size`` (m,
    default 0.1), ``action`` (``point`` or ``touch``, default ``point``),
    ``d_pref`` (m, the preferred distance; default from the action, see
    :func:`pedvr.demonstrator.arm.preferred_distance`), ``talk`` (s at the
    stroke point, default 4). ``facing_deg`` is the model's Z axis when the
    exhibit is not on an obstacle (on one, Z is orthogonal to its nearest edge).

    Affordance ``demonstrate``: the node :class:`Demonstrate` with the user as
    the observer (``use``); the ``demonstrate`` node and tree name any observer.
    """

    AFFORDANCES = ("demonstrate",)
    ON_OBSTACLES = True
    PARAMS = {"height": Param(positive, required=False), "size": Param(positive, required=False),
              "action": Param(_action_kind, required=False), "d_pref": Param(positive, required=False),
              "talk": Param(positive, required=False)}

    def __init__(self, decl: ObjectDef) -> None:
        super().__init__(decl)
        self.size = float(self.params.get("size", 0.1))
        self.action_kind = str(self.params.get("action", "point"))
        self.d_pref = float(self.params["d_pref"]) if "d_pref" in self.params else None
        self.talk = float(self.params.get("talk", 4.0))
        self._height = float(self.params["height"]) if "height" in self.params else None
        self._stage: Stage | None = None
        # who stands where for a demonstration now (other demonstrators keep clear): agent -> (x, y, r)
        self.active: dict[int, tuple[float, float, float]] = {}

    def stage(self, ctx: Context) -> Stage | None:
        """The planner's world (built on first use), or None without a world in the context."""
        if self._stage is None and ctx.world is not None:
            self._stage = Stage(ctx.world, ctx.walkable)
        return self._stage

    def height(self, stage: Stage) -> float:
        if self._height is None:
            i = stage.support(self.at)
            self._height = float(stage.height[i]) + 0.1 if i is not None else 1.0
        return self._height

    def affordance(self, name: str, agent: int, ctx: Context) -> Behaviour | None:
        if name == "demonstrate":
            return Demonstrate(agent, self, observer=None)
        return None

    def figures(self) -> dict[str, float]:
        """For the run's metrics, over the demonstrations that ended here (:data:`FIGURES`)."""
        log = self.log
        return {"demonstrations": len(log),
                "demonstrations_unseen": sum(1 for e in log if e["seen"] is False),
                "demonstrations_widened": sum(1 for e in log if e["widened"]),
                "demonstrations_fallback": sum(1 for e in log if e["fallbacks"]),
                "demonstration_hidden_s": round(sum(e["hidden_s"] for e in log), 6)}


def repeats_of(ctx: Context, agent: int) -> int:
    """Demonstrations ``agent`` completed before, at any exhibit (for declining gaze durations, §8)."""
    return sum(1 for o in ctx.objects.values() if isinstance(o, Exhibit)
               for e in o.log if e["agent"] == agent and e["outcome"] == "success")


class Demonstrate(Behaviour):
    """``agent`` demonstrates ``exhibit`` to ``observer`` (an agent id; None: the user). See the module."""

    def __init__(self, agent: int, exhibit: Exhibit, *, observer: int | None, name: str = "") -> None:
        super().__init__(name or f"{exhibit.name}.demonstrate")
        self.agent = agent
        self.exhibit = exhibit
        self.observer_arg = observer
        self._reset()

    def _reset(self) -> None:
        self.observer: int | None = None
        self.why = ""
        self.phase = PLAN
        self.search: PlacementSearch | None = None
        self.placement: Placement | None = None
        self.pre: tuple[float, float] | None = None
        self.walk: Handle | None = None
        self.obs_ref = (0.0, 0.0)
        self.figure: Figure | None = None
        self.stage: Stage | None = None
        self.action: Action | None = None
        self.t0 = 0.0
        self.start: co.Start | None = None
        self.acting = False  # the arm follows a path (pointing, holding or retracting)
        self.path: np.ndarray | None = None
        self.t_action = math.nan
        self.t_stroke = math.nan
        self.t_obs = math.nan
        self.t_hold_end = math.nan
        self.t_retract_end = math.nan
        self.retracting = False
        self.talk_left = 0.0
        self.gazing = ""
        self.schedule: list[tuple[float, str]] = []
        self.t_arrived = math.nan
        self.t_feet_stop = math.nan
        self.t_stepping = math.nan  # the last tick the feet were stepping (walking or turning)
        self.cruise = 1.0
        self.next_check = 0.0
        self.pending: PlacementSearch | None = None
        self.entry: dict[str, Any] = {}
        self.away_since = math.inf
        self.demo_id = -1  # numbered once it starts (ctx.events)
        self.t_watch = math.nan  # the last visibility check while holding, and what it found
        self.was_hidden = False

    # -- set-up ---------------------------------------------------------------------------------

    def initialise(self, ctx: Context) -> None:
        self._reset()
        self.t0 = ctx.t
        ex = self.exhibit
        self.observer = ctx.user if self.observer_arg is None else self.observer_arg
        self.entry = {"object": ex.name, "kind": ex.kind, "agent": self.agent,
                      "observer": "user" if self.observer == ctx.user else self.observer,
                      "t_start": round(ctx.t, 6), "outcome": "", "why": "", "replans": 0, "repositions": 0,
                      "placements": [], "t_action": [], "window_planned": [], "swing": [],
                      "t_stop_predicted": [], "t_feet_stop": [], "head_limit_deg": [],
                      "t_stroke": [], "eye_contact_deg": [], "t_end": None,
                      "placement_origins": [], "widened": 0, "fallbacks": 0, "hidden_s": 0.0, "seen": None}
        if self.observer is None or ctx.find(self.observer) is None:
            self.why = "no observer"
            return
        if ctx.sitting(self.agent):
            self.why = "seated"
            return
        stage = ex.stage(ctx)
        if stage is None:
            self.why = "no world"
            return
        self.stage = stage
        r = ctx.row(self.agent)
        self.figure = Figure.of_dims(ctx.body.state.dims[r], float(ctx.crowd.radius[r]))
        height = ex.height(stage)
        self.action = Action(ex.action_kind, ex.at, height,
                             preferred_distance(ex.action_kind, self.figure, height=height, size=ex.size,
                                                d_pref=ex.d_pref))
        for ch in ("walk", "gaze", "face", "reach_right"):
            ctx.claim(self.agent, ch, self)
        starts = [e for e in ctx.events if e.get("kind") == "demonstration" and e["event"] == "start"]
        self.demo_id = len(starts)
        self._event(ctx, "start")
        if self.observer == ctx.user:
            ctx.engaged.add(self.agent)
        ctx.body.go_to(self.agent, None)
        self.talk_left = ex.talk
        self.search = self._search(ctx)
        ex.active[self.agent] = (*ctx.pos(self.agent), float(ctx.crowd.radius[r]))

    def _observer(self, ctx: Context) -> Observer:
        assert self.observer is not None
        r = ctx.row(self.observer)
        if self.observer == ctx.user:
            eye = float(ctx.body.user_head(ctx.crowd)[1])
        else:
            eye = float(ctx.body.state.world_pos[r, sk.HEAD, 1]) or 1.6
        return Observer(ctx.pos(self.observer), eye_height=eye if eye > 0.5 else 1.6,
                        radius=float(ctx.crowd.radius[r]))

    def _search(self, ctx: Context) -> PlacementSearch:
        assert self.stage is not None and self.figure is not None and self.action is not None
        obs = self._observer(ctx)
        self.obs_ref = obs.pos
        clear = [v for o in ctx.objects.values() if isinstance(o, Exhibit)
                 for a, v in o.active.items() if a != self.agent]
        return PlacementSearch(self.stage, self.figure, self.action, obs, start=ctx.pos(self.agent),
                               default_zeta=self.exhibit.facing, keep_clear=clear)

    # -- the tick -------------------------------------------------------------------------------

    def update(self, ctx: Context) -> Status:
        if self.why:
            return self._fail(self.why)
        if ctx.t - self.t0 > TIMEOUT:
            return self._fail("timeout")
        if self.observer is None or ctx.find(self.observer) is None:
            return self._fail("no observer")
        if self._left(ctx):
            self.why = "observer left"
            return SUCCESS
        self.wake = 0.0
        if self.phase == PLAN:
            assert self.search is not None
            if not self.search.advance(PLAN_BUDGET):
                return RUNNING
            self.entry["widened"] += int(self.search.plan.widened)
            best = self.search.plan.best
            if best is None:
                self.entry["seen"] = False  # nowhere the observer could be shown to
                return self._fail("no placement")
            self._go(ctx, best, short=False)
        if self.phase == WALK:
            s = self._walk(ctx)
            if s is not RUNNING:
                return s
        if self.phase == SETTLE:
            self._settle(ctx)
        if self.phase == RETREAT:
            if ctx.t >= self.t_retract_end - 1e-9:
                self._release_arm(ctx)
                assert self.pending is not None and self.pending.plan.best is not None
                self._go(ctx, self.pending.plan.best, short=True)
                self.pending = None
        if self.acting:
            done = self._act(ctx)
            if done:
                return self._succeed(ctx)
        if self.phase == STAND:
            self._replan(ctx)
        elif self.phase != RETREAT:
            self.wake = 0.0  # planning, walking, settling: every tick
        return RUNNING

    def _left(self, ctx: Context) -> bool:
        """The observer has been farther than :data:`LEAVE_DIST` from the exhibit for
        :data:`LEAVE_AFTER` s."""
        assert self.observer is not None
        if math.dist(ctx.pos(self.observer), self.exhibit.at) <= LEAVE_DIST:
            self.away_since = math.inf
            return False
        self.away_since = min(self.away_since, ctx.t)
        return ctx.t - self.away_since >= LEAVE_AFTER

    # -- walking --------------------------------------------------------------------------------

    def _go(self, ctx: Context, p: Placement, *, short: bool) -> None:
        """Walk to placement ``p`` (``short``: a reposition, at reduced speed)."""
        self.placement = p
        self.phase = WALK
        self.start = None
        self.t_arrived = math.nan
        self.exhibit.active[self.agent] = (p.pos[0], p.pos[1], self.figure.radius if self.figure else 0.25)
        self.entry["placements"].append([round(p.pos[0], 4), round(p.pos[1], 4),
                                         round(math.degrees(p.heading), 2)])
        self.entry["placement_origins"].append(p.origin)
        self.entry["fallbacks"] += int(p.fallback)
        self.entry["head_limit_deg"].append(round(p.head_limit, 3))
        here = ctx.pos(self.agent)
        self.pre = None
        far = math.dist(here, p.pos) > APPROACH + SWITCH + 0.2
        toward = math.atan2(p.pos[1] - here[1], p.pos[0] - here[0])
        ahead = abs((toward - p.heading + math.pi) % (2 * math.pi) - math.pi) < APPROACH_CONE
        if far and ahead and not short:
            pre = (p.pos[0] - APPROACH * math.cos(p.heading), p.pos[1] - APPROACH * math.sin(p.heading))
            mesh = ctx.walkable
            if mesh.contains(pre) and mesh.same_component(pre, p.pos) and \
                    ctx.visibility.segment_clear(pre, p.pos, float(ctx.crowd.radius[ctx.row(self.agent)])):
                self.pre = pre
        r = ctx.row(self.agent)
        ctx.behavior.face[r] = np.nan
        self.cruise = REPOSITION_SPEED if short and math.dist(here, p.pos) < SHORT else 1.0
        # §5's short-range repositioning: a few side or back steps, turning toward θ on the way,
        # as people shift their stance, not a turn to walk and a turn back
        ctx.body.hold_facing(self.agent, p.heading if short and math.dist(here, p.pos) < SIDESTEP else None)
        ctx.behavior.speed_scale[r] = self.cruise
        goal = self.pre if self.pre is not None else p.pos
        self.walk = ctx.body.go_to(self.agent, goal, arrive_dist=ARRIVE if self.pre is None else SWITCH,
                                   timeout=TIMEOUT)
        self._look_floor(ctx)

    def _look_floor(self, ctx: Context) -> None:
        x, y = ctx.pos(self.agent)
        h = ctx.heading(self.agent)
        self._gaze(ctx, "floor", (x + en.FLOOR_AHEAD * math.cos(h), 0.0, y + en.FLOOR_AHEAD * math.sin(h)))

    def _walk(self, ctx: Context) -> Status:
        p = self.placement
        assert p is not None and self.walk is not None and self.search is not None
        h = self.walk.status
        if h is BodyStatus.FAILURE:
            nxt = self.search.plan.after(p)
            if nxt is None:
                return self._fail("blocked")
            self._go(ctx, nxt, short=False)  # §4: the next placement of the sorted list
            return RUNNING
        here = ctx.pos(self.agent)
        if self.pre is not None and (h is BodyStatus.SUCCESS or math.dist(here, self.pre) < SWITCH):
            self.pre = None
            self.walk = ctx.body.go_to(self.agent, p.pos, arrive_dist=ARRIVE, timeout=TIMEOUT)
            h = self.walk.status
        if self.pre is None:
            self._brake(ctx, here, p.pos)
        if not self.acting and self.gazing in ("", "floor"):
            self._look_floor(ctx)
        # re-plan while walking when the observer has gone far from where the plan was made
        if not self.acting:
            self._walk_replan(ctx)
        if not self.acting:
            self._coordinate(ctx)
        self.t_stepping = ctx.t
        if h is BodyStatus.SUCCESS and self.pre is None:
            self.phase = SETTLE
            self.t_arrived = ctx.t
            self.walk = None
            ctx.body.go_to(self.agent, None)
            ctx.body.hold_facing(self.agent, None)
            ctx.behavior.speed_scale[ctx.row(self.agent)] = 1.0
        return RUNNING

    def _brake(self, ctx: Context, here: tuple[float, float], goal: tuple[float, float]) -> None:
        """On the last leg, scale the preferred speed so the walker brakes at ``coordination.BRAKE``
        and stops at the placement (the plan phase's own slowing, linear inside
        ``SLOWING_DIST``, is divided out)."""
        r = ctx.row(self.agent)
        d = math.dist(here, goal)
        if not ctx.visibility.segment_clear(here, goal, 0.0):
            return  # a corner ahead: the plan phase does not slow toward it
        pref = float(ctx.crowd.pref_speed[r]) * self.cruise
        want = min(pref, co.braking_speed(d, arrive=ARRIVE))
        slowing = min(1.0, d / co.SLOWING_DIST)
        ctx.behavior.speed_scale[r] = min(want / max(float(ctx.crowd.pref_speed[r]) * slowing, 1e-6), 4.0)

    def _walk_replan(self, ctx: Context) -> None:
        obs = ctx.pos(self.observer) if self.observer is not None else self.obs_ref
        if self.pending is None and math.dist(obs, self.obs_ref) > WALK_REPLAN_MOVE:
            self.pending = self._search(ctx)
            self.entry["replans"] += 1
        if self.pending is not None and self.pending.advance(PLAN_BUDGET):
            best = self.pending.plan.best
            self.entry["widened"] += int(self.pending.plan.widened)
            p = self.placement
            if best is None or p is None:
                self.pending = None  # nowhere better: keep walking, the check while holding follows
                return
            self.search, self.pending = self.pending, None
            if best.fallback and not p.fallback and math.isfinite(self._score(ctx, p, p.pos)):
                return  # a placement off the model never replaces one that still works
            if math.dist(best.pos, p.pos) > MIN_MOVE:
                self._go(ctx, best, short=False)

    def _remaining(self, ctx: Context) -> float:
        assert self.placement is not None
        here = ctx.pos(self.agent)
        if self.pre is not None:
            return math.dist(here, self.pre) + math.dist(self.pre, self.placement.pos)
        return math.dist(here, self.placement.pos)

    def _coordinate(self, ctx: Context) -> None:
        """Start the action within the transition window before the feet stop (§7)."""
        r = ctx.row(self.agent)
        speed = ctx.speed(self.agent)
        pref = float(ctx.crowd.pref_speed[r]) * self.cruise
        assert self.placement is not None
        here = ctx.pos(self.agent)
        rate = float(ctx.body.state.base_limits[r, LIMIT_TURN_STANDING])
        if self.phase == SETTLE:  # arrived: the turn on the spot and the last steps are left
            turn = abs((self.placement.heading - ctx.heading(self.agent) + math.pi) % (2 * math.pi) - math.pi)
            t_stop = max(self.t_arrived + co.LAST_STEP, ctx.t) + turn / rate
        else:
            last = self.pre if self.pre is not None else here
            goal = self.placement.pos
            arrive_dir = math.atan2(goal[1] - last[1], goal[0] - last[0]) if math.dist(last, goal) > 0.05 \
                else ctx.heading(self.agent)
            turn = abs((self.placement.heading - arrive_dir + math.pi) % (2 * math.pi) - math.pi)
            t_stop = ctx.t + co.time_to_stop(self._remaining(ctx), speed=speed, pref_speed=pref,
                                             arrive=ARRIVE, turn=turn, turn_rate=rate)
        if t_stop - ctx.t <= co.WINDOW[1] + 0.2 or self.start is not None:
            psi, rate = ctx.body.arm_swing(self.agent, "right")
            self.start = co.choose_start(ctx.t, t_stop, psi=psi, rate=rate)
            self.t_stop_predicted = t_stop
        if self.start is not None and ctx.t >= self.start.t - 0.5 / 30.0:
            self._start_action(ctx)

    def _settle(self, ctx: Context) -> None:
        """Arrived: turn on the spot to the placement's orientation; the feet come to rest."""
        assert self.placement is not None
        r = ctx.row(self.agent)
        ctx.behavior.face[r] = self.placement.heading
        if not self.acting:
            self._coordinate(ctx)
        body = ctx.body.state
        still = not bool(body.stepping[r]) and ctx.speed(self.agent) < V_WALK
        if not still:
            self.t_stepping = ctx.t
        off = (ctx.heading(self.agent) - self.placement.heading + math.pi) % (2 * math.pi) - math.pi
        on = abs(off) < FACE_TOL
        if still and on and ctx.t - self.t_stepping >= QUIET - 1e-9:
            # the locomotion (walk and the turn on the spot) ended after the last tick it stepped
            self.phase = STAND
            self.t_feet_stop = self.t_stepping + 1.0 / 30.0 if math.isfinite(self.t_stepping) else ctx.t
            self.entry["t_feet_stop"].append(round(self.t_feet_stop, 6))
            self.next_check = ctx.t + REPLAN_EVERY

    # -- the action and the gaze ----------------------------------------------------------------

    def _start_action(self, ctx: Context) -> None:
        p = self.placement
        assert p is not None and self.stage is not None and self.figure is not None
        assert self.action is not None
        path, _ = hand_path(self.stage, self.figure, pos=p.pos, heading=p.heading, stroke=p.stroke)
        times = ctx.t + min_jerk_times(len(path), T_PREP)
        ctx.claim(self.agent, "reach_right", self)
        ctx.body.reach_along(self.agent, path, times, side="right")
        ctx.body.gaze_limit(self.agent, math.radians(p.head_limit))
        self.path = path
        self.acting = True
        self.retracting = False
        self.t_action = ctx.t
        self.t_stroke = ctx.t + T_PREP
        self.t_hold_end = math.nan
        self.schedule = []
        start = self.start if self.start is not None else co.Start(ctx.t, math.nan, "late")
        self.entry["t_action"].append(round(ctx.t, 6))
        self.entry["window_planned"].append(None if math.isnan(start.window) else round(start.window, 4))
        self.entry["swing"].append(start.how)
        self.entry["t_stop_predicted"].append(round(getattr(self, "t_stop_predicted", math.nan), 6))
        tgt = self._target3()
        self._gaze(ctx, "target", tgt)
        r = ctx.row(self.agent)
        head = ctx.body.state.world_pos[r, sk.HEAD].copy()
        if not np.any(head):
            head = np.array([p.pos[0], self.figure.eye_height, p.pos[1]])
        shift = en.shift_deg(head, np.asarray(tgt), self._observer_head(ctx))
        self.t_obs = self.t_stroke + en.observer_delay(shift)

    def _target3(self) -> tuple[float, float, float]:
        assert self.action is not None
        return (self.action.target[0], self.action.height, self.action.target[1])

    def _observer_head(self, ctx: Context) -> np.ndarray:
        assert self.observer is not None
        if self.observer == ctx.user:
            return np.asarray(ctx.body.user_head(ctx.crowd), np.float64)
        return np.asarray(ctx.body.state.world_pos[ctx.row(self.observer), sk.HEAD], np.float64)

    def _gaze(self, ctx: Context, who: str, point: object = None) -> None:
        """Look at the floor or the target (``point``), or at the observer; log observer gazes."""
        if who == "observer" and self.gazing != "observer":
            ctx.body.gaze_at(self.agent, "user" if self.observer == ctx.user else ("agent", self.observer))
            self._gaze_event(ctx, "start")
        elif who != "observer":
            if self.gazing == "observer":
                self._gaze_event(ctx, "end")
            ctx.body.gaze_at(self.agent, point)
        self.gazing = who

    def _gaze_event(self, ctx: Context, what: str) -> None:
        ctx.gaze_events.append({"agent": self.agent, "t": round(ctx.t, 6), "event": what,
                                "target": "user" if self.observer == ctx.user else "agent",
                                "source": "demonstration"})

    def _act(self, ctx: Context) -> bool:
        """The action's timeline: gaze switches, the stroke, the hold, the return. True when done."""
        t = ctx.t
        if self.retracting:
            if t >= self.t_retract_end - 1e-9:
                self._release_arm(ctx)
                return self.phase != RETREAT
            self.wake = self.t_retract_end
            return False
        if math.isnan(self.t_hold_end):
            if t >= self.t_obs - 1e-9 and self.gazing != "observer":
                self._gaze(ctx, "observer")
            if t >= self.t_stroke - 1e-9:
                self._stroke(ctx)
            else:
                self.wake = self.t_obs if t < self.t_obs else self.t_stroke
                return False
        while self.schedule and t >= self.schedule[0][0] - 1e-9:
            _, who = self.schedule.pop(0)
            self._gaze(ctx, who, self._target3())
        if t >= self.t_hold_end - 1e-9:
            self.talk_left = 0.0
            self.entry["seen"] = not self._watch(ctx)
            self.t_watch = math.nan
            self._retract(ctx, T_RETRACT)
            self._gaze(ctx, "observer")
            return False
        nxt = min(self.schedule[0][0] if self.schedule else math.inf, self.t_hold_end)
        self.wake = nxt if self.phase != STAND else min(nxt, self.next_check)
        return False

    def _event(self, ctx: Context, what: str, **extra: object) -> None:
        """A demonstration event for recorders (``ctx.events``): start, stroke, end."""
        ctx.events.append({"kind": "demonstration", "event": what, "id": self.demo_id, "t": round(ctx.t, 6),
                           "agent": self.agent, "object": self.exhibit.name, "x": self.exhibit.at[0],
                           "y": self.exhibit.at[1], "observer": self.entry.get("observer"), **extra})

    def _stroke(self, ctx: Context) -> None:
        self._event(ctx, "stroke")
        self._watch(ctx)  # the hold starts: from here on, hidden time counts
        self.entry["t_stroke"].append(round(ctx.t, 6))
        self.entry["eye_contact_deg"].append(round(self.eye_contact_error(ctx), 3))
        self.t_hold_end = ctx.t + self.talk_left
        self.t_hold_started = ctx.t
        self.schedule = en.hold_schedule(ctx.t, self.t_hold_end, repeats_of(ctx, self.agent))
        self.schedule.pop(0)  # the observer gaze is on already

    def eye_contact_error(self, ctx: Context) -> float:
        """Degrees between where the demonstrator's eyes look (mean of both) and the observer's head."""
        r = ctx.row(self.agent)
        b = ctx.body.state
        obs = self._observer_head(ctx)
        errs = []
        for eye in (sk.L_EYE, sk.R_EYE):
            q = b.world_q[r, eye]
            x, y, z, w = q
            # the eye's +Z axis in the world
            fwd = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
            d = obs - b.world_pos[r, eye]
            c = float(np.dot(fwd, d) / max(float(np.linalg.norm(d)), 1e-9))
            errs.append(math.degrees(math.acos(min(max(c, -1.0), 1.0))))
        return float(np.mean(errs))

    def _retract(self, ctx: Context, seconds: float) -> None:
        """The hand back along its path from wherever it is, over ``seconds``."""
        assert self.path is not None
        b = ctx.body.state
        here = b.world_pos[ctx.row(self.agent), sk.R_HAND].copy()
        back = np.concatenate([here[None, :], self.path[::-1][1:]])
        ctx.body.reach_along(self.agent, back, ctx.t + min_jerk_times(len(back), seconds), side="right")
        self.retracting = True
        self.t_retract_end = ctx.t + seconds
        self.wake = self.t_retract_end

    def _release_arm(self, ctx: Context) -> None:
        if ctx.owns(self.agent, "reach_right", self):
            ctx.body.reach_for(self.agent, None, side="right")
        self.acting = False
        self.retracting = False

    # -- re-planning while standing -------------------------------------------------------------

    def _replan(self, ctx: Context) -> None:
        """Every :data:`REPLAN_EVERY` s while holding: watch whether the observer can see, and search
        again when it has moved :data:`REPLAN_MOVE` m from where the plan was made (and settled), or
        :data:`REPLAN_STILL` m while the placement no longer works for it (hidden, too close, beyond
        eye contact): a search that finds nothing is not repeated for an observer standing still.
        Within :data:`DWELL` s of arriving a placement that still works is kept even if a better one
        is found (that search's observer place becomes the reference), and one that no longer works
        is searched for once the dwell is over (the reference is kept, so the check comes back)."""
        if self.retracting or math.isnan(self.t_hold_end):
            return
        t = ctx.t
        if self.pending is None:
            if t < self.next_check - 1e-9:
                return
            self.next_check = t + REPLAN_EVERY
            self._watch(ctx)
            assert self.observer is not None
            moved = math.dist(ctx.pos(self.observer), self.obs_ref)
            works = math.isfinite(self._current_score(ctx))
            if moved < (REPLAN_MOVE if works else REPLAN_STILL):
                return
            if ctx.speed(self.observer) > SETTLED and works:
                return  # the observer is still on the move and can still be shown to: wait
            if not works and t - self.t_feet_stop < DWELL:
                return  # it must move, but not yet: the reference is kept, so the check comes back
            self.pending = self._search(ctx)
            self.entry["replans"] += 1
        self.wake = 0.0
        if not self.pending.advance(PLAN_BUDGET):
            return
        self.entry["widened"] += int(self.pending.plan.widened)
        best = self.pending.plan.best
        p = self.placement
        assert p is not None
        now = self._current_score(ctx)
        # a valid placement beats one off the model; one off the model replaces only a placement
        # that no longer works, or another off the model
        better = best is not None and (
            not math.isfinite(now) or (p.fallback and not best.fallback)
            or (best.cost < now - HYSTERESIS and (p.fallback or not best.fallback)))
        if best is not None and better and math.dist(best.pos, ctx.pos(self.agent)) >= MIN_MOVE:
            if t - self.t_feet_stop < DWELL:  # only better, the current one still works: not worth a dance
                self.pending = None
                return
            self._watch(ctx)
            self.t_watch = math.nan  # walking, not holding: hidden time counts again once back
            self.entry["repositions"] += 1
            self.talk_left = max(self.t_hold_end - t, 0.0)
            self.t_hold_end = math.nan
            self.schedule = []
            self._retract(ctx, T_RETRACT_FAST)
            self._gaze(ctx, "floor", self._floor_point(ctx))
            ctx.body.gaze_limit(self.agent, None)
            self.phase = RETREAT
            self.search = self.pending  # kept for the placement's alternatives; pending is consumed below
            return
        self.search, self.pending = self.pending, None  # kept: the observer's new place is the reference

    def _current_score(self, ctx: Context) -> float:
        """The current placement's cost for where the observer is now (inf: no longer valid)."""
        assert self.placement is not None
        return self._score(ctx, self.placement, ctx.pos(self.agent))

    def _score(self, ctx: Context, p: Placement, pos: tuple[float, float]) -> float:
        assert self.stage is not None and self.figure is not None and self.action is not None
        return score(self.stage, self.figure, self.action, self._observer(ctx), pos=pos, heading=p.heading,
                     head_limit=p.head_limit)

    def hidden(self, ctx: Context) -> bool:
        """Whether obstacles hide the observer's head from the demonstrator's eyes where it stands
        (more than :data:`pedvr.demonstrator.placement.VIS_DISCARD` of the sight line, as the
        planner discards)."""
        assert self.stage is not None and self.figure is not None
        obs = self._observer(ctx)
        e = self.stage.occluded(np.asarray([ctx.pos(self.agent)]), self.figure.eye_height,
                                np.asarray([obs.pos]), obs.eye_height)
        return bool(e[0] > VIS_DISCARD)

    def _watch(self, ctx: Context) -> bool:
        """Sample visibility while holding; the time since the last sample counts as hidden when that
        sample was (``hidden_s`` in the log). Returns whether the observer is hidden now."""
        now = self.hidden(ctx)
        if self.was_hidden and math.isfinite(self.t_watch):
            self.entry["hidden_s"] = round(self.entry["hidden_s"] + ctx.t - self.t_watch, 6)
        self.t_watch = ctx.t
        self.was_hidden = now
        return now

    def _floor_point(self, ctx: Context) -> tuple[float, float, float]:
        x, y = ctx.pos(self.agent)
        h = ctx.heading(self.agent)
        return (x + en.FLOOR_AHEAD * math.cos(h), 0.0, y + en.FLOOR_AHEAD * math.sin(h))

    # -- the end ----------------------------------------------------------------------------------

    def _succeed(self, ctx: Context) -> Status:
        if self.entry.get("seen") is False:
            return self._fail("observer hidden")  # never a success the observer could not see
        self.exhibit.count("demonstrate")
        return SUCCESS

    def _fail(self, why: str) -> Status:
        self.why = why
        return self.exhibit.fail(why)

    def terminate(self, ctx: Context, new_status: Status) -> None:
        a = self.agent
        if ctx.find(a) is not None:
            if ctx.release(a, "walk", self):
                ctx.body.go_to(a, None)
            if self.gazing == "observer":
                self._gaze_event(ctx, "end")
            if ctx.release(a, "gaze", self):
                ctx.body.gaze_at(a, None)
            ctx.body.gaze_limit(a, None)
            ctx.body.hold_facing(a, None)
            if ctx.release(a, "reach_right", self):
                ctx.body.reach_for(a, None, side="right")
            r = ctx.row(a)
            if ctx.release(a, "face", self):
                ctx.behavior.face[r] = np.nan
            ctx.behavior.speed_scale[r] = 1.0
        self.gazing = ""
        ctx.engaged.discard(a)
        self.exhibit.active.pop(a, None)
        if self.entry and self.was_hidden and math.isfinite(self.t_watch):  # stopped mid-talk, hidden
            self.entry["hidden_s"] = round(self.entry["hidden_s"] + ctx.t - self.t_watch, 6)
        self.t_watch = math.nan
        outcome = ("left" if self.why == "observer left" else
                   {SUCCESS: "success", FAILURE: "failure", INVALID: "stopped"}[new_status])
        if self.entry and self.demo_id >= 0:
            self._event(ctx, "end", outcome=outcome)
        if self.entry:
            self.entry["t_end"] = round(ctx.t, 6)
            self.entry["outcome"] = outcome
            self.entry["why"] = self.why
            self.exhibit.log.append(self.entry)
            self.entry = {}


node_types.register("demonstrate")(NodeType(
    main="agent", attrs={"object": Attr("object", True), "to": Attr("actor")},
    build=lambda s, b: _build(s, b), affords=("object", "demonstrate"),
    doc="demonstrate an exhibit to an observer (PLACE): walk to a placement, point, engage"))


def _build(spec: Any, b: Any) -> Behaviour:
    obj = b.object(spec.attrs["object"])
    if not isinstance(obj, Exhibit):
        raise LookupError(f"{spec.key}: demonstrate needs an exhibit; got {getattr(obj, 'kind', obj)!r}")
    to = spec.attrs.get("to")
    observer = None if to is None else b.actor(to)
    return Demonstrate(b.agent(spec.main), obj, observer=observer, name=spec.key)


trees.register("demonstrate")(define_tree(
    "demonstrate", {"guide": "agent", "observer": "actor", "exhibit": "object"},
    {"demonstrate": "guide", "object": "exhibit", "to": "observer"}))


PROTOCOL_EVENT = "demonstrate"  # the event a cue adds when the scene declares none running the tree
PROTOCOL_PRIORITY = 2  # as the shipped scenes' demonstration events: above conversations and door holds


def demonstrate_to_user(scheduler: Scheduler, exhibit: str, *,
                        guide_state: str | None = None) -> EventRun | None:
    """Start the demonstration of ``exhibit`` to the user now (a study protocol's cue, issue 15).

    It goes through the behavior layer as a scene's trigger does: an event
    running the ``demonstrate`` tree (``guide``, ``observer`` = the user,
    ``exhibit``) is started on the scheduler, so the demonstrator claims its
    guide, plans, walks, points and records as for any demonstration. The
    event is the scene's own that runs the tree (the first by name, so its
    priority and patience are the scene's), or, when the scene declares none,
    :data:`PROTOCOL_EVENT` at :data:`PROTOCOL_PRIORITY` added to the scheduler.

    Our choice of guide (the issue names none): the agent nearest the user
    among those that are not the user and not in an event, and, when
    ``guide_state`` is given, in that BFSM state (``"guide"`` in the
    gallery). Returns the event run, or None when no agent qualifies (nothing
    is started). Raises UsageError for an exhibit the scene lacks.
    """
    ctx = scheduler.ctx
    if ctx.user is None:
        raise UsageError(f"exhibit {exhibit!r}: a demonstration to the user needs a scene with a user")
    obj = ctx.objects.get(exhibit)
    if not isinstance(obj, Exhibit):
        known = sorted(n for n, o in ctx.objects.items() if isinstance(o, Exhibit))
        raise UsageError(f"exhibit {exhibit!r}: not in the scene; its exhibits: {', '.join(known) or 'none'}")
    names = sorted(n for n, e in scheduler.events.items() if e.tree == "demonstrate")
    if names:
        event = names[0]
    else:
        event = PROTOCOL_EVENT
        while event in scheduler.events:
            event += "_"
        scheduler.events[event] = EventDef(name=event, tree="demonstrate", priority=PROTOCOL_PRIORITY)
    crowd, b = ctx.crowd, ctx.behavior
    ok = ~crowd.is_user & ~b.in_event
    if guide_state is not None:
        ok &= b.state == scheduler.bfsm.ids[guide_state]
    rows = np.flatnonzero(ok)
    if rows.size == 0:
        return None
    r = int(rows[np.argmin(np.hypot(*(crowd.pos[rows] - np.asarray(ctx.pos(ctx.user))).T))])
    guide = int(crowd.ids[r])
    return scheduler.start_event(event, {"guide": guide, "observer": ctx.user, "exhibit": exhibit})
