"""The SteerSuite importer, against the SteerBench cases and hand-made files.

The SteerSuite cases are GPL reference data outside the repository; they are
read from ``../shared/benchmarks/steersuite/`` and never copied here.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from shapely.geometry import Point, Polygon

from pedvr.errors import SceneError
from pedvr.scene.config import SceneConfig
from pedvr.scene.steersuite import load_steersuite

CASES = Path(__file__).resolve().parents[2] / ".." / "shared" / "benchmarks" / "steersuite"
CASE_FILES = sorted(CASES.glob("*.xml")) if CASES.is_dir() else []
UNSUPPORTED = ("agentEmitter", "seekDynamicTarget", "fleeDynamicTarget")

needs_cases = pytest.mark.skipif(not CASE_FILES, reason=f"SteerSuite cases not found in {CASES}")


def _unsupported_in(path: Path) -> set[str]:
    """Unsupported elements used by a case, comments aside."""
    text = re.sub(r"<!--.*?-->", "", path.read_text(encoding="utf-8"), flags=re.DOTALL)
    return {tag for tag in UNSUPPORTED if re.search(rf"<{tag}\b", text)}


def _case(tmp_path: Path, body: str, *, bounds: str = "-20 20 -20 20", name: str = "t") -> Path:
    x0, x1, z0, z1 = bounds.split()
    xml = f"""<?xml version="1.0"?>
