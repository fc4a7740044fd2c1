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
leader) the paper's "more proximal" is read as a rank in one passing order for the door, so that the
two sides' queues merge like a zipper and groups arriving together interleave (§6.1): a holder
first, its committed follower next, then everyone by ``key``: the least ``E`` to the doorway,
``d_door - wait_credit * t_wait``, of the pedestrian and everyone behind it in its own queue (those
ahead of someone who has waited long must pass before that one can, so a long wait anywhere in a
queue brings its whole front forward: first come, first served across the door). The head of a
side's queue follows the last of the other side's pedestrians ranked before it, or else the holder /
follower. Two choices here are pedvr's, from running the literal reading with 20 people a side
(issue 26): proximity to the holder's body favours the holder's own queue (it stands outside the
swing on its own side), and ranking a whole queue by its members' own ``E`` (a far pedestrian who
has waited long counts as near, while the one in front of it, who has not, counts as far) made
leaders point across and back again in cycles; a cycle broken at the nearer pedestrian left the door
to whoever stood closest, and the other side waited a minute. With the rank, a leader always ranks
before its follower and there are no cycles. A head with no holder or follower anywhere has no
leader (Alg. 1); the mutex settles who opens the door.

Who is in front. Alg. 1 takes "pedestrians to the front (on the same side of and closer to the
door)"; pedestrians waiting at a door stop where they enter a waiting region, and the regions
are circles about the hinge or the door, so the one closer to the door is whoever stopped on the
near part of the circle, not whoever came first: with six a side, a pedestrian waited 55 s while
later arrivals stopped nearer and went before it. pedvr's reading: the front is by distance to
the door less ``wait_credit`` for the time waited beyond :data:`QUEUE_HOLD` (people keep their
place in a queue); a holder is in front of everyone, its committed follower next.

