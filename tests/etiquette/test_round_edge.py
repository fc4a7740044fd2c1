"""Walking out of the pocket behind an open leaf (between the leaf and the wall, the pull side)
round its free edge: every leg of the path keeps a body's radius clear of the edge
(:func:`pedvr.etiquette.interaction.round_edge`). The path it replaced went straight from behind
the leaf to a point 25° in front of it, a chord that passed the edge closer than a body's radius;
ORCA's line off the edge held a holder walking through there for 6 s in ``door_single_flow``."""

from __future__ import annotations

import math

import numpy as np

from pedvr.etiquette.interaction import round_edge
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


def test_the_old_chord_cut_past_the_edge() -> None:
    """The set-up of door_single_flow's seed 1: a 1.1 m leaf open 90°, a holder 0.2 m behind it."""
    radius = 0.25
    fr = LeafFrame.of(np.array([0.0, -0.55]), math.pi / 2, 1.1, 1)
    a = math.radians(90.0)
    p = np.array([-1.28, -0.73])
    tip = fr.polar(fr.w, a)
    to = a - math.radians(25.0)
    old = np.stack([p, fr.polar(fr.outer(radius), to)])
    assert _clearance(old, tip) < radius
    new = np.concatenate([p[None], round_edge(fr, p, a, radius, to)])
    assert _clearance(new, tip) >= radius
