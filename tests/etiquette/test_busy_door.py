"""Issue 26, item 3: three rules of a busy single door (:mod:`pedvr.etiquette.interaction`).

* :func:`~pedvr.etiquette.interaction._batch_side` counts a holder still on its own side in the
  current run of passages: it goes through next, and the next it holds for is chosen before it
  does. Counted from passages alone, a chain of hand-overs alternated one by one.
* a door is busy (passes in batches) from when :data:`~pedvr.etiquette.interaction.BATCH_LOAD`
  wait on each side until fewer than :data:`~pedvr.etiquette.interaction.BATCH_KEEP` wait on the
  side whose turn it is not, or nobody on the side whose turn it is;
* :func:`~pedvr.etiquette.interaction._in_the_way`: the one who commits as a holder's follower is
  not someone standing behind people of its own side; the one in its way nearest the door goes;
* :func:`~pedvr.etiquette.interaction._hand_on`: a follower blocked on its way to take the door
  over from a holder of its own side hands it on to the one in its way.

The whole-scene effect is guarded by ``test_door_flow.py`` and ``test_door_rush.py``; here each
rule is checked on its own, on a small stand-in for the etiquette's state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
import pytest

from pedvr.etiquette import interaction as it
from pedvr.etiquette.core import Walker
from pedvr.etiquette.vocab import APPROACH, FOLLOWER, HOLDER


@dataclass
class _Door:
    """The parts of the etiquette's state the three rules read: a single door in the plane x = 0, its
    +1 side toward +x, and every body's position and radius."""

    pos: dict[int, tuple[float, float]]
    run_side: int = 0
    run_len: int = 0
    radius: float = 0.25
    kind: str = "single"
    et: SimpleNamespace = field(init=False)

    def __post_init__(self) -> None:
        ds = SimpleNamespace(centre=np.zeros(2), n=np.array([1.0, 0.0]), run_side=self.run_side,
                             run_len=self.run_len, busy=False)
        self.et = SimpleNamespace(dstate=[ds], doors=[SimpleNamespace(kind=self.kind)],
                                  _row={i: i for i in self.pos},
                                  pos=lambda crowd, i: np.array(self.pos[i], float),
                                  radius=lambda crowd, i: self.radius)


def _walker(i: int, side: int, role: int = APPROACH) -> Walker:
    return Walker(id=i, door=0, side=side, role=role)


def _queues(per_side: int) -> tuple[dict[int, tuple[float, float]], list[Walker]]:
    pos, walkers = {}, []
    for k in range(per_side):
        pos[k] = (2.0 + 0.6 * k, 0.0)
        walkers.append(_walker(k, +1))
        pos[100 + k] = (-2.0 - 0.6 * k, 0.0)
        walkers.append(_walker(100 + k, -1))
    return pos, walkers


def test_a_holder_yet_to_pass_counts_in_the_run() -> None:
    pos, walkers = _queues(it.BATCH_LOAD)
    # The last passage came from +1; a holder from -1 holds the door, still on its own side.
    pos[50] = (-0.6, 0.3)
    walkers.append(_walker(50, -1, HOLDER))
    door = _Door(pos, run_side=+1, run_len=1)
    assert it._batch_side(door.et, 0, walkers, None) == -1
    # Once it stands beyond the doorway, its passage has been counted: the run is +1's again.
    pos[50] = (0.6, 0.3)
    assert it._batch_side(door.et, 0, walkers, None) == +1


def test_a_batch_ends_at_its_length_and_needs_a_queue_on_each_side() -> None:
    pos, walkers = _queues(it.BATCH_LOAD)
    assert it._batch_side(_Door(pos, run_side=-1, run_len=it.BATCH - 1).et, 0, walkers, None) == -1
    assert it._batch_side(_Door(pos, run_side=-1, run_len=it.BATCH).et, 0, walkers, None) == 0
    # a holder from the run's side still to pass brings it to BATCH as well
    pos[50] = (-0.6, 0.3)
    held = [*walkers, _walker(50, -1, HOLDER)]
    assert it._batch_side(_Door(pos, run_side=-1, run_len=it.BATCH - 1).et, 0, held, None) == 0
    # one short of BATCH_LOAD on one side: no batch, the ordering alone decides
    short = [w for w in walkers if w.id != 100 + it.BATCH_LOAD - 1]
    assert it._batch_side(_Door(pos, run_side=-1, run_len=1).et, 0, short, None) == 0
    # a double door passes both ways at once: no batches
    assert it._batch_side(_Door(pos, run_side=-1, run_len=1, kind="double").et, 0, walkers, None) == 0


