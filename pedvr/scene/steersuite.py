"""Import SteerSuite (SteerBench) XML test cases as a :class:`SceneConfig`.

SteerSuite's walking plane is x–z with y up; a SteerSuite point ``(x, y, z)``
becomes the pedvr ground point ``(x, z)`` and ``y`` is dropped (it only gives
obstacle heights). Units are SteerSuite's: metres, seconds, degrees for
``thetaY``.

What is imported, and how (SteerSuite's ``TestCaseReader`` is the reference):

* ``header``: ``description``, ``worldBounds``; the scene is named after the file
  (headers' names are often copy-paste leftovers).
  ``version`` must be 1.0, 1.1 or 1.2, as SteerSuite's reader demands.
* ``obstacle`` (axis-aligned box) → a counter-clockwise 4-gon, ``kind="box"``,
  ``height = ymax - ymin`` (0 is kept: some cases use flat walls).
* ``orientedBoxObstacle`` (``thetaY``, ``size``, ``position``) → a rectangle
  ``size.x`` by ``size.z`` centred on ``position``, height ``size.y``. Sign
  convention: SteerSuite rotates the corner offsets with
  ``Util::rotateInXZPlane(p, θ) = (x cosθ + z sinθ, z cosθ − x sinθ)``, a
  right-handed rotation by ``θ`` about +y. In pedvr's ground frame ``(x, z)``
  (counter-clockwise positive) that is a rotation by **−θ**: a positive
  ``thetaY`` turns the box clockwise, from +x toward −z.
* ``circleObstacle`` (``radius``, ``height``, ``position``) → a regular
  16-gon *circumscribing* the circle (vertex radius ``r / cos(π/16)``), so the
  true disc is inside the polygon, ``kind="pillar"``.
* ``obstacleRegion`` → ``numObstacles`` square boxes of side ``obstacleSize``
  placed uniformly inside ``regionBounds`` (whole square inside), rejecting
  squares that overlap an obstacle or an explicitly placed agent.
* ``agent`` → one :class:`Spawn` in state ``seek`` with its single position,
  ``facing = atan2(dir_z, dir_x)`` (``None`` for a zero direction) and its
  goal sequence. The initial ``speed`` is read and checked but not used:
  pedvr agents start at rest.
* ``agentRegion`` → one :class:`Spawn` with ``count = numAgents`` and
  ``region = ("box", (xmin, zmin, xmax, zmax))``; the simulation draws those
  positions with the run's rng. A random ``direction`` in a region gives
  ``facing = None`` (face the first goal). When a region's goals need a
  *per-agent* random draw (a ``<random>`` target or a
  ``seekAxisAlignedBoxRegion``), one shared goal sequence cannot express it,
  so the region is expanded here into ``numAgents`` single-agent spawns with
  positions, facings and targets drawn as below.
* Goals: ``seekStaticTarget`` → ``seek``; ``fleeStaticTarget`` → ``flee``;
  ``idle`` → ``idle`` (for ``timeDuration``); ``flowStaticDirection`` →
  ``flow`` with ``target`` = the ``(x, z)`` direction;
  ``seekAxisAlignedBoxRegion`` → ``seek`` to a point drawn uniformly in
  ``goalRegionBounds`` (SteerSuite seeks ``targetLocation`` and counts
  arrival when the disc touches the box; a spread of points in the box is the
  closest a point goal gets to that). ``timeDuration`` defaults to 100000 s
  when absent, as in SteerSuite. ``Behaviour``, ``state``, ``flowType`` and a
  ``targetDirection`` on a seek goal are SteerSuite extensions for choosing
  the steering algorithm per goal; they are ignored.
* Not supported, each reported as a :class:`SceneError` line naming the
  element: ``agentEmitter`` (agents spawned over time),
  ``seekDynamicTarget`` / ``fleeDynamicTarget`` (targets are other agents),
  ``flowDynamicDirection``, ``polygonObstacle``, ``orientedWallObstacle``,
  and any element SteerSuite does not define.

``<random>true</random>`` in place of a vector is expanded *here*, with
``numpy.random.default_rng(seed)`` where ``seed`` is the run's seed, so the
same seed gives the same scene. Draws happen in document order: first the
obstacle regions, then agents and expanded regions. A random position lies
inside the world bounds (for a region: inside its box), inset by the agent
radius where the box is wide enough, and is rejected and redrawn while the
disc overlaps an obstacle or an already placed agent (shapely tests the
obstacle polygons); a random direction is a uniform heading; a random target
lies inside the world bounds and at least the agent radius from obstacles.
After 1000 rejected draws the case is reported as too full.

SteerSuite's bounds are sometimes inverted (``xmin > xmax``, e.g.
``circle-20``, ``office-complex``); every box is read with its two ends
sorted. If the world bounds then do not contain every explicit agent, goal
target and agent region (``circle-20``'s do not), they are grown to contain
them plus a 2 m margin; huge bounds (±100 m around a 20 m scene) are kept.

Behaviour: all agents start in state ``seek``, whose ``sequence`` goal
selector walks the spawn's ``goal_sequence``; its ``arrival`` transition to
the final state ``exit`` fires only after the last goal, and a final state
removes the agent, as SteerSuite disables an agent at its last goal.
SteerSuite's AIs count a goal reached when the distance falls below about one
agent radius. Several agents often share one target point; at one radius
they then ring it, each blocking the others (seen in 4-way-oncomming). So
``arrive_dist`` is twice the largest agent radius of the case, at least 1 m:
the disc overlaps the target by its own size.

Profiles: one :class:`AgentProfile` per distinct (radius, speeds), named
``steersuite_r0.50`` (``_v1.30`` is appended when agents of one radius have
different speeds). ``pref_speed`` is the first goal's ``desiredSpeed``
(at least 0.1 m/s); ``max_speed = max(1.25 v, v + 0.3)`` where ``v`` is the
largest desired speed of the agent's goals.

The user is disabled (SteerSuite cases have none) and starts at a free point
near the world corner farthest from the agents. ``duration`` is the largest
sum of an agent's finite goal durations, clamped to [30 s, 120 s].
"""

