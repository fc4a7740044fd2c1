"""The body capabilities the demonstrator adds (pedvr/body/directed.py): a facing held while moving."""

from __future__ import annotations

import math

import pytest

from tests.demonstrator._demo import demo_sim


def _side_step(hold: bool) -> list[float]:
    sim = demo_sim(start=(-5.0, -3.0))
    sim.advance_to(1.0)
    h0 = float(sim.crowd.heading[sim.crowd.index_of(1)])
    left = (-5.0 - 1.0 * math.sin(h0), -3.0 + 1.0 * math.cos(h0))  # 1 m to its left
    if hold:
        sim.body.hold_facing(1, h0)
    sim.body.go_to(1, left, arrive_dist=0.1)
    out = []
    while sim.t < 6.0:
        sim.step()
        out.append(math.degrees((float(sim.crowd.heading[sim.crowd.index_of(1)]) - h0 + math.pi)
                                % (2 * math.pi) - math.pi))
    assert math.dist(sim.crowd.pos[sim.crowd.index_of(1)], left) < 0.15  # it got there
    sim.body.hold_facing(1, None)
    assert sim.body.held_facings.held == {}
    return out


@pytest.mark.parametrize("hold", [True, False])
def test_a_held_facing_side_steps_instead_of_turning(hold: bool) -> None:
    turn = max(abs(x) for x in _side_step(hold))
    assert (turn < 5.0) if hold else (turn > 45.0), turn
