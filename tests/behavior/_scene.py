"""Small test scenes for the behavior layer: a 20 × 12 m room, agents at given places."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable

from pedvr.behavior.context import Run
from pedvr.behavior.nodes import Bindings, build, define_tree
from pedvr.behavior.tree import INVALID, RUNNING, Behaviour, Status
from pedvr.scene.loader import parse_scene
from pedvr.sim import Simulation

BASE = """
[scene]
name = "behavior_test"
seed = {seed}
duration = 30.0

[world]
bounds = [[-10.0, -6.0], [10.0, 6.0]]
{world}

[agents.profiles.p]
radius = 0.25
pref_speed = 1.3
max_speed = 1.6

{spawns}

[behavior.goal_sets.ends]
points = [[-8.0, 0.0], [8.0, 0.0]]

[behavior.states.stand]
goal = {{ selector = "stay" }}

[behavior.states.walk]
goal = {{ selector = "set", set = "ends" }}
arrive_dist = 0.5

[[behavior.states.walk.transitions]]
on = "arrival"
to = "walk"

{behavior}

[user]
start = {user_start}
speed = {user_speed}
{user_route}enabled = {user}
"""


def scene_text(*, agents: list[tuple[float, float, str]], behavior: str = "", world: str = "", seed: int = 1,
               user: bool = True, user_start: tuple[float, float] = (-9.5, -5.5),
               user_route: list[tuple[float, float]] | None = None, user_speed: float = 1.3) -> str:
    spawns = "\n".join(f'[[agents.spawns]]\nprofile = "p"\nstate = "{s}"\npositions = [[{x}, {y}]]\n'
                       f"facing_deg = 0\n" for x, y, s in agents)
    return BASE.format(seed=seed, world=world, spawns=spawns, behavior=behavior,
                       user_start=list(user_start), user_speed=user_speed,
                       user_route=f"route = {[list(p) for p in user_route]}\n" if user_route else "",
                       user="true" if user else "false")


def make_sim(**kw: object) -> Simulation:
    text = scene_text(**kw)  # type: ignore[arg-type]
    return Simulation(parse_scene(tomllib.loads(text), source="test.toml"), record=True)


def step_until(sim: Simulation, done: Callable[[], bool], *, seconds: float) -> bool:
    """Step until ``done()`` (checked every step) or ``seconds`` more have passed; returns done()."""
    end = sim.t + seconds
    while sim.t < end - 1e-9:
        sim.step()
        if done():
            return True
    return done()


def row(sim: Simulation, agent: int) -> int:
    return sim.crowd.index_of(agent)


class Driver:
    """Ticks one tree on the simulation's context at each decision tick, as the scheduler would."""

    def __init__(self, sim: Simulation, root: Behaviour) -> None:
        self.sim = sim
        self.root = root
        self.run = Run()
        self.status = INVALID

    def tick(self) -> Status:
        ctx = self.sim.scheduler.ctx
        ctx.t = self.sim.t
        ctx.wake = math.inf
        ctx.run = self.run
        self.status = self.root.tick(ctx)
        return self.status

    def drive(self, seconds: float, *, until_done: bool = True) -> Status:
        """Step ``seconds``, ticking the tree at the decision rate while it runs; return early when it
        ends (``until_done``), else go on stepping without ticking it again."""
        sim = self.sim
        end = sim.t + seconds
        while sim.t < end - 1e-9:
            done = self.status is not RUNNING and self.status is not INVALID
            if done and until_done:
                return self.status
            if not done and sim.step_index % sim.scene.decision_every == 0:
                self.tick()
            sim.step()
        return self.status

    def halt(self) -> None:
        """The termination signal, then the end of the tree (undo what it left in place)."""
        ctx = self.sim.scheduler.ctx
        ctx.run = self.run
        self.root.stop(ctx)
        self.run.end()


def tree(sim: Simulation, node: dict[str, object], params: dict[str, str], values: dict[str, object]) -> Driver:
    """A driver for a tree written in the scene format, bound to ``values``."""
    objects = {name: o.kind for name, o in sim.scheduler.objects.items()}
    spec = define_tree("t", params, node, objects=objects, goal_sets=frozenset(sim.scene.behavior.goal_sets))
    b = Bindings(values, objects=sim.scheduler.objects, user=sim.scheduler.ctx.user)
    return Driver(sim, build(spec.root, b))