from __future__ import annotations

import hashlib
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from pedvr.errors import SceneError
from pedvr.scene.config import (
    AgentProfile,
    BehaviorConfig,
    GoalSelector,
    Obstacle,
    SceneConfig,
    SequenceGoal,
    Spawn,
    StateConfig,
    SteeringParams,
    Transition,
    UserConfig,
    Vec2,
    WorldConfig,
    default_dt,
)

NAMESPACE = "http://www.magix.ucla.edu/steerbench"
SUPPORTED_VERSIONS = ("1.0", "1.1", "1.2")
CIRCLE_SEGMENTS = 16
MAX_TRIES = 1000  # draws per random placement before giving up, as SteerSuite
DEFAULT_TIME_DURATION = 100000.0  # s, SteerSuite's default for a goal
MIN_PREF_SPEED = 0.1  # m/s
BOUNDS_MARGIN = 2.0  # m, added when the world bounds are grown
MIN_DURATION, MAX_DURATION = 30.0, 120.0  # s

_GOAL_KINDS = {
    "seekStaticTarget": "seek",
    "fleeStaticTarget": "flee",
    "idle": "idle",
    "flowStaticDirection": "flow",
    "seekAxisAlignedBoxRegion": "box",
}
_UNSUPPORTED_GOALS = {
    "seekDynamicTarget": "dynamic targets are not supported (the target is another agent)",
    "fleeDynamicTarget": "dynamic targets are not supported (the target is another agent)",
    "flowDynamicDirection": "dynamic flow directions are not supported",
    "groupTarget": "group targets are not supported",
}
_UNSUPPORTED_TOP = {
    "agentEmitter": "agent emitters are not supported (agents spawned over time)",
    "polygonObstacle": "polygon obstacles are not supported by this importer",
    "orientedWallObstacle": "oriented wall obstacles (with doorways) are not supported",
}
# Per-goal SteerSuite extensions that only choose a steering algorithm.
_IGNORED_GOAL_CHILDREN = {"Behaviour", "state", "flowType", "type", "targetName"}

_RANDOM = "random"  # marker: the vector was <random>true</random>

Box = tuple[float, float, float, float]  # (xmin, zmin, xmax, zmax)


def load_steersuite(path: str | Path, *, seed: int) -> SceneConfig:
    """Read a SteerSuite XML test case into a validated :class:`SceneConfig`.

    ``seed`` is the run's seed: it seeds ``np.random.default_rng(seed)``,
    which expands every ``<random>`` vector and places ``obstacleRegion``
    boxes, and it is stored as ``SceneConfig.seed``. Same file and seed, same
    config.

    Raises :class:`SceneError` listing every problem found, one line each,
    ``FILE: element.path = value: expectation``; malformed XML gives one line
    with the parser's line and column. See the module docstring for what is
    imported and how.
    """
    return _Importer(Path(path), seed).load()


# --------------------------------------------------------------------------- parsing


@dataclass
class _Goal:
    path: str
    kind: str  # seek, flee, idle, flow, box
    target: Vec2 | str | None  # a point/direction, _RANDOM, or None (idle)
    speed: float
    duration: float
    box: Box | None = None  # for kind "box"


@dataclass
class _Agent:
    path: str
    radius: float
    position: Vec2 | str | None  # _RANDOM; None for a region
    direction: Vec2 | str  # (dx, dz) or _RANDOM
    goals: list[_Goal]
    region: Box | None = None
    count: int = 1


@dataclass
class _Case:
    name: str = ""
    description: str = ""
    bounds: Box | None = None
    obstacles: list[Obstacle] = field(default_factory=list)
    obstacle_regions: list[tuple[str, int, float, float, Box]] = field(default_factory=list)
    agents: list[_Agent] = field(default_factory=list)


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _strip_late_declaration(text: str) -> str:
    """Blank out an ``<?xml ...?>`` that follows leading comments.

    Several SteerSuite files put a licence comment before the declaration,
    which XML forbids; blanking it (same length, newlines kept) keeps the
    parser's line and column numbers true to the file.
    """
    m = re.match(r"\A(?:\s*<!--.*?-->)+\s*(<\?xml[^>]*\?>)", text, re.DOTALL)
    if not m:
        return text
    a, b = m.span(1)
    return text[:a] + " " * (b - a) + text[b:]


