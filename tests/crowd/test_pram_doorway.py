"""A pushed pram walks through an opening it fits through (issue 26, "no carrier left behind"): its
obstacle lines are those of the discs that hold its ellipse (``orca.rigid_obstacle_lines``), not of
one disc as wide as its support toward each edge, which saw the jamb beside its front as ahead of it
and slowed it to the clearance over the obstacle horizon."""

from __future__ import annotations

import math

import numpy as np

from pedvr.crowd.footprint import COVER_DISCS, covering_discs, footprints
from pedvr.scene.loader import load_scene
from pedvr.sim import Simulation

GAP = 1.0  # m: the opening, 0.2 m wider than the pram (0.8 m)

SCENE = f"""
[scene]
name = "pram_doorway"
seed = 3
duration = 20.0

[world]
bounds = [[-7.0, -4.0], [7.0, 4.0]]

[[world.obstacles]]
kind = "wall"
wall = [[0.0, {GAP / 2}], [0.0, 4.0]]

[[world.obstacles]]
kind = "wall"
wall = [[0.0, -4.0], [0.0, -{GAP / 2}]]

[agents.profiles.pram]
radius = 0.4
pref_speed = 1.0
max_speed = 1.4
carrying = "perambulator"

[[agents.spawns]]
profile = "pram"
state = "east"
positions = [[-5.0, 0.0]]
facing_deg = 0

[behavior.states.east]
goal = {{ selector = "point", at = [5.0, 0.0] }}
arrive_dist = 0.4

[user]
start = [6.0, 3.5]
heading_deg = 180
"""


def _crossing(tmp_path) -> tuple[float, float, float]:  # noqa: ANN001
    """When the pram's front reached the opening, when its pusher left it, and the least clearance
    of its covering discs to the jambs on the way."""
    path = tmp_path / "pram_doorway.toml"
    path.write_text(SCENE)
    sim = Simulation(load_scene(path))
    row = int(np.flatnonzero(sim.crowd.length > 0.0)[0])
    front_in = out = math.nan
    least = math.inf
    jambs = np.array([[0.0, GAP / 2], [0.0, -GAP / 2]])
    while sim.t < 20.0 and math.isnan(out):
        sim.step()
        c = sim.crowd
        fp = footprints(c.pos, c.radius, c.turn, c.torso, c.heading, c.ahead, c.length)
        discs, rad, _ = covering_discs(fp, np.array([row]))
        front = float(discs[:, 0].max() + rad.max())
        if math.isnan(front_in) and front >= 0.0:
            front_in = sim.t
        if c.pos[row, 0] - float(c.radius[row]) > 0.0:
            out = sim.t
        gaps = np.hypot(*(discs[:, None, :] - jambs[None, :, :]).transpose(2, 0, 1)) - rad[:, None]
        least = min(least, float(gaps.min()))
    return front_in, out, least


def test_a_pram_walks_through_an_opening_it_fits(tmp_path) -> None:  # noqa: ANN001
    """The pusher is through at most 2.5 s after the pram's front reached the opening (1.7 s; the
    front 1.4 m ahead of the pusher's back at 1.06 m/s), and nowhere nearer the jambs than 1 cm.
    With one disc as wide as the support toward each edge it took 3.9 s (the code before)."""
    front_in, out, least = _crossing(tmp_path)
    assert not math.isnan(out), "the pram did not get through in 20 s"
    assert out - front_in <= 2.5, (front_in, out)
    assert least >= -0.01, least


def test_the_covering_discs_are_as_small_as_the_ellipse_allows() -> None:
    """The discs that hold a pram's ellipse (``footprint.covering_discs``, which ORCA's obstacle lines
    and the door controller share) are, within 0.5 mm, the least that do: each as large as the
    farthest point of the outline nearest its centre, measured here on 720 samples of the whole
    outline (the door controller's own computation before the two were one)."""
    a, b = 0.805, 0.4
    fp = footprints(np.zeros((1, 2)), np.array([b]), np.zeros(1), np.zeros(1), np.zeros(1), np.array([0.577]),
                    np.array([a]))
    _, rad, _ = covering_discs(fp, np.array([0]))
    x = np.linspace(-(a - b), a - b, COVER_DISCS)
    t = np.linspace(0.0, 2.0 * np.pi, 721)[:-1]
    bx, by = a * np.cos(t), b * np.sin(t)
    near = np.abs(bx[:, None] - x[None, :]).argmin(axis=1)
    least = np.zeros(COVER_DISCS)
    np.maximum.at(least, near, np.hypot(bx - x[near], by))
    np.testing.assert_allclose(rad, least + 2e-3, atol=5e-4)
