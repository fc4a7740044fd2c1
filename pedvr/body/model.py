"""The full body layer: per-agent body state as arrays and the :class:`FullBody` model.

One :class:`FullBody` serves the whole crowd; its rows align with
:class:`~pedvr.crowd.state.CrowdState` rows (``append``/``keep`` follow the
crowd's). Each simulation step it is asked, in order:

1. ``fill_limits`` (avoid phase): what each body can do now (PedVR §4.1);
2. ``animate`` (animate phase): the root motion the body makes of the
   commanded velocity — the proposed root the contact pass then corrects;
3. ``compose`` (animate phase, after contacts): the footsteps (gait state
   commit), the choreographers, the coordinator's blend, the leg-IK node and
   forward kinematics; contact and step metrics.

See :mod:`pedvr.body` for the pose API the renderer reads.
"""

from __future__ import annotations

import bisect
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from enum import Enum
from typing import Any, cast

import numba
import numpy as np

from pedvr.body import actions as act
from pedvr.body import carry
from pedvr.body import pose as ps
from pedvr.body import skeleton as sk
from pedvr.body.coordinator import MESSAGES, Coordinator, default_choreographers, step_weights_kernel
from pedvr.body.directed import HandPaths, HeadCaps, HeldFacings
from pedvr.body.graph import (
    ARM_ACTIONS,
    ARM_GOALS,
    GAZE_AGENT,
    GAZE_NONE,
    GAZE_POINT,
    GAZE_USER,
    gaze_rule_kernel,
    gaze_targets_kernel,
    heads_kernel,
    pose_graph_kernel,
)
from pedvr.body.locomotion import T_INPLACE, V_WALK, cadence, gait_kernel, limits_kernel
from pedvr.body.metrics import SkateMeter
from pedvr.body.quat import matrices_kernel
from pedvr.body.simple import SimpleBody
from pedvr.body.style import N_EMOTIONS, PA, Pa, Pb, blend_style, draw_emotions, speed_factor
from pedvr.crowd.state import (
    LIMIT_TURN_STANDING,
    CrowdState,
)
from pedvr.errors import UsageError
from pedvr.kernels import Chooser

FOV_HALF = math.radians(100.0)  # half field of view for the gaze rule (human ≈ 200° horizontal)
STEP_EVENT_CAP = 4096
RUNNING_SPEED = 2.2  # m/s: above this the "running" message is posted
ACTION_TICK = 1.0 / 30.0  # s: the subconscious scheduler runs at the decision rate
# The pose graph runs serial, or over chunks of bodies in parallel once a serial call takes more
# than pedvr.kernels.SERIAL_BUDGET_S (from about 500 bodies on a 2-core VM: `pedvr bench sim`):
# bodies are independent, so the bytes are the same either way (tests/body/test_threads.py).
_POSE_CHOOSER = Chooser()
_IS_ARM_ACTION = np.zeros(ARM_GOALS.shape[0] + 1, np.bool_)  # by action kind: it takes an arm
_IS_ARM_ACTION[ARM_ACTIONS] = True
BODY_ORDER = ("locomotion", "sitting", "gesture", "idle", "gaze", "reach")


