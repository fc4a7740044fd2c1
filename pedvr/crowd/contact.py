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
the agent takes all of it (the user never moves; walls never move).
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
be ambiguous for walls thinner than a disc.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from pedvr.crowd.neighbors import ObstacleGrid, build_agent_grid_arrays, edges_near
from pedvr.kernels import PARALLEL_MIN_ROWS, parallel_kernel

DEFAULT_TOLERANCE = 0.005  # m: stop when no overlap exceeds this (the bar is 1 cm)
DEFAULT_ITERATIONS = 300
SLACK = 0.0005  # m: pushed this much past touching, so iterations settle faster
MOMENTUM = 0.9  # share of the previous iteration's step kept (heavy ball)
_EDGE_CAP = 64


@njit(cache=True, fastmath={"nsz", "arcp", "contract"})
def _edge_push(px, py, r, ax, ay, bx, by, closed):
    """Correction ``(cx, cy, depth)`` that moves a disc off the edge a -> b."""
    ex = bx - ax
    ey = by - ay
    ll = ex * ex + ey * ey
    t = ((px - ax) * ex + (py - ay) * ey) / ll
    if closed and t > 1.0:
        # The end vertex is the start of the next edge, which handles it.
        return 0.0, 0.0, 0.0
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
        return 0.0, 0.0, 0.0
    if d >= r:
        return 0.0, 0.0, 0.0
    depth = r - d
    if d > 1e-12:
        ux = dx / d
        uy = dy / d
    else:
        ux = nx
        uy = ny
    return (depth + SLACK) * ux, (depth + SLACK) * uy, depth


@parallel_kernel(fastmath={"nsz", "arcp", "contract"})
def _corrections(cur, radius, is_user, origin, cell, nx, ny, cell_start, order, sorted_pos,
                 vertices, nxt, prv, og_origin, og_cell, og_nx, og_ny, og_cell_start,
                 og_cell_edges, og_edge_cells, edge_scratch, corr, depth):
    n = cur.shape[0]
    nchunks = edge_scratch.shape[0]
    cap = edge_scratch.shape[1]
    inv = 1.0 / cell
    for c in prange(nchunks):
        eidx = edge_scratch[c]
        lo = (n * c) // nchunks
        hi = (n * (c + 1)) // nchunks
        for i in range(lo, hi):
            corr[i, 0] = 0.0
            corr[i, 1] = 0.0
            depth[i] = 0.0
            if is_user[i]:
                continue
            px = cur[i, 0]
            py = cur[i, 1]
            ri = radius[i]
            cx = int((px - origin[0]) * inv)
            cy = int((py - origin[1]) * inv)
            sx = 0.0
            sy = 0.0
            worst = 0.0
            for gy in range(max(cy - 1, 0), min(cy + 1, ny - 1) + 1):
                for gx in range(max(cx - 1, 0), min(cx + 1, nx - 1) + 1):
                    cc = gy * nx + gx
                    for k in range(cell_start[cc], cell_start[cc + 1]):
                        j = order[k]
                        if j == i:
                            continue
                        dx = px - sorted_pos[k, 0]
                        dy = py - sorted_pos[k, 1]
                        rr = ri + radius[j]
                        dsq = dx * dx + dy * dy
                        if dsq >= rr * rr:
                            continue
                        d = np.sqrt(dsq)
                        ov = rr - d
                        worst = max(worst, ov)
                        share = 1.0 if is_user[j] else 0.5
                        if d > 1e-12:
                            ux = dx / d
                            uy = dy / d
                        elif j > i:
                            # Coincident centres: split along x by row order
                            # (the pair moves apart, symmetric and deterministic).
                            ux = -1.0
                            uy = 0.0
                        else:
                            ux = 1.0
                            uy = 0.0
                        sx += share * (ov + SLACK) * ux
                        sy += share * (ov + SLACK) * uy
            if vertices.shape[0] > 0:
                total = edges_near(px, py, ri, og_origin, og_cell, og_nx, og_ny, og_cell_start,
                                   og_cell_edges, og_edge_cells, eidx, cap)
                for q in range(min(total, cap)):
                    e = eidx[q]
                    e2 = nxt[e]
                    closed = nxt[e] != prv[e]
                    if not closed and e2 < e:
                        continue  # a two-vertex segment: handle it once
                    ex, ey, dep = _edge_push(px, py, ri, vertices[e, 0], vertices[e, 1],
                                             vertices[e2, 0], vertices[e2, 1], closed)
                    sx += ex
                    sy += ey
                    worst = max(worst, dep)
                if total > cap:
                    depth[i] = -1.0  # scratch too small: the caller retries with more room
            corr[i, 0] = sx
            corr[i, 1] = sy
            if depth[i] >= 0.0:
                depth[i] = worst


@parallel_kernel()
def _apply(cur, corr, step, momentum):
    # Heavy-ball Jacobi: the step keeps a share of the previous one, which
    # carries a push through a packed cluster in O(depth) instead of
    # O(depth^2) iterations (plain Jacobi diffuses).
    for i in prange(cur.shape[0]):
        step[i, 0] = momentum * step[i, 0] + corr[i, 0]
        step[i, 1] = momentum * step[i, 1] + corr[i, 1]
        cur[i, 0] += step[i, 0]
        cur[i, 1] += step[i, 1]


_corrections_par, _corrections_ser = _corrections.parallel, _corrections.serial
_apply_par, _apply_ser = _apply.parallel, _apply.serial


