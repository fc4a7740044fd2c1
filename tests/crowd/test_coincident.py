"""Bodies at one point (issue 24, item 1): two spawns at one position, agents teleported onto
each other or onto the user, many at one point. No input may crash a step; after a second the
bodies are apart with no overlap over 1 cm, nobody is ever inside the user, and the same seed
gives the same bytes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pedvr.cli import main
from pedvr.crowd.coincident import apart
from pedvr.crowd.footprint import footprints
from pedvr.crowd.overlap import pair_overlaps, user_clearance
from pedvr.crowd.steering import Steering
from pedvr.scene.config import SteeringParams
from pedvr.scene.loader import load_scene
from pedvr.sim import Simulation
from pedvr.world.obstacles import ObstacleSet
from tests.crowd._helpers import crowd

SCENE = """\
[scene]
name = "coincident"
seed = 5
duration = 3.0

[world]
bounds = {bounds}

[agents.profiles.adult]
radius = 0.25
pref_speed = 1.3
max_speed = 1.6

[[agents.spawns]]
profile = "adult"
state = "stand"
positions = {positions}

[behavior.states.stand]
goal = {{ selector = "stay" }}

[user]
start = {user}
heading_deg = 0
route = {route}
"""


def write_scene(tmp_path: Path, *, positions: list[list[float]], bounds: str = "[[-5.0, -5.0], [5.0, 5.0]]",
                user: str = "[-3.0, -3.0]", route: str = "[[-2.5, -3.0]]") -> Path:
    path = tmp_path / "coincident.toml"
    path.write_text(SCENE.format(bounds=bounds, positions=json.dumps(positions), user=user, route=route))
    return path


def overlap_now(sim: Simulation) -> float:
    """The deepest overlap between two footprints in the simulation's committed state (m)."""
    c = sim.crowd
    fp = footprints(c.pos, c.radius, c.turn, c.torso, c.heading, c.ahead, c.length)
    worst, _ = pair_overlaps(fp.centre, fp.radius, fp.depth, fp.facing, 0.01)
    return float(worst)


def into_user(sim: Simulation) -> float:
    """How deep any footprint cuts into the user's disc now (m; 0 or less: nobody inside)."""
    c = sim.crowd
    u = int(np.flatnonzero(c.is_user)[0])
    fp = footprints(c.pos, c.radius, c.turn, c.torso, c.heading, c.ahead, c.length)
    _, clear, _ = user_clearance(c.pos, fp.centre, fp.radius, fp.depth, fp.facing, u, c.pos[u], float(c.radius[u]))
    return -float(clear)


def test_two_spawns_at_one_position_run_from_the_command_line(tmp_path: Path) -> None:
    """The issue's report: such a scene died in the ORCA kernel with ZeroDivisionError."""
    path = write_scene(tmp_path, positions=[[1.0, 1.0], [1.0, 1.0]])
    metrics = tmp_path / "m.json"
    assert main(["run", str(path), "--backend", "headless", "--duration", "1", "--out", str(tmp_path),
                 "--metrics-json", str(metrics), "--quiet"]) == 0
    m = json.loads(metrics.read_text())
    assert m["max_overlap_m"] <= 0.01 and m["overlaps_over_1cm"] == 0, m


@pytest.mark.parametrize("condition", ["decoupled", "pedvr", "pedvr+g"])
def test_many_at_one_point_come_apart_within_a_second(tmp_path: Path, condition: str) -> None:
    sim = Simulation(load_scene(write_scene(tmp_path, positions=[[1.0, 1.0]] * 5)), condition=condition)
    sim.advance_to(1.0)
    assert np.isfinite(sim.crowd.pos).all() and np.isfinite(sim.crowd.vel).all()
    assert overlap_now(sim) <= 0.01
    agents = sim.crowd.pos[~sim.crowd.is_user]
    gaps = np.linalg.norm(agents[:, None] - agents[None], axis=2)[np.triu_indices(5, 1)]
    assert gaps.min() >= 0.49  # every pair apart (radii 0.25)


