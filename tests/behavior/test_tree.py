"""Node semantics of the behavior-tree framework (pedvr.behavior.tree), without a simulation.

A ``Probe`` leaf plays a scripted list of statuses and logs every hook call,
so each test asserts exactly what ran, what was terminated, and with which
status (py_trees' contract: terminate(INVALID) when a parent stops a
RUNNING child).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from pedvr.behavior.context import Run
from pedvr.behavior.tree import (
    FAILURE,
    INVALID,
    RUNNING,
    SUCCESS,
    Behaviour,
    Cooldown,
    Fail,
    Invert,
    Parallel,
    RandomSelector,
    Repeat,
    Selector,
    Sequence,
    Status,
    Succeed,
    Timeout,
    Until,
    Wait,
)


class Probe(Behaviour):
    """Returns ``script[k]`` at its k-th update over its whole life (the last one repeats); logs hooks."""

    def __init__(self, name: str, script: list[Status], log: list[tuple[str, str, str]],
                 wake: float = 0.0) -> None:
        super().__init__(name)
        self.wake = wake  # 0: needs every tick; larger: sleeps until then
        self.script = script
        self.log = log
        self.k = 0

    def initialise(self, ctx: object) -> None:  # type: ignore[override]
        self.log.append((self.name, "initialise", ""))

    def update(self, ctx: object) -> Status:  # type: ignore[override]
        s = self.script[min(self.k, len(self.script) - 1)]
        self.k += 1
        self.log.append((self.name, "update", s.value))
        return s

    def terminate(self, ctx: object, new_status: Status) -> None:  # type: ignore[override]
        self.log.append((self.name, "terminate", new_status.value))


def ctx(seed: int = 0) -> SimpleNamespace:
    return SimpleNamespace(t=0.0, wake=math.inf, rng=np.random.default_rng(seed), run=Run())


def tick(node: Behaviour, c: SimpleNamespace, t: float | None = None) -> Status:
    if t is not None:
        c.t = t
    c.wake = math.inf
    return node.tick(c)  # type: ignore[arg-type]


def terms(log: list[tuple[str, str, str]]) -> list[tuple[str, str]]:
    return [(n, s) for n, h, s in log if h == "terminate"]


# -- sequence ---------------------------------------------------------------------------------------


def test_sequence_runs_children_in_order_and_resumes_the_running_one() -> None:
    log: list[tuple[str, str, str]] = []
    a = Probe("a", [SUCCESS], log)
    b = Probe("b", [RUNNING, RUNNING, SUCCESS], log)
    c_ = Probe("c", [SUCCESS], log)
    seq = Sequence([a, b, c_])
    c = ctx()
    assert tick(seq, c) is RUNNING
    assert tick(seq, c) is RUNNING
    assert tick(seq, c) is SUCCESS
    # memory: a ran once; b was resumed, not re-initialised
    assert [x for x in log if x[0] == "a" and x[1] == "update"] == [("a", "update", "success")]
    assert [x for x in log if x[0] == "b" and x[1] == "initialise"] == [("b", "initialise", "")]
    assert terms(log) == [("a", "success"), ("b", "success"), ("c", "success")]


def test_sequence_fails_at_the_first_failure_without_running_the_rest() -> None:
    log: list[tuple[str, str, str]] = []
    seq = Sequence([Probe("a", [SUCCESS], log), Probe("b", [FAILURE], log), Probe("c", [SUCCESS], log)])
    assert tick(seq, ctx()) is FAILURE
    assert not [x for x in log if x[0] == "c"]


def test_reactive_sequence_rechecks_conditions_and_stops_the_running_action() -> None:
    log: list[tuple[str, str, str]] = []
    cond = Probe("cond", [SUCCESS, SUCCESS, FAILURE], log)
    act = Probe("act", [RUNNING], log)
    seq = Sequence([cond, act], memory=False)
    c = ctx()
    assert tick(seq, c) is RUNNING
    assert c.wake == c.t  # a reactive composite keeps its tree awake
    assert tick(seq, c) is RUNNING
    assert tick(seq, c) is FAILURE  # the condition failed: the running action is stopped
    assert ("act", "invalid") in terms(log)
    assert act.status is INVALID


def test_stopping_a_sequence_terminates_its_running_child_with_invalid() -> None:
    log: list[tuple[str, str, str]] = []
    inner = Probe("inner", [RUNNING], log)
    seq = Sequence([Probe("a", [SUCCESS], log), Sequence([inner])])
    c = ctx()
    tick(seq, c)
    seq.stop(c)  # type: ignore[arg-type]
    assert terms(log)[-1] == ("inner", "invalid")
    assert seq.status is INVALID and inner.status is INVALID


# -- selector ---------------------------------------------------------------------------------------


def test_selector_falls_back_in_priority_order() -> None:
    log: list[tuple[str, str, str]] = []
    sel = Selector([Probe("a", [FAILURE], log), Probe("b", [SUCCESS], log), Probe("c", [SUCCESS], log)])
    assert tick(sel, ctx()) is SUCCESS
    assert not [x for x in log if x[0] == "c"]
    assert tick(Selector([Probe("x", [FAILURE], log)]), ctx()) is FAILURE


def test_reactive_selector_preempts_the_lower_priority_child() -> None:
    log: list[tuple[str, str, str]] = []
    high = Probe("high", [FAILURE, FAILURE, RUNNING], log)
    low = Probe("low", [RUNNING], log)
    sel = Selector([high, low])
    c = ctx()
    assert tick(sel, c) is RUNNING and low.status is RUNNING
    assert c.wake == c.t
    tick(sel, c)
    assert tick(sel, c) is RUNNING
    assert high.status is RUNNING
    assert ("low", "invalid") in terms(log)  # the lower branch was terminated


def test_selector_with_memory_does_not_retry_higher_children() -> None:
    log: list[tuple[str, str, str]] = []
    high = Probe("high", [FAILURE, RUNNING], log)
    low = Probe("low", [RUNNING], log)
    sel = Selector([high, low], memory=True)
    c = ctx()
    tick(sel, c)
    tick(sel, c)
    assert [x for x in log if x[0] == "high" and x[1] == "update"] == [("high", "update", "failure")]
    assert low.status is RUNNING


def test_random_selector_draws_its_order_by_weight_from_the_rng() -> None:
    firsts = []
    for seed in range(400):
        log: list[tuple[str, str, str]] = []
        rs = RandomSelector([Probe("a", [SUCCESS], log), Probe("b", [SUCCESS], log), Probe("z", [SUCCESS], log)],
                            weights=[3.0, 1.0, 0.0])
        tick(rs, ctx(seed))
        firsts.append(log[0][0])
    share_a = firsts.count("a") / len(firsts)
    assert 0.68 < share_a < 0.82  # 3 : 1
    assert "z" not in firsts  # weight 0 is tried last
    # same seed, same order; failures fall through to the next drawn child
    order = []
    for _ in range(2):
        log = []
        rs = RandomSelector([Probe(n, [FAILURE], log) for n in "abcde"])
        assert tick(rs, ctx(7)) is FAILURE
        order.append([n for n, h, _ in log if h == "update"])
    assert order[0] == order[1] and sorted(order[0]) == list("abcde")


def test_random_selector_rejects_bad_weights() -> None:
    with pytest.raises(ValueError, match="one number >= 0 per child"):
        RandomSelector([Wait((1.0, 1.0))], weights=[1.0, 2.0])


# -- parallel ---------------------------------------------------------------------------------------


def test_parallel_success_on_all_and_failure_on_one() -> None:
    log: list[tuple[str, str, str]] = []
    a = Probe("a", [SUCCESS], log)
    b = Probe("b", [RUNNING, SUCCESS], log)
    par = Parallel([a, b])
    c = ctx()
    assert tick(par, c) is RUNNING
    assert tick(par, c) is SUCCESS
    assert [x for x in log if x[0] == "a" and x[1] == "update"] == [("a", "update", "success")]  # synchronised
    log.clear()
    slow = Probe("slow", [RUNNING], log)
    par = Parallel([slow, Probe("bad", [RUNNING, FAILURE], log)])
    tick(par, c)
    assert tick(par, c) is FAILURE
    assert ("slow", "invalid") in terms(log)  # the parallel ended: the child still running is stopped


def test_parallel_failure_policy_all_waits_for_every_child() -> None:
    log: list[tuple[str, str, str]] = []
    par = Parallel([Probe("bad", [FAILURE], log), Probe("slow", [RUNNING, SUCCESS], log)], failure="all")
    c = ctx()
    assert tick(par, c) is RUNNING  # one failed, the other still runs
    assert tick(par, c) is FAILURE  # all finished, not all succeeded
    race = Parallel([Probe("ok", [RUNNING, SUCCESS], log), Probe("no", [RUNNING, RUNNING, FAILURE], log)],
                    success="one", failure="one")
    assert tick(race, c) is RUNNING
    assert tick(race, c) is SUCCESS  # the first to finish decides
    with pytest.raises(ValueError, match="failure policy 'some'"):
        Parallel([Wait((1.0, 1.0))], failure="some")


def test_parallel_success_on_one_stops_the_others() -> None:
    log: list[tuple[str, str, str]] = []
    hold = Probe("hold", [RUNNING], log)
    par = Parallel([hold, Probe("done", [RUNNING, SUCCESS], log)], success="one")
    c = ctx()
    assert tick(par, c) is RUNNING
    assert tick(par, c) is SUCCESS
    assert ("hold", "invalid") in terms(log)
    par = Parallel([Probe("f1", [FAILURE], log), Probe("f2", [RUNNING, FAILURE], log)], success="one")
    assert tick(par, c) is RUNNING
    assert tick(par, c) is FAILURE  # only when all failed


# -- decorators -------------------------------------------------------------------------------------


def test_repeat_count_seconds_and_failure() -> None:
    log: list[tuple[str, str, str]] = []
    child = Probe("c", [SUCCESS], log)
    rep = Repeat(child, count=3)
    c = ctx()
    statuses = [tick(rep, c) for _ in range(3)]
    assert statuses == [RUNNING, RUNNING, SUCCESS]
    assert [h for n, h, _ in log].count("initialise") == 3
    # by duration: the running child is stopped at the deadline
    log.clear()
    run = Probe("r", [RUNNING], log, wake=100.0)
    rep = Repeat(run, seconds=(2.0, 2.0))
    assert tick(rep, c, 0.0) is RUNNING
    assert c.wake == 2.0
    assert tick(rep, c, 1.0) is RUNNING
    assert tick(rep, c, 2.0) is SUCCESS
    assert terms(log) == [("r", "invalid")]
    # a child failure ends the loop with failure
    assert tick(Repeat(Probe("f", [FAILURE], log)), c) is FAILURE
    with pytest.raises(ValueError, match="count 0"):
        Repeat(run, count=0)


def test_invert_succeed_fail() -> None:
    log: list[tuple[str, str, str]] = []
    c = ctx()
    assert tick(Invert(Probe("s", [SUCCESS], log)), c) is FAILURE
    assert tick(Invert(Probe("f", [FAILURE], log)), c) is SUCCESS
    assert tick(Invert(Probe("r", [RUNNING], log)), c) is RUNNING
    assert tick(Succeed(Probe("f", [FAILURE], log)), c) is SUCCESS
    assert tick(Fail(Probe("s", [SUCCESS], log)), c) is FAILURE
    assert tick(Fail(Probe("r", [RUNNING], log)), c) is RUNNING


def test_until_waits_for_its_child_to_succeed() -> None:
    log: list[tuple[str, str, str]] = []
    node = Until(Probe("cond", [FAILURE, FAILURE, SUCCESS], log))
    c = ctx()
    assert tick(node, c) is RUNNING and c.wake == c.t  # polled at every tick
    assert tick(node, c) is RUNNING
    assert tick(node, c) is SUCCESS


def test_timeout_fails_and_stops_the_child() -> None:
    log: list[tuple[str, str, str]] = []
    node = Timeout(Probe("slow", [RUNNING], log, wake=100.0), seconds=(1.5, 1.5))
    c = ctx()
    assert tick(node, c, 0.0) is RUNNING
    assert c.wake == 1.5
    assert tick(node, c, 1.0) is RUNNING
    assert tick(node, c, 1.5) is FAILURE
    assert terms(log) == [("slow", "invalid")]
    assert tick(Timeout(Probe("quick", [SUCCESS], log), seconds=(1.0, 1.0)), c, 2.0) is SUCCESS


def test_cooldown_blocks_reruns_for_its_duration() -> None:
    log: list[tuple[str, str, str]] = []
    node = Cooldown(Probe("c", [SUCCESS], log), seconds=5.0)
    c = ctx()
    assert tick(node, c, 0.0) is SUCCESS
    assert tick(node, c, 4.9) is FAILURE
    assert tick(node, c, 5.0) is SUCCESS
    assert [h for n, h, _ in log].count("update") == 2


def test_wait_draws_its_duration_and_sleeps_until_then() -> None:
    c = ctx(3)
    w = Wait((2.0, 4.0))
    assert tick(w, c, 10.0) is RUNNING
    end = w.end
    assert 12.0 <= end <= 14.0 and c.wake == end
    assert tick(w, c, end - 0.01) is RUNNING
    assert tick(w, c, end) is SUCCESS
    c2 = ctx(3)
    w2 = Wait((2.0, 4.0))
    tick(w2, c2, 10.0)
    assert w2.end == end  # same seed, same draw


def test_a_tree_sleeps_until_its_earliest_wake() -> None:
    c = ctx()
    tree = Parallel([Wait((3.0, 3.0)), Sequence([Wait((1.0, 1.0)), Wait((5.0, 5.0))])])
    assert tick(tree, c, 0.0) is RUNNING
    assert c.wake == 1.0
    assert tick(tree, c, 1.0) is RUNNING
    assert c.wake == 3.0
    assert tick(tree, c, 3.0) is RUNNING
    assert c.wake == 6.0
    assert tick(tree, c, 6.0) is SUCCESS
