"""Path search over the navigation mesh: A* over triangles, then the funnel.

Pure functions over the mesh arrays (``verts (V, 2)``, CCW ``tris (T, 3)``,
``neighbors (T, 3)`` where ``neighbors[t, k]`` is the triangle across edge
``tris[t, k] -> tris[t, (k + 1) % 3]`` or -1). Queries are not per step, so
they are plain Python; the result depends only on the inputs.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

# Two points closer than this (metres) are the same waypoint.
SAME_POINT = 1e-9


def _portal_point(
    px: float, py: float, ax: float, ay: float, bx: float, by: float, gx: float, gy: float
) -> tuple[float, float]:
    """The point q on portal a–b minimising |p - q| + |q - g|.

    The sum is convex along the portal, so the minimiser on the portal's
    line (the straight line p -> g, with g mirrored when both lie on the
    same side), clamped to the portal, is the minimiser on the portal.
    """
    ex, ey = bx - ax, by - ay
    ll = ex * ex + ey * ey
    if ll <= 0.0:
        return ax, ay
    sp = ex * (py - ay) - ey * (px - ax)
    sg = ex * (gy - ay) - ey * (gx - ax)
    if sp * sg > 0.0:  # same side: mirror the goal across the portal's line
        k = 2.0 * sg / ll
        gx, gy = gx + k * ey, gy - k * ex
        sg = -sg
    if sp == sg:  # both on the line
        s = ((px - ax) * ex + (py - ay) * ey) / ll
    else:
        w = sp / (sp - sg)
        qx, qy = px + w * (gx - px), py + w * (gy - py)
        s = ((qx - ax) * ex + (qy - ay) * ey) / ll
    s = min(max(s, 0.0), 1.0)
    return ax + s * ex, ay + s * ey


def astar_corridor(
    verts: np.ndarray,
    tris: np.ndarray,
    neighbors: np.ndarray,
    start_tri: int,
    goal_tri: int,
    start: tuple[float, float],
    goal: tuple[float, float],
) -> list[int] | None:
    """The triangle sequence from ``start_tri`` to ``goal_tri``, or None.

    A* over triangles. A triangle is entered at the point of its portal that
    lies on the straightest line from the previous entry point toward the goal
    (see :func:`_portal_point`); the cost is the polyline length through those
    points and the heuristic the Euclidean distance to the goal, which never
    overestimates that cost. The entry points depend on the route taken, so
    the search is a close approximation of the shortest corridor, not an
    exact one (a triangle reached again more cheaply is expanded again); the
    funnel then makes the path taut inside the corridor.
    Heap ties are broken by triangle index, so the result is deterministic.
    """
    gx, gy = goal
    n = tris.shape[0]
    best_g = np.full(n, np.inf)
    entry = np.zeros((n, 2))
    parent = np.full(n, -1, np.int64)
    best_f = np.full(n, np.inf)
    best_g[start_tri] = 0.0
    entry[start_tri] = start
    best_f[start_tri] = math.hypot(start[0] - gx, start[1] - gy)
    heap: list[tuple[float, int]] = [(best_f[start_tri], start_tri)]
    while heap:
        f, t = heapq.heappop(heap)
        if f > best_f[t]:
            continue  # stale entry
        if t == goal_tri:
            corridor = [t]
            while parent[corridor[-1]] >= 0:
                corridor.append(int(parent[corridor[-1]]))
            return corridor[::-1]
        px, py = entry[t]
        for k in range(3):
            nb = int(neighbors[t, k])
            if nb < 0:
                continue
            a, b = verts[tris[t, k]], verts[tris[t, (k + 1) % 3]]
            qx, qy = _portal_point(px, py, a[0], a[1], b[0], b[1], gx, gy)
            g = best_g[t] + math.hypot(qx - px, qy - py)
            if g < best_g[nb]:
                best_g[nb] = g
                entry[nb] = (qx, qy)
                parent[nb] = t
                best_f[nb] = g + math.hypot(gx - qx, gy - qy)
                heapq.heappush(heap, (best_f[nb], nb))
    return None


def corridor_portals(
    verts: np.ndarray, tris: np.ndarray, neighbors: np.ndarray, corridor: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """The shared edges along a corridor as ``(left (n, 2), right (n, 2))``.

    Left and right are as seen walking from ``corridor[i]`` into
    ``corridor[i + 1]``: crossing CCW edge ``v_k -> v_k+1`` outward, ``v_k``
    is on the right.
    """
    m = len(corridor) - 1
    left = np.empty((m, 2))
    right = np.empty((m, 2))
    for i in range(m):
        t, nxt = corridor[i], corridor[i + 1]
        k = int(np.flatnonzero(neighbors[t] == nxt)[0])
        right[i] = verts[tris[t, k]]
        left[i] = verts[tris[t, (k + 1) % 3]]
    return left, right


def _cross(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    """Twice the signed area of a, b, c: > 0 when c is left of a -> b."""
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 < SAME_POINT * SAME_POINT)


def funnel(start: np.ndarray, goal: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The taut path through the portals (Mononen's simple stupid funnel).

    ``left``/``right`` ``(n, 2)`` are the portal endpoints in walking order.
    Returns ``(K, 2)`` waypoints, ``K >= 2``, first ``start``, last ``goal``;
    interior waypoints are portal endpoints (mesh vertices) where the path
    turns.
    """
    lefts = [start, *left, goal]
    rights = [start, *right, goal]
    n = len(lefts)
    apex, pl, pr = start, start, start
    apex_i = left_i = right_i = 0
    pts = [start]
    i = 1
    while i < n:
        lt, rt = lefts[i], rights[i]
        # Right side: the new right point narrows the funnel when it is left of the right ray.
        if _cross(apex, pr, rt) >= 0.0:
            if _same(apex, pr) or _cross(apex, pl, rt) < 0.0:
                pr, right_i = rt, i
            else:
                # Right crosses over left: the left point is a corner of the path.
                apex, apex_i = pl, left_i
                pts.append(apex)
                pl = pr = apex
                left_i = right_i = apex_i
                i = apex_i + 1
                continue
        # Left side, mirrored.
        if _cross(apex, pl, lt) <= 0.0:
            if _same(apex, pl) or _cross(apex, pr, lt) > 0.0:
                pl, left_i = lt, i
            else:
                apex, apex_i = pr, right_i
                pts.append(apex)
                pl = pr = apex
                left_i = right_i = apex_i
                i = apex_i + 1
                continue
        i += 1
    if not _same(pts[-1], goal) or len(pts) == 1:
        pts.append(goal)
    out = [pts[0]]
    for p in pts[1:-1]:
        if not _same(p, out[-1]):
            out.append(p)
    out.append(pts[-1])
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)
