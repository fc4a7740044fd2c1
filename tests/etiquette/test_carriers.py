"""No carrier left behind (issue 24 item 4, issue 26): a perambulator pusher waiting at a double door gets
through. Before the fix, holders in turn held the door for it and gave up, and in seed 5 of this set-up it
was still on its side after 90 s."""

from __future__ import annotations

import dataclasses

import numpy as np

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


def _through_at(seed: int) -> tuple[float | None, int]:
    """When the pram's pusher got past the door line (None: not in 90 s), and the run's overlaps."""
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
    return through_at, int(sim.summary()["overlaps_over_1cm"])


def test_a_pram_at_a_double_door_gets_through() -> None:
    """Seeds 0-9: at least 8 prams through in 90 s, none overlapping anyone. Issue 26's crowd model
    passed 7 before a pusher steered past keys beside it and kept its course against a shove
    (``Simulation._pram_keeps_its_course``); main before that model passed 8 (not the same 8).
    Not every pram gets through yet: over seeds 0-19, 19 of 20 on stop 37's code (seed 9: a pusher
    alone at the pull side frees a hand and opens a leaf itself, and its pram stands in the leaf's
    swing; main before stop 37 also 19, seed 1 left), 16 on an earlier machine and code; 19 of 20
    since issue 26's change 15 (seed 9 through; seed 17 left, the same way as seed 9 was)
    (bench/door_observations.py ``--only pram`` measures it)."""
    results = {seed: _through_at(seed) for seed in range(10)}
    stuck = [s for s, (t, _) in results.items() if t is None]
    assert len(stuck) <= 2, f"prams still on their side after 90 s in seeds {stuck}"
    assert all(o == 0 for _, o in results.values()), results