def test_a_run_drains_its_own_queue_before_the_turn_changes() -> None:
    """Issue 26, change 16: a busy door stays busy while the run's own side still has people
    waiting, however few; it ends once the other side has fewer than BATCH_KEEP waiting, or the
    run's side nobody (door_single_flow seed 11: the run ended with two of its queue left, who
    waited out the other side's whole run)."""
    def door(keep_run: int, keep_other: int) -> tuple[_Door, list[Walker]]:
        pos, walkers = _queues(it.BATCH_LOAD)
        d = _Door(pos, run_side=-1, run_len=3)
        assert it._batch_side(d.et, 0, walkers, None) == -1  # busy: both sides have BATCH_LOAD
        run = [w for w in walkers if w.side == -1][:keep_run]
        other = [w for w in walkers if w.side == +1][:keep_other]
        return d, run + other

    d, left = door(2, it.BATCH_LOAD)  # two of the run's queue left: the run goes on
    assert it._batch_side(d.et, 0, left, None) == -1
    d, left = door(0, it.BATCH_LOAD)  # the run's side has emptied: no longer busy
    assert it._batch_side(d.et, 0, left, None) == 0
    assert not d.et.dstate[0].busy
    d, left = door(it.BATCH_LOAD, it.BATCH_KEEP - 1)  # the other side has almost nobody left
    assert it._batch_side(d.et, 0, left, None) == 0


def test_the_one_standing_in_the_way_commits_instead() -> None:
    # door_single_flow seed 6 at 71 s: the committed follower stood 2.3 m out behind two people of
    # its own side who touched shoulders across its way, and the held door waited 6 s for it.
    pos = {20: (-2.31, 0.35), 24: (-1.80, 0.23), 26: (-2.05, -0.24), 9: (1.5, 0.1)}
    ws = {20: _walker(20, -1), 24: _walker(24, -1), 26: _walker(26, -1), 9: _walker(9, +1)}
    door = _Door(pos)
    assert it._in_the_way(door.et, ws[20], ws, None).id == 24
    # nobody between it and the door: it commits itself
    assert it._in_the_way(door.et, ws[24], ws, None).id == 24
    # the chain is followed to the one nearest the door
    pos[30] = (-1.2, 0.1)
    ws[30] = _walker(30, -1)
    assert it._in_the_way(_Door(pos).et, ws[20], ws, None).id == 30


def test_who_is_not_in_the_way() -> None:
    pos = {20: (-2.3, 0.0), 21: (-1.5, 0.0)}
    ws = {20: _walker(20, -1), 21: _walker(21, -1)}
    door = _Door(pos)
    assert it._in_the_way(door.et, ws[20], ws, None).id == 21
    # beside the way, the two discs clear of each other across it
    pos[21] = (-1.5, 0.51)
    assert it._in_the_way(door.et, ws[20], ws, None).id == 20
    pos[21] = (-1.5, 0.0)
    # from the other side, already committed, or helping a carrier: not a queue-mate standing there
    for change in ({"side": +1}, {"role": FOLLOWER}, {"helping": 7}):
        ws[21] = Walker(id=21, door=0, **{"side": -1, "role": APPROACH, **change})
        assert it._in_the_way(door.et, ws[20], ws, None).id == 20, change
    # behind it, farther from the door
    ws[21] = _walker(21, -1)
    pos[21] = (-2.9, 0.0)
    assert it._in_the_way(door.et, ws[20], ws, None).id == 20


