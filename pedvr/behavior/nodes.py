"""Node types as data: the tree format scenes and the library write, checked and built.

A node is a table whose *type key* names a registered node type; the type
key's value is the node's main argument (its children, its child, the actor
it acts on, a duration) and the other keys are its attributes::

    { sequence = [ { go_to = "a", to = "spot", arrive = 0.7 }, { wait = [2, 4] } ] }
    { repeat = { gesture = "a", clip = ["talk", "shrug"], seconds = [1.5, 3] }, seconds = [8, 16] }

Type names and attribute names are disjoint, so a table has exactly one
type key. :func:`parse_tree` checks a whole definition and reports every
problem through a callback as ``(dotted key, value, expectation)``;
:func:`build` turns a checked :class:`~pedvr.behavior.spec.NodeSpec` into
live nodes for concrete actors (:class:`Bindings`).

New node types are registered like selectors and object kinds::

    node_types.register("hold_door")(NodeType(main="agent", attrs={"door": Attr("object", True)},
                                              build=lambda spec, b: HoldDoor(b.agent(spec.main), ...)))
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pedvr.behavior import leaves as lv
from pedvr.behavior import tree as bt
from pedvr.behavior.objects import ObjectTarget, SmartObject, Use, object_kinds
from pedvr.behavior.spec import PARAM_KINDS, NodeSpec, Ref, TreeDef
from pedvr.registry import Registry
from pedvr.validation import MISSING, fmt, is_num

GESTURE_CLIPS = ("wave", "point", "shrug", "check_phone", "hands_in_pockets", "talk")
Report = Callable[[str, object, str], None]


@dataclass(frozen=True)
class Attr:
    """An attribute: ``kind`` names a value check (see ``_VALUES``); ``required`` or ``default``."""

    kind: str
    required: bool = False
    default: Any = None


@dataclass
class Env:
    """What a tree may refer to while it is checked: its parameters, the scene's objects and goal sets."""

    params: dict[str, str]
    objects: dict[str, str] = field(default_factory=dict)  # name -> kind
    goal_sets: frozenset[str] = frozenset()
    report: Report = lambda key, value, why: None  # noqa: E731
    uses: dict[str, set[str]] = field(default_factory=dict)  # object param -> affordances used


@dataclass(frozen=True)
class NodeType:
    """``main``: the kind of the type key's value (``children``, ``child``, or a value kind);
    ``attrs``: the other keys; ``build``: spec + bindings -> node; ``affords``: ``(attribute,
    affordance)`` when the node invokes that affordance of the object its attribute names (checked
    like ``use``'s: the object's kind must have it, and a tree's object parameter records it)."""

    main: str
    attrs: dict[str, Attr]
    build: Callable[[NodeSpec, Bindings], bt.Behaviour]
    doc: str = ""
    affords: tuple[str, str] | None = None


node_types: Registry[NodeType] = Registry("node type")


# -- value checks: raw TOML value -> parsed value, or report ---------------------------------------


class _Bad(Exception):
    def __init__(self, why: str) -> None:
        self.why = why


def _param(env: Env, v: str, kinds: tuple[str, ...], what: str) -> Ref:
    if v not in env.params:
        known = ", ".join(f"{k} ({t})" for k, t in env.params.items()) or "none"
        raise _Bad(f"not a parameter of this tree; expected {what}; its parameters: {known}")
    if env.params[v] not in kinds:
        raise _Bad(f"parameter {v!r} is a {env.params[v]}; expected {what} ({' or '.join(kinds)})")
    return Ref("param", v)


def _agent(v: object, env: Env) -> Ref:
    if v == "user":
        raise _Bad("the user is observed, never driven: actions take an agent parameter")
    if not isinstance(v, str) or not v:
        raise _Bad("expected the name of an agent parameter")
    if env.params.get(v) in ("user", "actor"):
        raise _Bad(f"parameter {v!r} is a {env.params[v]} (observed, never driven); actions take an "
                   "agent parameter")
    return _param(env, v, ("agent",), "an agent parameter")


def _actor(v: object, env: Env) -> Ref:
    if v == "user":
        return Ref("user")
    if not isinstance(v, str) or not v:
        raise _Bad('expected the name of an actor parameter, or "user"')
    return _param(env, v, ("agent", "user", "actor"), "an actor parameter")


