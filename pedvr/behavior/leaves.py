"""Leaves: actions on body capabilities and steering, and conditions on the world (ADAPT §5.1, §6).

Actions act on an *agent* (a virtual pedestrian); conditions may read any
*actor*, the user included (the user is observed, never driven). Every
action ends what it started when it is stopped (``terminate(INVALID)``):
walking stops, a gaze or gesture stops, a reaching arm is released, a body
that was sitting down stands up. What an action leaves in place on purpose
after SUCCESS (a gaze on its target, a hand on its target, a seated body, a
speed change) is filed with the running tree and undone when the tree ends
(:mod:`pedvr.behavior.context`).

Actions:

=============  ==========================================================================
``GoTo``       walk to a target (body ``go_to``); SUCCESS within ``arrive`` m, FAILURE if
               unreachable, seated, or after ``max_time`` s. Walking stops when it ends.
``Follow``     keep ``distance`` m behind a moving actor; runs until stopped.
``Stop``       stop walking; SUCCESS at once.
``Face``       turn on the spot toward a target or a heading; SUCCESS within 10°
               (``hold``: keep turning toward it until stopped; re-aimed at 2 Hz once on it).
``GazeAt``     look at a target (body ``gaze_at``); SUCCESS once on target, the gaze kept
               until the tree ends; with ``seconds``: look that long, then stop.
``Gesture``    play a clip (one drawn from a list) for ``seconds``; SUCCESS when it ends.
``ReachFor``   put a hand on a target at ``height``; like ``GazeAt``.
``SitDown``    sit where the agent stands; SUCCESS when seated; stands up when the tree ends.
``StandUp``    SUCCESS when standing.
``SetSpeed``   scale the agent's preferred speed; restored when the tree ends.
``Wait``       (:mod:`pedvr.behavior.tree`) stand for ``seconds``.
``Use``        invoke a smart object's affordance (:mod:`pedvr.behavior.objects`).
=============  ==========================================================================

Conditions: ``Near``, ``Sees``, ``Facing``, ``Moving``, ``Idle``, ``After``, ``Before``.

Targets (:class:`Target`): an actor (followed as it moves), a fixed point, a
smart object's place, or a point drawn when the leaf starts (a random
walkable point in a box, or a weighted point of a goal set).
"""

from __future__ import annotations

import math
from collections.abc import Sequence as Seq

import numpy as np

from pedvr.behavior.context import Context
from pedvr.behavior.state import EYE_HEIGHT
from pedvr.behavior.tree import (
    FAILURE,
    INVALID,
    RUNNING,
    SUCCESS,
    Behaviour,
    Condition,
    Status,
    draw_seconds,
)
from pedvr.body.model import Handle
from pedvr.body.model import Status as BodyStatus
from pedvr.errors import NavigationError

B_RUNNING, B_SUCCESS = BodyStatus.RUNNING, BodyStatus.SUCCESS
FACE_TOLERANCE = math.radians(10.0)
FACE_HOLD_EVERY = 0.5  # s: a held facing that is on target looks again this often
REACH_SPEED_MARGIN = 1.25  # a walker can be pushed a little faster than its max speed
FOLLOW_REPLAN = 0.4  # m: a followed actor that moved this far gets a new goal
FOLLOW_EVERY = 0.3  # s between follow updates
GAZE_GIVE_UP = 3.0  # s: a gaze that never reaches its target fails


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


# -- targets ---------------------------------------------------------------------------------------


class Target:
    """Something a leaf goes to, looks at or faces. ``resolve`` runs when the leaf starts."""

    actor: int | None = None

    def resolve(self, ctx: Context) -> bool:
        """Fix what is drawn or chosen at the start; False if there is no such target now."""
        return True

    def point(self, ctx: Context) -> tuple[float, float] | None:
        """Where it is now (ground, m), None if it has gone."""
        raise NotImplementedError

    def gaze(self, ctx: Context) -> object:
        """What the body's ``gaze_at`` takes for it."""
        p = self.point(ctx)
        return None if p is None else (p[0], EYE_HEIGHT, p[1])


