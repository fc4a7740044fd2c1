"""A small demonstration scene (the paper's table, §3) and a per-step trace of the demonstrator's body."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

from pedvr.body import skeleton as sk
from pedvr.crowd.user import StandingUser, UserInput
from pedvr.scene.loader import parse_scene
from pedvr.sim import Simulation
from tests.behavior._scene import scene_text

TABLE = """
[[world.obstacles]]
kind = "table"
box = [-0.8, -0.4, 0.8, 0.4]
height = 0.75
"""
EXHIBIT = """
[[behavior.objects]]
name = "vase"
kind = "exhibit"
at = [0.3, 0.2]
talk = {talk}

[behavior.events.show]
tree = "demonstrate"
priority = 2
"""


class MovingUser:
    """Stands at ``a`` and walks to ``b`` at 1.2 m/s from time ``at`` (then stands), facing ``heading``."""

    def __init__(self, a: tuple[float, float], b: tuple[float, float], *, at: float, heading: float) -> None:
        self.a, self.b, self.at, self.heading = np.asarray(a), np.asarray(b), at, heading

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        d = float(np.linalg.norm(self.b - self.a))
        k = min(max((t - self.at) * 1.2 / max(d, 1e-9), 0.0), 1.0)
        return self.a + k * (self.b - self.a), self.heading


@dataclass
class Trace:
    t: list[float] = field(default_factory=list)
    root: list[np.ndarray] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    stepping: list[bool] = field(default_factory=list)
    feet: list[np.ndarray] = field(default_factory=list)  # (2, 2) ground references
    planted: list[np.ndarray] = field(default_factory=list)
    hand: list[np.ndarray] = field(default_factory=list)  # right hand joint and tip (2, 3)
    chain_yaw: list[float] = field(default_factory=list)  # lumbar..head yaw on the trunk, rad

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.__dict__.items()}


def demo_sim(*, observer: tuple[float, float] = (0.3, 2.5), start: tuple[float, float] = (-5.0, -3.0),
             user: UserInput | None = None, talk: float = 3.0, world: str = TABLE, extra: str = "",
             agents: list[tuple[float, float, str]] | None = None, seed: int = 1) -> Simulation:
    text = scene_text(agents=agents or [(start[0], start[1], "stand")], behavior=EXHIBIT.format(talk=talk) + extra,
                      world=world, user_start=observer, seed=seed)
    src = user if user is not None else StandingUser(observer, -math.pi / 2)
    return Simulation(parse_scene(tomllib.loads(text), source="demo.toml"), user_input=src, record=True)


def run_demo(sim: Simulation, *, agent: int = 1, exhibit: str = "vase", seconds: float = 30.0) -> Trace:
    """Start the demonstration of ``exhibit`` by ``agent`` to the user; step until it ends."""
    run = sim.scheduler.start_event("show", {"guide": agent, "observer": 0, "exhibit": exhibit})
    tr = Trace()
    end = sim.t + seconds
    while sim.t < end and run.phase != "ended":
        sim.step()
        r = sim.crowd.index_of(agent)
        b = sim.body.state
        tr.t.append(sim.t)
        tr.root.append(b.root[r].copy())
        tr.heading.append(float(b.heading[r]))
        tr.stepping.append(bool(b.stepping[r]))
        tr.feet.append(b.foot_ref[r].copy())
        tr.planted.append(b.planted[r].copy())
        tr.hand.append(b.world_pos[r, [sk.R_HAND, sk.R_HAND_TIP]].copy())
        tr.chain_yaw.append(float(b.gaze_ang[r, :4, 0].sum()))
    return tr