def _point(v: object) -> tuple[float, float] | None:
    if isinstance(v, list | tuple) and len(v) == 2 and all(is_num(x) for x in v):
        return (float(v[0]), float(v[1]))
    return None


def _target(v: object, env: Env) -> Ref:
    p = _point(v)
    if p is not None:
        return Ref("point", p)
    if v == "user":
        return Ref("user")
    if isinstance(v, str) and v:
        if v in env.params:
            if env.params[v] not in PARAM_KINDS:
                raise _Bad("unknown parameter kind")
            return Ref("param", v)
        if v in env.objects:
            return Ref("object", v)
        known = ", ".join(env.params) or "none"
        raise _Bad(f"unknown target; expected a parameter ({known}), an object, \"user\" or [x, y]")
    if isinstance(v, dict) and len(v) == 1:
        (k, x), = v.items()
        if k == "region":
            if (isinstance(x, list) and len(x) == 4 and all(is_num(y) for y in x)
                    and x[0] < x[2] and x[1] < x[3]):
                return Ref("region", tuple(float(y) for y in x))
            raise _Bad("region: expected [xmin, ymin, xmax, ymax] with min < max")
        if k == "goal_set":
            if isinstance(x, str) and x in env.goal_sets:
                return Ref("goal_set", x)
            raise _Bad(f"unknown goal set; known: {', '.join(sorted(env.goal_sets)) or 'none'}")
    raise _Bad('expected a parameter, an object, "user", [x, y], {region = [xmin, ymin, xmax, ymax]} '
               'or {goal_set = "name"}')


def _object(v: object, env: Env) -> Ref:
    if isinstance(v, dict) and len(v) == 1 and "nearest" in v:
        k = v["nearest"]
        if k not in object_kinds:
            raise _Bad(object_kinds.unknown(k))
        return Ref("nearest", k)
    if isinstance(v, str) and v:
        if v in env.params:
            return _param(env, v, ("object",), "an object parameter")
        if v in env.objects:
            return Ref("object", v)
        params = ", ".join(k for k, t in env.params.items() if t == "object") or "none"
        raise _Bad(f"unknown object; the scene's objects: {', '.join(env.objects) or 'none'}; "
                   f"object parameters: {params}")
    raise _Bad('expected an object name, an object parameter, or {nearest = "kind"}')


def _seconds(v: object, env: Env) -> tuple[float, float]:
    if is_num(v) and float(v) >= 0:  # type: ignore[arg-type]
        return (float(v), float(v))  # type: ignore[arg-type]
    if isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v) and 0 <= v[0] <= v[1]:
        return (float(v[0]), float(v[1]))
    raise _Bad("expected seconds >= 0, or [lo, hi] with 0 <= lo <= hi")


def _number(check: Callable[[float], bool], expect: str) -> Callable[[object, Env], float]:
    def parse(v: object, env: Env) -> float:
        if not is_num(v) or not check(float(v)):  # type: ignore[arg-type]
            raise _Bad(f"expected a number {expect}")
        return float(v)  # type: ignore[arg-type]

    return parse


def _count(v: object, env: Env) -> int:
    if isinstance(v, int) and not isinstance(v, bool) and v >= 1:
        return v
    raise _Bad("expected an integer >= 1")


def _bool(v: object, env: Env) -> bool:
    if isinstance(v, bool):
        return v
    raise _Bad("expected true or false")


def _choice(*choices: str) -> Callable[[object, Env], str]:
    def parse(v: object, env: Env) -> str:
        if v in choices:
            return str(v)
        raise _Bad(f"expected one of {', '.join(choices)}")

    return parse


def _clips(v: object, env: Env) -> tuple[str, ...]:
    names = [v] if isinstance(v, str) else v
    if not isinstance(names, list) or not names or not all(isinstance(x, str) for x in names):
        raise _Bad(f"expected a gesture name or a list of them: {', '.join(GESTURE_CLIPS)}")
    bad = [x for x in names if x not in GESTURE_CLIPS]
    if bad:
        raise _Bad(f"unknown gesture {bad[0]!r}; known: {', '.join(GESTURE_CLIPS)}")
    return tuple(names)


def _weights(v: object, env: Env) -> tuple[float, ...]:
    if isinstance(v, list) and v and all(is_num(x) and x >= 0 for x in v) and sum(v) > 0:
        return tuple(float(x) for x in v)
    raise _Bad("expected numbers >= 0 with a positive sum, one per child")


