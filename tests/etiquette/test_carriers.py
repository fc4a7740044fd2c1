"""No carrier left behind (issue 24 item 4, issue 26): a perambulator pusher waiting at a double door gets
through. Before the fix, holders in turn held the door for it and gave up, and in seed 5 of this set-up it
was still on its side after 90 s."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

START = (-5.0, -1.0)  # on the double door's pull side (the door spans x = 0, y in [-1, 1])


def _door_double_with_pram() -> object:
    """door_double with three walkers a side and a pram pusher from the pull side (as
    ``bench/door_observations.py --only pram`` sets it up)."""
    s = load_any(resolve_scene("door_double"), seed=None)
    s = dataclasses.replace(s, spawns=tuple(dataclasses.replace(sp, count=3) for sp in s.spawns))
    walker = s.profiles["walker"]
    prof = dataclasses.replace(walker, name="pram", radius=0.4, pref_speed=1.0, max_speed=1.4,
                               carrying="perambulator", sex="female")
    pram = dataclasses.replace(s.spawns[0], profile="pram", state="east", positions=(START,), count=0,
                               region=None)
    return dataclasses.replace(s, profiles={**s.profiles, "pram": prof}, spawns=(pram, *s.spawns))


def _pram_run(seed: int) -> tuple[float | None, int, list[str]]:
    """When the pram's pusher got past the door line (None: not in 90 s), the run's overlaps, and
    the pusher's etiquette events."""
    sim = Simulation(_door_double_with_pram(), seed=seed)  # type: ignore[arg-type]
    row = int(np.argmin(np.hypot(*(sim.crowd.pos - np.asarray(START)).T)))
    pram = int(sim.crowd.ids[row])
    assert float(sim.crowd.length[row]) > 0.0  # the pram's footprint: this is the pusher
    through_at = None
    while sim.t < 90.0 and through_at is None:
        sim.step()
        r = np.nonzero(sim.crowd.ids == pram)[0]
        if len(r) and sim.crowd.pos[r[0], 0] > 0.5:  # past the door line, clear of the leaves
            through_at = sim.t
    events = [e["event"] for e in sim.etiquette.events if e.get("agent") == pram]
    return through_at, int(sim.summary()["overlaps_over_1cm"]), events


def _through_at(seed: int) -> tuple[float | None, int]:
    """When the pram's pusher got past the door line (None: not in 90 s), and the run's overlaps."""
    through_at, overlaps, _ = _pram_run(seed)
    return through_at, overlaps


def test_a_pram_at_a_double_door_gets_through() -> None:
    """Seeds 0-9: every pram through in 90 s, none overlapping anyone. Issue 26's crowd model
    passed 7 before a pusher steered past keys beside it and kept its course against a shove
    (``Simulation._pram_keeps_its_course``); main before that model passed 8 (not the same 8).
    Over seeds 0-19: 19 of 20 on stop 37's code (seed 9: a pusher alone at the pull side frees a
    hand and opens a leaf itself, and its pram stands in the leaf's swing), 19 of 20 after issue
    26's change 15 (seed 9 through; seed 17 left), 20 of 20 since a holder holds on for a carrier
    until it is through (change 17; the last through at 66.6 s, seed 11); 18 of 20 on stop 50's
    code (seeds 16 and 18 left), 20 of 20 after change 24, the last through at 49.4 s (seed 6)
    (bench/door_observations.py ``--only pram`` measures it)."""
    results = {seed: _through_at(seed) for seed in range(10)}
    stuck = [s for s, (t, _) in results.items() if t is None]
    assert not stuck, f"prams still on their side after 90 s in seeds {stuck}"
    assert all(o == 0 for _, o in results.values()), results


