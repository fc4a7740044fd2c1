"""A pushed pram at a door (issue 26, "no carrier left behind"): it pursues a point along its keys
instead of each key (``system.pursuit_point``), lines up with its leaf's lane out of the leaf's swing
before it passes (``interaction._pf_points``, ``_line_up``), and backs off a leaf it is wedged
against (``Simulation._prams_back_out``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.etiquette.interaction import _line_up_out, _pf_points
from pedvr.etiquette.regions import LeafFrame
from pedvr.etiquette.system import pursuit_point
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import PRAM_BACK_AFTER, PRAM_BACK_S, PRAM_BACK_SPEED, Simulation

PLAN = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])


def test_pursuit_aims_a_look_ahead_along_the_keys() -> None:
    """Beside its keys, a pusher aims at the point ``look`` on from the nearest point of them, not
    at the key abeam; near the end, at the last key; never back before its current key."""
    k, target = pursuit_point(PLAN, 0, np.array([0.5, 0.3]), 1.0)
    assert k == 1
    np.testing.assert_allclose(target, [1.5, 0.0])
    k, target = pursuit_point(PLAN, 0, np.array([2.8, 0.1]), 1.0)
    assert k == 3
    np.testing.assert_allclose(target, PLAN[3])
    k, target = pursuit_point(PLAN, 2, np.array([0.5, 0.0]), 0.5)
    assert k == 2
    np.testing.assert_allclose(target, [2.5, 0.0])


# the lower leaf of a double door spanning x = 0, y in [-1, 1], pulled from x < 0
FRAME = LeafFrame.of(np.array([0.0, -1.0]), math.pi / 2, 0.97, 1)


def test_a_pram_lines_up_out_of_the_swing() -> None:
    """A walker's way through is unchanged; a pram (its front 0.98 m beyond its disc) standing
    farther out first walks to the lane point from which its front clears the leaf's swing, and
    one already nearer the door does not walk back to it."""
    walker = _pf_points(FRAME, 1, 0.25)
    assert walker.shape == (3, 2)
    far = np.array([-3.5, -0.2])
    pram = _pf_points(FRAME, 1, 0.4, reach=0.98, at=far)
    assert pram.shape == (4, 2)
    out = _line_up_out(FRAME, 0.4, 0.98)
    assert out - 0.98 >= FRAME.w + 0.4  # the pusher's disc is out of the swing, and its front with it
    np.testing.assert_allclose(pram[0], FRAME.lane(out))
    np.testing.assert_allclose(pram[1:], _pf_points(FRAME, 1, 0.4))
    near = np.array([-1.5, -0.4])
    assert _pf_points(FRAME, 1, 0.4, reach=0.98, at=near).shape == (3, 2)


def _pram_at_double_door() -> Simulation:
    s = load_any(resolve_scene("door_double"), seed=None)
    import dataclasses

    walker = s.profiles["walker"]
    prof = dataclasses.replace(walker, name="pram", radius=0.4, pref_speed=1.0, max_speed=1.4,
                               carrying="perambulator")
    pram = dataclasses.replace(s.spawns[0], profile="pram", state="east", positions=((-1.3, -0.45),), count=0,
                               region=None, facing=0.0)
    return Simulation(dataclasses.replace(s, profiles={**s.profiles, "pram": prof}, spawns=(pram,)), seed=1)


@pytest.mark.parametrize("against", [True, False])
def test_a_wedged_pram_backs_out(against: bool) -> None:
    """A pram stuck for PRAM_BACK_AFTER with its front against a leaf (the lower leaf half open onto
    it) is steered straight back along its heading for PRAM_BACK_S; one stuck as long in the open
    is left to the other remedies."""
    sim = _pram_at_double_door()
    row = int(np.flatnonzero(sim.crowd.length > 0.0)[0])
    if not against:
        sim.crowd.pos[row] = [-4.0, -2.0]
    sim.doors.angle[0] = 0.75  # the lower leaf (hinge (0, -1)) swung back onto the pram's front
    assert (sim._leaf_depth(sim.crowd.pos, sim.crowd.heading, margin=0.05)[row] > 0.0) == against
    sim.stuck_time[row] = PRAM_BACK_AFTER
    pref = np.zeros((len(sim.crowd), 2))
    pref[row] = [1.0, 0.0]
    out = sim._prams_back_out(pref)
    if not against:
        np.testing.assert_array_equal(out, pref)
        assert sim.backing[row] == 0.0
        return
    h = float(sim.crowd.heading[row])
    np.testing.assert_allclose(out[row], -PRAM_BACK_SPEED * np.array([math.cos(h), math.sin(h)]))
    assert sim.stuck_time[row] == 0.0
    steps = 1
    while sim.backing[row] > 0.0:
        sim._prams_back_out(pref)
        steps += 1
    assert steps == pytest.approx(PRAM_BACK_S / sim.dt, abs=1)
