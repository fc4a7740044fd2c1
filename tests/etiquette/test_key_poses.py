"""App. C's step generator carries the key-pose moves of the door interaction (issue 24 item 7):
the walk to the BOP, the push into the doorway, the holding poses, the follower closing up and
reaching the edge, passing first, and the holder passing through; only a target that moves while
it is walked to is walked to straight (the puller stepping round with the opening leaf's edge)."""

from __future__ import annotations

import collections

import numpy as np

from pedvr.body.steps import C_S2
from pedvr.etiquette.vocab import (
    FINISH_DOOR,
    FOLLOWER,
    FOLLOWER_INIT,
    HOLD_DOOR,
    HOLDER,
    OPEN_DOOR,
    OPENER_INIT,
    PASSING,
    REACH_EDGE,
    STATE_NAMES,
)
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation

KEY_POSE_STATES = {HOLDER: (OPENER_INIT, OPEN_DOOR, HOLD_DOOR, FINISH_DOOR), FOLLOWER: (FOLLOWER_INIT, REACH_EDGE)}


def test_key_pose_moves_are_app_c_steps() -> None:
    sim = Simulation(load_scene(resolve_scene("door_opposing")), seed=2)
    et = sim.etiquette
    assert et is not None
    seen: collections.Counter[str] = collections.Counter()
    straight: list[tuple[float, int, str]] = []
    while sim.t < 30.0:
        for _ in range(3):
            sim.step()
        for w in et.walkers.values():
            if w.is_user or w.plan is None:
                continue
            r = et.row(w.id)
            assert r is not None
            if float(np.hypot(*(sim.crowd.pos[r] - w.plan[-1]))) < 0.3:
                continue  # there: no move to speak of
            if w.role == PASSING and w.holder >= 0:
                what = "PF"
            elif w.state in KEY_POSE_STATES.get(w.role, ()):
                what = STATE_NAMES[w.state]
                if w.state == OPEN_DOOR and w.side == (1 if float(w.frame.m @ et.dstate[w.door].n) > 0 else -1):
                    continue  # pulling: stepping round with the leaf's edge as it opens (a moving target)
            else:
                continue
            seen[what] += 1
            if w.gait != "steps":
                straight.append((round(sim.t, 2), w.id, what))
                continue
            gaps = np.hypot(*np.diff(np.vstack([sim.crowd.pos[r], w.plan[w.plan_i:]]), axis=0).T)
            assert gaps[1:].max(initial=0.0) <= C_S2 + 1e-9, (what, w.plan)  # root keys a step apart
    assert not straight, straight
    for what in ("OpenerInit", "HoldDoor", "FollowerInit", "ReachEdge", "FinishDoor"):
        assert seen[what] >= 3, seen
