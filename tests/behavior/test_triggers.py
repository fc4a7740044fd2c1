"""Triggers: spatial (near, enter), temporal, and the user's actions start events."""

from __future__ import annotations

import math

from tests.behavior._scene import make_sim, row, step_until

GREET = """
[behavior.events.greet]
tree = "wave_at_user"
priority = 2

[[behavior.triggers]]
kind = "near"
who = ["user", "agent"]
distance = 3.0
idle = true
event = "greet"
bind = { a = "agent", u = "user" }
cooldown = 60.0
"""


def test_an_idle_agent_waves_at_the_user_who_comes_near() -> None:
    # The user walks past a standing agent (A) and a walking one (B).
    sim = make_sim(agents=[(2.0, 1.5, "stand"), (-8.0, -1.5, "walk")], behavior=GREET,
                   user_start=(-8.0, 0.0), user_route=[(8.0, 0.0)])
    A, B = 1, 2
    assert step_until(sim, lambda: len(sim.scheduler.log) >= 1, seconds=12.0)
    ev = sim.scheduler.log[0]
    assert ev["event"] == "greet" and ev["agents"] == [A] and ev["outcome"] == "succeeded"
    assert 2.0 <= ev["t_ended"] - ev["t_started"] <= 3.1  # 0.3 s, then a 2 s wave
    assert ev["t_started"] == sim.scheduler.log[0]["t_requested"]
    sim.advance_to(16.0)
    assert [e["agents"] for e in sim.scheduler.log] == [[A]]  # cooldown: once; B walked, never idle
    assert sim.scheduler.triggers.fired == [1]
    _ = B


def test_the_waver_turned_toward_the_user() -> None:
    sim = make_sim(agents=[(2.0, 2.0, "stand")], behavior=GREET, user_start=(-6.0, 0.0), user_route=[(8.0, 0.0)])
    A = 1
    assert step_until(sim, lambda: bool(sim.scheduler.live), seconds=10.0)
    run = sim.scheduler.live[0]
    sim.advance_to(sim.t + 1.2)
    r = row(sim, A)
    assert sim.body.state.g_kind[r] == 1  # "wave"
    u = sim.crowd.pos[0] - sim.crowd.pos[r]
    want = math.atan2(u[1], u[0])
    assert abs(math.remainder(float(sim.crowd.heading[r]) - want, 2 * math.pi)) < math.radians(25)
    assert step_until(sim, lambda: run.phase == "ended", seconds=3.0)


FRIENDS = """
[behavior.states.stroll]
goal = { selector = "point", at = [8.0, 0.0] }

[behavior.events.chat]
tree = "conversation"

[[behavior.triggers]]
kind = "near"
who = ["agent", "agent"]
distance = 4.0
states = ["stroll"]
event = "chat"
bind = { a = "agent", b = "other", spot = "midpoint" }
cooldown = 60.0
"""


def test_two_strollers_who_meet_talk_at_their_midpoint() -> None:
    # A and B stroll; C walks in state "walk" (not a friend) right past them.
    sim = make_sim(agents=[(-7.0, 1.0, "stroll"), (-4.0, -1.0, "stroll"), (-7.0, -4.0, "walk")],
                   behavior=FRIENDS)
    for _ in range(3):
        sim.step()
    assert len(sim.scheduler.live) == 1
    run = sim.scheduler.live[0]
    assert run.agents == [1, 2]
    assert run.values["spot"] == (-5.5, 0.0)
    assert step_until(sim, lambda: run.phase == "ended", seconds=30.0)
    assert sim.scheduler.log[-1]["outcome"] == "succeeded"
    assert sim.scheduler.triggers.fired == [1]


def test_enter_time_and_user_action_triggers() -> None:
    behavior = """
[behavior.trees.nod]
params = { a = "agent" }
root = { gesture = "a", clip = "shrug", seconds = 0.5 }
[behavior.trees.wave_back]
params = { a = "agent", u = "user" }
root = { gesture = "a", clip = "wave", seconds = 0.5 }
[behavior.events.nod]
tree = "nod"
[behavior.events.wave_back]
tree = "wave_back"

[[behavior.triggers]]
kind = "enter"
who = "user"
region = { box = [-1.0, -1.0, 1.0, 1.0] }
event = "nod"
bind = { a = "agent" }

[[behavior.triggers]]
kind = "time"
at = 1.0
every = 2.0
event = "nod"
bind = { a = "agent" }

[[behavior.triggers]]
kind = "user_action"
action = "wave"
distance = 4.0
event = "wave_back"
bind = { a = "agent", u = "user" }
"""
    sim = make_sim(agents=[(3.0, 0.0, "stand")], behavior=behavior, user_start=(-4.0, 0.0),
                   user_route=[(4.0, 0.0)])
    sim.advance_to(4.0)
    fired = sim.scheduler.triggers.fired
    assert fired[1] == 2  # at 1 s and 3 s
    assert fired[0] == 1  # the user walked into the box once (about 2.3 s)
    assert fired[2] == 0
    sim.scheduler.user_action("wave")
    sim.advance_to(4.2)
    assert fired[2] == 1
    assert sim.scheduler.log[-1]["event"] == "wave_back" or any(r.event.name == "wave_back"
                                                                for r in sim.scheduler.live)
    sim.scheduler.user_action("jump")  # an action no trigger listens for
    sim.advance_to(4.4)
    assert fired[2] == 1