def _name(v: object, env: Env) -> str:
    if isinstance(v, str) and v:
        return v
    raise _Bad("expected a non-empty string")


_VALUES: dict[str, Callable[[object, Env], Any]] = {
    "agent": _agent, "actor": _actor, "target": _target, "object": _object, "seconds": _seconds,
    "positive": _number(lambda x: x > 0, "> 0"), "non_negative": _number(lambda x: x >= 0, ">= 0"),
    "time": _number(lambda x: x >= 0, ">= 0 s"), "scale": _number(lambda x: 0 < x <= 2, "in (0, 2]"),
    "angle_deg": _number(lambda x: True, "(degrees)"), "count": _count, "bool": _bool,
    "side": _choice("left", "right"), "policy": _choice("all", "one"), "clips": _clips,
    "weights": _weights, "affordance": _name,
}


# -- parsing ---------------------------------------------------------------------------------------


def parse_node(raw: object, key: str, env: Env) -> NodeSpec | None:
    """Check one node (and everything below it); problems go to ``env.report``; None if unusable."""
    if not isinstance(raw, dict):
        env.report(key, raw, "expected a node: a table such as { wait = 2 } or { sequence = [...] }")
        return None
    kinds = [k for k in raw if k in node_types]
    if len(kinds) != 1:
        if not kinds:
            bad = next(iter(raw), None)
            env.report(f"{key}.{bad}" if bad is not None else key, raw.get(bad, "{}") if bad else "{}",
                       f"unknown node type; known: {', '.join(node_types)}")
        else:
            env.report(key, raw, f"one node per table; this one names {', '.join(kinds)}")
        return None
    kind = kinds[0]
    nt = node_types[kind]
    here = f"{key}.{kind}"
    ok = True
    main: Any = None
    v = raw[kind]
    if nt.main == "children":
        if not isinstance(v, list) or not v:
            env.report(here, v, "expected a non-empty list of nodes")
            ok = False
        else:
            kids = [parse_node(c, f"{here}[{i}]", env) for i, c in enumerate(v)]
            ok = all(k is not None for k in kids)
            main = tuple(k for k in kids if k is not None)
    elif nt.main == "child":
        main = parse_node(v, here, env)
        ok = main is not None
    else:
        try:
            main = _VALUES[nt.main](v, env)
        except _Bad as e:
            env.report(here, v, e.why)
            ok = False
    attrs: dict[str, Any] = {}
    for a, val in raw.items():
        if a == kind:
            continue
        spec = nt.attrs.get(a)
        if spec is None:
            known = ", ".join(nt.attrs) or "none"
            env.report(f"{key}.{a}", val, f"unknown attribute of {kind!r}; known: {known}")
            ok = False
            continue
        try:
            attrs[a] = _VALUES[spec.kind](val, env)
        except _Bad as e:
            env.report(f"{key}.{a}", val, e.why)
            ok = False
    for a, spec in nt.attrs.items():
        if spec.required and a not in raw:
            env.report(f"{key}.{a}", MISSING, f"required by {kind!r}")
            ok = False
        elif a not in attrs and spec.default is not None:
            attrs[a] = spec.default
    if ok:
        bad = _extra_check(kind, main, attrs, env)
        if bad:
            where, why = bad
            env.report(f"{key}.{where}" if where else key, raw.get(where, raw) if where else raw, why)
            ok = False
    return NodeSpec(kind=kind, main=main, attrs=attrs, key=key) if ok else None


