"""Declarations of trees, events, smart objects and triggers: frozen, validated data.

These are what a scene file (or the built-in library) declares; the scene
loader validates them (:mod:`pedvr.behavior.declare`) and the scheduler
turns them into running trees (:mod:`pedvr.behavior.build`). Nothing here
imports the simulation: :mod:`pedvr.scene.config` holds these types.

A tree definition has named, typed parameters (ADAPT §6's parameterized
behavior trees, "PBTs"); it is instantiated at run time for any actors,
points and objects that fit them. Parameter kinds:

``agent``   a virtual pedestrian the tree drives;
``user``    the user: observed (position, velocity, facing), never driven;
``actor``   either, observed only;
``point``   a ground point ``(x, y)``;
``object``  a smart object.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

PARAM_KINDS = ("agent", "user", "actor", "point", "object")
Point = tuple[float, float]


@dataclass(frozen=True)
class Ref:
    """A reference inside a tree: ``kind`` is ``param`` (value: its name), ``user``, ``point``
    (value: (x, y)), ``object`` (value: a scene object's name), ``nearest`` (value: an object
    kind: the nearest object of that kind that can serve the affordance), ``region`` (value:
    a box: a random walkable point drawn when the leaf starts) or ``goal_set`` (value: a set's
    name: a weighted point drawn when the leaf starts)."""

    kind: str
    value: Any = None


@dataclass(frozen=True)
class NodeSpec:
    """One node of a tree definition.

    ``kind`` names a registered node type; ``main`` is the value of its
    type key (children, a child, an actor reference, seconds, ...);
    ``attrs`` its other, validated attributes; ``key`` the dotted key where it
    was declared (for messages at run time).
    """

    kind: str
    main: Any
    attrs: dict[str, Any] = field(default_factory=dict)
    key: str = ""


@dataclass(frozen=True)
class TreeDef:
    """A parameterized tree: ``params`` maps each name to its kind (see the module docstring)."""

    name: str
    params: dict[str, str]
    root: NodeSpec
    source: str = ""  # where it was declared: a scene file, or "library"
    uses: dict[str, frozenset[str]] = field(default_factory=dict)  # object param -> affordances used


@dataclass(frozen=True)
class EventDef:
    """A multi-actor event (ADAPT §6.1): a tree run with exclusive control of its agents.

    ``priority`` >= 1 (personal trees and the BFSM are 0); a higher one
    interrupts a lower one. A started event waits for all its agents to be
    ready at most ``patience`` seconds, then is dropped.
    """

    name: str
    tree: str
    priority: int = 1
    patience: float = 10.0


@dataclass(frozen=True)
class ObjectDef:
    """A smart object in the scene (ADAPT §6.2): ``kind`` names a registered object kind."""

    name: str
    kind: str
    at: Point
    facing: float = 0.0  # rad
    params: dict[str, Any] = field(default_factory=dict)


TRIGGER_KINDS = ("enter", "near", "time", "user_action")


@dataclass(frozen=True)
class TriggerDef:
    """What starts an event (ADAPT §7: spatial and temporal triggers, and the user's actions).

    ``kind``: ``enter`` (an actor of ``who`` enters ``region``), ``near`` (a
    user–agent or agent–agent pair comes within ``distance``), ``time`` (at
    ``at`` s, then every ``every`` s), ``user_action`` (the backend reports the
    user's ``action``). ``bind`` maps each of the event's parameters to a
    symbol (``agent``, ``other``, ``user``, ``midpoint``, ``here``), an object
    name, or a point. Agents are eligible when they are in one of
    ``states`` (any state if empty), not in an event, and, with ``idle``,
    standing on their feet. ``chance`` is the probability that a firing
    starts the event; ``cooldown`` seconds pass before the same actors (for
    ``time`` and ``user_action``: the trigger) fire it again; at most
    ``max_running`` of its events run at once.
    """

    kind: str
    event: str
    bind: dict[str, Any]
    who: tuple[str, ...] = ()
    region: tuple[str, tuple[float, ...]] | None = None
    distance: float = 0.0
    at: float = 0.0
    every: tuple[float, float] | None = None
    action: str = ""
    states: tuple[str, ...] = ()
    idle: bool = False
    chance: float = 1.0
    cooldown: float = 0.0
    max_running: int = 1_000_000
