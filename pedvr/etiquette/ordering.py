"""Doorway ordering: who follows whom (Huang & Terzopoulos §4.2, Alg. 1; §4.5.2, Alg. 3–4).

Pure functions over the pedestrians taking part in one door's ordering, given as
:class:`Candidate` records. They are re-evaluated at the decision rate (30 Hz), so followers may
change until the holder reaches the critical motion phase; the state machine
(:mod:`pedvr.etiquette.interaction`) then commits them.

Proximity. Alg. 1 "competes" by proximity to a leader evaluated as ``E(d_leader, t_wait)``;
pedvr takes ``E = d_leader - wait_credit * t_wait`` (smaller is more proximal): each second a
pedestrian has waited counts as ``wait_credit`` metres closer, so that waiting time counts (the
paper names the function, not its form). Alg. 3–4 rank pedestrians "prior to me" by the same
``E`` against the door.

Across the doorway (a pedestrian whose leader is a holder or a follower competes with the other
side's pedestrians, or one with nobody ahead on its side takes the other side's follower as its
leader) the competition is by ``E`` to the doorway, ``d_door - wait_credit * t_wait``: the
holder's body stands outside the swing on its own side, so proximity to it would favour the
holder's own queue and groups arriving together would never interleave (§6.1 observes that they
do). This is pedvr's reading of Alg. 1 across the door.

Double doors (Alg. 3–4): a pedestrian's passing side is one of the two leaves. Alg. 4 has a
pedestrian with an opposite-side pedestrian prior to it adopt that pedestrian's passing side; read
literally, two people meeting at a free double door would queue through one leaf, and §6.3 /
Fig. 15(a) observe a two-way flow through the two right-hand doors instead. pedvr's choice: an
opposite-side leader whose passing side is not mine, while my keep-side leaf is free, is no
leader of mine (each passes its own door); otherwise its side is adopted. "The right-hand
door" is the leaf on the pedestrian's ``keep`` side as it walks through (configurable:
``[etiquette] keep``); a leaf is *free* when nobody holds it, waits for it or walks to it; a
leader's passing side is adopted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pedvr.etiquette.vocab import NONE

__all__ = ["NONE", "Candidate", "DoubleDoor", "choose_side", "initial_leader", "leaders", "proximity"]


@dataclass
class Candidate:
    """A pedestrian in one door's ordering: ``id``, ``pos`` (x, y), the ``side`` (+1 / -1) it
    comes from, ``d_door`` (m to the door), ``waited`` (s), ``holder`` / ``follower`` (its role
    now), ``critical`` (a holder past the critical motion phase), ``leaf`` (its passing side at a
    double door, -1 undecided), ``skip`` (ids it does not take as a leader: a friend walking
    beside it, a carrier it overtakes to help)."""

    id: int
    pos: tuple[float, float]
    side: int
    d_door: float
    waited: float = 0.0
    holder: bool = False
    follower: bool = False
    critical: bool = False
    leaf: int = -1
    skip: frozenset[int] = field(default_factory=frozenset)


def _dist(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def proximity(c: Candidate, to: tuple[float, float], wait_credit: float) -> float:
    """``E(d, t_wait)``: distance to ``to`` less the credit for time waited (module docstring)."""
    return _dist(c.pos, to) - wait_credit * c.waited


def initial_leader(me: Candidate, everyone: list[Candidate]) -> Candidate | None:
    """The closest pedestrian to the front of ``me``: on its side and closer to the door."""
    best, best_d = None, math.inf
    for c in everyone:
        if c.id == me.id or c.side != me.side or c.d_door >= me.d_door or c.id in me.skip:
            continue
        d = _dist(c.pos, me.pos)
        if d < best_d:
            best, best_d = c, d
    return best


def _compete(me: Candidate, leader: Candidate, rivals: list[Candidate], wait_credit: float) -> Candidate:
    """Among ``rivals`` more proximal to ``leader`` than ``me``, the least proximal; else ``leader``."""
    mine = proximity(me, leader.pos, wait_credit)
    closer = [(proximity(r, leader.pos, wait_credit), r.id, r) for r in rivals
              if r.id != me.id and r.id != leader.id and proximity(r, leader.pos, wait_credit) < mine]
    if not closer:
        return leader
    return max(closer, key=lambda t: (t[0], -t[1]))[2]


def _compete_across(me: Candidate, leader: Candidate, rivals: list[Candidate],
                    wait_credit: float) -> Candidate:
    """:func:`_compete` against the other side's pedestrians, by ``E`` to the doorway: who passes
    after a holder or its follower is whoever is nearer the doorway (less the credit for waiting),
    not nearer the holder's body, which stands outside the swing on its own side (module docstring)."""
    mine = me.d_door - wait_credit * me.waited
    closer = [(r.d_door - wait_credit * r.waited, r.id, r) for r in rivals
              if r.id != me.id and r.id != leader.id and r.d_door - wait_credit * r.waited < mine]
    if not closer:
        return leader
    return max(closer, key=lambda t: (t[0], -t[1]))[2]


