"""Scene keys of the interaction layer, checked with the scene's all-errors collector.

``[behavior.trees.NAME]``, ``[behavior.events.NAME]``, ``[[behavior.objects]]``,
``[[behavior.triggers]]`` and a state's ``tree``; the format is in
``scenes/README.md``. Called by :mod:`pedvr.scene.loader`; every problem is
one line naming the dotted key, its value and what was expected.
"""

from __future__ import annotations

import math
from typing import Any

from shapely.geometry import Point

from pedvr.behavior.library import library_trees
from pedvr.behavior.nodes import parse_tree
from pedvr.behavior.objects import object_kinds
from pedvr.behavior.spec import TRIGGER_KINDS, EventDef, ObjectDef, TreeDef, TriggerDef
from pedvr.behavior.triggers import BIND_SYMBOLS
from pedvr.validation import MISSING, Checker, is_num

_SYMBOLS_FOR = {"agent": ("agent", "other"), "user": ("user",), "actor": ("agent", "other", "user"),
                "point": ("midpoint", "here")}
_TRIGGER_KEYS = {
    "enter": ("who", "region"), "near": ("who", "distance"), "time": ("at", "every"),
    "user_action": ("action", "distance"),
}
_COMMON = ("kind", "event", "bind", "states", "idle", "chance", "cooldown", "max_running")


