"""Issue 26, item 3: a busy single door passes a stream (``validation/door_single_flow``: 20 people
from each side arriving over 20 s at a 1.1 m sprung door, the realism benchmark's case).

Two rules of :mod:`pedvr.etiquette.interaction` carry it, on top of the busy-door rules that
``test_door_rush.py`` guards: the next in a queue moves up into the committed follower's place as
soon as that follower walks to the leaf's edge, so it is closed up when the door changes hands;
and nobody starts opening the door while someone passes the other way (a holder walking through
after letting go included), where before the two met head-on in the doorway and stood for seconds.
Before them (h-lead-model at e019491) seeds 1-3 passed 27, 28 and 21 of 40 in 90 s; with them 29,
28 and 31; and 33, 33 and 29 once a holder walking through from behind the open leaf goes round
its edge clear of it and a body pushed abreast of its next key walks on to the one after
(:func:`~pedvr.etiquette.interaction.round_edge`, ``DoorEtiquette.steer``). With coupled ORCA's
dense slack on by default (``[steering] dense_slack``; none for those in a door's etiquette,
``DoorEtiquette.at_doors``) seeds 1-3 pass 32, 30 and 28; over seeds 1-8 the slack passes 229
against 232 without it (25-33 a seed either way), so the sum over these three was held at 88.
With the body's acceleration limit at 2.2 m/s² (issue 26, change 10) seeds 1-8 pass 244 (30, 21,
32, 34, 33, 32, 30, 32) against 234 before it (35, 27, 28, 21, 27, 34, 31, 31): more in all, but
seed 2 now passes 21 where seed 4 did before, so three seeds no longer tell the door's pace; the
test took all eight and held their sum at 232 and every seed at 20. Stop 35's three busy-door
rules (a holder still to pass counts in the batch's run, batches of up to 20 while both queues
stand, and the one standing in a committed follower's way goes first; ``test_busy_door.py``) took
seeds 1-8 to 312 (38, 40, 39, 36, 40, 40, 37, 42; 42 because a follower pushed over the line
before taking the door over walked back to it, and each crossing counts), and the test holds the
sum at 300 and every seed at 34. Then a door stays busy until fewer than three wait on a side
(five make it busy, as before): 323 (42, 40, 39, 40, 40, 40, 40, 42), held at 315 and 37. A
pull-side follower pushed through the doorway before it took the door over now walks on instead
of back to the leaf: 321 (42, 40, 39, 40, 40, 40, 40, 40; seed 1's 42 is someone pushed back
through the doorway by the other side's stream, who then passed again). With a pulled leaf taken
over 15° round from its edge (``TAKE_STAND``): 322 (42, 40, 40, 40, 40, 40, 40, 40), the last
crossing 76.3 s in on average against 80.7 s. Stop 36: seed 1's 42 was not pushed back; it
walked through as an approacher (its holder let the door go, NH), was then taken for someone
coming from the far side, and sent back through the door to queue (``DoorEtiquette._engage``: a
leg's door counts only while the agent is on the side the leg starts from); and a follower
blocked on its way to take the door over hands it on to the one in its way (``_hand_on``): 320
(40 in every seed), nobody crossing twice, the last crossing 72.9 s in on average (range
66.3-77.9 s) against 76.3 s; with the headway's change of the same stop (of two each ahead of
the other, only the one further behind follows) 72.2 s (66.3-77.3 s). Issue 26's change 21: a
holder held back on its way into the doorway turns toward it, and a puller beyond the leaf's edge
goes round it one way: 68.0 s (63.4-75.1 s) against 69.4 s (63.7-77.4 s) on stop 44's code, 40
in every seed, and no holder done holding takes longer than 12.6 s to cross (20.9 and 20.6 s
before, seeds 3 and 6). Change 23 (the time in the queue counts while one shuffles forward,
:func:`~pedvr.etiquette.interaction._update_waiting`): 65.0 s (62.2-68.6 s), 40 in every seed,
no holder done holding longer than 10.2 s.
Passages are counted
as the benchmark counts them: crossings of the doorway line, here from 0.3 m on one side to
0.3 m on the other.
"""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.etiquette.vocab import FINISH_DOOR, HOLDER
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

