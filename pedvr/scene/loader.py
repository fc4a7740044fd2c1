"""Load and validate TOML scene files into :class:`SceneConfig`.

Every problem in a file is collected and reported at once, one line each:
``scenes/x.toml: agents.profiles.child.radius = -0.2: must be > 0``.
Required keys never default silently; optional keys have the defaults written
in :mod:`pedvr.scene.config` and in ``scenes/README.md``.
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from pathlib import Path
from typing import Any

from shapely.geometry import LineString, Point, Polygon, box

import pedvr.demonstrator  # noqa: F401  (registers the exhibit smart object and the demonstrate node)
from pedvr.behavior.declare import Interactions
from pedvr.behavior.goals import selectors, validate_params
from pedvr.errors import SceneError
from pedvr.scene.avatars import AVATAR_SUFFIXES, AvatarError, open_avatar
from pedvr.scene.config import (
    CARRYING,
    DOOR_KINDS,
    DOOR_ROTATIONS,
    DOOR_SWINGS,
    ETIQUETTE_DECISIONS,
    FLOORS,
    GESTURE_CLIPS,
    KEEP_SIDES,
    MARKING_KINDS,
    PRAM_MIN_RADIUS,
    SEXES,
    SOURCE_TIMINGS,
    TURNED_DEPTH_RATIO,
    USER_WALKS,
    AgentProfile,
    BehaviorConfig,
    Door,
    EtiquetteConfig,
    GoalSelector,
    GoalSet,
    Marking,
    MotionLimits,
    Obstacle,
    SceneConfig,
    Sink,
    Source,
    Spawn,
    StateConfig,
    SteeringParams,
    Transition,
    UserConfig,
    Vec2,
    WorldConfig,
    default_dt,
)
from pedvr.validation import MISSING, Checker, is_num

OBSTACLE_KINDS = ("polygon", "box", "wall", "table", "booth", "shop", "pillar", "counter", "building",
                  "plant")
# success / failure: the state's behavior tree ended so (pedvr.behavior.scheduler)
TRANSITION_EVENTS = ("arrival", "timer", "probability", "success", "failure")


class _Checker(Checker):
    """The shared problem collector plus the accessors scenes need (``string`` lists its choices
    unquoted, as scene messages always have)."""

    def whole(self, d: dict[str, Any], key: str, path: str, *, required: bool = True,
              default: int | None = None, minimum: int = 0) -> int | None:
        """An integer ``>= minimum`` (scenes say so in these words; protocols use ``integer``)."""
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, "required")
            return default
        if not isinstance(v, int) or isinstance(v, bool) or v < minimum:
            self.bad(path, v, f"expected an integer >= {minimum}")
            return default
        return v

    def string(self, d: dict[str, Any], key: str, path: str, *, required: bool = True,
               default: str | None = None, choices: tuple[str, ...] | None = None) -> str | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, "required" + (f"; one of {', '.join(choices)}" if choices else ""))
            return default
        if not isinstance(v, str) or not v:
            self.bad(path, v, "expected a non-empty string")
            return default
        if choices and v not in choices:
            self.bad(path, v, f"expected one of {', '.join(choices)}")
            return default
        return v

    def point(self, v: object, path: str) -> Vec2 | None:
        if isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v):
            return (float(v[0]), float(v[1]))
        self.bad(path, v, "expected [x, y] in metres")
        return None

    def points(self, d: dict[str, Any], key: str, path: str, *, required: bool = True,
               minimum: int = 1) -> tuple[Vec2, ...] | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, f"required list of at least {minimum} [x, y] points")
            return None
        if not isinstance(v, list) or len(v) < minimum:
            self.bad(path, v, f"expected a list of at least {minimum} [x, y] points")
            return None
        out = [self.point(p, f"{path}[{i}]") for i, p in enumerate(v)]
        if any(p is None for p in out):
            return None
        return tuple(p for p in out if p is not None)

    def floats(self, v: object, path: str, n: int, expect: str) -> tuple[float, ...] | None:
        if isinstance(v, list) and len(v) == n and all(is_num(x) for x in v):
            return tuple(float(x) for x in v)
        self.bad(path, v, f"expected {expect}")
        return None


def load_scene(path: str | Path, *, display_path: str | None = None) -> SceneConfig:
    """Load a scene: a ``.toml`` pedvr scene or a SteerSuite ``.xml`` case.

    Raises :class:`SceneError` listing every problem. SteerSuite cases are
    loaded with seed 0 here; pass a seed through :func:`load_any` to expand
    their ``<random>`` elements differently.
    """
    return load_any(path, seed=None, display_path=display_path)


def load_any(path: str | Path, *, seed: int | None, display_path: str | None = None) -> SceneConfig:
    p = Path(path)
    shown = display_path or str(path)
    if not p.is_file():
        raise SceneError([f"{shown}: no such scene file"])
    if p.suffix.lower() == ".xml":
        from pedvr.scene.steersuite import load_steersuite

        return load_steersuite(p, seed=0 if seed is None else seed)
    if p.suffix.lower() != ".toml":
        raise SceneError([f"{shown}: unknown scene format {p.suffix!r}; expected .toml or .xml"])
    raw = p.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError([f"{shown}: not valid TOML: {exc}"]) from None
    cfg = parse_scene(data, source=shown, content_hash=hashlib.sha256(raw).hexdigest()[:16],
                      base=p.parent)
    if seed is not None:
        from dataclasses import replace

        cfg = replace(cfg, seed=seed)
    return cfg


def parse_scene(data: dict[str, Any], *, source: str, content_hash: str = "",
                base: Path | None = None) -> SceneConfig:
    """Validate a parsed TOML document; raise one SceneError with all problems. ``base`` is the
    folder the scene's relative file patterns (avatars) are resolved in (default: the working one)."""
    c = _Checker(source)
    c.known(data, "", ("scene", "world", "steering", "gaze", "agents", "behavior", "user", "characters",
                       "etiquette"))

    scene = c.table(data, "scene", "scene", required=True) or {}
    c.known(scene, "scene", ("name", "description", "seed", "duration", "dt"))
    name = c.string(scene, "name", "scene.name")
    description = c.string(scene, "description", "scene.description", required=False, default="")
    seed = c.whole(scene, "seed", "scene.seed")
    duration = c.number(scene, "duration", "scene.duration", check=lambda x: x > 0, expect="> 0 s")
    dt = c.number(scene, "dt", "scene.dt", required=False, default=default_dt(),
                  check=lambda x: 0 < x <= 0.1, expect="in (0, 0.1] s")

    world = _world(c, c.table(data, "world", "world", required=True) or {})
    steering = _steering(c, c.table(data, "steering", "steering", required=False) or {})
    gaze = c.table(data, "gaze", "gaze", required=False) or {}
    c.known(gaze, "gaze", ("distance", "speed"))
    gaze_distance = c.number(gaze, "distance", "gaze.distance", required=False, default=4.0,
                             check=lambda x: x > 0, expect="> 0 m")
    gaze_speed = c.number(gaze, "speed", "gaze.speed", required=False, default=2.0,
                          check=lambda x: x > 0, expect="> 0 m/s")

    behavior = _behavior(c, c.table(data, "behavior", "behavior", required=True) or {}, world)
    agents = c.table(data, "agents", "agents", required=True) or {}
    c.known(agents, "agents", ("profiles", "spawns", "sources", "sinks"))
    chars = c.table(data, "characters", "characters", required=False) or {}
    c.known(chars, "characters", ("bone_map",))
    bone_map = chars.get("bone_map", {})
    if not isinstance(bone_map, dict) or not all(isinstance(k, str) and isinstance(v, str) and v
                                                 for k, v in bone_map.items()):
        c.bad("characters.bone_map", bone_map, 'expected a table of "bone name" = "pedvr joint name"')
        bone_map = {}
    profiles_raw = c.table(agents, "profiles", "agents.profiles", required=True) or {}
    profiles = _profiles(c, profiles_raw, base, bone_map=bone_map)
    declared = (set(profiles_raw), set(_table_keys(data, "behavior", "states")))
    spawns = _spawns(c, agents.get("spawns", MISSING), profiles, behavior, world, declared=declared)
    sources = _sources(c, agents.get("sources", MISSING), profiles, behavior, world, declared=declared)
    sinks = _sinks(c, agents.get("sinks", MISSING), world, behavior, declared=declared[1])
    user = _user(c, c.table(data, "user", "user", required=True) or {}, world)
    etiquette = _etiquette(c, c.table(data, "etiquette", "etiquette", required=False) or {})

    if c.problems:
        raise SceneError(c.problems)
    assert name is not None and seed is not None and duration is not None and dt is not None
    assert world is not None and behavior is not None and user is not None
    assert gaze_distance is not None and gaze_speed is not None and description is not None
    return SceneConfig(name=name, source=source, seed=seed, dt=dt, duration=duration, world=world,
                       profiles=profiles, spawns=spawns, behavior=behavior, user=user,
                       steering=steering, gaze_distance=gaze_distance, gaze_speed=gaze_speed,
                       description=description, content_hash=content_hash, bone_map=dict(bone_map),
                       etiquette=etiquette, sources=sources, sinks=sinks)