class ActorTarget(Target):
    def __init__(self, agent: int) -> None:
        self.actor = agent

    def point(self, ctx: Context) -> tuple[float, float] | None:
        assert self.actor is not None
        return ctx.pos(self.actor) if ctx.find(self.actor) is not None else None

    def gaze(self, ctx: Context) -> object:
        if self.actor == ctx.user:
            return "user"
        return ("agent", self.actor)


class PointTarget(Target):
    def __init__(self, p: tuple[float, float]) -> None:
        self.p = (float(p[0]), float(p[1]))

    def point(self, ctx: Context) -> tuple[float, float] | None:
        return self.p


class DrawnTarget(Target):
    """A point drawn at the leaf's start: uniform walkable in ``box``, or from goal set ``goal_set``."""

    def __init__(self, *, box: tuple[float, float, float, float] | None = None,
                 goal_set: str | None = None) -> None:
        self.box = box
        self.goal_set = goal_set
        self.p: tuple[float, float] | None = None

    def resolve(self, ctx: Context) -> bool:
        if self.box is not None:
            from shapely.geometry import box as shapely_box

            try:
                self.p = ctx.walkable.random_point(ctx.rng, shapely_box(*self.box))
            except NavigationError:  # no walkable area in the box: the leaf that drew it fails
                self.p = None
            return self.p is not None
        assert self.goal_set is not None
        gs = ctx.goal_sets[self.goal_set]
        w = np.asarray(gs.weights, np.float64)
        k = int(ctx.rng.choice(len(w), p=w / w.sum()))
        self.p = (float(gs.points[k][0]), float(gs.points[k][1]))
        return True

    def point(self, ctx: Context) -> tuple[float, float] | None:
        return self.p


# -- actions ---------------------------------------------------------------------------------------


class Action(Behaviour):
    """A leaf that drives ``agent``."""

    __slots__ = ("agent",)

    def __init__(self, agent: int, name: str = "") -> None:
        super().__init__(name)
        self.agent = agent


def _from_handle(h: Handle) -> Status:
    s = h.status
    return RUNNING if s is B_RUNNING else SUCCESS if s is B_SUCCESS else FAILURE


class GoTo(Action):
    """Walk to ``target`` along the navigation mesh (ADAPT's ``GoTo``; body ``go_to``).

    The target is fixed when the leaf starts (an actor's place then; use
    :class:`Follow` to track a mover). SUCCESS within ``arrive`` m; FAILURE
    when the navigation mesh cannot reach it, the agent is seated, or after
    ``max_time`` s. Walking stops when the leaf ends, however it ends, unless
    another node took the agent's walking over meanwhile. While walking the
    tree sleeps until the earliest moment the agent could have arrived.
    """

    __slots__ = ("target", "arrive", "max_time", "handle", "goal")

    def __init__(self, agent: int, target: Target, *, arrive: float = 0.3, max_time: float = 60.0,
                 name: str = "") -> None:
        super().__init__(agent, name)
        self.target = target
        self.arrive = arrive
        self.max_time = max_time
        self.handle: Handle | None = None
        self.goal = (0.0, 0.0)

    def initialise(self, ctx: Context) -> None:
        self.handle = None
        self.wake = 0.0
        if ctx.sitting(self.agent) or not self.target.resolve(ctx):
            return
        p = self.target.point(ctx)
        if p is None:
            return
        self.goal = p
        ctx.claim(self.agent, "walk", self)
        self.handle = ctx.body.go_to(self.agent, p, arrive_dist=self.arrive, timeout=self.max_time)

    def update(self, ctx: Context) -> Status:
        h = self.handle
        if h is None:
            return FAILURE
        s = _from_handle(h)
        if s is RUNNING:
            r = ctx.row(self.agent)
            p = ctx.crowd.pos[r]
            gap = math.hypot(self.goal[0] - float(p[0]), self.goal[1] - float(p[1])) - self.arrive
            vmax = REACH_SPEED_MARGIN * float(ctx.crowd.max_speed[r])
            self.wake = min(ctx.t + max(gap, 0.0) / vmax, h.started + self.max_time)
        return s

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if ctx.release(self.agent, "walk", self) and ctx.find(self.agent) is not None:
            ctx.body.go_to(self.agent, None)


