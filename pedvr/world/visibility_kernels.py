"""numba kernels for line-of-sight and ray queries against static edges.

Edges are two ``(M, 2)`` float64 arrays ``p1``, ``p2`` (segment ``k`` runs
``p1[k] -> p2[k]``), e.g. from :func:`pedvr.world.geometry.edges`. Pure
functions; outputs are passed in; nothing allocates. :func:`segment_clear`
and :func:`raycast` are linear in M per query; the batch kernels look only at
the edges in the cells of an :class:`EdgeGrid` that a query's bounding box
touches, with the same per-edge test, so they answer exactly as a scan of
every edge would.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from pedvr.kernels import parallel_kernel


@njit(cache=True, inline="always")
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def _point_segment_dist2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx = bx - ax
    dy = by - ay
    ll = dx * dx + dy * dy
    s = 0.0
    if ll > 0.0:
        s = min(max(((px - ax) * dx + (py - ay) * dy) / ll, 0.0), 1.0)
    ex = ax + s * dx - px
    ey = ay + s * dy - py
    return ex * ex + ey * ey


@njit(cache=True)
def segment_distance2(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> float:
    """Squared distance between segments a–b and c–d (0 when they cross or touch)."""
    o1 = _orient(ax, ay, bx, by, cx, cy)
    o2 = _orient(ax, ay, bx, by, dx, dy)
    o3 = _orient(cx, cy, dx, dy, ax, ay)
    o4 = _orient(cx, cy, dx, dy, bx, by)
    if ((o1 > 0.0 and o2 < 0.0) or (o1 < 0.0 and o2 > 0.0)) and (
        (o3 > 0.0 and o4 < 0.0) or (o3 < 0.0 and o4 > 0.0)
    ):
        return 0.0  # proper crossing
    # Otherwise the closest pair involves an endpoint (touching gives 0 here too).
    d = _point_segment_dist2(ax, ay, cx, cy, dx, dy)
    d = min(d, _point_segment_dist2(bx, by, cx, cy, dx, dy))
    d = min(d, _point_segment_dist2(cx, cy, ax, ay, bx, by))
    return min(d, _point_segment_dist2(dx, dy, ax, ay, bx, by))


@njit(cache=True)
def segment_clear(
    ax: float, ay: float, bx: float, by: float, radius: float, p1: np.ndarray, p2: np.ndarray
) -> bool:
    """Whether segment a–b thickened by ``radius`` (m) touches no edge.

    True when the distance from a–b to every edge is strictly greater than
    ``radius``; with ``radius = 0`` a segment merely touching an edge is
    blocked.
    """
    r2 = radius * radius
    lox = min(ax, bx) - radius
    hix = max(ax, bx) + radius
    loy = min(ay, by) - radius
    hiy = max(ay, by) + radius
    for k in range(p1.shape[0]):
        if _edge_within(k, ax, ay, bx, by, r2, lox, hix, loy, hiy, p1, p2):
            return False
    return True


@njit(cache=True, inline="always")
def _edge_within(
    k: int, ax: float, ay: float, bx: float, by: float, r2: float,
    lox: float, hix: float, loy: float, hiy: float, p1: np.ndarray, p2: np.ndarray,
) -> bool:
    """Whether edge ``k`` comes within ``sqrt(r2)`` of segment a–b (whose box, widened by that
    distance, is ``lox..hix`` × ``loy..hiy``)."""
    cx = p1[k, 0]
    cy = p1[k, 1]
    dx = p2[k, 0]
    dy = p2[k, 1]
    # Bounding boxes more than the distance apart cannot be within it.
    if max(cx, dx) < lox or min(cx, dx) > hix or max(cy, dy) < loy or min(cy, dy) > hiy:
        return False
    return segment_distance2(ax, ay, bx, by, cx, cy, dx, dy) <= r2


class EdgeGrid(NamedTuple):
    """Edges bucketed by the uniform cells their bounding boxes touch (CSR).

    ``origin (2,)`` and ``cell`` (m) place the ``shape = (nx, ny)`` cells over
    the edges' bounding box; cell ``(ix, iy)`` lists edges
    ``items[start[ix * ny + iy] : start[ix * ny + iy + 1]]``.
    """

    origin: np.ndarray
    cell: float
    shape: np.ndarray
    start: np.ndarray
    items: np.ndarray

    @classmethod
    def build(cls, p1: np.ndarray, p2: np.ndarray, *, cell: float = 4.0,
              max_cells: int = 1 << 18) -> EdgeGrid:
        lo = np.minimum(p1, p2).reshape(-1, 2)
        hi = np.maximum(p1, p2).reshape(-1, 2)
        if lo.shape[0] == 0:
            return cls(np.zeros(2), 1.0, np.ones(2, np.int64), np.zeros(2, np.int64), np.zeros(0, np.int64))
        origin = lo.min(axis=0)
        extent = hi.max(axis=0) - origin
        while np.prod(np.floor(extent / cell) + 1) > max_cells:
            cell *= 2.0
        shape = (np.floor(extent / cell) + 1).astype(np.int64)
        i0 = np.minimum(((lo - origin) // cell).astype(np.int64), shape - 1)
        i1 = np.minimum(((hi - origin) // cell).astype(np.int64), shape - 1)
        counts = (i1 - i0 + 1).prod(axis=1)
        edge = np.repeat(np.arange(lo.shape[0]), counts)
        # Each edge's cells, row-major inside its bounding box of cells.
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        w = np.repeat(i1[:, 1] - i0[:, 1] + 1, counts)
        ix = np.repeat(i0[:, 0], counts) + k // w
        iy = np.repeat(i0[:, 1], counts) + k % w
        key = ix * shape[1] + iy
        order = np.lexsort((edge, key))
        start = np.zeros(int(shape.prod()) + 1, np.int64)
        np.add.at(start, key + 1, 1)
        return cls(origin.astype(np.float64), float(cell), shape, np.cumsum(start),
                   edge[order].astype(np.int64))


@njit(cache=True)
def _cell_edges_clear(
    c: int, ax: float, ay: float, bx: float, by: float, r2: float,
    lox: float, hix: float, loy: float, hiy: float, p1: np.ndarray, p2: np.ndarray,
    start: np.ndarray, items: np.ndarray,
) -> bool:
    for j in range(start[c], start[c + 1]):
        if _edge_within(items[j], ax, ay, bx, by, r2, lox, hix, loy, hiy, p1, p2):
            return False
    return True


@njit(cache=True)
def segment_clear_grid(
    ax: float, ay: float, bx: float, by: float, radius: float, p1: np.ndarray, p2: np.ndarray,
    origin: np.ndarray, cell: float, shape: np.ndarray, start: np.ndarray, items: np.ndarray,
) -> bool:
    """:func:`segment_clear` looking only at the edges in the grid cells near the segment.

    The segment is walked along its longer axis one column (or row) of cells
    at a time; in each, the cells its stretch there, widened by ``radius``,
    overlaps are searched. Every edge within ``radius`` of the segment lies in
    one of them, so the answer is :func:`segment_clear`'s.
    """
    r2 = radius * radius
    lox = min(ax, bx) - radius
    hix = max(ax, bx) + radius
    loy = min(ay, by) - radius
    hiy = max(ay, by) + radius
    nx, ny = shape[0], shape[1]
    ox, oy = origin[0], origin[1]
    along_x = abs(bx - ax) >= abs(by - ay)
    if along_x:
        i0 = max(int(np.floor((lox - ox) / cell)), 0)
        i1 = min(int(np.floor((hix - ox) / cell)), nx - 1)
    else:
        i0 = max(int(np.floor((loy - oy) / cell)), 0)
        i1 = min(int(np.floor((hiy - oy) / cell)), ny - 1)
    for i in range(i0, i1 + 1):
        # The stretch of the segment inside this column (row), widened by the radius.
        if along_x:
            u0, u1, a_u, b_u, a_v, b_v = ox + i * cell - radius, ox + (i + 1) * cell + radius, ax, bx, ay, by
        else:
            u0, u1, a_u, b_u, a_v, b_v = oy + i * cell - radius, oy + (i + 1) * cell + radius, ay, by, ax, bx
        du = b_u - a_u
        if abs(du) > 1e-12:
            t0 = min(max((u0 - a_u) / du, 0.0), 1.0)
            t1 = min(max((u1 - a_u) / du, 0.0), 1.0)
            v0 = a_v + t0 * (b_v - a_v)
            v1 = a_v + t1 * (b_v - a_v)
            vlo, vhi = min(v0, v1) - radius, max(v0, v1) + radius
        else:
            vlo, vhi = min(a_v, b_v) - radius, max(a_v, b_v) + radius
        if along_x:
            j0 = max(int(np.floor((vlo - oy) / cell)), 0)
            j1 = min(int(np.floor((vhi - oy) / cell)), ny - 1)
        else:
            j0 = max(int(np.floor((vlo - ox) / cell)), 0)
            j1 = min(int(np.floor((vhi - ox) / cell)), nx - 1)
        for j in range(j0, j1 + 1):
            c = i * ny + j if along_x else j * ny + i
            if not _cell_edges_clear(c, ax, ay, bx, by, r2, lox, hix, loy, hiy, p1, p2, start, items):
                return False
    return True


@parallel_kernel()
def visible_batch(
    a: np.ndarray, b: np.ndarray, radius: np.ndarray, p1: np.ndarray, p2: np.ndarray, out: np.ndarray
) -> None:
    """``out[i] = segment_clear(a[i], b[i], radius[i])`` for ``(N, 2)`` a, b; parallel over N."""
    for i in prange(a.shape[0]):
        out[i] = segment_clear(a[i, 0], a[i, 1], b[i, 0], b[i, 1], radius[i], p1, p2)


@parallel_kernel()
def visible_batch_grid(
    a: np.ndarray, b: np.ndarray, radius: np.ndarray, p1: np.ndarray, p2: np.ndarray,
    origin: np.ndarray, cell: float, shape: np.ndarray, start: np.ndarray, items: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`visible_batch` through an :class:`EdgeGrid` (the same answers)."""
    for i in prange(a.shape[0]):
        out[i] = segment_clear_grid(a[i, 0], a[i, 1], b[i, 0], b[i, 1], radius[i], p1, p2,
                                    origin, cell, shape, start, items)