@njit(cache=True)
def contact_kernel(pos, radius, is_user, vertices, nxt, prv, og_origin, og_cell, og_nx, og_ny,
                   og_cell_start, og_cell_edges, og_edge_cells, tolerance, max_iterations,
                   momentum, edge_scratch, out_pos):
    """Jacobi contact iterations; writes ``out_pos`` and returns ``(iterations, worst)``.

    ``worst`` is the largest overlap left, or -1 when ``edge_scratch`` was too
    small for some agent's edges (retry with more room).
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
    corr = np.zeros((n, 2))
    step = np.zeros((n, 2))
    depth = np.zeros(n)
    worst = 0.0
    it = 0
    while True:
        origin, cell, nx, ny, cell_start, order, sorted_pos = build_agent_grid_arrays(
            out_pos, 2.0 * rmax * 1.0001)
        if n >= PARALLEL_MIN_ROWS:
            _corrections_par(out_pos, radius, is_user, origin, cell, nx, ny, cell_start, order,
                             sorted_pos, vertices, nxt, prv, og_origin, og_cell, og_nx, og_ny,
                             og_cell_start, og_cell_edges, og_edge_cells, edge_scratch, corr, depth)
        else:
            _corrections_ser(out_pos, radius, is_user, origin, cell, nx, ny, cell_start, order,
                             sorted_pos, vertices, nxt, prv, og_origin, og_cell, og_nx, og_ny,
                             og_cell_start, og_cell_edges, og_edge_cells, edge_scratch, corr, depth)
        worst = 0.0
        for i in range(n):
            if depth[i] < 0.0:
                return it, -1.0
            worst = max(worst, depth[i])
        if worst <= tolerance or it >= max_iterations:
            break
        if n >= PARALLEL_MIN_ROWS:
            _apply_par(out_pos, corr, step, momentum)
        else:
            _apply_ser(out_pos, corr, step, momentum)
        it += 1
    return it, worst


def resolve_contacts(pos: np.ndarray, radius: np.ndarray, is_user: np.ndarray,
                     vertices: np.ndarray, nxt: np.ndarray, prv: np.ndarray,
                     grid: ObstacleGrid, *, tolerance: float = DEFAULT_TOLERANCE,
                     max_iterations: int = DEFAULT_ITERATIONS) -> np.ndarray:
    """Positions ``(N,2)`` after the contact pass; ``pos`` is not modified.

    The user row keeps its position exactly. Returns new positions; the
    largest remaining overlap is at most ``tolerance`` unless
    ``max_iterations`` ran out first (jams denser than discs can pack).
    """
    out = np.empty_like(pos)
    cap = _EDGE_CAP
    chunks = 8
    while True:
        scratch = np.zeros((chunks, cap), np.int64)
        _, worst = contact_kernel(pos, radius, is_user, vertices, nxt, prv, grid.origin,
                                  grid.cell, grid.shape[0], grid.shape[1], grid.cell_start,
                                  grid.cell_edges, grid.edge_cells, float(tolerance),
                                  int(max_iterations), MOMENTUM, scratch, out)
        if worst >= 0.0:
            return out
        cap *= 4


@njit(cache=True)
def overlapping_pairs(pos, radius, tolerance):
    """Pairs ``(i, j)``, ``i < j``, whose discs overlap by more than ``tolerance``.

    Returns an ``(P, 2) int64`` array, rows sorted; for metrics and tests.
    """
    n = pos.shape[0]
    if n == 0:
        return np.zeros((0, 2), np.int64)
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    origin, cell, nx, ny, cell_start, order, sorted_pos = build_agent_grid_arrays(
        pos, 2.0 * rmax * 1.0001)
    inv = 1.0 / cell
    cap = 64
    pairs = np.empty((cap, 2), np.int64)
    m = 0
    for i in range(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx = int((px - origin[0]) * inv)
        cy = int((py - origin[1]) * inv)
        for gy in range(max(cy - 1, 0), min(cy + 1, ny - 1) + 1):
            for gx in range(max(cx - 1, 0), min(cx + 1, nx - 1) + 1):
                cc = gy * nx + gx
                for k in range(cell_start[cc], cell_start[cc + 1]):
                    j = order[k]
                    if j <= i:
                        continue
                    dx = px - sorted_pos[k, 0]
                    dy = py - sorted_pos[k, 1]
                    rr = radius[i] + radius[j]
                    if rr - np.sqrt(dx * dx + dy * dy) > tolerance:
                        if m == cap:
                            grown = np.empty((2 * cap, 2), np.int64)
                            grown[:m] = pairs[:m]
                            pairs = grown
                            cap *= 2
                        pairs[m, 0] = i
                        pairs[m, 1] = j
                        m += 1
    out = pairs[:m].copy()
    # Sort rows lexicographically (i then j) for a canonical order.
    key = out[:, 0] * n + out[:, 1]
    return out[np.argsort(key)]


@njit(cache=True)
def max_obstacle_penetration(pos, radius, vertices, nxt, prv):
    """Largest depth by which any disc overlaps an obstacle edge (brute force, m)."""
    worst = 0.0
    m = vertices.shape[0]
    for i in range(pos.shape[0]):
        for e in range(m):
            e2 = nxt[e]
            closed = nxt[e] != prv[e]
            _, _, dep = _edge_push(pos[i, 0], pos[i, 1], radius[i], vertices[e, 0],
                                   vertices[e, 1], vertices[e2, 0], vertices[e2, 1], closed)
            worst = max(worst, dep)
    return worst