class Follow(Action):
    """Keep about ``distance`` m from a moving actor, walking after it; runs until stopped.

    The goal is renewed every 0.3 s when the followed actor moved more than
    0.4 m; within ``distance`` the agent stops. FAILURE if the followed actor
    leaves the scene.
    """

    __slots__ = ("target", "distance", "last")

    def __init__(self, agent: int, target: Target, *, distance: float = 1.0, name: str = "") -> None:
        super().__init__(agent, name)
        self.target = target
        self.distance = distance
        self.last: tuple[float, float] | None = None

    def initialise(self, ctx: Context) -> None:
        self.last = None
        ctx.claim(self.agent, "walk", self)

    def update(self, ctx: Context) -> Status:
        tp = self.target.point(ctx)
        if tp is None or ctx.sitting(self.agent):
            return FAILURE
        if not ctx.owns(self.agent, "walk", self):
            ctx.claim(self.agent, "walk", self)
            self.last = None
        a = ctx.pos(self.agent)
        d = math.hypot(tp[0] - a[0], tp[1] - a[1])
        if d <= self.distance:
            if self.last is not None:
                ctx.body.go_to(self.agent, None)
                self.last = None
        elif self.last is None or math.hypot(tp[0] - self.last[0], tp[1] - self.last[1]) > FOLLOW_REPLAN:
            k = (d - self.distance) / d
            goal = (a[0] + (tp[0] - a[0]) * k, a[1] + (tp[1] - a[1]) * k)
            ctx.body.go_to(self.agent, goal, arrive_dist=0.2, timeout=math.inf)
            self.last = tp
        self.wake = ctx.t + FOLLOW_EVERY
        return RUNNING

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if ctx.release(self.agent, "walk", self) and ctx.find(self.agent) is not None:
            ctx.body.go_to(self.agent, None)


class Stop(Action):
    """Stop walking where the agent is; SUCCESS at once."""

    __slots__ = ()

    def update(self, ctx: Context) -> Status:
        ctx.claim(self.agent, "walk", self)
        ctx.body.go_to(self.agent, None)
        ctx.release(self.agent, "walk", self)
        return SUCCESS


class Face(Action):
    """Turn on the spot toward a target, or to a fixed ``heading`` (rad); a steering-level action.

    Sets the agent's preferred facing while it stands (``BehaviorState.face``,
    read by the plan phase); a walking agent faces its path until it stops.
    SUCCESS within 10°; with ``hold`` it keeps facing the (moving) target and
    never succeeds. The facing is released when the leaf ends.
    """

    __slots__ = ("target", "heading", "hold")

    def __init__(self, agent: int, target: Target | None = None, *, heading: float | None = None,
                 hold: bool = False, name: str = "") -> None:
        super().__init__(agent, name)
        if (target is None) == (heading is None):
            raise ValueError("Face takes a target or a heading")
        self.target = target
        self.heading = heading
        self.hold = hold

    def initialise(self, ctx: Context) -> None:
        ctx.claim(self.agent, "face", self)
        if self.target is not None:
            self.target.resolve(ctx)

    def update(self, ctx: Context) -> Status:
        r = ctx.row(self.agent)
        if self.heading is not None:
            want = self.heading
        else:
            assert self.target is not None
            tp = self.target.point(ctx)
            if tp is None:
                return FAILURE
            p = ctx.crowd.pos[r]
            dx, dy = tp[0] - float(p[0]), tp[1] - float(p[1])
            if dx * dx + dy * dy < 1e-12:
                return SUCCESS
            want = math.atan2(dy, dx)
        ctx.claim(self.agent, "face", self)
        ctx.behavior.face[r] = want
        on = abs(_wrap(float(ctx.crowd.heading[r]) - want)) < FACE_TOLERANCE
        if on and not self.hold:
            return SUCCESS
        self.wake = ctx.t + FACE_HOLD_EVERY if on else 0.0  # turning: every tick; holding: 2 Hz
        return RUNNING

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if ctx.release(self.agent, "face", self):
            r = ctx.find(self.agent)
            if r is not None:
                ctx.behavior.face[r] = np.nan


