"""numba kernels for line-of-sight and ray queries against static edges.

Edges are two ``(M, 2)`` float64 arrays ``p1``, ``p2`` (segment ``k`` runs
``p1[k] -> p2[k]``), e.g. from :func:`pedvr.world.geometry.edges`. Pure
functions; outputs are passed in; nothing allocates. Linear in M per query.
"""

from __future__ import annotations

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
        cx = p1[k, 0]
        cy = p1[k, 1]
        dx = p2[k, 0]
        dy = p2[k, 1]
        # Bounding boxes more than radius apart cannot be within radius.
        if max(cx, dx) < lox or min(cx, dx) > hix or max(cy, dy) < loy or min(cy, dy) > hiy:
            continue
        if segment_distance2(ax, ay, bx, by, cx, cy, dx, dy) <= r2:
            return False
    return True


@parallel_kernel()
def visible_batch(
    a: np.ndarray, b: np.ndarray, radius: np.ndarray, p1: np.ndarray, p2: np.ndarray, out: np.ndarray
) -> None:
    """``out[i] = segment_clear(a[i], b[i], radius[i])`` for ``(N, 2)`` a, b; parallel over N."""
    for i in prange(a.shape[0]):
        out[i] = segment_clear(a[i, 0], a[i, 1], b[i, 0], b[i, 1], radius[i], p1, p2)


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
    waypoint keep theirs. Parallel over agents.
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
            if segment_clear(pos[i, 0], pos[i, 1], path_pts[w, 0], path_pts[w, 1], clear, p1, p2):
                out_cursor[i] = k
                break
