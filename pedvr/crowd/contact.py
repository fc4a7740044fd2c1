"""Contact pass: push overlapping discs apart after the velocity update.

ORCA guarantees no collision only while its program is feasible; in dense
crowds ``linear_program3`` (and numerical slack) let discs interpenetrate.
DESIGN.md requires no two discs (agents, user, obstacles) to overlap by more
than 1 cm, so after positions are integrated this pass projects them apart.

Method: Jacobi iterations (compute all corrections from the same positions,
then apply them), so the result does not depend on agent order or on the
number of threads. Plain Jacobi diffuses a push through a packed jam in
O(depth²) iterations; a heavy-ball term (each step keeps ``MOMENTUM`` of the
previous one) makes it O(depth), which is what lets a 4000-agent antipodal
circle jam settle below 1 cm within ``DEFAULT_ITERATIONS``. Per iteration,
for every overlapping pair the overlap plus a small ``SLACK`` is split
half/half between two virtual agents; against the user or an obstacle edge
the agent takes all of it (the user never moves; walls never move). Two centres at
one point part along their pair's own direction (:func:`pedvr.crowd.coincident.apart`:
opposite for the two, so the result still does not depend on agent order). Pairs
and edges use the bodies' footprints (:mod:`pedvr.crowd.footprint`): discs,
or narrower ellipses for agents that turned their shoulders. The user's body
wins over everything: after each iteration agents are projected out of the
user's disc, so an agent pinned between the user and a wall gives way into
the wall, never into the user (the metrics report it).
Iterations stop when the largest overlap is at most ``tolerance`` or after
``max_iterations``.

Obstacle edges follow RVO2's orientation: agents belong on the right of every
edge of a closed polygon (outside a counter-clockwise obstacle, inside a
clockwise boundary). A disc overlapping an edge it faces is pushed away from
the edge's nearest point. Each vertex is handled once, as the start of its
outgoing edge; a two-vertex segment once, as an unoriented segment.

Sharp edge: a disc whose *centre* is already behind an edge (inside an
obstacle) is not pulled back out; the obstacle lines of ORCA and this pass
keep centres outside in practice, and the edge nearest such a centre would
be ambiguous for walls thinner than a disc. So no iteration's step carries a
centre through an edge: a step as long as the way to the nearest edge (the
push out of a deep overlap, such as two bodies at one point) stops 1 mm short
of any edge it would cross.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit, prange

from pedvr.crowd.coincident import COINCIDENT, apart
from pedvr.crowd.footprint import support
from pedvr.crowd.neighbors import MAX_CELLS_PER_ITEM, ObstacleGrid, build_agent_grid_arrays, edges_near
from pedvr.crowd.overlap import pair_overlaps
from pedvr.kernels import Chooser, parallel_kernel

DEFAULT_TOLERANCE = 0.005  # m: stop when no overlap exceeds this (the bar is 1 cm)
DEFAULT_ITERATIONS = 300
SLACK = 0.0005  # m: pushed this much past touching, so iterations settle faster
MOMENTUM = 0.9  # share of the previous iteration's step kept (heavy ball)
_EDGE_CAP = 64
SKIN = 0.1  # m: Verlet lists hold pairs and edges up to this far beyond touching


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _edge_push(px, py, r, b, fx, fy, ax, ay, bx, by, closed):
    """Correction ``(cx, cy, depth, dist)`` that moves a footprint off the edge a -> b (its disc
    radius ``r``, or, turned, its support radius toward the edge: ``b`` front to back
    along the facing ``(fx, fy)``); ``dist`` is how far the centre is from the edge on the
    side it belongs (inf where another edge measures it, or the centre is behind this one)."""
    inf = np.inf
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = ((px - ax) * ex + (py - ay) * ey) / ll
    if closed and t > 1.0:
        # The end vertex is the start of the next edge, which handles it.
        return 0.0, 0.0, 0.0, inf
    tc = min(max(t, 0.0), 1.0)
    qx = ax + tc * ex
    qy = ay + tc * ey
    dx = px - qx
    dy = py - qy
    d = np.sqrt(dx * dx + dy * dy)
    # Right normal of the edge (outside a counter-clockwise polygon).
    inv = 1.0 / np.sqrt(ll)
    nx = ey * inv
    ny = -ex * inv
    if closed and t >= 0.0 and dx * nx + dy * ny < 0.0:
        # Centre behind this edge: inside the polygon, or past a wall thinner
        # than the disc, where the edges on the centre's own side act.
        return 0.0, 0.0, 0.0, inf
    if d >= r:
        return 0.0, 0.0, 0.0, d
    if b < r and d > 1e-12:
        r = support(r, b, fx, fy, dx / d, dy / d)
        if d >= r:
            return 0.0, 0.0, 0.0, d
    depth = r - d
    if d > 1e-12:
        ux = dx / d
        uy = dy / d
    else:
        ux = nx
        uy = ny
    return (depth + SLACK) * ux, (depth + SLACK) * uy, depth, d


@njit(cache=True, fastmath={"nsz", "arcp", "contract"}, inline="always")
def _crossing(px, py, sx, sy, ax, ay, bx, by, closed):
    """Fraction of the move ``(px, py) -> (px + sx, py + sy)`` at which it meets the edge
    a -> b (1.0 where it does not); a closed polygon's edge only when the move starts on the
    side agents belong (its right)."""
    ex = bx - ax
    ey = by - ay
    wx = ax - px
    wy = ay - py
    if closed and ex * wy - ey * wx <= 0.0:
        return 1.0  # the centre starts behind the edge (or on it)
    den = sx * ey - sy * ex
    if den == 0.0:
        return 1.0
    t = (wx * ey - wy * ex) / den
    u = (wx * sy - wy * sx) / den
    if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
        return t
    return 1.0


@njit(cache=True, inline="always")
def _neighbours_near(i, pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos, out, write):
    """Rows ``j`` within ``r_i + r_j + skin`` of row ``i``: their count, and with ``write`` the rows
    themselves into ``out[:count]``, as many as ``out`` holds (the list builds share this scan)."""
    px = pos[i, 0]
    py = pos[i, 1]
    inv = 1.0 / cell
    cx = int((px - origin[0]) * inv)
    cy = int((py - origin[1]) * inv)
    m = 0
    gx0 = max(cx - 1, 0)
    gx1 = min(cx + 1, nx - 1)
    if gx0 > gx1:
        return 0  # beside the grid (its first cell's run would start past the end)
    for gy in range(max(cy - 1, 0), min(cy + 1, ny - 1) + 1):
        # a grid row's three cells lie side by side in the grid's order: one run of rows, the
        # same rows in the same order as cell by cell, without a loop per (mostly empty) cell
        for k in range(cell_start[gy * nx + gx0], cell_start[gy * nx + gx1 + 1]):
            j = order[k]
            if j == i:
                continue
            dx = px - sorted_pos[k, 0]
            dy = py - sorted_pos[k, 1]
            rr = radius[i] + radius[j] + skin
            if dx * dx + dy * dy < rr * rr:
                if write and m < out.shape[0]:
                    out[m] = j
                m += 1
    return m


@parallel_kernel(allocates=False)
def _list_counts(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos, vertices,
                 og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells,
                 scratch, out_nbr, out_edge):
    """Per row: how many neighbours and nearby edges its lists will hold (pass 1 of 2)."""
    nchunks = scratch.shape[0]
    n = pos.shape[0]
    for c in prange(nchunks):
        lo = (n * c) // nchunks
        hi = (n * (c + 1)) // nchunks
        for i in range(lo, hi):
            out_nbr[i] = _neighbours_near(i, pos, radius, skin, origin, cell, nx, ny, cell_start, order,
                                          sorted_pos, scratch[c], False)
            out_edge[i] = 0
            if vertices.shape[0] > 0:
                out_edge[i] = edges_near(pos[i, 0], pos[i, 1], radius[i] + skin, og_origin, og_cell, og_nx,
                                         og_ny, og_cell_start, og_cell_edges, og_edge_cells, scratch[c],
                                         scratch.shape[1])


@parallel_kernel(allocates=False)
def _list_fill(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos, vertices,
               og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells,
               nbr_start, edge_start, out_nbr, out_edge):
    """Fill each row's neighbour and edge lists at its offsets (pass 2 of 2)."""
    n = pos.shape[0]
    for i in prange(n):
        _neighbours_near(i, pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos,
                         out_nbr[nbr_start[i]:nbr_start[i + 1]], True)
        if vertices.shape[0] > 0:
            e0 = edge_start[i]
            edges_near(pos[i, 0], pos[i, 1], radius[i] + skin, og_origin, og_cell, og_nx, og_ny,
                       og_cell_start, og_cell_edges, og_edge_cells, out_edge[e0:edge_start[i + 1]],
                       edge_start[i + 1] - e0)


