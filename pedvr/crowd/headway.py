"""Preferred speed from the headway: people walk no faster than keeps a time gap to whoever
is ahead of them (Tordeux, Chraibi, Seyfried 2016, the collision-free speed model, as
JuPedSim's CFSM; after Newell's car-following model).

For agent ``i`` with preferred velocity ``p`` (speed ``v0``, direction ``e``), the
neighbours ``j`` it follows are those ahead of it, ``(x_j - x_i)·e > 0``, in its lane (their
bodies would touch if ``i`` walked straight on: ``|(x_j - x_i)·e⊥|`` below the two
footprints' extents across ``e``) and going its way (``j``'s own preferred velocity has at
least ``FOLLOW`` m/s along ``e``; someone oncoming, crossing or standing aside, a door
holder say, is ORCA's to pass, not a leader to queue behind: with oncoming people counted
the BaSiGo counterflow jammed at 2.4 m⁻², and with standing ones the double door's
followers queued behind its holder). The headway ``s`` is the least free distance to one of
them, the centre distance less the two footprints' support radii along the line of
centres (:func:`pedvr.crowd.footprint.support`), and the preferred speed becomes

    v = min(v0, max(0, s / T))

with the time gap ``T`` (s). Tordeux et al. write ``(s - ℓ)/T`` with ``s`` the centre
distance and ``ℓ`` the body's length; with pedvr's footprints the body's length along
the line of centres is the two support radii, so ``s`` here is already free distance.
The direction is kept: ORCA (``pedvr.crowd.orca``) still chooses the velocity, this only
says how fast the person wants to go. The user never takes part (the encounter model,
:mod:`pedvr.crowd.encounter`, handles the user), and the user's row is left as it is.

Two whose ways converge can each stand ahead of the other, in its lane, going its way (two
merging into an opening, or stepping off a doorway); both following, both would stand still for
good. Only the one further behind the other, ``(x_j - x_i)·e_i > (x_i - x_j)·e_j``, follows
(ties: the later row), and the other walks on (issue 26, stop 36).

This is pedvr's reading for an ORCA crowd: the CFSM computes the speed of its own
velocity from the headway; here the headway limits the *preferred* speed, and ORCA's
reciprocal lines keep the bodies apart. ``T <= 0`` switches it off.
"""

from __future__ import annotations

import math

from numba import njit

from pedvr.crowd.footprint import support

FOLLOW = 0.1  # m/s: a neighbour is followed when it wants to go at least this fast the agent's way


@njit(cache=True)  # O(N·K) and cheap: a parallel region would cost more than it saves (pedvr.kernels)
def headway_kernel(pos, pref_vel, radius, depth, facing, is_user, nbr_idx, nbr_count, time_gap, out):  # type: ignore[no-untyped-def]
    """``out (N, 2)``: each row's preferred velocity with its speed limited by the headway
    (see the module docstring), from footprint centres ``pos``, the footprints' semi-axes
    ``radius`` (across the facing) and ``depth`` (along it), unit ``facing (N, 2)``, and the
    nearest-first neighbour lists; user rows and standing rows are copied. Allocates nothing."""
    for i in range(pos.shape[0]):
        px = pref_vel[i, 0]
        py = pref_vel[i, 1]
        out[i, 0] = px
        out[i, 1] = py
        v0 = math.sqrt(px * px + py * py)
        if is_user[i] or v0 < 1e-9 or time_gap <= 0.0:
            continue
        ex = px / v0
        ey = py / v0
        fx = facing[i, 0]
        fy = facing[i, 1]
        # the agent's half extent across its way
        wi = support(radius[i], depth[i], fx, fy, -ey, ex)
        best = math.inf
        for q in range(nbr_count[i]):
            j = nbr_idx[i, q]
            dx = pos[j, 0] - pos[i, 0]
            dy = pos[j, 1] - pos[i, 1]
            along = dx * ex + dy * ey
            across = abs(-dx * ey + dy * ex)
            wj = support(radius[j], depth[j], facing[j, 0], facing[j, 1], -ey, ex)
            # Not going the agent's way (oncoming, crossing, standing: ORCA's to pass), not ahead
            # of it or not in its lane: one branch (``|``, not ``or``), the lane's extent made for
            # every neighbour. A branch for each, on new neighbours every step, was mispredicted
            # often enough that the kernel took 110 µs at 1000 agents, 69 µs this way (issue 27).
            if is_user[j] | (pref_vel[j, 0] * ex + pref_vel[j, 1] * ey < FOLLOW) | (along <= 0.0) | (
                    across >= wi + wj):
                continue
            # Each in the other's lane, ahead of it, going its way (ways that converge, as two
            # people merging into an opening or stepping off a doorway): only the one further
            # behind follows. Both following, both stood still for good (door_single_flow seed 18:
            # two just through the door, 12 s, while the held door and its follower waited).
            qx = pref_vel[j, 0]
            qy = pref_vel[j, 1]
            vj = math.sqrt(qx * qx + qy * qy)
            if vj >= 1e-9 and px * qx + py * qy >= FOLLOW * vj:  # i goes j's way
                gx = qx / vj
                gy = qy / vj
                back = -(dx * gx + dy * gy)  # how far i is ahead of j along j's way
                if back > along or (back == along and i < j):  # j is the one further behind (back > 0)
                    lane = support(radius[j], depth[j], facing[j, 0], facing[j, 1], -gy, gx) + support(
                        radius[i], depth[i], fx, fy, -gy, gx)
                    if abs(dx * gy - dy * gx) < lane:
                        continue  # j follows i: i walks on
            d = math.sqrt(dx * dx + dy * dy)
            free = d - support(radius[i], depth[i], fx, fy, dx / d, dy / d) - support(
                radius[j], depth[j], facing[j, 0], facing[j, 1], -dx / d, -dy / d)
            if free < best:
                best = free
        if best < math.inf:
            v = min(v0, max(0.0, best / time_gap))
            out[i, 0] = ex * v
            out[i, 1] = ey * v
