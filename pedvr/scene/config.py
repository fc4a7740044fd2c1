"""Frozen, validated scene configuration.

A scene file (TOML, or a SteerSuite XML case) is loaded into these types by
:mod:`pedvr.scene.loader` or :mod:`pedvr.scene.steersuite`; everything below
them (world, crowd, behavior, sim) reads only these types, never the file.

Units are SI (metres, seconds, radians). The ground plane is 2D ``(x, y)``;
in 3D (Y up) a ground point ``(x, y)`` sits at ``(x, 0, y)``, which is also
SteerSuite's x–z plane. Headings are measured counter-clockwise from +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from pedvr.behavior.spec import EventDef, ObjectDef, TreeDef, TriggerDef

Vec2 = tuple[float, float]

CONDITIONS = ("decoupled", "pedvr", "pedvr+g")
GESTURE_CLIPS = ("wave", "point", "shrug", "check_phone", "hands_in_pockets", "talk")
Condition = Literal["decoupled", "pedvr", "pedvr+g"]


@dataclass(frozen=True)
class Obstacle:
    """A static obstacle: a simple polygon, vertices counter-clockwise.

    ``kind`` says what it is for the renderer (``wall``, ``box``, ``table``,
    ``booth``, ``shop``, ``pillar``, ``plant``, ``polygon``); the simulation treats all
    kinds alike. ``height`` is only for drawing and occlusion in 3D.
    ``occlusion`` in (0, 1] is how much of what lies behind the obstacle it
    hides from view (1: opaque; a house plant 0.5, PLACE §4's partial occluder).
    """

    vertices: tuple[Vec2, ...]
    kind: str = "polygon"
    height: float = 1.0
    occlusion: float = 1.0


DOOR_KINDS = ("single", "double", "revolving")
DOOR_SWINGS = ("one_way", "both_ways")
DOOR_ROTATIONS = ("ccw", "cw")


@dataclass(frozen=True)
class Door:
    """A sprung hinged door or a revolving door filling a doorway (Huang & Terzopoulos §4, §4.5).

    ``span`` runs from one jamb to the other across the doorway; the doorway
    itself must be a gap between obstacles (walls), since the simulation
    navigates through it like any free space. Sides: ``+1`` is the left of
    ``span[0] -> span[1]``, ``-1`` its right.

    ``single``: one leaf hinged at ``span[hinge]``; ``double``: two mirrored
    leaves hinged at both jambs, meeting in the middle (the paper's double
    door is "two juxtaposed sprung single hinged doors", §4.5.2);
    ``revolving``: four panels turning about the middle of ``span`` (its
    diameter), inside a drum whose two curved walls the scene loader adds to
    the world's obstacles (§4.5.1). ``swing``: ``one_way`` leaves open only
    into their pull side ``pull`` (the paper's sprung door: pulled by the
    handle from that side, pushed by the bar from the other), ``both_ways``
    leaves are double-acting (pushed open from either side). ``closing_speed``
    (rad/s) caps the closer; ``sensing_range`` (m) is how far from the door
    pedestrians take part in its doorway ordering (§4.2). ``rotation`` is the
    revolving door's sense, seen from above (``ccw``: people keep right).
    ``height`` is the leaf's, for drawing; ``name`` names the door's smart
    object (``door_<k>`` by default).
    """

    span: tuple[Vec2, Vec2]
    kind: str = "single"
    height: float = 2.1
    swing: str = "one_way"
    hinge: int = 0
    pull: int = 1
    closing_speed: float = math.radians(120.0)
    sensing_range: float = 8.0
    rotation: str = "ccw"
    name: str = ""

    @property
    def width(self) -> float:
        return math.dist(self.span[0], self.span[1])


ETIQUETTE_DECISIONS = ("meu", "sampled")
KEEP_SIDES = ("right", "left")
CARRYING = ("none", "box", "perambulator")
# m: a perambulator pusher's radius is the half width of its pram-and-pusher footprint (§4.6,
# pedvr.crowd.footprint): it must hold the pram (0.54 m wide, pedvr.body.carry) with room to spare
# for a footprint of sensible length.
PRAM_MIN_RADIUS = 0.35
SEXES = ("female", "male")


@dataclass(frozen=True)
class EtiquetteConfig:
    """Doorway etiquette for every door of the scene (Huang & Terzopoulos §4–5; ``[etiquette]``).

    ``enabled`` False: no ordering or holding, every walker pushes doors open
    as it reaches them (the NH pusher of App. B.3). ``decisions``: ``meu``
    takes the most probable holding action (§5.2), ``sampled`` draws it with
    the simulation's generator. ``keep``: the door of a double door people
    prefer (§4.5.2, "right-hand preference"). ``wait_credit`` (m/s): in
    Alg. 1's proximity ``E(d_leader, t_wait) = d_leader - wait_credit * t_wait``
    each second waited counts as that many metres closer. ``user_patience``
    (s): an agent holding a door for the user who stops coming gives up after
    this long.
    """

    enabled: bool = True
    decisions: str = "meu"
    keep: str = "right"
    wait_credit: float = 0.5
    user_patience: float = 4.0


MARKING_KINDS = ("crosswalk",)
FLOORS = ("grid", "tiles", "wood", "carpet", "asphalt", "paving")


@dataclass(frozen=True)
class Marking:
    """Paint on the floor, for drawing only: a ``crosswalk`` (zebra stripes) of ``width`` metres
    across the line from ``start`` to ``end`` (the way people cross)."""

    kind: str
    start: Vec2
    end: Vec2
    width: float = 3.0


@dataclass(frozen=True)
class WorldConfig:
    """The static world: a rectangular walkable area, obstacles inside it, and doors.

    ``bounds`` is ``((xmin, ymin), (xmax, ymax))``; its border acts as a wall.
    The rest is for drawing only (issue 16): ``indoor`` worlds have walls of
    ``wall_height`` along the bounds (default 2.6 m; outdoors a 1.1 m barrier)
    and, with ``ceiling``, a ceiling on top; ``floor`` names the floor's
    material; ``markings`` are painted on the floor.
    """

    bounds: tuple[Vec2, Vec2]
    obstacles: tuple[Obstacle, ...] = ()
    doors: tuple[Door, ...] = ()
    indoor: bool = False
    wall_height: float = 2.6
    ceiling: bool = False
    floor: str = "grid"
    markings: tuple[Marking, ...] = ()


@dataclass(frozen=True)
class MotionLimits:
    """What a walking body can do, as used by coupled steering (PedVR §4.1).

    The turn-rate limit falls linearly with speed, from ``turn_rate_standing``
    at rest to ``turn_rate_walking`` at ``pref_speed`` and beyond: people
    pivot on the spot quickly but turn slowly at a walk.
    """

    # m/s^2, speeding up. Not a paper's constant (PedVR §4.1 gives none); issue 26 chose it from
    # people's figures: pedestrians starting from standing at signal-controlled crosswalks average
    # 0.14 ± 0.09 g (1.37 ± 0.88 m/s², 288 people; Fugger, Randles et al., SAE 2001-01-0896 and the
    # group's companion study), so a limit of 1.5 (pedvr's before) let nobody speed up faster than
    # the average person averages. 2.2 is that mean plus one standard deviation, below the 2.5 a
    # relaxation time of 0.54 s gives from standing at 1.34 m/s (Moussaïd et al. 2009). Against the
    # Jülich corridors (seeds 1-4): 1.5 left uo_070 and uo_100 27 % short of the real flow, 2.2
    # -17 % and -11 %, 2.5 -8 % and -9 % with uo_145 +18 % (README, issue 26, change 10).
    max_accel: float = 2.2
    max_decel: float = 2.5  # m/s^2, slowing down
    turn_rate_standing: float = 3.0  # rad/s
    turn_rate_walking: float = 1.6  # rad/s
    max_backward_speed: float = 0.5  # m/s, stepping back
    max_sideways_speed: float = 0.6  # m/s, side-stepping


@dataclass(frozen=True)
class AgentProfile:
    """Per-agent physical and steering parameters (PedVR §3.1: the disc)."""

    name: str
    radius: float = 0.25
    pref_speed: float = 1.3
    max_speed: float = 1.6
    limits: MotionLimits = field(default_factory=MotionLimits)
    # Drawing only (issue 16): characters an agent of this profile is drawn as, picked per agent:
    # "builtin" (the procedural character) or glTF/VRM files; empty: the procedural character.
    characters: tuple[str, ...] = ()
    # Door etiquette (Huang & Terzopoulos §5.1.3, §4.6): Kindness and Rush as uniform ranges
    # [lo, hi] drawn per agent (lo == hi: fixed), the body's sex ("female", "male", or "" drawn
    # 50/50 by the body), and what the agent carries ("none", "box", "perambulator").
    kindness: tuple[float, float] = (0.2, 0.9)
    rush: tuple[float, float] = (0.0, 0.6)
    sex: str = ""
    carrying: str = "none"


# A body that turned its shoulders to squeeze past: its half depth front to back over its radius
# (chest depth 0.26 m beside a 0.50 m shoulder width; pedvr.crowd.footprint).
TURNED_DEPTH_RATIO = 0.52


@dataclass(frozen=True)
class SteeringParams:
    """ORCA parameters shared by every agent (van den Berg et al. 2011)."""

    neighbor_dist: float = 5.0
    max_neighbors: int = 10
    time_horizon: float = 2.0
    time_horizon_obst: float = 1.0
    user_responsibility: float = 1.0  # share ρ of each encounter's avoidance an agent takes toward the user
    personal_space: float = 0.3  # m added to the user's radius for avoidance (not for contact)
    user_safety: bool = True  # the late safety step toward the user (off: pure ρ, contacts possible)
    user_safety_horizon: float = 1.0  # s: horizon of that safety step
    # Coupled mode (issue 26): a walking body's half depth front to back as a share of its
    # radius, the footprint an ellipse along its heading (1: the disc; pedvr.crowd.footprint)
    depth_ratio: float = 0.72
    # Coupled mode (issue 26): the time gap (s) kept to whoever walks ahead in one's lane going
    # one's way; the preferred speed is the free distance to them over it (pedvr.crowd.headway)
    time_gap: float = 0.3
    # Coupled mode (issue 26): in ORCA's dense case, how much more (m/s) than the least violation
    # an agent may violate its neighbours' lines to keep toward its goal (0: the paper's §5.3;
    # pedvr.crowd.orca.toward_preferred), pressing only on neighbours it would push the way they
    # go: at the validation openings 7-14 % more flow (seeds 1-4); pressing on everyone, standing
    # and oncoming people were shoved backwards past their limits in shibuya_crossing (0.69 and
    # 0.80 m/s, limit 0.5)
    dense_slack: float = 0.1
    # Coupled mode (issue 26): the obstacle horizon (s) of agents outside a door's etiquette and
    # away from the user and door leaves (pedvr.crowd.orca.obstacle_horizon; there, and in
    # decoupled's plain ORCA, time_horizon_obst; never longer than it). About the time a walker
    # needs to brake (1.34 m/s at 2.5 m/s²: 0.54 s); with 1 s people slowed at the edges of an
    # opening a second before they reached them (bottleneck_050 0.80 /s, real 1.16).
    time_horizon_obst_coupled: float = 0.5


@dataclass(frozen=True)
class GoalSelector:
    """How a BFSM state picks a goal (PedVR §4.3; Menge's goal selectors).

    ``kind`` names a registered selector (see :mod:`pedvr.behavior.goals`);
    ``params`` are its validated parameters.
    """

    kind: str
    params: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class Transition:
    """A BFSM transition: ``on`` is ``arrival``, ``timer`` or ``probability``.

    ``timer`` fires ``after`` seconds (a number or a ``[lo, hi]`` uniform range)
    after entering the state; ``probability`` is checked at each decision tick
    with the given per-second rate; ``arrival`` fires when the agent is within
    ``arrive_dist`` of its goal. When several targets are listed with
    ``weights``, the next state is drawn from them.
    """

    on: str
    to: tuple[str, ...]
    weights: tuple[float, ...] = ()
    after: tuple[float, float] = (0.0, 0.0)
    rate: float = 0.0


@dataclass(frozen=True)
class StateConfig:
    """One BFSM state: a goal (or none: stand still), and transitions out."""

    name: str
    goal: GoalSelector | None
    transitions: tuple[Transition, ...] = ()
    speed_scale: float = 1.0
    arrive_dist: float = 0.3
    final: bool = False  # entering a final state removes the agent (it has left)
    # PedVR §4.3: the gesture set of this state, (clip names, weights); None: the body's defaults
    gestures: tuple[tuple[str, ...], tuple[float, ...]] | None = None
    tree: str | None = None  # a personal behavior tree run while in this state (pedvr.behavior.scheduler)


@dataclass(frozen=True)
class GoalSet:
    """Named points with weights, for the ``set`` goal selector."""

    name: str
    points: tuple[Vec2, ...]
    weights: tuple[float, ...]


@dataclass(frozen=True)
class BehaviorConfig:
    states: dict[str, StateConfig]
    goal_sets: dict[str, GoalSet] = field(default_factory=dict)
    decision_hz: float = 30.0
    # ADAPT §6: parameterized trees, multi-actor events, smart objects, triggers (pedvr.behavior)
    trees: dict[str, TreeDef] = field(default_factory=dict)
    events: dict[str, EventDef] = field(default_factory=dict)
    objects: tuple[ObjectDef, ...] = ()
    triggers: tuple[TriggerDef, ...] = ()


@dataclass(frozen=True)
class SequenceGoal:
    """One entry of a per-agent goal sequence (SteerSuite's ``goalSequence``).

    ``kind`` is ``seek`` (walk to ``target``), ``flee`` (walk away from
    ``target``), ``idle`` (stand for ``duration`` s) or ``flow`` (walk along the
    direction ``target`` for ``duration`` s). ``speed`` is the desired speed.
    """

    kind: str
    target: Vec2 = (0.0, 0.0)
    speed: float = 1.3
    duration: float = 0.0


@dataclass(frozen=True)
class Spawn:
    """Agents placed at the start: explicit positions or ``count`` in a region.

    ``region`` is ``("box", (xmin, ymin, xmax, ymax))`` or
    ``("circle", (cx, cy, r))`` (points on the circle) or
    ``("disc", (cx, cy, r))`` (points inside it). Positions drawn from a
    region are drawn with the run's rng and kept apart by their radii.
    ``facing`` is a heading in radians, or None to face the first goal.
    """

    profile: str
    state: str
    positions: tuple[Vec2, ...] = ()
    count: int = 0
    region: tuple[str, tuple[float, ...]] | None = None
    facing: float | None = None
    goal_sequence: tuple[SequenceGoal, ...] = ()  # for the "sequence" goal selector
    friends: bool = False  # consecutive pairs of this spawn walk together (Huang & Terzopoulos §4.6)


SOURCE_TIMINGS = ("regular", "poisson")


@dataclass(frozen=True)
class Source:
    """Agents that keep arriving: ``rate`` per second into an area or along a line (a metered inflow).

    ``region`` is a :class:`Spawn` region (``box`` or ``disc``; points drawn inside it) or
    ``line`` ``((x0, y0), (x1, y1))`` (points drawn along it). ``timing``: ``regular`` (one
    agent every ``1 / rate`` s from ``start``) or ``poisson`` (exponential gaps of mean
    ``1 / rate``, drawn with the run's generator). ``max_count`` caps the agents it ever adds
    (0: no cap); ``stop`` (s) ends it (``inf``: never). An agent whose time has come waits
    until a spot in the area is free of every body and of the user (never spawned overlapping),
    then enters; the waiting agents enter first come first served, so a blocked source delays
    its inflow instead of dropping it. ``facing`` is a heading in radians, or None to face the
    first goal.
    """

    profile: str
    state: str
    rate: float
    region: tuple[str, tuple[float, ...]] | None = None
    line: tuple[Vec2, Vec2] | None = None
    max_count: int = 0
    start: float = 0.0
    stop: float = math.inf
    timing: str = "regular"
    facing: float | None = None


@dataclass(frozen=True)
class Sink:
    """An exit region: a virtual agent whose position enters it is removed (it has left the scene).

    ``region`` is ``("box", (xmin, ymin, xmax, ymax))`` or ``("disc", (cx, cy, r))``. The user
    is never removed. ``states``: when not empty, only agents in one of these BFSM states leave
    by it (an exit for those walking one way; someone of the other stream pushed into it stays)."""

    region: tuple[str, tuple[float, ...]]
    states: tuple[str, ...] = ()


USER_WALKS = ("straight", "reactive")


@dataclass(frozen=True)
class UserConfig:
    """The user agent: where it starts and the red-sphere route it follows.

    In headless runs a scripted user walks the route along the navigation
    mesh at ``speed``; interactive backends feed the same interface. ``walk``
    says how the scripted user walks: ``straight`` (the route, whatever
    happens: the reference for the responsibility trials) or ``reactive``
    (like a person: it steps aside for pedestrians about to come too close,
    after a reaction delay; see :class:`pedvr.crowd.user.ReactiveUser`).
    """

    start: Vec2
    heading: float = 0.0
    radius: float = 0.25
    speed: float = 1.3
    route: tuple[Vec2, ...] = ()
    sphere_radius: float = 0.5
    enabled: bool = True
    walk: str = "straight"
    # Door etiquette (Huang & Terzopoulos Table 3): what agents read for the user's Care, and
    # whether the scripted user holds doors it opens for this long (s; 0: it walks through).
    sex: str = "male"
    carrying: str = "none"
    door_hold: float = 0.0


@dataclass(frozen=True)
class SceneConfig:
    """A whole scene, validated. ``source`` is the file it came from."""

    name: str
    source: str
    seed: int
    dt: float
    duration: float
    world: WorldConfig
    profiles: dict[str, AgentProfile]
    spawns: tuple[Spawn, ...]
    behavior: BehaviorConfig
    user: UserConfig
    steering: SteeringParams = field(default_factory=SteeringParams)
    gaze_distance: float = 4.0  # D1 of PedVR eq. 3, metres
    gaze_speed: float = 2.0  # D2 of PedVR eq. 3, m/s
    description: str = ""
    content_hash: str = ""
    bone_map: dict[str, str] = field(default_factory=dict)  # avatars' bone name -> pedvr joint
    etiquette: EtiquetteConfig = field(default_factory=EtiquetteConfig)  # door etiquette ([etiquette])
    sources: tuple[Source, ...] = ()  # agents arriving at a rate ([[agents.sources]])
    sinks: tuple[Sink, ...] = ()  # exit regions that remove agents ([[agents.sinks]])

    @property
    def decision_every(self) -> int:
        """Steps between behavior decisions (30 Hz at the default 90 Hz step)."""
        return max(1, round(1.0 / (self.behavior.decision_hz * self.dt)))


def default_dt() -> float:
    return 1.0 / 90.0


def heading_of(v: Vec2) -> float:
    return math.atan2(v[1], v[0])
