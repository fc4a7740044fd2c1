"""The state-based door interaction model for hinged doors (Huang & Terzopoulos §4.2–4.4, App. B).

One decision tick of one single or double door: the doorway ordering (Alg. 1, or Alg. 3–4
for a double door, :mod:`.ordering`), the doorway behavior of Alg. 2 with the waiting regions
of Table 1, and then the interaction states of Fig. 7 and App. B for every holder and follower:

Holder: ``OpenerInit`` (walk to the BOP) → ``ReachDoor`` (face the handle or bar,
reach with the right hand to pull, the left to push, eyes on the hand) → ``OpenDoor`` (the
automatic opening; the door leads the hand, ``f_pabs``; pulling, the holder steps round outside
the swing; pushing, it walks into the doorway) → ``HolderDec`` (the critical motion phase: the
follower is committed and the holder decides HOF / HOL / NH with the network of §5) →
``HoldDoor`` (HOF: stand just beyond the open leaf's edge holding it, watching the follower pass;
HOL: step into or through the doorway holding it until the follower has it) → ``ReleaseDoor`` →
``FinishDoor`` (pass, the hand on the leaf until past it, then let go: ``f_bounce``).

Follower: ``FollowerInit`` (committed: close up behind, or to the opposing side's waiting place)
→ ``FollowerDec`` (PF to HOF: pass first, thanking the holder; PL to HOL: ``ReachEdge``, take
the door, and become the holder in ``HolderDec``, the red routine of Fig. 7; after NH: open the
door itself once the holder lets go). A HOF holder whose follower has passed is back in
``HolderDec`` for the next one (the blue routine).

Motion between key poses (App. C; issue 24 item 7). Every key-pose move of App. B walks along
App. C's generated steps (:meth:`~pedvr.etiquette.core.EtiquetteCore.set_plan` /
``walk_to``): to the BOP, pushing into the doorway, stepping aside to hold (HOF, facing the door
as it steps) or into the doorway (HOL), closing up behind the holder or to the Opposing Goal,
reaching the leaf's edge to take it over, passing first, and the holder passing through
(FinishDoor); a move that must go round an open leaf's edge is one sequence of legs. Two moves
are walked straight, re-aimed at 30 Hz, because their target moves while it is walked to and
App. C.2 generates steps to a fixed target: a puller stepping round outside the swing with the
leaf's edge as the door opens, and (in :mod:`.revolving`) a pedestrian catching a turning
compartment. Waiting and queueing before the interaction begins is doorway locomotion, not the
procedural model (App. B.1: OpenerInit is where the holder switches to it).

Under load (issue 26; §7 leaves "the efficiency of the flow" as dense crowds' future work):
a committed follower's decision waits until it has closed up (App. B.3), and followers from the
other side wait at the Opposing Goal beside the doorway's mouth, off the lane, where whoever
comes through the other way passes them; the next in a queue waits :data:`QUEUE_GAP` behind a
committed follower's place; a PF follower frees its holder for the next as it sets off (the
blue routine, pipelined; a carrier, who cannot catch the door, only once it is through) and lets
anyone coming through the other way out first; a pulling
holder stays on the passage side of the leaf's edge (HOL walks on through; HOF steps round
behind the leaf); holders walk at their own speed; HOL decided for a carrier (who cannot take a
door over) or by a holder already through the doorway (a pusher holding from beyond it) is held
as HOF, the hold the network was willing to give. Two more at a busy door (issue 26): a committed
follower whose holder decided NH catches the door at its edge as the holder walks through, rather
than letting it swing shut and opening it again from the BOP (:func:`_catch_nh`, App. B.2–B.3),
and a single door with a queue on each side passes each side in batches (:func:`_batch_side`).
Later (issue 26): the next in a queue moves up into a committed follower's place once that one
walks to the leaf's edge; nobody opens the door while someone comes through the other way (a
holder walking through after letting go included); a way out of the pocket behind an open
leaf goes round its edge clear of it (:func:`round_edge`); and who commits as a holder's follower
is never someone standing behind people of its own side (:func:`_in_the_way`), nor, blocked on its
way to take the door over, stays its follower (:func:`_hand_on`).

Choices where the paper leaves room (it draws the key poses, Fig. 18, without measuring them):
positions come from :class:`~pedvr.etiquette.regions.LeafFrame`; NH opens to the smallest angle
that clears the passing lane plus 25° (at least 45°, App. B.3 "the minimal angle that permits
passage"); a carrier or a perambulator pusher (no free hand, §4.6) pushes a push side open with
its body, waits at a pull side for someone to open it (a helper overtakes it), passes first
whatever the holder decided (it cannot take a door over), and after :data:`CARRIER_PATIENCE`
alone frees a hand; a pram pusher alone at a closed pull door then turns round, opens it with its
pram trailing and backs through (:func:`_backing_through`); every state gives up after a timeout,
so nobody waits for ever on a state.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from pedvr.body.steps import LEFT, RIGHT
from pedvr.etiquette.ordering import Candidate, DoubleDoor, choose_side, leaders
from pedvr.etiquette.regions import (
    BOP_PULL_POLAR,
    HOLD_ANGLE,
    LANE_AT,
    OUTER_MARGIN,
    PULL_HAND_AT,
    PUSH_HAND_AT,
    LeafFrame,
    point_segment,
    waiting_radii,
)
from pedvr.etiquette.vocab import (
    APPROACH,
    CARRIER_PATIENCE,
    CATCH_UP,
    CATCH_UP_AT,
    CLEAR,
    DECIDE_WAIT,
    FINISH_DOOR,
    FOLLOWER,
    FOLLOWER_DEC,
    FOLLOWER_INIT,
    HELP_RANGE,
    HOLD_DOOR,
    HOLD_TIMEOUT,
    HOLDER,
    HOLDER_DEC,
    NONE,
    OPEN_DOOR,
    OPENER_INIT,
    OPENER_RANGE,
    PASSING,
    REACH_DOOR,
    REACH_EDGE,
    REACH_TIME,
    STATE_TIMEOUT,
    THANK_RANGE,
    USER_STANDING_S,
)
from pedvr.kernels import wrap_pi

if TYPE_CHECKING:
    from pedvr.crowd.state import CrowdState
    from pedvr.etiquette.core import EtiquetteCore, Walker

TICK = 1.0 / 30.0
READY_AFTER = 2.5  # s: the longest a holder waits for its committed follower to close up
PULL_OPEN_SPEED = 0.9  # rad/s: a pulled leaf opens no faster than the puller steps round with it
PUSH_OPEN_SPEED = 2.0  # rad/s: a pushed one, as the pusher walks in
READY_NEAR = 0.4  # m from its close-up place at which a committed follower is ready
PULL_STAND = math.radians(5.0)  # a puller stands this far round from the leaf's edge, passage side
# A PL follower takes a pulled leaf over this far round from its edge (issue 26, stop 35): at
# PULL_STAND (5°) the spot lay 2° from where a body counts as behind the edge, the new holder stood
# at the leaf's tip, and its own way round the edge into the doorway crossed the spot its next
# follower walked to: in 11 of 33 same-side hand-overs (door_single_flow seeds 1-3) it was pushed
# behind the edge and got through a median 5.0 s late. Over seeds 1-8 the 35th crossing came at
# 69.2 / 65.2 / 62.8 / 61.5 / 63.9 s on average with 5 / 10 / 15 / 20 / 25°; 15° is kept (seeds
# 9-24: 70.9 -> 64.2 s; door_rush 71.1 -> 64.3 s). The hand still reaches the handle (0.45 m).
# Single doors only: at a double door it left the pram behind (tests/etiquette/test_carriers.py;
# door_observations' pram at door_double, seeds 1-8, 17 -> 10 passages), so there PULL_STAND stays.
TAKE_STAND = math.radians(15.0)
QUEUE_GAP = 0.8  # m between a committed follower's place and the next in its queue (issue 26)
QUEUE_ASIDE = 0.45  # m off the lane that next one waits, on the side it came from
BATCH = 20  # passages in a row from one side of a busy single door at most (issue 26, _batch_side)
BATCH_LOAD = 5  # waiting on each side at which a single door becomes busy
BATCH_KEEP = 3  # waiting on each side below which it is no longer busy
BATCH_WAIT = 120.0  # s of waiting credited to the side that has the door within a batch: it goes first
CATCH_RANGE = 4.0  # m from the doorway within which NH's follower catches the door (issue 26)
HAND_ON_SPEED = 0.3  # m/s: a follower slower than this on its way to take the door over is blocked (_hand_on)
CRAWL_SPEED = 0.5  # m/s: one who has stood at a single door and moves up slower than this still waits
# A pram pusher backing through a pull door (_backing_through, issue 26)
BACK_SPEED = 0.5  # m/s: stepping back ([motion] max_backward_speed)
BACK_TURNED = math.radians(12.0)  # a turn round is done this close to the facing it turns to
BACK_CLEAR = 0.3  # m past the doorway line its pram's far end gets before it turns round
BACK_LINE_UP = 0.6  # m before the doorway line (at least) it gets onto the lane, its pram in line behind
BACK_ON_LANE = 0.12  # m off the lane that counts as on it
BACK_CLOSED = math.radians(20.0)  # a leaf open less than this is one the pusher must open itself
BACK_OPEN_S = 8.0  # s it may take to pull the leaf open, stepping round (5 s for other pullers)
BACK_EXTRA = 8.0  # s more than STATE_TIMEOUT that backing through may take
POCKET_CLEAR = 0.15  # m beyond a leaf's swing a pram's front backs out to, from the pocket behind it
BACK_TURN_ROOM = 0.3  # m: a pram turns round only this much farther from the door's line than it reaches
HAND_ON_AHEAD = 0.2  # m nearer the door than the follower that the one it hands on to stands, at least
PASS_ON_AFTER = 2.0  # s a PF walker stands blocked before it lets the one in its way pass (_pass_on)
HOF_LANE_WAIT = 2.5  # s a pram's pusher waits at most for HOF's holder to clear its lane (_hof_lane_clear)
# A body beyond a pulled leaf's free edge goes round it (off_the_tip) from up to TIP_BEHIND behind
# the leaf about its hinge to TIP_CLEAR in front of it, whence it walks on into the doorway clear of it
TIP_CLEAR = math.radians(15.0)
TIP_BEHIND = math.radians(30.0)


def nh_angle(frame: LeafFrame, radius: float) -> float:
    """The angle NH opens to: the passing lane clear of the leaf by the radius, plus 25°."""
    a = math.asin(min(1.0, (radius + 0.12) / (LANE_AT * frame.w))) + math.radians(25.0)
    return min(max(a, math.radians(45.0)), math.radians(85.0))


def decide_hinged(et: EtiquetteCore, k: int, walkers: list[Walker], crowd: CrowdState) -> None:
    """One decision tick of hinged door ``k`` (module docstring)."""
    ds = et.dstate[k]
    door = et.doors[k]
    by_id = {w.id: w for w in walkers}
    _update_waiting(et, walkers, crowd)
    _choose_helpers(et, walkers, crowd)
    # -- ordering ---------------------------------------------------------------------------
    batch = _batch_side(et, k, walkers, crowd)
    cands = []
    for w in walkers:
        if w.role == PASSING or w.id not in et._row or (w.role == HOLDER and w.state == FINISH_DOOR):
            continue  # on its way through: no longer anyone's leader
        p = et.pos(crowd, w.id)
        rel = p - ds.centre
        skip: set[int] = set()
        r = et._row[w.id]
        fr = int(et.friend[r])
        pull_r, push_r, _ = waiting_radii(door.kind)
        if fr != NONE and fr in by_id and float(np.hypot(*rel)) > push_r:
            skip.add(fr)  # friends side by side: no leader between them until the door (§4.6)
        if w.helping != NONE:
            skip.add(w.helping)
        # a holder is at the door, its committed follower next, whatever their distances (the BOP
        # lies farther from the door's middle than the lane does)
        d_door = 0.0 if w.role == HOLDER else 0.05 if w.role == FOLLOWER else float(np.hypot(*rel))
        cands.append(Candidate(id=w.id, pos=(float(p[0]), float(p[1])), side=w.side, d_door=d_door,
                               waited=w.waited + (BATCH_WAIT if w.side == batch else 0.0),
                               holder=w.role == HOLDER, follower=w.role == FOLLOWER,
                               critical=w.role == HOLDER and w.state >= HOLDER_DEC,
                               leaf=ds.leaves.index(w.leaf) if w.leaf in ds.leaves else -1,
                               skip=frozenset(skip)))
    if door.kind == "double":
        _double_sides(et, k, walkers, cands, crowd)
        lead = {}
        for side in (0, 1):
            lead.update(leaders([c for c in cands if c.leaf == side], wait_credit=et.cfg.wait_credit))
    else:
        for w in walkers:
            w.leaf = ds.leaves[0]
        lead = leaders(cands, wait_credit=et.cfg.wait_credit)
    for w in walkers:
        if w.role == APPROACH and w.id in lead:
            w.leader = lead[w.id]
    # -- Alg. 2 and the interaction states, in id order ----------------------------------------
    for w in walkers:
        if w.id not in et.walkers:
            continue  # dropped by an earlier walker's transition
        if w.is_user:
            _user_walker(et, w, by_id, crowd)
        elif w.role == APPROACH:
            _doorway_behavior(et, w, by_id, crowd)
        elif w.role == HOLDER:
            _holder(et, w, by_id, crowd)
        elif w.role == FOLLOWER:
            _follower(et, w, by_id, crowd)
        elif w.role == PASSING:
            _passing(et, w, by_id, crowd)


# -- ordering helpers ----------------------------------------------------------------------------


def _batch_side(et: EtiquetteCore, k: int, walkers: list[Walker], crowd: CrowdState) -> int:
    """The side whose queue keeps a busy single door for a batch (issue 26), or 0.

    §6.1 observes groups arriving together interleave at the door, and pedvr's ordering merges the
    two queues like a zipper (:mod:`.ordering`); at a door under load that alternates one by one,
    and every change of direction is a take-over across the doorway (HOL) or a door let go. Real
    people at a busy narrow door pass in bursts: once some pass one way, those behind them follow,
    and the direction changes when the crowd on the other side presses harder (the oscillation of
    the passing direction at bottlenecks that Helbing and Molnár's social force model reproduces,
    Phys. Rev. E 51, 1995). pedvr's reading: a single door is busy from when :data:`BATCH_LOAD` or
    more wait on each side until fewer than :data:`BATCH_KEEP` wait on the side whose turn it is
    not, or nobody is left on the side whose turn it is; while it is, the side the latest passages
    came from counts :data:`BATCH_WAIT` s more waiting in the ordering (Alg. 1's ``E``), until
    :data:`BATCH` passages in a row came from it; then the other side's turn comes by the ordering
    as before. Fewer waiting (the paper's groups of four, §6.1) alternate as before.

    A run drains its own side's queue to the end (within :data:`BATCH`): until issue 26's change
    16 it ended as soon as fewer than :data:`BATCH_KEEP` waited on either side, so the last two of
    a run's queue waited out the whole of the other side's run and came last, through a tail of
    hand-overs across the doorway (door_single_flow seed 11: two who had queued from 30 s passed
    at 75 and 82 s, the last passage at 86 s).

    A holder still on its own side passes next, whatever it decides, so its passage counts in the
    run already: the next it holds for is chosen before it goes through. Counted from passages
    alone, a holder from side ``a`` chose its follower while the run was the other side's, and a
    chain of hand-overs alternated one by one however busy the door (door_single_flow seed 2: runs
    of 1-2 with 12-17 waiting on each side).

    :data:`BATCH` was 4 before that was seen; with the holder counted, door_single_flow and
    door_rush over seeds 1-8 passed 237 / not run (4), 282 / 301 (6), 272 / 291 (8), 291 / 298
    (12) and 299 / 316 (20) of 320 in 90 s, and door_rush's 95th-percentile wait fell with 20
    (README, "What issue 26 changed", item 11): a cap of 20 a side keeps the far side from waiting
    for ever behind an endless stream."""
    ds = et.dstate[k]
    if et.doors[k].kind != "single" or ds.run_side == 0:
        return 0
    run_side, run_len = ds.run_side, ds.run_len
    n = {1: 0, -1: 0}
    for w in walkers:
        if w.role in (APPROACH, FOLLOWER) and not w.is_user and w.side in n:
            n[w.side] += 1
        elif w.role == HOLDER and not w.is_user and w.side in n and w.id in et._row:
            if float((et.pos(crowd, w.id) - ds.centre) @ ds.n) * w.side > 0:  # not through yet
                run_len = run_len + 1 if w.side == run_side else 1
                run_side = w.side
    if not ds.busy:
        ds.busy = min(n.values()) >= BATCH_LOAD
    elif n[-run_side] < BATCH_KEEP or n[run_side] == 0:
        ds.busy = False
    return run_side if ds.busy and run_len < BATCH else 0


def _update_waiting(et: EtiquetteCore, walkers: list[Walker], crowd: CrowdState) -> None:
    """The time each pedestrian has waited at its door, Alg. 1's ``t_wait`` (:mod:`.ordering`). It
    grows while the pedestrian stands waiting (told to stand, slower than 0.2 m/s) and, at a single
    door, once it has stood there, while it moves up slower than :data:`CRAWL_SPEED`.

    The paper does not say when waiting time counts (issue 26, change 23). Counted only while
    standing, whoever shuffled forward lost its place to whoever stood, and the two swapped places
    in the order every tick: in door_rush seed 9 one crept from 7.7 to 6.6 m from the held door
    in 38 s, and the last five through, who had waited 5-8 m out, passed at 68-84 s. Counted from
    the first stand on whatever the pace (stop 47, tried), the side that stood first passed as a
    block, and groups arriving together from opposite sides no longer interleaved (§6.1, Fig. 12).
    pedvr's reading: below half a walking pace (Weidmann's free speed is 1.34 m/s) one moving up
    in a queue is shuffling in it, still waiting; one who walks up earns nothing while it walks.
    Single doors only: at a double door (Alg. 3-4 rank by the same ``E``) the same rule left 15 of
    30 on their side in ``validation/door_double_flow`` under ``decoupled``, and door_double's
    pram on its side in three of ten seeds (not traced further)."""
    for w in walkers:
        if w.is_user or w.id not in et._row:
            continue
        r = et._row[w.id]
        v = float(np.hypot(*crowd.vel[r]))
        crawl = w.waited > 0.0 and v < CRAWL_SPEED and et.doors[w.door].kind == "single"
        if w.role in (APPROACH, FOLLOWER) and ((v < 0.2 and w.waiting) or crawl):
            w.waited += TICK


def _choose_helpers(et: EtiquetteCore, walkers: list[Walker], crowd: CrowdState) -> None:
    """§4.6: a pedestrian who sees someone carrying a box or pushing a perambulator ahead of it
    overtakes to open the door for them (walking as if Rush = 1 meanwhile)."""
    carriers = [w for w in walkers if w.role in (APPROACH, FOLLOWER) and w.id in et._row
                and bool(et.carrying[et._row[w.id]])]
    for w in walkers:
        if w.is_user or w.role != APPROACH or w.id not in et._row:
            w.helping = NONE if w.role != HOLDER else w.helping
            continue
        r = et._row[w.id]
        if bool(et.carrying[r]) or float(et.kindness[r]) < 0.3:
            continue
        if w.helping != NONE and w.helping in et.walkers:
            continue
        w.helping = NONE
        for c in carriers:
            if c.side != w.side or c.id == w.id:
                continue
            d = float(np.hypot(*(et.pos(crowd, c.id) - et.pos(crowd, w.id))))
            if d <= HELP_RANGE and not any(o.helping == c.id for o in walkers if o.id != w.id):
                w.helping = c.id
                break


def _double_sides(et: EtiquetteCore, k: int, walkers: list[Walker], cands: list[Candidate],
                  crowd: CrowdState) -> None:
    """Alg. 3–4 pick each pedestrian's leaf; holders and followers keep theirs."""
    ds = et.dstate[k]
    l0, l1 = ds.leaves
    load = [0, 0]
    for w in walkers:
        if w.leaf in (l0, l1) and w.role != PASSING:
            load[0 if w.leaf == l0 else 1] += 1
    # The leaf on the keep side of someone coming from side +1, walking along -n: its right is
    # right(d) = (d_y, -d_x) of d = -n.
    mid0 = et.leaves.hinge[l0] + 0.5 * (et.leaves.tips()[l0] - et.leaves.hinge[l0])
    d = -ds.n
    right = np.array([d[1], -d[0]])
    on_right = float((mid0 - ds.centre) @ right) > 0.0
    keep_plus = (0 if on_right else 1) if et.cfg.keep == "right" else (1 if on_right else 0)
    pull_r, push_r, _ = waiting_radii("double")
    leaf_rows = (l0, l1)
    index = {c.id: c for c in cands}
    # the farthest first: a queue's later arrivers move to the less congested leaf (§6.3), and
    # each choice counts in the load the next one sees
    for w in sorted(walkers, key=lambda w: (-index[w.id].d_door, w.id) if w.id in index else (0.0, w.id)):
        c = index.get(w.id)
        if c is None:
            continue
        if w.role in (HOLDER, FOLLOWER) or (w.is_user and w.leaf in leaf_rows):
            c.leaf = leaf_rows.index(w.leaf) if w.leaf in leaf_rows else 0
            continue
        # what the door looks like to this pedestrian: its own earlier choice does not make a leaf busy
        own = [int(w.leaf == l0 and w.role != PASSING), int(w.leaf == l1 and w.role != PASSING)]
        ld = (load[0] - own[0], load[1] - own[1])
        dd = DoubleDoor(free=(l0 not in ds.holder and ld[0] == 0, l1 not in ds.holder and ld[1] == 0),
                        load=ld, keep_leaf_for_plus=keep_plus)
        leader, side = choose_side(c, cands, dd, in_region=c.d_door <= max(pull_r, push_r),
                                   wait_credit=et.cfg.wait_credit)
        if leader != NONE and index[leader].leaf >= 0:
            side = index[leader].leaf
        if not w.is_user and _front_reach(crowd, et._row[w.id]) > 0.0:
            side = dd.keep_leaf(w.side)  # a pram keeps to its lane (_line_up), whoever holds the other
        side = 0 if side < 0 else side
        c.leaf = side
        if w.role != PASSING and w.leaf != leaf_rows[side]:
            if w.leaf in leaf_rows:
                load[leaf_rows.index(w.leaf)] -= 1
            load[side] += 1
        w.leaf = leaf_rows[side]


# -- Alg. 2: doorway behavior --------------------------------------------------------------------


def _regions(et: EtiquetteCore, w: Walker, holder: Walker | None, leader: Walker | None,
             crowd: CrowdState) -> list[tuple[np.ndarray, float]]:
    """The waiting regions ``w`` stops at (§4.2, Fig. 4, Table 1)."""
    door = et.doors[w.door]
    ds = et.dstate[w.door]
    r = et._row[w.id]
    carrier = bool(et.carrying[r])
    pull_r, push_r, agent_r = waiting_radii(door.kind, carrier=carrier)
    leaf = w.leaf if w.leaf >= 0 else ds.leaves[0]
    lv = et.leaves
    if door.kind == "double":
        pull_c = push_c = lv.hinge[leaf] + 0.5 * lv.length[leaf] * np.array(
            [math.cos(lv.base[leaf]), math.sin(lv.base[leaf])])
    else:
        pull_c, push_c = lv.hinge[leaf].copy(), ds.centre
    out: list[tuple[np.ndarray, float]] = []
    if holder is not None and holder.frame is not None:
        holder_pull = holder.frame.side_of(et.pos(crowd, holder.id)) > 0
        same = holder.side == w.side
        if same:
            out.append((pull_c, pull_r) if holder_pull else (push_c, push_r))
            hr = et._row.get(holder.id)
            big = hr is not None and bool(et.carrying[hr]) and door.kind == "single"
            a_r = agent_r * (1.2 if big else 1.0)
            out.append((et.pos(crowd, holder.id).copy(), a_r))
        else:
            out.append((push_c, push_r) if holder_pull else (pull_c, pull_r))
    if leader is not None and (holder is None or leader.id != holder.id) and leader.side == w.side:
        out.append((et.pos(crowd, leader.id).copy(), agent_r))
    return out


def _dist(a: np.ndarray, b: np.ndarray) -> float:
    return math.hypot(float(a[0] - b[0]), float(a[1] - b[1]))


def _holder_of(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker]) -> Walker | None:
    ds = et.dstate[w.door]
    leaf = w.leaf if w.leaf >= 0 else ds.leaves[0]
    h = ds.holder.get(leaf, ds.mutex.get(leaf))
    return by_id.get(h) if h is not None else None


