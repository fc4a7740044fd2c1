"""The simulation step: the user is never steered, motion limits, conditions (the encounter
model toward the user is tested in tests/crowd/test_user_encounter.py)."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.crowd.orca import STATUS_FOR_USER
from pedvr.crowd.state import LIMIT_ACCEL, LIMIT_BACKWARD, LIMIT_DECEL, LIMIT_SIDEWAYS
from pedvr.errors import UsageError
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import PHASES, Simulation


def headon(rho: float, condition: str = "pedvr") -> dict[str, np.ndarray | float]:
    sim = Simulation(load_scene(resolve_scene("headon_corridor")), condition=condition,
                     responsibility=rho, record=True)
    sim.advance_to(10.0)
    arr = sim.recording.arrays()  # type: ignore[union-attr]
    user = int(np.flatnonzero(arr["is_user"])[0])
    agent = 1 - user
    pu, pa = arr["pos"][:, user], arr["pos"][:, agent]
    gap = np.linalg.norm(pa - pu, axis=1)
    ahead = pa[:, 0] > pu[:, 0] + 0.5  # before they meet
    return {"user_y": pu[:, 1], "agent_dev": np.abs(pa[:, 1] - 0.1), "gap": gap, "ahead": ahead,
            "min_gap": float(gap.min()), "user_x_end": float(pu[-1, 0])}


@pytest.fixture(scope="module")
def trials() -> dict[float, dict]:
    return {rho: headon(rho) for rho in (0.0, 0.25, 0.5, 1.0)}


def test_user_is_never_steered(trials: dict[float, dict]) -> None:
    for t in trials.values():
        assert np.abs(t["user_y"]).max() < 1e-9  # walks the corridor's centre line, whatever ρ
        assert t["user_x_end"] > 5.0  # and gets to the far end


@pytest.mark.parametrize("scene", ["shibuya_crossing", "bidirectional_flow"])
def test_motion_limits_hold_in_coupled_mode(scene: str) -> None:
    sim = Simulation(load_scene(resolve_scene(scene)), condition="pedvr")
    lim = sim.crowd.limits[~sim.crowd.is_user][0].copy()
    worst = {"accel": 0.0, "back": 0.0, "side": 0.0}
    keep = ~sim.crowd.is_user  # nobody leaves these scenes
    u = int(np.flatnonzero(sim.crowd.is_user)[0])
    for_user = 0
    for _ in range(round(20.0 / sim.dt)):
        before = sim.crowd.vel.copy()
        h = sim.crowd.heading[keep].copy()
        near_user = np.hypot(*(sim.crowd.pos - sim.crowd.pos[u]).T)[keep] < 1.0
        sim.step()
        # the steered (commanded) velocity against the body's actual one before the step; contact
        # pushes are not steps the body took (they move it, and its velocity, afterwards); nor
        # is the last resort of the user's safety (orca.STATUS_FOR_USER: the user walked into an
        # agent faster than its limits let it step away), which must be rare and by the user
        dodge = (sim.steering.last_status[keep] & STATUS_FOR_USER) != 0
        assert near_user[dodge].all()
        for_user += int(np.count_nonzero(dodge))
        v = sim._new_vel[keep][~dodge]
        h = h[~dodge]
        dv = np.linalg.norm(v - before[keep][~dodge], axis=1) / sim.dt
        worst["accel"] = max(worst["accel"], float(dv.max(initial=0)))
        fwd = np.stack([np.cos(h), np.sin(h)], 1)
        worst["back"] = max(worst["back"], float((-(v * fwd).sum(1)).max(initial=0)))
    assert for_user <= 20, for_user  # agent-steps of 20 s
    assert worst["accel"] <= max(lim[LIMIT_ACCEL], lim[LIMIT_DECEL]) * 1.05 + 1e-6, worst
    assert worst["back"] <= lim[LIMIT_BACKWARD] + 0.05, worst
    assert lim[LIMIT_SIDEWAYS] > 0


@pytest.mark.parametrize("condition", ["pedvr", "decoupled"])
def test_a_body_s_velocity_is_its_actual_motion(condition: str) -> None:
    """The velocity the next step starts from is how far the body moved (contact pushes
    included, at most its max speed), not the velocity it was told to walk (issue 26: a coupled
    agent held back at a corner went on walking into it)."""
    sim = Simulation(load_scene(resolve_scene("validation/uo_070")), condition=condition)
    sim.advance_to(8.0)  # the crowd presses at the entrance
    virt = ~sim.crowd.is_user
    differs = 0
    for _ in range(90):
        before = sim.crowd.pos.copy()
        sim.step()
        moved = (sim.crowd.pos - before) / sim.dt
        speed = np.linalg.norm(moved, axis=1)
        moved *= np.minimum(1.0, sim.crowd.max_speed / np.maximum(speed, 1e-12))[:, None]
        np.testing.assert_allclose(sim.crowd.vel[virt], moved[virt], atol=1e-9)
        differs += int(np.count_nonzero(np.linalg.norm(sim._new_vel[virt] - moved[virt], axis=1) > 1e-6))
    if condition == "pedvr":  # contacts did move bodies other than they were steered
        assert differs > 0
    # decoupled: ORCA's discs (nobody turns its shoulders there, issue 26) need no contact push
    # at this entrance, so the steered and the actual motion agree


def test_decoupled_mode_ignores_limits() -> None:
    """The baseline is plain ORCA: its accelerations exceed the body's limits."""
    scene = load_scene(resolve_scene("shibuya_crossing"))
    s = Simulation(scene, condition="decoupled")
    s.advance_to(20.0)
    c = Simulation(scene, condition="pedvr")
    c.advance_to(20.0)
    assert s.summary()["max_accel_mps2"] > c.summary()["max_accel_mps2"]  # type: ignore[operator]
    assert c.summary()["max_turn_rate_radps"] <= 3.0 + 1e-6  # turn_rate_standing