def _extra_check(kind: str, main: Any, attrs: dict[str, Any], env: Env) -> tuple[str, str] | None:
    """Checks across a node's values: ``(attribute or "", expectation)`` for a problem."""
    if kind == "random" and "weights" in attrs and len(attrs["weights"]) != len(main):
        return "weights", f"expected {len(main)} weights, one per child"
    if kind == "repeat" and "count" in attrs and "seconds" in attrs:
        return "", "repeat: give count or seconds, not both"
    if kind == "face" and ("toward" in attrs) == ("heading_deg" in attrs):
        return "", "face: give exactly one of toward or heading_deg"
    if kind == "use":
        obj: Ref = attrs["object"]
        aff = attrs["affordance"]
        okind = (env.objects.get(obj.value) if obj.kind == "object" else
                 obj.value if obj.kind == "nearest" else None)
        if okind is not None and okind in object_kinds and aff not in object_kinds[okind].AFFORDANCES:
            return "affordance", (f"unknown affordance of a {okind}; its affordances: "
                                  f"{', '.join(object_kinds[okind].AFFORDANCES)}")
        if obj.kind == "param":
            env.uses.setdefault(obj.value, set()).add(aff)
    affords = node_types[kind].affords
    if affords is not None:
        attr, aff = affords
        ref: Ref = attrs[attr]
        okind = (env.objects.get(ref.value) if ref.kind == "object" else
                 ref.value if ref.kind == "nearest" else None)
        if okind is not None and okind in object_kinds and aff not in object_kinds[okind].AFFORDANCES:
            return attr, (f"a {okind} has no affordance {aff!r}; kinds that have it: "
                          f"{', '.join(k for k in object_kinds if aff in object_kinds[k].AFFORDANCES)}")
        if ref.kind == "param":
            env.uses.setdefault(ref.value, set()).add(aff)
    return None


def parse_params(raw: object, key: str, report: Report) -> dict[str, str] | None:
    """``params = { a = "agent", spot = "point" }`` (kinds: agent, user, actor, point, object)."""
    if not isinstance(raw, dict):
        report(key, raw, f'expected a table such as {{ a = "agent", at = "point" }}; kinds: '
               f'{", ".join(PARAM_KINDS)}')
        return None
    out: dict[str, str] = {}
    for name, kind in raw.items():
        if name in node_types or name in ("user",):
            report(f"{key}.{name}", kind, "a parameter cannot be named like a node type or \"user\"")
        elif kind not in PARAM_KINDS:
            report(f"{key}.{name}", kind, f"unknown parameter kind; expected one of {', '.join(PARAM_KINDS)}")
        else:
            out[name] = str(kind)
    return out


def parse_tree(name: str, raw: object, key: str, *, report: Report, objects: dict[str, str] | None = None,
               goal_sets: frozenset[str] = frozenset(), source: str = "") -> TreeDef | None:
    """Check ``{ params = {...}, root = {...} }``: every problem goes to ``report``; None if any."""
    problems: list[int] = []

    def rep(k: str, v: object, why: str) -> None:
        problems.append(1)
        report(k, v, why)

    if not isinstance(raw, dict):
        rep(key, raw, "expected a table with params and root")
        return None
    for k in raw:
        if k not in ("params", "root"):
            rep(f"{key}.{k}", raw[k], "unknown key; expected params, root")
    params = parse_params(raw.get("params", {}), f"{key}.params", rep) or {}
    if "root" not in raw:
        rep(f"{key}.root", MISSING, "required: the tree's root node")
        return None
    env = Env(params=params, objects=dict(objects or {}), goal_sets=goal_sets, report=rep)
    root = parse_node(raw["root"], f"{key}.root", env)
    if root is None or problems:
        return None
    return TreeDef(name=name, params=params, root=root, source=source,
                   uses={k: frozenset(v) for k, v in env.uses.items()})


def define_tree(name: str, params: dict[str, str], root: dict[str, Any], *,
                goal_sets: frozenset[str] = frozenset(), objects: dict[str, str] | None = None) -> TreeDef:
    """A checked tree from Python data in the scene format; ValueError lists every problem.

    ``objects`` (name -> kind) and ``goal_sets`` are what the tree may name besides its parameters.
    """
    lines: list[str] = []
    tree = parse_tree(name, {"params": params, "root": root}, name,
                      report=lambda k, v, why: lines.append(f"{k} = {fmt(v)}: {why}"),
                      objects=objects, goal_sets=goal_sets, source="library")
    if tree is None:
        raise ValueError(f"tree {name!r}:\n" + "\n".join(lines))
    return tree


# -- building --------------------------------------------------------------------------------------


