"""Issue 26, item 3: the single sprung door of ``door_rush`` (20 people from each side, setting off
over 20 s) passes people as a busy door does: a follower whose holder decided NH catches the door
at its edge as the holder walks through, so the door does not swing shut and open again from the
BOP between close followers (:func:`pedvr.etiquette.interaction._catch_nh`), and each side passes
in batches (:func:`pedvr.etiquette.interaction._batch_side`).

Before that change (main at e491b88) seed 1 passed 17 and seed 2 passed 19 of 40 in 90 s, and the
door was opened from shut once for every two passages; the thresholds below are what the change
reaches (29 and 24 with the bench's count from positions), the lower less two, and at least four
passages for each opening (README, "Door and doorway etiquette"). Later rules of issue 26 (the queue
moving up, no opening against someone coming through, the way round a leaf's edge, walking on from
a key one was pushed abreast of) took seeds 1 and 2 from 26 and 26 to 29 and 32; the threshold
is the lower less two. Stop 35 counted a holder still to pass in the batch's run, let batches run
while both queues stand (up to 20), and had the one standing in a committed follower's way go
first (:func:`~pedvr.etiquette.interaction._in_the_way`), and kept a door busy until fewer than
three wait on a side: seeds 1 and 2 pass all 40, opening the door from shut 3 and 2 times; the
threshold is 40 less two. Seed 9 is the far-out crawl of issue 26's change 22: its last five,
who had waited 5-8 m out, passed at 68-84 s, one of them creeping 1.1 m in 38 s as it and the one
behind it swapped places in the queue; with the time in the queue counted while shuffling forward
(change 23, :func:`~pedvr.etiquette.interaction._update_waiting`) the last passes at 74.7 s.
"""

from __future__ import annotations

import pytest

from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

THROUGH_AT_LEAST = 38  # of 40 in 90 s
PASSAGES_PER_OPENING = 4.0  # door_passages / times the door was opened from shut
SEEDS = (1, 2, 9)
CRAWL_SEED, CRAWL_LAST_BY = 9, 79.0  # s: seed 9's last passage (84.4 s before change 23, 74.7 s since)


@pytest.fixture(scope="module")
def rush_runs() -> dict[int, dict[str, object]]:
    out = {}
    for seed in SEEDS:
        sim = Simulation(load_scene(resolve_scene("door_rush")), seed=seed)
        while sim.t < 90.0 - 1e-9:
            sim.step()
        out[seed] = sim.summary()
    return out


@pytest.mark.parametrize("seed", SEEDS)
def test_door_rush_passes_a_chain_of_followers(rush_runs: dict[int, dict[str, object]], seed: int) -> None:
    s = rush_runs[seed]
    events = s["door_events"]
    assert isinstance(events, list)
    opens = sum(1 for e in events if e["event"] == "open")
    passages = s["door_passages"]
    assert isinstance(passages, int)
    assert passages >= THROUGH_AT_LEAST, (seed, passages)
    assert passages >= PASSAGES_PER_OPENING * max(opens, 1), (seed, passages, opens)
    assert s["overlaps_over_1cm"] == 0


def test_nobody_is_left_crawling_in_from_far_out(rush_runs: dict[int, dict[str, object]]) -> None:
    events = rush_runs[CRAWL_SEED]["door_events"]
    assert isinstance(events, list)
    last = max(e["t"] for e in events if e["event"] == "pass" and not e["user"])
    assert last <= CRAWL_LAST_BY, last
