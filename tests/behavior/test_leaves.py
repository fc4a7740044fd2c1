"""Leaves on a running simulation: each action drives the body, and ends what it started when stopped."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body.model import GAZE_NONE, GAZE_USER
from tests.behavior._scene import make_sim, row, tree

A = 1  # the first agent's id (the user is 0)


def speed(sim, agent: int) -> float:  # type: ignore[no-untyped-def]
    return float(np.hypot(*sim.crowd.vel[row(sim, agent)]))


def test_go_to_arrives_then_stops_walking() -> None:
    sim = make_sim(agents=[(-5.0, 0.0, "stand")])
    d = tree(sim, {"go_to": "a", "to": [3.0, 1.0]}, {"a": "agent"}, {"a": A})
    assert d.drive(15.0).value == "success"
    p = sim.crowd.pos[row(sim, A)]
    assert math.dist(p, (3.0, 1.0)) <= 0.3
    assert np.isnan(sim.behavior.goal[row(sim, A)]).all()  # the leaf ended: walking stopped
    d.drive(1.5, until_done=False)
    assert speed(sim, A) < 0.05


def test_go_to_stopped_midway_stops_the_agent() -> None:
    sim = make_sim(agents=[(-5.0, 0.0, "stand")])
    d = tree(sim, {"go_to": "a", "to": [6.0, 0.0]}, {"a": "agent"}, {"a": A})
    d.drive(2.0)
    assert d.status.value == "running" and speed(sim, A) > 0.8
    d.halt()
    x = float(sim.crowd.pos[row(sim, A)][0])
    for _ in range(180):
        sim.step()
    assert speed(sim, A) < 0.05
    assert float(sim.crowd.pos[row(sim, A)][0]) < x + 1.5  # it braked where it was, far from the goal


def test_go_to_an_unreachable_point_fails() -> None:
    world = '[[world.obstacles]]\nkind = "box"\nbox = [2.0, -2.0, 6.0, 2.0]\n'
    sim = make_sim(agents=[(-5.0, 0.0, "stand")], world=world)
    # inside the box: snapped to its edge by the navigation mesh, never reached within arrive
    d = tree(sim, {"go_to": "a", "to": [4.0, 0.0], "max_time": 8.0}, {"a": "agent"}, {"a": A})
    assert d.drive(12.0).value == "failure"


def test_face_turns_on_the_spot_and_releases_the_facing() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")])
    d = tree(sim, {"face": "a", "heading_deg": 120.0}, {"a": "agent"}, {"a": A})
    assert d.drive(4.0).value == "success"
    h = float(sim.crowd.heading[row(sim, A)])
    assert abs(math.remainder(h - math.radians(120.0), 2 * math.pi)) < math.radians(10.0)
    assert np.isnan(sim.behavior.face[row(sim, A)])
    assert math.dist(sim.crowd.pos[row(sim, A)], (0.0, 0.0)) < 0.05  # on the spot


def test_face_hold_tracks_a_moving_user_until_stopped() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")], user_start=(-4.0, 3.0), user_route=[(4.0, 3.0)])
    d = tree(sim, {"face": "a", "toward": "user", "hold": True}, {"a": "agent"}, {"a": A})
    assert d.drive(5.0).value == "running"
    u = sim.crowd.pos[0] - sim.crowd.pos[row(sim, A)]
    want = math.atan2(u[1], u[0])
    assert abs(math.remainder(float(sim.crowd.heading[row(sim, A)]) - want, 2 * math.pi)) < math.radians(15)
    d.halt()
    assert np.isnan(sim.behavior.face[row(sim, A)])


def test_gesture_plays_for_its_duration_and_is_cut_when_stopped() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")])
    d = tree(sim, {"gesture": "a", "clip": "wave", "seconds": 1.0}, {"a": "agent"}, {"a": A})
    t0 = sim.t
    assert d.drive(3.0).value == "success"
    assert 1.0 <= sim.t - t0 <= 1.2
    d2 = tree(sim, {"gesture": "a", "clip": "shrug", "seconds": 5.0}, {"a": "agent"}, {"a": A})
    d2.drive(0.5)
    b = sim.body.state
    r = row(sim, A)
    assert b.g_kind[r] > 0 and sim.t < b.g_start[r] + b.g_dur[r]
    d2.halt()
    assert sim.t >= b.g_start[r] + b.g_dur[r] - 0.02  # the clip ends now, not in 4.5 s


def test_gaze_at_lingers_until_the_tree_ends_or_stops_after_its_seconds() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")], user_start=(3.0, 0.0))
    d = tree(sim, {"gaze_at": "a", "at": "user"}, {"a": "agent"}, {"a": A})
    assert d.drive(2.0).value == "success"
    r = row(sim, A)
    assert sim.body.state.gaze_kind[r] == GAZE_USER  # kept after the leaf succeeded
    d.halt()
    assert sim.body.state.gaze_kind[r] == GAZE_NONE  # the tree's end undid it
    d = tree(sim, {"gaze_at": "a", "at": "user", "seconds": 1.0}, {"a": "agent"}, {"a": A})
    d.drive(0.5)
    assert sim.body.state.gaze_kind[r] == GAZE_USER
    assert d.drive(2.0).value == "success"
    assert sim.body.state.gaze_kind[r] == GAZE_NONE


def test_reach_for_puts_the_hand_there_and_releases_it_at_the_end() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")])
    d = tree(sim, {"reach_for": "a", "at": [0.35, 0.15], "height": 1.0}, {"a": "agent"}, {"a": A})
    assert d.drive(3.0).value == "success"
    r = row(sim, A)
    assert sim.body.state.reach_on[r, 1]
    d.halt()
    assert not sim.body.state.reach_on[r].any()


def test_sit_down_stays_seated_until_the_tree_ends() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")])
    d = tree(sim, {"sit_down": "a"}, {"a": "agent"}, {"a": A})
    assert d.drive(4.0).value == "success"
    r = row(sim, A)
    co = sim.body.coordinator
    assert sim.body.state.sitting[r] and co.weights[r, co.index["sitting"]] == 1.0
    d.halt()
    assert not sim.body.state.sitting[r]
    d2 = tree(sim, {"sequence": [{"sit_down": "a"}, {"stand_up": "a"}]}, {"a": "agent"}, {"a": A})
    assert d2.drive(8.0).value == "success"
    assert not sim.body.state.sitting[r] and co.weights[r, co.index["sitting"]] == 0.0


def test_sit_down_fails_while_walking() -> None:
    sim = make_sim(agents=[(-6.0, 0.0, "walk")])
    for _ in range(120):
        sim.step()
    d = tree(sim, {"sit_down": "a"}, {"a": "agent"}, {"a": A})
    assert d.drive(1.0).value == "failure"


def test_set_speed_is_restored_when_the_tree_ends() -> None:
    sim = make_sim(agents=[(0.0, 0.0, "stand")])
    r = row(sim, A)
    d = tree(sim, {"sequence": [{"set_speed": "a", "scale": 0.5}, {"wait": 1.0}]}, {"a": "agent"}, {"a": A})
    d.drive(0.1)
    assert sim.behavior.speed_scale[r] == 0.5
    assert d.drive(2.0).value == "success"
    assert sim.behavior.speed_scale[r] == 0.5  # the tree has not ended yet: its driver ends it
    d.halt()
    assert sim.behavior.speed_scale[r] == 1.0


def test_follow_keeps_behind_a_walker_until_stopped() -> None:
    sim = make_sim(agents=[(-8.0, 0.0, "walk"), (-9.0, -1.0, "stand")])
    B = 2
    d = tree(sim, {"follow": "b", "leader": "a", "distance": 1.5}, {"a": "agent", "b": "agent"}, {"a": A, "b": B})
    gaps = []
    for _ in range(8):
        d.drive(1.0, until_done=False)
        gaps.append(math.dist(sim.crowd.pos[row(sim, A)], sim.crowd.pos[row(sim, B)]))
    assert d.status.value == "running"
    assert float(sim.crowd.pos[row(sim, B)][0]) > -2.0  # it came along
    assert max(gaps[3:]) < 3.5
    d.halt()
    for _ in range(180):
        sim.step()
    assert speed(sim, B) < 0.05


def test_conditions_read_the_world() -> None:
    world = '[[world.obstacles]]\nkind = "box"\nbox = [1.0, 1.0, 2.0, 5.0]\n'
    sim = make_sim(agents=[(0.0, 0.0, "stand"), (3.0, 3.0, "stand")], world=world, user_start=(2.0, 0.0))
    B = 2
    p = {"a": "agent", "b": "agent"}
    v = {"a": A, "b": B}

    def check(node: dict[str, object]) -> str:
        return tree(sim, node, p, v).drive(0.05, until_done=False).value

    assert check({"near": "a", "of": "user", "within": 2.5}) == "success"
    assert check({"near": "a", "of": "user", "within": 1.5}) == "failure"
    assert check({"sees": "a", "at": "user"}) == "success"  # facing +x, the user is ahead
    assert check({"sees": "a", "at": "b"}) == "failure"  # behind the box
    assert check({"facing": "a", "toward": "user", "within_deg": 10}) == "success"
    assert check({"facing": "user", "toward": "a", "within_deg": 30}) == "failure"  # the user faces +x
    assert check({"moving": "user", "above": 0.1}) == "failure"
    assert check({"idle": "a"}) == "success"
    assert check({"after": 0.0}) == "success"
    assert check({"before": 0.0}) == "failure"


@pytest.mark.parametrize("node,err", [
    ({"go_to": "user", "to": [0, 0]}, "never driven"),
    ({"gesture": "u", "clip": "wave"}, "observed, never driven"),
])
def test_actions_never_drive_the_user(node: dict[str, object], err: str) -> None:
    from pedvr.behavior.nodes import define_tree

    with pytest.raises(ValueError, match=err):
        define_tree("t", {"u": "user"}, node)
