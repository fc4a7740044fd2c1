"""Overlap measurements for the ``record`` phase, as numba kernels over arrays.

The metrics measure every recorded step (max overlap, pairs over 1 cm, how
close walls are), so they must cost little next to the step they measure:
no per-agent Python, no tree rebuilt per step. Footprints are the steering's
(:mod:`pedvr.crowd.footprint`): discs, or turned ellipses measured by the
separating-axis theorem over a few directions (:func:`_ellipse_penetration`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pedvr.crowd.footprint import depth_of, row_footprint, support
from pedvr.crowd.neighbors import MAX_CELLS_PER_ITEM, build_agent_grid_arrays, cell_span
from pedvr.kernels import wrap_pi

_COARSE = 36  # directions over a half turn (5° apart) before refining round the best one


@njit(cache=True, inline="always")
def _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, theta):
    """How far two ellipses' projections on the line at angle ``theta`` overlap (``(dx, dy)``:
    centre ``j`` minus centre ``i``)."""
    ux = math.cos(theta)
    uy = math.sin(theta)
    return (support(ai, bi, fxi, fyi, ux, uy) + support(aj, bj, fxj, fyj, ux, uy)
            - abs(dx * ux + dy * uy))


@njit(cache=True)
def _ellipse_penetration(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy):
    """Penetration depth of two ellipses by the separating-axis theorem: the least overlap of
    their projections over all directions, found on a 5° grid over a half turn (the line of
    centres among them) and refined by golden-section search round the best. The line of
    centres alone (what steering constrains) overstates a turned body's overlap by a centimetre
    or more when the bodies meet off their axes. Never below the true depth (every value is a
    projection overlap) and within a fraction of a millimetre of it."""
    base = math.atan2(dy, dx)
    step = math.pi / _COARSE
    best = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, base)
    at = base
    for k in range(1, _COARSE):
        v = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, base + k * step)
        if v < best:
            best = v
            at = base + k * step
    lo = at - step
    hi = at + step
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    x1 = hi - g * (hi - lo)
    x2 = lo + g * (hi - lo)
    f1 = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, x1)
    f2 = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, x2)
    for _ in range(24):
        if f1 < f2:
            hi = x2
            x2 = x1
            f2 = f1
            x1 = hi - g * (hi - lo)
            f1 = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, x1)
        else:
            lo = x1
            x1 = x2
            f1 = f2
            x2 = lo + g * (hi - lo)
            f2 = _overlap_at(ai, bi, fxi, fyi, aj, bj, fxj, fyj, dx, dy, x2)
    return min(best, f1, f2)


@njit(cache=True)
def pair_overlaps(pos, radius, depth, facing, tolerance):
    """``(max_overlap, pairs)``: the deepest overlap between any two footprints (m, 0 if
    none) and the rows ``(i, j)``, ``i < j``, overlapping by more than ``tolerance``."""
    n = pos.shape[0]
    if n < 2:
        return 0.0, np.zeros((0, 2), np.int64)
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    origin, cell, nx, ny, cell_start, order, sorted_pos = build_agent_grid_arrays(pos, 2.0 * rmax * 1.0001,
                                                                                  MAX_CELLS_PER_ITEM)
    inv = 1.0 / cell
    worst = 0.0
    cap = 16
    pairs = np.empty((cap, 2), np.int64)
    m = 0
    for i in range(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx = int((px - origin[0]) * inv)
        cy = int((py - origin[1]) * inv)
        gx0 = max(cx - 1, 0)
        gx1 = min(cx + 1, nx - 1)
        if gx0 > gx1:
            continue  # beside the grid (its first cell's run would start past the end)
        for gy in range(max(cy - 1, 0), min(cy + 1, ny - 1) + 1):
            # the three cells of a grid row lie side by side in the grid's order: one run of rows
            # (the same rows in the same order as cell by cell; most cells hold none or one)
            for k in range(cell_start[gy * nx + gx0], cell_start[gy * nx + gx1 + 1]):
                j = order[k]
                if j <= i:
                    continue
                dx = sorted_pos[k, 0] - px
                dy = sorted_pos[k, 1] - py
                d = math.sqrt(dx * dx + dy * dy)
                rr = radius[i] + radius[j]
                if d >= rr:
                    continue
                ov = rr - d
                if d > 1e-12 and (depth[i] < radius[i] or depth[j] < radius[j]):
                    # along the line of centres first (cheap, and never below the true depth):
                    # only bodies that may overlap pay for the search over directions
                    ov = (support(radius[i], depth[i], facing[i, 0], facing[i, 1], dx / d, dy / d)
                          + support(radius[j], depth[j], facing[j, 0], facing[j, 1], -dx / d, -dy / d)
                          - d)
                    if ov > 0.0:
                        ov = _ellipse_penetration(radius[i], depth[i], facing[i, 0], facing[i, 1],
                                                  radius[j], depth[j], facing[j, 0], facing[j, 1], dx, dy)
                worst = max(worst, ov)
                if ov > tolerance:
                    if m == cap:
                        grown = np.empty((2 * cap, 2), np.int64)
                        grown[:m] = pairs[:m]
                        pairs = grown
                        cap *= 2
                    pairs[m, 0] = i
                    pairs[m, 1] = j
                    m += 1
    return worst, pairs[:m].copy()


@njit(cache=True)
def nearest_edges(pos, reach, p1, p2, origin, cell, shape, start, items, out_dist, out_away):
    """For each point, the distance to the nearest of the segments ``p1[k] -> p2[k]`` within
    ``reach`` (inf if none) and the unit direction from that nearest point to the point
    (zero if none). The segments are filed in the cells of an
    :class:`pedvr.world.visibility_kernels.EdgeGrid` (``origin``, ``cell``, ``shape``,
    ``start``, ``items``)."""
    nx = shape[0]
    ny = shape[1]
    for i in range(pos.shape[0]):
        px = pos[i, 0]
        py = pos[i, 1]
        best = np.inf
        bx = 0.0
        by = 0.0
        x0, x1, y0, y1 = cell_span(px, py, reach, origin, cell, nx, ny)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                c = ix * ny + iy
                for s in range(start[c], start[c + 1]):
                    k = items[s]
                    ax = p1[k, 0]
                    ay = p1[k, 1]
                    ex = p2[k, 0] - ax
                    ey = p2[k, 1] - ay
                    ll = ex * ex + ey * ey
                    t = 0.0 if ll <= 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / ll, 0.0), 1.0)
                    vx = px - (ax + t * ex)
                    vy = py - (ay + t * ey)
                    d = math.sqrt(vx * vx + vy * vy)
                    if d < best:
                        best = d
                        bx = vx
                        by = vy
        if best <= reach:
            out_dist[i] = best
            if best > 1e-12:
                out_away[i, 0] = bx / best
                out_away[i, 1] = by / best
            else:
                out_away[i, 0] = 0.0
                out_away[i, 1] = 0.0
        else:
            out_dist[i] = np.inf
            out_away[i, 0] = 0.0
            out_away[i, 1] = 0.0


@njit(cache=True)
def user_clearance(pos, centre, a, b, facing, user, user_pos, user_radius):
    """The user's distances in one pass over the rows (``user`` is the user's row, left out):
    ``(nearest, clear, dist)`` — the least distance from ``user_pos`` to any row's ``pos``, and
    the least clearance (m, surface to the user's disc of ``user_radius``, negative inside it)
    of any row's footprint (``centre``, ``a``, ``b``, ``facing``: the arrays of
    :func:`pedvr.crowd.footprint.footprints`; ``facing`` unit vectors), with that footprint's centre
    distance. ``(inf, inf, inf)`` when there are no others. A row that cannot come nearer the user
    than the best so far (its centre distance less its larger semi-axis, with 1 nm to spare for
    rounding, as in :func:`body_user_clearance`) skips its support radius: the same bytes."""
    nearest = math.inf
    best = math.inf
    best_d = math.inf
    ux = user_pos[0]
    uy = user_pos[1]
    for i in range(pos.shape[0]):
        if i == user:
            continue
        px = pos[i, 0] - ux
        py = pos[i, 1] - uy
        nearest = min(nearest, px * px + py * py)  # squared until the end (a root keeps the order)
        rx = centre[i, 0] - ux
        ry = centre[i, 1] - uy
        d = math.sqrt(rx * rx + ry * ry)
        if d - max(a[i], b[i]) - user_radius - 1e-9 > best:
            continue
        reach = support(a[i], b[i], facing[i, 0], facing[i, 1], -rx / d, -ry / d) if d > 1e-12 else 0.0
        clear = d - reach - user_radius
        if clear < best:
            best = clear
            best_d = d
    return math.sqrt(nearest), best, best_d


@njit(cache=True)
def body_user_clearance(pos, radius, turn, torso, heading, ahead, length, user, user_pos, user_radius):
    """:func:`user_clearance` of the footprints of bodies at ``pos`` (``radius`` to ``length``:
    :func:`pedvr.crowd.footprint.footprints`' arguments), without making their arrays, and with
    the same bytes. A row that cannot come nearer the user than the best so far (its centre
    distance less its larger semi-axis, with 1 nm to spare for rounding, since a support radius
    is no longer than that) skips its footprint's cosine and sine: about every row of a large
    crowd, whose footprints cost a sincos each (issue 27)."""
    nearest = math.inf
    best = math.inf
    best_d = math.inf
    ux = user_pos[0]
    uy = user_pos[1]
    for i in range(pos.shape[0]):
        if i == user:
            continue
        px = pos[i, 0] - ux
        py = pos[i, 1] - uy
        d2 = px * px + py * py
        nearest = min(nearest, d2)  # squared until the end, as in user_clearance
        if length[i] <= 0.0:  # a body's footprint is centred on it, its larger semi-axis known
            d = math.sqrt(d2)
            if d - max(radius[i], depth_of(radius[i], turn[i])) - user_radius - 1e-9 > best:
                continue
        cx, cy, a, b, fx, fy = row_footprint(pos[i, 0], pos[i, 1], radius[i], turn[i], torso[i], heading[i],
                                             ahead[i], length[i])
        rx = cx - ux
        ry = cy - uy
        d = math.sqrt(rx * rx + ry * ry)
        reach = support(a, b, fx, fy, -rx / d, -ry / d) if d > 1e-12 else 0.0
        clear = d - reach - user_radius
        if clear < best:
            best = clear
            best_d = d
    return math.sqrt(nearest), best, best_d


@njit(cache=True)
def motion_extremes(vel, prev_vel, heading, prev_heading, is_user, dt):
    """One pass over the virtual rows: ``(speed sum, rows, max acceleration m/s², max turn
    rate rad/s)`` between the previous step's velocities and headings and this one's."""
    total = 0.0
    rows = 0
    acc = 0.0
    turn = 0.0
    for i in range(vel.shape[0]):
        if is_user[i]:
            continue
        total += math.sqrt(vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1])
        rows += 1
        ax = vel[i, 0] - prev_vel[i, 0]
        ay = vel[i, 1] - prev_vel[i, 1]
        acc = max(acc, ax * ax + ay * ay)  # squared: one root at the end keeps the order
        turn = max(turn, abs(wrap_pi(heading[i] - prev_heading[i])) / dt)
    return total, rows, math.sqrt(acc) / dt, turn


@njit(cache=True)
def wall_overlaps(radius, depth, facing, dist, away, inside, is_user, tolerance):
    """``(worst, rows)``: how deep footprints cut into walls, from each row's nearest edge
    ``dist`` (inf where none is within reach) and the unit ``away`` from it, and whether its
    centre is ``inside`` an obstacle (then the whole reach plus the distance back out counts);
    the deepest cut (m, ``-inf`` with no rows) and the rows cut more than ``tolerance``. The
    user's row is measured by no one here: it is not steered."""
    worst = -math.inf
    rows = np.empty(radius.shape[0], np.int64)
    m = 0
    for i in range(radius.shape[0]):
        if is_user[i]:
            continue
        near = math.isfinite(dist[i])
        if near:
            reach = support(radius[i], depth[i], facing[i, 0], facing[i, 1], away[i, 0], away[i, 1])
        else:
            reach = radius[i]
        if inside[i]:
            ov = reach + (dist[i] if near else 0.0)
        else:
            ov = reach - dist[i]
        worst = max(worst, ov)
        if ov > tolerance:
            rows[m] = i
            m += 1
    return worst, rows[:m]