Double doors (Alg. 3–4): a pedestrian's passing side is one of the two leaves. Alg. 4 has a
pedestrian with an opposite-side pedestrian prior to it adopt that pedestrian's passing side; read
literally, two people meeting at a free double door would queue through one leaf, and §6.3 /
Fig. 15(a) observe a two-way flow through the two right-hand doors instead. pedvr's choice: an
opposite-side leader whose passing side is not mine, while my keep-side leaf is free, is no
leader of mine (each passes its own door); otherwise its side is adopted. Alg. 3 read literally
has everyone with more than two same-side pedestrians before it follow its initial leader, so a
queue files through one leaf while the other stands free (issue 26); §6.3 observes that "if one
door is in relatively heavy use while the other is clear, then the later arrivers will start using
the less congested door". pedvr's choice: such a pedestrian follows its initial leader unless the
leader's leaf carries :data:`LOAD_MARGIN` more pedestrians than the other, and then takes the other
leaf (the simulation asks the farthest first, so the queue's tail moves over), and stays there
while that leaf is not the busier by as much. "The right-hand
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


QUEUE_HOLD = 5.0  # s: waiting longer than this at a door keeps one's place against later arrivals


def proximity(c: Candidate, to: tuple[float, float], wait_credit: float) -> float:
    """``E(d, t_wait)``: distance to ``to`` less the credit for time waited (module docstring)."""
    return _dist(c.pos, to) - wait_credit * c.waited


def place(c: Candidate, wait_credit: float) -> float:
    """Where ``c`` stands in its side's queue (smaller: nearer the front): a holder first, a
    committed follower next, then by distance to the door less ``wait_credit`` for the time
    waited beyond :data:`QUEUE_HOLD` (module docstring)."""
    if c.holder:
        return -math.inf
    if c.follower:
        return -1e9 + c.d_door
    return c.d_door - wait_credit * max(0.0, c.waited - QUEUE_HOLD)


def initial_leader(me: Candidate, everyone: list[Candidate], *, wait_credit: float = 0.0) -> Candidate | None:
    """The closest pedestrian to the front of ``me``: on its side and before it in the queue
    (:func:`place`; with ``wait_credit`` 0, closer to the door)."""
    best, best_d = None, math.inf
    mine = place(me, wait_credit)
    for c in everyone:
        if c.id == me.id or c.side != me.side or place(c, wait_credit) >= mine or c.id in me.skip:
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


def queue_keys(everyone: list[Candidate], *, wait_credit: float) -> tuple[dict[int, Candidate | None],
                                                                        dict[int, tuple[float, int, int]]]:
    """Each side's queue and the rank of every pedestrian in the door's passing order (module
    docstring, "Across the doorway"): ``(same, rank)`` with ``same[id]`` its leader on its own side
    (Alg. 1's initial leader after competing on its side; None at the head of its side) and
    ``rank[id] = (key, depth, id)``, smaller passes earlier. A holder ranks first, a committed
    follower next; ``key`` is the least ``E`` to the door of the pedestrian and everyone behind it
    on its side (nobody passes before the one ahead of it in its own queue)."""
    initial = {c.id: initial_leader(c, everyone, wait_credit=wait_credit) for c in everyone}
    same: dict[int, Candidate | None] = {}
    for me in everyone:
        init = initial[me.id]
        if me.holder or me.follower or init is None:
            same[me.id] = None
            continue
        sharing = [c for c in everyone if c.side == me.side and initial[c.id] is not None
                   and initial[c.id].id == init.id and c.id != me.id]  # type: ignore[union-attr]
        same[me.id] = _compete(me, init, sharing, wait_credit) if sharing else init
    # Depth along each side's queue, and each queue's members from its head back.
    depth: dict[int, int] = {}

    def deep(c: Candidate) -> int:
        if c.id not in depth:
            ahead = same[c.id]
            depth[c.id] = 0 if ahead is None else deep(ahead) + 1
        return depth[c.id]

    for c in everyone:
        deep(c)
    behind: dict[int, list[Candidate]] = {c.id: [] for c in everyone}
    for c in everyone:
        if same[c.id] is not None:
            behind[same[c.id].id].append(c)  # type: ignore[union-attr]
    key: dict[int, float] = {}
    for c in sorted(everyone, key=lambda c: -depth[c.id]):  # from the back of each queue forward
        own = c.d_door - wait_credit * c.waited
        key[c.id] = min([own] + [key[b.id] for b in behind[c.id]])
    rank: dict[int, tuple[float, int, int]] = {}
    for c in everyone:
        if c.holder:
            rank[c.id] = (-math.inf, 0, c.id)
        elif c.follower:
            rank[c.id] = (-1e9 + c.d_door, 0, c.id)
        else:
            rank[c.id] = (key[c.id], depth[c.id], c.id)
    return same, rank


def leaders(everyone: list[Candidate], *, wait_credit: float) -> dict[int, int]:
    """Alg. 1 for every pedestrian that is neither holder nor follower: ``{id: leader id}``
    (``NONE``: no leader). One follows the pedestrian ahead of it on its side; the head of a
    side's queue (whose leader is a holder or follower, or who has none) competes with the other
    side's pedestrians and follows the last of them prior to it in the door's passing order, or
    else the holder / follower it had (an opposing one when it had none). Leaders always rank
    before their followers, so there are no cycles (module docstring)."""
    by_id = {c.id: c for c in everyone}
    same, rank = queue_keys(everyone, wait_credit=wait_credit)
    out: dict[int, int] = {}
    for me in everyone:
        if me.holder or me.follower:
            continue
        lead = same[me.id]
        if lead is not None and not (lead.holder or lead.follower):
            out[me.id] = lead.id
            continue
        mine = rank[me.id]
        if lead is None:
            opposing = [c for c in everyone if c.side != me.side and (c.follower or c.holder)]
            if opposing:
                followers = [c for c in opposing if c.follower]
                lead = min(followers or opposing, key=lambda c: (c.d_door, c.id))
        prior = [c for c in everyone if c.side != me.side and not c.holder and not c.follower
                 and rank[c.id] < mine]
        if prior and lead is not None:  # Alg. 1 competes across only after a holder or follower
            lead = max(prior, key=lambda c: rank[c.id])
        out[me.id] = lead.id if lead is not None else NONE
    # A leader always ranks before its follower; this only guards the invariant.
    for start in list(out):
        seen: list[int] = []
        cur = start
        while cur in out and out[cur] != NONE and cur not in seen:
            seen.append(cur)
            cur = out[cur]
        if cur in seen:  # pragma: no cover - unreachable while ranks decrease along leaders
            out[min(seen[seen.index(cur):], key=lambda i: (by_id[i].d_door, i))] = NONE
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
        theirs = _leaf_of(init, me, door)
        if me.leaf >= 0 and me.leaf != theirs and door.load[me.leaf] - door.load[theirs] < LOAD_MARGIN:
            return NONE, me.leaf  # it moved over before: it stays while its leaf is not the busier
        if door.load[theirs] - door.load[1 - theirs] >= LOAD_MARGIN:
            return NONE, 1 - theirs  # §6.3: a later arriver takes the less congested door
        return init.id, theirs
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