def test_a_holder_holds_on_until_a_carrier_is_through() -> None:
    """A follower passing first frees its holder for the next follower at once (pipelined), but a
    carrier does not: it cannot catch the door (§4.6), so the holder holds on until the carrier is
    through (``interaction._pass_first``). Freed, the holder of seed 17 below went through itself
    0.6 s later, and the leaf swung shut on the pram."""
    from pedvr.etiquette.core import Walker
    from pedvr.etiquette.interaction import _pass_first
    from pedvr.etiquette.vocab import FOLLOWER, HOLD_DOOR, HOLDER, NONE, PASSING

    sim = Simulation(_door_double_with_pram(), seed=17)  # type: ignore[arg-type]
    et, crowd = sim.etiquette, sim.crowd
    rows = np.argsort(np.hypot(*(crowd.pos - np.asarray(START)).T))
    pram_row = int(rows[0])
    assert bool(et.carrying[pram_row]) and float(crowd.length[pram_row]) > 0.0
    walker_row, holder_row = [int(r) for r in rows[1:] if not et.carrying[r] and not crowd.is_user[r]][:2]
    leaf = et.dstate[0].leaves[0]
    fr = et.frame(leaf, 1)  # side 1: the pull side, x < 0
    crowd.pos[holder_row] = fr.hold_beyond_tip(math.radians(90.0), float(crowd.radius[holder_row]))[0]
    kept = {}
    for row in (pram_row, walker_row):
        crowd.pos[row] = fr.lane(2.0)
        f_id, h_id = int(crowd.ids[row]), int(crowd.ids[holder_row])
        f = Walker(id=f_id, door=0, side=1, leaf=leaf, role=FOLLOWER, holder=h_id, leader=h_id)
        h = Walker(id=h_id, door=0, side=1, leaf=leaf, role=HOLDER, state=HOLD_DOOR, action="HOF",
                   follower=f_id, frame=fr)
        et.walkers.clear()
        et.walkers.update({f_id: f, h_id: h})
        _pass_first(et, f, h, crowd, fr, 1)
        assert f.role == PASSING
        kept[row] = h.follower
    assert kept[pram_row] == int(crowd.ids[pram_row])  # held for until it is through
    assert kept[walker_row] == NONE  # free for the next


def test_the_pram_of_seed_17_gets_through() -> None:
    """The run the rule above was made for: before it, the pram was still on its side at 90 s."""
    through_at, overlaps = _through_at(17)
    assert through_at is not None and through_at < 60.0
    assert overlaps == 0


@pytest.mark.parametrize("seed", [16, 18])
def test_a_pram_waits_for_the_holder_to_clear_its_lane(seed: int) -> None:
    """HOF at a double door: the holder steps round from the handle to its place beyond the leaf's
    edge, across the lane its follower passes along. A pram's pusher that set off at once met the
    holder with the pram's front; steering took it round the holder on the hinge side into the
    pocket behind the held leaf, where it stood until its passing state gave up (seed 18, 23-35 s;
    seeds 16 and 18 never through in 90 s). It now waits, at most ``HOF_LANE_WAIT``, until the
    holder is clear of its lane (``interaction._hof_lane_clear``): measured through at 27.9 and
    29.1 s."""
    through_at, overlaps = _through_at(seed)
    assert through_at is not None and through_at < 45.0, through_at
    assert overlaps == 0


@pytest.mark.parametrize("seed", [2, 11])
def test_a_pram_among_others_turns_round_and_backs_through(seed: int) -> None:
    """Others about, nobody leading the pram or holding its leaf: its pusher frees a hand, turns
    round and backs through as a pusher alone does (``interaction._doorway_behavior``, issue 26).
    Before, it went to open the door as a walker does, from a place on the far side of its own
    pram, and gave up every 10 s ("could not reach the door"): twice in each of these seeds, through
    at 49.9 and 52.9 s only when someone else held the leaf. Measured now: 29.3 and 30.0 s."""
    through_at, overlaps, events = _pram_run(seed)
    assert "pram_turns_round" in events and "give_up" not in events, events
    assert through_at is not None and through_at < 40.0, through_at
    assert overlaps == 0


