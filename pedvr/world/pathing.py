"""Path search over the navigation mesh: A* over triangles, then the funnel.

Pure functions over the mesh arrays (``verts (V, 2)``, CCW ``tris (T, 3)``,
``neighbors (T, 3)`` where ``neighbors[t, k]`` is the triangle across edge
``tris[t, k] -> tris[t, (k + 1) % 3]`` or -1); the result depends only on
the inputs. They are numba kernels: a whole crowd plans when it spawns, and
many agents may replan in the same step.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numba import njit

# Two points closer than this (metres) are the same waypoint.
SAME_POINT = 1e-9


@njit(cache=True)
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
    cost: np.ndarray | None = None,
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
    ``cost (T,)`` (>= 1; None: all 1) weighs each metre walked inside a triangle: the leg from
    one entry point to the next counts at the cost of the triangle it crosses (the heuristic
    stays admissible).
    """
    n = np.shape(tris)[0]
    weights = np.ones(n) if cost is None else np.ascontiguousarray(cost, np.float64)
    out = _astar(np.ascontiguousarray(verts, np.float64), np.ascontiguousarray(tris, np.int64),
                 np.ascontiguousarray(neighbors, np.int64), int(start_tri), int(goal_tri),
                 float(start[0]), float(start[1]), float(goal[0]), float(goal[1]), weights)
    return None if out.shape[0] == 0 else [int(t) for t in out]


@njit(cache=True)
def _astar(verts, tris, neighbors, start_tri, goal_tri, sx, sy, gx, gy, cost):  # noqa: ANN001, ANN202
    n = tris.shape[0]
    best_g = np.full(n, np.inf)
    entry = np.zeros((n, 2))
    parent = np.full(n, -1, np.int64)
    best_f = np.full(n, np.inf)
    best_g[start_tri] = 0.0
    entry[start_tri, 0], entry[start_tri, 1] = sx, sy
    best_f[start_tri] = math.hypot(sx - gx, sy - gy)
    heap = [(best_f[start_tri], np.int64(start_tri))]
    while len(heap) > 0:
        f, t = heapq.heappop(heap)
        if f > best_f[t]:
            continue  # stale entry
        if t == goal_tri:
            m = 1
            u = t
            while parent[u] >= 0:
                u = parent[u]
                m += 1
            corridor = np.empty(m, np.int64)
            u = t
            for i in range(m - 1, -1, -1):
                corridor[i] = u
                u = parent[u]
            return corridor
        px, py = entry[t, 0], entry[t, 1]
        for k in range(3):
            nb = neighbors[t, k]
            if nb < 0:
                continue
            a, b = tris[t, k], tris[t, (k + 1) % 3]
            qx, qy = _portal_point(px, py, verts[a, 0], verts[a, 1], verts[b, 0], verts[b, 1], gx, gy)
            g = best_g[t] + cost[t] * math.hypot(qx - px, qy - py)
            if g < best_g[nb]:
                best_g[nb] = g
                entry[nb, 0], entry[nb, 1] = qx, qy
                parent[nb] = t
                best_f[nb] = g + math.hypot(gx - qx, gy - qy)
                heapq.heappush(heap, (best_f[nb], np.int64(nb)))
    return np.empty(0, np.int64)