def _world(c: _Checker, w: dict[str, Any]) -> WorldConfig | None:
    c.known(w, "world", ("bounds", "obstacles", "doors", "indoor", "wall_height", "ceiling", "floor",
                         "markings"))
    bounds = None
    b = w.get("bounds", MISSING)
    if b is MISSING:
        c.bad("world.bounds", b, "required [[xmin, ymin], [xmax, ymax]]")
    else:
        pts = c.points(w, "bounds", "world.bounds", minimum=2)
        if pts is not None:
            if len(pts) != 2 or not (pts[0][0] < pts[1][0] and pts[0][1] < pts[1][1]):
                c.bad("world.bounds", b, "expected [[xmin, ymin], [xmax, ymax]] with min < max")
            else:
                bounds = (pts[0], pts[1])
    obstacles: list[Obstacle] = []
    raw = w.get("obstacles", [])
    if not isinstance(raw, list):
        c.bad("world.obstacles", raw, "expected an array of tables [[world.obstacles]]")
        raw = []
    for i, o in enumerate(raw):
        path = f"world.obstacles[{i}]"
        if not isinstance(o, dict):
            c.bad(path, o, "expected a table")
            continue
        ob = _obstacle(c, o, path)
        if ob is not None:
            if bounds is not None and not box(*bounds[0], *bounds[1]).intersects(Polygon(ob.vertices)):
                c.bad(path, "{...}", "lies outside world.bounds")
            obstacles.append(ob)
    doors = _doors(c, w.get("doors", []), bounds, obstacles)
    indoor = c.boolean(w, "indoor", "world.indoor", default=False)
    wall_height = c.number(w, "wall_height", "world.wall_height", required=False, default=2.6,
                           check=lambda x: 2.0 <= x <= 30.0, expect="between 2 and 30 m")
    ceiling = c.boolean(w, "ceiling", "world.ceiling", default=False)
    if ceiling and not indoor:
        c.bad("world.ceiling", True, "needs world.indoor = true")
    floor = c.string(w, "floor", "world.floor", required=False, default="grid", choices=FLOORS)
    markings = _markings(c, w.get("markings", []))
    if not bounds:
        return None
    return WorldConfig(bounds=bounds, obstacles=tuple(obstacles), doors=doors, indoor=indoor,
                       wall_height=wall_height or 2.6, ceiling=ceiling, floor=floor or "grid",
                       markings=markings)


def _markings(c: _Checker, raw: object) -> tuple[Marking, ...]:
    """``[[world.markings]]``: paint on the floor (drawing only)."""
    if not isinstance(raw, list):
        c.bad("world.markings", raw, "expected an array of tables [[world.markings]]")
        return ()
    out = []
    for i, m in enumerate(raw):
        path = f"world.markings[{i}]"
        if not isinstance(m, dict):
            c.bad(path, m, "expected a table")
            continue
        c.known(m, path, ("kind", "from", "to", "width"))
        kind = c.string(m, "kind", f"{path}.kind", choices=MARKING_KINDS)
        a = b = None
        for key in ("from", "to"):
            if key not in m:
                c.bad(f"{path}.{key}", MISSING, "required [x, y]")
        if "from" in m:
            a = c.point(m["from"], f"{path}.from")
        if "to" in m:
            b = c.point(m["to"], f"{path}.to")
        width = c.number(m, "width", f"{path}.width", required=False, default=3.0,
                         check=lambda x: 0.5 <= x <= 10.0, expect="between 0.5 and 10 m")
        if a is not None and b is not None and math.dist(a, b) < 1.0:
            c.bad(f"{path}.to", m["to"], "must be at least 1 m from world.markings.from")
        elif kind and a is not None and b is not None and width is not None:
            out.append(Marking(kind=kind, start=a, end=b, width=width))
    return tuple(out)


DOOR_WIDTH = {"single": (0.7, 1.6), "double": (1.2, 3.2), "revolving": (1.6, 3.6)}  # m, jamb to jamb
_DOOR_KEYS = ("kind", "span", "at", "width", "along_deg", "height", "swing", "hinge", "pull_side",
              "closing_speed_deg", "sensing_range", "rotation", "name")
DRUM_WALL = 0.1  # m: thickness of a revolving door's drum wall
DRUM_ARC = 45.0  # degrees either side of the wall line the drum wall covers (the openings are the rest)


def _door_span(c: _Checker, d: dict[str, Any], path: str) -> tuple[Vec2, Vec2] | None:
    """``span = [[x0, y0], [x1, y1]]``, or ``at``, ``width`` and ``along_deg`` (the wall's direction)."""
    alt = [k for k in ("at", "width", "along_deg") if k in d]
    if "span" in d and alt:
        c.bad(f"{path}.{alt[0]}", d[alt[0]], "give either span or at, width and along_deg")
        return None
    if "span" not in d:
        if len(alt) != 3:
            c.bad(f"{path}.span", MISSING, "required [[x0, y0], [x1, y1]] (or at, width and along_deg)")
            return None
        at = c.point(d["at"], f"{path}.at")
        width = c.number(d, "width", f"{path}.width", check=lambda x: x > 0, expect="> 0 m")
        along = c.number(d, "along_deg", f"{path}.along_deg")
        if at is None or width is None or along is None:
            return None
        ux, uy = math.cos(math.radians(along)), math.sin(math.radians(along))
        return ((at[0] - 0.5 * width * ux, at[1] - 0.5 * width * uy),
                (at[0] + 0.5 * width * ux, at[1] + 0.5 * width * uy))
    pts = c.points(d, "span", f"{path}.span", minimum=2)
    if pts is None:
        return None
    if len(pts) != 2:
        c.bad(f"{path}.span", d["span"], "expected two jambs [[x0, y0], [x1, y1]]")
        return None
    return (pts[0], pts[1])


