"""The way round a held leaf's free edge passes outside a holder standing beyond it (issue 26,
change 16; :func:`pedvr.etiquette.interaction._round_holder`).

HOF's key pose puts the holder just beyond the open leaf's free edge, on the leaf's back
(:meth:`~pedvr.etiquette.regions.LeafFrame.hold_beyond_tip`). door_single_flow seed 11: a follower
coming along the wall behind the leaf went round the edge between the holder and the leaf, 0.35 m
apart, and stood there from 45 s to 79 s while the holder held for the other side's batch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.etiquette.core import Walker
from pedvr.etiquette.interaction import _round_holder, _segments_apart, _via
from pedvr.etiquette.regions import HOLD_ANGLE
from pedvr.etiquette.vocab import HOLD_DOOR, HOLDER, OPEN_DOOR
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _clearance_to_point(path: np.ndarray, q: np.ndarray) -> float:
    return min(_segments_apart(a, b, q, q) for a, b in zip(path[:-1], path[1:], strict=True))


@pytest.fixture()
def sim() -> Simulation:
    return Simulation(load_scene(resolve_scene("door_rush")), seed=1)  # one single door, 1.1 m


def test_the_way_round_the_edge_passes_outside_the_holder(sim: Simulation) -> None:
    et, crowd = sim.etiquette, sim.crowd
    leaf = et.dstate[0].leaves[0]
    fr = et.frame(leaf, +1)  # door_rush: span (0, -0.55)-(0, 0.55), pulled open from the west
    assert fr.local(np.array([-1.0, 0.0]))[1] > 0.0  # local +y: the pull side
    et.leaves.angle[leaf] = fr.sign * HOLD_ANGLE
    holder, walker = (int(i) for i in crowd.ids[~crowd.is_user][:2])
    hr, wr = et._row[holder], et._row[walker]
    radius = float(crowd.radius[wr])
    crowd.pos[hr] = fr.hold_beyond_tip(HOLD_ANGLE, float(crowd.radius[hr]))[0]
    et.dstate[0].holder[leaf] = holder
    et.walkers[holder] = Walker(id=holder, door=0, side=-1, role=HOLDER, state=HOLD_DOOR)
    # behind the leaf, beside its free edge, on the way to the lane in front of the door
    p = fr.polar(fr.w + 0.05, HOLD_ANGLE + math.radians(15.0))
    crowd.pos[wr] = p
    target = fr.lane(radius + 1.1)
    gap = float(crowd.radius[hr]) + radius
    q = crowd.pos[hr].copy()
    plain = np.concatenate([p[None], _via(et, fr, leaf, p, radius, target)])
    assert len(plain) > 2  # in the pocket: round the edge, as before
    assert _clearance_to_point(plain, q) < gap  # but through the holder
    way = np.concatenate([p[None], _via(et, fr, leaf, p, radius, target, crowd=crowd)])
    assert np.allclose(way[-1], target)
    assert _clearance_to_point(way[1:], q) >= gap  # outside the holder, bodies clear
    # the holder's own way is not widened round itself
    assert _round_holder(et, crowd, leaf, fr, HOLD_ANGLE, q, radius) == 0.0
    # nor anyone's while the leaf is still opening (the puller steps round with its edge, and
    # people in front of a half-open leaf are beyond its angle), or opened less than wide
    et.walkers[holder].state = OPEN_DOOR
    assert _round_holder(et, crowd, leaf, fr, HOLD_ANGLE, p, radius) == 0.0
    et.walkers[holder].state = HOLD_DOOR
    assert _round_holder(et, crowd, leaf, fr, HOLD_ANGLE, p, radius) > fr.outer(radius)
    assert _round_holder(et, crowd, leaf, fr, HOLD_ANGLE - math.radians(30.0), p, radius) == 0.0
    # nor once nobody holds the leaf
    del et.dstate[0].holder[leaf]
    assert np.allclose(_via(et, fr, leaf, p, radius, target, crowd=crowd),
                       _via(et, fr, leaf, p, radius, target))