def corridor_portals(
    verts: np.ndarray, tris: np.ndarray, neighbors: np.ndarray, corridor: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """The shared edges along a corridor as ``(left (n, 2), right (n, 2))``.

    Left and right are as seen walking from ``corridor[i]`` into
    ``corridor[i + 1]``: crossing CCW edge ``v_k -> v_k+1`` outward, ``v_k``
    is on the right.
    """
    return _portals(np.ascontiguousarray(verts, np.float64), np.ascontiguousarray(tris, np.int64),
                    np.ascontiguousarray(neighbors, np.int64), np.asarray(corridor, np.int64))


@njit(cache=True)
def _portals(verts, tris, neighbors, corridor):  # noqa: ANN001, ANN202
    m = corridor.shape[0] - 1
    left = np.empty((max(m, 0), 2))
    right = np.empty((max(m, 0), 2))
    for i in range(m):
        t, nxt = corridor[i], corridor[i + 1]
        k = 0
        while neighbors[t, k] != nxt:
            k += 1
        right[i, 0], right[i, 1] = verts[tris[t, k], 0], verts[tris[t, k], 1]
        a = tris[t, (k + 1) % 3]
        left[i, 0], left[i, 1] = verts[a, 0], verts[a, 1]
    return left, right


@njit(cache=True)
def _cross(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """Twice the signed area of a, b, c: > 0 when c is left of a -> b."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def _same(ax: float, ay: float, bx: float, by: float) -> bool:
    return (ax - bx) ** 2 + (ay - by) ** 2 < SAME_POINT * SAME_POINT


def funnel(start: np.ndarray, goal: np.ndarray, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The taut path through the portals (Mononen's simple stupid funnel).

    ``left``/``right`` ``(n, 2)`` are the portal endpoints in walking order.
    Returns ``(K, 2)`` waypoints, ``K >= 2``, first ``start``, last ``goal``;
    interior waypoints are portal endpoints (mesh vertices) where the path
    turns.
    """
    s = np.asarray(start, np.float64).reshape(1, 2)
    g = np.asarray(goal, np.float64).reshape(1, 2)
    lefts = np.concatenate([s, np.asarray(left, np.float64).reshape(-1, 2), g])
    rights = np.concatenate([s, np.asarray(right, np.float64).reshape(-1, 2), g])
    return _funnel(lefts, rights)


@njit(cache=True)
def _funnel(lefts, rights):  # noqa: ANN001, ANN202
    n = lefts.shape[0]
    pts = np.empty((2 * n + 1, 2))
    npts = 1
    pts[0] = lefts[0]
    ax, ay = lefts[0, 0], lefts[0, 1]  # apex
    lx, ly, rx, ry = ax, ay, ax, ay  # funnel sides
    apex_i = left_i = right_i = 0
    i = 1
    while i < n:
        ltx, lty, rtx, rty = lefts[i, 0], lefts[i, 1], rights[i, 0], rights[i, 1]
        # Right side: the new right point narrows the funnel when it is left of the right ray.
        if _cross(ax, ay, rx, ry, rtx, rty) >= 0.0:
            if _same(ax, ay, rx, ry) or _cross(ax, ay, lx, ly, rtx, rty) < 0.0:
                rx, ry, right_i = rtx, rty, i
            else:
                # Right crosses over left: the left point is a corner of the path.
                ax, ay, apex_i = lx, ly, left_i
                pts[npts, 0], pts[npts, 1] = ax, ay
                npts += 1
                lx, ly, rx, ry = ax, ay, ax, ay
                left_i = right_i = apex_i
                i = apex_i + 1
                continue
        # Left side, mirrored.
        if _cross(ax, ay, lx, ly, ltx, lty) <= 0.0:
            if _same(ax, ay, lx, ly) or _cross(ax, ay, rx, ry, ltx, lty) > 0.0:
                lx, ly, left_i = ltx, lty, i
            else:
                ax, ay, apex_i = rx, ry, right_i
                pts[npts, 0], pts[npts, 1] = ax, ay
                npts += 1
                lx, ly, rx, ry = ax, ay, ax, ay
                left_i = right_i = apex_i
                i = apex_i + 1
                continue
        i += 1
    gx, gy = lefts[n - 1, 0], lefts[n - 1, 1]
    if not _same(pts[npts - 1, 0], pts[npts - 1, 1], gx, gy) or npts == 1:
        pts[npts, 0], pts[npts, 1] = gx, gy
        npts += 1
    out = np.empty((npts, 2))
    out[0] = pts[0]
    k = 1
    for j in range(1, npts - 1):
        if not _same(pts[j, 0], pts[j, 1], out[k - 1, 0], out[k - 1, 1]):
            out[k] = pts[j]
            k += 1
    out[k] = pts[npts - 1]
    return out[: k + 1].copy()


@njit(cache=True)
def path_length(path):  # noqa: ANN001, ANN201
    """Length (m) of the polyline ``path (K, 2)``."""
    total = 0.0
    for k in range(path.shape[0] - 1):
        dx = path[k + 1, 0] - path[k, 0]
        dy = path[k + 1, 1] - path[k, 1]
        total += math.sqrt(dx * dx + dy * dy)
    return total


@njit(cache=True)
def follow_paths(pos, pts, starts, lens, cursor, is_user, pref_speed, speed_scale, face, heading, vel,
                 slowing, target, pref_vel, pref_heading):
    """The ``plan`` phase's arithmetic for every row in one pass (PedVR §3.2.1): each row's
    current waypoint ``target (N, 2)`` (its own position when it has no path of two or more
    points; the user has none), and its preferred velocity toward it, ``pref_speed ×
    speed_scale``, slowed linearly inside ``slowing`` m of its last waypoint, with the heading
    of that velocity, or where it stands still its ``face`` (NaN: keep ``heading``). The user's
    rows keep their input ``vel`` and ``heading``. Written in place; the same operations, in the
    same order, as the numpy expression it replaces, so the results are the same bits."""
    m = pts.shape[0]
    for i in range(pos.shape[0]):
        has_path = lens[i] >= 2 and not is_user[i]
        cur = min(cursor[i], max(lens[i] - 1, 0))
        if has_path and m:
            k = min(starts[i] + cur, m - 1)
            target[i, 0] = pts[k, 0]
            target[i, 1] = pts[k, 1]
        else:
            target[i, 0] = pos[i, 0]
            target[i, 1] = pos[i, 1]
        if is_user[i]:
            pref_vel[i, 0] = vel[i, 0]
            pref_vel[i, 1] = vel[i, 1]
            pref_heading[i] = heading[i]
            continue
        dx = target[i, 0] - pos[i, 0]
        dy = target[i, 1] - pos[i, 1]
        dist = math.sqrt(dx * dx + dy * dy)
        speed = pref_speed[i] * speed_scale[i]
        if cur >= lens[i] - 1:
            speed = speed * min(1.0, dist / slowing)
        if dist > 1e-9:
            ux = dx / dist
            uy = dy / dist
        else:
            ux = 0.0
            uy = 0.0
        if has_path and dist > 1e-6:
            pref_vel[i, 0] = ux * speed
            pref_vel[i, 1] = uy * speed
            pref_heading[i] = math.atan2(uy, ux)
        else:
            pref_vel[i, 0] = 0.0
            pref_vel[i, 1] = 0.0
            pref_heading[i] = heading[i] if math.isnan(face[i]) else face[i]