def drum_walls(door: Door) -> list[Obstacle]:
    """The two curved walls of a revolving door's drum (§4.5.1): arcs of radius half the span
    about its middle, :data:`DRUM_ARC` degrees either side of the wall line, so the drum is
    open toward both sides of the wall."""
    a, b = door.span
    cx, cy = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])
    base = math.atan2(b[1] - a[1], b[0] - a[0])
    r = 0.5 * door.width
    out = []
    for centre in (base, base + math.pi):
        ang = [centre + math.radians(DRUM_ARC) * (k / 6.0 - 1.0) for k in range(13)]
        outer = [(cx + (r + DRUM_WALL) * math.cos(t), cy + (r + DRUM_WALL) * math.sin(t)) for t in ang]
        inner = [(cx + r * math.cos(t), cy + r * math.sin(t)) for t in reversed(ang)]
        out.append(Obstacle(vertices=tuple(outer + inner), kind="wall", height=door.height + 0.3))
    return out


def _doors(c: _Checker, raw: object, bounds: tuple[Vec2, Vec2] | None,
           obstacles: list[Obstacle]) -> tuple[Door, ...]:
    """``[[world.doors]]``: each a doorway span in a gap between obstacles (see :class:`Door`).
    A revolving door's drum walls are appended to ``obstacles``."""
    from shapely.geometry import LineString
    from shapely.ops import substring

    if not isinstance(raw, list):
        c.bad("world.doors", raw, "expected an array of tables [[world.doors]]")
        return ()
    solid = [Polygon(o.vertices) for o in obstacles]
    out: list[Door] = []
    spans: list[tuple[str, LineString]] = []
    names: set[str] = set()
    for i, d in enumerate(raw):
        path = f"world.doors[{i}]"
        if not isinstance(d, dict):
            c.bad(path, d, "expected a table")
            continue
        c.known(d, path, _DOOR_KEYS)
        kind = c.string(d, "kind", f"{path}.kind", required=False, default="single", choices=DOOR_KINDS)
        height = c.number(d, "height", f"{path}.height", required=False, default=2.1,
                          check=lambda x: 1.5 <= x <= 4.0, expect="in [1.5, 4] m")
        swing = c.string(d, "swing", f"{path}.swing", required=False, default="one_way", choices=DOOR_SWINGS)
        hinge_name = c.string(d, "hinge", f"{path}.hinge", required=False, default="start",
                              choices=("start", "end"))
        closing = c.number(d, "closing_speed_deg", f"{path}.closing_speed_deg", required=False,
                           default=120.0, check=lambda x: 10.0 <= x <= 720.0, expect="in [10, 720] deg/s")
        sensing = c.number(d, "sensing_range", f"{path}.sensing_range", required=False, default=8.0,
                           check=lambda x: 2.0 <= x <= 50.0, expect="in [2, 50] m")
        rotation = c.string(d, "rotation", f"{path}.rotation", required=False, default="ccw",
                            choices=DOOR_ROTATIONS)
        name = c.string(d, "name", f"{path}.name", required=False, default=f"door_{i}")
        if name is not None:
            if name in names:
                c.bad(f"{path}.name", name, "another door has this name")
            names.add(name)
        span = _door_span(c, d, path)
        if span is not None and kind is not None:  # the width first: a 0 m door has no side to pull from
            lo, hi = DOOR_WIDTH[kind]
            width = math.dist(span[0], span[1])
            if not lo <= width <= hi:
                c.bad(f"{path}.span" if "span" in d else f"{path}.width", d["span"] if "span" in d
                      else d.get("width"), f"a {kind} door is {lo:g} to {hi:g} m wide; this is {width:.2f} m")
                span = None
        if kind == "revolving":
            for key in ("swing", "hinge", "pull_side", "closing_speed_deg"):
                if key in d:
                    c.bad(f"{path}.{key}", d[key], "a revolving door has no leaves to swing")
        elif "rotation" in d:
            c.bad(f"{path}.rotation", d["rotation"], "only a revolving door rotates")
        if kind != "single" and "hinge" in d:
            c.bad(f"{path}.hinge", d["hinge"], "only a single door has one hinge")
        pull = 1
        if span is not None and kind != "revolving" and swing == "one_way":
            ps = d.get("pull_side", MISSING)
            if ps is MISSING:
                c.bad(f"{path}.pull_side", ps, "required for a one-way door: a point [x, y] on the side "
                      "it is pulled open from (or swing = \"both_ways\")")
                span = None
            else:
                q = c.point(ps, f"{path}.pull_side")
                side = 0.0 if q is None else ((span[1][0] - span[0][0]) * (q[1] - span[0][1])
                                              - (span[1][1] - span[0][1]) * (q[0] - span[0][0]))
                if q is not None and abs(side) < 1e-9:
                    c.bad(f"{path}.pull_side", ps, "lies on the door's line; give a point on one side")
                    span = None
                elif q is None:
                    span = None
                else:
                    pull = 1 if side > 0 else -1
        elif "pull_side" in d and swing == "both_ways":
            c.bad(f"{path}.pull_side", d["pull_side"], "a double-acting door (swing = \"both_ways\") has no "
                  "pull side")
        if span is None or kind is None or height is None or swing is None or hinge_name is None \
                or closing is None or sensing is None or rotation is None or name is None:
            continue
        width = math.dist(span[0], span[1])
        key = f"{path}.span" if "span" in d else f"{path}.width"
        shown = d["span"] if "span" in d else d.get("width")
        line = LineString(span)
        if bounds is not None and not box(*bounds[0], *bounds[1]).contains(line):
            c.bad(key, shown, "lies outside world.bounds")
            continue
        inner = substring(line, 0.05, width - 0.05)  # jambs may sit a little inside the walls
        if any(p.intersects(inner) for p in solid):
            c.bad(key, shown, "crosses an obstacle; a door fills a gap between obstacles")
            continue
        clash = next((k for k, s in spans if s.distance(line) < 0.5 * (width + s.length)), None)
        if clash is not None:
            c.bad(key, shown, f"its leaves would swing into those of {clash}")
            continue
        spans.append((path, line))
        door = Door(span=span, kind=kind, height=height, swing=swing, hinge=0 if hinge_name == "start" else 1,
                    pull=pull, closing_speed=math.radians(closing), sensing_range=sensing,
                    rotation=rotation, name=name)
        if kind == "revolving":
            drum = drum_walls(door)
            if bounds is not None and not all(box(*bounds[0], *bounds[1]).contains(Polygon(o.vertices))
                                              for o in drum):
                c.bad(key, shown, "its drum lies outside world.bounds")
                continue
            obstacles.extend(drum)
        out.append(door)
    return tuple(out)


