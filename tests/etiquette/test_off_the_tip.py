"""A body beyond a pulled leaf's free edge, in line with the leaf, walking into the doorway: one way
round the edge, clear of it by the body's radius, whichever side of the leaf's line it stands
(:func:`pedvr.etiquette.interaction.off_the_tip`). A puller stands just beyond the edge it holds;
from there the straight way into the doorway passed the edge closer than a body's radius, and a
holder walking on after handing the door over re-planned between going round the edge and going
straight as it swayed across the leaf's line, and stood at the edge (door_single_flow seed 8:
13 s)."""

from __future__ import annotations

import math

import numpy as np

from pedvr.etiquette.interaction import CLEAR, TIP_BEHIND, TIP_CLEAR, off_the_tip
from pedvr.etiquette.regions import LeafFrame


def _clearance(path: np.ndarray, q: np.ndarray) -> float:
    """The least distance from ``q`` to the polyline ``path``."""
    best = math.inf
    for a, b in zip(path[:-1], path[1:], strict=True):
        d = b - a
        t = 0.0 if not d @ d else min(1.0, max(0.0, float((q - a) @ d / (d @ d))))
        best = min(best, float(np.hypot(*(a + t * d - q))))
    return best


def _targets(fr: LeafFrame, radius: float) -> list[np.ndarray]:
    """Where such a body walks on to: into the doorway holding the leaf (HOL), or through it (FinishDoor)."""
    return [fr.world(0.42 * fr.w, -0.05), fr.lane(-(radius + CLEAR + 0.5))]


def test_the_way_round_keeps_a_body_clear_of_the_edge() -> None:
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
    fr = LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, 1.1, 1)
    a = math.radians(90.0)
    rho = fr.outer(radius)
    ways = [off_the_tip(fr, fr.polar(rho, a + d), a, radius) for d in (math.radians(-5.0), math.radians(3.0))]
    assert all(w is not None for w in ways)
    np.testing.assert_allclose(ways[0][-1], ways[1][-1])
    np.testing.assert_allclose(ways[0][-1], fr.polar(rho, a - TIP_CLEAR))
    # where the puller stands (5° in front of the edge), straight into the doorway cuts past the edge
    p = fr.polar(rho, a - math.radians(5.0))
    assert _clearance(np.stack([p, _targets(fr, radius)[0]]), fr.polar(fr.w, a)) < radius


def test_elsewhere_it_leaves_the_way_alone() -> None:
    radius = 0.25
    fr = LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, 1.1, 1)
    a = math.radians(90.0)
    rho = fr.outer(radius)
    assert off_the_tip(fr, fr.polar(rho, a - TIP_CLEAR - 0.05), a, radius) is None  # clear in front of it
    assert off_the_tip(fr, fr.polar(rho, a + TIP_BEHIND + 0.05), a, radius) is None  # well behind it
    assert off_the_tip(fr, fr.polar(0.6, a + math.radians(30.0)), a, radius) is None  # in the pocket: round_edge
    assert off_the_tip(fr, fr.world(0.6, -1.0), a, radius) is None  # the push side
