"""The built-in tree library: definitions registered by name, usable from any scene.

Written in the scene format (:mod:`pedvr.behavior.nodes`), checked at import.

``conversation(a: agent, b: agent, spot: point)``
    ADAPT Fig. 7: both walk to the meeting point (each stops within 0.75 m
    of it, so they end about a metre apart), turn to face each other, look at
    each other, then take turns gesturing (``talk``, ``shrug`` or ``point``,
    1.5–3 s each) for 8–16 s while they keep facing each other; then the
    event ends and both return to autonomy.

``wave_at_user(a: agent, u: user)``
    If the user is within 5 m: turn toward the user (and keep turning as the
    user walks on), look at the user, and wave for 2 s after 0.3 s; the
    event ends when the wave does (or after 3 s of looking).

``rest_on_chair(self: agent)``
    A personal tree: sit on the nearest free chair for 10–25 s, then stand
    up; when no chair can be had (all taken, or the chosen one blocked) the
    fallback checks the phone for 3–6 s where the agent stands.
"""

from __future__ import annotations

from pedvr.behavior.nodes import define_tree
from pedvr.behavior.spec import TreeDef
from pedvr.registry import Registry

trees: Registry[TreeDef] = Registry("tree")

_TALK = ["talk", "shrug", "point"]

trees.register("conversation")(define_tree("conversation", {"a": "agent", "b": "agent", "spot": "point"}, {
    "sequence": [
        {"parallel": [{"go_to": "a", "to": "spot", "arrive": 0.75, "max_time": 40.0},
                      {"go_to": "b", "to": "spot", "arrive": 0.75, "max_time": 40.0}]},
        {"parallel": [{"face": "a", "toward": "b"}, {"face": "b", "toward": "a"}]},
        # Keep facing each other (passers-by make standing people step aside) while talking.
        {"parallel": [
            {"face": "a", "toward": "b", "hold": True},
            {"face": "b", "toward": "a", "hold": True},
            {"sequence": [
                {"parallel": [{"gaze_at": "a", "at": "b"}, {"gaze_at": "b", "at": "a"}]},
                {"repeat": {"sequence": [{"gesture": "a", "clip": _TALK, "seconds": [1.5, 3.0]},
                                         {"gesture": "b", "clip": _TALK, "seconds": [1.5, 3.0]}]},
                 "seconds": [8.0, 16.0]}]},
        ], "success": "one"},
    ]}))

trees.register("wave_at_user")(define_tree("wave_at_user", {"a": "agent", "u": "user"}, {
    "sequence": [
        {"near": "u", "of": "a", "within": 5.0},
        {"parallel": [{"face": "a", "toward": "u", "hold": True},
                      {"gaze_at": "a", "at": "u", "seconds": 3.0},
                      {"sequence": [{"wait": 0.3}, {"gesture": "a", "clip": "wave", "seconds": 2.0}]}],
         "success": "one"},
    ]}))

trees.register("rest_on_chair")(define_tree("rest_on_chair", {"self": "agent"}, {
    "selector": [
        {"sequence": [{"use": "self", "object": {"nearest": "chair"}, "affordance": "sit"},
                      {"wait": [10.0, 25.0]},
                      {"stand_up": "self"}]},
        {"sequence": [{"gesture": "self", "clip": "check_phone", "seconds": [3.0, 6.0]}]},
    ], "memory": True}))


def library_trees() -> dict[str, TreeDef]:
    """Every registered library tree by name."""
    return {name: trees[name] for name in trees}