def _obstacle(c: _Checker, o: dict[str, Any], path: str) -> Obstacle | None:
    shapes = ("box", "polygon", "wall", "circle")
    c.known(o, path, ("kind", "height", "thickness", "occlusion", *shapes))
    given = [s for s in shapes if s in o]
    if len(given) != 1:
        c.bad(path, "{...}", f"expected exactly one shape key of {', '.join(shapes)}")
        return None
    kind = c.string(o, "kind", f"{path}.kind", required=False, default=given[0] if given[0] in
                    OBSTACLE_KINDS else "polygon", choices=OBSTACLE_KINDS)
    height = c.number(o, "height", f"{path}.height", required=False, default=1.0,
                      check=lambda x: x > 0, expect="> 0 m")
    occlusion = c.number(o, "occlusion", f"{path}.occlusion", required=False, default=1.0,
                         check=lambda x: 0 < x <= 1, expect="in (0, 1]: the share of the view it hides")
    shape = given[0]
    verts: list[Vec2] | None = None
    if shape == "box":
        v = c.floats(o["box"], f"{path}.box", 4, "[xmin, ymin, xmax, ymax]")
        if v is not None:
            if not (v[0] < v[2] and v[1] < v[3]):
                c.bad(f"{path}.box", o["box"], "expected xmin < xmax and ymin < ymax")
            else:
                verts = [(v[0], v[1]), (v[2], v[1]), (v[2], v[3]), (v[0], v[3])]
    elif shape == "polygon":
        pts = c.points(o, "polygon", f"{path}.polygon", minimum=3)
        if pts is not None:
            poly = Polygon(pts)
            if not poly.is_valid or poly.area <= 1e-9:
                c.bad(f"{path}.polygon", o["polygon"], "expected a simple polygon with area > 0")
            else:
                verts = list(pts) if poly.exterior.is_ccw else list(reversed(pts))
    elif shape == "wall":
        pts = c.points(o, "wall", f"{path}.wall", minimum=2)
        thickness = c.number(o, "thickness", f"{path}.thickness", required=False, default=0.2,
                             check=lambda x: x > 0, expect="> 0 m")
        if pts is not None and thickness is not None:
            from shapely.geometry import LineString

            if len(pts) != 2 or math.dist(pts[0], pts[1]) <= 1e-9:
                c.bad(f"{path}.wall", o["wall"], "expected two distinct points [[x0, y0], [x1, y1]]")
            else:
                poly = LineString(pts).buffer(thickness / 2, cap_style="flat")
                verts = [tuple(p) for p in poly.exterior.coords[:-1]]  # type: ignore[misc]
                if not poly.exterior.is_ccw:
                    verts.reverse()
    else:
        v = c.floats(o["circle"], f"{path}.circle", 3, "[cx, cy, radius]")
        if v is not None:
            if v[2] <= 0:
                c.bad(f"{path}.circle", o["circle"], "radius must be > 0")
            else:
                # 16 sides circumscribing the circle, so the true circle is inside.
                r = v[2] / math.cos(math.pi / 16)
                verts = [(v[0] + r * math.cos(2 * math.pi * (k + 0.5) / 16),
                          v[1] + r * math.sin(2 * math.pi * (k + 0.5) / 16)) for k in range(16)]
    if verts is None or kind is None or height is None or occlusion is None:
        return None
    return Obstacle(vertices=tuple(verts), kind=kind, height=height, occlusion=occlusion)


def _steering(c: _Checker, s: dict[str, Any]) -> SteeringParams:
    d = SteeringParams()
    c.known(s, "steering", ("neighbor_dist", "max_neighbors", "time_horizon", "time_horizon_obst",
                            "user_responsibility", "personal_space", "user_safety",
                            "user_safety_horizon", "depth_ratio", "time_gap", "dense_slack",
                            "time_horizon_obst_coupled"))
    pos = lambda x: x > 0  # noqa: E731
    return SteeringParams(
        neighbor_dist=c.number(s, "neighbor_dist", "steering.neighbor_dist", required=False,
                               default=d.neighbor_dist, check=pos, expect="> 0 m") or d.neighbor_dist,
        max_neighbors=c.whole(s, "max_neighbors", "steering.max_neighbors", required=False,
                              default=d.max_neighbors, minimum=1) or d.max_neighbors,
        time_horizon=c.number(s, "time_horizon", "steering.time_horizon", required=False,
                              default=d.time_horizon, check=pos, expect="> 0 s") or d.time_horizon,
        time_horizon_obst=c.number(s, "time_horizon_obst", "steering.time_horizon_obst",
                                   required=False, default=d.time_horizon_obst, check=pos,
                                   expect="> 0 s") or d.time_horizon_obst,
        user_responsibility=_or(c.number(s, "user_responsibility", "steering.user_responsibility",
                                         required=False, default=d.user_responsibility,
                                         check=lambda x: 0 <= x <= 1, expect="in [0, 1]"),
                                d.user_responsibility),
        personal_space=_or(c.number(s, "personal_space", "steering.personal_space", required=False,
                                    default=d.personal_space, check=lambda x: 0 <= x <= 2,
                                    expect="in [0, 2] m"), d.personal_space),
        user_safety=c.boolean(s, "user_safety", "steering.user_safety", default=d.user_safety),
        user_safety_horizon=c.number(s, "user_safety_horizon", "steering.user_safety_horizon",
                                     required=False, default=d.user_safety_horizon, check=pos,
                                     expect="> 0 s") or d.user_safety_horizon,
        depth_ratio=_or(c.number(s, "depth_ratio", "steering.depth_ratio", required=False,
                                 default=d.depth_ratio, check=lambda x: TURNED_DEPTH_RATIO <= x <= 1,
                                 expect=f"in [{TURNED_DEPTH_RATIO}, 1] (a turned body's depth to the disc)"),
                        d.depth_ratio),
        time_gap=_or(c.number(s, "time_gap", "steering.time_gap", required=False, default=d.time_gap,
                              check=lambda x: 0 <= x <= 5, expect="in [0, 5] s (0: off)"), d.time_gap),
        dense_slack=_or(c.number(s, "dense_slack", "steering.dense_slack", required=False,
                                 default=d.dense_slack, check=lambda x: 0 <= x <= 1,
                                 expect="in [0, 1] m/s (0: ORCA's least violation)"), d.dense_slack),
        time_horizon_obst_coupled=c.number(
            s, "time_horizon_obst_coupled", "steering.time_horizon_obst_coupled", required=False,
            default=d.time_horizon_obst_coupled, check=pos, expect="> 0 s") or d.time_horizon_obst_coupled,
    )


def _or(v: float | None, d: float) -> float:
    return d if v is None else v


_PROFILE_KEYS = ("inherit", "radius", "pref_speed", "max_speed", "limits", "characters", "kindness", "rush",
                 "sex", "carrying")
_LIMIT_KEYS = ("max_accel", "max_decel", "turn_rate_standing", "turn_rate_walking",
               "max_backward_speed", "max_sideways_speed")


