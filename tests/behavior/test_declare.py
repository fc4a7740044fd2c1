"""Scene validation of trees, events, objects, triggers and state trees: one line per problem."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from pedvr.errors import SceneError
from pedvr.scene.loader import parse_scene
from tests.behavior._scene import scene_text

OK = """
[[behavior.objects]]
name = "bench"
kind = "chair"
at = [2.0, 2.0]
facing_deg = -90

[behavior.trees.chat]
params = { a = "agent", b = "agent", at = "point" }
root = { sequence = [
  { parallel = [ { go_to = "a", to = "at", arrive = 0.7 }, { go_to = "b", to = "at", arrive = 0.7 } ] },
  { repeat = { gesture = "a", clip = ["talk", "shrug"], seconds = [1, 2] }, seconds = [3, 5] },
] }

[behavior.trees.sit]
params = { me = "agent" }
root = { selector = [ { use = "me", object = "bench", affordance = "sit" }, { wait = 2 } ], memory = true }

[behavior.events.chat]
tree = "chat"
priority = 2

[behavior.states.resting]
goal = { selector = "stay" }
tree = "sit"

[[behavior.states.resting.transitions]]
on = "success"
to = "walk"

[[behavior.triggers]]
kind = "near"
who = ["agent", "agent"]
distance = 3
event = "chat"
bind = { a = "agent", b = "other", at = "midpoint" }
"""


def load(behavior: str) -> object:
    text = scene_text(agents=[(0.0, 0.0, "walk")], behavior=behavior)
    return parse_scene(tomllib.loads(text), source="s.toml")


def problems(behavior: str) -> list[str]:
    with pytest.raises(SceneError) as e:
        load(behavior)
    return e.value.problems


def test_a_valid_declaration_loads_into_config() -> None:
    cfg = load(OK)
    b = cfg.behavior  # type: ignore[attr-defined]
    assert set(b.trees) == {"chat", "sit"} and b.trees["chat"].params == {"a": "agent", "b": "agent", "at": "point"}
    assert b.events["chat"].priority == 2 and b.events["chat"].patience == 10.0
    assert b.objects[0].name == "bench" and b.objects[0].kind == "chair"
    assert b.states["resting"].tree == "sit"
    assert b.triggers[0].bind == {"a": "agent", "b": "other", "at": "midpoint"}


@pytest.mark.parametrize("bad,line", [
    ('root = { dance = "a" }',
     "s.toml: behavior.trees.t.root.dance = 'a': unknown node type; known: after, before, cooldown"),
    ('root = { go_to = "a", to = [1, 1], speed = 2 }',
     "s.toml: behavior.trees.t.root.speed = 2: unknown attribute of 'go_to'; known: to, arrive, max_time"),
    ('root = { go_to = "c", to = [1, 1] }',
     "s.toml: behavior.trees.t.root.go_to = 'c': not a parameter of this tree; expected an agent parameter; "
     "its parameters: a (agent), u (user)"),
    ('root = { gesture = "u", clip = "wave" }',
     "s.toml: behavior.trees.t.root.gesture = 'u': parameter 'u' is a user (observed, never driven); "
     "actions take an agent parameter"),
    ('root = { go_to = "user", to = [1, 1] }',
     "s.toml: behavior.trees.t.root.go_to = 'user': the user is observed, never driven"),
    ('root = { use = "a", object = "bench", affordance = "lie" }',
     "s.toml: behavior.trees.t.root.affordance = 'lie': unknown affordance of a chair; its affordances: sit, stand"),
    ('root = { use = "a", object = "sofa", affordance = "sit" }',
     "s.toml: behavior.trees.t.root.object = 'sofa': unknown object; the scene's objects: bench"),
    ('root = { use = "a", object = { nearest = "sofa" }, affordance = "sit" }',
     "s.toml: behavior.trees.t.root.object = {...}: unknown smart object kind 'sofa'; known: chair"),
    ('root = { go_to = "a" }', "s.toml: behavior.trees.t.root.to = <missing>: required by 'go_to'"),
    ('root = { wait = [3, 1] }', "s.toml: behavior.trees.t.root.wait = [3, 1]: expected seconds >= 0"),
    ('root = { gesture = "a", clip = "dance" }',
     "s.toml: behavior.trees.t.root.clip = 'dance': unknown gesture 'dance'; known: wave"),
    ('root = { near = "u", of = "a" }', "s.toml: behavior.trees.t.root.within = <missing>: required by 'near'"),
    ('root = { random = [ { wait = 1 }, { wait = 2 } ], weights = [1] }',
     "s.toml: behavior.trees.t.root.weights = [1]: expected 2 weights, one per child"),
    ('root = { sequence = [] }', "s.toml: behavior.trees.t.root.sequence = []: expected a non-empty list of nodes"),
    ('root = { face = "a" }', "s.toml: behavior.trees.t.root = {...}: face: give exactly one of toward or heading_deg"),
    ('root = { go_to = "a", to = { goal_set = "shops" } }',
     "s.toml: behavior.trees.t.root.to = {...}: unknown goal set; known: ends"),
])
def test_tree_problems_name_the_key(bad: str, line: str) -> None:
    decl = ('[[behavior.objects]]\nname = "bench"\nkind = "chair"\nat = [2.0, 2.0]\n'
            f'[behavior.trees.t]\nparams = {{ a = "agent", u = "user" }}\n{bad}\n')
    got = problems(decl)
    assert len(got) == 1, got
    assert got[0].startswith(line), got[0]


@pytest.mark.parametrize("bad,line", [
    ('[behavior.events.e]\ntree = "nope"',
     "s.toml: behavior.events.e.tree = 'nope': unknown tree; known: conversation, demonstrate, rest_on_chair, wave_at_user"),
    ('[behavior.events.e]\ntree = "conversation"\npriority = 0',
     "s.toml: behavior.events.e.priority = 0: must be >= 1 (personal trees and the BFSM are 0)"),
    ('[[behavior.objects]]\nname = "x"\nkind = "sofa"\nat = [0, 0]',
     "s.toml: behavior.objects[0].kind = 'sofa': expected one of: chair"),
    ('[[behavior.objects]]\nname = "x"\nkind = "chair"\nat = [20, 0]',
     "s.toml: behavior.objects[0].at = [20.0, 0.0]: lies outside the walkable area"),
    ('[[behavior.objects]]\nname = "x"\nkind = "chair"\nat = [0, 0]\ncolour = "red"',
     "s.toml: behavior.objects[0].colour = 'red': unknown key; expected one of name, kind, at, facing_deg, "
     "blocked_after, approach_time"),
    ('[behavior.states.s]\ngoal = { selector = "stay" }\ntree = "conversation"',
     "s.toml: behavior.states.s.tree = 'conversation': a state's tree takes exactly one parameter, the agent"),
    ('[behavior.states.s]\ngoal = { selector = "stay" }\ntree = "nope"',
     "s.toml: behavior.states.s.tree = 'nope': unknown tree; known: conversation, demonstrate, rest_on_chair, wave_at_user"),
    ('[behavior.states.s]\ngoal = { selector = "stay" }\n[[behavior.states.s.transitions]]\non = "success"\n'
     'to = "walk"', "s.toml: behavior.states.s.transitions[0].on = 'success': only a state with a tree takes"),
])
def test_event_object_and_state_problems(bad: str, line: str) -> None:
    got = problems(bad)
    assert len(got) == 1, got
    assert got[0].startswith(line), got[0]


EVENT = '[behavior.events.chat]\ntree = "conversation"\n[behavior.events.wave]\ntree = "wave_at_user"\n'


@pytest.mark.parametrize("bad,line", [
    ('kind = "bump"\nevent = "chat"\nbind = {}',
     "s.toml: behavior.triggers[0].kind = 'bump': expected one of enter, near, time, user_action"),
    ('kind = "near"\nwho = ["agent", "agent"]\ndistance = 3\nevent = "talk"\nbind = {}',
     "s.toml: behavior.triggers[0].event = 'talk': unknown event; known: chat, wave"),
    ('kind = "near"\nwho = ["agent", "agent"]\ndistance = 3\nevent = "chat"\nbind = { a = "agent", b = "other" }',
     "s.toml: behavior.triggers[0].bind.spot = <missing>: required: event 'chat' (tree 'conversation') takes "
     "a (agent), b (agent), spot (point)"),
    ('kind = "near"\nwho = ["agent", "agent"]\ndistance = 3\nevent = "chat"\n'
     'bind = { a = "agent", b = "other", spot = "midpoint", c = "user" }',
     "s.toml: behavior.triggers[0].bind.c = 'user': unknown parameter of tree 'conversation'"),
    ('kind = "near"\nwho = ["user", "agent"]\ndistance = 3\nevent = "chat"\n'
     'bind = { a = "agent", b = "other", spot = "midpoint" }',
     "s.toml: behavior.triggers[0].bind.b = 'other': an agent parameter; this trigger binds agent"),
    ('kind = "near"\nwho = ["user", "agent"]\ndistance = 3\nevent = "wave"\nbind = { a = "user", u = "user" }',
     "s.toml: behavior.triggers[0].bind.a = 'user': an agent parameter; this trigger binds agent"),
    ('kind = "near"\nwho = ["user", "agent"]\ndistance = 3\nevent = "wave"\nbind = { a = "agent", u = "user" }\n'
     'states = ["shopping"]', "s.toml: behavior.triggers[0].states = ['shopping']: unknown state 'shopping'"),
    ('kind = "near"\nwho = ["user", "user"]\ndistance = 3\nevent = "wave"\nbind = { a = "agent", u = "user" }',
     "s.toml: behavior.triggers[0].who = ['user', 'user']: expected [\"user\", \"agent\"] or [\"agent\", \"agent\"]"),
    ('kind = "enter"\nwho = "user"\nevent = "wave"\nbind = { a = "agent", u = "user" }',
     "s.toml: behavior.triggers[0].region = <missing>: required: {box = [xmin, ymin, xmax, ymax]}"),
    ('kind = "time"\nevery = 0\nevent = "wave"\nbind = { a = "agent", u = "user" }',
     "s.toml: behavior.triggers[0].every = 0: expected seconds > 0"),
])
def test_trigger_problems(bad: str, line: str) -> None:
    got = problems(EVENT + "[[behavior.triggers]]\n" + bad)
    assert len(got) == 1, got
    assert got[0].replace('"', "'").startswith(line.replace('"', "'")), got[0]


def test_every_problem_is_reported_at_once() -> None:
    bad = """