class _Importer:
    def __init__(self, path: Path, seed: int) -> None:
        self.path = path
        self.label = str(path)
        self.seed = seed
        self.problems: list[str] = []

    # ---- problem reporting

    def problem(self, where: str, expectation: str, value: object = None) -> None:
        if value is None:
            self.problems.append(f"{self.label}: {where}: {expectation}")
        else:
            self.problems.append(f"{self.label}: {where} = {value}: {expectation}")

    # ---- small readers; each returns None after reporting a problem

    def children(self, el: ET.Element, where: str, known: set[str]) -> dict[str, ET.Element]:
        """Singleton children by local name; unknown and repeated ones are problems."""
        out: dict[str, ET.Element] = {}
        for c in el:
            name = _local(c.tag)
            if name not in known:
                self.problem(f"{where}.{name}", f"unknown element; expected one of "
                             f"{', '.join(sorted(known))}")
            elif name in out:
                self.problem(f"{where}.{name}", "given more than once")
            else:
                out[name] = c
        return out

    def need(self, kids: dict[str, ET.Element], name: str, where: str) -> ET.Element | None:
        el = kids.get(name)
        if el is None:
            self.problem(f"{where}.{name}", "required", "<missing>")
        return el

    def number(self, el: ET.Element | None, where: str, *, check: str = "") -> float | None:
        if el is None:
            return None
        text = (el.text or "").strip()
        try:
            v = float(text)
        except ValueError:
            self.problem(where, "expected a number", repr(text))
            return None
        if math.isnan(v):
            self.problem(where, "expected a number", text)
            return None
        if check == ">0" and not v > 0:
            self.problem(where, "must be > 0", text)
            return None
        if check == ">=0" and not v >= 0:
            self.problem(where, "must be >= 0", text)
            return None
        if check != "inf" and math.isinf(v):
            self.problem(where, "must be finite", text)
            return None
        return v

    def count(self, el: ET.Element | None, where: str) -> int | None:
        if el is None:
            return None
        text = (el.text or "").strip()
        if not text.isdigit():
            self.problem(where, "expected a whole number >= 0", repr(text))
            return None
        return int(text)

    def xyz(self, el: ET.Element | None, where: str, *, allow_random: bool = True
            ) -> tuple[float, float, float] | str | None:
        """``<x/><y/><z/>`` or ``<random>true</random>``, as SteerSuite reads them."""
        if el is None:
            return None
        kids = self.children(el, where, {"x", "y", "z", "random"})
        rnd = kids.get("random")
        is_random = False
        if rnd is not None:
            flag = (rnd.text or "").strip()
            if flag not in ("true", "false"):
                self.problem(f"{where}.random", "expected true or false", repr(flag))
                return None
            is_random = flag == "true"
        given = [k for k in ("x", "y", "z") if k in kids]
        if is_random:
            if given:
                self.problem(where, "either <x>, <y>, <z> or <random>true</random>, not both")
                return None
            if not allow_random:
                self.problem(where, "must not be random")
                return None
            return _RANDOM
        if len(given) != 3:
            self.problem(where, "expected <x>, <y> and <z> (or <random>true</random>)")
            return None
        vals = [self.number(kids[k], f"{where}.{k}") for k in ("x", "y", "z")]
        if any(v is None for v in vals):
            return None
        x, y, z = (float(v) for v in vals)  # type: ignore[arg-type]
        return (x, y, z)

    def bounds(self, el: ET.Element | None, where: str) -> tuple[float, ...] | None:
        """``xmin xmax ymin ymax zmin zmax``, each pair sorted."""
        if el is None:
            return None
        names = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
        kids = self.children(el, where, set(names))
        missing = [n for n in names if n not in kids]
        if missing:
            self.problem(where, f"missing {', '.join(missing)}; all six bounds are required")
            return None
        vals = [self.number(kids[n], f"{where}.{n}") for n in names]
        if any(v is None for v in vals):
            return None
        x0, x1, y0, y1, z0, z1 = (float(v) for v in vals)  # type: ignore[arg-type]
        return (min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1), min(z0, z1), max(z0, z1))

    # ---- document

    def load(self) -> SceneConfig:
        try:
            data = self.path.read_bytes()
        except OSError as e:
            raise SceneError([f"{self.label}: cannot read: {e.strerror or e}"]) from None
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise SceneError([f"{self.label}: not UTF-8 text (byte {e.start})"]) from None
        try:
            root = ET.fromstring(_strip_late_declaration(text))
        except ET.ParseError as e:
            line, col = e.position
            raise SceneError([f"{self.label}: malformed XML at line {line}, column {col + 1}: "
                              f"{str(e).split(':')[0]}"]) from None
        if root.tag not in (f"{{{NAMESPACE}}}SteerBenchTestCase", "SteerBenchTestCase"):
            raise SceneError([f"{self.label}: root element = {root.tag}: expected "
                              f"SteerBenchTestCase in namespace {NAMESPACE}"])

        case = self.parse(root)
        if self.problems:
            raise SceneError(self.problems)
        scene = self.build(case, data)
        if self.problems:
            raise SceneError(self.problems)
        return scene

    def parse(self, root: ET.Element) -> _Case:
        case = _Case()
        index: dict[str, int] = {}
        seen_header = False
        for el in root:
            name = _local(el.tag)
            k = index.get(name, 0)
            index[name] = k + 1
            where = f"{name}[{k}]"
            if name == "header":
                if seen_header:
                    self.problem("header", "given more than once")
                seen_header = True
                self.header(el, case)
            elif not seen_header:
                self.problem(where, "<header> must come first")
            elif name == "suggestedCameraView":
                pass  # a viewing hint only
            elif name == "obstacle":
                self.box_obstacle(el, where, case)
            elif name == "orientedBoxObstacle":
                self.oriented_box(el, where, case)
            elif name == "circleObstacle":
                self.circle(el, where, case)
            elif name == "obstacleRegion":
                self.obstacle_region(el, where, case)
            elif name == "agent":
                self.agent(el, where, case)
            elif name == "agentRegion":
                self.agent_region(el, where, case)
            elif name in _UNSUPPORTED_TOP:
                self.problem(where, _UNSUPPORTED_TOP[name])
            else:
                self.problem(where, "unknown element; expected header, suggestedCameraView, "
                             "obstacle, orientedBoxObstacle, circleObstacle, obstacleRegion, "
                             "agent or agentRegion")
        if not seen_header:
            self.problem("header", "required", "<missing>")
        return case

    def header(self, el: ET.Element, case: _Case) -> None:
        kids = self.children(el, "header", {"version", "name", "description", "worldBounds",
                                            "passingCriteria"})
        version = kids.get("version")
        if version is not None:
            v = (version.text or "").strip()
            if v not in SUPPORTED_VERSIONS:
                self.problem("header.version", f"expected one of {', '.join(SUPPORTED_VERSIONS)}",
                             repr(v))
        name = kids.get("name")
        case.name = " ".join((name.text or "").split()) if name is not None else ""
        desc = kids.get("description")
        case.description = " ".join((desc.text or "").split()) if desc is not None else ""
        b = self.bounds(self.need(kids, "worldBounds", "header"), "header.worldBounds")
        if b is not None:
            case.bounds = (b[0], b[4], b[1], b[5])

    def box_obstacle(self, el: ET.Element, where: str, case: _Case) -> None:
        b = self.bounds(el, where)
        if b is None:
            return
        x0, x1, y0, y1, z0, z1 = b
        if not (x0 < x1 and z0 < z1):
            self.problem(where, "needs xmin != xmax and zmin != zmax (a box with floor area)",
                         f"x {x0}..{x1}, z {z0}..{z1}")
            return
        verts = ((x0, z0), (x1, z0), (x1, z1), (x0, z1))
        case.obstacles.append(Obstacle(vertices=verts, kind="box", height=y1 - y0))

    def oriented_box(self, el: ET.Element, where: str, case: _Case) -> None:
        kids = self.children(el, where, {"thetaY", "size", "position"})
        theta = self.number(self.need(kids, "thetaY", where), f"{where}.thetaY")
        size = self.xyz(self.need(kids, "size", where), f"{where}.size", allow_random=False)
        pos = self.xyz(self.need(kids, "position", where), f"{where}.position",
                       allow_random=False)
        if theta is None or not isinstance(size, tuple) or not isinstance(pos, tuple):
            return
        lx, h, lz = size
        if not (lx > 0 and lz > 0 and h >= 0):
            self.problem(f"{where}.size", "x and z must be > 0 and y >= 0", f"{size}")
            return
        case.obstacles.append(Obstacle(
            vertices=oriented_box_vertices((pos[0], pos[2]), lx, lz, theta),
            kind="box", height=h))

    def circle(self, el: ET.Element, where: str, case: _Case) -> None:
        kids = self.children(el, where, {"radius", "height", "position"})
        r = self.number(self.need(kids, "radius", where), f"{where}.radius", check=">0")
        h = self.number(self.need(kids, "height", where), f"{where}.height", check=">=0")
        pos = self.xyz(self.need(kids, "position", where), f"{where}.position",
                       allow_random=False)
        if r is None or h is None or not isinstance(pos, tuple):
            return
        case.obstacles.append(Obstacle(vertices=circle_vertices((pos[0], pos[2]), r),
                                       kind="pillar", height=h))

    def obstacle_region(self, el: ET.Element, where: str, case: _Case) -> None:
        kids = self.children(el, where, {"numObstacles", "obstacleSize", "obstacleHeight",
                                         "regionBounds"})
        n = self.count(self.need(kids, "numObstacles", where), f"{where}.numObstacles")
        size = self.number(self.need(kids, "obstacleSize", where), f"{where}.obstacleSize",
                           check=">0")
        height = self.number(self.need(kids, "obstacleHeight", where),
                             f"{where}.obstacleHeight", check=">=0")
        region = self.region(kids, where)
        if n is None or size is None or height is None or region is None:
            return
        case.obstacle_regions.append((where, n, size, height, region))

    def region(self, kids: dict[str, ET.Element], where: str, name: str = "regionBounds"
               ) -> Box | None:
        b = self.bounds(self.need(kids, name, where), f"{where}.{name}")
        if b is None:
            return None
        x0, x1, _, _, z0, z1 = b
        if not (x0 < x1 and z0 < z1):
            self.problem(f"{where}.{name}", "needs xmin != xmax and zmin != zmax",
                         f"x {x0}..{x1}, z {z0}..{z1}")
            return None
        return (x0, z0, x1, z1)

    def initial_conditions(self, el: ET.Element | None, where: str, *, region: bool
                           ) -> tuple[float, Vec2 | str | None, Vec2 | str] | None:
        if el is None:
            return None
        where = f"{where}.initialConditions"
        known = {"radius", "direction", "speed", "color"} | (set() if region else {"position"})
        kids = self.children(el, where, known)
        radius = self.number(self.need(kids, "radius", where), f"{where}.radius", check=">0")
        self.number(kids.get("speed"), f"{where}.speed", check=">=0")
        pos: tuple[float, float, float] | str | None = None
        if not region:
            pos = self.xyz(self.need(kids, "position", where), f"{where}.position")
        d = self.xyz(self.need(kids, "direction", where), f"{where}.direction")
        if radius is None or d is None or (not region and pos is None):
            return None
        pos2 = (pos[0], pos[2]) if isinstance(pos, tuple) else pos
        d2 = (d[0], d[2]) if isinstance(d, tuple) else d
        return radius, pos2, d2

    def goal_sequence(self, el: ET.Element | None, where: str) -> list[_Goal] | None:
        if el is None:
            return None
        where = f"{where}.goalSequence"
        goals: list[_Goal] = []
        ok = True
        index: dict[str, int] = {}
        for g in el:
            name = _local(g.tag)
            k = index.get(name, 0)
            index[name] = k + 1
            gw = f"{where}.{name}[{k}]"
            if name in _UNSUPPORTED_GOALS:
                self.problem(gw, _UNSUPPORTED_GOALS[name])
                ok = False
            elif name not in _GOAL_KINDS:
                self.problem(gw, f"unknown goal; expected one of {', '.join(_GOAL_KINDS)}")
                ok = False
            else:
                goal = self.goal(g, gw, _GOAL_KINDS[name])
                if goal is None:
                    ok = False
                else:
                    goals.append(goal)
        if ok and not goals:
            self.problem(where, "needs at least one goal")
            return None
        return goals if ok else None

    def goal(self, el: ET.Element, where: str, kind: str) -> _Goal | None:
        known = {"targetLocation", "targetDirection", "random", "desiredSpeed", "timeDuration",
                 "goalRegionBounds"} | _IGNORED_GOAL_CHILDREN
        kids = self.children(el, where, known)
        speed = self.number(self.need(kids, "desiredSpeed", where), f"{where}.desiredSpeed",
                            check=">=0")
        duration: float | None = DEFAULT_TIME_DURATION
        if "timeDuration" in kids:
            duration = self.number(kids["timeDuration"], f"{where}.timeDuration", check="inf")
            if duration is not None and duration <= 0:
                self.problem(f"{where}.timeDuration", "must be > 0", duration)
                duration = None
        random_flag = False
        if "random" in kids:
            flag = (kids["random"].text or "").strip()
            if flag not in ("true", "false"):
                self.problem(f"{where}.random", "expected true or false", repr(flag))
                return None
            random_flag = flag == "true"
        target: Vec2 | str | None = None
        box: Box | None = None
        if kind in ("seek", "flee", "box"):
            t = self.xyz(self.need(kids, "targetLocation", where), f"{where}.targetLocation")
            if t is None:
                return None
            target = _RANDOM if random_flag or isinstance(t, str) else (t[0], t[2])
            if kind == "box":
                box = self.region(kids, where, "goalRegionBounds")
                if box is None:
                    return None
        elif kind == "flow":
            t = self.xyz(self.need(kids, "targetDirection", where), f"{where}.targetDirection")
            if t is None:
                return None
            if random_flag or isinstance(t, str):
                target = _RANDOM
            elif math.hypot(t[0], t[2]) == 0:
                self.problem(f"{where}.targetDirection", "must not be zero", t)
                return None
            else:
                target = (t[0], t[2])
        if speed is None or duration is None:
            return None
        return _Goal(where, kind, target, speed, duration, box)

    def agent(self, el: ET.Element, where: str, case: _Case) -> None:
        kids = self.children(el, where, {"name", "initialConditions", "goalSequence"})
        ic = self.initial_conditions(self.need(kids, "initialConditions", where), where,
                                     region=False)
        goals = self.goal_sequence(self.need(kids, "goalSequence", where), where)
        if ic is None or goals is None:
            return
        radius, pos, d = ic
        case.agents.append(_Agent(where, radius, pos, d, goals))

    def agent_region(self, el: ET.Element, where: str, case: _Case) -> None:
        kids = self.children(el, where, {"numAgents", "regionBounds", "initialConditions",
                                         "goalSequence"})
        n = self.count(self.need(kids, "numAgents", where), f"{where}.numAgents")
        region = self.region(kids, where)
        ic = self.initial_conditions(self.need(kids, "initialConditions", where), where,
                                     region=True)
        goals = self.goal_sequence(self.need(kids, "goalSequence", where), where)
        if n is None or region is None or ic is None or goals is None:
            return
        radius, _, d = ic
        case.agents.append(_Agent(where, radius, None, d, goals, region=region, count=n))

    # ------------------------------------------------------------------- building

    def build(self, case: _Case, data: bytes) -> SceneConfig:
        assert case.bounds is not None
        bounds = _grown_bounds(case)
        rng = np.random.default_rng(self.seed)
        placer = _Placer(bounds, case.obstacles, max((a.radius for a in case.agents),
                                                     default=0.5))
        for a in case.agents:
            if isinstance(a.position, tuple):
                placer.add_agent(a.position, a.radius)

        obstacles = list(case.obstacles)
        for where, n, size, height, region in case.obstacle_regions:
            for i in range(n):
                sq = placer.place_square(rng, region, size)
                if sq is None:
                    self.problem(where, f"could not place obstacle {i + 1} of {n} without "
                                 f"overlap after {MAX_TRIES} tries: the region is too full")
                    break
                x0, z0, x1, z1 = sq
                obstacles.append(Obstacle(((x0, z0), (x1, z0), (x1, z1), (x0, z1)),
                                          kind="box", height=height))

        profiles = _profile_names(case.agents)
        spawns: list[Spawn] = []
        placed: list[Vec2] = []
        for a in case.agents:
            if self.problems:
                break
            split = a.region is not None and any(
                g.target == _RANDOM or g.kind == "box" for g in a.goals)
            if a.region is not None and not split:
                if a.count == 0:
                    continue
                facing = _heading(a.direction) if isinstance(a.direction, tuple) else None
                shared = self.goals(a, rng)  # not split: nothing in them is random
                if shared is None:
                    break
                spawns.append(Spawn(profile=profiles[_profile_key(a)], state="seek",
                                    count=a.count, region=("box", a.region), facing=facing,
                                    goal_sequence=tuple(shared)))
                continue
            for i in range(a.count):
                pos = a.position
                if not isinstance(pos, tuple):
                    area = a.region if a.region is not None else bounds
                    pos = placer.place_disc(rng, area, a.radius)
                    if pos is None:
                        where = a.path if a.region is None else f"{a.path} agent {i + 1}"
                        self.problem(where, f"could not place the agent without overlap "
                                     f"after {MAX_TRIES} tries: too full")
                        break
                placed.append(pos)
                if a.direction == _RANDOM:
                    facing = _wrap(float(rng.uniform(0.0, 2.0 * math.pi)))
                else:
                    facing = _heading(a.direction)  # type: ignore[arg-type]
                goals = self.goals(a, rng, placer)
                if goals is None:
                    break
                spawns.append(Spawn(profile=profiles[_profile_key(a)], state="seek",
                                    positions=(pos,), facing=facing,
                                    goal_sequence=tuple(goals)))

        arrive = max([1.0] + [2.0 * a.radius for a in case.agents])
        behavior = BehaviorConfig(states={
            "seek": StateConfig("seek", GoalSelector("sequence", {}),
                                transitions=(Transition(on="arrival", to=("exit",)),),
                                arrive_dist=arrive),
            "exit": StateConfig("exit", None, final=True),
        })
        crowd: list[Box] = [(p[0], p[1], p[0], p[1]) for p in placed]
        for a in case.agents:
            if a.region is not None:
                crowd.append(a.region)
            crowd += [(g.target[0], g.target[1], g.target[0], g.target[1])
                      for g in a.goals if g.kind == "seek" and isinstance(g.target, tuple)]
        start = placer.user_start(crowd, clearance=0.25 + 0.05)
        if start is None:
            self.problem("header.worldBounds", "no free point for the (disabled) user")
            start = (bounds[0], bounds[1])

        durations = [sum(g.duration for g in a.goals if math.isfinite(g.duration))
                     for a in case.agents]
        duration = min(MAX_DURATION, max([MIN_DURATION, *durations]))
        profile_objs = {name: AgentProfile(name=name, radius=key[0], pref_speed=key[1],
                                           max_speed=key[2])
                        for key, name in profiles.items()}
        return SceneConfig(
            name=self.path.stem,  # headers are often copy-paste leftovers; the file name is not
            source=str(self.path),
            seed=self.seed,
            dt=default_dt(),
            duration=duration,
            world=WorldConfig(bounds=((bounds[0], bounds[1]), (bounds[2], bounds[3])),
                              obstacles=tuple(obstacles)),
            profiles=profile_objs,
            spawns=tuple(spawns),
            behavior=behavior,
            user=UserConfig(start=start, enabled=False),
            steering=SteeringParams(),
            description=case.description or (f"SteerSuite case {case.name}" if case.name else ""),
            content_hash=hashlib.sha256(data).hexdigest()[:16],
        )

    def goals(self, a: _Agent, rng: np.random.Generator, placer: _Placer | None = None
              ) -> list[SequenceGoal] | None:
        """The agent's goals with random targets drawn (``placer`` is None: none are)."""
        out: list[SequenceGoal] = []
        for g in a.goals:
            target: Vec2 = (0.0, 0.0)
            if g.kind == "flow" and g.target == _RANDOM:
                ang = float(rng.uniform(0.0, 2.0 * math.pi))
                target = (math.cos(ang), math.sin(ang))
            elif g.kind == "box" or g.target == _RANDOM:
                assert placer is not None
                area = g.box if g.kind == "box" and g.box is not None else placer.bounds
                p = placer.free_point(rng, area, a.radius)
                if p is None:
                    self.problem(g.path, f"could not draw a target clear of obstacles after "
                                 f"{MAX_TRIES} tries")
                    return None
                target = p
            elif isinstance(g.target, tuple):
                target = g.target
            kind = "seek" if g.kind == "box" else g.kind
            out.append(SequenceGoal(kind, target, g.speed, g.duration))
        return out