SEEDS = tuple(range(1, 9))
EACH_AT_LEAST = 39  # of 40 in 90 s, in every seed
ALL_AT_LEAST = 318  # of 320, over the eight seeds
CROSSED_AGAIN_AT_MOST = 0  # people crossing the doorway more than once, over the eight seeds
AFTER_HOLDING_S = 16.0  # the longest a holder done holding takes to cross, in any seed
LAST_BY_S = 67.0  # the last crossing, on average over the eight seeds (65.0 s; 68.0 s before change 23)


def _passages(seed: int) -> tuple[int, int, int, float, float]:
    """Crossings of the doorway line, overlaps over 1 cm, how many crossed more than once, when
    the last crossing was, and the longest a holder took to cross after it was done holding
    (FinishDoor) while still on its own side."""
    sim = Simulation(load_any(resolve_scene("validation/door_single_flow"), seed=None), seed=seed)
    et = sim.etiquette
    assert et is not None
    side: dict[int, int] = {}
    times: dict[int, int] = {}
    done_at: dict[int, float] = {}
    n = 0
    last = 0.0
    after_holding = 0.0
    while sim.t < 90.0 - 1e-9:
        sim.step()
        for w in et.walkers.values():
            if w.role == HOLDER and w.state == FINISH_DOOR and w.id not in times:
                done_at.setdefault(w.id, sim.t)
        x = sim.crowd.pos[:, 0]
        s = np.where(x > 0.3, 1, np.where(x < -0.3, -1, 0))
        for i, si in zip(sim.crowd.ids.tolist(), s.tolist(), strict=True):
            if si == 0:
                continue
            if side.get(i, si) != si:
                n += 1
                times[i] = times.get(i, 0) + 1
                last = sim.t
                if i in done_at:
                    after_holding = max(after_holding, sim.t - done_at.pop(i))
            side[i] = si
    again = sum(1 for k in times.values() if k > 1)
    after_holding = max([after_holding, *(sim.t - t for t in done_at.values())])  # never crossed
    return n, int(sim.summary()["overlaps_over_1cm"]), again, last, after_holding


@pytest.fixture(scope="module")
def runs() -> dict[int, tuple[int, int, int, float, float]]:
    return {seed: _passages(seed) for seed in SEEDS}


def test_a_busy_single_door_passes_a_stream(runs: dict[int, tuple[int, int, int, float, float]]) -> None:
    through = {seed: n for seed, (n, _, _, _, _) in runs.items()}
    assert min(through.values()) >= EACH_AT_LEAST, through
    assert sum(through.values()) >= ALL_AT_LEAST, through
    assert all(o == 0 for _, o, _, _, _ in runs.values()), runs


def test_the_stream_is_through_sooner(runs: dict[int, tuple[int, int, int, float, float]]) -> None:
    """Where a pulled leaf changes hands (``TAKE_STAND``): the last crossing came 76.3 s in on
    average over seeds 1-8, 80.7 s with the take-over spot at the leaf's edge (5°); with the two
    changes of stop 36 (module docstring) 72.9 s."""
    last = {seed: t for seed, (_, _, _, t, _) in runs.items()}
    assert sum(last.values()) / len(last) <= LAST_BY_S, last


def test_nobody_walks_back_through_the_door(runs: dict[int, tuple[int, int, int, float, float]]) -> None:
    """A pull-side follower pushed through the doorway before it took the door over walked back
    to the leaf's edge and through again (seed 8; two people over seeds 1-8 crossed twice); and an
    approacher who walked through was sent back to queue from the far side (seed 1). Nobody
    crosses twice now."""
    again = {seed: a for seed, (_, _, a, _, _) in runs.items()}
    assert sum(again.values()) <= CROSSED_AGAIN_AT_MOST, again


def test_a_holder_done_holding_walks_on_through(runs: dict[int, tuple[int, int, int, float, float]]) -> None:
    """A puller who held the door and walked on into the doorway (HOL), done holding, stood at the
    leaf's edge: the body turned toward where it drifted, and its way re-planned between round the
    edge and straight on as it swayed across the leaf's line (seed 3: 20.9 s, seed 6: 20.6 s, before
    ``DoorEtiquette._held_back`` and :func:`~pedvr.etiquette.interaction.off_the_tip`; now 12.6 s
    at most, seed 1, and 4.3-9.8 s in the other seeds; the one traced, seed 8's 9.8 s, waited for
    followers of its own side streaming past it through the held door)."""
    longest = {seed: round(h, 1) for seed, (_, _, _, _, h) in runs.items()}
    assert max(longest.values()) <= AFTER_HOLDING_S, longest
