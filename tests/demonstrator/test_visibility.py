"""A demonstration never claims success where the observer cannot see (issue 24 item 8).

The reported case, reproduced: a demonstrator explains a painting in a gallery bay; the user
walks while it talks, and stops behind a 3 m pillar. For that spot no placement near d_pref
is valid (every one is hidden), so the re-plan must widen the search (farther out, hidden
candidates perturbed too) and move the demonstrator to where the user can see it, rather
than keep the hidden placement and log ``success``. And when nothing anywhere lets the
observer see the demonstrator, the log and the metrics say so.
"""

from __future__ import annotations

import math

import numpy as np

from pedvr.body import skeleton as sk
from pedvr.demonstrator.demonstration import Exhibit
from pedvr.demonstrator.placement import VIS_DISCARD
from pedvr.sim import Simulation
from tests.demonstrator._demo import PAINTING, PILLAR, MovingUser, RouteUser, demo_sim

STOP = (0.0, 0.8)  # where the user stops: behind the pillar, seen from the painting
SETTLE = 9.0  # s after the user stops: a re-plan (three ticks, after the 2 s dwell) and a short walk


def _watch(sim: Simulation, *, seconds: float) -> tuple[dict, np.ndarray, np.ndarray]:
    """Run the demonstration of the painting by agent 1 to the user; per step: time, and whether
    obstacles hide the user's head from the demonstrator's eyes (as the planner measures it)."""
    run = sim.scheduler.start_event("show", {"guide": 1, "observer": 0, "exhibit": "vase"})
    ex = sim.scheduler.objects["vase"]
    assert isinstance(ex, Exhibit)
    ctx = sim.scheduler.ctx
    stage = ex.stage(ctx)
    assert stage is not None
    ts, hidden = [], []
    end = sim.t + seconds
    while sim.t < end and run.phase != "ended":
        sim.step()
        d = sim.crowd.index_of(1)
        eye = float(sim.body.state.world_pos[d, sk.L_EYE, 1])
        user = sim.crowd.index_of(0)
        head = sim.body.user_head(sim.crowd)
        e = stage.occluded(sim.crowd.pos[d][None], eye, sim.crowd.pos[user][None], float(head[1]))[0]
        ts.append(sim.t)
        hidden.append(e > VIS_DISCARD)
    assert run.phase == "ended"
    return ex.log[0], np.asarray(ts), np.asarray(hidden)


def test_the_observer_behind_a_pillar_is_shown_to_from_where_it_can_see() -> None:
    # The user watches from the bay's left, then walks at 1.2 m/s while the demonstrator talks,
    # and stops behind the pillar (3.4 s later) for the rest of the talk.
    walk_at = 12.0
    user = MovingUser((-4.0, 1.5), STOP, at=walk_at, heading=math.pi / 2)
    sim = demo_sim(observer=(-4.0, 1.5), start=(-6.0, -3.0), user=user, talk=16.0, world=PILLAR,
                   exhibit=PAINTING)
    e, t, hidden = _watch(sim, seconds=60.0)
    stopped = walk_at + math.dist((-4.0, 1.5), STOP) / 1.2
    assert e["t_stroke"][0] < walk_at < e["t_end"] - SETTLE - 3.0, e  # it talked while the user walked
    # seen for the rest of the talk once it could re-plan and step over
    late = t >= stopped + SETTLE
    assert late.sum() > 90 and not hidden[late].any(), (e, t[late][hidden[late]][:5])
    assert e["outcome"] == "success" and e["seen"] is True, e
    # the search at the user's final spot found nothing near d_pref and widened; whether that ends
    # in a new placement ("wide") depends on where the demonstrator stood by then (with issue 26's
    # crowd model its second placement, made while the user walked, was already one the widened
    # search keeps): what matters is that it widened and was seen, asserted above and below
    assert e["widened"] >= 1 and e["placement_origins"][-1] in ("wide", "model"), e
    assert e["hidden_s"] < SETTLE + 1.0
    s = sim.summary()
    assert s["demonstrations_unseen"] == 0 and s["demonstrations_widened"] == 1
    assert s["demonstration_hidden_s"] == e["hidden_s"]


# An alcove open to the south: its walls hide whoever stands in it from everywhere more than
# 6.4 m from the painting, so from every place within 5 m of it (the farthest the planner looks,
# placement.FALLBACK_FAR); the user in it is 5.65 m from the painting and never farther than
# demonstration.LEAVE_DIST for long on the way: it has not left.
ALCOVE = PILLAR + "".join(f"""
[[world.obstacles]]
kind = "wall"
box = {b}
height = 2.5
""" for b in ([-1.1, 0.7, 1.1, 0.8], [-1.1, -0.8, -1.0, 0.7], [1.0, -0.8, 1.1, 0.7]))


def test_a_demonstration_the_observer_cannot_see_is_not_logged_a_success() -> None:
    # The user walks from the bay round into the alcove while the demonstrator talks, and stays.
    user = RouteUser([(-4.0, 1.5), (-1.6, -1.2), (0.0, -1.2), (0.0, 0.0)], at=12.0, heading=math.pi / 2)
    sim = demo_sim(observer=(-4.0, 1.5), start=(-6.0, -3.0), user=user, talk=14.0, world=ALCOVE,
                   exhibit=PAINTING)
    e, t, hidden = _watch(sim, seconds=60.0)
    assert hidden[-30:].all()  # the end of the talk: the observer cannot see the demonstrator
    assert e["outcome"] == "failure" and e["why"] == "observer hidden", e
    assert e["seen"] is False and e["hidden_s"] > 3.0, e
    ex = sim.scheduler.objects["vase"]
    assert ex.failures == {"observer hidden": 1} and ex.uses == {}
    s = sim.summary()
    assert s["demonstrations_unseen"] == 1
    assert s["affordance_failures"] == {"exhibit.observer hidden": 1}
    assert sim.scheduler.log[-1]["outcome"] == "failed"
