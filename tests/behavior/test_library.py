"""Every registered library tree runs to success in a small scene, leaving nothing behind."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.behavior.library import library_trees
from pedvr.body.model import GAZE_NONE
from tests.behavior._scene import make_sim, row, step_until

SEAT = '[[behavior.objects]]\nname = "seat"\nkind = "chair"\nat = [0.0, -3.0]\nfacing_deg = 90\n'
EXHIBIT = '[[behavior.objects]]\nname = "vase"\nkind = "exhibit"\nat = [0.0, -5.0]\nfacing_deg = 90\n'


@pytest.mark.parametrize("name", sorted(library_trees()))
def test_library_tree_runs_to_success(name: str) -> None:
    tree = library_trees()[name]
    behavior = SEAT + EXHIBIT + f'[behavior.events.e]\ntree = "{name}"\n'
    sim = make_sim(agents=[(-3.0, 1.0, "stand"), (3.0, 1.0, "stand")], behavior=behavior, user_start=(0.0, 3.5))
    agents = iter([1, 2])
    values: dict[str, object] = {}
    objects = sim.scheduler.objects
    for p, kind in tree.params.items():
        # an object whose kind has every affordance the tree uses of this parameter
        fit = next(n for n, o in objects.items() if tree.uses.get(p, frozenset()) <= set(o.AFFORDANCES))
        values[p] = {"agent": lambda: next(agents), "user": lambda: 0, "actor": lambda: 0,
                     "point": lambda: (0.0, 0.0), "object": lambda: fit}[kind]()  # noqa: B023
    run = sim.scheduler.start_event("e", values)
    assert step_until(sim, lambda: run.phase == "ended", seconds=45.0), name
    assert sim.scheduler.log[-1]["outcome"] == "succeeded", sim.scheduler.log
    for a in run.agents:
        r = row(sim, a)
        assert not sim.behavior.in_event[r] and np.isnan(sim.behavior.face[r])
        assert sim.body.state.gaze_kind[r] == GAZE_NONE and not sim.body.state.sitting[r]
        assert not sim.body.state.reach_on[r].any()
    assert not sim.scheduler.ctx.owners  # every channel released
    assert sim.summary()["overlaps_over_1cm"] == 0