def test_the_lane_is_clear_once_the_holder_stands_beyond_the_leafs_edge() -> None:
    """``_hof_lane_clear`` on door_double's pull side: a holder standing on the lane, or beside it
    closer than its radius plus the pram's half-width, is in the way; one at HOF's place beyond the
    held leaf's edge (``LeafFrame.hold_beyond_tip``) is not."""
    from pedvr.etiquette.core import Walker
    from pedvr.etiquette.interaction import HOLD_ANGLE, _hof_lane_clear
    from pedvr.etiquette.vocab import HOLD_DOOR, HOLDER

    sim = Simulation(_door_double_with_pram(), seed=1)  # type: ignore[arg-type]
    et, crowd = sim.etiquette, sim.crowd
    row = int(np.nonzero(~crowd.is_user & ~et.carrying.astype(bool))[0][0])
    leaf = et.dstate[0].leaves[0]
    fr = et.frame(leaf, 1)
    h = Walker(id=int(crowd.ids[row]), door=0, side=1, leaf=leaf, role=HOLDER, state=HOLD_DOOR, action="HOF",
               frame=fr)
    radius = float(crowd.radius[row])
    pram_half = 0.4
    place = fr.hold_beyond_tip(HOLD_ANGLE, radius)[0]
    lane_x = fr.local(fr.lane(0.0))[0]
    for where, clear in [(fr.lane(1.0), False), (fr.world(lane_x - (radius + pram_half) + 0.05, 1.0), False),
                         (fr.world(lane_x - (radius + pram_half) - 0.05, 1.0), True), (place, True)]:
        crowd.pos[row] = where
        assert _hof_lane_clear(et, h, crowd, pram_half) is clear, (where, clear)


def _lone_pram(scene: str, start: tuple[float, float]) -> object:
    """``scene`` with nobody but a pram pusher, from ``start`` on the door's pull side (x < 0)."""
    s = load_any(resolve_scene(scene), seed=None)
    prof = dataclasses.replace(s.profiles["walker"], name="pram", radius=0.4, pref_speed=1.0, max_speed=1.4,
                               carrying="perambulator", sex="female")
    pram = dataclasses.replace(s.spawns[0], profile="pram", state="east", positions=(start,), count=0,
                               region=None)
    return dataclasses.replace(s, profiles={**s.profiles, "pram": prof}, spawns=(pram,))


@pytest.mark.parametrize(("scene", "start", "seed"), [("door_double", START, 1), ("door_double", (-5.0, 0.6), 2),
                                                      ("door_same_side", START, 1), ("door_same_side", (-5.0, 0.3), 3)])
def test_a_lone_pram_at_a_pull_door_backs_through(scene: str, start: tuple[float, float], seed: int) -> None:
    """Nobody else about (issue 26): the pusher frees a hand after CARRIER_PATIENCE (§4.6), turns
    round so that its pram trails, backs up to the handle, pulls the leaf open and backs through
    pulling its pram (``interaction._backing_through``). Before, its opener's place beside the
    handle put its pram in the leaf's swing, and it gave up (``could not reach the door``) every
    10 s for 90 s. Measured: through 22.4-23.0 s in, in seeds 0-3 of both doors; asserted: within
    30 s, at the first try, touching nobody and no leaf, its whole pram through, and facing its way
    again once it is clear of the door."""
    sim = Simulation(_lone_pram(scene, start), seed=seed)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    pid = int(sim.crowd.ids[row])
    assert float(sim.crowd.length[row]) > 0.0
    backed = False
    while sim.t < 30.0 and (pid in sim.etiquette.walkers or sim.crowd.pos[row, 0] <= 0.5):
        sim.step()
        backed |= math.cos(float(sim.crowd.heading[row])) < -0.7 and float(sim.crowd.vel[row, 0]) > 0.3
    events = [e["event"] for e in sim.etiquette.events]
    assert pid not in sim.etiquette.walkers and sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    assert backed  # it walked east (through the door) facing west: backwards, its pram trailing
    assert "pram_turns_round" in events and "give_up" not in events, events
    # done with the door: its whole footprint (pram ahead of it again) on the far side, facing east
    heading = float(sim.crowd.heading[row])
    tail = float(sim.crowd.pos[row, 0] + (sim.crowd.ahead[row] - sim.crowd.length[row]) * math.cos(heading))
    assert math.cos(heading) > 0.9 and tail > 0.3, (heading, tail)
    summary = sim.summary()
    assert summary["overlaps_over_1cm"] == 0 and summary["door_leaf_overlap_max_m"] < 0.01
    assert summary["wall_overlap_max_m"] < 0.01


