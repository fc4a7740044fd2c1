"""Issue 26, change 23: the time a pedestrian has waited at a door, Alg. 1's ``t_wait``
(:func:`pedvr.etiquette.interaction._update_waiting`).

It grows while the pedestrian stands waiting and, at a single door, once it has stood there,
while it moves up slower than :data:`~pedvr.etiquette.interaction.CRAWL_SPEED`. Counted only while
standing, the one who shuffled forward lost its place in the queue to the one who stood, and the
two swapped places every tick (door_rush seed 9: the last five passed at 68-84 s). The whole-scene
effect is guarded by ``test_door_rush.py`` and ``test_door_flow.py``.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from pedvr.etiquette import interaction as it
from pedvr.etiquette.core import Walker
from pedvr.etiquette.vocab import APPROACH, FOLLOWER, HOLDER

SECONDS = 3.0


def _waited_after(w: Walker, speed: float, *, kind: str = "single") -> float:
    """``w.waited`` after :data:`SECONDS` of ticks at ``speed`` (m/s) at a door of ``kind``."""
    et = SimpleNamespace(_row={w.id: 0}, doors=[SimpleNamespace(kind=kind)], t=0.0)
    crowd = SimpleNamespace(vel=np.array([[speed, 0.0]]))
    for _ in range(round(SECONDS / it.TICK)):
        it._update_waiting(et, [w], crowd)  # type: ignore[arg-type]
        et.t += it.TICK
    return w.waited


def _approacher(*, waited: float = 0.0, waiting: bool = False, role: int = APPROACH) -> Walker:
    return Walker(id=7, door=0, side=-1, role=role, waited=waited, waiting=waiting)


@pytest.mark.parametrize("role", [APPROACH, FOLLOWER])
def test_standing_at_the_door_counts(role: int) -> None:
    assert _waited_after(_approacher(waiting=True, role=role), 0.05) == pytest.approx(SECONDS)


def test_moving_up_slowly_after_standing_still_counts() -> None:
    """The crawl of door_rush seed 9: released by its leader it shuffles forward, below half a
    walking pace; it keeps its place in the queue while it does."""
    w = _approacher(waited=4.0)
    assert _waited_after(w, 0.4) == pytest.approx(4.0 + SECONDS)


@pytest.mark.parametrize(("case", "speed", "kind", "waited"), [
    ("walking up the queue", 0.7, "single", 4.0),
    ("not yet stood at the door", 0.3, "single", 0.0),
    ("at a double door", 0.3, "double", 4.0),
])
def test_what_does_not_count(case: str, speed: float, kind: str, waited: float) -> None:
    assert _waited_after(_approacher(waited=waited), speed, kind=kind) == pytest.approx(waited), case


def test_holders_and_the_user_do_not_wait() -> None:
    holder = _approacher(waited=2.0, waiting=True, role=HOLDER)
    assert _waited_after(holder, 0.0) == pytest.approx(2.0)
    user = _approacher(waited=2.0, waiting=True)
    user.is_user = True
    assert _waited_after(user, 0.0) == pytest.approx(2.0)
