"""The door-holding decision network (Huang & Terzopoulos §5, Fig. 10, Tables 2–3).

Four factors feed the network: *Effort* (how much holding pays, from the
distance to the follower, §5.1.1), *Care* (how much the follower is assessed
to need help, from its gender and whether it carries something: Table 3,
§5.1.2), *Kindness* and *Rush* (the holder's personality and state of mind,
assigned per pedestrian from the start, §5.1.3). Each factor's value in
[0, 1] is read as the probability that the binary variable is "true", and the
action distribution is marginalised exactly over the 16 parent combinations::

    P(a) = Σ_{e,c,k,r} P(E=e) P(C=c) P(K=k) P(R=r) · T2[e,c,k,r][a]

with ``T2`` the conditional probability table of Table 2 (rows read Effort,
Care, Kindness; one half for Rush = T, one for Rush = F), reproduced in
:data:`TABLE_2` exactly. The action is the one of maximal probability
(MEU, §5.2), or, when a scene asks for stochastic decisions, a draw from
``P`` with the simulation's generator.

Ties (the marginal of a corner such as Effort = F, Care = T, Kindness = F,
Rush = F gives HOL 0.5 against NH 0.5) are broken toward the action that
costs the holder least: NH, then HOL, then HOF. The paper does not say; this
keeps "a follower beyond 4 m is not held for" true at every factor setting.
"""

from __future__ import annotations

import math

import numpy as np

from pedvr.errors import PedvrError

ACTIONS = ("HOL", "HOF", "NH")
HOL, HOF, NH = 0, 1, 2
TIE_ORDER = (NH, HOL, HOF)  # least effort first (module docstring)

EFFORT_NEAR = 1.0  # m: Effort is 1 below this distance to the follower (§5.1.1)
EFFORT_FAR = 4.0  # m: and 0 above this one, linear between

# Table 2: (Effort, Care, Kindness, Rush) -> (HOL, HOF, NH).
TABLE_2: dict[tuple[bool, bool, bool, bool], tuple[float, float, float]] = {
    # Rush = T
    (True, True, True, True): (0.7, 0.1, 0.2),
    (True, True, False, True): (0.6, 0.1, 0.3),
    (True, False, True, True): (0.7, 0.0, 0.3),
    (True, False, False, True): (0.5, 0.0, 0.5),
    (False, True, True, True): (0.1, 0.0, 0.9),
    (False, True, False, True): (0.1, 0.0, 0.9),
    (False, False, True, True): (0.1, 0.0, 0.9),
    (False, False, False, True): (0.0, 0.0, 1.0),
    # Rush = F
    (True, True, True, False): (0.2, 0.8, 0.0),
    (True, True, False, False): (0.7, 0.2, 0.1),
    (True, False, True, False): (0.9, 0.1, 0.0),
    (True, False, False, False): (0.6, 0.1, 0.3),
    (False, True, True, False): (0.2, 0.1, 0.7),
    (False, True, False, False): (0.5, 0.0, 0.5),
    (False, False, True, False): (0.3, 0.0, 0.7),
    (False, False, False, False): (0.1, 0.0, 0.9),
}

# The same table as an array indexed [e, c, k, r, action] with index 1 = true, for the sum.
_T2 = np.zeros((2, 2, 2, 2, 3))
for (_e, _c, _k, _r), _p in TABLE_2.items():
    _T2[int(_e), int(_c), int(_k), int(_r)] = _p

# Table 3: (female, carrier) -> P(Care = T).
TABLE_3: dict[tuple[bool, bool], float] = {
    (True, True): 1.0,
    (True, False): 1.0,
    (False, True): 1.0,
    (False, False): 0.0,
}


class DecisionInputError(PedvrError, ValueError):
    """A factor given to the decision network is not a probability (or a distance is negative)."""


def _unit(name: str, v: float) -> float:
    x = float(v)
    if not (math.isfinite(x) and 0.0 <= x <= 1.0):
        raise DecisionInputError(f"{name} = {v!r}: expected a probability in [0, 1]")
    return x


def effort_factor(distance_m: float) -> float:
    """Effort (§5.1.1): 1.0 for a follower closer than 1 m, 0.0 beyond 4 m, linear between."""
    d = float(distance_m)
    if not math.isfinite(d) or d < 0.0:
        raise DecisionInputError(f"distance_m = {distance_m!r}: expected a distance >= 0 m")
    if d <= EFFORT_NEAR:
        return 1.0
    if d >= EFFORT_FAR:
        return 0.0
    return (EFFORT_FAR - d) / (EFFORT_FAR - EFFORT_NEAR)


def care_factor(*, follower_female: bool, follower_carrying: bool) -> float:
    """Care (§5.1.2, Table 3): 1.0 for a female follower, carrying or not, and for a male
    carrier; 0.0 for a male follower with empty hands. A perambulator counts as carrying."""
    return TABLE_3[(bool(follower_female), bool(follower_carrying))]


def holding_probabilities(*, effort: float, care: float, kindness: float, rush: float) -> dict[str, float]:
    """``{"HOL": p, "HOF": p, "NH": p}``: the network's marginal over its four parents,
    each factor the probability of "true" (module docstring). The three sum to 1."""
    pe, pc = _unit("effort", effort), _unit("care", care)
    pk, pr = _unit("kindness", kindness), _unit("rush", rush)
    p = _marginal(pe, pc, pk, pr)
    return {name: float(p[i]) for i, name in enumerate(ACTIONS)}


def _marginal(pe: float, pc: float, pk: float, pr: float) -> np.ndarray:
    we = np.array([1.0 - pe, pe])
    wc = np.array([1.0 - pc, pc])
    wk = np.array([1.0 - pk, pk])
    wr = np.array([1.0 - pr, pr])
    return np.einsum("e,c,k,r,eckra->a", we, wc, wk, wr, _T2)


def decide(probabilities: dict[str, float], *, rng: np.random.Generator | None = None) -> str:
    """The action: the most probable (MEU, ties as the module says), or, given ``rng``, one
    drawn from the distribution (one uniform draw)."""
    p = np.array([probabilities[a] for a in ACTIONS])
    if rng is not None:
        u = float(rng.random())
        cum = np.cumsum(p) / p.sum()
        return ACTIONS[min(int(np.searchsorted(cum, u, side="right")), len(ACTIONS) - 1)]
    best = max(TIE_ORDER, key=lambda i: (round(float(p[i]), 12), -TIE_ORDER.index(i)))
    return ACTIONS[best]
