"""The scheduler (ADAPT §6.1.1): suspension, priorities, readiness, resumption, personal trees."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body.model import GAZE_NONE
from pedvr.errors import UsageError
from tests.behavior._scene import make_sim, row, step_until

EVENTS = """
[behavior.trees.alarm]
params = { a = "agent" }
root = { sequence = [ { face = "a", heading_deg = 90 }, { wait = 3.0 } ] }

[behavior.trees.look_at_user]
params = { a = "agent", u = "user" }
root = { gaze_at = "a", at = "u", seconds = 2.0 }

[behavior.events.chat]
tree = "conversation"
priority = 1
patience = {patience}

[behavior.events.alarm]
tree = "alarm"
priority = 3

[behavior.events.look]
tree = "look_at_user"
priority = 1
"""

A, B, C = 1, 2, 3


def sim_with(patience: float = 10.0, agents: list[tuple[float, float, str]] | None = None):  # type: ignore[no-untyped-def]
    return make_sim(agents=agents or [(-6.0, -1.0, "walk"), (6.0, 1.0, "walk"), (0.0, -4.0, "stand")],
                    behavior=EVENTS.replace("{patience}", str(patience)))


def test_an_event_suspends_its_agents_and_gives_them_back_their_bfsm() -> None:
    sim = sim_with()
    for _ in range(30):
        sim.step()
    goals = {a: tuple(sim.behavior.goal[row(sim, a)]) for a in (A, B)}
    run = sim.scheduler.start_event("chat", {"a": A, "b": B, "spot": (0.0, 0.0)})
    for _ in range(3):
        sim.step()
    assert run.phase == "running"
    assert all(sim.behavior.in_event[row(sim, a)] for a in (A, B))
    assert sim.scheduler.frozen()[[row(sim, A), row(sim, B)]].all()
    assert step_until(sim, lambda: run.phase == "ended", seconds=40.0)
    assert sim.scheduler.log[-1]["outcome"] == "succeeded"
    for a in (A, B):
        r = row(sim, a)
        assert not sim.behavior.in_event[r]
        assert tuple(sim.behavior.goal[r]) == goals[a]  # the BFSM goal it had
        assert sim.body.state.gaze_kind[r] == GAZE_NONE  # the conversation's gazes were undone
    arrivals = sim.metrics.arrivals
    sim.advance_to(sim.t + 15.0)
    assert sim.metrics.arrivals > arrivals  # walking its BFSM again


def test_a_higher_priority_event_interrupts_a_conversation_cleanly() -> None:
    sim = sim_with()
    b_goal = tuple(sim.behavior.goal[row(sim, B)])
    chat = sim.scheduler.start_event("chat", {"a": A, "b": B, "spot": (0.0, 0.0)})
    # wait until they talk (gestures are playing)
    assert step_until(sim, lambda: bool((sim.body.state.g_kind[[row(sim, A), row(sim, B)]] > 0).any()),
                      seconds=20.0)
    alarm = sim.scheduler.start_event("alarm", {"a": A})
    assert chat.phase == "ended" and chat.outcome == "interrupted by alarm"
    assert sim.scheduler.counts["events_interrupted"] == 1
    rb = row(sim, B)
    assert not sim.behavior.in_event[rb]  # B went back to autonomy at once
    assert tuple(sim.behavior.goal[rb]) == b_goal
    assert sim.body.state.gaze_kind[rb] == GAZE_NONE
    assert sim.t >= sim.body.state.g_start[rb] + sim.body.state.g_dur[rb] - 0.02  # its gesture was cut
    for _ in range(3):
        sim.step()
    assert alarm.phase == "running"
    assert sim.scheduler.control[A] is alarm
    sim.advance_to(sim.t + 2.0)
    assert float(np.hypot(*sim.crowd.vel[rb])) > 0.5  # B walks its BFSM route
    ra = row(sim, A)
    h = float(sim.crowd.heading[ra])
    assert abs(math.remainder(h - math.pi / 2, 2 * math.pi)) < math.radians(12)  # A obeys the alarm
    assert step_until(sim, lambda: alarm.phase == "ended", seconds=6.0)
    assert not sim.behavior.in_event[row(sim, A)]
    sim.advance_to(sim.t + 2.0)
    assert float(np.hypot(*sim.crowd.vel[row(sim, A)])) > 0.5  # A resumed its BFSM too


def test_an_event_waits_until_all_its_agents_are_ready() -> None:
    sim = sim_with()
    alarm = sim.scheduler.start_event("alarm", {"a": B})
    chat = sim.scheduler.start_event("chat", {"a": A, "b": B, "spot": (0.0, 0.0)})
    for _ in range(6):
        sim.step()
    assert chat.phase == "pending" and alarm.phase == "running"
    assert sim.scheduler.control[A] is chat  # A is claimed and waits, standing
    assert sim.behavior.in_event[row(sim, A)]
    assert step_until(sim, lambda: chat.phase == "running", seconds=6.0)
    assert alarm.phase == "ended" and alarm.outcome == "success"
    assert chat.started >= alarm.requested + 3.0


def test_a_pending_event_is_dropped_after_its_patience() -> None:
    sim = sim_with(patience=1.0)
    sim.scheduler.start_event("alarm", {"a": B})
    chat = sim.scheduler.start_event("chat", {"a": A, "b": B, "spot": (0.0, 0.0)})
    assert step_until(sim, lambda: chat.phase == "ended", seconds=2.0)
    assert chat.outcome == "dropped: actors not ready"
    assert sim.scheduler.counts["events_dropped"] == 1
    assert not sim.behavior.in_event[row(sim, A)]


def test_bfsm_timers_pause_while_suspended() -> None:
    behavior = EVENTS.replace("{patience}", "10") + """