<SteerBenchTestCase xmlns="http://www.magix.ucla.edu/steerbench">
  <header>
    <version>1.0</version>
    <name>{name}</name>
    <worldBounds>
      <xmin>{x0}</xmin> <xmax>{x1}</xmax> <ymin>0</ymin> <ymax>0</ymax>
      <zmin>{z0}</zmin> <zmax>{z1}</zmax>
    </worldBounds>
  </header>
{body}
</SteerBenchTestCase>
"""
    p = tmp_path / f"{name}.xml"
    p.write_text(xml, encoding="utf-8")
    return p


def _agent(pos: str = "<x>0</x><y>0</y><z>0</z>", radius: str = "0.5",
           direction: str = "<x>1</x><y>0</y><z>0</z>",
           goals: str = "<seekStaticTarget><targetLocation><x>5</x><y>0</y><z>0</z>"
                        "</targetLocation><desiredSpeed>1.3</desiredSpeed>"
                        "<timeDuration>100</timeDuration></seekStaticTarget>") -> str:
    position = f"<position>{pos}</position>" if pos else ""
    return f"""<agent>
    <initialConditions>
      <radius>{radius}</radius>{position}
      <direction>{direction}</direction>
      <speed>0</speed>
    </initialConditions>
    <goalSequence>{goals}</goalSequence>
  </agent>"""


def _signed_area(vertices: tuple[tuple[float, float], ...]) -> float:
    n = len(vertices)
    return 0.5 * sum(vertices[k][0] * vertices[(k + 1) % n][1]
                     - vertices[(k + 1) % n][0] * vertices[k][1] for k in range(n))


def _check_invariants(scene: SceneConfig) -> None:
    (x0, y0), (x1, y1) = scene.world.bounds
    assert x0 < x1 and y0 < y1
    for o in scene.world.obstacles:
        assert _signed_area(o.vertices) > 0, "obstacles must be counter-clockwise"
        assert o.height >= 0
    for sp in scene.spawns:
        assert sp.profile in scene.profiles
        assert sp.state in scene.behavior.states
        assert sp.goal_sequence
        assert (len(sp.positions) > 0) != (sp.region is not None)
        for x, y in sp.positions:
            assert x0 <= x <= x1 and y0 <= y <= y1
        if sp.region is not None:
            kind, (rx0, ry0, rx1, ry1) = sp.region
            assert kind == "box" and rx0 < rx1 and ry0 < ry1 and sp.count > 0
        if sp.facing is not None:
            assert -math.pi <= sp.facing <= math.pi
        for g in sp.goal_sequence:
            assert g.kind in ("seek", "flee", "idle", "flow")
            assert all(math.isfinite(v) for v in g.target) and g.speed >= 0 and g.duration > 0
    for p in scene.profiles.values():
        assert p.radius > 0 and 0 < p.pref_speed < p.max_speed
    assert MIN_DURATION <= scene.duration <= MAX_DURATION
    assert scene.dt == pytest.approx(1 / 90)
    assert len(scene.content_hash) == 16
    assert not scene.user.enabled
    ux, uy = scene.user.start
    assert x0 <= ux <= x1 and y0 <= uy <= y1
    assert not any(Polygon(o.vertices).distance(Point(ux, uy)) < scene.user.radius
                   for o in scene.world.obstacles)


MIN_DURATION, MAX_DURATION = 30.0, 120.0


# ---------------------------------------------------------------- the SteerBench cases


@needs_cases
def test_every_case_loads_or_names_what_is_unsupported() -> None:
    expected_failures = {p.name for p in CASE_FILES if _unsupported_in(p)}
    assert {"simple-emitter.xml", "EXAMPLE.xml"} <= expected_failures
    failures: set[str] = set()
    for path in CASE_FILES:
        try:
            scene = load_steersuite(path, seed=7)
        except SceneError as e:
            failures.add(path.name)
            for tag in _unsupported_in(path):
                assert tag in str(e), f"{path.name}: {e}"
            for line in e.problems:
                assert line.startswith(f"{path}: ")
                assert "not supported" in line
            continue
        _check_invariants(scene)
    assert failures == expected_failures


@needs_cases
def test_crossing_1() -> None:
    path = CASES / "crossing-1.xml"
    scene = load_steersuite(path, seed=0)
    assert scene.name == "crossing-1"
    assert scene.source == str(path)
    assert [sp.positions for sp in scene.spawns] == [((9.0, 1.0),), ((1.0, 10.0),)]
    assert [sp.goal_sequence[0].target for sp in scene.spawns] == [(-10.0, 1.0), (1.0, -10.0)]
    assert [sp.goal_sequence[0].kind for sp in scene.spawns] == ["seek", "seek"]
    assert scene.spawns[0].facing == pytest.approx(math.pi)
    assert scene.spawns[1].facing == pytest.approx(-math.pi / 2)
    assert scene.world.bounds == ((-100.0, -100.0), (100.0, 100.0))
    (profile,) = scene.profiles.values()
    assert (profile.name, profile.radius, profile.pref_speed) == ("steersuite_r0.50", 0.5, 1.3)
    assert profile.max_speed == pytest.approx(1.625)
    assert scene.duration == 120.0  # 1000 s goals, capped
    seek = scene.behavior.states["seek"]
    assert seek.goal is not None and seek.goal.kind == "sequence"
    assert seek.transitions[0].on == "arrival" and seek.transitions[0].to == ("exit",)
    assert seek.arrive_dist == 1.0
    assert scene.behavior.states["exit"].final
    # The user is far from both agents.
    assert min(math.dist(scene.user.start, sp.positions[0]) for sp in scene.spawns) > 50


@needs_cases
def test_declaration_after_licence_comment() -> None:
    scene = load_steersuite(CASES / "concentric-circles-noise.xml", seed=0)
    assert len(scene.spawns) == 20


@needs_cases
def test_inverted_world_bounds_are_grown_around_the_agents() -> None:
    scene = load_steersuite(CASES / "circle-20.xml", seed=0)  # bounds -100..-200
    (x0, y0), (x1, y1) = scene.world.bounds
    for sp in scene.spawns:
        (x, y), = sp.positions
        assert x0 < x < x1 and y0 < y < y1
        tx, ty = sp.goal_sequence[0].target
        assert x0 < tx < x1 and y0 < ty < y1


@needs_cases
def test_random_region_targets_and_positions_are_clear() -> None:
    scene = load_steersuite(CASES / "forest.xml", seed=3)
    polys = [Polygon(o.vertices) for o in scene.world.obstacles]
    assert len(polys) == 4 + 696  # walls + the obstacle region
    pts = [sp.positions[0] for sp in scene.spawns]
    assert len(pts) == 500  # the region, expanded: each agent has its own random targets
    from shapely import STRtree

    tree = STRtree(polys)
    for sp in scene.spawns:
        r = scene.profiles[sp.profile].radius
        assert len(tree.query(Point(sp.positions[0]), predicate="dwithin", distance=r * 0.999)) == 0
        for g in sp.goal_sequence:
            assert len(tree.query(Point(g.target), predicate="dwithin", distance=r * 0.999)) == 0
    for i, a in enumerate(pts):
        for b in pts[i + 1:]:
            assert math.dist(a, b) >= 1.0 - 1e-9


@needs_cases
def test_box_region_goal_is_a_point_in_the_box() -> None:
    scene = load_steersuite(CASES / "hallway-twoway-2.xml", seed=0)
    assert len(scene.spawns) == 800
    for sp in scene.spawns:
        (g,) = sp.goal_sequence
        x, y = g.target
        assert g.kind == "seek" and -6 <= y <= 6 and 95 <= abs(x) <= 104
    assert len({sp.goal_sequence[0].target for sp in scene.spawns}) == 800


# ---------------------------------------------------------------- obstacles


def test_oriented_box_matches_hand_computation(tmp_path: Path) -> None:
    body = """<orientedBoxObstacle>
    <thetaY>90</thetaY>
    <size><x>4</x><y>1.5</y><z>2</z></size>
    <position><x>1</x><y>0</y><z>2</z></position>
  </orientedBoxObstacle>""" + _agent(pos="<x>-10</x><y>0</y><z>-10</z>")
    scene = load_steersuite(_case(tmp_path, body), seed=0)
    (box,) = scene.world.obstacles
    # thetaY = 90 rotates SteerSuite's local (x, z) to (z, -x): the 4 m side
    # turns from +x onto -z. Corners (-2,-1) (2,-1) (2,1) (-2,1) about (1, 2):
    expected = [(0.0, 4.0), (0.0, 0.0), (2.0, 0.0), (2.0, 4.0)]
    assert [tuple(round(c, 9) for c in v) for v in box.vertices] == expected
    assert box.height == 1.5 and box.kind == "box"
    assert _signed_area(box.vertices) == pytest.approx(8.0)


def test_oriented_box_positive_theta_turns_clockwise(tmp_path: Path) -> None:
    body = """<orientedBoxObstacle>
    <thetaY>30</thetaY>
    <size><x>10</x><y>1</y><z>1</z></size>
    <position><x>0</x><y>0</y><z>0</z></position>
  </orientedBoxObstacle>""" + _agent(pos="<x>-10</x><y>0</y><z>-10</z>")
    (box,) = load_steersuite(_case(tmp_path, body), seed=0).world.obstacles
    (ax, ay), (bx, by) = box.vertices[0], box.vertices[1]
    assert math.atan2(by - ay, bx - ax) == pytest.approx(-math.radians(30))


def test_circle_obstacle_polygon_contains_the_circle(tmp_path: Path) -> None:
    body = """<circleObstacle>
    <radius>2</radius><height>3</height>
    <position><x>4</x><y>0</y><z>-1</z></position>
  </circleObstacle>""" + _agent(pos="<x>-10</x><y>0</y><z>-10</z>")
    (pillar,) = load_steersuite(_case(tmp_path, body), seed=0).world.obstacles
    assert len(pillar.vertices) == 16 and pillar.height == 3
    poly = Polygon(pillar.vertices)
    disc = Point(4, -1).buffer(2.0, quad_segs=256)
    assert poly.buffer(1e-9).covers(disc)
    assert poly.exterior.distance(Point(4, -1)) == pytest.approx(2.0)  # edges touch the circle
    assert poly.area < 1.02 * math.pi * 4
    assert _signed_area(pillar.vertices) > 0


def test_axis_aligned_box(tmp_path: Path) -> None:
    body = """<obstacle><xmin>1</xmin><xmax>3</xmax><ymin>0</ymin><ymax>2</ymax>
    <zmin>-1</zmin><zmax>4</zmax></obstacle>""" + _agent(pos="<x>-10</x><y>0</y><z>-10</z>")
    (box,) = load_steersuite(_case(tmp_path, body), seed=0).world.obstacles
    assert box.vertices == ((1.0, -1.0), (3.0, -1.0), (3.0, 4.0), (1.0, 4.0))
    assert box.height == 2.0


# ---------------------------------------------------------------- <random> expansion

RANDOM_BODY = """
  <obstacleRegion>
    <numObstacles>20</numObstacles><obstacleSize>1</obstacleSize>
    <obstacleHeight>1</obstacleHeight>
    <regionBounds><xmin>-15</xmin><xmax>15</xmax><ymin>0</ymin><ymax>0</ymax>
      <zmin>-15</zmin><zmax>15</zmax></regionBounds>
  </obstacleRegion>
  <agent>
    <initialConditions>
      <radius>0.4</radius>
      <position><random>true</random></position>
      <direction><random>true</random></direction>
      <speed>0</speed>
    </initialConditions>
    <goalSequence>
      <seekStaticTarget><targetLocation><random>true</random></targetLocation>
        <desiredSpeed>1.2</desiredSpeed><timeDuration>20</timeDuration></seekStaticTarget>
      <flowStaticDirection><targetDirection><random>true</random></targetDirection>
        <desiredSpeed>1.0</desiredSpeed><timeDuration>5</timeDuration></flowStaticDirection>
      <idle><desiredSpeed>0</desiredSpeed><timeDuration>3</timeDuration></idle>
      <fleeStaticTarget><targetLocation><x>1</x><y>0</y><z>2</z></targetLocation>
        <desiredSpeed>1.5</desiredSpeed><timeDuration>4</timeDuration></fleeStaticTarget>
    </goalSequence>
  </agent>
  <agentRegion>
    <numAgents>5</numAgents>
    <regionBounds><xmin>-5</xmin><xmax>5</xmax><ymin>0</ymin><ymax>0</ymax>
      <zmin>-5</zmin><zmax>5</zmax></regionBounds>
    <initialConditions>
      <radius>0.5</radius><direction><x>0</x><y>0</y><z>1</z></direction><speed>0</speed>
    </initialConditions>
    <goalSequence>
      <seekStaticTarget><targetLocation><random>true</random></targetLocation>
        <desiredSpeed>1.3</desiredSpeed><timeDuration>100</timeDuration></seekStaticTarget>
    </goalSequence>
  </agentRegion>
  <agentRegion>
    <numAgents>7</numAgents>
    <regionBounds><xmin>-5</xmin><xmax>5</xmax><ymin>0</ymin><ymax>0</ymax>
      <zmin>10</zmin><zmax>8</zmax></regionBounds>
    <initialConditions>
      <radius>0.5</radius><direction><random>true</random></direction><speed>0</speed>
    </initialConditions>
    <goalSequence>
      <seekStaticTarget><targetLocation><x>0</x><y>0</y><z>-18</z></targetLocation>
        <desiredSpeed>1.3</desiredSpeed><timeDuration>100</timeDuration></seekStaticTarget>
    </goalSequence>
  </agentRegion>
