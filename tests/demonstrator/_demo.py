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

# A gallery bay (issue 24 item 8): a painting on a partition wall, a 3 m pillar 2.85 m in front of it.
# An observer standing at (0, 0.8) behind the pillar can be seen from no placement near d_pref
# (1.4 m for the painting's 0.5 m), only from a metre or so farther out.
PILLAR = """
[[world.obstacles]]
kind = "wall"
box = [-3.0, 5.5, 3.0, 5.8]
height = 2.5

[[world.obstacles]]
kind = "pillar"
circle = [0.0, 2.8, 0.6]
height = 3.0
"""
PAINTING = """
[[behavior.objects]]
name = "vase"
kind = "exhibit"
at = [0.0, 5.65]
height = 1.5
size = 0.5
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


class RouteUser:
    """Stands at ``route[0]`` and walks the route at 1.2 m/s from time ``at`` (then stands)."""

    def __init__(self, route: list[tuple[float, float]], *, at: float, heading: float) -> None:
        self.route, self.at, self.heading = np.asarray(route, np.float64), at, heading
        self.cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.route, axis=0), axis=1))])

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        s = min(max((t - self.at) * 1.2, 0.0), float(self.cum[-1]))
        k = min(int(np.searchsorted(self.cum, s, side="right")) - 1, len(self.route) - 2)
        u = (s - self.cum[k]) / max(float(self.cum[k + 1] - self.cum[k]), 1e-9)
        return self.route[k] + u * (self.route[k + 1] - self.route[k]), self.heading


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
             agents: list[tuple[float, float, str]] | None = None, seed: int = 1,
             exhibit: str = EXHIBIT) -> Simulation:
    text = scene_text(agents=agents or [(start[0], start[1], "stand")], behavior=exhibit.format(talk=talk) + extra,
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