@parallel_kernel(fastmath={"nsz", "arcp", "contract"}, allocates=False)
def _iterate(cur, radius, fp_depth, facing, rigid, fixed, nbr_start, nbr_idx, edge_start, edge_idx,
             vertices, nxt, prv, n_static, momentum, step, out_pos, depth):
    """One Jacobi iteration, fused: each row's correction from ``cur`` (its neighbour and
    edge lists), then its heavy-ball step, written to ``out_pos``; ``depth[i]`` is the
    deepest overlap row ``i`` saw (measured before the step)."""
    for i in prange(cur.shape[0]):
        px = cur[i, 0]
        py = cur[i, 1]
        ri = radius[i]
        bi = fp_depth[i]
        fxi = facing[i, 0]
        fyi = facing[i, 1]
        sx = 0.0
        sy = 0.0
        worst = 0.0
        together = False
        for q in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_idx[q]
            dx = px - cur[j, 0]
            dy = py - cur[j, 1]
            rr = ri + radius[j]
            dsq = dx * dx + dy * dy
            if dsq >= rr * rr:
                continue
            d = np.sqrt(dsq)
            if d <= COINCIDENT:
                together = True  # no line of centres: after this loop
                continue
            if bi < ri or fp_depth[j] < radius[j]:
                rr = (support(ri, bi, fxi, fyi, -dx / d, -dy / d)
                      + support(radius[j], fp_depth[j], facing[j, 0], facing[j, 1], dx / d, dy / d))
                if d >= rr:
                    continue
            ov = rr - d
            worst = max(worst, ov)
            share = 1.0 if fixed[j] else 0.5
            ux = dx / d
            uy = dy / d
            sx += share * (ov + SLACK) * ux
            sy += share * (ov + SLACK) * uy
        if together:
            # Coincident centres part along the pair's own direction (opposite for j, so the
            # pushes cancel; pedvr.crowd.coincident). Out of the loop above, which it would slow.
            for q in range(nbr_start[i], nbr_start[i + 1]):
                j = nbr_idx[q]
                dx = px - cur[j, 0]
                dy = py - cur[j, 1]
                d = np.sqrt(dx * dx + dy * dy)
                if d > COINCIDENT:
                    continue
                ov = ri + radius[j] - d
                worst = max(worst, ov)
                share = 1.0 if fixed[j] else 0.5
                ux, uy = apart(i, j)
                sx += share * (ov + SLACK) * ux
                sy += share * (ov + SLACK) * uy
        near_edge = np.inf
        for q in range(edge_start[i], edge_start[i + 1]):
            e = edge_idx[q]
            e2 = nxt[e]
            closed = nxt[e] != prv[e]
            if not closed and e2 < e:
                continue  # a two-vertex segment: handle it once
            # Moving segments (door leaves) see the disc, as the door controller does, except a
            # rigid footprint (a pushed pram), which they see as it is.
            be = bi if e < n_static or rigid[i] else ri
            ex, ey, dep, dist = _edge_push(px, py, ri, be, fxi, fyi, vertices[e, 0], vertices[e, 1],
                                           vertices[e2, 0], vertices[e2, 1], closed)
            sx += ex
            sy += ey
            worst = max(worst, dep)
            near_edge = min(near_edge, dist)
        depth[i] = worst
        if fixed[i]:
            out_pos[i, 0] = px
            out_pos[i, 1] = py
            continue
        # Heavy-ball Jacobi: the step keeps a share of the previous one, which
        # carries a push through a packed cluster in O(depth) instead of
        # O(depth^2) iterations (plain Jacobi diffuses).
        stx = momentum * step[i, 0] + sx
        sty = momentum * step[i, 1] + sy
        ll = stx * stx + sty * sty
        reach = ri + 0.5 * SKIN
        if ll >= near_edge * near_edge or (ll > reach * reach and vertices.shape[0] > 0):
            # A step as long as the way to an edge (the push of a deep overlap, bodies at one
            # point): it never carries the centre through the edge, behind which no edge would
            # push it back. It stops 1 mm short; and it is no longer than the edges left out of
            # the lists are far (r + SKIN / 2: lists hold edges within r + SKIN of where they were
            # built, and are rebuilt when someone has moved SKIN / 2).
            step_len = np.sqrt(ll)
            keep = min(1.0, reach / step_len)
            for q in range(edge_start[i], edge_start[i + 1]):
                e = edge_idx[q]
                e2 = nxt[e]
                f = _crossing(px, py, stx, sty, vertices[e, 0], vertices[e, 1], vertices[e2, 0],
                              vertices[e2, 1], nxt[e] != prv[e])
                if f < 1.0:
                    keep = min(keep, max(f - 1e-3 / step_len, 0.0))
            stx *= keep
            sty *= keep
        step[i, 0] = stx
        step[i, 1] = sty
        out_pos[i, 0] = px + stx
        out_pos[i, 1] = py + sty


