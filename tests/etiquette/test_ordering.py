"""Doorway ordering as pure functions (Huang & Terzopoulos §4.2 Alg. 1, §4.5.2 Alg. 3–4):
waiting time counts in the proximity E, and a double door's side choice prefers the keep-side
(right-hand) door, adopts a held door, and turns to the freer door under load."""

from __future__ import annotations

from pedvr.etiquette.ordering import NONE, Candidate, DoubleDoor, choose_side, leaders, proximity


def _c(i: int, x: float, y: float = 0.0, *, side: int | None = None, **kw: object) -> Candidate:
    s = side if side is not None else (1 if x > 0 else -1)
    return Candidate(id=i, pos=(x, y), side=s, d_door=abs(x) if "d_door" not in kw else kw.pop("d_door"),
                     **kw)  # type: ignore[arg-type]


def test_a_queue_on_one_side_follows_front_to_back() -> None:
    out = leaders([_c(1, 1.0), _c(2, 2.0), _c(3, 3.0)], wait_credit=0.5)
    assert out == {1: NONE, 2: 1, 3: 2}


def test_waiting_time_counts_in_proximity() -> None:
    # Two pedestrians compete for the one in front: the nearer one wins until the other has
    # waited long enough to be "closer" by E = d - wait_credit * t_wait.
    front = _c(1, 1.0)
    near, far = _c(2, 2.0, 0.3), _c(3, 2.0, -0.9, waited=0.0)
    assert proximity(near, front.pos, 0.5) < proximity(far, front.pos, 0.5)
    out = leaders([front, near, far], wait_credit=0.5)
    assert out[2] == 1 and out[3] == 2
    far_waited = _c(3, 2.0, -0.9, waited=3.0)
    out = leaders([front, near, far_waited], wait_credit=0.5)
    assert out[3] == 1 and out[2] == 3


def test_opposite_sides_without_a_holder_break_the_cycle_at_the_nearer() -> None:
    out = leaders([_c(1, 1.0), _c(2, -1.5)], wait_credit=0.5)
    assert out[1] == NONE and out[2] in (NONE, 1)
    assert NONE in out.values()  # never two pedestrians leading each other


def test_double_door_keeps_right_when_both_are_free() -> None:
    door = DoubleDoor(free=(True, True), load=(0, 0), keep_leaf_for_plus=0)
    me_plus = _c(1, 2.0)
    me_minus = _c(2, -2.0)
    assert choose_side(me_plus, [me_plus], door, in_region=True, wait_credit=0.5) == (NONE, 0)
    assert choose_side(me_minus, [me_minus], door, in_region=True, wait_credit=0.5) == (NONE, 1)
    left = DoubleDoor(free=(True, True), load=(0, 0), keep_leaf_for_plus=1)  # [etiquette] keep = "left"
    assert choose_side(me_plus, [me_plus], left, in_region=True, wait_credit=0.5) == (NONE, 1)


def test_double_door_the_held_door_is_taken() -> None:
    # The pedestrian in front on my side holds leaf 1 (not my keep side): I follow it there.
    holder = _c(1, 0.6, holder=True, critical=True, leaf=1)
    me = _c(2, 2.5)
    door = DoubleDoor(free=(True, False), load=(0, 1), keep_leaf_for_plus=0)
    leader, leaf = choose_side(me, [holder, me], door, in_region=True, wait_credit=0.5)
    assert leader == 1 and leaf == 1


def test_double_door_the_freer_door_under_load() -> None:
    me = _c(9, 3.0)
    # a leaf nobody uses is taken, the keep side first
    assert choose_side(me, [me], DoubleDoor(free=(False, True), load=(1, 0), keep_leaf_for_plus=0),
                       in_region=True, wait_credit=0.5) == (NONE, 1)
    # both in use: the keep side, unless it is busier by LOAD_MARGIN (§6.3)
    assert choose_side(me, [me], DoubleDoor(free=(False, False), load=(1, 1), keep_leaf_for_plus=0),
                       in_region=True, wait_credit=0.5) == (NONE, 0)
    assert choose_side(me, [me], DoubleDoor(free=(False, False), load=(3, 1), keep_leaf_for_plus=0),
                       in_region=True, wait_credit=0.5) == (NONE, 1)


def test_double_door_a_queue_spreads_over_both_leaves() -> None:
    """§6.3, issue 26: with more than two ahead of it on its side and its leader's leaf carrying
    LOAD_MARGIN more than the other, a later arriver takes the less congested leaf (Alg. 3 read
    literally kept a queue of eight on one leaf while the other stood free)."""
    queue = [_c(i, 1.0 + 0.8 * i, leaf=0) for i in range(1, 9)]
    me = queue[-1]
    busy = DoubleDoor(free=(False, True), load=(7, 0), keep_leaf_for_plus=0)
    assert choose_side(me, queue, busy, in_region=False, wait_credit=0.5) == (NONE, 1)
    balanced = DoubleDoor(free=(False, False), load=(4, 3), keep_leaf_for_plus=0)
    assert choose_side(me, queue, balanced, in_region=False, wait_credit=0.5) == (queue[-2].id, 0)