def test_five_at_one_point_in_a_narrow_corridor_spread_along_it(tmp_path: Path) -> None:
    """A 0.9 m corridor running along y: five bodies side by side across it do not fit, so a
    separation along one fixed axis (x) would press them into the walls for ever; they spread
    in two dimensions and end up one behind the other."""
    path = write_scene(tmp_path, positions=[[0.0, 0.0]] * 5, bounds="[[-0.45, -6.0], [0.45, 6.0]]",
                       user="[0.0, -5.0]", route="[[0.0, -4.5]]")
    sim = Simulation(load_scene(path))
    sim.advance_to(1.0)
    s = sim.summary()
    assert overlap_now(sim) <= 0.01
    assert np.ptp(sim.crowd.pos[~sim.crowd.is_user, 1]) > 1.5  # strung out along the corridor
    assert s["user_overlap_max_m"] == 0.0, s


def teleport_run(tmp_path: Path, condition: str = "pedvr") -> tuple[Simulation, list[float]]:
    """Six agents and a user walking among them; at 1 s three agents are put at one point and two
    more onto the user's centre (a head moving into them), and an agent source adds one more on
    top of another agent. Returns the simulation after one more second and how deep anyone cut
    into the user at each step after the teleport."""
    positions = [[-2.0 + 0.8 * k, 0.6] for k in range(6)]
    path = write_scene(tmp_path, positions=positions, user="[-4.0, 0.0]", route="[[4.0, 0.0]]")
    sim = Simulation(load_scene(path), condition=condition)
    sim.advance_to(1.0)
    c = sim.crowd
    rows = np.flatnonzero(~c.is_user)
    user = int(np.flatnonzero(c.is_user)[0])
    c.pos[rows[1:3]] = c.pos[rows[0]]
    c.vel[rows[0:3]] = 0.0  # put there at rest
    c.pos[rows[3:5]] = c.pos[user]
    c.vel[rows[3:5]] = c.vel[user]  # and moving with the user
    sim.add_agents("adult", c.pos[rows[5]][None], state="stand")
    cut = []
    for _ in range(round(1.0 / sim.dt)):
        sim.step()
        cut.append(into_user(sim))
    return sim, cut


@pytest.mark.parametrize("condition", ["decoupled", "pedvr"])
def test_agents_teleported_onto_each_other_and_onto_the_user(tmp_path: Path, condition: str) -> None:
    sim, cut = teleport_run(tmp_path, condition)
    assert np.isfinite(sim.crowd.pos).all()
    assert max(cut) <= 0.0, max(cut)  # the user's body wins from the first step on
    assert overlap_now(sim) <= 0.01
    assert sim.summary()["user_overlap_max_m"] == 0.0


def test_same_seed_same_bytes_with_coincident_bodies(tmp_path: Path) -> None:
    a, _ = teleport_run(tmp_path)
    b, _ = teleport_run(tmp_path)
    assert a.crowd.pos.tobytes() == b.crowd.pos.tobytes()
    assert a.crowd.vel.tobytes() == b.crowd.vel.tobytes()


def test_an_agent_on_the_user_beside_a_wall_is_pushed_out_not_in() -> None:
    """The user 0.3 m from a wall, an agent exactly on the user's centre: whichever way the pair's
    direction points (here toward the wall for some rows), the agent ends outside the user's disc,
    the user does not move, and the same input gives the same bytes."""
    wall = ObstacleSet.from_polygons([np.array([[-3.0, 0.3], [3.0, 0.3], [3.0, 1.0], [-3.0, 1.0]])])
    steer = Steering(SteeringParams(), wall, coupled=False)
    for row in range(1, 9):
        pos = np.zeros((9, 2))
        pos[1:, 0] = np.arange(1, 9) * 2.0 - 9.0  # the others far apart
        pos[1:, 1] = -2.0
        pos[row] = pos[0]  # agent `row` on the user at the origin
        radius = np.full(9, 0.25)
        is_user = np.zeros(9, np.bool_)
        is_user[0] = True
        out = steer.resolve_contacts(pos, radius, is_user)
        again = steer.resolve_contacts(pos, radius, is_user)
        assert out.tobytes() == again.tobytes()
        assert np.array_equal(out[0], pos[0])
        assert np.linalg.norm(out[row] - out[0]) >= 0.5, (row, out[row])


