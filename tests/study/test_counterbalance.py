"""Balanced Latin squares and the counterbalanced plan (PedVR §6.4)."""

from __future__ import annotations

import itertools
from collections import Counter
from pathlib import Path

import pytest

from pedvr.study.counterbalance import balanced_latin_square, left_right_flipped, square_row
from pedvr.study.protocol import load_protocol, plan_for

PROTOCOL = Path(__file__).resolve().parents[2] / "user_study" / "pedvr_replication.toml"


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_balanced_latin_square_properties(n: int) -> None:
    rows = balanced_latin_square(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for r in rows:
        assert sorted(r) == list(range(n))
    reps = len(rows) // n
    for pos in range(n):  # every condition in every position equally often
        assert Counter(r[pos] for r in rows) == {c: reps for c in range(n)}
    follows = Counter((r[i], r[i + 1]) for r in rows for i in range(n - 1))
    assert set(follows) == {(a, b) for a in range(n) for b in range(n) if a != b}
    assert len(set(follows.values())) == 1  # every ordered pair equally often


def test_three_conditions_give_all_six_orders() -> None:
    assert sorted(map(tuple, balanced_latin_square(3))) == sorted(itertools.permutations(range(3)))
    assert [square_row(number=k, n=3) for k in (1, 7, 13)] == [square_row(number=1, n=3)] * 3


def test_plan_covers_all_orders_equally_and_labels_by_appearance() -> None:
    p = load_protocol(PROTOCOL)
    orders: dict[str, Counter] = {"antipodal_circle": Counter(), "bidirectional_flow": Counter()}
    first_block = Counter()
    flips: Counter = Counter()
    for number in range(1, 13):
        plan = plan_for(p, number=number)
        trials = [s for s in plan if s.kind == "trial" and s.design == "block"]
        assert len(trials) == 6
        first_block[trials[0].block] += 1
        for block in orders:
            bt = [s for s in trials if s.block == block]
            orders[block][tuple(s.condition for s in bt)] += 1
            assert [s.label for s in bt] == ["A", "B", "C"]  # by order of appearance
            assert [s.trial.order for s in bt] == [1, 2, 3]
            assert len({s.trial.seed for s in bt}) == 1  # one crowd seed per block
        for q in (s for s in plan if s.pairs):
            assert len(q.pairs) == 3
            for pair in q.pairs:
                left, right = pair.comparison.split("/")
                assert (pair.left_condition, pair.right_condition) == ((right, left) if pair.flipped else (left, right))
                flips[(q.block, pair.comparison, pair.flipped)] += 1
            # the participant sees labels only, in label order
            assert [tuple(sorted((x.left_label, x.right_label))) for x in q.pairs] == [("A", "B"), ("A", "C"), ("B", "C")]
        corridor = [s.trial.responsibility for s in plan if s.design == "sweep"]
        assert sorted(corridor) == [0.0, 0.25, 0.5, 1.0]
    for block, c in orders.items():
        assert sorted(c) == sorted(itertools.permutations(["decoupled", "pedvr", "pedvr+g"])), block
        assert set(c.values()) == {2}, block  # 12 participants: each of the 6 orders twice
    assert first_block == {"antipodal_circle": 6, "bidirectional_flow": 6}
    assert set(flips.values()) == {6}  # each comparison shown each way round for half the participants


def test_six_participants_see_every_order_once_per_block() -> None:
    p = load_protocol(PROTOCOL)
    for block in ("antipodal_circle", "bidirectional_flow"):
        seen = {tuple(s.condition for s in plan_for(p, number=k) if s.block == block and s.kind == "trial")
                for k in range(1, 7)}
        assert len(seen) == 6


def test_left_right_alternates() -> None:
    a = [left_right_flipped(number=k, block=0, comparison=0, cycle=6) for k in range(1, 13)]
    assert a[:6] == [False, True, False, True, False, True] and a[6:] == [True, False, True, False, True, False]


def test_plan_is_a_pure_function_of_the_number() -> None:
    p = load_protocol(PROTOCOL)
    assert [s.to_json() for s in plan_for(p, number=4)] == [s.to_json() for s in plan_for(p, number=4)]
    assert [s.to_json() for s in plan_for(p, number=4)] != [s.to_json() for s in plan_for(p, number=5)]
