"""Run metrics that must measure every step: the user's distance, stalled agents."""

from __future__ import annotations

import numpy as np

from pedvr.scene.loader import load_scene, parse_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def test_min_user_distance_is_measured_even_when_no_discs_are_close() -> None:
    """headon_corridor's agent passes the user without ever coming within two radii of anyone:
    the figure was None; it is the closest centre distance in the recording."""
    sim = Simulation(load_scene(resolve_scene("headon_corridor")), record=True)
    sim.advance_to(8.0)
    arr = sim.recording.arrays()  # type: ignore[union-attr]
    u = int(np.flatnonzero(arr["is_user"])[0])
    d = np.linalg.norm(arr["pos"][1:, 1 - u] - arr["pos"][1:, u], axis=1)
    got = sim.summary()["min_user_distance_m"]
    assert got is not None and abs(float(got) - float(d.min())) < 1e-5  # type: ignore[arg-type]


def _walled(goal: list[float]) -> Simulation:
    """A 10 x 4 m room split by a full-height wall at x = 0; one agent at x = -3."""
    data = {
        "scene": {"name": "stall", "seed": 1, "duration": 30.0},
        "world": {"bounds": [[-5.0, -2.0], [5.0, 2.0]],
                  "obstacles": [{"polygon": [[-0.1, -2.0], [0.1, -2.0], [0.1, 2.0], [-0.1, 2.0]]}]},
        "agents": {"profiles": {"adult": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6}},
                   "spawns": [{"profile": "adult", "state": "go", "positions": [[-3.0, 0.0]]}]},
        "behavior": {"states": {"go": {"goal": {"selector": "point", "at": goal}}}},
        "user": {"enabled": False, "start": [4.0, 0.0]},
    }
    return Simulation(parse_scene(data, source="stall.toml"))


def test_an_agent_that_cannot_reach_its_goal_is_stalled_after_20_s() -> None:
    sim = _walled([3.0, 0.0])  # behind the wall: no path, it stands
    sim.advance_to(19.0)
    assert sim.summary()["stalled_agents"] == 0
    sim.advance_to(21.0)
    s = sim.summary()
    assert s["stalled_agents"] == 1 and s["stalled_agents_ever"] == 1


def test_an_agent_that_arrived_is_not_stalled() -> None:
    sim = _walled([-3.0, 1.5])  # reachable, 1.5 m away
    sim.advance_to(25.0)
    s = sim.summary()
    assert s["stalled_agents"] == 0 and s["stalled_agents_ever"] == 0


def test_root_sync_is_the_largest_pelvis_offset_of_walking_virtual_agents() -> None:
    """observe_body: the horizontal pelvis-to-agent distance, its largest over virtual rows that
    are not seated (the user's and a seated body's pelvis may be anywhere)."""
    from pedvr.crowd.state import N_LIMITS, CrowdState
    from pedvr.record import Metrics

    n = 4
    crowd = CrowdState(ids=np.arange(n), pos=np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]),
                       vel=np.zeros((n, 2)), pref_vel=np.zeros((n, 2)), heading=np.zeros(n),
                       pref_heading=np.zeros(n), radius=np.full(n, 0.25), pref_speed=np.ones(n),
                       max_speed=np.ones(n), responsibility=np.ones(n), is_user=np.array([True, False, False, False]),
                       limits=np.zeros((n, N_LIMITS)))
    # pelvis (x, height, z) against the 2D (x, z): the user 1 m off, row 1 3 cm, row 2 (seated) 0.3 m, row 3 4 cm
    pelvis = np.array([[1.0, 0.9, 0.0], [1.03, 0.9, 1.0], [2.0, 0.5, 2.3], [3.0, 0.9, 3.04]])
    m = Metrics(np.zeros((0, 2)), np.zeros((0, 2)), inside=None)
    m.observe_body(crowd, pelvis=pelvis, seated=np.array([False, False, True, False]))
    assert abs(m.root_sync_error - 0.04) < 1e-12
    m.observe_body(crowd, pelvis=pelvis, seated=None)  # nobody seated: row 2's 0.3 m counts
    assert abs(m.root_sync_error - 0.3) < 1e-12


def test_the_metric_kernels_match_their_numpy_definitions() -> None:
    """user_clearance and motion_extremes (pedvr.crowd.overlap) against the array expressions they
    replaced, on random crowds with turned ellipses and carried objects' footprints."""
    from pedvr.crowd.footprint import footprints
    from pedvr.crowd.overlap import motion_extremes, user_clearance
    from tests.crowd._helpers import pair_support

    rng = np.random.default_rng(7)
    for _ in range(20):
        n = int(rng.integers(2, 60))
        pos = rng.uniform(-4.0, 4.0, (n, 2))
        radius, turn, torso = rng.uniform(0.2, 0.4, n), rng.uniform(0.0, 1.0, n), rng.uniform(-3, 3, n)
        heading = rng.uniform(-3.0, 3.0, n)
        length = np.where(rng.random(n) < 0.2, rng.uniform(0.5, 0.8, n), 0.0)
        ahead = np.where(length > 0.0, 0.4, 0.0)
        u = int(rng.integers(0, n))
        others = np.delete(np.arange(n), u)
        fp = footprints(pos, radius, turn, torso, heading, ahead, length)
        rel = fp.centre[others] - pos[u]
        du = np.hypot(rel[:, 0], rel[:, 1])
        clear = du - pair_support(fp.radius, fp.depth, fp.facing, others, -rel / du[:, None]) - radius[u]
        k = int(np.argmin(clear))
        nearest, got_clear, got_d = user_clearance(pos, fp.centre, fp.radius, fp.depth, fp.facing, u, pos[u],
                                                   float(radius[u]))
        assert abs(nearest - np.hypot(*(pos[others] - pos[u]).T).min()) < 1e-12
        assert abs(got_clear - clear[k]) < 1e-9 and abs(got_d - du[k]) < 1e-9

        vel, prev = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
        h0, h1 = rng.uniform(-3.1, 3.1, n), rng.uniform(-3.1, 3.1, n)
        user = np.zeros(n, np.bool_)
        user[u] = True
        total, rows, acc, turn_rate = motion_extremes(vel, prev, h1, h0, user, 0.01)
        virt = ~user
        assert rows == n - 1 and abs(total - np.linalg.norm(vel[virt], axis=1).sum()) < 1e-9
        assert abs(acc - (np.linalg.norm(vel[virt] - prev[virt], axis=1) / 0.01).max()) < 1e-9
        dh = np.abs((h1[virt] - h0[virt] + np.pi) % (2 * np.pi) - np.pi) / 0.01
        assert abs(turn_rate - dh.max()) < 1e-9
