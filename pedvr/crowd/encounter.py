"""The user encounter: responsibility ρ as a share of the whole avoidance, personal space.

Why not ORCA's share
    ORCA splits the velocity correction ``u`` of each pair: agent ``i`` takes
    ``share * u`` (0.5 between virtual agents). Toward the user, PedVR §6 varies
    that share (0, 25, 50, 100 %) as a study variable. Per step it is void: the
    user does not reciprocate, so after one step the remaining correction is
    ``(1 - ρ) u``, of which the agent takes ``ρ`` again, and so on; at 90 Hz the
    agent has taken all of it within a fraction of a second, whatever ρ. pedvr
    therefore makes ρ a share of the *encounter*.

The model (pedvr's interpretation of PedVR §3.5 and §6; DESIGN.md "crowd")
    An encounter starts when, with the agent walking its *planned* velocity and
    the user keeping theirs, they would come closer than the clearance
    ``R = r_i + r_u + personal_space`` within ``ENGAGE_TIME`` seconds (and are
    within ``ENGAGE_DIST``). At that moment the model fixes

    * the side ``n`` (a unit vector across the relative motion): the agent passes
      on the side where it already is, or, head on, on its right;
    * the predicted miss distance ``M0`` along ``n`` and the clearance still
      needed ``S0 = R - M0``.

    While it lasts, the user's own lateral evasion ``U`` is measured (the user's
    velocity change across ``n`` since the start, integrated), and the agent
    aims its planned miss distance at

        ``M* = M0 + U + min(ρ S, max(0, S - U))``, ``S = S0 - min(U, 0)``:

    it takes its share ``ρ S0`` early and smoothly (a lateral preferred velocity
    that closes the gap within ``clip(t_ca - safety_horizon, 0.4, 1.5)`` s, at most
    ``MAX_LATERAL`` m/s), leaves ``(1 - ρ) S0`` to the user, and does less if the
    user does more (if the user comes toward it instead, ``U < 0``, the clearance
    needed grows and so does the share). Nothing of this is a constraint: it shapes the preferred
    velocity, and ORCA keeps everyone apart, so a margin that does not fit cannot
    cause a jam.

    If the user has not done their part, the *late safety step* does it: the
    user's ORCA line (:mod:`pedvr.crowd.orca`) has share 1, contact radii and
    the short horizon ``safety_horizon`` (default 1 s), so the agent makes a
    visibly hurried step aside about a second before contact, and only then. A
    study that wants pure ρ switches it off (``steering.user_safety = false``):
    then nothing but the contact pass keeps bodies apart, and the metrics count
    the contacts.

Personal space, shrinking where there is no room
    ``personal_space`` (default 0.3 m) widens the clearance the agent aims for,
    not the contact radius. The agent never aims further than the free room
    beside it: a ray along ``n`` to the nearest wall caps ``M*`` (corridors,
    doorways). Where even the bodies would not pass with its disc, the agent is
    *short of room*: it turns its shoulders (:mod:`pedvr.crowd.footprint`) and aims
    for the room its narrower, turned footprint leaves.

Units: m, s, m/s. Rows align with the crowd; the user row is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from pedvr.crowd.footprint import DEPTH_RATIO
from pedvr.world.visibility_kernels import raycast

ENGAGE_TIME = 4.0  # s before the closest approach an encounter starts
ENGAGE_DIST = 8.0  # m: and only within this distance of the user
MAX_LATERAL = 0.6  # m/s: the share is taken at most this fast (a brisk side step)
ROOM_RAY = 4.0  # m: how far the room beside the agent is looked for
CONTACT_BUFFER = 0.03  # m: short of room when even this much clearance beyond contact does not fit
TURN_DIST = 4.0  # m: a short-of-room agent turns its shoulders once the user is this close
USER_MOVING = 0.3  # m/s: a short-of-room agent waits for a user walking faster; a slower one it squeezes past


@dataclass
class EncounterState:
    """Per-row encounter state (rows align with the crowd)."""

    on: np.ndarray  # (N,) bool: an encounter with the user is running
    axis: np.ndarray  # (N, 2) unit: the side n the agent passes on, fixed at the start
    miss0: np.ndarray  # (N,) m: predicted miss distance along n at the start, M0
    need: np.ndarray  # (N,) m: clearance still needed at the start, S0
    user_shift: np.ndarray  # (N,) m: the user's lateral evasion since the start, U
    user_v0: np.ndarray  # (N, 2) m/s: the user's velocity at the start

    @classmethod
    def rows(cls, n: int) -> EncounterState:
        return cls(on=np.zeros(n, np.bool_), axis=np.zeros((n, 2)), miss0=np.zeros(n), need=np.zeros(n),
                   user_shift=np.zeros(n), user_v0=np.zeros((n, 2)))

    def append(self, other: EncounterState) -> None:
        for f in fields(self):
            setattr(self, f.name, np.concatenate([getattr(self, f.name), getattr(other, f.name)]))

    def keep(self, mask: np.ndarray) -> None:
        for f in fields(self):
            setattr(self, f.name, np.ascontiguousarray(getattr(self, f.name)[mask]))

    def __len__(self) -> int:
        return int(self.on.shape[0])


@njit(cache=True)  # O(N) and cheap: a parallel region would cost more than it saves (pedvr.kernels)
def encounter_kernel(pos, vel, pref_vel, radius, responsibility, is_user, user, personal_space,
                     safety_horizon, dt, edge_a, edge_b, on, axis, miss0, need, user_shift, user_v0,
                     out_pref, out_short, out_room_dir):
    """Advance every row's encounter with the user row ``user`` (state arrays updated in
    place, row by row: each row reads and writes only its own) and write its preferred
    velocity with the share taken (``out_pref``), whether it is short of room
    (``out_short``) and, for those, the way its torso should face (``out_room_dir``:
    across the passing line, toward the user's side, ``-n``)."""
    ux = pos[user, 0]
    uy = pos[user, 1]
    vux = vel[user, 0]
    vuy = vel[user, 1]
    ru = radius[user]
    for i in range(pos.shape[0]):
        out_pref[i, 0] = pref_vel[i, 0]
        out_pref[i, 1] = pref_vel[i, 1]
        out_short[i] = False
        out_room_dir[i, 0] = 0.0
        out_room_dir[i, 1] = 0.0
        if is_user[i]:
            on[i] = False
            continue
        px = ux - pos[i, 0]
        py = uy - pos[i, 1]
        dist = math.sqrt(px * px + py * py)
        r_contact = radius[i] + ru
        clearance = r_contact + personal_space
        # Planned relative velocity: the agent walking its plan, the user keeping theirs.
        wx = pref_vel[i, 0] - vux
        wy = pref_vel[i, 1] - vuy
        ww = wx * wx + wy * wy
        if on[i]:
            # The user's evasion across n since the start (positive: away from the agent's side).
            user_shift[i] -= ((vux - user_v0[i, 0]) * axis[i, 0] + (vuy - user_v0[i, 1]) * axis[i, 1]) * dt
            rvx = vel[i, 0] - vux
            rvy = vel[i, 1] - vuy
            closing = px * rvx + py * rvy > 0.0
            if (not closing and dist > clearance + 0.3) or dist > ENGAGE_DIST + 2.0:
                on[i] = False
        if not on[i] and dist < ENGAGE_DIST and ww > 1e-6:
            tca = (px * wx + py * wy) / ww
            if 0.0 < tca < ENGAGE_TIME:
                mx = px - wx * tca
                my = py - wy * tca
                mm = math.sqrt(mx * mx + my * my)
                if mm < clearance:
                    on[i] = True
                    if mm > 0.02:
                        axis[i, 0] = -mx / mm
                        axis[i, 1] = -my / mm
                    else:
                        # Head on (in relative motion): across the relative motion, on the
                        # agent's right (its own planned direction's right, or, standing,
                        # the right of the relative motion).
                        w_len = math.sqrt(ww)
                        ax = wy / w_len
                        ay = -wx / w_len
                        sx = pref_vel[i, 0]
                        sy = pref_vel[i, 1]
                        if sx * sx + sy * sy > 0.01 and ax * sy - ay * sx < 0.0:
                            ax = -ax
                            ay = -ay
                        axis[i, 0] = ax
                        axis[i, 1] = ay
                    m0 = -(mx * axis[i, 0] + my * axis[i, 1])
                    if m0 < 0.15:
                        # Nearly head on: if the chosen side has no room for the body and
                        # the other side has, pass on the other side.
                        here = raycast(pos[i, 0], pos[i, 1], axis[i, 0], axis[i, 1], ROOM_RAY,
                                       edge_a, edge_b)
                        there = raycast(pos[i, 0], pos[i, 1], -axis[i, 0], -axis[i, 1], ROOM_RAY,
                                        edge_a, edge_b)
                        if (m0 + here - radius[i] < r_contact + CONTACT_BUFFER
                                and there - radius[i] - m0 >= r_contact + CONTACT_BUFFER):
                            axis[i, 0] = -axis[i, 0]
                            axis[i, 1] = -axis[i, 1]
                            m0 = -m0
                    miss0[i] = m0
                    need[i] = clearance - miss0[i]
                    user_shift[i] = 0.0
                    user_v0[i, 0] = vux
                    user_v0[i, 1] = vuy
        if not on[i]:
            continue
        nx = axis[i, 0]
        ny = axis[i, 1]
        # The planned miss distance along n now.
        t_star = max(0.0, (px * wx + py * wy) / ww) if ww > 1e-9 else 0.0
        m_plan = -((px - wx * t_star) * nx + (py - wy * t_star) * ny)
        # A user who came toward the agent's side (u < 0) added to what is needed; one
        # who stepped away (u > 0) took that much off the agent's share, down to 0.
        u = user_shift[i]
        s_tot = need[i] - min(u, 0.0)
        share = min(responsibility[i] * s_tot, max(0.0, s_tot - max(u, 0.0)))
        target = miss0[i] + u + share
        # Room beside the agent on its side: the margin shrinks to what fits.
        wall = raycast(pos[i, 0], pos[i, 1], nx, ny, ROOM_RAY, edge_a, edge_b)
        cap = m_plan + max(0.0, wall - radius[i])
        if cap < r_contact + CONTACT_BUFFER and dist < TURN_DIST:
            # Not even the bodies pass with the disc: turn the shoulders and use
            # the room the turned footprint leaves (its contact radius shrinks too).
            out_short[i] = True
            out_room_dir[i, 0] = -nx
            out_room_dir[i, 1] = -ny
            cap = m_plan + max(0.0, wall - radius[i] * DEPTH_RATIO)
        goal = min(target, cap)
        # Close the gap before the safety step would; short of room, at once (a brisk
        # side step), or the safety step has only the way ahead left to offer.
        tau = 0.5 if out_short[i] else min(max(t_star - safety_horizon, 0.4), 1.5)
        lateral = min(max((goal - m_plan) / tau, 0.0), MAX_LATERAL)
        if out_short[i] and vux * vux + vuy * vuy > USER_MOVING * USER_MOVING:
            # Flatten against the wall and let the user pass, as people do in a narrow
            # corridor: step aside, do not walk on (an agent that walks on ahead of the
            # user is chased into the dead end). A user who stands is squeezed past.
            out_pref[i, 0] = lateral * nx
            out_pref[i, 1] = lateral * ny
        else:
            out_pref[i, 0] = pref_vel[i, 0] + lateral * nx
            out_pref[i, 1] = pref_vel[i, 1] + lateral * ny


class UserEncounters:
    """The encounter model's state and its typed entry point (see the module docstring).

    ``personal_space`` (m) widens the clearance aimed for; ``safety_horizon`` (s) is
    the horizon of the late safety step (the caller passes it to ORCA as well).
    ``edges`` are the world's wall segments ``(a (M,2), b (M,2))`` for the room rays.
    """

    def __init__(self, *, personal_space: float, safety_horizon: float,
                 edges: tuple[np.ndarray, np.ndarray]) -> None:
        self.personal_space = float(personal_space)
        self.safety_horizon = float(safety_horizon)
        self.edge_a = np.ascontiguousarray(edges[0], np.float64).reshape(-1, 2)
        self.edge_b = np.ascontiguousarray(edges[1], np.float64).reshape(-1, 2)
        self.state = EncounterState.rows(0)

    def append(self, n: int) -> None:
        self.state.append(EncounterState.rows(n))

    def keep(self, mask: np.ndarray) -> None:
        self.state.keep(mask)

    def steer(self, *, pos: np.ndarray, vel: np.ndarray, pref_vel: np.ndarray, radius: np.ndarray,
              responsibility: np.ndarray, is_user: np.ndarray, dt: float,
              engaged: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance the encounters one step; return ``(pref_vel, short_of_room, facing)``:
        preferred velocities with each agent's share taken, ``(N,)`` bool, and ``(N,2)``
        unit torso facings for the rows short of room (across the passing line).
        Without a user row everything passes through unchanged, and so do ``engaged`` rows
        (agents interacting with the user in a behavior event: they have no encounter)."""
        n = pos.shape[0]
        out = np.array(pref_vel, np.float64, copy=True)
        short = np.zeros(n, np.bool_)
        to_user = np.zeros((n, 2))
        users = np.flatnonzero(is_user)
        if users.size == 0 or n < 2:
            self.state.on[:] = False
            return out, short, to_user
        s = self.state
        encounter_kernel(np.ascontiguousarray(pos), np.ascontiguousarray(vel),
                         np.ascontiguousarray(pref_vel), np.ascontiguousarray(radius),
                         np.ascontiguousarray(responsibility), np.ascontiguousarray(is_user),
                         int(users[0]), self.personal_space, self.safety_horizon, float(dt),
                         self.edge_a, self.edge_b, s.on, s.axis, s.miss0, s.need, s.user_shift,
                         s.user_v0, out, short, to_user)
        if engaged is not None and engaged.any():
            s.on[engaged] = False
            out[engaged] = pref_vel[engaged]
            short[engaged] = False
        return out, short, to_user