def _doorway_behavior(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> None:
    """Alg. 2 for a pedestrian not yet holder or follower."""
    ds = et.dstate[w.door]
    p = et.pos(crowd, w.id)
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    leaf = w.leaf if w.leaf >= 0 else ds.leaves[0]
    holder = _holder_of(et, w, by_id)
    leader = by_id.get(w.leader) if w.leader != NONE else None
    face_door = math.atan2(*(ds.centre - p)[::-1])
    for lf in ds.leaves:  # caught in the pocket behind an open leaf: out round its edge first
        if _pram_backs_out_of_swing(et, w, crowd, r, lf, p):
            return  # (a pram's front may be in the pocket with its pusher outside it)
        fr_lf = et.frame(lf, w.side)
        out = fr_lf.lane(fr_lf.side_of(p) * (radius + 1.1))
        way = _via(et, fr_lf, lf, p, radius, out, beyond=True, crowd=crowd)
        if way.shape[0] > 1:
            et.walk_to(w, crowd, way, facing=face_door, speed=float(crowd.pref_speed[r]))
            return
    if leader is not None and leader.role == HOLDER and leader.state >= HOLDER_DEC \
            and leader.follower == NONE and _accepts(leader):
        # The leader is a holder in the critical phase: commit as its follower, or let the one
        # standing in the way go first (_in_the_way).
        f = w if w.helping != NONE else _in_the_way(et, w, by_id, crowd)
        f.role = FOLLOWER
        f.holder = leader.id
        f.leader = leader.id
        leader.follower = f.id
        f.plan = None
        et.set_state(f, FOLLOWER_INIT)
        return
    spot = _line_up(et, w, crowd) if leader is not None or holder is not None else None
    if spot is not None:
        fr = et.frame(leaf, w.side)
        facing = _toward(spot, fr.lane(0.0))
        if float(np.hypot(*(p - spot))) > 0.2:
            et.go_direct(w, spot, facing=facing, speed=float(crowd.pref_speed[r]))
        else:
            et.stand(w, facing)
        return
    if leader is not None and leader.role == FOLLOWER and leader.side == w.side:
        lh = by_id.get(leader.holder)
        if lh is not None and lh.frame is not None:
            # Next after a committed follower on its side: queue behind that follower's place,
            # QUEUE_GAP back, a little off the lane that people coming through walk along.
            fr = lh.frame
            side_local = 1 if w.side == _pull_side_world(et, lh) else -1
            # Once that follower has left its place for the leaf's edge (REACH_EDGE), the next moves
            # up into the place itself, so that it is closed up when the door changes hands.
            moved_on = leader.state == REACH_EDGE
            back = _behind(fr, radius, side_local) + fr.m * side_local * (0.0 if moved_on else QUEUE_GAP)
            off = 1.0 if float((p - back) @ fr.e) >= 0.0 or side_local > 0 else -1.0  # pull side: latch way
            spot = back if moved_on else back + fr.e * off * QUEUE_ASIDE
            if float(np.hypot(*(p - spot))) > 0.25:
                et.go_direct(w, spot, facing=_toward(spot, fr.lane(0.0)), speed=float(crowd.pref_speed[r]))
            else:
                et.stand(w, _toward(p, fr.lane(0.0)))
            return
    if leader is not None or holder is not None:
        if any(float(np.hypot(*(p - c))) <= rad for c, rad in _regions(et, w, holder, leader, crowd)):
            et.stand(w, face_door)  # stop on entering the waiting region (§4.2)
        else:
            et.approach(w)
        return
    # No leader and nobody holds the door: take it when close enough (the mutex: one at a time).
    carrier = bool(et.carrying[r])
    fr = et.frame(leaf, w.side)
    pull = fr.side_of(p) > 0
    bop = fr.bop_pull(radius)[0] if pull else fr.bop_push(radius)[0]
    helper_coming = any(o.helping == w.id for o in by_id.values())
    if carrier and (helper_coming or pull):
        if float(np.hypot(*(p - bop))) <= OPENER_RANGE + 1.0 or helper_coming:
            if math.isnan(w.alone_since):
                w.alone_since = et.t
            # alone, it frees a hand after CARRIER_PATIENCE; a helper who does not come within
            # twice that is no help (no carrier is left waiting for ever)
            patience = CARRIER_PATIENCE * (2.0 if helper_coming else 1.0)
            if et.t - w.alone_since >= patience:
                if not w.freed_hand:
                    w.freed_hand = True
                    et.carrier_forced += 1
                    et.log("carrier_frees_hand", w)
            else:
                et.stand(w, face_door)
                return
        else:
            et.approach(w)
            return
    if carrier and pull and w.freed_hand and not w.backing and float(crowd.length[r]) > 0.0 \
            and et.leaf_open(leaf, fr) < BACK_CLOSED:
        # A pusher at a closed pull door, with nobody to lead it or hold the leaf, turns round
        # where it waits, so that its pram trails (_backing_through); it sets off once its back is
        # to where it opens the door from. Until stop 51 only a pusher alone did (stop 42: backing
        # among others left door_double's pram behind in seeds 6 and 17); with others about it
        # opened the door as a walker does, from a place on the far side of its own pram, and gave
        # up every 10 s ("could not reach the door": seeds 2 and 11 of test_carriers.py, through
        # at 49.9 and 52.9 s after two give-ups each; backing, at 29.3 and 30.0 s, and 20 of 20).
        away = _toward(bop, p)
        if abs(wrap_pi(float(crowd.heading[r]) - away)) > BACK_TURNED:
            h = float(crowd.heading[r])
            ahead = np.array([math.cos(h), math.sin(h)])
            off = abs(float((p - ds.centre) @ ds.n))
            need = float(crowd.ahead[r] + crowd.length[r]) + BACK_TURN_ROOM
            toward = -float(ahead @ ds.n) * w.side  # > 0: the pram points at the door
            if off < need and toward > 0.0:
                # Too near the door to turn: the pram would sweep into the leaf or the wall, which
                # it may not turn into, and it stood trying to for the rest of the run
                # (door_double, seed 2, the participant pushing through the other leaf as it
                # came to open it). It backs off along its course first.
                et.go_direct(w, p - ahead * ((need - off) / max(toward, 0.5) + 0.1), facing=h,
                             speed=BACK_SPEED, lock=True)
                return
            et.stand(w, away)
            w.lock = True  # the facing turns the body (EtiquetteCore.face)
            return
        w.backing = True
        et.log("pram_turns_round", w)
    if carrier and not pull:
        # no free hand: it pushes the door open with its body (the leaves yield to it)
        w.role = PASSING
        w.state = -1
        et.walk_to(w, crowd, fr.lane(radius + CLEAR + 0.3), facing=fr.heading(0.0, 1.0),
                     speed=float(crowd.pref_speed[r]))
        et.log("push_through", w)
        return
    if leaf in ds.mutex or leaf in ds.holder or _oncoming(et, w, crowd):
        et.stand(w, face_door)
        return
    if w.backing or float(np.hypot(*(p - bop))) <= OPENER_RANGE \
            or float(np.hypot(*(p - ds.centre))) <= OPENER_RANGE:
        ds.mutex[leaf] = w.id
        w.role = HOLDER
        w.leaf = leaf
        w.frame = fr
        w.waiting = False
        target, facing = fr.bop_pull(radius) if pull else fr.bop_push(radius)
        way = _via(et, fr, leaf, p, radius, target, crowd=crowd)
        if w.backing:  # backwards to the handle, its pram trailing out of the leaf's swing
            et.set_plan(w, crowd, way, facing=_toward(target, p), speed=BACK_SPEED, backward=True, lock=True)
        else:
            et.set_plan(w, crowd, way, facing=facing, lock=False)
        et.set_state(w, OPENER_INIT)
        return
    et.approach(w)  # along its own path


def _accepts(holder: Walker) -> bool:
    """A holder takes a (new) follower in HolderDec: after opening, or, holding for someone to pass
    first, once that one has passed (the blue routine of Fig. 7)."""
    return holder.state == HOLDER_DEC and holder.follower == NONE


# -- the holder -----------------------------------------------------------------------------------


def _holder(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> None:
    ds = et.dstate[w.door]
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    p = et.pos(crowd, w.id)
    fr = w.frame
    assert fr is not None
    leaf = w.leaf
    pull = _on_pull(et, w, crowd)
    age = et.t - w.since
    if w.state == OPENER_INIT:
        if w.backing and w.plan is not None and float(np.hypot(*(w.plan[-1] - p))) > 0.3:
            w.face = _toward(w.plan[-1], p)  # backing up to its place: its back to it, pram in line
        if et.arrived(w, crowd, 0.15) or (age > 4.0 and w.plan is not None
                                         and float(np.hypot(*(p - w.plan[-1]))) < 0.45):
            et.stand(w, w.face)
            w.lock = True
            et.set_state(w, REACH_DOOR)
            at = PULL_HAND_AT if pull else PUSH_HAND_AT
            h = fr.handle(et.leaf_open(leaf, fr), at)
            arm = _arm_for(et, w, crowd, h) if w.backing else (RIGHT if pull else LEFT)
            et.body.gaze_at(w.id, (float(h[0]), 1.0, float(h[1])))  # eyes on the handle (§4.4)
            et.body.reach_for(w.id, (float(h[0]), 1.0, float(h[1])), side="right" if arm == RIGHT else "left")
        elif age > STATE_TIMEOUT:
            _give_up(et, w, crowd, why="could not reach the door")
        return
    if w.state == REACH_DOOR:
        if age >= REACH_TIME:
            wanted = w.backing or _followers_in_sight(et, w, by_id, crowd)  # a pram wants it wide
            open_to = HOLD_ANGLE if wanted else nh_angle(fr, radius)
            arm = (_arm_for(et, w, crowd, fr.handle(et.leaf_open(leaf, fr), PULL_HAND_AT)) if w.backing
                   else RIGHT if pull else LEFT)
            et.take_leaf(w, leaf, arm=arm, p_rel=PULL_HAND_AT if pull else PUSH_HAND_AT,
                         open_to=open_to, speed=PULL_OPEN_SPEED if pull else PUSH_OPEN_SPEED)
            et.set_state(w, OPEN_DOOR)
            et.log("open", w, leaf=leaf, case="pull" if pull else "push")
        return
    if w.state == OPEN_DOOR:
        a = et.leaf_open(leaf, fr)
        target_a = w.want
        if pull:
            # Pulling: the holder steps round outside the swing with the leaf's edge, on the passage
            # side of it (whatever it decides next: HOL walks on through, HOF steps round behind
            # the leaf while the follower comes, App. B.3).
            phi = max(BOP_PULL_POLAR, min(a - math.radians(5.0), target_a - PULL_STAND))
            if w.backing:  # pulling the leaf behind it, its pram ahead round the swing, as far as the lane
                phi = min(phi, _lane_polar(fr, radius))
                now = max(math.atan2(*fr.local(p)[::-1]), BOP_PULL_POLAR)  # facing along the circle
                _arc(et, w, fr, radius, p, phi, facing=fr.heading(-math.sin(now), math.cos(now)),
                     speed=BACK_SPEED)
            else:
                _arc(et, w, fr, radius, p, phi, facing=_toward(p, fr.handle(a, PULL_HAND_AT)), speed=1.5)
            lx, ly = fr.local(p)
            kept_up = math.atan2(ly, lx) >= min(target_a - PULL_STAND, _lane_polar(fr, radius) if w.backing
                                                else math.inf) - math.radians(12.0)  # at its place
        else:
            et.walk_to(w, crowd, fr.lane(0.0), facing=fr.heading(0.0, 1.0), speed=0.55, lock=True)
            kept_up = True
        if (a >= target_a - math.radians(4.0) and kept_up) or age > (BACK_OPEN_S if w.backing else 5.0):
            et.set_state(w, HOLDER_DEC)
            ds.mutex.pop(leaf, None)
            w.action = ""
            et.stand(w, w.face)
            w.lock = True
        return
    if w.state == HOLDER_DEC:
        f = by_id.get(w.follower) if w.follower != NONE else None
        if w.backing:  # it has a pram to get through: it holds for nobody
            if f is not None:
                _demote(f)
            _finish(et, w, crowd)
            return
        if f is None:
            if age < DECIDE_WAIT:
                _look_back(et, w, crowd)
                return
            _finish(et, w, crowd)
            return
        if not _ready(et, f, crowd):
            return  # App. B.3: the committed follower moves close behind; then the holder commits
        network = et.decide_hold(w, f, crowd)
        action = network
        f_row = et._row.get(f.id)
        if network == "HOL" and ((not f.is_user and f_row is not None and bool(et.carrying[f_row]))
                                 or _past(et, w, crowd)):
            # Nobody is left to take the door over: a carrier cannot (§4.6), and a holder already on
            # its far side (a pusher holding beyond the leaf's edge) has nothing to pass first. It
            # was willing to hold: it holds for the follower to pass (module docstring).
            action = "HOF"
        elif network == "HOF" and not f.is_user and f.side != w.side and not _past(et, w, crowd) \
                and not (f_row is not None and bool(et.carrying[f_row])):
            # §6.1: those who reach the door first pass first; a holder still to pass does not
            # send someone from the other side ahead of itself: it holds the door for them to take
            # over after it has passed (HOL)
            action = "HOL"
        w.action = action
        et.holds[action] += 1
        dist = et.effort_distance(w, f, crowd)  # Effort's distance (§5.1.1)
        extra = {} if action == network else {"network": network}
        et.log("hold", w, follower=f.id, action=action, for_user=f.is_user, case="pull" if pull else "push",
               distance_m=round(dist, 3), **extra)
        if action == "NH":
            _finish(et, w, crowd)
            return
        et.set_state(w, HOLD_DOOR)
        et.start_hold_event(w, f)
        et.body.gaze_at(w.id, "user" if f.is_user else ("agent", f.id))  # watch the follower (§4.4)
        if f.is_user:
            w.user_best = float(np.hypot(*(et.pos(crowd, f.id) - ds.centre)))
            w.user_best_at = et.t
        _hold_pose(et, w, crowd, action, pull)
        return
    if w.state == HOLD_DOOR:
        f = by_id.get(w.follower) if w.follower != NONE else None
        if w.stop_hold:  # another event took the holder: it lets go and goes on
            w.stop_hold = False
            if f is not None:
                _demote(f)
            _finish(et, w, crowd)
            return
        _hold_pose(et, w, crowd, w.action, pull)
        if f is None:
            # the follower passed (blue routine) or left: back to HolderDec for the next one
            et.end_hold(w, "passed")
            et.set_state(w, HOLDER_DEC)
            w.action = ""
            return
        if f.is_user:
            d = float(np.hypot(*(et.pos(crowd, f.id) - ds.centre)))
            if d < w.user_best - 0.25:
                w.user_best, w.user_best_at = d, et.t
            if _through(et, f, crowd):
                et.log("held_for_user", w, action=w.action)
                et.end_hold(w, "passed")
                w.follower = NONE
                et.set_state(w, HOLDER_DEC)
                return
            if w.action == "HOL" and _at_doorway(et, f, crowd):
                et.end_hold(w, "took over")
                w.follower = NONE
                _finish(et, w, crowd)
                return
            if et.t - w.user_best_at > et.cfg.user_patience:
                et.log("give_up", w, follower=f.id, for_user=True)
                et.end_hold(w, "gave up")
                f.role = APPROACH
                f.holder = NONE
                w.follower = NONE
                _finish(et, w, crowd)
            return
        if age > HOLD_TIMEOUT:
            et.log("give_up", w, follower=f.id, for_user=False)
            et.end_hold(w, "gave up")
            _demote(f)
            w.follower = NONE
            _finish(et, w, crowd)
        return
    if w.state == FINISH_DOOR:
        _finishing(et, w, crowd)
        return


def _close_up(et: EtiquetteCore, w: Walker, h: Walker, fr: LeafFrame, radius: float,
              side_local: int) -> np.ndarray:
    """Where a committed follower goes before the holder decides (App. B.3): closely behind the
    holder on the lane when it comes from the holder's side; from the other side, to the Opposing
    Goal (Fig. 4), which pedvr puts beside the doorway's mouth and off the lane, so that whoever
    comes through the other way (the holder passing first, HOL, or an earlier follower) walks past
    it: on the pull side beyond the latch jamb (the open leaf fills the hinge side), on the push
    side at the hinge jamb. A double door's leaves are half a doorway wide and meet in its middle:
    there both wait on the lane."""
    if w.side == h.side or et.doors[w.door].kind != "single":
        return _behind(fr, radius, side_local)
    if side_local > 0:
        return fr.world(fr.w + radius + 0.1, radius + 0.45)
    return fr.world(-0.2 * radius, -(radius + 0.7))


def _past(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    """Whether ``w`` stands beyond the doorway line on its far side already."""
    ds = et.dstate[w.door]
    return float((et.pos(crowd, w.id) - ds.centre) @ ds.n) * w.side < -et.radius(crowd, w.id)


def _behind(fr: LeafFrame, radius: float, side_local: int) -> np.ndarray:
    """Where a follower closes up behind its holder, on the lane: on the push side 1.1 m out; on
    the pull side 1.75 m out, clear of the puller, who stands outside the leaf's swing just on the
    lane's side of its edge."""
    if side_local > 0:
        return fr.lane(radius + 1.75)
    return fr.lane(-(radius + 1.1))


def _via(et: EtiquetteCore, fr: LeafFrame, leaf: int, p: np.ndarray, radius: float,
         target: np.ndarray, *, beyond: bool = False, crowd: CrowdState | None = None) -> np.ndarray:
    """``(K, 2)`` waypoints from ``p`` to ``target``: straight, unless ``p`` is in the pocket
    between an open leaf and the wall (the pull side, behind the leaf, inside its swing) and the
    target is not; then out to the swing's edge and round the leaf's free edge first.

    The leaf is ``leaf`` (in ``fr``) or, at a double door, the other leaf (issue 26): one who
    came up beside the wall behind a leaf someone holds open is in that leaf's pocket on its
    way to the other leaf's opening place, and went straight for it into the held leaf
    (door_double with the pram, seed 9: an opener stood behind the open leaf for the state's
    10 s, twice, and the queue behind it with it). With ``beyond`` (the doorway behavior's way
    out of a pocket), behind a leaf counts beyond its swing too, within the leaf's length and a
    radius, wherever the way on runs into it: walkers coming along the wall toward an open leaf's
    back stood packed there, one behind another out to 1.5 m from the hinge, the ones beyond
    the swing going straight for the lane into the leaf (the realism bench's double door, the
    ``decoupled`` model: a holder and four others standing 10–30 s each from 50 s on).

    Given ``crowd``, a holder standing beyond the leaf's free edge (HOF's key pose, on the leaf's
    back) widens the way round to pass outside the holder too (:func:`_round_holder`)."""
    end = np.asarray(target, np.float64).reshape(1, 2)
    ds = et.dstate[int(et.leaves.door[leaf])]
    pull_side = 1 if float(fr.m @ ds.n) > 0 else -1
    for k in [leaf, *(o for o in ds.leaves if o != leaf)]:
        f = fr if k == leaf else et.frame(k, pull_side)
        a = et.leaf_open(k, f)
        if a < math.radians(20.0):
            continue
        lx, ly = f.local(p)
        rho = f.outer(radius)
        tx, ty = f.local(target)
        target_behind = ty > 0.0 and math.hypot(tx, ty) < rho and math.atan2(ty, tx) > a
        if ly <= 0.0 or math.atan2(ly, lx) <= a + math.radians(3.0) or target_behind:
            continue
        if crowd is not None:
            rho = max(rho, _round_holder(et, crowd, k, f, a, p, radius))
        # In the pocket (inside the swing), or behind the leaf farther out, wherever the way on runs
        # into the leaf.
        tip = f.polar(f.w, a)
        along = float((p - f.hinge) @ (tip - f.hinge)) / f.w  # behind the leaf's back, not past its tip
        if math.hypot(lx, ly) < rho or ((k != leaf or (beyond and along < f.w + radius)) and _segments_apart(
                np.asarray(p, np.float64), end[0], f.hinge, tip) < radius + OUTER_MARGIN):
            return np.concatenate([round_edge(f, p, a, radius, a - math.radians(20.0), rho=rho), end])
    return end


def _round_holder(et: EtiquetteCore, crowd: CrowdState, leaf: int, fr: LeafFrame, a: float, p: np.ndarray,
                  radius: float) -> float:
    """How far from the hinge a way round ``leaf``'s free edge keeps a body of ``radius`` clear of
    the leaf's holder where that holder stands beyond the edge on the leaf's back (HOF's key pose,
    :meth:`~pedvr.etiquette.regions.LeafFrame.hold_beyond_tip`), holding the leaf wide open
    (within 10° of :data:`HOLD_ANGLE`, in HolderDec or HoldDoor); 0 where none does, or the body at
    ``p`` is the holder. Not while a leaf is opening: a puller stepping round with its edge is
    beyond a half-open leaf's angle, and everyone within two metres in front of that leaf then
    counted as behind it (door_double's pram, seeds 9 and 13: never through).

    Issue 26, door_single_flow seed 11: a pusher who had walked through held the door from beyond
    its edge for the other side's batch; a follower coming along the wall behind the leaf went
    round the edge between the holder and the leaf, 0.35 m apart, and stood there from 45 s to
    79 s; the last passage came at 86 s."""
    ds = et.dstate[int(et.leaves.door[leaf])]
    h = ds.holder.get(leaf)
    hw = et.walkers.get(h) if h is not None else None
    if hw is None or h not in et._row or hw.state not in (HOLDER_DEC, HOLD_DOOR) \
            or a < HOLD_ANGLE - math.radians(10.0):
        return 0.0  # only a leaf held wide open by a holder standing at it
    q = et.pos(crowd, h)
    if float(np.hypot(*(q - p))) < 1e-6:
        return 0.0
    qx, qy = fr.local(q)
    rq = et.radius(crowd, h)
    if qy <= 0.0 or not a < math.atan2(qy, qx) < a + math.radians(45.0) \
            or not fr.w <= math.hypot(qx, qy) <= fr.outer(rq) + rq:
        return 0.0  # not beyond the free edge, on the leaf's back
    return math.hypot(qx, qy) + rq + radius + OUTER_MARGIN


def _segments_apart(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> float:
    """The least distance between the segments ``p0``–``p1`` and ``q0``–``q1`` (0 where they cross)."""
    def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
        return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))

    if cross(q0, q1, p0) * cross(q0, q1, p1) < 0.0 and cross(p0, p1, q0) * cross(p0, p1, q1) < 0.0:
        return 0.0
    return min(point_segment(p0, q0, q1), point_segment(p1, q0, q1), point_segment(q0, p0, p1),
               point_segment(q1, p0, p1))


def round_edge(fr: LeafFrame, p: np.ndarray, a: float, radius: float, to: float, *,
               rho: float | None = None) -> np.ndarray:
    """``(K, 2)`` waypoints from ``p``, behind a leaf open ``a`` (in the pocket between it and the
    wall), round the leaf's free edge to the angle ``to`` in front of it: out to the swing's circle
    (its outer radius for a body of ``radius``), along it in legs of at most 20° to abeam of the
    edge, then on to ``to``.
    Every leg keeps the body's radius clear of the edge. Before, the path went straight from behind
    the leaf to the point in front, a chord that passed the edge 3 cm closer than a body's radius;
    ORCA's line off the edge held a holder walking through there (door_single_flow: 6 s in the
    pocket while the door swung shut behind the one it had handed over to). ``rho``: a wider
    circle than the swing's (round a holder standing beyond the edge, :func:`_round_holder`)."""
    rho = fr.outer(radius) if rho is None else rho
    lx, ly = fr.local(p)
    phi = max(math.atan2(ly, lx), a + math.radians(10.0))
    arc = np.linspace(phi, a, max(2, math.ceil((phi - a) / math.radians(20.0)) + 1))  # legs of <= 20°
    return np.stack([*(fr.polar(rho, float(t)) for t in arc), fr.polar(rho, to)])


def off_the_tip(fr: LeafFrame, p: np.ndarray, a: float, radius: float) -> np.ndarray | None:
    """``(K, 2)`` waypoints for a body on the pull side beyond the free edge of a leaf open ``a``,
    in line with the leaf (within :data:`TIP_CLEAR` of it about the hinge, in front of it, or up
    to :data:`TIP_BEHIND` behind it), on its way into the doorway: out to the swing's circle and
    round on it to :data:`TIP_CLEAR` in front of the leaf, where the way along the leaf into the
    doorway keeps the body's radius clear of the edge; None for a body elsewhere.

    Issue 26, door_single_flow: a puller stands just beyond the edge it held (``PULL_STAND``), and
    from there the straight way into the doorway passes the edge 4 cm closer than a body's
    radius. Walking on through after handing the door over (FinishDoor), it was either behind the
    edge (round it, :func:`round_edge`) or not (straight on) as it swayed across the leaf's line,
    re-planned the other way every decision tick, and stood at the edge: 13 s (seed 8 from 16 s).
    One way round for the whole stretch beyond the edge, either side of the line, ends that.
    Single doors only, as :data:`TAKE_STAND`: at door_double's half-width leaves, with the pram of
    ``tests/etiquette/test_carriers.py``, it left the pram on its side after 90 s in seeds 3 and 6
    (each change alone, this or ``DoorEtiquette._held_back``, let it through)."""
    lx, ly = fr.local(p)
    phi = math.atan2(ly, lx)
    rho = math.hypot(lx, ly)
    if ly <= 0.0 or rho < fr.w - 0.1 or not a - TIP_CLEAR < phi < a + TIP_BEHIND:
        return None
    out = fr.outer(radius)
    to = a - TIP_CLEAR
    n = max(1, math.ceil((phi - to) / math.radians(20.0)))
    pts = [fr.polar(out, phi + (to - phi) * (k + 1) / n) for k in range(n)]
    if rho < out - 0.1:
        pts.insert(0, fr.polar(out, phi))  # out to the circle first, radially
    return np.stack(pts)


def _ready(et: EtiquetteCore, f: Walker, crowd: CrowdState) -> bool:
    """A committed follower is ready for the holder's decision (App. B.3) once it has closed up
    (within :data:`READY_NEAR` of its place; or, blocked, it has stood still a second; or
    :data:`READY_AFTER` has passed since it committed); the user, whom nothing drives, at once.
    Effort (§5.1.1) is then read at the distance the follower waits at, as App. B.3 has it."""
    if f.is_user or f.state != FOLLOWER_INIT:
        return True
    if et.t - f.since >= READY_AFTER:
        return True
    if f.plan is not None and float(np.hypot(*(et.pos(crowd, f.id) - f.plan[-1]))) < READY_NEAR:
        return True
    return et.t - f.since > 1.0 and float(np.hypot(*crowd.vel[et._row[f.id]])) < 0.1


def _on_pull(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    """Whether the holder started on the leaf's pull side (the case it handles, App. B.2)."""
    assert w.frame is not None
    return w.side == _pull_side_world(et, w)


def _pull_side_world(et: EtiquetteCore, w: Walker) -> int:
    assert w.frame is not None
    ds = et.dstate[w.door]
    return 1 if float(w.frame.m @ ds.n) > 0 else -1


def _arc(et: EtiquetteCore, w: Walker, fr: LeafFrame, radius: float, p: np.ndarray, phi: float, *,
         facing: float, speed: float, lock: bool = True) -> None:
    """Walk round the leaf's swing circle (outside it, where no leaf angle reaches) to polar ``phi``."""
    rho = fr.outer(radius)
    lx, ly = fr.local(p)
    now = math.atan2(ly, lx)
    n = max(1, int(abs(phi - now) / math.radians(15.0)))
    pts = [fr.polar(rho, now + (phi - now) * (k + 1) / n) for k in range(n)]
    if math.hypot(lx, ly) < rho - 0.1:  # inside the circle: out to it first, radially
        pts.insert(0, fr.polar(rho, now))
    w.plan = np.asarray(pts)
    w.plan_i = 0
    w.face = facing
    w.lock = lock
    w.speed = speed
    w.waiting = False


def _toward(p: np.ndarray, q: np.ndarray) -> float:
    return math.atan2(q[1] - p[1], q[0] - p[0])


def _followers_in_sight(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> bool:
    """Someone who may follow: a walker at this door, not passing, within 6 m."""
    p = et.pos(crowd, w.id)
    for o in by_id.values():
        if o.id == w.id or o.role == PASSING or o.id not in et._row:
            continue
        if o.door == w.door and float(np.hypot(*(et.pos(crowd, o.id) - p))) < 6.0:
            return True
    return False


def _look_back(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> None:
    """§4.4: a considerate holder turns its head back to check for a follower."""
    if et.t - w.since < TICK * 1.5:
        ds = et.dstate[w.door]
        back = ds.centre + ds.n * w.side * 3.0
        et.body.gaze_at(w.id, (float(back[0]), 1.6, float(back[1])))


def _hold_pose(et: EtiquetteCore, w: Walker, crowd: CrowdState, action: str, pull: bool) -> None:
    """Where the holder stands while holding (HoldDoor): HOF beyond the open leaf's edge, HOL in
    (pulling) or just through (pushing) the doorway; the hand keeps the leaf at the held angle."""
    fr = w.frame
    assert fr is not None
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    p = et.pos(crowd, w.id)
    w.want = HOLD_ANGLE
    if action == "HOF":
        target, facing = fr.hold_beyond_tip(HOLD_ANGLE, radius)
        w.p_rel = 0.95 * fr.w
        lx, ly = fr.local(p)
        if not pull and ly < radius + 0.1 and math.hypot(lx, ly) < fr.outer(radius) - 0.05:
            target = fr.lane(radius + 0.45)  # pushing: through the doorway first
        elif (math.atan2(ly, lx) < HOLD_ANGLE - math.radians(20.0)
              and math.hypot(lx, ly) < fr.outer(radius) - 0.1):
            target = fr.polar(fr.outer(radius), HOLD_ANGLE - math.radians(25.0))  # out round the swing first
        et.walk_to(w, crowd, target, facing=facing, speed=0.7, lock=True)
    else:  # HOL: into (pull) or just through (push) the doorway, holding the leaf behind
        y = -0.05 if pull else radius + 0.15
        target = fr.world(0.42 * fr.w, y)
        facing = fr.heading(0.0, -1.0) if pull else fr.heading(0.0, 1.0)
        w.p_rel = 0.45 * fr.w
        lx, ly = fr.local(p)
        a = et.leaf_open(w.leaf, fr)
        tip = off_the_tip(fr, p, a, radius) if pull and et.doors[w.door].kind == "single" else None
        if tip is not None:  # the puller stands beyond the leaf's edge: round it into the doorway
            target = np.concatenate([tip, target[None]])
        elif pull and ly > 0.0 and math.atan2(ly, lx) > a - math.radians(3.0):
            target = fr.polar(fr.outer(radius), HOLD_ANGLE - math.radians(25.0))  # behind it: round the edge
        et.walk_to(w, crowd, target, facing=facing, speed=float(crowd.pref_speed[r]), lock=False)


def _finish(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> None:
    """NH, or done holding: pass through with the hand on the leaf, then let go (FinishDoor)."""
    if w.event is not None:
        et.end_hold(w, "passed")
    et.set_state(w, FINISH_DOOR)
    w.follower = NONE
    et.body.gaze_at(w.id, None)
    _finishing(et, w, crowd)


def _finishing(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> None:
    fr = w.frame
    assert fr is not None
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    p = et.pos(crowd, w.id)
    lx, ly = fr.local(p)
    pull = _on_pull(et, w, crowd)
    leaf = w.leaf
    a = et.leaf_open(leaf, fr)
    holding = w.arm >= 0
    if w.backing:
        _backing_through(et, w, crowd, fr, r, radius, ly, a, holding)
        return
    if pull:
        # from the pull side through to the push side
        out = fr.lane(-(radius + CLEAR + 0.5))
        tip = off_the_tip(fr, p, a, radius) if et.doors[w.door].kind == "single" else None
        if tip is not None:  # beyond the free edge, in line with the leaf: round the edge first
            target = np.concatenate([tip, out[None]])
        elif ly > 0.0 and math.atan2(ly, lx) > a - math.radians(3.0):  # behind the edge: round it first
            target = np.concatenate([round_edge(fr, p, a, radius, max(a - math.radians(25.0),
                                                                       math.radians(10.0))), out[None]])
        else:
            target = out
        if holding:
            w.want = max(a, math.radians(45.0))
            w.p_rel = min(max(math.hypot(lx, ly) - 0.1, 0.3 * fr.w), 0.95 * fr.w)
            if ly < -radius or et.t - w.since > STATE_TIMEOUT:
                et.let_go(w)
        done = ly < -(radius + CLEAR)
        facing = fr.heading(0.0, -1.0)
    else:
        if ly < radius + 0.2:
            target = fr.lane(radius + CLEAR + 0.4)
        else:
            target = fr.lane(radius + CLEAR + 0.6) if math.atan2(ly, lx) < a else fr.polar(
                fr.outer(radius) + 0.3, a + math.radians(15.0))
        if holding:
            w.want = max(a, math.radians(50.0))
            w.p_rel = min(max(math.hypot(lx, ly) - 0.1, 0.3 * fr.w), 0.95 * fr.w)
            if ly > min(0.9 * fr.w, radius + 0.6) or et.t - w.since > STATE_TIMEOUT:
                et.let_go(w)
        done = ly > radius + CLEAR and not holding
        facing = fr.heading(0.0, 1.0)
    if done or et.t - w.since > STATE_TIMEOUT + 4.0:
        if holding:
            et.let_go(w)
        et.finish(w, crowd)
        return
    et.walk_to(w, crowd, target, facing=facing, speed=float(crowd.pref_speed[r]), lock=False)


def _backing_through(et: EtiquetteCore, w: Walker, crowd: CrowdState, fr: LeafFrame, r: int, radius: float,
                     ly: float, a: float, holding: bool) -> None:
    """A pram pusher alone at a pull door (issue 26, "no carrier left behind"). §4.6 has a carrier
    with no free hand wait for help at a pull side, and after :data:`CARRIER_PATIENCE` alone
    pedvr's pusher frees a hand. Pushing, it cannot reach the handle: its pram, 0.8 m ahead of
    it, would stand in the leaf's swing, and it gave up again and again. So it does what real
    pushers do at a pull door: it turns round where it waits (:func:`_doorway_behavior`), backs
    up to the handle with its pram trailing out of the swing, pulls the leaf wide open stepping
    round the swing's edge (walking forward, its pram ahead of it and the leaf in the hand behind
    it) only as far as the passing lane (:func:`_lane_polar`), and backs down the lane through
    the doorway pulling its pram, holding the leaf until its body is through. The leaf
    then closes onto the pram's side and rests on it (leaves yield to the pram,
    ``Simulation._door_discs``) until it is through. Beyond the doorway, with room for the pram's
    sweep, it turns round to face its way.

    pedvr's choices (the paper has no such choreography): backwards at :data:`BACK_SPEED`, the
    body's own limit for stepping back (``[motion] max_backward_speed``); the turns at the body's
    standing turn rate; it holds the door for nobody (a follower committed to it is let go)."""
    back = fr.heading(0.0, 1.0)  # facing the pull side: the pram trails
    reach = float(crowd.ahead[r] + crowd.length[r])  # the pram's far end ahead of the pusher
    p = et.pos(crowd, w.id)
    lx = fr.local(p)[0]
    if holding:
        w.want = max(a, HOLD_ANGLE)
        w.p_rel = min(max(math.hypot(lx, ly) - 0.1, 0.3 * fr.w), 0.95 * fr.w)
        if ly < -radius or et.t - w.since > STATE_TIMEOUT:
            et.let_go(w)
    clear = ly < -(reach + BACK_CLEAR)
    if et.t - w.since > STATE_TIMEOUT + BACK_EXTRA:
        if w.arm >= 0:
            et.let_go(w)
        et.finish(w, crowd)
        return
    if not clear:
        # onto the lane first, where the pram lines up behind it, then straight down it
        end = fr.lane(-(reach + BACK_CLEAR + 0.2))
        on_lane = abs(lx - LANE_AT * fr.w) < BACK_ON_LANE or ly < radius + 0.2
        if on_lane:
            way, facing = end, back
        else:
            a_ly = min(max(ly - 0.3, BACK_LINE_UP), 2.0 * BACK_LINE_UP)
            line_up = fr.lane(a_ly)
            way = np.stack([line_up, end])
            facing = _toward(line_up, p) if ly > a_ly + 0.1 else back  # its back to the way
        et.walk_to(w, crowd, way, facing=facing, speed=BACK_SPEED, lock=True, backward=True)
        return
    ahead = fr.heading(0.0, -1.0)
    if abs(wrap_pi(float(crowd.heading[r]) - ahead)) > BACK_TURNED:
        et.stand(w, ahead)  # room for the pram's sweep: it turns round to face its way
        w.lock = True
        return
    et.finish(w, crowd)


def _pram_backs_out_of_swing(et: EtiquetteCore, w: Walker, crowd: CrowdState, r: int, leaf: int,
                             p: np.ndarray) -> bool:
    """A pram alone at the door (:func:`_alone`), its front in the pocket behind an open leaf
    (:func:`_pram_front_behind`), backs straight out, keeping its course, until the front is
    :data:`POCKET_CLEAR` beyond the swing; then the way round the leaf's edge can turn it (issue
    26). Returns whether it is backing. Traced (door_same_side with the pram alone and the user
    coming through from the push side, seed 1): the user held the door for it and let go as the
    pram reached the leaf's back; the leaf swung onto the pram's front, and the way round the edge
    drove the pram back into it, which a pram cannot turn (``Simulation._no_turning_into_leaves``)
    nor wait out: it stood there from 4 s to the end of the run. Its pusher need not be in the
    pocket: a pusher 1.6 m off the hinge, its pram's front holding the leaf open from behind, shoved
    the leaf to and fro until it gave the door up (the same set-up, the user from 4 m east; through
    at 45.5 s, now 27.5 s). (With others at the door this left `test_carriers.py`'s seed 6 behind,
    so it is for a pram alone.)"""
    if float(crowd.length[r]) <= 0.0 or not _alone(et, w):
        return False
    inside = _pram_front_behind(et, crowd, r, leaf)
    if inside <= 0.0:
        return False
    h = float(crowd.heading[r])
    ahead = np.array([math.cos(h), math.sin(h)])
    et.go_direct(w, p - ahead * (inside + 0.3), facing=h, speed=BACK_SPEED, lock=True)
    return True


def _pram_front_behind(et: EtiquetteCore, crowd: CrowdState, r: int, leaf: int) -> float:
    """How far (m) the front of row ``r``'s pram is inside the swing of ``leaf`` (plus
    :data:`POCKET_CLEAR`) behind it: the leaf open at least :data:`BACK_CLOSED` and the front
    beyond the leaf's angle, in the pocket between the open leaf and its wall; 0 if not there
    (or no pram)."""
    if float(crowd.length[r]) <= 0.0:
        return 0.0
    lv = et.leaves
    angle = float(lv.angle[leaf])
    a = abs(angle)
    if a < BACK_CLOSED:
        return 0.0
    fr = LeafFrame.of(lv.hinge[leaf], float(lv.base[leaf]), float(lv.length[leaf]), 1 if angle >= 0.0 else -1)
    h = float(crowd.heading[r])
    reach = float(crowd.ahead[r] + crowd.length[r])
    lx, ly = fr.local(crowd.pos[r] + reach * np.array([math.cos(h), math.sin(h)]))
    if math.atan2(ly, lx) <= a:
        return 0.0
    return max(0.0, float(lv.length[leaf]) + POCKET_CLEAR - math.hypot(lx, ly))


def _alone(et: EtiquetteCore, w: Walker) -> bool:
    """Nobody but ``w`` takes part in its door's etiquette (the user included, once it does),
    except a participant who has stood still for :data:`USER_STANDING_S` with no hand on a leaf:
    someone standing by a door, looking about, is not about to open it, and a pram pusher waiting
    on such a participant gave up every 10 s for as long as they stood there (issue 26). If they
    stand in its way, its steering keeps it off them, as it keeps off anyone. (One still on their
    way from the far side is counted: tried, a participant from 22 m beyond the door came through
    while the pram backed through, and ORCA, giving way, put the pram in the pocket behind the
    open leaf, where it stayed.)"""
    return not any(o.door == w.door and o.id != w.id and not _standing_user(et, o)
                   for o in et.walkers.values())


def _standing_user(et: EtiquetteCore, o: Walker) -> bool:
    return (o.is_user and o.role == APPROACH and et.user_leaf < 0
            and et.t - o.still_since >= USER_STANDING_S)  # False while it moves (still_since NaN)


def _lane_polar(fr: LeafFrame, radius: float) -> float:
    """Where the circle outside the leaf's swing crosses the passing lane (polar angle from the
    closed leaf): a pusher backing through pulls the leaf open stepping round to here, so that it
    backs straight down the lane with its pram in line behind it (_backing_through)."""
    return math.acos(min(1.0, LANE_AT * fr.w / fr.outer(radius)))


def _arm_for(et: EtiquetteCore, w: Walker, crowd: CrowdState, h: np.ndarray) -> int:
    """The arm on the side of point ``h``, for a pusher with its back to the door (_backing_through)."""
    r = et._row[w.id]
    th = float(crowd.heading[r])
    d = h - et.pos(crowd, w.id)
    return LEFT if math.cos(th) * float(d[1]) - math.sin(th) * float(d[0]) > 0.0 else RIGHT


def _give_up(et: EtiquetteCore, w: Walker, crowd: CrowdState, *, why: str) -> None:
    et.log("give_up", w, why=why)
    if w.arm >= 0:
        et.let_go(w)
    ds = et.dstate[w.door]
    for leaf, m in list(ds.mutex.items()):
        if m == w.id:
            del ds.mutex[leaf]
    if w.follower != NONE and w.follower in et.walkers:
        _demote(et.walkers[w.follower])
    w.follower = NONE
    _demote(w)
    w.backing = False  # a pusher that gave up backing through decides afresh (alone or not)


def _in_the_way(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> Walker:
    """Who commits as a holder's follower when ``w`` would (issue 26): ``w``, or the pedestrian of
    its own side who stands in its way to the doorway, nearest the door along that way.

    Alg. 2 commits the pedestrian whose leader is the holder, and pedvr's queue puts first whoever
    waited longest (:mod:`.ordering`, "Who is in front"). At a busy door the waiting crowd is a
    blob, not a line, and the one who waited longest may stand behind later arrivals who stopped
    nearer: committed, it had no way through them, they stood (their leaders are ahead of them),
    and the held door waited for it (door_single_flow seed 6: 6 s at 0.1 m/s behind two people
    touching shoulders). pedvr's reading: a pedestrian does not walk through people to take a held
    door; the one in its way nearest the door goes first, and the one who waited keeps its place
    in the queue and comes next. In its way: on the same side (and leaf), still approaching,
    between it and the doorway's middle, with the two bodies' discs overlapping across that way."""
    ds = et.dstate[w.door]
    cur = w
    for _ in range(4):
        p = et.pos(crowd, cur.id)
        d = ds.centre - p
        length = float(np.hypot(*d))
        if length < 1e-6:
            break
        u = d / length
        best, best_s = None, length
        for o in by_id.values():
            if (o.id == cur.id or o.is_user or o.role != APPROACH or o.side != cur.side or o.leaf != cur.leaf
                    or o.id not in et._row or o.helping != NONE):
                continue
            q = et.pos(crowd, o.id) - p
            s = float(q @ u)
            lateral = abs(float(q[0] * u[1] - q[1] * u[0]))
            if 0.0 < s < best_s and lateral < et.radius(crowd, cur.id) + et.radius(crowd, o.id):
                best, best_s = o, s
        if best is None:
            break
        cur = best
    return cur


def _demote(w: Walker) -> None:
    w.role = APPROACH
    w.state = -1
    w.holder = NONE
    w.leader = NONE
    w.plan = None
    w.action = ""
    w.frame = w.frame if w.arm >= 0 else None


# -- the follower ---------------------------------------------------------------------------------


def _follower(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> None:
    h = by_id.get(w.holder) if w.holder != NONE else None
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    p = et.pos(crowd, w.id)
    age = et.t - w.since
    if h is None or h.role != HOLDER or h.frame is None:
        _demote(w)
        return
    fr = h.frame
    side_local = 1 if w.side == _pull_side_world(et, h) else -1  # +1: the follower is on the pull side
    carrier = bool(et.carrying[r])
    if w.state == FOLLOWER_INIT:
        if h.action == "" or h.state < HOLDER_DEC:
            spot = _close_up(et, w, h, fr, radius, side_local)
            far = float(np.hypot(*(p - et.pos(crowd, h.id)))) > CATCH_UP_AT
            et.walk_to(w, crowd, _via(et, fr, h.leaf, p, radius, spot, crowd=crowd),
                       facing=_toward(spot, fr.lane(0.0)),
                       speed=float(crowd.pref_speed[r]) * (CATCH_UP if far else 1.0))
            if age > STATE_TIMEOUT + 6.0:
                _demote(w)
                h.follower = NONE
            return
        et.set_state(w, FOLLOWER_DEC)
    if w.state == FOLLOWER_DEC:
        if h.action == "HOF" or (carrier and h.action == "HOL"):
            if _oncoming(et, w, crowd):
                et.stand(w, _toward(p, fr.lane(0.0)))  # one coming through the other way first
                return
            if h.action == "HOF" and _front_reach(crowd, r) > 0.0 and et.t - w.since < HOF_LANE_WAIT \
                    and not _hof_lane_clear(et, h, crowd, radius):  # (w.since: when it entered FollowerDec)
                et.stand(w, _toward(p, fr.lane(0.0)))  # a pram waits for the holder to clear its lane
                return
            _pass_first(et, w, h, crowd, fr, side_local)
            return
        if h.action == "HOL" or (h.action == "NH" and not carrier and _catch_nh(et, w, h, crowd)):
            # NH at a busy door: the holder walks on through with its hand on the leaf, and the
            # committed follower catches the door at its edge before it swings shut (App. B.2,
            # module docstring) instead of letting it close and opening it again from the BOP
            et.set_state(w, REACH_EDGE)
        else:  # NH: the holder lets go; the follower opens the door itself (OpenerInit)
            _demote(w)
            w.leader = NONE
            return
    if w.state == REACH_EDGE:
        if _hand_on(et, w, h, by_id, crowd):
            return
        if side_local > 0 and not h.is_user and _past(et, w, crowd):
            # Pushed through the doorway on its way to the leaf's edge: it has passed, and a pulled
            # leaf cannot be taken over from its far side. Walking back to take it (and through a
            # second time) is what it did before; it goes on, and the holder holds for the next.
            _thank(et, w, h)
            h.follower = NONE
            et.finish(w, crowd)
            return
        a = et.leaf_open(h.leaf, fr)
        if side_local > 0:  # at the leaf's edge on the passage side, where the holder stood
            stand = TAKE_STAND if et.doors[w.door].kind == "single" else PULL_STAND
            target = fr.polar(fr.outer(radius), max(a, math.radians(60.0)) - stand)
            facing = _toward(target, fr.handle(a, 0.92))
            arm, at = RIGHT, 0.92
        else:  # from the push side: at the hinge jamb, beside the lane the holder comes through on
            target, facing = fr.world(0.6 * radius, -(radius + 0.1)), fr.heading(0.0, 1.0)
            arm, at = LEFT, 0.35
        et.walk_to(w, crowd, _via(et, fr, h.leaf, p, radius, target, crowd=crowd), facing=facing,
                     speed=float(crowd.pref_speed[r]))
        # HOL across the door: the holder passes first, so the follower takes the door over once
        # the holder is in or through the doorway (not while it is still on its own side)
        ds = et.dstate[w.door]
        h_there = h.is_user or h.side == w.side or \
            float((et.pos(crowd, h.id) - ds.centre) @ ds.n) * h.side < 0.0
        if (float(np.hypot(*(p - target))) < 0.3 and h_there) or age > 6.0:
            _take_over(et, w, h, crowd, arm=arm, at=at)
        elif age > STATE_TIMEOUT:
            _demote(w)
            h.follower = NONE
        return


def _hof_lane_clear(et: EtiquetteCore, h: Walker, crowd: CrowdState, half_width: float) -> bool:
    """Whether HOF's holder is out of the lane its follower passes along: its disc clear of a body
    ``half_width`` m to each side of the lane (:meth:`LeafFrame.lane`; a pram is as wide as its
    pusher's disc, :mod:`pedvr.crowd.footprint`).

    Issue 26, "no carrier left behind": a pram's pusher set off as the holder decided HOF, while
    the holder was still stepping round from the handle to its place beyond the leaf's edge,
    across the lane. The pram's front, a metre ahead of its pusher, met the holder; steering took
    the pusher round it on the hinge side and into the pocket behind the held leaf, where it stood
    until the passing state gave up (door_double with the pram, seed 18, 23-35 s: never through in
    90 s). A walker steps round the holder, as App. B.3's PF has it; a pram waits for the lane."""
    fr = h.frame
    assert fr is not None
    if h.is_user or h.id not in et._row:
        return True
    lx, _ = fr.local(et.pos(crowd, h.id))
    lane_x, _ = fr.local(fr.lane(0.0))
    return abs(lx - lane_x) >= float(crowd.radius[et._row[h.id]]) + half_width


def _ahead_of(et: EtiquetteCore, o: Walker, w: Walker, crowd: CrowdState) -> bool:
    """Whether ``o`` stands at least :data:`HAND_ON_AHEAD` nearer ``w``'s door than ``w`` does: one in
    ``w``'s way that ``w`` hands the door on to (:func:`_hand_on`, :func:`_pass_on`), not one side by
    side with it, each in the other's way."""
    centre = et.dstate[w.door].centre
    return _dist(et.pos(crowd, o.id), centre) <= _dist(et.pos(crowd, w.id), centre) - HAND_ON_AHEAD


def _hand_on(et: EtiquetteCore, w: Walker, h: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> bool:
    """Whether a follower on its way to take the door over from a holder of its own side hands that
    on to the one standing in its way (issue 26), as :func:`_in_the_way` does when it commits.

    The one who committed may not have closed up (a holder decides once it has stood blocked,
    :func:`_ready`), and the next in the queue moves up to the follower's place meanwhile: it then
    stands between the follower and the leaf's edge (door_single_flow seed 1 at 39-42 s and seed 7
    at 33-39 s: the follower worked round it at 0.1-0.4 m/s for 3 and 6 s while the holder waited
    at the door). Blocked (slower than :data:`HAND_ON_SPEED`), the follower lets the one in its way
    (:func:`_in_the_way`) take the door over, and keeps its own place in the queue as the next:
    the same reading as at the commitment, that nobody walks through people to take a held door.
    Single doors only: at door_double_queue's leaves it made the last passage later (seeds 1-8,
    ``bench/door_observations.py --only double_queue``: 29.1 / 33.8 s median / worst against
    28.6 / 30.6 s), and nothing there was traced to need it."""
    if w.is_user or h.is_user or w.side != h.side or w.helping != NONE or et.doors[w.door].kind != "single":
        return False
    r = et._row[w.id]
    if float(np.hypot(*crowd.vel[r])) >= HAND_ON_SPEED or bool(et.carrying[r]):
        return False
    o = _in_the_way(et, w, by_id, crowd)
    if o is w or bool(et.carrying[et._row[o.id]]):
        return False
    if not _ahead_of(et, o, w, crowd):
        return False  # side by side, each in the other's way: it would only come back (seed 5)
    _demote(w)
    o.role = FOLLOWER
    o.holder = h.id
    o.leader = h.id
    o.plan = None
    h.follower = o.id
    et.set_state(o, REACH_EDGE)
    et.log("hand_on", w, to=o.id, holder=h.id)
    return True


def _catch_nh(et: EtiquetteCore, w: Walker, h: Walker, crowd: CrowdState) -> bool:
    """Whether a committed follower whose holder decided NH catches the door behind it (issue 26).

    App. B.3 has the follower of NH open the door itself once the holder has let go; App. B.2 lets
    "the next holder interrupt the door closing procedure". pedvr reads the two together at a busy
    door: a follower within :data:`CATCH_RANGE` of the doorway, whose holder (an agent, not the
    user) still has its hand on the leaf, walks to the leaf's edge as a PL follower does and takes
    the door as the holder lets it go, so the door does not swing shut between close followers.
    Farther away, or behind a carrier (no free hand), it opens the door itself as App. B.3 has it."""
    if h.is_user or h.arm < 0:
        return False
    ds = et.dstate[w.door]
    return float(np.hypot(*(et.pos(crowd, w.id) - ds.centre))) <= CATCH_RANGE


def _oncoming(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    """Whether someone passing this door the other way is still in the doorway or coming out of it
    on ``w``'s side (a PF follower, or one about to open the door, waits for it: the doorway takes
    one way at a time). Passing the other way: a follower passing first, or a holder walking
    through after letting go (FinishDoor); an opener from the other side that did not wait met
    such a holder head-on in the doorway, where both stood for seconds."""
    ds = et.dstate[w.door]
    for o in et.walkers.values():
        if o.door != w.door or o.side == w.side or o.id not in et._row:
            continue
        if not (o.role == PASSING or (o.role == HOLDER and o.state == FINISH_DOOR)):
            continue
        rel = float((et.pos(crowd, o.id) - ds.centre) @ ds.n) * o.side  # > 0: still on its own side
        if rel > -(et.radius(crowd, o.id) + 0.35):
            return True
    return False


def _pass_first(et: EtiquetteCore, w: Walker, h: Walker, crowd: CrowdState, fr: LeafFrame,
                side_local: int) -> None:
    """PF: walk through the held door, thanking the holder on the way."""
    r = et._row[w.id]
    radius = float(crowd.radius[r])
    w.role = PASSING
    w.state = -1
    w.blocked_since = math.nan
    if h.follower == w.id and not bool(et.carrying[r]):
        # On its way: the holder is free for its next follower (the blue routine of Fig. 7), who
        # closes up while this one walks through (pipelined, module docstring). Not from a
        # carrier: it cannot catch the door (§4.6), so the holder holds on until it is through
        # (_passing frees it then; its next follower commits after that). Issue 26, "no carrier
        # left behind" (tests/etiquette/test_carriers.py): freed, a holder with nobody else to
        # hold for went through itself 0.6 s later and the leaf swung shut on the slower pram
        # (seed 6, through at 71 s), or held for the walkers behind the pram, who went first while
        # it was pushed off its lane (seed 17, never through).
        h.follower = NONE
    pts = _pf_points(fr, side_local, radius, reach=_front_reach(crowd, r), at=et.pos(crowd, w.id))
    via = _via(et, fr, h.leaf, et.pos(crowd, w.id), radius, pts[0], crowd=crowd)
    et.set_plan(w, crowd, np.concatenate([via[:-1], pts]), facing=fr.heading(0.0, -float(side_local)),
                speed=float(crowd.pref_speed[r]))


def _pf_points(fr: LeafFrame, side_local: int, radius: float, reach: float = 0.0,
               at: np.ndarray | None = None) -> np.ndarray:
    """PF's way through the held door: into the lane on its side, the doorway, out beyond it.

    A body whose footprint reaches ``reach`` m beyond its disc ahead (a pushed pram,
    :func:`_front_reach`) and that stands ``at`` farther out first lines up with the lane that
    much farther out, so that its front meets the doorway straight along the lane (issue 26, "no
    carrier left behind"): a pram that turned into the lane where a walker does had its front in
    the doorway while its pusher was still converging on the lane, grazing the other leaf's
    edge, or swinging into the pocket beside the held leaf (door_observations' pram at the
    double door, seed 1)."""
    pts = [fr.lane(side_local * (radius + 0.35)), fr.lane(0.0),
           fr.lane(-side_local * (radius + CLEAR + 0.35))]
    if reach > 0.0 and at is not None:
        out = _line_up_out(fr, radius, reach)
        if fr.local(at)[1] * side_local > out + 0.1:
            pts.insert(0, fr.lane(side_local * out))
    return np.stack(pts)


def _line_up_out(fr: LeafFrame, radius: float, reach: float) -> float:
    """How far out on the lane a body whose footprint reaches ``reach`` beyond its disc lines up:
    its front (when on the lane) out of the leaf's swing."""
    return max(radius + 0.35, fr.w + radius + 0.2) + reach


def _line_up(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> np.ndarray | None:
    """Where a pushed pram waits its turn at a double door: on its leaf's lane, :func:`_line_up_out`
    out, so that it walks through straight along the lane (None: not a pram, or not a double
    door). Issue 26, "no carrier left behind": a pusher that waited where it stopped, beside the
    lane or in front of the other leaf, had to turn into the lane in front of the doorway, and
    with its front a metre ahead of it, swung that front into the pocket beside the held leaf or
    against the other leaf's edge (door_observations' pram at door_double, seed 1: never through
    in 90 s)."""
    r = et._row[w.id]
    reach = _front_reach(crowd, r)
    ds = et.dstate[w.door]
    if reach <= 0.0 or et.doors[w.door].kind != "double" or w.leaf not in ds.leaves:
        return None
    fr = et.frame(w.leaf, w.side)
    side_local = 1 if fr.side_of(et.pos(crowd, w.id)) > 0 else -1
    return fr.lane(side_local * _line_up_out(fr, float(crowd.radius[r]), reach))


def _front_reach(crowd: CrowdState, r: int) -> float:
    """How far row ``r``'s rigid footprint (a pushed pram: ``ahead`` and the half ``length`` of
    its ellipse, :mod:`pedvr.crowd.footprint`) reaches ahead beyond its disc (0: none)."""
    if float(crowd.length[r]) <= 0.0:
        return 0.0
    return max(float(crowd.ahead[r]) + float(crowd.length[r]) - float(crowd.radius[r]), 0.0)


def _take_over(et: EtiquetteCore, w: Walker, h: Walker, crowd: CrowdState, *, arm: int, at: float) -> None:
    """PL: the follower takes the door (ReachEdge → ReleaseDoor) and is its holder now (red routine)."""
    leaf = h.leaf
    ds = et.dstate[w.door]
    fr = h.frame
    assert fr is not None
    et.log("take_over", w, holder=h.id, leaf=leaf)
    _thank(et, w, h)
    if h.is_user:
        et._user_release()
    else:
        et.end_hold(h, "took over")
        h.follower = NONE
        ds.holder.pop(leaf, None)
        if h.arm >= 0:
            et.body.reach_for(h.id, None, side="right" if h.arm == RIGHT else "left")
        h.arm = -1
        _finish(et, h, crowd)
    w.role = HOLDER
    w.holder = NONE
    w.frame = fr
    w.leaf = leaf
    et.take_leaf(w, leaf, arm=arm, p_rel=at, open_to=None)
    w.want = max(et.leaf_open(leaf, fr), math.radians(80.0))
    et.set_state(w, HOLDER_DEC)
    w.action = ""
    w.follower = NONE


def _thank(et: EtiquetteCore, w: Walker, h: Walker) -> None:
    """A follower thanks its holder: eyes on the holder, then a nod (a short dip of the gaze) or a
    small wave, drawn from the etiquette's generator."""
    if w.thanked or w.is_user or w.id not in et._row:
        return
    w.thanked = True
    et.thanks += 1
    target: object = "user" if h.is_user else ("agent", h.id)
    et.body.gaze_at(w.id, target)
    if float(et.rng.random()) < 0.5:
        et.body.gesture(w.id, "wave", duration=1.0)
        how = "wave"
    else:
        agent = w.id

        def dip() -> None:
            if agent in et._row and h.id in et._row:
                hp = et.body.state.world_pos[et._row[h.id], sk_head()]
                et.body.gaze_at(agent, (float(hp[0]), float(hp[1]) - 0.35, float(hp[2])))
                et.later(0.35, lambda: et.body.gaze_at(agent, target) if agent in et._row else None)

        et.later(0.3, dip)
        how = "nod"
    et.later(1.6, lambda: et.body.gaze_at(w.id, None) if w.id in et._row else None)
    et.log("thank", w, holder=h.id, how=how, to_user=h.is_user)


def sk_head() -> int:
    from pedvr.body import skeleton as sk

    return sk.HEAD


def _passing(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> None:
    p = et.pos(crowd, w.id)
    ds = et.dstate[w.door]
    h = by_id.get(w.holder) if w.holder != NONE else None
    if h is not None and not w.thanked and h.id in et._row:
        if float(np.hypot(*(et.pos(crowd, h.id) - p))) < THANK_RANGE:
            _thank(et, w, h)
    if h is not None and _pass_on(et, w, h, by_id, crowd):
        return
    rel = float((p - ds.centre) @ ds.n) * w.side
    r = et._row[w.id]
    fr = h.frame if h is not None and h.frame is not None else (
        et.frame(w.leaf, w.side) if w.leaf in ds.leaves else None)
    if fr is not None and w.leaf in ds.leaves and w.leaf not in ds.holder and w.leaf not in ds.mutex:
        # Its holder has let go before it was through (the participant held the door, walked on
        # and let go; door_same_side, issue 26), and it is no longer passing a held door: back to
        # the doorway behavior, where a carrier waits for help or frees a hand and a pram backs out
        # of the pocket behind a leaf first. Either way it waited out the passing state's 20 s:
        # a carrier whose door shut in front of it on its pull side (the user from 8 m east), and
        # a pram whose front was in the pocket, where the way round the edge drove it into the
        # leaf's back, which it held open and which swung back onto it (the user from 4 m east).
        why = ""
        if bool(et.carrying[r]) and fr.side_of(p) > 0 and et.leaf_open(w.leaf, fr) < BACK_CLOSED:
            why = "door_shut_before_carrier"
        elif w.plan is not None and _pram_front_behind(et, crowd, r, w.leaf) > 0.0:
            why = "pram_caught_behind_leaf"
        if why:
            et.log(why, w)
            _demote(w)
            return
    if fr is not None and w.plan is not None and w.leaf in ds.leaves:
        # pushed into the pocket behind the open leaf on its way: out round the leaf's edge first
        side_local = 1 if w.side == (1 if float(fr.m @ ds.n) > 0 else -1) else -1
        pts = _pf_points(fr, side_local, float(crowd.radius[r]), reach=_front_reach(crowd, r), at=p)
        via = _via(et, fr, w.leaf, p, float(crowd.radius[r]), pts[0], crowd=crowd)
        if via.shape[0] > 1 and w.gait_legs != via.shape[0] - 1 + pts.shape[0]:
            et.set_plan(w, crowd, np.concatenate([via[:-1], pts]), facing=w.face, speed=w.speed)
    if rel < -(float(crowd.radius[r]) + CLEAR) or (w.plan is not None and et.arrived(w, crowd, 0.3)):
        if h is not None and h.follower == w.id:
            h.follower = NONE
        et.finish(w, crowd)
    elif et.t - w.since > STATE_TIMEOUT + 10.0 and w.state == -1:
        et.finish(w, crowd)  # it could not get through: the door is given up (no passage counted)


def _pass_on(et: EtiquetteCore, w: Walker, h: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> bool:
    """Whether a pedestrian passing first (PF) through a held single door lets the one of its own
    side standing in its way pass instead (issue 26), as a follower on its way to take the door over
    does (:func:`_hand_on`): nobody walks through people to pass a held door.

    The one in its way (:func:`_in_the_way`) arrived after it set off and slid into the doorway's
    mouth as it stopped. door_single_flow seed 10 from 22 s, under a waiting rule tried in stop 46
    and not kept (README, change 22): the PF follower stood behind it at
    0.05 m/s for 22 s, the holder's next follower on the other side waited for the PF one to come
    through (:func:`_oncoming`), and the one in the way waited for that next follower's queue;
    nobody passed the door from 21 to 45 s. Blocked (slower than :data:`HAND_ON_SPEED` for
    :data:`PASS_ON_AFTER`) on its own side of the doorway, the PF walker goes back to the doorway
    behavior, keeping its place in the queue, and the one in its way passes first through the same
    held door. Not for the user, a carrier (who cannot be passed by in the doorway) or a helper.
    Blocked for a moment is not blocked: handing on at the first slow tick (door_single_flow seed
    21 at 50.5 s) sent back one who was through 2 s later without it, and the door passed 5
    instead of 7 in the next 7 s."""
    if w.is_user or h.is_user or h.role != HOLDER or h.frame is None or w.helping != NONE \
            or et.doors[w.door].kind != "single" or w.leaf not in et.dstate[w.door].holder:
        return False
    r = et._row[w.id]
    if float(np.hypot(*crowd.vel[r])) >= HAND_ON_SPEED or bool(et.carrying[r]):
        w.blocked_since = math.nan
        return False
    if math.isnan(w.blocked_since):
        w.blocked_since = et.t
    if et.t - w.blocked_since < PASS_ON_AFTER:
        return False
    ds = et.dstate[w.door]
    p = et.pos(crowd, w.id)
    if float((p - ds.centre) @ ds.n) * w.side < float(crowd.radius[r]):
        return False  # in the doorway already
    o = _in_the_way(et, w, by_id, crowd)
    if o is w or bool(et.carrying[et._row[o.id]]):
        return False
    if not _ahead_of(et, o, w, crowd):
        return False  # side by side: each in the other's way
    _demote(w)
    w.blocked_since = math.nan
    o.holder = h.id
    o.leader = h.id
    o.leaf = h.leaf
    _pass_first(et, o, h, crowd, h.frame, 1 if o.side == _pull_side_world(et, h) else -1)
    et.log("pass_on", w, to=o.id, holder=h.id)
    return True


def _through(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    ds = et.dstate[w.door]
    rel = float((et.pos(crowd, w.id) - ds.centre) @ ds.n) * w.side
    return rel < -(0.25 + CLEAR)


def _at_doorway(et: EtiquetteCore, w: Walker, crowd: CrowdState) -> bool:
    ds = et.dstate[w.door]
    rel = et.pos(crowd, w.id) - ds.centre
    return abs(float(rel @ ds.n)) < 0.7 and abs(float(rel @ ds.u)) < 0.5 * et.doors[w.door].width + 0.2


# -- the user ------------------------------------------------------------------------------------


def _user_walker(et: EtiquetteCore, w: Walker, by_id: dict[int, Walker], crowd: CrowdState) -> None:
    """The user is observed: a follower of an agent holder (who decides for the user), or a
    holder whose followers respond PF (the user stays on the approach side) or PL (the user is in
    or through the doorway: they take the door over)."""
    if w.role == HOLDER:
        if w.frame is None or w.leaf < 0:
            return
        a = et.leaf_open(w.leaf, w.frame)
        if a < math.radians(60.0):
            w.state = OPEN_DOOR
            return
        w.state = HOLDER_DEC if w.follower == NONE else HOLD_DOOR
        f = by_id.get(w.follower) if w.follower != NONE else None
        if f is not None and w.action == "":
            lx, ly = w.frame.local(et.pos(crowd, w.id))
            f_pull = 1 if f.side == _pull_side_world(et, w) else -1
            past = ly * f_pull < 0.3  # the user is in the doorway or on the far side from the follower
            w.action = "HOL" if past else "HOF"
            et.log("user_holds", w, follower=f.id, action=w.action)
        if f is None:
            w.action = ""
        return
    # as a follower: an agent holder in the critical phase whose ordering puts the user next
    leader = by_id.get(w.leader) if w.leader != NONE else None
    ds = et.dstate[w.door]
    crossed = float((et.pos(crowd, w.id) - ds.centre) @ ds.n) * w.side < 0.0  # through: nobody to hold for
    if w.role == APPROACH and leader is not None and leader.role == HOLDER and not leader.is_user \
            and leader.state >= HOLDER_DEC and leader.follower == NONE and _accepts(leader) and not crossed:
        w.role = FOLLOWER
        w.holder = leader.id
        leader.follower = w.id
        et.set_state(w, FOLLOWER_INIT)
    elif w.role == FOLLOWER:
        h = by_id.get(w.holder)
        if h is None or h.follower != w.id:
            w.role = APPROACH
            w.holder = NONE
            w.state = -1