class Interactions:
    """The checked trees, events and objects of one scene (triggers come after the states)."""

    def __init__(self, c: Checker, b: dict[str, Any], *, goal_sets: frozenset[str], blocked: Any) -> None:
        self.c = c
        self.objects = self._objects(b.get("objects", MISSING), blocked)
        self.library = library_trees()
        # names declared, valid or not: a reference to an invalid one is not reported again as unknown
        self.declared: set[str] = set()
        self.trees = self._trees(b.get("trees", MISSING), goal_sets)
        self.events = self._events(b.get("events", MISSING))

    @property
    def known_trees(self) -> dict[str, TreeDef]:
        return {**self.library, **self.trees}

    # -- objects --------------------------------------------------------------------------------

    def _objects(self, raw: object, blocked: Any) -> tuple[ObjectDef, ...]:
        c = self.c
        if raw is MISSING:
            return ()
        if not isinstance(raw, list) or not all(isinstance(x, dict) for x in raw):
            c.bad("behavior.objects", raw, "expected an array of tables [[behavior.objects]]")
            return ()
        out: list[ObjectDef] = []
        seen: set[str] = set()
        for i, o in enumerate(raw):
            path = f"behavior.objects[{i}]"
            name = c.string(o, "name", f"{path}.name")
            if name is not None:
                if name in seen:
                    c.bad(f"{path}.name", name, "another object has this name")
                elif name in BIND_SYMBOLS:
                    c.bad(f"{path}.name", name, f"reserved: {', '.join(BIND_SYMBOLS)} are trigger symbols")
                seen.add(name)
            kind = o.get("kind", MISSING)
            cls = None
            if kind not in object_kinds:
                c.bad(f"{path}.kind", kind, object_kinds.unknown(None if kind is MISSING else kind)
                      .split("; ", 1)[1].replace("known:", "expected one of:"))
            else:
                cls = object_kinds[str(kind)]
            extra = tuple(cls.PARAMS) if cls is not None else tuple(k for k in o if k not in
                                                                    ("name", "kind", "at", "facing_deg"))
            c.known(o, path, ("name", "kind", "at", "facing_deg", *extra))
            at = _point(o.get("at", MISSING))
            if at is None:
                c.bad(f"{path}.at", o.get("at", MISSING), "required [x, y] in metres")
            elif blocked is not None and blocked.contains(Point(at)) and not (cls and cls.ON_OBSTACLES):
                c.bad(f"{path}.at", list(at), "lies outside the walkable area")
                at = None
            facing = c.number(o, "facing_deg", f"{path}.facing_deg", required=False, default=0.0)
            params: dict[str, Any] = {}
            if cls is not None:
                for key, p in cls.PARAMS.items():
                    if key not in o:
                        if p.required:
                            c.bad(f"{path}.{key}", MISSING, f"required by a {kind}")
                        continue
                    why = p.check(o[key])
                    if why:
                        c.bad(f"{path}.{key}", o[key], why)
                    else:
                        params[key] = o[key]
            if name is not None and cls is not None and at is not None and facing is not None:
                out.append(ObjectDef(name=name, kind=str(kind), at=at, facing=math.radians(facing),
                                     params=params))
        return tuple(out)

    # -- trees and events -----------------------------------------------------------------------

    def _trees(self, raw: object, goal_sets: frozenset[str]) -> dict[str, TreeDef]:
        c = self.c
        if raw is MISSING:
            return {}
        if not isinstance(raw, dict):
            c.bad("behavior.trees", raw, "expected a table of trees [behavior.trees.NAME]")
            return {}
        kinds = {o.name: o.kind for o in self.objects}
        out: dict[str, TreeDef] = {}
        for name, t in raw.items():
            path = f"behavior.trees.{name}"
            self.declared.add(f"tree:{name}")
            if name in self.library:
                c.bad(path, "{...}", "a library tree has this name; choose another")
                continue
            tree = parse_tree(name, t, path, report=c.bad, objects=kinds, goal_sets=goal_sets,
                              source=c.source)
            if tree is not None:
                out[name] = tree
        return out

    def _events(self, raw: object) -> dict[str, EventDef]:
        c = self.c
        if raw is MISSING:
            return {}
        if not isinstance(raw, dict):
            c.bad("behavior.events", raw, "expected a table of events [behavior.events.NAME]")
            return {}
        out: dict[str, EventDef] = {}
        for name, e in raw.items():
            path = f"behavior.events.{name}"
            self.declared.add(f"event:{name}")
            if not isinstance(e, dict):
                c.bad(path, e, "expected a table with tree, priority, patience")
                continue
            c.known(e, path, ("tree", "priority", "patience"))
            tree = c.string(e, "tree", f"{path}.tree")
            if tree is not None and tree not in self.known_trees:
                if f"tree:{tree}" not in self.declared:
                    c.bad(f"{path}.tree", tree, f"unknown tree; known: {', '.join(sorted(self.known_trees))}")
                tree = None
            prio = c.integer(e, "priority", f"{path}.priority", required=False, default=1,
                             check=lambda x: x >= 1, expect=">= 1 (personal trees and the BFSM are 0)")
            patience = c.number(e, "patience", f"{path}.patience", required=False, default=10.0,
                                check=lambda x: x > 0, expect="> 0 s")
            if tree is not None and prio is not None and patience is not None:
                out[name] = EventDef(name=name, tree=tree, priority=prio, patience=patience)
        return out

    # -- states ---------------------------------------------------------------------------------

    def state_tree(self, s: dict[str, Any], path: str) -> str | None:
        """A state's ``tree``: a known tree with exactly one parameter, an agent."""
        if "tree" not in s:
            return None
        name = s["tree"]
        known = self.known_trees
        if not isinstance(name, str) or name not in known:
            if f"tree:{name}" not in self.declared:
                self.c.bad(f"{path}.tree", name, f"unknown tree; known: {', '.join(sorted(known))}")
            return None
        params = known[name].params
        if list(params.values()) != ["agent"]:
            self.c.bad(f"{path}.tree", name, "a state's tree takes exactly one parameter, the agent; "
                       f"this one takes {', '.join(f'{k} ({v})' for k, v in params.items())}")
            return None
        return name

    # -- triggers -------------------------------------------------------------------------------

    def triggers(self, raw: object, states: set[str]) -> tuple[TriggerDef, ...]:
        c = self.c
        if raw is MISSING:
            return ()
        if not isinstance(raw, list) or not all(isinstance(x, dict) for x in raw):
            c.bad("behavior.triggers", raw, "expected an array of tables [[behavior.triggers]]")
            return ()
        out: list[TriggerDef] = []
        for i, t in enumerate(raw):
            tr = self._trigger(t, f"behavior.triggers[{i}]", states)
            if tr is not None:
                out.append(tr)
        return tuple(out)

    def _trigger(self, t: dict[str, Any], path: str, states: set[str]) -> TriggerDef | None:
        c = self.c
        n0 = len(c.problems)
        kind = c.string(t, "kind", f"{path}.kind", choices=TRIGGER_KINDS)
        if kind is None:
            return None
        c.known(t, path, (*_COMMON, *_TRIGGER_KEYS[kind]))
        ev_name = c.string(t, "event", f"{path}.event")
        ev = None
        if ev_name is not None:
            ev = self.events.get(ev_name)
            if ev is None and f"event:{ev_name}" not in self.declared:
                c.bad(f"{path}.event", ev_name,
                      f"unknown event; known: {', '.join(sorted(self.events)) or 'none'}")
        who: tuple[str, ...] = ()
        region = None
        distance = 0.0
        at = 0.0
        every = None
        action = ""
        if kind == "enter":
            w = t.get("who", MISSING)
            if w not in ("user", "agent"):
                c.bad(f"{path}.who", w, 'expected "user" or "agent"')
            else:
                who = (str(w),)
            region = _region(c, t.get("region", MISSING), f"{path}.region")
        elif kind == "near":
            w = t.get("who", MISSING)
            if w not in (["user", "agent"], ["agent", "user"], ["agent", "agent"]):
                c.bad(f"{path}.who", w, 'expected ["user", "agent"] or ["agent", "agent"]')
            else:
                who = ("agent", "agent") if w == ["agent", "agent"] else ("user", "agent")
            distance = c.number(t, "distance", f"{path}.distance", check=lambda x: x > 0,
                                expect="> 0 m") or 0.0
        elif kind == "time":
            at = c.number(t, "at", f"{path}.at", required=False, default=0.0, check=lambda x: x >= 0,
                          expect=">= 0 s") or 0.0
            if "every" in t:
                every = _seconds(t["every"])
                if every is None or every[1] <= 0:
                    c.bad(f"{path}.every", t["every"],
                          "expected seconds > 0, or [lo, hi] with 0 < hi, lo <= hi")
                    every = None
        else:
            action = c.string(t, "action", f"{path}.action") or ""
            distance = c.number(t, "distance", f"{path}.distance", required=False, default=0.0,
                                check=lambda x: x >= 0, expect=">= 0 m (0: any distance)") or 0.0
        st = c.strings(t, "states", f"{path}.states", required=False, default=()) or ()
        for s in st:
            if s not in states:
                c.bad(f"{path}.states", list(st), f"unknown state {s!r}; known: {', '.join(sorted(states))}")
                break
        idle = c.boolean(t, "idle", f"{path}.idle", default=False)
        chance = c.number(t, "chance", f"{path}.chance", required=False, default=1.0,
                          check=lambda x: 0 < x <= 1, expect="in (0, 1]")
        cooldown = c.number(t, "cooldown", f"{path}.cooldown", required=False, default=0.0,
                            check=lambda x: x >= 0, expect=">= 0 s")
        max_running = c.integer(t, "max_running", f"{path}.max_running", required=False, default=1_000_000,
                                check=lambda x: x >= 1, expect=">= 1")
        bind = self._bind(t.get("bind", MISSING), f"{path}.bind", ev, kind, who)
        if len(c.problems) > n0 or ev is None or bind is None:
            return None
        assert chance is not None and cooldown is not None and max_running is not None
        return TriggerDef(kind=kind, event=ev.name, bind=bind, who=who, region=region, distance=distance,
                          at=at, every=every, action=action, states=tuple(st), idle=idle, chance=chance,
                          cooldown=cooldown, max_running=max_running)

    def _bind(self, raw: object, path: str, ev: EventDef | None, kind: str,
              who: tuple[str, ...]) -> dict[str, Any] | None:
        c = self.c
        if not isinstance(raw, dict):
            c.bad(path, raw,
                  'required: a table mapping the event\'s parameters, e.g. { a = "agent", b = "other" }')
            return None
        if ev is None:
            return None
        tree = self.known_trees[ev.tree]
        have = {"enter": ("agent", "user", "here") if who != ("user",) else BIND_SYMBOLS,
                "near": ("agent", "user", "midpoint", "here") if who == ("user", "agent")
                else ("agent", "other", "midpoint", "here", "user"),
                "time": BIND_SYMBOLS, "user_action": ("agent", "user", "midpoint", "here")}[kind]
        objects = {o.name: o.kind for o in self.objects}
        out: dict[str, Any] = {}
        for p in tree.params:
            if p not in raw:
                c.bad(f"{path}.{p}", MISSING, f"required: event {ev.name!r} (tree {ev.tree!r}) takes "
                      f"{', '.join(f'{k} ({v})' for k, v in tree.params.items())}")
        for p, v in raw.items():
            if p not in tree.params:
                c.bad(f"{path}.{p}", v, f"unknown parameter of tree {ev.tree!r}; its parameters: "
                      f"{', '.join(tree.params)}")
                continue
            pk = tree.params[p]
            if pk == "point" and _point(v) is not None:
                out[p] = _point(v)
                continue
            if pk == "object":
                if v not in objects:
                    c.bad(f"{path}.{p}", v, f"expected an object name; the scene's objects: "
                          f"{', '.join(objects) or 'none'}")
                    continue
                okind = objects[v]
                missing = sorted(tree.uses.get(p, frozenset()) - set(object_kinds[okind].AFFORDANCES))
                if missing:
                    c.bad(f"{path}.{p}", v, f"a {okind} has no affordance {missing[0]!r}; its affordances: "
                          f"{', '.join(object_kinds[okind].AFFORDANCES)}")
                    continue
                out[p] = v
                continue
            allowed = tuple(s for s in _SYMBOLS_FOR[pk] if s in have)
            if v not in allowed:
                extra = " or [x, y]" if pk == "point" else ""
                article = "an" if pk[0] in "aeiou" else "a"
                c.bad(f"{path}.{p}", v, f"{article} {pk} parameter; this trigger binds "
                      f"{', '.join(allowed) or 'nothing'}{extra}")
                continue
            out[p] = v
        return out


def _point(v: object) -> tuple[float, float] | None:
    if isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v):
        return (float(v[0]), float(v[1]))
    return None


def _seconds(v: object) -> tuple[float, float] | None:
    if is_num(v) and float(v) >= 0:  # type: ignore[arg-type]
        return (float(v), float(v))  # type: ignore[arg-type]
    if isinstance(v, list) and len(v) == 2 and all(is_num(x) for x in v) and 0 <= v[0] <= v[1]:
        return (float(v[0]), float(v[1]))
    return None


def _region(c: Checker, r: object, path: str) -> tuple[str, tuple[float, ...]] | None:
    if isinstance(r, dict) and len(r) == 1:
        (k, v), = r.items()
        if k == "box" and isinstance(v, list) and len(v) == 4 and all(is_num(x) for x in v) \
                and v[0] < v[2] and v[1] < v[3]:
            return ("box", tuple(float(x) for x in v))
        if k == "disc" and isinstance(v, list) and len(v) == 3 and all(is_num(x) for x in v) and v[2] > 0:
            return ("disc", tuple(float(x) for x in v))
    c.bad(path, r, "required: {box = [xmin, ymin, xmax, ymax]} or {disc = [cx, cy, r]}")
    return None
