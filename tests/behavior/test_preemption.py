"""Scene triggers pre-empt lower-priority events (ADAPT §6.1.1 Event Priority; issue 24 item 9).

Two agents talk (a conversation started by the scene's ``near`` trigger); a third stands idle
far off. The user then walks up to the talkers and a second trigger (``enter``) starts a
greeting bound to the agent nearest the user. Declared at a higher priority than the
conversation, the greeting must take a talker (the conversation ends, interrupted); declared
lower, it must leave the conversation alone and take the idle agent.
"""

from __future__ import annotations

import pytest

from pedvr.behavior.state import FREE
from tests.behavior._scene import make_sim, row, step_until

A, B, C = 1, 2, 3

SCENE = """
[behavior.events.chat]
tree = "conversation"
priority = {chat}

[behavior.events.greet]
tree = "wave_at_user"
priority = {greet}

[[behavior.triggers]]
kind = "near"
who = ["agent", "agent"]
distance = 3.0
event = "chat"
bind = {{ a = "agent", b = "other", spot = "midpoint" }}
cooldown = 300.0

[[behavior.triggers]]
kind = "enter"
who = "user"
region = {{ disc = [-1.0, 2.2, 0.6] }}
event = "greet"
bind = {{ a = "agent", u = "user" }}
cooldown = 300.0
"""


def _run(chat: int, greet: int):  # type: ignore[no-untyped-def]
    sim = make_sim(agents=[(-1.0, 0.0, "stand"), (1.0, 0.0, "stand"), (7.0, -4.5, "stand")],
                   behavior=SCENE.format(chat=chat, greet=greet), user_start=(-8.0, 2.2),
                   user_route=[(-1.0, 2.2)], user_speed=1.3)
    sch = sim.scheduler
    # the conversation starts and the two talk (gestures playing) before the user arrives
    assert step_until(sim, lambda: bool((sim.body.state.g_kind[[row(sim, A), row(sim, B)]] > 0).any()),
                      seconds=5.0)
    chat_run = next(r for r in sch.live if r.event.name == "chat")
    assert chat_run.phase == "running" and sorted(chat_run.agents) == [A, B]
    assert all(sim.behavior.event_priority[row(sim, a)] == chat for a in (A, B))
    assert step_until(sim, lambda: sch.triggers.fired[1] == 1, seconds=8.0)
    # the greeting's agents: from its run, or from the log if it already ended (the idle agent is
    # too far from the user for wave_at_user's "near" check and fails at once)
    greet = [r.agents for r in sch.live if r.event.name == "greet"]
    greet += [e["agents"] for e in sch.log if e["event"] == "greet"]
    assert len(greet) == 1
    return sim, chat_run, greet[0]


def test_a_higher_priority_trigger_takes_an_agent_out_of_a_conversation() -> None:
    sim, chat_run, greet_agents = _run(chat=1, greet=3)
    sch = sim.scheduler
    # the talker nearest the user, not the idle agent far away
    assert greet_agents in ([A], [B]), greet_agents
    greet_run = next(r for r in sch.live if r.event.name == "greet")
    assert chat_run.phase == "ended" and chat_run.outcome == "interrupted by greet"
    assert sch.counts["events_interrupted"] == 1
    taken = greet_run.agents[0]
    other = B if taken == A else A
    assert sch.control[taken] is greet_run
    assert sim.behavior.event_priority[row(sim, taken)] == 3
    assert not sim.behavior.in_event[row(sim, other)]  # the other talker is back to autonomy
    assert sim.behavior.event_priority[row(sim, other)] == FREE
    assert step_until(sim, lambda: greet_run.phase == "ended", seconds=6.0)
    assert sch.log[-1]["event"] == "greet" and sch.log[-1]["outcome"] == "succeeded"
    assert sim.behavior.event_priority[row(sim, taken)] == FREE


@pytest.mark.parametrize("greet", [1, 2], ids=["equal", "lower"])
def test_a_trigger_of_equal_or_lower_priority_never_pre_empts(greet: int) -> None:
    chat = 1 if greet == 1 else 3
    sim, chat_run, greet_agents = _run(chat=chat, greet=greet)
    assert greet_agents == [C]  # the only eligible agent: the idle one
    assert chat_run.phase == "running"
    assert sim.scheduler.counts["events_interrupted"] == 0
    assert step_until(sim, lambda: chat_run.phase == "ended", seconds=40.0)
    assert chat_run.outcome == "success"
