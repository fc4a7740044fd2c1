"""Smart objects (ADAPT §6.2, Fig. 8): the chair's sit/stand, its failures, and fallbacks."""

from __future__ import annotations

import math

import numpy as np

from tests.behavior._scene import make_sim, row, step_until, tree

A, B = 1, 2
CHAIRS = """
[[behavior.objects]]
name = "seat"
kind = "chair"
at = [2.0, -4.0]
facing_deg = 90

[[behavior.objects]]
name = "walled"
kind = "chair"
at = [-6.0, 3.5]
facing_deg = 0
"""
# "walled" stands in a pocket closed on every side: its approach point is off the walkable area.
POCKET = """
[[world.obstacles]]
kind = "wall"
wall = [[-7.0, 2.5], [-5.0, 2.5]]
[[world.obstacles]]
kind = "wall"
wall = [[-7.0, 4.5], [-5.0, 4.5]]
[[world.obstacles]]
kind = "wall"
wall = [[-7.0, 2.4], [-7.0, 4.6]]
[[world.obstacles]]
kind = "wall"
wall = [[-5.0, 2.4], [-5.0, 4.6]]
[[world.obstacles]]
kind = "box"
box = [1.6, -5.1, 2.4, -4.6]
height = 0.45
"""


def rest(chair: str) -> dict[str, object]:
    return {"selector": [{"use": "a", "object": chair, "affordance": "sit"},
                         {"gesture": "a", "clip": "check_phone", "seconds": 1.0}], "memory": True}


def sitting_weight(sim, agent: int) -> float:  # type: ignore[no-untyped-def]
    co = sim.body.coordinator
    return float(co.weights[row(sim, agent), co.index["sitting"]])


def test_sit_walks_up_turns_and_sits_on_the_seat_then_stands_when_the_tree_ends() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand")], behavior=CHAIRS, world=POCKET)
    chair = sim.scheduler.objects["seat"]
    d = tree(sim, {"use": "a", "object": "seat", "affordance": "sit"}, {"a": "agent"}, {"a": A})
    assert d.drive(20.0).value == "success"
    r = row(sim, A)
    assert math.dist(sim.crowd.pos[r], chair.at) <= 0.15
    assert abs(math.remainder(float(sim.crowd.heading[r]) - math.pi / 2, 2 * math.pi)) < math.radians(10)
    assert sim.body.state.sitting[r] and sitting_weight(sim, A) == 1.0
    assert chair.occupant == A and chair.uses == {"sit": 1}
    d.drive(3.0, until_done=False)
    assert math.dist(sim.crowd.pos[r], chair.at) <= 0.15  # seated bodies stay put
    d.halt()  # the tree ends: the sitter stands up and the seat is free
    assert chair.occupant is None and not sim.body.state.sitting[r]
    sim.advance_to(sim.t + 2.0)
    assert sitting_weight(sim, A) == 0.0


def test_stand_affordance_frees_the_seat() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand")], behavior=CHAIRS, world=POCKET)
    chair = sim.scheduler.objects["seat"]
    d = tree(sim, {"sequence": [{"use": "a", "object": "seat", "affordance": "sit"}, {"wait": 1.0},
                                {"use": "a", "object": "seat", "affordance": "stand"}]},
             {"a": "agent"}, {"a": A})
    assert d.drive(25.0).value == "success"
    assert chair.occupant is None and sitting_weight(sim, A) == 0.0


def test_an_occupied_chair_fails_and_the_fallback_runs() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand"), (5.0, 1.0, "stand")], behavior=CHAIRS, world=POCKET)
    chair = sim.scheduler.objects["seat"]
    first = tree(sim, {"use": "a", "object": "seat", "affordance": "sit"}, {"a": "agent"}, {"a": A})
    assert first.drive(20.0).value == "success"
    second = tree(sim, rest("seat"), {"a": "agent"}, {"a": B})
    second.tick()
    assert chair.failures == {"occupied": 1}
    rb = row(sim, B)
    assert sim.body.state.g_kind[rb] == 4  # check_phone: the selector's fallback
    assert second.drive(3.0).value == "success"


def test_a_blocked_chair_reports_failure_and_the_fallback_runs() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand")], behavior=CHAIRS, world=POCKET)
    d = tree(sim, rest("walled"), {"a": "agent"}, {"a": A})
    d.tick()
    assert sim.scheduler.objects["walled"].failures == {"blocked": 1}
    assert sim.body.state.g_kind[row(sim, A)] == 4
    assert d.drive(3.0).value == "success"
    assert math.dist(sim.crowd.pos[row(sim, A)], (-3.0, 1.0)) < 0.1  # it never walked off