def _characters(c: _Checker, v: object, path: str, base: Path | None, *, bone_map: dict[str, str],
                checked: dict[Path, bool]) -> tuple[str, ...]:
    """``characters = ["builtin", "avatars/*.glb"]``: each entry ``builtin`` or a glob of glTF/VRM
    files relative to the scene file's folder, matching at least one file (issue 16). Each file
    must be a usable skinned humanoid (:func:`pedvr.scene.avatars.open_avatar`, no GL: issue
    25.11); ``checked`` remembers the files read so far, so a profile that inherits the list does
    not read (or report) them again."""
    if not isinstance(v, list) or not v or not all(isinstance(x, str) and x for x in v):
        c.bad(path, v, 'expected a list of "builtin" or glTF/VRM file patterns')
        return ()
    out: list[str] = []
    folder = base or Path.cwd()
    for i, pattern in enumerate(v):
        if pattern == "builtin":
            out.append(pattern)
            continue
        p = Path(pattern)
        found = sorted(Path(p.anchor).glob(str(p.relative_to(p.anchor))) if p.is_absolute()
                       else folder.glob(pattern))
        files = [f for f in found if f.is_file()]
        if not files:
            c.bad(f"{path}[{i}]", pattern, f"matches no file in {folder}")
        elif bad := [f.name for f in files if f.suffix.lower() not in AVATAR_SUFFIXES]:
            c.bad(f"{path}[{i}]", pattern, f"{bad[0]}: expected a {', '.join(AVATAR_SUFFIXES)} file")
        else:
            usable = True
            for f in files:
                key = f.resolve()
                if key not in checked:
                    try:
                        open_avatar(f, bone_map=bone_map)
                        checked[key] = True
                    except AvatarError as exc:
                        checked[key] = False
                        c.bad(f"{path}[{i}]", pattern, str(exc))
                usable &= checked[key]
            if usable:
                out.extend(str(f.resolve()) for f in files)
    return tuple(out)


def _profiles(c: _Checker, raw: dict[str, Any], base: Path | None = None, *,
              bone_map: dict[str, str] | None = None) -> dict[str, AgentProfile]:
    """Resolve ``inherit`` chains (a child overrides its parent key by key)."""
    resolved: dict[str, dict[str, Any]] = {}
    checked: dict[Path, bool] = {}

    def resolve(name: str, chain: tuple[str, ...]) -> dict[str, Any] | None:
        if name in resolved:
            return resolved[name]
        body = raw.get(name)
        path = f"agents.profiles.{name}"
        if not isinstance(body, dict):
            c.bad(path, body, "expected a table")
            return None
        parent = body.get("inherit")
        merged: dict[str, Any] = {}
        if parent is not None:
            if parent in chain:
                c.bad(f"{path}.inherit", parent, f"inheritance cycle: {' -> '.join((*chain, parent))}")
                return None
            if parent not in raw:
                c.bad(f"{path}.inherit", parent, f"unknown profile; known: {', '.join(sorted(raw))}")
                return None
            base = resolve(parent, (*chain, parent))
            if base is None:
                return None
            merged = {k: v for k, v in base.items() if k != "limits"}
            merged["limits"] = dict(base.get("limits", {}))
        for k, v in body.items():
            if k == "limits" and isinstance(v, dict):
                merged.setdefault("limits", {}).update(v)
            elif k != "inherit":
                merged[k] = v
        resolved[name] = merged
        return merged

    out: dict[str, AgentProfile] = {}
    for name in raw:
        body = raw[name]
        if isinstance(body, dict):
            c.known(body, f"agents.profiles.{name}", _PROFILE_KEYS)
        m = resolve(name, (name,))
        if m is None:
            continue
        path = f"agents.profiles.{name}"
        pos = lambda x: x > 0  # noqa: E731
        radius = c.number(m, "radius", f"{path}.radius", check=pos, expect="> 0")
        pref = c.number(m, "pref_speed", f"{path}.pref_speed", check=pos, expect="> 0 m/s")
        mx = c.number(m, "max_speed", f"{path}.max_speed", check=pos, expect="> 0 m/s")
        if pref is not None and mx is not None and mx < pref:
            c.bad(f"{path}.max_speed", mx, f"must be >= pref_speed ({pref})")
        lim_raw = m.get("limits", {})
        d = MotionLimits()
        lim = d
        if not isinstance(lim_raw, dict):
            c.bad(f"{path}.limits", lim_raw, "expected a table")
        else:
            c.known(lim_raw, f"{path}.limits", _LIMIT_KEYS)
            vals = {k: c.number(lim_raw, k, f"{path}.limits.{k}", required=False,
                                default=getattr(d, k), check=pos, expect="> 0") for k in _LIMIT_KEYS}
            lim = MotionLimits(**{k: (v if v is not None else getattr(d, k)) for k, v in vals.items()})
        chars = (_characters(c, m["characters"], f"{path}.characters", base, bone_map=bone_map or {},
                             checked=checked) if "characters" in m else ())
        d_prof = AgentProfile(name=name)
        kindness = _trait(c, m, "kindness", path, d_prof.kindness)
        rush = _trait(c, m, "rush", path, d_prof.rush)
        sex = c.string(m, "sex", f"{path}.sex", required=False, default="", choices=SEXES)
        carrying = c.string(m, "carrying", f"{path}.carrying", required=False, default="none",
                            choices=CARRYING)
        if carrying == "perambulator" and radius is not None and radius < PRAM_MIN_RADIUS:
            c.bad(f"{path}.radius", radius, f"must be >= {PRAM_MIN_RADIUS} for a perambulator pusher "
                  "(the footprint holds pusher and pram)")
        if radius is not None and pref is not None and mx is not None:
            out[name] = AgentProfile(name=name, radius=radius, pref_speed=pref, max_speed=mx,
                                     limits=lim, characters=chars, kindness=kindness, rush=rush,
                                     sex=sex or "", carrying=carrying or "none")
    return out


def _trait(c: _Checker, m: dict[str, Any], key: str, path: str,
           default: tuple[float, float]) -> tuple[float, float]:
    """A personality factor of Huang & Terzopoulos §5.1.3 in [0, 1]: a number, or
    ``{uniform = [lo, hi]}`` drawn per agent."""
    v = m.get(key, MISSING)
    if v is MISSING:
        return default
    if is_num(v) and 0.0 <= float(v) <= 1.0:
        return (float(v), float(v))
    if (isinstance(v, dict) and list(v) == ["uniform"] and isinstance(v["uniform"], list)
            and len(v["uniform"]) == 2 and all(is_num(x) for x in v["uniform"])
            and 0.0 <= v["uniform"][0] <= v["uniform"][1] <= 1.0):
        return (float(v["uniform"][0]), float(v["uniform"][1]))
    c.bad(f"{path}.{key}", v, "expected a number in [0, 1] or {uniform = [lo, hi]} with 0 <= lo <= hi <= 1")
    return default


def _etiquette(c: _Checker, e: dict[str, Any]) -> EtiquetteConfig:
    """``[etiquette]``: door etiquette for the scene's doors (see :class:`EtiquetteConfig`)."""
    d = EtiquetteConfig()
    c.known(e, "etiquette", ("enabled", "decisions", "keep", "wait_credit", "user_patience"))
    return EtiquetteConfig(
        enabled=c.boolean(e, "enabled", "etiquette.enabled", default=d.enabled),
        decisions=c.string(e, "decisions", "etiquette.decisions", required=False, default=d.decisions,
                           choices=ETIQUETTE_DECISIONS) or d.decisions,
        keep=c.string(e, "keep", "etiquette.keep", required=False, default=d.keep,
                      choices=KEEP_SIDES) or d.keep,
        wait_credit=_or(c.number(e, "wait_credit", "etiquette.wait_credit", required=False,
                                 default=d.wait_credit, check=lambda x: 0.0 <= x <= 5.0,
                                 expect="in [0, 5] m/s"), d.wait_credit),
        user_patience=_or(c.number(e, "user_patience", "etiquette.user_patience", required=False,
                                   default=d.user_patience, check=lambda x: 0.5 <= x <= 60.0,
                                   expect="in [0.5, 60] s"), d.user_patience),
    )


