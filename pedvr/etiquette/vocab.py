"""The etiquette's shared vocabulary: roles, App. B's states and the constants the door models share
(Huang & Terzopoulos §4.2–4.6, App. B).

This module imports nothing of :mod:`pedvr.etiquette`: the state (:mod:`.core`), the door models
(:mod:`.interaction`, :mod:`.revolving`), the smart objects (:mod:`.objects`) and the layer that
runs them (:mod:`.system`) all read their names from here, so none of them needs another to know
what a ``HOLDER`` or ``HOLD_DOOR`` is (issue 24, "the house": no import circles in a room).
"""

from __future__ import annotations

import math

NONE = -1  # no pedestrian (no leader, no follower, no holder)

# Roles of a pedestrian at a door.
APPROACH, FOLLOWER, HOLDER, PASSING, ENTRANT, RIDER, EXITING = range(7)
ROLE_NAMES = ("approach", "follower", "holder", "passing", "entrant", "rider", "exiting")
# App. B's states.
(OPENER_INIT, REACH_DOOR, OPEN_DOOR, HOLDER_DEC, HOLD_DOOR, FOLLOWER_INIT, FOLLOWER_DEC, REACH_EDGE,
 RELEASE_DOOR, FINISH_DOOR) = range(10)
STATE_NAMES = ("OpenerInit", "ReachDoor", "OpenDoor", "HolderDec", "HoldDoor", "FollowerInit",
               "FollowerDec", "ReachEdge", "ReleaseDoor", "FinishDoor")

OPENER_RANGE = 1.6  # m from the BOP within which a leaderless pedestrian takes the door (Alg. 2)
REPLAN_AT = 0.05  # m a key pose moves before App. C's steps to it are generated again
ARRIVE = 0.12  # m: a key pose is reached
REACH_TIME = 0.35  # s: the hand reaches the handle (ReachDoor)
DECIDE_WAIT = 0.6  # s: a holder in HolderDec waits this long for a follower to commit
PASS_CONFIRM = 0.4  # m beyond the doorway line at which a body that crossed the doorway has passed
CLEAR = 0.45  # m past the doorway line (plus the radius) at which a walker has passed
PURSUIT_LOOK = 0.8  # m: a pram's pusher aims this far on along its keys (etiquette.system.pursuit_point)
RUSH_SPEEDUP = 0.4  # a pedestrian walks (1 + RUSH_SPEEDUP * Rush) times its speed near a doorway
CATCH_UP = 1.3  # a committed follower farther than CATCH_UP_AT from its holder walks this much faster
CATCH_UP_AT = 2.5  # m
STATE_TIMEOUT = 10.0  # s: a door state that has not moved on gives up (never a deadlock)
HOLD_TIMEOUT = 12.0  # s: a holder waits this long for an agent follower
CARRIER_PATIENCE = 8.0  # s: a carrier alone at a pull side frees a hand after this long
HELP_RANGE = 6.0  # m: a pedestrian behind a carrier this close overtakes to open the door (§4.6)
DEADLOCK_AFTER = 20.0  # s of waiting with the doorway free: a deadlock (the metric)
WAIT_ENDS = 5.0  # s of walking on without waiting that end a wait at a door (door_deadlocks)
DEADLOCK_FREE_S = 3.0  # s the doorway must have stayed free for a long wait to count as a deadlock
USER_AFTER_PASS = 4.0  # s after going through a door in which the user is not taken to approach it
SENSE_USER = 0.2  # m/s: the user walking toward a door faster than this takes part in its ordering
USER_STANDING_S = 2.0  # s: the user standing (below SENSE_USER) this long, no hand on a leaf, is not coming
THANK_RANGE = 2.5  # m: a follower thanks its holder when passing this close
LEAF_REACH = 0.9  # m: a hand farther than this from its leaf lets go
IDLE_ANGLE = math.radians(1.2)  # rad: a holding hand's idle sway along the door's swing
IDLE_LIFT = 0.012  # m: and up and down
GRAB_REACH_S = 1.5  # s: a press of E or the trigger takes a handle that comes within reach this soon