"""


def test_random_expansion_is_deterministic_per_seed(tmp_path: Path) -> None:
    path = _case(tmp_path, RANDOM_BODY)
    a, b, c = (load_steersuite(path, seed=s) for s in (11, 11, 12))
    assert a == b
    assert a.world.obstacles != c.world.obstacles
    assert a.spawns != c.spawns
    _check_invariants(a)

    assert len(a.world.obstacles) == 20
    polys = [Polygon(o.vertices) for o in a.world.obstacles]
    for p, q in ((p, q) for i, p in enumerate(polys) for q in polys[i + 1:]):
        assert not p.overlaps(q) and not p.within(q)
    single, *expanded, region = a.spawns
    # The agent: a position clear of obstacles, a random facing and targets.
    (pos,) = single.positions
    assert all(poly.distance(Point(pos)) >= 0.4 for poly in polys)
    assert single.facing is not None
    seek, flow, idle, flee = single.goal_sequence
    assert (seek.kind, flow.kind, idle.kind, flee.kind) == ("seek", "flow", "idle", "flee")
    assert -20 <= seek.target[0] <= 20 and -20 <= seek.target[1] <= 20
    assert math.hypot(*flow.target) == pytest.approx(1.0)
    assert (idle.duration, flee.target, flee.speed) == (3.0, (1.0, 2.0), 1.5)
    # A region with random targets is expanded agent by agent...
    assert len(expanded) == 5
    assert all(sp.facing == pytest.approx(math.pi / 2) for sp in expanded)
    assert len({sp.goal_sequence[0].target for sp in expanded}) == 5
    for sp in expanded:
        (x, y), = sp.positions
        assert -5 <= x <= 5 and -5 <= y <= 5
    # ... one without is left to the simulation, with its box sorted.
    assert region.positions == () and region.count == 7
    assert region.region == ("box", (-5.0, 8.0, 5.0, 10.0))
    assert region.facing is None  # random direction: face the first goal
    assert a.duration == 100.0  # the regions' 100 s goals
    assert a.profiles[single.profile].pref_speed == 1.2
    assert a.profiles[single.profile].max_speed == pytest.approx(1.5 + 0.375)


def test_short_goals_give_at_least_thirty_seconds(tmp_path: Path) -> None:
    goals = ("<seekStaticTarget><targetLocation><x>5</x><y>0</y><z>0</z></targetLocation>"
             "<desiredSpeed>1.3</desiredSpeed><timeDuration>10</timeDuration></seekStaticTarget>"
             "<idle><desiredSpeed>0</desiredSpeed><timeDuration>inf</timeDuration></idle>")
    scene = load_steersuite(_case(tmp_path, _agent(goals=goals)), seed=0)
    assert scene.duration == 30.0
    assert scene.spawns[0].goal_sequence[1].duration == math.inf
    assert scene.name == "t" and scene.description == "SteerSuite case t"


# ---------------------------------------------------------------- errors


def test_malformed_xml(tmp_path: Path) -> None:
    path = tmp_path / "bad.xml"
    path.write_text("<!-- licence -->\n<?xml version='1.0'?>\n<SteerBenchTestCase>\n"
                    "  <header><name>x</name>\n</SteerBenchTestCase>\n", encoding="utf-8")
    with pytest.raises(SceneError, match=r"bad\.xml: malformed XML at line 5, column \d+") as e:
        load_steersuite(path, seed=0)
    assert len(e.value.problems) == 1


def test_negative_radius(tmp_path: Path) -> None:
    path = _case(tmp_path, _agent(radius="-1"))
    with pytest.raises(SceneError,
                       match=rf"^{re.escape(str(path))}: agent\[0\]\.initialConditions\.radius "
                             r"= -1: must be > 0$"):
        load_steersuite(path, seed=0)


def test_missing_position(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"agent\[0\]\.initialConditions\.position = "
                                         r"<missing>: required"):
        load_steersuite(_case(tmp_path, _agent(pos="")), seed=0)


def test_emitter(tmp_path: Path) -> None:
    body = _agent().replace("<agent>", "<agentEmitter>").replace("</agent>", "</agentEmitter>")
    with pytest.raises(SceneError, match=r"agentEmitter\[0\]: agent emitters are not supported"):
        load_steersuite(_case(tmp_path, body), seed=0)


def test_dynamic_target(tmp_path: Path) -> None:
    goals = ("<seekDynamicTarget><targetName>B</targetName><random>false</random>"
             "<desiredSpeed>1</desiredSpeed><timeDuration>9</timeDuration></seekDynamicTarget>")
    with pytest.raises(SceneError, match=r"agent\[0\]\.goalSequence\.seekDynamicTarget\[0\]: "
                                         r"dynamic targets are not supported"):
        load_steersuite(_case(tmp_path, _agent(goals=goals)), seed=0)


def test_all_problems_are_reported_at_once(tmp_path: Path) -> None:
    body = (_agent(radius="-1") + _agent(pos="") + "<teleporter/>"
            + _agent(goals="<seekStaticTarget><targetLocation><random>true</random>"
                           "</targetLocation><timeDuration>1</timeDuration>"
                           "</seekStaticTarget>"))
    with pytest.raises(SceneError) as e:
        load_steersuite(_case(tmp_path, body), seed=0)
    lines = e.value.problems
    assert len(lines) == 4, lines
    assert any("agent[0].initialConditions.radius = -1" in x for x in lines)
    assert any("agent[1].initialConditions.position = <missing>" in x for x in lines)
    assert any("teleporter[0]: unknown element" in x for x in lines)
    assert any("agent[2].goalSequence.seekStaticTarget[0].desiredSpeed = <missing>" in x
               for x in lines)
    assert str(e.value) == "\n".join(lines)


def test_bad_values_name_path_and_value(tmp_path: Path) -> None:
    body = _agent(pos="<x>a</x><y>0</y><z>0</z>") + _agent(
        pos="<random>true</random><x>1</x><y>0</y><z>0</z>")
    with pytest.raises(SceneError) as e:
        load_steersuite(_case(tmp_path, body), seed=0)
    text = str(e.value)
    assert "agent[0].initialConditions.position.x = 'a': expected a number" in text
    assert "agent[1].initialConditions.position: either <x>, <y>, <z> or <random>true</random>" \
        in text


def test_overfull_region_is_an_error(tmp_path: Path) -> None:
    body = """<obstacleRegion>
    <numObstacles>50</numObstacles><obstacleSize>2</obstacleSize>
    <obstacleHeight>1</obstacleHeight>
    <regionBounds><xmin>0</xmin><xmax>4</xmax><ymin>0</ymin><ymax>0</ymax>
      <zmin>0</zmin><zmax>4</zmax></regionBounds>
  </obstacleRegion>""" + _agent(pos="<x>-10</x><y>0</y><z>-10</z>")
    with pytest.raises(SceneError, match=r"obstacleRegion\[0\]: could not place obstacle"):
        load_steersuite(_case(tmp_path, body), seed=0)