def test_a_busy_door_stays_busy_until_a_queue_thins() -> None:
    pos, walkers = _queues(it.BATCH_LOAD)
    door = _Door(pos, run_side=+1, run_len=1)

    def side_with(per_side_left: int) -> int:
        keep = [w for w in walkers if (w.id % 100) < per_side_left]
        return it._batch_side(door.et, 0, keep, None)

    assert it.BATCH_KEEP < it.BATCH_LOAD
    # the paper's groups of four (§6.1) do not make a door busy: they alternate
    assert side_with(it.BATCH_LOAD - 1) == 0
    assert side_with(it.BATCH_LOAD) == +1
    # busy, it stays so while BATCH_KEEP or more wait on each side
    assert side_with(it.BATCH_KEEP) == +1
    assert side_with(it.BATCH_KEEP - 1) == 0
    # and only a queue of BATCH_LOAD on each side makes it busy again
    assert side_with(it.BATCH_KEEP) == 0
    assert side_with(it.BATCH_LOAD) == +1


def _handing(pos: dict[int, tuple[float, float]], speed: float) -> tuple[SimpleNamespace, SimpleNamespace]:
    """The stand-in state with what :func:`~pedvr.etiquette.interaction._hand_on` also reads and
    writes: each body's speed, who carries something, the state changes and the log."""
    et = _Door(pos).et
    rows = max(pos) + 1
    vel = np.zeros((rows, 2))
    vel[:, 0] = speed
    et.carrying = np.zeros(rows, np.bool_)
    et.log = lambda *a, **k: None
    et.set_state = lambda w, s: setattr(w, "state", s)
    return et, SimpleNamespace(vel=vel)


def test_a_blocked_follower_hands_the_door_on_to_the_one_in_its_way() -> None:
    # door_single_flow seed 7 at 34-39 s: the next in the queue moved up to the committed follower's
    # place, ahead of it, and the follower worked round it for 6 s while the holder held the door.
    pos = {50: (-0.5, 0.0), 1: (-2.6, 0.1), 2: (-1.8, 0.0)}
    h = Walker(id=50, door=0, side=-1, role=HOLDER, follower=1)
    f = Walker(id=1, door=0, side=-1, role=FOLLOWER, holder=50, leader=50, state=it.REACH_EDGE, waited=9.0)
    nxt = Walker(id=2, door=0, side=-1, role=APPROACH, leader=1, waited=3.0)
    ws = {50: h, 1: f, 2: nxt}
    et, crowd = _handing(pos, speed=0.1)
    assert it._hand_on(et, f, h, ws, crowd)
    assert (nxt.role, nxt.state, nxt.holder, h.follower) == (FOLLOWER, it.REACH_EDGE, 50, 2)
    # back in the queue, with its wait: the ordering puts it next (it waited longest)
    assert f.role == APPROACH and f.holder == it.NONE and f.waited == 9.0


@pytest.mark.parametrize("case", ["walking", "nobody_in_the_way", "across_the_door", "carrier", "side_by_side",
                                  "double_door"])
def test_a_follower_keeps_the_door_when_not_blocked(case: str) -> None:
    pos = {50: (-0.5, 0.0), 1: (-2.6, 0.1), 2: (-1.8, 0.0)}
    h = Walker(id=50, door=0, side=-1, role=HOLDER, follower=1)
    f = Walker(id=1, door=0, side=-1, role=FOLLOWER, holder=50, leader=50, state=it.REACH_EDGE)
    ws = {50: h, 1: f, 2: Walker(id=2, door=0, side=-1, role=APPROACH)}
    if case == "nobody_in_the_way":
        pos[2] = (-1.8, 0.8)
    if case == "across_the_door":  # HOL across the door: its way is past the holder coming through
        h.side = +1
    if case == "side_by_side":  # each in the other's way, neither nearer the door: no hand-on back
        pos[1], pos[2] = (-2.0, 0.2), (-2.0, -0.2)  # and forth every tick (seed 5, 41.4-41.6 s)
        assert it._in_the_way(_Door(pos).et, f, ws, None).id == 2
    et, crowd = _handing(pos, speed=0.6 if case == "walking" else 0.1)
    if case == "double_door":
        et.doors[0].kind = "double"
    if case == "carrier":
        et.carrying[1] = True  # a carrier passes first whatever the holder decided (App. B, §4.6)
    assert not it._hand_on(et, f, h, ws, crowd)
    assert (f.role, h.follower, ws[2].role) == (FOLLOWER, 1, APPROACH)