def _point3(target: object, *, what: str) -> np.ndarray:
    """A finite 3D point from a capability's target, or :class:`UsageError` naming it."""
    try:
        p = np.asarray(target, np.float64).reshape(3)
    except (TypeError, ValueError):
        raise UsageError(f"{what} {target!r}: expected a 3D point (x, y, z)") from None
    if not np.isfinite(p).all():
        raise UsageError(f"{what} {target!r}: expected a finite 3D point")
    return p


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (M,3)`` by unit quaternions ``q (M,4)`` (x, y, z, w)."""
    u, w = q[:, :3], q[:, 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


@dataclass
class BodyState:
    """Per-agent body arrays (row i = crowd row i). Units SI, angles radians.

    Shapes: N agents, J = 26 joints, K = 33 nodes (joints + end sites).
    ``local_q (N,J,4)`` and ``pelvis (N,3)`` are the final blended pose;
    ``world_pos (N,K,3)``/``world_q (N,K,4)`` its forward kinematics (3D, Y up).
    """

    dims: np.ndarray  # (N,4) height m, sex (0 m / 1 f), build [0,1], scale
    base_limits: np.ndarray  # (N,6) the profile's motion limits (crowd.state LIMIT_* columns)
    offsets: np.ndarray  # (N,K,3) rest offsets, m
    half_width: np.ndarray  # (N,) m, hip joint lateral offset
    pelvis_rest: np.ndarray  # (N,) m, standing pelvis height
    emotion: np.ndarray  # (N,6) weights over style.EMOTIONS
    style: np.ndarray  # (N,11,5) Ashida style table
    tiredness0: np.ndarray  # (N,) in [0,1] at t = 0
    fear: np.ndarray  # (N,)
    boredom: np.ndarray  # (N,)
    speaking: np.ndarray  # (N,) bool
    right_handed: np.ndarray  # (N,) bool
    noise_seed: np.ndarray  # (N,) Perlin offset
    root: np.ndarray  # (N,2) m, ground root (after contacts)
    root_prev: np.ndarray  # (N,2) m
    heading: np.ndarray  # (N,) rad, 2D facing
    vel_s: np.ndarray  # (N,2) smoothed root velocity the planner uses
    stepping: np.ndarray  # (N,) bool
    s: np.ndarray  # (N,) step progress [0,1)
    swing: np.ndarray  # (N,) int64: 0 left, 1 right
    foot_ref: np.ndarray  # (N,2,2) ground reference under each ankle
    foot_yaw: np.ndarray  # (N,2) 2D heading of each foot
    foot_pitch: np.ndarray  # (N,2) + heel up, - toes up
    foot_lift: np.ndarray  # (N,2) m
    since_land: np.ndarray  # (N,2) s
    lift_ref: np.ndarray  # (N,2)
    lift_yaw: np.ndarray  # (N,)
    lift_pitch: np.ndarray  # (N,)
    trail_pitch0: np.ndarray  # (N,)
    roll: np.ndarray  # (N,) heel-toe roll amount [0,1]
    phase: np.ndarray  # (N,) gait phase, 0 at left heel strike
    amp: np.ndarray  # (N,) gait amplitude (speed / 1.3, smoothed)
    planted: np.ndarray  # (N,2) int8
    h_prev: np.ndarray  # (N,) m, pelvis height last step
    ik_miss: np.ndarray  # (N,2) m, ankle left short of its target
    land: np.ndarray  # (N,3) the swing foot's committed landing: x, y m, yaw rad
    first: np.ndarray  # (N,) bool: the current step began from standing
    shoulder_turn: np.ndarray  # (N,) rad: upper-torso yaw relative to the pelvis, set by the simulation
    gaze_ang: np.ndarray  # (N,5,2) lumbar, thorax, neck, head, eyes × (yaw, pitch)
    gaze_kind: np.ndarray  # (N,) int64 GAZE_*
    gaze_point: np.ndarray  # (N,3) world target of GAZE_POINT
    gaze_agent: np.ndarray  # (N,) int64 agent id of GAZE_AGENT
    gaze_rule: np.ndarray  # (N,) bool: the PedVR rule holds now
    g_kind: np.ndarray  # (N,) int64 gesture clip
    g_start: np.ndarray  # (N,) s
    g_dur: np.ndarray  # (N,) s
    g_next: np.ndarray  # (N,) s: earliest time of the next BFSM-state gesture
    sitting: np.ndarray  # (N,) bool target posture
    reach_on: np.ndarray  # (N,2) bool per arm (capability)
    reach_pt: np.ndarray  # (N,2,3) world target
    carrying: np.ndarray  # (N,) int8 carry.NONE / BOX / PERAMBULATOR: both hands on it (pedvr.body.carry)
    carry_yaw: np.ndarray  # (N,) rad: the carried thing's 2D facing this step (carry.object_yaw)
    carry_frame: np.ndarray  # (N,5) where it is drawn: x, y (up), z world m, yaw, tilt (carry.object_frame)
    q_kind: np.ndarray  # (N,Q) int64
    q_prio: np.ndarray
    q_wait: np.ndarray
    q_planned: np.ndarray
    q_dur: np.ndarray
    run_kind: np.ndarray  # (N,4) int64
    run_end: np.ndarray  # (N,4)
    run_mask: np.ndarray  # (N,4) int64
    run_start: np.ndarray  # (N,4)
    itch: np.ndarray  # (N,A)
    local_q: np.ndarray  # (N,J,4)
    pelvis: np.ndarray  # (N,3)
    world_pos: np.ndarray  # (N,K,3)
    world_q: np.ndarray  # (N,K,4)

    @classmethod
    def rows(cls, n: int) -> BodyState:
        z = np.zeros
        ident = np.zeros((n, sk.J, 4))
        ident[..., 3] = 1.0
        wq = np.zeros((n, sk.K, 4))
        wq[..., 3] = 1.0
        return cls(
            dims=z((n, sk.N_DIMS)), base_limits=z((n, 6)), offsets=z((n, sk.K, 3)), half_width=z(n),
            pelvis_rest=z(n),
            emotion=z((n, N_EMOTIONS)), style=z((n, 11, 5)), tiredness0=z(n), fear=z(n), boredom=z(n),
            speaking=z(n, np.bool_), right_handed=np.ones(n, np.bool_), noise_seed=z(n),
            root=z((n, 2)), root_prev=z((n, 2)), heading=z(n), vel_s=z((n, 2)),
            stepping=z(n, np.bool_), s=z(n), swing=z(n, np.int64), foot_ref=z((n, 2, 2)),
            foot_yaw=z((n, 2)), foot_pitch=z((n, 2)), foot_lift=z((n, 2)), since_land=np.full((n, 2), 10.0),
            lift_ref=z((n, 2)), lift_yaw=z(n), lift_pitch=z(n), trail_pitch0=z(n), roll=z(n), phase=z(n),
            amp=z(n), planted=np.ones((n, 2), np.int8), h_prev=z(n), ik_miss=z((n, 2)), land=z((n, 3)),
            first=z(n, np.bool_), shoulder_turn=z(n),
            gaze_ang=z((n, 5, 2)), gaze_kind=z(n, np.int64), gaze_point=z((n, 3)),
            gaze_agent=np.full(n, -1, np.int64), gaze_rule=z(n, np.bool_),
            g_kind=z(n, np.int64), g_start=z(n), g_dur=z(n), g_next=z(n), sitting=z(n, np.bool_),
            reach_on=z((n, 2), np.bool_), reach_pt=z((n, 2, 3)), carrying=z(n, np.int8),
            carry_yaw=z(n), carry_frame=z((n, carry.FRAME_COLUMNS)),
            q_kind=np.full((n, act.QUEUE), act.EMPTY, np.int64), q_prio=z((n, act.QUEUE)),
            q_wait=z((n, act.QUEUE)), q_planned=z((n, act.QUEUE), np.bool_), q_dur=z((n, act.QUEUE)),
            run_kind=np.full((n, act.N_RES), -1, np.int64), run_end=z((n, act.N_RES)),
            run_mask=z((n, act.N_RES), np.int64), run_start=z((n, act.N_RES)),
            itch=z((n, act.N_ACTIONS)), local_q=ident, pelvis=z((n, 3)),
            world_pos=z((n, sk.K, 3)), world_q=wq,
        )

    def __len__(self) -> int:
        return int(self.dims.shape[0])

    def append(self, other: BodyState) -> None:
        for f in fields(self):
            setattr(self, f.name, np.concatenate([getattr(self, f.name), getattr(other, f.name)]))

    def keep(self, mask: np.ndarray) -> None:
        for f in fields(self):
            setattr(self, f.name, np.ascontiguousarray(getattr(self, f.name)[mask]))


class Status(Enum):
    RUNNING = "running"
    SUCCESS = "success"
    FAILURE = "failure"


@dataclass
class Handle:
    """What a body capability returns (ADAPT's Body layer): poll :attr:`status`.

    A handle is updated by the body at each ``compose``; a handle whose
    agent has been removed reports FAILURE. Starting the same capability
    again on the agent (or calling it with target ``None``) ends the old
    handle with SUCCESS (stopped) unless it had already finished.
    """

    capability: str
    agent: int
    target: object
    started: float
    status: Status = Status.RUNNING
    detail: str = ""

    @property
    def running(self) -> bool:
        return self.status is Status.RUNNING


@dataclass
class GestureSets:
    """PedVR §4.3: a set of gestures per BFSM state and a selection policy.

    ``by_state`` maps a BFSM state name to ``(gesture names, weights)``;
    ``standing`` is used for states without an entry while the agent stands,
    ``walking`` while it walks. ``rate`` is gestures per second per agent
    (Poisson); the clip is drawn by weight (the policy).
    """

    by_state: dict[str, tuple[tuple[str, ...], tuple[float, ...]]] = field(default_factory=dict)
    standing: tuple[tuple[str, ...], tuple[float, ...]] = (("check_phone", "hands_in_pockets", "shrug"),
                                                          (0.4, 0.4, 0.2))
    walking: tuple[tuple[str, ...], tuple[float, ...]] = (("hands_in_pockets", "wave"), (0.8, 0.2))
    rate: float = 1.0 / 20.0
    duration: tuple[float, float] = (2.0, 4.0)


class FullBody:
    """Full-body motion synthesis for the whole crowd (issue 3).

    Keyword-only: ``rng`` — the simulation's generator; the body draws from
    a child stream spawned from it (``rng.spawn(1)``), so its draws do not
    shift the behavior layer's. ``gestures`` — the per-state gesture sets.
    """

    def __init__(self, *, rng: np.random.Generator, gestures: GestureSets | None = None,
                 navigate: Callable[[int, tuple[float, float] | None], None] | None = None) -> None:
        self.rng = rng.spawn(1)[0]
        self.state = BodyState.rows(0)
        # ADAPT §4.5's heuristic ranks our two-arm reach (S = 8/10) before gaze (S = 6/7); ADAPT's own
        # graph (Fig. 3) has gaze first, and the reach must see the thorax the gaze turned: override.
        self.coordinator = Coordinator(default_choreographers(), order=list(BODY_ORDER))
        ci = self.coordinator.index
        self._weight_cols = np.array([ci["sitting"], ci["gesture"], ci["reach"]], np.int64)
        self._message_cols = np.array([MESSAGES.index(m) for m in ("running", "walking", "sitting")],
                                      np.int64)
        self.gestures = gestures or GestureSets()
        self.navigate = navigate
        self._simple = SimpleBody()
        self._steps = np.zeros((STEP_EVENT_CAP, 4))
        self.step_log: list[np.ndarray] = []  # completed steps: (row id, duration, distance, speed)
        self.skate = SkateMeter()
        self.handles: list[Handle] = []
        self.ids = np.zeros(0, np.int64)
        self._action_clock = 0.0
        self._t = 0.0
        self.hmd_position: np.ndarray | None = None
        self.state_names: tuple[str, ...] = ()
        self.hand_paths = HandPaths()  # reach_along: timed hand paths (pedvr.body.directed)
        self.head_caps = HeadCaps()  # gaze_limit: per-agent caps on the gaze chain's yaw
        self.held_facings = HeldFacings()  # hold_facing: a facing kept while moving

    # -- rows ------------------------------------------------------------------------------

    def append(self, n: int, *, ids: np.ndarray, pos: np.ndarray, heading: np.ndarray, is_user: bool,
               limits: np.ndarray | None = None, emotion: np.ndarray | None = None,
               dims: np.ndarray | None = None, carrying: str = "none") -> np.ndarray:
        """Add ``n`` bodies; returns their preferred-speed factors ``(n,)`` (emotion).

        ``carrying`` (a profile's ``"none"``, ``"box"`` or ``"perambulator"``) puts both hands
        on a box or a pram's handle (:mod:`pedvr.body.carry`); it draws nothing.

        Draws (documented order, from the body's stream): dims
        (:func:`skeleton.draw_dims`), emotions (:func:`style.draw_emotions`),
        then agent model: tiredness0 U(0, 0.6), fear (0 w.p. 0.8 else U(0, 1)),
        boredom U(0, 0.3), speaking (p 0.1), right-handed (p 0.9), noise seed
        U(0, 1000). The user's body is the reference adult, neutral.
        """
        rows = BodyState.rows(n)
        g = self.rng
        if is_user:
            rows.dims[:] = sk.user_dims(n) if dims is None else dims
            rows.emotion[:, 0] = 1.0
        else:
            rows.dims[:] = sk.draw_dims(g, n) if dims is None else dims
            rows.emotion[:] = draw_emotions(g, n) if emotion is None else emotion
            rows.tiredness0[:] = g.uniform(0.0, 0.6, n)
            rows.fear[:] = np.where(g.random(n) < 0.8, 0.0, g.random(n))
            rows.boredom[:] = g.uniform(0.0, 0.3, n)
            rows.speaking[:] = g.random(n) < 0.1
            rows.right_handed[:] = g.random(n) < 0.9
            rows.noise_seed[:] = g.uniform(0.0, 1000.0, n)
        if emotion is not None and is_user:
            rows.emotion[:] = emotion
        rows.carrying[:] = carry.KINDS[carrying]
        rows.offsets[:] = sk.dims_offsets(rows.dims)
        rows.half_width[:] = rows.offsets[:, sk.L_HIP, 0]
        rows.pelvis_rest[:] = rows.offsets[:, sk.PELVIS, 1]
        rows.h_prev[:] = rows.pelvis_rest
        rows.style[:] = blend_style(rows.emotion)
        p = np.asarray(pos, np.float64).reshape(n, 2)
        h = np.asarray(heading, np.float64).reshape(n)
        h = np.where(np.isnan(h), 0.0, h)
        rows.root[:] = p
        rows.root_prev[:] = p
        rows.heading[:] = h
        for f in range(2):
            left = np.stack([np.sin(h), -np.cos(h)], 1) * (1.0 if f == 0 else -1.0)
            rows.foot_ref[:, f] = p + left * rows.half_width[:, None]
            rows.foot_yaw[:, f] = h - 0.09 if f == 0 else h + 0.09
        if limits is not None:
            rows.base_limits[:] = np.asarray(limits, np.float64).reshape(n, -1)
        self.state.append(rows)
        self.ids = np.concatenate([self.ids, np.asarray(ids, np.int64).reshape(n)])
        self.coordinator.append(n)
        if carrying != "none" and "reach" in self.coordinator.index:  # they arrive holding it
            k = self.coordinator.index["reach"]
            self.coordinator.weights[-n:, k] = self.coordinator.targets[-n:, k] = 1.0
        self.skate.append(n)
        return speed_factor(rows.emotion)

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the rows where ``mask`` is true (follows ``CrowdState.keep``)."""
        gone = set(int(i) for i in self.ids[~mask])
        for hd in self.handles:
            if hd.running and hd.agent in gone:
                hd.status, hd.detail = Status.FAILURE, "agent removed"
        self.handles = [hd for hd in self.handles if hd.running]
        self.state.keep(mask)
        self.ids = self.ids[mask]
        self.coordinator.keep(mask)
        self.skate.keep(mask)

    def set_emotion(self, agent_id: int, emotion: np.ndarray) -> None:
        """Set an agent's emotion weights ``(6,)`` (style follows; speed is the caller's)."""
        r = self._row(agent_id)
        self.state.emotion[r] = emotion
        self.state.style[r] = blend_style(self.state.emotion[r:r + 1])[0]

    def _row(self, agent_id: int) -> int:
        hit = np.flatnonzero(self.ids == agent_id)
        if hit.size == 0:
            raise UsageError(f"agent {agent_id}: no such body; known ids: {self.ids.tolist()[:20]}")
        return int(hit[0])

    # -- avoid: limits ------------------------------------------------------------------------

    def fill_limits(self, crowd: CrowdState, out: np.ndarray) -> None:
        """Motion limits per agent for this step (never above the profile's).

        Acceleration and deceleration are the profile's (avoidance relies on
        braking; modulating acceleration by phase changed contact outcomes
        at the micrometre level without visible benefit); the walking
        turn rate is full at foot contact, 80 % mid-swing; stepping back is
        allowed fully when slow, less the faster the body walks forward
        (down to 40 %). User rows are left as they are.
        """
        b = self.state
        if len(b) != len(crowd):
            return
        limits_kernel(b.base_limits, b.stepping, b.s, crowd.vel, crowd.heading, crowd.pref_speed,
                      crowd.is_user, out)

    # -- animate --------------------------------------------------------------------------------

    def animate(self, crowd: CrowdState, new_vel: np.ndarray, dt: float, *,
                coupled: bool) -> tuple[np.ndarray, np.ndarray]:
        """Proposed root ``(N,2)`` and heading ``(N,)`` for the commanded velocities.

        Coupled: the root moves with the commanded velocity (already inside
        this body's limits) and turns no faster than the turn rate allows;
        decoupled: the root is the disc and faces its velocity. The user's
        root is its input pose.
        """
        saved = crowd.limits
        if len(self.state) == len(crowd):
            crowd.limits = self.state.base_limits  # turn rates: the profile's, as the heading rule expects
        try:
            root, heading = self._simple.animate(crowd, new_vel, dt, coupled=coupled)
        finally:
            crowd.limits = saved
        if coupled and self.held_facings.held and len(self.state) == len(crowd):
            self.held_facings.apply(self.ids, crowd.heading, heading,
                                    self.state.base_limits[:, LIMIT_TURN_STANDING], dt)
        return root, heading

    def compose(self, crowd: CrowdState, root: np.ndarray, heading: np.ndarray, *, dt: float, t: float,
                coupled: bool, state_names: np.ndarray | None = None) -> None:
        """Commit the gait for the final roots and pose every body (after the contact pass)."""
        b = self.state
        n = len(b)
        if n == 0:
            return
        b.root_prev[:] = b.root
        b.root[:] = root
        b.heading[:] = heading
        ne = gait_kernel(coupled, dt, t, b.root, b.root_prev, b.heading, crowd.is_user,
                         b.dims[:, sk.DIM_SCALE].copy(), b.half_width, b.vel_s, b.stepping, b.s, b.swing,
                         b.foot_ref, b.foot_yaw, b.foot_pitch, b.foot_lift, b.since_land, b.lift_ref,
                         b.lift_yaw, b.lift_pitch, b.trail_pitch0, b.roll, b.phase, b.amp, b.planted,
                         b.land, b.first, self._steps, 0)
        if ne:
            ev = self._steps[:ne].copy()
            ev[:, 0] = self.ids[ev[:, 0].astype(np.int64)]
            self.step_log.append(ev)
        self._behaviour_tick(crowd, dt=dt, t=t, state_names=state_names)
        self._pose(crowd, dt=dt, t=t)
        if (b.carrying != carry.NONE).any():
            b.carry_frame[:] = carry.object_frame(b.carrying, b.root, b.carry_yaw, b.dims[:, sk.DIM_SCALE],
                                                  b.world_pos[:, [sk.L_HAND, sk.R_HAND]], b.reach_on)
        self.skate.observe(b.world_pos, b.planted, b.foot_pitch, b.foot_lift, ~crowd.is_user)
        self._update_handles(t)

    def pose_at_rest(self, crowd: CrowdState, heading: np.ndarray) -> None:
        """Pose every body where it stands, facing ``heading``, before the first step: a frame
        drawn at t = 0 (a headless video's first frame, a recording's first pose) shows people
        standing, not every joint at the origin. Time does not pass (dt = 0): no step is taken
        and no gait advances."""
        b = self.state
        if len(b) == 0:
            return
        b.heading[:] = np.where(np.isnan(heading), b.heading, heading)
        self._pose(crowd, dt=0.0, t=0.0)
        if (b.carrying != carry.NONE).any():
            b.carry_frame[:] = carry.object_frame(b.carrying, b.root, b.carry_yaw, b.dims[:, sk.DIM_SCALE],
                                                  b.world_pos[:, [sk.L_HAND, sk.R_HAND]], b.reach_on)

    # -- choreographers + coordinator -----------------------------------------------------------

    def _pose(self, crowd: CrowdState, *, dt: float, t: float) -> None:
        """Weights and messages for this step, then the whole graph, leg IK and FK in one kernel."""
        b = self.state
        co = self.coordinator
        n = len(b)
        # Messages, targets and smoothed weights in one pass (coordinator.step_weights_kernel): a
        # carrier's arms stay on what it carries (no swing, no gesture); a clip plays on while its
        # weight fades out, so it ends where it was going.
        running = np.empty(n, np.bool_)
        kind = np.empty(n, np.int64)
        idle_w = np.empty(n)
        step_weights_kernel(t, dt, co.smoothing, b.vel_s, b.sitting, b.carrying, b.g_kind, b.g_start, b.g_dur,
                            b.run_kind, _IS_ARM_ACTION, b.reach_on, RUNNING_SPEED, V_WALK, self._weight_cols,
                            self._message_cols, co.weights, co.targets, co.messages, running, kind, idle_w)
        order, masks, moves_pelvis = co.graph()
        self.hand_paths.apply(self.ids, b.reach_on, b.reach_pt, t)  # reach_along's paths, at t
        reach_on, reach_pt = self._carry_reach()
        heads, fresh = self._heads()
        has_user, user_head = self._user_head(crowd, heads)
        par = _POSE_CHOOSER.choose(len(b))
        t0 = time.perf_counter()
        pose_graph_kernel(
            dt, t, order, co.weights, masks, moves_pelvis, ps.GESTURE_MASKS,
            b.phase, b.amp, b.style, b.dims[:, sk.DIM_SCALE].copy(), b.pelvis_rest, b.dims,
            kind, b.g_start, b.g_dur, b.noise_seed, idle_w, ps.PERM,
            b.gaze_kind, b.gaze_point, self._gaze_rows(), b.gaze_rule, user_head, has_user,
            running, b.heading, b.gaze_ang,
            ps.GAZE_SHARE, self.head_caps.table(self.ids, ps.GAZE_YAW_LIMIT), ps.GAZE_PITCH_LIMIT,
            ps.GAZE_SPEED, ps.GAZE_TAU,
            b.run_kind, b.run_mask, b.run_start, reach_on, reach_pt, ARM_GOALS,
            b.root, b.foot_ref, b.foot_yaw, b.foot_pitch, b.foot_lift, b.planted, b.stepping, b.s, b.swing,
            b.h_prev, b.ik_miss, heads, fresh, b.shoulder_turn, sk.PARENTS, b.local_q, b.pelvis, b.world_pos,
            b.world_q, 4 * numba.get_num_threads() if par else 0)
        _POSE_CHOOSER.record(par, len(b), time.perf_counter() - t0)

    def _carry_reach(self) -> tuple[np.ndarray, np.ndarray]:
        """The arms' reach this step: the behaviour's ``reach_on``/``reach_pt``, and where an arm
        is not taken by it, a carrier's hand on its box or pram handle (:mod:`pedvr.body.carry`),
        following the root, heading and shoulder turn just committed. Returns new arrays; the capability's own
        state (what ``reach_for`` handles are judged by) is unchanged."""
        b = self.state
        carrying = b.carrying != carry.NONE
        if not carrying.any():
            return b.reach_on, b.reach_pt
        held = carrying[:, None] & ~b.reach_on
        b.carry_yaw[:] = carry.object_yaw(b.carrying, b.heading, b.shoulder_turn)
        # Targets in the untwisted frame: the pose graph turns the shoulders after the reach
        # (graph.turn_shoulders), which takes the arms, and so the box, round with the chest.
        pts = carry.hand_targets(b.carrying, b.root, b.heading, b.dims[:, sk.DIM_SCALE])
        return (np.ascontiguousarray(b.reach_on | held),
                np.ascontiguousarray(np.where(held[:, :, None], pts, b.reach_pt)))

    def _heads(self) -> tuple[np.ndarray, np.ndarray]:
        """Head positions after the last frame ``(N, 3)`` (a copy) and where no FK has run yet."""
        b = self.state
        hp = np.empty((len(b), 3))
        fresh = np.empty(len(b), np.bool_)
        heads_kernel(b.world_pos, b.root, b.offsets, b.dims, hp, fresh)  # before the first FK: standing
        return hp, fresh

    def _gaze_rows(self) -> np.ndarray:
        """The row of each ``gaze_at(("agent", id))`` target, -1 where none (or gone)."""
        b = self.state
        rows = np.full(len(b), -1, np.int64)
        ag = np.flatnonzero(b.gaze_kind == GAZE_AGENT)
        if ag.size:
            # ids are appended in increasing order and rows removed in place: they stay sorted
            r = np.minimum(np.searchsorted(self.ids, b.gaze_agent[ag]), len(b) - 1)
            rows[ag] = np.where(self.ids[r] == b.gaze_agent[ag], r, -1)
        return rows

    def _user_head(self, crowd: CrowdState, heads: np.ndarray) -> tuple[bool, np.ndarray]:
        if not crowd.is_user.any():
            return False, np.zeros(3)
        if self.hmd_position is not None:
            return True, np.asarray(self.hmd_position, np.float64).reshape(3)
        return True, heads[int(np.flatnonzero(crowd.is_user)[0])]

    def gaze_targets(self, crowd: CrowdState) -> np.ndarray:
        """``(N, 3)`` world points each agent attends to (``gaze_at`` or the PedVR gaze rule); NaN where none.

        Subconscious look-arounds are left out: this is what the overhead view's
        gaze lines show (PedVR Fig. 4).
        """
        b = self.state
        n = len(b)
        heads, _ = self._heads()
        has_user, user_head = self._user_head(crowd, heads)
        out = np.empty((n, 3))
        deliberate = np.zeros(n, np.bool_)
        gaze_targets_kernel(self._t, b.gaze_kind, b.gaze_point, self._gaze_rows(), b.gaze_rule, user_head,
                            has_user, heads, b.run_kind, b.run_start, b.heading, b.root, out, deliberate)
        return np.where(deliberate[:, None], out, np.nan)

    def user_head(self, crowd: CrowdState) -> np.ndarray:
        """The user's head (HMD) position, 3D.

        ``hmd_position`` (3,) if the backend set it, else the user body's head.
        """
        return self._user_head(crowd, self._heads()[0])[1]

    # -- behaviour: gestures and subconscious actions ---------------------------------------------

    def _behaviour_tick(self, crowd: CrowdState, *, dt: float, t: float,
                        state_names: np.ndarray | None) -> None:
        self._t = t
        b = self.state
        n = len(b)
        self._action_clock += dt
        if self._action_clock + 1e-12 < ACTION_TICK:
            return
        tick = self._action_clock
        self._action_clock = 0.0
        g = self.rng
        virt = ~crowd.is_user
        speed = np.sqrt(b.vel_s[:, 0] ** 2 + b.vel_s[:, 1] ** 2)
        standing = speed < V_WALK
        # draws, in this order: arrivals u (N, A); durations of the arrivals, row-major; then the
        # gesture sets' fire (N), pick (N) and duration (N)
        u = g.random((n, act.N_ACTIONS))
        arrive = np.empty((n, act.N_ACTIONS), np.bool_)
        act.agent_model_kernel(t, tick, b.tiredness0, b.boredom, b.fear, b.speaking, b.emotion, standing,
                               virt, u, arrive)
        dur = np.zeros((n, act.N_ACTIONS))
        k = int(np.count_nonzero(arrive))
        if k:
            dur[arrive] = g.gamma(4.0, act.MEAN_DURATION / 4.0, k)
        # a planned gesture holds the arms, torso and head while it plays; the gaze rule, the head
        g_active = (b.g_kind > 0) & (t < b.g_start + b.g_dur)
        blocked = (np.where(b.gaze_rule | (b.gaze_kind != GAZE_NONE), act.HEAD, 0)
                   | np.where(g_active, act.LEFT_ARM | act.RIGHT_ARM | act.UPPER_TORSO, 0)
                   | np.where(b.reach_on[:, 0], act.LEFT_ARM, 0)
                   | np.where(b.reach_on[:, 1], act.RIGHT_ARM, 0)).astype(np.int64)
        started = np.empty((n, act.N_RES), np.bool_)
        act.schedule_kernel(t, tick, arrive, dur, b.right_handed, blocked, b.q_kind, b.q_prio, b.q_wait,
                            b.q_planned, b.q_dur, b.run_kind, b.run_end, b.run_mask, act.ALTERNATIVES, b.itch,
                            started)
        b.run_start[started] = t
        # subconscious gestures play through the gesture choreographer
        some = np.flatnonzero(started.any(axis=1) & ~g_active)  # rows that started an action now
        for a, clip in ((act.A_TALK, ps.G_TALK), (act.A_SHRUG, ps.G_SHRUG)) if some.size else ():
            this = b.run_kind[some] == a
            rows = some[(this & started[some]).any(axis=1)]
            b.g_kind[rows] = clip
            b.g_start[rows] = t
            b.g_dur[rows] = ((b.run_end[rows] - t) * (b.run_kind[rows] == a)).max(axis=1)
        # PedVR §4.3: gestures from the BFSM state's set, Poisson with the set's rate
        gs = self.gestures
        p = 1.0 - math.exp(-gs.rate * tick)
        fire = virt & ~g_active & (g.random(n) < p) & (t >= b.g_next) & ~b.sitting
        pick = g.random(n)
        durs = g.uniform(*gs.duration, n)
        for row in np.flatnonzero(fire):  # only the few agents starting a gesture at this tick
            name = None if state_names is None else str(state_names[row])
            names, weights = gs.by_state.get(name or "", gs.standing if standing[row] else gs.walking)
            cw = np.cumsum(weights) / np.sum(weights)
            chosen = names[min(bisect.bisect_right(cw.tolist(), float(pick[row])), len(names) - 1)]
            b.g_kind[row] = ps.GESTURES.index(chosen)
            b.g_start[row] = t
            b.g_dur[row] = durs[row]
            b.g_next[row] = t + durs[row] + 5.0

    # -- the PedVR gaze rule -------------------------------------------------------------------

    def gaze_rule(self, crowd: CrowdState, *, t: float, visibility: object, d1: float, d2: float,
                  enabled: bool) -> list[dict[str, object]]:
        """PedVR §4.2 eqs. 1–3 with DESIGN.md's closing speed; returns start/end events.

        Agent i gazes at the user u when ``|p_u − p_i| < D1``, ``0 < w < D2``
        with ``w = (v_i − v_u)·(p_u − p_i)/|p_u − p_i|``, the user is inside
        i's field of view (±``FOV_HALF`` about its heading) and the segment
        i–u is clear of walls (2D visibility). Off (and every ongoing gaze
        ended) when ``enabled`` is False.
        """
        b = self.state
        n = len(crowd)
        g = np.zeros(n, np.bool_)
        user = np.flatnonzero(crowd.is_user)
        if enabled and user.size and n > 1:
            u = int(user[0])
            cand = np.empty(n, np.bool_)
            gaze_rule_kernel(crowd.pos, crowd.vel, crowd.heading, crowd.is_user, u, d1, d2,
                             math.cos(FOV_HALF), cand)
            idx = np.flatnonzero(cand)
            if idx.size:
                vis = visibility.visible(crowd.pos[idx], np.repeat(crowd.pos[u:u + 1], idx.size, 0))  # type: ignore[attr-defined]
                g[idx] = vis
        events: list[dict[str, object]] = []
        for row in np.flatnonzero(g != b.gaze_rule):
            events.append({"agent": int(self.ids[row]), "t": round(float(t), 6),
                           "event": "start" if g[row] else "end", "target": "user"})
        b.gaze_rule[:] = g
        return events

    # -- capabilities (ADAPT's Body layer) -------------------------------------------------------

    def _start(self, capability: str, agent_id: int, target: object) -> Handle:
        for hd in self.handles:
            if hd.running and hd.agent == agent_id and hd.capability == capability:
                hd.status, hd.detail = Status.SUCCESS, "stopped"
        hd = Handle(capability, agent_id, target, self._t)
        self.handles.append(hd)
        return hd

    def go_to(self, agent_id: int, target: tuple[float, float] | None, *, arrive_dist: float = 0.3,
              timeout: float = 60.0) -> Handle:
        """Walk to ``target`` (2D) through the simulation's navigation (``navigate``); None stops."""
        row = self._row(agent_id)
        hd = self._start("go_to", agent_id, target)
        if self.navigate is None:
            hd.status, hd.detail = Status.FAILURE, "no navigator"
            return hd
        try:
            self.navigate(row, target)
        except Exception as exc:  # the navigator's error is the handle's failure, reported
            hd.status, hd.detail = Status.FAILURE, f"{type(exc).__name__}: {exc}"
            return hd
        if target is None:
            hd.status, hd.detail = Status.SUCCESS, "stopped"
        hd.target = (target, arrive_dist, timeout)
        return hd

    def gaze_at(self, agent_id: int, target: object) -> Handle:
        """Gaze at a 3D point ``(x, y, z)``, ``("agent", id)`` or ``"user"``; None stops.

        Succeeds when head and eyes are within 5° of the target; keeps gazing
        until stopped. A target that is none of these raises :class:`UsageError`
        and changes nothing.
        """
        row = self._row(agent_id)
        b = self.state
        point = None
        is_user = isinstance(target, str) and target == "user"
        is_agent = isinstance(target, tuple) and len(target) == 2 and target[0] == "agent"
        if not (target is None or is_user or is_agent):
            point = _point3(target, what="gaze_at target")
        hd = self._start("gaze_at", agent_id, target)
        if target is None:
            b.gaze_kind[row] = GAZE_NONE
            hd.status, hd.detail = Status.SUCCESS, "stopped"
        elif point is not None:
            b.gaze_kind[row] = GAZE_POINT
            b.gaze_point[row] = point
        elif is_user:
            b.gaze_kind[row] = GAZE_USER
        else:
            b.gaze_kind[row] = GAZE_AGENT
            b.gaze_agent[row] = int(cast(tuple[str, int], target)[1])
        return hd

    def reach_for(self, agent_id: int, target: tuple[float, float, float] | None, *,
                  side: str = "right") -> Handle:
        """Put the hand on a 3D world point; fails if it stays out of reach for 2 s. None releases.

        A bad ``side`` or target raises :class:`UsageError` and changes nothing.
        """
        row = self._row(agent_id)
        if side not in ("left", "right"):
            raise UsageError(f"reach_for side {side!r}: expected 'left' or 'right'")
        s = 1 if side == "right" else 0
        point = None if target is None else _point3(target, what="reach_for target")
        hd = self._start("reach_for", agent_id, (target, s))
        if point is None:
            self.state.reach_on[row, s] = False
            hd.status, hd.detail = Status.SUCCESS, "released"
        else:
            self.state.reach_on[row, s] = True
            self.state.reach_pt[row, s] = point
        return hd

    def reach_along(self, agent_id: int, points: np.ndarray, times: np.ndarray, *,
                    side: str = "right") -> Handle:
        """Move the hand along a timed path: ``points (M, 3)`` world, ``times (M,)`` s (simulation
        time, not decreasing). The reach target follows the path, interpolated at every step; before
        the first time it is the first point, after the last the last point, held until released
        with ``reach_for(agent, None)``. The handle is ``reach_for``'s for the last point (success
        when the hand is there, failure if it is not 2 s after the path's end)."""
        pts = np.asarray(points, np.float64).reshape(-1, 3)
        ts = np.asarray(times, np.float64).reshape(-1)
        hd = self.reach_for(agent_id, (float(pts[-1, 0]), float(pts[-1, 1]), float(pts[-1, 2])), side=side)
        s = 1 if side == "right" else 0
        self.hand_paths.set(agent_id, s, ts, pts)
        self.state.reach_pt[self._row(agent_id), s] = pts[0]
        hd.started = max(hd.started, float(ts[-1]))
        return hd

    def gaze_limit(self, agent_id: int, yaw: float | None) -> None:
        """Cap the yaw (rad) the gaze chain's body joints (lumbar, thorax, neck, head) may turn toward
        a gaze target, the eyes doing the rest within their own limit; None lifts the cap."""
        self._row(agent_id)
        self.head_caps.set(agent_id, yaw)

    def hold_facing(self, agent_id: int, heading: float | None) -> None:
        """Keep facing ``heading`` (rad) while moving, turning toward it at the standing turn rate,
        instead of turning to face the motion (coupled bodies): a short side or back step. None
        lets the facing follow the motion again."""
        self._row(agent_id)
        self.held_facings.set(agent_id, heading)

    def arm_swing(self, agent_id: int, side: str = "right") -> tuple[float, float]:
        """``(psi, rate)``: the walk's swing of one arm now. The locomotion's shoulder flexion of
        that arm goes as ``sin(psi)`` (forward positive), ``psi`` advancing at ``rate`` rad/s at
        the current step's pace (0 when the feet are still): the arm swings forward while ``cos(psi) > 0``."""
        r = self._row(agent_id)
        b = self.state
        st = b.style[r, 1]  # the shoulder flexion DOF of the Ashida style table (pose.loco_shadow_kernel)
        ts = b.phase[r] + (math.pi if side == "right" else 0.0)
        psi = st[Pa] * ts + st[Pb] + (math.pi if st[PA] < 0.0 else 0.0)
        speed = float(np.hypot(*b.vel_s[r]))
        if not b.stepping[r]:
            return float(psi), 0.0
        step = 1.0 / cadence(speed, b.dims[r, sk.DIM_SCALE]) if speed > V_WALK else T_INPLACE
        return float(psi), float(st[Pa] * math.pi / step)

    def gesture(self, agent_id: int, name: str | None, *, duration: float = 2.5) -> Handle:
        """Play a gesture clip (``pose.GESTURES``) for ``duration`` s; None stops the current one.

        An unknown name or a duration that is not a positive finite number
        raises :class:`UsageError` *before* anything changes: the running
        clip plays on and its handle stays RUNNING (a bad call is the
        caller's mistake, reported at once, not a FAILURE handle that a
        behavior tree might silently poll past).
        """
        row = self._row(agent_id)
        b = self.state
        if name is not None:
            if name not in ps.GESTURES[1:]:
                raise UsageError(f"gesture {name!r}: unknown; known: {', '.join(ps.GESTURES[1:])}")
            if not (math.isfinite(duration) and duration > 0.0):
                raise UsageError(f"gesture {name!r}: duration = {duration}: "
                                 "must be a positive number of seconds")
        hd = self._start("gesture", agent_id, name)
        if name is None:
            b.g_dur[row] = max(0.0, self._t - b.g_start[row])
            hd.status, hd.detail = Status.SUCCESS, "stopped"
            return hd
        b.g_kind[row] = ps.GESTURES.index(name)
        b.g_start[row] = self._t
        b.g_dur[row] = duration
        return hd

    def sit_down(self, agent_id: int) -> Handle:
        """Sit where the agent stands (fails while it walks)."""
        row = self._row(agent_id)
        hd = self._start("sit_down", agent_id, None)
        if np.linalg.norm(self.state.vel_s[row]) > V_WALK:
            hd.status, hd.detail = Status.FAILURE, "walking"
            return hd
        self.state.sitting[row] = True
        return hd

    def stand_up(self, agent_id: int) -> Handle:
        row = self._row(agent_id)
        hd = self._start("stand_up", agent_id, None)
        self.state.sitting[row] = False
        return hd

    def _update_handles(self, t: float) -> None:
        if not self.handles:
            return
        b = self.state
        ci = self.coordinator.index
        for hd in self.handles:
            if not hd.running:
                continue
            hit = np.flatnonzero(self.ids == hd.agent)
            if hit.size == 0:
                hd.status, hd.detail = Status.FAILURE, "agent removed"
                continue
            r = int(hit[0])
            if hd.capability == "go_to":
                goal, arrive, timeout = cast(tuple[Any, float, float], hd.target)
                if np.hypot(*(b.root[r] - np.asarray(goal))) <= arrive:
                    hd.status = Status.SUCCESS
                elif t - hd.started > timeout:
                    hd.status, hd.detail = Status.FAILURE, "timeout"
            elif hd.capability == "gaze_at":
                if abs(b.gaze_ang[r, :, 0].sum() - self._gaze_goal_yaw(r)) < math.radians(5.0):
                    hd.status = Status.SUCCESS
            elif hd.capability == "reach_for":
                point, arm = cast(tuple[Any, int], hd.target)
                tip = sk.L_HAND if arm == 0 else sk.R_HAND
                miss = float(np.linalg.norm(b.world_pos[r, tip] - np.asarray(point)))
                if miss < 0.03:
                    hd.status = Status.SUCCESS
                elif t - hd.started > 2.0:
                    hd.status, hd.detail = Status.FAILURE, f"out of reach by {miss:.2f} m"
            elif hd.capability == "gesture":
                if t >= b.g_start[r] + b.g_dur[r]:
                    hd.status = Status.SUCCESS
            elif hd.capability in ("sit_down", "stand_up"):
                w = self.coordinator.weights[r, ci["sitting"]]
                if (hd.capability == "sit_down" and w >= 1.0) or (hd.capability == "stand_up" and w <= 0.0):
                    hd.status = Status.SUCCESS
        self.handles = [hd for hd in self.handles if hd.running]

    def _gaze_goal_yaw(self, r: int) -> float:
        b = self.state
        k = b.gaze_kind[r]
        if k == GAZE_POINT:
            tgt = b.gaze_point[r]
        else:
            return float(b.gaze_ang[r, :, 0].sum())
        d = tgt - self._heads()[0][r]
        ry = 0.5 * np.pi - b.heading[r]
        c, s = math.cos(-ry), math.sin(-ry)
        return math.atan2(c * d[0] + s * d[2], -s * d[0] + c * d[2])

    # -- the renderer's view ------------------------------------------------------------------------

    def joint_matrices(self, out: np.ndarray | None = None) -> np.ndarray:
        """World transforms of the 26 joints, ``(N, J, 4, 4) float32``, column vectors."""
        b = self.state
        n = len(b)
        if out is None:
            out = np.empty((n, sk.J, 4, 4), np.float32)
        matrices_kernel(b.world_pos, b.world_q, sk.J, out)
        return out