[[behavior.objects]]
name = "x"
kind = "sofa"
at = [0, 0]

[behavior.trees.t]
params = { a = "agent" }
root = { sequence = [ { dance = "a" }, { go_to = "b", to = [0, 0] }, { wait = -1 } ] }

[behavior.events.e]
tree = "t"
priority = 0

[[behavior.triggers]]
kind = "time"
event = "nope"
bind = {}
"""
    got = problems(bad)
    assert len(got) == 6, got
    assert [g.split(" = ")[0] for g in got] == [
        "s.toml: behavior.objects[0].kind", "s.toml: behavior.trees.t.root.sequence[0].dance",
        "s.toml: behavior.trees.t.root.sequence[1].go_to", "s.toml: behavior.trees.t.root.sequence[2].wait",
        "s.toml: behavior.events.e.priority", "s.toml: behavior.triggers[0].event"]


def test_scene_check_prints_each_problem(tmp_path: Path) -> None:
    text = scene_text(agents=[(0.0, 0.0, "walk")],
                      behavior='[behavior.trees.t]\nparams = { a = "agent" }\nroot = { go_to = "user", to = [0, 0] }\n'
                               '[behavior.events.e]\ntree = "nope"\n')
    f = tmp_path / "bad.toml"
    f.write_text(text)
    p = subprocess.run([sys.executable, "-m", "pedvr", "scene", "check", str(f)], capture_output=True, text=True,
                       cwd=Path(__file__).resolve().parents[2])
    assert p.returncode == 2
    lines = p.stdout.strip().splitlines()
    assert len(lines) == 2 and "Traceback" not in p.stderr
    assert lines[0] == f"{f}: behavior.trees.t.root.go_to = 'user': the user is observed, never driven: actions " \
                       "take an agent parameter"
    assert lines[1].startswith(f"{f}: behavior.events.e.tree = 'nope': unknown tree")