_list_counts_par = _list_counts.parallel
_list_fill_par = _list_fill.parallel
_iterate_par, _iterate_ser = _iterate.parallel, _iterate.serial


@njit(cache=True)
def _build_lists(pos, radius, skin, vertices, og_origin, og_cell, og_nx, og_ny, og_cell_start,
                 og_cell_edges, og_edge_cells, scratch, parallel):
    """Verlet lists: each row's neighbours within ``r_i + r_j + skin`` and the edges that
    may come within ``r_i + skin`` of it, as CSR arrays ``(nbr_start, nbr_idx,
    edge_start, edge_idx)``; -1 in ``nbr_start[0]`` when ``scratch`` was too small for
    some row's edges (the caller retries with more room). The index arrays may be longer than
    their last offset (room left over from the serial build)."""
    n = pos.shape[0]
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    origin, cell, nx, ny, cell_start, order, sorted_pos = build_agent_grid_arrays(
        pos, (2.0 * rmax + skin) * 1.0001, MAX_CELLS_PER_ITEM)
    if not parallel:
        return _lists_one_pass(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos,
                               vertices, og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges,
                               og_edge_cells, scratch.shape[1])
    cnt_n = np.empty(n, np.int64)
    cnt_e = np.empty(n, np.int64)
    _list_counts_par(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos,
                     vertices, og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges,
                     og_edge_cells, scratch, cnt_n, cnt_e)
    nbr_start = np.zeros(n + 1, np.int64)
    edge_start = np.zeros(n + 1, np.int64)
    for i in range(n):
        if cnt_e[i] > scratch.shape[1]:
            nbr_start[0] = -1
            return nbr_start, np.zeros(0, np.int64), edge_start, np.zeros(0, np.int64)
        nbr_start[i + 1] = nbr_start[i] + cnt_n[i]
        edge_start[i + 1] = edge_start[i] + cnt_e[i]
    nbr_idx = np.empty(nbr_start[n], np.int64)
    edge_idx = np.empty(edge_start[n], np.int64)
    _list_fill_par(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos, vertices,
                   og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells,
                   nbr_start, edge_start, nbr_idx, edge_idx)
    return nbr_start, nbr_idx, edge_start, edge_idx