class Bindings:
    """Concrete values for a tree's parameters: agent ids (agent/user/actor), ``(x, y)`` points,
    :class:`SmartObject` instances; plus the scene's objects and the user's id."""

    def __init__(self, values: dict[str, Any], *, objects: dict[str, SmartObject], user: int | None) -> None:
        self.values = values
        self.objects = objects
        self.user = user

    def actor(self, ref: Ref) -> int:
        if ref.kind == "user":
            if self.user is None:
                raise LookupError("this scene has no user")
            return self.user
        return int(self.values[ref.value])

    agent = actor

    def target(self, ref: Ref) -> lv.Target:
        k, v = ref.kind, ref.value
        if k == "point":
            return lv.PointTarget(v)
        if k == "region":
            return lv.DrawnTarget(box=v)
        if k == "goal_set":
            return lv.DrawnTarget(goal_set=v)
        if k == "object":
            return ObjectTarget(self.objects[v])
        if k == "user":
            return lv.ActorTarget(self.actor(ref))
        val = self.values[v]
        if isinstance(val, SmartObject):
            return ObjectTarget(val)
        if isinstance(val, tuple):
            return lv.PointTarget(val)
        return lv.ActorTarget(int(val))

    def object(self, ref: Ref) -> SmartObject | str:
        if ref.kind == "nearest":
            return str(ref.value)
        if ref.kind == "object":
            return self.objects[ref.value]
        val = self.values[ref.value]
        assert isinstance(val, SmartObject)
        return val


def build(spec: NodeSpec, b: Bindings) -> bt.Behaviour:
    """Live nodes for ``spec`` with the parameters bound by ``b``."""
    return node_types[spec.kind].build(spec, b)


def _kids(spec: NodeSpec, b: Bindings) -> list[bt.Behaviour]:
    return [build(c, b) for c in spec.main]


def _reg(name: str, main: str, attrs: dict[str, Attr], fn: Callable[[NodeSpec, Bindings], bt.Behaviour],
         doc: str) -> None:
    node_types.register(name)(NodeType(main=main, attrs=attrs, build=fn, doc=doc))


_reg("sequence", "children", {"memory": Attr("bool", default=True)},
     lambda s, b: bt.Sequence(_kids(s, b), memory=s.attrs["memory"], name=s.key),
     "children in order until one fails")
_reg("selector", "children", {"memory": Attr("bool", default=False)},
     lambda s, b: bt.Selector(_kids(s, b), memory=s.attrs["memory"], name=s.key),
     "the first child that does not fail (re-tried every tick unless memory = true)")
_reg("parallel", "children", {"success": Attr("policy", default="all"), "failure": Attr("policy")},
     lambda s, b: bt.Parallel(_kids(s, b), success=s.attrs["success"], failure=s.attrs.get("failure"),
                              name=s.key),
     "children together; success when all (or one) succeed, failure when one (or all) fail")
_reg("random", "children", {"weights": Attr("weights")},
     lambda s, b: bt.RandomSelector(_kids(s, b), weights=s.attrs.get("weights"), name=s.key),
     "a selector whose order is drawn by weight")
_reg("repeat", "child", {"count": Attr("count"), "seconds": Attr("seconds")},
     lambda s, b: bt.Repeat(build(s.main, b), count=s.attrs.get("count"), seconds=s.attrs.get("seconds"),
                            name=s.key),
     "run the child again on success: count times, for seconds, or forever")
_reg("invert", "child", {}, lambda s, b: bt.Invert(build(s.main, b), name=s.key), "success <-> failure")
_reg("succeed", "child", {}, lambda s, b: bt.Succeed(build(s.main, b), name=s.key), "always success")
_reg("fail", "child", {}, lambda s, b: bt.Fail(build(s.main, b), name=s.key), "always failure")
_reg("until", "child", {}, lambda s, b: bt.Until(build(s.main, b), name=s.key),
     "wait until the child succeeds (its failure reads as running)")
_reg("timeout", "child", {"seconds": Attr("seconds", True)},
     lambda s, b: bt.Timeout(build(s.main, b), seconds=s.attrs["seconds"], name=s.key),
     "failure if the child runs longer")
_reg("cooldown", "child", {"seconds": Attr("non_negative", True)},
     lambda s, b: bt.Cooldown(build(s.main, b), seconds=s.attrs["seconds"], name=s.key),
     "failure for seconds after each run of the child")
_reg("wait", "seconds", {}, lambda s, b: bt.Wait(s.main, name=s.key), "stand for seconds")
_reg("go_to", "agent", {"to": Attr("target", True), "arrive": Attr("positive", default=0.3),
                        "max_time": Attr("positive", default=60.0)},
     lambda s, b: lv.GoTo(b.agent(s.main), b.target(s.attrs["to"]), arrive=s.attrs["arrive"],
                          max_time=s.attrs["max_time"], name=s.key),
     "walk to a target")