def _behavior(c: _Checker, b: dict[str, Any], world: WorldConfig | None) -> BehaviorConfig | None:
    c.known(b, "behavior", ("decision_hz", "goal_sets", "states", "trees", "events", "objects", "triggers"))
    hz = c.number(b, "decision_hz", "behavior.decision_hz", required=False, default=30.0,
                  check=lambda x: 0 < x <= 1000, expect="in (0, 1000] Hz")
    goal_sets: dict[str, GoalSet] = {}
    for gname, g in (c.table(b, "goal_sets", "behavior.goal_sets", required=False) or {}).items():
        path = f"behavior.goal_sets.{gname}"
        if not isinstance(g, dict):
            c.bad(path, g, "expected a table")
            continue
        c.known(g, path, ("points", "weights"))
        pts = c.points(g, "points", f"{path}.points")
        if pts is None:
            continue
        w = g.get("weights", [1.0] * len(pts))
        if (not isinstance(w, list) or len(w) != len(pts) or not all(is_num(x) and x >= 0 for x in w)
                or sum(w) <= 0):
            c.bad(f"{path}.weights", w, f"expected {len(pts)} numbers >= 0 with a positive sum")
            continue
        goal_sets[gname] = GoalSet(gname, pts, tuple(float(x) for x in w))

    inter = Interactions(c, b, goal_sets=frozenset(goal_sets), blocked=_blocked(world))
    states_raw = c.table(b, "states", "behavior.states", required=True) or {}
    if not states_raw:
        c.bad("behavior.states", "{}", "expected at least one state")
    states: dict[str, StateConfig] = {}
    for sname, s in states_raw.items():
        path = f"behavior.states.{sname}"
        if not isinstance(s, dict):
            c.bad(path, s, "expected a table")
            continue
        c.known(s, path, ("goal", "transitions", "speed_scale", "arrive_dist", "final", "gestures", "tree"))
        tree = inter.state_tree(s, path)
        gestures = _gestures(c, s.get("gestures", MISSING), f"{path}.gestures")
        goal = _goal(c, s.get("goal", MISSING), f"{path}.goal", goal_sets)
        trans = []
        raw_t = s.get("transitions", [])
        if not isinstance(raw_t, list):
            c.bad(f"{path}.transitions", raw_t, "expected an array of tables")
            raw_t = []
        for i, t in enumerate(raw_t):
            tr = _transition(c, t, f"{path}.transitions[{i}]", states_raw)
            if tr is not None:
                trans.append(tr)
        speed_scale = c.number(s, "speed_scale", f"{path}.speed_scale", required=False, default=1.0,
                               check=lambda x: 0 < x <= 2, expect="in (0, 2]")
        arrive = c.number(s, "arrive_dist", f"{path}.arrive_dist", required=False, default=0.3,
                          check=lambda x: x > 0, expect="> 0 m")
        final = c.boolean(s, "final", f"{path}.final", default=False)
        for i, tr in enumerate(trans):
            if tr.on in ("success", "failure") and "tree" not in s:
                c.bad(f"{path}.transitions[{i}].on", tr.on, "only a state with a tree takes this transition")
        if "goal" in s:
            states[sname] = StateConfig(name=sname, goal=goal, transitions=tuple(trans), tree=tree,
                                        speed_scale=speed_scale or 1.0, arrive_dist=arrive or 0.3,
                                        final=final, gestures=gestures)
    triggers = inter.triggers(b.get("triggers", MISSING), set(states_raw))
    return BehaviorConfig(states=states, goal_sets=goal_sets, decision_hz=hz or 30.0, trees=inter.trees,
                          events=inter.events, objects=inter.objects, triggers=triggers)


def _gestures(c: _Checker, g: object, path: str) -> tuple[tuple[str, ...], tuple[float, ...]] | None:
    """``{clips = ["wave", ...], weights = [...]}``: the state's gesture set (PedVR §4.3)."""
    if g is MISSING:
        return None
    if not isinstance(g, dict):
        c.bad(path, g, 'expected a table such as {clips = ["wave", "shrug"], weights = [1, 1]}')
        return None
    c.known(g, path, ("clips", "weights"))
    clips = g.get("clips", MISSING)
    if not isinstance(clips, list) or not clips or not all(isinstance(x, str) for x in clips):
        c.bad(f"{path}.clips", clips, f"expected a list of gesture names from {', '.join(GESTURE_CLIPS)}")
        return None
    unknown = [x for x in clips if x not in GESTURE_CLIPS]
    if unknown:
        c.bad(f"{path}.clips", clips, f"unknown gesture {unknown[0]!r}; known: {', '.join(GESTURE_CLIPS)}")
        return None
    w = g.get("weights", [1.0] * len(clips))
    if not isinstance(w, list) or len(w) != len(clips) or not all(is_num(x) and x >= 0 for x in w) \
            or sum(w) <= 0:
        c.bad(f"{path}.weights", w, f"expected {len(clips)} numbers >= 0 with a positive sum")
        return None
    return tuple(clips), tuple(float(x) for x in w)


def _goal(c: _Checker, g: object, path: str, goal_sets: dict[str, GoalSet]) -> GoalSelector | None:
    if g is MISSING:
        c.bad(path, g, 'required: a table such as {selector = "point", at = [x, y]}, '
              'or {selector = "stay"}')
        return None
    if not isinstance(g, dict):
        c.bad(path, g, 'expected a table such as {selector = "point", at = [x, y]}')
        return None
    kind = g.get("selector", MISSING)
    if kind not in selectors:
        c.bad(f"{path}.selector", kind, selectors.unknown(kind if kind is not MISSING else None)
              .split("; ", 1)[1].replace("known:", "expected one of:"))
        return None
    params = {k: v for k, v in g.items() if k != "selector"}
    for key, value, why in validate_params(str(kind), params):
        c.bad(f"{path}.{key}", value, why)
    if kind == "set" and isinstance(params.get("set"), str) and params["set"] not in goal_sets:
        c.bad(f"{path}.set", params["set"],
              f"unknown goal set; known: {', '.join(sorted(goal_sets)) or 'none'}")
    if kind == "stay":
        return None
    return GoalSelector(kind=str(kind), params=params)


def _transition(c: _Checker, t: object, path: str, states_raw: dict[str, Any]) -> Transition | None:
    if not isinstance(t, dict):
        c.bad(path, t, "expected a table")
        return None
    c.known(t, path, ("on", "to", "weights", "after", "rate"))
    on = c.string(t, "on", f"{path}.on", choices=TRANSITION_EVENTS)
    to_raw = t.get("to", MISSING)
    to: tuple[str, ...] | None = None
    if to_raw is MISSING:
        c.bad(f"{path}.to", to_raw, "required: a state name or a list of them")
    else:
        names = [to_raw] if isinstance(to_raw, str) else to_raw
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            c.bad(f"{path}.to", to_raw, "expected a state name or a list of them")
        else:
            unknown = [n for n in names if n not in states_raw]
            if unknown:
                c.bad(f"{path}.to", to_raw, f"unknown state {unknown[0]!r}; known: "
                      f"{', '.join(sorted(states_raw))}")
            else:
                to = tuple(names)
    weights: tuple[float, ...] = ()
    if "weights" in t:
        w = t["weights"]
        n = len(to) if to else -1
        if not isinstance(w, list) or len(w) != n or not all(is_num(x) and x >= 0 for x in w) \
                or sum(w) <= 0:
            c.bad(f"{path}.weights", w, f"expected {max(n, 1)} numbers >= 0 with a positive sum, "
                  "one per target state")
        else:
            weights = tuple(float(x) for x in w)
    after = (0.0, 0.0)
    rate = 0.0
    if on == "timer":
        a = t.get("after", MISSING)
        if is_num(a) and float(a) >= 0:  # type: ignore[arg-type]
            after = (float(a), float(a))  # type: ignore[arg-type]
        elif isinstance(a, list) and len(a) == 2 and all(is_num(x) for x in a) and 0 <= a[0] <= a[1]:
            after = (float(a[0]), float(a[1]))
        else:
            c.bad(f"{path}.after", a, "required for a timer: seconds >= 0, or [lo, hi] with lo <= hi")
    elif "after" in t:
        c.bad(f"{path}.after", t["after"], "only a timer transition takes 'after'")
    if on == "probability":
        r = c.number(t, "rate", f"{path}.rate", check=lambda x: x > 0, expect="> 0 per second")
        rate = r or 0.0
    elif "rate" in t:
        c.bad(f"{path}.rate", t["rate"], "only a probability transition takes 'rate'")
    if on is None or to is None:
        return None
    return Transition(on=on, to=to, weights=weights, after=after, rate=rate)