class GazeAt(Action):
    """Look at a target (ADAPT's ``GazeAt``; body ``gaze_at``).

    Without ``seconds``: SUCCESS once head and eyes are on the target (the
    body's handle), the gaze kept until the tree ends; FAILURE if that takes
    over 3 s. With ``seconds``: RUNNING for that long (drawn per run), then
    the gaze stops and the leaf succeeds. Stopped early, the gaze stops.
    """

    __slots__ = ("target", "seconds", "handle", "end")

    def __init__(self, agent: int, target: Target, *, seconds: tuple[float, float] | None = None,
                 name: str = "") -> None:
        super().__init__(agent, name)
        self.target = target
        self.seconds = seconds
        self.handle: Handle | None = None
        self.end = 0.0

    def initialise(self, ctx: Context) -> None:
        self.handle = None
        self.wake = 0.0
        if not self.target.resolve(ctx):
            return
        g = self.target.gaze(ctx)
        if g is None:
            return
        ctx.claim(self.agent, "gaze", self)
        self.handle = ctx.body.gaze_at(self.agent, g)
        if self.seconds is not None:
            self.end = ctx.t + draw_seconds(ctx.rng, self.seconds)
            self.wake = self.end
        else:
            self.end = ctx.t + GAZE_GIVE_UP

    def update(self, ctx: Context) -> Status:
        h = self.handle
        if h is None:
            return FAILURE
        if self.seconds is not None:
            return SUCCESS if ctx.t >= self.end - 1e-9 else RUNNING
        s = _from_handle(h)
        if s is RUNNING and ctx.t >= self.end:
            return FAILURE
        return s

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if new_status is SUCCESS and self.seconds is None:
            agent, node = self.agent, self

            def undo() -> None:
                if ctx.release(agent, "gaze", node) and ctx.find(agent) is not None:
                    ctx.body.gaze_at(agent, None)

            ctx.linger(self.agent, "gaze", undo)
        elif ctx.release(self.agent, "gaze", self) and ctx.find(self.agent) is not None:
            ctx.body.gaze_at(self.agent, None)


class Gesture(Action):
    """Play a gesture clip for ``seconds`` (drawn per run); one clip drawn from ``clips`` with the rng."""

    __slots__ = ("clips", "seconds", "handle")

    def __init__(self, agent: int, clips: Seq[str], *, seconds: tuple[float, float] = (2.5, 2.5),
                 name: str = "") -> None:
        super().__init__(agent, name)
        if not clips:
            raise ValueError("Gesture needs at least one clip")
        self.clips = tuple(clips)
        self.seconds = seconds
        self.handle: Handle | None = None

    def initialise(self, ctx: Context) -> None:
        clip = self.clips[0] if len(self.clips) == 1 else self.clips[int(ctx.rng.integers(len(self.clips)))]
        d = draw_seconds(ctx.rng, self.seconds)
        ctx.claim(self.agent, "gesture", self)
        self.handle = ctx.body.gesture(self.agent, clip, duration=d)
        self.wake = ctx.t + d

    def update(self, ctx: Context) -> Status:
        assert self.handle is not None
        return _from_handle(self.handle)

    def terminate(self, ctx: Context, new_status: Status) -> None:
        owner = ctx.release(self.agent, "gesture", self)
        if new_status is INVALID and owner and self.handle is not None and self.handle.running \
                and ctx.find(self.agent) is not None:
            ctx.body.gesture(self.agent, None)