def test_a_pram_the_user_let_go_of_the_door_on_gets_through() -> None:
    """The participant comes through from the push side, holds the door (HOL) for a lone pram and
    lets go as the pram reaches the leaf (door_same_side, seed 1): the leaf swings onto the pram's
    front in the pocket behind it. Before issue 26's change 18 the pram stood there to the end of
    the run (the way round the leaf's edge drove it back into the leaf); now it backs out of the
    swing, frees a hand and backs through (``interaction._pram_backs_out_of_swing``): measured
    through at 44.8 s, and at 27.5 s since its front in the pocket ends its passing at once
    (issue 26, change 19). Nothing ever overlaps the user."""
    s = _lone_pram("door_same_side", START)
    s = dataclasses.replace(s, user=dataclasses.replace(s.user, start=(4.0, 0.0), route=((-4.0, 0.0),)))  # type: ignore[attr-defined]
    sim = Simulation(s, seed=1)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    while sim.t < 60.0 and sim.crowd.pos[row, 0] <= 0.5:
        sim.step()
    events = [e["event"] for e in sim.etiquette.events]
    assert "user_holds" in events and "release" in events  # the set-up: the user held it, then let go
    assert sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    summary = sim.summary()
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0


@pytest.mark.parametrize(("scene", "stand", "seed"), [("door_same_side", (-3.0, 0.8), 1),
                                                      ("door_double", (-2.5, -2.5), 2)])
def test_a_lone_pram_backs_through_past_a_participant_standing_by(scene: str, stand: tuple[float, float],
                                                                  seed: int) -> None:
    """The participant walks toward the door and stops a few metres short of it, on the pram's side,
    out of its way, and stands there looking about. Walking toward the door made them take part in
    its etiquette, so the pram was not alone: it waited for them to open the door and gave up
    every 10 s for as long as they stood (issue 26). A participant standing still, no hand on a
    leaf, is no longer counted (``interaction._alone``): measured through at 22.4 and 22.7 s, as
    with nobody about."""
    s = _lone_pram(scene, START)
    s = dataclasses.replace(s, user=dataclasses.replace(s.user, start=(-8.0, stand[1]), route=(stand,)))  # type: ignore[attr-defined]
    sim = Simulation(s, seed=seed)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    user = int(sim.crowd.ids[sim.crowd.is_user][0])
    took_part = False
    while sim.t < 30.0 and sim.crowd.pos[row, 0] <= 0.5:
        sim.step()
        took_part |= user in sim.etiquette.walkers
    events = [e["event"] for e in sim.etiquette.events]
    assert took_part  # the set-up: the user came toward the door and stood as one taking part
    assert sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    assert "pram_turns_round" in events and "give_up" not in events, events
    assert float(np.hypot(*(sim.crowd.pos[sim.crowd.is_user][0] - stand))) < 0.05  # they stood there
    summary = sim.summary()
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0
    assert summary["door_leaf_overlap_max_m"] < 0.01 and summary["wall_overlap_max_m"] < 0.01


@pytest.mark.parametrize(("scene", "seed", "start"), [("door_same_side", 1, (4.0, 0.0)), ("door_same_side", 1, (8.0, 0.0)),
                                                      ("door_double", 1, (8.0, 0.0)), ("door_double", 2, (22.0, 0.0))])
def test_a_lone_pram_gets_through_soon_after_the_participant_came_the_other_way(
        scene: str, seed: int, start: tuple[float, float]) -> None:
    """The participant comes through the door from the push side, toward a lone pram on the pull
    side, and walks on (issue 26, the participant taking part). Traced on the code before: in the
    first set-up the user held the door, let go once through, and the pram, passing first, was
    in the pocket behind the leaf: it pressed on the leaf's back until the passing state's 20 s
    ran out, then, its pusher outside the pocket, 9 s more, before backing out (through at 45.5 s;
    now it backs out at once, ``interaction._pram_front_behind``); in the second and third the
    door shut in front of the pram while it was passing first, and it waited out the same 20 s
    (46.2 s, and not through in 60 s; now it is no longer passing once the door is shut); in the
    fourth, the user pushed through as the pram came to open the door, which left it facing the
    closed door too near to turn round, and it stood trying to (not through in 60 s; now it backs
    off first, ``BACK_TURN_ROOM``). Measured now: 27.5, 22.7, 22.7 and 35.1 s. Nothing overlaps
    the user, anyone, a leaf or a wall."""
    s = _lone_pram(scene, START)
    s = dataclasses.replace(s, user=dataclasses.replace(s.user, start=start, route=((-8.0, start[1]),)))  # type: ignore[attr-defined]
    sim = Simulation(s, seed=seed)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    while sim.t < 40.0 and sim.crowd.pos[row, 0] <= 0.5:
        sim.step()
    events = [e["event"] for e in sim.etiquette.events]
    assert sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    summary = sim.summary()
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0
    assert summary["door_leaf_overlap_max_m"] < 0.01 and summary["wall_overlap_max_m"] < 0.01