@njit(cache=True)
def _lists_one_pass(pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos, vertices,
                    og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells, edge_cap):
    """:func:`_build_lists` on one thread in one scan: each row's lists are written as it is
    scanned, into buffers that grow when a row does not fit (its scan then runs again). The
    parallel build counts first and fills at the counts' offsets, two scans; one thread needs
    no offsets ahead (issue 27: the second scan was 2 % of a 1000-agent step's CPU time). The
    same lists in the same order. A row with more than ``edge_cap`` edges fails the build, as
    the counting pass does."""
    n = pos.shape[0]
    nbr_start = np.zeros(n + 1, np.int64)
    edge_start = np.zeros(n + 1, np.int64)
    nbr_idx = np.empty(max(8 * n, 64), np.int64)
    edge_idx = np.empty(max(2 * n, edge_cap), np.int64)
    for i in range(n):
        at = nbr_start[i]
        m = _neighbours_near(i, pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos,
                             nbr_idx[at:], True)
        if at + m > nbr_idx.shape[0]:
            grown = np.empty(max(2 * nbr_idx.shape[0], at + m), np.int64)
            grown[:at] = nbr_idx[:at]
            nbr_idx = grown
            _neighbours_near(i, pos, radius, skin, origin, cell, nx, ny, cell_start, order, sorted_pos,
                             nbr_idx[at:], True)
        nbr_start[i + 1] = at + m
        e = 0
        if vertices.shape[0] > 0:
            at = edge_start[i]
            if at + edge_cap > edge_idx.shape[0]:
                grown = np.empty(max(2 * edge_idx.shape[0], at + edge_cap), np.int64)
                grown[:at] = edge_idx[:at]
                edge_idx = grown
            e = edges_near(pos[i, 0], pos[i, 1], radius[i] + skin, og_origin, og_cell, og_nx, og_ny,
                           og_cell_start, og_cell_edges, og_edge_cells, edge_idx[at:], edge_cap)
            if e > edge_cap:
                nbr_start[0] = -1
                return nbr_start, np.zeros(0, np.int64), edge_start, np.zeros(0, np.int64)
        edge_start[i + 1] = edge_start[i] + e
    return nbr_start, nbr_idx, edge_start, edge_idx


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _first_crossing(x0, y0, x1, y1, vertices, nxt, og_origin, og_cell, og_nx, og_ny,
                    og_cell_start, og_cell_edges, og_edge_cells, scratch):
    """Fraction along the move ``(x0, y0) -> (x1, y1)`` at which it first crosses an
    obstacle edge (1.0 when it crosses none), and that edge's index (-1 for none)."""
    mx = 0.5 * (x0 + x1)
    my = 0.5 * (y0 + y1)
    reach = 0.5 * np.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2) + 1e-6
    total = edges_near(mx, my, reach, og_origin, og_cell, og_nx, og_ny, og_cell_start,
                       og_cell_edges, og_edge_cells, scratch, scratch.shape[0])
    best = 1.0
    hit = -1
    dx = x1 - x0
    dy = y1 - y0
    for q in range(min(total, scratch.shape[0])):
        e = scratch[q]
        e2 = nxt[e]
        ex = vertices[e2, 0] - vertices[e, 0]
        ey = vertices[e2, 1] - vertices[e, 1]
        den = dx * ey - dy * ex
        if den == 0.0:
            continue
        wx = vertices[e, 0] - x0
        wy = vertices[e, 1] - y0
        t = (wx * ey - wy * ex) / den
        u = (wx * dy - wy * dx) / den
        if 0.0 <= t < best and 0.0 <= u <= 1.0:
            best = t
            hit = e
    return best, hit