_reg("follow", "agent", {"leader": Attr("actor", True), "distance": Attr("positive", default=1.0)},
     lambda s, b: lv.Follow(b.agent(s.main), lv.ActorTarget(b.actor(s.attrs["leader"])),
                            distance=s.attrs["distance"], name=s.key),
     "walk after an actor until stopped")
_reg("stop", "agent", {}, lambda s, b: lv.Stop(b.agent(s.main), name=s.key), "stop walking")
_reg("face", "agent",
     {"toward": Attr("target"), "heading_deg": Attr("angle_deg"), "hold": Attr("bool", default=False)},
     lambda s, b: lv.Face(b.agent(s.main), b.target(s.attrs["toward"]) if "toward" in s.attrs else None,
                          heading=math.radians(s.attrs["heading_deg"]) if "heading_deg" in s.attrs else None,
                          hold=s.attrs["hold"], name=s.key),
     "turn on the spot toward a target or heading")
_reg("gaze_at", "agent", {"at": Attr("target", True), "seconds": Attr("seconds")},
     lambda s, b: lv.GazeAt(b.agent(s.main), b.target(s.attrs["at"]), seconds=s.attrs.get("seconds"),
                            name=s.key),
     "look at a target")
_reg("gesture", "agent", {"clip": Attr("clips", True), "seconds": Attr("seconds", default=(2.5, 2.5))},
     lambda s, b: lv.Gesture(b.agent(s.main), s.attrs["clip"], seconds=s.attrs["seconds"], name=s.key),
     "play a gesture clip")
_reg("reach_for", "agent", {"at": Attr("target", True), "height": Attr("positive", default=1.0),
                            "side": Attr("side", default="right"), "seconds": Attr("seconds")},
     lambda s, b: lv.ReachFor(b.agent(s.main), b.target(s.attrs["at"]), height=s.attrs["height"],
                              side=s.attrs["side"], seconds=s.attrs.get("seconds"), name=s.key),
     "put a hand on a target")
_reg("sit_down", "agent", {}, lambda s, b: lv.SitDown(b.agent(s.main), name=s.key), "sit where it stands")
_reg("stand_up", "agent", {}, lambda s, b: lv.StandUp(b.agent(s.main), name=s.key), "stand up")
_reg("set_speed", "agent", {"scale": Attr("scale", True)},
     lambda s, b: lv.SetSpeed(b.agent(s.main), s.attrs["scale"], name=s.key),
     "scale the preferred speed (restored when the tree ends)")
_reg("use", "agent", {"object": Attr("object", True), "affordance": Attr("affordance", True)},
     lambda s, b: Use(b.agent(s.main), b.object(s.attrs["object"]), affordance=s.attrs["affordance"],
                      name=s.key),
     "invoke a smart object's affordance")
_reg("near", "actor", {"of": Attr("target", True), "within": Attr("positive", True)},
     lambda s, b: lv.Near(b.actor(s.main), b.target(s.attrs["of"]), within=s.attrs["within"], name=s.key),
     "condition: within a distance of a target")
_reg("sees", "actor", {"at": Attr("target", True)},
     lambda s, b: lv.Sees(b.actor(s.main), b.target(s.attrs["at"]), name=s.key),
     "condition: a target in view and not occluded")
_reg("facing", "actor", {"toward": Attr("target", True), "within_deg": Attr("positive", default=30.0)},
     lambda s, b: lv.Facing(b.actor(s.main), b.target(s.attrs["toward"]),
                            within=math.radians(s.attrs["within_deg"]), name=s.key),
     "condition: heading toward a target")
_reg("moving", "actor", {"above": Attr("non_negative", default=0.0), "below": Attr("positive")},
     lambda s, b: lv.Moving(b.actor(s.main), above=s.attrs["above"],
                            below=s.attrs.get("below", math.inf), name=s.key),
     "condition: speed between above and below")
_reg("idle", "actor", {}, lambda s, b: lv.Idle(b.actor(s.main), name=s.key), "condition: standing still")
_reg("after", "time", {}, lambda s, b: lv.After(s.main, name=s.key), "condition: simulation time >= t")
_reg("before", "time", {}, lambda s, b: lv.Before(s.main, name=s.key), "condition: simulation time < t")


def _disjoint() -> None:
    attrs = {a for t in node_types for a in node_types[t].attrs}
    clash = attrs & set(node_types)
    assert not clash, f"attribute names that are also node types: {clash}"


_disjoint()