def test_phases_are_timed_and_named() -> None:
    sim = Simulation(load_scene(resolve_scene("antipodal_circle")))
    sim.step()
    assert tuple(sim.metrics.phase_ms) == PHASES


def test_agents_can_be_added_and_removed_between_steps() -> None:
    sim = Simulation(load_scene(resolve_scene("antipodal_circle")))
    sim.advance_to(1.0)
    ids = sim.crowd.ids.copy()
    sim.remove_agents([ids[3]])
    new = sim.add_agents("adult", np.array([[0.0, -8.0], [0.0, 8.0]]), state="cross")
    sim.advance_to(3.0)
    assert ids[3] not in sim.crowd.ids
    assert set(new) <= set(sim.crowd.ids) and len(set(new) | set(ids)) == len(ids) + 2
    assert len(sim.crowd) == len(ids) + 1
    rows = np.isin(sim.crowd.ids, new)
    assert (np.linalg.norm(sim.crowd.pos[rows] - [[0.0, -8.0], [0.0, 8.0]], axis=1) > 0.5).all()  # they walk
    with pytest.raises(UsageError, match="profile 'ghost': unknown; known: adult, slow"):
        sim.add_agents("ghost", np.zeros((1, 2)), state="cross")


def test_bad_options_are_clear() -> None:
    scene = load_scene(resolve_scene("antipodal_circle"))
    with pytest.raises(UsageError, match=r"condition 'fast': expected one of decoupled, pedvr, pedvr\+g"):
        Simulation(scene, condition="fast")
    with pytest.raises(UsageError, match=r"responsibility 2\.0: expected a number in \[0, 1\]"):
        Simulation(scene, responsibility=2.0)