def test_the_participant_opens_the_double_door_leaf_they_walk_through() -> None:
    """The scripted participant (``DoorUser``, what headless runs of door scenes use) walks along a
    double door's middle from its pull side, a pram beside it. Its press took the handle nearest a
    reach straight ahead: the other leaf's, so it opened one leaf and walked into the other, still
    closed, 25 cm deep, and the pram was not through in 60 s. Its hand now goes to the handle of
    the leaf it walks through, as a controller does: it holds that leaf for the pram (measured:
    the pram through at 11.3 s) and nothing cuts into anyone."""
    s = _lone_pram("door_double", START)
    s = dataclasses.replace(s, user=dataclasses.replace(s.user, start=(-8.0, 0.0), route=((4.0, 0.0),)))  # type: ignore[attr-defined]
    sim = Simulation(s, seed=1)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    while sim.t < 20.0:
        sim.step()
    events = [e["event"] for e in sim.etiquette.events]
    assert "user_holds" in events and sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    assert float(sim.crowd.pos[sim.crowd.is_user][0][0]) > 1.0  # the user is through too
    summary = sim.summary()
    assert summary["door_leaf_overlap_max_m"] < 0.01, summary["door_leaf_overlap_max_m"]
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0


@pytest.mark.parametrize("start", [(26.0, 0.0), (30.0, 0.0)])
def test_the_participant_steps_aside_for_a_pram_backing_through(start: tuple[float, float]) -> None:
    """The participant walks toward the door from the push side while a lone pram backs through it
    toward them (door_same_side, seed 1). The scripted participant (``DoorUser``) walked into the
    doorway and stood there, 0.45 m from the pusher, and the pusher, giving way, backed off into
    the doorway again: both stood until the backing state ran out 14 s later, and the pram was
    through at 59.2 and 55.8 s. Like a person, the participant now steps aside, off the passing
    lane beside the doorway, while someone is coming through, and goes on once the doorway is
    clear (``DoorUser._step_aside``): measured through at 22.2 and 22.9 s. Asserted: the pram through
    in 30 s, the participant through too, beside the lane while the pram came through, and
    nothing cutting into anyone (a first version walked from beside the doorway straight to it and
    the hinge's end of the open leaf cut 21 cm into the participant)."""
    from pedvr.etiquette.user import GIVE_WAY

    s = _lone_pram("door_same_side", START)
    s = dataclasses.replace(s, user=dataclasses.replace(s.user, start=start, route=((-8.0, 0.0),)))  # type: ignore[attr-defined]
    sim = Simulation(s, seed=1)  # type: ignore[arg-type]
    row = int(np.nonzero(~sim.crowd.is_user)[0][0])
    aside: list[float] = []  # how far off the lane (the line y = 0.05 through the doorway) the user stood
    while sim.t < 30.0 and sim.crowd.pos[row, 0] <= 0.5:
        sim.step()
        if sim.user.source.mode == GIVE_WAY:  # type: ignore[attr-defined]
            aside.append(abs(float(sim.crowd.pos[sim.crowd.is_user][0][1]) - 0.05))
    events = [e["event"] for e in sim.etiquette.events]
    assert sim.crowd.pos[row, 0] > 0.5, (sim.t, events)
    assert "pram_turns_round" in events and aside and max(aside) > 0.9, (events, aside[-1:])
    while sim.t < 45.0:
        sim.step()
    assert float(sim.crowd.pos[sim.crowd.is_user][0][0]) < -1.0  # the participant went on through
    summary = sim.summary()
    assert summary["user_overlap_max_m"] == 0.0 and summary["overlaps_over_1cm"] == 0
    assert summary["door_leaf_overlap_max_m"] < 0.01 and summary["wall_overlap_max_m"] < 0.01