def _table_keys(data: dict[str, Any], *keys: str) -> list[str]:
    """The keys of the table at ``data[keys[0]][keys[1]]...`` as written, or [] (not a table)."""
    node: object = data
    for k in keys:
        node = node.get(k) if isinstance(node, dict) else None
    return list(node) if isinstance(node, dict) else []


def _profile_and_state(c: _Checker, s: dict[str, Any], path: str, profiles: dict[str, AgentProfile],
                       behavior: BehaviorConfig | None,
                       declared: tuple[set[str], set[str]]) -> tuple[str | None, str | None]:
    """A spawn's or source's ``profile`` and ``state``, each checked against the ones the file
    declares (``declared``: names with problems of their own are not also "unknown")."""
    profile = c.string(s, "profile", f"{path}.profile")
    if profile is not None and profile not in profiles and profile not in declared[0]:
        known = sorted(set(profiles) | declared[0])
        c.bad(f"{path}.profile", profile, f"unknown profile; known: {', '.join(known) or 'none'}")
    state = c.string(s, "state", f"{path}.state")
    if state is not None and behavior is not None and state not in behavior.states \
            and state not in declared[1]:
        known = sorted(set(behavior.states) | declared[1])
        c.bad(f"{path}.state", state, f"unknown state; known: {', '.join(known) or 'none'}")
    return profile, state


def _spawns(c: _Checker, raw: object, profiles: dict[str, AgentProfile],
            behavior: BehaviorConfig | None, world: WorldConfig | None, *,
            declared: tuple[set[str], set[str]] = (set(), set())) -> tuple[Spawn, ...]:
    """``declared``: the profile and state names the file declares; a spawn naming one that has
    problems of its own is not reported again as "unknown" (those problems say what is wrong)."""
    if raw is MISSING:
        return ()
    if not isinstance(raw, list):
        c.bad("agents.spawns", raw, "expected an array of tables [[agents.spawns]]")
        return ()
    out = []
    blocked = _blocked(world)
    for i, s in enumerate(raw):
        path = f"agents.spawns[{i}]"
        if not isinstance(s, dict):
            c.bad(path, s, "expected a table")
            continue
        c.known(s, path, ("profile", "state", "positions", "count", "region", "facing_deg", "friends"))
        friends = c.boolean(s, "friends", f"{path}.friends", default=False)
        profile, state = _profile_and_state(c, s, path, profiles, behavior, declared)
        facing = c.number(s, "facing_deg", f"{path}.facing_deg", required=False, default=None)
        positions: tuple[Vec2, ...] = ()
        count = 0
        region: tuple[str, tuple[float, ...]] | None = None
        if ("positions" in s) == ("region" in s):
            c.bad(path, "{...}", "expected exactly one of 'positions' or 'count' with 'region'")
        elif "positions" in s:
            positions = c.points(s, "positions", f"{path}.positions") or ()
            for k, p in enumerate(positions):
                if blocked is not None and blocked.contains(Point(p)):
                    c.bad(f"{path}.positions[{k}]", list(p), "lies outside the walkable area")
        else:
            count = c.whole(s, "count", f"{path}.count", minimum=1) or 0
            region = _region(c, s["region"], f"{path}.region")
        if friends and (len(positions) or count) % 2:
            c.bad(f"{path}.friends", True, "friends walk in pairs: the spawn needs an even number of agents")
        if profile in profiles and state is not None and (positions or count):
            out.append(Spawn(profile=profile, state=state, positions=positions, count=count,
                             region=region, facing=None if facing is None else math.radians(facing),
                             friends=bool(friends)))
    return tuple(out)


def _sources(c: _Checker, raw: object, profiles: dict[str, AgentProfile],
             behavior: BehaviorConfig | None, world: WorldConfig | None, *,
             declared: tuple[set[str], set[str]] = (set(), set())) -> tuple[Source, ...]:
    """``[[agents.sources]]``: agents arriving at a rate into an area or along a line. ``declared``
    as for :func:`_spawns`: a profile or state with problems of its own is not also unknown."""
    if raw is MISSING:
        return ()
    if not isinstance(raw, list) or not all(isinstance(x, dict) for x in raw):
        c.bad("agents.sources", raw, "expected an array of tables [[agents.sources]]")
        return ()
    out = []
    blocked = _blocked(world)
    for i, s in enumerate(raw):
        path = f"agents.sources[{i}]"
        c.known(s, path, ("profile", "state", "rate", "region", "line", "max_count", "start", "stop",
                          "timing", "facing_deg"))
        profile, state = _profile_and_state(c, s, path, profiles, behavior, declared)
        rate = c.number(s, "rate", f"{path}.rate", check=lambda x: 0 < x <= 100,
                        expect="in (0, 100] agents/s")
        max_count = c.whole(s, "max_count", f"{path}.max_count", required=False, default=0)
        start = c.number(s, "start", f"{path}.start", required=False, default=0.0,
                         check=lambda x: x >= 0, expect=">= 0 s")
        stop = c.number(s, "stop", f"{path}.stop", required=False, default=math.inf,
                        check=lambda x: x > 0, expect="> 0 s")
        if start is not None and stop is not None and stop <= start:
            c.bad(f"{path}.stop", stop, f"must be after start ({start} s)")
        timing = c.string(s, "timing", f"{path}.timing", required=False, default="regular",
                          choices=SOURCE_TIMINGS)
        facing = c.number(s, "facing_deg", f"{path}.facing_deg", required=False, default=None)
        region: tuple[str, tuple[float, ...]] | None = None
        line: tuple[Vec2, Vec2] | None = None
        if ("region" in s) == ("line" in s):
            given = "both region and line" if "region" in s else "neither region nor line"
            c.bad(path, given,
                  "expected exactly one of 'region' (a spawn area) or 'line' [[x0, y0], [x1, y1]]")
        elif "region" in s:
            region = _region(c, s["region"], f"{path}.region")
            if region is not None and region[0] == "circle":
                c.bad(f"{path}.region", s["region"],
                      "expected {box = [...]} or {disc = [cx, cy, r]}: an area")
                region = None
            if region is not None and blocked is not None and blocked.contains(_region_shape(region)):
                c.bad(f"{path}.region", s["region"], "lies outside the walkable area")
        else:
            pts = c.points(s, "line", f"{path}.line", minimum=2)
            if pts is not None and len(pts) != 2:
                c.bad(f"{path}.line", s["line"], "expected exactly two points [[x0, y0], [x1, y1]]")
            elif pts is not None and math.dist(pts[0], pts[1]) < 0.05:
                c.bad(f"{path}.line", s["line"], "expected two points at least 0.05 m apart")
            elif pts is not None:
                line = (pts[0], pts[1])
                if blocked is not None and blocked.contains(LineString(line)):
                    c.bad(f"{path}.line", s["line"], "lies outside the walkable area")
        if (profile in profiles and state is not None and rate is not None and max_count is not None
                and start is not None and stop is not None and timing is not None
                and (region is not None or line is not None)):
            out.append(Source(profile=profile, state=state, rate=rate, region=region, line=line,
                              max_count=max_count, start=start, stop=stop, timing=timing,
                              facing=None if facing is None else math.radians(facing)))
    return tuple(out)


