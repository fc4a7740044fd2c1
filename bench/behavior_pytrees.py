"""Tree-framework overhead: py_trees against pedvr.behavior.tree on the same trees.

Why pedvr does not depend on py_trees (issue 13): this ticks ``--agents``
copies of the bench's personal tree shape (``pedvr.behavior.bench.WANDER``,
18 nodes: forever { sequence [ random [walk, wait | walk, gesture],
selector [near → gaze, not running], succeed(timeout(wait)) ] }) with
identical synthetic leaves (an action runs for a drawn number of ticks, a
condition answers at once) at 30 Hz for ``--ticks`` ticks, in

* ``py_trees``: py_trees 2.x (``Repeat``, ``Sequence``/``Selector`` with memory,
  ``Inverter``, ``FailureIsSuccess``, ``Timeout``; a memory ``Selector`` stands in
  for the weighted random selector py_trees lacks, which only favours it);
* ``pedvr``: the same tree in ``pedvr.behavior.tree``, every tree ticked every tick;
* ``pedvr_sleeping``: pedvr with its scheduler's rule: a tree whose running
  leaves only wait is not ticked until its wake time.

No simulation, no body: only the frameworks. Prints ms per tick for all the
trees. Needs ``pip install py_trees`` (the ``bench`` extra).

    python bench/behavior_pytrees.py --agents 200 --ticks 300
"""

from __future__ import annotations

import argparse
import heapq
import json
import math
import os
import time
from types import SimpleNamespace

import numpy as np

from pedvr.behavior import tree as bt

DT = 1.0 / 30.0


def durations(seed: int, n: int) -> list[int]:
    """Per-leaf action lengths in ticks: 1 to 90 (3 s), drawn once, the same for both frameworks."""
    return [int(x) for x in np.random.default_rng(seed).integers(1, 91, n)]


# -- pedvr ------------------------------------------------------------------------------------------


class PAct(bt.Behaviour):
    """RUNNING for ``n`` ticks per run, then SUCCESS; states its wake time, as pedvr's waiting leaves do."""

    __slots__ = ("n", "end")

    def __init__(self, n: int) -> None:
        super().__init__("act")
        self.n = n
        self.end = 0.0

    def initialise(self, ctx):  # type: ignore[no-untyped-def]
        self.end = ctx.t + self.n * DT
        self.wake = self.end

    def update(self, ctx):  # type: ignore[no-untyped-def]
        return bt.SUCCESS if ctx.t >= self.end - 1e-9 else bt.RUNNING


class PCond(bt.Condition):
    __slots__ = ("value",)

    def __init__(self, value: bool) -> None:
        super().__init__("cond")
        self.value = value

    def check(self, ctx):  # type: ignore[no-untyped-def]
        return self.value


def pedvr_tree(d: list[int]) -> bt.Behaviour:
    return bt.Repeat(bt.Sequence([
        bt.RandomSelector([bt.Sequence([PAct(d[0]), PAct(d[1])]), bt.Sequence([PAct(d[2]), PAct(d[3])])],
                          weights=[3.0, 1.0]),
        bt.Selector([bt.Sequence([PCond(False), PAct(d[4])]), bt.Invert(PCond(False))], memory=True),
        bt.Succeed(bt.Timeout(PAct(d[5]), seconds=(3.0, 3.0))),
    ]))


def run_pedvr(agents: int, ticks: int, *, sleeping: bool) -> float:
    trees = [pedvr_tree(durations(k, 6)) for k in range(agents)]
    ctx = SimpleNamespace(t=0.0, wake=math.inf, rng=np.random.default_rng(0))
    heap = [(0.0, k) for k in range(agents)]
    start = time.perf_counter()
    for i in range(ticks):
        ctx.t = i * DT
        if sleeping:
            due = []
            while heap and heap[0][0] <= ctx.t + 1e-9:
                due.append(heapq.heappop(heap)[1])
            for k in sorted(due):
                ctx.wake = math.inf
                trees[k].tick(ctx)  # type: ignore[arg-type]
                heapq.heappush(heap, (ctx.wake, k))
        else:
            for tr in trees:
                ctx.wake = math.inf
                tr.tick(ctx)  # type: ignore[arg-type]
    return (time.perf_counter() - start) * 1e3 / ticks


# -- py_trees ---------------------------------------------------------------------------------------


def run_py_trees(agents: int, ticks: int) -> float:
    import py_trees
    from py_trees.common import Status

    class Act(py_trees.behaviour.Behaviour):
        def __init__(self, n: int) -> None:
            super().__init__("act")
            self.n = n
            self.left = 0

        def initialise(self) -> None:
            self.left = self.n

        def update(self) -> Status:
            self.left -= 1
            return Status.SUCCESS if self.left <= 0 else Status.RUNNING

    class Cond(py_trees.behaviour.Behaviour):
        def __init__(self, value: bool) -> None:
            super().__init__("cond")
            self.value = value

        def update(self) -> Status:
            return Status.SUCCESS if self.value else Status.FAILURE

    def make(d: list[int]) -> py_trees.behaviour.Behaviour:
        c = py_trees.composites
        dec = py_trees.decorators
        pick = c.Selector("random", memory=True, children=[
            c.Sequence("walk", memory=True, children=[Act(d[0]), Act(d[1])]),
            c.Sequence("spot", memory=True, children=[Act(d[2]), Act(d[3])])])
        look = c.Selector("look", memory=True, children=[
            c.Sequence("near", memory=True, children=[Cond(False), Act(d[4])]),
            dec.Inverter("not", child=Cond(False))])
        pause = dec.FailureIsSuccess("ok", child=dec.Timeout("t", child=Act(d[5]), duration=3600.0))
        return dec.Repeat("forever", child=c.Sequence("main", memory=True, children=[pick, look, pause]),
                          num_success=-1)

    roots = [make(durations(k, 6)) for k in range(agents)]
    start = time.perf_counter()
    for _ in range(ticks):
        for r in roots:
            r.tick_once()
    return (time.perf_counter() - start) * 1e3 / ticks


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--agents", type=int, default=200)
    p.add_argument("--ticks", type=int, default=300)
    a = p.parse_args()
    out: dict[str, object] = {"agents": a.agents, "ticks": a.ticks, "nodes_per_tree": 18}
    out["pedvr_ms_per_tick"] = round(run_pedvr(a.agents, a.ticks, sleeping=False), 4)
    out["pedvr_sleeping_ms_per_tick"] = round(run_pedvr(a.agents, a.ticks, sleeping=True), 4)
    try:
        out["py_trees_ms_per_tick"] = round(run_py_trees(a.agents, a.ticks), 4)
    except ImportError:
        out["py_trees_ms_per_tick"] = None
        out["note"] = "py_trees is not installed: pip install py_trees (the bench extra)"
    out["loadavg_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