ProfileKey = tuple[float, float, float]  # radius, pref_speed, max_speed


def _profile_key(a: _Agent) -> ProfileKey:
    pref = max(MIN_PREF_SPEED, a.goals[0].speed)
    top = max(pref, *(g.speed for g in a.goals))
    return (a.radius, pref, max(top * 1.25, top + 0.3))


def _profile_names(agents: list[_Agent]) -> dict[ProfileKey, str]:
    """``steersuite_r0.50``; ``_v1.30`` is added where one radius has several speeds."""
    keys = sorted({_profile_key(a) for a in agents})
    names: dict[ProfileKey, str] = {}
    for key in keys:
        base = f"steersuite_r{key[0]:.2f}"
        if sum(1 for k in keys if k[0] == key[0]) > 1:
            base += f"_v{key[1]:.2f}"
        name, n = base, 2
        while name in names.values():
            name, n = f"{base}_{n}", n + 1
        names[key] = name
    return names


def _heading(d: Vec2) -> float | None:
    if math.hypot(d[0], d[1]) == 0.0:
        return None
    return math.atan2(d[1], d[0])


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def oriented_box_vertices(center: Vec2, length_x: float, length_z: float, theta_y_deg: float
                          ) -> tuple[Vec2, ...]:
    """Corners of SteerSuite's ``orientedBoxObstacle`` in pedvr's ground frame, CCW.

    The local corners ``(±lx/2, ±lz/2)`` are rotated by SteerSuite's
    ``rotateInXZPlane(p, θ) = (x cosθ + z sinθ, z cosθ − x sinθ)``: a rotation
    by −θ in the counter-clockwise ``(x, z)`` frame, which keeps the order CCW.
    """
    t = math.radians(theta_y_deg)
    c, s = math.cos(t), math.sin(t)
    hx, hz = length_x / 2.0, length_z / 2.0
    out = []
    for dx, dz in ((-hx, -hz), (hx, -hz), (hx, hz), (-hx, hz)):
        out.append((center[0] + dx * c + dz * s, center[1] + dz * c - dx * s))
    return tuple(out)


