"""The crowd as a structure of arrays.

Every per-agent quantity is a row in one array; row order is internal and may
change when agents are removed, while ``ids`` are stable for the life of the
simulation. The user agent, when present, is an ordinary row with
``is_user`` set: it is avoided but never steered.

Shapes, dtypes and units (N agents):

=================  ===========  =======  ==========================================
field              shape        dtype    meaning
=================  ===========  =======  ==========================================
ids                (N,)         int64    stable agent id
pos                (N, 2)       float64  position of the disc centre, m
vel                (N, 2)       float64  current velocity, m/s
pref_vel           (N, 2)       float64  preferred velocity from the planner, m/s
heading            (N,)         float64  body facing, rad, CCW from +x
pref_heading       (N,)         float64  preferred facing (toward the waypoint), rad
radius             (N,)         float64  disc radius, m
pref_speed         (N,)         float64  comfortable walking speed, m/s
max_speed          (N,)         float64  speed limit for ORCA, m/s
responsibility     (N,)         float64  share ρ of avoidance taken toward the user
is_user            (N,)         bool     the row is the user agent
limits             (N, 6)       float64  motion limits, columns LIMIT_* below
turn               (N,)         float64  shoulder turn τ in [0, 1] (0: the disc)
torso              (N,)         float64  torso facing while turned, rad, CCW from +x
ahead              (N,)         float64  a pushed object's footprint: centre ahead of pos, m
length             (N,)         float64  its half length along the heading, m (0: none)
=================  ===========  =======  ==========================================

``turn`` and ``torso`` describe the footprint (:mod:`pedvr.crowd.footprint`):
a disc of ``radius`` unless the agent turned its shoulders to squeeze past
someone. They may be left out when constructing a state: then every row is a
disc (``turn`` 0, ``torso`` 0). ``length > 0`` marks a rigid footprint that
reaches ahead of the body (a perambulator and its pusher, §4.6 of Huang &
Terzopoulos): an ellipse along the heading (:func:`pedvr.crowd.footprint.footprints`);
left out, there is none.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

# Columns of ``limits``: what the body can do this step (see MotionLimits).
LIMIT_ACCEL = 0  # m/s^2 speeding up
LIMIT_DECEL = 1  # m/s^2 slowing down
LIMIT_TURN_STANDING = 2  # rad/s
LIMIT_TURN_WALKING = 3  # rad/s
LIMIT_BACKWARD = 4  # m/s
LIMIT_SIDEWAYS = 5  # m/s
N_LIMITS = 6


@dataclass
class CrowdState:
    ids: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    pref_vel: np.ndarray
    heading: np.ndarray
    pref_heading: np.ndarray
    radius: np.ndarray
    pref_speed: np.ndarray
    max_speed: np.ndarray
    responsibility: np.ndarray
    is_user: np.ndarray
    limits: np.ndarray
    turn: np.ndarray = field(default_factory=lambda: np.zeros(0))
    torso: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ahead: np.ndarray = field(default_factory=lambda: np.zeros(0))
    length: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        n = len(self)
        for name in ("turn", "torso", "ahead", "length"):  # built without footprints: every row a disc
            if getattr(self, name).shape[0] != n:
                setattr(self, name, np.zeros(n))

    @classmethod
    def empty(cls) -> CrowdState:
        return cls(
            ids=np.zeros(0, np.int64),
            pos=np.zeros((0, 2)),
            vel=np.zeros((0, 2)),
            pref_vel=np.zeros((0, 2)),
            heading=np.zeros(0),
            pref_heading=np.zeros(0),
            radius=np.zeros(0),
            pref_speed=np.zeros(0),
            max_speed=np.zeros(0),
            responsibility=np.zeros(0),
            is_user=np.zeros(0, np.bool_),
            limits=np.zeros((0, N_LIMITS)),
        )

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    def append(self, other: CrowdState) -> None:
        """Add the rows of ``other`` (between steps only)."""
        for f in fields(self):
            setattr(self, f.name, np.concatenate([getattr(self, f.name), getattr(other, f.name)]))

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the rows where ``mask`` is true (between steps only)."""
        for f in fields(self):
            setattr(self, f.name, np.ascontiguousarray(getattr(self, f.name)[mask]))

    def index_of(self, agent_id: int) -> int:
        hit = np.flatnonzero(self.ids == agent_id)
        if hit.size == 0:
            raise KeyError(f"no agent with id {agent_id}")
        return int(hit[0])

    def copy(self) -> CrowdState:
        return CrowdState(**{f.name: getattr(self, f.name).copy() for f in fields(self)})