def _sinks(c: _Checker, raw: object, world: WorldConfig | None, behavior: BehaviorConfig | None, *,
           declared: set[str]) -> tuple[Sink, ...]:
    """``[[agents.sinks]]``: exit regions that remove the agents that reach them (``states``: only
    those in one of these BFSM states; ``declared`` as for :func:`_spawns`)."""
    if raw is MISSING:
        return ()
    if not isinstance(raw, list) or not all(isinstance(x, dict) for x in raw):
        c.bad("agents.sinks", raw, "expected an array of tables [[agents.sinks]]")
        return ()
    out = []
    blocked = _blocked(world)
    for i, s in enumerate(raw):
        path = f"agents.sinks[{i}]"
        c.known(s, path, ("region", "states"))
        states = _sink_states(c, s, path, behavior, declared)
        if "region" not in s:
            c.bad(f"{path}.region", MISSING,
                  "required {box = [xmin, ymin, xmax, ymax]} or {disc = [cx, cy, r]}")
            continue
        region = _region(c, s["region"], f"{path}.region")
        if region is not None and region[0] == "circle":
            c.bad(f"{path}.region", s["region"],
                  "expected {box = [...]} or {disc = [cx, cy, r]}: an area")
            continue
        if region is not None and blocked is not None and blocked.contains(_region_shape(region)):
            c.bad(f"{path}.region", s["region"], "lies outside the walkable area: no agent could reach it")
            continue
        if region is not None:
            out.append(Sink(region=region, states=states))
    return tuple(out)


def _sink_states(c: _Checker, s: dict[str, Any], path: str, behavior: BehaviorConfig | None,
                 declared: set[str]) -> tuple[str, ...]:
    """A sink's optional ``states``: a non-empty array of the file's BFSM state names."""
    raw = s.get("states", MISSING)
    if raw is MISSING:
        return ()
    if not isinstance(raw, list) or not raw or not all(isinstance(x, str) for x in raw):
        c.bad(f"{path}.states", raw, "expected a non-empty array of state names")
        return ()
    known = set(declared) | (set(behavior.states) if behavior is not None else set())
    unknown = [x for x in raw if x not in known]
    if unknown:
        c.bad(f"{path}.states", raw,
              f"unknown state {unknown[0]!r}; known: {', '.join(sorted(known)) or 'none'}")
        return ()
    return tuple(raw)


def _region_shape(region: tuple[str, tuple[float, ...]]) -> Any:
    """A box or disc region as a shapely polygon."""
    kind, v = region
    return box(*v) if kind == "box" else Point(v[0], v[1]).buffer(v[2])


def _region(c: _Checker, r: object, path: str) -> tuple[str, tuple[float, ...]] | None:
    kinds = {"box": (4, "[xmin, ymin, xmax, ymax]"), "circle": (3, "[cx, cy, radius]"),
             "disc": (3, "[cx, cy, radius]")}
    if not isinstance(r, dict) or len(r) != 1 or next(iter(r)) not in kinds:
        c.bad(path, r, "expected one of {box = [xmin, ymin, xmax, ymax]}, {circle = [cx, cy, r]}, "
              "{disc = [cx, cy, r]}")
        return None
    kind = next(iter(r))
    n, expect = kinds[kind]
    v = c.floats(r[kind], f"{path}.{kind}", n, expect)
    if v is None:
        return None
    if (kind == "box" and not (v[0] < v[2] and v[1] < v[3])) or (kind != "box" and v[2] <= 0):
        c.bad(f"{path}.{kind}", r[kind], f"expected {expect} with positive size")
        return None
    return (kind, v)


def _blocked(world: WorldConfig | None) -> Any:
    """Everything not walkable (outside the bounds or inside an obstacle), or None."""
    if world is None:
        return None
    from shapely.ops import unary_union

    (x0, y0), (x1, y1) = world.bounds
    outside = box(x0 - 1e6, y0 - 1e6, x1 + 1e6, y1 + 1e6).difference(box(x0, y0, x1, y1))
    return unary_union([outside, *(Polygon(o.vertices) for o in world.obstacles)])


def _user(c: _Checker, u: dict[str, Any], world: WorldConfig | None) -> UserConfig | None:
    c.known(u, "user", ("start", "heading_deg", "radius", "speed", "route", "sphere_radius",
                        "enabled", "walk", "sex", "carrying", "door_hold"))
    sex = c.string(u, "sex", "user.sex", required=False, default="male", choices=SEXES)
    carrying = c.string(u, "carrying", "user.carrying", required=False, default="none", choices=CARRYING)
    door_hold = c.number(u, "door_hold", "user.door_hold", required=False, default=0.0,
                         check=lambda x: 0.0 <= x <= 60.0, expect="in [0, 60] s")
    s = u.get("start", MISSING)
    start = c.point(s, "user.start") if s is not MISSING else None
    if s is MISSING:
        c.bad("user.start", s, "required [x, y]")
    heading = c.number(u, "heading_deg", "user.heading_deg", required=False, default=0.0)
    radius = c.number(u, "radius", "user.radius", required=False, default=0.25,
                      check=lambda x: x > 0, expect="> 0 m")
    speed = c.number(u, "speed", "user.speed", required=False, default=1.3,
                     check=lambda x: 0 < x <= 3, expect="in (0, 3] m/s")
    route = c.points(u, "route", "user.route", required=False) or ()
    sphere = c.number(u, "sphere_radius", "user.sphere_radius", required=False, default=0.5,
                      check=lambda x: x > 0, expect="> 0 m")
    enabled = c.boolean(u, "enabled", "user.enabled", default=True)
    walk = u.get("walk", "straight")
    if walk not in USER_WALKS:
        c.bad("user.walk", walk, f"expected one of {', '.join(USER_WALKS)}")
        walk = "straight"
    blocked = _blocked(world)
    if blocked is not None:
        for key, p in [("user.start", start)] + [(f"user.route[{k}]", q) for k, q in enumerate(route)]:
            if p is not None and blocked.contains(Point(p)):
                c.bad(key, list(p), "lies outside the walkable area")
    if start is None or heading is None or radius is None or speed is None or sphere is None:
        return None
    return UserConfig(start=start, heading=math.radians(heading), radius=radius, speed=speed,
                      route=route, sphere_radius=sphere, enabled=enabled, walk=walk, sex=sex or "male",
                      carrying=carrying or "none", door_hold=door_hold or 0.0)