def circle_vertices(center: Vec2, radius: float, n: int = CIRCLE_SEGMENTS) -> tuple[Vec2, ...]:
    """A regular ``n``-gon, CCW, whose edges touch the circle: the disc is inside it."""
    r = radius / math.cos(math.pi / n)
    return tuple((center[0] + r * math.cos(2 * math.pi * k / n),
                  center[1] + r * math.sin(2 * math.pi * k / n)) for k in range(n))


def _grown_bounds(case: _Case) -> Box:
    """World bounds (sorted), grown to hold every explicit agent, seek target and region.

    Bounds with no area, or that miss the content entirely (``circle-20``),
    are replaced by the content's box plus the margin.
    """
    assert case.bounds is not None
    x0, z0, x1, z1 = case.bounds
    m = BOUNDS_MARGIN
    xs: list[float] = []
    zs: list[float] = []
    for a in case.agents:
        if isinstance(a.position, tuple):
            xs += [a.position[0] - a.radius, a.position[0] + a.radius]
            zs += [a.position[1] - a.radius, a.position[1] + a.radius]
        if a.region is not None:
            xs += [a.region[0], a.region[2]]
            zs += [a.region[1], a.region[3]]
        for g in a.goals:
            if g.kind == "seek" and isinstance(g.target, tuple):
                xs.append(g.target[0])
                zs.append(g.target[1])
            if g.box is not None:
                xs += [g.box[0], g.box[2]]
                zs += [g.box[1], g.box[3]]
    has_area = x0 < x1 and z0 < z1
    if not xs:
        return (x0, z0, x1, z1) if has_area else (x0 - m, z0 - m, x1 + m, z1 + m)
    cx0, cz0, cx1, cz1 = min(xs), min(zs), max(xs), max(zs)
    if has_area and x0 <= cx0 and cx1 <= x1 and z0 <= cz0 and cz1 <= z1:
        return (x0, z0, x1, z1)
    overlaps = has_area and cx0 <= x1 and x0 <= cx1 and cz0 <= z1 and z0 <= cz1
    if overlaps:
        return (min(x0, cx0 - m), min(z0, cz0 - m), max(x1, cx1 + m), max(z1, cz1 + m))
    return (cx0 - m, cz0 - m, cx1 + m, cz1 + m)


