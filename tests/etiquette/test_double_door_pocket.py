"""The way to a double door's leaf from beside its other leaf, held open toward the walker
(issue 26): round that leaf's free edge, not straight into it (:func:`interaction._via`).

``door_double`` with a pram, seed 9: a walker came up beside the wall to the south while the
south leaf stood open 90° toward it, took the north leaf (whose pull-side opening place lies in
front of the south leaf, beyond the north leaf's latch) and walked straight for it: into the pocket
behind the open leaf, where it stood for the opening state's 10 s, twice, the pram waiting behind.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.etiquette.interaction import _segments_apart, _via
from pedvr.etiquette.regions import OUTER_MARGIN
from pedvr.scene.loader import load_any, load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _clearance(path: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The least distance between the polyline ``path`` and the segment ``a``–``b``."""
    return min(_segments_apart(p, q, a, b) for p, q in zip(path[:-1], path[1:], strict=True))


@pytest.fixture(scope="module")
def et():  # type: ignore[no-untyped-def]
    return Simulation(load_scene(resolve_scene("door_double")), seed=1).etiquette


def test_segments_apart() -> None:
    def seg(*xy: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array(xy[:2]), np.array(xy[2:])

    assert _segments_apart(*seg(0.0, 0.0, 2.0, 0.0), *seg(1.0, -1.0, 1.0, 1.0)) == 0.0  # crossing
    assert _segments_apart(*seg(0.0, 0.0, 2.0, 0.0), *seg(0.0, 0.5, 2.0, 0.5)) == pytest.approx(0.5)  # parallel
    assert _segments_apart(*seg(0.0, 0.0, 1.0, 0.0), *seg(2.0, 1.0, 3.0, 1.0)) == pytest.approx(math.sqrt(2.0))


def test_the_way_from_beside_the_other_open_leaf_goes_round_its_edge(et) -> None:  # type: ignore[no-untyped-def]
    radius = 0.25
    south, north = 0, 1  # door_double: hinges at (0, -1) and (0, 1), both pulled toward -x
    fr_s = et.frame(south, -1)
    fr_n = et.frame(north, -1)
    target, _ = fr_n.bop_pull(radius)  # the north leaf's opening place: in front of the south leaf
    assert fr_s.local(target)[0] < fr_s.w  # (beyond the north leaf's latch, over the south leaf's span)
    old = et.leaves.angle[south]
    # beside the wall south of the door: where the walker of seed 9 stood (inside the south leaf's
    # swing circle, for a body) and a step farther out (outside it)
    for p in (np.array([-1.2, -1.6]), np.array([-1.3, -1.7])):
        straight = np.stack([p, target])
        try:
            et.leaves.angle[south] = fr_s.sign * math.radians(90.0)
            tip = fr_s.polar(fr_s.w, math.radians(90.0))
            assert _clearance(straight, fr_s.hinge, tip) < radius  # straight on runs into the open leaf
            way = np.concatenate([p[None], _via(et, fr_n, north, p, radius, target)])
            assert len(way) > 2 and np.allclose(way[-1], target)
            assert _clearance(way, fr_s.hinge, tip) >= radius  # round its edge, a body's radius clear
            et.leaves.angle[south] = 0.0  # closed: straight on
            assert np.allclose(_via(et, fr_n, north, p, radius, target), target[None])
        finally:
            et.leaves.angle[south] = old
    assert math.hypot(*fr_s.local(p)) > fr_s.outer(radius)


def test_the_way_from_behind_an_open_leafs_back_beyond_its_swing_goes_round_its_edge(et) -> None:  # type: ignore[no-untyped-def]
    """Behind a leaf's back beyond its swing circle, the way on into the leaf goes round its edge
    (``beyond``, the doorway behavior's way out of a pocket); one who passes beyond the leaf's
    free edge is left to the steering. The realism bench's double door, ``decoupled``: walkers
    who came along the wall stood packed behind the open south leaf 1.5 m from its hinge."""
    radius = 0.25
    south = 0
    fr = et.frame(south, -1)
    old = et.leaves.angle[south]
    try:
        a = math.radians(87.0)
        et.leaves.angle[south] = fr.sign * a
        tip = fr.polar(fr.w, a)
        out = fr.lane(radius + 1.1)  # where the doorway behavior leads a walker out of the pocket
        for p in (fr.polar(fr.outer(radius) + 0.2, math.radians(150.0)),  # behind the leaf's back
                  fr.polar(fr.outer(radius) + 0.5, math.radians(160.0))):
            assert math.hypot(*fr.local(p)) > fr.outer(radius)  # outside the swing circle
            straight = np.stack([p, out])
            assert _clearance(straight, fr.hinge, tip) < radius  # straight on runs into the leaf
            assert np.allclose(_via(et, fr, south, p, radius, out), out[None])  # as before: straight
            way = np.concatenate([p[None], _via(et, fr, south, p, radius, out, beyond=True)])
            assert len(way) > 2 and np.allclose(way[-1], out)
            assert _clearance(way[1:], fr.hinge, tip) >= radius  # round the edge, a body's radius clear
        # past the leaf's free edge (farther from the hinge along the leaf than it is long, and a
        # radius more), on the wall's side of it, its way on close by the edge: passing the edge
        # is the steering's, not a way round
        beside, on = fr.polar(1.5, math.radians(100.0)), fr.polar(1.2, math.radians(60.0))
        assert float((beside - fr.hinge) @ (tip - fr.hinge)) / fr.w > fr.w + radius
        assert math.hypot(*fr.local(beside)) > fr.outer(radius)
        assert _clearance(np.stack([beside, on]), fr.hinge, tip) < radius + OUTER_MARGIN
        assert np.allclose(_via(et, fr, south, beside, radius, on, beyond=True), on[None])
    finally:
        et.leaves.angle[south] = old


def test_the_realism_double_door_without_coupling_passes_everyone() -> None:
    """``validation/door_double_flow`` at its seed under ``decoupled`` (plain ORCA discs with the
    door etiquette): everyone through in 90 s. Before the way out from behind a leaf's back beyond
    its swing, 26 of 30: from 50 s on walkers stood packed behind the held-open south leaf."""
    sim = Simulation(load_any(resolve_scene("validation/door_double_flow"), seed=None), condition="decoupled")
    sim.advance_to(90.0)
    s = sim.summary()
    assert s["sink_agents_removed"] == 30, s["sink_agents_removed"]
    assert s["overlaps_over_1cm"] == 0
