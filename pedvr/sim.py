"""The Simulation: one fixed step made of named, timed phases (DESIGN.md).

``step()`` runs ``sense → decide → plan → avoid → animate → sync → record``.
Each phase computes into new buffers and commits at its end, so no agent
reads a half-updated world. One ``numpy.random.Generator``, seeded from the
scene or the caller, is the only source of randomness: the same seed gives
the same run, bit for bit. Agents are added (spawn) and removed (on reaching a
final BFSM state, or inside a sink region) only between steps; sources add agents at a
rate (:mod:`pedvr.inflow`).
"""

from __future__ import annotations

import math
import time

import numpy as np
import shapely

from pedvr.behavior.bfsm import BFSM, BehaviorState
from pedvr.behavior.context import Context
from pedvr.behavior.objects import make_objects
from pedvr.behavior.scheduler import Scheduler
from pedvr.body import FullBody
from pedvr.body import skeleton as sk
from pedvr.body.carry import PRAM_HULL
from pedvr.body.model import GestureSets
from pedvr.body.simple import sync_kernel
from pedvr.crowd.encounter import UserEncounters
from pedvr.crowd.footprint import covering_discs, enclosing_ellipse, footprints, shoulder_twist
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.crowd.steering import Steering
from pedvr.crowd.user import ReactiveUser, ScriptedUser, StandingUser, UserAgent, UserInput
from pedvr.errors import NavigationError, SceneError, UsageError
from pedvr.etiquette.doors import CLOSED_EPS, DoorLeaves
from pedvr.etiquette.objects import DOOR_HOLD_EVENT, DOOR_HOLD_TREE
from pedvr.etiquette.system import DoorEtiquette
from pedvr.etiquette.user import DoorUser
from pedvr.inflow import Inflow, bounding_discs
from pedvr.record import Metrics, Recording
from pedvr.scene.config import (
    CONDITIONS,
    PRAM_MIN_RADIUS,
    TURNED_DEPTH_RATIO,
    USER_WALKS,
    AgentProfile,
    SceneConfig,
    SequenceGoal,
    Spawn,
)
from pedvr.world import NavMesh, Visibility, edges, obstacle_set, walkable_area
from pedvr.world.pathing import follow_paths

PHASES = ("sense", "decide", "plan", "avoid", "animate", "sync", "record")
SLOWING_DIST = 0.8  # m: agents slow down linearly inside this distance of their final waypoint
LOOKAHEAD = 8  # waypoints checked for visibility ahead of the current one
LOST_CHECK_S = 0.1  # s: how often each agent checks its waypoint is still in sight (10 Hz)
STALL_GOAL_DIST = 0.5  # m: an agent this close to its goal (or with none) is not stalled, only waiting
# A pushed pram wedged against a door leaf backs out (Simulation._prams_back_out):
PRAM_BACK_AFTER = 2.0  # s stuck (crowd.deadlock's stuck_time) with the footprint against a leaf
PRAM_BACK_NEAR = 0.05  # m: a footprint this close to a leaf is against it
PRAM_BACK_S = 1.5  # s it backs up for
PRAM_BACK_SPEED = 0.4  # m/s
PRAM_SIDEWAYS = 0.1  # m/s: a pushed pram's sideways speed at most (it steers: body.simple.root_motion_kernel)


def _limits_row(p: AgentProfile) -> list[float]:
    """A profile's motion limits as a crowd row; a pram's pusher goes sideways at most
    :data:`PRAM_SIDEWAYS` (it steers: body.simple.root_motion_kernel)."""
    m = p.limits
    sideways = m.max_sideways_speed
    if p.carrying == "perambulator":
        sideways = min(sideways, PRAM_SIDEWAYS)
    return [m.max_accel, m.max_decel, m.turn_rate_standing, m.turn_rate_walking,
            m.max_backward_speed, sideways]


