"""Revolving doors: push and pass (Huang & Terzopoulos §4.5.1, Fig. 8a, Fig. 9).

A revolving door has four compartments turning on one axis. There is only one behavior, push
and pass, so the interaction model reduces to: wait, enter a compartment (catching the moving
panel, or waiting for the next opening), ride it round pushing the door, step out on the far
side. Up to two holders (pushers) and two followers at once (§4.5.1): a same-side follower may
enter only once the pedestrian ahead of it is riding (the holder's critical motion, Fig. 9's
"*"), an opposite-side follower whenever a compartment opens to it, and never more than
:data:`MAX_OCCUPANTS` in the door.

Angles are measured from the door's span direction in its sense of rotation (``psi``): the
compartments' middles are at ``rotation + (k + 1/2) 90°``; side ``s`` opens at ``s·90°`` in
that sense (so with the default counter-clockwise sense a pedestrian keeps right). A
compartment may be entered from side ``s`` while its middle is within :data:`ENTRY_WINDOW` of
that opening, and its rider steps out once its middle is :data:`EXIT_BEFORE` short of the far
opening. The best entry phase for a side is the compartment whose window the pedestrian can
reach first given the door's angle and speed (:func:`best_entry`): it speeds up, up to its
maximum speed, to catch one that is leaving, or waits at the opening for the next one. Catching
a compartment is walked straight at its middle, re-aimed at 30 Hz (the target turns with the
door; App. C's steps are generated to a fixed target).

Riders are carried: their velocity is the compartment's (``omega x r``, plus a pull toward the
compartment's middle), set after ORCA, and the door turns at the speed its riders push it
(:data:`V_PUSH` at the compartment's middle), never into anyone else (App. A's p_stop).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from pedvr.etiquette.regions import waiting_radii
from pedvr.etiquette.vocab import APPROACH, ENTRANT, EXITING, NONE, RIDER

if TYPE_CHECKING:
    from pedvr.crowd.state import CrowdState
    from pedvr.etiquette.core import EtiquetteCore, Walker

RIDE_AT = 0.55  # fraction of the radius at which a rider stands
V_PUSH = 0.5  # m/s: riders push the door round at this speed (at the compartment's middle)
ENTRY_WINDOW = (math.radians(-15.0), math.radians(30.0))  # of a compartment's middle about an opening
EXIT_BEFORE = math.radians(30.0)  # a rider steps out this short of the far opening
MAX_OCCUPANTS = 4  # two holders and two followers (§4.5.1)
CARRY_GAIN = 3.0  # 1/s: a rider's pull toward its compartment's middle
QUARTER = 0.5 * math.pi
USER_CLAIM = 1.0  # m outside the drum: the user approaching claims the compartment in front of it
USER_CLAIM_ANGLE = math.radians(20.0)  # and a compartment this close to the user's bearing
SLOW = 0.2  # rad/s: a door turning slower than this is (nearly) standing for whoever enters it
ENTRANT_PUSH = 0.25  # m beyond touching the drum at which an entrant's hand pushes the panel
SIDE_OFFSET = math.radians(25.0)  # riders step out through an opening's first half, others in at its second


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _rev(et: EtiquetteCore, k: int) -> int:
    return int(np.flatnonzero(et.leaves.revolvers.door == k)[0])


def psi_of(et: EtiquetteCore, r: int, world: float) -> float:
    rv = et.leaves.revolvers
    return float(rv.sense[r]) * (world - float(rv.base[r]))


def compartment_psi(et: EtiquetteCore, r: int, c: int) -> float:
    rv = et.leaves.revolvers
    return float(rv.sense[r]) * float(rv.rotation[r]) + (c + 0.5) * QUARTER


def opening_psi(et: EtiquetteCore, r: int, side: int) -> float:
    rv = et.leaves.revolvers
    return float(rv.sense[r]) * side * QUARTER


def world_of(et: EtiquetteCore, r: int, psi: float) -> float:
    rv = et.leaves.revolvers
    return float(rv.base[r]) + psi / float(rv.sense[r])


def best_entry(psi: list[float], opening: float, omega: float, eta: float,
               taken: set[int]) -> tuple[int, float, float]:
    """The best entry phase: ``(compartment, time it can be entered from, time its window closes)``
    for a pedestrian ``eta`` seconds from the opening, ``psi`` the compartments' middles now,
    ``omega`` (rad/s, >= 0 in the door's sense) its speed; (-1, inf, inf) if none is free."""
    lo, hi = ENTRY_WINDOW
    best = (-1, math.inf, math.inf)
    for c, p in enumerate(psi):
        if c in taken:
            continue
        d = _wrap(p - opening)
        if omega < 1e-3:
            if abs(d) <= math.radians(45.0):
                cand = (c, eta, math.inf)
                if best[0] < 0 or abs(d) < abs(_wrap(psi[best[0]] - opening)):
                    best = cand
            continue
        if d > hi:
            d -= 2.0 * math.pi  # it has gone by: the next time round
        t_open = max(0.0, (lo - d) / omega)
        t_close = (hi - d) / omega
        t = max(eta, t_open)
        if t <= t_close and t < best[1]:
            best = (c, t, t_close)
    return best


def decide_revolving(et: EtiquetteCore, k: int, walkers: list[Walker], crowd: CrowdState) -> None:
    """One decision tick of revolving door ``k`` (module docstring)."""
    r = _rev(et, k)
    rv = et.leaves.revolvers
    ds = et.dstate[k]
    centre = rv.centre[r]
    radius = float(rv.radius[r])
    omega = max(0.0, float(rv.omega[r]) * float(rv.sense[r]))
    psi = [compartment_psi(et, r, c) for c in range(4)]
    taken = {w.compartment for w in walkers if w.role in (ENTRANT, RIDER) and w.compartment >= 0}
    claimed = _user_claim(et, r, crowd, psi)
    taken |= claimed
    for w in walkers:  # an agent about to enter the user's compartment takes the next one
        if w.role == ENTRANT and w.compartment in claimed and not _inside(et, r, w, crowd):
            et.log("missed", w, compartment=w.compartment, why="user")
            w.compartment = -1
            w.catching = False
    occupants = sum(1 for w in walkers if w.role in (ENTRANT, RIDER))
    _, _, agent_r = waiting_radii("revolving")
    wr = waiting_radii("revolving")[0]
    for side in (1, -1):
        queue = sorted((w for w in walkers if w.side == side and w.role == APPROACH and not w.is_user),
                       key=lambda w: (float(np.hypot(*(et.pos(crowd, w.id) - centre)))
                                      - et.cfg.wait_credit * w.waited, w.id))
        entrant = any(w.side == side and w.role == ENTRANT for w in walkers)
        opening = opening_psi(et, r, side)
        face = world_of(et, r, opening + SIDE_OFFSET) + math.pi  # toward the door from this side
        prev: Walker | None = None
        for i, w in enumerate(queue):
            row = et._row[w.id]
            p = crowd.pos[row]
            slow = float(np.hypot(*crowd.vel[row])) < 0.2
            w.leader = NONE if prev is None else prev.id
            may_enter = i == 0 and not entrant and occupancy_ok(occupants)
            if may_enter:
                spot = centre + (radius + float(crowd.radius[row]) + 0.3) * _dir(
                    world_of(et, r, opening + SIDE_OFFSET))
                eta = _eta_in(p, spot, centre, radius, float(crowd.pref_speed[row]))
                c, t_from, t_close = best_entry(psi, opening, omega, eta, taken)
                if c >= 0:
                    w.role = ENTRANT
                    w.catching = False
                    w.compartment = c
                    w.waiting = False
                    taken.add(c)
                    occupants += 1
                    entrant = True
                    et.log("enter", w, compartment=c, catch=bool(t_close < math.inf))
                    prev = w
                    continue
            # wait: stop on entering the waiting region, or behind the leader
            d_c = float(np.hypot(*(p - centre)))
            behind = prev is not None and float(np.hypot(*(p - et.pos(crowd, prev.id)))) <= agent_r
            if d_c <= wr or behind:
                et.stand(w, face)
                w.waiting = True
                if slow:
                    w.waited += 1.0 / 30.0
            else:
                w.plan = None
                w.waiting = False
            prev = w
    for w in walkers:
        if w.role == ENTRANT:
            _entrant(et, r, w, crowd, claimed)
        elif w.role == RIDER:
            p_c = compartment_psi(et, r, w.compartment)
            exit_open = opening_psi(et, r, -w.side)
            if -EXIT_BEFORE <= _wrap(p_c - exit_open) <= QUARTER:
                w.role = EXITING
                out = world_of(et, r, exit_open - SIDE_OFFSET)  # out through the opening's first half
                row = et._row[w.id]
                target = centre + (radius + float(crowd.radius[row]) + 0.9) * _dir(out)
                et.go_direct(w, target, facing=out, speed=float(crowd.pref_speed[row]))
                et.log("exit", w, compartment=w.compartment)
                w.compartment = -1
        elif w.role == EXITING:
            row = et._row[w.id]
            if float(np.hypot(*(crowd.pos[row] - centre))) > radius + float(crowd.radius[row]) + 0.45:
                et.finish(w, crowd)
    del ds


def occupancy_ok(occupants: int) -> bool:
    return occupants < MAX_OCCUPANTS


def _dir(a: float) -> np.ndarray:
    return np.array([math.cos(a), math.sin(a)])


def _containing(et: EtiquetteCore, r: int, p: np.ndarray) -> int:
    """The compartment whose quarter ``p`` (inside the drum) lies in."""
    rv = et.leaves.revolvers
    rel = p - rv.centre[r]
    psi = psi_of(et, r, math.atan2(rel[1], rel[0])) - float(rv.sense[r]) * float(rv.rotation[r])
    return int((psi % (2.0 * math.pi)) // QUARTER) % 4


def _eta_in(p: np.ndarray, spot: np.ndarray, centre: np.ndarray, radius: float, speed: float) -> float:
    """Seconds until a pedestrian at ``p`` can be inside a compartment from ``spot`` (its place
    at the opening): the walk to the spot, then in to the compartment's middle. The best entry
    phase is the first compartment it can be inside before that compartment goes by, so that the
    one it chooses is one it can catch (issue 24 item 5)."""
    v = max(speed, 0.1)
    inward = float(np.hypot(*(spot - centre))) - RIDE_AT * radius
    return float(np.hypot(*(p - spot))) / v + inward / v


def _user_claim(et: EtiquetteCore, r: int, crowd: CrowdState, psi: list[float]) -> set[int]:
    """The compartments the user is in or walks into (within :data:`USER_CLAIM` of the drum)."""
    user_row = None if et.user_id is None else et._row.get(et.user_id)
    if user_row is None:
        return set()
    rv = et.leaves.revolvers
    up = crowd.pos[user_row] - rv.centre[r]
    if float(np.hypot(*up)) >= float(rv.radius[r]) + USER_CLAIM:
        return set()
    up_psi = psi_of(et, r, math.atan2(up[1], up[0]))
    return {c for c, p in enumerate(psi) if abs(_wrap(up_psi - p)) < QUARTER / 2 + USER_CLAIM_ANGLE}


def _inside(et: EtiquetteCore, r: int, w: Walker, crowd: CrowdState) -> bool:
    rv = et.leaves.revolvers
    return float(np.hypot(*(et.pos(crowd, w.id) - rv.centre[r]))) < float(rv.radius[r]) - 0.05


def _in_window(d: float, omega: float) -> bool:
    """Whether a compartment whose middle is ``d`` past the opening may be walked into now: in its
    entry window, or anywhere in front of the opening while the door (nearly) stands."""
    lo, hi = ENTRY_WINDOW
    return lo - math.radians(5.0) <= d <= hi or (omega < SLOW and abs(d) <= math.radians(45.0))


def _gone_by(d: float, omega: float) -> bool:
    """Whether a compartment being caught, its middle ``d`` past the opening, has gone by."""
    return d > max(ENTRY_WINDOW[1], math.radians(45.0) if omega < SLOW else 0.0) + math.radians(5.0)


def _entrant(et: EtiquetteCore, r: int, w: Walker, crowd: CrowdState, claimed: set[int]) -> None:
    """Walk into the compartment chosen for it, catching it (faster, up to the maximum speed) or
    waiting at the opening for it; inside, ride the compartment it is in.

    The choice is kept (issue 24 item 5: entering should succeed at the first try): the best
    entry phase is found once, when the pedestrian starts to enter, and again only when something
    new blocks it: the compartment is taken (the user walks into it, or another pedestrian), or
    it goes by before the pedestrian reaches it (a ``missed`` event, then the next one)."""
    rv = et.leaves.revolvers
    centre = rv.centre[r]
    radius = float(rv.radius[r])
    row = et._row[w.id]
    p = crowd.pos[row]
    rad = float(crowd.radius[row])
    omega = max(0.0, float(rv.omega[r]) * float(rv.sense[r]))
    opening = opening_psi(et, r, w.side)
    if _inside(et, r, w, crowd):
        w.compartment = _containing(et, r, p)
        w.catching = True
        p_c = compartment_psi(et, r, w.compartment)
        middle = centre + RIDE_AT * radius * _dir(world_of(et, r, p_c))
        if float(np.hypot(*(p - middle))) < 0.25:
            w.role = RIDER
            w.plan = None
            et.log("ride", w, compartment=w.compartment)
        return
    taken = {o.compartment for o in et.walkers.values()
             if o.door == w.door and o.id != w.id and o.role in (ENTRANT, RIDER) and o.compartment >= 0}
    taken |= claimed
    spot = centre + (radius + rad + 0.3) * _dir(world_of(et, r, opening + SIDE_OFFSET))
    psi = [compartment_psi(et, r, c) for c in range(4)]
    c = w.compartment
    if c >= 0 and (c in taken or (w.catching and _gone_by(_wrap(psi[c] - opening), omega))):
        et.log("missed", w, compartment=c, why="taken" if c in taken else "gone by")
        c = -1
    elif c >= 0 and omega < 1e-3 and abs(_wrap(psi[c] - opening)) > math.radians(45.0):
        c = -1  # the door has stopped with it elsewhere: nothing will bring it (no miss: choose again)
    if c < 0:
        eta = _eta_in(p, spot, centre, radius, float(crowd.pref_speed[row]))
        c, _, _ = best_entry(psi, opening, omega, eta, taken)
    w.compartment = c
    lo, hi = ENTRY_WINDOW
    w.catching = False  # until it is in the window
    if c >= 0:
        d = _wrap(psi[c] - opening)
        if _in_window(d, omega):
            w.catching = True
            middle = centre + RIDE_AT * radius * _dir(world_of(et, r, psi[c] + omega * 0.3))
            dist = float(np.hypot(*(p - middle)))
            left = (hi - d) / omega if omega > 1e-3 else math.inf
            speed = float(crowd.pref_speed[row])
            if dist / speed > left:
                speed = min(float(crowd.max_speed[row]), dist / max(left, 1e-3))  # catch the panel
            et.go_direct(w, middle, facing=world_of(et, r, psi[c]) + 0.5 * math.pi * float(rv.sense[r]),
                         speed=speed)
            return
    face = world_of(et, r, opening + SIDE_OFFSET) + math.pi
    et.go_direct(w, spot, facing=face, speed=float(crowd.pref_speed[row]))


def carry_riders(et: EtiquetteCore, new_vel: np.ndarray, crowd: CrowdState) -> None:
    """Whoever is inside a revolving door moves with its compartment (riders, and entrants and
    exiters while inside the drum, stepping in or out as they go); the door turns while someone
    rides (pushes) it."""
    rv = et.leaves.revolvers
    if not len(rv):
        return
    push = np.zeros(len(rv))
    for w in et.walkers.values():
        if w.is_user:
            continue
        if not carried(et, w, crowd):
            if w.role == ENTRANT and w.catching and w.id in et._row:
                # at the drum catching its compartment: a hand on the panel pushes the door round
                # (§4.5.1, push and pass), so a door that stopped with a panel across the way
                # turns the compartment in
                r = _rev(et, w.door)
                row = et._row[w.id]
                reach = float(rv.radius[r]) + float(crowd.radius[row]) + ENTRANT_PUSH
                if float(np.hypot(*(crowd.pos[row] - rv.centre[r]))) < reach:
                    push[r] = V_PUSH / (RIDE_AT * float(rv.radius[r]))
            continue
        row = et._row[w.id]
        r = _rev(et, w.door)
        radius = float(rv.radius[r])
        centre = rv.centre[r]
        rel = crowd.pos[row] - centre
        omega = float(rv.omega[r])
        v = omega * np.array([-rel[1], rel[0]])
        if w.role == EXITING:
            d = float(np.hypot(*rel))
            v = v + (rel / max(d, 1e-9)) * float(crowd.pref_speed[row]) * 0.8
        else:
            push[r] = V_PUSH / (RIDE_AT * radius)  # riders, and entrants once in, push it round
            p_c = compartment_psi(et, r, w.compartment)
            middle = centre + RIDE_AT * radius * _dir(world_of(et, r, p_c))
            v = v + CARRY_GAIN * (middle - crowd.pos[row])
        sp = float(np.hypot(*v))
        cap = float(crowd.max_speed[row])
        new_vel[row] = v * (cap / sp) if sp > cap else v
    rv.push[:] = push


def carried(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    """Whether ``w`` moves with a revolving door's compartment now."""
    if w.role == RIDER:
        return w.id in et._row
    if w.role not in (ENTRANT, EXITING) or w.id not in et._row:
        return False
    if w.role == ENTRANT and not w.catching:
        return False
    rv = et.leaves.revolvers
    r = _rev(et, w.door)
    row = et._row[w.id]
    return float(np.hypot(*(crowd.pos[row] - rv.centre[r]))) < float(rv.radius[r]) + 0.05