class ReachFor(Action):
    """Put a hand (``side``) on a target at ``height`` m (ADAPT's ``ReachFor``).

    Without ``seconds``: SUCCESS when the hand is there (the body's handle:
    within 3 cm; FAILURE if out of reach for 2 s), kept there until the tree
    ends. With ``seconds``: hold that long after reaching, then release.
    """

    __slots__ = ("target", "height", "side", "seconds", "handle", "end")

    def __init__(self, agent: int, target: Target, *, height: float = 1.0, side: str = "right",
                 seconds: tuple[float, float] | None = None, name: str = "") -> None:
        super().__init__(agent, name)
        self.target = target
        self.height = height
        self.side = side
        self.seconds = seconds
        self.handle: Handle | None = None
        self.end = math.inf

    def initialise(self, ctx: Context) -> None:
        self.handle = None
        self.end = math.inf
        if not self.target.resolve(ctx):
            return
        p = self.target.point(ctx)
        if p is None:
            return
        ctx.claim(self.agent, f"reach_{self.side}", self)
        self.handle = ctx.body.reach_for(self.agent, (p[0], self.height, p[1]), side=self.side)

    def update(self, ctx: Context) -> Status:
        h = self.handle
        if h is None:
            return FAILURE
        if self.end < math.inf:
            if ctx.t >= self.end - 1e-9:
                return SUCCESS
            self.wake = self.end
            return RUNNING
        s = _from_handle(h)
        if s is SUCCESS and self.seconds is not None:
            self.end = ctx.t + draw_seconds(ctx.rng, self.seconds)
            self.wake = self.end
            return RUNNING
        self.wake = 0.0
        return s

    def terminate(self, ctx: Context, new_status: Status) -> None:
        ch = f"reach_{self.side}"
        if new_status is SUCCESS and self.seconds is None:
            agent, node, side = self.agent, self, self.side

            def undo() -> None:
                if ctx.release(agent, ch, node) and ctx.find(agent) is not None:
                    ctx.body.reach_for(agent, None, side=side)

            ctx.linger(self.agent, ch, undo)
        elif ctx.release(self.agent, ch, self) and ctx.find(self.agent) is not None:
            ctx.body.reach_for(self.agent, None, side=self.side)


def stand_up_undo(ctx: Context, agent: int, owner: object) -> None:
    """Stand ``agent`` up if ``owner`` still holds its posture (an undo for seated bodies)."""
    if ctx.release(agent, "posture", owner) and ctx.find(agent) is not None:
        ctx.body.stand_up(agent)


class SitDown(Action):
    """Sit where the agent stands (body ``sit_down``; no seat: see the chair smart object).

    FAILURE if the agent is walking. SUCCESS when fully seated; the agent
    stands up again when the tree ends, or at once if stopped on the way down.
    """

    __slots__ = ("handle",)

    def __init__(self, agent: int, name: str = "") -> None:
        super().__init__(agent, name)
        self.handle: Handle | None = None

    def initialise(self, ctx: Context) -> None:
        ctx.claim(self.agent, "walk", self)
        ctx.body.go_to(self.agent, None)
        ctx.release(self.agent, "walk", self)
        ctx.claim(self.agent, "posture", self)
        self.handle = ctx.body.sit_down(self.agent)

    def update(self, ctx: Context) -> Status:
        assert self.handle is not None
        return _from_handle(self.handle)

    def terminate(self, ctx: Context, new_status: Status) -> None:
        if new_status is SUCCESS:
            agent, node = self.agent, self
            ctx.linger(agent, "posture", lambda: stand_up_undo(ctx, agent, node))
        else:
            stand_up_undo(ctx, self.agent, self)


class StandUp(Action):
    """Stand up (body ``stand_up``); SUCCESS when standing."""

    __slots__ = ("handle",)

    def __init__(self, agent: int, name: str = "") -> None:
        super().__init__(agent, name)
        self.handle: Handle | None = None

    def initialise(self, ctx: Context) -> None:
        ctx.claim(self.agent, "posture", self)
        ctx.run.undo.pop((self.agent, "posture"), None)
        self.handle = ctx.body.stand_up(self.agent)

    def update(self, ctx: Context) -> Status:
        assert self.handle is not None
        return _from_handle(self.handle)

    def terminate(self, ctx: Context, new_status: Status) -> None:
        ctx.release(self.agent, "posture", self)