class Simulation:
    """A running scene. Keyword-only options:

    ``seed``: overrides the scene's seed. ``condition``: ``decoupled`` (plain
    ORCA, no motion limits, the body follows the disc), ``pedvr`` (coupled) or
    ``pedvr+g`` (coupled, gaze on). ``responsibility``: overrides the scene's
    share ρ of each encounter's avoidance taken toward the user.
    ``personal_space``: overrides the scene's margin (m) agents keep from the
    user where there is room. ``user_input``: the source of the user's pose
    (default: a scripted walk along the red-sphere route, ``straight`` or
    ``reactive`` as ``user_walk`` or the scene says). ``record``: keep the
    per-step trajectory.
    """

    def __init__(self, scene: SceneConfig, *, seed: int | None = None, condition: str = "pedvr",
                 responsibility: float | None = None, user_input: UserInput | None = None,
                 record: bool = False, personal_space: float | None = None,
                 user_walk: str | None = None) -> None:
        if condition not in CONDITIONS:
            raise UsageError(f"condition {condition!r}: expected one of {', '.join(CONDITIONS)}")
        if responsibility is not None and not 0.0 <= responsibility <= 1.0:
            raise UsageError(f"responsibility {responsibility}: expected a number in [0, 1]")
        if personal_space is not None and not 0.0 <= personal_space <= 2.0:
            raise UsageError(f"personal_space {personal_space}: expected a number of metres in [0, 2]")
        if user_walk is not None and user_walk not in USER_WALKS:
            raise UsageError(f"user_walk {user_walk!r}: expected one of {', '.join(USER_WALKS)}")
        self.scene = scene
        self.seed = scene.seed if seed is None else int(seed)
        self.rng = np.random.default_rng(self.seed)
        self.condition = condition
        self.coupled = condition != "decoupled"
        self.gaze_on = condition == "pedvr+g"
        self.responsibility = (scene.steering.user_responsibility if responsibility is None
                               else float(responsibility))
        self.personal_space = (scene.steering.personal_space if personal_space is None
                               else float(personal_space))
        self.user_walk = scene.user.walk if user_walk is None else user_walk
        self.dt = scene.dt
        self.t = 0.0
        self.step_index = 0

        self.obstacles = obstacle_set(scene.world)
        self.doors = DoorLeaves.of_world(scene.world)
        self.visibility = Visibility(scene.world)
        self._walkable = walkable_area(scene.world)
        shapely.prepare(self._walkable)  # contains_xy on every recorded step
        self._navmeshes: dict[float, NavMesh] = {}
        radii = [p.radius for p in scene.profiles.values()] or [scene.user.radius]
        self.goal_mesh = self.navmesh_for(max(radii))
        self.steering = Steering(scene.steering, self.obstacles, coupled=self.coupled)
        self.encounters = UserEncounters(personal_space=self.personal_space,
                                         safety_horizon=scene.steering.user_safety_horizon,
                                         edges=edges(scene.world))
        self.bfsm = BFSM(scene.behavior, self.goal_mesh)
        gestures = GestureSets(by_state={n: st.gestures for n, st in scene.behavior.states.items()
                                         if st.gestures is not None})
        self.body = FullBody(rng=self.rng, gestures=gestures, navigate=self._navigate)
        # Huang & Terzopoulos: door and doorway etiquette (pedvr.etiquette), when there are doors
        self.etiquette = (DoorEtiquette(scene, leaves=self.doors, body=self.body, rng=self.rng,
                                        replan=self._replan)
                          if scene.world.doors and scene.etiquette.enabled else None)

        self.crowd = CrowdState.empty()
        self.behavior = BehaviorState.rows(0)
        self.paths: list[np.ndarray] = []
        self.cursor = np.zeros(0, np.int64)
        self.sequences: list[tuple[SequenceGoal, ...]] = []
        self.stuck_time = np.zeros(0)
        self.backing = np.zeros(0)  # s a wedged pram still backs up for (_prams_back_out)
        # Each row's profile, as an index into list(scene.profiles) (-1: the user); for drawing.
        self.profile_index = np.zeros(0, np.int64)
        self._flat: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._replanned: list[int] = []  # rows whose new path is not in self._flat yet
        self._next_id = 0
        self._leaving = np.zeros(0, np.bool_)
        self._new_vel = np.zeros((0, 2))
        self._root = np.zeros((0, 2))
        self._root_heading = np.zeros(0)
        self._pinned = np.zeros(0, np.bool_)
        self.unreachable_goals = 0

        self.user: UserAgent | None = None
        if scene.user.enabled:
            self.user = UserAgent(user_input or self._scripted_user(), route=scene.user.route,
                                  sphere_radius=scene.user.sphere_radius)
            self._add_rows(1, pos=np.asarray([scene.user.start]), radius=scene.user.radius,
                           pref_speed=scene.user.speed, max_speed=3.0, limits=[0.0] * N_LIMITS,
                           is_user=True, heading=np.asarray([scene.user.heading]))
        for k, spawn in enumerate(scene.spawns):
            self._spawn(k, spawn)
        # ADAPT §6: personal trees, events, smart objects and triggers (pedvr.behavior.scheduler)
        objects = make_objects(scene.behavior.objects)
        if self.etiquette is not None:  # doors are smart objects; a holder and its follower, an event
            objects.update(self.etiquette.smart_objects())
        self.scheduler = Scheduler(scene.behavior, Context(
            crowd=self.crowd, behavior=self.behavior, body=self.body, visibility=self.visibility,
            walkable=self.goal_mesh, rng=self.rng, goal_sets=scene.behavior.goal_sets,
            objects=objects, user=None if self.user is None else int(self.crowd.ids[0]), world=scene.world),
            bfsm=self.bfsm)
        if self.etiquette is not None:
            self.scheduler.events.setdefault(DOOR_HOLD_EVENT.name, DOOR_HOLD_EVENT)
            self.scheduler.trees.setdefault(DOOR_HOLD_TREE.name, DOOR_HOLD_TREE)
            self.etiquette.scheduler = self.scheduler

        seg_a, seg_b = edges(scene.world)
        self.metrics = Metrics(seg_a=seg_a, seg_b=seg_b, inside=self._inside_obstacle,
                               personal_space=self.personal_space)
        self.scheduler.ctx.gaze_events = self.metrics.gaze_events  # behaviors' gaze events (demonstrations)
        self.recording = Recording() if record else None
        # [[agents.sources]] / [[agents.sinks]]: agents due at t = 0 enter before the first frame
        self.inflow = Inflow(scene.sources, scene.sinks, state_names=self.bfsm.names)
        self._sources_and_sinks()
        self._face_unset()
        self.body.pose_at_rest(self.crowd, self.crowd.heading)
        if self.recording is not None:
            self.recording.add(self.t, self.crowd, self.doors.angle)

    # -- set-up ----------------------------------------------------------------------------

    def navmesh_for(self, radius: float) -> NavMesh:
        """The navigation mesh shrunk by ``radius`` (built once per distinct radius)."""
        key = round(radius, 4)
        if key not in self._navmeshes:
            self._navmeshes[key] = NavMesh.build(self.scene.world, clearance=key)
        return self._navmeshes[key]

    def path_mesh_for(self, radius: float) -> NavMesh:
        """The mesh agents of ``radius`` plan their paths on: coupled, the navigation mesh with
        the narrow passages a body turned to squeeze through fits (its half depth
        ``TURNED_DEPTH_RATIO * radius``; :mod:`pedvr.world.navmesh`), which the full radius
        closes (issue 26: real people pass a 0.5 m bottleneck); decoupled (the paper's discs),
        :meth:`navmesh_for`. Spawns, sources and goals stay on :meth:`navmesh_for`: a disc must
        fit where an agent stands."""
        if not self.coupled:
            return self.navmesh_for(radius)
        key = -round(radius, 4)  # negative keys: the path meshes
        if key not in self._navmeshes:
            self._navmeshes[key] = NavMesh.build(self.scene.world, clearance=-key,
                                                 narrow=-key * TURNED_DEPTH_RATIO)
        return self._navmeshes[key]

    def _scripted_user(self) -> UserInput:
        u = self.scene.user
        if not u.route:
            return StandingUser(u.start, u.heading)
        mesh = self.navmesh_for(u.radius)
        pts = [np.asarray([u.start])]
        here = u.start
        for target in u.route:
            leg = mesh.find_path(here, target)
            pts.append(leg[1:])
            here = target
        path = np.concatenate(pts)
        if self.etiquette is not None and self.user_walk == "straight":
            # at doors the scripted user opens (and, with user.door_hold, holds) them as a person would
            return DoorUser(path, speed=u.speed, heading=u.heading, radius=u.radius, hold=u.door_hold,
                            etiquette=self.etiquette, perceive=lambda: self.crowd,
                            inside=lambda p: mesh.contains((float(p[0]), float(p[1]))))
        if self.user_walk == "reactive":
            def perceive() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
                c = self.crowd
                return c.pos, c.vel, c.radius, c.is_user

            return ReactiveUser(path, speed=u.speed, heading=u.heading, radius=u.radius,
                                perceive=perceive, inside=lambda p: mesh.contains((float(p[0]), float(p[1]))))
        return ScriptedUser(path, speed=u.speed, heading=u.heading)

    def _face_unset(self) -> None:
        """New agents without a given facing face their first waypoint, or a random way when standing."""
        self._plan()
        unset = np.isnan(self.crowd.heading)
        self.crowd.heading[unset] = self.crowd.pref_heading[unset]
        still = np.flatnonzero(np.isnan(self.crowd.heading))
        self.crowd.heading[still] = self.rng.uniform(-np.pi, np.pi, still.size)

    def _inside_obstacle(self, pts: np.ndarray) -> np.ndarray:
        return ~shapely.contains_xy(self._walkable, pts[:, 0], pts[:, 1])

    def _add_rows(self, n: int, *, pos: np.ndarray, radius: float, pref_speed: float, max_speed: float,
                  limits: list[float], is_user: bool, heading: np.ndarray,
                  state: str | None = None, sequence: tuple[SequenceGoal, ...] = (),
                  profile: int = -1) -> None:
        ids = np.arange(self._next_id, self._next_id + n, dtype=np.int64)
        self._next_id += n
        rows = CrowdState(
            ids=ids, pos=np.asarray(pos, np.float64).reshape(n, 2), vel=np.zeros((n, 2)),
            pref_vel=np.zeros((n, 2)), heading=np.asarray(heading, np.float64).reshape(n),
            pref_heading=np.zeros(n), radius=np.full(n, radius), pref_speed=np.full(n, pref_speed),
            max_speed=np.full(n, max_speed), responsibility=np.full(n, self.responsibility),
            is_user=np.full(n, is_user), limits=np.tile(np.asarray(limits, np.float64), (n, 1)),
        )
        first = len(self.crowd)
        prof = list(self.scene.profiles.values())[profile] if profile >= 0 else None
        carrying = self.scene.user.carrying if is_user else prof.carrying if prof is not None else "none"
        if carrying == "perambulator":  # pusher and pram: one footprint (§4.6), the user's too
            # A profile's pusher is validated at least as wide as the pram; the user (whose radius
            # defaults to a body's, and whom a study protocol may hand a pram) is widened to it.
            rows.radius[:] = np.maximum(rows.radius, PRAM_MIN_RADIUS)
            rows.ahead[:], rows.length[:] = enclosing_ellipse(float(rows.radius[0]), PRAM_HULL)
        dims = None
        if prof is not None and prof.sex:  # a profile that says who its agents are (door etiquette's Care)
            dims = sk.draw_dims(self.body.rng, n, sex=sk.SEX_FEMALE if prof.sex == "female" else sk.SEX_MALE)
        rows.pref_speed *= self.body.append(n, ids=ids, pos=rows.pos, heading=rows.heading, is_user=is_user,
                                            limits=rows.limits, dims=dims,
                                            carrying=carrying)
        if self.etiquette is not None:
            self.etiquette.append(ids, profile=prof, is_user=is_user,
                                  female=self.body.state.dims[first:first + n, sk.DIM_SEX] == sk.SEX_FEMALE)
        self.crowd.append(rows)
        self.steering.forget_neighbors()
        self.encounters.append(n)
        self.behavior.append(BehaviorState.rows(n))
        self.paths.extend(np.zeros((0, 2)) for _ in range(n))
        self.cursor = np.concatenate([self.cursor, np.ones(n, np.int64)])
        self.sequences.extend(sequence for _ in range(n))
        self.stuck_time = np.concatenate([self.stuck_time, np.zeros(n)])
        self.backing = np.concatenate([self.backing, np.zeros(n)])
        self.profile_index = np.concatenate([self.profile_index, np.full(n, profile, np.int64)])
        self._flat = None
        if state is not None:
            for row in range(first, first + n):
                self.bfsm.enter(self.behavior, row, state, t=self.t, pos=self.crowd.pos[row],
                                rng=self.rng, sequence=sequence)
                self._replan(row)

    def _spawn(self, k: int, spawn: Spawn) -> None:
        prof = self.scene.profiles[spawn.profile]
        pts = list(spawn.positions) if spawn.positions else self._place(k, spawn, prof.radius)
        first_id = self._next_id
        for p in pts:
            heading = np.nan if spawn.facing is None else spawn.facing
            self._add_rows(1, pos=np.asarray([p]), radius=prof.radius, pref_speed=prof.pref_speed,
                           max_speed=prof.max_speed, limits=_limits_row(prof), is_user=False,
                           heading=np.asarray([heading]), state=spawn.state, sequence=spawn.goal_sequence,
                           profile=list(self.scene.profiles).index(spawn.profile))
        if spawn.friends and self.etiquette is not None:  # consecutive pairs walk together (§4.6)
            for a in range(first_id, self._next_id - 1, 2):
                self.etiquette.pair_friends(a, a + 1)

    def _place(self, k: int, spawn: Spawn, radius: float) -> list[tuple[float, float]]:
        """Draw ``spawn.count`` free positions in the spawn's region with the run's rng."""
        assert spawn.region is not None
        kind, v = spawn.region
        mesh = self.navmesh_for(radius)
        out: list[tuple[float, float]] = []
        taken = [(tuple(p), r) for p, r in zip(self.crowd.pos, self.crowd.radius, strict=True)]
        for _ in range(200 * spawn.count):
            if len(out) == spawn.count:
                break
            if kind == "box":
                p = (float(self.rng.uniform(v[0], v[2])), float(self.rng.uniform(v[1], v[3])))
            else:
                a = float(self.rng.uniform(-math.pi, math.pi))
                r = v[2] if kind == "circle" else v[2] * math.sqrt(float(self.rng.uniform()))
                p = (v[0] + r * math.cos(a), v[1] + r * math.sin(a))
            if not mesh.contains(p):
                continue
            if any(math.dist(p, q) < radius + rq + 0.1 for q, rq in taken):
                continue
            out.append(p)
            taken.append((p, radius))
        if len(out) < spawn.count:
            raise SceneError([f"{self.scene.source}: agents.spawns[{k}].count = {spawn.count}: only "
                              f"{len(out)} agents of radius {radius} m fit in region {kind} {list(v)}"])
        return out

    # -- the step --------------------------------------------------------------------------

    def step(self) -> None:
        """Advance one fixed ``dt`` through the named phases (``PHASES``), each timed."""
        start = t0 = time.perf_counter()
        self._prev_vel, self._prev_heading = self.crowd.vel.copy(), self.crowd.heading.copy()
        phase_ms = self.metrics.phase_ms
        for name, run in zip(PHASES, (self._sense, self._decide, self._plan, self._avoid, self._animate,
                                      self._sync, self._record), strict=True):
            run()
            t1 = time.perf_counter()
            phase_ms[name] = phase_ms.get(name, 0.0) + (t1 - t0) * 1e3
            t0 = t1
        self.metrics.step_ms.append((t0 - start) * 1e3)
        self._remove_leaving()
        self._sources_and_sinks()

    def advance_to(self, t: float) -> None:
        """Step until simulation time reaches ``t`` (the frame loop's entry point)."""
        while self.t + self.dt <= t + 1e-9:
            self.step()

    def _sense(self) -> None:
        """The user agent takes its pose from its input; velocity is filtered."""
        if self.user is None:
            return
        pos, vel, heading = self.user.sense(self.t + self.dt, self.dt)
        self.crowd.pos[0], self.crowd.vel[0], self.crowd.heading[0] = pos, vel, heading

    def _decide(self) -> None:
        """The BFSM, then behavior trees and events, set goals at the decision rate (30 Hz by default).

        Each agent's BFSM decides once every ``decision_every`` steps, staggered by id
        (``id % decision_every``): the arrivals, goal draws and replans of a crowd spread over
        the steps instead of landing on one (issue 12: a decision step cost about 0.3 ms more
        than the others at 100 agents). Doorway ordering and events tick for everyone on the
        decision steps."""
        self._leaving = np.zeros(len(self.crowd), np.bool_)
        self.metrics.gaze_events += self.body.gaze_rule(
            self.crowd, t=self.t, visibility=self.visibility, d1=self.scene.gaze_distance,
            d2=self.scene.gaze_speed, enabled=self.gaze_on)
        every = self.scene.decision_every
        phase = self.step_index % every
        waiting = self.crowd.ids % every != phase
        d = self.bfsm.decide(self.behavior, t=self.t, dt=self.dt * every, pos=self.crowd.pos, rng=self.rng,
                             sequences=self.sequences, frozen=self.scheduler.frozen() | waiting)
        self.metrics.arrivals += d.arrived
        for row in np.flatnonzero(d.goal_changed & ~d.leaving):
            self._replan(int(row))
        self._leaving = d.leaving
        if phase != 0:
            return
        if self.etiquette is not None:  # doorway ordering and the door interaction states
            self.etiquette.decide(self.t, self.crowd, self.paths, self.cursor)
        for back in self.scheduler.tick(self.t):  # agents an event gave back to their BFSM
            self._replan(back)

    def _navigate(self, row: int, target: tuple[float, float] | None) -> None:
        """The body's ``go_to`` capability: walk ``row`` to ``target`` along the navmesh.

        It sets the agent's goal directly; the BFSM may set another at its next
        transition (a behavior that uses go_to owns the agent's goal meanwhile).
        Raises NavigationError when the target cannot be reached.
        """
        previous = self.behavior.goal[row].copy()
        self.behavior.goal[row] = np.nan if target is None else target
        try:
            self._replan(row, strict=True)
        except NavigationError:
            self.behavior.goal[row] = previous  # the handle fails; the agent keeps its goal
            self._replan(row)
            raise

    def _replan(self, row: int, *, strict: bool = False) -> None:
        """A new path to the row's goal; unreachable goals leave it standing (or raise, if strict)."""
        goal = self.behavior.goal[row]
        self.cursor[row] = 1
        self._replanned.append(row)
        if np.isnan(goal[0]):
            self.paths[row] = np.zeros((0, 2))
            return
        mesh = self.path_mesh_for(float(self.crowd.radius[row]))
        try:
            self.paths[row] = mesh.find_path(tuple(self.crowd.pos[row]), (float(goal[0]), float(goal[1])))
        except NavigationError:
            self.paths[row] = np.zeros((0, 2))
            if strict:
                raise
            self.unreachable_goals += 1

    def _flat_paths(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every row's path as one array for the kernels: ``(points (P, 2), starts (N,), lens (N,))``.

        Built whole when rows come or go; a replanned row's new path is appended and its
        slice pointed at it, the old points left unreferenced until they outweigh the live
        ones (then it is built whole again): a replan costs its own path, not the crowd's."""
        if self._flat is not None and self._replanned:
            pts, starts, lens = self._flat
            rows = sorted(set(self._replanned))
            new = [self.paths[r] for r in rows]
            live = int(lens.sum())
            if pts.shape[0] + sum(p.shape[0] for p in new) > 2 * live + 64:
                self._flat = None
            else:
                starts, lens = starts.copy(), lens.copy()
                at = pts.shape[0]
                for r, p in zip(rows, new, strict=True):
                    starts[r], lens[r] = at, p.shape[0]
                    at += p.shape[0]
                pts = np.ascontiguousarray(np.concatenate([pts, *new]), dtype=np.float64)
                self._flat = (pts, starts, lens)
        self._replanned.clear()
        if self._flat is None:
            lens = np.fromiter((p.shape[0] for p in self.paths), np.int64, len(self.paths))
            starts = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int64)
            pts = np.concatenate(self.paths) if self.paths else np.zeros((0, 2))
            self._flat = (np.ascontiguousarray(pts, dtype=np.float64), starts, lens)
        return self._flat

    def _plan(self) -> None:
        """Preferred velocity toward the furthest visible waypoint, facing it (PedVR §3.2.1).

        A push (contact, a crowd) can leave the waypoint behind a corner the cursor already
        passed: the agent would walk into the wall for ever. Each agent checks its waypoint
        is still in sight every ``LOST_CHECK_S`` and, if it lost it, replans from where it
        stands. The checks are staggered by id over the interval, so every step checks the
        same share of the crowd (a thick ray each, about 1 µs per agent in a 70 m plaza)."""
        crowd = self.crowd
        pts, starts, lens = self._flat_paths()
        cursor = self.visibility.furthest_visible(crowd.pos, crowd.radius, pts, starts, lens,
                                                  self.cursor, lookahead=LOOKAHEAD)
        n = len(crowd)
        target, pref_vel, pref_heading = np.empty((n, 2)), np.empty((n, 2)), np.empty(n)
        follow = (crowd.pos, pts, starts, lens, cursor, crowd.is_user, crowd.pref_speed,
                  self.behavior.speed_scale, self.behavior.face, crowd.heading, crowd.vel, SLOWING_DIST)
        follow_paths(*follow, target, pref_vel, pref_heading)
        every = max(1, round(LOST_CHECK_S / self.dt))
        due = np.flatnonzero((crowd.ids % every == self.step_index % every) & (lens >= 2) & ~crowd.is_user)
        if due.size:
            lost = due[~self.visibility.visible(crowd.pos[due], target[due], crowd.radius[due] * 0.25)]
            if lost.size:
                for row in lost:
                    self._replan(int(row))
                pts, starts, lens = self._flat_paths()
                cursor[lost] = 1
                follow = (crowd.pos, pts, starts, lens, cursor, *follow[5:])
                follow_paths(*follow, target, pref_vel, pref_heading)
        # commit
        self.cursor = cursor
        crowd.pref_vel = pref_vel
        crowd.pref_heading = pref_heading
        if self.etiquette is not None:  # pedestrians at a door go where the door interaction says
            self.etiquette.steer(crowd)

    def _avoid(self) -> None:
        """ORCA: reciprocal between agents, asymmetric toward the user (the agent's share ρ of
        each encounter in its preferred velocity, :mod:`pedvr.crowd.encounter`), inside the
        body's limits; then shoulders turn where people squeeze past each other."""
        self.body.fill_limits(self.crowd, self.crowd.limits)
        crowd = self.crowd
        # the footprints ORCA steers, made once for the headway and ORCA (nothing between the two
        # moves, turns or adds a body)
        fp = self.steering.footprints(crowd)
        # coupled: no faster than keeps the time gap to whoever walks ahead (pedvr.crowd.headway);
        # an agent that waits in a queue is waiting, not stuck (its preferred speed is 0)
        pref = self.steering.headway(crowd, crowd.pref_vel, footprints=fp)
        pref = self.steering.unstick(crowd.vel, pref, crowd.is_user, self.stuck_time, self.dt)
        if len(self.doors) and (crowd.length > 0.0).any():
            pref = self._prams_back_out(pref)
        pref, short, to_user = self.encounters.steer(
            pos=crowd.pos, vel=crowd.vel, pref_vel=pref, radius=crowd.radius,
            responsibility=crowd.responsibility, is_user=crowd.is_user, dt=self.dt,
            engaged=self.scheduler.engaged_with_user() if self.etiquette is None
            else self.scheduler.engaged_with_user() | self.etiquette.engaged_with_user(crowd))
        saved = crowd.pref_vel
        crowd.pref_vel = pref
        if len(self.doors):  # door leaves are obstacles where they stand now (ORCA, then contacts)
            self.steering.set_moving_segments(self.doors.hinge, self.doors.tips())
        at_doors = None if self.etiquette is None else self.etiquette.at_doors(crowd)
        self._new_vel = self.steering.compute_velocities(crowd, self.dt, intent=saved, at_doors=at_doors,
                                                         footprints=fp)
        if self.etiquette is not None:  # revolving-door riders move with their compartment
            self.etiquette.carry(self._new_vel, crowd)
        crowd.pref_vel = saved
        self._pinned = self.scheduler.pinned()  # seated bodies do not slide (contacts move the others)
        self._new_vel[self._pinned] = 0.0
        turn, torso = self.steering.turn_shoulders(crowd, self.dt, short_of_room=short, to_user=to_user,
                                                   pinned=self._pinned)
        crowd.turn, crowd.torso = turn, torso

    def _animate(self) -> None:
        """The body turns commanded velocities into root motion; contacts are resolved; bodies are posed."""
        root, heading = self.body.animate(self.crowd, self._new_vel, self.dt, coupled=self.coupled)
        if self.etiquette is not None:  # holders stepping round a door keep facing it (App. C)
            heading = self.etiquette.face(heading, self.crowd.heading, self.crowd, self.dt,
                                          coupled=self.coupled)
        self.metrics.observe_user_contact(self.crowd, root)
        if (self.crowd.length > 0.0).any():
            heading = self._pram_keeps_its_course(heading)
            if len(self.doors):
                heading = self._no_turning_into_leaves(root, heading)
        self._root_heading = heading
        self._root = self.steering.resolve_contacts(root, self.crowd.radius, self.crowd.is_user,
                                                    turn=self.crowd.turn, torso=self.crowd.torso,
                                                    heading=heading, ahead=self.crowd.ahead,
                                                    length=self.crowd.length, pinned=self._pinned)
        if len(self.doors):
            self._root = self._move_doors(self._root)
        if len(self.body.state) == len(self.crowd):  # the footprint's shoulder turn, shown by the body
            # shoulder_twist is a 2D angle (CCW, as headings are); the body's shoulder_turn is a turn
            # about the 3D vertical +Y, which is the opposite 2D direction (pedvr.body.quat)
            self.body.state.shoulder_turn[:] = np.where(
                self.crowd.is_user, 0.0, -shoulder_twist(self.crowd.turn, self.crowd.torso, heading))
        self.body.compose(self.crowd, self._root, heading, dt=self.dt, t=self.t + self.dt,
                          coupled=self.coupled,
                          state_names=np.asarray(self.bfsm.names + ("",))[self.behavior.state])

    def _move_doors(self, root: np.ndarray) -> np.ndarray:
        """Door leaves yield to the bodies' new discs, then bodies yield to leaves that cannot
        (:mod:`pedvr.etiquette.doors`); before the bodies are posed, so the body stays the truth."""
        crowd, doors = self.crowd, self.doors
        # a leaf counts as opened when it leaves its closed position (a hand may have taken it in
        # the decide phase already); a revolving door when it starts turning from rest
        was_closed = ~doors.panel & (np.abs(doors.angle) < CLOSED_EPS)
        was_still = doors.revolvers.omega == 0.0
        vel = np.where(crowd.is_user[:, None], crowd.vel, self._new_vel)
        et = self.etiquette
        if et is not None:  # the holders' hands lead their leaves (App. A's f_a)
            et.user_reach(crowd)
            et.before_doors(crowd)
        discs, rad, owner = self._door_discs(root)  # a pushed pram is seen whole (footprint.covering_discs)
        doors.step(self.dt, discs, vel[owner], rad, fixed=crowd.is_user[owner],
                   auto=None if et is None else et.auto_open(crowd)[owner],
                   carried=None if et is None else et.carried(crowd)[owner])
        if et is not None:  # and the leaves lead the hands (f_pabs)
            et.after_doors(crowd)
        pushed, overlap = self._push_out(root)
        if len(root):
            self.metrics.door_push = max(self.metrics.door_push, float(np.hypot(*(pushed - root).T).max()))
        if not np.array_equal(pushed, root):  # a pushed disc may now press on another: settle once more
            root = self.steering.resolve_contacts(pushed, crowd.radius, crowd.is_user,
                                                  turn=crowd.turn, torso=crowd.torso,
                                                  heading=self._root_heading, ahead=crowd.ahead,
                                                  length=crowd.length, pinned=self._pinned)
            root, overlap = self._push_out(root)
        self.metrics.door_overlap = max(self.metrics.door_overlap, overlap)
        self.metrics.door_openings += int(np.count_nonzero(was_closed & (np.abs(doors.angle) >= CLOSED_EPS))
                                          + np.count_nonzero(was_still & (doors.revolvers.omega != 0.0)))
        return root

    def _pram_keeps_its_course(self, heading: np.ndarray) -> np.ndarray:
        """A pushed pram is not turned toward a velocity that leads away from where its pusher
        wants to go: a rigid footprint whose avoidance velocity points more than a right angle
        off its preferred one keeps its old heading this step (it is shoved aside, or backs up,
        but does not swing round). Turning it there swung the pram's front round a door leaf's
        free end, which pushed it further round: a pusher 1.5 m before an open double door
        circled there for 40 s (``tests/etiquette/test_carriers.py``)."""
        c = self.crowd
        v, p = self._new_vel, c.pref_vel
        rows = np.flatnonzero((c.length > 0.0) & (np.einsum("ij,ij->i", v, p) < 0.0))
        if not rows.size:
            return heading
        heading = heading.copy()
        heading[rows] = c.heading[rows]
        return heading

    def _prams_back_out(self, pref: np.ndarray) -> np.ndarray:
        """A pushed pram wedged against a door leaf backs out: a rigid footprint that has been stuck
        (``stuck_time``, :mod:`pedvr.crowd.deadlock`) for :data:`PRAM_BACK_AFTER` s while it wants
        to move, with its footprint within :data:`PRAM_BACK_NEAR` of a leaf, is steered straight
        back along its heading at :data:`PRAM_BACK_SPEED` for :data:`PRAM_BACK_S` s (about 0.6 m),
        keeping its course (:meth:`_pram_keeps_its_course`); then it goes on as its path and the
        etiquette say. Real pushers back a pram off what it is stuck against; nothing else frees
        it: it cannot step sideways, it may not turn its front into the leaf
        (:meth:`_no_turning_into_leaves`), and the leaf's spring holds the leaf on its front.
        Issue 26, "no carrier left behind", traced at the double door (door_observations' pram,
        seed 1): a pusher that had followed a holder into the pocket beside the open leaf, and one
        whose leaf swung back onto its front when the holder let go, each stood still facing the
        leaf until the passage timed out, over and over, for 90 s. Returns ``pref`` (a copy where a
        row backs)."""
        c = self.crowd
        start = ((c.length > 0.0) & ~c.is_user & (self.backing <= 0.0) & (self.stuck_time >= PRAM_BACK_AFTER)
                 & (np.hypot(*pref.T) > 0.0))
        if start.any():
            start &= self._leaf_depth(c.pos, c.heading, margin=PRAM_BACK_NEAR) > 0.0
            self.backing[start] = PRAM_BACK_S
            self.stuck_time[start] = 0.0
        rows = np.flatnonzero(self.backing > 0.0)
        if not rows.size:
            return pref
        pref = pref.copy()
        h = c.heading[rows]
        pref[rows] = -PRAM_BACK_SPEED * np.stack([np.cos(h), np.sin(h)], axis=1)
        self.backing[rows] = np.maximum(self.backing[rows] - self.dt, 0.0)
        return pref

    def _no_turning_into_leaves(self, root: np.ndarray, heading: np.ndarray) -> np.ndarray:
        """A pushed pram does not swing into a door leaf: a rigid footprint (0.8 m long) whose new
        heading would put it deeper into a leaf than its old one keeps its old heading this step.
        Steering keeps the footprint's centre off the leaf, not its turn; a pusher standing
        nearly still beside a leaf held at its stop has a heading that wavers by a few hundredths
        of a radian a step, which swung the pram's front 2-3 cm into the leaf every other step, and
        the leaf shoved it back out."""
        c = self.crowd
        rows = np.flatnonzero((c.length > 0.0) & (heading != c.heading))
        if not rows.size:
            return heading
        new = self._leaf_depth(root, heading)
        old = self._leaf_depth(root, c.heading)
        back = rows[new[rows] > old[rows] + 1e-4]
        if back.size:
            heading = heading.copy()
            heading[back] = c.heading[back]
        return heading

    def _leaf_depth(self, root: np.ndarray, heading: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """How far each body's footprint at ``root`` facing ``heading``, grown by ``margin``, lies
        inside a door leaf (m)."""
        discs, rad, owner = self._door_discs(root, heading)
        pushed, _ = self.doors.push_out(discs, rad + margin, ~self.crowd.is_user[owner])
        depth = np.zeros(len(self.crowd))
        np.maximum.at(depth, owner, np.hypot(*(pushed - discs).T))
        return depth

    def _door_discs(self, root: np.ndarray, heading: np.ndarray | None = None,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The discs the door controller sees, and each one's crowd row: every body's disc, except
        that a pushed pram's rigid footprint is seen as the discs that hold its ellipse
        (:func:`pedvr.crowd.footprint.covering_discs`) instead of its pusher's disc."""
        c = self.crowd
        n = len(c)
        rows = np.flatnonzero(c.length > 0.0)
        if not rows.size:
            return root, c.radius, np.arange(n)
        heading = self._root_heading if heading is None else heading
        fp = footprints(root, c.radius, c.turn, c.torso, heading, c.ahead, c.length)
        pos, rad, own = covering_discs(fp, rows)
        radius = c.radius.copy()
        radius[rows] = 0.0
        return np.concatenate([root, pos]), np.concatenate([radius, rad]), np.concatenate([np.arange(n), own])

    def _push_out(self, root: np.ndarray) -> tuple[np.ndarray, float]:
        """``DoorLeaves.push_out`` over :meth:`_door_discs`: each body moves with the largest push
        on any of its discs (a pram and its pusher move as one)."""
        discs, rad, owner = self._door_discs(root)
        pushed, overlap = self.doors.push_out(discs, rad, ~self.crowd.is_user[owner])
        if discs.shape[0] == root.shape[0]:
            return pushed, overlap
        move = pushed - discs
        mag = np.hypot(move[:, 0], move[:, 1])
        out = root.copy()
        for k in np.lexsort((mag, owner)):  # per row, the largest push comes last
            if mag[k] > 0.0:
                out[owner[k]] = root[owner[k]] + move[k]
        return out, overlap

    def _sync(self) -> None:
        """The 2D agent takes the position and heading of its body's root (the body is the truth)."""
        crowd = self.crowd
        # The velocity is the body's actual motion, contacts included (position-based dynamics),
        # in both conditions: the next step's ORCA sees a blocked neighbour as blocked, and a
        # coupled body's motion limits start from what it really did. (Until issue 26 a coupled
        # body kept its commanded velocity: an agent held back at a corner or behind a neighbour
        # went on "walking" into it, its acceleration limits centred on a speed it did not have;
        # at the 0.7 m corridor entrance 18 of 111 passed in 40 s, with this 33.)
        # A push can make it faster than the body walks; it keeps at most its max speed (else its
        # acceleration limits would lie outside what it can walk, and the linear program drop them).
        n = len(crowd)
        pos, vel = np.empty((n, 2)), np.empty((n, 2))  # new arrays: the old ones may be held
        sync_kernel(np.ascontiguousarray(self._root, np.float64), crowd.pos, crowd.vel, crowd.max_speed,
                    crowd.is_user, float(self.dt), pos, vel)
        crowd.pos = pos
        crowd.vel = vel
        crowd.heading = self._root_heading
        self.t = (self.step_index + 1) * self.dt
        self.step_index += 1

    def _record(self) -> None:
        self.metrics.observe(self.crowd, prev_vel=self._prev_vel, prev_heading=self._prev_heading, dt=self.dt)
        goal = self.behavior.goal
        wants = ~self.crowd.is_user & (np.hypot(*(goal - self.crowd.pos).T) > STALL_GOAL_DIST)  # NaN: no goal
        self.metrics.observe_progress(self.crowd.ids, self.crowd.pos, wants, self.t)
        self.metrics.observe_body(self.crowd, pelvis=self.body.state.world_pos[:, 0],
                                  seated=self.body.state.sitting)
        if self.recording is not None:
            self.recording.add(self.t, self.crowd, self.doors.angle)

    def add_agents(self, profile: str, positions: np.ndarray, *, state: str,
                   facing: float | None = None) -> np.ndarray:
        """Add agents between steps; returns their new stable ids."""
        if profile not in self.scene.profiles:
            raise UsageError(f"profile {profile!r}: unknown; known: {', '.join(sorted(self.scene.profiles))}")
        if state not in self.bfsm.ids:
            raise UsageError(f"state {state!r}: unknown; known: {', '.join(self.bfsm.names)}")
        prof = self.scene.profiles[profile]
        pts = np.asarray(positions, np.float64).reshape(-1, 2)
        first = self._next_id
        for p in pts:
            heading = np.nan if facing is None else facing
            self._add_rows(1, pos=p[None], radius=prof.radius, pref_speed=prof.pref_speed,
                           max_speed=prof.max_speed, limits=_limits_row(prof), is_user=False,
                           heading=np.asarray([heading]), state=state,
                           profile=list(self.scene.profiles).index(profile))
        self._face_unset()
        return np.arange(first, self._next_id, dtype=np.int64)

    def remove_agents(self, ids: np.ndarray | list[int]) -> None:
        """Remove virtual agents by id between steps (the user cannot be removed)."""
        drop = np.isin(self.crowd.ids, np.asarray(ids)) & ~self.crowd.is_user
        self._drop_rows(drop)

    def _remove_leaving(self) -> None:
        self._drop_rows(self._leaving)

    def _sources_and_sinks(self) -> None:
        """Between steps: agents inside a sink leave; each source's due agents enter where a spot
        is free of every body and of the user (else they wait; :mod:`pedvr.inflow`)."""
        inflow = self.inflow
        if inflow.sinks:
            sunk = inflow.sunk(self.crowd, self.behavior.state)
            if sunk.any():
                inflow.removed += int(np.count_nonzero(sunk))
                self._drop_rows(sunk)
        added = False
        for k, src in enumerate(inflow.sources):
            owed = inflow.owed(k, self.t, self.rng)
            if not owed:
                continue
            prof = self.scene.profiles[src.profile]
            mesh = self.navmesh_for(prof.radius)
            centres, reach = bounding_discs(self.crowd)
            spots = inflow.place(k, owed, centres=centres, reach=reach, radius=prof.radius, rng=self.rng,
                                 on_mesh=mesh.contains)
            index = list(self.scene.profiles).index(src.profile)
            for p in spots:
                heading = np.nan if src.facing is None else src.facing
                self._add_rows(1, pos=np.asarray([p]), radius=prof.radius, pref_speed=prof.pref_speed,
                               max_speed=prof.max_speed, limits=_limits_row(prof), is_user=False,
                               heading=np.asarray([heading]), state=src.state, profile=index)
            inflow.entered(k, len(spots), self.t)
            added |= bool(spots)
        if added and self.step_index > 0:
            self._face_unset()

    def _drop_rows(self, drop: np.ndarray) -> None:
        if not drop.any():
            return
        keep = ~drop
        self.crowd.keep(keep)
        self.steering.forget_neighbors()
        self.encounters.keep(keep)
        self.body.keep(keep)
        if self.etiquette is not None:
            self.etiquette.keep(keep)
        self.behavior.keep(keep)
        self.paths = [p for p, k in zip(self.paths, keep, strict=True) if k]
        self.sequences = [s for s, k in zip(self.sequences, keep, strict=True) if k]
        self.cursor = self.cursor[keep]
        self.profile_index = self.profile_index[keep]
        self.stuck_time = self.stuck_time[keep]
        self.backing = self.backing[keep]
        self._flat = None
        self._leaving = np.zeros(len(self.crowd), np.bool_)

    # -- results ---------------------------------------------------------------------------

    def summary(self) -> dict[str, object]:
        out = self.metrics.summary()
        out.update({
            "scene": self.scene.name,
            "scene_hash": self.scene.content_hash,
            "seed": self.seed,
            "condition": self.condition,
            "responsibility": self.responsibility,
            "personal_space_m": self.personal_space,
            "user_walk": self.user_walk if self.user is not None else None,
            "dt": self.dt,
            "sim_time_s": round(self.t, 6),
            "unreachable_goals": self.unreachable_goals,
            "user_spheres_reached": None if self.user is None else self.user.sphere,
            "user_spheres_total": None if self.user is None else int(self.user.route.shape[0]),
        })
        if self.inflow.sources or self.inflow.sinks:
            out.update(self.inflow.summary(self.t))
        out.update(self.metrics.body_summary(slides=self.body.skate.slides(), steps=self.body.step_log))
        out.update(self.scheduler.summary())
        if self.etiquette is not None:
            out.update(self.etiquette.summary())
        else:
            out.update(DoorEtiquette.empty_summary())
        return out