@njit(cache=True, fastmath={"nsz", "arcp", "contract"}, inline="always")
def _user_reach(i, user, radius, fp_depth, facing, nx, ny):
    """Centre distance at which row ``i``'s footprint touches the user's along the unit ``(nx, ny)``
    (from the user toward the agent): the user's support (its disc, or a pram's ellipse) plus the
    agent's."""
    ru = radius[user]
    su = ru
    if fp_depth[user] < ru:
        su = support(ru, fp_depth[user], facing[user, 0], facing[user, 1], nx, ny)
    return su + support(radius[i], fp_depth[i], facing[i, 0], facing[i, 1], -nx, -ny)


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _leave_along(i, user, ux, uy, sx, sy, ex, ey, sign, radius, fp_depth, facing):
    """How far (signed, m) to move from ``(sx, sy)`` along the unit ``(ex, ey)`` to where row
    ``i``'s footprint just clears the user's (``SLACK`` beyond touching): the root of
    ``|s + τ e - u| = reach`` on the side of ``sign`` (the nearer root where ``sign`` is 0). The
    reach depends on the direction (turned footprints), so it is solved again, with the reach
    where the last root landed, until that reach is no longer than the one solved for."""
    px = sx - ux
    py = sy - uy
    d = np.sqrt(px * px + py * py)
    if d > COINCIDENT:
        nx = px / d
        ny = py / d
    else:
        nx, ny = apart(i, user)
    reach = _user_reach(i, user, radius, fp_depth, facing, nx, ny) + SLACK
    tau = 0.0
    for _ in range(8):
        b = px * ex + py * ey
        c = px * px + py * py - reach * reach
        disc = b * b - c
        if disc < 0.0:  # s is outside the reach (no root on the line): nothing to do
            return tau
        root = np.sqrt(disc)
        up = -b + root
        down = -b - root
        if sign > 0.0 or (sign == 0.0 and abs(up) <= abs(down)):
            tau = up
        else:
            tau = down
        qx = px + tau * ex
        qy = py + tau * ey
        q = np.sqrt(qx * qx + qy * qy)
        if q <= COINCIDENT:
            break
        there = _user_reach(i, user, radius, fp_depth, facing, qx / q, qy / q) + SLACK
        if there <= reach:
            break  # clear of the user's footprint there
        reach = there
    return tau