def test_go_to_capability_walks_the_agent_there() -> None:
    """ADAPT's GoTo through the simulation's navigation: running, then success."""
    sim = Simulation(load_scene(resolve_scene("headon_corridor")))
    agent = int(sim.crowd.ids[~sim.crowd.is_user][0])
    # The scene's BFSM counts arrival at 0.4 m and then stands the agent still.
    handle = sim.body.go_to(agent, (3.0, -0.4), arrive_dist=0.5)
    assert handle.status.name == "RUNNING"
    sim.advance_to(4.0)
    row = sim.crowd.index_of(agent)
    assert np.linalg.norm(sim.crowd.pos[row] - (3.0, -0.4)) < 0.5
    assert handle.status.name == "SUCCESS"
    stop = sim.body.go_to(agent, None)
    assert stop.status.name == "SUCCESS" and np.isnan(sim.behavior.goal[row]).all()


def test_an_agent_pushed_out_of_sight_of_its_waypoint_replans() -> None:
    """An agent pushed back behind the corner it already turned (its waypoints all out of
    sight) replans from where it stands within LOST_CHECK_S (plus a step) and walks round
    again to its goal, instead of walking into the wall for ever."""
    from pedvr.scene.loader import parse_scene
    from pedvr.sim import LOST_CHECK_S

    scene = parse_scene({
        "scene": {"name": "lost_waypoint", "seed": 3, "duration": 40.0},
        "world": {"bounds": [[-10.0, -10.0], [10.0, 10.0]],
                  "obstacles": [{"box": [-0.25, -10.0, 0.25, 5.0], "height": 3.0}]},
        "agents": {"profiles": {"adult": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6}},
                   "spawns": [{"profile": "adult", "state": "go", "count": 1,
                               "region": {"box": [-5.1, -0.1, -4.9, 0.1]}}]},
        "behavior": {"states": {"go": {"goal": {"selector": "point", "at": [5.0, 0.0]}, "transitions": []}}},
        "user": {"start": [-9.0, 9.0], "heading_deg": 0.0},
    }, source="<lost waypoint>")
    sim = Simulation(scene, condition="decoupled")
    row = int(np.flatnonzero(~sim.crowd.is_user)[0])
    while not (sim.crowd.pos[row, 0] > 1.0 and sim.cursor[row] == len(sim.paths[row]) - 1):
        sim.step()  # round the wall's end, heading down to the goal
        assert sim.t < 20.0
    pushed = np.array([-3.0, 0.0])
    assert not sim.visibility.visible(pushed[None], np.array([[5.0, 0.0]]), np.array([0.0625]))[0]
    sim.crowd.pos[row] = pushed
    sim.advance_to(sim.t + LOST_CHECK_S + 2 * sim.dt)
    assert np.linalg.norm(sim.paths[row][0] - pushed) < 0.2  # replanned from where it was pushed to
    sim.advance_to(sim.t + 16.0)
    assert np.linalg.norm(sim.crowd.pos[row] - [5.0, 0.0]) < 0.5


def test_a_seated_body_keeps_its_footprint() -> None:
    """Seated (pinned) bodies do not move in the contact pass, so they must not change their
    footprint either: in shopping_mall two seated neighbours turned their shoulders as a walker
    squeezed past and, once a shorter obstacle horizon let walkers closer (issue 26, branch
    h-horizon), overlapped each other by 12.5 cm, which no contact could undo. (Before the fix a
    seated body here was turned past a walker's turn in 2022 of the seated steps over 90 s.)"""
    sim = Simulation(load_scene(resolve_scene("shopping_mall")), condition="pedvr")
    seated_steps = 0
    while sim.t < 60.0:
        before = dict(zip(sim.crowd.ids.tolist(), sim.crowd.turn.tolist(), strict=True))
        was = set(sim.crowd.ids[sim._pinned].tolist()) if len(sim._pinned) == len(sim.crowd) else set()
        sim.step()
        for k in np.flatnonzero(sim._pinned):
            i = int(sim.crowd.ids[k])
            if i in was:
                seated_steps += 1
                assert sim.crowd.turn[k] == before[i], (sim.t, i)
    assert seated_steps > 1000  # people sat there most of the minute
