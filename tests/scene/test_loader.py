"""Scene validation: every problem at once, each naming file, key, value and expectation."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import tomli_w

from pedvr.errors import SceneError
from pedvr.scene.loader import load_scene
from pedvr.scenes import shipped_scenes

GOOD = {
    "scene": {"name": "t", "seed": 1, "duration": 10.0},
    "world": {"bounds": [[-5.0, -5.0], [5.0, 5.0]],
              "obstacles": [{"kind": "box", "box": [1.0, 1.0, 2.0, 2.0]}]},
    "agents": {
        "profiles": {"adult": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6},
                     "child": {"inherit": "adult", "radius": 0.2}},
        "spawns": [{"profile": "child", "state": "walk", "positions": [[-3.0, 0.0]]}],
    },
    "behavior": {"states": {
        "walk": {"goal": {"selector": "point", "at": [3.0, -3.0]},
                 "transitions": [{"on": "arrival", "to": "wait"}]},
        "wait": {"goal": {"selector": "stay"}, "transitions": [{"on": "timer", "after": [1, 2], "to": "walk"}]},
    }},
    "user": {"start": [-4.0, -4.0], "route": [[4.0, 4.0]]},
}


def write(tmp_path: Path, data: dict) -> Path:
    p = tmp_path / "x.toml"
    p.write_bytes(tomli_w.dumps(data).encode())
    return p


def patched(**changes: object) -> dict:
    """GOOD with dotted keys replaced (value None deletes the key)."""
    import copy

    d = copy.deepcopy(GOOD)
    for dotted, value in changes.items():
        keys = dotted.split("__")
        node = d
        for k in keys[:-1]:
            node = node[int(k)] if isinstance(node, list) else node[k]
        if value is None:
            del node[keys[-1]]
        elif isinstance(node, list):
            node[int(keys[-1])] = value
        else:
            node[keys[-1]] = value
    return d


def test_good_scene_loads_with_inheritance(tmp_path: Path) -> None:
    s = load_scene(write(tmp_path, GOOD))
    assert s.profiles["child"].radius == 0.2
    assert s.profiles["child"].pref_speed == 1.3  # inherited
    assert s.behavior.states["walk"].goal is not None
    assert s.behavior.states["wait"].goal is None
    assert s.behavior.states["wait"].transitions[0].after == (1.0, 2.0)
    assert len(s.content_hash) == 16
    assert s.behavior.states["wait"].gestures is None


def test_state_gesture_sets_reach_the_body(tmp_path: Path) -> None:
    """PedVR §4.3: a gesture set per BFSM state, drawn by weight."""
    from pedvr.sim import Simulation

    data = patched(behavior__states__wait__gestures={"clips": ["check_phone", "wave"], "weights": [3, 1]})
    s = load_scene(write(tmp_path, data))
    assert s.behavior.states["wait"].gestures == (("check_phone", "wave"), (3.0, 1.0))
    sim = Simulation(s)
    assert sim.body.gestures.by_state == {"wait": (("check_phone", "wave"), (3.0, 1.0))}


DOORWAY = [{"kind": "wall", "wall": [[0.0, -5.0], [0.0, -0.5]]}, {"kind": "wall", "wall": [[0.0, 0.5], [0.0, 5.0]]}]


PULL = {"pull_side": [-1.0, 0.0]}


@pytest.mark.parametrize("door, message", [
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "kind": "sliding", **PULL},
     r"world\.doors\[0\]\.kind = 'sliding': expected one of single, double, revolving$"),
    ({"kind": "single"},
     r"world\.doors\[0\]\.span = <missing>: required \[\[x0, y0\], \[x1, y1\]\] \(or at, width and along_deg\)"),
    ({"span": [[0.0, -0.5], [0.0, 0.5], [0.0, 1.0]], **PULL},
     r"world\.doors\[0\]\.span = .*: expected two jambs \[\[x0, y0\], \[x1, y1\]\]"),
    ({"span": [[0.0, -1.0], [0.0, 1.0]], **PULL},
     r"world\.doors\[0\]\.span = .*: a single door is 0\.7 to 1\.6 m wide; this is 2\.00 m"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "kind": "double", **PULL},
     r"world\.doors\[0\]\.span = .*: a double door is 1\.2 to 3\.2 m wide; this is 1\.00 m"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "kind": "revolving"},
     r"world\.doors\[0\]\.span = .*: a revolving door is 1\.6 to 3\.6 m wide; this is 1\.00 m"),
    ({"span": [[0.0, -1.2], [0.0, -0.2]], **PULL},
     r"world\.doors\[0\]\.span = .*: crosses an obstacle; a door fills a gap between obstacles"),
    ({"span": [[4.8, 0.0], [5.8, 0.0]], "swing": "both_ways"},
     r"world\.doors\[0\]\.span = .*: lies outside world\.bounds"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "height": 9, **PULL},
     r"world\.doors\[0\]\.height = 9: must be in \[1\.5, 4\] m"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "hinge": "left", **PULL},
     r"world\.doors\[0\]\.hinge = 'left': expected one of start, end"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]]},
     r"world\.doors\[0\]\.pull_side = <missing>: required for a one-way door: a point \[x, y\] on the side "
     r"it is pulled open from \(or swing = \"both_ways\"\)$"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "pull_side": [0.0, 2.0]},
     r"world\.doors\[0\]\.pull_side = \[0\.0, 2\.0\]: lies on the door's line; give a point on one side"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "swing": "both_ways", **PULL},
     r"world\.doors\[0\]\.pull_side = .*: a double-acting door \(swing = \"both_ways\"\) has no pull side"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "swing": "sideways"},
     r"world\.doors\[0\]\.swing = 'sideways': expected one of one_way, both_ways"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "rotation": "ccw", **PULL},
     r"world\.doors\[0\]\.rotation = 'ccw': only a revolving door rotates"),
    ({"span": [[0.0, -1.0], [0.0, 1.0]], "kind": "revolving", **PULL},
     r"world\.doors\[0\]\.pull_side = .*: a revolving door has no leaves to swing"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "closing_speed_deg": 5, **PULL},
     r"world\.doors\[0\]\.closing_speed_deg = 5: must be in \[10, 720\] deg/s"),
    ({"span": [[0.0, -0.5], [0.0, 0.5]], "sensing_range": 100, **PULL},
     r"world\.doors\[0\]\.sensing_range = 100: must be in \[2, 50\] m"),
    ({"at": [0.0, 0.0], "width": 1.0, **PULL},
     r"world\.doors\[0\]\.span = <missing>: required \[\[x0, y0\], \[x1, y1\]\] \(or at, width and along_deg\)"),
    ({"at": [0.0, 0.0], "span": [[0.0, -0.5], [0.0, 0.5]], **PULL},
     r"world\.doors\[0\]\.at = \[0\.0, 0\.0\]: give either span or at, width and along_deg"),
])
def test_each_door_problem_has_its_message(tmp_path: Path, door: dict, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        load_scene(write(tmp_path, patched(world__obstacles=DOORWAY, world__doors=[door])))


def test_doors_whose_leaves_would_meet_are_refused(tmp_path: Path) -> None:
    doors = [{"span": [[0.0, -0.5], [0.0, 0.5]], **PULL}, {"span": [[0.2, -0.5], [1.2, -0.5]], "swing": "both_ways"}]
    with pytest.raises(SceneError, match=r"world\.doors\[1\]\.span = .*: its leaves would swing into those "
                                         r"of world\.doors\[0\]"):
        load_scene(write(tmp_path, patched(world__obstacles=DOORWAY, world__doors=doors)))


def test_a_good_door_loads(tmp_path: Path) -> None:
    s = load_scene(write(tmp_path, patched(world__obstacles=DOORWAY,
                                           world__doors=[{"kind": "single", "span": [[0.0, -0.5], [0.0, 0.5]],
                                                          "pull_side": [-1.0, 0.2], "hinge": "end"}])))
    (door,) = s.world.doors
    assert door.kind == "single" and door.width == pytest.approx(1.0) and door.height == 2.1
    # span[0] -> span[1] runs +y; its left is -x, where the pull side is.
    assert door.swing == "one_way" and door.pull == 1 and door.hinge == 1 and door.name == "door_0"


def test_a_revolving_door_gets_its_drum(tmp_path: Path) -> None:
    wall = [{"kind": "wall", "wall": [[0.0, -5.0], [0.0, -1.1]]}, {"kind": "wall", "wall": [[0.0, 1.1], [0.0, 5.0]]}]
    s = load_scene(write(tmp_path, patched(world__obstacles=wall, world__doors=[
        {"kind": "revolving", "at": [0.0, 0.0], "width": 2.2, "along_deg": 90, "name": "main"}])))
    (door,) = s.world.doors
    assert door.kind == "revolving" and door.width == pytest.approx(2.2) and door.name == "main"
    assert len(s.world.obstacles) == 4  # the two walls and the drum's two curved walls
    from shapely.geometry import Point, Polygon

    drum = [Polygon(o.vertices) for o in s.world.obstacles[2:]]
    assert all(d.is_valid for d in drum)
    # The drum closes the door's sides along the wall and leaves both sides of the wall open.
    assert any(d.distance(Point(0.0, 1.15)) < 0.06 for d in drum)
    assert not any(d.distance(Point(1.1, 0.0)) < 0.2 or d.distance(Point(-1.1, 0.0)) < 0.2 for d in drum)


@pytest.mark.parametrize("changes, message", [
    ({"etiquette": {"keep": "middle"}}, r"etiquette\.keep = 'middle': expected one of right, left"),
    ({"etiquette": {"decisions": "coin"}}, r"etiquette\.decisions = 'coin': expected one of meu, sampled"),
    ({"etiquette": {"wait_credit": -1}}, r"etiquette\.wait_credit = -1: must be in \[0, 5\] m/s"),
    ({"etiquette": {"patience": 3}}, r"etiquette\.patience = 3: unknown key"),
    ({"agents__profiles__adult__kindness": 1.5},
     r"agents\.profiles\.adult\.kindness = 1\.5: expected a number in \[0, 1\] or \{uniform = \[lo, hi\]\}"),
    ({"agents__profiles__adult__rush": {"uniform": [0.8, 0.2]}},
     r"agents\.profiles\.adult\.rush = \{\.\.\.\}: expected a number in \[0, 1\] or \{uniform"),
    ({"agents__profiles__adult__carrying": "bag"},
     r"agents\.profiles\.adult\.carrying = 'bag': expected one of none, box, perambulator"),
    ({"agents__profiles__adult__sex": "x"}, r"agents\.profiles\.adult\.sex = 'x': expected one of female, male"),
    ({"user__door_hold": -2}, r"user\.door_hold = -2: must be in \[0, 60\] s"),
    ({"user__carrying": "pram"}, r"user\.carrying = 'pram': expected one of none, box, perambulator"),
])
def test_each_etiquette_problem_has_its_message(tmp_path: Path, changes: dict, message: str) -> None:
    data = patched(**{k: v for k, v in changes.items() if k != "etiquette"})
    if "etiquette" in changes:
        data["etiquette"] = changes["etiquette"]
    with pytest.raises(SceneError, match=message):
        load_scene(write(tmp_path, data))


def test_friends_come_in_pairs(tmp_path: Path) -> None:
    data = patched(agents__spawns__0__friends=True)
    n = len(data["agents"]["spawns"][0].get("positions", [])) or data["agents"]["spawns"][0].get("count", 0)
    if n % 2 == 0:
        data["agents"]["spawns"][0]["positions"] = data["agents"]["spawns"][0]["positions"][:1]
    with pytest.raises(SceneError, match=r"agents\.spawns\[0\]\.friends = true: friends walk in pairs"):
        load_scene(write(tmp_path, data))


@pytest.mark.parametrize("changes, message", [
    ({"agents__profiles__adult__radius": -0.2},
     r"x\.toml: agents\.profiles\.adult\.radius = -0\.2: must be > 0$"),
    ({"scene__seed": None}, r"x\.toml: scene\.seed = <missing>: required"),
    ({"scene__duration": "long"}, r"scene\.duration = 'long': expected a number"),
    ({"world__bounds": [[5.0, 5.0], [-5.0, -5.0]]}, r"world\.bounds = .*min < max"),
    ({"world__obstacles": [{"box": [2.0, 1.0, 1.0, 2.0]}]},
     r"world\.obstacles\[0\]\.box = \[2\.0, 1\.0, 1\.0, 2\.0\]: expected xmin < xmax"),
    ({"world__obstacles": [{"box": [1, 1, 2, 2], "circle": [0, 0, 1]}]},
     r"world\.obstacles\[0\] = .*exactly one shape key"),
    ({"agents__profiles__child__inherit": "ghost"},
     r"agents\.profiles\.child\.inherit = 'ghost': unknown profile; known: adult, child"),
    ({"agents__profiles__adult__inherit": "child"}, r"inheritance cycle"),
    ({"agents__profiles__adult__max_speed": 1.0}, r"max_speed = 1\.0: must be >= pref_speed"),
    ({"agents__profiles__adult__colour": "red"}, r"agents\.profiles\.adult\.colour = 'red': unknown key"),
    ({"agents__spawns__0__state": "run"}, r"agents\.spawns\[0\]\.state = 'run': unknown state; known: wait, walk"),
    ({"agents__spawns__0__positions": [[1.5, 1.5]]},
     r"agents\.spawns\[0\]\.positions\[0\] = \[1\.5, 1\.5\]: lies outside the walkable area"),
    ({"behavior__states__walk__goal": {"selector": "teleport"}},
     r"behavior\.states\.walk\.goal\.selector = 'teleport': expected one of: circle, point, region"),
    ({"behavior__states__walk__goal": {"selector": "circle", "center": [0, 0], "radius": -1, "spread": 0.1}},
     r"behavior\.states\.walk\.goal\.radius = -1: must be a number > 0"),
    ({"behavior__states__walk__goal": {"selector": "set", "set": "booths"}},
     r"goal\.set = 'booths': unknown goal set; known: none"),
    ({"behavior__states__walk__transitions": [{"on": "arrival", "to": "nowhere"}]},
     r"transitions\[0\]\.to = 'nowhere': unknown state 'nowhere'; known: wait, walk"),
    ({"behavior__states__walk__transitions": [{"on": "whenever", "to": "wait"}]},
     r"transitions\[0\]\.on = 'whenever': expected one of arrival, timer, probability"),
    ({"behavior__states__wait__transitions": [{"on": "timer", "to": "walk"}]},
     r"transitions\[0\]\.after = <missing>: required for a timer"),
    ({"behavior__states__walk__goal": None}, r"behavior\.states\.walk\.goal = <missing>: required"),
    ({"user__start": [1.5, 1.5]}, r"user\.start = \[1\.5, 1\.5\]: lies outside the walkable area"),
    ({"user__speed": 9}, r"user\.speed = 9: must be in \(0, 3\] m/s"),
    ({"steering": {"user_responsibility": 1.5}}, r"steering\.user_responsibility = 1\.5: must be in \[0, 1\]"),
    ({"steering": {"personal_space": -0.1}}, r"steering\.personal_space = -0\.1: must be in \[0, 2\] m"),
    ({"steering": {"user_safety": "yes"}}, r"steering\.user_safety = 'yes': expected true or false"),
    ({"steering": {"user_safety_horizon": 0}}, r"steering\.user_safety_horizon = 0: must be > 0 s"),
    ({"steering": {"time_gap": -0.2}}, r"steering\.time_gap = -0\.2: must be in \[0, 5\] s \(0: off\)"),
    ({"steering": {"depth_ratio": 0.4}}, r"steering\.depth_ratio = 0\.4: must be in \[0\.52, 1\] \(a turned"),
    ({"steering": {"dense_slack": -0.1}}, r"steering\.dense_slack = -0\.1: must be in \[0, 1\] m/s \(0: ORCA's"),
    ({"steering": {"time_horizon_obst_coupled": 0}}, r"steering\.time_horizon_obst_coupled = 0: must be > 0 s"),
    ({"user__walk": "zigzag"}, r"user\.walk = 'zigzag': expected one of straight, reactive"),
    ({"colour": "blue"}, r"x\.toml: colour = 'blue': unknown key"),
    ({"behavior__states__wait__gestures": {"clips": ["juggle"]}},
     r"behavior\.states\.wait\.gestures\.clips = \[\"juggle\"\]: unknown gesture 'juggle'; known: wave, point"),
    ({"behavior__states__wait__gestures": {"clips": ["wave", "shrug"], "weights": [1]}},
     r"behavior\.states\.wait\.gestures\.weights = \[1\]: expected 2 numbers >= 0"),
])
def test_each_problem_has_its_message(tmp_path: Path, changes: dict, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        load_scene(write(tmp_path, patched(**changes)))


def test_all_problems_are_reported_at_once(tmp_path: Path) -> None:
    bad = patched(agents__profiles__adult__radius=-1, scene__seed=None, user__speed=0)
    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, bad))
    assert len(info.value.problems) == 3
    assert all(line.startswith(str(tmp_path / "x.toml")) for line in info.value.problems)


def test_malformed_toml_and_missing_file(tmp_path: Path) -> None:
    p = tmp_path / "broken.toml"
    p.write_text("[scene\nname = 1\n")
    with pytest.raises(SceneError, match=r"broken\.toml: not valid TOML: .*line 1"):
        load_scene(p)
    with pytest.raises(SceneError, match=r"nope\.toml: no such scene file"):
        load_scene(tmp_path / "nope.toml")


def test_scene_check_cli_prints_problems_and_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from pedvr.cli import main

    p = write(tmp_path, patched(agents__profiles__adult__radius=-0.2))
    assert main(["scene", "check", str(p)]) == 2
    out = capsys.readouterr().out
    assert "agents.profiles.adult.radius = -0.2: must be > 0" in out
    assert main(["scene", "check", str(write(tmp_path, GOOD))]) == 0


def test_circle_obstacle_circumscribes(tmp_path: Path) -> None:
    s = load_scene(write(tmp_path, patched(world__obstacles=[{"kind": "pillar", "circle": [0.0, 0.0, 1.0]}])))
    v = s.world.obstacles[0].vertices
    # every edge's midpoint is at distance >= r: the true circle lies inside
    for a, b in zip(v, v[1:] + v[:1], strict=True):
        assert math.hypot((a[0] + b[0]) / 2, (a[1] + b[1]) / 2) >= 1.0 - 1e-9


@pytest.mark.parametrize("path", shipped_scenes(), ids=lambda p: p.stem)
def test_shipped_scenes_load(path: Path) -> None:
    s = load_scene(path)
    assert s.user.route, "every shipped scene has a red-sphere route"
    assert sum(sp.count or len(sp.positions) for sp in s.spawns) >= 1


def test_all_six_paper_scenes_are_shipped() -> None:
    names = {p.stem for p in shipped_scenes()}
    assert {"antipodal_circle", "bidirectional_flow", "headon_corridor", "shibuya_crossing",
            "tradeshow", "shopping_mall"} <= names


def test_the_world_s_look_keys_load_and_default_outdoors(tmp_path: Path) -> None:
    """Issue 16: walls at real heights, a ceiling, the floor's material, crosswalks (drawing only)."""
    plain = load_scene(write(tmp_path, GOOD)).world
    assert (plain.indoor, plain.ceiling, plain.floor, plain.markings) == (False, False, "grid", ())
    s = load_scene(write(tmp_path, patched(
        world__indoor=True, world__ceiling=True, world__wall_height=3.2, world__floor="tiles",
        world__markings=[{"kind": "crosswalk", "from": [-2.0, 0.0], "to": [2.0, 0.0], "width": 2.5}])))
    w = s.world
    assert (w.indoor, w.ceiling, w.wall_height, w.floor) == (True, True, 3.2, "tiles")
    (m,) = w.markings
    assert (m.kind, m.start, m.end, m.width) == ("crosswalk", (-2.0, 0.0), (2.0, 0.0), 2.5)