[behavior.states.browse]
goal = { selector = "stay" }

[[behavior.states.browse.transitions]]
on = "timer"
after = 4.0
to = "walk"
"""
    sim = make_sim(agents=[(0.0, 0.0, "browse")], behavior=behavior)
    walk = sim.bfsm.ids["walk"]
    sim.advance_to(1.0)
    alarm = sim.scheduler.start_event("alarm", {"a": A})
    assert step_until(sim, lambda: alarm.phase == "ended", seconds=6.0)
    away = sim.t - 1.0
    assert away > 3.0
    assert step_until(sim, lambda: sim.behavior.state[row(sim, A)] == walk, seconds=10.0)
    assert sim.t == pytest.approx(4.0 + away, abs=0.1)  # 1 s before, 3 s after the event


def test_the_user_fills_observed_roles_of_several_events_at_once() -> None:
    sim = sim_with(agents=[(1.0, 0.0, "stand"), (-1.0, 0.0, "stand")])
    r1 = sim.scheduler.start_event("look", {"a": A, "u": 0})
    r2 = sim.scheduler.start_event("look", {"a": B, "u": 0})
    for _ in range(3):
        sim.step()
    assert r1.phase == r2.phase == "running"
    assert 0 not in sim.scheduler.control
    assert step_until(sim, lambda: r1.phase == r2.phase == "ended", seconds=3.0)
    assert [e["outcome"] for e in sim.scheduler.log] == ["succeeded", "succeeded"]


def test_start_event_rejects_values_that_do_not_fit() -> None:
    sim = sim_with()
    s = sim.scheduler
    with pytest.raises(UsageError, match="event 'nope': unknown; known: alarm, chat, look"):
        s.start_event("nope", {})
    with pytest.raises(UsageError, match="a is an agent role; the user is never driven"):
        s.start_event("alarm", {"a": 0})
    with pytest.raises(UsageError, match="u is the user's role; 1 is not the user"):
        s.start_event("look", {"a": A, "u": A})
    with pytest.raises(UsageError, match="agent 1 fills two roles"):
        s.start_event("chat", {"a": A, "b": A, "spot": (0.0, 0.0)})
    with pytest.raises(UsageError, match=r"missing \['spot'\]"):
        s.start_event("chat", {"a": A, "b": B})
    with pytest.raises(UsageError, match="a = 99: expected the id of an agent in the scene"):
        s.start_event("alarm", {"a": 99})


def test_an_event_fails_when_one_of_its_agents_leaves() -> None:
    sim = sim_with()
    run = sim.scheduler.start_event("chat", {"a": A, "b": B, "spot": (0.0, 0.0)})
    sim.advance_to(1.0)
    sim.remove_agents([B])
    assert step_until(sim, lambda: run.phase == "ended", seconds=0.2)
    assert sim.scheduler.log[-1]["outcome"] == "failed"
    assert not sim.behavior.in_event[row(sim, A)]


PERSONAL = """
[behavior.trees.pace]
params = { me = "agent" }
root = { sequence = [ { go_to = "me", to = { region = [2.0, 2.0, 4.0, 4.0] } }, { wait = 0.5 } ] }

[behavior.states.pacing]
goal = { selector = "stay" }
tree = "pace"