def test_coincident_pair_moves_apart_reciprocally() -> None:
    """Compute, then apply: both rows of a coincident pair are computed from the same state and go
    opposite ways, in ORCA (decoupled, both at rest) and in the contact pass (the pair's centroid
    stays put); the direction depends on the pair, not on which of them is computed first."""
    assert apart(3, 7) == tuple(-x for x in apart(7, 3))
    for i, j in ((0, 1), (1, 2), (2, 5), (4, 9)):
        pos = np.full((10, 2), 50.0)
        pos[:, 0] += np.arange(10) * 3.0  # the others far apart
        pos[i] = pos[j] = (0.0, 0.0)
        state = crowd(pos, responsibility=0.5)
        steer = Steering(SteeringParams(), ObstacleSet.empty(), coupled=False)
        v = steer.compute_velocities(state, 1 / 90)
        assert np.isfinite(v).all()
        assert np.linalg.norm(v[i]) > 1.0 and np.allclose(v[i], -v[j], atol=1e-12)
        out = steer.resolve_contacts(pos, state.radius, state.is_user)
        assert np.allclose(out[i] + out[j], 0.0, atol=1e-12)
        assert np.linalg.norm(out[i] - out[j]) >= 0.5 - 0.005


def test_orca_line_at_the_cut_off_centre_has_a_direction() -> None:
    """In collision the relative velocity can sit exactly on the cut-off centre (it closes the gap
    in exactly one step): RVO2 divides by zero there. The line then points the pair apart."""
    dt = 0.125  # binary fractions: the relative velocity equals the gap / dt exactly
    pos = np.array([[0.0, 0.0], [0.375, 0.0]])
    vel = np.array([[1.5, 0.0], [-1.5, 0.0]])  # relative velocity 3 m/s = 0.375 m / dt
    state = crowd(pos, vel)
    steer = Steering(SteeringParams(), ObstacleSet.empty(), coupled=False)
    lines = steer.orca_lines(state, dt, 0)
    assert np.isfinite(lines).all()
    (_, _, dx, dy), = lines
    assert (-dy, dx) == (-1.0, 0.0)  # the permitted side (left of the direction) lies away from row 1
    v = steer.compute_velocities(state, dt)
    assert np.isfinite(v).all() and v[0, 0] < 0.0 < v[1, 0]


def test_contact_pass_spreads_five_at_one_point_in_a_narrow_corridor() -> None:
    """The contact pass alone (no steering): five discs at one point in a 0.9 m corridor along y.
    Pushed apart along one axis across the corridor they would stay pressed into the walls; along
    their pairs' directions they come apart along it, off the walls."""
    walls = ObstacleSet.from_polygons([np.array([[-0.45, -6.0], [-0.45, 6.0], [0.45, 6.0], [0.45, -6.0]])])
    steer = Steering(SteeringParams(), walls, coupled=False)
    pos = np.zeros((5, 2))
    radius = np.full(5, 0.25)
    out = steer.resolve_contacts(pos, radius, np.zeros(5, np.bool_))
    gaps = np.linalg.norm(out[:, None] - out[None], axis=2)[np.triu_indices(5, 1)]
    assert gaps.min() >= 0.5 - 0.01
    assert np.abs(out[:, 0]).max() <= 0.45 - 0.25 + 0.01  # off the walls
