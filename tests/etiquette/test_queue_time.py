"""A pedestrian's time in a door's queue (``queued``) counts from the first time it stood waiting
there and goes on while the queue moves up, and orders its side's queue (``interaction._update_waiting``,
``ordering.place``; issue 26, README change 23). The time stood (``waited``) still ranks the two
sides against each other.

Before, a side's queue was ordered by the time stood, so whoever moved up lost its place to whoever
stood. Traced in door_rush seed 9: two people 5-8 m out overtook each other every few ticks and
crept from 7.7 to 6.6 m between 25 and 63 s; the last of the 40 passed at 84.4 s."""

from __future__ import annotations

import pytest

from pedvr.etiquette.core import Walker
from pedvr.etiquette.interaction import TICK, _update_waiting
from pedvr.etiquette.ordering import QUEUE_HOLD, Candidate, initial_leader, place
from pedvr.etiquette.vocab import APPROACH, FOLLOWER, PASSING
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

LAST_BY = 76.0  # s: door_rush seed 9's last passage; 84.4 s when only standing counted


def _walkers(speeds: dict[str, float]) -> tuple[Simulation, dict[str, Walker]]:
    sim = Simulation(load_scene(resolve_scene("door_rush")), seed=1)
    et, crowd = sim.etiquette, sim.crowd
    assert et is not None
    ids = [int(a) for a in crowd.ids[~crowd.is_user][: len(speeds)]]
    out = {}
    for (name, v), a in zip(speeds.items(), ids, strict=True):
        crowd.vel[et._row[a]] = (v, 0.0)
        out[name] = Walker(id=a, door=0, side=1, role=APPROACH)
    return sim, out


def _tick(sim: Simulation, walkers: dict[str, Walker], n: int = 30) -> None:
    for _ in range(n):
        assert sim.etiquette is not None
        _update_waiting(sim.etiquette, list(walkers.values()), sim.crowd)


def test_the_time_in_the_queue_goes_on_while_it_moves_up() -> None:
    sim, w = _walkers({"stood": 0.0, "walking": 1.3, "following": 0.0, "passing": 0.0})
    w["stood"].waiting = True
    w["walking"].waiting = False  # walking up to the door, has not stood yet
    w["following"].waiting = True
    w["following"].role = FOLLOWER
    w["passing"].waiting = True
    w["passing"].role = PASSING
    w["passing"].waited = w["passing"].queued = 4.0
    _tick(sim, w)
    for name in ("stood", "following"):
        assert w[name].waited == pytest.approx(30 * TICK) and w[name].queued == pytest.approx(30 * TICK)
    assert w["walking"].waited == 0.0 and w["walking"].queued == 0.0  # not in the queue yet
    assert w["passing"].waited == 4.0 and w["passing"].queued == 4.0  # on its way through
    # the queue moves up: the one who stood walks on at 0.6 m/s; its time stood stops, its time in
    # the queue goes on
    sim.crowd.vel[sim.etiquette._row[w["stood"].id]] = (0.6, 0.0)  # type: ignore[union-attr]
    w["stood"].waiting = False
    _tick(sim, w)
    assert w["stood"].waited == pytest.approx(30 * TICK)
    assert w["stood"].queued == pytest.approx(60 * TICK)
    assert w["walking"].queued == 0.0


def test_who_moved_up_keeps_its_place_before_a_later_one_who_stood() -> None:
    """Two of one side: ``a`` joined first and has just moved up, ``b`` joined later and stood
    since; ``b`` is a little nearer the door. By the time stood ``b`` would be in front."""
    a = Candidate(id=1, pos=(-3.0, 0.0), side=1, d_door=3.0, waited=6.0, queued=12.0)
    b = Candidate(id=2, pos=(-2.8, 0.3), side=1, d_door=2.84, waited=9.0, queued=9.0)
    credit = 0.5
    assert place(a, credit) < place(b, credit)
    assert initial_leader(b, [a, b], wait_credit=credit) is a
    assert initial_leader(a, [a, b], wait_credit=credit) is None
    # the time stood alone would have put b in front
    a_stood = Candidate(id=1, pos=a.pos, side=1, d_door=3.0, waited=6.0)
    assert place(b, credit) < place(a_stood, credit)
    assert QUEUE_HOLD < 6.0


def test_the_user_has_no_queue_time() -> None:
    sim, w = _walkers({"user": 0.0})
    w["user"].is_user = True
    w["user"].waiting = True
    _tick(sim, w)
    assert w["user"].waited == 0.0


def test_door_rush_seed_9_has_no_far_out_crawl() -> None:
    """The traced seed: all 40 through, the last by :data:`LAST_BY`, nobody overlapping."""
    sim = Simulation(load_scene(resolve_scene("door_rush")), seed=9)
    while sim.t < 90.0 - 1e-9:
        sim.step()
    s = sim.summary()
    first: dict[int, float] = {}
    for e in s["door_events"]:  # type: ignore[union-attr]
        if e["event"] == "pass" and not e["user"]:
            first.setdefault(int(e["agent"]), float(e["t"]))
    assert len(first) == 40
    assert max(first.values()) <= LAST_BY, sorted(first.values())[-5:]
    assert s["overlaps_over_1cm"] == 0