MAX_SLIDES = 4  # walls a push out of the user slides along before it gives up on staying inside them


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _slide_out(i, user, ux, uy, x0, y0, x1, y1, first, radius, fp_depth, facing, vertices, nxt, og_origin,
               og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells, scratch):
    """From ``(x0, y0)`` toward the point ``(x1, y1)`` on the user's outline without crossing a
    wall: where the way meets one, stop 1 mm short and slide along it to where its line leaves
    the outline, the way the push leans (``first`` > 0 or < 0 overrides that for the first wall),
    and so on round corners, up to ``MAX_SLIDES`` walls. Returns ``(found, x, y)``."""
    for k in range(MAX_SLIDES):
        frac, e = _first_crossing(x0, y0, x1, y1, vertices, nxt, og_origin, og_cell, og_nx, og_ny,
                                  og_cell_start, og_cell_edges, og_edge_cells, scratch)
        if e < 0:
            return True, x1, y1
        stop = max(frac - 1e-3 / max(np.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2), 1e-12), 0.0)
        sx = x0 + stop * (x1 - x0)
        sy = y0 + stop * (y1 - y0)
        ex = vertices[nxt[e], 0] - vertices[e, 0]
        ey = vertices[nxt[e], 1] - vertices[e, 1]
        el = np.sqrt(ex * ex + ey * ey)
        ex /= el
        ey /= el
        lean = (x1 - sx) * ex + (y1 - sy) * ey
        if k == 0 and first != 0.0:
            lean = first
        tau = _leave_along(i, user, ux, uy, sx, sy, ex, ey, lean, radius, fp_depth, facing)
        x0 = sx
        y0 = sy
        x1 = sx + tau * ex
        y1 = sy + tau * ey
    return False, x0, y0


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _out_of_user(cur, radius, fp_depth, facing, user, near, step, vertices, nxt, og_origin,
                 og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells, scratch):
    """Project the agents ``near`` the user row ``user`` out of the user's footprint (its
    disc, or the ellipse of a user pushing a pram: the user cannot be moved, so it wins over
    walls and other agents); their heavy-ball momentum is dropped so the next iteration does
    not carry them back in.

    Each agent is moved onto the user's outline (``SLACK`` beyond touching) without its centre
    crossing a wall: straight out from the user's centre, or, where that way meets a wall,
    stopped 1 mm short and slid along the wall to where the wall's line leaves the outline (the
    way the push leans; a turned agent's reach is solved for where it lands), round corners
    too (:func:`_slide_out`). Cornered that way (the user walked into a corner someone stands
    in), it slides along the first wall the other way, past the user; and where not even that
    frees the user, the user's body still wins: the agent goes straight out, through the wall,
    and the metrics report the wall overlap.
    """
    ux = cur[user, 0]
    uy = cur[user, 1]
    ru = radius[user]
    for k in range(near.shape[0]):
        i = near[k]
        dx = cur[i, 0] - ux
        dy = cur[i, 1] - uy
        d = np.sqrt(dx * dx + dy * dy)
        if d >= ru + radius[i]:
            continue
        if d > COINCIDENT:
            nx = dx / d
            ny = dy / d
        else:  # on the user's centre: out along the pair's own direction (pedvr.crowd.coincident)
            nx, ny = apart(i, user)
        rr = _user_reach(i, user, radius, fp_depth, facing, nx, ny)
        if d >= rr:
            continue
        x0 = cur[i, 0]
        y0 = cur[i, 1]
        x1 = ux + (rr + SLACK) * nx
        y1 = uy + (rr + SLACK) * ny
        if vertices.shape[0] > 0:
            found, x, y = _slide_out(i, user, ux, uy, x0, y0, x1, y1, 0.0, radius, fp_depth, facing, vertices,
                                     nxt, og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges,
                                     og_edge_cells, scratch)
            if not found:
                # Cornered: the first wall's other way, past the user.
                frac, e = _first_crossing(x0, y0, x1, y1, vertices, nxt, og_origin, og_cell, og_nx, og_ny,
                                          og_cell_start, og_cell_edges, og_edge_cells, scratch)
                ex = vertices[nxt[e], 0] - vertices[e, 0]
                ey = vertices[nxt[e], 1] - vertices[e, 1]
                lean = (x1 - x0) * ex + (y1 - y0) * ey
                found, x, y = _slide_out(i, user, ux, uy, x0, y0, x1, y1, -1.0 if lean >= 0.0 else 1.0,
                                         radius, fp_depth, facing, vertices, nxt, og_origin, og_cell, og_nx,
                                         og_ny, og_cell_start, og_cell_edges, og_edge_cells, scratch)
            if found:
                x1 = x
                y1 = y
            # else: no way out inside the walls; the user's body wins (straight out, through the wall)
        cur[i, 0] = x1
        cur[i, 1] = y1
        step[i, 0] = 0.0
        step[i, 1] = 0.0


