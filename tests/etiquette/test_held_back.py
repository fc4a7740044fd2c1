"""A walker held back on its way to a key pose turns toward where it wants to go, not toward where
it drifts (``DoorEtiquette.face`` and ``_held_back``, issue 26).

The body turns toward its motion, and coupled ORCA keeps the motion inside the body's limits,
narrow sideways: a puller facing the handle, told to walk on into the doorway (HOL), was deflected
by the leaf's edge, turned with the deflection, drifted at 0.2 m/s into the leaf and stood at its
edge for 40 s (door_single_flow seed 12 from 38 s: the last passage at 79 s)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from pedvr.etiquette.core import Walker
from pedvr.etiquette.system import HELD_BACK_ANGLE, HELD_BACK_SPEED, DoorEtiquette
from pedvr.etiquette.vocab import HOLD_DOOR, HOLDER

DT = 1.0 / 90.0
TURN = 3.0  # rad/s: the standing turn rate (limits[:, 2])


def _face(vel: tuple[float, float], *, want: float = 0.0, plan: bool = True, lock: bool = False,
          length: float = 0.0, prev: float = -1.14, coupled: bool = True) -> float:
    """The facing ``face`` leaves for one walker (row 0) whose body turned toward its motion."""
    w = Walker(id=7, door=0, side=1, role=HOLDER, state=HOLD_DOOR)
    w.plan = np.array([[1.0, 0.0]]) if plan else None
    w.lock = lock
    w.face = math.nan if not lock else want
    et = SimpleNamespace(walkers={7: w}, _row={7: 0}, _held_back=DoorEtiquette._held_back)
    limits = np.zeros((1, 6))
    limits[0, 2] = TURN
    crowd = SimpleNamespace(pref_heading=np.array([want]), pref_vel=np.array([[1.3 * math.cos(want),
                                                                             1.3 * math.sin(want)]]),
                            vel=np.array([vel]), limits=limits, length=np.array([length]))
    body = np.array([math.atan2(vel[1], vel[0]) if np.hypot(*vel) > 0.05 else prev])  # toward the motion
    return float(DoorEtiquette.face(et, body, np.array([prev]), crowd, DT, coupled=coupled)[0])


def test_a_held_back_walker_turns_toward_where_it_wants_to_go() -> None:
    # the puller of door_single_flow seed 12 at 38.3 s: facing -1.14 rad, wanting +x (0 rad),
    # drifting at 0.22 m/s down toward the leaf
    out = _face((0.09, -0.2))
    assert math.isclose(out, -1.14 + TURN * DT)
    # standing still it turns the same way
    assert math.isclose(_face((0.0, 0.0)), -1.14 + TURN * DT)


def test_who_is_not_held_back() -> None:
    drift = (0.09, -0.2)
    motion = math.atan2(drift[1], drift[0])
    # walking at speed, or slowly the way it wants: the body's own turn stands
    assert math.isclose(_face((1.2, 0.1)), math.atan2(0.1, 1.2))
    off = -0.8 * HELD_BACK_ANGLE
    slow_on = (0.9 * HELD_BACK_SPEED * math.cos(off), 0.9 * HELD_BACK_SPEED * math.sin(off))
    assert math.isclose(_face(slow_on), math.atan2(slow_on[1], slow_on[0]))
    # standing (no key pose to walk to), facing a key pose (locked: the older rule), a pushed pram
    assert math.isclose(_face(drift, plan=False), motion)
    assert math.isclose(_face(drift, length=0.5), motion)
    assert math.isclose(_face(drift, coupled=False), motion)  # decoupled: the paper's plain discs
    assert math.isclose(_face(drift, lock=True, want=0.0), -1.14 + TURN * DT)  # the lock's own turn