class SetSpeed(Action):
    """Scale the agent's preferred speed by ``scale``; SUCCESS at once, restored when the tree ends."""

    __slots__ = ("scale",)

    def __init__(self, agent: int, scale: float, name: str = "") -> None:
        super().__init__(agent, name)
        self.scale = scale

    def update(self, ctx: Context) -> Status:
        r = ctx.row(self.agent)
        key = (self.agent, "speed")
        if key not in ctx.run.undo:  # the first change in this tree remembers the value to restore
            before = float(ctx.behavior.speed_scale[r])
            agent = self.agent

            def undo() -> None:
                row = ctx.find(agent)
                if row is not None:
                    ctx.behavior.speed_scale[row] = before

            ctx.linger(self.agent, "speed", undo)
        ctx.behavior.speed_scale[r] = self.scale
        return SUCCESS


# -- conditions ------------------------------------------------------------------------------------


class _TargetCondition(Condition):
    """A condition on ``actor`` and a ``target`` (resolved when the condition starts)."""

    __slots__ = ("actor", "target", "within")

    def __init__(self, actor: int, target: Target, *, within: float = 0.0, name: str = "") -> None:
        super().__init__(name)
        self.actor = actor
        self.target = target
        self.within = within

    def initialise(self, ctx: Context) -> None:
        self.target.resolve(ctx)

    def _points(self, ctx: Context) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """The target's point and the actor's position, or None when either is gone."""
        tp = self.target.point(ctx)
        if tp is None or ctx.find(self.actor) is None:
            return None
        return tp, ctx.pos(self.actor)


class Near(_TargetCondition):
    """``actor`` within ``within`` m of ``target`` (centre to centre)."""

    __slots__ = ()

    def check(self, ctx: Context) -> bool:
        pts = self._points(ctx)
        if pts is None:
            return False
        tp, a = pts
        return math.hypot(tp[0] - a[0], tp[1] - a[1]) < self.within


class Sees(_TargetCondition):
    """``target`` is inside ``actor``'s field of view (±100°) and not occluded (2D)."""

    __slots__ = ()

    def check(self, ctx: Context) -> bool:
        pts = self._points(ctx)
        return pts is not None and ctx.in_view(self.actor, pts[0])


class Facing(_TargetCondition):
    """``actor``'s heading points at ``target`` within ``within`` rad (for the user: where the
    head points, the HMD's yaw, the only gaze pedvr knows of the user)."""

    __slots__ = ()

    def check(self, ctx: Context) -> bool:
        pts = self._points(ctx)
        if pts is None:
            return False
        tp, a = pts
        if math.hypot(tp[0] - a[0], tp[1] - a[1]) < 1e-9:
            return True
        want = math.atan2(tp[1] - a[1], tp[0] - a[0])
        return abs(_wrap(ctx.heading(self.actor) - want)) <= self.within


class Moving(Condition):
    """``actor``'s speed is above ``above`` (and below ``below``) m/s."""

    __slots__ = ("actor", "above", "below")

    def __init__(self, actor: int, *, above: float = 0.0, below: float = math.inf, name: str = "") -> None:
        super().__init__(name)
        self.actor = actor
        self.above = above
        self.below = below

    def check(self, ctx: Context) -> bool:
        if ctx.find(self.actor) is None:
            return False
        v = ctx.speed(self.actor)
        return self.above < v < self.below


class Idle(Condition):
    """``actor`` stands still (below 0.2 m/s) on its feet."""

    __slots__ = ("actor",)

    def __init__(self, actor: int, name: str = "") -> None:
        super().__init__(name)
        self.actor = actor

    def check(self, ctx: Context) -> bool:
        return ctx.find(self.actor) is not None and ctx.idle(self.actor)


class After(Condition):
    """Simulation time is at least ``t`` s."""

    __slots__ = ("at",)

    def __init__(self, at: float, name: str = "") -> None:
        super().__init__(name)
        self.at = at

    def check(self, ctx: Context) -> bool:
        return ctx.t >= self.at


class Before(Condition):
    """Simulation time is below ``t`` s."""

    __slots__ = ("at",)

    def __init__(self, at: float, name: str = "") -> None:
        super().__init__(name)
        self.at = at

    def check(self, ctx: Context) -> bool:
        return ctx.t < self.at