def test_bad_look_keys_are_all_reported(tmp_path: Path) -> None:
    path = write(tmp_path, patched(
        world__ceiling=True, world__wall_height=1.0, world__floor="lava",
        world__markings=[{"kind": "zebra", "from": [0.0, 0.0], "to": [0.3, 0.0]}]))
    with pytest.raises(SceneError) as e:
        load_scene(path)
    msg = str(e.value)
    assert "world.ceiling = true: needs world.indoor = true" in msg
    assert "world.wall_height = 1.0: must be between 2 and 30 m" in msg
    assert "world.floor = 'lava': expected one of grid, tiles, wood, carpet, asphalt, paving" in msg
    assert "world.markings[0].kind = 'zebra': expected one of crosswalk" in msg
    assert "world.markings[0].to = [0.3, 0.0]: must be at least 1 m from world.markings.from" in msg


@pytest.mark.parametrize("door, message", [
    ({"span": [[0.0, 0.0], [0.0, 0.0]], **PULL},
     r"^\S+: world\.doors\[0\]\.span = \[\[0\.0, 0\.0\], \[0\.0, 0\.0\]\]: a single door is 0\.7 to 1\.6 m wide; "
     r"this is 0\.00 m$"),
    ({"span": [[0.0, 0.0], [0.0, 0.0]], "kind": "double", "swing": "both_ways"},
     r"^\S+: world\.doors\[0\]\.span = .*: a double door is 1\.2 to 3\.2 m wide; this is 0\.00 m$"),
    ({"at": [0.0, 0.0], "width": 0, "along_deg": 90, **PULL},
     r"^\S+: world\.doors\[0\]\.width = 0: must be > 0 m$"),
])
def test_a_zero_width_door_is_refused_for_its_width(tmp_path: Path, door: dict, message: str) -> None:
    """Issue 25.12: a 0 m door was refused with "pull_side lies on the door's line", never its width."""
    import re

    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, patched(world__obstacles=DOORWAY, world__doors=[door])))
    assert len(info.value.problems) == 1, info.value.problems
    assert re.search(message, info.value.problems[0]), info.value.problems[0]


def test_a_bad_profile_is_not_also_unknown(tmp_path: Path) -> None:
    """Issue 25.12: a negative radius added "unknown profile; known: " (an empty list) on the spawn."""
    bad = patched(agents__profiles__adult__radius=-0.3, agents__profiles__child__radius=-0.2)
    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, bad))
    assert [ln.split(": ", 1)[1] for ln in info.value.problems] == [
        "agents.profiles.adult.radius = -0.3: must be > 0",
        "agents.profiles.child.radius = -0.2: must be > 0",
    ]
    typo = patched(agents__profiles__child__radius=-0.2, agents__spawns__0__profile="chlid")
    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, typo))
    assert [ln.split(": ", 1)[1] for ln in info.value.problems] == [
        "agents.profiles.child.radius = -0.2: must be > 0",
        "agents.spawns[0].profile = 'chlid': unknown profile; known: adult, child",
    ]
    no_goal = patched(behavior__states__walk__goal=None)  # the state's own problem; the spawn names it
    with pytest.raises(SceneError) as info:
        load_scene(write(tmp_path, no_goal))
    assert not [ln for ln in info.value.problems if "unknown state" in ln], info.value.problems
