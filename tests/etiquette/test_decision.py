"""The holding decision network (Huang & Terzopoulos §5): Tables 2 and 3 reproduced exactly,
the exact marginal over the four factors, Effort's ramp, MEU and sampled decisions."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pedvr.etiquette import care_factor, effort_factor, holding_probabilities
from pedvr.etiquette.decision import DecisionInputError, decide

T, F = True, False
# Table 2 as printed (HOL, HOF, NH), rows read Effort, Care, Kindness.
RUSH_T = {(T, T, T): (0.7, 0.1, 0.2), (T, T, F): (0.6, 0.1, 0.3), (T, F, T): (0.7, 0.0, 0.3),
          (T, F, F): (0.5, 0.0, 0.5), (F, T, T): (0.1, 0.0, 0.9), (F, T, F): (0.1, 0.0, 0.9),
          (F, F, T): (0.1, 0.0, 0.9), (F, F, F): (0.0, 0.0, 1.0)}
RUSH_F = {(T, T, T): (0.2, 0.8, 0.0), (T, T, F): (0.7, 0.2, 0.1), (T, F, T): (0.9, 0.1, 0.0),
          (T, F, F): (0.6, 0.1, 0.3), (F, T, T): (0.2, 0.1, 0.7), (F, T, F): (0.5, 0.0, 0.5),
          (F, F, T): (0.3, 0.0, 0.7), (F, F, F): (0.1, 0.0, 0.9)}


@pytest.mark.parametrize("rush,table", [(1.0, RUSH_T), (0.0, RUSH_F)], ids=["rush", "no-rush"])
def test_corners_are_table_2(rush: float, table: dict[tuple[bool, bool, bool], tuple[float, ...]]) -> None:
    for (e, c, k), (hol, hof, nh) in table.items():
        p = holding_probabilities(effort=float(e), care=float(c), kindness=float(k), rush=rush)
        assert p == pytest.approx({"HOL": hol, "HOF": hof, "NH": nh}, abs=1e-12)


def test_marginal_is_the_exact_sum_over_parents() -> None:
    pe, pc, pk, pr = 0.3, 0.8, 0.6, 0.25
    want = np.zeros(3)
    for e, c, k, r in itertools.product((T, F), repeat=4):
        w = ((pe if e else 1 - pe) * (pc if c else 1 - pc) * (pk if k else 1 - pk) * (pr if r else 1 - pr))
        want += w * np.array((RUSH_T if r else RUSH_F)[(e, c, k)])
    got = holding_probabilities(effort=pe, care=pc, kindness=pk, rush=pr)
    assert [got["HOL"], got["HOF"], got["NH"]] == pytest.approx(want.tolist(), abs=1e-12)
    assert sum(got.values()) == pytest.approx(1.0)


def test_effort_ramp() -> None:
    assert effort_factor(0.0) == 1.0 and effort_factor(1.0) == 1.0
    assert effort_factor(2.5) == pytest.approx(0.5)
    assert effort_factor(4.0) == 0.0 and effort_factor(10.0) == 0.0
    with pytest.raises(DecisionInputError, match=r"distance_m = -1: expected a distance >= 0 m"):
        effort_factor(-1)


def test_care_is_table_3() -> None:
    assert care_factor(follower_female=True, follower_carrying=True) == 1.0
    assert care_factor(follower_female=True, follower_carrying=False) == 1.0
    assert care_factor(follower_female=False, follower_carrying=True) == 1.0
    assert care_factor(follower_female=False, follower_carrying=False) == 0.0


def test_bad_factor_is_one_line() -> None:
    with pytest.raises(DecisionInputError, match=r"^kindness = 1.5: expected a probability in \[0, 1\]$"):
        holding_probabilities(effort=1.0, care=0.0, kindness=1.5, rush=0.0)


def test_meu_and_its_tie_break() -> None:
    # A close female follower, kind unhurried holder: hold for her to pass first (Table 2, TTT / Rush F).
    assert decide(holding_probabilities(effort=1, care=1, kindness=1, rush=0)) == "HOF"
    # A male follower with empty hands: hold, he passes later (TFT).
    assert decide(holding_probabilities(effort=1, care=0, kindness=1, rush=0)) == "HOL"
    # Beyond 4 m nobody is held for, even at the 0.5 / 0.5 corner (ties go to NH).
    for c, k, r in itertools.product((0.0, 1.0), repeat=3):
        assert decide(holding_probabilities(effort=effort_factor(4.5), care=c, kindness=k, rush=r)) == "NH"


def test_sampled_decisions_follow_the_distribution() -> None:
    p = holding_probabilities(effort=0.7, care=1.0, kindness=0.6, rush=0.3)
    rng = np.random.default_rng(4)
    draws = [decide(p, rng=rng) for _ in range(4000)]
    for a in ("HOL", "HOF", "NH"):
        assert draws.count(a) / len(draws) == pytest.approx(p[a], abs=0.03)