@njit(cache=True)
def contact_kernel(pos, radius, fp_depth, facing, rigid, fixed, user, vertices, nxt, prv, n_static, og_origin,
                   og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells, tolerance,
                   max_iterations, momentum, edge_scratch, parallel, out_pos):
    """Jacobi contact iterations; writes ``out_pos`` and returns ``(iterations, worst)``.

    ``fixed`` rows never move (the user, seated bodies); ``user`` is the user's row (-1
    without one), out of whose disc every other row, fixed or not, is projected.
    ``worst`` is the largest overlap left, or -1 when ``edge_scratch`` was too small
    for some agent's edges (retry with more room). After every iteration, and at the
    end, agents are projected out of the user: where there is truly no room, an agent
    gives way into a wall or another agent, never into the user. ``parallel`` picks the
    parallel or serial twins (the same bytes either way).

    Neighbours and edges come from Verlet lists built once (``SKIN`` beyond touching)
    and rebuilt only when some row has moved ``SKIN / 2`` since; each iteration is one
    pass (one parallel region) over the rows, double-buffered.
    """
    n = pos.shape[0]
    for i in range(n):
        out_pos[i, 0] = pos[i, 0]
        out_pos[i, 1] = pos[i, 1]
    if n == 0:
        return 0, 0.0
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    near = np.zeros(0, np.int64)
    if user >= 0:
        # Agents that can touch the user within this pass (pushes are a few cm per step).
        reach = radius[user] + rmax + 0.5
        cnt = 0
        for i in range(n):
            if i != user:
                dx = pos[i, 0] - pos[user, 0]
                dy = pos[i, 1] - pos[user, 1]
                if dx * dx + dy * dy < reach * reach:
                    cnt += 1
        near = np.empty(cnt, np.int64)
        cnt = 0
        for i in range(n):
            if i != user:
                dx = pos[i, 0] - pos[user, 0]
                dy = pos[i, 1] - pos[user, 1]
                if dx * dx + dy * dy < reach * reach:
                    near[cnt] = i
                    cnt += 1
    cur = out_pos
    nxt_pos = np.empty_like(out_pos)
    swapped = False
    anchor = out_pos.copy()
    step = np.zeros((n, 2))
    depth = np.zeros(n)
    nbr_start, nbr_idx, edge_start, edge_idx = _build_lists(
        cur, radius, SKIN, vertices, og_origin, og_cell, og_nx, og_ny, og_cell_start, og_cell_edges,
        og_edge_cells, edge_scratch, parallel)
    if nbr_start[0] < 0:
        return 0, -1.0
    worst = 0.0
    it = 0
    while True:
        if parallel:
            _iterate_par(cur, radius, fp_depth, facing, rigid, fixed, nbr_start, nbr_idx, edge_start,
                         edge_idx, vertices, nxt, prv, n_static, momentum, step, nxt_pos, depth)
        else:
            _iterate_ser(cur, radius, fp_depth, facing, rigid, fixed, nbr_start, nbr_idx, edge_start,
                         edge_idx, vertices, nxt, prv, n_static, momentum, step, nxt_pos, depth)
        worst = 0.0
        for i in range(n):
            worst = max(worst, depth[i])
        if worst <= tolerance or it >= max_iterations:
            break  # cur holds the positions the overlaps were measured on
        cur, nxt_pos = nxt_pos, cur
        swapped = not swapped
        if user >= 0:
            _out_of_user(cur, radius, fp_depth, facing, user, near, step, vertices, nxt, og_origin,
                         og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells,
                         edge_scratch[0])
        it += 1
        moved = 0.0
        for i in range(n):
            dx = cur[i, 0] - anchor[i, 0]
            dy = cur[i, 1] - anchor[i, 1]
            moved = max(moved, dx * dx + dy * dy)
        if moved > 0.25 * SKIN * SKIN:
            # Someone moved half the skin: the lists may miss a new contact. Rebuild.
            for i in range(n):
                anchor[i, 0] = cur[i, 0]
                anchor[i, 1] = cur[i, 1]
            nbr_start, nbr_idx, edge_start, edge_idx = _build_lists(
                cur, radius, SKIN, vertices, og_origin, og_cell, og_nx, og_ny, og_cell_start,
                og_cell_edges, og_edge_cells, edge_scratch, parallel)
            if nbr_start[0] < 0:
                return it, -1.0
    if user >= 0:
        _out_of_user(cur, radius, fp_depth, facing, user, near, step, vertices, nxt, og_origin,
                     og_cell, og_nx, og_ny, og_cell_start, og_cell_edges, og_edge_cells,
                     edge_scratch[0])
    if swapped:  # cur is the other buffer
        for i in range(n):
            out_pos[i, 0] = cur[i, 0]
            out_pos[i, 1] = cur[i, 1]
    return it, worst