def leaders(everyone: list[Candidate], *, wait_credit: float) -> dict[int, int]:
    """Alg. 1 for every pedestrian that is neither holder nor follower: ``{id: leader id}``
    (``NONE``: no leader). Cycles (two pedestrians leading each other, which Alg. 1 does not
    rule out across the door) are broken at the one nearer the door, which then leads."""
    by_id = {c.id: c for c in everyone}
    initial = {c.id: initial_leader(c, everyone) for c in everyone}
    out: dict[int, int] = {}
    for me in everyone:
        if me.holder or me.follower:
            continue
        init = initial[me.id]
        if init is not None:
            sharing = [c for c in everyone if c.side == me.side and initial[c.id] is not None
                       and initial[c.id].id == init.id and c.id != me.id]  # type: ignore[union-attr]
            leader = _compete(me, init, sharing, wait_credit) if sharing else init
            if leader.holder or leader.follower:
                opposite = [c for c in everyone if c.side != me.side and not c.holder and not c.follower]
                leader = _compete_across(me, leader, opposite, wait_credit)
            out[me.id] = leader.id
            continue
        opposing = [c for c in everyone if c.side != me.side and (c.follower or c.holder)]
        if opposing:
            followers = [c for c in opposing if c.follower]
            init = min(followers or opposing, key=lambda c: (c.d_door, c.id))
            rivals = [c for c in everyone if c.side != me.side and not c.holder and not c.follower]
            out[me.id] = _compete_across(me, init, rivals, wait_credit).id
            continue
        out[me.id] = NONE
    # Break cycles: follow each chain; a pedestrian met twice closes a cycle.
    for start in list(out):
        seen: list[int] = []
        cur = start
        while cur in out and out[cur] != NONE and cur not in seen:
            seen.append(cur)
            cur = out[cur]
        if cur in seen:
            loop = seen[seen.index(cur):]
            front = min(loop, key=lambda i: (by_id[i].d_door, i))
            out[front] = NONE
    return out


# -- double doors: Alg. 3 and 4 -------------------------------------------------------------------


@dataclass(frozen=True)
class DoubleDoor:
    """What Alg. 3–4 need about a double door now: per leaf (0, 1) whether it is free, how
    many pedestrians use it (held, waited for, walked to), and which leaf is on the ``keep``
    side for a pedestrian coming from side +1 (the other one for side -1)."""

    free: tuple[bool, bool]
    load: tuple[int, int]
    keep_leaf_for_plus: int

    def keep_leaf(self, side: int) -> int:
        return self.keep_leaf_for_plus if side > 0 else 1 - self.keep_leaf_for_plus


LOAD_MARGIN = 2  # pedestrians: a leaf this much busier than the other counts as congested (§6.3)


def choose_side(me: Candidate, everyone: list[Candidate], door: DoubleDoor, *, in_region: bool,
                wait_credit: float) -> tuple[int, int]:
    """Alg. 3 with Alg. 4: ``(leader id or NONE, leaf)``. A returned leader's leaf is adopted."""
    by_id = {c.id: c for c in everyone}
    same_before = sorted((c for c in everyone if c.side == me.side and c.id != me.id and c.id not in me.skip
                          and c.d_door < me.d_door), key=lambda c: _dist(c.pos, me.pos))
    init = same_before[0] if same_before else None
    if len(same_before) > 2 or (len(same_before) == 2 and not in_region):
        assert init is not None
        return init.id, _leaf_of(init, me, door)
    leader, leaf = _alg4(me, init, everyone, door, wait_credit)
    if leader != NONE:
        theirs = _leaf_of(by_id[leader], me, door)
        keep = door.keep_leaf(me.side)
        if by_id[leader].side != me.side and theirs != keep and door.free[keep]:
            return NONE, keep  # Fig. 15(a): they pass their door, I pass mine (both keep right)
        return leader, theirs
    return NONE, leaf


def _leaf_of(leader: Candidate, me: Candidate, door: DoubleDoor) -> int:
    return leader.leaf if leader.leaf >= 0 else _preferred(me, door)


def _preferred(me: Candidate, door: DoubleDoor) -> int:
    """The keep-side door, unless it is congested and the other is not (§6.3: the freer door)."""
    keep = door.keep_leaf(me.side)
    other = 1 - keep
    if door.load[keep] - door.load[other] >= LOAD_MARGIN:
        return other
    return keep


def _alg4(me: Candidate, init: Candidate | None, everyone: list[Candidate], door: DoubleDoor,
          wait_credit: float) -> tuple[int, int]:
    e_me = me.d_door - wait_credit * me.waited
    prior_opp = sorted((c for c in everyone if c.side != me.side and not c.follower
                        and c.d_door - wait_credit * c.waited < e_me),
                       key=lambda c: c.d_door - wait_credit * c.waited)
    free = [k for k in (0, 1) if door.free[k]]
    if not prior_opp:
        if (init is not None and (init.follower or init.holder)) or not free:
            if init is not None:
                return init.id, -1
            return NONE, _preferred(me, door)
        keep = door.keep_leaf(me.side)
        return NONE, keep if keep in free else free[0]
    # An opposite-side pedestrian is prior to me.
    ranked = sorted(everyone, key=lambda c: (c.d_door - wait_credit * c.waited, c.id))
    rank = [c.id for c in ranked].index(me.id)
    if init is not None and (init.follower or init.holder) and rank >= 2:
        if free:
            keep = door.keep_leaf(me.side)
            return NONE, keep if keep in free else free[0]
        return prior_opp[-1].id, -1
    if init is not None:
        return init.id, -1
    return prior_opp[-1].id, -1
