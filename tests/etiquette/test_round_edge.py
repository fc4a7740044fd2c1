"""Walking out of the pocket behind an open leaf (between the leaf and the wall, the pull side)
round its free edge: every leg of the path keeps a body's radius clear of the edge
(:func:`pedvr.etiquette.interaction.round_edge`). The path it replaced went straight from behind
the leaf to a point 25° in front of it, a chord that passed the edge closer than a body's radius;
ORCA's line off the edge held a holder walking through there for 6 s in ``door_single_flow``.

And a body beyond a pulled leaf's free edge, in line with the leaf, walking into the doorway: one
way round the edge, clear of it by the body's radius, whichever side of the leaf's line it stands
(:func:`pedvr.etiquette.interaction.off_the_tip`). A puller stands just beyond the edge it holds;
from there the straight way into the doorway passed the edge closer than a body's radius, and a
holder walking on after handing the door over re-planned between going round the edge and going
straight as it swayed across the leaf's line, and stood at the edge (door_single_flow seed 8:
13 s)."""

from __future__ import annotations

import math

import numpy as np

from pedvr.etiquette.interaction import CLEAR, TIP_BEHIND, TIP_CLEAR, off_the_tip, round_edge
from pedvr.etiquette.regions import LeafFrame


def _clearance(path: np.ndarray, q: np.ndarray) -> float:
    """The least distance from ``q`` to the polyline ``path``."""
    best = math.inf
    for a, b in zip(path[:-1], path[1:], strict=True):
        d = b - a
        t = 0.0 if not d @ d else min(1.0, max(0.0, float((q - a) @ d / (d @ d))))
        best = min(best, float(np.hypot(*(a + t * d - q))))
    return best


def test_the_way_round_a_leaf_keeps_a_body_clear_of_its_edge() -> None:
    radius = 0.25
    rng = np.random.default_rng(3)
    worst = math.inf
    old_cut = 0
    for _ in range(300):
        fr = LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, float(rng.uniform(0.8, 1.2)), 1)
        a = float(rng.uniform(math.radians(30.0), math.radians(95.0)))
        tip = fr.polar(fr.w, a)
        # a body behind the leaf, touching neither it nor the wall: inside the swing, past the leaf
        rho = float(rng.uniform(radius + 0.1, fr.w + radius))
        phi = float(rng.uniform(a + math.radians(8.0), math.radians(175.0)))
        p = fr.polar(rho, phi)
        if _clearance(np.stack([fr.hinge, tip]), p) < radius:
            continue
        to = max(a - math.radians(25.0), math.radians(10.0))
        path = np.concatenate([p[None], round_edge(fr, p, a, radius, to)])
        worst = min(worst, _clearance(path, tip))
        old = np.stack([p, fr.polar(fr.outer(radius), to)])  # the old way: straight to the point in front
        old_cut += _clearance(old, tip) < radius
    assert worst >= radius, worst
    assert old_cut > 0  # the set-ups include ones the old way cut


def _door_single_flow() -> tuple[LeafFrame, float]:
    """door_single_flow's leaf (1.1 m, hinged at the doorway's south jamb) and its held angle, 90°."""
    return LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, 1.1, 1), math.radians(90.0)


def test_the_old_chord_cut_past_the_edge() -> None:
    """The set-up of door_single_flow's seed 1: a 1.1 m leaf open 90°, a holder 0.2 m behind it."""
    radius = 0.25
    fr, a = _door_single_flow()
    p = np.array([-1.28, -0.73])
    tip = fr.polar(fr.w, a)
    to = a - math.radians(25.0)
    old = np.stack([p, fr.polar(fr.outer(radius), to)])
    assert _clearance(old, tip) < radius
    new = np.concatenate([p[None], round_edge(fr, p, a, radius, to)])
    assert _clearance(new, tip) >= radius


def _targets(fr: LeafFrame, radius: float) -> list[np.ndarray]:
    """Where such a body walks on to: into the doorway holding the leaf (HOL), or through it (FinishDoor)."""
    return [fr.world(0.42 * fr.w, -0.05), fr.lane(-(radius + CLEAR + 0.5))]


def test_the_way_off_the_tip_keeps_a_body_clear_of_the_edge() -> None:
    radius = 0.25
    rng = np.random.default_rng(5)
    worst = math.inf
    old_cut = tried = 0
    for _ in range(400):
        fr = LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, float(rng.uniform(0.8, 1.2)), 1)
        a = float(rng.uniform(math.radians(40.0), math.radians(95.0)))
        tip = fr.polar(fr.w, a)
        rho = float(rng.uniform(fr.w + radius, fr.outer(radius) + 0.3))
        phi = float(rng.uniform(a - TIP_CLEAR + 0.01, a + TIP_BEHIND - 0.01))
        p = fr.polar(rho, phi)
        if _clearance(np.stack([fr.hinge, tip]), p) < radius:
            continue  # it would stand in the leaf
        way = off_the_tip(fr, p, a, radius)
        assert way is not None, (a, rho, phi)
        tried += 1
        for target in _targets(fr, radius):
            worst = min(worst, _clearance(np.concatenate([p[None], way, target[None]]), tip))
            old_cut += _clearance(np.stack([p, target]), tip) < radius
    assert tried > 200
    assert worst >= radius, worst
    assert old_cut > 0  # the set-ups include ones the straight way cut


def test_either_side_of_the_leafs_line_goes_the_same_way() -> None:
    """The puller of door_single_flow: a 1.1 m leaf open 90°, the body just beyond its edge."""
    radius = 0.25
    fr, a = _door_single_flow()
    rho = fr.outer(radius)
    ways = [off_the_tip(fr, fr.polar(rho, a + d), a, radius) for d in (math.radians(-5.0), math.radians(3.0))]
    assert all(w is not None for w in ways)
    np.testing.assert_allclose(ways[0][-1], ways[1][-1])
    np.testing.assert_allclose(ways[0][-1], fr.polar(rho, a - TIP_CLEAR))
    # where the puller stands (5° in front of the edge), straight into the doorway cuts past the edge
    p = fr.polar(rho, a - math.radians(5.0))
    assert _clearance(np.stack([p, _targets(fr, radius)[0]]), fr.polar(fr.w, a)) < radius


def test_off_the_tip_leaves_other_ways_alone() -> None:
    radius = 0.25
    fr, a = _door_single_flow()
    rho = fr.outer(radius)
    assert off_the_tip(fr, fr.polar(rho, a - TIP_CLEAR - 0.05), a, radius) is None  # clear in front of it
    assert off_the_tip(fr, fr.polar(rho, a + TIP_BEHIND + 0.05), a, radius) is None  # well behind it
    assert off_the_tip(fr, fr.polar(0.6, a + math.radians(30.0)), a, radius) is None  # in the pocket: round_edge
    assert off_the_tip(fr, fr.world(0.6, -1.0), a, radius) is None  # the push side