def test_someone_standing_on_the_seat_blocks_it() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand"), (2.0, -3.95, "stand")], behavior=CHAIRS, world=POCKET)
    d = tree(sim, rest("seat"), {"a": "agent"}, {"a": A})
    assert d.drive(20.0).value == "success"
    assert sim.scheduler.objects["seat"].failures == {"blocked": 1}
    assert not sim.body.state.sitting[row(sim, A)]


def test_nearest_free_chair_is_chosen_and_a_taken_one_is_skipped() -> None:
    chairs = """
[[behavior.objects]]
name = "near"
kind = "chair"
at = [0.0, 2.0]
[[behavior.objects]]
name = "far"
kind = "chair"
at = [6.0, 2.0]
"""
    sim = make_sim(agents=[(0.5, 0.0, "stand"), (1.0, -2.0, "stand")], behavior=chairs)
    objs = sim.scheduler.objects
    p = {"a": "agent"}
    node = {"use": "a", "object": {"nearest": "chair"}, "affordance": "sit"}
    da = tree(sim, node, p, {"a": A})
    db = tree(sim, node, p, {"a": B})
    da.tick()
    db.tick()  # "near" is reserved by A now: B takes "far"
    for _ in range(25 * 30):
        if da.status.value != "running" and db.status.value != "running":
            break
        sim.step()
        if sim.step_index % sim.scene.decision_every == 0:
            for d in (da, db):
                if d.status.value == "running":
                    d.tick()
    assert da.status.value == db.status.value == "success"
    assert objs["near"].occupant == A and objs["far"].occupant == B


def test_a_seated_agent_is_not_pushed_by_walkers_but_yields_to_the_user() -> None:
    sim = make_sim(agents=[(-3.0, 1.0, "stand"), (2.0, 2.0, "stand")], behavior=CHAIRS, world=POCKET,
                   user_start=(8.0, -4.0))
    d = tree(sim, {"use": "a", "object": "seat", "affordance": "sit"}, {"a": "agent"}, {"a": A})
    assert d.drive(20.0).value == "success"
    seat = sim.crowd.pos[row(sim, A)].copy()
    walker = tree(sim, {"go_to": "b", "to": [2.0, -4.6]}, {"b": "agent"}, {"b": B})  # straight at the sitter
    walker.drive(6.0)
    assert np.linalg.norm(sim.crowd.pos[row(sim, A)] - seat) < 1e-3
    s = sim.summary()
    assert s["overlaps_over_1cm"] == 0
    assert sim.scheduler.pinned()[row(sim, A)]


def test_a_sitting_agent_claimed_by_an_event_stands_up_first() -> None:
    behavior = CHAIRS + """
[behavior.trees.rest]
params = { me = "agent" }
root = { sequence = [ { use = "me", object = "seat", affordance = "sit" }, { wait = 30.0 } ] }
[behavior.states.resting]
goal = { selector = "stay" }
tree = "rest"
[behavior.trees.hop]
params = { a = "agent" }
root = { go_to = "a", to = [0.0, 0.0] }
[behavior.events.hop]
tree = "hop"
priority = 2
"""
    sim = make_sim(agents=[(-3.0, 1.0, "resting")], behavior=behavior, world=POCKET)
    chair = sim.scheduler.objects["seat"]
    assert step_until(sim, lambda: chair.occupant == A and sitting_weight(sim, A) == 1.0, seconds=20.0)
    run = sim.scheduler.start_event("hop", {"a": A})
    for _ in range(6):
        sim.step()
    assert run.phase == "pending"  # claimed, getting up
    assert chair.occupant is None and not sim.body.state.sitting[row(sim, A)]
    assert step_until(sim, lambda: run.phase == "running", seconds=3.0)
    assert sitting_weight(sim, A) == 0.0
    assert step_until(sim, lambda: run.phase == "ended", seconds=10.0)
    assert sim.scheduler.log[-1]["outcome"] == "succeeded"
    # back to its state: its tree starts again and it sits down once more
    assert step_until(sim, lambda: chair.occupant == A, seconds=15.0)


def test_a_sit_stopped_on_the_way_stops_walking_and_frees_the_reservation() -> None:
    sim = make_sim(agents=[(-6.0, 1.0, "stand")], behavior=CHAIRS, world=POCKET)
    chair = sim.scheduler.objects["seat"]
    d = tree(sim, {"use": "a", "object": "seat", "affordance": "sit"}, {"a": "agent"}, {"a": A})
    d.drive(1.5)
    assert d.status.value == "running" and chair.reserved == A
    d.halt()
    assert chair.reserved is None and chair.occupant is None
    assert np.isnan(sim.behavior.goal[row(sim, A)]).all()
    sim.advance_to(sim.t + 2.0)
    assert float(np.hypot(*sim.crowd.vel[row(sim, A)])) < 0.05