@njit(cache=True)
def raycast(
    ox: float, oy: float, ux: float, uy: float, max_dist: float, p1: np.ndarray, p2: np.ndarray
) -> float:
    """Distance along the unit direction ``(ux, uy)`` from ``(ox, oy)`` to the first edge.

    Returns ``max_dist`` when nothing is hit within it. An edge through the
    origin is hit at distance 0; an edge parallel to the ray is not hit.
    """
    best = max_dist
    for k in range(p1.shape[0]):
        ex = p2[k, 0] - p1[k, 0]
        ey = p2[k, 1] - p1[k, 1]
        denom = ux * ey - uy * ex  # cross(u, e)
        if denom == 0.0:
            continue
        wx = p1[k, 0] - ox
        wy = p1[k, 1] - oy
        t = (wx * ey - wy * ex) / denom  # along the ray
        s = (wx * uy - wy * ux) / denom  # along the edge
        if t >= 0.0 and 0.0 <= s <= 1.0 and t < best:
            best = t
    return best


@parallel_kernel()
def furthest_visible(
    pos: np.ndarray,
    radius: np.ndarray,
    path_pts: np.ndarray,
    path_start: np.ndarray,
    path_len: np.ndarray,
    cursor: np.ndarray,
    lookahead: int,
    p1: np.ndarray,
    p2: np.ndarray,
    origin: np.ndarray,
    cell: float,
    shape: np.ndarray,
    start: np.ndarray,
    items: np.ndarray,
    out_cursor: np.ndarray,
) -> None:
    """Advance each agent's waypoint cursor to the furthest visible waypoint.

    PedVR §3.2.1: an agent faces its intermediate waypoint as long as it is
    visible. Agent ``i``'s waypoints are
    ``path_pts[path_start[i] : path_start[i] + path_len[i]]`` and its cursor
    indexes into them (local index). Looking at most ``lookahead`` waypoints
    past the cursor, ``out_cursor[i]`` is the furthest one whose segment from
    ``pos[i]`` clears every edge by ``0.5 * radius[i]``; when none does, the
    cursor stays (a negative cursor becomes 0). The cursor never moves
    backward; agents with ``path_len == 0`` or a cursor at or past their last
    waypoint keep theirs. Parallel over agents; edges through an :class:`EdgeGrid`.
    """
    for i in prange(pos.shape[0]):
        n = path_len[i]
        c = cursor[i]
        out_cursor[i] = c
        if n <= 0 or c >= n - 1:
            continue  # no path, or already at the last waypoint
        c = max(c, 0)
        out_cursor[i] = c
        base = path_start[i]
        clear = 0.5 * radius[i]
        # Scan from the far end back, so the first visible waypoint is the furthest.
        for k in range(min(c + lookahead, n - 1), c, -1):
            w = base + k
            if segment_clear_grid(pos[i, 0], pos[i, 1], path_pts[w, 0], path_pts[w, 1], clear, p1, p2,
                                  origin, cell, shape, start, items):
                out_cursor[i] = k
                break