# --------------------------------------------------------------------------- placement


class _Placer:
    """Rejection sampling of discs and squares clear of obstacles and agents.

    Explicit obstacles are tested exactly with shapely (an STRtree); random
    squares and agent discs, which are added as they are drawn, live in
    uniform grids of cell ``cell`` metres.
    """

    def __init__(self, bounds: Box, obstacles: list[Obstacle], max_radius: float) -> None:
        self.bounds = bounds
        self.polys = [Polygon(o.vertices) for o in obstacles]
        self.tree = shapely.STRtree(self.polys)
        self.cell = max(2.0, 4.0 * max_radius)
        self.squares: dict[tuple[int, int], list[Box]] = {}
        self.discs: dict[tuple[int, int], list[tuple[float, float, float]]] = {}
        self.max_radius = max_radius
        self.max_square = 0.0

    def _cells(self, x0: float, z0: float, x1: float, z1: float) -> Iterator[tuple[int, int]]:
        c = self.cell
        for i in range(math.floor(x0 / c), math.floor(x1 / c) + 1):
            for j in range(math.floor(z0 / c), math.floor(z1 / c) + 1):
                yield (i, j)

    def add_agent(self, p: Vec2, r: float) -> None:
        self.discs.setdefault((math.floor(p[0] / self.cell), math.floor(p[1] / self.cell)),
                              []).append((p[0], p[1], r))

    def _near_discs(self, x0: float, z0: float, x1: float, z1: float
                    ) -> Iterator[tuple[float, float, float]]:
        """Every placed disc that may overlap the box ``x0..x1, z0..z1``."""
        m = self.max_radius
        for key in self._cells(x0 - m, z0 - m, x1 + m, z1 + m):
            yield from self.discs.get(key, ())

    def _square_hits(self, x0: float, z0: float, x1: float, z1: float, pad: float) -> bool:
        """Does a random square come within ``pad`` of the box? (touching counts)"""
        for key in self._cells(x0 - pad, z0 - pad, x1 + pad, z1 + pad):
            for sx0, sz0, sx1, sz1 in self.squares.get(key, ()):
                dx = max(sx0 - x1, x0 - sx1, 0.0)
                dz = max(sz0 - z1, z0 - sz1, 0.0)
                if dx * dx + dz * dz <= pad * pad:
                    return True
        return False

    def _clear_of_obstacles(self, p: Vec2, r: float) -> bool:
        if self._square_hits(p[0], p[1], p[0], p[1], r):
            return False
        return len(self.tree.query(Point(p), predicate="dwithin", distance=r)) == 0

    @staticmethod
    def _draw(rng: np.random.Generator, area: Box, inset: float) -> Vec2:
        x0, z0, x1, z1 = area
        if x1 - x0 > 2 * inset:
            x0, x1 = x0 + inset, x1 - inset
        else:
            x0 = x1 = (x0 + x1) / 2
        if z1 - z0 > 2 * inset:
            z0, z1 = z0 + inset, z1 - inset
        else:
            z0 = z1 = (z0 + z1) / 2
        return (float(rng.uniform(x0, x1)), float(rng.uniform(z0, z1)))

    def place_square(self, rng: np.random.Generator, region: Box, size: float) -> Box | None:
        h = size / 2
        for _ in range(MAX_TRIES):
            cx, cz = self._draw(rng, region, h)
            sq = (cx - h, cz - h, cx + h, cz + h)
            if self._square_hits(*sq, pad=0.0):
                continue
            if any((max(sq[0] - x, x - sq[2], 0.0) ** 2 + max(sq[1] - z, z - sq[3], 0.0) ** 2)
                   < r * r for x, z, r in self._near_discs(*sq)):
                continue
            if len(self.tree.query(shapely.box(*sq), predicate="intersects")):
                continue
            for key in self._cells(*sq):
                self.squares.setdefault(key, []).append(sq)
            return sq
        return None

    def place_disc(self, rng: np.random.Generator, area: Box, r: float) -> Vec2 | None:
        for _ in range(MAX_TRIES):
            p = self._draw(rng, area, r)
            if any((p[0] - x) ** 2 + (p[1] - z) ** 2 < (r + q) ** 2
                   for x, z, q in self._near_discs(p[0] - r, p[1] - r, p[0] + r, p[1] + r)):
                continue
            if not self._clear_of_obstacles(p, r):
                continue
            self.add_agent(p, r)
            return p
        return None

    def free_point(self, rng: np.random.Generator, area: Box, r: float) -> Vec2 | None:
        for _ in range(MAX_TRIES):
            p = self._draw(rng, area, r)
            if self._clear_of_obstacles(p, r):
                return p
        return None

    def user_start(self, crowd: list[Box], clearance: float) -> Vec2 | None:
        """A free point near a world corner, the one farthest from the crowd.

        ``crowd`` holds boxes (points as empty boxes): agents, agent regions
        and goal targets.

        Each corner is tried along its diagonal, moving inward; when every
        diagonal is blocked (hallway cases fill the corners with boxes), the
        free point of a 41 x 41 grid over the bounds farthest from the crowd.
        """
        x0, z0, x1, z1 = self.bounds
        cx, cz = (x0 + x1) / 2, (z0 + z1) / 2

        def free(p: Vec2) -> bool:
            return self._clear_of_obstacles(p, clearance) and not any(
                (p[0] - x) ** 2 + (p[1] - z) ** 2 < (r + clearance) ** 2
                for x, z, r in self._near_discs(p[0] - clearance, p[1] - clearance,
                                                p[0] + clearance, p[1] + clearance))

        def spread(p: Vec2) -> float:
            return min((math.hypot(max(b[0] - p[0], p[0] - b[2], 0.0),
                                   max(b[1] - p[1], p[1] - b[3], 0.0)) for b in crowd),
                       default=0.0)

        corners: list[Vec2] = []
        for corner in ((x0, z0), (x1, z0), (x1, z1), (x0, z1)):
            inset = 1.0
            while inset <= min(x1 - x0, z1 - z0) / 4:
                p = (corner[0] + math.copysign(inset, cx - corner[0]),
                     corner[1] + math.copysign(inset, cz - corner[1]))
                if free(p):
                    corners.append(p)
                    break
                inset *= 1.5
        if corners:
            return max(corners, key=spread)
        grid = [(float(x), float(z)) for x in np.linspace(x0 + 1, x1 - 1, 41)
                for z in np.linspace(z0 + 1, z1 - 1, 41)]
        grid = [p for p in grid if free(p)]
        return max(grid, key=spread) if grid else None