[behavior.states.once]
goal = { selector = "stay" }
tree = "pace"

[[behavior.states.once.transitions]]
on = "success"
to = "stand"
"""


def test_a_bfsm_state_runs_its_personal_tree_and_takes_its_outcome() -> None:
    sim = make_sim(agents=[(-3.0, 0.0, "once"), (-3.0, -2.0, "pacing")], behavior=PERSONAL)
    stand = sim.bfsm.ids["stand"]
    assert step_until(sim, lambda: sim.behavior.state[row(sim, A)] == stand, seconds=10.0)
    p = sim.crowd.pos[row(sim, A)]
    assert 1.7 <= p[0] <= 4.3 and 1.7 <= p[1] <= 4.3  # it walked to the region, then its state moved on
    assert A not in sim.scheduler.personal
    # without a success/failure transition the tree starts again: B keeps pacing inside the region
    assert B in sim.scheduler.personal
    starts = sim.scheduler._seq
    sim.advance_to(sim.t + 6.0)
    assert sim.scheduler._seq > starts
    assert sim.behavior.state[row(sim, B)] == sim.bfsm.ids["pacing"]


def test_same_seed_same_interactions() -> None:
    behavior = EVENTS.replace("{patience}", "10") + """
[[behavior.triggers]]
kind = "time"
at = 0.5
every = [1.0, 3.0]
event = "chat"
bind = { a = "agent", b = "other", spot = "midpoint" }
chance = 0.7
max_running = 2
"""
    agents = [(-6.0, -1.0, "walk"), (6.0, 1.0, "walk"), (0.0, -4.0, "walk"), (3.0, 3.0, "walk")]

    def run(seed: int) -> tuple[bytes, list[object]]:
        import tomllib

        from pedvr.scene.loader import parse_scene
        from pedvr.sim import Simulation
        from tests.behavior._scene import scene_text

        sim = Simulation(parse_scene(tomllib.loads(scene_text(agents=agents, behavior=behavior)), source="t"),
                         seed=seed, record=True)
        sim.advance_to(12.0)
        assert sim.recording is not None
        events = [*sim.scheduler.log, *((r.event.name, r.agents, r.requested, r.phase) for r in sim.scheduler.live)]
        return sim.recording.arrays()["pos"].tobytes(), events

    a, b, c = run(3), run(3), run(4)
    assert a[0] == b[0] and a[1] == b[1]
    assert len(a[1]) >= 2
    assert a[0] != c[0] and a[1] != c[1]


def test_agents_removed_mid_tree_leave_nothing_behind() -> None:
    sim = make_sim(agents=[(-3.0, 0.0, "pacing"), (3.0, 0.0, "stand")],
                   behavior=PERSONAL + '[behavior.trees.talk]\nparams = { a = "agent" }\n'
                   'root = { gesture = "a", clip = "talk", seconds = 5.0 }\n'
                   '[behavior.events.talk]\ntree = "talk"\n')
    run = sim.scheduler.start_event("talk", {"a": B})
    sim.advance_to(1.0)
    assert A in sim.scheduler.personal and run.phase == "running"
    sim.remove_agents([A, B])
    sim.advance_to(1.2)
    assert not sim.scheduler.personal and run.phase == "ended"
    assert not sim.scheduler.ctx.owners and not sim.scheduler.control


def test_a_personal_tree_keeps_its_cooldown_across_runs() -> None:
    behavior = """
[behavior.trees.fidget]
params = { me = "agent" }
root = { selector = [ { cooldown = { gesture = "me", clip = "shrug", seconds = 0.5 }, seconds = 4.0 },
                      { wait = 0.5 } ] }
[behavior.states.fidgeting]
goal = { selector = "stay" }
tree = "fidget"
"""
    sim = make_sim(agents=[(0.0, 0.0, "fidgeting")], behavior=behavior)
    starts = []
    last = -1.0
    while sim.t < 9.2:  # shrugs at 0, 4.5 and 9 s: a 0.5 s clip, then the 4 s cooldown
        sim.step()
        g = float(sim.body.state.g_start[row(sim, A)])
        if sim.body.state.g_kind[row(sim, A)] == 3 and g != last:  # a new shrug
            starts.append(g)
            last = g
    # the tree ran again every 0.5-1 s, but shrugs came only once per 4 s cooldown
    assert len(starts) == 3, starts
    assert all(b - a >= 4.0 for a, b in zip(starts, starts[1:], strict=False))
