"""A pedestrian passing first through a held single door, blocked by one of its own side standing in
its way, lets that one pass instead (``interaction._pass_on``, issue 26), as a follower on its way to
take the door over does (``_hand_on``).

Traced in door_single_flow seed 10: one arriving at 1.3 m/s stopped in the doorway's mouth, in front
of a PF follower who had set off; the holder's next follower, on the other side, waited for the PF
one to come through, and nobody passed the door from 21 s to 45 s."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.etiquette.core import Walker
from pedvr.etiquette.interaction import PASS_ON_AFTER, _pass_on
from pedvr.etiquette.vocab import APPROACH, HOLD_DOOR, HOLDER, PASSING
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

WEST, EAST = 1, -1  # door_rush's sides: its span runs south to north, the west room on its left


def _case(*, me: tuple[float, float] = (-0.80, 0.67), other: tuple[float, float] = (-0.73, 0.30),
          speed: float = 0.05, blocked_for: float | None = PASS_ON_AFTER + 0.5,
          scene: str = "door_rush") -> tuple[bool, Walker, Walker, Walker]:
    """The traced set-up: a holder from the east holding the door from the west side (HOF), a
    west-side PF walker at ``me`` moving at ``speed`` (blocked since ``blocked_for`` s, or not yet
    seen blocked: None), and a west-side pedestrian at ``other``."""
    sim = Simulation(load_scene(resolve_scene(scene)), seed=1)
    et, crowd = sim.etiquette, sim.crowd
    assert et is not None
    h_id, w_id, o_id = (int(a) for a in crowd.ids[~crowd.is_user][:3])
    leaf = et.dstate[0].leaves[0]
    for a, p in ((h_id, (-0.85, 0.01)), (w_id, me), (o_id, other)):
        crowd.pos[et._row[a]] = p
        crowd.vel[et._row[a]] = 0.0
    crowd.vel[et._row[w_id]] = (speed, 0.0)
    h = Walker(id=h_id, door=0, side=EAST, role=HOLDER, state=HOLD_DOOR, leaf=leaf, action="HOF",
               follower=-1)
    h.frame = et.frame(leaf, EAST)
    et.dstate[0].holder[leaf] = h_id
    w = Walker(id=w_id, door=0, side=WEST, role=PASSING, leaf=leaf, holder=h_id, leader=h_id)
    o = Walker(id=o_id, door=0, side=WEST, role=APPROACH, leaf=leaf, leader=-1)
    for x in (h, w, o):
        et.walkers[x.id] = x
    et.t = 22.0
    if blocked_for is not None:
        w.blocked_since = et.t - blocked_for
    done = _pass_on(et, w, h, {x.id: x for x in (h, w, o)}, crowd)
    return done, h, w, o


def test_the_one_in_the_way_passes_instead() -> None:
    done, h, w, o = _case()
    assert done
    assert o.role == PASSING and o.holder == h.id and o.plan is not None
    # its way ends beyond the doorway, on the east side
    assert float(o.plan[-1][0]) > 0.5
    assert w.role == APPROACH and w.holder == -1 and w.plan is None


def test_blocked_for_a_moment_is_not_blocked() -> None:
    done, h, w, o = _case(blocked_for=None)  # first seen blocked: the clock starts
    assert not done and w.blocked_since == 22.0 and w.role == PASSING
    done, h, w, o = _case(blocked_for=PASS_ON_AFTER - 0.5)
    assert not done and w.role == PASSING and o.role == APPROACH
    done, h, w, o = _case(speed=0.5)  # moving again: the clock stops
    assert not done and np.isnan(w.blocked_since)


@pytest.mark.parametrize("case", ["walking", "in_doorway", "side_by_side", "nobody_ahead"])
def test_who_keeps_passing(case: str) -> None:
    kw: dict[str, object] = {
        "walking": {"speed": 0.5},
        "in_doorway": {"me": (-0.15, 0.2), "other": (-0.05, 0.1)},
        "side_by_side": {"other": (-0.70, 0.78)},
        "nobody_ahead": {"other": (-1.6, 1.2)},
    }[case]  # type: ignore[assignment]
    done, h, w, o = _case(**kw)  # type: ignore[arg-type]
    assert not done
    assert w.role == PASSING and o.role == APPROACH


def test_not_at_a_double_door() -> None:
    sim = Simulation(load_scene(resolve_scene("door_double")), seed=1)
    assert sim.etiquette is not None
    assert sim.scene.world.doors[0].kind == "double"
    et, crowd = sim.etiquette, sim.crowd
    h_id, w_id, o_id = (int(a) for a in crowd.ids[~crowd.is_user][:3])
    leaf = et.dstate[0].leaves[0]
    ds = et.dstate[0]
    c, n = ds.centre, ds.n
    crowd.pos[et._row[w_id]] = c + 1.0 * n
    crowd.pos[et._row[o_id]] = c + 0.6 * n
    crowd.vel[et._row[w_id]] = 0.0
    h = Walker(id=h_id, door=0, side=-1, role=HOLDER, state=HOLD_DOOR, leaf=leaf, action="HOF")
    h.frame = et.frame(leaf, -1)
    ds.holder[leaf] = h_id
    w = Walker(id=w_id, door=0, side=1, role=PASSING, leaf=leaf, holder=h_id, blocked_since=0.0)
    et.t = 10.0
    o = Walker(id=o_id, door=0, side=1, role=APPROACH, leaf=leaf)
    assert not _pass_on(et, w, h, {x.id: x for x in (h, w, o)}, crowd)
    assert np.isfinite(crowd.pos).all()