_CHOOSER = Chooser()  # the whole pass, serial or parallel, by its measured cost (pedvr.kernels)


def resolve_contacts(pos: np.ndarray, radius: np.ndarray, is_user: np.ndarray,
                     vertices: np.ndarray, nxt: np.ndarray, prv: np.ndarray,
                     grid: ObstacleGrid, *, depth: np.ndarray | None = None,
                     facing: np.ndarray | None = None, rigid: np.ndarray | None = None,
                     n_static: int | None = None, pinned: np.ndarray | None = None,
                     tolerance: float = DEFAULT_TOLERANCE,
                     max_iterations: int = DEFAULT_ITERATIONS) -> np.ndarray:
    """Positions ``(N,2)`` after the contact pass; ``pos`` is not modified.

    The user row keeps its position exactly, and no agent is left inside the
    user's disc. ``pinned`` rows (seated bodies) do not move either, except out of
    the user's way. ``depth``/``facing`` are the footprints (:mod:`pedvr.crowd.footprint`;
    default: discs), ``rigid`` the rows whose footprint door leaves see as it is (default:
    none). Returns new positions; the largest remaining overlap is at most
    ``tolerance`` unless ``max_iterations`` ran out first (jams denser than discs
    can pack) or an agent is pinned between the user and a wall (it then overlaps
    the wall).
    """
    out = np.empty_like(pos)
    n = pos.shape[0]
    users = np.flatnonzero(is_user)
    user = int(users[0]) if users.size else -1
    fixed = np.ascontiguousarray(is_user if pinned is None else (is_user | pinned), np.bool_)
    depth = np.ascontiguousarray(radius if depth is None else depth, np.float64)
    facing = np.ascontiguousarray(np.tile([1.0, 0.0], (n, 1)) if facing is None else facing, np.float64)
    rigid = np.zeros(n, np.bool_) if rigid is None else np.ascontiguousarray(rigid, np.bool_)
    cap = _EDGE_CAP
    chunks = 8
    while True:
        scratch = np.zeros((chunks, cap), np.int64)
        par = _CHOOSER.choose(n)
        t0 = time.perf_counter()
        _, worst = contact_kernel(pos, radius, depth, facing, rigid, fixed, user, vertices, nxt, prv,
                                  vertices.shape[0] if n_static is None else int(n_static), grid.origin,
                                  grid.cell, grid.shape[0], grid.shape[1], grid.cell_start,
                                  grid.cell_edges, grid.edge_cells, float(tolerance),
                                  int(max_iterations), MOMENTUM, scratch, par, out)
        _CHOOSER.record(par, n, time.perf_counter() - t0)
        if worst >= 0.0:
            return out
        cap *= 4


def overlapping_pairs(pos: np.ndarray, radius: np.ndarray, tolerance: float) -> np.ndarray:
    """Pairs ``(i, j)``, ``i < j``, whose discs overlap by more than ``tolerance``.

    Returns an ``(P, 2) int64`` array, rows sorted; for metrics and tests. The discs are
    footprints that never turn (:func:`pedvr.crowd.overlap.pair_overlaps`).
    """
    pos = np.ascontiguousarray(pos, np.float64)
    radius = np.ascontiguousarray(radius, np.float64)
    n = pos.shape[0]
    facing = np.zeros((n, 2))
    facing[:, 0] = 1.0
    _, out = pair_overlaps(pos, radius, radius, facing, float(tolerance))
    # Sort rows lexicographically (i then j) for a canonical order.
    return out[np.argsort(out[:, 0] * n + out[:, 1])]


@njit(cache=True)
def max_obstacle_penetration(pos, radius, vertices, nxt, prv):
    """Largest depth by which any disc overlaps an obstacle edge (brute force, m)."""
    worst = 0.0
    m = vertices.shape[0]
    for i in range(pos.shape[0]):
        for e in range(m):
            e2 = nxt[e]
            closed = nxt[e] != prv[e]
            _, _, dep, _ = _edge_push(pos[i, 0], pos[i, 1], radius[i], radius[i], 1.0, 0.0,
                                   vertices[e, 0], vertices[e, 1], vertices[e2, 0],
                                   vertices[e2, 1], closed)
            worst = max(worst, dep)
    return worst
