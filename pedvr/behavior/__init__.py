"""Behavior: what agents decide to do (PedVR §4.3; ADAPT §5–6).

Modules
-------
``bfsm``, ``goals``   the BFSM (PedVR §4.3): states, goal selectors, transitions.
``tree``              behavior-tree nodes in py_trees' vocabulary (``initialise`` / ``update`` /
                      ``terminate``; RUNNING / SUCCESS / FAILURE / INVALID), composites and decorators.
``leaves``            actions on the body's capabilities and on steering; conditions on the world.
``objects``           smart objects and their affordances (the chair); the ``use`` leaf.
``nodes``             the node types as data: the tree format of scene files, checked and built.
``spec``, ``declare`` declarations of trees, events, objects, triggers, and their scene checks.
``library``           the built-in trees: ``conversation`` (ADAPT Fig. 7), ``wave_at_user``,
                      ``rest_on_chair``.
``scheduler``         personal trees, events with priorities and suspension, ticked at the
                      decision rate in the simulation's ``decide`` phase (ADAPT §6.1.1).
``triggers``          spatial, temporal and user-action triggers that start events.
``context``           what a tree sees and drives at a tick; ownership and lingering effects.
``bench``             ``pedvr bench behavior``.

Writing a new interaction (a door, a demonstration)
---------------------------------------------------
An interaction is made of parts that are each registered by name, so a scene
can name them and the loader can check every reference:

1. **A smart object kind** (``objects.object_kinds``): a :class:`~pedvr.behavior.objects.SmartObject`
   subclass that owns the per-object state (who holds the door, the exhibit's
   demonstrator), lists its ``AFFORDANCES`` and returns, for each, a node that
   drives the agent until it reports SUCCESS or FAILURE. ``tick(ctx)`` runs once
   per decision tick, before the trees, for state that changes on its own.
2. **Leaves**, when the built-in ones (``go_to``, ``follow``, ``face``, ``gaze_at``,
   ``gesture``, ``reach_for``, ``sit_down``, ``stand_up``, ``set_speed``, ``use``,
   ``near``, ``sees``, ``facing``, ``moving``, ``idle``, ``after``, ``before``) are not
   enough: a :class:`~pedvr.behavior.tree.Behaviour` subclass, registered as a
   node type (``nodes.node_types``) so scene files can use it too.
3. **A tree definition** with typed parameters for the roles: ``agent`` (driven),
   ``user`` or ``actor`` (observed only: the user is never driven, and the
   loader rejects an action on such a role), ``point``, ``object``. Written in
   the scene format, in a scene (``[behavior.trees.NAME]``) or in Python
   (``nodes.define_tree``, registered in ``library.trees``).
4. **An event** (``[behavior.events.NAME]``: the tree, a priority >= 1, a
   patience) and **triggers** that start it, or ``sim.scheduler.start_event``
   from code.

Rules the framework relies on: a leaf ends in ``terminate`` what it started
(for INVALID: it was stopped), and only if it still owns the channel
(``ctx.claim`` / ``ctx.release``); an effect meant to outlast the leaf is filed
with ``ctx.linger`` and undone when the tree ends; a RUNNING leaf that only
waits sets ``self.wake`` so its tree can sleep; randomness comes from
``ctx.rng``. Trees read positions (the last step's) and write goals, facings,
speeds and capability commands only.

Worked example: holding a gate for someone (a door, much simplified). The
holder walks through first, then holds the gate until the follower (the user
or another agent) is through. It runs as written (``tests/behavior/test_guide.py``
executes it)::

    import math

    from pedvr.behavior.leaves import Face, GoTo, PointTarget
    from pedvr.behavior.library import trees
    from pedvr.behavior.nodes import Attr, NodeType, define_tree, node_types
    from pedvr.behavior.objects import SmartObject, object_kinds
    from pedvr.behavior.tree import RUNNING, SUCCESS, Behaviour, Condition, Sequence


    @object_kinds.register("gate")
    class Gate(SmartObject):
        \"\"\"A gate at ``at``; ``facing`` points from its near side through to its far side.\"\"\"

        AFFORDANCES = ("pass", "hold")

        def __init__(self, decl):
            super().__init__(decl)
            self.holder = None  # per-object state: the agent holding it open

        def side(self, ahead, left=0.0):  # a point `ahead` m through the gate, `left` m to its left
            c, s = math.cos(self.facing), math.sin(self.facing)
            return (self.at[0] + ahead * c - left * s, self.at[1] + ahead * s + left * c)

        def affordance(self, name, agent, ctx):
            if name == "pass":  # up to the gate, then through it
                return Sequence([GoTo(agent, PointTarget(self.side(-1.0))),
                                 GoTo(agent, PointTarget(self.side(1.0)))])
            return HoldGate(self, agent)


    class HoldGate(Behaviour):
        \"\"\"Stand beside the gate on its far side, facing back, until stopped.\"\"\"

        def __init__(self, gate, agent):
            super().__init__(f"{gate.name}.hold")
            self.gate, self.agent = gate, agent
            self.steps = Sequence([GoTo(agent, PointTarget(gate.side(0.8, 0.9)), arrive=0.2),
                                   Face(agent, heading=gate.facing + math.pi)])

        def initialise(self, ctx):
            self.gate.holder = self.agent

        def update(self, ctx):
            if self.steps.status is not SUCCESS:
                s = self.steps.tick(ctx)
                if s is not SUCCESS:
                    return s
            self.wake = math.inf  # holding needs no ticks: the tree sleeps on this branch
            return RUNNING

        def terminate(self, ctx, new_status):
            if self.steps.status is RUNNING:
                self.steps.stop(ctx)  # walking or turning ends with the hold
            self.gate.holder = None


    class Through(Condition):
        \"\"\"The actor is half a metre or more past the gate.\"\"\"

        def __init__(self, actor, gate):
            super().__init__("through")
            self.actor, self.gate = actor, gate

        def check(self, ctx):
            x, y = ctx.pos(self.actor)
            g = self.gate
            return (x - g.at[0]) * math.cos(g.facing) + (y - g.at[1]) * math.sin(g.facing) > 0.5


    node_types.register("through")(NodeType(
        main="actor", attrs={"gate": Attr("object", required=True)},
        build=lambda spec, b: Through(b.actor(spec.main), b.object(spec.attrs["gate"]))))

    trees.register("hold_gate")(define_tree(
        "hold_gate", {"holder": "agent", "follower": "actor", "gate": "object"},
        {"sequence": [
            {"use": "holder", "object": "gate", "affordance": "pass"},
            {"parallel": [{"use": "holder", "object": "gate", "affordance": "hold"},
                          {"until": {"through": "follower", "gate": "gate"}}],
             "success": "one"},
        ]}))

A scene then places a gate and starts the event when the user comes near an
agent (or code calls ``sim.scheduler.start_event("hold_gate", {...})``)::

    [[behavior.objects]]
    name = "gate_1"
    kind = "gate"
    at = [0.0, 0.0]
    facing_deg = 0

    [behavior.events.hold_gate]
    tree = "hold_gate"
    priority = 2

    [[behavior.triggers]]
    kind = "near"
    who = ["user", "agent"]
    distance = 4.0
    event = "hold_gate"
    bind = { holder = "agent", follower = "user", gate = "gate_1" }
    cooldown = 30.0
"""
