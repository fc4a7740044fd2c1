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
the other, only the one further behind follows) 72.2 s (66.3-77.3 s).
Passages are counted
as the benchmark counts them: crossings of the doorway line, here from 0.3 m on one side to
0.3 m on the other.
"""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

SEEDS = tuple(range(1, 9))
EACH_AT_LEAST = 39  # of 40 in 90 s, in every seed
ALL_AT_LEAST = 318  # of 320, over the eight seeds
CROSSED_AGAIN_AT_MOST = 0  # people crossing the doorway more than once, over the eight seeds
LAST_BY_S = 75.5  # the last crossing, on average over the eight seeds (72.2 s; 76.3 s before stop 36)


def _passages(seed: int) -> tuple[int, int, int, float]:
    """Crossings of the doorway line, overlaps over 1 cm, how many crossed more than once, and
    when the last crossing was."""
    sim = Simulation(load_any(resolve_scene("validation/door_single_flow"), seed=None), seed=seed)
    side: dict[int, int] = {}
    times: dict[int, int] = {}
    n = 0
    last = 0.0
    while sim.t < 90.0 - 1e-9:
        sim.step()
        x = sim.crowd.pos[:, 0]
        s = np.where(x > 0.3, 1, np.where(x < -0.3, -1, 0))
        for i, si in zip(sim.crowd.ids.tolist(), s.tolist(), strict=True):
            if si == 0:
                continue
            if side.get(i, si) != si:
                n += 1
                times[i] = times.get(i, 0) + 1
                last = sim.t
            side[i] = si
    again = sum(1 for k in times.values() if k > 1)
    return n, int(sim.summary()["overlaps_over_1cm"]), again, last


@pytest.fixture(scope="module")
def runs() -> dict[int, tuple[int, int, int, float]]:
    return {seed: _passages(seed) for seed in SEEDS}


def test_a_busy_single_door_passes_a_stream(runs: dict[int, tuple[int, int, int, float]]) -> None:
    through = {seed: n for seed, (n, _, _, _) in runs.items()}
    assert min(through.values()) >= EACH_AT_LEAST, through
    assert sum(through.values()) >= ALL_AT_LEAST, through
    assert all(o == 0 for _, o, _, _ in runs.values()), runs


def test_the_stream_is_through_sooner(runs: dict[int, tuple[int, int, int, float]]) -> None:
    """Where a pulled leaf changes hands (``TAKE_STAND``): the last crossing came 76.3 s in on
    average over seeds 1-8, 80.7 s with the take-over spot at the leaf's edge (5°); with the two
    changes of stop 36 (module docstring) 72.9 s."""
    last = {seed: t for seed, (_, _, _, t) in runs.items()}
    assert sum(last.values()) / len(last) <= LAST_BY_S, last


def test_nobody_walks_back_through_the_door(runs: dict[int, tuple[int, int, int, float]]) -> None:
    """A pull-side follower pushed through the doorway before it took the door over walked back
    to the leaf's edge and through again (seed 8; two people over seeds 1-8 crossed twice); and an
    approacher who walked through was sent back to queue from the far side (seed 1). Nobody
    crosses twice now."""
    again = {seed: a for seed, (_, _, a, _) in runs.items()}
    assert sum(again.values()) <= CROSSED_AGAIN_AT_MOST, again
